//! One rank's part of the body: its owned range's families (searched for those nodes only),
//! its ghosts, the halo plan agreed with its peers, and the part of the body the rank keeps.

use crate::body::Body;
use crate::bonds::search::build_bonds_of;
use crate::bonds::{Bonds, PartialVolume, Precrack};
use crate::solver::ranks::{Halo, Ranks};
use std::collections::BTreeMap;
use std::ops::Range;

/// What `split` makes of the whole body for one rank.
pub struct Split<const D: usize> {
    /// Owned nodes first (in global order), then ghosts (in global order).
    pub body: Body<D>,
    /// Owned nodes' families in local indices (each row in the one-process order); ghosts'
    /// rows are empty.
    pub bonds: Bonds,
    /// The global index of each local node.
    pub globals: Vec<u32>,
    pub owned: Range<usize>,
    pub halo: Halo,
    /// The smallest and largest nearest-neighbour distance of the owned nodes (for the grid
    /// report).
    pub spacing: (f64, f64),
}

/// Splits `body` for rank `rank` of `ranges`. Every rank calls it (it exchanges the ghost
/// lists with the peers).
pub fn split<const D: usize>(
    body: &Body<D>,
    rule: PartialVolume,
    precracks: &[Precrack],
    ranges: &[Range<usize>],
    ranks: &dyn Ranks,
) -> Split<D> {
    let owned = ranges[ranks.rank()].clone();
    let global = build_bonds_of(body, rule, precracks, owned.clone());
    let nearest = |i: usize| {
        global
            .family(i)
            .map(|b| global.ref_lengths[b])
            .fold(f64::INFINITY, f64::min)
    };
    let spacing = (0..owned.len())
        .map(nearest)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), d| {
            (lo.min(d), if d.is_finite() { hi.max(d) } else { hi })
        });
    // Ghosts: neighbours outside the owned range, in global order.
    let mut ghosts: Vec<u32> = global
        .neighbors
        .iter()
        .copied()
        .filter(|&j| !owned.contains(&(j as usize)))
        .collect();
    ghosts.sort_unstable();
    ghosts.dedup();
    let local_of = |j: u32| -> u32 {
        let j = j as usize;
        if owned.contains(&j) {
            (j - owned.start) as u32
        } else {
            let k = ghosts.binary_search(&(j as u32)).expect("a ghost");
            (owned.len() + k) as u32
        }
    };
    let mut offsets = global.offsets.clone();
    offsets.extend(std::iter::repeat_n(global.len(), ghosts.len()));
    let bonds = Bonds {
        offsets,
        neighbors: global.neighbors.iter().map(|&j| local_of(j)).collect(),
        ref_lengths: global.ref_lengths,
    };
    let globals: Vec<u32> = (owned.start as u32..owned.end as u32)
        .chain(ghosts.iter().copied())
        .collect();
    let halo = halo(&ghosts, owned.len(), ranges, ranks, &owned);
    Split {
        body: part_of(body, &globals, &owned),
        bonds,
        globals,
        owned,
        halo,
        spacing,
    }
}

/// The rank that owns global node `j`.
fn owner(ranges: &[Range<usize>], j: usize) -> usize {
    ranges.partition_point(|r| r.end <= j)
}

/// The halo plan: ghosts are received from their owners; each peer tells this rank which of
/// its nodes it has as ghosts (families are symmetric, so the peers of a rank are the ranks
/// whose nodes it has as ghosts, both ways).
fn halo(
    ghosts: &[u32],
    first_ghost: usize,
    ranges: &[Range<usize>],
    ranks: &dyn Ranks,
    owned: &Range<usize>,
) -> Halo {
    let mut by_peer: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
    for (k, &g) in ghosts.iter().enumerate() {
        by_peer
            .entry(owner(ranges, g as usize))
            .or_default()
            .push(k as u32);
    }
    let peers: Vec<usize> = by_peer.keys().copied().collect();
    let recv: Vec<Vec<u32>> = by_peer
        .values()
        .map(|ks| ks.iter().map(|&k| first_ghost as u32 + k).collect())
        .collect();
    // The global indices each peer wants, counts first (exact in f64 below 2^53).
    let wanted: Vec<Vec<f64>> = by_peer
        .values()
        .map(|ks| ks.iter().map(|&k| ghosts[k as usize] as f64).collect())
        .collect();
    let counts: Vec<Vec<f64>> = wanted.iter().map(|w| vec![w.len() as f64]).collect();
    let mut their_counts: Vec<Vec<f64>> = peers.iter().map(|_| vec![0.0]).collect();
    ranks.swap(&peers, &counts, &mut their_counts);
    let mut asked: Vec<Vec<f64>> = their_counts
        .iter()
        .map(|c| vec![0.0; c[0] as usize])
        .collect();
    ranks.swap(&peers, &wanted, &mut asked);
    let send = asked
        .iter()
        .map(|a| {
            a.iter()
                .map(|&g| (g as usize - owned.start) as u32)
                .collect()
        })
        .collect();
    Halo {
        peers,
        send,
        recv,
        ..Halo::default()
    }
}

/// The rank's part of the body: its local nodes' data, and the node sets restricted to its
/// owned nodes (a ghost's loading is its owner's to apply and book).
fn part_of<const D: usize>(body: &Body<D>, globals: &[u32], owned: &Range<usize>) -> Body<D> {
    let node_sets = body
        .node_sets
        .iter()
        .map(|(name, nodes)| {
            let mine = nodes
                .iter()
                .filter(|&&g| owned.contains(&(g as usize)))
                .map(|&g| (g as usize - owned.start) as u32)
                .collect();
            (name.clone(), mine)
        })
        .collect();
    Body {
        positions: globals
            .iter()
            .map(|&g| body.positions[g as usize])
            .collect(),
        volumes: globals.iter().map(|&g| body.volumes[g as usize]).collect(),
        cell_sizes: globals
            .iter()
            .map(|&g| body.cell_sizes[g as usize])
            .collect(),
        horizons: globals.iter().map(|&g| body.horizons[g as usize]).collect(),
        blocks: globals.iter().map(|&g| body.blocks[g as usize]).collect(),
        no_fail: globals.iter().map(|&g| body.no_fail[g as usize]).collect(),
        node_sets,
        thickness: body.thickness,
    }
}
