//! Morris elementary-effects screening (Morris 1991, Technometrics 33:161) with the trajectory
//! selection of Campolongo, Cariboni & Saltelli 2007 (Environ. Model. Softw. 22:1509), as used
//! in seed 004 §3 (Willberg et al. 2022: k = 9 factors, r = 5 trajectories, 50 runs).
//!
//! The design lives in the unit hypercube on a grid of `p` levels {0, 1/(p−1), …, 1}. A
//! trajectory is k+1 points; between consecutive points exactly one factor moves by ±Δ, each
//! factor once. Each move gives one elementary effect per trajectory; their mean μ, mean
//! absolute value μ* and standard deviation σ over the trajectories rank the factors (μ*: how
//! much a factor matters; σ: how much its effect depends on the other factors or on itself).
//!
//! Seed 004 builds its trajectories from a Latin hypercube sample of size 20; here the pool is
//! the one of Campolongo 2007: N random Morris trajectories, of which the r most spread out
//! are kept.
//!
//! Run order: trajectory by trajectory, k+1 runs each; `MorrisDesign::points` and the outputs
//! given to `morris_statistics` follow it.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One input varied by the study, between `lo` and `hi` (physical units).
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    pub name: String,
    pub lo: f64,
    pub hi: f64,
}

impl Factor {
    pub fn new(name: impl Into<String>, lo: f64, hi: f64) -> Self {
        Factor {
            name: name.into(),
            lo,
            hi,
        }
    }

    /// The physical value of unit-cube coordinate `x`: lo + x (hi − lo).
    pub fn physical(&self, x: f64) -> f64 {
        self.lo + x * (self.hi - self.lo)
    }
}

/// How the design is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MorrisOptions {
    /// r: trajectories kept, each k+1 runs. At least 2 (σ needs two effects).
    pub trajectories: usize,
    /// N: trajectories drawn before keeping the r most spread out (Campolongo 2007).
    /// `pool == trajectories` keeps the random trajectories as drawn (plain Morris 1991).
    pub pool: usize,
    /// p: grid levels per factor, even and at least 2.
    pub levels: usize,
    /// The same seed gives the same design on every machine (ChaCha8).
    pub seed: u64,
}

impl Default for MorrisOptions {
    /// Seed 004 §3: r = 5 out of N = 20; p = 4 levels (the usual choice, Campolongo 2007).
    fn default() -> Self {
        MorrisOptions {
            trajectories: 5,
            pool: 20,
            levels: 4,
            seed: 0,
        }
    }
}

/// How the r trajectories were picked from the pool.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Selection {
    /// No pool (N = r): the random trajectories as drawn.
    AsDrawn,
    /// Every r-subset of the pool compared; the most spread out kept.
    Exhaustive,
    /// Too many subsets to compare (more than `EXHAUSTIVE_LIMIT`): greedy, see `select_greedy`.
    Greedy,
}

/// Largest C(N, r) searched exhaustively; N = 20, r = 5 (seed 004) is 15 504.
pub const EXHAUSTIVE_LIMIT: u128 = 200_000;

/// Points of one trajectory in the unit cube: k+1 points of k coordinates.
pub type Trajectory = Vec<Vec<f64>>;

/// Why a design or its evaluation was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyError {
    #[error("a Morris design needs at least one factor")]
    NoFactors,
    #[error("factor `{name}`: bounds must be finite numbers, got [{lo}, {hi}]")]
    NonFiniteBounds { name: String, lo: f64, hi: f64 },
    #[error("factor `{name}`: lower bound {lo} is not below upper bound {hi}")]
    BoundsOrder { name: String, lo: f64, hi: f64 },
    #[error("factor `{0}` is given twice")]
    DuplicateFactor(String),
    #[error("levels must be an even number ≥ 2, got {0}")]
    Levels(usize),
    #[error("r = {0} trajectories is too few: the standard deviation σ needs r ≥ 2")]
    TooFewTrajectories(usize),
    #[error("r = {trajectories} trajectories cannot be chosen from a pool of {pool}")]
    PoolTooSmall { trajectories: usize, pool: usize },
    #[error(
        "expected {expected} outputs ({trajectories} trajectories × {per_trajectory} runs), got {got}"
    )]
    OutputCount {
        expected: usize,
        trajectories: usize,
        per_trajectory: usize,
        got: usize,
    },
}

/// A Morris design: r trajectories in the unit cube and the factors that scale them.
#[derive(Debug, Clone, PartialEq)]
pub struct MorrisDesign {
    factors: Vec<Factor>,
    levels: usize,
    selection: Selection,
    trajectories: Vec<Trajectory>,
}

impl MorrisDesign {
    /// Draws `options.pool` trajectories from `options.seed` and keeps the
    /// `options.trajectories` most spread out; refuses bad factors and options.
    pub fn new(factors: Vec<Factor>, options: &MorrisOptions) -> Result<Self, StudyError> {
        check_factors(&factors)?;
        let levels = options.levels;
        if levels < 2 || !levels.is_multiple_of(2) {
            return Err(StudyError::Levels(levels));
        }
        let r = options.trajectories;
        if r < 2 {
            return Err(StudyError::TooFewTrajectories(r));
        }
        if options.pool < r {
            return Err(StudyError::PoolTooSmall {
                trajectories: r,
                pool: options.pool,
            });
        }

        let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
        let pool: Vec<Trajectory> = (0..options.pool)
            .map(|_| random_trajectory(factors.len(), levels, &mut rng))
            .collect();
        let (selection, chosen) = select_spread(&pool, r);
        let trajectories = chosen.into_iter().map(|t| pool[t].clone()).collect();
        Ok(MorrisDesign {
            factors,
            levels,
            selection,
            trajectories,
        })
    }

    pub fn factors(&self) -> &[Factor] {
        &self.factors
    }

    /// p, the grid levels per factor.
    pub fn levels(&self) -> usize {
        self.levels
    }

    /// Δ = p / (2(p−1)) in unit-cube units (Morris 1991).
    pub fn delta(&self) -> f64 {
        jump_of(self.levels)
    }

    pub fn selection(&self) -> Selection {
        self.selection
    }

    /// D of the kept trajectories (Campolongo 2007), for reports: larger is better spread.
    pub fn spread(&self) -> f64 {
        let kept: Vec<&Trajectory> = self.trajectories.iter().collect();
        spread(&kept)
    }

    /// The r trajectories in the unit cube.
    pub fn trajectories(&self) -> &[Trajectory] {
        &self.trajectories
    }

    /// Simulations needed: r (k+1).
    pub fn runs(&self) -> usize {
        self.trajectories.len() * (self.factors.len() + 1)
    }

    /// The design points in the unit cube, in run order.
    pub fn unit_points(&self) -> impl Iterator<Item = &[f64]> + '_ {
        self.trajectories.iter().flatten().map(|p| p.as_slice())
    }

    /// The design points in physical values (x_phys = lo + x (hi − lo)), in run order.
    pub fn points(&self) -> impl Iterator<Item = Vec<f64>> + '_ {
        self.unit_points().map(|unit| {
            self.factors
                .iter()
                .zip(unit)
                .map(|(factor, &x)| factor.physical(x))
                .collect()
        })
    }
}

/// Screening result of one factor for one output.
#[derive(Debug, Clone, PartialEq)]
pub struct FactorEffect {
    pub name: String,
    /// μ: mean elementary effect (signed).
    pub mu: Option<f64>,
    /// μ*: mean absolute elementary effect (Campolongo 2007).
    pub mu_star: Option<f64>,
    /// σ: sample standard deviation of the elementary effects.
    pub sigma: Option<f64>,
    /// Elementary effects behind the numbers: r, minus those lost to failed runs.
    pub effects: usize,
}

/// μ, μ* and σ of every factor for one output, `outputs[run]` in run order.
///
/// Elementary effects are in unit-cube units: the change of the output when a factor moves
/// across its whole range would be ≈ the effect (multiply by 1/(hi − lo) for physical units).
///
/// A failed run is `None` (a NaN or infinite output counts as failed too): the two elementary
/// effects that need it (the moves into and out of that point) are skipped, and `effects` says
/// how many each factor kept. With no effect left, μ, μ* and σ are `None`; with one, σ is `None`.
pub fn morris_statistics(
    design: &MorrisDesign,
    outputs: &[Option<f64>],
) -> Result<Vec<FactorEffect>, StudyError> {
    let per_trajectory = design.factors.len() + 1;
    if outputs.len() != design.runs() {
        return Err(StudyError::OutputCount {
            expected: design.runs(),
            trajectories: design.trajectories.len(),
            per_trajectory,
            got: outputs.len(),
        });
    }

    let mut effects: Vec<Vec<f64>> = vec![Vec::new(); design.factors.len()];
    for (trajectory, ys) in design
        .trajectories
        .iter()
        .zip(outputs.chunks(per_trajectory))
    {
        for (points, y) in trajectory.windows(2).zip(ys.windows(2)) {
            let (before, after) = (&points[0], &points[1]);
            // By construction exactly one coordinate differs between consecutive points.
            let Some(moved) = (0..before.len()).find(|&i| before[i] != after[i]) else {
                continue;
            };
            let (Some(y_before), Some(y_after)) = (usable(y[0]), usable(y[1])) else {
                continue;
            };
            // Morris 1991, elementary effect d_i = [y(x + Δe_i) − y(x)] / Δ; dividing by the
            // signed step keeps it right for −Δ moves.
            effects[moved].push((y_after - y_before) / (after[moved] - before[moved]));
        }
    }

    Ok(design
        .factors
        .iter()
        .zip(&effects)
        .map(|(factor, ee)| summarize(&factor.name, ee))
        .collect())
}

/// A finite output, or `None` for a failed run.
fn usable(y: Option<f64>) -> Option<f64> {
    y.filter(|v| v.is_finite())
}

/// μ, μ*, σ of one factor's elementary effects.
fn summarize(name: &str, ee: &[f64]) -> FactorEffect {
    let n = ee.len();
    if n == 0 {
        return FactorEffect {
            name: name.to_string(),
            mu: None,
            mu_star: None,
            sigma: None,
            effects: 0,
        };
    }
    let count = n as f64;
    // Morris 1991: μ = (1/r) Σ ee; Campolongo 2007: μ* = (1/r) Σ |ee| (seed 004 Eq. 3).
    let mu = ee.iter().sum::<f64>() / count;
    let mu_star = ee.iter().map(|e| e.abs()).sum::<f64>() / count;
    // σ² = 1/(r−1) Σ (ee − μ)², the sample variance of Morris 1991 and Campolongo 2007.
    // Seed 004 Eq. 4 is garbled as printed (1/r, square outside the sum); the standard form is
    // used. A 1/r form would be smaller by √((r−1)/r).
    let sigma = (n >= 2).then(|| {
        let squares: f64 = ee.iter().map(|e| (e - mu) * (e - mu)).sum();
        (squares / (count - 1.0)).sqrt()
    });
    FactorEffect {
        name: name.to_string(),
        mu: Some(mu),
        mu_star: Some(mu_star),
        sigma,
        effects: n,
    }
}

fn check_factors(factors: &[Factor]) -> Result<(), StudyError> {
    if factors.is_empty() {
        return Err(StudyError::NoFactors);
    }
    for (i, factor) in factors.iter().enumerate() {
        let (name, lo, hi) = (factor.name.clone(), factor.lo, factor.hi);
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(StudyError::NonFiniteBounds { name, lo, hi });
        }
        if lo >= hi {
            return Err(StudyError::BoundsOrder { name, lo, hi });
        }
        if factors[..i].iter().any(|f| f.name == factor.name) {
            return Err(StudyError::DuplicateFactor(name));
        }
    }
    Ok(())
}

/// Δ = p / (2(p−1)) (Morris 1991).
fn jump_of(levels: usize) -> f64 {
    levels as f64 / (2.0 * (levels as f64 - 1.0))
}

/// One random Morris trajectory of k factors on a p-level grid.
///
/// Morris 1991's orientation matrix B* = (J x* + (Δ/2)[(2B − J) D* + J]) P*, worked in grid
/// indices so every coordinate is exactly a level: Δ is p/2 grid steps; the base x* has levels
/// {0, …, p/2 − 1} (so x* + Δ ≤ 1); a factor with D*_ii = +1 starts at x* and moves to x* + Δ,
/// one with −1 starts at x* + Δ and moves to x*; P* is the random order of the moves.
fn random_trajectory(k: usize, levels: usize, rng: &mut ChaCha8Rng) -> Trajectory {
    let jump = levels / 2;
    let base: Vec<usize> = (0..k).map(|_| rng.random_range(0..jump)).collect();
    let upward: Vec<bool> = (0..k).map(|_| rng.random_bool(0.5)).collect();
    let mut order: Vec<usize> = (0..k).collect();
    order.shuffle(rng);

    let top = (levels - 1) as f64;
    let to_unit = |grid: &[usize]| grid.iter().map(|&g| g as f64 / top).collect::<Vec<f64>>();
    let mut grid: Vec<usize> = (0..k)
        .map(|i| if upward[i] { base[i] } else { base[i] + jump })
        .collect();
    let mut points = Vec::with_capacity(k + 1);
    points.push(to_unit(&grid));
    for &i in &order {
        grid[i] = if upward[i] { base[i] + jump } else { base[i] };
        points.push(to_unit(&grid));
    }
    points
}

/// Campolongo 2007: distance between trajectories m and l,
/// d_ml = Σ_i Σ_j ‖X_i^(m) − X_j^(l)‖ over their points i and j.
fn trajectory_distance(m: &Trajectory, l: &Trajectory) -> f64 {
    m.iter()
        .flat_map(|a| l.iter().map(move |b| euclidean(a, b)))
        .sum()
}

fn euclidean(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Campolongo 2007: spread of a set of trajectories, D = √(Σ over pairs d_ml²).
fn spread(trajectories: &[&Trajectory]) -> f64 {
    let mut sum = 0.0;
    for (a, m) in trajectories.iter().enumerate() {
        for l in &trajectories[a + 1..] {
            let d = trajectory_distance(m, l);
            sum += d * d;
        }
    }
    sum.sqrt()
}

/// Indices (ascending, so run order follows the pool) of the r trajectories of `pool` to keep.
fn select_spread(pool: &[Trajectory], r: usize) -> (Selection, Vec<usize>) {
    if pool.len() == r {
        return (Selection::AsDrawn, (0..r).collect());
    }
    let squared: Vec<Vec<f64>> = pool
        .iter()
        .map(|m| {
            pool.iter()
                .map(|l| trajectory_distance(m, l).powi(2))
                .collect()
        })
        .collect();
    if binomial_capped(pool.len(), r) <= EXHAUSTIVE_LIMIT {
        (Selection::Exhaustive, select_exhaustive(&squared, r))
    } else {
        let mut chosen = select_greedy(&squared, r);
        chosen.sort_unstable();
        (Selection::Greedy, chosen)
    }
}

/// Σ over pairs of `subset` of d², i.e. D² (maximizing it maximizes D).
fn spread_squared(squared: &[Vec<f64>], subset: &[usize]) -> f64 {
    let mut sum = 0.0;
    for (a, &m) in subset.iter().enumerate() {
        for &l in &subset[a + 1..] {
            sum += squared[m][l];
        }
    }
    sum
}

/// The r-subset with the largest D (Campolongo 2007), comparing all C(N, r); the first in
/// lexicographic order wins a tie.
fn select_exhaustive(squared: &[Vec<f64>], r: usize) -> Vec<usize> {
    let mut subset: Vec<usize> = (0..r).collect();
    let mut best = subset.clone();
    let mut best_sum = spread_squared(squared, &subset);
    while next_combination(&mut subset, squared.len()) {
        let sum = spread_squared(squared, &subset);
        if sum > best_sum {
            best_sum = sum;
            best.clone_from(&subset);
        }
    }
    best
}

/// Steps `subset` to the next r-subset of {0, …, n−1} in lexicographic order; false after the last.
fn next_combination(subset: &mut [usize], n: usize) -> bool {
    let r = subset.len();
    for i in (0..r).rev() {
        if subset[i] < n - r + i {
            subset[i] += 1;
            for j in i + 1..r {
                subset[j] = subset[j - 1] + 1;
            }
            return true;
        }
    }
    false
}

/// Greedy stand-in for the exhaustive search when C(N, r) is too large: start from the pair
/// with the largest distance, then repeatedly add the trajectory whose Σ d² to those already
/// kept is largest (the one that raises D most). Not guaranteed optimal.
fn select_greedy(squared: &[Vec<f64>], r: usize) -> Vec<usize> {
    let n = squared.len();
    let mut pair = (0, 1);
    for m in 0..n {
        for l in m + 1..n {
            if squared[m][l] > squared[pair.0][pair.1] {
                pair = (m, l);
            }
        }
    }
    let mut chosen = vec![pair.0, pair.1];
    while chosen.len() < r {
        let gain = |c: usize| chosen.iter().map(|&m| squared[m][c]).sum::<f64>();
        let mut best: Option<(usize, f64)> = None;
        for c in (0..n).filter(|c| !chosen.contains(c)) {
            let g = gain(c);
            if best.is_none_or(|(_, b)| g > b) {
                best = Some((c, g));
            }
        }
        match best {
            Some((c, _)) => chosen.push(c),
            None => break, // pool exhausted; cannot happen as r ≤ N
        }
    }
    chosen
}

/// C(n, r), or some value above `EXHAUSTIVE_LIMIT` once it is known to exceed it.
fn binomial_capped(n: usize, r: usize) -> u128 {
    // C(n, i) grows with i up to n/2, so stopping early on the smaller side is safe.
    let r = r.min(n - r);
    let mut c: u128 = 1;
    for i in 0..r {
        c = c * (n - i) as u128 / (i + 1) as u128;
        if c > EXHAUSTIVE_LIMIT {
            return c;
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_factors(k: usize) -> Vec<Factor> {
        (0..k)
            .map(|i| Factor::new(format!("x{}", i + 1), 0.0, 1.0))
            .collect()
    }

    fn options(r: usize, pool: usize, seed: u64) -> MorrisOptions {
        MorrisOptions {
            trajectories: r,
            pool,
            levels: 4,
            seed,
        }
    }

    fn evaluate(design: &MorrisDesign, model: impl Fn(&[f64]) -> f64) -> Vec<Option<f64>> {
        design.points().map(|x| Some(model(&x))).collect()
    }

    /// The result of the factor called `name`.
    fn effect(effects: &[FactorEffect], name: &str) -> FactorEffect {
        effects
            .iter()
            .find(|e| e.name == name)
            .cloned()
            .unwrap_or_else(|| panic!("no factor {name}"))
    }

    #[test]
    fn seed_004_design_has_morris_structure() {
        let k = 9;
        let design = MorrisDesign::new(unit_factors(k), &options(5, 20, 4)).expect("valid");
        assert_eq!(design.runs(), 50);
        assert_eq!(design.unit_points().count(), 50);
        assert_eq!(design.points().count(), 50);
        assert_eq!(design.trajectories().len(), 5);
        assert_eq!(design.selection(), Selection::Exhaustive);
        let delta = 2.0 / 3.0;
        assert!((design.delta() - delta).abs() < 1e-15);

        for x in design.unit_points() {
            assert_eq!(x.len(), k);
            for &v in x {
                let on_grid = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0]
                    .iter()
                    .any(|g| (v - g).abs() < 1e-12);
                assert!(on_grid, "{v} is not a level of the 4-level grid");
            }
        }
        for trajectory in design.trajectories() {
            assert_eq!(trajectory.len(), k + 1);
            let mut moves = vec![0; k];
            for pair in trajectory.windows(2) {
                let changed: Vec<usize> = (0..k)
                    .filter(|&i| (pair[1][i] - pair[0][i]).abs() > 1e-12)
                    .collect();
                assert_eq!(changed.len(), 1, "one factor moves per step");
                let i = changed[0];
                assert!(((pair[1][i] - pair[0][i]).abs() - delta).abs() < 1e-12);
                moves[i] += 1;
            }
            assert_eq!(moves, vec![1; k], "each factor moves exactly once");
        }
    }

    #[test]
    fn points_are_scaled_to_the_bounds() {
        let factors = vec![
            Factor::new("E", 2.0e9, 3.0e9),
            Factor::new("nu", -0.5, 0.25),
        ];
        let design = MorrisDesign::new(factors, &options(3, 6, 1)).expect("valid");
        for (unit, physical) in design.unit_points().zip(design.points()) {
            assert!((physical[0] - (2.0e9 + unit[0] * 1.0e9)).abs() <= 1e-6);
            assert!((physical[1] - (-0.5 + unit[1] * 0.75)).abs() <= 1e-15);
            assert!((2.0e9..=3.0e9).contains(&physical[0]));
            assert!((-0.5..=0.25).contains(&physical[1]));
        }
    }

    #[test]
    fn linear_model_effects_are_coefficient_times_range() {
        let factors = vec![
            Factor::new("a", 1.0, 3.0),
            Factor::new("b", -2.0, 5.0),
            Factor::new("c", 10.0, 10.5),
            Factor::new("d", 0.0, 4.0),
        ];
        let coefficients = [2.0, -3.0, 7.0, 0.0];
        let design = MorrisDesign::new(factors.clone(), &options(6, 12, 7)).expect("valid");
        let linear = |x: &[f64]| coefficients.iter().zip(x).map(|(a, x)| a * x).sum();
        let outputs = evaluate(&design, linear);

        // Every trajectory's own effect, checked from the raw design (no statistics code).
        let per = factors.len() + 1;
        for (t, trajectory) in design.trajectories().iter().enumerate() {
            for j in 0..factors.len() {
                let (before, after) = (&trajectory[j], &trajectory[j + 1]);
                let i = (0..factors.len())
                    .find(|&i| before[i] != after[i])
                    .expect("one factor moves");
                let y0 = outputs[t * per + j].expect("ran");
                let y1 = outputs[t * per + j + 1].expect("ran");
                let ee = (y1 - y0) / (after[i] - before[i]);
                let expected = coefficients[i] * (factors[i].hi - factors[i].lo);
                assert!((ee - expected).abs() <= 1e-9 * expected.abs().max(1.0));
            }
        }

        let effects = morris_statistics(&design, &outputs).expect("valid outputs");
        for ((factor, a), e) in factors.iter().zip(coefficients).zip(&effects) {
            let expected = a * (factor.hi - factor.lo);
            let scale = expected.abs().max(1.0);
            assert_eq!(e.name, factor.name);
            assert_eq!(e.effects, 6);
            let (mu, mu_star, sigma) = (e.mu.unwrap(), e.mu_star.unwrap(), e.sigma.unwrap());
            assert!((mu - expected).abs() <= 1e-9 * scale, "{}: μ {mu}", e.name);
            assert!((mu_star - expected.abs()).abs() <= 1e-9 * scale);
            assert!(sigma <= 1e-9 * scale, "{}: σ {sigma}", e.name);
        }
        assert_eq!(effect(&effects, "b").mu.unwrap().signum(), -1.0);
        assert!(effect(&effects, "d").mu_star.unwrap() == 0.0);
    }

    #[test]
    fn interaction_and_curvature_show_in_sigma() {
        let design = MorrisDesign::new(unit_factors(4), &options(10, 20, 11)).expect("valid");
        let outputs = evaluate(&design, |x| x[0] * x[1] + x[2] * x[2]);
        let effects = morris_statistics(&design, &outputs).expect("valid");
        for name in ["x1", "x2", "x3"] {
            let e = effect(&effects, name);
            assert!(e.mu_star.unwrap() > 0.1, "{name}: μ* {:?}", e.mu_star);
            assert!(e.sigma.unwrap() > 1e-3, "{name}: σ {:?}", e.sigma);
        }
        let idle = effect(&effects, "x4");
        assert_eq!(idle.mu_star, Some(0.0));
        assert_eq!(idle.sigma, Some(0.0));
    }

    #[test]
    fn mu_star_ranks_factors_by_influence() {
        let design = MorrisDesign::new(unit_factors(3), &options(5, 20, 3)).expect("valid");
        let outputs = evaluate(&design, |x| 10.0 * x[0] + x[1] + 0.1 * x[2]);
        let effects = morris_statistics(&design, &outputs).expect("valid");
        let mu_star: Vec<f64> = effects.iter().map(|e| e.mu_star.unwrap()).collect();
        assert!(
            mu_star[0] > mu_star[1] && mu_star[1] > mu_star[2],
            "{mu_star:?}"
        );
    }

    /// The pool a design was chosen from, drawn again from the same seed.
    fn pool_of(k: usize, opts: &MorrisOptions) -> Vec<Trajectory> {
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        (0..opts.pool)
            .map(|_| random_trajectory(k, opts.levels, &mut rng))
            .collect()
    }

    #[test]
    fn campolongo_selection_is_the_most_spread_subset() {
        let k = 4;
        // Several seeds, so a pool whose first r happen to be the best cannot pass alone.
        let mut beat_first = 0;
        for seed in 0..6 {
            let opts = options(3, 8, seed);
            let design = MorrisDesign::new(unit_factors(k), &opts).expect("valid");
            assert_eq!(design.selection(), Selection::Exhaustive);
            let pool = pool_of(k, &opts);
            for t in design.trajectories() {
                assert!(pool.contains(t), "kept trajectories come from the pool");
            }
            let chosen = design.spread();

            let mut best = 0.0_f64;
            let mut subsets = 0;
            for a in 0..8 {
                for b in a + 1..8 {
                    for c in b + 1..8 {
                        let other = spread(&[&pool[a], &pool[b], &pool[c]]);
                        assert!(chosen >= other - 1e-12, "{a},{b},{c}: {other} > {chosen}");
                        best = best.max(other);
                        subsets += 1;
                    }
                }
            }
            assert_eq!(subsets, 56);
            assert!((chosen - best).abs() <= 1e-12 * best);
            let first = spread(&[&pool[0], &pool[1], &pool[2]]);
            assert!(chosen >= first);
            if chosen > first {
                beat_first += 1;
            }
        }
        assert!(
            beat_first > 0,
            "the selection never differed from the first r"
        );
    }

    #[test]
    fn greedy_selection_on_a_large_pool_beats_the_first_trajectories() {
        let k = 3;
        let opts = options(10, 30, 9); // C(30, 10) ≈ 3e7: greedy
        let design = MorrisDesign::new(unit_factors(k), &opts).expect("valid");
        assert_eq!(design.selection(), Selection::Greedy);
        assert_eq!(design.trajectories().len(), 10);
        let pool = pool_of(k, &opts);
        let first: Vec<&Trajectory> = pool.iter().take(10).collect();
        assert!(design.spread() > spread(&first));
    }

    #[test]
    fn without_a_pool_the_trajectories_are_kept_as_drawn() {
        let opts = options(4, 4, 2);
        let design = MorrisDesign::new(unit_factors(3), &opts).expect("valid");
        assert_eq!(design.selection(), Selection::AsDrawn);
        assert_eq!(design.trajectories(), pool_of(3, &opts).as_slice());
    }

    #[test]
    fn combinations_and_their_count() {
        let mut subset = vec![0, 1, 2];
        let mut count = 1;
        while next_combination(&mut subset, 8) {
            assert!(subset.windows(2).all(|w| w[0] < w[1]) && subset[2] < 8);
            count += 1;
        }
        assert_eq!(count, 56);
        assert_eq!(binomial_capped(20, 5), 15_504);
        assert_eq!(binomial_capped(30, 29), 30);
        assert!(binomial_capped(30, 10) > EXHAUSTIVE_LIMIT);
    }

    #[test]
    fn a_failed_run_costs_only_the_effects_that_need_it() {
        let k = 4;
        let design = MorrisDesign::new(unit_factors(k), &options(5, 10, 8)).expect("valid");
        let mut outputs = evaluate(&design, |x| 3.0 * x[0] - x[1] + x[2] * x[3]);
        // Run 2 of trajectory 1 sits between the moves of steps 1 and 2.
        let failed = (k + 1) + 2;
        outputs[failed] = None;
        let trajectory = &design.trajectories()[1];
        let moved = |step: usize| {
            (0..k)
                .find(|&i| trajectory[step][i] != trajectory[step + 1][i])
                .expect("one factor moves")
        };
        let lost = [moved(1), moved(2)];

        let effects = morris_statistics(&design, &outputs).expect("valid");
        for (i, e) in effects.iter().enumerate() {
            let expected = if lost.contains(&i) { 4 } else { 5 };
            assert_eq!(e.effects, expected, "{}", e.name);
            assert!(e.mu.unwrap().is_finite());
            assert!(e.mu_star.unwrap().is_finite());
            assert!(e.sigma.unwrap().is_finite());
        }

        // A NaN output is a failed run as well.
        outputs[failed] = Some(f64::NAN);
        assert_eq!(
            morris_statistics(&design, &outputs).expect("valid"),
            effects
        );
    }

    #[test]
    fn a_factor_with_no_effect_left_reports_none() {
        let design = MorrisDesign::new(unit_factors(2), &options(2, 2, 0)).expect("valid");
        let all_failed = vec![None; design.runs()];
        for e in morris_statistics(&design, &all_failed).expect("valid") {
            assert_eq!((e.effects, e.mu, e.mu_star, e.sigma), (0, None, None, None));
        }

        // One effect left: μ and μ* exist, σ does not.
        let mut outputs = evaluate(&design, |x| x[0] + x[1]);
        // Trajectory 2 (runs 3, 4, 5) failed entirely.
        outputs[3..6].fill(None);
        for e in morris_statistics(&design, &outputs).expect("valid") {
            assert_eq!(e.effects, 1);
            assert!((e.mu.unwrap() - 1.0).abs() < 1e-12);
            assert_eq!(e.sigma, None);
        }
    }

    #[test]
    fn statistics_of_known_effects() {
        // ee = {1, −3, 5}: μ = 1, μ* = 3, σ² = (0 + 16 + 16) / (3 − 1) = 16 (1/(r−1) form).
        let e = summarize("x", &[1.0, -3.0, 5.0]);
        assert_eq!(e.effects, 3);
        assert!((e.mu.unwrap() - 1.0).abs() < 1e-15);
        assert!((e.mu_star.unwrap() - 3.0).abs() < 1e-15);
        assert!((e.sigma.unwrap() - 4.0).abs() < 1e-15);
    }

    fn refusal(factors: Vec<Factor>, opts: MorrisOptions) -> String {
        match MorrisDesign::new(factors, &opts) {
            Ok(_) => panic!("accepted a bad design"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn bad_input_is_refused_with_clear_messages() {
        let ok = options(5, 20, 0);
        assert_eq!(
            refusal(vec![Factor::new("E", 3e9, 2e9)], ok),
            "factor `E`: lower bound 3000000000 is not below upper bound 2000000000"
        );
        assert_eq!(
            refusal(vec![Factor::new("nu", 0.3, 0.3)], ok),
            "factor `nu`: lower bound 0.3 is not below upper bound 0.3"
        );
        assert_eq!(
            refusal(vec![Factor::new("G", f64::NAN, 1.0)], ok),
            "factor `G`: bounds must be finite numbers, got [NaN, 1]"
        );
        assert_eq!(
            refusal(vec![Factor::new("G", 0.0, f64::INFINITY)], ok),
            "factor `G`: bounds must be finite numbers, got [0, inf]"
        );
        assert_eq!(
            refusal(vec![], ok),
            "a Morris design needs at least one factor"
        );
        assert_eq!(
            refusal(
                vec![Factor::new("a", 0.0, 1.0), Factor::new("a", 1.0, 2.0)],
                ok
            ),
            "factor `a` is given twice"
        );
        for levels in [0, 1, 5] {
            assert_eq!(
                refusal(unit_factors(2), MorrisOptions { levels, ..ok }),
                format!("levels must be an even number ≥ 2, got {levels}")
            );
        }
        assert_eq!(
            refusal(unit_factors(2), options(6, 5, 0)),
            "r = 6 trajectories cannot be chosen from a pool of 5"
        );
        assert_eq!(
            refusal(unit_factors(2), options(1, 20, 0)),
            "r = 1 trajectories is too few: the standard deviation σ needs r ≥ 2"
        );

        let design = MorrisDesign::new(unit_factors(9), &ok).expect("valid");
        let short = vec![Some(1.0); 49];
        assert_eq!(
            morris_statistics(&design, &short).map_err(|e| e.to_string()),
            Err("expected 50 outputs (5 trajectories × 10 runs), got 49".to_string())
        );
    }

    #[test]
    fn two_levels_give_corner_designs() {
        let opts = MorrisOptions {
            levels: 2,
            ..options(3, 6, 4)
        };
        let design = MorrisDesign::new(unit_factors(3), &opts).expect("valid");
        assert_eq!(design.delta(), 1.0);
        assert!(design
            .unit_points()
            .flatten()
            .all(|&v| v == 0.0 || v == 1.0));
    }

    #[test]
    fn same_seed_same_design_bit_for_bit() {
        let draw = |seed| MorrisDesign::new(unit_factors(9), &options(5, 20, seed)).expect("ok");
        let bits = |d: &MorrisDesign| -> Vec<u64> {
            d.unit_points().flatten().map(|v| v.to_bits()).collect()
        };
        assert_eq!(bits(&draw(42)), bits(&draw(42)));
        assert_eq!(draw(42), draw(42));
        assert_ne!(bits(&draw(42)), bits(&draw(43)));
    }
}
