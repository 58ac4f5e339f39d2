//! The report header: machine, commit, date and the command, so each figure can be regenerated.

use crate::harness::machine::Machine;
use std::process::Command;

/// Where and when a report was produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// CPU model of the machine writing the report (`/proc/cpuinfo`), or `unknown`, escaped
    /// for the README ([`escape_cell`]).
    pub cpu: String,
    /// Logical cores available to the process.
    pub cores: usize,
    /// Operating system and architecture.
    pub os: String,
    /// Git commit (`git rev-parse --short HEAD`, `+dirty` when the tree has changes), or
    /// `unknown`.
    pub commit: String,
    /// UTC date and time, ISO 8601.
    pub date: String,
    /// The command that produced the report.
    pub command: String,
    /// Worker processes of the sweep.
    pub workers: usize,
}

impl Header {
    /// A fixed header for tests of the report's sections: a 2-core machine `cpu`, commit
    /// `abc`, run by `command` with `workers` worker processes.
    #[cfg(test)]
    pub(crate) fn for_tests(command: &str, workers: usize) -> Self {
        Self {
            cpu: "cpu".into(),
            cores: 2,
            os: "os".into(),
            commit: "abc".into(),
            date: "today".into(),
            command: command.into(),
            workers,
        }
    }

    /// Collect the header for the current machine and working directory, for a sweep run by
    /// `workers` worker processes.
    pub fn collect(command: &str, workers: usize, out_dir: &std::path::Path) -> Self {
        let machine = Machine::current();
        Self {
            cpu: escape_cell(&machine.cpu_model),
            cores: machine.cores,
            os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
            commit: commit(out_dir),
            date: utc_now(),
            command: command.to_owned(),
            workers,
        }
    }
}

/// `text` made safe to print in a Markdown table cell or HTML: control characters (a newline
/// would end the table row) become spaces, and the characters Markdown or HTML would read as
/// markup (`<`, `>`, `&`, `|`, a backquote, `*`, `_`, `[`, `]`, `\`) become HTML character
/// references, which both render as the character itself. Every machine field the report prints
/// (host, CPU model) goes through it.
pub fn escape_cell(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            c if c.is_control() => out.push(' '),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '|' | '`' | '*' | '_' | '[' | ']' | '\\' => {
                out.push_str(&format!("&#{};", u32::from(c)));
            }
            c => out.push(c),
        }
    }
    out
}

/// The lcpbench commit of the working directory: `git rev-parse --short HEAD`, with `+dirty`
/// when tracked files have changes outside `out_dir` (a report's or sweep's own outputs, which
/// are being rewritten, do not count), or `unknown` outside a git checkout.
pub fn commit(out_dir: &std::path::Path) -> String {
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
    };
    match git(&["rev-parse", "--short", "HEAD"]) {
        Some(c) => {
            let exclude = report_pathspec(out_dir, git(&["rev-parse", "--show-toplevel"]));
            let mut args = vec!["status", "--porcelain", "--untracked-files=no"];
            if let Some(e) = &exclude {
                args.extend(["--", ".", e.as_str()]);
            }
            let dirty = git(&args).is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{c}+dirty")
            } else {
                c
            }
        }
        None => "unknown".into(),
    }
}

/// Current UTC time as `YYYY-MM-DDTHH:MM:SSZ` (civil-from-days, no time-zone database needed).
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    format_utc(secs)
}

/// Format seconds since the Unix epoch as `YYYY-MM-DDTHH:MM:SSZ`.
pub fn format_utc(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The git pathspec that leaves out the report's output directory, when it lies inside the
/// repository whose top level is `top`.
fn report_pathspec(out_dir: &std::path::Path, top: Option<String>) -> Option<String> {
    let top = std::fs::canonicalize(top?).ok()?;
    let out = std::fs::canonicalize(out_dir).ok()?;
    let rel = out.strip_prefix(&top).ok()?;
    (!rel.as_os_str().is_empty()).then(|| format!(":(top,exclude){}", rel.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn machine_text_cannot_break_a_table_or_carry_markup() {
        let hostile = "node\n| x |\n```\n<img src=x onerror=alert(1)>";
        let cell = escape_cell(hostile);
        for bad in ['\n', '|', '`', '<', '>'] {
            assert!(!cell.contains(bad), "{cell}");
        }
        assert_eq!(
            cell,
            "node &#124; x &#124; &#96;&#96;&#96; &lt;img src=x onerror=alert(1)&gt;"
        );
        assert_eq!(
            escape_cell("Intel(R) Xeon(R) 2.10GHz"),
            "Intel(R) Xeon(R) 2.10GHz"
        );
        assert_eq!(escape_cell("a&b_c"), "a&amp;b&#95;c");
    }

    #[test]
    fn formats_known_dates() {
        assert_eq!(format_utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(format_utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(format_utc(1_700_000_000), "2023-11-14T22:13:20Z");
    }

    #[test]
    fn the_report_directory_is_left_out_of_the_dirty_check_only_inside_the_repository() {
        let top = std::env::temp_dir().join("lcpbench_pathspec_test");
        std::fs::create_dir_all(top.join("reports")).unwrap();
        let top_s = Some(top.display().to_string());
        assert_eq!(
            super::report_pathspec(&top.join("reports"), top_s.clone()).as_deref(),
            Some(":(top,exclude)reports")
        );
        assert_eq!(super::report_pathspec(&top, top_s.clone()), None);
        assert_eq!(super::report_pathspec(&std::env::temp_dir(), top_s), None);
    }
}
