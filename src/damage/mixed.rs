//! Different damage laws in different blocks. Each half of a bond follows the law of the node
//! that owns it, so a bond between two blocks fails half by half (see `docs/models.md`,
//! "Bonds between blocks"). The history holds every law's record: [s_max | work record].

use super::{CriticalEnergy, CriticalStretch, DamageLaw, Softening, Stretch, Work};

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
}

/// Where each law keeps its record in the mixed history.
const STRETCH: std::ops::Range<usize> = 0..1;
const WORK: std::ops::RangeFrom<usize> = 1..;

impl DamageLaw for MixedDamage {
    const HISTORY: usize = 1 + CriticalEnergy::HISTORY;
    const HISTORY_VECTOR: usize = 1 + CriticalEnergy::HISTORY_VECTOR;
    const ON_STRETCH: bool = true;
    const ON_WORK: bool = true;
    const PARTIAL: bool = true;

    #[inline(always)]
    fn record_stretch(&self, st: Stretch, h: &mut [f64]) {
        super::softening::record_largest(st, &mut h[STRETCH]);
    }

    #[inline(always)]
    fn fails_on_stretch(&self, node: usize, st: Stretch, h: &[f64]) -> bool {
        match self.law(node) {
            BlockLaw::CriticalStretch(l) => l.fails_on_stretch(node, st, &[]),
            BlockLaw::Softening(l) => l.fails_on_stretch(node, st, &h[STRETCH]),
            BlockLaw::CriticalEnergy(_) => false,
        }
    }

    #[inline(always)]
    fn record_work(&self, work: Work, h: &mut [f64]) {
        super::critical_energy::accumulate_work(work, &mut h[WORK]);
    }

    #[inline(always)]
    fn fails_on_work(&self, node: usize, extension: f64, weight: f64, h: &[f64]) -> bool {
        match self.law(node) {
            BlockLaw::CriticalEnergy(l) => l.fails_on_work(node, extension, weight, &h[WORK]),
            _ => false,
        }
    }

    #[inline(always)]
    fn factor(&self, node: usize, h: &[f64]) -> f64 {
        match self.law(node) {
            BlockLaw::Softening(l) => l.factor(node, &h[STRETCH]),
            _ => 1.0,
        }
    }
}
