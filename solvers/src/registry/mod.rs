//! The solver registry: every solver described once, by a [`SolverEntry`] — its name, level,
//! one-line summary, problem classes, what its iteration count counts, whether it starts from
//! a warm start, the relaxed problem it solves (if any), its parameters with defaults and
//! ranges, and its constructor from [`Params`].
//!
//! Each solver's entry is a `static` in the solver's own file; the built-in entries of this
//! crate are listed once, in [`MATRIX_SOLVERS`] and [`CONE_SOLVERS`] (the body-level ones in
//! `lcpbench-contact`, which owns their trait). Everything else reads the registry: the kind
//! handles ([`crate::SolverKind`], [`crate::ConeSolverKind`]), names and their look-up, help
//! texts and error messages, the command line's solver specifications, the report's styles.
//!
//! A program outside the workspace adds its own solver at run time with [`register`] (a
//! process-global, append-only list), before it parses any solver name:
//!
//! ```
//! use lcpbench_solvers::registry::{self, Make, Params, SolverEntry};
//! use lcpbench_solvers::{Problem, ProjectedSor, Settings, Solver, SolverKind, Status};
//!
//! static HALF_SOR: SolverEntry = SolverEntry {
//!     name: "doc-half-sor",
//!     summary: "projected SOR at omega = 0.5 (under-relaxed Gauss-Seidel)",
//!     problem_classes: "standard and boxed LCPs (as sor)",
//!     iteration_unit: "sweeps over the rows",
//!     iterative: true,
//!     relaxation: None,
//!     params: &[],
//!     make: Make::Matrix(|_: &Params| Box::new(ProjectedSor::sor(0.5))),
//! };
//! registry::register(&HALF_SOR).unwrap();
//! let kind = SolverKind::from_name("doc-half-sor").unwrap();
//! let a = faer::Mat::from_fn(2, 2, |i, j| [[2.0, 1.0], [1.0, 2.0]][i][j]);
//! let problem = Problem::lcp(a, vec![-1.0, 1.0]).unwrap();
//! let result = kind.create().solve(&problem, &Settings::default());
//! assert_eq!(result.status, Status::Converged);
//! assert!(registry::register(&HALF_SOR).is_err(), "a name is registered once");
//! ```
//!
//! (A solver's own `name()` comes from its entry; the entry above makes a built-in type, which
//! names itself `sor`.)

pub mod params;

pub use params::{ParamSpec, Params, MAX_PARAMS};

use crate::{cone, lcp, ConeSolver, Solver};
use std::any::Any;
use std::fmt;
use std::sync::RwLock;
use thiserror::Error;

/// The level a solver works at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Level {
    /// Solves the assembled (boxed) LCP `w = A f + b` ([`Solver`]).
    Matrix,
    /// Works on the bodies through the Delassus operator, inside the stepper (scenes only;
    /// the trait, `BodySolver`, is `lcpbench-contact`'s).
    Body,
    /// Solves the exact Coulomb-cone problem, FC3D ([`ConeSolver`]).
    Cone,
}

impl Level {
    /// `matrix`, `body` or `cone`.
    pub fn name(self) -> &'static str {
        match self {
            Level::Matrix => "matrix",
            Level::Body => "body",
            Level::Cone => "cone",
        }
    }

    /// The solvers of this level in words (`matrix solvers`), for help texts and messages.
    pub fn plural(self) -> &'static str {
        match self {
            Level::Matrix => "matrix solvers",
            Level::Body => "body-level solvers",
            Level::Cone => "cone solvers",
        }
    }

    /// Every level, in the registry's order.
    pub const ALL: [Level; 3] = [Level::Matrix, Level::Body, Level::Cone];
}

/// How an entry makes its solver from its parameters (which follow the entry's
/// [`SolverEntry::params`] and have been checked against them). The variant is the solver's
/// level.
#[derive(Clone, Copy)]
pub enum Make {
    /// A matrix solver.
    Matrix(fn(&Params) -> Box<dyn Solver + Send>),
    /// A cone solver.
    Cone(fn(&Params) -> Box<dyn ConeSolver + Send>),
    /// A body-level solver. Its trait lives in `lcpbench-contact`, which this crate does not
    /// see, so the constructor is held type-erased: `lcpbench-contact` puts its `BodyMake` here
    /// and reads it back.
    Body(&'static (dyn Any + Send + Sync)),
}

/// One solver, described once.
pub struct SolverEntry {
    /// Name on the command line, in scene files and in the CSV (letters, digits, `-`, `_`,
    /// `.`; unique in the registry).
    pub name: &'static str,
    /// What the solver is, in one line.
    pub summary: &'static str,
    /// The problem classes it takes and its limits, in one line (`lcpbench solvers`).
    pub problem_classes: &'static str,
    /// What one unit of its iteration count is (`sweeps over the rows`, `pivots`, …).
    pub iteration_unit: &'static str,
    /// True when it iterates from a starting impulse, so a warm start (`+warm`) applies.
    pub iterative: bool,
    /// The relaxed or soft problem it solves in place of the one it is given, when it does
    /// (its status then says so); `None` for the solvers of the problem as posed.
    pub relaxation: Option<&'static str>,
    /// Its parameters (`name@key=value,…`) with defaults and ranges; empty for none.
    pub params: &'static [ParamSpec],
    /// Its constructor, which also says its level.
    pub make: Make,
}

impl SolverEntry {
    /// Matrix, body-level or cone (from the constructor).
    pub const fn level(&self) -> Level {
        match self.make {
            Make::Matrix(_) => Level::Matrix,
            Make::Cone(_) => Level::Cone,
            Make::Body(_) => Level::Body,
        }
    }

    /// Every parameter at its default.
    pub const fn defaults(&self) -> Params {
        Params::defaults(self.params)
    }

    /// The parameters of `text` (`key=value,…`; empty for the defaults; a bare value is the
    /// value of the solver's only key), checked against [`SolverEntry::params`]. The message
    /// starts with the solver's name and names the key and its range, or the keys it takes.
    pub fn parse_params(&self, text: &str) -> Result<Params, String> {
        let text = text.trim();
        if !text.is_empty() && self.params.is_empty() {
            return Err(format!("{}: takes no parameters (got `{text}`)", self.name));
        }
        let keyed;
        let text = match self.params {
            [only] if !text.is_empty() && !text.contains('=') => {
                keyed = format!("{}={text}", only.key);
                keyed.as_str()
            }
            _ => text,
        };
        Params::parse(self.params, text).map_err(|e| format!("{}: {e}", self.name))
    }

    /// The matrix solver with `params` (`None` at another level).
    pub fn create(&self, params: &Params) -> Option<Box<dyn Solver + Send>> {
        match self.make {
            Make::Matrix(make) => Some(make(params)),
            _ => None,
        }
    }

    /// The cone solver with `params` (`None` at another level).
    pub fn create_cone(&self, params: &Params) -> Option<Box<dyn ConeSolver + Send>> {
        match self.make {
            Make::Cone(make) => Some(make(params)),
            _ => None,
        }
    }

    /// True when the solver with its defaults works without the assembled `A`: a matrix solver
    /// that sweeps on the factors `J`, `M⁻¹` ([`Solver::works_on_factors`], asked of a solver
    /// made with the defaults) and every body-level solver (matrix-free by construction); a
    /// cone solver reads the assembled `W`.
    pub fn works_on_factors(&self) -> bool {
        match self.make {
            Make::Matrix(make) => make(&self.defaults()).works_on_factors(),
            Make::Body(_) => true,
            Make::Cone(_) => false,
        }
    }

    /// Why this entry cannot be registered, if it cannot: a name that is empty, too long or has
    /// characters other than ASCII letters, digits, `-`, `_`, `.` (so that `@`, `+`, `,` and
    /// `:` keep their meaning in specifications and case keys) or starts with `fault-`; more
    /// than [`MAX_PARAMS`] parameters, a repeated key, or a default outside its range.
    pub fn check(&self) -> Result<(), String> {
        let name = self.name;
        if name.is_empty() || name.len() > MAX_NAME_LEN {
            return Err(format!(
                "solver name `{name}` must have 1 to {MAX_NAME_LEN} characters"
            ));
        }
        if let Some(c) = name
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')))
        {
            return Err(format!(
                "solver name `{name}` has `{c}`: only ASCII letters, digits, `-`, `_` and `.` \
                 are allowed"
            ));
        }
        if name.starts_with("fault-") || RESERVED_NAMES.contains(&name) {
            return Err(format!(
                "solver name `{name}` is reserved (fault-…, {})",
                RESERVED_NAMES.join(", ")
            ));
        }
        if self.params.len() > MAX_PARAMS {
            return Err(format!(
                "solver `{name}` has {} parameters, more than the limit of {MAX_PARAMS} \
                 (MAX_PARAMS)",
                self.params.len()
            ));
        }
        for (k, p) in self.params.iter().enumerate() {
            if self.params[..k].iter().any(|q| q.key == p.key) {
                return Err(format!(
                    "solver `{name}`: parameter `{}` listed twice",
                    p.key
                ));
            }
            if !p.admits(p.default) {
                return Err(format!(
                    "solver `{name}`: the default {} of `{}` is outside its range {}",
                    p.default,
                    p.key,
                    p.range()
                ));
            }
        }
        Ok(())
    }
}

/// Longest solver name.
pub const MAX_NAME_LEN: usize = 64;

/// Words the command line gives a meaning of their own where solver names go (`--solvers all`,
/// `body`, `cone`, `engine`), which no solver may take.
pub const RESERVED_NAMES: [&str; 5] = ["all", "body", "cone", "engine", "none"];

/// Entries are one solver each: equal when their names are (names are unique in the
/// registry).
impl PartialEq for SolverEntry {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Eq for SolverEntry {}

impl std::hash::Hash for SolverEntry {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.name.hash(state);
    }
}

impl fmt::Debug for SolverEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "SolverEntry({}, {})", self.name, self.level().name())
    }
}

/// The matrix solvers of this crate, in report order.
pub static MATRIX_SOLVERS: &[&SolverEntry] = &[
    &lcp::pgs::PGS,
    &lcp::pgs::SOR,
    &lcp::lemke::LEMKE,
    &lcp::dantzig::DANTZIG,
    &lcp::clarabel_qp::CLARABEL,
    &lcp::micro_impulse::MICRO,
    &lcp::newton::NEWTON_FB,
    &lcp::newton::NEWTON_MIN,
    &lcp::newton::NEWTON_KRYLOV_FB,
    &lcp::newton::NEWTON_KRYLOV_MIN,
    &lcp::apgd::APGD,
    &lcp::nncg::NNCG,
    &lcp::nsgs::NSGS,
    &lcp::enumeration::ENUM,
];

/// The cone solvers of this crate, in report order.
pub static CONE_SOLVERS: &[&SolverEntry] = &[
    &cone::nsgs_cone::NSGS_CONE,
    &cone::newton::NEWTON_AC,
    &cone::newton::NEWTON_FB_CONE,
    &cone::newton::NEWTON_NM_CONE,
    &cone::newton::NEWTON_KRYLOV_AC,
    &cone::newton::NEWTON_KRYLOV_FB_CONE,
    &cone::extragradient::EG_CONE,
    &cone::fixed_point_projection::FPP_CONE,
    &cone::admm::ADMM_CONE,
    &cone::proximal::PROX_CONE,
    &cone::clarabel_socp::CLARABEL_SOCP,
    &cone::sap::SAP,
];

/// The entries registered at run time, in registration order.
static REGISTERED: RwLock<Vec<&'static SolverEntry>> = RwLock::new(Vec::new());

/// An entry [`register`] refuses.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("cannot register solver `{name}`: {reason}")]
pub struct RegistryError {
    /// The entry's name.
    pub name: String,
    /// Why.
    pub reason: String,
}

/// The entries registered at run time, in registration order (every level).
pub fn registered() -> Vec<&'static SolverEntry> {
    // The list only grows, one whole entry at a time: a panic elsewhere while it was locked
    // leaves it valid.
    REGISTERED.read().unwrap_or_else(|e| e.into_inner()).clone()
}

/// The built-in matrix and cone solvers of this crate, then the registered entries of every
/// level (the body-level built-ins are `lcpbench-contact`'s, which lists them all).
pub fn entries() -> Vec<&'static SolverEntry> {
    MATRIX_SOLVERS
        .iter()
        .chain(CONE_SOLVERS)
        .copied()
        .chain(registered())
        .collect()
}

/// The matrix or cone solvers: this crate's built-ins of `level`, then the registered ones of
/// that level (for [`Level::Body`], the registered ones only).
pub fn entries_at(level: Level) -> Vec<&'static SolverEntry> {
    let builtin: &[&SolverEntry] = match level {
        Level::Matrix => MATRIX_SOLVERS,
        Level::Cone => CONE_SOLVERS,
        Level::Body => &[],
    };
    builtin
        .iter()
        .copied()
        .chain(registered().into_iter().filter(|e| e.level() == level))
        .collect()
}

/// Add a matrix or cone solver to the registry for the rest of the process, after the checks
/// of [`SolverEntry::check`]; a name already taken is refused. A body-level entry is registered
/// through `lcpbench_contact::registry::register`, which also knows the body-level built-ins.
pub fn register(entry: &'static SolverEntry) -> Result<(), RegistryError> {
    if entry.level() == Level::Body {
        return Err(RegistryError {
            name: entry.name.to_owned(),
            reason: "a body-level solver is registered with \
                     lcpbench_contact::registry::register"
                .into(),
        });
    }
    register_beside(entry, &[])
}

/// [`register`] for any level, refusing also the names of `taken` (the caller's built-ins,
/// which this crate does not list: `lcpbench-contact` passes its body-level solvers).
pub fn register_beside(
    entry: &'static SolverEntry,
    taken: &[&'static SolverEntry],
) -> Result<(), RegistryError> {
    let refuse = |reason: String| RegistryError {
        name: entry.name.to_owned(),
        reason,
    };
    entry.check().map_err(refuse)?;
    let mut list = REGISTERED.write().unwrap_or_else(|e| e.into_inner());
    let clash = MATRIX_SOLVERS
        .iter()
        .chain(CONE_SOLVERS)
        .chain(taken)
        .chain(list.iter())
        .any(|e| e.name == entry.name);
    if clash {
        return Err(refuse("a solver of that name exists".into()));
    }
    list.push(entry);
    Ok(())
}

/// The entry named `name` among this crate's built-ins and the registered entries.
pub fn find(name: &str) -> Option<&'static SolverEntry> {
    entries().into_iter().find(|e| e.name == name)
}

/// A `Copy` handle to a registry entry of one level, for `SolverKind`, `ConeSolverKind` and
/// `lcpbench-contact`'s `BodySolverKind`: equality, hashing and `Debug` by name, and the
/// look-ups every level shares. `$all` is the function listing the level's entries.
#[doc(hidden)]
#[macro_export]
macro_rules! kind_handle {
    ($kind:ident, $level:expr, $all:expr) => {
        impl $kind {
            /// Every solver of this level: the built-ins in report order, then those
            /// registered at run time.
            pub fn all() -> Vec<Self> {
                let all: fn() -> Vec<&'static $crate::registry::SolverEntry> = $all;
                all().into_iter().map(Self).collect()
            }

            /// The handle of `entry`, when it is a solver of this level in the registry.
            pub fn of(entry: &'static $crate::registry::SolverEntry) -> Option<Self> {
                Self::all().into_iter().find(|k| k.0 == entry)
            }

            /// Look a solver of this level up by name.
            pub fn from_name(name: &str) -> Option<Self> {
                Self::all().into_iter().find(|k| k.name() == name)
            }

            /// Its registry entry.
            pub const fn entry(self) -> &'static $crate::registry::SolverEntry {
                self.0
            }

            /// The name used on the command line and in reports.
            pub const fn name(self) -> &'static str {
                self.0.name
            }

            /// What the solver is, in one line.
            pub const fn summary(self) -> &'static str {
                self.0.summary
            }

            /// The problem classes the solver handles, in one line.
            pub const fn problem_classes(self) -> &'static str {
                self.0.problem_classes
            }

            /// True for solvers that iterate from a starting impulse (and so use a warm
            /// start).
            pub const fn is_iterative(self) -> bool {
                self.0.iterative
            }

            /// The relaxed or soft problem the solver solves in place of the one it is given,
            /// when it does; `None` for the solvers of the problem as posed.
            pub const fn relaxation(self) -> Option<&'static str> {
                self.0.relaxation
            }

            /// The parameters it takes (`name@key=value,…`), with defaults and ranges.
            pub const fn param_specs(self) -> &'static [$crate::registry::ParamSpec] {
                self.0.params
            }

            /// The names of every solver of this level, comma-separated.
            pub fn names() -> String {
                Self::all()
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        }

        impl PartialEq for $kind {
            fn eq(&self, other: &Self) -> bool {
                self.0.name == other.0.name
            }
        }

        impl Eq for $kind {}

        impl std::hash::Hash for $kind {
            fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
                self.0.name.hash(state);
            }
        }

        impl std::fmt::Debug for $kind {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{}({})", stringify!($kind), self.0.name)
            }
        }

        impl std::fmt::Display for $kind {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.0.name)
            }
        }

        impl std::str::FromStr for $kind {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                Self::from_name(s).ok_or_else(|| {
                    format!(
                        "unknown {} `{s}` (known: {})",
                        $level.plural().trim_end_matches('s'),
                        Self::names()
                    )
                })
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ConeSolverKind, SolverKind};
    use std::collections::HashSet;

    #[test]
    fn builtin_entries_are_valid_unique_and_of_their_lists_level() {
        let mut names = HashSet::new();
        for e in MATRIX_SOLVERS.iter().chain(CONE_SOLVERS) {
            e.check().unwrap_or_else(|m| panic!("{m}"));
            assert!(names.insert(e.name), "{} twice", e.name);
            assert!(
                !e.summary.is_empty() && !e.problem_classes.is_empty(),
                "{}",
                e.name
            );
            assert!(!e.iteration_unit.is_empty(), "{}", e.name);
        }
        assert!(MATRIX_SOLVERS.iter().all(|e| e.level() == Level::Matrix));
        assert!(CONE_SOLVERS.iter().all(|e| e.level() == Level::Cone));
    }

    /// Each entry's constructor makes a solver that names itself by the entry, with the
    /// defaults and with every parameter at either end of its range.
    #[test]
    fn constructors_make_the_solver_their_entry_names() {
        for e in MATRIX_SOLVERS {
            assert_eq!(e.create(&e.defaults()).unwrap().name(), e.name);
            assert!(e.create_cone(&e.defaults()).is_none());
            assert_eq!(SolverKind::from_name(e.name).unwrap().entry(), *e);
        }
        for e in CONE_SOLVERS {
            assert_eq!(e.create_cone(&e.defaults()).unwrap().name(), e.name);
            assert!(e.create(&e.defaults()).is_none());
            assert_eq!(ConeSolverKind::from_name(e.name).unwrap().entry(), *e);
        }
    }

    #[test]
    fn sor_takes_omega_in_the_open_interval_and_names_the_key_and_range() {
        let sor = SolverKind::Sor.entry();
        assert_eq!(sor.parse_params("omega=1.7").unwrap().get("omega"), 1.7);
        assert_eq!(sor.parse_params("1.7").unwrap().get("omega"), 1.7);
        assert_eq!(sor.parse_params("").unwrap().get("omega"), 1.3);
        let e = sor.parse_params("omega=2.5").unwrap_err();
        assert!(
            e.contains("omega must be in (0, 2)") && e.contains("sor"),
            "{e}"
        );
        let e = sor.parse_params("alpha=1").unwrap_err();
        assert!(
            e.contains("unknown parameter `alpha`") && e.contains("keys: omega"),
            "{e}"
        );
        let e = SolverKind::Pgs
            .entry()
            .parse_params("omega=1.2")
            .unwrap_err();
        assert!(e.contains("takes no parameters"), "{e}");
        assert!(SolverKind::Sor.entry().works_on_factors());
        assert!(!SolverKind::Lemke.entry().works_on_factors());
    }

    #[test]
    fn bad_entries_are_refused_with_the_reason() {
        const BASE: SolverEntry = SolverEntry {
            name: "my solver",
            summary: "",
            problem_classes: "",
            iteration_unit: "",
            iterative: false,
            relaxation: None,
            params: &[],
            make: Make::Matrix(|_| Box::new(crate::Lemke::default())),
        };
        static SPACE: SolverEntry = BASE;
        static OUTSIDE: SolverEntry = SolverEntry {
            name: "bad-default",
            params: &[ParamSpec::real("k", 5.0, 0.0, 1.0, "a gain")],
            ..BASE
        };
        static TAKEN: SolverEntry = SolverEntry {
            name: "pgs",
            ..BASE
        };
        static RESERVED: SolverEntry = SolverEntry {
            name: "fault-x",
            ..BASE
        };
        assert!(register(&SPACE).unwrap_err().reason.contains("only ASCII"));
        let e = register(&OUTSIDE).unwrap_err();
        assert!(
            e.reason.contains("default 5") && e.reason.contains("[0, 1]"),
            "{e}"
        );
        assert!(register(&TAKEN).unwrap_err().reason.contains("exists"));
        assert!(register(&RESERVED).unwrap_err().reason.contains("reserved"));
        assert!(find("my solver").is_none() && find("bad-default").is_none());
    }
}
