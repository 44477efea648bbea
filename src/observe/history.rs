//! The CSV history: energies, broken bonds, the step (time step or load increment, and
//! iterations), the reaction force and mean displacement of every named node set, and the
//! openings between probe nodes.

use super::csv::CsvHistory;
use super::observer::{Every, Observer, StageStart, StepView};
use crate::math::Vector;
use std::path::Path;

pub struct History {
    csv: CsvHistory,
    every: Every,
    sets: Vec<Vec<u32>>,
    /// Node pairs whose change of distance is recorded (`opening_<name>`).
    openings: Vec<(usize, usize)>,
    /// The stage in progress (from 1), when the run has several and the column `stage`.
    stage: Option<usize>,
}

const AXES: [&str; 3] = ["x", "y", "z"];

impl History {
    pub fn new<const D: usize>(path: &Path, every: u64, set_names: &[(String, Vec<u32>)]) -> Self {
        let mut header: Vec<String> = [
            "time",
            "step",
            "kinetic_energy",
            "strain_energy",
            "external_work",
            "viscous_dissipation",
            "energy_balance",
            "damage_dissipation",
            "energy_residual",
            "broken_bonds",
            "dt",
            "iterations",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for (name, _) in set_names {
            for axis in AXES.iter().take(D) {
                header.push(format!("reaction_{name}_{axis}"));
            }
            for axis in AXES.iter().take(D) {
                header.push(format!("displacement_{name}_{axis}"));
            }
        }
        History {
            csv: CsvHistory::new(path, header),
            every: Every(every),
            sets: set_names.iter().map(|(_, n)| n.clone()).collect(),
            openings: Vec::new(),
            stage: None,
        }
    }

    /// Adds a last column `stage`: the number (from 1) of the stage a row belongs to.
    pub fn with_stages(mut self) -> Self {
        self.csv.add_column("stage".into());
        self.stage = Some(1);
        self
    }

    /// Adds a column `opening_<name>` per (name, node a, node b): |y_b − y_a| − |x_b − x_a|,
    /// e.g. the crack-mouth opening displacement between two probe nodes.
    pub fn with_openings(mut self, openings: &[(String, usize, usize)]) -> Self {
        for (name, a, b) in openings {
            self.csv.add_column(format!("opening_{name}"));
            self.openings.push((*a, *b));
        }
        self
    }
}

impl<const D: usize> Observer<D> for History {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D>) -> std::io::Result<()> {
        let state = view.state;
        let (ek, es) = (view.kinetic_energy(), view.strain_energy());
        let (w, dv, dd) = (
            state.external_work,
            state.dissipated_viscous,
            view.damage_dissipation(),
        );
        // Energy balance: E_kin + E_strain + D_viscous − W_ext, constant (≈ 0) for an elastic run;
        // its growth is the energy dissipated by damage, which the force engine books as
        // D_damage; the residual W_ext − (E_kin + E_strain + D_viscous + D_damage) is what is
        // left unexplained (time-integration error).
        let mut row = vec![
            state.time,
            state.step as f64,
            ek,
            es,
            w,
            dv,
            ek + es + dv - w,
            dd,
            w - (ek + es + dv + dd),
            (state.broken / 2) as f64,
            state.dt,
            state.iterations as f64,
        ];
        for nodes in &self.sets {
            let r = view.reaction(nodes);
            row.extend(r.iter());
            row.extend(mean_displacement(&state.u, nodes).iter());
        }
        let x = &view.body.positions;
        for &(a, b) in &self.openings {
            row.push((state.current[b] - state.current[a]).norm() - (x[b] - x[a]).norm());
        }
        if let Some(stage) = self.stage {
            row.push(stage as f64);
        }
        self.csv.push(row)?;
        if view.last {
            self.csv.flush()?;
        }
        Ok(())
    }

    fn begin_stage(&mut self, stage: &StageStart) {
        self.every = Every(stage.history_interval);
        if self.stage.is_some() {
            self.stage = Some(stage.index + 1);
        }
    }

    fn finish(&mut self) -> std::io::Result<()> {
        self.csv.flush()
    }
}

/// Mean displacement of a node set (zero for an empty set).
fn mean_displacement<const D: usize>(u: &[Vector<D>], nodes: &[u32]) -> Vector<D> {
    let sum = nodes
        .iter()
        .fold(Vector::<D>::zeros(), |a, &i| a + u[i as usize]);
    sum / (nodes.len().max(1) as f64)
}
