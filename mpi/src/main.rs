//! The `peridyn-mpi` program: peridyn's command line on the ranks `mpirun` starts
//! (`docs/distributed.md`). With one rank (or without `mpirun`) it is the `peridyn` program.

mod ranks;

use peridyn::solver::ranks::Ranks;
use ranks::MpiRanks;
use std::process::ExitCode;
use std::sync::Arc;

fn main() -> ExitCode {
    // Serialized: the calls come from whichever thread drives the run, one at a time.
    let Some((universe, _)) = mpi::initialize_with_threading(mpi::Threading::Serialized) else {
        eprintln!("error: MPI could not be initialised (or was initialised already)");
        return ExitCode::FAILURE;
    };
    let world: Arc<dyn Ranks> = Arc::new(MpiRanks::world());
    let code = peridyn::cli::main(Some(world));
    // MPI is finalised here, after every rank's files are written.
    drop(universe);
    code
}
