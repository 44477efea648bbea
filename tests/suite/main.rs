//! The verification suite, one test binary (each file a module): linking one binary instead
//! of one per file keeps the release build of the tests, and CI, short. Run one file's tests
//! with `cargo test --release --test suite patch::` (the module name), one test by its name.

mod adaptive_dt;
mod blocks;
mod boundary_gradient;
mod boundary_layers;
mod common;
mod conformance;
mod contact;
mod correspondence;
mod crack_path_run;
mod crack_surface;
mod crack_tracking;
mod deck_errors;
mod decks_good;
mod delta_convergence;
mod determinism;
mod dual_horizon;
mod energy_accounting;
mod energy_conservation;
mod examples_run;
mod field_maps;
mod fracture_energy;
mod fracture_rules;
mod gmsh;
mod grids;
mod instability;
mod kernels;
mod kirsch;
mod patch;
mod quasi_static;
mod restart;
mod separation_work;
mod softening;
mod staged;
mod study;
mod validation;
mod wave_speed;
mod wedge_splitting;
