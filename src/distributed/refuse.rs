//! What a distributed run does not do yet: refused at start, naming the feature, rather than
//! run to a different answer.

use crate::deck::schema::Discretization;
use crate::deck::solver_settings::solver_settings;
use crate::deck::LoadedDeck;
use crate::material::surface_correction::SurfaceCorrection;
use crate::run::{DamageAndReports, RunControl, RunError};

/// The refusal of `feature` on `ranks` ranks.
pub fn refusal(feature: &str, ranks: usize) -> RunError {
    RunError::Distributed(format!(
        "{feature} is not yet distributed: run it on 1 rank (this run has {ranks}; see docs/distributed.md)"
    ))
}

/// The first feature of the deck (or of the run's control) not yet distributed, if any.
pub fn deck_refusal(ld: &LoadedDeck, control: &RunControl, ranks: usize) -> Result<(), RunError> {
    let deck = &ld.deck;
    // `distributed::restart` continues explicit runs; the quasi-static solver's memory of the
    // last equilibrium and a stage's start are not yet handed to the ranks from a checkpoint.
    let quasi_static = solver_settings(deck).quasi_static.is_some();
    if control.restart && (quasi_static || !deck.stages.is_empty()) {
        return Err(refusal(
            "a restart of a quasi-static or staged run (--restart)",
            ranks,
        ));
    }
    // Lattices (with pores), NB-NUG grids, free meshes and point clouds whose nodes share one
    // horizon (`distributed::share` refuses the others when it builds the families); the
    // grid's uniformity is agreed over the whole body (`solver::ranks::agreed_uniform`).
    match &deck.discretization {
        Discretization::Lattice { refine, .. } if !refine.is_empty() => Err(refusal(
            "a refined lattice (discretization.refine, dual horizons)",
            ranks,
        )),
        Discretization::Gmsh { .. } => Err(refusal("a Gmsh grid", ranks)),
        _ => Ok(()),
    }
}

/// Refuses the parts of the constitution not yet distributed.
pub fn constitution_refusal(rest: &DamageAndReports, ranks: usize) -> Result<(), RunError> {
    // Every model and damage law, several of them by block, and porosity run distributed;
    // the surface correction's one-pass factors come from each node's family and are
    // exchanged once, but the iterated method's sweeps read the neighbours' factors of the
    // sweep before.
    match &rest.surface {
        Some(s) if s.method == SurfaceCorrection::EnergyIterated => Err(refusal(
            "the iterated energy surface correction (discretization.surface_correction = \"energy_iterated\")",
            ranks,
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deck::build::{build_constitution, build_model};
    use std::path::Path;

    /// The plate's lattice (the `[discretization]` lines).
    const LATTICE: &str = r#"type = "lattice"
shape = { type = "rectangle", min = [0.0, 0.0], max = [4e-3, 2e-3] }
spacing = 0.25e-3
horizon_ratio = 3.0"#;

    /// A small plate of `material` (its `[material]` lines) with `extra` deck text.
    fn deck(material: &str, extra: &str) -> String {
        format!(
            r#"version = 2
dimension = 2
plane = "stress"
thickness = 1e-3
[discretization]
{LATTICE}
[material]
density = 1000.0
youngs_modulus = 1e9
fracture_energy = 100.0
{material}
[solver]
type = "explicit"
end_time = 1e-6
{extra}
"#
        )
    }

    /// A run continued from its checkpoint.
    fn restart() -> RunControl {
        RunControl {
            restart: true,
            ..RunControl::default()
        }
    }

    /// What a run of `src` on 2 ranks refuses, if anything.
    fn refused(src: &str, control: &RunControl) -> Option<String> {
        let ld = LoadedDeck::from_str(src, Path::new("t.toml")).expect("a valid deck");
        let check = || -> Result<(), RunError> {
            deck_refusal(&ld, control, 2)?;
            let model = build_model::<2>(&ld).expect("a model");
            let (_, rest) = build_constitution(&ld, &model).expect("laws").split();
            constitution_refusal(&rest, 2)
        };
        check().err().map(|e| e.to_string())
    }

    #[test]
    fn distributed_models_laws_and_solvers_run() {
        let fresh = RunControl::default();
        for (material, extra) in [
            ("type = \"pmb\"", ""),
            (
                "type = \"pmb\"\ndamage = { type = \"critical_energy\" }",
                "",
            ),
            (
                "type = \"pmb\"\ndamage = { type = \"bilinear\", tensile_strength = 1e6 }",
                "",
            ),
            ("type = \"lps\"\npoisson_ratio = 0.3", "[solver.adaptive]"),
            (
                "type = \"pmb\"",
                "[contact]\n[[impactors]]\nname = \"disk\"\nshape = \"sphere\"\ncentre = [-1e-3, 1e-3]\nradius = 1e-3\nvelocity = [10.0, 0.0]\nmass = 1e-3\n[analysis.crack_path]",
            ),
            (
                "type = \"lps\"\npoisson_ratio = 0.3\ndamage = { type = \"critical_energy\" }",
                "",
            ),
            (
                "type = \"correspondence\"\npoisson_ratio = 0.3\ndamage = { type = \"critical_energy\" }",
                "",
            ),
            // Porosity; several materials and damage laws by block.
            (
                "type = \"pmb\"\nporosity = { porosity = 0.05, critical_porosity = 1.0, seed = 1 }",
                "",
            ),
            (
                "type = \"pmb\"",
                "[materials.disk]\ntype = \"correspondence\"\ndensity = 1000.0\nyoungs_modulus = 2e9\npoisson_ratio = 0.3\nfracture_energy = 100.0\ndamage = { type = \"critical_energy\" }\n[[blocks]]\nid = 1\nregion = { type = \"disk\", center = [2e-3, 1e-3], radius = 5e-4 }\nmaterial = \"disk\"",
            ),
        ] {
            assert_eq!(refused(&deck(material, extra), &fresh), None, "{material}");
            assert_eq!(
                refused(&deck(material, extra), &restart()),
                None,
                "{material}"
            );
        }
        let nbnug = "type = \"nbnug\"\nshape = { type = \"rectangle\", min = [0.0, 0.0], max = [4e-3, 2e-3] }\nsize = 0.25e-3\nhorizon_ratio = 3.0\npores = { count = 1, radius = [3e-4, 3e-4], seed = 1 }";
        let src = deck("type = \"pmb\"", "").replace(LATTICE, nbnug);
        assert_eq!(refused(&src, &fresh), None);
        // The quasi-static solvers, and a staged run.
        let explicit = "type = \"explicit\"\nend_time = 1e-6";
        for method in ["adr", "ncg"] {
            let quasi_static =
                format!("type = \"quasi_static\"\nload_steps = 2\nmethod = \"{method}\"");
            let src = deck("type = \"pmb\"", "").replace(explicit, &quasi_static);
            assert_eq!(refused(&src, &fresh), None, "{method}");
        }
        let stage = format!("[[stages]]\n[stages.solver]\n{explicit}");
        assert_eq!(refused(&deck("type = \"pmb\"", &stage), &fresh), None);
        // The one-pass surface corrections.
        for method in ["energy", "volume"] {
            let corrected = format!("{LATTICE}\nsurface_correction = \"{method}\"");
            let src = deck("type = \"pmb\"", "").replace(LATTICE, &corrected);
            assert_eq!(refused(&src, &fresh), None, "{method}");
        }
    }

    #[test]
    fn the_rest_is_refused_by_name() {
        let lps = "type = \"lps\"\npoisson_ratio = 0.3";
        let fresh = RunControl::default();
        for (material, extra, control, name) in [(
            lps,
            "[[stages]]\nname = \"release\"\nsolver = { type = \"explicit\", steps = 10 }",
            &restart(),
            "a restart of a quasi-static or staged run",
        )] {
            let message = refused(&deck(material, extra), control).expect("refused");
            assert!(
                message.contains(name) && message.contains("not yet distributed"),
                "{message}"
            );
        }
        let refined = format!(
            "{LATTICE}\nrefine = [{{ region = {{ type = \"disk\", center = [2e-3, 1e-3], radius = 5e-4 }}, levels = 1 }}]"
        );
        let iterated = format!("{LATTICE}\nsurface_correction = \"energy_iterated\"");
        for (material, grid, name) in [
            (
                lps,
                "type = \"gmsh\"\nfile = \"plate.msh\"\nhorizon = 1e-3",
                "a Gmsh grid",
            ),
            (lps, refined.as_str(), "a refined lattice"),
            (
                "type = \"pmb\"",
                iterated.as_str(),
                "the iterated energy surface correction",
            ),
        ] {
            let src = deck(material, "").replace(LATTICE, grid);
            let message = refused(&src, &fresh).expect("refused");
            assert!(message.contains(name), "{message}");
        }
    }
}
