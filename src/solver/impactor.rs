//! Rigid impactors (plane, sphere/disk, cylinder) pressing on the nodes by a penalty force, as
//! LAMMPS' `fix indent`: a node at depth p inside the impactor feels F = K p² (N) along the
//! impactor's outward normal, the impactor the opposite; the penalty energy is K p³/3
//! (∫ K p² dp). An impactor either moves at a prescribed velocity (the force that keeps it so
//! does work on the body) or is a free rigid body of mass M that the body's reaction
//! decelerates, advanced by the same velocity-Verlet step as the nodes.

use crate::body::Body;
use crate::math::Vector;
use crate::solver::ranks::Share;
use crate::state::State;
use rayon::prelude::*;

/// Nodes per parallel chunk (fixed, so the reaction's sum order does not depend on threads).
const CHUNK: usize = 4096;

/// A node inside an impactor: its global index, the penalty force on it (N) and its penalty
/// energy (J).
type Contribution<const D: usize> = (usize, Vector<D>, f64);

/// Σ of the nodes' forces and energies as one process sums them: each chunk of `CHUNK` nodes
/// from zero in node order, then the chunks' sums in chunk order (a chunk with no node inside
/// adds +0, which changes no sum). `all` is in global node order.
fn chunked_sum<const D: usize>(all: &[Contribution<D>]) -> (Vector<D>, f64) {
    let (mut total, mut energy) = (Vector::<D>::zeros(), 0.0);
    let mut chunk: Option<(usize, Vector<D>, f64)> = None;
    for &(i, f, e) in all {
        match &mut chunk {
            Some((c, t, w)) if *c == i / CHUNK => {
                *t += f;
                *w += e;
            }
            _ => {
                if let Some((_, t, w)) = chunk {
                    total += t;
                    energy += w;
                }
                let (mut t, mut w) = (Vector::<D>::zeros(), 0.0);
                t += f;
                w += e;
                chunk = Some((i / CHUNK, t, w));
            }
        }
    }
    if let Some((_, t, w)) = chunk {
        total += t;
        energy += w;
    }
    (total, energy)
}

/// Contributions as words for a transfer: the index (exact in f64 below 2^53), the force,
/// the energy.
fn pack<const D: usize>(list: &[Contribution<D>]) -> Vec<f64> {
    let mut buf = Vec::with_capacity(list.len() * (D + 2));
    for (i, f, e) in list {
        buf.push(*i as f64);
        buf.extend_from_slice(f.as_slice());
        buf.push(*e);
    }
    buf
}

fn unpack<const D: usize>(words: &[f64]) -> Vec<Contribution<D>> {
    words
        .chunks_exact(D + 2)
        .map(|w| {
            let f = Vector::<D>::from_column_slice(&w[1..=D]);
            (w[0] as usize, f, w[D + 1])
        })
        .collect()
}

/// The impactor's shape, about its reference point (`Impactor::position`).
#[derive(Debug, Clone, Copy)]
pub enum ImpactorShape<const D: usize> {
    /// The half-space behind a plane through the point; `normal` (unit) points out of the
    /// impactor, towards the body. With `extent`, only nodes whose projection onto the plane
    /// lies within that distance of the point (a flat punch).
    Plane {
        normal: Vector<D>,
        extent: Option<f64>,
    },
    /// A sphere (a disk in 2D) of this radius about the point.
    Sphere { radius: f64 },
    /// A cylinder of this radius whose axis runs along z through the point (a disk in 2D).
    Cylinder { radius: f64 },
}

/// How an impactor moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// At its velocity, whatever the load.
    Prescribed,
    /// A free rigid body of this mass (kg).
    Free { mass: f64 },
}

/// One rigid impactor and its state.
#[derive(Debug, Clone)]
pub struct Impactor<const D: usize> {
    pub name: String,
    pub shape: ImpactorShape<D>,
    pub motion: Motion,
    /// Penalty constant K (N/m²).
    pub stiffness: f64,
    /// Centre (sphere), a point of the axis (cylinder) or of the plane (m).
    pub position: Vector<D>,
    /// Velocity (m/s).
    pub velocity: Vector<D>,
    /// Force of the body on the impactor at the last evaluation (N).
    pub force: Vector<D>,
    /// Penalty energy at the last evaluation (J).
    pub energy: f64,
    /// The force at the start of the current step (for the work of a prescribed motion).
    force_start: Vector<D>,
}

impl<const D: usize> Impactor<D> {
    pub fn new(
        name: String,
        shape: ImpactorShape<D>,
        motion: Motion,
        stiffness: f64,
        position: Vector<D>,
        velocity: Vector<D>,
    ) -> Self {
        Impactor {
            name,
            shape,
            motion,
            stiffness,
            position,
            velocity,
            force: Vector::zeros(),
            energy: 0.0,
            force_start: Vector::zeros(),
        }
    }

    /// Depth of a point inside the impactor and the outward normal there, if it is inside.
    #[inline]
    fn penetration(&self, y: &Vector<D>) -> Option<(f64, Vector<D>)> {
        let d = y - self.position;
        let round = |d: Vector<D>, radius: f64| {
            let r2 = d.norm_squared();
            if r2 >= radius * radius || r2 == 0.0 {
                return None;
            }
            let r = r2.sqrt();
            Some((radius - r, d / r))
        };
        match self.shape {
            ImpactorShape::Plane { normal, extent } => {
                let h = d.dot(&normal);
                if h >= 0.0 {
                    return None;
                }
                if let Some(e) = extent {
                    if (d - normal * h).norm_squared() > e * e {
                        return None;
                    }
                }
                Some((-h, normal))
            }
            ImpactorShape::Sphere { radius } => round(d, radius),
            ImpactorShape::Cylinder { radius } => {
                let mut d = d;
                if D == 3 {
                    d[2] = 0.0;
                }
                round(d, radius)
            }
        }
    }

    /// Adds the penalty force densities F/V_i to this process's nodes' `state.force`; keeps
    /// the reaction on the impactor and the penalty energy, summed over every node of the
    /// body (on every rank of a distributed run, the same bits).
    fn add_forces(&mut self, body: &Body<D>, state: &mut State<D>, share: Option<&Share>) {
        let k = self.stiffness;
        let this = &*self;
        let (first, owned) = share.map_or((0, body.len()), |s| (s.first, s.owned));
        let (current, volumes) = (&state.current, &body.volumes);
        let chunks: Vec<Vec<Contribution<D>>> = state.force[..owned]
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, forces)| {
                let mut found = Vec::new();
                for (m, f) in forces.iter_mut().enumerate() {
                    let i = c * CHUNK + m;
                    if let Some((p, n)) = this.penetration(&current[i]) {
                        // LAMMPS fix indent: F = K p² along the outward normal.
                        let force = n * (k * p * p);
                        *f += force / volumes[i];
                        found.push((first + i, force, k * p * p * p / 3.0));
                    }
                }
                found
            })
            .collect();
        let mine = chunks.concat();
        let all = match share {
            None => mine,
            // Every rank's contributions, in rank order: the global node order.
            Some(s) => unpack(&s.ranks.all_gather(&pack(&mine))),
        };
        let (total, energy) = chunked_sum(&all);
        self.force = -total;
        self.energy = energy;
    }

    /// Kinetic energy of a free impactor (J); a prescribed one's is the driver's business.
    pub fn kinetic_energy(&self) -> f64 {
        match self.motion {
            Motion::Free { mass } => 0.5 * mass * self.velocity.norm_squared(),
            Motion::Prescribed => 0.0,
        }
    }
}

/// What a checkpoint keeps of an impactor: where it is and how fast it moves, and the force
/// and penalty energy of the last evaluation (the next step's half-kick, the history and the
/// energy balance read them). The rest is the deck's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactorState<const D: usize> {
    pub position: Vector<D>,
    pub velocity: Vector<D>,
    pub force: Vector<D>,
    pub energy: f64,
}

/// The impactors of a run (empty: none, at no cost).
#[derive(Debug, Clone, Default)]
pub struct Impactors<const D: usize> {
    pub list: Vec<Impactor<D>>,
}

impl<const D: usize> Impactors<D> {
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Start of a velocity-Verlet step: a free impactor's half-kick with the last force, then
    /// every impactor's drift over dt.
    pub fn begin_step(&mut self, dt: f64) {
        for im in &mut self.list {
            im.force_start = im.force;
            if let Motion::Free { mass } = im.motion {
                im.velocity += im.force * (0.5 * dt / mass);
            }
            im.position += im.velocity * dt;
        }
    }

    /// Adds every impactor's penalty forces to `state.force` at the current positions (a
    /// distributed run's: to its owned nodes, the reactions summed over every rank's).
    pub fn add_forces(&mut self, body: &Body<D>, state: &mut State<D>, share: Option<&Share>) {
        for im in &mut self.list {
            im.add_forces(body, state, share);
        }
    }

    /// End of a step: a free impactor's second half-kick. Returns the work that the drivers
    /// of prescribed impactors did on the body over the step (J): the driver holds the
    /// impactor against the body's force F, so its work is −F·v dt (trapezoidal rule in F).
    pub fn end_step(&mut self, dt: f64) -> f64 {
        let mut work = 0.0;
        for im in &mut self.list {
            match im.motion {
                Motion::Free { mass } => im.velocity += im.force * (0.5 * dt / mass),
                Motion::Prescribed => {
                    work -= 0.5 * (im.force_start + im.force).dot(&im.velocity) * dt
                }
            }
        }
        work
    }

    /// Every impactor's state, in deck order, for a checkpoint.
    pub fn states(&self) -> Vec<ImpactorState<D>> {
        self.list
            .iter()
            .map(|im| ImpactorState {
                position: im.position,
                velocity: im.velocity,
                force: im.force,
                energy: im.energy,
            })
            .collect()
    }

    /// Puts back the states a checkpoint kept (the same deck: the same impactors, in order).
    pub fn restore(&mut self, states: &[ImpactorState<D>]) {
        assert_eq!(states.len(), self.list.len(), "impactors of another deck");
        for (im, s) in self.list.iter_mut().zip(states) {
            im.position = s.position;
            im.velocity = s.velocity;
            im.force = s.force;
            im.energy = s.energy;
        }
    }

    /// Penalty energy of every impactor (J).
    pub fn energy(&self) -> f64 {
        self.list.iter().map(|im| im.energy).sum()
    }

    /// Kinetic energy of the free impactors (J).
    pub fn kinetic_energy(&self) -> f64 {
        self.list.iter().map(|im| im.kinetic_energy()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-process sum before contributions were listed: every chunk of `CHUNK` nodes
    /// from zero, then every chunk's sum, empty ones included.
    fn dense_sum(n: usize, all: &[Contribution<2>]) -> (Vector<2>, f64) {
        let (mut total, mut energy) = (Vector::<2>::zeros(), 0.0);
        for c in 0..n.div_ceil(CHUNK) {
            let (mut t, mut w) = (Vector::<2>::zeros(), 0.0);
            for &(_, f, e) in all.iter().filter(|x| x.0 / CHUNK == c) {
                t += f;
                w += e;
            }
            total += t;
            energy += w;
        }
        (total, energy)
    }

    #[test]
    fn listed_contributions_sum_as_the_chunks_do_whatever_the_ranks() {
        // Nodes inside in three chunks, with forces of mixed magnitudes and signs (the sum
        // rounds differently if grouped otherwise).
        let n = 5 * CHUNK;
        let all: Vec<Contribution<2>> = [3, 17, 4095, 4096, 4100, 9000, 12287, 16000]
            .iter()
            .enumerate()
            .map(|(k, &i)| {
                let x = (k as f64 + 1.0).powi(7) * if k % 2 == 0 { 1.0 } else { -1e-9 };
                (i, Vector::<2>::new(x, 0.1 * x + 1e-3), x.abs() * 1e-3 + 0.3)
            })
            .collect();
        let (t, e) = dense_sum(n, &all);
        let (t2, e2) = chunked_sum(&all);
        assert_eq!(
            (t[0].to_bits(), t[1].to_bits()),
            (t2[0].to_bits(), t2[1].to_bits())
        );
        assert_eq!(e.to_bits(), e2.to_bits());
        // Ranks split at node chunks of 256, not at impactor chunks: their lists, sent as
        // words and put one after the other, are the same list.
        for split in [256, 4096 + 256, 12288 - 256] {
            let (a, b): (Vec<_>, Vec<_>) = all.iter().copied().partition(|x| x.0 < split);
            let mut words = pack(&a);
            words.extend(pack(&b));
            assert_eq!(unpack::<2>(&words), all);
        }
    }
}
