//! Cases: what a run solves. A case is either one LCP (a generated family instance or a problem
//! file, for example one exported from a scene) or a scene run through the stepping loop.
//!
//! Every case has a stable text *key* that names it in CSV rows, on the command line of the
//! isolated child process, and on resume:
//!
//! | key                                   | case                                                   |
//! |---------------------------------------|--------------------------------------------------------|
//! | `spd:n=100:cond=1e4:seed=1`           | SPD, condition number `cond` (planted solution)        |
//! | `psd:n=100:rank=50:seed=1`            | PSD of rank `rank` (redundant contacts)                |
//! | `pmatrix:n=100:seed=1`                | non-symmetric P-matrix                                 |
//! | `murty:n=12`                          | Murty's exponential example for Lemke                  |
//! | `dup:n=100:seed=1`                    | degenerate: every row duplicated (identical contacts)  |
//! | `weak:n=100:seed=1`                   | degenerate: a third of the rows have `f_i = w_i = 0`   |
//! | `zerob:n=100:seed=1`                  | degenerate: PSD `A`, `b = 0`                           |
//! | `infeasible:n=50:seed=1`              | PSD with no solution                                   |
//! | `file:PATH`                           | a problem file: JSON (e.g. from `lcpbench export`), Siconos `.dat`, FCLIB `.hdf5` |
//! | `scene:PATH`                          | a scene file, stepped with the chosen solver           |
//! | `scene:PATH?steps=N`                  | the same, at most `N` steps                            |
//! | `scene:PATH?friction=MODEL`           | the scene with its friction model replaced (`none`, `box`, `pyramid`, `pyramid-K`, `cone`) |
//! | `scene:PATH?steps=N&friction=MODEL`   | both                                                   |
//! | `scene:PATH?residual=SCHEDULE`        | the scene with the shared residual measured on `every`, `none` or `sample=K` steps (body-level and substepping solvers; see `lcpbench_contact::step::ResidualSchedule`) |

use crate::harness::text::serde_as_text;
use lcpbench_contact::step::ResidualSchedule;
use lcpbench_contact::FrictionModel;
use lcpbench_solvers::generate::{self, generate, Family, Generated, MAX_CONDITION};
use lcpbench_solvers::{read_problem, Problem};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Instant;
use thiserror::Error;

/// Largest size `n` of a generated case (and of `lcpbench gen --n`): its dense `n × n` matrix
/// takes 0.8 GB, and generation is O(n³) work.
pub const MAX_GENERATED_N: usize = 10_000;

/// A malformed case key.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("case `{key}`: {message}")]
pub struct CaseError {
    /// The key as given.
    pub key: String,
    /// What is wrong.
    pub message: String,
}

/// A class or family name that names none of them.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("unknown {what} `{name}`: expected one of {expected}")]
pub struct UnknownName {
    /// What was being named (`problem class`, `case family`).
    pub what: &'static str,
    /// The name as given.
    pub name: String,
    /// The names known.
    pub expected: String,
}

/// The problem class a case belongs to, as used by the robustness matrix.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ProblemClass {
    /// Symmetric positive definite `A` (also the value of a
    /// [`RunRecord`](crate::harness::RunRecord) not yet filled).
    #[default]
    Spd,
    /// Symmetric positive semidefinite, rank-deficient `A`.
    RankDeficient,
    /// Non-symmetric `A` (P-matrix).
    NonSymmetric,
    /// Degenerate: duplicated rows, weakly complementary solutions, `b = 0`.
    Degenerate,
    /// No solution exists.
    Infeasible,
    /// A boxed LCP with friction rows (exported from a scene).
    Friction,
    /// A scene (stepping loop).
    Scene,
}

impl ProblemClass {
    /// Classes of the robustness matrix, in report order.
    pub const MATRIX: [ProblemClass; 6] = [
        ProblemClass::Spd,
        ProblemClass::RankDeficient,
        ProblemClass::NonSymmetric,
        ProblemClass::Degenerate,
        ProblemClass::Infeasible,
        ProblemClass::Friction,
    ];

    /// Short name used in CSV files.
    pub fn name(self) -> &'static str {
        match self {
            ProblemClass::Spd => "spd",
            ProblemClass::RankDeficient => "rank_deficient",
            ProblemClass::NonSymmetric => "non_symmetric",
            ProblemClass::Degenerate => "degenerate",
            ProblemClass::Infeasible => "infeasible",
            ProblemClass::Friction => "friction",
            ProblemClass::Scene => "scene",
        }
    }

    /// Every class: those of the robustness matrix, then scenes.
    pub const ALL: [ProblemClass; 7] = [
        ProblemClass::Spd,
        ProblemClass::RankDeficient,
        ProblemClass::NonSymmetric,
        ProblemClass::Degenerate,
        ProblemClass::Infeasible,
        ProblemClass::Friction,
        ProblemClass::Scene,
    ];

    /// Inverse of [`ProblemClass::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }
}

impl fmt::Display for ProblemClass {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.pad(self.name())
    }
}

impl std::str::FromStr for ProblemClass {
    type Err = UnknownName;

    fn from_str(name: &str) -> Result<Self, UnknownName> {
        Self::from_name(name).ok_or_else(|| UnknownName {
            what: "problem class",
            name: name.to_owned(),
            expected: names(Self::ALL.map(Self::name)),
        })
    }
}

serde_as_text!(ProblemClass);

/// The family a case belongs to, named by the first part of its key (`spd`, `psd`, `pmatrix`,
/// `murty`, `dup`, `weak`, `zerob`, `infeasible`, `file`, `step`, `scene`): the `family` column.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CaseFamily {
    /// Generated SPD (also the value of a [`RunRecord`](crate::harness::RunRecord) not yet
    /// filled).
    #[default]
    Spd,
    /// Generated PSD of a given rank.
    Psd,
    /// Generated non-symmetric P-matrix.
    PMatrix,
    /// Murty's example.
    Murty,
    /// Every row duplicated.
    Duplicated,
    /// Weakly complementary rows.
    Weak,
    /// PSD with `b = 0`.
    ZeroB,
    /// No solution.
    Infeasible,
    /// A problem file.
    File,
    /// One step's problem of a scene.
    SceneStep,
    /// A scene.
    Scene,
}

impl CaseFamily {
    /// Every family, in the order of the case keys' table.
    pub const ALL: [CaseFamily; 11] = [
        CaseFamily::Spd,
        CaseFamily::Psd,
        CaseFamily::PMatrix,
        CaseFamily::Murty,
        CaseFamily::Duplicated,
        CaseFamily::Weak,
        CaseFamily::ZeroB,
        CaseFamily::Infeasible,
        CaseFamily::File,
        CaseFamily::SceneStep,
        CaseFamily::Scene,
    ];

    /// The key prefix, as written in the `family` column.
    pub fn name(self) -> &'static str {
        match self {
            CaseFamily::Spd => "spd",
            CaseFamily::Psd => "psd",
            CaseFamily::PMatrix => "pmatrix",
            CaseFamily::Murty => "murty",
            CaseFamily::Duplicated => "dup",
            CaseFamily::Weak => "weak",
            CaseFamily::ZeroB => "zerob",
            CaseFamily::Infeasible => "infeasible",
            CaseFamily::File => "file",
            CaseFamily::SceneStep => "step",
            CaseFamily::Scene => "scene",
        }
    }
}

impl fmt::Display for CaseFamily {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.pad(self.name())
    }
}

impl std::str::FromStr for CaseFamily {
    type Err = UnknownName;

    fn from_str(name: &str) -> Result<Self, UnknownName> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| UnknownName {
                what: "case family",
                name: name.to_owned(),
                expected: names(Self::ALL.map(Self::name)),
            })
    }
}

serde_as_text!(CaseFamily);

/// `a, b, c` from a list of names.
fn names<const N: usize>(list: [&str; N]) -> String {
    list.join(", ")
}

/// A generated LCP family, including the degenerate families the harness adds to the solver
/// core's generators.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GenFamily {
    /// SPD with condition number `cond`.
    Spd {
        /// Condition number.
        cond: f64,
    },
    /// PSD of the given rank.
    Psd {
        /// Rank of `A`.
        rank: usize,
    },
    /// Non-symmetric P-matrix.
    PMatrix,
    /// Murty's example.
    Murty,
    /// Every row and column of an SPD matrix duplicated (identical redundant contacts).
    Duplicated,
    /// SPD with a planted solution where a third of the rows have `f_i = w_i = 0`.
    Weak,
    /// PSD `A` of half rank and `b = 0`.
    ZeroB,
    /// No solution.
    Infeasible,
}

impl GenFamily {
    /// The rank of a PSD case that names none: `max(n / 2, 1)`.
    pub fn default_rank(n: usize) -> usize {
        (n / 2).max(1)
    }

    /// PSD of the default rank.
    pub fn psd_default(n: usize) -> Self {
        GenFamily::Psd {
            rank: Self::default_rank(n),
        }
    }
}

/// What a run solves.
#[derive(Debug, Clone, PartialEq)]
pub enum Case {
    /// A generated instance.
    Generated {
        /// The family.
        family: GenFamily,
        /// Rows.
        n: usize,
        /// Seed.
        seed: u64,
    },
    /// A problem file.
    File(PathBuf),
    /// The box-friction LCP the stepper assembles at one step of a scene (the earlier steps
    /// simulated with the scene's own solver and settings), built in the run that solves it:
    /// the problems of large scenes, too big to keep as files. Cone solvers take its cone form.
    SceneStep {
        /// The scene file.
        path: PathBuf,
        /// The step (0-based).
        step: usize,
    },
    /// A scene file.
    Scene {
        /// The scene file.
        path: PathBuf,
        /// Cap on the steps taken (the scene's own step count when `None`).
        steps: Option<usize>,
        /// Friction model replacing the scene's (the scene's own when `None`).
        friction: Option<FrictionModel>,
        /// Which steps have the shared residual measured, replacing the scene's `residual`
        /// (the scene's own when `None`).
        residual: Option<ResidualSchedule>,
    },
}

/// A loaded LCP case: the problem and, when known, a solution.
#[derive(Debug, Clone)]
pub struct LoadedLcp {
    /// The problem.
    pub problem: Problem,
    /// A known solution (planted), if any.
    pub solution: Option<Vec<f64>>,
}

fn fmt_num(v: f64) -> String {
    if v >= 1.0 && v.log10().fract() == 0.0 {
        format!("1e{}", v.log10() as i32)
    } else {
        format!("{v}")
    }
}

impl fmt::Display for Case {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Case::Generated { family, n, seed } => match family {
                GenFamily::Spd { cond } => {
                    write!(out, "spd:n={n}:cond={}:seed={seed}", fmt_num(*cond))
                }
                GenFamily::Psd { rank } => write!(out, "psd:n={n}:rank={rank}:seed={seed}"),
                GenFamily::PMatrix => write!(out, "pmatrix:n={n}:seed={seed}"),
                GenFamily::Murty => write!(out, "murty:n={n}"),
                GenFamily::Duplicated => write!(out, "dup:n={n}:seed={seed}"),
                GenFamily::Weak => write!(out, "weak:n={n}:seed={seed}"),
                GenFamily::ZeroB => write!(out, "zerob:n={n}:seed={seed}"),
                GenFamily::Infeasible => write!(out, "infeasible:n={n}:seed={seed}"),
            },
            Case::File(p) => write!(out, "file:{}", p.display()),
            Case::SceneStep { path, step } => write!(out, "step:{}?step={step}", path.display()),
            Case::Scene {
                path,
                steps,
                friction,
                residual,
            } => {
                write!(out, "scene:{}", path.display())?;
                let mut query = Vec::new();
                if let Some(n) = steps {
                    query.push(format!("steps={n}"));
                }
                if let Some(m) = friction {
                    query.push(format!("friction={}", m.name()));
                }
                if let Some(r) = residual {
                    query.push(format!("residual={r}"));
                }
                if !query.is_empty() {
                    write!(out, "?{}", query.join("&"))?;
                }
                Ok(())
            }
        }
    }
}

impl std::str::FromStr for Case {
    type Err = CaseError;

    fn from_str(key: &str) -> Result<Self, CaseError> {
        let err = |message: String| CaseError {
            key: key.to_owned(),
            message,
        };
        if let Some(path) = key.strip_prefix("file:") {
            return Ok(Case::File(PathBuf::from(path)));
        }
        if let Some(rest) = key.strip_prefix("scene:") {
            return parse_scene_key(rest).map_err(err);
        }
        if let Some(rest) = key.strip_prefix("step:") {
            return parse_step_key(rest).map_err(err);
        }
        parse_generated_key(key).map_err(err)
    }
}

/// `PATH[?steps=N][&friction=MODEL][&residual=SCHEDULE]` of a `scene:` key.
fn parse_scene_key(rest: &str) -> Result<Case, String> {
    let (path, query) = match rest.rsplit_once('?') {
        Some((p, q))
            if ["steps=", "friction=", "residual="]
                .iter()
                .any(|k| q.starts_with(k)) =>
        {
            (p, q)
        }
        _ => (rest, ""),
    };
    let (mut steps, mut friction, mut residual) = (None, None, None);
    for part in query.split('&').filter(|p| !p.is_empty()) {
        match part.split_once('=') {
            Some(("steps", n)) => {
                steps = Some(
                    n.parse::<usize>()
                        .ok()
                        .filter(|&s| s >= 1)
                        .ok_or_else(|| format!("`{n}` is not a step count (>= 1)"))?,
                )
            }
            Some(("friction", m)) => {
                friction = Some(FrictionModel::from_name(m).ok_or_else(|| {
                    format!(
                        "unknown friction model `{m}` (known: {})",
                        FrictionModel::NAMES
                    )
                })?)
            }
            Some(("residual", r)) => residual = Some(r.parse::<ResidualSchedule>()?),
            _ => {
                return Err(format!(
                    "`{part}` is not steps=N, friction=MODEL or residual=SCHEDULE"
                ))
            }
        }
    }
    Ok(Case::Scene {
        path: PathBuf::from(path),
        steps,
        friction,
        residual,
    })
}

/// `PATH?step=K` of a `step:` key.
fn parse_step_key(rest: &str) -> Result<Case, String> {
    let (path, step) = rest
        .rsplit_once("?step=")
        .ok_or_else(|| format!("`{rest}` is not PATH?step=K"))?;
    let step = step
        .parse::<usize>()
        .map_err(|_| format!("`{step}` is not a step index (0-based)"))?;
    Ok(Case::SceneStep {
        path: PathBuf::from(path),
        step,
    })
}

/// `KIND:n=N[:seed=S][:cond=C][:rank=R]` of a generated case.
fn parse_generated_key(key: &str) -> Result<Case, String> {
    let mut parts = key.split(':');
    let kind = parts.next().unwrap_or_default();
    let (mut n, mut seed, mut cond, mut rank) = (None, 0u64, None, None);
    for part in parts {
        let (k, v) = part
            .split_once('=')
            .ok_or_else(|| format!("`{part}` is not key=value"))?;
        let bad = |_| format!("`{v}` is not a valid value for `{k}`");
        match k {
            "n" => n = Some(v.parse::<usize>().map_err(|e| bad(e.to_string()))?),
            "seed" => {
                seed = v
                    .parse()
                    .map_err(|e: std::num::ParseIntError| bad(e.to_string()))?
            }
            "cond" => cond = Some(v.parse::<f64>().map_err(|e| bad(e.to_string()))?),
            "rank" => rank = Some(v.parse::<usize>().map_err(|e| bad(e.to_string()))?),
            _ => return Err(format!("unknown parameter `{k}`")),
        }
    }
    let n = n.ok_or_else(|| "missing `n=`".to_owned())?;
    if n == 0 || n > MAX_GENERATED_N {
        return Err(format!(
            "n must be between 1 and {MAX_GENERATED_N}, got {n}"
        ));
    }
    let family = generated_family(kind, n, cond, rank)?;
    Ok(Case::Generated { family, n, seed })
}

/// The generated family called `kind`, with its parameters checked against `n`.
fn generated_family(
    kind: &str,
    n: usize,
    cond: Option<f64>,
    rank: Option<usize>,
) -> Result<GenFamily, String> {
    Ok(match kind {
        "spd" => {
            let cond = cond.unwrap_or(1e3);
            if !(cond.is_finite() && (1.0..=MAX_CONDITION).contains(&cond)) {
                return Err(format!(
                    "cond = {} must be between 1 and {MAX_CONDITION:e}",
                    lcpbench_contact::scene::readable(cond)
                ));
            }
            GenFamily::Spd { cond }
        }
        "psd" => {
            let rank = rank.unwrap_or(GenFamily::default_rank(n));
            if rank == 0 || rank > n {
                return Err(format!("rank = {rank} must be in 1..={n}"));
            }
            GenFamily::Psd { rank }
        }
        "pmatrix" => GenFamily::PMatrix,
        "murty" => GenFamily::Murty,
        "dup" => GenFamily::Duplicated,
        "weak" => GenFamily::Weak,
        "zerob" => GenFamily::ZeroB,
        "infeasible" => GenFamily::Infeasible,
        _ => {
            return Err(format!(
                "unknown kind `{kind}` (known: spd, psd, pmatrix, murty, dup, weak, zerob, \
                 infeasible, file:PATH, step:PATH?step=K, scene:PATH)"
            ))
        }
    })
}

impl Case {
    /// The class used by the robustness matrix. For a problem file it is decided from the data
    /// (friction rows, symmetry), which needs the file; [`Case::class_of_problem`] does that.
    pub fn class(&self) -> ProblemClass {
        match self {
            Case::Generated { family, .. } => match family {
                GenFamily::Spd { .. } => ProblemClass::Spd,
                GenFamily::Psd { .. } => ProblemClass::RankDeficient,
                GenFamily::PMatrix | GenFamily::Murty => ProblemClass::NonSymmetric,
                GenFamily::Duplicated | GenFamily::Weak | GenFamily::ZeroB => {
                    ProblemClass::Degenerate
                }
                GenFamily::Infeasible => ProblemClass::Infeasible,
            },
            Case::File(_) | Case::SceneStep { .. } => ProblemClass::Friction,
            Case::Scene { .. } => ProblemClass::Scene,
        }
    }

    /// Class of a problem read from a file: friction rows or bounds make it a friction problem,
    /// otherwise symmetric problems count as rank-deficient (contact Delassus matrices usually
    /// are) and the rest as non-symmetric.
    pub fn class_of_problem(problem: &Problem) -> ProblemClass {
        if !problem.is_standard() {
            ProblemClass::Friction
        } else if problem.is_symmetric(1e-10) {
            ProblemClass::RankDeficient
        } else {
            ProblemClass::NonSymmetric
        }
    }

    /// The family the case belongs to (the first part of its key).
    pub fn family(&self) -> CaseFamily {
        match self {
            Case::Generated { family, .. } => match family {
                GenFamily::Spd { .. } => CaseFamily::Spd,
                GenFamily::Psd { .. } => CaseFamily::Psd,
                GenFamily::PMatrix => CaseFamily::PMatrix,
                GenFamily::Murty => CaseFamily::Murty,
                GenFamily::Duplicated => CaseFamily::Duplicated,
                GenFamily::Weak => CaseFamily::Weak,
                GenFamily::ZeroB => CaseFamily::ZeroB,
                GenFamily::Infeasible => CaseFamily::Infeasible,
            },
            Case::File(_) => CaseFamily::File,
            Case::SceneStep { .. } => CaseFamily::SceneStep,
            Case::Scene { .. } => CaseFamily::Scene,
        }
    }

    /// Size: rows for generated problems, `None` for files and scenes until loaded.
    pub fn size(&self) -> Option<usize> {
        match self {
            Case::Generated { n, .. } => Some(*n),
            _ => None,
        }
    }

    /// True for a scene case.
    pub fn is_scene(&self) -> bool {
        matches!(self, Case::Scene { .. })
    }

    /// For a scene case, the steps a run takes: the cap, or the scene's own count when that is
    /// smaller or there is no cap (the cap alone when the scene does not load; a run of it then
    /// records the error). `None` for LCP cases.
    pub fn planned_steps(&self) -> Option<usize> {
        let Case::Scene { path, steps, .. } = self else {
            return None;
        };
        let own = lcpbench_contact::scene::Scene::load(path)
            .ok()
            .map(|s| s.settings.steps);
        Some(match (steps, own) {
            (Some(cap), Some(own)) => (*cap).min(own),
            (Some(cap), None) => *cap,
            (None, Some(own)) => own,
            (None, None) => 1,
        })
    }

    /// A generated case.
    pub fn generated(family: GenFamily, n: usize, seed: u64) -> Self {
        Case::Generated { family, n, seed }
    }

    /// A generated SPD case with condition number `cond`.
    pub fn spd(n: usize, cond: f64, seed: u64) -> Self {
        Self::generated(GenFamily::Spd { cond }, n, seed)
    }

    /// A generated PSD case of the default rank `max(n / 2, 1)`.
    pub fn psd(n: usize, seed: u64) -> Self {
        Self::generated(GenFamily::psd_default(n), n, seed)
    }

    /// A scene case with the scene's own friction model.
    pub fn scene(path: impl Into<PathBuf>, steps: Option<usize>) -> Self {
        Case::Scene {
            path: path.into(),
            steps,
            friction: None,
            residual: None,
        }
    }

    /// A scene case with its friction model replaced by `friction`.
    pub fn scene_with_friction(
        path: impl Into<PathBuf>,
        steps: Option<usize>,
        friction: FrictionModel,
    ) -> Self {
        Case::Scene {
            path: path.into(),
            steps,
            friction: Some(friction),
            residual: None,
        }
    }

    /// This scene case with the shared residual measured on the steps of `schedule` (other
    /// cases unchanged).
    pub fn with_residual(self, schedule: ResidualSchedule) -> Self {
        match self {
            Case::Scene {
                path,
                steps,
                friction,
                ..
            } => Case::Scene {
                path,
                steps,
                friction,
                residual: Some(schedule),
            },
            other => other,
        }
    }

    /// Short display name: the file stem for scenes and files (`STEM stepK` for a scene's
    /// step), the key otherwise.
    pub fn short_name(&self) -> String {
        match self {
            Case::SceneStep { path, step } => format!(
                "{} step{step}",
                path.file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| path.display().to_string())
            ),
            Case::Scene { path, .. } | Case::File(path) => path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| self.to_string()),
            _ => self.to_string(),
        }
    }

    /// Build (or read) the LCP of a non-scene case.
    pub fn load_lcp(&self) -> Result<LoadedLcp, String> {
        self.load_lcp_within(None)
    }

    /// [`Case::load_lcp`] within a deadline: a scene step case simulates the steps before its
    /// step only while the deadline has not passed ([`step_problem_within`]), and says how far
    /// it got when it has.
    ///
    /// [`step_problem_within`]: crate::harness::export::step_problem_within
    pub fn load_lcp_within(&self, deadline: Option<Instant>) -> Result<LoadedLcp, String> {
        match self {
            Case::Generated { family, n, seed } => Ok(generate_case(*family, *n, *seed)),
            Case::File(path) => read_problem(path)
                .map(|problem| LoadedLcp {
                    problem,
                    solution: None,
                })
                .map_err(|e| e.to_string()),
            Case::SceneStep { path, step } => scene_step_lcp(path, *step, deadline),
            Case::Scene { path, .. } => Err(format!("{} is a scene, not an LCP", path.display())),
        }
    }
}

/// The warm start a problem file carries: the `warm_start` array of a JSON file (one value per
/// row, as `lcpbench export` writes it for a warm-started step). `Ok(None)` when the file is
/// not JSON or has no such key; an error naming the file and the field when the key holds
/// anything but finite numbers. The file is read within the problem files' size limit; the
/// caller checks the length against the problem's rows.
pub fn file_warm_start(path: &Path) -> Result<Option<Vec<f64>>, String> {
    use lcpbench_solvers::io::{input::read_input_file, MAX_PROBLEM_FILE_BYTES};
    use lcpbench_solvers::ProblemFormat;
    let bytes = read_input_file(path, MAX_PROBLEM_FILE_BYTES)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let head = &bytes[..bytes.len().min(64)];
    if ProblemFormat::detect(path, head) != ProblemFormat::Json {
        return Ok(None);
    }
    json_warm_start(&bytes, path)
}

/// The `warm_start` array of the JSON text `bytes` read from `path` (see [`file_warm_start`]);
/// the other keys are skipped without being kept.
pub fn json_warm_start(bytes: &[u8], path: &Path) -> Result<Option<Vec<f64>>, String> {
    #[derive(serde::Deserialize)]
    struct WarmStartKey {
        #[serde(default)]
        warm_start: Option<Vec<f64>>,
    }
    let parsed: WarmStartKey = serde_json::from_slice(bytes)
        .map_err(|e| format!("{}: field `warm_start`: {e}", path.display()))?;
    if let Some(values) = &parsed.warm_start {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "{}: field `warm_start`: entry {i} is not a finite number",
                path.display()
            ));
        }
    }
    Ok(parsed.warm_start)
}

/// The LCP of step `step` of the scene at `path` (see [`Case::SceneStep`]).
fn scene_step_lcp(
    path: &std::path::Path,
    step: usize,
    deadline: Option<Instant>,
) -> Result<LoadedLcp, String> {
    use crate::harness::export::{step_problem_within, StepProblem};
    let scene = lcpbench_contact::scene::Scene::load(path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let mut world = scene.world();
    match step_problem_within(&mut world, &scene.name, step, deadline, || {}).0 {
        StepProblem::Lcp { problem, .. } => Ok(LoadedLcp {
            problem,
            solution: None,
        }),
        StepProblem::Cone { .. } => Err(format!(
            "{} step {step}: the scene's friction model is the cone; a scene step case is its \
             box-friction LCP",
            path.display()
        )),
        StepProblem::NoContacts => Err(format!(
            "{} step {step} has no contacts, so no problem",
            path.display()
        )),
        StepProblem::Refused(reason) => Err(format!(
            "{} step {step} was not solved: {reason}",
            path.display()
        )),
    }
}

fn from_generated(g: Generated) -> LoadedLcp {
    LoadedLcp {
        problem: g.problem,
        solution: g.solution,
    }
}

/// Generate the instance of a family.
pub fn generate_case(family: GenFamily, n: usize, seed: u64) -> LoadedLcp {
    match family {
        GenFamily::Spd { cond } => from_generated(generate(Family::Spd { cond }, n, seed)),
        GenFamily::Psd { rank } => {
            from_generated(generate(Family::PsdRankDeficient { rank }, n, seed))
        }
        GenFamily::PMatrix => from_generated(generate(Family::PMatrix, n, seed)),
        GenFamily::Murty => from_generated(generate(Family::Murty, n, seed)),
        GenFamily::Infeasible => from_generated(generate(Family::Infeasible, n, seed)),
        GenFamily::Duplicated => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xD0B1);
            let m = n.div_ceil(2);
            let base = generate::spd_matrix(m, 1e2, &mut rng);
            let a = faer::Mat::from_fn(n, n, |i, j| base[(i % m, j % m)]);
            let (f, b) = generate::plant(&a, &mut rng);
            let problem = Problem::lcp(a, b)
                .expect("finite")
                .with_name(format!("dup n={n}"));
            LoadedLcp {
                problem,
                solution: Some(f),
            }
        }
        GenFamily::Weak => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x3EA);
            let a = generate::spd_matrix(n, 1e2, &mut rng);
            let mut f = vec![0.0; n];
            let mut w = vec![0.0; n];
            for i in 0..n {
                match rng.random_range(0..3) {
                    0 => f[i] = rng.random_range(0.5..1.5),
                    1 => w[i] = rng.random_range(0.5..1.5),
                    _ => {} // degenerate: f_i = w_i = 0
                }
            }
            let b = (0..n)
                .map(|i| w[i] - (0..n).map(|j| a[(i, j)] * f[j]).sum::<f64>())
                .collect();
            let problem = Problem::lcp(a, b)
                .expect("finite")
                .with_name(format!("weak n={n}"));
            LoadedLcp {
                problem,
                solution: Some(f),
            }
        }
        GenFamily::ZeroB => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x2E0);
            let a = generate::psd_matrix(n, (n / 2).max(1), &mut rng);
            let problem = Problem::lcp(a, vec![0.0; n])
                .expect("finite")
                .with_name(format!("zerob n={n}"));
            LoadedLcp {
                problem,
                solution: Some(vec![0.0; n]),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lcpbench_solvers::residuals;

    #[test]
    fn keys_round_trip() {
        for key in [
            "spd:n=100:cond=1e4:seed=1",
            "spd:n=10:cond=3.5:seed=0",
            "psd:n=20:rank=5:seed=2",
            "pmatrix:n=7:seed=3",
            "murty:n=12",
            "dup:n=9:seed=1",
            "weak:n=9:seed=1",
            "zerob:n=9:seed=1",
            "infeasible:n=9:seed=1",
            "file:reports/lcps/tower.json",
            "step:bench_scenes/tower_10.toml?step=3",
            "scene:bench_scenes/tower_10.toml",
            "scene:bench_scenes/tower_10.toml?steps=50",
            "scene:bench_scenes/tower_10.toml?friction=cone",
            "scene:bench_scenes/tower_10.toml?steps=50&friction=pyramid-8",
        ] {
            let case: Case = key.parse().unwrap();
            assert_eq!(case.to_string(), key);
            // The family column is the key's first part, and reads back as the same family.
            let family = case.family();
            assert_eq!(family.to_string(), key.split(':').next().unwrap());
            assert_eq!(family.to_string().parse::<CaseFamily>(), Ok(family));
            let class = case.class();
            assert_eq!(class.to_string().parse::<ProblemClass>(), Ok(class));
        }
        assert!("Spd".parse::<CaseFamily>().is_err());
        assert!("rank-deficient".parse::<ProblemClass>().is_err());
        assert!("spd:n=0".parse::<Case>().is_err());
        assert!("spd:n=100000000".parse::<Case>().is_err());
        assert!("scene:a.toml?steps=0".parse::<Case>().is_err());
        assert!("scene:a.toml?friction=ellipse".parse::<Case>().is_err());
        assert!("scene:a.toml?steps=5&colour=red".parse::<Case>().is_err());
        assert!("spd:cond=1e3".parse::<Case>().is_err());
        assert!("cube:n=3".parse::<Case>().is_err());
        assert!("step:a.toml".parse::<Case>().is_err());
        assert!("step:a.toml?step=-1".parse::<Case>().is_err());
    }

    #[test]
    fn a_scene_step_case_is_the_lcp_the_stepper_assembles_at_that_step() {
        use crate::harness::export::{step_problem, StepProblem};
        let path = "bench_scenes/tower_5.toml";
        let lcp = format!("step:{path}?step=2")
            .parse::<Case>()
            .unwrap()
            .load_lcp()
            .unwrap();
        let scene = lcpbench_contact::scene::Scene::load(path).unwrap();
        let mut world = scene.world();
        let StepProblem::Lcp { problem, .. } = step_problem(&mut world, &scene.name, 2, || {}).0
        else {
            panic!("tower_5 step 2 has an LCP");
        };
        assert_eq!(lcp.problem.n(), problem.n());
        assert!(lcp.problem.n() >= 3 * 4, "a tower of 5 has contacts");
        assert_eq!(lcp.problem.b(), problem.b());
        let missing = "step:bench_scenes/no_such_scene.toml?step=1".parse::<Case>();
        let err = missing.unwrap().load_lcp().unwrap_err();
        assert!(err.contains("no_such_scene"), "{err}");
    }

    #[test]
    fn planted_degenerate_solutions_solve_their_problems() {
        for key in ["dup:n=11:seed=1", "weak:n=12:seed=2", "zerob:n=8:seed=3"] {
            let case: Case = key.parse().unwrap();
            let lcp = case.load_lcp().unwrap();
            let r = residuals(&lcp.problem, lcp.solution.as_ref().unwrap());
            assert!(r.natural_map_rel < 1e-12, "{key}: {r:?}");
            assert_eq!(case.class(), ProblemClass::Degenerate);
        }
    }
}
