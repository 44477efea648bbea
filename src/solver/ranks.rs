//! A simulation distributed over several processes (ranks): what a rank's share of the run
//! needs of the others, as a trait (the transport over MPI is the `mpi/` package's), and the
//! halo of ghost nodes a share reads.
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
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// The other ranks of a distributed run, seen from one.
pub trait Ranks: Send + Sync {
    fn rank(&self) -> usize;
    fn size(&self) -> usize;
    /// Continues a left fold across the ranks in rank order: rank 0 calls `local(None)`, rank
    /// r `local(Some(a))` with rank r − 1's result a; every rank returns the last rank's.
    fn chain(&self, local: &mut dyn FnMut(Option<f64>) -> f64) -> f64;
    /// `chain` of `words` numbers: rank 0 calls `local(None)`, rank r `local(Some(a))` with
    /// rank r − 1's `words` results a; every rank returns the last rank's.
    fn chain_words(
        &self,
        words: usize,
        local: &mut dyn FnMut(Option<&[f64]>) -> Vec<f64>,
    ) -> Vec<f64>;
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
    /// Every rank's `local` handed to `each` on rank 0, in rank order, one rank's at a time
    /// (rank 0 never holds two); the other ranks only send theirs.
    fn gather_each(&self, local: &[f64], each: &mut dyn FnMut(&[f64]));
    /// Rank 0's `x` on every rank.
    fn broadcast_bool(&self, x: bool) -> bool;
    /// Rank r's part from rank 0: rank 0 calls `part(r)` for every rank, one at a time (so it
    /// holds one part at once), and each rank returns its own (the others never call `part`).
    fn scatter(&self, part: &mut dyn FnMut(usize) -> Vec<f64>) -> Vec<f64>;
    /// Every rank's `local` on every rank, in rank order.
    fn all_gather(&self, local: &[f64]) -> Vec<f64>;
    /// Ends every rank's process after an error on this one alone (the others may be waiting
    /// for it in a collective).
    fn abort(&self, code: i32) -> !;
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
    /// Nanoseconds spent in the swaps so far (waiting for the peers included), shared by the
    /// clones of the halo: the run's exchange time in its summary.
    pub waited: Arc<AtomicU64>,
}

impl Halo {
    /// Ghost nodes of this rank.
    pub fn ghosts(&self) -> usize {
        self.recv.iter().map(Vec::len).sum()
    }

    /// Seconds spent in the halo's swaps so far.
    pub fn seconds_waited(&self) -> f64 {
        self.waited.load(Ordering::Relaxed) as f64 * 1e-9
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
        let started = Instant::now();
        ranks.swap(&self.peers, &send, &mut recv);
        self.waited
            .fetch_add(started.elapsed().as_nanos() as u64, Ordering::Relaxed);
        for (nodes, buf) in self.recv.iter().zip(&recv) {
            for (&i, w) in nodes.iter().zip(buf.chunks_exact(words)) {
                unpack(i as usize, w);
            }
        }
    }
}

/// Bytes (bond status) as f64 words for the transport, eight to a word bit for bit, after
/// the exact byte count: an eighth of the words one byte per word takes.
pub fn bytes_to_words(bytes: &[u8]) -> Vec<f64> {
    let mut words = Vec::with_capacity(1 + bytes.len().div_ceil(8));
    words.push(bytes.len() as f64);
    words.extend(bytes.chunks(8).map(|c| {
        let mut b = [0u8; 8];
        b[..c.len()].copy_from_slice(c);
        f64::from_bits(u64::from_le_bytes(b))
    }));
    words
}

/// One `bytes_to_words` read off the front of `words`: the bytes, and the words after them.
pub fn bytes_from_words(words: &[f64]) -> (Vec<u8>, &[f64]) {
    let n = words[0] as usize;
    let (packed, rest) = words[1..].split_at(n.div_ceil(8));
    let mut bytes: Vec<u8> = packed
        .iter()
        .flat_map(|w| w.to_bits().to_le_bytes())
        .collect();
    bytes.truncate(n);
    (bytes, rest)
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

/// `W` left folds over the owned nodes at once, each from `start` on rank 0 and continued
/// from rank to rank (a loop `for i { add(i, &mut acc) }` over every node of the body, `add`
/// adding node i's terms to the accumulators in place; i is a local index).
pub fn ordered_folds<const W: usize>(
    share: Option<&Share>,
    nodes: usize,
    start: [f64; W],
    add: impl Fn(usize, &mut [f64; W]),
) -> [f64; W] {
    let fold = |mut acc: [f64; W]| {
        for i in 0..nodes {
            add(i, &mut acc);
        }
        acc
    };
    match share {
        None => fold(start),
        Some(s) => {
            let all = s.ranks.chain_words(W, &mut |before| {
                let acc = before.map_or(start, |b| std::array::from_fn(|k| b[k]));
                fold(acc).to_vec()
            });
            std::array::from_fn(|k| all[k])
        }
    }
}

/// `W` sums over the nodes as one process takes them in fixed chunks of `chunk` nodes of
/// the global order (the same for any thread count): each chunk's accumulators start at
/// `start` and take its nodes' terms in order (`add(i, &mut acc)`, i a local index), and the
/// chunks' accumulators are added in chunk order to totals that start at `start`. `nodes`:
/// the nodes summed (the owned ones of a share). A chunk that spans ranks is continued from
/// rank to rank with the totals, so the additions are the one process's for any number of
/// ranks; the chunks inside a rank are summed in parallel.
pub fn chunked_sums<const W: usize>(
    share: Option<&Share>,
    nodes: usize,
    chunk: usize,
    start: [f64; W],
    add: impl Fn(usize, &mut [f64; W]) + Sync,
) -> [f64; W] {
    let (first, total) = share.map_or((0, nodes), |s| (s.first, s.global_nodes));
    let end = first + nodes;
    // This rank's pieces of the chunks, in global indices: (start, end, whether the piece
    // ends its chunk).
    let pieces: Vec<(usize, usize, bool)> = (first / chunk..end.div_ceil(chunk))
        .map(|c| {
            let (lo, hi) = (c * chunk, ((c + 1) * chunk).min(total));
            (lo.max(first), hi.min(end), hi <= end)
        })
        .filter(|&(lo, hi, _)| lo < hi)
        .collect();
    let piece = |mut acc: [f64; W], lo: usize, hi: usize| {
        for i in lo - first..hi - first {
            add(i, &mut acc);
        }
        acc
    };
    // The first piece continues the previous rank's chunk when it starts inside one.
    let continued = first % chunk != 0 && !pieces.is_empty();
    let own: Vec<[f64; W]> = pieces[continued as usize..]
        .par_iter()
        .map(|&(lo, hi, _)| piece(start, lo, hi))
        .collect();
    // (totals of the finished chunks, the open chunk's accumulators).
    let combine = |mut totals: [f64; W], mut open: [f64; W]| {
        let mut finished = |acc: &[f64; W]| {
            for (t, a) in totals.iter_mut().zip(acc) {
                *t += a;
            }
        };
        if continued {
            let (lo, hi, ends) = pieces[0];
            open = piece(open, lo, hi);
            if ends {
                finished(&open);
            }
        }
        let tail = &pieces[continued as usize..];
        for (acc, &(_, _, ends)) in own.iter().zip(tail) {
            if ends {
                finished(acc);
            } else {
                open = *acc;
            }
        }
        (totals, open)
    };
    match share {
        None => combine(start, start).0,
        Some(s) => {
            let all = s.ranks.chain_words(2 * W, &mut |before| {
                let (totals, open) = match before {
                    None => (start, start),
                    Some(b) => (
                        std::array::from_fn(|k| b[k]),
                        std::array::from_fn(|k| b[W + k]),
                    ),
                };
                let (totals, open) = combine(totals, open);
                totals.iter().chain(&open).copied().collect()
            });
            std::array::from_fn(|k| all[k])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bond status bytes of any length, packed eight to a word and read back in a row (as
    /// rank 0 reads the ranks' parts), are the same bytes; the words are an eighth as many.
    #[test]
    fn bytes_travel_eight_to_a_word() {
        let parts: Vec<Vec<u8>> = [0usize, 1, 7, 8, 9, 23]
            .iter()
            .map(|&n| (0..n).map(|i| (i * 37 % 256) as u8).collect())
            .collect();
        let words: Vec<f64> = parts.iter().flat_map(|p| bytes_to_words(p)).collect();
        assert_eq!(words.len(), parts.len() + (1 + 1 + 1 + 2 + 3));
        let mut rest = &words[..];
        for p in &parts {
            let (bytes, after) = bytes_from_words(rest);
            assert_eq!(&bytes, p);
            rest = after;
        }
        assert!(rest.is_empty());
        // Every byte value, NaN-pattern words included, comes back bit for bit.
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(bytes_from_words(&bytes_to_words(&all)).0, all);
    }

    /// What every rank returns when the ranks own the node ranges starting at `starts`
    /// (ranks as threads of this process): the last rank's result, which all must share.
    fn over_ranks<const W: usize>(
        terms: &[[f64; W]],
        starts: &[usize],
        run: impl Fn(&Share, &[[f64; W]]) -> [f64; W] + Sync,
    ) -> [f64; W] {
        let n = terms.len();
        let results = crate::distributed::thread_ranks::ThreadRanks::run(starts.len(), |ranks| {
            let r = ranks.rank();
            let first = starts[r];
            let end = starts.get(r + 1).copied().unwrap_or(n);
            let share = Share {
                ranks,
                first,
                owned: end - first,
                global_nodes: n,
                halo: Halo::default(),
            };
            run(&share, &terms[first..end])
        });
        let last = results[results.len() - 1];
        for r in &results {
            assert_eq!(
                r.map(f64::to_bits),
                last.map(f64::to_bits),
                "every rank the last's"
            );
        }
        last
    }

    /// Terms of very different sizes and signs: any other order of the additions rounds
    /// differently.
    fn terms(n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let h = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                let x = ((h >> 11) as f64 / (1u64 << 53) as f64) - 0.3;
                [x * 10f64.powi((i % 17) as i32 - 8), x.sin()]
            })
            .collect()
    }

    #[test]
    fn chunked_sums_continue_the_one_process_chunks_across_ranks() {
        let chunk = 4096;
        for n in [700, 4096, 9000, 13_000] {
            let t = terms(n);
            // The one process's sums: chunks in parallel, each a left fold, then in order.
            let parts: Vec<[f64; 2]> = t
                .par_chunks(chunk)
                .map(|c| c.iter().fold([0.0, 0.0], |[a, b], [x, y]| [a + x, b + y]))
                .collect();
            let expected = parts
                .iter()
                .fold([0.0, 0.0], |[a, b], [x, y]| [a + x, b + y]);
            let add = |t: &[[f64; 2]]| {
                let t = t.to_vec();
                move |i: usize, acc: &mut [f64; 2]| {
                    acc[0] += t[i][0];
                    acc[1] += t[i][1];
                }
            };
            let one = chunked_sums(None, n, chunk, [0.0, 0.0], add(&t));
            assert_eq!(one.map(f64::to_bits), expected.map(f64::to_bits), "{n}");
            // Ranks starting at multiples of 256 (the force engine's node chunk), inside
            // and at the chunks' bounds.
            for starts in [
                vec![0, 256],
                vec![0, 512, 4096],
                vec![0, 256, 512],
                vec![0, 3840, 4352, 8448],
            ] {
                if starts.iter().any(|&s| s >= n) {
                    continue;
                }
                let got = over_ranks(&t, &starts, |share, mine| {
                    chunked_sums(Some(share), mine.len(), chunk, [0.0, 0.0], add(mine))
                });
                assert_eq!(
                    got.map(f64::to_bits),
                    expected.map(f64::to_bits),
                    "{n} nodes, ranks from {starts:?}"
                );
                let got = over_ranks(&t, &starts, |share, mine| {
                    ordered_folds(Some(share), mine.len(), [0.0, 0.0], add(mine))
                });
                let fold = ordered_folds(None, n, [0.0, 0.0], add(&t));
                assert_eq!(got.map(f64::to_bits), fold.map(f64::to_bits));
            }
        }
    }
}
