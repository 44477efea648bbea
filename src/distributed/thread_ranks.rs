//! `Ranks` as threads of one process, for tests: each rank runs on its own thread and its
//! calls meet the others' through mailboxes (one queue per sender, receiver and kind of
//! call), so the distributed code can be run on several ranks without MPI.

use crate::solver::ranks::Ranks;
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Condvar, Mutex};

/// What a message belongs to (collectives and point-to-point swaps never mix).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Kind {
    Swap,
    Chain,
    Collective,
}

/// The messages not yet received, per (sender, receiver, kind), in the order sent.
type Mailboxes = HashMap<(usize, usize, Kind), VecDeque<Vec<f64>>>;

#[derive(Default)]
struct Hub {
    boxes: Mutex<Mailboxes>,
    arrived: Condvar,
}

/// One rank of a group of threads.
pub struct ThreadRanks {
    rank: usize,
    size: usize,
    hub: Arc<Hub>,
}

impl ThreadRanks {
    /// Runs `f` on `size` ranks, one thread each; their results in rank order.
    pub fn run<T: Send>(size: usize, f: impl Fn(Arc<dyn Ranks>) -> T + Sync) -> Vec<T> {
        let hub = Arc::new(Hub::default());
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..size)
                .map(|rank| {
                    let ranks: Arc<dyn Ranks> = Arc::new(ThreadRanks {
                        rank,
                        size,
                        hub: hub.clone(),
                    });
                    let f = &f;
                    s.spawn(move || f(ranks))
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        })
    }

    fn send(&self, to: usize, kind: Kind, words: Vec<f64>) {
        let mut boxes = self.hub.boxes.lock().unwrap();
        boxes
            .entry((self.rank, to, kind))
            .or_default()
            .push_back(words);
        self.hub.arrived.notify_all();
    }

    fn receive(&self, from: usize, kind: Kind) -> Vec<f64> {
        let mut boxes = self.hub.boxes.lock().unwrap();
        loop {
            if let Some(w) = boxes
                .get_mut(&(from, self.rank, kind))
                .and_then(VecDeque::pop_front)
            {
                return w;
            }
            boxes = self.hub.arrived.wait(boxes).unwrap();
        }
    }

    /// Every rank's words, in rank order, on every rank.
    fn everyone(&self, local: &[f64]) -> Vec<Vec<f64>> {
        for to in (0..self.size).filter(|&q| q != self.rank) {
            self.send(to, Kind::Collective, local.to_vec());
        }
        (0..self.size)
            .map(|q| {
                if q == self.rank {
                    local.to_vec()
                } else {
                    self.receive(q, Kind::Collective)
                }
            })
            .collect()
    }
}

impl Ranks for ThreadRanks {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.size
    }
    fn chain(&self, local: &mut dyn FnMut(Option<f64>) -> f64) -> f64 {
        let before = (self.rank > 0).then(|| self.receive(self.rank - 1, Kind::Chain)[0]);
        let acc = local(before);
        if self.rank + 1 < self.size {
            self.send(self.rank + 1, Kind::Chain, vec![acc]);
        }
        self.everyone(&[acc])[self.size - 1][0]
    }
    fn chain_words(
        &self,
        words: usize,
        local: &mut dyn FnMut(Option<&[f64]>) -> Vec<f64>,
    ) -> Vec<f64> {
        let before = (self.rank > 0).then(|| self.receive(self.rank - 1, Kind::Chain));
        let acc = local(before.as_deref());
        debug_assert_eq!(acc.len(), words);
        if self.rank + 1 < self.size {
            self.send(self.rank + 1, Kind::Chain, acc.clone());
        }
        self.everyone(&acc).swap_remove(self.size - 1)
    }
    fn sum_u64(&self, x: u64) -> u64 {
        self.everyone(&[x as f64]).iter().map(|w| w[0] as u64).sum()
    }
    fn min_f64(&self, x: f64) -> f64 {
        self.everyone(&[x]).iter().map(|w| w[0]).fold(x, f64::min)
    }
    fn max_f64(&self, x: f64) -> f64 {
        self.everyone(&[x]).iter().map(|w| w[0]).fold(x, f64::max)
    }
    fn swap(&self, peers: &[usize], send: &[Vec<f64>], recv: &mut [Vec<f64>]) {
        for (&p, buf) in peers.iter().zip(send) {
            self.send(p, Kind::Swap, buf.clone());
        }
        for (&p, buf) in peers.iter().zip(recv.iter_mut()) {
            let w = self.receive(p, Kind::Swap);
            assert_eq!(w.len(), buf.len(), "rank {} from {p}", self.rank);
            buf.copy_from_slice(&w);
        }
    }
    fn first_message(&self, local: Option<String>) -> Option<String> {
        let words: Vec<f64> = local
            .map(|m| m.bytes().map(f64::from).collect::<Vec<_>>())
            .map_or(vec![-1.0], |mut w| {
                w.insert(0, 0.0);
                w
            });
        self.everyone(&words)
            .into_iter()
            .find(|w| w[0] == 0.0)
            .map(|w| w[1..].iter().map(|&b| b as u8 as char).collect())
    }
    fn gather(&self, local: &[f64]) -> Option<Vec<f64>> {
        let all = self.all_gather(local);
        (self.rank == 0).then_some(all)
    }
    fn broadcast_bool(&self, x: bool) -> bool {
        self.everyone(&[x as u8 as f64])[0][0] != 0.0
    }
    fn all_gather(&self, local: &[f64]) -> Vec<f64> {
        self.everyone(local).concat()
    }
    fn abort(&self, code: i32) -> ! {
        panic!("rank {} aborted the group (code {code})", self.rank)
    }
    fn gather_each(&self, local: &[f64], each: &mut dyn FnMut(&[f64])) {
        if self.rank != 0 {
            return self.send(0, Kind::Collective, local.to_vec());
        }
        each(local);
        for from in 1..self.size {
            each(&self.receive(from, Kind::Collective));
        }
    }
    fn scatter(&self, part: &mut dyn FnMut(usize) -> Vec<f64>) -> Vec<f64> {
        if self.rank != 0 {
            return self.receive(0, Kind::Collective);
        }
        for to in 1..self.size {
            self.send(to, Kind::Collective, part(to));
        }
        part(0)
    }
}
