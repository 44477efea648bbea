//! What a distributed run does not do yet: refused at start, naming the feature, rather than
//! run to a different answer.

use crate::deck::build::MaterialChoice;
use crate::deck::schema::Discretization;
use crate::deck::solver_settings::solver_settings;
use crate::deck::LoadedDeck;
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
    let settings = solver_settings(deck);
    let analysis = deck.analysis.as_ref();
    let found = [
        (control.restart, "a restart from a checkpoint (--restart)"),
        (
            settings.quasi_static.is_some(),
            "the quasi-static solver ([solver] quasi_static)",
        ),
        (
            settings.adaptive.is_some(),
            "the adaptive time step ([solver] adaptive)",
        ),
        (!deck.stages.is_empty(), "a staged run ([[stages]])"),
        (
            deck.contact.is_some() || !deck.impactors.is_empty(),
            "contact ([contact], [[impactors]])",
        ),
        (
            analysis.is_some_and(|a| a.crack_path.is_some()),
            "[analysis.crack_path]",
        ),
        (
            analysis.is_some_and(|a| a.crack_surface.is_some()),
            "[analysis.crack_surface]",
        ),
        (
            !deck.materials.is_empty() || !deck.blocks.is_empty(),
            "several materials ([materials], [[blocks]])",
        ),
    ]
    .into_iter()
    .find(|(refused, _)| *refused);
    if let Some((_, feature)) = found {
        return Err(refusal(feature, ranks));
    }
    match &deck.discretization {
        Discretization::Lattice { refine, pores, .. } => {
            if !refine.is_empty() {
                return Err(refusal(
                    "a refined lattice (discretization.refine, dual horizons)",
                    ranks,
                ));
            }
            if pores.is_some() {
                return Err(refusal("pores (discretization.pores)", ranks));
            }
            Ok(())
        }
        Discretization::FreeMesh { .. } => Err(refusal("the free-mesh grid", ranks)),
        Discretization::Nbnug { .. } => Err(refusal("the NB-NUG grid", ranks)),
        Discretization::PointCloud { .. } => Err(refusal("a point-cloud grid", ranks)),
        Discretization::Gmsh { .. } => Err(refusal("a Gmsh grid", ranks)),
    }
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
        Damage::CriticalStretch(_) => Ok(()),
        Damage::CriticalEnergy(_) => Err(refusal("the critical-energy damage law", ranks)),
        Damage::Softening(_) => Err(refusal("softening damage laws", ranks)),
        Damage::Mixed(_) => Err(refusal("several damage laws", ranks)),
    }
}
