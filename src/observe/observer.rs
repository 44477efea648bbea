//! The observer interface: after each committed step the driver offers observers a read-only
//! view whose derived fields (damage, strain energy density) are computed at most once.
//! Observers do not depend on the material: they see the simulation through `Fields`.

use crate::body::Body;
use crate::bonds::{Bonds, Quadrature};
use crate::math::Vector;
use crate::solver::Fields;
use crate::state::State;
use std::cell::OnceCell;

/// A read-only view of a committed step.
pub struct StepView<'a, const D: usize> {
    pub body: &'a Body<D>,
    pub state: &'a State<D>,
    pub bonds: &'a Bonds,
    pub quad: &'a Quadrature,
    /// True for the last step of the run.
    pub last: bool,
    fields: &'a dyn Fields<D>,
    damage: OnceCell<Vec<f64>>,
    energy: OnceCell<Vec<f64>>,
}

impl<'a, const D: usize> StepView<'a, D> {
    pub fn new(sim: &'a dyn Fields<D>, last: bool) -> Self {
        StepView {
            body: sim.body(),
            state: sim.state(),
            bonds: sim.bonds(),
            quad: sim.quadrature(),
            last,
            fields: sim,
            damage: OnceCell::new(),
            energy: OnceCell::new(),
        }
    }
    /// The nodes' reference positions in the plane (their x and y): what the 2D analyses
    /// read.
    pub fn plane_positions(&self) -> Vec<Vector<2>> {
        self.body
            .positions
            .iter()
            .map(|p| Vector::<2>::new(p[0], p[1]))
            .collect()
    }
    /// Damage index per node.
    pub fn damage(&self) -> &[f64] {
        self.damage.get_or_init(|| self.fields.damage())
    }
    /// Strain energy density per node (J/m³).
    pub fn energy_density(&self) -> &[f64] {
        self.energy.get_or_init(|| self.fields.energy_density())
    }
    /// Energy dissipated by damage since the start (J).
    pub fn damage_dissipation(&self) -> f64 {
        self.fields.damage_dissipation()
    }
    /// Total strain energy (J).
    pub fn strain_energy(&self) -> f64 {
        self.energy_density()
            .iter()
            .zip(&self.body.volumes)
            .map(|(w, v)| w * v)
            .sum()
    }
    /// Kinetic energy (J).
    pub fn kinetic_energy(&self) -> f64 {
        self.fields.kinetic_energy()
    }
    /// External force (N) that holds a node set.
    pub fn reaction(&self, nodes: &[u32]) -> Vector<D> {
        self.fields.reaction(nodes)
    }
    /// Contact potential energy, node–node and impactor penalty (J).
    pub fn contact_energy(&self) -> f64 {
        self.fields.contact_energy()
    }
    /// Kinetic energy of the free impactors (J).
    pub fn impactor_kinetic_energy(&self) -> f64 {
        self.fields.impactor_kinetic_energy()
    }
    /// The impactors and their state.
    pub fn impactors(&self) -> &[crate::solver::impactor::Impactor<D>] {
        self.fields.impactors()
    }
    /// The broken halves of the bonds, in node then bond order.
    pub fn broken_halves(&self) -> Vec<crate::analysis::BrokenHalf<D>> {
        self.fields.broken_halves()
    }
}

/// Something that watches the run: writers, trackers, progress.
pub trait Observer<const D: usize> {
    /// Whether this observer wants the view of `step` (the driver builds the view only then).
    fn wants(&self, step: u64, last: bool) -> bool;
    fn observe(&mut self, view: &StepView<D>) -> std::io::Result<()>;
    /// Whether `observe` reads the broken bonds (`StepView::broken_halves`): a distributed
    /// run then gathers them from every rank for the step.
    fn reads_broken_bonds(&self) -> bool {
        false
    }
    /// Whether `observe` reads the nodes' fields; `false`: only the view's step and time (a
    /// distributed run then gathers no field for it).
    fn reads_fields(&self) -> bool {
        true
    }
    /// Called once at the end, also after a failed step, so nothing written so far is lost.
    fn finish(&mut self) -> std::io::Result<()> {
        Ok(())
    }
    /// A new stage of a staged run starts after the step last offered (stage 0 starts
    /// before step 0 and is not announced).
    fn begin_stage(&mut self, _stage: &StageStart) {}
    /// Brings the files up to the last observed step, before a checkpoint is written (a
    /// restart keeps what they hold up to the checkpoint's step). By default `finish`: the
    /// writers rewrite their files whole, so finishing early is only a flush.
    fn flush(&mut self) -> std::io::Result<()> {
        self.finish()
    }
}

/// What observers learn when a stage starts.
#[derive(Debug, Clone, Copy)]
pub struct StageStart {
    /// 0 for the deck's own stage, k for `[[stages]]` entry k − 1.
    pub index: usize,
    /// Steps between history rows in this stage.
    pub history_interval: u64,
}

/// "Every n steps, and the last one" — the schedule shared by the writers.
#[derive(Debug, Clone, Copy)]
pub struct Every(pub u64);

impl Every {
    pub fn hits(self, step: u64, last: bool) -> bool {
        last || step == 0 || (self.0 > 0 && step.is_multiple_of(self.0))
    }
}
