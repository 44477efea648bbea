//! `Ranks` over MPI (the `mpi` crate, rsmpi; Open MPI or MPICH underneath). Only the
//! process's world communicator, fetched per call: the handle stays `Send + Sync`, and the
//! calls come from whichever thread drives the run, one at a time (MPI initialised with
//! `Threading::Serialized`).

use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Count;
use peridyn::solver::ranks::Ranks;

/// The world's ranks.
#[derive(Debug, Clone, Copy)]
pub struct MpiRanks {
    rank: usize,
    size: usize,
}

/// Tags of the point-to-point messages (collectives need none).
const CHAIN_TAG: i32 = 11;
const HALO_TAG: i32 = 12;
const SCATTER_TAG: i32 = 13;
const GATHER_EACH_TAG: i32 = 14;

impl MpiRanks {
    /// The world of an initialised MPI.
    pub fn world() -> Self {
        let w = SimpleCommunicator::world();
        MpiRanks {
            rank: w.rank() as usize,
            size: w.size() as usize,
        }
    }
}

impl Ranks for MpiRanks {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn chain(&self, local: &mut dyn FnMut(Option<f64>) -> f64) -> f64 {
        let w = SimpleCommunicator::world();
        let before = (self.rank > 0).then(|| {
            let mut a = 0.0f64;
            w.process_at_rank(self.rank as i32 - 1)
                .receive_into_with_tag(&mut a, CHAIN_TAG);
            a
        });
        let mut acc = local(before);
        if self.rank + 1 < self.size {
            w.process_at_rank(self.rank as i32 + 1)
                .send_with_tag(&acc, CHAIN_TAG);
        }
        w.process_at_rank(self.size as i32 - 1)
            .broadcast_into(&mut acc);
        acc
    }

    fn chain_words(
        &self,
        words: usize,
        local: &mut dyn FnMut(Option<&[f64]>) -> Vec<f64>,
    ) -> Vec<f64> {
        let w = SimpleCommunicator::world();
        let before = (self.rank > 0).then(|| {
            let mut a = vec![0.0f64; words];
            w.process_at_rank(self.rank as i32 - 1)
                .receive_into_with_tag(&mut a[..], CHAIN_TAG);
            a
        });
        let mut acc = local(before.as_deref());
        assert_eq!(acc.len(), words, "a chain of {words} words");
        if self.rank + 1 < self.size {
            w.process_at_rank(self.rank as i32 + 1)
                .send_with_tag(&acc[..], CHAIN_TAG);
        }
        w.process_at_rank(self.size as i32 - 1)
            .broadcast_into(&mut acc[..]);
        acc
    }

    fn sum_u64(&self, x: u64) -> u64 {
        let mut y = 0u64;
        SimpleCommunicator::world().all_reduce_into(&x, &mut y, SystemOperation::sum());
        y
    }

    fn min_f64(&self, x: f64) -> f64 {
        let mut y = 0.0f64;
        SimpleCommunicator::world().all_reduce_into(&x, &mut y, SystemOperation::min());
        y
    }

    fn max_f64(&self, x: f64) -> f64 {
        let mut y = 0.0f64;
        SimpleCommunicator::world().all_reduce_into(&x, &mut y, SystemOperation::max());
        y
    }

    fn swap(&self, peers: &[usize], send: &[Vec<f64>], recv: &mut [Vec<f64>]) {
        let w = SimpleCommunicator::world();
        mpi::request::scope(|scope| {
            let sends: Vec<_> = peers
                .iter()
                .zip(send)
                .map(|(&p, buf)| {
                    w.process_at_rank(p as i32)
                        .immediate_send_with_tag(scope, &buf[..], HALO_TAG)
                })
                .collect();
            for (&p, buf) in peers.iter().zip(recv.iter_mut()) {
                w.process_at_rank(p as i32)
                    .receive_into_with_tag(&mut buf[..], HALO_TAG);
            }
            for s in sends {
                s.wait();
            }
        });
    }

    fn first_message(&self, local: Option<String>) -> Option<String> {
        let w = SimpleCommunicator::world();
        let mine = if local.is_some() {
            self.rank as u64
        } else {
            u64::MAX
        };
        let mut first = 0u64;
        w.all_reduce_into(&mine, &mut first, SystemOperation::min());
        if first == u64::MAX {
            return None;
        }
        let root = w.process_at_rank(first as i32);
        let bytes = local.unwrap_or_default().into_bytes();
        let mut len = bytes.len() as u64;
        root.broadcast_into(&mut len);
        let mut buf = if self.rank as u64 == first {
            bytes
        } else {
            vec![0u8; len as usize]
        };
        root.broadcast_into(&mut buf[..]);
        Some(String::from_utf8_lossy(&buf).into_owned())
    }

    fn gather(&self, local: &[f64]) -> Option<Vec<f64>> {
        let w = SimpleCommunicator::world();
        let root = w.process_at_rank(0);
        let count = local.len() as Count;
        if self.rank == 0 {
            let mut counts = vec![0 as Count; self.size];
            root.gather_into_root(&count, &mut counts[..]);
            let displs = offsets(&counts);
            let total: Count = counts.iter().sum();
            let mut all = vec![0.0f64; total as usize];
            {
                let mut partition = PartitionMut::new(&mut all[..], counts, &displs[..]);
                root.gather_varcount_into_root(local, &mut partition);
            }
            Some(all)
        } else {
            root.gather_into(&count);
            root.gather_varcount_into(local);
            None
        }
    }

    fn gather_each(&self, local: &[f64], each: &mut dyn FnMut(&[f64])) {
        let w = SimpleCommunicator::world();
        if self.rank == 0 {
            each(local);
            for r in 1..self.size {
                let (part, _) = w
                    .process_at_rank(r as i32)
                    .receive_vec_with_tag::<f64>(GATHER_EACH_TAG);
                each(&part);
            }
        } else {
            w.process_at_rank(0).send_with_tag(local, GATHER_EACH_TAG);
        }
    }

    fn scatter(&self, part: &mut dyn FnMut(usize) -> Vec<f64>) -> Vec<f64> {
        let w = SimpleCommunicator::world();
        if self.rank == 0 {
            for r in 1..self.size {
                w.process_at_rank(r as i32)
                    .send_with_tag(&part(r)[..], SCATTER_TAG);
            }
            part(0)
        } else {
            w.process_at_rank(0).receive_vec_with_tag(SCATTER_TAG).0
        }
    }

    fn broadcast_bool(&self, x: bool) -> bool {
        let mut b = x as u8;
        SimpleCommunicator::world()
            .process_at_rank(0)
            .broadcast_into(&mut b);
        b != 0
    }

    fn all_gather(&self, local: &[f64]) -> Vec<f64> {
        let w = SimpleCommunicator::world();
        let count = local.len() as Count;
        let mut counts = vec![0 as Count; self.size];
        w.all_gather_into(&count, &mut counts[..]);
        let displs = offsets(&counts);
        let total: Count = counts.iter().sum();
        let mut all = vec![0.0f64; total as usize];
        {
            let mut partition = PartitionMut::new(&mut all[..], counts, &displs[..]);
            w.all_gather_varcount_into(local, &mut partition);
        }
        all
    }

    fn abort(&self, code: i32) -> ! {
        SimpleCommunicator::world().abort(code)
    }
}

/// Where each rank's part starts in the gathered buffer: the sums of the counts before it.
fn offsets(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |acc, &c| {
            let d = *acc;
            *acc += c;
            Some(d)
        })
        .collect()
}
