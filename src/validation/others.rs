//! Comparisons across cases: a derived output with `other_case` reads its second input from
//! another case's full measurement (`validation/measured/`), at the run of that case's series
//! with the same value when both series sweep the same key (2D against 3D at one grid
//! spacing), otherwise at the run in the same position. Only full measurements are compared:
//! a reduced run has no committed counterpart, so such an output has no value at the reduced
//! size.

use super::measured::{Measured, MeasuredRun};
use super::Layout;
use crate::deck::case::{LoadedCase, WALL_MINUTES};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The cases a case's derived outputs compare with, each with its full measurement.
#[derive(Debug, Clone, Default)]
pub struct Others {
    cases: Vec<Other>,
}

#[derive(Debug, Clone)]
struct Other {
    /// `other_case` as the derived output writes it.
    named: PathBuf,
    case: LoadedCase,
    measured: Option<Measured>,
    /// The measurement file, relative to the repository (the report names it).
    source: String,
}

impl Others {
    /// No other case: a case without comparisons, or a reduced run.
    pub fn none() -> Others {
        Others::default()
    }

    /// The cases `case`'s derived outputs name, read with their committed full measurement.
    /// Refuses an unreadable case, a missing output, and series it cannot pair: a value the
    /// other series of the same key lacks, or series of other keys and different lengths.
    pub fn load(case: &LoadedCase, layout: &Layout) -> Result<Others, String> {
        let mut cases: Vec<Other> = Vec::new();
        let here = case.file.parent().unwrap_or(Path::new(""));
        for (k, d) in case.case.derived.iter().enumerate() {
            let Some(named) = &d.other_case else { continue };
            let at = format!("{}: derived[{k}].other_case", layout.relative(&case.file));
            if cases.iter().any(|o| &o.named == named) {
                continue;
            }
            let other =
                LoadedCase::from_file(&here.join(named)).map_err(|e| format!("{at}: {e}"))?;
            let second = [&d.difference, &d.ratio]
                .into_iter()
                .flatten()
                .map(|pair| &pair[1])
                .next();
            if let Some(name) = second {
                if !other.case.has_output(name) {
                    return Err(format!(
                        "{at}: {} has no output `{name}`",
                        layout.relative(&other.file)
                    ));
                }
            }
            for reduced in [false, true] {
                let (mine, theirs) = (case.series_values(reduced), other.series_values(reduced));
                if same_key(case, &other) {
                    if let Some(v) = mine.iter().find(|v| !theirs.contains(v)) {
                        return Err(format!(
                            "{at}: the runs are paired by their value of the series' key, but {} has no {} run at {v}",
                            layout.relative(&other.file),
                            if reduced { "reduced" } else { "full" },
                        ));
                    }
                } else if mine.len() != theirs.len() {
                    return Err(format!(
                        "{at}: the runs are paired by position in the series, but this case has {} {} values and {} has {}",
                        mine.len(),
                        if reduced { "reduced" } else { "full" },
                        layout.relative(&other.file),
                        theirs.len()
                    ));
                }
            }
            let path = layout.measured_file(&other);
            cases.push(Other {
                named: named.clone(),
                measured: Measured::read(&path)?,
                source: layout.relative(&path),
                case: other,
            });
        }
        Ok(Others { cases })
    }

    /// The value of `output` in the run of `other_case` paired with the full run of `case`
    /// at `series` (the same value of the same key, or the same position in the two series).
    pub fn value(
        &self,
        case: &LoadedCase,
        other_case: &Path,
        series: Option<f64>,
        output: &str,
    ) -> Option<f64> {
        let other = self.cases.iter().find(|o| o.named == other_case)?;
        let measured = other.measured.as_ref()?;
        let paired = if same_key(case, &other.case) {
            series
        } else {
            let position = match series {
                Some(v) => case.series_values(false).iter().position(|s| *s == v)?,
                None => 0,
            };
            other.case.series_values(false).get(position).copied()
        };
        let run = measured.runs.iter().find(|r| r.series == paired)?;
        run.values(&other.case, &Others::none())
            .get(output)
            .copied()
    }

    /// The measurement file a comparison with `other_case` reads, relative to the repository.
    pub fn source(&self, other_case: &Path) -> Option<&str> {
        self.cases
            .iter()
            .find(|o| o.named == other_case)
            .map(|o| o.source.as_str())
    }
}

/// Both cases sweep the same key: their runs pair by the key's value.
fn same_key(case: &LoadedCase, other: &LoadedCase) -> bool {
    match (&case.case.series, &other.case.series) {
        (Some(a), Some(b)) => a.key == b.key,
        _ => false,
    }
}

impl MeasuredRun {
    /// Its outputs, its wall time and the case's derived outputs, computed in order from
    /// them; a comparison across cases reads its second input from `others`.
    pub fn values(&self, case: &LoadedCase, others: &Others) -> BTreeMap<String, f64> {
        let mut values = self.outputs.clone();
        values.insert(WALL_MINUTES.into(), self.wall_minutes);
        for d in &case.case.derived {
            let of_other = |n: &str| {
                d.other_case
                    .as_deref()
                    .and_then(|c| others.value(case, c, self.series, n))
            };
            if let Some(v) = d.value(|n| values.get(n).copied(), of_other) {
                values.insert(d.name.clone(), v);
            }
        }
        values
    }
}
