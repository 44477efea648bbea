//! Different damage laws in different blocks. Each half of a bond follows the law of the node
//! that owns it, so a bond between two blocks fails half by half (see `docs/models.md`,
//! "Bonds between blocks").
//!
//! The engine runs `MixedLaws<SOFTENS, WORKS>`, the form that stores and does only what the
//! body's laws need: the largest stretch when a block softens, the work record when a block
//! breaks on energy. History per bond: [s_max if SOFTENS | work record if WORKS].

use super::{BondForce, CriticalEnergy, CriticalStretch, DamageLaw, Softening, Stretch, Work};

/// One block's law.
#[derive(Debug, Clone)]
pub enum BlockLaw {
    CriticalStretch(CriticalStretch),
    CriticalEnergy(CriticalEnergy),
    Softening(Softening),
}

/// Laws per block and the block of each node.
#[derive(Debug, Clone)]
pub struct MixedDamage {
    pub laws: Vec<BlockLaw>,
    /// Index into `laws` of each node.
    pub law_of: Vec<u16>,
}

impl MixedDamage {
    #[inline(always)]
    fn law(&self, node: usize) -> &BlockLaw {
        &self.laws[self.law_of[node] as usize]
    }

    /// Node i's softening parameters, if its block softens.
    pub fn softening_at(&self, node: usize) -> Option<super::softening::UniformSoftening> {
        match self.law(node) {
            BlockLaw::Softening(s) => Some(s.at(node)),
            _ => None,
        }
    }

    /// A block softens: bonds keep their largest stretch.
    pub fn softens(&self) -> bool {
        self.laws
            .iter()
            .any(|l| matches!(l, BlockLaw::Softening(_)))
    }

    /// A block breaks bonds on energy: bonds keep their work record.
    pub fn records_work(&self) -> bool {
        self.laws
            .iter()
            .any(|l| matches!(l, BlockLaw::CriticalEnergy(_)))
    }

    /// f64 words of history per bond for a material whose pair force is `force`.
    pub fn history_words(&self, force: BondForce) -> usize {
        history_words(
            self.softens(),
            self.records_work(),
            matches!(force, BondForce::Linear | BondForce::Central),
        )
    }

    /// (μ_ij, μ_ji) of a bond entry (see `DamageLaw::factors`).
    pub fn factors(&self, i: usize, j: usize, history: &[f64], status: u8) -> (f64, f64) {
        match (self.softens(), self.records_work()) {
            (false, false) => MixedLaws::<false, false>(self).factors(i, j, history, status),
            (false, true) => MixedLaws::<false, true>(self).factors(i, j, history, status),
            (true, false) => MixedLaws::<true, false>(self).factors(i, j, history, status),
            (true, true) => MixedLaws::<true, true>(self).factors(i, j, history, status),
        }
    }
}

/// History words of a mixed law that softens and/or records work, for a central material or
/// not (a mixed law keeps the work record for linear bonds too: its halves break apart).
pub const fn history_words(softens: bool, works: bool, central: bool) -> usize {
    let work = if !works {
        0
    } else if central {
        CriticalEnergy::HISTORY
    } else {
        CriticalEnergy::HISTORY_VECTOR
    };
    softens as usize + work
}

/// The mixed law with the history and passes of the laws it holds (see the module notes).
#[derive(Clone, Copy)]
pub struct MixedLaws<'a, const SOFTENS: bool, const WORKS: bool>(pub &'a MixedDamage);

impl<const SOFTENS: bool, const WORKS: bool> MixedLaws<'_, SOFTENS, WORKS> {
    /// Where each law keeps its record in the history.
    const STRETCH: std::ops::Range<usize> = 0..SOFTENS as usize;
    const WORK: std::ops::RangeFrom<usize> = SOFTENS as usize..;
}

impl<const SOFTENS: bool, const WORKS: bool> DamageLaw for MixedLaws<'_, SOFTENS, WORKS> {
    const HISTORY: usize = history_words(SOFTENS, WORKS, true);
    const HISTORY_VECTOR: usize = history_words(SOFTENS, WORKS, false);
    const ON_STRETCH: bool = true;
    const ON_WORK: bool = WORKS;
    const PARTIAL: bool = SOFTENS;

    #[inline(always)]
    fn record_stretch(&self, st: Stretch, h: &mut [f64]) {
        if SOFTENS {
            super::softening::record_largest(st, &mut h[Self::STRETCH]);
        }
    }

    #[inline(always)]
    fn fails_on_stretch(&self, node: usize, st: Stretch, h: &[f64]) -> bool {
        match self.0.law(node) {
            BlockLaw::CriticalStretch(l) => l.fails_on_stretch(node, st, &[]),
            BlockLaw::Softening(l) => SOFTENS && l.fails_on_stretch(node, st, &h[Self::STRETCH]),
            BlockLaw::CriticalEnergy(_) => false,
        }
    }

    #[inline(always)]
    fn record_work(&self, work: Work, h: &mut [f64]) -> f64 {
        if WORKS {
            super::critical_energy::accumulate_work(work, &mut h[Self::WORK])
        } else {
            0.0
        }
    }

    #[inline(always)]
    fn fails_on_work(&self, node: usize, extension: f64, weight: f64, work: f64) -> bool {
        match self.0.law(node) {
            BlockLaw::CriticalEnergy(l) => WORKS && l.fails_on_work(node, extension, weight, work),
            _ => false,
        }
    }

    #[inline(always)]
    fn factor(&self, node: usize, h: &[f64]) -> f64 {
        match self.0.law(node) {
            BlockLaw::Softening(l) if SOFTENS => l.factor(node, &h[Self::STRETCH]),
            _ => 1.0,
        }
    }
}
