//! The lcpbench command line with `jacobi-example` added: every subcommand, sweep and report
//! of `lcpbench`, the example solver listed, parsed and run beside the built-in ones.

use std::process::ExitCode;

fn main() -> ExitCode {
    if let Err(e) = lcpbench::registry::register(&lcpbench_own_solver::JACOBI_EXAMPLE) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    lcpbench::cli::main()
}
