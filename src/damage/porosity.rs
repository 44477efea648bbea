//! Intermediately homogenized PD (IH-PD, seed 001 §4.2): a porous quasi-brittle material as
//! its solid phase with a random fraction of bonds broken before loading.

use super::BROKEN;
use crate::bonds::Bonds;
use crate::solver::cross_bonds::CrossBonds;
use crate::solver::ranks::Share;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Porosity φ, critical porosity φc and the seed of the pre-broken bonds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Porosity {
    pub porosity: f64,
    pub critical: f64,
    pub seed: u64,
}

impl Porosity {
    /// Solid-phase property from the measured effective one (seed 001, Eq. 18):
    /// M_sp = M_eff / (1 − φ/φc)², for E, G0 and σu alike.
    pub fn solid_phase(&self, effective: f64) -> f64 {
        effective / (1.0 - self.porosity / self.critical).powi(2)
    }

    /// Breaks a fraction φ of the bonds whose both ends satisfy `member`, each physical bond
    /// with probability φ, drawn from a ChaCha8 stream seeded with `seed` in a fixed order
    /// (node i ascending, then its family, bonds with j > i): the same seed gives the same
    /// bonds on any machine and thread count. Returns the number of physical bonds broken.
    pub fn prebreak(
        &self,
        bonds: &Bonds,
        member: impl Fn(usize) -> bool,
        status: &mut [u8],
    ) -> usize {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut broken = 0;
        for i in 0..bonds.nodes() {
            if !member(i) {
                continue;
            }
            for b in bonds.family(i) {
                let j = bonds.neighbors[b] as usize;
                if j <= i || !member(j) {
                    continue;
                }
                if rng.random::<f64>() < self.porosity {
                    let r = bonds.reverse(i, b).expect("families are symmetric");
                    status[b] = BROKEN;
                    status[r] = BROKEN;
                    broken += 1;
                }
            }
        }
        broken
    }

    /// `prebreak` on one rank's share of a distributed run (`bonds`: its owned nodes' rows),
    /// drawing the one-process stream's values: a bond is drawn by its end that comes first
    /// in the global order, so this rank's rows draw, in the one-process order, the part of
    /// the stream after the draws of the ranks before it (counted in rank order and skipped:
    /// each draw reads two 32-bit words of the ChaCha stream), and a bond to a ghost drawn
    /// on the ghost's rank is broken here by that rank's word (`CrossBonds`). Returns the
    /// number of physical bonds broken over every rank.
    pub fn prebreak_shared(
        &self,
        bonds: &Bonds,
        member: impl Fn(usize) -> bool,
        status: &mut [u8],
        share: &Share,
        cross: &CrossBonds,
    ) -> usize {
        let (owned, ranks) = (share.owned, &*share.ranks);
        // The ghosts whose global index follows this rank's nodes.
        let mut later = vec![false; bonds.nodes() - owned];
        for (&peer, ghosts) in share.halo.peers.iter().zip(&share.halo.recv) {
            for &k in ghosts {
                later[k as usize - owned] = peer > ranks.rank();
            }
        }
        let draws = |i: usize, b: usize| {
            let j = bonds.neighbors[b] as usize;
            let first = if j < owned { j > i } else { later[j - owned] };
            first && member(i) && member(j)
        };
        let entries = || (0..owned).flat_map(|i| bonds.family(i).map(move |b| (i, b)));
        let mine = entries().filter(|&(i, b)| draws(i, b)).count() as f64;
        let mut before = 0.0;
        ranks.chain(&mut |earlier| {
            before = earlier.unwrap_or(0.0);
            before + mine
        });
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_word_pos(2 * before as u128);
        let mut broken = 0u64;
        for (i, b) in entries().filter(|&(i, b)| draws(i, b)) {
            if rng.random::<f64>() < self.porosity {
                status[b] = BROKEN;
                let j = bonds.neighbors[b] as usize;
                if j < owned {
                    status[bonds.reverse(i, b).expect("families are symmetric")] = BROKEN;
                }
                broken += 1;
            }
        }
        let mut drawn_there = Vec::new();
        let pack = |_, e: usize, buf: &mut Vec<f64>| buf.push(f64::from(status[e]));
        cross.swap(ranks, &share.halo.peers, 1, pack, |_, _, e, w| {
            if w[0] == f64::from(BROKEN) {
                drawn_there.push(e);
            }
        });
        for e in drawn_there {
            status[e] = BROKEN;
        }
        ranks.sum_u64(broken) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stream whose first draws are skipped (`prebreak_shared`) goes on with the values
    /// of the stream that drew them.
    #[test]
    fn skipping_draws_continues_the_stream() {
        let mut whole = ChaCha8Rng::seed_from_u64(7);
        // Within the generator's first buffer of blocks and beyond it.
        for skipped in [0u128, 1, 7, 8, 15, 100] {
            let mut drawn = ChaCha8Rng::seed_from_u64(7);
            for _ in 0..skipped {
                drawn.random::<f64>();
            }
            whole.set_word_pos(2 * skipped);
            for _ in 0..20 {
                assert_eq!(
                    whole.random::<f64>().to_bits(),
                    drawn.random::<f64>().to_bits()
                );
            }
        }
    }

    /// The entries (global i, global j) of the owned rows that porosity broke, and the count
    /// of physical bonds broken, on `size` ranks (ranks as threads; 1: one process).
    fn prebroken(size: usize) -> (Vec<(u32, u32)>, usize) {
        use crate::deck::build::{build_model, build_model_with, Part};
        use crate::deck::LoadedDeck;
        use crate::distributed::partition::{bond_weights, ranges};
        use crate::distributed::share::split;
        use crate::distributed::thread_ranks::ThreadRanks;
        const PLATE: &str = r#"
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
critical_stretch = 0.01
[solver]
type = "explicit"
steps = 1
"#;
        let ld = LoadedDeck::from_str(PLATE, std::path::Path::new("plate.toml")).unwrap();
        let porosity = Porosity {
            porosity: 0.2,
            critical: 1.0,
            seed: 11,
        };
        let results = ThreadRanks::run(size, |ranks| {
            let (mut share, mut globals) = (None, None);
            let model = if size == 1 {
                build_model::<2>(&ld).unwrap()
            } else {
                build_model_with::<2>(&ld, |body, families| {
                    let r = ranges(&bond_weights(&body, families.rule), size).unwrap();
                    let s = split(&body, families.rule, &[], &r, &*ranks);
                    globals = Some(s.globals.clone());
                    share = Some(Share {
                        ranks: ranks.clone(),
                        first: s.owned.start,
                        owned: s.owned.len(),
                        global_nodes: body.len(),
                        halo: s.halo,
                    });
                    Ok(Part {
                        body: s.body,
                        bonds: s.bonds,
                        globals: Some(s.globals),
                    })
                })
                .unwrap()
            };
            let bonds = &model.bonds;
            let mut status = vec![0u8; bonds.len()];
            let (count, owned) = match &share {
                Some(s) => {
                    let cross = CrossBonds::new(bonds, s);
                    let n = porosity.prebreak_shared(bonds, |_| true, &mut status, s, &cross);
                    (n, s.owned)
                }
                None => (
                    porosity.prebreak(bonds, |_| true, &mut status),
                    bonds.nodes(),
                ),
            };
            let global = |i: usize| globals.as_ref().map_or(i as u32, |g| g[i]);
            let mut broken = Vec::new();
            for i in 0..owned {
                for b in bonds.family(i).filter(|&b| status[b] == BROKEN) {
                    broken.push((global(i), global(bonds.neighbors[b] as usize)));
                }
            }
            (broken, count)
        });
        let count = results[0].1;
        assert!(results.iter().all(|r| r.1 == count), "every rank the total");
        (results.into_iter().flat_map(|r| r.0).collect(), count)
    }

    #[test]
    fn ranks_break_the_bonds_one_process_breaks() {
        let (one, count) = prebroken(1);
        assert!(count > 100, "{count} bonds broken");
        assert_eq!(one.len(), 2 * count, "both entries of each bond");
        for size in [2, 3] {
            assert_eq!(prebroken(size), (one.clone(), count), "{size} ranks");
        }
    }

    #[test]
    fn seed001_solid_phase_values() {
        // Seed 001 §2.7: φ/φc = 1 %, E = 192 GPa → E_sp = 195.9 GPa.
        let p = Porosity {
            porosity: 0.01,
            critical: 1.0,
            seed: 1,
        };
        assert!((p.solid_phase(192e9) / 195.90e9 - 1.0).abs() < 1e-4);
    }
}
