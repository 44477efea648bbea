//! The CSV history: energies, broken bonds and reaction forces of every named node set.

use super::csv::CsvHistory;
use super::observer::{Every, Observer, StepView};
use crate::material::Material;
use std::path::Path;

pub struct History {
    csv: CsvHistory,
    every: Every,
    sets: Vec<Vec<u32>>,
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
            "broken_bonds",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for (name, _) in set_names {
            for axis in AXES.iter().take(D) {
                header.push(format!("reaction_{name}_{axis}"));
            }
        }
        History {
            csv: CsvHistory::new(path, header),
            every: Every(every),
            sets: set_names.iter().map(|(_, n)| n.clone()).collect(),
        }
    }
}

impl<const D: usize, M: Material<D>> Observer<D, M> for History {
    fn wants(&self, step: u64, last: bool) -> bool {
        self.every.hits(step, last)
    }

    fn observe(&mut self, view: &StepView<D, M>) -> std::io::Result<()> {
        let sim = view.sim;
        let (ek, es) = (sim.kinetic_energy(), view.strain_energy());
        let (w, dv) = (sim.state.external_work, sim.state.dissipated_viscous);
        // Energy balance: E_kin + E_strain + D_viscous − W_ext, constant (≈ 0) for an elastic run;
        // its growth is the energy dissipated by breaking bonds.
        let mut row = vec![
            sim.state.time,
            sim.state.step as f64,
            ek,
            es,
            w,
            dv,
            ek + es + dv - w,
            (sim.state.broken / 2) as f64,
        ];
        for nodes in &self.sets {
            let r = sim.reaction(nodes);
            row.extend(r.iter());
        }
        self.csv.push(row)?;
        if view.last {
            self.csv.flush()?;
        }
        Ok(())
    }

    fn finish(&mut self) -> std::io::Result<()> {
        self.csv.flush()
    }
}
