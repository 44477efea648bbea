//! Distributed runs: one model across several processes (ranks), bitwise identical to a run
//! in one process (`docs/distributed.md`). Each rank owns a contiguous range of the Morton
//! node order (`partition`), builds the families of its own nodes and the halo of ghosts they
//! reach (`share`), exchanges the ghosts inside each step and continues every sum over nodes
//! in rank order (`solver::ranks`); rank 0 gathers the fields its observers read (`gather`)
//! and writes every file, and hands each rank its part of a checkpoint to continue from
//! (`restart`). Every feature of a one-process run runs distributed.
//!
//! Everything here is plain Rust; the transport (`Ranks` over MPI) is the `mpi/` package's,
//! the only part that needs an MPI library.

pub mod gather;
pub mod partition;
pub mod plan;
pub mod restart;
pub mod run;
pub mod share;
pub mod study;
#[cfg(test)]
pub mod thread_ranks;

pub use run::run_with;
