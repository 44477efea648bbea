//! Validation case files (`validation/seedNNN/*.toml`; the format is in `validation/README.md`):
//! a deck at a paper's scale, the numbers set for its full and reduced versions, an optional
//! series of one number (the paper's parameter or a convergence series), the outputs read from
//! every run (a study's outputs), and the paper's results those outputs are compared with.
//! Parsed and validated like a deck: every problem is named at its file, line and key. A case
//! runs as a one-factor sweep study (`study_run`), which gives it resumption for free; a
//! screening case instead names a Morris study file, and its outputs are the screening's
//! statistics (`screening_outputs`).

use super::edit::{settable, DeckValue};
use super::study::{FixedSpec, LinkedSpec, LoadedStudy, OutputSpec, StudyFile, StudyMethod};
use super::{locate_issues, parse_located, DeckError, DeckIssue, KeyPath, LoadedDeck};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A case file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseFile {
    pub version: u32,
    /// The seed number of the paper ("002").
    pub paper: String,
    pub title: String,
    /// Where in the paper: section, figure, table.
    pub section: String,
    /// The deck the runs start from, relative to the case file; none for a case whose rows
    /// are all `not_run`, or that reads a `screening`.
    pub deck: Option<PathBuf>,
    /// A Morris study file (relative to the case file) whose screening the case reads instead
    /// of a deck and a series: its outputs are then the screening's (`screening_outputs`).
    pub screening: Option<PathBuf>,
    /// The outputs a screening gives, found when the case is loaded.
    #[serde(skip)]
    pub screening_names: Vec<String>,
    /// A paragraph for the report: what is reproduced, and every input the paper does not
    /// state with how it was chosen.
    #[serde(default)]
    pub about: String,
    /// Values (numbers, or words of the deck) set in every run.
    #[serde(default)]
    pub fixed: Vec<FixedSpec>,
    /// Why the reduced version cannot run in CI's budget (it still runs with `--reduced`).
    pub not_in_ci: Option<String>,
    /// Values set only in the reduced (CI) version, over `fixed`.
    #[serde(default)]
    pub reduced: Vec<FixedSpec>,
    pub series: Option<SeriesSpec>,
    #[serde(default)]
    pub outputs: Vec<OutputSpec>,
    /// Outputs made of other outputs (a count over several boxes, a difference of two times).
    #[serde(default)]
    pub derived: Vec<DerivedSpec>,
    #[serde(default)]
    pub results: Vec<ResultSpec>,
    #[serde(default)]
    pub not_run: Vec<NotRunSpec>,
    #[serde(default)]
    pub plots: Vec<PlotSpec>,
}

/// One number of the deck swept: a run per value.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeriesSpec {
    pub key: String,
    pub values: Vec<f64>,
    /// The values of the reduced version (default: the full ones).
    pub reduced: Option<Vec<f64>>,
    /// Numbers set with the series, one value per series value (the load steps or the end
    /// of loading each horizon needs).
    #[serde(default)]
    pub with: Vec<SeriesLinkSpec>,
}

/// A number of the deck set with the series: `values` with the full series, `reduced` with
/// the reduced one (default: `values`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeriesLinkSpec {
    pub key: String,
    pub values: Vec<f64>,
    pub reduced: Option<Vec<f64>>,
}

/// The output every run has without an `[[outputs]]` entry: its wall time in minutes, as its
/// summary reports it (a comparison of two grids' cost, seed 003 Table 3).
pub const WALL_MINUTES: &str = "wall_minutes";

impl CaseFile {
    /// Whether a run of this case has an output `name`: one of its outputs, its derived
    /// outputs or its wall time.
    pub fn has_output(&self, name: &str) -> bool {
        name == WALL_MINUTES
            || self.outputs.iter().any(|o| o.name == name)
            || self.screening_names.iter().any(|o| o == name)
            || self.derived.iter().any(|d| d.name == name)
    }
}

/// The outputs of a Morris screening over `factors` (their keys) reading `outputs`: for each
/// output and factor, μ* (`mu_star.<output>.<factor>`), μ, σ and the factor's rank by μ*
/// (`rank.…`: 1 the most influential, ties in the study's order); for each output its
/// smallest and largest value over the runs (`min.<output>`, `max.<output>`: the spread of
/// the runs).
pub fn screening_outputs(outputs: &[String], factors: &[String]) -> Vec<String> {
    let mut names = Vec::new();
    for o in outputs {
        for stat in ["mu_star", "mu", "sigma", "rank"] {
            names.extend(factors.iter().map(|f| format!("{stat}.{o}.{f}")));
        }
        names.push(format!("min.{o}"));
        names.push(format!("max.{o}"));
    }
    names
}

/// An output computed from others of the same run: exactly one of `sum`, `min`, `max` (of
/// the listed outputs that have a value: the first of several cracks to start), `difference`
/// (first − second) or `ratio` (first / second). With `other_case`, the second output of a
/// difference or ratio is read from that case's full measurement, at the run in the same
/// position of its series (the two cases list the same δ or Δx in the same order).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DerivedSpec {
    pub name: String,
    pub sum: Option<Vec<String>>,
    pub min: Option<Vec<String>>,
    pub max: Option<Vec<String>>,
    pub difference: Option<[String; 2]>,
    pub ratio: Option<[String; 2]>,
    /// Another case file, relative to this one (`fig12_pmb.toml`).
    pub other_case: Option<PathBuf>,
}

impl DerivedSpec {
    /// The outputs it reads from this case's run.
    pub fn inputs(&self) -> Vec<&String> {
        let mut v: Vec<&String> = Vec::new();
        for list in [&self.sum, &self.min, &self.max] {
            v.extend(list.iter().flatten());
        }
        for pair in [&self.difference, &self.ratio].into_iter().flatten() {
            v.push(&pair[0]);
            if self.other_case.is_none() {
                v.push(&pair[1]);
            }
        }
        v
    }

    /// Its value from the values of its inputs (`None` when one has none); `of_other` gives
    /// the second input of a comparison across cases.
    pub fn value(
        &self,
        of: impl Fn(&str) -> Option<f64>,
        of_other: impl Fn(&str) -> Option<f64>,
    ) -> Option<f64> {
        let second = |n: &str| match self.other_case {
            Some(_) => of_other(n),
            None => of(n),
        };
        if let Some(names) = &self.sum {
            return names.iter().map(|n| of(n)).sum();
        }
        // Of the inputs that have a value (a box without a crack has no start).
        let present = |names: &Vec<String>| names.iter().filter_map(|n| of(n)).collect::<Vec<_>>();
        if let Some(names) = &self.min {
            return present(names).into_iter().reduce(f64::min);
        }
        if let Some(names) = &self.max {
            return present(names).into_iter().reduce(f64::max);
        }
        if let Some([a, b]) = &self.difference {
            return Some(of(a)? - second(b)?);
        }
        if let Some([a, b]) = &self.ratio {
            return Some(of(a)? / second(b)?);
        }
        None
    }
}

/// How a result behaves over the series.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Trend {
    Increasing,
    Decreasing,
    /// Every value within `tolerance` (relative) of their mean.
    Constant,
    /// Every value below the row's `paper` level (0 without one: a difference across cases,
    /// one grid's load below the other's).
    Below,
    /// Every value above the row's `paper` level (0 without one: a speed above 0.5 c_R).
    Above,
}

/// A result of the paper and the output it is compared with.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResultSpec {
    pub id: String,
    pub quantity: String,
    pub source: String,
    /// The paper's number in `unit` (none for a trend).
    pub paper: Option<f64>,
    #[serde(default)]
    pub unit: String,
    pub output: String,
    /// With a series: the series value whose run the row reads (a bound, `below` or
    /// `above`, reads every run without it).
    pub at: Option<f64>,
    /// The reduced series' value whose run the row reads in CI (default `at`): a paper's
    /// number asserted at the reduced size with its `reduced_tolerance`.
    pub reduced_at: Option<f64>,
    /// measured = output × scale.
    #[serde(default = "one")]
    pub scale: f64,
    pub tolerance: Option<f64>,
    pub abs_tolerance: Option<f64>,
    /// Why the tolerance is what it is.
    #[serde(default)]
    pub why: String,
    pub reduced_tolerance: Option<f64>,
    pub reduced_abs_tolerance: Option<f64>,
    #[serde(default)]
    pub why_reduced: String,
    /// Why a full run differs from the paper: erratum, inferred input or model limitation.
    #[serde(default)]
    pub explanation: String,
    pub trend: Option<Trend>,
    /// With a trend: the series values whose runs it reads (default: every run), when the
    /// paper's statement covers only some of them (its own horizons, not coarser ones).
    pub among: Option<Vec<f64>>,
}

fn one() -> f64 {
    1.0
}

/// A result of the paper that cannot be run here, and what it needs.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NotRunSpec {
    pub id: String,
    pub quantity: String,
    pub source: String,
    pub paper: Option<f64>,
    #[serde(default)]
    pub unit: String,
    pub needs: String,
}

/// A figure of the report.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// Letters, digits, `_` or `-`: it names the PNG.
    pub name: String,
    pub title: String,
    pub x: AxisSpec,
    pub y: AxisSpec,
    /// The paper's points, in the plot's units.
    #[serde(default)]
    pub paper: Vec<[f64; 2]>,
}

/// What an axis shows: the series value, an output (a point per run), or a column of a CSV
/// file of the runs (a curve per run).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisSpec {
    #[serde(default)]
    pub series: bool,
    pub output: Option<String>,
    pub file: Option<String>,
    pub column: Option<String>,
    #[serde(default = "one")]
    pub scale: f64,
    #[serde(default)]
    pub label: String,
}

impl AxisSpec {
    /// A curve of a CSV column, one per run (rather than one point per run).
    pub fn is_column(&self) -> bool {
        self.column.is_some()
    }
}

/// A parsed and validated case with its deck.
#[derive(Debug, Clone)]
pub struct LoadedCase {
    pub case: CaseFile,
    pub file: PathBuf,
    pub src: String,
    pub deck: Option<LoadedDeck>,
    /// The Morris study a screening case reads.
    pub screening: Option<LoadedStudy>,
}

impl LoadedCase {
    /// Whether the TOML text is a validation case (it names its paper) rather than a study
    /// or a deck: `peridyn check` takes all three.
    pub fn is_case(src: &str) -> bool {
        src.parse::<toml::Table>()
            .is_ok_and(|t| t.get("paper").is_some_and(|v| v.is_str()))
    }

    /// Reads, parses and validates a case file and its deck.
    pub fn from_file(path: &Path) -> Result<Self, DeckError> {
        let src = std::fs::read_to_string(path).map_err(|source| DeckError::Io {
            file: path.display().to_string(),
            source,
        })?;
        let mut case: CaseFile = parse_located(&src, path)?;
        let fail = |issues: Vec<DeckIssue>| locate_issues(&src, path, issues);
        let screening = match &case.screening {
            None => None,
            Some(f) => {
                let study =
                    LoadedStudy::from_file(&path.parent().unwrap_or(Path::new("")).join(f))?;
                if study.study.method != StudyMethod::Morris {
                    return Err(fail(vec![DeckIssue::new(
                        "screening",
                        format!(
                            "{} is a sweep; a screening case reads a Morris study",
                            f.display()
                        ),
                    )]));
                }
                let outputs: Vec<String> =
                    study.study.outputs.iter().map(|o| o.name.clone()).collect();
                let factors: Vec<String> =
                    study.study.factors.iter().map(|f| f.key.clone()).collect();
                case.screening_names = screening_outputs(&outputs, &factors);
                Some(study)
            }
        };
        let deck = match &case.deck {
            None => None,
            Some(d) => {
                let deck_path = path.parent().unwrap_or(Path::new("")).join(d);
                match std::fs::read_to_string(&deck_path) {
                    Ok(text) => Some(LoadedDeck::from_str(&text, &deck_path)?),
                    Err(e) => {
                        return Err(fail(vec![DeckIssue::new(
                            "deck",
                            format!("cannot read the deck {}: {e}", deck_path.display()),
                        )]))
                    }
                }
            }
        };
        let base = deck.as_ref().or(screening.as_ref().map(|s| &s.base));
        let issues = validate(&case, base.map(|d| d.src.as_str()));
        if !issues.is_empty() {
            return Err(fail(issues));
        }
        Ok(LoadedCase {
            case,
            file: path.to_path_buf(),
            src,
            deck,
            screening,
        })
    }

    /// The case's file name without `.toml`: it names its results folder and measured file.
    pub fn name(&self) -> String {
        self.file
            .file_stem()
            .map_or("case".into(), |s| s.to_string_lossy().into_owned())
    }

    /// The series values of the full or reduced version (one run without a series).
    pub fn series_values(&self, reduced: bool) -> Vec<f64> {
        match &self.case.series {
            None => Vec::new(),
            Some(s) if reduced => s.reduced.clone().unwrap_or_else(|| s.values.clone()),
            Some(s) => s.values.clone(),
        }
    }

    /// The case as a sweep study over its series (no factor without one), or the Morris
    /// study it screens, with the reduced numbers over the fixed ones when `reduced`. `None`
    /// for a case without a deck or a screening.
    pub fn study(&self, reduced: bool) -> Option<LoadedStudy> {
        let mut fixed = self.case.fixed.clone();
        if reduced {
            for r in &self.case.reduced {
                fixed.retain(|f| f.key != r.key);
                fixed.push(r.clone());
            }
        }
        if let Some(screening) = &self.screening {
            let mut study = screening.clone();
            for f in fixed {
                study.study.fixed.retain(|g| g.key != f.key);
                study.study.fixed.push(f);
            }
            return Some(study);
        }
        let base = self.deck.clone()?;
        let factors = self
            .case
            .series
            .iter()
            .map(|s| super::study::FactorSpec {
                key: s.key.clone(),
                min: None,
                max: None,
                values: Some(self.series_values(reduced)),
                with: s
                    .with
                    .iter()
                    .map(|l| LinkedSpec {
                        key: l.key.clone(),
                        values: match (&l.reduced, reduced) {
                            (Some(r), true) => r.clone(),
                            _ => l.values.clone(),
                        },
                    })
                    .collect(),
                also: Vec::new(),
            })
            .collect::<Vec<_>>();
        let keys = factors.iter().map(|f| KeyPath::parse(&f.key)).collect();
        Some(LoadedStudy {
            study: StudyFile {
                version: 1,
                deck: self.case.deck.clone().unwrap_or_default(),
                method: StudyMethod::Sweep,
                morris: None,
                fixed,
                factors,
                outputs: self.case.outputs.clone(),
            },
            file: self.file.clone(),
            src: self.src.clone(),
            base,
            keys,
        })
    }
}

fn is_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

fn validate(case: &CaseFile, deck: Option<&str>) -> Vec<DeckIssue> {
    let mut issues = Vec::new();
    let mut issue = |path: String, message: String| issues.push(DeckIssue::new(&path, message));
    if case.version != 1 {
        issue(
            "version".into(),
            format!(
                "case file version {} is not known; expected 1",
                case.version
            ),
        );
    }
    // Each key must hold a value of its kind in the deck: a number for the series.
    let mut key_exists = |path: String, key: &str, value: &DeckValue| {
        if let Some(src) = deck {
            if let Err(e) = settable(src, &KeyPath::parse(key), value) {
                issue(path, e);
            }
        }
    };
    for (list, name) in [(&case.fixed, "fixed"), (&case.reduced, "reduced")] {
        for (k, f) in list.iter().enumerate() {
            key_exists(format!("{name}[{k}].key"), &f.key, &f.value);
        }
    }
    if let Some(s) = &case.series {
        let a_number = DeckValue::Number(0.0);
        key_exists("series.key".into(), &s.key, &a_number);
        for (j, l) in s.with.iter().enumerate() {
            key_exists(format!("series.with[{j}].key"), &l.key, &a_number);
        }
    }
    if let Some(s) = &case.series {
        let set_elsewhere = |key: &str| {
            key == s.key
                || case.fixed.iter().chain(&case.reduced).any(|f| f.key == key)
                || s.with.iter().filter(|l| l.key == key).count() > 1
        };
        for (j, l) in s.with.iter().enumerate() {
            if set_elsewhere(&l.key) {
                issue(
                    format!("series.with[{j}].key"),
                    format!(
                        "`{}` is set twice (the series, `fixed`, `reduced` or another `with`)",
                        l.key
                    ),
                );
            }
            let reduced_count = s.reduced.as_ref().unwrap_or(&s.values).len();
            for (name, values, count) in [
                ("values", Some(&l.values), s.values.len()),
                ("reduced", l.reduced.as_ref(), reduced_count),
            ] {
                match values {
                    Some(v) if v.len() != count => issue(
                        format!("series.with[{j}].{name}"),
                        format!(
                            "expected one value per series value ({count}), got {}",
                            v.len()
                        ),
                    ),
                    Some(v) if v.iter().any(|x| !x.is_finite()) => issue(
                        format!("series.with[{j}].{name}"),
                        "values must be finite numbers".into(),
                    ),
                    _ => {}
                }
            }
            if l.reduced.is_none() && s.reduced.is_some() && reduced_count != s.values.len() {
                issue(
                    format!("series.with[{j}].key"),
                    "the reduced series has another length: give `reduced` values too".into(),
                );
            }
        }
        for (name, values) in [("values", Some(&s.values)), ("reduced", s.reduced.as_ref())] {
            let repeats =
                values.is_some_and(|v| v.iter().enumerate().any(|(i, x)| v[..i].contains(x)));
            if repeats && !s.with.is_empty() {
                issue(
                    format!("series.{name}"),
                    "a series with numbers set with it (`with`) needs distinct values: each names its position".into(),
                );
            }
            match values {
                Some(v) if v.is_empty() => issue(
                    format!("series.{name}"),
                    "expected at least one value".into(),
                ),
                Some(v) if v.iter().any(|x| !x.is_finite()) => issue(
                    format!("series.{name}"),
                    "values must be finite numbers".into(),
                ),
                _ => {}
            }
        }
    }
    if case
        .not_in_ci
        .as_deref()
        .is_some_and(|w| w.trim().is_empty())
    {
        issue(
            "not_in_ci".into(),
            "say why the reduced version cannot run in CI".into(),
        );
    }
    let has_runs = deck.is_some() || case.screening.is_some();
    if !has_runs && (!case.results.is_empty() || !case.outputs.is_empty()) {
        issue(
            "deck".into(),
            "a case with results or outputs needs a deck to run (or a screening to read)".into(),
        );
    }
    if case.screening.is_some() {
        for (what, given) in [
            ("deck", case.deck.is_some()),
            ("series", case.series.is_some()),
            ("outputs", !case.outputs.is_empty()),
        ] {
            if given {
                issue(
                    what.into(),
                    format!("a screening case reads its study's runs: remove `{what}` (the study file has the deck and its outputs)"),
                );
            }
        }
    }
    for (k, o) in case.outputs.iter().enumerate() {
        if !is_name(&o.name) {
            issue(
                format!("outputs[{k}].name"),
                format!("expected letters, digits, '_' or '-', got {:?}", o.name),
            );
        }
        if case.outputs[..k].iter().any(|p| p.name == o.name) || o.name == WALL_MINUTES {
            issue(
                format!("outputs[{k}].name"),
                format!(
                    "output `{}` is named twice (`{WALL_MINUTES}` is every run's)",
                    o.name
                ),
            );
        }
        for (key, message) in super::study::output_issues(o) {
            issue(format!("outputs[{k}].{key}"), message);
        }
    }
    for (k, d) in case.derived.iter().enumerate() {
        let at = |key: &str| format!("derived[{k}].{key}");
        let known_before = |n: &str| {
            n == WALL_MINUTES
                || case.outputs.iter().any(|o| o.name == n)
                || case.screening_names.iter().any(|o| o == n)
                || case.derived[..k].iter().any(|e| e.name == n)
        };
        if !is_name(&d.name) {
            issue(
                at("name"),
                format!("expected letters, digits, '_' or '-', got {:?}", d.name),
            );
        }
        if known_before(&d.name) {
            issue(at("name"), format!("output `{}` is named twice", d.name));
        }
        let lists = [&d.sum, &d.min, &d.max];
        let kinds = lists.iter().filter(|l| l.is_some()).count()
            + d.difference.is_some() as usize
            + d.ratio.is_some() as usize;
        if kinds != 1
            || lists
                .iter()
                .any(|l| l.as_ref().is_some_and(|s| s.is_empty()))
        {
            issue(
                at("name"),
                "expected one of `sum`, `min` or `max = [outputs…]`, `difference = [a, b]` or `ratio = [a, b]`"
                    .into(),
            );
        }
        if d.other_case.is_some() && lists.iter().any(|l| l.is_some()) {
            issue(
                at("other_case"),
                "`other_case` goes with `difference` or `ratio`: their second output is read from the other case".into(),
            );
        }
        for input in d.inputs() {
            if !known_before(input) {
                issue(
                    at("name"),
                    format!("no output `{input}` above it (outputs and earlier derived ones)"),
                );
            }
        }
    }
    let outputs = || {
        case.outputs
            .iter()
            .map(|o| o.name.as_str())
            .chain(case.derived.iter().map(|d| d.name.as_str()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    for (k, r) in case.results.iter().enumerate() {
        let at = |key: &str| format!("results[{k}].{key}");
        if !case.has_output(&r.output) {
            issue(
                at("output"),
                format!("no output `{}` (the outputs are: {})", r.output, outputs()),
            );
        }
        let series = case.series.as_ref();
        match (series, r.at, r.trend) {
            (_, Some(_), Some(t)) if !matches!(t, Trend::Below | Trend::Above) => issue(
                at("at"),
                "a direction or a constant reads every run of the series; remove `at` (a bound, `below` or `above`, may read one run)".into(),
            ),
            (None, Some(_), _) => issue(at("at"), "`at` needs a [series]".into()),
            // A bound holds run by run, so one run is enough; a direction or a constant
            // compares the runs of a series.
            (None, None, Some(t)) if !matches!(t, Trend::Below | Trend::Above) => issue(
                at("trend"),
                "a trend over runs needs a [series] (`below` and `above` hold for one run too)"
                    .into(),
            ),
            (Some(s), Some(a), _) if !s.values.contains(&a) => issue(
                at("at"),
                format!("{a} is not one of the series values {:?}", s.values),
            ),
            (Some(_), None, None) => issue(
                at("at"),
                "with a [series], a value row names the series value it reads (`at`)".into(),
            ),
            _ => {}
        }
        if let Some(among) = &r.among {
            let values = series.map_or(&[][..], |s| &s.values[..]);
            let fewest = match r.trend {
                None => None,
                Some(Trend::Below | Trend::Above) => Some(1),
                Some(_) => Some(2),
            };
            if let Some(v) = among.iter().find(|v| !values.contains(v)) {
                issue(
                    at("among"),
                    format!("{v} is not one of the series values {values:?}"),
                );
            } else if fewest.is_none_or(|n| among.len() < n) || r.at.is_some() {
                issue(
                    at("among"),
                    "`among` lists the series values a trend reads (two or more for a direction or a constant), without `at`".into(),
                );
            }
        }
        match (series, r.reduced_at) {
            (_, Some(_)) if r.at.is_none() => {
                issue(at("reduced_at"), "`reduced_at` goes with `at`".into())
            }
            (Some(s), Some(a)) if !s.reduced.as_ref().unwrap_or(&s.values).contains(&a) => issue(
                at("reduced_at"),
                format!(
                    "{a} is not one of the reduced series values {:?}",
                    s.reduced.as_ref().unwrap_or(&s.values)
                ),
            ),
            _ => {}
        }
        if r.trend.is_none() {
            if r.paper.is_none() {
                issue(at("paper"), "a value row needs the paper's number".into());
            }
            if r.tolerance.is_none() && r.abs_tolerance.is_none() {
                issue(
                    at("tolerance"),
                    "a value row needs `tolerance` (relative) or `abs_tolerance`".into(),
                );
            }
        } else if r.trend == Some(Trend::Constant) && r.tolerance.is_none() {
            issue(
                at("tolerance"),
                "a constant trend needs `tolerance`: how far from the mean counts as constant"
                    .into(),
            );
        }
        let has_tolerance = r.tolerance.is_some() || r.abs_tolerance.is_some();
        if has_tolerance && r.why.trim().is_empty() {
            issue(at("why"), "say why the tolerance is what it is".into());
        }
        let reduced = r.reduced_tolerance.is_some() || r.reduced_abs_tolerance.is_some();
        if reduced && r.why_reduced.trim().is_empty() {
            issue(
                at("why_reduced"),
                "say how the reduced tolerance was measured and why it holds".into(),
            );
        }
        for (key, v) in [
            ("tolerance", r.tolerance),
            ("abs_tolerance", r.abs_tolerance),
            ("reduced_tolerance", r.reduced_tolerance),
            ("reduced_abs_tolerance", r.reduced_abs_tolerance),
        ] {
            if v.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
                issue(at(key), "expected a finite number ≥ 0".into());
            }
        }
        if !r.scale.is_finite() || r.scale == 0.0 {
            issue(at("scale"), "expected a finite, non-zero factor".into());
        }
    }
    let mut ids: Vec<&str> = case.results.iter().map(|r| r.id.as_str()).collect();
    ids.extend(case.not_run.iter().map(|r| r.id.as_str()));
    for (k, id) in ids.iter().enumerate() {
        if id.trim().is_empty() {
            issue("results".into(), format!("row {k} has an empty id"));
        } else if ids[..k].contains(id) {
            issue("results".into(), format!("the id `{id}` is used twice"));
        }
    }
    for (k, r) in case.not_run.iter().enumerate() {
        if r.needs.trim().is_empty() {
            issue(
                format!("not_run[{k}].needs"),
                "say what the result needs to be run".into(),
            );
        }
    }
    for (k, p) in case.plots.iter().enumerate() {
        let at = |key: &str| format!("plots[{k}].{key}");
        if !is_name(&p.name) {
            issue(
                at("name"),
                format!("expected letters, digits, '_' or '-', got {:?}", p.name),
            );
        }
        for (axis, a) in [("x", &p.x), ("y", &p.y)] {
            let kinds =
                a.series as usize + a.output.is_some() as usize + a.column.is_some() as usize;
            if kinds != 1 {
                issue(
                    at(axis),
                    "expected one of `series = true`, `output = …` or `file`/`column`".into(),
                );
            }
            if a.file.is_some() && a.column.is_none() {
                issue(at(axis), "a `file` needs its `column`".into());
            }
            if a.series && case.series.is_none() {
                issue(at(axis), "`series = true` needs a [series]".into());
            }
            if let Some(o) = &a.output {
                if !case.has_output(o) {
                    issue(
                        at(axis),
                        format!("no output `{o}` (the outputs are: {})", outputs()),
                    );
                }
            }
        }
        if p.x.is_column() != p.y.is_column() {
            issue(
                at("y"),
                "both axes are columns of a file (a curve per run) or neither (a point per run)"
                    .into(),
            );
        }
    }
    issues
}
