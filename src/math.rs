//! Small vector aliases shared by every module.
//!
//! The dimension is a const generic `D` (2 or 3) chosen once per run (see `run.rs`);
//! everything below the dispatch is monomorphised for it.

/// A point or vector in `D` dimensions.
pub type Vector<const D: usize> = nalgebra::SVector<f64, D>;

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
