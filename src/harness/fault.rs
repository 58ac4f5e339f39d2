//! Faults injected into the isolated child instead of a solve, to test that a sweep records
//! a panic, a hang or an abort and carries on.

use std::time::Duration;

/// A deliberate failure injected into the child process, to test that the sweep records it and
/// carries on. Selected with the hidden solver names `fault-panic`, `fault-hang`, `fault-abort`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Panic inside the run.
    Panic,
    /// Sleep forever (the parent must kill the child).
    Hang,
    /// Abort the process (no unwinding).
    Abort,
}

impl Fault {
    /// Name used in `fault-NAME` and `--fault NAME`.
    pub fn name(self) -> &'static str {
        match self {
            Fault::Panic => "panic",
            Fault::Hang => "hang",
            Fault::Abort => "abort",
        }
    }

    /// Inverse of [`Fault::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        [Fault::Panic, Fault::Hang, Fault::Abort]
            .into_iter()
            .find(|f| f.name() == name)
    }

    /// Make the fault happen.
    pub fn trigger(self) -> ! {
        match self {
            Fault::Panic => panic!("injected fault: panic"),
            Fault::Hang => loop {
                std::thread::sleep(Duration::from_secs(3600));
            },
            Fault::Abort => std::process::abort(),
        }
    }
}
