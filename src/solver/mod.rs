//! Solvers: the force engine and the explicit velocity-Verlet integrator.

pub mod forces;
pub mod verlet;

pub use forces::ForceEngine;
pub use verlet::{Fields, Simulation, StepError};
