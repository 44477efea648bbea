//! `peridyn validate`: the papers' results as re-runnable comparisons. Each case file
//! (`deck::case`) runs as a one-factor sweep study (`study_run`, so a stopped validation
//! continues where it stopped), its outputs are kept (`measured`), judged against the paper's
//! numbers (`verdict`), drawn beside the paper's points (`figures`) and written into
//! `docs/validation.md` (`report`).

pub mod figures;
pub mod measured;
pub mod others;
pub mod report;
pub mod screening;
pub mod verdict;

use crate::deck::case::LoadedCase;
use crate::solver::ranks::Ranks;
use crate::study_run::run_folder;
use crate::study_run::{run_study_over, Spread, StudyOptions};
use measured::{Measured, MeasuredRun};
use others::Others;
use report::CaseEntry;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where and how cases run.
#[derive(Debug, Clone)]
pub struct ValidateOptions {
    /// Runs go to `<out_dir>/<paper folder>/<case>/`.
    pub out_dir: PathBuf,
    /// The reduced (CI) version of each case.
    pub reduced: bool,
    /// Only the first values of each series (the others stay not run).
    pub first: Option<usize>,
    /// Only the last values of each series (the finest grids); the others keep their
    /// committed measurement.
    pub last: Option<usize>,
    pub threads: Option<usize>,
    pub quiet: bool,
}

/// The repository's validation folder layout, found from a case file or the working folder.
#[derive(Debug, Clone)]
pub struct Layout {
    /// `validation/`.
    pub root: PathBuf,
}

impl Layout {
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Layout { root: root.into() }
    }

    /// Every case file: `validation/seed*/*.toml`, sorted.
    pub fn cases(&self) -> Result<Vec<PathBuf>, String> {
        let mut cases = Vec::new();
        let read = |dir: &Path| {
            std::fs::read_dir(dir).map_err(|e| format!("cannot list {}: {e}", dir.display()))
        };
        for entry in read(&self.root)? {
            let dir = entry.map_err(|e| e.to_string())?.path();
            let is_paper = dir
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("seed"));
            if !(dir.is_dir() && is_paper) {
                continue;
            }
            for file in read(&dir)? {
                let file = file.map_err(|e| e.to_string())?.path();
                if file.extension().is_some_and(|e| e == "toml") {
                    cases.push(file);
                }
            }
        }
        cases.sort();
        Ok(cases)
    }

    /// `<paper folder>-<case>`: a case's name across papers.
    pub fn key(case: &LoadedCase) -> String {
        let folder = case
            .file
            .parent()
            .and_then(|p| p.file_name())
            .map_or(String::new(), |f| f.to_string_lossy().into_owned());
        format!("{folder}-{}", case.name())
    }

    /// The committed measurement of a case's full runs.
    pub fn measured_file(&self, case: &LoadedCase) -> PathBuf {
        self.root
            .join("measured")
            .join(format!("{}.toml", Self::key(case)))
    }

    /// The finished runs of a screening case's full study, kept as they end
    /// (`study_run::kept_runs`).
    pub fn kept_runs_file(&self, case: &LoadedCase) -> PathBuf {
        self.root
            .join("measured")
            .join(format!("{}.runs.csv", Self::key(case)))
    }

    /// `docs/` beside `validation/`.
    pub fn docs(&self) -> PathBuf {
        self.root.parent().unwrap_or(Path::new(".")).join("docs")
    }

    /// `README.md` beside `validation/`.
    pub fn readme(&self) -> PathBuf {
        self.root
            .parent()
            .unwrap_or(Path::new("."))
            .join("README.md")
    }

    /// A path as the report shows it: relative to the repository.
    pub fn relative(&self, path: &Path) -> String {
        let top = self.root.parent().unwrap_or(Path::new(""));
        path.strip_prefix(top).unwrap_or(path).display().to_string()
    }
}

/// Runs a case (or continues it) and returns what it measured. The series runs one value at a
/// time and `keep` receives the measurement after each, so a case stopped in its longest run
/// (the finest grid) keeps what its shorter runs measured. With `over`, each run is one model
/// over those ranks, and only rank 0 measures (the others return no runs) and keeps.
pub fn run_case(
    case: &LoadedCase,
    layout: &Layout,
    opts: &ValidateOptions,
    over: Option<&Arc<dyn Ranks>>,
    keep: &mut dyn FnMut(&Measured) -> Result<(), String>,
) -> Result<Measured, String> {
    let spread = over.map_or(Spread::Alone, |r| Spread::RunOverRanks(r.clone()));
    let root = over.is_none_or(|r| r.rank() == 0);
    let size = if opts.reduced { "reduced" } else { "full" };
    let mut measured = Measured {
        case: layout.relative(&case.file),
        size: size.into(),
        threads: opts
            .threads
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
        ..Measured::default()
    };
    let Some(study) = case.study(opts.reduced) else {
        return Ok(measured);
    };
    let out = case_dir(case, opts);
    if case.screening.is_some() {
        // A screening is measured whole: its statistics need every run of the design. Its
        // full runs are kept beside the measurement as they end, so that the screening,
        // hours long, continues on another machine from the committed ones.
        let options = StudyOptions {
            out_dir: out.clone(),
            threads: opts.threads,
            quiet: opts.quiet,
            from_run: 0,
            kept_runs: (!opts.reduced).then(|| layout.kept_runs_file(case)),
        };
        // Its runs are small: one per thread side by side uses the cores better than each
        // over all of them.
        let spread = match over {
            Some(_) => spread,
            None => Spread::AtOnce(measured.threads),
        };
        let report = run_study_over(&study, &options, &spread).map_err(|e| e.to_string())?;
        if root {
            let minutes = report.minutes.iter().flatten().sum();
            let outputs: Vec<String> = study.study.outputs.iter().map(|o| o.name.clone()).collect();
            let run = screening::measure(&report, &outputs, minutes);
            measured.wall_minutes = run.wall_minutes;
            measured.runs = vec![run];
        }
        agreed(over, if root { keep(&measured) } else { Ok(()) })?;
        return Ok(measured);
    }
    let series = study
        .study
        .factors
        .first()
        .and_then(|f| f.values.clone())
        .unwrap_or_default();
    let end = opts.first.map_or(series.len(), |n| n.min(series.len()));
    let from_run = opts.last.map_or(0, |n| series.len().saturating_sub(n));
    for upto in from_run + 1..=end.max(1) {
        // The study over the first `upto` values continues the one over `upto - 1`: its
        // earlier runs are found finished in `runs.csv` and not run again.
        let mut part = study.clone();
        if let Some(factor) = part.study.factors.first_mut() {
            factor.values = Some(series[..upto].to_vec());
        }
        let report = run_study_over(
            &part,
            &StudyOptions {
                out_dir: out.clone(),
                threads: opts.threads,
                quiet: opts.quiet,
                from_run,
                kept_runs: None,
            },
            &spread,
        )
        .map_err(|e| e.to_string())?;
        if !root {
            // Rank 0 measures and keeps; the others only wait for its word that it could.
            agreed(over, Ok(()))?;
            continue;
        }
        measured.wall_minutes = 0.0;
        measured.runs.clear();
        // Runs left out (`--last`, no status) are not measured here: `keep_full` keeps their
        // earlier measurement.
        let runs = report.runs.iter().enumerate();
        for (k, run) in runs.filter(|(_, r)| !r.status.is_empty()) {
            let dir = run_folder::of_run(&out.join("runs"), k);
            let minutes = run_folder::wall_minutes(&dir).unwrap_or(0.0);
            measured.wall_minutes += minutes;
            measured.runs.push(MeasuredRun {
                series: run.values.first().copied(),
                status: run.status.clone(),
                wall_minutes: minutes,
                threads: None,
                outputs: study
                    .study
                    .outputs
                    .iter()
                    .zip(&run.outputs)
                    .filter_map(|(o, v)| v.map(|v| (o.name.clone(), v)))
                    .collect(),
            });
        }
        agreed(over, keep(&measured))?;
    }
    Ok(measured)
}

/// `local` on one process; over ranks, the lowest rank's error on every rank (so no rank goes
/// on to wait for one that stopped).
fn agreed(over: Option<&Arc<dyn Ranks>>, local: Result<(), String>) -> Result<(), String> {
    match over {
        None => local,
        Some(r) => r.first_message(local.err()).map_or(Ok(()), Err),
    }
}

/// The folder a case's runs go to.
pub fn case_dir(case: &LoadedCase, opts: &ValidateOptions) -> PathBuf {
    opts.out_dir.join(Layout::key(case))
}

/// Writes a full measurement and the case's figures where the report finds them. Runs of the
/// series this invocation did not reach (`--first`) keep their earlier measurement.
pub fn keep_full(
    case: &LoadedCase,
    measured: &Measured,
    layout: &Layout,
    opts: &ValidateOptions,
) -> Result<(), String> {
    let path = layout.measured_file(case);
    let series = case.series_values(false);
    let mut kept = measured.clone();
    if let Some(earlier) = Measured::read(&path)? {
        // A run found finished (the same folder: the same wall time, its outputs read again,
        // perhaps more of them) or not reached keeps the threads it ran on, which may not be
        // this invocation's.
        let own_threads = |run: &MeasuredRun| {
            Some(run.threads.unwrap_or(earlier.threads)).filter(|t| *t != kept.threads)
        };
        for run in &earlier.runs {
            let same = |r: &MeasuredRun| {
                r.series == run.series
                    && r.status == run.status
                    && r.wall_minutes == run.wall_minutes
            };
            if let Some(found) = kept.runs.iter_mut().find(|r| same(r)) {
                found.threads = own_threads(run);
            }
            let reached = kept.runs.iter().any(|r| r.series == run.series);
            if !reached && run.series.is_some_and(|v| series.contains(&v)) {
                kept.wall_minutes += run.wall_minutes;
                kept.runs.push(MeasuredRun {
                    threads: own_threads(run),
                    ..run.clone()
                });
            }
        }
        let position = |v: Option<f64>| series.iter().position(|s| Some(*s) == v);
        kept.runs.sort_by_key(|r| position(r.series));
    }
    kept.write(&path)?;
    figures::draw(
        case,
        &kept,
        &Others::load(case, layout)?,
        &case_dir(case, opts).join("runs"),
        &layout.docs().join("validation"),
    )?;
    Ok(())
}

/// Every case of `layout` with its committed measurement; ids must be unique over all cases.
pub fn load_all(layout: &Layout) -> Result<Vec<CaseEntry>, String> {
    let mut entries = Vec::new();
    let mut ids: Vec<(String, String)> = Vec::new();
    for file in layout.cases()? {
        let case = LoadedCase::from_file(&file).map_err(|e| e.to_string())?;
        let path = layout.relative(&file);
        for id in case
            .case
            .results
            .iter()
            .map(|r| &r.id)
            .chain(case.case.not_run.iter().map(|r| &r.id))
        {
            if let Some((_, other)) = ids.iter().find(|(i, _)| i == id) {
                return Err(format!("{path}: the id `{id}` is also used in {other}"));
            }
            ids.push((id.clone(), path.clone()));
        }
        let measured = Measured::read(&layout.measured_file(&case))?;
        let others = Others::load(&case, layout)?;
        let progress = match measured {
            None => screening_progress(&case, layout),
            Some(_) => None,
        };
        entries.push(CaseEntry {
            case,
            measured,
            others,
            path,
            progress,
        });
    }
    Ok(entries)
}

/// How far a screening without a measurement has come: its runs kept so far (the
/// statistics need them all), and the command that continues it.
fn screening_progress(case: &LoadedCase, layout: &Layout) -> Option<String> {
    let total = case.screening.as_ref()?.runs();
    let file = layout.kept_runs_file(case);
    let text = std::fs::read_to_string(&file).ok()?;
    let kept = text
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .count();
    Some(format!(
        "The screening is under way: {kept} of its {total} runs are kept in `{}`; `peridyn validate {}` continues it.",
        layout.relative(&file),
        layout.relative(&case.file)
    ))
}

/// The texts of `docs/validation.md` and of `README.md` (its summary table rewritten), from
/// every case and its committed measurement.
pub fn report_texts(layout: &Layout) -> Result<(String, Option<String>), String> {
    let entries = load_all(layout)?;
    let unexplained = unexplained_differences(&entries);
    if !unexplained.is_empty() {
        return Err(format!(
            "rows that differ from the paper without a cause: {}; give each an `explanation` in its case (an erratum with the derivation, an inferred input, or a model limitation, and the size of the difference)",
            unexplained.join(", ")
        ));
    }
    let report = report::markdown(&entries, "validation", &layout.docs().join("validation"));
    let readme = std::fs::read_to_string(layout.readme())
        .ok()
        .and_then(|r| report::with_readme_summary(&r, &report::readme_summary(&entries)));
    Ok((report, readme))
}

/// `<case>: <id>` of every full-size row that differs and whose case gives no explanation.
fn unexplained_differences(entries: &[CaseEntry]) -> Vec<String> {
    entries
        .iter()
        .flat_map(|e| {
            e.rows()
                .into_iter()
                .filter(|row| row.status == verdict::Status::Differs)
                .filter(|row| {
                    e.case
                        .case
                        .results
                        .iter()
                        .any(|r| r.id == row.id && r.explanation.trim().is_empty())
                })
                .map(|row| format!("{}: {}", e.path, row.id))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Writes `docs/validation.md` and the README's summary again.
pub fn write_report(layout: &Layout) -> Result<PathBuf, String> {
    let (report, readme) = report_texts(layout)?;
    let write = |path: PathBuf, text: String| {
        crate::atomic_file::write_atomic(&path, text.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    if let Some(readme) = readme {
        write(layout.readme(), readme)?;
    }
    let path = layout.docs().join("validation.md");
    write(path.clone(), report)?;
    Ok(path)
}

/// What `validate` did: each case's rows at the size it ran.
pub struct Validation {
    pub cases: Vec<(String, Vec<verdict::Row>)>,
    /// The report written (full runs and `--report`).
    pub report: Option<PathBuf>,
}

impl Validation {
    /// Rows outside their tolerance.
    pub fn differing(&self) -> usize {
        self.cases
            .iter()
            .flat_map(|(_, rows)| rows)
            .filter(|r| r.status == verdict::Status::Differs)
            .count()
    }
}

impl std::fmt::Display for Validation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use verdict::number;
        for (case, rows) in &self.cases {
            writeln!(f, "{case}")?;
            for r in rows {
                let show = |v: Option<f64>| v.map_or("—".to_string(), number);
                let measured = if r.values.is_empty() {
                    show(r.measured)
                } else {
                    r.values
                        .iter()
                        .map(|v| number(*v))
                        .collect::<Vec<_>>()
                        .join(" → ")
                };
                writeln!(
                    f,
                    "  {:<9} {:<34} peridyn {measured} (paper {}) {} {}",
                    r.status.to_string(),
                    r.id,
                    show(r.paper),
                    r.unit,
                    r.tolerance
                )?;
            }
        }
        if let Some(p) = &self.report {
            write!(f, "report written to {}", p.display())?;
        }
        Ok(())
    }
}

/// Runs `files` (every case of `layout` when empty) at the size `opts` says and judges them;
/// full runs keep their measurements and figures and write the report again. `run = false`:
/// only the report, from the committed measurements. With `over`, each run is one model over
/// those ranks; rank 0 alone prints, judges and writes (the others' `Validation` is empty).
pub fn validate(
    files: &[PathBuf],
    layout: &Layout,
    opts: &ValidateOptions,
    run: bool,
    over: Option<Arc<dyn Ranks>>,
) -> Result<Validation, String> {
    let over = over.as_ref();
    let root = over.is_none_or(|r| r.rank() == 0);
    let files = if files.is_empty() {
        layout.cases()?
    } else {
        files.to_vec()
    };
    let mut done = Validation {
        cases: Vec::new(),
        report: None,
    };
    if run {
        for file in &files {
            let case = LoadedCase::from_file(file).map_err(|e| e.to_string())?;
            if root && !opts.quiet {
                println!("case {}: {}", layout.relative(file), case.case.title);
            }
            let measured = run_case(&case, layout, opts, over, &mut |measured| {
                if opts.reduced {
                    measured.write(&case_dir(&case, opts).join("measured.toml"))?;
                    figures::draw(
                        &case,
                        measured,
                        &Others::none(),
                        &case_dir(&case, opts).join("runs"),
                        &case_dir(&case, opts).join("figures"),
                    )
                    .map(|_| ())
                } else {
                    keep_full(&case, measured, layout, opts)?;
                    // The report covers every case: a problem in another case (a difference
                    // without its explanation) must not stop this one's runs, which may be
                    // hours long; the report is written, or refused, again at the end.
                    if let Err(e) = write_report(layout) {
                        eprintln!("note: docs/validation.md not written yet: {e}");
                    }
                    Ok(())
                }
            })?;
            let judged = match root {
                true => judge(&case, measured, layout, opts).map(|rows| {
                    done.cases.push((layout.relative(file), rows));
                }),
                false => Ok(()),
            };
            agreed(over, judged)?;
        }
    }
    if root && (!run || !opts.reduced) {
        done.report = Some(write_report(layout)?);
    }
    Ok(done)
}

/// The rows of a case that ran. A full run judges what was kept: with `--first` or `--last`,
/// also the runs of before.
fn judge(
    case: &LoadedCase,
    measured: Measured,
    layout: &Layout,
    opts: &ValidateOptions,
) -> Result<Vec<verdict::Row>, String> {
    let kept = if opts.reduced {
        measured
    } else {
        Measured::read(&layout.measured_file(case))?.unwrap_or(measured)
    };
    let others = if opts.reduced {
        Others::none()
    } else {
        Others::load(case, layout)?
    };
    Ok(verdict::judge_case(
        case,
        Some(&kept),
        opts.reduced,
        &others,
    ))
}
