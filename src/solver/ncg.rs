//! Nonlinear conjugate gradients: equilibrium as the minimum of the potential energy
//! Π(u) = Σ_i W_i V_i − Σ_i b_i·u_i V_i over the free degrees of freedom, for convex models
//! (seed 000 §2.10, seed 001 §2.10: PMB with critical stretch; softening laws are not convex).
//!
//! Polak–Ribière with restarts (β ≤ 0, or every `n` iterations), Jacobi-preconditioned by the
//! same diagonal stiffness bound as dynamic relaxation (plus, with two levels, the coarse
//! grid's correction of `coarse_space.rs`), and a secant line search on the
//! directional derivative Π'(u + αd)·d = −r(u + αd)·d (Shewchuk 1994, "An introduction to the
//! conjugate gradient method without the agonizing pain", algorithm B5): only force
//! evaluations, no energy. The residual r = V (f + b) on the free components is the negative
//! gradient. The secant iteration stops once the directional derivative has fallen to 1 % of
//! its value at α = 0 (|η(α)| ≤ 10⁻² |η(0)|: the strong-Wolfe curvature condition with
//! σ = 0.01, Nocedal & Wright 2006, §3.1 and §5.2, tighter than the σ < ½ nonlinear CG asks
//! for), or when a secant step changes α by less than 10⁻⁶ of it. On a nearly quadratic Π the
//! first secant step lands there, so an iteration costs two force evaluations (the probe and
//! the step) instead of the three that confirming the step to 10⁻⁶ took
//! (`QuasiStaticSettings::exact_line_search` keeps that search). The minimiser stops on the
//! caller's residual test either way: the equilibria satisfy the same tolerance. Bonds do not break during a minimisation (the caller freezes the damage state).

use super::coarse_space::CoarseSpace;
use super::quasi_static_memory::Pause;
use super::ranks::{chunked_sums, Share};
use super::{Simulation, StepError};
use crate::material::Material;
use crate::math::Vector;
use rayon::prelude::*;

/// Fixed chunk for deterministic parallel sums.
const CHUNK: usize = 4096;

/// The minimiser's buffers: preconditioner, search direction, residuals. A distributed run's
/// rank minimises over its owned nodes (the ghosts take their owners' displacements at each
/// force evaluation), and its dot products continue the one process's sums across ranks.
pub struct Ncg<const D: usize> {
    /// 1/(V_i λ_i) per node: the inverse of the diagonal stiffness bound.
    inverse_diagonal: Vec<f64>,
    /// The search direction (a paused minimisation continues along it: a checkpoint keeps it).
    pub(super) direction: Vec<Vector<D>>,
    exact_line_search: bool,
    /// The two-level preconditioner's coarse correction added to Jacobi's (`None`: Jacobi).
    coarse: Option<CoarseSpace<D>>,
}

/// Where a minimisation continues from, when it paused: its force evaluations so far and its
/// iterations since the direction was last restarted (the direction is `Ncg::direction`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Continued {
    pub evaluations: u64,
    pub since_restart: u64,
}

/// How a minimisation ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Minimised {
    /// At the caller's equilibrium, after this many force evaluations.
    Converged(u64),
    /// `max_evaluations` reached: the state is the best found so far.
    Exhausted,
    /// Paused between two iterations, as `pause` asked; the next call continues from here.
    Paused(Continued),
}

impl<const D: usize> Ncg<D> {
    /// `stiffness`: λ_i, the diagonal bound per node (force density per displacement).
    pub fn new<M: Material<D>>(
        sim: &Simulation<D, M>,
        stiffness: &[f64],
        exact_line_search: bool,
        two_level: bool,
    ) -> Self {
        let inverse_diagonal = stiffness
            .iter()
            .zip(&sim.body.volumes)
            .map(|(&k, &v)| if k > 0.0 { 1.0 / (k * v) } else { 0.0 })
            .collect();
        Ncg {
            inverse_diagonal,
            direction: vec![Vector::zeros(); sim.owned()],
            exact_line_search,
            coarse: two_level.then(|| CoarseSpace::new(sim)),
        }
    }

    /// Minimises from the current state until `converged(sim, evaluations so far)`, or, with
    /// `continued`, goes on with the minimisation that paused there (the state and the
    /// direction as it left them). `max_evaluations` bounds the work; `pause` may stop it
    /// between two iterations (never before the first of this call). A pause changes no
    /// number: an iteration starts from the residual of the state's forces, its
    /// preconditioned copy and their product, all recomputed alike from the state.
    pub fn minimise<M: Material<D>>(
        &mut self,
        sim: &mut Simulation<D, M>,
        max_evaluations: u64,
        continued: Option<Continued>,
        pause: Option<Pause>,
        mut converged: impl FnMut(&Simulation<D, M>, u64) -> bool,
    ) -> Result<Minimised, StepError> {
        let share = sim.share.clone();
        let dot = |a: &[Vector<D>], b: &[Vector<D>]| dot(share.as_deref(), a, b);
        let n_free = sim.constrained_mask[..sim.owned()]
            .iter()
            .map(|m| m[..D].iter().filter(|c| !**c).count())
            .sum::<usize>();
        let n_free = share
            .as_deref()
            .map_or(n_free, |s| s.ranks.sum_u64(n_free as u64) as usize)
            .max(1);
        if let Some(coarse) = self.coarse.as_mut() {
            coarse.update(sim);
        }
        let mut r = self.residual(sim);
        let mut s = self.precondition(share.as_deref(), &r);
        let (mut evaluations, mut since_restart) = match continued {
            Some(c) => (c.evaluations, c.since_restart as usize),
            None => {
                self.direction.clone_from(&s);
                (0, 0)
            }
        };
        let entered = evaluations;
        let mut delta_new = dot(&r, &s);
        while !converged(sim, evaluations) {
            if evaluations >= max_evaluations {
                return Ok(Minimised::Exhausted);
            }
            if evaluations > entered && pause.is_some_and(|p| p.due(evaluations - entered)) {
                return Ok(Minimised::Paused(Continued {
                    evaluations,
                    since_restart: since_restart as u64,
                }));
            }
            // Secant line search on η(α) = Π'(u + αd)·d = −r(u + αd)·d: a probe at σ0, then
            // the root of the line through the last two points, until the step is negligible.
            let d = &self.direction;
            let [dd, rd] = dots(share.as_deref(), [(d, d), (&r, d)]);
            if dd == 0.0 {
                break;
            }
            let sigma0 = 1e-3;
            let (mut alpha_a, mut eta_a) = (0.0, -rd);
            let eta0 = eta_a;
            self.shift(sim, d, sigma0)?;
            evaluations += 1;
            let (mut alpha_b, mut eta_b) = (sigma0, -dot(&self.residual(sim), d));
            for _ in 0..8 {
                if eta_b == eta_a {
                    break;
                }
                let alpha = alpha_b - eta_b * (alpha_b - alpha_a) / (eta_b - eta_a);
                let step = alpha - alpha_b;
                self.shift(sim, d, step)?;
                evaluations += 1;
                (alpha_a, eta_a) = (alpha_b, eta_b);
                (alpha_b, eta_b) = (alpha, -dot(&self.residual(sim), d));
                // Converged when the last move is a millionth of the step taken.
                if step.abs() <= 1e-6 * alpha.abs() {
                    break;
                }
                // Or, unless exact, once the directional derivative is 1 % of its start: on a
                // nearly quadratic Π the first secant step lands there, and a third force
                // evaluation would only confirm it.
                if !self.exact_line_search && eta_b.abs() <= 1e-2 * eta0.abs() {
                    break;
                }
            }
            r = self.residual(sim);
            let delta_old = delta_new;
            let s_new = self.precondition(share.as_deref(), &r);
            let delta_mid;
            [delta_mid, delta_new] = dots(share.as_deref(), [(&r, &s), (&r, &s_new)]);
            s = s_new;
            let beta = (delta_new - delta_mid) / delta_old;
            since_restart += 1;
            if since_restart >= n_free || beta <= 0.0 {
                self.direction.clone_from(&s);
                since_restart = 0;
            } else {
                self.direction
                    .par_iter_mut()
                    .zip(s.par_iter())
                    .for_each(|(d, s)| *d = s + *d * beta);
            }
        }
        Ok(Minimised::Converged(evaluations))
    }

    /// u += α d on the free components, then the forces there.
    fn shift<M: Material<D>>(
        &self,
        sim: &mut Simulation<D, M>,
        d: &[Vector<D>],
        alpha: f64,
    ) -> Result<(), StepError> {
        let owned = sim.owned();
        let positions = &sim.body.positions[..owned];
        let s = &mut sim.state;
        (&mut s.u[..owned], &mut s.current[..owned])
            .into_par_iter()
            .zip(d.par_iter())
            .zip(positions.par_iter())
            .for_each(|(((u, y), d), x)| {
                *u += d * alpha;
                *y = x + *u;
            });
        sim.refresh_forces()?;
        Ok(())
    }

    /// r = V (f + b) on the free components, 0 on the constrained ones (owned nodes).
    fn residual<M: Material<D>>(&self, sim: &Simulation<D, M>) -> Vec<Vector<D>> {
        let (s, mask, vol) = (&sim.state, &sim.constrained_mask, &sim.body.volumes);
        (0..sim.owned())
            .into_par_iter()
            .map(|i| {
                Vector::<D>::from_fn(|k, _| {
                    if mask[i][k] {
                        0.0
                    } else {
                        vol[i] * (s.force[i][k] + s.body_force[i][k])
                    }
                })
            })
            .collect()
    }

    /// D⁻¹ r, plus the coarse correction P A_c⁻¹ Pᵀ r with two levels.
    fn precondition(&self, share: Option<&Share>, r: &[Vector<D>]) -> Vec<Vector<D>> {
        let mut s: Vec<Vector<D>> = r
            .par_iter()
            .zip(self.inverse_diagonal.par_iter())
            .map(|(r, m)| r * *m)
            .collect();
        if let Some(coarse) = &self.coarse {
            coarse.correct(share, r, &mut s);
        }
        s
    }
}

/// Σ a_i·b_i over the owned nodes in fixed chunks of the node order, each chunk summed as
/// `Iterator::sum` does and the chunks' sums then summed in order (the same for any thread
/// or rank count).
fn dot<const D: usize>(share: Option<&Share>, a: &[Vector<D>], b: &[Vector<D>]) -> f64 {
    let [sum] = dots(share, [(a, b)]);
    sum
}

/// `W` of `dot`'s sums in one pass (one exchange between ranks), each added exactly as `dot`
/// adds it alone.
fn dots<const D: usize, const W: usize>(
    share: Option<&Share>,
    pairs: [(&[Vector<D>], &[Vector<D>]); W],
) -> [f64; W] {
    // `Iterator::sum`'s start (−0.0): the sums are its left folds.
    let zero: f64 = std::iter::empty::<f64>().sum();
    let n = pairs
        .iter()
        .map(|(a, b)| a.len().min(b.len()))
        .min()
        .unwrap_or(0);
    chunked_sums(share, n, CHUNK, [zero; W], |i, acc| {
        for (sum, (a, b)) in acc.iter_mut().zip(&pairs) {
            *sum += a[i].dot(&b[i]);
        }
    })
}
