//! Fracture analysis on a damage field: pure functions of node positions, damage and time,
//! with no dependence on the solver, so results can be recomputed from written fields and
//! tested on synthetic data.
//!
//! - `crack_tip`: the tip of each branch (seed 000 Appendix 2, seed 002 §2.12) and, in 3D,
//!   the crack front.
//! - `crack_speed`: tip speed from a tip history, and the Rayleigh wave speed it is compared
//!   with (seed 002).
//! - `crack_path`: the crack as a 2D polyline and its Pearson correlation with a reference
//!   path (seed 003 Eq. 17).
//! - `dissipation_rate`: Γ = dE_diss/dā of a running crack (seed 002 Eq. 13).
//! - `crack_surface`: the crack area from the broken bonds (2D and 3D) and, in 3D, the crack
//!   as a surface binned on a grid normal to its mean normal.
//! - `branching`: connected damaged regions and the fork of a branching 2D crack, with the
//!   branch angles.
//! - `crossings`: how many cracks cross a 2D line, and where.
//! - `bar_wave`: the exact displacement of a fixed–free bar released from a uniform strain
//!   (seed 003 §4.1), which a run's nodes are compared with.
//!
//! Only `crate::math::Vector` is imported from the crate: this layer sits below the solver and
//! the observers, which may call it.

pub mod bar_wave;
pub mod branching;
pub mod crack_path;
pub mod crack_speed;
pub mod crack_surface;
pub mod crack_tip;
pub mod crossings;
pub mod dissipation_rate;

pub use bar_wave::FixedFreeBar;
pub use branching::{damaged_components, find_forks, Fork, ForkBranch};
pub use crack_path::{compare_paths, crack_path, pearson, PathComparison};
pub use crack_speed::{
    crack_speed, rayleigh_speed, wave_speeds, SpeedSample, WaveSetting, WaveSpeeds,
};
pub use crack_surface::{
    crack_area, crack_surface, in_plane_axes, pair_density, BrokenHalf, SurfaceCell,
};
pub use crack_tip::{
    branch_history, crack_front, find_tip, Branch, CrackFront, SearchBox, Tip, TipSample,
    TipTracker,
};
pub use crossings::{crossings, Crossing, CrossingLine};
pub use dissipation_rate::{dissipation_rate, RateSample};
