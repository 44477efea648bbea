//! The decomposition of a body over ranks: contiguous ranges of the global (Morton) node
//! order, cut at node-chunk boundaries and balanced by predicted bond count.

use crate::body::Body;
use crate::bonds::PartialVolume;
use crate::solver::forces::NODE_CHUNK;
use std::ops::Range;

/// Predicted bonds of node i: its horizon ball (plus the partial-volume band) over its
/// cell's measure, as `bonds::search::estimate_bonds` counts them. A surface node has fewer,
/// so a rank of many surface nodes gets a little less work than predicted.
pub fn bond_weights<const D: usize>(body: &Body<D>, rule: PartialVolume) -> Vec<f64> {
    (0..body.len())
        .map(|i| crate::bonds::search::estimate_node_bonds(body, rule, i))
        .collect()
}

/// `ranks` contiguous ranges covering 0..weights.len(), each starting at a multiple of
/// `NODE_CHUNK` (so a rank's node chunks are those of one process, whose per-chunk sums it
/// then continues in order), with about equal weight each. `None` when there are fewer
/// chunks than ranks.
pub fn ranges(weights: &[f64], ranks: usize) -> Option<Vec<Range<usize>>> {
    let n = weights.len();
    let chunks = n.div_ceil(NODE_CHUNK);
    if ranks == 0 || chunks < ranks {
        return None;
    }
    let chunk_weight: Vec<f64> = weights.chunks(NODE_CHUNK).map(|c| c.iter().sum()).collect();
    let total: f64 = chunk_weight.iter().sum();
    let mut cuts = vec![0usize];
    let mut acc = 0.0;
    for (c, w) in chunk_weight.iter().enumerate() {
        acc += w;
        let r = cuts.len();
        // Leave at least one chunk for each rank still to come.
        let left = chunks - (c + 1);
        if r < ranks && (acc >= total * r as f64 / ranks as f64 || left == ranks - r) {
            cuts.push(c + 1);
        }
    }
    cuts.truncate(ranks);
    let starts: Vec<usize> = cuts.iter().map(|&c| c * NODE_CHUNK).collect();
    Some(
        (0..ranks)
            .map(|r| starts[r]..starts.get(r + 1).copied().unwrap_or(n))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_cover_every_node_once_at_chunk_boundaries() {
        for (n, ranks) in [(1000, 2), (1000, 3), (256 * 7 + 5, 7), (5000, 4)] {
            let w = vec![1.0; n];
            let r = ranges(&w, ranks).unwrap();
            assert_eq!(r.len(), ranks);
            assert_eq!(r[0].start, 0);
            assert_eq!(r[ranks - 1].end, n);
            for k in 1..ranks {
                assert_eq!(r[k].start, r[k - 1].end);
                assert_eq!(r[k].start % NODE_CHUNK, 0);
                assert!(!r[k].is_empty());
            }
        }
        assert!(ranges(&[1.0; 300], 3).is_none());
    }

    #[test]
    fn ranges_balance_the_weight() {
        // The first half weighs three times the second: the first rank gets fewer nodes.
        let mut w = vec![3.0; 256 * 40];
        w.extend(vec![1.0; 256 * 40]);
        let r = ranges(&w, 2).unwrap();
        assert_eq!(r[0].end, 256 * 27);
    }
}
