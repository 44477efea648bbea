//! Small vector aliases shared by every module.
//!
//! The dimension is a const generic `D` (2 or 3) chosen once per run (see `run.rs`);
//! everything below the dispatch is monomorphised for it.

/// A point or vector in `D` dimensions.
pub type Vector<const D: usize> = nalgebra::SVector<f64, D>;

/// The smallest and largest coordinate of `points` along `axis` (m); [∞, −∞] without points.
pub fn extent<const D: usize>(points: &[Vector<D>], axis: usize) -> [f64; 2] {
    points
        .iter()
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], p| {
            [lo.min(p[axis]), hi.max(p[axis])]
        })
}

/// The middle of the points' extent along `axis` (m); 0 without points.
pub fn extent_middle<const D: usize>(points: &[Vector<D>], axis: usize) -> f64 {
    match extent(points, axis) {
        [lo, hi] if lo <= hi => 0.5 * (lo + hi),
        _ => 0.0,
    }
}

/// Builds a `Vector<D>` from the first `D` entries of a slice.
pub fn vector_from_slice<const D: usize>(s: &[f64]) -> Vector<D> {
    Vector::<D>::from_fn(|k, _| s[k])
}

/// Pads a `D`-vector to three components (z = 0 in 2D), for output.
pub fn to3<const D: usize>(v: &Vector<D>) -> [f64; 3] {
    let mut out = [0.0; 3];
    for k in 0..D {
        out[k] = v[k];
    }
    out
}

/// A D×D matrix (D = 2 or 3).
pub type Matrix<const D: usize> = nalgebra::SMatrix<f64, D, D>;

/// Determinant of a 2×2 or 3×3 matrix (written out: nalgebra's needs bounds a const-generic
/// dimension cannot state).
#[inline]
pub fn determinant<const D: usize>(m: &Matrix<D>) -> f64 {
    match D {
        2 => m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)],
        3 => {
            m[(0, 0)] * (m[(1, 1)] * m[(2, 2)] - m[(1, 2)] * m[(2, 1)])
                - m[(0, 1)] * (m[(1, 0)] * m[(2, 2)] - m[(1, 2)] * m[(2, 0)])
                + m[(0, 2)] * (m[(1, 0)] * m[(2, 1)] - m[(1, 1)] * m[(2, 0)])
        }
        _ => unreachable!("dimension 2 or 3"),
    }
}

/// Inverse of a 2×2 or 3×3 matrix by its adjugate, or `None` if the determinant is zero or
/// not finite.
#[inline]
pub fn inverse<const D: usize>(m: &Matrix<D>) -> Option<Matrix<D>> {
    let det = determinant(m);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    Some(match D {
        2 => Matrix::<D>::from_fn(|r, c| {
            let v = match (r, c) {
                (0, 0) => m[(1, 1)],
                (0, 1) => -m[(0, 1)],
                (1, 0) => -m[(1, 0)],
                _ => m[(0, 0)],
            };
            v * inv
        }),
        _ => Matrix::<D>::from_fn(|r, c| {
            // inverse(r, c) = cofactor(c, r) / det
            let (a0, a1) = ((c + 1) % 3, (c + 2) % 3);
            let (b0, b1) = ((r + 1) % 3, (r + 2) % 3);
            (m[(a0, b0)] * m[(a1, b1)] - m[(a0, b1)] * m[(a1, b0)]) * inv
        }),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_of_2x2_and_3x3() {
        let a = Matrix::<2>::new(2.0, 1.0, 0.5, 3.0);
        assert!((a * inverse(&a).unwrap() - Matrix::<2>::identity()).norm() < 1e-15);
        let b = Matrix::<3>::new(2.0, 1.0, 0.3, 0.5, 3.0, -1.0, 0.2, 0.1, 4.0);
        assert!((b * inverse(&b).unwrap() - Matrix::<3>::identity()).norm() < 1e-14);
        assert!((determinant(&b) - b.determinant()).abs() < 1e-12);
        assert!(inverse(&Matrix::<3>::zeros()).is_none());
    }
}
