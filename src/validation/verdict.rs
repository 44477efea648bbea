//! A paper's result against what a case measured: PASS within the row's tolerance, DIFFERS
//! outside it or without a value from a finished run (no crack where the paper has one),
//! NOT RUN without a measurement. The same rule serves the full runs (the row's
//! `tolerance`) and the reduced ones in CI (its `reduced_tolerance`).

use super::measured::{Measured, MeasuredRun};
use super::others::Others;
use crate::deck::case::{LoadedCase, ResultSpec, Trend};
use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    Pass,
    Differs,
    NotRun,
    /// Measured, with no tolerance at this size (a reduced run of a row CI does not assert).
    Unchecked,
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Status::Pass => "PASS",
            Status::Differs => "DIFFERS",
            Status::NotRun => "NOT RUN",
            Status::Unchecked => "measured",
        })
    }
}

/// One row of the report.
#[derive(Debug, Clone)]
pub struct Row {
    pub id: String,
    pub quantity: String,
    pub source: String,
    pub paper: Option<f64>,
    pub unit: String,
    pub measured: Option<f64>,
    /// A trend's values over the series, in the order of the series values.
    pub values: Vec<f64>,
    pub status: Status,
    /// The tolerance applied, as the report shows it ("±5 %", "±1 N", "increasing").
    pub tolerance: String,
    /// Why it differs, what it needs, or why the tolerance.
    pub note: String,
}

impl Row {
    /// A row of the paper's result with nothing measured yet.
    fn not_run(id: &str, quantity: &str, source: &str, paper: Option<f64>, unit: &str) -> Row {
        Row {
            id: id.into(),
            quantity: quantity.into(),
            source: source.into(),
            paper,
            unit: unit.into(),
            measured: None,
            values: Vec::new(),
            status: Status::NotRun,
            tolerance: String::new(),
            note: String::new(),
        }
    }

    /// (measured − paper) / |paper|.
    pub fn relative_difference(&self) -> Option<f64> {
        match (self.measured, self.paper) {
            (Some(m), Some(p)) if p != 0.0 => Some((m - p) / p.abs()),
            _ => None,
        }
    }
}

/// The note of a result whose case has no measurement at this size.
pub const NOT_YET_RUN: &str = "Not yet run at this size.";

/// Every row of a case: its results judged against `measured` (none: never run at this size),
/// then its `not_run` rows. `others`: the cases its comparisons read (`Others::none()` at the
/// reduced size, where there is no committed measurement to compare with).
pub fn judge_case(
    case: &LoadedCase,
    measured: Option<&Measured>,
    reduced: bool,
    others: &Others,
) -> Vec<Row> {
    let mut rows: Vec<Row> = case
        .case
        .results
        .iter()
        .map(|r| judge(case, r, measured, reduced, others))
        .collect();
    rows.extend(case.case.not_run.iter().map(|r| Row {
        note: format!("Needs: {}", r.needs),
        ..Row::not_run(&r.id, &r.quantity, &r.source, r.paper, &r.unit)
    }));
    rows
}

fn judge(
    case: &LoadedCase,
    r: &ResultSpec,
    measured: Option<&Measured>,
    reduced: bool,
    others: &Others,
) -> Row {
    let (rel, abs) = if reduced {
        (r.reduced_tolerance, r.reduced_abs_tolerance)
    } else {
        (r.tolerance, r.abs_tolerance)
    };
    let mut row = Row::not_run(&r.id, &r.quantity, &r.source, r.paper, &r.unit);
    let Some(m) = measured else {
        row.note = NOT_YET_RUN.into();
        return row;
    };
    let output = |run: &super::measured::MeasuredRun| {
        run.values(case, others)
            .get(&r.output)
            .copied()
            .map(|v| v * r.scale)
    };
    let at = if reduced { r.reduced_at.or(r.at) } else { r.at };
    if let Some(trend) = r.trend {
        // A bound may be read at one series value (the paper's grid) only, any trend at some
        // (the full series' values: a reduced run reads its own).
        let read = |run: &&MeasuredRun| match (&r.among, at) {
            (Some(among), _) if !reduced => run.series.is_some_and(|v| among.contains(&v)),
            (_, Some(a)) => run.series == Some(a),
            _ => true,
        };
        let mut runs: Vec<_> = m.runs.iter().filter(read).collect();
        runs.sort_by(|a, b| a.series.unwrap_or(0.0).total_cmp(&b.series.unwrap_or(0.0)));
        let values: Vec<Option<f64>> = runs.iter().map(|run| output(run)).collect();
        let level = r.paper.unwrap_or(0.0);
        let every = if at.is_none() { " at every run" } else { "" };
        row.tolerance = match trend {
            Trend::Increasing => "increasing".into(),
            Trend::Decreasing => "decreasing".into(),
            Trend::Constant => format!("constant ±{}", percent(rel.unwrap_or(0.0))),
            Trend::Below => format!("below {}{every}", number(level)),
            Trend::Above => format!("above {}{every}", number(level)),
        };
        if let (Some(a), true) = (at, runs.is_empty()) {
            row.note = format!("The series value {a} is not run at this size.");
            return row;
        }
        // A bound holds run by run; a direction or a constant needs two runs to compare.
        let bound = matches!(trend, Trend::Below | Trend::Above);
        let fewest = if bound { 1 } else { 2 };
        let without: Vec<String> = runs
            .iter()
            .zip(&values)
            .filter(|(_, v)| v.is_none())
            .map(|(run, _)| number(run.series.unwrap_or(f64::NAN)))
            .collect();
        if !without.is_empty() {
            // A finished run without a value (no crack where the paper has one) is a result
            // that differs; its cause is the row's explanation.
            let finished = runs
                .iter()
                .zip(&values)
                .all(|(run, v)| v.is_some() || gave_no_value(case, run, &r.output, others));
            if finished {
                row.status = verdict(false, reduced && r.why_reduced.trim().is_empty());
            }
            let runs = format!(
                "The run{} at {}",
                if without.len() > 1 { "s" } else { "" },
                without.join(" and ")
            );
            row.note = no_value_note(&runs, r, reduced);
            return row;
        }
        if values.len() < fewest {
            row.note = "The series has fewer than two measured runs.".into();
            return row;
        }
        row.values = values.into_iter().flatten().collect();
        let holds = match trend {
            Trend::Increasing => row.values.windows(2).all(|w| w[1] > w[0]),
            Trend::Decreasing => row.values.windows(2).all(|w| w[1] < w[0]),
            Trend::Constant => {
                let mean = row.values.iter().sum::<f64>() / row.values.len() as f64;
                let tol = rel.unwrap_or(0.0) * mean.abs();
                row.values.iter().all(|v| (v - mean).abs() <= tol)
            }
            Trend::Below => row.values.iter().all(|v| *v < level),
            Trend::Above => row.values.iter().all(|v| *v > level),
        };
        // At the reduced size a trend is asserted where the row says why it holds there.
        row.status = verdict(holds, reduced && r.why_reduced.trim().is_empty());
    } else {
        let run = m.runs.iter().find(|run| run.series == at || at.is_none());
        let Some(run) = run else {
            row.note = format!(
                "The series value {} is not run at this size.",
                at.unwrap_or(f64::NAN)
            );
            return row;
        };
        row.measured = output(run);
        let (Some(v), Some(p)) = (row.measured, r.paper) else {
            if row.measured.is_none()
                && r.paper.is_some()
                && gave_no_value(case, run, &r.output, others)
            {
                // As for a trend: a finished run without a value differs from the paper's.
                row.status = verdict(false, rel.is_none() && abs.is_none());
                row.note = no_value_note("The run", r, reduced);
            } else {
                row.note = format!("The run gave no value ({}).", run.status);
            }
            return row;
        };
        row.tolerance = match (rel, abs) {
            (Some(t), _) => format!("±{}", percent(t)),
            (None, Some(a)) => format!("±{} {}", number(a), r.unit),
            (None, None) => String::new(),
        };
        let within = rel
            .map(|t| (v - p).abs() <= t * p.abs())
            .or(abs.map(|a| (v - p).abs() <= a));
        row.status = match within {
            Some(ok) => verdict(ok, false),
            None => Status::Unchecked,
        };
    }
    row.note = match row.status {
        Status::Differs if !reduced => r.explanation.clone(),
        _ if reduced => r.why_reduced.clone(),
        _ => r.why.clone(),
    };
    // A comparison across cases says where its second value came from.
    let other = case
        .case
        .derived
        .iter()
        .find(|d| d.name == r.output)
        .and_then(|d| d.other_case.as_deref())
        .and_then(|c| others.source(c));
    if let Some(source) = other {
        row.note = format!("{} (Second value from {source}.)", row.note)
            .trim()
            .to_string();
    }
    row
}

/// Whether a run finished without a value of `output` of its own: not when it failed, nor
/// when `output` compares with another case that has nothing at this run (no measurement
/// yet, or a reduced run), which leaves the comparison not run.
fn gave_no_value(
    case: &LoadedCase,
    run: &super::measured::MeasuredRun,
    output: &str,
    others: &Others,
) -> bool {
    if run.status != "ok" {
        return false;
    }
    let across = case
        .case
        .derived
        .iter()
        .find(|d| d.name == output && d.other_case.is_some());
    match across {
        Some(d) => {
            let own = run.values(case, others);
            d.inputs().iter().any(|n| !own.contains_key(*n))
        }
        None => true,
    }
}

/// "<runs> gave no value of `<output>`.", with the row's explanation at full size.
fn no_value_note(runs: &str, r: &ResultSpec, reduced: bool) -> String {
    let cause = if reduced { "" } else { r.explanation.as_str() };
    format!("{runs} gave no value of `{}`. {cause}", r.output)
        .trim()
        .to_string()
}

fn verdict(holds: bool, unchecked: bool) -> Status {
    match (unchecked, holds) {
        (true, _) => Status::Unchecked,
        (false, true) => Status::Pass,
        (false, false) => Status::Differs,
    }
}

/// A fraction as a percentage with the digits it needs ("5 %", "0.5 %").
pub fn percent(fraction: f64) -> String {
    format!("{} %", number(100.0 * fraction))
}

/// A number with four significant digits, plain where that reads well.
pub fn number(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let magnitude = v.abs().log10().floor();
    if !(-3.0..6.0).contains(&magnitude) {
        return format!("{v:.3e}");
    }
    let decimals = (3.0 - magnitude).max(0.0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_a_reader_writes_them() {
        assert_eq!(number(137.0), "137");
        assert_eq!(number(8.535), "8.535");
        assert_eq!(number(538.24), "538.2");
        assert_eq!(number(0.0421), "0.0421");
        assert_eq!(number(2.5e-7), "2.500e-7");
        assert_eq!(percent(0.05), "5 %");
    }
}
