//! The crack path and its forks during a 2D run (`[analysis.crack_path]`): every `interval`
//! steps the damaged region is searched for forks (`analysis::find_forks`), a fork being
//! recorded the first time it is seen; at the end the crack is binned into a polyline
//! (`analysis::crack_path`) and compared with the deck's reference path
//! (`analysis::compare_paths`, seed 003 §4). Files, written atomically at the end:
//! `crack_path.csv`, `crack_path_comparison.csv` (with a reference) and `branching.csv`.
//! Sequential scans on the reference positions: the same files for any number of threads.
//! A restart reads the forks back from `branching.csv`.

use super::csv::{push_number, push_row};
use super::observer::{Every, Observer, StepView};
use super::resume::{cannot_continue, rows_up_to};
use crate::analysis::{compare_paths, crack_path, find_forks, Fork, ForkBranch, PathComparison};
use crate::atomic_file::write_atomic;
use crate::geometry::Shape;
use crate::math::Vector;
use std::cell::RefCell;
use std::io;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// What the analysis found, for the run summary.
#[derive(Debug, Clone, PartialEq)]
pub struct PathReport {
    /// Points of the final path.
    pub points: usize,
    /// The deck gave a reference path.
    pub reference_given: bool,
    pub comparison: Option<PathComparison>,
    /// Forks with the time they were first seen (s).
    pub forks: Vec<(f64, Fork)>,
}

impl std::fmt::Display for PathReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} points", self.points)?;
        if self.reference_given && self.comparison.is_none() {
            write!(
                f,
                "; the path and the reference do not overlap along the axis"
            )?;
        }
        if let Some(c) = &self.comparison {
            match c.correlation {
                Some(r) => write!(f, "; against the reference: Pearson r = {r:.4}")?,
                None => write!(
                    f,
                    "; against the reference: Pearson r undefined (a flat path)"
                )?,
            }
            write!(
                f,
                ", max distance {:.3} mm, mean {:.3} mm",
                c.max_distance * 1e3,
                c.mean_distance * 1e3
            )?;
        }
        match self.forks.first() {
            None => write!(f, "; no fork"),
            Some((t, fork)) => write!(
                f,
                "; {} fork(s), the first at t = {:.3} µs, ({:.2}, {:.2}) mm",
                self.forks.len(),
                t * 1e6,
                fork.position[0] * 1e3,
                fork.position[1] * 1e3
            ),
        }
    }
}

/// Settings of the analysis (lengths in m).
#[derive(Debug, Clone)]
pub struct PathSettings {
    /// 0: binned along x, forks looked for along +x; 1: along y.
    pub axis: usize,
    pub threshold: f64,
    pub bin_width: f64,
    pub reference: Vec<(f64, f64)>,
    pub samples: usize,
    pub interval: u64,
    pub link: f64,
    pub fit_bands: usize,
    /// Only the damaged nodes inside it count (none: the whole body).
    pub region: Option<Shape>,
}

pub struct CrackPath {
    settings: PathSettings,
    every: Every,
    dir: PathBuf,
    forks: Vec<(f64, u64, Fork)>,
    path: Vec<(f64, f64)>,
    report: Rc<RefCell<Option<PathReport>>>,
    /// Per node, whether it lies in the region, when there is one (found at the first
    /// observation).
    inside: Option<Vec<bool>>,
}

impl CrackPath {
    pub fn new(dir: &Path, settings: PathSettings) -> Self {
        CrackPath {
            every: Every(settings.interval),
            settings,
            dir: dir.to_path_buf(),
            forks: Vec::new(),
            path: Vec::new(),
            report: Rc::new(RefCell::new(None)),
            inside: None,
        }
    }

    /// Continues after a restart at `step`: the forks first seen up to `step` are read back
    /// from `branching.csv` (written before every checkpoint), with the branches they had
    /// then. The fork's component and band are not in the file; nothing written reads them.
    pub fn resume(mut self, step: u64) -> io::Result<Self> {
        let path = self.dir.join("branching.csv");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| crate::atomic_file::with_path(e, "cannot read", &path))?;
        for line in rows_up_to(&text, step, &path)?.lines().skip(1) {
            let cells: Vec<Option<f64>> = line.split(',').map(|c| c.parse::<f64>().ok()).collect();
            let [Some(t), Some(s), Some(k), Some(x), Some(y), ix, iy, Some(_), Some(bx), Some(by), angle] =
                cells[..]
            else {
                return Err(cannot_continue(
                    &path,
                    format!("expected the 11 cells of a fork's branch, found {line:?}"),
                ));
            };
            let branch = ForkBranch {
                start: Vector::<2>::new(bx, by),
                angle_deg: angle,
                bands_fitted: 0,
            };
            if self.forks.len() == k as usize + 1 {
                self.forks[k as usize].2.branches.push(branch);
                continue;
            }
            let intersection = ix.zip(iy).map(|(a, b)| Vector::<2>::new(a, b));
            let fork = Fork {
                component: 0,
                band: 0,
                position: Vector::<2>::new(x, y),
                intersection,
                branches: vec![branch],
            };
            self.forks.push((t, s as u64, fork));
        }
        Ok(self)
    }

    /// Where `finish` leaves the report.
    pub fn report(&self) -> Rc<RefCell<Option<PathReport>>> {
        Rc::clone(&self.report)
    }

    /// Records the forks not seen before, with the time they were first seen; a fork within
    /// `link` of a recorded one is that fork, seen again with longer branches: its branches
    /// (and their fitted angles) are taken from the latest sighting.
    fn record_forks(&mut self, time: f64, step: u64, found: Vec<Fork>) {
        for fork in found {
            let link = self.settings.link;
            match self
                .forks
                .iter_mut()
                .find(|(_, _, f)| (f.position - fork.position).norm() <= link)
            {
                Some((_, _, known)) => *known = fork,
                None => self.forks.push((time, step, fork)),
            }
        }
    }

    /// The path's points with the length along it from its first point (the polyline's).
    fn render_path(&self) -> String {
        let mut s = String::from("x,y,length\n");
        let mut length = 0.0;
        for (k, &(a, b)) in self.path.iter().enumerate() {
            if k > 0 {
                let (a0, b0) = self.path[k - 1];
                length += (a - a0).hypot(b - b0);
            }
            let (x, y) = if self.settings.axis == 0 {
                (a, b)
            } else {
                (b, a)
            };
            push_row(&mut s, &[x, y, length]);
        }
        s
    }

    /// One row per branch of each fork.
    fn render_forks(&self) -> String {
        let mut s = String::from(
            "time,step,fork,x,y,intersection_x,intersection_y,branch,start_x,start_y,angle_deg\n",
        );
        for (k, (t, step, fork)) in self.forks.iter().enumerate() {
            for (b, branch) in fork.branches.iter().enumerate() {
                let cells = [
                    Some(*t),
                    Some(*step as f64),
                    Some(k as f64),
                    Some(fork.position[0]),
                    Some(fork.position[1]),
                    fork.intersection.map(|p| p[0]),
                    fork.intersection.map(|p| p[1]),
                    Some(b as f64),
                    Some(branch.start[0]),
                    Some(branch.start[1]),
                    branch.angle_deg,
                ];
                for (c, v) in cells.iter().enumerate() {
                    if c > 0 {
                        s.push(',');
                    }
                    if let Some(v) = v {
                        push_number(&mut s, *v);
                    }
                }
                s.push('\n');
            }
        }
        s
    }
}

/// (a, b) coordinates of a 2D point with a along `axis`.
fn along(axis: usize, p: &Vector<2>) -> (f64, f64) {
    if axis == 0 {
        (p[0], p[1])
    } else {
        (p[1], p[0])
    }
}

impl<const D: usize> Observer<D> for CrackPath {
    fn wants(&self, step: u64, last: bool) -> bool {
        D == 2 && self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let positions = view.plane_positions();
        let s = self.settings.clone();
        let mut direction = Vector::<2>::zeros();
        direction[s.axis] = 1.0;
        let in_region: Vec<f64>;
        let damage = match &s.region {
            None => view.damage(),
            Some(region) => {
                let inside = self.inside.get_or_insert_with(|| {
                    positions
                        .iter()
                        .map(|p| region.contains(p.as_slice()))
                        .collect()
                });
                // Outside the region a node counts as undamaged.
                in_region = view
                    .damage()
                    .iter()
                    .zip(inside.iter())
                    .map(|(&d, &i)| if i { d } else { 0.0 })
                    .collect();
                &in_region
            }
        };
        let forks = find_forks(
            &positions,
            damage,
            s.threshold,
            &direction,
            s.link,
            s.fit_bands,
        );
        self.record_forks(view.state.time, view.state.step, forks);
        if view.last {
            let axis = s.axis;
            let rotated: Vec<Vector<2>> = positions
                .iter()
                .map(|p| {
                    let (a, b) = along(axis, p);
                    Vector::<2>::new(a, b)
                })
                .collect();
            self.path = crack_path(&rotated, damage, s.threshold, 0, s.bin_width);
        }
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        write_atomic(
            &self.dir.join("crack_path.csv"),
            self.render_path().as_bytes(),
        )?;
        write_atomic(
            &self.dir.join("branching.csv"),
            self.render_forks().as_bytes(),
        )?;
        let s = &self.settings;
        let comparison = if s.reference.is_empty() {
            None
        } else {
            let reference: Vec<(f64, f64)> = s
                .reference
                .iter()
                .map(|&(x, y)| along(s.axis, &Vector::<2>::new(x, y)))
                .collect();
            compare_paths(&self.path, &reference, s.samples)
        };
        if let Some(c) = &comparison {
            let mut text = String::from("abscissa,path,reference\n");
            for &(a, p, r) in &c.samples {
                push_row(&mut text, &[a, p, r]);
            }
            write_atomic(&self.dir.join("crack_path_comparison.csv"), text.as_bytes())?;
        }
        *self.report.borrow_mut() = Some(PathReport {
            points: self.path.len(),
            reference_given: !s.reference.is_empty(),
            comparison,
            forks: self.forks.iter().map(|(t, _, f)| (*t, f.clone())).collect(),
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> PathSettings {
        PathSettings {
            axis: 0,
            threshold: 0.35,
            bin_width: 1.0,
            reference: Vec::new(),
            samples: 52,
            interval: 1,
            link: 0.5,
            fit_bands: 3,
            region: None,
        }
    }

    fn fork(x: f64, angles: [Option<f64>; 2], crossing: bool) -> Fork {
        Fork {
            component: 0,
            band: 0,
            position: Vector::<2>::new(x, 1.0),
            intersection: crossing.then(|| Vector::<2>::new(x - 0.25, 1.0)),
            branches: angles
                .iter()
                .enumerate()
                .map(|(k, a)| ForkBranch {
                    start: Vector::<2>::new(x + 0.5, k as f64),
                    angle_deg: *a,
                    bands_fitted: 0,
                })
                .collect(),
        }
    }

    #[test]
    fn a_fork_seen_again_keeps_its_time_and_takes_the_new_branches() {
        let mut o = CrackPath::new(Path::new("."), settings());
        o.record_forks(1.0, 10, vec![fork(3.0, [None, None], false)]);
        o.record_forks(2.0, 20, vec![fork(3.2, [Some(-20.0), Some(25.0)], true)]);
        o.record_forks(3.0, 30, vec![fork(6.0, [None, None], false)]);
        assert_eq!(o.forks.len(), 2);
        assert_eq!((o.forks[0].0, o.forks[0].1), (1.0, 10));
        assert_eq!(o.forks[0].2.branches[1].angle_deg, Some(25.0));
    }

    #[test]
    fn a_restart_reads_back_the_forks_up_to_its_step() {
        let dir = crate::atomic_file::test_dir("crack-path-resume");
        let mut o = CrackPath::new(&dir, settings());
        o.record_forks(1.5, 10, vec![fork(3.0, [Some(-20.0), None], true)]);
        o.record_forks(2.5, 20, vec![fork(6.0, [None, Some(30.0)], false)]);
        Observer::<2>::finish(&mut o).unwrap();
        let written = o.render_forks();
        let whole = CrackPath::new(&dir, settings()).resume(20).unwrap();
        assert_eq!(whole.render_forks(), written);
        let part = CrackPath::new(&dir, settings()).resume(15).unwrap();
        assert_eq!(part.forks.len(), 1);
        assert_eq!(part.forks[0].2.branches.len(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
