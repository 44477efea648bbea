//! Cracks crossing lines during a 2D run (`[analysis.crack_crossings]`): every `interval` steps
//! the number of separate cracks across each line (`analysis::crossings`) is a row of
//! `crack_crossings.csv` (`time`, `step`, one column per line); at the end
//! `crack_crossing_points.csv` says where the last counted ones cross. Sequential scans on the
//! reference positions: the same files for any number of threads. A restart continues the
//! counts through `ResumedCsv` (the rows hold a step column); the points are of the last step.

use super::csv::{push_row, CsvHistory};
use super::observer::{Every, Observer, StepView};
use crate::analysis::{crossings, Crossing, CrossingLine};
use crate::atomic_file::write_atomic;
use std::io;
use std::path::{Path, PathBuf};

/// Settings of the analysis (lengths in m).
#[derive(Debug, Clone)]
pub struct CrossingSettings {
    pub threshold: f64,
    pub interval: u64,
    pub link: f64,
    /// Each line with its column name.
    pub lines: Vec<(String, CrossingLine)>,
}

pub struct CrackCrossings {
    settings: CrossingSettings,
    every: Every,
    counts: CsvHistory,
    points_path: PathBuf,
    /// The crossings of each line at the last step counted.
    last: Vec<Vec<Crossing>>,
}

impl CrackCrossings {
    /// Counts into `counts_path` (`crack_crossings.csv`, or the side file of a continued run)
    /// and writes the last crossings into `dir/crack_crossing_points.csv`.
    pub fn new(counts_path: &Path, dir: &Path, settings: CrossingSettings) -> Self {
        let header = ["time", "step"]
            .into_iter()
            .map(String::from)
            .chain(settings.lines.iter().map(|(name, _)| name.clone()))
            .collect();
        CrackCrossings {
            every: Every(settings.interval),
            counts: CsvHistory::new(counts_path, header),
            points_path: dir.join("crack_crossing_points.csv"),
            last: Vec::new(),
            settings,
        }
    }

    /// One row per crossing of the last step counted: `line` (its index in the deck),
    /// `crossing` (from the line's start), `x`, `y`, `along` (m from the start), `nodes`.
    fn render_points(&self) -> String {
        let mut s = String::from("line,crossing,x,y,along,nodes\n");
        for (l, found) in self.last.iter().enumerate() {
            for (k, c) in found.iter().enumerate() {
                let cells = [
                    l as f64,
                    k as f64,
                    c.point[0],
                    c.point[1],
                    c.along,
                    c.nodes as f64,
                ];
                push_row(&mut s, &cells);
            }
        }
        s
    }
}

impl<const D: usize> Observer<D> for CrackCrossings {
    fn wants(&self, step: u64, last: bool) -> bool {
        D == 2 && self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let positions = view.plane_positions();
        let damage = view.damage();
        let s = &self.settings;
        self.last = s
            .lines
            .iter()
            .map(|(_, line)| crossings(&positions, damage, s.threshold, line, s.link))
            .collect();
        let mut row = vec![view.state.time, view.state.step as f64];
        row.extend(self.last.iter().map(|found| found.len() as f64));
        self.counts.push(row)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.counts.flush()
    }

    fn finish(&mut self) -> io::Result<()> {
        self.counts.flush()?;
        write_atomic(&self.points_path, self.render_points().as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vector;

    #[test]
    fn the_points_file_lists_each_lines_crossings_in_order() {
        let line = CrossingLine {
            from: Vector::<2>::new(0.0, 1.0),
            to: Vector::<2>::new(2.0, 1.0),
            width: 0.1,
        };
        let settings = CrossingSettings {
            threshold: 0.35,
            interval: 1,
            link: 0.3,
            lines: vec![("above".into(), line), ("below".into(), line)],
        };
        let mut o = CrackCrossings::new(Path::new("c.csv"), Path::new("."), settings);
        let at = |x: f64| Crossing {
            along: x,
            point: Vector::<2>::new(x, 1.0),
            nodes: 4,
        };
        o.last = vec![vec![at(0.5), at(1.25)], vec![]];
        assert_eq!(
            o.render_points(),
            "line,crossing,x,y,along,nodes\n0,0,0.5,1,0.5,4\n0,1,1.25,1,1.25,4\n"
        );
        assert_eq!(o.counts.header(), ["time", "step", "above", "below"]);
    }
}
