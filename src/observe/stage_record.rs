//! What a staged run leaves at the end of each stage: `stages.csv`, one row of energies per
//! stage, and in 2D `stored_energy.csv`, the strain energy per unit area of a crack plane
//! along a direction (seed 002 Eq. 11: G = 2EΔU²/h is what a preload stores in front of the crack,
//! and what a crack running through the specimen may dissipate).

use super::csv::CsvHistory;
use super::observer::{Observer, StageStart, StepView};
use super::resume::{parse_rows, read_if_present, rows_up_to};
use crate::math::Vector;
use std::path::Path;

pub struct StageRecord<const D: usize> {
    stages: CsvHistory,
    profile: CsvHistory,
    /// The stage in progress (0: the deck's own).
    index: usize,
    /// Unit vector along which the crack runs: profile positions are x·d.
    direction: Vector<D>,
    /// Bin width of the profile (m): the grid's smallest cell size.
    bin: f64,
}

impl<const D: usize> StageRecord<D> {
    pub fn new(dir: &Path, direction: Vector<D>, bin: f64) -> Self {
        let names = |n: &[&str]| n.iter().map(|s| s.to_string()).collect();
        StageRecord {
            stages: CsvHistory::new(
                dir.join("stages.csv"),
                names(&[
                    "stage",
                    "step",
                    "time",
                    "kinetic_energy",
                    "strain_energy",
                    "external_work",
                    "damage_dissipation",
                    "broken_bonds",
                ]),
            ),
            profile: CsvHistory::new(
                dir.join("stored_energy.csv"),
                names(&["stage", "position", "energy_per_area"]),
            ),
            index: 0,
            direction: direction.normalize(),
            bin,
        }
    }
}

impl<const D: usize> StageRecord<D> {
    /// Continues the files of a run interrupted after `step`: the rows of the stages that had
    /// ended by then.
    pub fn resume(mut self, step: u64) -> std::io::Result<Self> {
        let path = self.stages.path().to_path_buf();
        let kept = rows_up_to(&read_if_present(&path)?, step, &path)?;
        let ended = parse_rows(&kept, &path)?;
        let count = ended.len() as f64;
        for row in ended {
            self.stages.push(row)?;
        }
        let path = self.profile.path().to_path_buf();
        let text = read_if_present(&path)?;
        if !text.is_empty() {
            for row in parse_rows(&text, &path)? {
                // Stages are numbered from 1 in the files.
                if row.first().is_some_and(|&stage| stage <= count) {
                    self.profile.push(row)?;
                }
            }
        }
        Ok(self)
    }
}

/// Strain energy per unit area of a crack plane normal to `direction`, in bins of width
/// `bin` along it, centred on the first node's position and steps of `bin` from it:
/// Σ W_i V_i over the bin's nodes / (bin · thickness). In a strip stretched
/// across the crack plane this is the energy a crack running along `direction` finds per unit
/// of new area (seed 002 Eq. 11). Bins hold (position of the bin centre, value), in order.
pub fn energy_per_area<const D: usize>(
    positions: &[Vector<D>],
    energy: &[f64],
    volumes: &[f64],
    direction: &Vector<D>,
    bin: f64,
    thickness: f64,
) -> Vec<(f64, f64)> {
    let s: Vec<f64> = positions.iter().map(|x| x.dot(direction)).collect();
    let lo = s.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // Bins centred on lo + k·bin: on a lattice along `direction`, one column of nodes each.
    let bins = ((hi - lo) / bin).round() as usize + 1;
    let mut sums = vec![0.0; bins];
    for ((&si, w), v) in s.iter().zip(energy).zip(volumes) {
        let k = (((si - lo) / bin).round() as usize).min(bins - 1);
        sums[k] += w * v;
    }
    sums.iter()
        .enumerate()
        .map(|(k, e)| (lo + k as f64 * bin, e / (bin * thickness)))
        .collect()
}

impl<const D: usize> Observer<D> for StageRecord<D> {
    /// Stage ends are offered as `last`.
    fn wants(&self, _step: u64, last: bool) -> bool {
        last
    }

    fn observe(&mut self, view: &StepView<D>) -> std::io::Result<()> {
        let state = view.state;
        let stage = (self.index + 1) as f64;
        self.stages.push(vec![
            stage,
            state.step as f64,
            state.time,
            view.kinetic_energy(),
            view.strain_energy(),
            state.external_work,
            view.damage_dissipation(),
            (state.broken / 2) as f64,
        ])?;
        let body = view.body;
        if D != 2 {
            return self.finish();
        }
        for (s, g) in energy_per_area(
            &body.positions,
            view.energy_density(),
            &body.volumes,
            &self.direction,
            self.bin,
            body.thickness,
        ) {
            self.profile.push(vec![stage, s, g])?;
        }
        self.finish()
    }

    fn begin_stage(&mut self, stage: &StageStart) {
        self.index = stage.index;
    }

    fn finish(&mut self) -> std::io::Result<()> {
        self.stages.flush()?;
        self.profile.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniformly strained strip: every bin holds the energy density times the strip's
    /// height (the volume per unit area of the crack plane), here 2 J/m³ × 3 m.
    #[test]
    fn a_uniform_strip_stores_density_times_height_per_area() {
        let (dx, t) = (0.5, 0.1);
        let mut positions = Vec::new();
        for i in 0..8 {
            for j in 0..6 {
                positions.push(Vector::<2>::new(
                    (i as f64 + 0.5) * dx,
                    (j as f64 + 0.5) * dx,
                ));
            }
        }
        let n = positions.len();
        let profile = energy_per_area(
            &positions,
            &vec![2.0; n],
            &vec![dx * dx * t; n],
            &Vector::<2>::new(1.0, 0.0),
            dx,
            t,
        );
        assert_eq!(profile.len(), 8);
        for (k, (s, g)) in profile.iter().enumerate() {
            assert!(
                (s - (k as f64 + 0.5) * dx).abs() < 1e-12,
                "bin centre {s}: a node column"
            );
            assert!((g - 2.0 * 3.0).abs() < 1e-12, "energy per area {g}");
        }
    }
}
