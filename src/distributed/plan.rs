//! `peridyn check --ranks N`: the decomposition a distributed run of N ranks would make, rank
//! by rank (owned nodes, ghosts, bonds, halo bytes per step, memory), predicted in one process.

use super::partition::{bond_weights, ranges};
use crate::bonds::search::build_bonds_of;
use crate::bonds::Bonds;
use crate::deck::build::{build_model_with, Part};
use crate::deck::schema::MaterialDeck;
use crate::deck::{DeckError, DeckIssue, LoadedDeck};
use std::ops::Range;

/// One rank's share as predicted.
#[derive(Debug, Clone)]
pub struct RankPlan {
    pub nodes: Range<usize>,
    pub ghosts: usize,
    /// Directed bonds of the owned families.
    pub bonds: usize,
    /// Bytes the rank sends each step (u, v, y of the nodes its peers have as ghosts, and
    /// the point state their neighbours read: θ under LPS, B, C1 and the moment record
    /// under the correspondence model).
    pub halo_bytes: usize,
    /// Owned and ghost nodes at the largest model's bytes per node, plus the bonds.
    pub memory_bytes: usize,
}

impl std::fmt::Display for RankPlan {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "nodes {}..{} ({} owned, {} ghosts), {} directed bonds, halo {:.1} kB sent per step, memory estimate {:.1} MB",
            self.nodes.start,
            self.nodes.end,
            self.nodes.len(),
            self.ghosts,
            self.bonds,
            self.halo_bytes as f64 / 1e3,
            self.memory_bytes as f64 / 1e6
        )
    }
}

/// `Material::HALO_WORDS` of the model the deck builds: none for PMB, θ for LPS and for
/// several central materials, B, C1 and the moment record for the correspondence model, and
/// both for several materials with a correspondence block.
fn point_words<const D: usize>(ld: &LoadedDeck) -> usize {
    use crate::material::{Correspondence, Lps, Material};
    let models = || std::iter::once(&ld.deck.material).chain(ld.deck.materials.values());
    let correspondence = models().any(|m| matches!(m, MaterialDeck::Correspondence { .. }));
    let lps = <Lps as Material<D>>::HALO_WORDS;
    let tensors = <Correspondence as Material<D>>::HALO_WORDS;
    match (ld.deck.materials.is_empty(), &ld.deck.material) {
        (true, MaterialDeck::Pmb { .. }) => 0,
        (true, MaterialDeck::Lps { .. }) => lps,
        (true, _) => tensors,
        (false, _) if correspondence => lps + tensors,
        (false, _) => lps,
    }
}

/// The shares of `ranks` ranks. Each rank's families are searched in turn (one at a time in
/// memory); the halo a rank sends is what the others have of it as ghosts.
pub fn plan<const D: usize>(ld: &LoadedDeck, ranks: usize) -> Result<Vec<RankPlan>, DeckError> {
    let mut plans = Vec::new();
    // Words per halo node and step: u, v, y, and the point state a neighbour's half reads.
    let words = 3 * D + point_words::<D>(ld);
    build_model_with::<D>(ld, |body, families| {
        let weights = bond_weights(&body, families.rule);
        let Some(ranges) = ranges(&weights, ranks) else {
            return Err(ld.locate(vec![DeckIssue::new(
                "discretization",
                format!(
                    "{} nodes are too few for {ranks} ranks (each needs at least {})",
                    body.len(),
                    crate::solver::forces::NODE_CHUNK
                ),
            )]));
        };
        let mut sent = vec![0usize; ranks];
        for r in &ranges {
            let b = build_bonds_of(&body, families.rule, &ld.deck.precracks, r.clone());
            let mut ghosts: Vec<u32> = b
                .neighbors
                .iter()
                .copied()
                .filter(|&j| !r.contains(&(j as usize)))
                .collect();
            ghosts.sort_unstable();
            ghosts.dedup();
            for &g in &ghosts {
                sent[ranges.partition_point(|q| q.end <= g as usize)] += words * 8;
            }
            plans.push(RankPlan {
                nodes: r.clone(),
                ghosts: ghosts.len(),
                bonds: b.len(),
                halo_bytes: 0,
                memory_bytes: (r.len() + ghosts.len()) * families.bytes_per_node
                    + b.len() * families.bytes_per_bond,
            });
        }
        for (p, s) in plans.iter_mut().zip(sent) {
            p.halo_bytes = s;
        }
        let n = body.len();
        Ok(Part {
            body,
            bonds: Bonds {
                offsets: vec![0; n + 1],
                ..Default::default()
            },
            globals: None,
        })
    })?;
    Ok(plans)
}

/// Refuses a decomposition whose largest share needs more than `per_rank` bytes, naming the
/// rank, both numbers and the rank count that would fit.
pub fn refuse_unfit(plans: &[RankPlan], per_rank: u64) -> Result<(), String> {
    let Some((rank, largest)) = plans.iter().enumerate().max_by_key(|(_, p)| p.memory_bytes) else {
        return Ok(());
    };
    if largest.memory_bytes as u64 <= per_rank {
        return Ok(());
    }
    let total: usize = plans.iter().map(|p| p.memory_bytes).sum();
    // Ghosts grow as shares shrink; the total is a lower bound of what the ranks need.
    let at_least = total.div_ceil(per_rank.max(1) as usize);
    Err(format!(
        "rank {rank}'s share needs about {:.3} GB but a rank has {:.3} GB; \
         use at least {at_least} ranks (or a larger spacing)",
        largest.memory_bytes as f64 / 1e9,
        per_rank as f64 / 1e9
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn share(memory_bytes: usize) -> RankPlan {
        RankPlan {
            nodes: 0..256,
            ghosts: 0,
            bonds: 0,
            halo_bytes: 0,
            memory_bytes,
        }
    }

    #[test]
    fn a_share_larger_than_a_rank_is_refused_with_both_numbers() {
        let plans = [share(3_000_000_000), share(3_500_000_000)];
        assert!(refuse_unfit(&plans, 4_000_000_000).is_ok());
        let e = refuse_unfit(&plans, 2_000_000_000).unwrap_err();
        assert!(e.contains("rank 1's share needs about 3.500 GB"), "{e}");
        assert!(e.contains("a rank has 2.000 GB"), "{e}");
        assert!(e.contains("at least 4 ranks"), "{e}");
    }
}
