//! Solvers: the force engine, the explicit velocity-Verlet integrator (with the adaptive time
//! step controller) and the quasi-static load-step loop (adaptive dynamic relaxation).

pub mod adaptive_dt;
pub mod coarse_space;
pub mod contact;
pub mod contact_halo;
pub mod cross_bonds;
pub mod damage_cache;
pub mod dissipation;
pub mod forces;
pub mod impactor;
pub mod ncg;
pub mod quasi_static;
pub mod quasi_static_memory;
pub mod ranks;
pub mod verlet;

pub use adaptive_dt::{AdaptiveDt, AdaptiveDtSettings};
pub use forces::{bond_force, ForceEngine};
pub use quasi_static::{
    AdrDamping, AdrMass, Advanced, EquilibriumMethod, LoadStepReport, Pause, QuasiStatic,
    QuasiStaticSettings,
};
pub use verlet::{Fields, Simulation, StepError};
