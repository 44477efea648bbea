//! The bonds of a distributed run whose two ends are on different ranks, paired entry by
//! entry: a law that decides a bond from the words of both its entries (the split work of a
//! critical energy, `ForceEngine::resolve_split_work`) reads the other entry's word from the
//! rank that holds the other end's row.
//!
//! Families are symmetric, so the rows of this rank's nodes that a peer has as ghosts reach
//! exactly the peer's nodes whose rows reach them: the entries i→k this rank sends (for each
//! node of `Halo::send`, its entries to the peer's nodes, in row order) are, in the same
//! order, the reverses of the entries k→i the peer receives them for (for each ghost k of
//! `Halo::recv`, the peer's owned nodes i whose rows reach k, ascending).

use super::ranks::{Ranks, Share};
use crate::bonds::Bonds;

/// The pairing, agreed once.
#[derive(Debug, Clone, Default)]
pub struct CrossBonds {
    /// Per peer: (owned node i, entry i→k) whose word this rank sends.
    send: Vec<Vec<(usize, usize)>>,
    /// Per peer: (owned node i, entry i→k) whose reverse's word the peer sends, in its order.
    recv: Vec<Vec<(usize, usize)>>,
    /// Per peer: whether its nodes come before this rank's in the global order.
    earlier: Vec<bool>,
}

/// The other entry of a bond to a ghost k, from k's owner, when k's owner flagged k: k's
/// turn to decide the bond in the one-process order of `resolve_split_work`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GhostEntry {
    /// The owned node i and its entry i→k.
    pub node: usize,
    pub entry: usize,
    /// The word of the entry k→i.
    pub word: f64,
}

/// The other entries' words of one evaluation.
#[derive(Debug, Clone, Default)]
pub struct RemoteWords {
    /// Sorted by entry, for lookups from this rank's rows.
    by_entry: Vec<(usize, f64)>,
    /// The ghosts' entries in the global order of their ghosts, then of the owned nodes:
    /// those of the ghosts before this rank's nodes, and of those after them.
    pub earlier: Vec<GhostEntry>,
    pub later: Vec<GhostEntry>,
}

impl RemoteWords {
    /// The word of the other entry of this rank's entry `e` to a ghost.
    pub fn word(&self, e: usize) -> f64 {
        let k = self
            .by_entry
            .binary_search_by_key(&e, |&(entry, _)| entry)
            .expect("every bond to a ghost has its other entry on the ghost's owner");
        self.by_entry[k].1
    }
}

impl CrossBonds {
    /// The pairing of `share`'s rows (`bonds`: its owned nodes' rows; its ghosts' are empty).
    pub fn new(bonds: &Bonds, share: &Share) -> Self {
        let (owned, halo) = (share.owned, &share.halo);
        let ghosts = bonds.nodes() - owned;
        let mut peer_of = vec![usize::MAX; ghosts];
        for (p, nodes) in halo.recv.iter().enumerate() {
            for &k in nodes {
                peer_of[k as usize - owned] = p;
            }
        }
        let send = halo
            .send
            .iter()
            .enumerate()
            .map(|(p, nodes)| {
                nodes
                    .iter()
                    .flat_map(|&i| bonds.family(i as usize).map(move |e| (i as usize, e)))
                    .filter(|&(_, e)| {
                        let k = bonds.neighbors[e] as usize;
                        k >= owned && peer_of[k - owned] == p
                    })
                    .collect()
            })
            .collect();
        // Each ghost's entries: the owned rows that reach it, in ascending order.
        let mut of_ghost: Vec<Vec<(usize, usize)>> = vec![Vec::new(); ghosts];
        for i in 0..owned {
            for e in bonds.family(i) {
                let k = bonds.neighbors[e] as usize;
                if k >= owned {
                    of_ghost[k - owned].push((i, e));
                }
            }
        }
        let recv = halo
            .recv
            .iter()
            .map(|nodes| {
                nodes
                    .iter()
                    .flat_map(|&k| of_ghost[k as usize - owned].iter().copied())
                    .collect()
            })
            .collect();
        let rank = share.ranks.rank();
        let earlier = halo.peers.iter().map(|&p| p < rank).collect();
        CrossBonds {
            send,
            recv,
            earlier,
        }
    }

    /// Swaps `words` f64 per entry with the peers: `pack(i, e, buf)` appends those of this
    /// rank's entry e of node i, and `unpack(earlier, i, e, words)` hands this rank's entry
    /// e (of owned node i) the words of its reverse, `earlier` when the reverse's node comes
    /// before this rank's nodes in the global order.
    pub fn swap(
        &self,
        ranks: &dyn Ranks,
        peers: &[usize],
        words: usize,
        pack: impl Fn(usize, usize, &mut Vec<f64>),
        mut unpack: impl FnMut(bool, usize, usize, &[f64]),
    ) {
        let send: Vec<Vec<f64>> = self
            .send
            .iter()
            .map(|entries| {
                let mut buf = Vec::with_capacity(entries.len() * words);
                for &(i, e) in entries {
                    pack(i, e, &mut buf);
                }
                buf
            })
            .collect();
        let mut recv: Vec<Vec<f64>> = self
            .recv
            .iter()
            .map(|r| vec![0.0; words * r.len()])
            .collect();
        ranks.swap(peers, &send, &mut recv);
        for ((pairs, got), &earlier) in self.recv.iter().zip(&recv).zip(&self.earlier) {
            for (&(i, e), w) in pairs.iter().zip(got.chunks_exact(words)) {
                unpack(earlier, i, e, w);
            }
        }
    }

    /// The other entries' words (the first of `words` per entry of `history`), and whether
    /// their nodes take a turn (`flagged`: owned nodes, ascending).
    pub fn exchange(
        &self,
        ranks: &dyn Ranks,
        peers: &[usize],
        bonds: &Bonds,
        (history, words): (&[f64], usize),
        flagged: &[usize],
    ) -> RemoteWords {
        let mut remote = RemoteWords::default();
        let pack = |i: usize, e: usize, buf: &mut Vec<f64>| {
            let turn = flagged.binary_search(&i).is_ok();
            buf.extend([history[e * words], f64::from(u8::from(turn))]);
        };
        self.swap(ranks, peers, 2, pack, |earlier, node, entry, got| {
            let (word, turn) = (got[0], got[1] != 0.0);
            remote.by_entry.push((entry, word));
            let turn = turn.then_some(GhostEntry { node, entry, word });
            match earlier {
                true => remote.earlier.extend(turn),
                false => remote.later.extend(turn),
            }
        });
        remote.by_entry.sort_unstable_by_key(|&(e, _)| e);
        // Ghosts in local order are in global order; each ghost's nodes are ascending.
        let key = |t: &GhostEntry| (bonds.neighbors[t.entry], t.node);
        remote.earlier.sort_by_key(key);
        remote.later.sort_by_key(key);
        remote
    }
}
