//! A simulation distributed over several processes (ranks): what a rank's share of the run
//! needs of the others, as a trait (the transport, MPI, lives in `distributed/` behind the
//! `mpi` feature), and the halo of ghost nodes a share reads.
//!
//! A share owns a contiguous range of the global (Morton) node order; its local nodes are
//! the owned ones first, in global order, then its ghosts (the nodes of other ranks that its
//! families reach), in global order. Every family is an owned node's row, exactly as one
//! process builds it, so each node's gather reads the same inputs in the same order. Sums
//! over nodes are continued from rank to rank in rank order (`Ranks::chain`), which is the
//! one process's left-to-right order: the same bits for any number of ranks.

use crate::bonds::partial_volume::NodeWeight;
use crate::math::Vector;
use crate::state::State;
use std::sync::Arc;

/// The other ranks of a distributed run, seen from one.
pub trait Ranks: Send + Sync {
    fn rank(&self) -> usize;
    fn size(&self) -> usize;
    /// Continues a left fold across the ranks in rank order: rank 0 calls `local(None)`, rank
    /// r `local(Some(a))` with rank r − 1's result a; every rank returns the last rank's.
    fn chain(&self, local: &mut dyn FnMut(Option<f64>) -> f64) -> f64;
    /// Σ over ranks (exact: integers).
    fn sum_u64(&self, x: u64) -> u64;
    /// The smallest over ranks (exact in any order).
    fn min_f64(&self, x: f64) -> f64;
    /// The largest over ranks (exact in any order).
    fn max_f64(&self, x: f64) -> f64;
    /// Sends `send[k]` to rank `peers[k]` and receives its buffer into `recv[k]` (sized by
    /// the caller).
    fn swap(&self, peers: &[usize], send: &[Vec<f64>], recv: &mut [Vec<f64>]);
    /// The message of the lowest rank that has one, on every rank.
    fn first_message(&self, local: Option<String>) -> Option<String>;
    /// Every rank's `local` on rank 0, in rank order (`None` on the others).
    fn gather(&self, local: &[f64]) -> Option<Vec<f64>>;
    /// Rank 0's `x` on every rank.
    fn broadcast_bool(&self, x: bool) -> bool;
    /// Rank r's part from rank 0: rank 0 calls `part(r)` for every rank, one at a time (so it
    /// holds one part at once), and each rank returns its own (the others never call `part`).
    fn scatter(&self, part: &mut dyn FnMut(usize) -> Vec<f64>) -> Vec<f64>;
    /// Every rank's `local` on every rank, in rank order.
    fn all_gather(&self, local: &[f64]) -> Vec<f64>;
}

/// One rank's share of a distributed run.
pub struct Share {
    pub ranks: Arc<dyn Ranks>,
    /// Global index of the first owned node (local node 0).
    pub first: usize,
    /// Owned nodes: local 0..owned; ghosts follow.
    pub owned: usize,
    /// Nodes of the whole body.
    pub global_nodes: usize,
    pub halo: Halo,
}

/// Which local nodes a rank sends to each peer, and which ghosts it receives from each.
#[derive(Debug, Clone, Default)]
pub struct Halo {
    pub peers: Vec<usize>,
    /// Per peer: owned local nodes the peer has as ghosts, in global order.
    pub send: Vec<Vec<u32>>,
    /// Per peer: local ghost nodes the peer owns, in global order.
    pub recv: Vec<Vec<u32>>,
}

impl Halo {
    /// Ghost nodes of this rank.
    pub fn ghosts(&self) -> usize {
        self.recv.iter().map(Vec::len).sum()
    }

    /// Bytes this rank sends per exchange of `words` f64 per node.
    pub fn bytes_sent(&self, words: usize) -> usize {
        8 * words * self.send.iter().map(Vec::len).sum::<usize>()
    }

    /// Brings the ghosts' displacement, velocity and current position up to their owners':
    /// what a gather of a neighbour reads (positions; the velocity for the mid-step energy
    /// of a breaking step).
    pub fn exchange<const D: usize>(&self, ranks: &dyn Ranks, state: &mut State<D>) {
        let send = self.pack(3 * D, |i, buf| {
            for v in [&state.u[i], &state.v[i], &state.current[i]] {
                buf.extend_from_slice(v.as_slice());
            }
        });
        self.receive(ranks, 3 * D, send, |i, w| {
            state.u[i] = Vector::<D>::from_column_slice(&w[..D]);
            state.v[i] = Vector::<D>::from_column_slice(&w[D..2 * D]);
            state.current[i] = Vector::<D>::from_column_slice(&w[2 * D..]);
        });
    }

    /// Gives the ghosts' entries of a per-node array their owners' values.
    pub fn exchange_values(&self, ranks: &dyn Ranks, values: &mut [f64]) {
        self.exchange_items(ranks, 1, values, |v, buf| buf.push(*v), |v, w| *v = w[0]);
    }

    /// Gives the ghosts' entries of a per-node array their owners', `words` f64 per node:
    /// `pack(item, buf)` appends an owned item's words, `unpack(item, words)` sets a ghost's.
    pub fn exchange_items<T>(
        &self,
        ranks: &dyn Ranks,
        words: usize,
        items: &mut [T],
        pack: impl Fn(&T, &mut Vec<f64>),
        unpack: impl Fn(&mut T, &[f64]),
    ) {
        let send = self.pack(words, |i, buf| pack(&items[i], buf));
        self.receive(ranks, words, send, |i, w| unpack(&mut items[i], w));
    }

    /// Each peer's buffer of the owned nodes it has as ghosts.
    fn pack(&self, words: usize, pack: impl Fn(usize, &mut Vec<f64>)) -> Vec<Vec<f64>> {
        self.send
            .iter()
            .map(|nodes| {
                let mut buf = Vec::with_capacity(nodes.len() * words);
                for &i in nodes {
                    pack(i as usize, &mut buf);
                }
                debug_assert_eq!(buf.len(), nodes.len() * words);
                buf
            })
            .collect()
    }

    /// Swaps `send` with the peers and hands each ghost its words.
    fn receive(
        &self,
        ranks: &dyn Ranks,
        words: usize,
        send: Vec<Vec<f64>>,
        mut unpack: impl FnMut(usize, &[f64]),
    ) {
        let mut recv: Vec<Vec<f64>> = self
            .recv
            .iter()
            .map(|n| vec![0.0; n.len() * words])
            .collect();
        ranks.swap(&self.peers, &send, &mut recv);
        for (nodes, buf) in self.recv.iter().zip(&recv) {
            for (&i, w) in nodes.iter().zip(buf.chunks_exact(words)) {
                unpack(i as usize, w);
            }
        }
    }
}

/// Whether the whole body is a uniform grid, from each rank's `local` answer for its owned
/// nodes and ghosts: the one weight if every rank has it (bitwise: the smallest and largest
/// over ranks agree), else none. A rank's nodes may all be alike in a body that is not.
pub fn agreed_uniform(ranks: &dyn Ranks, local: Option<NodeWeight>) -> Option<NodeWeight> {
    let all = ranks.min_f64(local.is_some() as u8 as f64) == 1.0;
    let w = local.filter(|_| all)?;
    let alike = |x: f64| ranks.min_f64(x) == x && ranks.max_f64(x) == x;
    // Every rank asks the same three questions (each is a collective call).
    let same = [w.volume, w.half_cell, w.horizon].map(alike);
    let same = same.iter().all(|&s| s);
    (ranks.min_f64(same as u8 as f64) == 1.0).then_some(w)
}

/// Σ of `terms` in the order of one process: this rank's terms (its owned nodes' or
/// chunks') continue the sum of the ranks before it. `Iterator::sum` on rank 0 (and in one
/// process), then a left fold from the partial sum handed on, which is the same left fold.
pub fn ordered_sum(share: Option<&Share>, terms: impl Iterator<Item = f64>) -> f64 {
    match share {
        None => terms.sum(),
        Some(s) => {
            let mut terms = Some(terms);
            s.ranks.chain(&mut |before| {
                let terms = terms.take().expect("called once");
                match before {
                    None => terms.sum(),
                    Some(a) => terms.fold(a, |acc, t| acc + t),
                }
            })
        }
    }
}

/// `ordered_sum` of a left fold that starts from `start` on rank 0 (a loop `w = start;
/// w += t`).
pub fn ordered_fold(share: Option<&Share>, start: f64, terms: impl Iterator<Item = f64>) -> f64 {
    match share {
        None => terms.fold(start, |acc, t| acc + t),
        Some(s) => {
            let mut terms = Some(terms);
            s.ranks.chain(&mut |before| {
                let terms = terms.take().expect("called once");
                terms.fold(before.unwrap_or(start), |acc, t| acc + t)
            })
        }
    }
}
