//! Crack-tip tracking: the damaged node furthest along the propagation direction (seed 000,
//! Appendix 2: "the crack tip is the node with D > 0.35 furthest along the crack path";
//! seed 002 §2.12 the same with d > 0.4). Each branch of a branched crack gets its own
//! search box (seed 000, Fig. 22), so one tracker follows several tips at once.
//!
//! In 3D a crack has a front, not a tip: `crack_front` summarises it as the damaged nodes
//! within a tolerance of the furthest projection (their mean and the extreme node).

use crate::math::Vector;

/// An axis-aligned box, corners included, that restricts a tip search to one branch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchBox<const D: usize> {
    pub min: Vector<D>,
    pub max: Vector<D>,
}

impl<const D: usize> SearchBox<D> {
    pub fn new(min: Vector<D>, max: Vector<D>) -> Self {
        SearchBox { min, max }
    }

    /// Whether `p` lies in the box (boundary included, so a node on a shared face counts in
    /// both neighbouring boxes rather than in none).
    pub fn contains(&self, p: &Vector<D>) -> bool {
        (0..D).all(|k| p[k] >= self.min[k] && p[k] <= self.max[k])
    }
}

/// A crack tip: the node, where it is, and how far along the direction it lies (p · e).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tip<const D: usize> {
    pub index: usize,
    pub position: Vector<D>,
    pub projection: f64,
}

/// Summary of a crack front (3D): the damaged nodes whose projection is within the tolerance
/// of the furthest one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrackFront<const D: usize> {
    /// Mean position of the front nodes (unweighted: each node counts once).
    pub mean: Vector<D>,
    /// The furthest front node: the same node as the tip.
    pub extreme: Tip<D>,
    /// How many nodes make up the front.
    pub count: usize,
}

/// The unit vector along `direction`; tolerances are distances, so a non-unit direction given
/// by the caller is normalised rather than trusted.
fn unit<const D: usize>(direction: &Vector<D>) -> Vector<D> {
    let n = direction.norm();
    assert!(
        n > 0.0 && n.is_finite(),
        "the propagation direction must be a finite non-zero vector"
    );
    direction / n
}

/// Indices of nodes that are damaged (damage strictly above `threshold`, NaN never) and inside
/// `search` when one is given.
fn damaged<'a, const D: usize>(
    positions: &'a [Vector<D>],
    damage: &'a [f64],
    threshold: f64,
    search: Option<&'a SearchBox<D>>,
) -> impl Iterator<Item = usize> + 'a {
    assert_eq!(
        positions.len(),
        damage.len(),
        "one damage value per node position"
    );
    (0..positions.len())
        .filter(move |&i| damage[i] > threshold && search.is_none_or(|b| b.contains(&positions[i])))
}

/// The crack tip: among nodes with damage > `threshold` (inside `search` if given), the one
/// with the largest projection on `direction`; ties go to the lowest index so the answer does
/// not depend on iteration order. `None` when no node qualifies.
pub fn find_tip<const D: usize>(
    positions: &[Vector<D>],
    damage: &[f64],
    threshold: f64,
    direction: &Vector<D>,
    search: Option<&SearchBox<D>>,
) -> Option<Tip<D>> {
    let e = unit(direction);
    let mut best: Option<Tip<D>> = None;
    for i in damaged(positions, damage, threshold, search) {
        let s = positions[i].dot(&e);
        // Strictly greater: an equal projection later in index order never replaces the tip.
        if best.is_none_or(|b| s > b.projection) {
            best = Some(Tip {
                index: i,
                position: positions[i],
                projection: s,
            });
        }
    }
    best
}

/// The crack front: the damaged nodes whose projection on `direction` is within
/// `front_tolerance` of the tip's (e.g. one grid spacing), as their mean position and the tip.
pub fn crack_front<const D: usize>(
    positions: &[Vector<D>],
    damage: &[f64],
    threshold: f64,
    direction: &Vector<D>,
    search: Option<&SearchBox<D>>,
    front_tolerance: f64,
) -> Option<CrackFront<D>> {
    assert!(
        front_tolerance >= 0.0,
        "the front tolerance is a distance, not negative"
    );
    let tip = find_tip(positions, damage, threshold, direction, search)?;
    let e = unit(direction);
    let mut sum = Vector::<D>::zeros();
    let mut count = 0;
    for i in damaged(positions, damage, threshold, search) {
        if positions[i].dot(&e) >= tip.projection - front_tolerance {
            sum += positions[i];
            count += 1;
        }
    }
    Some(CrackFront {
        mean: sum / count as f64,
        extreme: tip,
        count,
    })
}

/// One branch to follow: a name for output and the box its tip is searched in (None: the
/// whole body).
#[derive(Debug, Clone, PartialEq)]
pub struct Branch<const D: usize> {
    pub name: String,
    pub search: Option<SearchBox<D>>,
}

/// One branch's tip at one time (and its front when the tracker summarises fronts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipSample<const D: usize> {
    pub time: f64,
    pub tip: Tip<D>,
    pub front: Option<CrackFront<D>>,
}

/// Follows the tips of a list of branches: one `sample` call per output time, one entry per
/// branch (None while that branch has no damaged node). Holds no history, so it can be called
/// from any observer without ordering constraints.
#[derive(Debug, Clone)]
pub struct TipTracker<const D: usize> {
    pub threshold: f64,
    pub direction: Vector<D>,
    /// When set, each sample also carries the crack front within this distance of the tip.
    pub front_tolerance: Option<f64>,
    pub branches: Vec<Branch<D>>,
}

impl<const D: usize> TipTracker<D> {
    /// A tracker with no front summary; `direction` is normalised.
    pub fn new(threshold: f64, direction: Vector<D>, branches: Vec<Branch<D>>) -> Self {
        TipTracker {
            threshold,
            direction: unit(&direction),
            front_tolerance: None,
            branches,
        }
    }

    /// The same tracker, also summarising the crack front within `tolerance` of each tip.
    pub fn with_front(mut self, tolerance: f64) -> Self {
        self.front_tolerance = Some(tolerance);
        self
    }

    /// The tip (and front) of every branch at `time`, in branch order.
    pub fn sample(
        &self,
        time: f64,
        positions: &[Vector<D>],
        damage: &[f64],
    ) -> Vec<Option<TipSample<D>>> {
        self.branches
            .iter()
            .map(|b| {
                let search = b.search.as_ref();
                let tip = find_tip(positions, damage, self.threshold, &self.direction, search)?;
                let front = self.front_tolerance.and_then(|tol| {
                    crack_front(
                        positions,
                        damage,
                        self.threshold,
                        &self.direction,
                        search,
                        tol,
                    )
                });
                Some(TipSample { time, tip, front })
            })
            .collect()
    }
}

/// One branch's history from a sequence of `sample` results: the times and tip positions at
/// which it had a tip (samples where it had none are skipped), ready for `crack_speed`.
pub fn branch_history<const D: usize>(
    samples: &[Vec<Option<TipSample<D>>>],
    branch: usize,
) -> (Vec<f64>, Vec<Vector<D>>) {
    samples
        .iter()
        .filter_map(|s| s.get(branch).copied().flatten())
        .map(|s| (s.time, s.tip.position))
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    type V2 = Vector<2>;
    type V3 = Vector<3>;

    /// A 2D lattice of spacing h, nx × ny nodes from the origin, index = j·nx + i.
    fn lattice2(nx: usize, ny: usize, h: f64) -> Vec<V2> {
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| V2::new(i as f64 * h, j as f64 * h)))
            .collect()
    }

    #[test]
    fn tip_is_the_furthest_damaged_node_of_a_horizontal_crack() {
        let h = 0.5;
        let (nx, ny) = (20, 11);
        let pos = lattice2(nx, ny, h);
        // Crack along row j = 5 from i = 0 to i = 12, damage 0.5 (> 0.35); a node further along
        // x (i = 17) carries damage 0.35 exactly, which is not above the threshold.
        let mut d = vec![0.0; pos.len()];
        for i in 0..=12 {
            d[5 * nx + i] = 0.5;
        }
        d[5 * nx + 17] = 0.35;
        let tip = find_tip(&pos, &d, 0.35, &V2::new(1.0, 0.0), None).unwrap();
        assert_eq!(tip.index, 5 * nx + 12);
        assert_eq!(tip.position, V2::new(6.0, 2.5));
        assert_eq!(tip.projection, 6.0);
        // Against the direction the tip is the crack's other end.
        let back = find_tip(&pos, &d, 0.35, &V2::new(-1.0, 0.0), None).unwrap();
        assert_eq!(back.index, 5 * nx);
    }

    #[test]
    fn ties_go_to_the_lowest_index_and_no_damage_gives_none() {
        let pos = lattice2(4, 4, 1.0);
        let mut d = vec![0.0; 16];
        assert!(find_tip(&pos, &d, 0.4, &V2::new(1.0, 0.0), None).is_none());
        // Whole column i = 3 damaged: all four share x = 3; the lowest index (3) wins.
        for j in 0..4 {
            d[j * 4 + 3] = 1.0;
        }
        assert_eq!(
            find_tip(&pos, &d, 0.4, &V2::new(1.0, 0.0), None)
                .unwrap()
                .index,
            3
        );
        // NaN damage never counts.
        let nan = vec![f64::NAN; 16];
        assert!(find_tip(&pos, &nan, 0.4, &V2::new(1.0, 0.0), None).is_none());
    }

    #[test]
    fn direction_is_normalised_and_oblique_directions_work() {
        let pos = vec![V2::new(0.0, 0.0), V2::new(2.0, 1.0), V2::new(1.0, 3.0)];
        let d = vec![1.0; 3];
        // Along (1, 1)/√2: projections 0, 3/√2, 4/√2 → node 2. Given unnormalised as (3, 3).
        let tip = find_tip(&pos, &d, 0.4, &V2::new(3.0, 3.0), None).unwrap();
        assert_eq!(tip.index, 2);
        assert!((tip.projection - 4.0 / 2f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn boxes_restrict_the_search_to_one_branch() {
        // A Y: stem y = 0 for x in [0, 4], upper branch to (10, 3), lower branch to (8, −3).
        let mut pos = Vec::new();
        for k in 0..=4 {
            pos.push(V2::new(k as f64, 0.0));
        }
        for k in 1..=6 {
            pos.push(V2::new(4.0 + k as f64, 0.5 * k as f64)); // upper ends at (10, 3)
        }
        for k in 1..=4 {
            pos.push(V2::new(4.0 + k as f64, -0.75 * k as f64)); // lower ends at (8, −3)
        }
        pos.push(V2::new(12.0, -3.0)); // undamaged node beyond both
        let mut d = vec![1.0; pos.len()];
        *d.last_mut().unwrap() = 0.0;
        let e = V2::new(1.0, 0.0);
        let upper = SearchBox::new(V2::new(4.0, 0.0), V2::new(20.0, 10.0));
        let lower = SearchBox::new(V2::new(4.0, -10.0), V2::new(20.0, 0.0));
        let whole = find_tip(&pos, &d, 0.35, &e, None).unwrap();
        assert_eq!(whole.position, V2::new(10.0, 3.0));
        let low = find_tip(&pos, &d, 0.35, &e, Some(&lower)).unwrap();
        assert_eq!(low.position, V2::new(8.0, -3.0));
        assert_eq!(low.index, 5 + 6 + 3);
        // A box with no damaged node gives no tip.
        let empty = SearchBox::new(V2::new(11.0, -5.0), V2::new(13.0, 5.0));
        assert!(find_tip(&pos, &d, 0.35, &e, Some(&empty)).is_none());

        let tracker = TipTracker::new(
            0.35,
            e,
            vec![
                Branch {
                    name: "upper".into(),
                    search: Some(upper),
                },
                Branch {
                    name: "lower".into(),
                    search: Some(lower),
                },
                Branch {
                    name: "none".into(),
                    search: Some(empty),
                },
            ],
        );
        let s = tracker.sample(1.5, &pos, &d);
        assert_eq!(s.len(), 3);
        assert_eq!(s[0].unwrap().tip.position, V2::new(10.0, 3.0));
        assert_eq!(s[0].unwrap().time, 1.5);
        assert!(s[0].unwrap().front.is_none());
        assert_eq!(s[1].unwrap().tip.position, V2::new(8.0, -3.0));
        assert!(s[2].is_none());
    }

    #[test]
    fn front_of_a_straight_3d_crack_is_its_leading_line() {
        // A planar crack z = 0 on a lattice of spacing 1: nodes x in 0..=5 damaged for
        // y in 0..=4, and one node reaching x = 6 at y = 2 (a front bulging by one spacing).
        let mut pos = Vec::new();
        let mut d = Vec::new();
        for x in 0..=8 {
            for y in 0..=4 {
                pos.push(V3::new(x as f64, y as f64, 0.0));
                let damaged = x <= 5 || (x == 6 && y == 2);
                d.push(if damaged { 0.8 } else { 0.1 });
            }
        }
        let e = V3::new(1.0, 0.0, 0.0);
        // Tolerance 0.5: only the bulge node. Tolerance 1: the bulge and the x = 5 line.
        let f = crack_front(&pos, &d, 0.4, &e, None, 0.5).unwrap();
        assert_eq!(f.count, 1);
        assert_eq!(f.mean, V3::new(6.0, 2.0, 0.0));
        let f = crack_front(&pos, &d, 0.4, &e, None, 1.0).unwrap();
        assert_eq!(f.count, 6);
        assert_eq!(f.extreme.position, V3::new(6.0, 2.0, 0.0));
        // Mean x = (6 + 5·5)/6, mean y = (2 + 0+1+2+3+4)/6 = 2.
        assert!((f.mean - V3::new(31.0 / 6.0, 2.0, 0.0)).norm() < 1e-14);

        let tracker = TipTracker::new(
            0.4,
            e,
            vec![Branch {
                name: "front".into(),
                search: None,
            }],
        )
        .with_front(1.0);
        let s = tracker.sample(0.0, &pos, &d)[0].unwrap();
        assert_eq!(s.front.unwrap().count, 6);
    }

    #[test]
    fn history_skips_samples_without_a_tip() {
        let tip = |t: f64, x: f64| {
            Some(TipSample {
                time: t,
                tip: Tip {
                    index: 0,
                    position: V2::new(x, 0.0),
                    projection: x,
                },
                front: None,
            })
        };
        let samples = vec![
            vec![None, tip(0.0, 1.0)],
            vec![tip(1.0, 2.0), tip(1.0, 3.0)],
            vec![tip(2.0, 4.0), None],
        ];
        let (t, p) = branch_history(&samples, 0);
        assert_eq!(t, vec![1.0, 2.0]);
        assert_eq!(p, vec![V2::new(2.0, 0.0), V2::new(4.0, 0.0)]);
        let (t, _) = branch_history(&samples, 1);
        assert_eq!(t, vec![0.0, 1.0]);
    }
}
