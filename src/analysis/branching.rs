//! Branching of a crack at one time: which damaged nodes form connected cracks, and where a
//! 2D crack forks and at what angles its branches leave.
//!
//! Components: damaged nodes (damage > threshold) linked when closer than a linking distance
//! ℓ (e.g. 1.5 grid spacings, so lattice diagonals link), found with a cell list of cell size
//! ℓ (a node's links lie in its own and the 3^D − 1 adjacent cells) and union–find, so the
//! cost is linear in the number of damaged nodes.
//!
//! Forks (2D): each component is cut into bands of width ℓ perpendicular to the propagation
//! direction e; in each band its nodes split into clusters wherever two consecutive
//! perpendicular coordinates are more than ℓ apart. A fork is a band with one cluster
//! followed by a band with two or more. Each branch is then followed over the next k bands
//! (nearest cluster to its last one) and a least-squares line through its cluster centres
//! gives its angle to e. This is the band-counting view of branching that seed 000 (Fig. 22)
//! and seed 002 (§2.12) apply by eye to their damage plots; the construction is ours.

use std::collections::{BTreeMap, HashMap};

use crate::math::Vector;

/// Connected components of the damaged nodes: nodes with damage > `threshold`, two of them
/// linked when their distance is strictly less than `link`. Each component lists node indices
/// in increasing order; components are ordered by their lowest index. Deterministic.
pub fn damaged_components<const D: usize>(
    positions: &[Vector<D>],
    damage: &[f64],
    threshold: f64,
    link: f64,
) -> Vec<Vec<usize>> {
    assert_eq!(
        positions.len(),
        damage.len(),
        "one damage value per node position"
    );
    assert!(
        link > 0.0 && link.is_finite(),
        "linking distance must be positive"
    );
    let nodes: Vec<usize> = (0..positions.len())
        .filter(|&i| damage[i] > threshold)
        .collect();
    let cell_of =
        |p: &Vector<D>| -> [i64; D] { std::array::from_fn(|k| (p[k] / link).floor() as i64) };
    let mut cells: HashMap<[i64; D], Vec<usize>> = HashMap::new();
    for (a, &i) in nodes.iter().enumerate() {
        cells.entry(cell_of(&positions[i])).or_default().push(a);
    }
    // Offsets {−1, 0, 1}^D to the adjacent cells.
    let offsets: Vec<[i64; D]> = (0..3usize.pow(D as u32))
        .map(|m| std::array::from_fn(|k| (m / 3usize.pow(k as u32) % 3) as i64 - 1))
        .collect();
    let mut parent: Vec<usize> = (0..nodes.len()).collect();
    let link2 = link * link;
    for (a, &i) in nodes.iter().enumerate() {
        let c = cell_of(&positions[i]);
        for off in &offsets {
            let key: [i64; D] = std::array::from_fn(|k| c[k] + off[k]);
            let Some(members) = cells.get(&key) else {
                continue;
            };
            for &b in members {
                if b > a && (positions[nodes[b]] - positions[i]).norm_squared() < link2 {
                    union(&mut parent, a, b);
                }
            }
        }
    }
    // Group by root in index order: the first member met starts the component.
    let mut slot: HashMap<usize, usize> = HashMap::new();
    let mut components: Vec<Vec<usize>> = Vec::new();
    for (a, &i) in nodes.iter().enumerate() {
        let r = find(&mut parent, a);
        let s = *slot.entry(r).or_insert_with(|| {
            components.push(Vec::new());
            components.len() - 1
        });
        components[s].push(i);
    }
    components
}

fn find(parent: &mut [usize], mut a: usize) -> usize {
    while parent[a] != a {
        parent[a] = parent[parent[a]]; // path halving
        a = parent[a];
    }
    a
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // The lower root wins: the forest's shape, not the partition, depends on it.
        parent[ra.max(rb)] = ra.min(rb);
    }
}

/// A run of damaged nodes within one band, separated from the next by a gap > ℓ in the
/// perpendicular coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Cluster {
    /// Mean coordinate along e of its nodes.
    pub s: f64,
    /// Mean coordinate along the perpendicular n of its nodes.
    pub r: f64,
    /// Its nodes.
    pub nodes: usize,
}

/// Clusters of one band's (s, r) pairs, in increasing r.
pub(super) fn clusters(mut pts: Vec<(f64, f64)>, link: f64) -> Vec<Cluster> {
    pts.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.total_cmp(&b.0)));
    let mut out = Vec::new();
    let mut start = 0;
    for j in 1..=pts.len() {
        if j == pts.len() || pts[j].1 - pts[j - 1].1 > link {
            let run = &pts[start..j];
            let n = run.len() as f64;
            out.push(Cluster {
                s: run.iter().map(|p| p.0).sum::<f64>() / n,
                r: run.iter().map(|p| p.1).sum::<f64>() / n,
                nodes: run.len(),
            });
            start = j;
        }
    }
    out
}

/// One branch leaving a fork.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForkBranch {
    /// Centre of the branch's cluster in the first band after the fork.
    pub start: Vector<2>,
    /// Angle of its fitted centre line to the propagation direction, degrees, positive
    /// counter-clockwise (towards n = e rotated by +90°); `None` with fewer than two bands.
    pub angle_deg: Option<f64>,
    /// Bands (cluster centres) the line was fitted through.
    pub bands_fitted: usize,
}

/// A fork of a 2D crack.
#[derive(Debug, Clone, PartialEq)]
pub struct Fork {
    /// Which component (index into `damaged_components`' order) it belongs to.
    pub component: usize,
    /// Index k of the last single-cluster band: band k covers s = p·e in [kℓ, (k + 1)ℓ).
    pub band: i64,
    /// Where the fork is detected: centre of band k along e, the single cluster's mean
    /// across. This lags the true branch point by about (ℓ/2 + crack half-width)/tan(half
    /// the opening angle), the distance the branches need to open a gap wider than ℓ.
    pub position: Vector<2>,
    /// With exactly two fitted branches, where their centre lines cross: the branch point
    /// without that lag. `None` otherwise (or if the lines are parallel).
    pub intersection: Option<Vector<2>>,
    /// The branches in increasing perpendicular coordinate (clockwise-most first).
    pub branches: Vec<ForkBranch>,
}

/// Forks of a 2D crack growing along `direction` (normalised here): per component of
/// `damaged_components(.., link)`, bands of width `link` across the direction, a fork where
/// one cluster becomes two or more between consecutive bands, each branch's angle fitted over
/// `fit_bands` bands from the first one after the fork. Forks come ordered by component,
/// then band. Working per component keeps a second, separate crack from reading as a fork.
///
/// Panics unless `link` > 0 and `fit_bands` ≥ 1.
pub fn find_forks(
    positions: &[Vector<2>],
    damage: &[f64],
    threshold: f64,
    direction: &Vector<2>,
    link: f64,
    fit_bands: usize,
) -> Vec<Fork> {
    assert!(fit_bands >= 1, "fit at least one band");
    let len = direction.norm();
    assert!(
        len > 0.0 && len.is_finite(),
        "the propagation direction must be a finite non-zero vector"
    );
    let e = direction / len;
    let n = Vector::<2>::new(-e[1], e[0]);
    let to_xy = |s: f64, r: f64| e * s + n * r;
    let mut forks = Vec::new();
    for (ci, comp) in damaged_components(positions, damage, threshold, link)
        .iter()
        .enumerate()
    {
        let mut bands: BTreeMap<i64, Vec<(f64, f64)>> = BTreeMap::new();
        for &i in comp {
            let (s, r) = (positions[i].dot(&e), positions[i].dot(&n));
            bands
                .entry((s / link).floor() as i64)
                .or_default()
                .push((s, r));
        }
        let bands: BTreeMap<i64, Vec<Cluster>> = bands
            .into_iter()
            .map(|(k, pts)| (k, clusters(pts, link)))
            .collect();
        let empty = Vec::new();
        let at = |k: i64| bands.get(&k).unwrap_or(&empty);
        for (&k, here) in &bands {
            let next = at(k + 1);
            if here.len() != 1 || next.len() < 2 {
                continue;
            }
            let position = to_xy((k as f64 + 0.5) * link, here[0].r);
            let mut branches = Vec::new();
            let mut lines = Vec::new();
            for start in next {
                let mut pts = vec![*start];
                for m in 2..=fit_bands as i64 {
                    let last = pts[pts.len() - 1].r;
                    // Nearest cluster; on a tie the lower r (first in order) is kept.
                    let nearest = at(k + m)
                        .iter()
                        .fold(None::<&Cluster>, |best, c| match best {
                            Some(b) if (b.r - last).abs() <= (c.r - last).abs() => Some(b),
                            _ => Some(c),
                        });
                    match nearest {
                        Some(c) => pts.push(*c),
                        None => break,
                    }
                }
                let line = fit_line(&pts);
                lines.push(line);
                branches.push(ForkBranch {
                    start: to_xy(start.s, start.r),
                    angle_deg: line.map(|(_, b)| b.atan().to_degrees()),
                    bands_fitted: pts.len(),
                });
            }
            let intersection = match lines.as_slice() {
                [Some((a1, b1)), Some((a2, b2))] if b1 != b2 => {
                    let s = (a2 - a1) / (b1 - b2);
                    Some(to_xy(s, a1 + b1 * s))
                }
                _ => None,
            };
            forks.push(Fork {
                component: ci,
                band: k,
                position,
                intersection,
                branches,
            });
        }
    }
    forks
}

/// Least-squares line r = a + b s through cluster centres (ordinary least squares, e.g.
/// Press et al., Numerical Recipes, 3rd ed., §15.2); `None` with fewer than two points or no
/// spread in s.
fn fit_line(pts: &[Cluster]) -> Option<(f64, f64)> {
    if pts.len() < 2 {
        return None;
    }
    let m = pts.len() as f64;
    let ms = pts.iter().map(|c| c.s).sum::<f64>() / m;
    let mr = pts.iter().map(|c| c.r).sum::<f64>() / m;
    let sss: f64 = pts.iter().map(|c| (c.s - ms).powi(2)).sum();
    let ssr: f64 = pts.iter().map(|c| (c.s - ms) * (c.r - mr)).sum();
    if sss <= 0.0 {
        return None;
    }
    let b = ssr / sss;
    Some((mr - b * ms, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    type V2 = Vector<2>;
    type V3 = Vector<3>;

    /// Damage 1 at lattice nodes (spacing h, x in [x0, x1], y in [y0, y1]) within `half` of
    /// one of `segments`, 0 elsewhere: a synthetic crack band on a grid.
    fn lattice_field(
        h: f64,
        (x0, x1, y0, y1): (f64, f64, f64, f64),
        segments: &[(V2, V2)],
        half: f64,
    ) -> (Vec<V2>, Vec<f64>) {
        let (nx, ny) = (
            ((x1 - x0) / h).round() as i64,
            ((y1 - y0) / h).round() as i64,
        );
        let mut pos = Vec::new();
        let mut d = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                let p = V2::new(x0 + i as f64 * h, y0 + j as f64 * h);
                let near = segments.iter().any(|&(a, b)| {
                    let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
                    (p - (a + (b - a) * t)).norm() <= half
                });
                pos.push(p);
                d.push(if near { 1.0 } else { 0.0 });
            }
        }
        (pos, d)
    }

    /// A Y: stem from the origin region to the fork at (xf, 0), branches at ±θ of length L.
    fn y_segments(xf: f64, theta_deg: f64, len: f64) -> Vec<(V2, V2)> {
        let t = theta_deg.to_radians();
        let f = V2::new(xf, 0.0);
        vec![
            (V2::new(0.0, 0.0), f),
            (f, f + V2::new(t.cos(), t.sin()) * len),
            (f, f + V2::new(t.cos(), -t.sin()) * len),
        ]
    }

    #[test]
    fn components_match_brute_force_on_random_points() {
        // Deterministic pseudo-random points (an LCG) in 2D and 3D, some damaged; the cell
        // list must give the same partition as checking every pair.
        let mut state = 12345u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let pos2: Vec<V2> = (0..600)
            .map(|_| V2::new(rnd() * 10.0 - 5.0, rnd() * 10.0))
            .collect();
        let d2: Vec<f64> = (0..600).map(|_| rnd()).collect();
        assert_eq!(
            damaged_components(&pos2, &d2, 0.3, 0.6),
            brute_force(&pos2, &d2, 0.3, 0.6)
        );
        let pos3: Vec<V3> = (0..600)
            .map(|_| V3::new(rnd() * 4.0, rnd() * 4.0 - 2.0, rnd() * 4.0))
            .collect();
        let d3: Vec<f64> = (0..600).map(|_| rnd()).collect();
        let c = damaged_components(&pos3, &d3, 0.5, 0.7);
        assert_eq!(c, brute_force(&pos3, &d3, 0.5, 0.7));
        assert!(
            c.len() > 1 && c.len() < 300,
            "a non-trivial partition: {}",
            c.len()
        );
    }

    fn brute_force<const D: usize>(
        pos: &[Vector<D>],
        d: &[f64],
        thr: f64,
        link: f64,
    ) -> Vec<Vec<usize>> {
        let n = pos.len();
        let mut label: Vec<Option<usize>> = vec![None; n];
        let mut out: Vec<Vec<usize>> = Vec::new();
        for i in 0..n {
            if d[i] <= thr || label[i].is_some() {
                continue;
            }
            let c = out.len();
            let mut stack = vec![i];
            label[i] = Some(c);
            let mut members = Vec::new();
            while let Some(a) = stack.pop() {
                members.push(a);
                for b in 0..n {
                    if d[b] > thr && label[b].is_none() && (pos[a] - pos[b]).norm() < link {
                        label[b] = Some(c);
                        stack.push(b);
                    }
                }
            }
            members.sort();
            out.push(members);
        }
        out
    }

    #[test]
    fn linking_is_strict_and_thresholded() {
        let pos = vec![V2::new(0.0, 0.0), V2::new(1.0, 0.0), V2::new(2.5, 0.0)];
        // Exactly ℓ apart: not linked.
        assert_eq!(
            damaged_components(&pos, &[1.0, 1.0, 1.0], 0.4, 1.0),
            vec![vec![0], vec![1], vec![2]]
        );
        assert_eq!(
            damaged_components(&pos, &[1.0, 1.0, 1.0], 0.4, 1.5 + 1e-12),
            vec![vec![0, 1, 2]]
        );
        // Node 1 at the threshold is not damaged, so 0 and 2 are not bridged.
        assert_eq!(
            damaged_components(&pos, &[1.0, 0.4, 1.0], 0.4, 2.0),
            vec![vec![0], vec![2]]
        );
    }

    #[test]
    fn components_of_1e5_nodes_in_well_under_a_second() {
        // 400 × 250 lattice, all damaged, ℓ = 1.5 h: one component of 100 000 nodes.
        let pos: Vec<V2> = (0..250)
            .flat_map(|j| (0..400).map(move |i| V2::new(i as f64 * 1e-3, j as f64 * 1e-3)))
            .collect();
        let d = vec![1.0; pos.len()];
        let t0 = std::time::Instant::now();
        let c = damaged_components(&pos, &d, 0.4, 1.5e-3);
        let elapsed = t0.elapsed();
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].len(), 100_000);
        assert!(elapsed.as_secs_f64() < 0.5, "took {elapsed:?}");
    }

    #[test]
    fn a_straight_crack_has_no_fork() {
        let h = 1.0;
        let seg = [(V2::new(0.0, 0.0), V2::new(40.0, 8.0))]; // sloped 11.3°
        let (pos, d) = lattice_field(h, (0.0, 45.0, -5.0, 15.0), &seg, 0.75 * h);
        assert_eq!(damaged_components(&pos, &d, 0.4, 1.5 * h).len(), 1);
        assert!(find_forks(&pos, &d, 0.4, &V2::new(1.0, 0.0), 1.5 * h, 8).is_empty());
    }

    #[test]
    fn two_parallel_cracks_are_two_components_without_a_fork() {
        // Staggered: the second starts 10 h later, so counting bands over both would read a
        // 1 → 2 rise at x = 10; per component there is none.
        let h = 1.0;
        let segs = [
            (V2::new(0.0, 0.0), V2::new(30.0, 0.0)),
            (V2::new(10.0, 6.0), V2::new(40.0, 6.0)),
        ];
        let (pos, d) = lattice_field(h, (0.0, 45.0, -5.0, 12.0), &segs, 0.75 * h);
        let comps = damaged_components(&pos, &d, 0.4, 1.5 * h);
        assert_eq!(comps.len(), 2);
        assert_eq!(comps[0].len(), 31);
        assert_eq!(comps[1].len(), 31);
        assert!(find_forks(&pos, &d, 0.4, &V2::new(1.0, 0.0), 1.5 * h, 8).is_empty());
    }

    /// Checks one fork of a Y with the fork at (xf, 0) and branches at ±θ.
    fn check_y(pos: &[V2], d: &[f64], xf: f64, theta: f64, link: f64, half: f64) {
        let forks = find_forks(pos, d, 0.4, &V2::new(1.0, 0.0), link, 10);
        assert_eq!(forks.len(), 1, "{forks:#?}");
        let f = &forks[0];
        assert_eq!(f.component, 0);
        assert_eq!(f.branches.len(), 2);
        let lower = f.branches[0].angle_deg.unwrap();
        let upper = f.branches[1].angle_deg.unwrap();
        assert!((lower + theta).abs() < 3.0, "θ = {theta}: lower {lower}");
        assert!((upper - theta).abs() < 3.0, "θ = {theta}: upper {upper}");
        assert_eq!(f.branches[0].bands_fitted, 10);
        // The branch point from the fitted lines: within one band of the truth.
        let x = f.intersection.unwrap();
        assert!((x[0] - xf).abs() < link, "θ = {theta}: {x:?}");
        assert!(x[1].abs() < link, "θ = {theta}: {x:?}");
        // The detected band: past the truth by at most the documented lag plus one band.
        let lag = (0.5 * link + half) / theta.to_radians().tan();
        assert!(f.position[1].abs() < 0.5 * link, "{:?}", f.position);
        assert!(
            f.position[0] > xf - link && f.position[0] < xf + lag + link,
            "θ = {theta}: detected at {:?}, lag {lag}",
            f.position
        );
    }

    #[test]
    fn a_y_on_a_lattice_has_one_fork_with_the_branch_angles() {
        let h = 1.0;
        for theta in [15.0, 30.0] {
            let xf = 20.0;
            let segs = y_segments(xf, theta, 40.0);
            let (pos, d) = lattice_field(h, (0.0, 65.0, -25.0, 25.0), &segs, 0.75 * h);
            check_y(&pos, &d, xf, theta, 1.5 * h, 0.75 * h);
        }
    }

    #[test]
    fn a_thin_y_is_found_within_one_band() {
        // Nodes exactly on the Y's segments, spaced 0.5 along them: no crack width, so the
        // detection lag is ℓ/(2 tan θ) alone, under one band at θ = 30°.
        let link = 1.5;
        let theta = 30.0f64;
        let xf = 10.0;
        let mut pos = Vec::new();
        for (a, b) in y_segments(xf, theta, 20.0) {
            let m = ((b - a).norm() / 0.5).round() as usize;
            for i in 0..=m {
                pos.push(a + (b - a) * (i as f64 / m as f64));
            }
        }
        let d = vec![1.0; pos.len()];
        let forks = find_forks(&pos, &d, 0.4, &V2::new(1.0, 0.0), link, 10);
        assert_eq!(forks.len(), 1);
        let f = &forks[0];
        assert!((f.position[0] - xf).abs() < link, "{:?}", f.position);
        assert!(f.position[1].abs() < 1e-12);
        // Collinear centres: the fit is exact up to rounding.
        assert!((f.branches[0].angle_deg.unwrap() + theta).abs() < 1e-9);
        assert!((f.branches[1].angle_deg.unwrap() - theta).abs() < 1e-9);
        let x = f.intersection.unwrap();
        assert!((x - V2::new(xf, 0.0)).norm() < 1e-9, "{x:?}");
    }

    #[test]
    fn a_rotated_y_gives_angles_relative_to_the_direction() {
        // The thin Y rotated by 40° and tracked along its own stem direction: same angles.
        let rot = nalgebra::Rotation2::new(40f64.to_radians());
        let mut pos = Vec::new();
        for (a, b) in y_segments(10.0, 20.0, 20.0) {
            for i in 0..=60 {
                pos.push(rot * (a + (b - a) * (i as f64 / 60.0)));
            }
        }
        let d = vec![1.0; pos.len()];
        let e = rot * V2::new(1.0, 0.0);
        let forks = find_forks(&pos, &d, 0.4, &(e * 3.0), 1.5, 6);
        assert_eq!(forks.len(), 1);
        assert!((forks[0].branches[0].angle_deg.unwrap() + 20.0).abs() < 1e-9);
        assert!((forks[0].branches[1].angle_deg.unwrap() - 20.0).abs() < 1e-9);
        assert!((forks[0].intersection.unwrap() - rot * V2::new(10.0, 0.0)).norm() < 1e-9);
    }
}
