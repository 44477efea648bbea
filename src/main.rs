//! The `peridyn` program: the command line (`cli`) in one process.

fn main() -> std::process::ExitCode {
    peridyn::cli::main(None)
}
