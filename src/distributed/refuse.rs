//! What a distributed run does not do yet: refused at start, naming the feature, rather than
//! run to a different answer.

use crate::material::surface_correction::SurfaceCorrection;
use crate::run::{DamageAndReports, RunError};

/// The refusal of `feature` on `ranks` ranks.
pub fn refusal(feature: &str, ranks: usize) -> RunError {
    RunError::Distributed(format!(
        "{feature} is not yet distributed: run it on 1 rank (this run has {ranks}; see docs/distributed.md)"
    ))
}

/// Refuses the parts of the constitution not yet distributed.
pub fn constitution_refusal(rest: &DamageAndReports, ranks: usize) -> Result<(), RunError> {
    // Every deck feature, model and damage law (several of them by block), grid, solver,
    // observer and restart runs distributed, and porosity;
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
    use crate::deck::LoadedDeck;
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

    /// What a run of `src` on 2 ranks refuses, if anything.
    fn refused(src: &str) -> Option<String> {
        let ld = LoadedDeck::from_str(src, Path::new("t.toml")).expect("a valid deck");
        let model = build_model::<2>(&ld).expect("a model");
        let (_, rest) = build_constitution(&ld, &model).expect("laws").split();
        constitution_refusal(&rest, 2).err().map(|e| e.to_string())
    }

    #[test]
    fn distributed_models_laws_and_solvers_run() {
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
            assert_eq!(refused(&deck(material, extra)), None, "{material}");
        }
        let nbnug = "type = \"nbnug\"\nshape = { type = \"rectangle\", min = [0.0, 0.0], max = [4e-3, 2e-3] }\nsize = 0.25e-3\nhorizon_ratio = 3.0\npores = { count = 1, radius = [3e-4, 3e-4], seed = 1 }";
        let refined = format!(
            "{LATTICE}\nrefine = [{{ region = {{ type = \"disk\", center = [2e-3, 1e-3], radius = 5e-4 }}, levels = 1 }}]"
        );
        for grid in [nbnug, refined.as_str()] {
            let src = deck("type = \"pmb\"", "").replace(LATTICE, grid);
            assert_eq!(refused(&src), None, "{grid}");
        }
        // The quasi-static solvers, and a staged run.
        let explicit = "type = \"explicit\"\nend_time = 1e-6";
        for method in ["adr", "ncg"] {
            let quasi_static =
                format!("type = \"quasi_static\"\nload_steps = 2\nmethod = \"{method}\"");
            let src = deck("type = \"pmb\"", "").replace(explicit, &quasi_static);
            assert_eq!(refused(&src), None, "{method}");
        }
        let stage = format!("[[stages]]\n[stages.solver]\n{explicit}");
        assert_eq!(refused(&deck("type = \"pmb\"", &stage)), None);
        // The one-pass surface corrections.
        for method in ["energy", "volume"] {
            let corrected = format!("{LATTICE}\nsurface_correction = \"{method}\"");
            let src = deck("type = \"pmb\"", "").replace(LATTICE, &corrected);
            assert_eq!(refused(&src), None, "{method}");
        }
    }

    #[test]
    fn the_rest_is_refused_by_name() {
        let iterated = format!("{LATTICE}\nsurface_correction = \"energy_iterated\"");
        let src = deck("type = \"pmb\"", "").replace(LATTICE, &iterated);
        let message = refused(&src).expect("refused");
        assert!(
            message.contains("the iterated energy surface correction")
                && message.contains("not yet distributed"),
            "{message}"
        );
    }
}
