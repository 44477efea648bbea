//! Critical-stretch failure (Silling & Askari 2005; seed 001, Eq. 5): a half of a bond breaks,
//! irreversibly, once the bond stretch exceeds the critical stretch s0 of the node that owns
//! it. No history.

use super::{DamageLaw, PerNode, Stretch, BROKEN, OWN_BROKEN};

/// Critical stretch s0 per node (uniform for one material and one horizon).
#[derive(Debug, Clone)]
pub struct CriticalStretch {
    pub s0: PerNode,
}

impl CriticalStretch {
    pub fn new(s0: f64) -> Self {
        CriticalStretch {
            s0: PerNode::Uniform(s0),
        }
    }

    /// Bonds never break.
    pub fn never() -> Self {
        Self::new(f64::INFINITY)
    }
}

impl DamageLaw for CriticalStretch {
    const ON_STRETCH: bool = true;

    #[inline(always)]
    fn fails_on_stretch(&self, node: usize, st: Stretch, _: &[f64]) -> bool {
        st.exceeds(self.s0.at(node))
    }

    /// With one s0 both halves break together, as one bond: one comparison.
    #[inline(always)]
    fn on_stretch(
        &self,
        i: usize,
        j: usize,
        st: Stretch,
        protected: impl Fn() -> bool,
        history: &mut [f64],
        status: &mut u8,
    ) -> u64 {
        match &self.s0 {
            PerNode::Uniform(s0) => {
                UniformCriticalStretch { s0: *s0 }.on_stretch(i, j, st, protected, history, status)
            }
            PerNode::Varying(_) if protected() => 0,
            PerNode::Varying(_) => super::break_halves(
                status,
                self.fails_on_stretch(i, st, history),
                self.fails_on_stretch(j, st, history),
            ),
        }
    }

    fn uniform_critical_stretch(&self) -> Option<f64> {
        self.s0.uniform()
    }

    fn critical_stretch_per_node(&self) -> Option<&[f64]> {
        match &self.s0 {
            PerNode::Varying(s0) => Some(s0),
            PerNode::Uniform(_) => None,
        }
    }
}

/// A critical-stretch law with one s0 for every node: both halves break together, as one
/// bond. The engine runs this form when it can (no per-node lookup in the bond loop).
#[derive(Debug, Clone, Copy)]
pub struct UniformCriticalStretch {
    pub s0: f64,
}

impl DamageLaw for UniformCriticalStretch {
    const ON_STRETCH: bool = true;
    const HALVES_TOGETHER: bool = true;

    #[inline(always)]
    fn fails_on_stretch(&self, _node: usize, st: Stretch, _: &[f64]) -> bool {
        st.exceeds(self.s0)
    }

    #[inline(always)]
    fn on_stretch(
        &self,
        _i: usize,
        _j: usize,
        st: Stretch,
        protected: impl Fn() -> bool,
        _history: &mut [f64],
        status: &mut u8,
    ) -> u64 {
        if st.exceeds(self.s0) && !protected() {
            let own = (*status & OWN_BROKEN == 0) as u64;
            *status = BROKEN;
            own
        } else {
            0
        }
    }

    fn uniform_critical_stretch(&self) -> Option<f64> {
        Some(self.s0)
    }
}
