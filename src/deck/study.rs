//! Study files: the deck every run starts from, the inputs a study varies (factors: numbers of
//! that deck by key path, between bounds or through a list of values), the design (Morris
//! screening or a sweep over every combination) and the outputs read from each run's CSV
//! files. Parsed and validated like a deck: every problem is named at its file, line and key.

use super::edit::{number_at, settable, DeckValue};
use super::{locate_issues, parse_located, DeckError, DeckIssue, KeyPath, LoadedDeck};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// More runs than this are refused as a likely mistake.
pub const MAX_RUNS: usize = 100_000;

/// A study file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    pub version: u32,
    /// The deck every run starts from, relative to the study file.
    pub deck: PathBuf,
    pub method: StudyMethod,
    /// Morris settings (`method = "morris"` only; defaults otherwise).
    pub morris: Option<MorrisSettings>,
    /// Values of the deck set for every run (e.g. a coarser grid for a screening study, or a
    /// solver's preconditioner), applied before the factors.
    #[serde(default)]
    pub fixed: Vec<FixedSpec>,
    pub factors: Vec<FactorSpec>,
    pub outputs: Vec<OutputSpec>,
}

/// A value of the base deck (a number, or a word such as a solver's preconditioner) set for
/// every run of the study.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FixedSpec {
    pub key: String,
    pub value: DeckValue,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StudyMethod {
    /// Morris elementary-effects screening (`study::morris`): factors between `min` and `max`.
    Morris,
    /// Every combination of the factors' `values` (a full factorial parameter study).
    Sweep,
}

/// The Morris design (Morris 1991; Campolongo et al. 2007; seed 004 §3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MorrisSettings {
    /// r: trajectories kept (k + 1 runs each, k factors).
    #[serde(default = "default_trajectories")]
    pub trajectories: usize,
    /// N: trajectories drawn, of which the r most spread out are kept.
    #[serde(default = "default_pool")]
    pub pool: usize,
    /// p: grid levels per factor (even).
    #[serde(default = "default_levels")]
    pub levels: usize,
    /// The random design's seed: the same seed, the same runs on every machine.
    #[serde(default)]
    pub seed: u64,
}

fn default_trajectories() -> usize {
    5
}
fn default_pool() -> usize {
    20
}
fn default_levels() -> usize {
    4
}

impl Default for MorrisSettings {
    /// Seed 004 §3: r = 5 of N = 20; p = 4.
    fn default() -> Self {
        MorrisSettings {
            trajectories: default_trajectories(),
            pool: default_pool(),
            levels: default_levels(),
            seed: 0,
        }
    }
}

/// One input of the study: a number of the base deck.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FactorSpec {
    /// Key path of the number in the deck, e.g. `material.youngs_modulus` or
    /// `boundary_conditions[0].value`.
    pub key: String,
    /// Bounds (Morris).
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// Values (sweep).
    pub values: Option<Vec<f64>>,
    /// Numbers set with the factor (sweep): in each run, each takes its value at the position
    /// of the factor's value (a series in the horizon with the load steps each horizon needs).
    #[serde(default)]
    pub with: Vec<LinkedSpec>,
    /// Other numbers of the deck set to the factor's own value in every run (either method):
    /// one input written at two places, e.g. a notch's length in its slot and in the bond
    /// filter along it (seed 004's l_c).
    #[serde(default)]
    pub also: Vec<String>,
}

/// A number of the deck set with a sweep factor, one value per value of the factor.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkedSpec {
    pub key: String,
    pub values: Vec<f64>,
}

/// One scalar read from every run: a column of a CSV file reduced to one number, or a number
/// of a TOML file the run writes (`resolved.toml`: the deck as run and its derived constants).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// The output's name in `runs.csv`, `morris.csv` and plot file names.
    pub name: String,
    /// The run's file it is read from (default `history.csv`): a CSV file, or `resolved.toml`.
    #[serde(default = "default_file")]
    pub file: String,
    /// The column of a CSV file.
    pub column: Option<String>,
    /// How the column becomes one number (CSV files).
    pub reduce: Option<Reduce>,
    /// The key path of a number in a TOML file, e.g. `derived.materials[0].peak_stretch`.
    pub key: Option<String>,
    /// `first_time_above`, `at_first_above`: the level the column must pass.
    pub threshold: Option<f64>,
    /// Only rows with `time` ≤ this (s) count (seed 004 evaluates its study up to a given
    /// grip displacement).
    pub until: Option<f64>,
    /// Only rows with `time` ≥ this (s) count (a crack speed once the crack runs).
    pub from: Option<f64>,
    /// `pearson`, `max_distance`: the second column of the same file; `angle`, `slope`: the
    /// abscissa column; `fork_opening`: the column numbering the forks.
    pub against: Option<String>,
    /// `at_first_above`: the column that must pass `threshold` (in `when_file`).
    pub when_column: Option<String>,
    /// `at_first_above`: the CSV file of `when_column` (default: `file`).
    pub when_file: Option<String>,
    /// `angle`: the length of the first part of the path, along `against` from its first row.
    pub first: Option<f64>,
    /// `time_of_max`: a row within this of the largest value counts as at it (a tip's
    /// position is resolved to one grid spacing; default 0).
    pub within: Option<f64>,
    /// `slope`, `angle`: only rows whose value of the column lies in [low, high] (a crack tip
    /// between the notch and the far edge; one of two cracks in one path file).
    pub between: Option<[f64; 2]>,
}

impl OutputSpec {
    /// Whether it reads a number of a TOML file by key rather than a CSV column.
    pub fn is_toml(&self) -> bool {
        self.file.ends_with(".toml")
    }
}

fn default_file() -> String {
    "history.csv".into()
}

/// How a column becomes one number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reduce {
    /// The last row's value.
    Final,
    Max,
    /// The largest value, once the column has turned down after it (an ultimate load); a
    /// run whose last row holds its largest value has not reached its peak and has none.
    Peak,
    /// The largest fall from one row to the next, as a fraction of the column's largest value
    /// (a load that drops at once, against one that softens step by step).
    LargestDrop,
    Min,
    /// The largest magnitude (a reaction force of either sign).
    MaxAbs,
    /// The `time` of the first row whose value exceeds `threshold` (e.g. crack initiation:
    /// `broken_bonds` above 0); a run that never passes it has no value.
    FirstTimeAbove,
    /// The `time` of the first row where the column has its largest value, or comes within
    /// `within` of it (a crack tip's y stops rising: the crack turns horizontal).
    TimeOfMax,
    /// The column's value at the time `when_column` first exceeds `threshold` (a crack's
    /// speed when its tip reaches a pore), interpolated linearly in time.
    AtFirstAbove,
    /// The mean of the values (a crack speed over a window of time).
    Mean,
    /// How many rows have a value (the forks of `branching.csv`).
    Count,
    /// 1 when the last row has a value, else 0 (a crack tip found in its box when the run
    /// ended, however early it ended).
    Present,
    /// The Pearson correlation with the column `against` (a crack path against its
    /// reference in `crack_path_comparison.csv`; seed 003 Eq. 17).
    Pearson,
    /// The largest |column − `against`| (a crack path's largest distance from its reference
    /// in `crack_path_comparison.csv`).
    MaxDistance,
    /// The least-squares slope of the column against the column `against`, over the rows
    /// whose value lies `between` two levels (a crack's speed: its tip's x against time, as a
    /// reader takes it from a plot of the tip's position).
    Slope,
    /// The angle (degrees) of the least-squares line of the column against the column
    /// `against`, over the rows within `first` of the first row (a crack's initial direction),
    /// of those whose value lies `between` two levels when given.
    Angle,
    /// The opening of the first fork: the largest minus the smallest value of the column (a
    /// branch's angle to the x axis) over the rows of the first fork, the rows sharing the
    /// first row's value of the column `against` (`fork` in `branching.csv`) that have at
    /// least two values (the angle between a fork's outer daughter cracks).
    ForkOpening,
}

/// A parsed and validated study with its base deck.
#[derive(Debug, Clone)]
pub struct LoadedStudy {
    pub study: StudyFile,
    pub file: PathBuf,
    pub src: String,
    /// The base deck, loaded and validated.
    pub base: LoadedDeck,
    /// The factors' key paths, parsed.
    pub keys: Vec<KeyPath>,
}

impl LoadedStudy {
    /// Whether the TOML text is a study file rather than a deck: a deck has no `deck` key, a
    /// study names its base deck there (`peridyn check` takes either).
    pub fn is_study(src: &str) -> bool {
        src.parse::<toml::Table>()
            .is_ok_and(|t| t.get("deck").is_some_and(|v| v.is_str()))
    }

    /// Reads, parses and validates a study file and its base deck.
    pub fn from_file(path: &Path) -> Result<Self, DeckError> {
        let src = std::fs::read_to_string(path).map_err(|source| DeckError::Io {
            file: path.display().to_string(),
            source,
        })?;
        let study: StudyFile = parse_located(&src, path)?;
        let fail = |issues: Vec<DeckIssue>| locate_issues(&src, path, issues);
        let base_path = path.parent().unwrap_or(Path::new("")).join(&study.deck);
        let base = match std::fs::read_to_string(&base_path) {
            Ok(text) => LoadedDeck::from_str(&text, &base_path)?,
            Err(e) => {
                return Err(fail(vec![DeckIssue::new(
                    "deck",
                    format!("cannot read the deck {}: {e}", base_path.display()),
                )]))
            }
        };
        let issues = validate(&study, &base.src);
        if !issues.is_empty() {
            return Err(fail(issues));
        }
        let keys = study
            .factors
            .iter()
            .map(|f| KeyPath::parse(&f.key))
            .collect();
        Ok(LoadedStudy {
            study,
            file: path.to_path_buf(),
            src,
            base,
            keys,
        })
    }

    /// The Morris settings in force (the defaults when the file gives none).
    pub fn morris(&self) -> MorrisSettings {
        self.study.morris.unwrap_or_default()
    }

    /// How many runs the design makes.
    pub fn runs(&self) -> usize {
        runs(&self.study).unwrap_or(usize::MAX)
    }
}

/// Runs of the design: r (k + 1) for Morris, the product of the value counts for a sweep
/// (`None` past `usize`).
fn runs(study: &StudyFile) -> Option<usize> {
    match study.method {
        StudyMethod::Morris => {
            let r = study.morris.unwrap_or_default().trajectories;
            r.checked_mul(study.factors.len() + 1)
        }
        StudyMethod::Sweep => study.factors.iter().try_fold(1usize, |n, f| {
            n.checked_mul(f.values.as_ref().map_or(0, |v| v.len()))
        }),
    }
}

fn validate(study: &StudyFile, base_src: &str) -> Vec<DeckIssue> {
    let mut issues = Vec::new();
    let mut issue = |path: String, message: String| issues.push(DeckIssue::new(&path, message));
    if study.version != 1 {
        issue(
            "version".into(),
            format!(
                "study file version {} is not known; expected 1",
                study.version
            ),
        );
    }
    let morris = study.method == StudyMethod::Morris;
    match (study.method, study.morris) {
        (StudyMethod::Sweep, Some(_)) => issue(
            "morris".into(),
            "Morris settings apply to method = \"morris\" only; remove them or change the method"
                .into(),
        ),
        (_, Some(m)) => {
            if m.trajectories < 2 {
                issue(
                    "morris.trajectories".into(),
                    format!(
                        "r = {} trajectories is too few: σ needs r ≥ 2",
                        m.trajectories
                    ),
                );
            }
            if m.pool < m.trajectories {
                issue(
                    "morris.pool".into(),
                    format!(
                        "a pool of {} trajectories cannot give r = {}; expected pool ≥ trajectories",
                        m.pool, m.trajectories
                    ),
                );
            }
            if m.levels < 2 || m.levels % 2 != 0 {
                issue(
                    "morris.levels".into(),
                    format!("expected an even number of levels ≥ 2, got {}", m.levels),
                );
            }
        }
        _ => {}
    }
    for (k, f) in study.fixed.iter().enumerate() {
        let at = |key: &str| format!("fixed[{k}].{key}");
        if let Err(e) = settable(base_src, &KeyPath::parse(&f.key), &f.value) {
            issue(at("key"), e);
        }
        if let DeckValue::Number(v) = f.value {
            if !v.is_finite() {
                issue(at("value"), format!("expected a finite number, got {v}"));
            }
        }
        if study.fixed[..k].iter().any(|g| g.key == f.key) {
            issue(at("key"), format!("`{}` is fixed twice", f.key));
        }
        if study.factors.iter().any(|g| g.key == f.key) || linked(study).any(|l| l == f.key) {
            issue(
                at("key"),
                format!("`{}` is also a factor; it cannot be both", f.key),
            );
        }
    }
    if study.factors.is_empty() {
        issue(
            "factors".into(),
            "a study needs at least one [[factors]] entry".into(),
        );
    }
    for (k, f) in study.factors.iter().enumerate() {
        let at = |key: &str| format!("factors[{k}].{key}");
        if let Err(e) = number_at(base_src, &KeyPath::parse(&f.key)) {
            issue(at("key"), e);
        }
        if study.factors[..k].iter().any(|g| g.key == f.key) {
            issue(at("key"), format!("`{}` is varied twice", f.key));
        }
        for (j, key) in f.also.iter().enumerate() {
            let at = format!("factors[{k}].also[{j}]");
            if let Err(e) = number_at(base_src, &KeyPath::parse(key)) {
                issue(at.clone(), e);
            }
            let varied = study.factors.iter().any(|g| &g.key == key);
            if varied || linked(study).filter(|&o| o == key).count() > 1 {
                issue(at, format!("`{key}` is varied twice"));
            }
        }
        for (j, l) in f.with.iter().enumerate() {
            let at = |key: &str| format!("factors[{k}].with[{j}].{key}");
            if let Err(e) = number_at(base_src, &KeyPath::parse(&l.key)) {
                issue(at("key"), e);
            }
            let varied = study.factors.iter().any(|g| g.key == l.key);
            if varied || linked(study).filter(|&o| o == l.key).count() > 1 {
                issue(at("key"), format!("`{}` is varied twice", l.key));
            }
            if morris {
                issue(
                    at("key"),
                    "numbers set with a factor (`with`) are for method = \"sweep\"".into(),
                );
                continue;
            }
            let count = f.values.as_ref().map_or(0, |v| v.len());
            if l.values.len() != count {
                issue(
                    at("values"),
                    format!(
                        "expected one value per value of the factor ({count}), got {}",
                        l.values.len()
                    ),
                );
            }
            if let Some(bad) = l.values.iter().find(|x| !x.is_finite()) {
                issue(
                    at("values"),
                    format!("values must be finite numbers, got {bad}"),
                );
            }
            let values = f.values.as_deref().unwrap_or_default();
            if values
                .iter()
                .enumerate()
                .any(|(i, v)| values[..i].contains(v))
            {
                issue(
                    format!("factors[{k}].values"),
                    "a factor with numbers set with it (`with`) needs distinct values: each names its position".into(),
                );
            }
        }
        if morris {
            if f.values.is_some() {
                issue(
                    at("values"),
                    "a Morris factor takes `min` and `max`, not `values` (those are for method = \"sweep\")".into(),
                );
            }
            match (f.min, f.max) {
                (Some(lo), Some(hi)) if !(lo.is_finite() && hi.is_finite()) => issue(
                    at("min"),
                    format!("bounds must be finite numbers, got [{lo}, {hi}]"),
                ),
                (Some(lo), Some(hi)) if lo >= hi => issue(
                    at("max"),
                    format!("expected max above min, got min = {lo}, max = {hi}"),
                ),
                (Some(_), Some(_)) => {}
                _ => issue(
                    at("key"),
                    "a Morris factor needs both `min` and `max`".into(),
                ),
            }
        } else {
            if f.min.is_some() || f.max.is_some() {
                issue(
                    at("key"),
                    "a sweep factor takes `values`, not `min` and `max` (those are for method = \"morris\")".into(),
                );
            }
            match &f.values {
                None => issue(at("key"), "a sweep factor needs `values`".into()),
                Some(v) if v.is_empty() => {
                    issue(at("values"), "expected at least one value".into())
                }
                Some(v) => {
                    if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
                        issue(
                            at("values"),
                            format!("values must be finite numbers, got {bad}"),
                        );
                    }
                }
            }
        }
    }
    if study.outputs.is_empty() {
        issue(
            "outputs".into(),
            "a study needs at least one [[outputs]] entry".into(),
        );
    }
    for (k, o) in study.outputs.iter().enumerate() {
        let at = |key: &str| format!("outputs[{k}].{key}");
        let name_ok = !o.name.is_empty()
            && o.name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !name_ok {
            issue(
                at("name"),
                format!(
                    "expected a name of letters, digits, '_' or '-' (it names files), got {:?}",
                    o.name
                ),
            );
        }
        if study.outputs[..k].iter().any(|p| p.name == o.name) {
            issue(at("name"), format!("output `{}` is named twice", o.name));
        }
        for issue_at in output_issues(o) {
            issue(at(issue_at.0), issue_at.1);
        }
    }
    match runs(study) {
        Some(n) if n <= MAX_RUNS => {}
        n => issue(
            "factors".into(),
            format!(
                "the design makes {} runs, more than {MAX_RUNS}; use fewer factors, values or trajectories",
                n.map_or("too many".into(), |n| n.to_string())
            ),
        ),
    }
    issues
}

/// The keys set with the factors (`with`, `also`), in order.
fn linked(study: &StudyFile) -> impl Iterator<Item = &str> {
    study.factors.iter().flat_map(|f| {
        let with = f.with.iter().map(|l| l.key.as_str());
        with.chain(f.also.iter().map(String::as_str))
    })
}

/// What is wrong with one output's keys, each as (key, message): the file, then the keys its
/// kind of output needs and those it does not use.
pub(crate) fn output_issues(o: &OutputSpec) -> Vec<(&'static str, String)> {
    let mut issues = Vec::new();
    let mut issue = |key: &'static str, message: String| issues.push((key, message));
    let plain = |f: &str| !f.contains(['/', '\\']);
    if o.is_toml() {
        if !plain(&o.file) {
            issue(
                "file",
                format!(
                    "expected the name of a file in the run's folder (resolved.toml), got {:?}",
                    o.file
                ),
            );
        }
        if o.key.is_none() {
            issue(
                "key",
                format!("a number of {} is read by key path: add e.g. `key = \"derived.materials[0].peak_stretch\"`", o.file),
            );
        }
        let csv_only = [
            ("column", o.column.is_some()),
            ("reduce", o.reduce.is_some()),
            ("threshold", o.threshold.is_some()),
            ("until", o.until.is_some()),
            ("from", o.from.is_some()),
            ("against", o.against.is_some()),
            ("when_column", o.when_column.is_some()),
            ("when_file", o.when_file.is_some()),
            ("first", o.first.is_some()),
            ("within", o.within.is_some()),
        ];
        for (key, given) in csv_only {
            if given {
                issue(
                    key,
                    format!(
                        "`{key}` applies to a CSV file; {} is read by `key` alone",
                        o.file
                    ),
                );
            }
        }
        return issues;
    }
    if !(plain(&o.file) && o.file.ends_with(".csv")) {
        issue(
            "file",
            format!(
                "expected the name of a CSV file the run writes (history.csv, crack_tip.csv, …) or resolved.toml, got {:?}",
                o.file
            ),
        );
    }
    if o.key.is_some() {
        issue(
            "key",
            format!(
                "`key` reads a TOML file (resolved.toml); {} is read by `column` and `reduce`",
                o.file
            ),
        );
    }
    if o.column.is_none() {
        issue(
            "column",
            format!("expected the column of {} to read", o.file),
        );
    }
    let Some(reduce) = o.reduce else {
        issue(
            "reduce",
            "expected how the column becomes one number: final, max, peak, largest_drop, min, max_abs, first_time_above, time_of_max, at_first_above, mean, count, pearson, max_distance, slope, angle or fork_opening".into(),
        );
        return issues;
    };
    let uses_threshold = matches!(reduce, Reduce::FirstTimeAbove | Reduce::AtFirstAbove);
    match o.threshold {
        None if uses_threshold => issue(
            "reduce",
            "first_time_above and at_first_above need a `threshold`".into(),
        ),
        Some(t) if uses_threshold && !t.is_finite() => {
            issue("threshold", format!("expected a finite number, got {t}"))
        }
        Some(_) if !uses_threshold => issue(
            "threshold",
            "a threshold is used by reduce = \"first_time_above\" or \"at_first_above\" only"
                .into(),
        ),
        _ => {}
    }
    match o.within {
        Some(w) if reduce != Reduce::TimeOfMax => issue(
            "within",
            format!("`within` ({w}) is used by reduce = \"time_of_max\" only"),
        ),
        Some(w) if !(w.is_finite() && w >= 0.0) => issue(
            "within",
            format!("expected a finite distance from the largest value, at least 0, got {w}"),
        ),
        _ => {}
    }
    let uses_against = matches!(
        reduce,
        Reduce::Pearson | Reduce::MaxDistance | Reduce::Slope | Reduce::Angle | Reduce::ForkOpening
    );
    match &o.against {
        None if uses_against => issue(
            "reduce",
            "pearson, max_distance, slope, angle and fork_opening need `against`: the second column of the file"
                .into(),
        ),
        Some(_) if !uses_against => issue(
            "against",
            "`against` is used by reduce = \"pearson\", \"max_distance\", \"slope\", \"angle\" or \"fork_opening\" only"
                .into(),
        ),
        _ => {}
    }
    match o.between {
        Some(b) if !matches!(reduce, Reduce::Slope | Reduce::Angle) => issue(
            "between",
            format!("`between` ({b:?}) is used by reduce = \"slope\" or \"angle\" only"),
        ),
        Some([low, high]) if !(low.is_finite() && high.is_finite() && low < high) => issue(
            "between",
            format!("expected [low, high], finite with low < high, got [{low}, {high}]"),
        ),
        _ => {}
    }
    let at_first = reduce == Reduce::AtFirstAbove;
    if at_first && o.when_column.is_none() {
        issue(
            "reduce",
            "at_first_above needs `when_column`: the column that passes `threshold`".into(),
        );
    }
    for (key, given) in [
        ("when_column", o.when_column.is_some()),
        ("when_file", o.when_file.is_some()),
    ] {
        if given && !at_first {
            issue(
                key,
                format!("`{key}` is used by reduce = \"at_first_above\" only"),
            );
        }
    }
    if let Some(f) = &o.when_file {
        if !(plain(f) && f.ends_with(".csv")) {
            issue(
                "when_file",
                format!("expected the name of a CSV file the run writes, got {f:?}"),
            );
        }
    }
    for (key, bound) in [("until", o.until), ("from", o.from)] {
        if let Some(t) = bound {
            if !(t.is_finite() && t >= 0.0) {
                issue(key, format!("expected a time ≥ 0 s, got {t}"));
            }
        }
    }
    if let (Some(from), Some(until)) = (o.from, o.until) {
        if from > until {
            issue(
                "from",
                format!("the window is empty: from = {from} s is after until = {until} s"),
            );
        }
    }
    match o.first {
        None if reduce == Reduce::Angle => issue(
            "reduce",
            "angle needs `first`: the length of the path's first part, in the units of `against`"
                .into(),
        ),
        Some(_) if reduce != Reduce::Angle => {
            issue("first", "`first` is used by reduce = \"angle\" only".into())
        }
        Some(l) if !(l.is_finite() && l > 0.0) => {
            issue("first", format!("expected a length > 0, got {l}"))
        }
        _ => {}
    }
    issues
}
