//! Parameter studies: which inputs of a simulation matter, and how much.
//!
//! A study varies a few deck inputs (factors) between bounds, runs the simulation at each
//! design point and relates the outputs back to the factors. This layer is pure math on
//! numbers: it builds designs and evaluates results, and knows nothing of decks or solvers.
//!
//! - `morris`: Morris elementary-effects screening (Morris 1991) with the trajectory selection
//!   of Campolongo et al. 2007, as used in seed 004 §3 (9 inputs, 5 trajectories out of 20,
//!   50 runs);
//! - `sweep`: every combination of given values (a full-factorial parameter study);
//! - `table`: a run's CSV output as numbers, and the reductions that make one output of it;
//! - `toml_number`: a number of a TOML file a run writes (`resolved.toml`), by key path.
//!
//! `study_run.rs` (front layer) edits the deck at each design point, runs it and reads the
//! outputs back.

pub mod morris;
pub mod sweep;
pub mod table;
pub mod toml_number;
