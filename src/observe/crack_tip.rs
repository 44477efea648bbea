//! Crack-tip tracking during a run (`[analysis.crack_tip]`): every `interval` steps the tip of
//! each branch is found on the damage field (`analysis::TipTracker`, seed 000 App. 2), and at
//! the end `crack_tip.csv` (tip positions) and `crack_speed.csv` (speeds from a forward
//! difference over `window` samples, `analysis::crack_speed`, against the Rayleigh speed) are
//! written atomically; in 2D also `dissipation_rate.csv`, Γ = dE_diss/dā of the first branch
//! over the same window (`analysis::dissipation_rate`), against G0 when the deck gives it. Tips are taken on the reference positions: damage is a field of the
//! material points, and a tip that only moves when the crack does gives speeds free of the
//! body's rigid motion. The tracker is a sequential scan, so the files are the same for any
//! number of threads.

use super::csv::{push_number, quote};
use super::observer::{Every, Observer, StepView};
use super::resume::{cannot_continue, rows_up_to};
use crate::analysis::{
    branch_history, crack_speed, dissipation_rate, CrackFront, Tip, TipSample, TipTracker,
};
use crate::atomic_file::write_atomic;
use crate::math::Vector;
use std::cell::RefCell;
use std::io;
use std::path::{Path, PathBuf};
use std::rc::Rc;

const AXES: [&str; 3] = ["x", "y", "z"];

/// What a run reports of its crack: the Rayleigh speed and, per branch, where the tip was first
/// seen and its mean speed (None without a tip, or with fewer samples than the window needs).
#[derive(Debug, Clone, PartialEq)]
pub struct CrackReport {
    /// c_R (m/s) the speeds are compared with.
    pub rayleigh: f64,
    pub branches: Vec<BranchReport>,
}

/// One branch in `CrackReport`.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchReport {
    pub name: String,
    /// The tip at the first sample that had one.
    pub first_tip: Option<Vec<f64>>,
    /// Mean of the windowed speeds (m/s).
    pub mean_speed: Option<f64>,
}

impl std::fmt::Display for CrackReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Rayleigh speed c_R = {:.1} m/s", self.rayleigh)?;
        for b in &self.branches {
            match b.mean_speed {
                Some(v) => write!(
                    f,
                    "; {}: mean speed {v:.1} m/s ({:.3} c_R)",
                    b.name,
                    v / self.rayleigh
                )?,
                None if b.first_tip.is_some() => {
                    write!(f, "; {}: too few tip samples for a speed", b.name)?
                }
                None => write!(f, "; {}: no damaged node", b.name)?,
            }
        }
        Ok(())
    }
}

/// The crack-tip observer: samples in memory, files at `finish`.
pub struct CrackTips<const D: usize> {
    tracker: TipTracker<D>,
    every: Every,
    window: usize,
    rayleigh: f64,
    tip_path: PathBuf,
    speed_path: PathBuf,
    rate_path: PathBuf,
    /// The crack's width for its area ā = (a − a0)·width (the thickness; None in 3D, where
    /// no rate is written) and G0 (J/m²) to compare Γ with.
    width: Option<f64>,
    g0: Option<f64>,
    steps: Vec<u64>,
    times: Vec<f64>,
    samples: Vec<Vec<Option<TipSample<D>>>>,
    /// Energy dissipated by damage at each sample (J).
    dissipated: Vec<f64>,
    report: Rc<RefCell<Option<CrackReport>>>,
}

impl<const D: usize> CrackTips<D> {
    /// Writes into `out_dir`; `rayleigh` is c_R (m/s). In 3D the tracker should carry a front
    /// tolerance (`TipTracker::with_front`) for the front columns to be filled.
    pub fn new(
        out_dir: &Path,
        tracker: TipTracker<D>,
        interval: u64,
        window: usize,
        rayleigh: f64,
    ) -> Self {
        CrackTips {
            tracker,
            every: Every(interval),
            window,
            rayleigh,
            tip_path: out_dir.join("crack_tip.csv"),
            speed_path: out_dir.join("crack_speed.csv"),
            rate_path: out_dir.join("dissipation_rate.csv"),
            width: None,
            g0: None,
            steps: Vec::new(),
            times: Vec::new(),
            samples: Vec::new(),
            dissipated: Vec::new(),
            report: Rc::new(RefCell::new(None)),
        }
    }

    /// Also writes `dissipation_rate.csv` for a crack `width` wide (2D: the thickness),
    /// normalised by `g0` when given.
    pub fn with_dissipation_rate(mut self, width: f64, g0: Option<f64>) -> Self {
        self.width = Some(width);
        self.g0 = g0;
        self
    }

    /// `dissipation_rate.csv`: Γ of the first branch against its advance a − a0 from where it
    /// was first seen (seed 002 counts one crack).
    fn render_rates(&self, width: f64) -> String {
        let mut s = String::from("time,crack_length,dissipation_rate,rate_over_g0\n");
        let (mut times, mut lengths, mut energies) = (Vec::new(), Vec::new(), Vec::new());
        for ((t, row), e) in self.times.iter().zip(&self.samples).zip(&self.dissipated) {
            if let Some(Some(sample)) = row.first() {
                times.push(*t);
                lengths.push(sample.tip.projection);
                energies.push(*e);
            }
        }
        let a0 = lengths.first().copied().unwrap_or(0.0);
        lengths.iter_mut().for_each(|a| *a -= a0);
        for r in dissipation_rate(&times, &lengths, &energies, self.window, width) {
            for (k, v) in [r.time, r.crack_length, r.rate].into_iter().enumerate() {
                if k > 0 {
                    s.push(',');
                }
                push_number(&mut s, v);
            }
            s.push(',');
            if let Some(g0) = self.g0 {
                push_number(&mut s, r.rate / g0);
            }
            s.push('\n');
        }
        s
    }

    /// Continues after a restart at `step`: the samples up to `step` are read back from
    /// `crack_tip.csv` (which holds every sample up to the checkpoint), so the speeds and the
    /// report span the whole run. `positions` are the body's reference positions: a tip is a
    /// node, found again by its position.
    pub fn resume(mut self, step: u64, positions: &[Vector<D>]) -> io::Result<Self> {
        let path = &self.tip_path;
        let text = std::fs::read_to_string(path)
            .map_err(|e| crate::atomic_file::with_path(e, "cannot read", path))?;
        let invalid = |what: String| cannot_continue(path, what);
        let per_branch = if D == 3 { 2 * D } else { D };
        let tip_cells = per_branch * self.tracker.branches.len();
        let unit = self.tracker.direction.normalize();
        let key = |p: &Vector<D>| p.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        let mut nodes = std::collections::HashMap::new();
        for (i, p) in positions.iter().enumerate() {
            nodes.entry(key(p)).or_insert(i);
        }
        for line in rows_up_to(&text, step, path)?.lines().skip(1) {
            // Empty cells: no tip in that branch.
            let cells = line
                .split(',')
                .map(|c| (!c.is_empty()).then(|| c.parse::<f64>()).transpose())
                .collect::<Result<Vec<Option<f64>>, _>>();
            let (time, sample_step, tips, dissipated) = match cells.as_deref() {
                Ok([Some(t), Some(s), tips @ .., Some(e)]) if tips.len() == tip_cells => {
                    (*t, *s, tips, *e)
                }
                _ => {
                    return Err(invalid(format!(
                        "expected time, step, {tip_cells} tip cells and the dissipated energy, found {line:?}"
                    )))
                }
            };
            let mut row = Vec::new();
            for cells in tips.chunks(per_branch) {
                let Some(v) = cells.iter().copied().collect::<Option<Vec<f64>>>() else {
                    row.push(None);
                    continue;
                };
                let position = Vector::<D>::from_iterator(v[..D].iter().copied());
                let index = *nodes
                    .get(&key(&position))
                    .ok_or_else(|| invalid(format!("no node at the tip {:?} of {line:?}", v)))?;
                let tip = Tip {
                    index,
                    position,
                    projection: position.dot(&unit),
                };
                // The front's node count is not in the file, and nothing written reads it.
                let front = (D == 3 && v[D..].iter().all(|x| !x.is_nan())).then(|| CrackFront {
                    mean: Vector::<D>::from_iterator(v[D..].iter().copied()),
                    extreme: tip,
                    count: 0,
                });
                row.push(Some(TipSample { time, tip, front }));
            }
            self.times.push(time);
            self.steps.push(sample_step as u64);
            self.samples.push(row);
            self.dissipated.push(dissipated);
        }
        Ok(self)
    }

    /// Where `finish` leaves the run's crack report (for the run summary).
    pub fn report(&self) -> Rc<RefCell<Option<CrackReport>>> {
        Rc::clone(&self.report)
    }

    /// `crack_tip.csv`: time, step, then per branch the tip (and in 3D the front mean); empty
    /// cells while a branch has no damaged node.
    fn render_tips(&self) -> String {
        let mut header = vec!["time".to_string(), "step".to_string()];
        for b in &self.tracker.branches {
            for axis in AXES.iter().take(D) {
                header.push(quote(&format!("{}_{axis}", b.name)));
            }
            if D == 3 {
                for axis in AXES.iter().take(D) {
                    header.push(quote(&format!("{}_front_mean_{axis}", b.name)));
                }
            }
        }
        header.push("damage_dissipation".to_string());
        let mut s = header.join(",");
        s.push('\n');
        let per_branch = if D == 3 { 2 * D } else { D };
        let rows = self.times.iter().zip(&self.steps).zip(&self.samples);
        for (((t, step), row), dissipated) in rows.zip(&self.dissipated) {
            push_number(&mut s, *t);
            s.push(',');
            push_number(&mut s, *step as f64);
            for sample in row {
                let values: Option<Vec<f64>> = sample.map(|smp| {
                    let mut v: Vec<f64> = smp.tip.position.iter().copied().collect();
                    if D == 3 {
                        match smp.front {
                            Some(f) => v.extend(f.mean.iter()),
                            None => v.extend([f64::NAN; 3]),
                        }
                    }
                    v
                });
                for k in 0..per_branch {
                    s.push(',');
                    if let Some(v) = &values {
                        push_number(&mut s, v[k]);
                    }
                }
            }
            s.push(',');
            push_number(&mut s, *dissipated);
            s.push('\n');
        }
        s
    }

    /// `crack_speed.csv` (long format, branches one after the other) and the report.
    fn render_speeds(&self) -> (String, CrackReport) {
        let mut s = String::from("branch,time,speed,speed_over_rayleigh\n");
        let mut branches = Vec::new();
        for (k, b) in self.tracker.branches.iter().enumerate() {
            let (times, tips): (Vec<f64>, Vec<Vector<D>>) = branch_history(&self.samples, k);
            let speeds = crack_speed(&times, &tips, self.window);
            for v in &speeds {
                s.push_str(&quote(&b.name));
                s.push(',');
                push_number(&mut s, v.time);
                s.push(',');
                push_number(&mut s, v.speed);
                s.push(',');
                push_number(&mut s, v.speed / self.rayleigh);
                s.push('\n');
            }
            branches.push(BranchReport {
                name: b.name.clone(),
                first_tip: tips.first().map(|p| p.iter().copied().collect()),
                mean_speed: (!speeds.is_empty())
                    .then(|| speeds.iter().map(|v| v.speed).sum::<f64>() / speeds.len() as f64),
            });
        }
        let report = CrackReport {
            rayleigh: self.rayleigh,
            branches,
        };
        (s, report)
    }
}

impl<const D: usize> Observer<D> for CrackTips<D> {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> io::Result<()> {
        let t = view.state.time;
        // The speed difference needs strictly increasing times; a step offered twice (or a
        // piece of a quasi-static step that did not advance) adds nothing.
        if self.times.last().is_some_and(|&last| t <= last) {
            return Ok(());
        }
        let sample = self.tracker.sample(t, &view.body.positions, view.damage());
        self.times.push(t);
        self.steps.push(view.state.step);
        self.samples.push(sample);
        self.dissipated.push(view.damage_dissipation());
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        write_atomic(&self.tip_path, self.render_tips().as_bytes())?;
        let (speeds, report) = self.render_speeds();
        write_atomic(&self.speed_path, speeds.as_bytes())?;
        if let Some(width) = self.width {
            write_atomic(&self.rate_path, self.render_rates(width).as_bytes())?;
        }
        *self.report.borrow_mut() = Some(report);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::{Branch, Tip};

    fn tracker2(names: &[&str]) -> TipTracker<2> {
        TipTracker::new(
            0.35,
            Vector::<2>::new(1.0, 0.0),
            names
                .iter()
                .map(|n| Branch {
                    name: n.to_string(),
                    search: None,
                })
                .collect(),
        )
    }

    fn sample(t: f64, x: f64) -> Option<TipSample<2>> {
        Some(TipSample {
            time: t,
            tip: Tip {
                index: 0,
                position: Vector::<2>::new(x, 0.5),
                projection: x,
            },
            front: None,
        })
    }

    #[test]
    fn tip_file_leaves_cells_empty_before_the_crack_and_speeds_use_the_window() {
        let dir = crate::atomic_file::test_dir("crack-tip");
        let mut o = CrackTips::new(&dir, tracker2(&["crack", "b"]), 10, 2, 1000.0);
        // Samples by hand: branch "crack" appears at t = 1 and moves 1 per unit time; "b" never.
        o.times = vec![0.0, 1.0, 2.0, 3.0];
        o.steps = vec![0, 10, 20, 30];
        o.samples = vec![
            vec![None, None],
            vec![sample(1.0, 1.0), None],
            vec![sample(2.0, 2.0), None],
            vec![sample(3.0, 3.0), None],
        ];
        o.dissipated = vec![0.0, 0.5, 1.0, 1.5];
        Observer::<2>::finish(&mut o).unwrap();
        let tips = std::fs::read_to_string(dir.join("crack_tip.csv")).unwrap();
        assert_eq!(
            tips,
            "time,step,crack_x,crack_y,b_x,b_y,damage_dissipation\n0,0,,,,,0\n1,10,1,0.5,,,0.5\n2,20,2,0.5,,,1\n3,30,3,0.5,,,1.5\n"
        );
        let speeds = std::fs::read_to_string(dir.join("crack_speed.csv")).unwrap();
        // Window 2 over three samples of branch "crack": one speed, 2/2 = 1, stamped at t = 2.
        assert_eq!(
            speeds,
            "branch,time,speed,speed_over_rayleigh\ncrack,2,1,0.001\n"
        );
        let r = o.report().borrow().clone().unwrap();
        assert_eq!(r.branches[0].mean_speed, Some(1.0));
        assert_eq!(r.branches[0].first_tip, Some(vec![1.0, 0.5]));
        assert_eq!(r.branches[1].first_tip, None);
        assert!(r.to_string().contains("b: no damaged node"), "{r}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn three_d_rows_carry_the_front_mean() {
        let dir = crate::atomic_file::test_dir("crack-front");
        // A planar crack z = 0: x ≤ 1 damaged at y = 0 and 1, x = 2 only at y = 0.
        let mut pos = Vec::new();
        let mut d = Vec::new();
        for x in 0..=3 {
            for y in 0..=1 {
                pos.push(Vector::<3>::new(x as f64, y as f64, 0.0));
                d.push(if x <= 1 || (x == 2 && y == 0) {
                    1.0
                } else {
                    0.0
                });
            }
        }
        let tracker = TipTracker::new(
            0.35,
            Vector::<3>::new(1.0, 0.0, 0.0),
            vec![Branch {
                name: "f".into(),
                search: None,
            }],
        )
        .with_front(1.0);
        let mut o = CrackTips::new(&dir, tracker, 1, 1, 100.0);
        o.times = vec![0.5];
        o.steps = vec![1];
        o.samples = vec![o.tracker.sample(0.5, &pos, &d)];
        o.dissipated = vec![2.0];
        Observer::<3>::finish(&mut o).unwrap();
        let tips = std::fs::read_to_string(dir.join("crack_tip.csv")).unwrap();
        // Front within 1 of x = 2: (2, 0), (1, 0), (1, 1) → mean (4/3, 1/3, 0).
        let (m, n) = (4.0_f64 / 3.0, 1.0_f64 / 3.0);
        assert_eq!(
            tips,
            format!("time,step,f_x,f_y,f_z,f_front_mean_x,f_front_mean_y,f_front_mean_z,damage_dissipation\n0.5,1,2,0,0,{m},{n},0,2\n")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
