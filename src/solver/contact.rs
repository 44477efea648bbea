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
//! A rank of a distributed run searches its owned nodes' candidates among its own and the
//! other ranks' nodes near them (`contact_halo`), in ascending global index: the same sums.

use super::contact_halo::{local_globals, RemoteNodes};
use super::ranks::{ordered_sum, Share};
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
    /// (neighbour, bond entry i→j or `UNBONDED`), ascending by the neighbour's global index.
    /// A neighbour indexes the nodes (one process) or `RemoteNodes::points` (a rank).
    offsets: Vec<usize>,
    pairs: Vec<(u32, u32)>,
    /// Current positions of the owned nodes when the list was built (empty: never built).
    built_at: Vec<Vector<D>>,
    /// Contact potential energy at the last evaluation (J).
    pub energy: f64,
    /// Times the list was built.
    pub rebuilds: u64,
    /// A distributed run's: the other ranks' nodes near this rank's, and the global index of
    /// every local node (for the bonds' rows).
    remote: Option<(RemoteNodes<D>, Vec<u32>)>,
}

/// What the search and the force read of the nodes: one process's own arrays, or a rank's
/// owned nodes followed by the other ranks' near them.
struct Points<'a, const D: usize> {
    positions: &'a [Vector<D>],
    volumes: &'a [f64],
    /// Global index of each point (`None`: the point's own index).
    globals: Option<&'a [u32]>,
}

impl<const D: usize> Points<'_, D> {
    fn global(&self, j: usize) -> u32 {
        self.globals.map_or(j as u32, |g| g[j])
    }
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
            remote: None,
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

    /// Builds the candidate list of the first `owned` points from a cell list over all of
    /// them. `row_globals` gives a bond row's neighbours' global indices (`None`: their own).
    fn rebuild(
        &mut self,
        bonds: &Bonds,
        points: &Points<D>,
        owned: usize,
        row_globals: Option<&[u32]>,
    ) {
        let current = points.positions;
        let reach = self.settings.radius + self.settings.skin;
        let cells = CellList::new(current, reach);
        let lists: Vec<Vec<(u32, u32)>> = (0..owned)
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| {
                let mut found = Vec::new();
                cells.for_each_near(current[i], |j| {
                    if j != i && (current[j] - current[i]).norm_squared() < reach * reach {
                        found.push((points.global(j), j as u32));
                    }
                });
                found.sort_unstable();
                let family = bonds.family(i);
                let row = &bonds.neighbors[family.clone()];
                // Rows are in ascending global order.
                let global_of = |l: &u32| row_globals.map_or(*l, |g| g[*l as usize]);
                found
                    .into_iter()
                    .map(|(g, j)| {
                        let entry = row
                            .binary_search_by_key(&g, global_of)
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
        self.built_at.extend_from_slice(&current[..owned]);
        self.rebuilds += 1;
    }

    /// Adds the contact force densities to `state.force` of this process's nodes (refreshing
    /// the list if needed) and keeps the contact energy of the whole body. In a distributed
    /// run every rank calls it in the same steps (it exchanges the remote nodes).
    pub fn add_forces(
        &mut self,
        body: &Body<D>,
        bonds: &Bonds,
        state: &mut State<D>,
        share: Option<&Share>,
    ) {
        let owned = share.map_or(body.len(), |s| s.owned);
        let stale = self.stale(&state.current[..owned]);
        // Every rank rebuilds when some node of any rank moved, as one process does.
        let stale = share.map_or(stale, |s| s.ranks.max_f64(stale as u8 as f64) > 0.0);
        if let Some(s) = share {
            let reach = self.settings.radius + self.settings.skin;
            match &mut self.remote {
                Some((remote, _)) if !stale => remote.refresh(s, &state.current),
                _ => {
                    let row_globals = match self.remote.take() {
                        Some((_, g)) => g,
                        None => local_globals(s, body.len()),
                    };
                    let remote = RemoteNodes::build(s, &state.current, &body.volumes, reach);
                    self.remote = Some((remote, row_globals));
                }
            }
        }
        let remote = self.remote.take();
        let points = match &remote {
            None => Points {
                positions: &state.current,
                volumes: &body.volumes,
                globals: None,
            },
            Some((r, _)) => Points {
                positions: &r.points,
                volumes: &r.volumes,
                globals: Some(&r.globals),
            },
        };
        if stale {
            let row_globals = remote.as_ref().map(|(_, g)| g.as_slice());
            self.rebuild(bonds, &points, owned, row_globals);
        }
        let chunk_energy = self.forces(&points, &state.status, &mut state.force[..owned]);
        self.energy = ordered_sum(share, chunk_energy.into_iter());
        self.remote = remote;
    }

    /// Adds each owned node's contact force density over its candidates, in their order;
    /// returns the contact energy of each chunk of `CHUNK` nodes.
    fn forces(&self, points: &Points<D>, status: &[u8], force: &mut [Vector<D>]) -> Vec<f64> {
        let ContactSettings {
            radius: rc,
            stiffness: cs,
            horizon: delta,
            ..
        } = self.settings;
        let (offsets, pairs) = (&self.offsets, &self.pairs);
        let (current, volumes) = (points.positions, points.volumes);
        force
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
            .collect()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deck::build::{build_model, build_model_with, Part};
    use crate::deck::LoadedDeck;
    use crate::distributed::partition::{bond_weights, ranges};
    use crate::distributed::share::split;
    use crate::distributed::thread_ranks::ThreadRanks;
    use crate::solver::ranks::Ranks;
    use std::path::Path;
    use std::sync::Arc;

    /// Two 20 mm × 5 mm blocks (1 600 nodes) cut apart at x = 10 mm.
    const BLOCKS: &str = r#"
version = 1
dimension = 2
plane = "stress"
thickness = 1e-3
[discretization]
type = "lattice"
shape = { type = "rectangle", min = [0.0, 0.0], max = [0.02, 0.005] }
spacing = 0.25e-3
horizon_ratio = 3.0
[material]
type = "pmb"
density = 1000.0
youngs_modulus = 1e9
critical_stretch = 10.0
[[precracks]]
type = "segment"
start = [0.01, -0.001]
end = [0.01, 0.006]
[solver]
type = "explicit"
steps = 1
"#;

    fn settings() -> ContactSettings {
        ContactSettings {
            radius: 0.9 * 0.25e-3,
            stiffness: 1e20,
            horizon: 0.75e-3,
            skin: 0.3 * 0.25e-3,
        }
    }

    /// The displacement of the node at `x` in move `k`: the right block pushed into the left
    /// one, and a ripple that brings some bonded neighbours within r_c.
    fn displacement(x: &Vector<2>, k: usize) -> Vector<2> {
        let push = if x[0] > 0.01 { -0.2e-3 } else { 0.0 } * (k as f64 + 1.0) / 3.0;
        let ripple = 0.06e-3 * (x[0] * 9e3 + x[1] * 4e3 + k as f64).sin();
        Vector::<2>::new(push + ripple, 0.5 * ripple)
    }

    /// A bond entry broken by a rule of the two nodes' global indices (the same at both ends).
    fn broken(gi: u32, gj: u32) -> bool {
        (gi + gj).is_multiple_of(5)
    }

    /// Contact force bits of every node and the energy bits, after each of three moves (the
    /// second within the skin: no rebuild), on `size` ranks (1: one process, no share).
    fn run(size: usize) -> Vec<(Vec<[u64; 2]>, u64)> {
        let ld = LoadedDeck::from_str(BLOCKS, Path::new("blocks.toml")).unwrap();
        let results = ThreadRanks::run(size, |ranks: Arc<dyn Ranks>| {
            let mut globals = None;
            let mut share = None;
            let model = if size == 1 {
                build_model::<2>(&ld).unwrap()
            } else {
                build_model_with::<2>(&ld, |body, families| {
                    let weights = bond_weights(&body, families.rule);
                    let r = ranges(&weights, size).unwrap();
                    let p = &ld.deck.precracks;
                    let s2 = split(&body, families.rule, p, &r, &*ranks);
                    globals = Some(s2.globals.clone());
                    share = Some(Share {
                        ranks: ranks.clone(),
                        first: s2.owned.start,
                        owned: s2.owned.len(),
                        global_nodes: body.len(),
                        halo: s2.halo,
                    });
                    Ok(Part {
                        body: s2.body,
                        bonds: s2.bonds,
                        globals: Some(s2.globals),
                    })
                })
                .unwrap()
            };
            let (body, bonds) = (&model.body, &model.bonds);
            let global = |i: usize| globals.as_ref().map_or(i as u32, |g| g[i]);
            let mut state = State::new(body, bonds, 0);
            for i in 0..body.len() {
                for b in bonds.family(i) {
                    if broken(global(i), global(bonds.neighbors[b] as usize)) {
                        state.status[b] = BROKEN;
                    }
                }
            }
            let mut contact = NodeContact::<2>::new(settings());
            let owned = share.as_ref().map_or(body.len(), |s| s.owned);
            (0..3)
                .map(|k| {
                    for i in 0..body.len() {
                        let x = body.positions[i];
                        state.current[i] = x + displacement(&x, if k == 1 { 0 } else { k });
                        state.force[i] = Vector::zeros();
                    }
                    contact.add_forces(body, bonds, &mut state, share.as_ref());
                    let forces: Vec<(u32, [u64; 2])> = (0..owned)
                        .map(|i| {
                            let f = state.force[i];
                            (global(i), [f[0].to_bits(), f[1].to_bits()])
                        })
                        .collect();
                    (forces, contact.energy.to_bits(), contact.rebuilds)
                })
                .collect::<Vec<_>>()
        });
        // Every rank's forces in global order, the energy as every rank has it.
        (0..3)
            .map(|k| {
                let mut forces: Vec<(u32, [u64; 2])> =
                    results.iter().flat_map(|r| r[k].0.clone()).collect();
                forces.sort_by_key(|f| f.0);
                let energies: Vec<u64> = results.iter().map(|r| r[k].1).collect();
                assert!(energies.iter().all(|&e| e == energies[0]));
                let rebuilds = results[0][k].2;
                assert_eq!(rebuilds, [1, 1, 2][k], "move {k}");
                (forces.into_iter().map(|f| f.1).collect(), energies[0])
            })
            .collect()
    }

    #[test]
    fn contact_on_ranks_is_the_one_process_contact_bit_for_bit() {
        let one = run(1);
        let pushed = one[2].0.iter().filter(|f| f[0] != 0).count();
        assert!(pushed > 40, "contact acts ({pushed} nodes)");
        assert!(f64::from_bits(one[2].1) > 0.0);
        for size in [2, 3] {
            assert!(run(size) == one, "{size} ranks");
        }
    }
}
