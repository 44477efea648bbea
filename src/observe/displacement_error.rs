//! The nodes' displacement against an analytic solution (`[analysis.displacement_error]`):
//! every `interval` steps from the solution's release on, a row of `displacement_error.csv`
//! with, per node set, the volume-weighted root mean square and the largest magnitude of
//! u − u_exact over the set's nodes the solution covers (seed 003 Figs. 9–10: the error of the
//! bar at one particle, and as an L2 norm over the bar). Sequential sums in node order: the
//! same file for any number of threads. A restart continues it through `ResumedCsv`.

use super::csv::CsvHistory;
use super::observer::{Every, Observer, StepView};
use crate::analysis::FixedFreeBar;
use std::io;
use std::path::Path;

pub struct DisplacementError {
    solution: FixedFreeBar,
    every: Every,
    /// Each set's nodes on the bar.
    sets: Vec<Vec<u32>>,
    rows: CsvHistory,
}

impl DisplacementError {
    /// Writes into `path` one `<set>_rms` and one `<set>_max` column per named set.
    pub fn new(
        path: &Path,
        solution: FixedFreeBar,
        interval: u64,
        sets: Vec<(String, Vec<u32>)>,
    ) -> Self {
        let mut header = vec!["time".to_string(), "step".to_string()];
        for (name, _) in &sets {
            header.push(format!("{name}_rms"));
            header.push(format!("{name}_max"));
        }
        DisplacementError {
            solution,
            every: Every(interval),
            sets: sets.into_iter().map(|(_, nodes)| nodes).collect(),
            rows: CsvHistory::new(path, header),
        }
    }
}

/// The volume-weighted RMS and the largest |error| of the nodes' displacement `u` against the
/// bar's (along x; the exact field has no other component), over `nodes` at time `t`.
pub fn bar_error<const D: usize>(
    bar: &FixedFreeBar,
    positions: &[crate::math::Vector<D>],
    volumes: &[f64],
    u: &[crate::math::Vector<D>],
    nodes: &[u32],
    t: f64,
) -> (f64, f64) {
    let (mut squares, mut volume, mut largest) = (0.0, 0.0, 0.0_f64);
    for &i in nodes {
        let i = i as usize;
        let x = positions[i][0];
        let mut e = u[i];
        e[0] -= bar.displacement(x, t);
        let e2 = e.norm_squared();
        squares += e2 * volumes[i];
        volume += volumes[i];
        largest = largest.max(e2.sqrt());
    }
    ((squares / volume).sqrt(), largest)
}

impl<const D: usize> Observer<D> for DisplacementError {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let (body, state) = (view.body, view.state);
        if state.time < self.solution.release {
            return Ok(()); // the body is not yet in the state the solution starts from
        }
        let mut row = vec![state.time, state.step as f64];
        for nodes in &self.sets {
            let (rms, max) = bar_error(
                &self.solution,
                &body.positions,
                &body.volumes,
                &state.u,
                nodes,
                state.time,
            );
            row.extend([rms, max]);
        }
        self.rows.push(row)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.rows.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vector;

    #[test]
    fn the_error_is_the_volume_weighted_rms_and_the_largest_magnitude() {
        let bar = FixedFreeBar {
            strain: 1e-3,
            length: 1.0,
            fixed_end: 0.0,
            release: 0.0,
            wave_speed: 5000.0,
        };
        let positions = [0.25, 0.5, 0.75].map(|x| Vector::<2>::new(x, 0.0));
        // Before the release the exact field is εx; the nodes are off by (1, 0), (0, 2) and
        // (−2, 0) µm, the last with twice the volume.
        let u = [
            Vector::<2>::new(0.25e-3 + 1e-6, 0.0),
            Vector::<2>::new(0.5e-3, 2e-6),
            Vector::<2>::new(0.75e-3 - 2e-6, 0.0),
        ];
        let volumes = [1.0, 1.0, 2.0];
        let (rms, max) = bar_error(&bar, &positions, &volumes, &u, &[0, 1, 2], -1.0);
        let expected = ((1.0 + 4.0 + 2.0 * 4.0) / 4.0_f64).sqrt() * 1e-6;
        assert!((rms - expected).abs() < 1e-18, "{rms} against {expected}");
        assert!((max - 2e-6).abs() < 1e-18);
        let (one, _) = bar_error(&bar, &positions, &volumes, &u, &[0], -1.0);
        assert!((one - 1e-6).abs() < 1e-18);
    }
}
