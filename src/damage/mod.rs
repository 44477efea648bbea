//! Damage laws: when and how much a bond's force is lost. A policy of its own, combined with
//! any material; the engine (`solver::forces`) calls it for every bond it visits.
//!
//! A directed bond entry i→j carries two halves: the force state of node i on the bond
//! (T_i⟨ξ⟩, "own") and that of node j (T_j⟨−ξ⟩, "other"). Each half follows the damage law
//! of its own node, so a bond and its dual break independently (dual-horizon PD, seed 003
//! §2.2) and a bond between two blocks fails half by half. Laws decide from quantities that
//! are bitwise the same from either end (stretch, pair work), so the entries i→j and j→i
//! always agree and breakage is symmetric where the two ends share a law.
//!
//! Adding a law touches: its file here, a variant of `Damage` (and its `match` arms below),
//! its deck twin in `deck/schema.rs`, and the fracture-energy test.

pub mod critical_energy;
pub mod critical_stretch;
pub mod mixed;
pub mod porosity;
pub mod softening;

pub use critical_energy::CriticalEnergy;
pub use critical_stretch::CriticalStretch;
pub use mixed::MixedDamage;
pub use softening::Softening;

pub use crate::per_node::PerNode;

pub use crate::state::{BROKEN, INTACT, OTHER_BROKEN, OWN_BROKEN};

/// What a material's pair force is, as far as the damage laws' records are concerned (the
/// engine derives it from `Material::CENTRAL` and `Material::LINEAR_BOND`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BondForce {
    /// Along the bond and a fixed multiple of its extension (PMB).
    Linear,
    /// Along the bond (bond-based, LPS).
    Central,
    /// In any direction (a body of several materials with correspondence blocks).
    Vector,
    /// In any direction, each half linear in the bond's ξ and η through its own node's
    /// matrices, T_i = ω φ (B_i ξ + C1_i η) (correspondence): a law can integrate each half's
    /// work apart from node i's matrices at the two evaluations (`DamageLaw::SPLITS_WORK`).
    NodeLinear,
}

/// The pair force of a bond (N/m⁶, weighted by its partial volumes) and the deformation it
/// works through since the previous evaluation.
#[derive(Debug, Clone, Copy)]
pub enum Work {
    /// The work done on a linear bond (`BondForce::Linear`, both halves intact) since its
    /// reference state: f = k e with k fixed, so the trapezoidal sum of `Along` telescopes,
    /// Σ ½ (f_{n−1} + f_n)(e_n − e_{n−1}) = ½ k Σ (e_n² − e_{n−1}²) = ½ f e, along any path.
    /// This is the bond's micropotential (Foster, Silling & Chen 2011, the bond-based form of
    /// seed 002's Eq. 6), known without a record.
    Stored { energy: f64 },
    /// A central force f M: its work is f de, exactly (M·dη = de).
    Along { force: f64, extension: f64 },
    /// Any force: F·dη, with `step` the change of the relative displacement η (padded to 3).
    Vector { force: [f64; 3], step: [f64; 3] },
}

/// The remaining fractions (μ_ij, μ_ji) of the two halves of a bond with binary damage.
#[inline(always)]
pub fn binary_factors(status: u8) -> (f64, f64) {
    (
        if status & OWN_BROKEN == 0 { 1.0 } else { 0.0 },
        if status & OTHER_BROKEN == 0 { 1.0 } else { 0.0 },
    )
}

/// The current and reference length of a bond, as the laws see it.
#[derive(Debug, Clone, Copy)]
pub struct Stretch {
    pub len: f64,
    pub ref_len: f64,
}

impl Stretch {
    /// s = (|ξ+η| − |ξ|)/|ξ| (seed 001, Eq. 3).
    #[inline(always)]
    pub fn s(&self) -> f64 {
        (self.len - self.ref_len) / self.ref_len
    }
    /// Whether s exceeds `limit`, written without a division (bitwise the same from either end).
    #[inline(always)]
    pub fn exceeds(&self, limit: f64) -> bool {
        self.len - self.ref_len > limit * self.ref_len
    }
}

/// A damage law, written for the halves of one bond entry i→j; the engine walks the families.
///
/// A law records what it needs in the entry's history (the same numbers from either end), then
/// decides each half with the parameters of the node that owns it. The provided `on_stretch`,
/// `on_work` and `factors` are what the engine calls.
pub trait DamageLaw: Sync + Send {
    /// f64 words of history per directed bond entry (0: none is stored), for a material whose
    /// force states lie along the bond (`Material::CENTRAL`).
    const HISTORY: usize = 0;
    /// The same for other materials (their bond work needs the force vector).
    const HISTORY_VECTOR: usize = Self::HISTORY;
    /// With a `BondForce::NodeLinear` material the law keeps one word per entry, the work of
    /// the entry's own half (w_i += ½ (T_i,prev + T_i)·Δη from node i's matrices at the two
    /// evaluations, which the engine keeps per node), and decides a bond from the sum of its
    /// two entries' words after the force sweep (`ForceEngine`'s split work). Valid for one
    /// law with one threshold (`HALVES_TOGETHER`, `fails_on_work`).
    const SPLITS_WORK: bool = false;
    /// With a linear-bond material (`BondForce::Linear`) the law takes a bond's work in
    /// closed form (`Work::Stored`) and keeps no record of it; valid when both halves always
    /// break together, so that the bond stays linear until it breaks. Its history is then
    /// `HISTORY_LINEAR` words.
    const CLOSED_FORM_WORK: bool = false;
    const HISTORY_LINEAR: usize = Self::HISTORY;
    /// Decides from the stretch, in the first sweep over a node's bonds in a step.
    const ON_STRETCH: bool = false;
    /// Decides from the work done on the bond, in the force sweep.
    const ON_WORK: bool = false;
    /// μ can lie strictly between 0 and 1 (softening); otherwise it is 0 or 1.
    const PARTIAL: bool = false;
    /// The two halves of a bond always break together (one law and one set of parameters
    /// for every node): the engine treats any broken bit as a broken bond, and every bond it
    /// visits as whole (μ = 1 unless the law is `PARTIAL`).
    const HALVES_TOGETHER: bool = false;

    /// Records the bond's stretch in its history (e.g. the largest stretch so far).
    #[inline(always)]
    fn record_stretch(&self, _st: Stretch, _history: &mut [f64]) {}

    /// Whether the half owned by `node` fails at this stretch (after `record_stretch`).
    #[inline(always)]
    fn fails_on_stretch(&self, _node: usize, _st: Stretch, _history: &[f64]) -> bool {
        false
    }

    /// Records the work of the pair force since the previous evaluation and returns the work
    /// done on the bond so far.
    #[inline(always)]
    fn record_work(&self, _work: Work, _history: &mut [f64]) -> f64 {
        0.0
    }

    /// Whether the half owned by `node` fails with `work` done on the bond (from
    /// `record_work`); `weight` is the bond's quadrature weight φ̄ = ½(φ_ij + φ_ji), which
    /// the work carries.
    #[inline(always)]
    fn fails_on_work(&self, _node: usize, _extension: f64, _weight: f64, _work: f64) -> bool {
        false
    }

    /// Remaining fraction of the intact half owned by `node` (softening); 1 otherwise.
    #[inline(always)]
    fn factor(&self, _node: usize, _history: &[f64]) -> f64 {
        1.0
    }

    /// The critical stretch, if this is a critical-stretch law with one value for every
    /// node (the AVX2 kernels implement only that law).
    fn uniform_critical_stretch(&self) -> Option<f64> {
        None
    }

    /// The critical stretch of every node, if this is a critical-stretch law with one per
    /// node (each half of a bond breaks on its own node's: the per-node kernel's law).
    fn critical_stretch_per_node(&self) -> Option<&[f64]> {
        None
    }

    /// The law, if this is a softening law with one parameter set for every node (the PMB
    /// AVX2 kernel implements it too).
    fn uniform_softening(&self) -> Option<softening::UniformSoftening> {
        None
    }

    /// The law, if this is a critical-energy law with one w_c for every node (the PMB and
    /// LPS AVX2 kernels implement it too).
    fn uniform_critical_energy(&self) -> Option<critical_energy::UniformCriticalEnergy> {
        None
    }

    /// First sweep: records the stretch and breaks the halves that fail; `protected()`: an end
    /// is in a no-fail set (nothing is recorded, nothing breaks; asked only when needed).
    /// Returns 1 if node i's own half broke now.
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
        if protected() {
            return 0;
        }
        self.record_stretch(st, history);
        break_halves(
            status,
            self.fails_on_stretch(i, st, history),
            self.fails_on_stretch(j, st, history),
        )
    }

    /// Force sweep: records the work and breaks the halves that fail (`extension` =
    /// |ξ+η| − |ξ|, `weight` the bond's φ̄). Returns 1 if node i's own half broke now.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn on_work(
        &self,
        i: usize,
        j: usize,
        work: Work,
        extension: f64,
        weight: f64,
        protected: bool,
        history: &mut [f64],
        status: &mut u8,
    ) -> u64 {
        let w = self.record_work(work, history);
        if protected {
            return 0;
        }
        break_halves(
            status,
            self.fails_on_work(i, extension, weight, w),
            self.fails_on_work(j, extension, weight, w),
        )
    }

    /// (μ_ij, μ_ji) of an entry that is not fully broken: 1 intact, 0 broken, between for a
    /// softened half.
    #[inline(always)]
    fn factors(&self, i: usize, j: usize, history: &[f64], status: u8) -> (f64, f64) {
        let (own, other) = binary_factors(status);
        if Self::PARTIAL {
            (
                own * self.factor(i, history),
                other * self.factor(j, history),
            )
        } else {
            (own, other)
        }
    }
}

/// Every damage law a body can use: the engine matches it once per force evaluation.
#[derive(Debug, Clone)]
pub enum Damage {
    CriticalStretch(CriticalStretch),
    CriticalEnergy(CriticalEnergy),
    Softening(Softening),
    /// Different laws in different blocks.
    Mixed(MixedDamage),
}

impl Damage {
    /// f64 words of history per directed bond for a material whose pair force is `force`:
    /// those of the form the engine runs (`ForceEngine::compute`: the uniform form of a
    /// critical-energy law when it has one).
    pub fn history_words(&self, force: BondForce) -> usize {
        match self {
            Damage::CriticalStretch(_) => history_words::<CriticalStretch>(force),
            Damage::CriticalEnergy(d) if d.uniform_form().is_some() => {
                history_words::<critical_energy::UniformCriticalEnergy>(force)
            }
            Damage::CriticalEnergy(_) => history_words::<CriticalEnergy>(force),
            Damage::Softening(_) => history_words::<Softening>(force),
            Damage::Mixed(d) => d.history_words(force),
        }
    }

    /// Whether the engine splits each bond's work between its two entries
    /// (`DamageLaw::SPLITS_WORK`) for a material whose pair force is `force`: it then keeps
    /// each node's own-half matrices of the previous evaluation.
    pub fn splits_work(&self, force: BondForce) -> bool {
        force == BondForce::NodeLinear
            && matches!(self, Damage::CriticalEnergy(d) if d.uniform_form().is_some())
    }

    /// Whether the law integrates the work done on bonds (for a non-central material the
    /// engine then keeps the positions of the previous evaluation).
    pub fn records_work(&self) -> bool {
        match self {
            Damage::CriticalStretch(_) | Damage::Softening(_) => false,
            Damage::CriticalEnergy(_) => true,
            Damage::Mixed(d) => d.records_work(),
        }
    }

    /// Whether bonds can carry a fraction of their force (softening): the history then
    /// sets the factors μ, not the status alone.
    pub fn partial(&self) -> bool {
        match self {
            Damage::CriticalStretch(_) | Damage::CriticalEnergy(_) => false,
            Damage::Softening(_) => true,
            Damage::Mixed(d) => d.softens(),
        }
    }

    /// Node i's softening parameters, if its half follows a softening law (its history's
    /// first word is then the bond's largest stretch).
    pub fn softening_at(&self, node: usize) -> Option<softening::UniformSoftening> {
        match self {
            Damage::Softening(d) => Some(d.at(node)),
            Damage::Mixed(d) => d.softening_at(node),
            _ => None,
        }
    }

    /// Bytes per directed bond this law stores for a material whose pair force is `force`.
    pub fn bytes_per_bond(&self, force: BondForce) -> usize {
        8 * self.history_words(force)
    }

    /// A critical-stretch law that never breaks a bond.
    pub fn none() -> Self {
        Damage::CriticalStretch(CriticalStretch::never())
    }

    /// (μ_ij, μ_ji) of a bond entry (see `DamageLaw::factors`).
    pub fn factors(&self, i: usize, j: usize, history: &[f64], status: u8) -> (f64, f64) {
        match self {
            Damage::CriticalStretch(d) => d.factors(i, j, history, status),
            Damage::CriticalEnergy(d) => d.factors(i, j, history, status),
            Damage::Softening(d) => d.factors(i, j, history, status),
            Damage::Mixed(d) => d.factors(i, j, history, status),
        }
    }

    /// Short name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Damage::CriticalStretch(_) => "critical stretch",
            Damage::CriticalEnergy(_) => "critical energy",
            Damage::Softening(s) => s.name(),
            Damage::Mixed(_) => "per block",
        }
    }
}

impl From<CriticalStretch> for Damage {
    fn from(d: CriticalStretch) -> Self {
        Damage::CriticalStretch(d)
    }
}
impl From<CriticalEnergy> for Damage {
    fn from(d: CriticalEnergy) -> Self {
        Damage::CriticalEnergy(d)
    }
}
impl From<Softening> for Damage {
    fn from(d: Softening) -> Self {
        Damage::Softening(d)
    }
}
impl From<MixedDamage> for Damage {
    fn from(d: MixedDamage) -> Self {
        Damage::Mixed(d)
    }
}

/// f64 words of history per directed bond of law `L` for a material whose pair force is
/// `force`.
pub const fn history_words<L: DamageLaw>(force: BondForce) -> usize {
    match force {
        BondForce::Linear if L::CLOSED_FORM_WORK => L::HISTORY_LINEAR,
        BondForce::Linear | BondForce::Central => L::HISTORY,
        BondForce::NodeLinear if L::SPLITS_WORK => 1,
        BondForce::Vector | BondForce::NodeLinear => L::HISTORY_VECTOR,
    }
}

/// Helper for a law with one decision per half: sets the bits of the halves that fail and
/// returns 1 if node i's own half broke now.
#[inline(always)]
pub fn break_halves(status: &mut u8, own_fails: bool, other_fails: bool) -> u64 {
    let before = *status;
    if own_fails {
        *status |= OWN_BROKEN;
    }
    if other_fails {
        *status |= OTHER_BROKEN;
    }
    ((*status & !before) & OWN_BROKEN) as u64
}
