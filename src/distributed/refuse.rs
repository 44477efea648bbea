//! What a distributed run does not do yet: refused at start, naming the feature, rather than
//! run to a different answer.

use crate::deck::build::MaterialChoice;
use crate::deck::LoadedDeck;
use crate::run::{DamageAndReports, RunControl, RunError};

/// The refusal of `feature` on `ranks` ranks.
pub fn refusal(feature: &str, ranks: usize) -> RunError {
    RunError::Distributed(format!(
        "{feature} is not yet distributed: run it on 1 rank (this run has {ranks}; see docs/distributed.md)"
    ))
}

/// The first feature of the deck not yet distributed, if any (the run's control, a restart
/// included, is distributed whole).
pub fn deck_refusal(ld: &LoadedDeck, _control: &RunControl, ranks: usize) -> Result<(), RunError> {
    let deck = &ld.deck;
    if !deck.materials.is_empty() || !deck.blocks.is_empty() {
        return Err(refusal(
            "several materials ([materials], [[blocks]])",
            ranks,
        ));
    }
    // Every grid is distributed: lattices (refined or not, with pores), NB-NUG grids, free
    // meshes, Gmsh meshes and point clouds; the grid's uniformity is agreed over the whole
    // body (`solver::ranks::agreed_uniform`).
    Ok(())
}

/// Refuses the models and damage laws not yet distributed.
pub fn constitution_refusal(
    material: &MaterialChoice,
    rest: &DamageAndReports,
    ranks: usize,
) -> Result<(), RunError> {
    let model = match material {
        MaterialChoice::Pmb(_) | MaterialChoice::Lps(_) => None,
        MaterialChoice::Correspondence(_) => Some("the correspondence model"),
        MaterialChoice::Mixed(_) => Some("several materials"),
    };
    if let Some(m) = model {
        return Err(refusal(m, ranks));
    }
    if rest.surface.is_some() {
        return Err(refusal(
            "the surface correction (discretization.surface_correction)",
            ranks,
        ));
    }
    if !rest.porosity.is_empty() {
        return Err(refusal("porosity (material.porosity)", ranks));
    }
    use crate::damage::Damage;
    match &rest.damage {
        // The laws decide a bond from its stretch or its pair work, the same bits at both
        // ends once the ghosts' positions and point states are their owners'.
        Damage::CriticalStretch(_) | Damage::CriticalEnergy(_) | Damage::Softening(_) => Ok(()),
        Damage::Mixed(_) => Err(refusal("several damage laws", ranks)),
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
            let (material, rest) = build_constitution(&ld, &model).expect("laws").split();
            constitution_refusal(&material, &rest, 2)
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
        // A Gmsh mesh (its file is read when the model is built, after this check).
        let gmsh = "type = \"gmsh\"\nfile = \"plate.msh\"\nhorizon = 1e-3";
        let src = deck("type = \"pmb\"", "").replace(LATTICE, gmsh);
        let ld = LoadedDeck::from_str(&src, Path::new("t.toml")).expect("a valid deck");
        assert!(deck_refusal(&ld, &fresh, 2).is_ok());
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
        // Their restarts too.
        let quasi_static = "type = \"quasi_static\"\nload_steps = 2";
        let src = deck("type = \"pmb\"", "").replace(explicit, quasi_static);
        assert_eq!(refused(&src, &restart()), None);
        assert_eq!(refused(&deck("type = \"pmb\"", &stage), &restart()), None);
    }

    #[test]
    fn the_rest_is_refused_by_name() {
        let lps = "type = \"lps\"\npoisson_ratio = 0.3";
        let fresh = RunControl::default();
        let correspondence =
            "type = \"correspondence\"\npoisson_ratio = 0.3\ndamage = { type = \"critical_energy\" }";
        let message = refused(&deck(correspondence, ""), &fresh).expect("refused");
        assert!(
            message.contains("the correspondence model") && message.contains("not yet distributed"),
            "{message}"
        );
    }
}
