//! `lcpbench`: the command-line front end of the contact-solver workbench (the command line
//! itself is the library's [`lcpbench::cli`]).

fn main() -> std::process::ExitCode {
    lcpbench::cli::main()
}
