//! The observer interface: after each committed step the driver offers observers a read-only
//! view whose derived fields (damage, strain energy density) are computed at most once.

use crate::material::Material;
use crate::solver::Simulation;
use std::cell::OnceCell;

/// A read-only view of a committed step.
pub struct StepView<'a, const D: usize, M: Material<D>> {
    pub sim: &'a Simulation<D, M>,
    /// True for the last step of the run.
    pub last: bool,
    damage: OnceCell<Vec<f64>>,
    energy: OnceCell<Vec<f64>>,
}

impl<'a, const D: usize, M: Material<D>> StepView<'a, D, M> {
    pub fn new(sim: &'a Simulation<D, M>, last: bool) -> Self {
        StepView {
            sim,
            last,
            damage: OnceCell::new(),
            energy: OnceCell::new(),
        }
    }
    /// Damage index per node.
    pub fn damage(&self) -> &[f64] {
        self.damage.get_or_init(|| {
            self.sim
                .engine
                .damage(&self.sim.body, &self.sim.bonds, &self.sim.state)
        })
    }
    /// Strain energy density per node (J/m³).
    pub fn energy_density(&self) -> &[f64] {
        self.energy.get_or_init(|| {
            self.sim
                .engine
                .energy_density(&self.sim.body, &self.sim.bonds, &self.sim.state)
        })
    }
    /// Total strain energy (J).
    pub fn strain_energy(&self) -> f64 {
        self.energy_density()
            .iter()
            .zip(&self.sim.body.volumes)
            .map(|(w, v)| w * v)
            .sum()
    }
}

/// Something that watches the run: writers, trackers, progress.
pub trait Observer<const D: usize, M: Material<D>> {
    /// Whether this observer wants the view of `step` (the driver builds the view only then).
    fn wants(&self, step: u64, last: bool) -> bool;
    fn observe(&mut self, view: &StepView<D, M>) -> std::io::Result<()>;
    /// Called once at the end, also after a failed step, so nothing written so far is lost.
    fn finish(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// "Every n steps, and the last one" — the schedule shared by the writers.
#[derive(Debug, Clone, Copy)]
pub struct Every(pub u64);

impl Every {
    pub fn hits(self, step: u64, last: bool) -> bool {
        last || step == 0 || (self.0 > 0 && step.is_multiple_of(self.0))
    }
}
