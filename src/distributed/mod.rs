//! Distributed runs: one model across several processes (ranks), bitwise identical to a run
//! in one process (`docs/distributed.md`). Each rank owns a contiguous range of the Morton
//! node order (`partition`), builds the families of its own nodes and the halo of ghosts they
//! reach (`share`), exchanges the ghosts inside each step and continues every sum over nodes
//! in rank order (`solver::ranks`); rank 0 gathers the fields its observers read (`gather`)
//! and writes every file, and hands each rank its part of a checkpoint to continue from
//! (`restart`). Every feature of a one-process run runs distributed.
//!
//! Everything here but the transport is plain Rust; the transport (`mpi_ranks`, the `mpi`
//! feature) is the only part that needs an MPI library.

pub mod gather;
#[cfg(feature = "mpi")]
pub mod mpi_ranks;
pub mod partition;
pub mod plan;
pub mod restart;
pub mod run;
pub mod share;
pub mod study;
#[cfg(test)]
pub mod thread_ranks;

pub use run::run_with;
