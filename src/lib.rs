//! peridyn: peridynamic fracture simulation in 2D and 3D.
//!
//! The flow of a run: a deck (`deck`) or Rust code builds a `Body` (`discretize`, `geometry`),
//! its `Bonds` (`bonds`), a material (`material`) and `Loading`; a `solver::Simulation`
//! advances the `State`, and observers (`observe`, `plot`) write fields, histories and pictures.

pub mod analysis;
pub mod atomic_file;
pub mod bench;
pub mod body;
pub mod bonds;
pub mod checkpoint;
pub mod cli;
pub mod counters;
pub mod damage;
pub mod deck;
pub mod dimensionality;
pub mod discretize;
pub mod distributed;
pub mod geometry;
pub mod grid;
pub mod loading;
pub mod material;
pub mod math;
pub mod memory;
pub mod observe;
pub mod per_node;
pub mod plot;
pub mod run;
pub mod session;
pub mod solver;
pub mod state;
pub mod study;
pub mod study_run;
pub mod validation;
