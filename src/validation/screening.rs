//! A screening case's measurement: the Morris statistics of its study's runs as one run's
//! outputs (`deck::case::screening_outputs` names them), so that the paper's rankings are rows
//! like any other (seed 004 Fig. 11: "δ is the most influential input for the crack length"
//! is `rank.crack_length.discretization.horizon` = 1).

use super::measured::MeasuredRun;
use crate::study::morris::FactorEffect;
use crate::study_run::StudyReport;
use std::collections::BTreeMap;

/// The screening's outputs from a finished (or partly finished) study: μ*, μ, σ and the rank
/// by μ* of each factor per output, and each output's extremes over the runs that gave it.
/// `status` says how many runs ended and how many failed.
pub fn measure(report: &StudyReport, outputs: &[String], wall_minutes: f64) -> MeasuredRun {
    let mut values = BTreeMap::new();
    for (o, effects) in &report.effects {
        for (f, e) in report.factors.iter().zip(effects) {
            let stats = [("mu_star", e.mu_star), ("mu", e.mu), ("sigma", e.sigma)];
            for (stat, v) in stats {
                if let Some(v) = v {
                    values.insert(format!("{stat}.{o}.{f}"), v);
                }
            }
        }
        for (f, rank) in report.factors.iter().zip(ranks(effects)) {
            if let Some(rank) = rank {
                values.insert(format!("rank.{o}.{f}"), rank as f64);
            }
        }
    }
    for (k, o) in outputs.iter().enumerate() {
        let given = report
            .runs
            .iter()
            .filter_map(|r| r.outputs.get(k).copied().flatten());
        let (lo, hi) = given.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        if lo <= hi {
            values.insert(format!("min.{o}"), lo);
            values.insert(format!("max.{o}"), hi);
        }
    }
    let ended = report.runs.iter().filter(|r| !r.status.is_empty()).count();
    let status = match report.failed() - (report.runs.len() - ended) {
        _ if ended < report.runs.len() => format!("{ended} of {} runs", report.runs.len()),
        0 => "ok".into(),
        failed => format!("ok ({failed} of {} runs failed)", report.runs.len()),
    };
    MeasuredRun {
        series: None,
        status,
        wall_minutes,
        threads: None,
        outputs: values,
    }
}

/// Each factor's place by μ* (1: the largest); equal μ* keep the study's order; a factor
/// without μ* (every effect lost to failed runs) has none.
fn ranks(effects: &[FactorEffect]) -> Vec<Option<usize>> {
    let mut order: Vec<usize> = (0..effects.len())
        .filter(|&k| effects[k].mu_star.is_some())
        .collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (effects[a].mu_star.unwrap(), effects[b].mu_star.unwrap());
        y.total_cmp(&x).then(a.cmp(&b))
    });
    let mut rank = vec![None; effects.len()];
    for (place, &k) in order.iter().enumerate() {
        rank[k] = Some(place + 1);
    }
    rank
}

#[cfg(test)]
mod tests {
    use super::*;

    fn effect(mu_star: Option<f64>) -> FactorEffect {
        FactorEffect {
            name: String::new(),
            mu: mu_star,
            mu_star,
            sigma: None,
            effects: 2,
        }
    }

    #[test]
    fn factors_rank_by_their_mu_star_ties_in_order_and_none_without_one() {
        let effects: Vec<FactorEffect> = [Some(0.5), Some(2.0), None, Some(0.5), Some(3.0)]
            .into_iter()
            .map(effect)
            .collect();
        assert_eq!(ranks(&effects), [Some(3), Some(2), None, Some(4), Some(1)]);
    }
}
