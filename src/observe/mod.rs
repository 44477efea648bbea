//! Observers of a run and the file writers they use.

pub mod crack_crossings;
pub mod crack_path;
pub mod crack_surface;
pub mod crack_tip;
pub mod csv;
pub mod displacement_error;
pub mod field_maps;
pub mod history;
pub mod observer;
pub mod progress;
pub mod pvd;
pub mod resume;
pub mod snapshots;
pub mod stage_record;
pub mod vtu;

pub use observer::{Every, Observer, StageStart, StepView};
