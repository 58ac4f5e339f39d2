//! The machine a run ran on: host name, CPU model and core count. Every row of a sweep records
//! it (the columns `host`, `cpu_model`, `cores` of [`RunRecord`](crate::harness::RunRecord)), so
//! rows merged from the shards of a sweep run on several machines say where each was timed, and
//! the report can keep its timing comparisons within one machine.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::sync::OnceLock;

/// Where a run ran.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Machine {
    /// Host name (`/proc/sys/kernel/hostname`, `/etc/hostname`, or `$HOSTNAME`), or `unknown`.
    pub host: String,
    /// CPU model (the first `model name` of `/proc/cpuinfo`), or `unknown`.
    pub cpu_model: String,
    /// Logical cores available to the process.
    pub cores: usize,
}

impl Machine {
    /// This machine, read once per process.
    pub fn current() -> &'static Machine {
        static CURRENT: OnceLock<Machine> = OnceLock::new();
        CURRENT.get_or_init(|| Machine {
            host: host_name(),
            cpu_model: cpu_model(),
            cores: cores(),
        })
    }
}

impl fmt::Display for Machine {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            out,
            "{} ({}, {} cores)",
            self.host, self.cpu_model, self.cores
        )
    }
}

/// The CPU model: the first `model name` line of `/proc/cpuinfo`, or `unknown`.
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_owned())
        })
        .filter(|m| !m.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// Logical cores available to the process (1 when unknown).
pub fn cores() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// The host name, or `unknown`.
pub fn host_name() -> String {
    ["/proc/sys/kernel/hostname", "/etc/hostname"]
        .iter()
        .filter_map(|p| std::fs::read_to_string(p).ok())
        .chain(
            ["HOSTNAME", "COMPUTERNAME"]
                .iter()
                .filter_map(|v| std::env::var(v).ok()),
        )
        .map(|h| h.trim().to_owned())
        .find(|h| !h.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_current_machine_is_named() {
        let m = Machine::current();
        assert!(!m.host.is_empty() && !m.cpu_model.is_empty());
        assert!(m.cores >= 1);
        assert!(m.to_string().contains(&m.host));
    }
}
