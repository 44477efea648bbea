//! Node ordering along a space-filling curve (Morton / Z-order), so that the members of a
//! family sit close together in memory and the bond loop streams through cache.

/// Returns the permutation `perm` such that node `perm[k]` goes to position `k`.
/// Ties (identical keys) keep their original order, so the result is deterministic.
pub fn morton_order(positions: &[[f64; 3]], dim: usize, cell: f64) -> Vec<u32> {
    if positions.is_empty() {
        return Vec::new();
    }
    let mut lo = [f64::INFINITY; 3];
    for p in positions {
        for k in 0..dim {
            lo[k] = lo[k].min(p[k]);
        }
    }
    let bits = if dim == 2 { 31 } else { 21 };
    let max = ((1u64 << bits) - 1) as f64;
    let key = |p: &[f64; 3]| -> u64 {
        let mut key = 0u64;
        for k in 0..dim {
            let q = ((p[k] - lo[k]) / cell).floor().clamp(0.0, max) as u64;
            key |= spread_bits(q, dim) << k;
        }
        key
    };
    let mut order: Vec<(u64, u32)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| (key(p), i as u32))
        .collect();
    order.sort_unstable();
    order.into_iter().map(|(_, i)| i).collect()
}

/// Inserts `dim - 1` zero bits between the bits of `v`.
fn spread_bits(v: u64, dim: usize) -> u64 {
    let mut out = 0u64;
    let bits = if dim == 2 { 32 } else { 21 };
    for b in 0..bits {
        out |= ((v >> b) & 1) << (b * dim);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_is_a_permutation_and_groups_neighbours() {
        let mut pts = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                pts.push([i as f64, j as f64, 0.0]);
            }
        }
        let perm = morton_order(&pts, 2, 1.0);
        let mut seen = perm.clone();
        seen.sort();
        assert_eq!(seen, (0..64).collect::<Vec<u32>>());
        // The first four entries of a Z-curve are one 2x2 block.
        let first: Vec<[f64; 3]> = perm[..4].iter().map(|&i| pts[i as usize]).collect();
        for p in first {
            assert!(p[0] < 2.0 && p[1] < 2.0);
        }
    }
}
