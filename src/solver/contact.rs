//! Node–node contact: a short-range repulsion between nodes that no intact bond joins (crack
//! faces that close, fragments, separate bodies), so that they cannot pass through each other.
//!
//! The law is the short-range force of LAMMPS' `pair peri/pmb` (Parks, Lehoucq, Plimpton &
//! Silling 2008, "Implementing peridynamics within a molecular dynamics code", §3.2): a pair
//! closer than the contact radius r_c pushes apart with the force density on i
//!
//!   f_i = c_s (r_c − r)/δ · V_j · (y_i − y_j)/r,   c_s = 15 c
//!
//! (LAMMPS `PairPeriPMB::compute`: `rk = 15 kspring V_j (d_ij − r)/δ` with kspring the PMB
//! micromodulus c = 18K/(πδ⁴); Peridigm's short-range contact force has the same form with a
//! user "spring constant"),
//!
//! whose pair potential is φ = c_s V_i V_j (r_c − r)²/(2δ). The default r_c = 0.9 Δx is LAMMPS'
//! `d_ij = min(0.9 |x_i − x_j|, 1.35 lc)` for nearest lattice neighbours: no contact at rest.
//!
//! Candidates come from a cell list over the current positions within r_c + skin, refreshed
//! (Verlet skin) when some node has moved more than skin/2 since the list was built. Each node
//! sums its own candidates in ascending index order (gather, no atomics): the force does not
//! depend on the thread count, nor on when the list was rebuilt (pairs beyond r_c add nothing).

use crate::body::Body;
use crate::bonds::Bonds;
use crate::math::Vector;
use crate::state::{State, BROKEN};
use rayon::prelude::*;

/// No bond joins the pair.
const UNBONDED: u32 = u32::MAX;
/// Nodes per parallel chunk (fixed, so the energy sum's order does not depend on threads).
const CHUNK: usize = 256;

/// The contact law's constants.
#[derive(Debug, Clone, Copy)]
pub struct ContactSettings {
    /// Contact radius r_c (m).
    pub radius: f64,
    /// Spring constant c_s (N/m⁶, the units of the PMB micromodulus).
    pub stiffness: f64,
    /// Length δ that scales the overlap, (r_c − r)/δ (m): the horizon.
    pub horizon: f64,
    /// Verlet skin (m): the list holds pairs within r_c + skin.
    pub skin: f64,
}

/// Node–node contact: its settings, the candidate list and the energy of the last evaluation.
#[derive(Debug, Clone)]
pub struct NodeContact<const D: usize> {
    pub settings: ContactSettings,
    /// CSR candidate list: node i's candidates are `pairs[offsets[i]..offsets[i + 1]]`, each
    /// (neighbour, bond entry i→j or `UNBONDED`), ascending by neighbour.
    offsets: Vec<usize>,
    pairs: Vec<(u32, u32)>,
    /// Current positions when the list was built (empty: never built).
    built_at: Vec<Vector<D>>,
    /// Contact potential energy at the last evaluation (J).
    pub energy: f64,
    /// Times the list was built.
    pub rebuilds: u64,
}

impl<const D: usize> NodeContact<D> {
    pub fn new(settings: ContactSettings) -> Self {
        NodeContact {
            settings,
            offsets: Vec::new(),
            pairs: Vec::new(),
            built_at: Vec::new(),
            energy: 0.0,
            rebuilds: 0,
        }
    }

    /// Candidate pairs in the list (directed).
    pub fn candidates(&self) -> usize {
        self.pairs.len()
    }

    /// Whether some node moved more than skin/2 since the list was built (then a pair outside
    /// r_c + skin at the build may now be within r_c).
    fn stale(&self, current: &[Vector<D>]) -> bool {
        if self.built_at.len() != current.len() {
            return true;
        }
        let limit = (0.5 * self.settings.skin).powi(2);
        current
            .par_iter()
            .zip(self.built_at.par_iter())
            .with_min_len(4096)
            .any(|(y, y0)| (y - y0).norm_squared() > limit)
    }

    /// Builds the candidate list from a cell list over the current positions.
    fn rebuild(&mut self, bonds: &Bonds, current: &[Vector<D>]) {
        let n = current.len();
        let reach = self.settings.radius + self.settings.skin;
        let cells = CellList::new(current, reach);
        let lists: Vec<Vec<(u32, u32)>> = (0..n)
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| {
                let mut found = Vec::new();
                cells.for_each_near(current[i], |j| {
                    if j != i && (current[j] - current[i]).norm_squared() < reach * reach {
                        found.push(j as u32);
                    }
                });
                found.sort_unstable();
                let family = bonds.family(i);
                let row = &bonds.neighbors[family.clone()];
                found
                    .into_iter()
                    .map(|j| {
                        let entry = row
                            .binary_search(&j)
                            .map_or(UNBONDED, |k| (family.start + k) as u32);
                        (j, entry)
                    })
                    .collect()
            })
            .collect();
        self.offsets.clear();
        self.offsets.push(0);
        self.pairs.clear();
        for l in &lists {
            self.pairs.extend_from_slice(l);
            self.offsets.push(self.pairs.len());
        }
        self.built_at.clear();
        self.built_at.extend_from_slice(current);
        self.rebuilds += 1;
    }

    /// Adds the contact force densities to `state.force` (refreshing the list if needed) and
    /// keeps the contact energy.
    pub fn add_forces(&mut self, body: &Body<D>, bonds: &Bonds, state: &mut State<D>) {
        if self.stale(&state.current) {
            self.rebuild(bonds, &state.current);
        }
        let ContactSettings {
            radius: rc,
            stiffness: cs,
            horizon: delta,
            ..
        } = self.settings;
        let (offsets, pairs) = (&self.offsets, &self.pairs);
        let (current, status, volumes) = (&state.current, &state.status, &body.volumes);
        let chunk_energy: Vec<f64> = state
            .force
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, forces)| {
                let mut energy = 0.0;
                for (k, f) in forces.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    let (mut sum, mut e) = (Vector::<D>::zeros(), 0.0);
                    for &(j, entry) in &pairs[offsets[i]..offsets[i + 1]] {
                        // An intact (or half-intact) bond carries the pair: no contact.
                        if entry != UNBONDED && status[entry as usize] != BROKEN {
                            continue;
                        }
                        let d = current[i] - current[j as usize];
                        let r2 = d.norm_squared();
                        if r2 >= rc * rc || r2 == 0.0 {
                            continue;
                        }
                        let r = r2.sqrt();
                        let overlap = rc - r;
                        let vj = volumes[j as usize];
                        // Parks et al. 2008 §3.2: c_s (r_c − r)/δ V_j along (y_i − y_j)/r.
                        sum += d * (cs * overlap / delta * vj / r);
                        // Half of φ = c_s V_i V_j (r_c − r)²/(2δ); the other half is j's.
                        e += 0.25 * cs * vj * overlap * overlap / delta;
                    }
                    if e > 0.0 {
                        *f += sum;
                        energy += e * volumes[i];
                    }
                }
                energy
            })
            .collect();
        self.energy = chunk_energy.iter().sum();
    }
}

/// Nodes binned into square/cubic cells of a side ≥ the search reach (counting sort, so the
/// nodes of a cell are in ascending order).
struct CellList<const D: usize> {
    origin: Vector<D>,
    size: f64,
    dims: [usize; 3],
    starts: Vec<usize>,
    nodes: Vec<usize>,
}

impl<const D: usize> CellList<D> {
    fn new(points: &[Vector<D>], reach: f64) -> Self {
        let mut lo = Vector::<D>::repeat(f64::INFINITY);
        let mut hi = Vector::<D>::repeat(f64::NEG_INFINITY);
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        // Cells at least `reach` wide, and not many more cells than nodes (scattered fragments).
        let mut size = reach.max(f64::MIN_POSITIVE);
        let count = |size: f64| -> [usize; 3] {
            let mut dims = [1; 3];
            for k in 0..D {
                dims[k] = (((hi[k] - lo[k]) / size).floor() as usize).saturating_add(1);
            }
            dims
        };
        let limit = 8 * points.len().max(1);
        let mut dims = count(size);
        while dims.iter().map(|&d| d as f64).product::<f64>() > limit as f64 {
            size *= 2.0;
            dims = count(size);
        }
        let total = dims[0] * dims[1] * dims[2];
        let mut list = CellList {
            origin: lo,
            size,
            dims,
            starts: vec![0; total + 1],
            nodes: vec![0; points.len()],
        };
        let ids: Vec<usize> = points.iter().map(|p| list.id(list.coords(*p))).collect();
        for &c in &ids {
            list.starts[c + 1] += 1;
        }
        for c in 0..total {
            list.starts[c + 1] += list.starts[c];
        }
        let mut next = list.starts.clone();
        for (i, &c) in ids.iter().enumerate() {
            list.nodes[next[c]] = i;
            next[c] += 1;
        }
        list
    }

    fn coords(&self, p: Vector<D>) -> [usize; 3] {
        let mut c = [0; 3];
        for k in 0..D {
            let x = ((p[k] - self.origin[k]) / self.size).floor();
            c[k] = (x.max(0.0) as usize).min(self.dims[k] - 1);
        }
        c
    }

    fn id(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Calls `f` for every node in the cells around `p` (its own and the adjacent ones).
    fn for_each_near(&self, p: Vector<D>, mut f: impl FnMut(usize)) {
        let c = self.coords(p);
        let range = |k: usize| {
            if k < D {
                c[k].saturating_sub(1)..=(c[k] + 1).min(self.dims[k] - 1)
            } else {
                0..=0
            }
        };
        for z in range(2) {
            for y in range(1) {
                for x in range(0) {
                    let id = self.id([x, y, z]);
                    for &j in &self.nodes[self.starts[id]..self.starts[id + 1]] {
                        f(j);
                    }
                }
            }
        }
    }
}
