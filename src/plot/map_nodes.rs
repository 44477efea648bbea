//! Which nodes a field map draws, at which 2D coordinates: the whole body in 2D, the nodes
//! near a plane in 3D (a slice).

use crate::math::{extent_middle, Vector};
use std::borrow::Cow;

const AXIS_NAMES: [&str; 3] = ["x", "y", "z"];

/// The drawn nodes of a map, chosen once per run (reference positions do not move).
#[derive(Debug, Clone)]
pub struct MapNodes {
    /// In-plane coordinates (m) of the drawn nodes.
    pub xy: Vec<[f64; 2]>,
    /// Cell sizes (m) of the drawn nodes.
    pub cell_sizes: Vec<f64>,
    /// Body indices of the drawn nodes; `None`: every node, in order (no copy of the values).
    nodes: Option<Vec<usize>>,
    /// Names of the horizontal and vertical axes.
    pub axis_names: [&'static str; 2],
    /// A slice's normal axis (0, 1, 2) and coordinate (m); `None` in 2D.
    pub plane: Option<(usize, f64)>,
}

/// The axes that span the plane normal to `axis`, in reading order (z vertical when in plane).
fn in_plane(axis: usize) -> [usize; 2] {
    match axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

impl MapNodes {
    /// Every node of a 2D body.
    pub fn whole<const D: usize>(positions: &[Vector<D>], cell_sizes: &[f64]) -> Self {
        MapNodes {
            xy: positions.iter().map(|p| [p[0], p[1]]).collect(),
            cell_sizes: cell_sizes.to_vec(),
            nodes: None,
            axis_names: ["x", "y"],
            plane: None,
        }
    }

    /// The nodes within half their cell size of the plane normal to `axis` at `at` (default:
    /// the mid-plane). A plane on a cell face takes the layers on both sides; where they
    /// overlap the map shows their mean, the field at the plane.
    pub fn slice<const D: usize>(
        positions: &[Vector<D>],
        cell_sizes: &[f64],
        axis: usize,
        at: Option<f64>,
    ) -> Self {
        let at = at.unwrap_or_else(|| extent_middle(positions, axis));
        let [a, b] = in_plane(axis);
        // A relative slack so a plane on a cell face does not lose a layer to rounding.
        let near = |p: &Vector<D>, c: f64| (p[axis] - at).abs() <= 0.5 * c * (1.0 + 1e-9);
        let nodes: Vec<usize> = (0..positions.len())
            .filter(|&i| near(&positions[i], cell_sizes[i]))
            .collect();
        MapNodes {
            xy: nodes
                .iter()
                .map(|&i| [positions[i][a], positions[i][b]])
                .collect(),
            cell_sizes: nodes.iter().map(|&i| cell_sizes[i]).collect(),
            nodes: Some(nodes),
            axis_names: [AXIS_NAMES[a], AXIS_NAMES[b]],
            plane: Some((axis, at)),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.xy.is_empty()
    }

    /// The values of the drawn nodes, out of one value per body node.
    pub fn pick<'a>(&self, all: &'a [f64]) -> Cow<'a, [f64]> {
        match &self.nodes {
            None => Cow::Borrowed(all),
            Some(nodes) => Cow::Owned(nodes.iter().map(|&i| all[i]).collect()),
        }
    }

    /// "slice z = 1.500 mm" for a slice, empty in 2D.
    pub fn plane_label(&self) -> String {
        match self.plane {
            Some((axis, at)) => format!("slice {} = {:.3} mm", AXIS_NAMES[axis], at * 1e3),
            None => String::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube lattice of n³ nodes at cell centres, spacing dx.
    fn cube(n: usize, dx: f64) -> (Vec<Vector<3>>, Vec<f64>) {
        let mut p = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let c = |m: usize| (m as f64 + 0.5) * dx;
                    p.push(Vector::<3>::new(c(i), c(j), c(k)));
                }
            }
        }
        let cells = vec![dx; p.len()];
        (p, cells)
    }

    fn assert_plane(s: &MapNodes, axis: usize, at: f64) {
        let (a, x) = s.plane.expect("a slice");
        assert!(a == axis && (x - at).abs() < 1e-12, "{:?}", s.plane);
    }

    #[test]
    fn a_slice_through_a_layer_takes_that_layer_only() {
        let (p, c) = cube(5, 1e-3);
        // Odd layer count: the mid-plane passes through the middle layer's centres.
        let s = MapNodes::slice(&p, &c, 2, None);
        assert_plane(&s, 2, 2.5e-3);
        assert_eq!(s.xy.len(), 25);
        assert_eq!(s.axis_names, ["x", "y"]);
        assert_eq!(s.plane_label(), "slice z = 2.500 mm");
        // Along x: the picture spans y and z.
        let s = MapNodes::slice(&p, &c, 0, Some(0.7e-3));
        assert_eq!(s.xy.len(), 25);
        assert_eq!(s.axis_names, ["y", "z"]);
        let values: Vec<f64> = p.iter().map(|q| q[0]).collect();
        assert!(s.pick(&values).iter().all(|&x| x == 0.5e-3));
    }

    #[test]
    fn a_plane_on_a_cell_face_takes_both_layers_and_outside_takes_none() {
        let (p, c) = cube(4, 1e-3);
        let s = MapNodes::slice(&p, &c, 2, None);
        assert_plane(&s, 2, 2e-3);
        assert_eq!(s.xy.len(), 32);
        assert!(MapNodes::slice(&p, &c, 1, Some(5e-3)).is_empty());
    }

    #[test]
    fn the_whole_2d_body_borrows_its_values() {
        let p = vec![Vector::<2>::new(0.0, 1.0), Vector::<2>::new(2.0, 3.0)];
        let m = MapNodes::whole(&p, &[1.0, 1.0]);
        assert_eq!(m.xy, vec![[0.0, 1.0], [2.0, 3.0]]);
        assert!(matches!(m.pick(&[4.0, 5.0]), Cow::Borrowed(_)));
        assert_eq!(m.plane_label(), "");
    }
}
