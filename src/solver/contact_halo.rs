//! The other ranks' nodes a rank's contact search needs (`solver::contact` in a distributed
//! run). A contact partner of an owned node may lie outside its family, and so outside the
//! rank's ghosts: a crack face that closes, a fragment that flies over. So, each time the
//! candidate list is built (the same steps on every rank: the Verlet-skin test is taken over
//! every rank's nodes), every rank sends each other rank its owned nodes inside that rank's
//! bounding box grown by the search reach (r_c + skin), with their global indices and volumes;
//! in every step between, it sends those nodes' current positions (D f64 per node).
//!
//! Every pair one process finds within the reach has its remote end among these nodes (within
//! the reach of an owned node is within the owner's box grown by it), and the search keeps the
//! same pairs with the same test on the same positions; each node's candidates are sorted by
//! global index, the one-process order. So each owned node sums its contact force over the
//! same partners in the same order: the same bits.

use super::ranks::{Halo, Share};
use crate::math::Vector;

/// A rank's owned nodes followed by the other ranks' nodes near them.
#[derive(Debug, Clone)]
pub struct RemoteNodes<const D: usize> {
    /// Per peer: the owned nodes it needs, and the points it fills.
    halo: Halo,
    /// Current positions: the owned nodes' (local 0..owned), then the remote nodes'.
    pub points: Vec<Vector<D>>,
    /// Global index of each point.
    pub globals: Vec<u32>,
    /// Volume of each point (m³).
    pub volumes: Vec<f64>,
}

/// The reach grown by a relative margin, so that a pair whose squared distance rounds below
/// reach² is never outside the grown box by rounding.
const MARGIN: f64 = 1e-6;

impl<const D: usize> RemoteNodes<D> {
    /// Finds, with every other rank, the nodes each needs of the others (a collective call:
    /// every rank makes it in the same step). `current` and `volumes` are this rank's local
    /// nodes (its owned nodes first).
    pub fn build(share: &Share, current: &[Vector<D>], volumes: &[f64], reach: f64) -> Self {
        let ranks = &*share.ranks;
        let owned = &current[..share.owned];
        // Every rank's bounding box of its owned nodes: lo then hi, D words each.
        let (mut lo, mut hi) = (
            Vector::<D>::repeat(f64::INFINITY),
            Vector::<D>::repeat(f64::NEG_INFINITY),
        );
        for p in owned {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let mut mine = lo.as_slice().to_vec();
        mine.extend_from_slice(hi.as_slice());
        let boxes = ranks.all_gather(&mine);
        let grow = reach * (1.0 + MARGIN);
        let others: Vec<usize> = (0..ranks.size()).filter(|&q| q != ranks.rank()).collect();
        let send: Vec<Vec<u32>> = others
            .iter()
            .map(|&q| {
                let b = &boxes[2 * D * q..2 * D * (q + 1)];
                let inside =
                    |p: &Vector<D>| (0..D).all(|k| p[k] >= b[k] - grow && p[k] <= b[D + k] + grow);
                (0..owned.len() as u32)
                    .filter(|&i| inside(&owned[i as usize]))
                    .collect()
            })
            .collect();
        // How many each peer sends, then their global indices and volumes.
        let counts: Vec<Vec<f64>> = send.iter().map(|s| vec![s.len() as f64]).collect();
        let mut theirs: Vec<Vec<f64>> = others.iter().map(|_| vec![0.0]).collect();
        ranks.swap(&others, &counts, &mut theirs);
        let keep: Vec<usize> = (0..others.len())
            .filter(|&k| !send[k].is_empty() || theirs[k][0] > 0.0)
            .collect();
        let peers: Vec<usize> = keep.iter().map(|&k| others[k]).collect();
        let send: Vec<Vec<u32>> = keep.iter().map(|&k| send[k].clone()).collect();
        let described: Vec<Vec<f64>> = send
            .iter()
            .map(|s| {
                s.iter()
                    .flat_map(|&i| [(share.first + i as usize) as f64, volumes[i as usize]])
                    .collect()
            })
            .collect();
        let mut received: Vec<Vec<f64>> = keep
            .iter()
            .map(|&k| vec![0.0; 2 * theirs[k][0] as usize])
            .collect();
        ranks.swap(&peers, &described, &mut received);
        let mut nodes = RemoteNodes {
            halo: Halo::default(),
            points: owned.to_vec(),
            globals: (0..share.owned).map(|i| (share.first + i) as u32).collect(),
            volumes: volumes[..share.owned].to_vec(),
        };
        let mut recv = Vec::with_capacity(peers.len());
        for words in &received {
            let start = nodes.points.len() as u32;
            for w in words.chunks_exact(2) {
                nodes.globals.push(w[0] as u32);
                nodes.volumes.push(w[1]);
                nodes.points.push(Vector::zeros());
            }
            recv.push((start..nodes.points.len() as u32).collect());
        }
        nodes.halo = Halo {
            peers,
            send,
            recv,
            ..Halo::default()
        };
        nodes.refresh(share, current);
        nodes
    }

    /// Brings every point up to the current positions: the owned nodes' from `current`, the
    /// remote ones' from their owners (a collective call).
    pub fn refresh(&mut self, share: &Share, current: &[Vector<D>]) {
        self.points[..share.owned].copy_from_slice(&current[..share.owned]);
        self.halo.exchange_items(
            &*share.ranks,
            D,
            &mut self.points,
            |p, buf| buf.extend_from_slice(p.as_slice()),
            |p, w| *p = Vector::<D>::from_column_slice(w),
        );
    }

    /// Remote nodes this rank receives.
    pub fn remote(&self) -> usize {
        self.halo.ghosts()
    }
}

/// The global index of each of this rank's local nodes (owned, then ghosts: their owners tell
/// them through the halo; a collective call).
pub fn local_globals(share: &Share, nodes: usize) -> Vec<u32> {
    let mut g: Vec<f64> = (0..nodes).map(|i| (share.first + i) as f64).collect();
    share.halo.exchange_values(&*share.ranks, &mut g);
    g.into_iter().map(|x| x as u32).collect()
}
