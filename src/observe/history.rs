//! The CSV history: energies, broken bonds, the step (time step or load increment, and
//! iterations), the reaction force and mean displacement of every named node set, the
//! openings between pairs of nodes and the motion of single nodes (probes).

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
    /// Nodes whose velocity and displacement are recorded (`probe_<name>_…`).
    probes: Vec<usize>,
    /// The stage in progress (from 1), when the run has several and the column `stage`.
    stage: Option<usize>,
    /// With contact or impactors: their energies join the balance and have columns.
    contact: bool,
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
            probes: Vec::new(),
            stage: None,
            contact: false,
        }
    }

    /// Adds the contact columns: `contact_energy`, `impactor_kinetic_energy`, and each
    /// impactor's force (of the body on it), position and velocity.
    pub fn with_contact<const D: usize>(mut self, impactors: &[String]) -> Self {
        self.contact = true;
        self.csv.add_column("contact_energy".to_string());
        self.csv.add_column("impactor_kinetic_energy".to_string());
        for name in impactors {
            for what in ["force", "position", "velocity"] {
                for axis in AXES.iter().take(D) {
                    self.csv
                        .add_column(format!("impactor_{name}_{what}_{axis}"));
                }
            }
        }
        self
    }

    /// Column names, as in the file.
    pub fn header(&self) -> &[String] {
        self.csv.header()
    }

    /// Rows recorded so far.
    pub fn rows(&self) -> &[Vec<f64>] {
        self.csv.rows()
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

    /// Adds columns `probe_<name>_velocity_<axis>` and `probe_<name>_displacement_<axis>`
    /// per (name, node): one node's motion, e.g. the particle velocity of a passing wave.
    pub fn with_probes<const D: usize>(mut self, probes: &[(String, usize)]) -> Self {
        for (name, node) in probes {
            for what in ["velocity", "displacement"] {
                for axis in AXES.iter().take(D) {
                    self.csv.add_column(format!("probe_{name}_{what}_{axis}"));
                }
            }
            self.probes.push(*node);
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
        // With contact, its potential energy and the free impactors' kinetic energy are part
        // of the conserved total.
        let (ec, ei) = if self.contact {
            (view.contact_energy(), view.impactor_kinetic_energy())
        } else {
            (0.0, 0.0)
        };
        let stored = if self.contact {
            ek + es + ec + ei
        } else {
            ek + es
        };
        let mut row = vec![
            state.time,
            state.step as f64,
            ek,
            es,
            w,
            dv,
            stored + dv - w,
            dd,
            w - (stored + dv + dd),
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
        for &i in &self.probes {
            row.extend(state.v[i].iter());
            row.extend(state.u[i].iter());
        }
        if self.contact {
            row.push(ec);
            row.push(ei);
            for im in view.impactors() {
                row.extend(im.force.iter());
                row.extend(im.position.iter());
                row.extend(im.velocity.iter());
            }
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
