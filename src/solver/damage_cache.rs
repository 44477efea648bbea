//! The nodes' damage as observers last saw it, with the bond statuses it was computed from.
//! Observers ask for damage at every step they sample (a crack-tip tracker: every step), a
//! pass over every bond that cost about a third of a PMB step; between two samples bonds
//! break at a few nodes, so only the nodes whose bonds' statuses changed are computed again.
//! Each node's value is computed by the same sum as a full pass, so the damage is bitwise the
//! full pass's.

use super::ForceEngine;
use crate::body::Body;
use crate::bonds::Bonds;
use crate::material::Material;
use crate::state::State;
use rayon::prelude::*;
use std::sync::Mutex;

/// Bytes per directed bond the cache holds once observers have asked (its copy of the
/// status byte; the memory estimate counts it).
pub const BYTES_PER_BOND: usize = 1;

/// Damage per node and the bond statuses it reflects (empty before the first request).
#[derive(Default)]
pub struct DamageCache {
    last: Mutex<Option<Seen>>,
}

struct Seen {
    status: Vec<u8>,
    damage: Vec<f64>,
}

impl DamageCache {
    /// The damage of every node at `state`.
    pub fn damage<const D: usize, M: Material<D>>(
        &self,
        engine: &ForceEngine<D, M>,
        body: &Body<D>,
        bonds: &Bonds,
        state: &State<D>,
    ) -> Vec<f64> {
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        let seen = match last.as_mut() {
            Some(seen) if seen.status.len() == state.status.len() => seen,
            _ => last.insert(Seen {
                status: state.status.clone(),
                damage: engine.damage(body, bonds, state),
            }),
        };
        let changed: Vec<(usize, f64)> = (0..body.len())
            .into_par_iter()
            .filter(|&i| {
                let family = bonds.family(i);
                state.status[family.clone()] != seen.status[family]
            })
            .map(|i| (i, engine.node_damage(i, body, bonds, state)))
            .collect();
        for (i, d) in changed {
            let family = bonds.family(i);
            seen.status[family.clone()].copy_from_slice(&state.status[family]);
            seen.damage[i] = d;
        }
        seen.damage.clone()
    }
}
