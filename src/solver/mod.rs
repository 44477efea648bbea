//! Solvers: the force engine, the explicit velocity-Verlet integrator and the quasi-static
//! load-step loop (adaptive dynamic relaxation).

pub mod forces;
pub mod quasi_static;
pub mod verlet;

pub use forces::ForceEngine;
pub use quasi_static::{LoadStepReport, QuasiStatic, QuasiStaticSettings};
pub use verlet::{Fields, Simulation, StepError};
