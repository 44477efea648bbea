//! The correspondence force pass's memo of the sums that change only with shape tensors:
//! per node, W = Σ s C1_j over its bonds that carry force, S = Σ s, and its own C1, keyed by
//! the versions of the C1s they were summed from (see `Correspondence::vector_force`).
//!
//! A node's C1 depends only on its shape tensor K, which the pre-pass recomputes only when the
//! node's set of bonds that carry force changes; each recomputation takes a fresh version from
//! one counter, which only grows. A node's key is its own version and the sum of its
//! neighbours' (exact: whole numbers below 2⁵³): when neither changed, no C1 it summed and
//! none of its weights s changed, and the memo holds what summing again would give, bit for
//! bit. Results therefore do not depend on whether a sum came from the memo, nor on threads.
//!
//! Each node's slot is written only by its own force pass; relaxed atomics make that sharing
//! safe without locks (they compile to plain loads and stores).

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Words of a node's memo: W's lower triangle from 0, its own C1's lower triangle from
/// `MEMO_C1` (kept here, on the line the force pass reads anyway, rather than read from the
/// node's point record, whose C1 no neighbour brings into the cache), S at `MEMO_SUM`.
pub const MEMO_C1: usize = 6;
pub const MEMO_SUM: usize = 12;
pub const MEMO_WORDS: usize = 13;

/// A slot: the memo, then its key (the neighbours' version sum and the node's own version),
/// one word of padding: two cache lines.
#[repr(C, align(64))]
struct Slot([AtomicU64; 16]);

const KEY: usize = MEMO_WORDS;

/// Bytes of memo per node.
pub const SLOT_BYTES: usize = std::mem::size_of::<Slot>();

impl Slot {
    fn empty() -> Self {
        // NaN keys equal no sum of versions.
        Slot(std::array::from_fn(|_| AtomicU64::new(f64::NAN.to_bits())))
    }
}

pub struct StabilisationMemo {
    /// The last version handed out.
    versions: AtomicU64,
    slots: Vec<Slot>,
}

impl StabilisationMemo {
    /// Empty slots for `nodes` nodes.
    pub fn new(nodes: usize) -> Self {
        StabilisationMemo {
            versions: AtomicU64::new(0),
            slots: (0..nodes).map(|_| Slot::empty()).collect(),
        }
    }

    /// A version no C1 had before (as f64: exact below 2⁵³).
    pub fn next_version(&self) -> f64 {
        (self.versions.fetch_add(1, Relaxed) + 1) as f64
    }

    /// Node i's memo if it was stored under `key`.
    pub fn get(&self, i: usize, key: [f64; 2]) -> Option<[f64; MEMO_WORDS]> {
        let slot = &self.slots.get(i)?.0;
        let same = (0..2).all(|k| slot[KEY + k].load(Relaxed) == key[k].to_bits());
        same.then(|| std::array::from_fn(|k| f64::from_bits(slot[k].load(Relaxed))))
    }

    /// Stores node i's memo under `key`.
    pub fn set(&self, i: usize, key: [f64; 2], memo: &[f64; MEMO_WORDS]) {
        if let Some(Slot(slot)) = self.slots.get(i) {
            for (word, value) in slot.iter().zip(memo.iter().chain(&key)) {
                word.store(value.to_bits(), Relaxed);
            }
        }
    }

    /// Asks for node i's slot (a hint).
    pub fn prefetch(&self, i: usize) {
        if let Some(slot) = self.slots.get(i) {
            super::simd::prefetch(slot);
            super::simd::prefetch(&slot.0[8]);
        }
    }
}

/// A copy starts with empty slots and goes on from the same version, so that its versions
/// are newer than any in the point states made so far.
impl Clone for StabilisationMemo {
    fn clone(&self) -> Self {
        StabilisationMemo {
            versions: AtomicU64::new(self.versions.load(Relaxed)),
            slots: (0..self.slots.len()).map(|_| Slot::empty()).collect(),
        }
    }
}

impl std::fmt::Debug for StabilisationMemo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StabilisationMemo")
            .field("nodes", &self.slots.len())
            .finish()
    }
}
