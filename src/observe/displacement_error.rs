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
            let (rms, max) =
                self.solution
                    .error(&body.positions, &body.volumes, &state.u, nodes, state.time);
            row.extend([rms, max]);
        }
        self.rows.push(row)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.rows.flush()
    }
}
