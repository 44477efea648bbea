//! Quasi-static loading: the load is applied in steps; in each step the body is relaxed to
//! equilibrium by adaptive dynamic relaxation (ADR) with every bond as it was, then the
//! damage law decides, and the body is re-equilibrated until the decision breaks no bond and
//! leaves the equilibrium intact (seed 001 §2.10 and Appendix B, Fig. B1).
//!
//! ADR after Kilic & Madenci (2010) (seed 001 ref. [39]; Underwood 1983), with the fictitious
//! time step Δt = 1:
//!
//! - fictitious diagonal mass λ_i ≥ ¼ Δt² Σ_j |K_ij| (Gershgorin bound of the stiffness row):
//!   λ_i = `mass_factor` · k_i / 2, with k_i = Σ_j C_ij φ̄ V_j the node stiffness of the
//!   stable-time-step estimate (`ForceEngine::node_stiffness`), whose row sum bounds
//!   Σ_j |K_ij| by 2 k_i;
//! - v^{n+½} = ((2 − c_n) v^{n−½} + 2 F^n/λ) / (2 + c_n), u^{n+1} = u^n + v^{n+½},
//!   v^{½} = F^0 / (2λ);
//! - c_n = 2 sqrt(uᵀ K^n u / uᵀ u) with the local diagonal stiffness
//!   K^n_kk = −(F^n_k/λ − F^{n−1}_k/λ) / v^{n−½}_k, and c_n = 0 when the quotient is not
//!   positive (softening bonds); c_n ≤ 2 (the critically damped update of the stiffest mode).
//!
//! Fictitious masses (`AdrMass`). Kilic & Madenci's λ_i bounds, by Gershgorin's circle
//! theorem, every eigenvalue of λ⁻¹K by 4/Δt², the stability limit ω_max Δt < 2 of the
//! central-difference update (Underwood 1983). The bound is loose: the row sum counts every
//! neighbour at full weight, while in the highest mode of a peridynamic body neighbours move
//! partly in phase. Convergence is set by the lowest frequency: per iteration the error
//! shrinks by about 1 − ω_min at the damping c ≈ 2ω_min the estimate above tracks (Underwood
//! 1983; Kilic & Madenci 2010). Masses scaled by a common factor s < 1 multiply every
//! ω by 1/√s, and the iterations by √s, as long as ω_max stays below 2. `AdrMass::Spectral`
//! (the default) measures ρ = λ_max(λ_G⁻¹K) for the Gershgorin masses λ_G by power iteration
//! on the intact body in its reference configuration (40 products Kx, each the force change
//! of a displacement εx with ε = 10⁻⁹ of the body's size: linear to about 10⁻⁶; ρ is the
//! Rayleigh quotient in the inner product weighted by λ_G V, in which λ_G⁻¹K is symmetric, so
//! it approaches the largest eigenvalue from below), and relaxes with λ = λ_G · 1.5ρ/4: the
//! largest ω² is then 4/1.5 by the measurement, and below 4 for a measurement up to a third
//! low. Damage only removes stiffness (for a bond-based model each broken bond takes a
//! positive semi-definite term out of K, and by Weyl's inequality no eigenvalue grows); the
//! geometric stiffening of a stretched bond is of the order of its stretch. A relaxation that
//! fails anyway (diverges, or does not converge in `max_iterations`) is taken again from its
//! start with the Gershgorin masses, which stay in use. The masses change the path to
//! equilibrium, not the equilibrium: the iteration's fixed point is F = 0 on the free
//! components, judged by the same relative residual and tolerance; intermediate equilibria,
//! and with them the bonds each decision breaks, differ only within the tolerance.
//!
//! F is the out-of-balance force density f + b on the free degrees of freedom; constrained
//! ones keep their prescribed values. Equilibrium: the relative residual
//! ‖V (f + b)‖ over free components ÷ (‖V (f + b)‖ over constrained components + ‖V b‖ over
//! free ones, or the largest such loading of an earlier equilibrium) — the out-of-balance
//! force against the forces that load the body — at most `tolerance`.
//!
//! Each relaxation after the first load step starts from the last committed step's
//! displacement increment extrapolated to the new load (u = u_k + (t_{k+1} − t_k)/(t_k −
//! t_{k−1}) (u_k − u_{k−1}) on the free components): in an elastic stretch of the loading the
//! start is then nearly the equilibrium, and the relaxation only removes the difference. The
//! equilibrium it reaches is the same (the damage state is frozen while it relaxes).
//!
//! Progress: with a `Ticker` set (`peridyn run` without `--quiet`), a load step that runs
//! longer than a few seconds prints, at most every few seconds, its equilibria so far, its
//! iterations, the residual and the bonds broken in the step.
//!
//! While the body relaxes no bond may break or soften: every node is protected (the no-fail
//! mechanism), so the damage state is the one of the last decision (a secant iteration for
//! softening laws, exact for critical stretch). Work-based laws integrate the work along the
//! quasi-static path, from one decision to the next, never along the relaxation's iterates
//! (or NCG's trial points), which are not a loading path: an LPS bond's force depends on its
//! ends' dilatations as well as its own stretch, so the work along the relaxation's
//! oscillations depends on how it oscillates (holding one grip and moving the other by 2u
//! recorded up to 17 % more work than moving both by ∓u, the same strains). The work record
//! (the bonds' history and the positions and matrices the last recording read) is therefore
//! put back after each relaxation, and the decision's evaluation adds the trapezoid from the
//! last decided equilibrium to this one (seed 002 Eq. 6 by the trapezoidal rule along the
//! equilibrium path; exact for a proportional elastic step).

use super::ncg::{Continued, Minimised, Ncg};
pub use super::quasi_static_memory::{Pause, QuasiStaticMemory, StepInProgress};
use super::quasi_static_memory::{RelaxationPaused, RelaxationStart, WorkRecord};
use super::ranks::{chunked_sums, ordered_folds, ordered_sum};
use super::{Simulation, StepError};
use crate::material::Material;
use crate::math::Vector;
use crate::state::State;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Parameters of the quasi-static solver (deck `[solver] type = "quasi_static"`).
#[derive(Debug, Clone)]
pub struct QuasiStaticSettings {
    /// How each equilibrium is found.
    pub method: EquilibriumMethod,
    /// Relative residual at which a relaxation has converged.
    pub tolerance: f64,
    /// ADR iterations allowed per relaxation.
    pub max_iterations: u64,
    /// Multiplies the fictitious mass bound (≥ 1 is stable by Gershgorin's theorem).
    pub mass_factor: f64,
    /// Relaxations (break, re-equilibrate) allowed per load step.
    pub max_equilibria: u32,
    /// A load step that breaks more bond halves than this is undone and split in two.
    pub max_broken_per_step: Option<u64>,
    /// How many times a load step may be halved.
    pub max_splits: u32,
    /// How ADR's fictitious masses are bounded (the spectral estimate by default).
    pub mass: AdrMass,
    /// How ADR estimates its damping.
    pub damping: AdrDamping,
    /// NCG's line search to a relative change of 10⁻⁶ in the step (as before 2026-11) instead
    /// of stopping once the directional derivative has fallen to 1 % of its start.
    pub exact_line_search: bool,
    /// NCG preconditioned by Jacobi plus a coarse grid's correction (`coarse_space`) instead
    /// of Jacobi alone.
    pub two_level: bool,
    /// The stage ends after the first load step whose equilibrium stores less than this
    /// fraction of the external work done so far (`QuasiStatic::broken_through`); never
    /// when unset.
    pub stop_when_stored_below: Option<f64>,
}

/// How ADR bounds its fictitious masses from the stiffness (both keep the central-difference
/// update stable: ω_max Δt < 2, see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdrMass {
    /// λ_i = k_i/2: Gershgorin's bound of the stiffness row (Kilic & Madenci 2010).
    Gershgorin,
    /// The Gershgorin masses scaled down to the measured largest eigenvalue of λ⁻¹K (with a
    /// margin), falling back to Gershgorin's when a relaxation fails with them.
    Spectral,
}

/// How ADR estimates the lowest frequency ω of λ⁻¹K for its damping c = 2ω (critical for the
/// slowest mode, which limits the convergence).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdrDamping {
    /// ω² = Σ u_k² K_kk / Σ u_k² with the local diagonal stiffness K_kk = −Δa_k / v_k (Kilic &
    /// Madenci 2010): the displacements weight it, so it follows the solution's shape, whose
    /// frequency lies above the slowest mode's on a fine grid; the slow modes are then
    /// overdamped (seed 002's elastic preload: 1745 → 6331 iterations from Δx = 80 to 40 µm).
    Local,
    /// ω² = ΔuᵀKΔu / ΔuᵀλΔu, the Rayleigh quotient of the last increment Δu = v (λ the
    /// fictitious masses): late in a relaxation the slowest modes dominate the increments, so
    /// this follows them (the same preload: 1430 → 2789 iterations).
    Increment,
}

/// How a load step finds equilibrium.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EquilibriumMethod {
    /// Adaptive dynamic relaxation: any model and damage law.
    Adr,
    /// Nonlinear conjugate gradients on the potential energy: convex models only.
    Ncg,
}

impl Default for QuasiStaticSettings {
    fn default() -> Self {
        QuasiStaticSettings {
            method: EquilibriumMethod::Adr,
            tolerance: 1e-6,
            max_iterations: 200_000,
            mass_factor: 1.0,
            max_equilibria: 1000,
            max_broken_per_step: None,
            max_splits: 8,
            mass: AdrMass::Spectral,
            damping: AdrDamping::Local,
            exact_line_search: false,
            two_level: false,
            stop_when_stored_below: None,
        }
    }
}

/// What one committed (sub)step took.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LoadStepReport {
    /// ADR iterations, over every relaxation of the step.
    pub iterations: u64,
    /// Relaxations: 1 when the first decision broke nothing.
    pub equilibria: u32,
    /// Bond halves broken in the step.
    pub broken: u64,
    /// Relative residual at the end.
    pub residual: f64,
}

/// Power iterations measuring the largest eigenvalue of λ⁻¹K (`AdrMass::Spectral`).
const SPECTRAL_ITERATIONS: usize = 40;

/// The spectral masses make the measured largest ω² = 4 / `SPECTRAL_MARGIN`: a measurement up
/// to a third below the true largest eigenvalue still leaves ω_max < 2.
const SPECTRAL_MARGIN: f64 = 1.5;

/// What the Gershgorin masses are scaled by for a measured largest eigenvalue ρ of λ⁻¹K:
/// `SPECTRAL_MARGIN` ρ / 4, at most 1, at least 1/16.
fn spectral_factor(rho: f64) -> f64 {
    (SPECTRAL_MARGIN * rho / 4.0).clamp(1.0 / 16.0, 1.0)
}

/// One relaxation taken by `QuasiStatic::probe`.
#[derive(Debug, Clone, Copy)]
pub struct Probe {
    /// Iterations (ADR) or force evaluations (NCG) taken: the budget when not converged.
    pub iterations: u64,
    pub converged: bool,
    /// Relative residual at the start and at the end.
    pub start_residual: f64,
    pub residual: f64,
    pub seconds: f64,
}

impl Probe {
    /// The iterations to reach `tolerance`: those taken when converged, else extrapolated at
    /// the mean rate of decrease so far (`None` when the residual did not decrease).
    pub fn iterations_to(&self, tolerance: f64) -> Option<f64> {
        if self.converged {
            return Some(self.iterations as f64);
        }
        let gained = (self.start_residual / self.residual).ln();
        let needed = (self.start_residual / tolerance).ln();
        (gained > 0.0 && needed.is_finite()).then(|| self.iterations as f64 * needed / gained)
    }
}

/// The quasi-static driver of one simulation: the fictitious masses and the ADR velocities.
pub struct QuasiStatic<const D: usize> {
    pub settings: QuasiStaticSettings,
    /// λ_i per node.
    mass: Vec<f64>,
    velocity: Vec<Vector<D>>,
    /// F^{n−1}/λ of the previous iteration.
    previous_acceleration: Vec<Vector<D>>,
    /// F^n/λ of this iteration (a buffer kept between iterations).
    acceleration: Vec<Vector<D>>,
    /// The load increment in use (pseudo-time), halved when a step breaks too much.
    increment: f64,
    /// The nominal increment.
    nominal: f64,
    /// Every node protected (the relaxation's no-fail flags).
    frozen: Vec<bool>,
    /// Squared norm of the largest loading forces of a committed equilibrium.
    largest_load: f64,
    /// The conjugate-gradient minimiser, when that is the method.
    ncg: Option<Ncg<D>>,
    /// The load parameter and displacements at the start of the last committed step: the
    /// predictor's previous point.
    previous: Option<(f64, Vec<Vector<D>>)>,
    /// Start each load step from the extrapolated increment (on by default).
    pub predictor: bool,
    /// Total ADR iterations.
    pub iterations: u64,
    /// Progress lines on stderr inside long load steps (off unless set).
    pub ticker: Ticker,
    /// λ_i from the Gershgorin bound (× `mass_factor`): what `mass` falls back to when a
    /// relaxation with the spectral mass does not converge.
    gershgorin: Vec<f64>,
    /// The spectral mass is still to be measured (at the first relaxation).
    spectral_pending: bool,
    /// `mass` is the spectral one (below the Gershgorin bound).
    spectral: bool,
    /// The largest eigenvalue of λ⁻¹K measured with the Gershgorin mass (0 before).
    pub spectral_radius: f64,
    /// Force evaluations spent measuring it (not counted as iterations).
    pub setup_evaluations: u64,
    /// A relaxation with the spectral masses failed: Gershgorin's are in use for good.
    fell_back: bool,
    /// When a relaxation pauses for a checkpoint (never when unset).
    pub pause: Option<Pause>,
    /// The load step in progress may pause: one process, and no state kept to undo the
    /// step (a step that may still be halved).
    may_pause: bool,
    /// The load step paused inside a relaxation, continued by the next `advance`.
    paused: Option<Box<StepInProgress<D>>>,
}

/// How a call of `advance` ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Advanced {
    /// A load step (or a part of a halved one) committed.
    Committed(LoadStepReport),
    /// Paused inside a relaxation, as `QuasiStatic::pause` asked: the memory holds the step
    /// in progress, and the next call continues it.
    Paused,
}

/// How a load step's relaxations and decisions ended.
enum Equilibrated<const D: usize> {
    /// Equilibrium, and the decision broke nothing.
    Done,
    /// More bond halves broke than the step may break.
    GaveUp,
    Paused(Box<RelaxationPaused<D>>),
}

/// How a relaxation ended.
enum Relaxed<const D: usize> {
    /// At equilibrium after this many iterations.
    Converged(u64),
    Paused(Box<RelaxationPaused<D>>),
}

/// Progress inside a load step: a line on stderr at most every `every` (none when `None`), so
/// that a load step in which a crack runs, with its thousands of iterations, does not look
/// hung; and a closing line for a load step that printed one.
#[derive(Debug, Clone)]
pub struct Ticker {
    pub every: Option<Duration>,
    last: Instant,
    started: Instant,
    printed: bool,
    /// The load step in progress: its number and load parameter.
    step: u64,
    load: f64,
    /// What the step took before the relaxation in progress.
    done: LoadStepReport,
}

impl Default for Ticker {
    fn default() -> Self {
        Ticker {
            every: None,
            last: Instant::now(),
            started: Instant::now(),
            printed: false,
            step: 0,
            load: 0.0,
            done: LoadStepReport::default(),
        }
    }
}

impl Ticker {
    /// A ticker printing at most every `seconds`.
    pub fn every(seconds: f64) -> Self {
        Ticker {
            every: Some(Duration::from_secs_f64(seconds)),
            ..Ticker::default()
        }
    }

    fn begin(&mut self, step: u64, load: f64) {
        (self.step, self.load, self.printed) = (step, load, false);
        self.done = LoadStepReport::default();
        self.started = Instant::now();
        self.last = self.started;
    }

    /// Inside a relaxation that has taken `iterations` so far, at `residual`.
    fn tick(&mut self, iterations: u64, residual: f64) {
        let Some(every) = self.every else { return };
        if self.last.elapsed() < every {
            return;
        }
        self.last = Instant::now();
        self.printed = true;
        let d = &self.done;
        eprintln!(
            "  load step {} (load {:.4e}): {} s, equilibrium {}, {} iterations, residual {residual:.2e}, {} bonds broken in the step",
            self.step,
            self.load,
            self.started.elapsed().as_secs(),
            d.equilibria,
            d.iterations + iterations,
            d.broken / 2
        );
    }

    fn end(&mut self, report: &LoadStepReport, committed: bool) {
        if self.every.is_none() || !self.printed {
            return;
        }
        eprintln!(
            "  load step {} (load {:.4e}) {} in {:.1} s: {} equilibria, {} iterations, residual {:.2e}, {} bonds broken",
            self.step,
            self.load,
            if committed { "committed" } else { "broke too many bonds: halved" },
            self.started.elapsed().as_secs_f64(),
            report.equilibria,
            report.iterations,
            report.residual,
            report.broken / 2
        );
    }
}

impl<const D: usize> QuasiStatic<D> {
    /// The memory a checkpoint between load steps keeps.
    pub fn memory(&self) -> QuasiStaticMemory<D> {
        debug_assert!(self.paused.is_none(), "a paused step is lent, not copied");
        QuasiStaticMemory {
            increment: self.increment,
            largest_load: self.largest_load,
            previous: self.previous.clone(),
            iterations: self.iterations,
            gershgorin: self.fell_back,
            spectrum: (!self.spectral_pending)
                .then_some((self.spectral_radius, self.setup_evaluations)),
            in_step: None,
        }
    }

    /// The memory a checkpoint inside a paused load step keeps, with the step and its ADR
    /// velocities (or NCG direction) moved out rather than copied: the step's work records hold two words of
    /// history per bond each, and a copy of them at every checkpoint took a third more
    /// memory than the relaxation itself (22.0 GB against 14.5 GB on seed 002's 3D plate at
    /// Δx = 60 µm). `take_back` returns them once the checkpoint is written.
    pub fn lend_memory(&mut self) -> QuasiStaticMemory<D> {
        let in_step = self.paused.take().map(|mut p| {
            match self.ncg.as_mut() {
                Some(ncg) => p.direction = std::mem::take(&mut ncg.direction),
                None => {
                    p.velocity = std::mem::take(&mut self.velocity);
                    p.previous_acceleration = std::mem::take(&mut self.previous_acceleration);
                }
            }
            p
        });
        QuasiStaticMemory {
            in_step,
            ..self.memory()
        }
    }

    /// Takes back the paused step `lend_memory` lent (or a checkpoint kept).
    pub fn take_back(&mut self, in_step: Option<Box<StepInProgress<D>>>) {
        self.paused = in_step.map(|mut p| {
            match self.ncg.as_mut() {
                Some(ncg) => ncg.direction = std::mem::take(&mut p.direction),
                None => {
                    self.velocity = std::mem::take(&mut p.velocity);
                    self.previous_acceleration = std::mem::take(&mut p.previous_acceleration);
                }
            }
            p
        });
    }

    /// Continues from a checkpoint's memory.
    pub fn resume(&mut self, memory: QuasiStaticMemory<D>) {
        self.increment = memory.increment;
        self.largest_load = memory.largest_load;
        self.previous = memory.previous;
        self.iterations = memory.iterations;
        if memory.gershgorin {
            self.use_gershgorin();
        }
        if let (true, Some((rho, evaluations))) = (self.spectral_pending, memory.spectrum) {
            self.spectral_pending = false;
            self.setup_evaluations = evaluations;
            self.scale_masses(rho);
        }
        self.take_back(memory.in_step);
    }

    /// Gershgorin's masses from now on (a relaxation failed with the spectral ones).
    fn use_gershgorin(&mut self) {
        self.mass.clone_from(&self.gershgorin);
        (self.spectral, self.spectral_pending, self.fell_back) = (false, false, true);
    }

    /// What the solver used and spent, for the run's summary: the method, and for ADR which
    /// fictitious masses (a run is only comparable with one that relaxed with the same).
    pub fn describe(&self) -> String {
        if self.ncg.is_some() {
            return format!("NCG, {} force evaluations", self.iterations);
        }
        let rho = self.spectral_radius;
        let masses = if self.spectral {
            format!(
                "the spectral masses (Gershgorin's × {:.3}, from ρ = {rho:.3} measured in {} force evaluations)",
                spectral_factor(rho),
                self.setup_evaluations
            )
        } else if self.fell_back && rho > 0.0 {
            format!("Gershgorin's masses (a relaxation failed with the spectral ones, ρ = {rho:.3}, and was taken again)")
        } else if self.fell_back {
            "Gershgorin's masses (a relaxation failed with the spectral ones before the checkpoint this run continued from)".into()
        } else if rho > 0.0 {
            format!("Gershgorin's masses (ρ = {rho:.3}: scaling them would gain nothing)")
        } else {
            "Gershgorin's masses".into()
        };
        let damping = match self.settings.damping {
            AdrDamping::Local => "",
            AdrDamping::Increment => " and the damping of the last increment",
        };
        format!("ADR with {masses}{damping}, {} iterations", self.iterations)
    }

    /// Whether the committed equilibrium stores less than `stop_when_stored_below` of the
    /// external work done so far: the body has broken through and carries (nearly) no load.
    /// Seed 000 §4.2 loads its plate "until full separation of the sample occurs"; after
    /// that, load steps only break the last bonds of slivers hanging across the crack, an
    /// equilibrium each. The stored energy, not a fall of the reaction from its peak,
    /// because it needs nothing remembered across a restart.
    pub fn broken_through<M: Material<D>>(&self, sim: &Simulation<D, M>) -> bool {
        // A step paused for a checkpoint is no equilibrium: its work is not yet booked.
        let Some(fraction) = self
            .settings
            .stop_when_stored_below
            .filter(|_| self.paused.is_none())
        else {
            return false;
        };
        let work = sim.state.external_work;
        work > 0.0 && sim.strain_energy() < fraction * work
    }

    /// Sets up the masses for `sim`; `increment` is the nominal load step (pseudo-time).
    pub fn new<M: Material<D>>(
        sim: &Simulation<D, M>,
        settings: QuasiStaticSettings,
        increment: f64,
    ) -> Self {
        let n = sim.body.len();
        let settings_method = settings.method;
        let mass: Vec<f64> = sim
            .engine
            .node_stiffness(&sim.body, &sim.bonds)
            .into_iter()
            .map(|k| settings.mass_factor * 0.5 * k)
            .collect();
        let ncg = (settings_method == EquilibriumMethod::Ncg)
            .then(|| Ncg::new(sim, &mass, settings.exact_line_search, settings.two_level));
        let spectral =
            settings_method == EquilibriumMethod::Adr && settings.mass == AdrMass::Spectral;
        let gershgorin = mass.clone();
        QuasiStatic {
            settings,
            mass,
            velocity: vec![Vector::zeros(); n],
            previous_acceleration: vec![Vector::zeros(); n],
            acceleration: vec![Vector::zeros(); n],
            increment,
            nominal: increment,
            frozen: vec![true; n],
            largest_load: 0.0,
            ncg,
            previous: None,
            predictor: true,
            iterations: 0,
            ticker: Ticker::default(),
            gershgorin,
            spectral_pending: spectral,
            spectral: false,
            spectral_radius: 0.0,
            setup_evaluations: 0,
            fell_back: false,
            pause: None,
            may_pause: false,
            paused: None,
        }
    }

    /// Commits one load step ending at `target` (pseudo-time), or a part of it when the step
    /// breaks more than `max_broken_per_step` bond halves (the state is restored exactly and
    /// the increment halved, up to `max_splits` times). Returns what the committed step took.
    /// Pauses, if `pause` asks for them, are passed through.
    pub fn advance<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        target: f64,
    ) -> Result<LoadStepReport, StepError> {
        loop {
            if let Advanced::Committed(report) = self.advance_or_pause(sim, target)? {
                return Ok(report);
            }
        }
    }

    /// As `advance`, but returns at a pause inside the step (`pause`), which the next call
    /// continues.
    pub fn advance_or_pause<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        target: f64,
    ) -> Result<Advanced, StepError> {
        let limit = self.settings.max_broken_per_step;
        let smallest = self.nominal / f64::powi(2.0, self.settings.max_splits as i32);
        loop {
            let (t1, abort_above) = match self.paused.as_deref() {
                // A paused step could not give up (it keeps no state to undo it with).
                Some(p) => (p.t1, None),
                None => {
                    // A remainder below a millionth of the nominal increment is rounding: go
                    // to target.
                    let t1 = sim.state.time + self.increment;
                    let t1 = if t1 >= target - 1e-6 * self.nominal {
                        target
                    } else {
                        t1
                    };
                    // A step that may still be halved gives up as soon as it breaks too much.
                    (t1, limit.filter(|_| self.increment > smallest * 1.5))
                }
            };
            let saved = abort_above.map(|_| sim.state.clone());
            // Undoing a step needs the whole state at its start, which no checkpoint keeps.
            self.may_pause = abort_above.is_none() && sim.share.is_none();
            let report = match self.load_step(sim, t1, abort_above)? {
                Some(Advanced::Committed(report)) => report,
                Some(Advanced::Paused) => return Ok(Advanced::Paused),
                None => {
                    sim.state = saved.expect("saved when a step may give up");
                    self.increment *= 0.5;
                    continue;
                }
            };
            if report.broken == 0 {
                // A quiet step lets the increment grow back to the nominal one.
                self.increment = (self.increment * 2.0).min(self.nominal);
            }
            sim.counters.steps += 1;
            sim.counters.bonds_broken += report.broken;
            return Ok(Advanced::Committed(report));
        }
    }

    /// Swaps the body's no-fail flags with `frozen` (every node protected) and back: while
    /// every node is protected no bond breaks or softens, and a distributed force evaluation
    /// need not ask the other ranks how many broke (every rank relaxes at the same time).
    fn toggle_protection<M: Material<D>>(&mut self, sim: &mut Simulation<D, M>) {
        std::mem::swap(&mut sim.body.no_fail, &mut self.frozen);
        sim.engine.all_protected = !sim.engine.all_protected;
    }

    /// Moves the body to the start of a load step ending at `t1`: the predictor's
    /// extrapolated increment on the free components, the boundary values at t1.
    fn start_step<M: Material<D>>(&self, sim: &mut Simulation<D, M>, t1: f64) {
        let t0 = sim.state.time;
        if let Some((t_prev, u_prev)) = self.previous.as_ref().filter(|_| self.predictor) {
            // The last step's increment, scaled to this one, on the free components.
            let ratio = (t1 - t0) / (t0 - t_prev);
            // Owned nodes only: the ghosts take their owners' at the next force evaluation.
            let owned = sim.owned();
            let (mask, positions) = (&sim.constrained_mask, &sim.body.positions);
            let s = &mut sim.state;
            (&mut s.u[..owned], &mut s.current[..owned])
                .into_par_iter()
                .zip(u_prev[..owned].par_iter())
                .enumerate()
                .with_min_len(4096)
                .for_each(|(i, ((u, y), up))| {
                    let step = (*u - up) * ratio;
                    for k in 0..D {
                        if !mask[i][k] {
                            u[k] += step[k];
                        }
                    }
                    *y = positions[i] + *u;
                });
        }
        sim.loading
            .apply_displacements(&sim.body, &mut sim.state, t1);
        sim.state.time = t1;
    }

    /// Takes the next load step's first relaxation (no decision, no bond breaks) with at most
    /// `budget` iterations, for `peridyn check`'s estimate; the state is left at the end of it
    /// and the predictor's memory set as a committed step would set it.
    pub fn probe<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        budget: u64,
    ) -> Result<Probe, StepError> {
        let started = Instant::now();
        let (t0, u0) = (sim.state.time, sim.state.u.clone());
        let t1 = t0 + self.increment;
        self.start_step(sim, t1);
        self.toggle_protection(sim);
        let max = std::mem::replace(&mut self.settings.max_iterations, budget);
        self.may_pause = false;
        let result = (|| {
            sim.refresh_forces()?;
            let start_residual = self.residual(sim).0;
            let relaxed = self.relax(sim, None).map(|r| match r {
                Relaxed::Converged(n) => n,
                Relaxed::Paused(_) => unreachable!("a probe does not pause"),
            });
            Ok::<_, StepError>((start_residual, relaxed))
        })();
        self.settings.max_iterations = max;
        self.toggle_protection(sim);
        let (start_residual, relaxed) = result?;
        let residual = self.residual(sim).0;
        let (iterations, converged) = match relaxed {
            Ok(n) => (n, true),
            Err(StepError::NotConverged { .. }) if residual.is_finite() => (budget, false),
            Err(e) => return Err(e),
        };
        self.largest_load = self.largest_load.max(self.residual(sim).1);
        self.previous = Some((t0, u0));
        sim.state.step += 1;
        Ok(Probe {
            iterations,
            converged,
            start_residual,
            residual,
            seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// Applies the load at t1, relaxes, lets the damage law decide and re-relaxes until it
    /// breaks nothing; books the external work and commits the step. `None` (the state left
    /// half-way) when more than `abort_above` bond halves broke; `Advanced::Paused` when a
    /// relaxation paused (a paused step is continued by the next call).
    fn load_step<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        t1: f64,
        abort_above: Option<u64>,
    ) -> Result<Option<Advanced>, StepError> {
        let started = Instant::now();
        let step = sim.state.step + 1;
        let (mut p, resume) = match self.paused.take() {
            Some(mut p) => {
                let relaxation = std::mem::take(&mut p.relaxation);
                // A run continued from a checkpoint prints this step's progress afresh.
                if self.ticker.step != step {
                    self.ticker.begin(step, t1);
                }
                sim.state.time = p.t1;
                (p, Some(relaxation))
            }
            None => {
                let (t0, u0, load0) = (
                    sim.state.time,
                    sim.state.u.clone(),
                    self.applied_forces(sim),
                );
                self.start_step(sim, t1);
                self.ticker.begin(step, t1);
                let p = Box::new(StepInProgress {
                    t0,
                    t1,
                    u0,
                    load0,
                    report: LoadStepReport::default(),
                    record: WorkRecord::of(&sim.state),
                    relaxation: RelaxationPaused::default(),
                    velocity: Vec::new(),
                    previous_acceleration: Vec::new(),
                    direction: Vec::new(),
                });
                (p, None)
            }
        };
        // Forces at the new boundary values, nothing deciding.
        self.toggle_protection(sim);
        let result = self.equilibrate(sim, &mut p, resume, abort_above);
        self.toggle_protection(sim);
        let report = p.report;
        if let Ok(Equilibrated::Paused(r)) = result {
            p.relaxation = *r;
            // Until the step commits, the clock stays at its start: the stage loop and the
            // checkpoint see the last committed time.
            sim.state.time = p.t0;
            self.paused = Some(p);
            sim.counters.force += started.elapsed();
            return Ok(Some(Advanced::Paused));
        }
        // The step ended (committed, gave up or failed): its iterations count.
        self.iterations += report.iterations;
        if let Equilibrated::GaveUp = result? {
            self.ticker.end(&report, false);
            return Ok(None);
        }
        self.ticker.end(&report, true);
        self.largest_load = self.largest_load.max(self.residual(sim).1);
        sim.state.external_work += self.step_work(sim, &p.u0, &p.load0);
        self.previous = Some((p.t0, p.u0));
        sim.state.dt = t1 - p.t0;
        sim.state.iterations = report.iterations;
        sim.state.step += 1;
        sim.counters.force += started.elapsed();
        Ok(Some(Advanced::Committed(report)))
    }

    /// The relaxations and decisions of the load step `p` (every node protected while it
    /// relaxes): from its start, or from the relaxation `resume` paused in.
    fn equilibrate<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        p: &mut StepInProgress<D>,
        mut resume: Option<RelaxationPaused<D>>,
        abort_above: Option<u64>,
    ) -> Result<Equilibrated<D>, StepError> {
        if resume.is_none() {
            sim.refresh_forces()?;
        }
        loop {
            if resume.is_none() {
                p.report.equilibria += 1;
            }
            self.ticker.done = p.report;
            p.report.iterations += match self.relax(sim, resume.take())? {
                Relaxed::Converged(n) => n,
                Relaxed::Paused(r) => return Ok(Equilibrated::Paused(r)),
            };
            p.record.restore(&mut sim.state);
            // The decision, with the user's no-fail sets.
            self.toggle_protection(sim);
            let broken = sim.refresh_forces();
            self.toggle_protection(sim);
            let broken = broken?;
            p.record.keep(&sim.state);
            p.report.broken += broken;
            if abort_above.is_some_and(|n| p.report.broken > n) {
                return Ok(Equilibrated::GaveUp);
            }
            p.report.residual = self.residual(sim).0;
            if broken == 0 && p.report.residual <= self.settings.tolerance {
                return Ok(Equilibrated::Done);
            }
            if p.report.equilibria >= self.settings.max_equilibria {
                return Err(StepError::NotConverged {
                    step: sim.state.step + 1,
                    time: p.t1,
                    what: format!("bonds still breaking after {} re-equilibrations (max_equilibria) in this load step", p.report.equilibria),
                });
            }
        }
    }

    /// Relaxes the body to equilibrium with the damage state frozen, from its state or from
    /// where `resume` paused; returns the iterations, or the pause.
    fn relax<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        resume: Option<RelaxationPaused<D>>,
    ) -> Result<Relaxed<D>, StepError> {
        let tol = self.settings.tolerance;
        if let Some(ncg) = self.ncg.as_mut() {
            let (largest, max) = (self.largest_load, self.settings.max_iterations);
            let continued = resume.map(|r| Continued {
                evaluations: r.iterations,
                since_restart: r.since_restart,
            });
            let pause = self.pause.filter(|_| self.may_pause);
            let ticker = &mut self.ticker;
            let found = ncg.minimise(sim, max, continued, pause, |s, evaluations| {
                let residual = relative_residual(s, largest).0;
                ticker.tick(evaluations, residual);
                residual <= tol
            })?;
            return match found {
                Minimised::Converged(evaluations) => Ok(Relaxed::Converged(evaluations)),
                Minimised::Paused(c) => Ok(Relaxed::Paused(Box::new(RelaxationPaused {
                    iterations: c.evaluations,
                    since_restart: c.since_restart,
                    ..RelaxationPaused::default()
                }))),
                Minimised::Exhausted => {
                    let residual = self.residual(sim).0;
                    Err(self.not_converged(sim, max, residual))
                }
            };
        }
        if self.spectral_pending {
            self.spectral_pending = false;
            self.measure_spectrum(sim)?;
        }
        let (continued, fallback_start) = match resume {
            Some(r) => (Some((r.iterations, r.start_residual)), r.fallback_start),
            None => (None, None),
        };
        if !self.spectral {
            return self.adr(sim, continued);
        }
        // A relaxation that fails with the spectral masses (the measurement missed a mode, or
        // a contact stiffened the body) is taken again from its start with Gershgorin's.
        let start = fallback_start.unwrap_or_else(|| RelaxationStart::of(&sim.state));
        match self.adr(sim, continued) {
            Ok(Relaxed::Paused(mut r)) => {
                r.fallback_start = Some(start);
                Ok(Relaxed::Paused(r))
            }
            Ok(converged) => Ok(converged),
            Err(_) => {
                start.restore(&mut sim.state);
                self.use_gershgorin();
                self.adr(sim, None)
            }
        }
    }

    /// The largest eigenvalue ρ of λ⁻¹K for the Gershgorin masses λ, by power iteration
    /// on the intact body at its reference configuration (a fresh state: the same number
    /// for a run and its continuation from a checkpoint), K x from the force change of a small
    /// displacement εx of the free components; then the masses scaled by
    /// `SPECTRAL_MARGIN` ρ / 4 (at most 1, at least 1/16). Leaves the state as it was.
    fn measure_spectrum<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
    ) -> Result<(), StepError> {
        let history_words = sim.state.history.len() / sim.bonds.len().max(1);
        let fresh = State::new(&sim.body, &sim.bonds, history_words);
        let saved = std::mem::replace(&mut sim.state, fresh);
        let result = self.power_iteration(sim);
        sim.state = saved;
        let (rho, evaluations) = result?;
        self.setup_evaluations += evaluations;
        self.scale_masses(rho);
        Ok(())
    }

    /// Scales Gershgorin's masses to the spectral radius `rho`, unless that gains nothing.
    fn scale_masses(&mut self, rho: f64) {
        self.spectral_radius = rho;
        let factor = spectral_factor(rho);
        if rho.is_finite() && factor < 0.95 {
            self.mass.iter_mut().for_each(|m| *m *= factor);
            self.spectral = true;
        }
    }

    /// `measure_spectrum`'s iteration from the current (reference) state: ρ and the force
    /// evaluations it took; the state is left displaced.
    fn power_iteration<M: Material<D>>(
        &self,
        sim: &mut Simulation<D, M>,
    ) -> Result<(f64, u64), StepError> {
        // The owned nodes (all in one process): ghosts take their owners' displacements at
        // each force evaluation, and every sum continues the one process's order.
        let n = sim.owned();
        let share = sim.share.clone();
        let share = share.as_deref();
        let first = share.map_or(0, |s| s.first);
        let mask = sim.constrained_mask.clone();
        let free = |i: usize, k: usize| !mask[i][k] && self.mass[i] > 0.0;
        // The length scale: the body's bounding box; a displacement of 1e-9 of it stretches
        // a bond a thousand times shorter by 1e-6 at most, far inside the linear range.
        let (mut lo, mut hi) = sim.body.positions[..n].iter().fold(
            (
                Vector::<D>::repeat(f64::INFINITY),
                Vector::<D>::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), x| (lo.inf(x), hi.sup(x)),
        );
        if let Some(s) = share {
            for k in 0..D {
                (lo[k], hi[k]) = (s.ranks.min_f64(lo[k]), s.ranks.max_f64(hi[k]));
            }
        }
        let eps = 1e-9 * (hi - lo).norm();
        if eps.is_nan() || eps <= 0.0 {
            return Ok((0.0, 0));
        }
        sim.refresh_forces()?;
        let mut evaluations = 1;
        let f0: Vec<Vector<D>> = (0..n)
            .map(|i| sim.state.force[i] + sim.state.body_force[i])
            .collect();
        let u0 = sim.state.u.clone();
        // A start with every mode in it: a fixed pseudo-random pattern in [-1, 1] (of the
        // global node index).
        let mut x: Vec<Vector<D>> = (0..n)
            .map(|i| {
                Vector::<D>::from_fn(|k, _| {
                    if free(i, k) {
                        let h =
                            (((first + i) * D + k) as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                        ((h >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        let weight: Vec<f64> = (0..n).map(|i| self.mass[i] * sim.body.volumes[i]).collect();
        let mut rho = 0.0f64;
        for _ in 0..SPECTRAL_ITERATIONS {
            {
                let (positions, s) = (&sim.body.positions, &mut sim.state);
                for i in 0..n {
                    s.u[i] = u0[i] + x[i] * eps;
                    s.current[i] = positions[i] + s.u[i];
                }
            }
            sim.refresh_forces()?;
            evaluations += 1;
            let s = &sim.state;
            let y: Vec<Vector<D>> = (0..n)
                .map(|i| {
                    Vector::<D>::from_fn(|k, _| {
                        if free(i, k) {
                            let f = s.force[i][k] + s.body_force[i][k] - f0[i][k];
                            -f / (eps * self.mass[i])
                        } else {
                            0.0
                        }
                    })
                })
                .collect();
            // The Rayleigh quotient in the inner product weighted by λ_i V_i, in which
            // λ⁻¹K is symmetric: never above the largest eigenvalue.
            let [num, den] = ordered_folds(share, n, [0.0, 0.0], |i, [num, den]| {
                *num += weight[i] * x[i].dot(&y[i]);
                *den += weight[i] * x[i].dot(&x[i]);
            });
            if den > 0.0 && (num / den).is_finite() {
                rho = rho.max(num / den);
            }
            let largest = y.iter().map(|v| v.amax()).fold(0.0, f64::max);
            // The largest over every rank (exact in any order; never NaN: f64::max drops it).
            let largest = share.map_or(largest, |s| s.ranks.max_f64(largest));
            if !(largest > 0.0 && largest.is_finite()) {
                break;
            }
            x = y.into_iter().map(|v| v / largest).collect();
        }
        Ok((rho, evaluations))
    }

    /// One ADR relaxation (see the module docs) with the masses in use. Each iteration
    /// takes the residual and the next damping coefficient in one pass over the nodes (one
    /// exchange between ranks, not two: the damping of iteration n + 1 reads only what the
    /// forces of iteration n left).
    fn adr<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        continued: Option<(u64, f64)>,
    ) -> Result<Relaxed<D>, StepError> {
        let tol = self.settings.tolerance;
        // The owned nodes: the ghosts take their owners' displacements at each evaluation.
        let owned = sim.owned();
        self.out_of_balance(sim);
        // A paused relaxation continues with what its last iteration computed from the
        // same state and velocities: the residual and the damping.
        let (mut n, start_residual, mut residual, mut c) = match continued {
            None => {
                let residual = self.residual(sim).0;
                (0, residual, residual, 0.0)
            }
            Some((n, start_residual)) => {
                let (residual, c) = self.residual_and_damping(sim);
                (n, start_residual, residual, c)
            }
        };
        let entered = n;
        while residual > tol {
            if n >= self.settings.max_iterations {
                return Err(self.not_converged(sim, n, residual));
            }
            let pause = self.pause.filter(|_| self.may_pause && n > entered);
            if pause.is_some_and(|p| p.due(n - entered)) {
                return Ok(Relaxed::Paused(Box::new(RelaxationPaused {
                    iterations: n,
                    start_residual,
                    ..RelaxationPaused::default()
                })));
            }
            // The first iteration starts from rest: v^{½} = F^0/(2λ).
            let first = n == 0;
            let (velocity, previous, accel) = (
                &mut self.velocity[..owned],
                &mut self.previous_acceleration[..owned],
                &self.acceleration[..owned],
            );
            let positions = &sim.body.positions[..owned];
            let s = &mut sim.state;
            (
                &mut s.u[..owned],
                &mut s.current[..owned],
                velocity,
                previous,
            )
                .into_par_iter()
                .zip(accel.par_iter())
                .zip(positions.par_iter())
                .with_min_len(4096)
                .for_each(|(((u, y, v, prev), a), x)| {
                    *v = if first {
                        a * 0.5
                    } else {
                        (*v * (2.0 - c) + a * 2.0) / (2.0 + c)
                    };
                    *prev = *a;
                    *u += *v;
                    *y = x + *u;
                });
            sim.refresh_forces()?;
            n += 1;
            self.out_of_balance(sim);
            (residual, c) = self.residual_and_damping(sim);
            self.ticker.tick(n, residual);
            if !residual.is_finite() || residual > 1e6 * start_residual.max(tol) {
                sim.check_finite()?;
                return Err(self.not_converged(sim, n, residual));
            }
        }
        Ok(Relaxed::Converged(n))
    }

    /// The out-of-balance acceleration F/λ on the free components of the owned nodes.
    fn out_of_balance<M: Material<D>>(&mut self, sim: &Simulation<D, M>) {
        let (s, mask, mass) = (&sim.state, &sim.constrained_mask, &self.mass);
        self.acceleration[..sim.owned()]
            .par_iter_mut()
            .enumerate()
            .with_min_len(4096)
            .for_each(|(i, a)| {
                *a = Vector::<D>::from_fn(|k, _| {
                    if mask[i][k] || mass[i] <= 0.0 {
                        0.0
                    } else {
                        (s.force[i][k] + s.body_force[i][k]) / mass[i]
                    }
                })
            });
    }

    /// The relative residual (as `residual`) and the damping c_n = 2 ω: with
    /// `AdrDamping::Local` ω² = uᵀKu / uᵀu from the local diagonal stiffness (Kilic & Madenci
    /// 2010), with `AdrDamping::Increment` ω² = ΔuᵀKΔu / ΔuᵀλΔu of the last increment Δu = v;
    /// c is 0 when ω² is not positive, at most 2;
    /// the four sums in fixed chunks of the node order (the same for any thread or rank
    /// count), each added exactly as on its own.
    fn residual_and_damping<M: Material<D>>(&self, sim: &Simulation<D, M>) -> (f64, f64) {
        let (u, v, p) = (&sim.state.u, &self.velocity, &self.previous_acceleration);
        let accel = &self.acceleration;
        let (mass, damping) = (&self.mass, self.settings.damping);
        let [free, held, num, den] = chunked_sums(
            sim.share.as_deref(),
            sim.owned(),
            RESIDUAL_CHUNK,
            [0.0; 4],
            |i, [free, held, num, den]| {
                add_residual_terms(sim, i, free, held);
                for k in 0..D {
                    if v[i][k] == 0.0 {
                        continue;
                    }
                    match damping {
                        AdrDamping::Local => {
                            let stiffness = -(accel[i][k] - p[i][k]) / v[i][k];
                            *num += u[i][k] * stiffness * u[i][k];
                            *den += u[i][k] * u[i][k];
                        }
                        // −Δu·ΔF = ΔuᵀKΔu, with Δu = v and ΔF = λ (a − a_prev).
                        AdrDamping::Increment => {
                            *num -= mass[i] * v[i][k] * (accel[i][k] - p[i][k]);
                            *den += mass[i] * v[i][k] * v[i][k];
                        }
                    }
                }
            },
        );
        let c = if num > 0.0 && den > 0.0 {
            (2.0 * (num / den).sqrt()).min(2.0)
        } else {
            0.0
        };
        (relative_of(free, held, self.largest_load).0, c)
    }

    /// The relative residual, and the squared norm of the loading forces it is measured
    /// against.
    pub fn residual<M: Material<D>>(&self, sim: &Simulation<D, M>) -> (f64, f64) {
        relative_residual(sim, self.largest_load)
    }

    /// The error of a relaxation that did not converge, naming the node with the largest
    /// out-of-balance force (every rank of a distributed run calls it, and returns the same
    /// error).
    fn not_converged<M: Material<D>>(
        &self,
        sim: &Simulation<D, M>,
        iterations: u64,
        residual: f64,
    ) -> StepError {
        let (node, position) = worst_node(sim);
        StepError::NotConverged {
            step: sim.state.step + 1,
            time: sim.state.time,
            what: format!(
                "relative residual {residual:.3e} after {iterations} {} (tolerance {:.1e}, max_iterations {}); the largest out-of-balance force is at node {node}, x = {position}; raise max_iterations or mass_factor, or use smaller load steps",
                match self.settings.method {
                    EquilibriumMethod::Adr => "ADR iterations",
                    EquilibriumMethod::Ncg => "force evaluations of conjugate gradients",
                },
                self.settings.tolerance,
                self.settings.max_iterations,
            ),
        }
    }

    /// The external forces at the constrained components (−V (f + b), what holds them) and
    /// the body forces V b on the free ones, per owned node.
    fn applied_forces<M: Material<D>>(&self, sim: &Simulation<D, M>) -> Vec<Vector<D>> {
        let (s, mask, vol) = (&sim.state, &sim.constrained_mask, &sim.body.volumes);
        (0..sim.owned())
            .map(|i| {
                Vector::<D>::from_fn(|k, _| {
                    if mask[i][k] {
                        -vol[i] * (s.force[i][k] + s.body_force[i][k])
                    } else {
                        vol[i] * s.body_force[i][k]
                    }
                })
            })
            .collect()
    }

    /// Work of the external forces over the step between two equilibria (trapezoidal rule),
    /// summed in node order.
    fn step_work<M: Material<D>>(
        &self,
        sim: &Simulation<D, M>,
        u0: &[Vector<D>],
        load0: &[Vector<D>],
    ) -> f64 {
        let load1 = self.applied_forces(sim);
        let terms =
            (0..load1.len()).map(|i| 0.5 * (load0[i] + load1[i]).dot(&(sim.state.u[i] - u0[i])));
        ordered_sum(sim.share.as_deref(), terms)
    }
}

/// The chunk of nodes whose sums (residual, damping) are taken first, in parallel; the
/// chunks' sums are then added in order.
const RESIDUAL_CHUNK: usize = 4096;

/// The relative residual of `sim` (see the module docs) against its loading or `largest_load`,
/// whichever is larger; the loading's squared norm. Sums over the owned nodes in fixed chunks
/// of the global node order, continued across ranks.
fn relative_residual<const D: usize, M: Material<D>>(
    sim: &Simulation<D, M>,
    largest_load: f64,
) -> (f64, f64) {
    let [free, held] = chunked_sums(
        sim.share.as_deref(),
        sim.owned(),
        RESIDUAL_CHUNK,
        [0.0, 0.0],
        |i, [free, held]| add_residual_terms(sim, i, free, held),
    );
    relative_of(free, held, largest_load)
}

/// Adds owned node i's terms to the residual's sums: |V (f + b)|² over its free components,
/// and the loading's squared norm (V (f + b) over constrained components, V b over free ones).
fn add_residual_terms<const D: usize, M: Material<D>>(
    sim: &Simulation<D, M>,
    i: usize,
    free: &mut f64,
    held: &mut f64,
) {
    let (s, mask, vol) = (&sim.state, &sim.constrained_mask, &sim.body.volumes);
    *free += own_residual(sim, i);
    for (k, &held_k) in mask[i].iter().take(D).enumerate() {
        let f = vol[i] * (s.force[i][k] + s.body_force[i][k]);
        if held_k {
            *held += f * f;
        } else {
            let b = vol[i] * s.body_force[i][k];
            *held += b * b;
        }
    }
}

/// The relative residual from the sums of `add_residual_terms`, and the loading's squared
/// norm it is measured against.
fn relative_of(free: f64, held: f64, largest_load: f64) -> (f64, f64) {
    // Against the largest loading of any equilibrium so far: once a crack has cut the
    // body and the reactions vanish, equilibrium is still judged at the scale of the loads
    // it carried.
    let held = held.max(largest_load);
    let relative = if held > 0.0 {
        (free / held).sqrt()
    } else if free == 0.0 {
        0.0
    } else {
        f64::INFINITY
    };
    (relative, held)
}

/// |V (f + b)|² of owned node i over its free components.
fn own_residual<const D: usize, M: Material<D>>(sim: &Simulation<D, M>, i: usize) -> f64 {
    let (s, mask, vol) = (&sim.state, &sim.constrained_mask, &sim.body.volumes);
    let mut own = 0.0;
    for k in (0..D).filter(|&k| !mask[i][k]) {
        let f = vol[i] * (s.force[i][k] + s.body_force[i][k]);
        own += f * f;
    }
    own
}

/// The node with the largest out-of-balance force (the first in the node order of those
/// with it), as its global index and its position: on every rank of a distributed run (each
/// calls it), from the rank that owns it.
fn worst_node<const D: usize, M: Material<D>>(sim: &Simulation<D, M>) -> (usize, String) {
    let (mut worst, mut node) = (-1.0, 0);
    for i in 0..sim.owned() {
        let own = own_residual(sim, i);
        if own > worst {
            (worst, node) = (own, i);
        }
    }
    let position = |i: usize| format!("{:?}", sim.body.positions[i].iter().collect::<Vec<_>>());
    let Some(s) = sim.share.as_deref() else {
        return (node, position(node));
    };
    // The largest over the ranks, then the first rank that has it (never NaN: `worst` only
    // takes values above −1).
    let top = s.ranks.max_f64(worst);
    let mine = (worst == top).then_some(s.ranks.rank());
    let first = s.ranks.min_f64(mine.map_or(f64::INFINITY, |r| r as f64));
    let message =
        (mine == Some(first as usize)).then(|| format!("{}\n{}", s.first + node, position(node)));
    let message = s.ranks.first_message(message).unwrap_or_default();
    let (node, position) = message.split_once('\n').unwrap_or(("0", ""));
    (node.parse().unwrap_or(0), position.to_string())
}
