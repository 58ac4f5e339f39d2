//! The default suite behind `lcpbench report`: which cases, solvers and budgets are run.
//!
//! Parts (each tagged so the report knows which rows feed which table):
//!
//! * **matrix**: every generated family at three sizes × every solver × budgets `default` and
//!   `tight`. Feeds the robustness matrix (budget `default`), time-to-accuracy, performance
//!   profiles, fastest-solver and convergence plots (budget `tight`, whose histories reach
//!   `1e-10`).
//! * **scaling**: SPD (`cond = 1e3`) at sizes doubling from 16 × every solver, budget `default`:
//!   time against the number of rows.
//! * **omega**: SOR with `omega` from 0.2 to 1.9 on three problems.
//! * **warm**: the iterative solvers warm and cold on four problems.
//! * **scenes**: every scene file × every matrix and body-level solver, cold, and the iterative
//!   ones warm-started too, × budgets [`SCENE_BUDGETS`] (`realtime`, `loose`, `default`; a
//!   budget's seconds bound each step's solve): small scenes at most [`SCENE_STEPS`] steps
//!   (those of [`SMALL_SCENE_STEP_EXCEPTIONS`] their whole run),
//!   large ones [`large_scene_steps`]; and the LCPs exported from the scenes (`file:` cases) ×
//!   every matrix solver × budgets `default`, `tight`.
//! * **friction models**: [`FRICTION_SCENES`] (those present among the scene files) under the
//!   friction models box, pyramid and cone, each with the solvers of [`FRICTION_MODELS`] warm
//!   started, budget [`FRICTION_BUDGET`], at most [`FRICTION_STEPS`] steps.
//! * **towers**: the 60 Hz towers of [`TOWER_SCENES`], whole runs, with the warm-started
//!   iterative solvers under [`TOWER_BUDGETS`] (20 and 50 iterations per step).
//! * **scene scaling**: the scenes of `scaling/` next to the scene files (a brick-wall family
//!   from about 100 to 5,000 contacts; the pyramids of the engine scaling family left out) ×
//!   every matrix and body-level solver, budget `default`, [`SCALING_STEPS`] steps: solver time
//!   per step against contacts.
//! * **engine scaling**: the pyramids `scaling/pyramid_3d_*.toml` (91 to 14,910 boxes) ×
//!   the runs of [`engine_scaling_runs`] (`pgs+warm` at 20 sweeps, `si+warm` at 8, `soft-step`
//!   at its defaults), [`ENGINE_SCALING_STEPS`] steps with the shared residual measured on the
//!   steps of [`ENGINE_SCALING_RESIDUAL`]: time per step against the number of boxes.
//! * **FCLIB**: the FCLIB problems of `fclib/` next to the scene files (frictional-contact
//!   problems from Siconos' test data, read as box-friction LCPs) × every matrix solver, budget
//!   [`FCLIB_BUDGET`]: time to the relative residual 1e-6.
//! * **FC3D collection**: the FCLIB files, the exported scene LCPs and steps 1 and 10 of the
//!   large scenes (`step:` cases, built in the run) in their exact-cone form × every cone
//!   solver, budget [`FC3D_BUDGET`] (the cone solvers' performance profiles at 1e-4 and 1e-8).
//!
//! * **joints**: the scenes of `joints/` next to the scene files (20-link chains with end
//!   masses 1, 1e3 and 1e6 links, a plank bridge, a ragdoll, a pendulum cradle) × every scene
//!   solver, cold and the iterative ones warm-started, × budgets [`SCENE_BUDGETS`], and the
//!   warm-started iterative solvers under [`JOINT_ITERATION_BUDGETS`] (10, 20 and 50
//!   iterations per step): joint drift, sag and cost.
//!
//! * **engine solvers**: the scenes of [`ENGINE_SCENES`] (after Solver2D's set) × every
//!   substepping solver at its defaults and two more costs, and `pgs+warm` and `si+warm` at
//!   iteration caps of about the same cost ([`engine_runs`]): cost, time and error at equal
//!   cost.
//!
//! The quick suite (`report --quick`) has every part, smaller: [`QUICK_SCENES`] for a few steps,
//! the generated families at 8 rows, two members of the scene scaling family, the two smallest
//! pyramids of the engine scaling family and the smallest FCLIB file.

use crate::harness::case::GenFamily;
use crate::harness::impact::{ImpactCase, ImpactMode};
use crate::harness::{BudgetName, Case, Job, NamedBudget, SolverSpec};
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::step::ResidualSchedule;
use lcpbench_contact::substep::{ParamSpec, Params};
use lcpbench_contact::FrictionModel;
use lcpbench_solvers::{ConeSolverKind, SolverKind};
use std::path::{Path, PathBuf};

/// Budgets of the scene runs (the points of the speed–accuracy plots), on every scene, each
/// solver cold and the iterative ones warm-started too. A budget's seconds bound each step's
/// solve. `tight` is not run on scenes: at 10 s per step, the runs of the solvers that cannot
/// keep up would take more than the rest of the report; the LCP sections carry it.
pub const SCENE_BUDGETS: [BudgetName; 3] =
    [BudgetName::Realtime, BudgetName::Loose, BudgetName::Default];

/// The budget of the scene runs at accuracy 1e-6 (tolerance 1e-6, 1000 iterations per step,
/// 1 s per step), which Findings answers at beside `loose` (1e-4) and `default` (1e-8):
/// `realtime`'s 20 iterations answer another question. Run by the iterative scene solvers
/// warm-started only (on the huge scenes, those of [`huge_scene_solvers`]): the cold runs and
/// the pivoting solvers count at 1e-6 through their `default` runs (a step converged at 1e-8
/// met 1e-6; the time is then an upper bound), which keeps the suite's growth to about one run
/// in eight of the scene runs.
pub const SCENE_MID_BUDGET: &str = "1e-6:1000:1";

/// [`SCENE_MID_BUDGET`] with its name.
pub fn scene_mid_budget() -> NamedBudget {
    custom_budget(SCENE_MID_BUDGET)
}

/// Scenes with more dynamic bodies than this are *large*: [`large_scene_steps`] steps, and
/// their own section (speed–accuracy per budget, phase times).
pub const LARGE_SCENE_BODIES: usize = 30;

/// Steps of a large scene's runs: [`LARGE_SCENE_STEPS`] unless [`LARGE_SCENE_STEP_EXCEPTIONS`]
/// names the scene (by file stem).
pub fn large_scene_steps(path: &std::path::Path) -> usize {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    LARGE_SCENE_STEP_EXCEPTIONS
        .iter()
        .find(|(name, _)| stem.as_deref() == Some(*name))
        .map_or(LARGE_SCENE_STEPS, |(_, steps)| *steps)
}

/// Steps of a large scene's runs in the full suite: the stacks and walls rest from the first
/// step, so 20 steps show a solver's steady state.
pub const LARGE_SCENE_STEPS: usize = 20;

/// The large scenes that run a different number of steps: the sphere piles fall for their
/// first 17 steps (no contacts), so 50 steps are 33 with contacts (40 for the 1,000-sphere pile,
/// whose steps cost most); the 1,016-box pyramid, 10; the 5,525-box pyramid (80,900 contacts)
/// and the 5,291-sphere packing (touching from the first step, 29,760 contacts), whose steps
/// take half a second and a fifth of one at 20 warm PGS sweeps, 5; the rush, whose spheres
/// fly for its first 25 steps (no contacts) and meet each other from about step 50, 60.
pub const LARGE_SCENE_STEP_EXCEPTIONS: [(&str, usize); 7] = [
    ("sphere_pile_100", 50),
    ("sphere_pile_200", 50),
    ("sphere_pile_1000", 40),
    ("pyramid_3d_1015", 10),
    ("pyramid_3d_5525", 5),
    ("sphere_pile_5291", 5),
    ("rush", 60),
];

/// Scenes with more dynamic bodies than this are *huge*: they run only
/// [`huge_scene_solvers`].
pub const HUGE_SCENE_BODIES: usize = 2_000;

/// The solvers of the huge scenes, cold (the warm-started forms of the iterative ones join them
/// in the scene jobs): those the registry says work without the assembled Delassus matrix
/// ([`SolverEntry::works_on_factors`](lcpbench_solvers::SolverEntry::works_on_factors): the
/// matrix solvers that sweep on its factors, PGS and SOR, and the body-level solvers), as
/// engines step such scenes, except the substepping solvers, which the engine comparison
/// measures on its own scenes ([`ENGINE_SCENES`]). The others read rows of the assembled `A`
/// (44 million entries on the 5,525-box pyramid) and would spend their runs forming and
/// factoring it.
pub fn huge_scene_solvers() -> Vec<SolverSpec> {
    lcpbench_contact::registry::entries()
        .into_iter()
        .filter(|e| e.works_on_factors())
        .filter(|e| BodySolverKind::of(e).is_none_or(|k| !k.substeps()))
        .map(SolverSpec::of)
        .collect()
}

/// True when the scene has more than [`HUGE_SCENE_BODIES`] dynamic bodies.
pub fn is_huge_scene(path: &std::path::Path) -> bool {
    lcpbench_contact::scene::Scene::load(path)
        .map(|s| s.bodies.iter().filter(|b| !b.is_static).count() > HUGE_SCENE_BODIES)
        .unwrap_or(false)
}

/// True when the scene has more than [`LARGE_SCENE_BODIES`] dynamic bodies (false when it does
/// not load; its runs then record the error).
pub fn is_large_scene(path: &std::path::Path) -> bool {
    lcpbench_contact::scene::Scene::load(path)
        .map(|s| s.bodies.iter().filter(|b| !b.is_static).count() > LARGE_SCENE_BODIES)
        .unwrap_or(false)
}

/// Steps of each scene run in the full suite (the scene's own count when smaller), except the
/// scenes of [`SMALL_SCENE_STEP_EXCEPTIONS`].
pub const SCENE_STEPS: usize = 100;

/// The small scenes that run more steps in the full suite: the sphere stack, whose top sphere
/// lands after 94 steps (150: the landing and the first second after it). The double domino
/// runs the common 100 steps (the first dominoes' fall): its whole 720-step run under every
/// solver and budget would cost the suite over an hour.
pub const SMALL_SCENE_STEP_EXCEPTIONS: [(&str, usize); 1] = [("sphere_stack", 150)];

/// Steps of a small scene's runs in the full suite: [`SCENE_STEPS`] unless
/// [`SMALL_SCENE_STEP_EXCEPTIONS`] names the scene (by file stem).
pub fn small_scene_steps(path: &std::path::Path) -> usize {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    SMALL_SCENE_STEP_EXCEPTIONS
        .iter()
        .find(|(name, _)| stem.as_deref() == Some(*name))
        .map_or(SCENE_STEPS, |(_, steps)| *steps)
}

/// The scenes of the quick suite (file stems): two small analytic scenes, a scene whose steps
/// have no solution, the 60 Hz tower of the tower and friction sections, and a large scene.
pub const QUICK_SCENES: [&str; 5] = [
    "box_on_ground",
    "v_groove",
    "wedged",
    "tower_10_60hz",
    "tower_40",
];

/// The scene files a suite runs: all of `scenes`, or for the quick suite those of
/// [`QUICK_SCENES`] among them.
pub fn suite_scenes(quick: bool, scenes: &[PathBuf]) -> Vec<PathBuf> {
    if !quick {
        return scenes.to_vec();
    }
    scenes
        .iter()
        .filter(|p| {
            p.file_stem()
                .is_some_and(|s| QUICK_SCENES.iter().any(|q| s == *q))
        })
        .cloned()
        .collect()
}

/// The towers of the low-budget comparison (file names in the scene directory), run for their
/// whole length.
pub const TOWER_SCENES: [&str; 2] = ["tower_10_60hz.toml", "tower_40_60hz.toml"];

/// Budgets of the low-budget tower comparison: tolerance 1e-6, 20 and 50 iterations per step,
/// 1 s per step.
pub const TOWER_BUDGETS: [&str; 2] = ["1e-6:20:1", "1e-6:50:1"];

/// Budgets of the joint scenes' low-iteration comparison: tolerance 1e-6, 10, 20 and 50
/// iterations per step, 1 s per step.
pub const JOINT_ITERATION_BUDGETS: [&str; 3] = ["1e-6:10:1", "1e-6:20:1", "1e-6:50:1"];

/// The joint scenes of the quick suite (file stems).
pub const QUICK_JOINT_SCENES: [&str; 1] = ["chain_20_1e3"];

/// The scenes with joints: `joints/*.toml` in the directory of the first scene file.
pub fn joint_scenes(scenes: &[PathBuf]) -> Vec<PathBuf> {
    files_beside(scenes, "joints", "*.toml")
}

/// Steps of each run of the scene scaling family.
pub const SCALING_STEPS: usize = 10;

/// The files matching `pattern` in the folder `sub` of the first scene file's directory.
fn files_beside(scenes: &[PathBuf], sub: &str, pattern: &str) -> Vec<PathBuf> {
    let Some(dir) = scenes.first().and_then(|p| p.parent()) else {
        return Vec::new();
    };
    let pattern = dir.join(sub).join(pattern);
    crate::report::scenes_matching(&pattern.to_string_lossy()).unwrap_or_default()
}

/// The scene scaling family: `scaling/*.toml` in the directory of the first scene file, the
/// engine scaling family's pyramids ([`engine_scaling_scenes`]) left out.
pub fn scaling_scenes(scenes: &[PathBuf]) -> Vec<PathBuf> {
    files_beside(scenes, "scaling", "*.toml")
        .into_iter()
        .filter(|p| pyramid_boxes(p).is_none())
        .collect()
}

/// The engine scaling family: `scaling/pyramid_3d_N.toml` in the directory of the first scene
/// file, by increasing box count `N`.
pub fn engine_scaling_scenes(scenes: &[PathBuf]) -> Vec<PathBuf> {
    let mut family: Vec<PathBuf> = files_beside(scenes, "scaling", "pyramid_3d_*.toml")
        .into_iter()
        .filter(|p| pyramid_boxes(p).is_some())
        .collect();
    family.sort_by_key(|p| pyramid_boxes(p).unwrap_or(usize::MAX));
    family
}

/// The box count `N` of a `pyramid_3d_N` scene (a path or a file stem).
pub fn pyramid_boxes(scene: &Path) -> Option<usize> {
    let stem = scene.file_stem()?.to_str()?;
    stem.strip_prefix("pyramid_3d_")?.parse().ok()
}

/// Steps of each run of the engine scaling family.
pub const ENGINE_SCALING_STEPS: usize = 10;

/// Steps of each run of the engine scaling family in the quick suite.
pub const QUICK_ENGINE_SCALING_STEPS: usize = 5;

/// The residual schedule of the engine scaling runs: steps 0, 5 and 9 of 10 (0 and 4 of the
/// quick suite's 5), so that the shared residual, one pass over every entry of `A` (42.6
/// million on the 5,525-box pyramid), is paid on three steps in ten. The 14,910-box pyramid's
/// `A` (121 million entries) is past
/// [`MAX_DELASSUS_ENTRIES`](lcpbench_contact::builder::MAX_DELASSUS_ENTRIES): its steps are
/// refused to `pgs+warm` and left unmeasured by the body-level solvers.
pub const ENGINE_SCALING_RESIDUAL: ResidualSchedule = ResidualSchedule::Sample(5);

/// The runs of the engine scaling family: `pgs+warm` capped at 20 sweeps per step, `si+warm`
/// at 8, and `soft-step` at its defaults (4 substeps; warm-started when it iterates), tolerance
/// 1e-6; 5 s per step's solve, so that a run is cut only past 100 s (twice its steps times
/// that) and the largest pyramid's steps are not.
pub fn engine_scaling_runs() -> Vec<(SolverSpec, NamedBudget)> {
    let soft = SolverSpec::body(BodySolverKind::SoftStep);
    let soft = if soft.is_iterative() {
        soft.with_warm()
    } else {
        soft
    };
    vec![
        (
            SolverSpec::plain(SolverKind::Pgs).with_warm(),
            custom_budget("1e-6:20:5"),
        ),
        (
            SolverSpec::body(BodySolverKind::SequentialImpulses).with_warm(),
            custom_budget("1e-6:8:5"),
        ),
        (soft, custom_budget("1e-6:500:5")),
    ]
}

/// The engine scaling family (the plan's smallest) × [`engine_scaling_runs`], each case with
/// the residual schedule [`ENGINE_SCALING_RESIDUAL`].
fn engine_scaling_jobs(suite: &mut Suite, scenes: &[PathBuf], plan: &Plan) {
    suite.engine_scaling_cases = engine_scaling_scenes(scenes)
        .iter()
        .take(plan.engine_scaling_scenes)
        .map(|p| {
            Case::scene(p, Some(plan.engine_scaling_steps)).with_residual(ENGINE_SCALING_RESIDUAL)
        })
        .collect();
    suite.engine_scaling_runs = engine_scaling_runs();
    for case in suite.engine_scaling_cases.clone() {
        for (solver, budget) in suite.engine_scaling_runs.clone() {
            push(suite, std::slice::from_ref(&case), &[solver], &[budget]);
        }
    }
}

/// Scenes whose steps only the FC3D collection takes: `fc3d/*.toml` in the directory of the
/// first scene file (a 385-box pyramid, 4,960 contacts at rest: the collection's 5,000-contact
/// problem, which the scene sections leave out to keep the suite's length).
pub fn fc3d_scenes(scenes: &[PathBuf]) -> Vec<PathBuf> {
    files_beside(scenes, "fc3d", "*.toml")
}

/// Budget of the FCLIB problems: tolerance `1e-6` (the accuracy the FCLIB comparison asks for),
/// 100,000 iterations and 20 s (the slowest Gauss–Seidel runs take a few seconds).
pub const FCLIB_BUDGET: &str = "1e-6:100000:20";

/// [`FCLIB_BUDGET`] with its name.
pub fn fclib_budget() -> NamedBudget {
    custom_budget(FCLIB_BUDGET)
}

/// The finer budget of the FCLIB problems: tolerance `1e-8`, so that Findings answers "fastest
/// on the FCLIB problems" at both accuracies; otherwise as [`FCLIB_BUDGET`].
pub const FCLIB_FINE_BUDGET: &str = "1e-8:100000:20";

/// Budget of the FC3D collection ([`fc3d_jobs`]): tolerance `1e-8` (the finer level of its
/// performance profiles), 100,000 iterations and 5 s per solve.
pub const FC3D_BUDGET: &str = "1e-8:100000:5";

/// [`FC3D_BUDGET`] with its name.
pub fn fc3d_budget() -> NamedBudget {
    custom_budget(FC3D_BUDGET)
}

/// Large scenes whose step problems the FC3D collection leaves out (file stems):
/// `pyramid_3d_5525` (80,900 contacts, 242,700 rows) has a Delassus matrix `W` of tens of
/// millions of entries, whose assembly alone would take most of a run's budget and gigabytes
/// per run; `rush`, whose bodies are still falling into the pile at the collection's steps
/// (steps 1 and 10 have no contact, so no problem to solve).
pub const FC3D_EXCLUDED_SCENES: [&str; 2] = ["pyramid_3d_5525", "rush"];

/// The FCLIB problem files: `fclib/*.hdf5` in the directory of the first scene file.
pub fn fclib_files(scenes: &[PathBuf]) -> Vec<PathBuf> {
    files_beside(scenes, "fclib", "*.hdf5")
}

/// Scenes of the friction-model comparison (by file stem): a slide on an incline, boxes
/// straddling the friction angle, a tower, and a box pushed diagonally (the box model's
/// anisotropy).
pub const FRICTION_SCENES: [&str; 4] = [
    "incline_slide",
    "friction_ramp",
    "tower_10_60hz",
    "diagonal_push",
];

/// Steps of each run of the friction-model comparison (the scene's own count when smaller).
pub const FRICTION_STEPS: usize = 100;

/// Budget of the friction-model comparison: tolerance `1e-8` with at most 1000 sweeps or
/// iterations per step, so that a tower's Gauss–Seidel runs stay short (they rarely reach
/// `1e-8`, which the converged-step counts show), and 1 s per step.
pub const FRICTION_BUDGET: &str = "1e-8:1000:1";

/// [`FRICTION_BUDGET`] with its name.
pub fn friction_budget() -> NamedBudget {
    custom_budget(FRICTION_BUDGET)
}

/// The friction models compared and the solvers run on each: a Gauss–Seidel method (warm
/// started) and a Newton or pivoting method. PGS is left out of the pyramid: its LCP matrix is
/// not symmetric and PGS does not converge on it.
pub const FRICTION_MODELS: [(FrictionModel, &[SolverSpec]); 3] = [
    (
        FrictionModel::Box,
        &[
            SolverSpec::plain(SolverKind::Pgs).with_warm(),
            SolverSpec::plain(SolverKind::Nsgs).with_warm(),
            SolverSpec::plain(SolverKind::NewtonFb).with_warm(),
        ],
    ),
    (
        FrictionModel::Pyramid { directions: 4 },
        &[
            SolverSpec::plain(SolverKind::NewtonFb).with_warm(),
            SolverSpec::plain(SolverKind::Lemke),
        ],
    ),
    (
        FrictionModel::Cone,
        &[
            SolverSpec::cone(ConeSolverKind::NsgsCone).with_warm(),
            SolverSpec::cone(ConeSolverKind::NewtonAc).with_warm(),
            SolverSpec::cone(ConeSolverKind::ClarabelSocp),
        ],
    ),
];

/// The friction-model cases of `scenes`: each of [`FRICTION_SCENES`] found among them, under
/// each model of [`FRICTION_MODELS`], in that order (scene-major).
pub fn friction_cases(scenes: &[PathBuf], steps: usize) -> Vec<Case> {
    let stem = |p: &PathBuf| p.file_stem().map(|s| s.to_string_lossy().into_owned());
    FRICTION_SCENES
        .iter()
        .filter_map(|name| scenes.iter().find(|p| stem(p).as_deref() == Some(*name)))
        .flat_map(|path| {
            FRICTION_MODELS
                .iter()
                .map(move |(model, _)| Case::scene_with_friction(path, Some(steps), *model))
        })
        .collect()
}

/// A suite: jobs plus the case lists the report groups them by.
#[derive(Debug, Clone, Default)]
pub struct Suite {
    /// Every job.
    pub jobs: Vec<Job>,
    /// Cases of the robustness matrix / profiles.
    pub matrix_cases: Vec<Case>,
    /// Cases of the scaling study, in increasing size.
    pub scaling_cases: Vec<Case>,
    /// Cases of the SOR omega sweep.
    pub omega_cases: Vec<Case>,
    /// SOR relaxation factors swept.
    pub omegas: Vec<f64>,
    /// Cases of the warm-versus-cold comparison.
    pub warm_cases: Vec<Case>,
    /// Scene cases.
    pub scene_cases: Vec<Case>,
    /// The large ones among them ([`is_large_scene`]).
    pub large_scene_cases: Vec<Case>,
    /// Cases of the scene scaling family (time per step against contacts).
    pub scene_scaling_cases: Vec<Case>,
    /// Cases of the engine scaling family ([`engine_scaling_scenes`]), by increasing size, each
    /// with the residual schedule [`ENGINE_SCALING_RESIDUAL`].
    pub engine_scaling_cases: Vec<Case>,
    /// Its runs ([`engine_scaling_runs`]).
    pub engine_scaling_runs: Vec<(SolverSpec, NamedBudget)>,
    /// Cases of the friction-model comparison ([`friction_cases`]).
    pub friction_cases: Vec<Case>,
    /// LCPs exported from scenes.
    pub exported_cases: Vec<Case>,
    /// Cases whose convergence histories are plotted.
    pub history_cases: Vec<Case>,
    /// The 60 Hz towers of the low-budget comparison (whole runs).
    pub tower_cases: Vec<Case>,
    /// The warm-started solvers of the tower comparison.
    pub tower_solvers: Vec<SolverSpec>,
    /// Its budgets.
    pub tower_budgets: Vec<NamedBudget>,
    /// The FCLIB problem files ([`fclib_files`]).
    pub fclib_cases: Vec<Case>,
    /// The FC3D collection of the cone solvers ([`fc3d_jobs`]): the FCLIB files, the exported
    /// scene LCPs and steps of the large scenes, each in its cone form.
    pub fc3d_cases: Vec<Case>,
    /// The scenes with joints ([`joint_scenes`]).
    pub joint_cases: Vec<Case>,
    /// The solvers of the joint scenes under [`SCENE_BUDGETS`]: every scene solver, cold, and
    /// the iterative ones warm-started.
    pub joint_solvers: Vec<SolverSpec>,
    /// The budgets of the joint scenes: [`SCENE_BUDGETS`], then [`JOINT_ITERATION_BUDGETS`]
    /// (warm-started iterative solvers only).
    pub joint_budgets: Vec<NamedBudget>,
    /// The scenes of the engine-solver comparison ([`ENGINE_SCENES`] found beside the scene
    /// files), each as the suite's own case of it (see `engine_jobs`).
    pub engine_cases: Vec<Case>,
    /// Its runs: each solver with its budget ([`engine_runs`]).
    pub engine_runs: Vec<(SolverSpec, NamedBudget)>,
    /// The time-of-impact runs ([`impact_cases`]).
    pub impact_cases: Vec<ImpactCase>,
}

/// A preset budget with its name.
fn preset(name: BudgetName) -> NamedBudget {
    name.named().expect("a preset names a budget")
}

/// One of the suite's custom budgets (`TOL:ITER:SECONDS`), named by its text.
fn custom_budget(spec: &str) -> NamedBudget {
    spec.parse().expect("the suite's custom budgets are valid")
}

/// Every matrix solver with default parameters, cold start.
pub fn all_solvers() -> Vec<SolverSpec> {
    SolverKind::all()
        .into_iter()
        .map(SolverSpec::plain)
        .collect()
}

/// Every cone solver, cold start.
pub fn cone_solvers() -> Vec<SolverSpec> {
    ConeSolverKind::all()
        .into_iter()
        .map(SolverSpec::cone)
        .collect()
}

/// Every solver a scene can use: the matrix solvers and the body-level ones, cold start.
pub fn scene_solvers() -> Vec<SolverSpec> {
    let mut v = all_solvers();
    v.extend(BodySolverKind::all().into_iter().map(SolverSpec::body));
    v
}

/// The sizes and counts that differ between the quick suite (tests) and the full one.
struct Plan {
    /// Sizes of the generated families of the matrix.
    sizes: &'static [usize],
    /// Condition numbers of its SPD problems.
    conds: &'static [f64],
    /// Sizes of Murty's example.
    murty: &'static [usize],
    /// Sizes of the SPD scaling family.
    scaling: &'static [usize],
    /// Size of the omega-sweep and warm-start problems.
    mid: usize,
    /// SOR relaxation factors.
    omegas: &'static [f64],
    /// Cap on the steps of a scene run (small scenes), and of a large scene's (which also
    /// caps [`large_scene_steps`]).
    scene_steps: usize,
    large_scene_steps: usize,
    /// Steps of a friction-model run.
    friction_steps: usize,
    /// Cap on the steps of a tower run of the low-budget comparison (`None`: the whole run).
    tower_steps: Option<usize>,
    /// How many of the scene scaling family run (smallest first), and their steps.
    scaling_scenes: usize,
    scaling_steps: usize,
    /// How many of the engine scaling family run (smallest first), and their steps.
    engine_scaling_scenes: usize,
    engine_scaling_steps: usize,
    /// How many FCLIB files run (smallest first).
    fclib_files: usize,
    /// The steps of each large scene in the FC3D collection.
    fc3d_scene_steps: &'static [usize],
    /// Whether the FC3D collection takes the steps of the scenes of [`fc3d_scenes`].
    fc3d_only_scenes: bool,
    /// Whether the small scenes of [`SMALL_SCENE_STEP_EXCEPTIONS`] run their steps (otherwise
    /// `scene_steps`).
    small_scene_exceptions: bool,
}

const QUICK: Plan = Plan {
    sizes: &[8],
    conds: &[1e2, 1e8],
    murty: &[6],
    scaling: &[8, 16],
    mid: 8,
    omegas: &[1.0, 1.4],
    scene_steps: 5,
    large_scene_steps: 5,
    friction_steps: 5,
    tower_steps: Some(10),
    scaling_scenes: 2,
    scaling_steps: 2,
    engine_scaling_scenes: 2,
    engine_scaling_steps: QUICK_ENGINE_SCALING_STEPS,
    fclib_files: 1,
    fc3d_scene_steps: &[1],
    fc3d_only_scenes: false,
    small_scene_exceptions: false,
};

const FULL: Plan = Plan {
    sizes: &[10, 50, 200],
    conds: &[1e2, 1e4, 1e6, 1e8, 1e10],
    murty: &[6, 10, 14],
    scaling: &[16, 32, 64, 128, 256, 512],
    mid: 100,
    omegas: &[
        0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9,
    ],
    scene_steps: SCENE_STEPS,
    large_scene_steps: usize::MAX,
    friction_steps: FRICTION_STEPS,
    tower_steps: None,
    scaling_scenes: usize::MAX,
    scaling_steps: SCALING_STEPS,
    engine_scaling_scenes: usize::MAX,
    engine_scaling_steps: ENGINE_SCALING_STEPS,
    fclib_files: usize::MAX,
    fc3d_scene_steps: &[1, 10],
    fc3d_only_scenes: true,
    small_scene_exceptions: true,
};

/// The generated families of the robustness matrix besides SPD (PSD of the default rank), each
/// run at every size with seed 1.
fn matrix_families(n: usize) -> [GenFamily; 6] {
    [
        GenFamily::psd_default(n),
        GenFamily::PMatrix,
        GenFamily::Duplicated,
        GenFamily::Weak,
        GenFamily::ZeroB,
        GenFamily::Infeasible,
    ]
}

/// Build the default suite (`quick`: a much smaller one, with every section, for tests and a
/// first look). `scenes` are scene files (the quick suite keeps those of [`QUICK_SCENES`]) and
/// `exported` problem files exported from scenes.
pub fn default_suite(quick: bool, scenes: &[PathBuf], exported: &[PathBuf]) -> Suite {
    let plan = if quick { &QUICK } else { &FULL };
    let all_scenes = scenes;
    let scenes = &suite_scenes(quick, scenes)[..];
    let mut suite = Suite::default();
    generated_cases(&mut suite, plan);
    let large_scenes = scene_cases(&mut suite, plan, scenes);
    exported_cases(&mut suite, exported);
    lcp_jobs(&mut suite);
    scene_jobs(&mut suite, &large_scenes);
    suite.friction_cases = friction_cases(scenes, plan.friction_steps);
    friction_jobs(&mut suite);
    tower_jobs(&mut suite, scenes, plan.tower_steps);
    scene_scaling_jobs(&mut suite, all_scenes, plan);
    engine_scaling_jobs(&mut suite, all_scenes, plan);
    fclib_jobs(&mut suite, all_scenes, plan.fclib_files);
    let fc3d_only = if plan.fc3d_only_scenes {
        fc3d_scenes(all_scenes)
    } else {
        Vec::new()
    };
    fc3d_jobs(&mut suite, &large_scenes, &fc3d_only, plan.fc3d_scene_steps);
    joint_jobs(&mut suite, all_scenes, quick, plan.scene_steps);
    engine_jobs(&mut suite, all_scenes, quick);
    suite.impact_cases = impact_cases(all_scenes, quick);
    suite
}

/// The scenes of the engine-solver comparison (paths under the scene directory, without
/// `.toml`), after Solver2D's set (Catto's solver comparison; `bench_scenes/README.md` maps
/// them). Each runs as the case the suite already has for it (see `engine_jobs`), so the
/// families Findings ranks over keep their cases.
pub const ENGINE_SCENES: [&str; 15] = [
    "tower_40_60hz",
    "pyramid_20",
    "pyramid_3d_1015",
    "house_of_cards",
    "arch",
    "confined",
    "friction_ramp",
    "mass_ratio_heavy_on_light_1e3",
    "overlap_25",
    "joints/chain_20_1e3",
    "joints/rope_bridge",
    "joints/ragdoll_pile",
    "rush",
    "double_domino",
    "sphere_stack",
];

/// The engine scenes of the quick suite.
pub const QUICK_ENGINE_SCENES: [&str; 2] = ["tower_40_60hz", "joints/chain_20_1e3"];

/// Steps of a quick engine run of a scene the quick suite has no case for.
pub const QUICK_ENGINE_STEPS: usize = 5;

/// Budget of the substepping solvers in the engine comparison: their own parameters set the
/// work (substeps, iterations); 500 sweeps per step is above any of their costs here, so the
/// cap does not cut them, and the tolerance 1e-6 only decides a step's status. (Not
/// [`SCENE_MID_BUDGET`], whose runs are the warm iterative solvers' on every scene.)
pub const ENGINE_BUDGET: &str = "1e-6:500:1";

/// The costs the substepping solvers run at besides their defaults: these values of their
/// `substeps` key (or of `iterations`, for a solver that does not substep by default), the
/// first two that differ from the default and are in the key's range.
pub const ENGINE_COSTS: [usize; 4] = [4, 8, 20, 2];

/// Iteration caps of the Gauss–Seidel baselines (`pgs+warm`, `si+warm`, tolerance 1e-6): the
/// sweeps per step of a substepping solver with one solve and one relax pass per substep at
/// 4, 8 and 20 substeps.
pub const ENGINE_BASELINE_ITERATIONS: [usize; 3] = [8, 16, 40];

/// The substepping solvers (every [`BodySolverKind`] with [`BodySolverKind::substeps`]) at
/// their defaults and at two more costs ([`cost_variants`]), warm-started when they iterate.
pub fn engine_solver_specs() -> Vec<SolverSpec> {
    let mut out = Vec::new();
    for kind in BodySolverKind::all().into_iter().filter(|k| k.substeps()) {
        let specs = std::iter::once(SolverSpec::body(kind)).chain(
            cost_variants(kind.param_specs())
                .into_iter()
                .map(|p| SolverSpec::body_with(kind, p)),
        );
        out.extend(specs.map(|s| if s.is_iterative() { s.with_warm() } else { s }));
    }
    out
}

/// The parameter sets of a solver's two more costs: its `substeps` key (or its `iterations`
/// key, when it does not substep by default or has no `substeps` key) set to the first two
/// values of [`ENGINE_COSTS`] that differ from the default and are in the key's range; none
/// for a solver with neither key.
pub fn cost_variants(specs: &'static [ParamSpec]) -> Vec<Params> {
    let default_of = |key: &str| specs.iter().find(|s| s.key == key).map(|s| s.default);
    let key = match (default_of("substeps"), default_of("iterations")) {
        (Some(d), Some(_)) if d <= 1.0 => "iterations",
        (Some(_), _) => "substeps",
        (None, Some(_)) => "iterations",
        (None, None) => return Vec::new(),
    };
    let default = default_of(key).unwrap_or(0.0);
    ENGINE_COSTS
        .iter()
        .filter(|&&c| c as f64 != default)
        .filter_map(|c| Params::parse(specs, &format!("{key}={c}")).ok())
        .take(2)
        .collect()
}

/// The runs of the engine comparison: [`engine_solver_specs`] under [`ENGINE_BUDGET`], and
/// `pgs+warm` and `si+warm` under each of [`ENGINE_BASELINE_ITERATIONS`].
pub fn engine_runs() -> Vec<(SolverSpec, NamedBudget)> {
    let mut out: Vec<(SolverSpec, NamedBudget)> = engine_solver_specs()
        .into_iter()
        .map(|s| (s, custom_budget(ENGINE_BUDGET)))
        .collect();
    for baseline in [
        SolverSpec::plain(SolverKind::Pgs).with_warm(),
        SolverSpec::body(BodySolverKind::SequentialImpulses).with_warm(),
    ] {
        for n in ENGINE_BASELINE_ITERATIONS {
            out.push((baseline.clone(), custom_budget(&format!("1e-6:{n}:1"))));
        }
    }
    out
}

/// The engine comparison: each scene of [`ENGINE_SCENES`] found beside the scene files (the
/// quick suite: those of [`QUICK_ENGINE_SCENES`]) × its runs ([`engine_runs`]). A scene runs
/// as the case the suite already has for it, so the engine runs add rows to cases every scene
/// solver ran, not cases of their own: a tower's whole run (the tower comparison), a joint
/// scene's (the joints part), otherwise the scene part's steps (100, a large scene
/// [`large_scene_steps`]). A scene the suite has no case for (the quick suite's) runs
/// [`QUICK_ENGINE_STEPS`] steps, or in the full suite as the scene part would run it.
fn engine_jobs(suite: &mut Suite, scenes: &[PathBuf], quick: bool) {
    let Some(dir) = scenes.first().and_then(|p| p.parent()) else {
        return;
    };
    let existing: Vec<Case> = suite
        .tower_cases
        .iter()
        .chain(&suite.joint_cases)
        .chain(&suite.scene_cases)
        .cloned()
        .collect();
    suite.engine_cases = ENGINE_SCENES
        .iter()
        .filter(|name| !quick || QUICK_ENGINE_SCENES.contains(name))
        .map(|name| dir.join(format!("{name}.toml")))
        .filter(|path| path.is_file())
        .map(|path| {
            let same = existing
                .iter()
                .find(|c| matches!(c, Case::Scene { path: p, friction: None, .. } if *p == path));
            same.cloned().unwrap_or_else(|| {
                let steps = if quick {
                    QUICK_ENGINE_STEPS
                } else if is_large_scene(&path) {
                    large_scene_steps(&path)
                } else {
                    small_scene_steps(&path)
                };
                Case::scene(&path, Some(steps))
            })
        })
        .collect();
    suite.engine_runs = engine_runs();
    for case in suite.engine_cases.clone() {
        for (solver, budget) in suite.engine_runs.clone() {
            push(suite, std::slice::from_ref(&case), &[solver], &[budget]);
        }
    }
}

/// The time-of-impact runs: every scene of `impact/` beside the first scene file under every
/// [`ImpactMode`] its size allows ([`impact_mode_runs`]).
pub fn impact_cases(scenes: &[PathBuf], quick: bool) -> Vec<ImpactCase> {
    let mut cases = Vec::new();
    for scene in files_beside(scenes, "impact", "*.toml") {
        let balls = bouncing_balls(&scene);
        for mode in ImpactMode::ALL {
            if impact_mode_runs(mode, balls, quick) {
                cases.push(ImpactCase {
                    scene: scene.clone(),
                    mode,
                });
            }
        }
    }
    cases
}

/// The ball count `N` of a `bouncing_N.toml` scene.
pub fn bouncing_balls(scene: &Path) -> Option<usize> {
    scene
        .file_stem()?
        .to_str()?
        .strip_prefix("bouncing_")?
        .parse()
        .ok()
}

/// The runtime budget of the time-of-impact runs (2 s of simulated time each): Timewarp and
/// the 60 Hz fixed step run every scene; 240 Hz and the backtracking methods (whose every step
/// is a pass over all bodies' swept boxes, the motion cut at the first impact) up to 1,000
/// balls; 1 kHz (2,000 steps) up to 100 balls. The quick suite stops at 100 balls.
pub fn impact_mode_runs(mode: ImpactMode, balls: Option<usize>, quick: bool) -> bool {
    let n = balls.unwrap_or(0);
    if quick && n > 100 {
        return false;
    }
    match mode {
        ImpactMode::Timewarp | ImpactMode::Fixed { hz: 60 } => true,
        ImpactMode::Fixed { hz: 1000 } => n <= 100,
        _ => n <= 1000,
    }
}

/// The scenes of [`joint_scenes`] (the quick suite: those of [`QUICK_JOINT_SCENES`], for
/// `quick_steps` steps) × every scene solver, cold and warm, × [`SCENE_BUDGETS`], and the
/// warm-started iterative solvers × [`JOINT_ITERATION_BUDGETS`].
fn joint_jobs(suite: &mut Suite, scenes: &[PathBuf], quick: bool, quick_steps: usize) {
    suite.joint_cases = joint_scenes(scenes)
        .iter()
        .filter(|p| {
            !quick
                || p.file_stem()
                    .is_some_and(|s| QUICK_JOINT_SCENES.iter().any(|q| s == *q))
        })
        .map(|p| Case::scene(p, quick.then_some(quick_steps)))
        .collect();
    let mut solvers = scene_solvers();
    solvers.extend(warm_scene_solvers());
    let presets: Vec<NamedBudget> = SCENE_BUDGETS.into_iter().map(preset).collect();
    let iterations: Vec<NamedBudget> = JOINT_ITERATION_BUDGETS
        .into_iter()
        .map(custom_budget)
        .collect();
    let cases = suite.joint_cases.clone();
    push(suite, &cases, &solvers, &presets);
    push(suite, &cases, &warm_scene_solvers(), &iterations);
    suite.joint_solvers = solvers;
    suite.joint_budgets = presets.into_iter().chain(iterations).collect();
}

/// The generated problems: the matrix, the histories, the scaling family, the omega sweep and
/// the warm-start comparison.
fn generated_cases(suite: &mut Suite, plan: &Plan) {
    for &n in plan.sizes {
        for &cond in plan.conds {
            suite.matrix_cases.push(Case::spd(n, cond, 1));
        }
        for family in matrix_families(n) {
            suite.matrix_cases.push(Case::generated(family, n, 1));
        }
    }
    for &n in plan.murty {
        suite
            .matrix_cases
            .push(Case::generated(GenFamily::Murty, n, 0));
    }
    let big = plan.sizes[plan.sizes.len() - 1];
    let cond = plan.conds[plan.conds.len() / 2];
    suite.history_cases = vec![
        Case::spd(big, cond, 1),
        Case::psd(big, 1),
        Case::generated(GenFamily::PMatrix, big, 1),
    ];
    suite.scaling_cases = plan.scaling.iter().map(|&n| Case::spd(n, 1e3, 2)).collect();
    let mid = plan.mid;
    suite.omega_cases = vec![
        Case::spd(mid, 1e2, 3),
        Case::spd(mid, 1e4, 3),
        Case::psd(mid, 3),
    ];
    suite.omegas = plan.omegas.to_vec();
    suite.warm_cases = vec![
        Case::spd(mid, 1e2, 4),
        Case::spd(mid, 1e4, 4),
        Case::psd(mid, 4),
        Case::generated(GenFamily::Duplicated, mid, 4),
    ];
}

/// One case per scene file; returns the large ones.
fn scene_cases(suite: &mut Suite, plan: &Plan, scenes: &[PathBuf]) -> Vec<Case> {
    let mut large_scenes = Vec::new();
    for path in scenes {
        let large = is_large_scene(path);
        let steps = if large {
            large_scene_steps(path).min(plan.large_scene_steps)
        } else if plan.small_scene_exceptions {
            small_scene_steps(path)
        } else {
            plan.scene_steps
        };
        let case = Case::scene(path, Some(steps));
        if large {
            large_scenes.push(case.clone());
        }
        suite.scene_cases.push(case);
    }
    suite.large_scene_cases = large_scenes.clone();
    large_scenes
}

/// The exported scene LCPs, also in the warm-start comparison (all), the omega sweep and the
/// histories (the first two each).
fn exported_cases(suite: &mut Suite, exported: &[PathBuf]) {
    suite.exported_cases = exported.iter().cloned().map(Case::File).collect();
    let first_two = || suite.exported_cases.iter().take(2).cloned();
    suite.omega_cases.extend(first_two());
    suite.history_cases.extend(first_two());
    suite
        .warm_cases
        .extend(suite.exported_cases.iter().cloned());
}

fn push(suite: &mut Suite, cases: &[Case], solvers: &[SolverSpec], budgets: &[NamedBudget]) {
    suite
        .jobs
        .extend(crate::harness::cross_product(cases, solvers, budgets));
}

fn warm(s: &SolverSpec) -> SolverSpec {
    s.clone().with_warm()
}

/// The LCP jobs: matrix and exported LCPs (budgets `default`, `tight`), the cone form of the
/// exported ones, the scaling family, the omega sweep, warm against cold.
fn lcp_jobs(suite: &mut Suite) {
    let solvers = all_solvers();
    let matrix_budgets = [preset(BudgetName::Default), preset(BudgetName::Tight)];
    let (matrix, exported) = (suite.matrix_cases.clone(), suite.exported_cases.clone());
    push(suite, &matrix, &solvers, &matrix_budgets);
    push(suite, &exported, &solvers, &matrix_budgets);
    let scaling = suite.scaling_cases.clone();
    push(suite, &scaling, &solvers, &[preset(BudgetName::Default)]);
    // An omega outside SOR's range (0, 2) has no run (the plans' omegas are all inside it).
    let omega_specs: Vec<SolverSpec> = suite
        .omegas
        .iter()
        .filter_map(|&w| SolverSpec::sor(w).ok())
        .collect();
    let omega = suite.omega_cases.clone();
    push(suite, &omega, &omega_specs, &[preset(BudgetName::Default)]);
    let iterative: Vec<SolverSpec> = solvers
        .iter()
        .filter(|s| s.is_iterative())
        .flat_map(|s| [s.clone(), warm(s)])
        .collect();
    let warm_cases = suite.warm_cases.clone();
    push(
        suite,
        &warm_cases,
        &iterative,
        &[preset(BudgetName::Default)],
    );
}

/// The iterative scene solvers, warm started.
fn warm_scene_solvers() -> Vec<SolverSpec> {
    scene_solvers()
        .iter()
        .filter(|s| s.is_iterative())
        .map(warm)
        .collect()
}

/// Every scene solver, cold and (the iterative ones) warm-started, on every scene under every
/// budget of [`SCENE_BUDGETS`]; the warm-started iterative ones under [`SCENE_MID_BUDGET`] too.
fn scene_jobs(suite: &mut Suite, _large_scenes: &[Case]) {
    let scene_budgets: Vec<NamedBudget> = SCENE_BUDGETS.into_iter().map(preset).collect();
    let mut solvers = scene_solvers();
    solvers.extend(warm_scene_solvers());
    let (huge, rest): (Vec<Case>, Vec<Case>) =
        suite
            .scene_cases
            .clone()
            .into_iter()
            .partition(|c| match c {
                Case::Scene { path, .. } => is_huge_scene(path),
                _ => false,
            });
    push(suite, &rest, &solvers, &scene_budgets);
    let mid = [scene_mid_budget()];
    push(suite, &rest, &warm_scene_solvers(), &mid);
    let huge_solvers = huge_scene_solvers();
    let engine: Vec<SolverSpec> = solvers
        .into_iter()
        .filter(|s| huge_solvers.contains(&s.clone().cold()))
        .collect();
    push(suite, &huge, &engine, &scene_budgets);
    let engine_warm: Vec<SolverSpec> = engine.into_iter().filter(|s| s.warm()).collect();
    push(suite, &huge, &engine_warm, &mid);
}

/// Each friction-model case with the solvers [`FRICTION_MODELS`] gives its model.
fn friction_jobs(suite: &mut Suite) {
    for case in suite.friction_cases.clone() {
        let Case::Scene {
            friction: Some(model),
            ..
        } = &case
        else {
            continue;
        };
        let specs = FRICTION_MODELS
            .iter()
            .find(|(m, _)| m == model)
            .map(|(_, specs)| specs.to_vec())
            .unwrap_or_default();
        push(
            suite,
            std::slice::from_ref(&case),
            &specs,
            &[friction_budget()],
        );
    }
}

/// The towers of [`TOWER_SCENES`] found among `scenes`, whole runs (or `steps`), with the
/// warm-started iterative scene solvers under [`TOWER_BUDGETS`].
fn tower_jobs(suite: &mut Suite, scenes: &[PathBuf], steps: Option<usize>) {
    suite.tower_cases = scenes
        .iter()
        .filter(|p| {
            p.file_name()
                .is_some_and(|f| TOWER_SCENES.iter().any(|t| f == *t))
        })
        .map(|p| Case::scene(p, steps))
        .collect();
    suite.tower_solvers = warm_scene_solvers();
    suite.tower_budgets = TOWER_BUDGETS.into_iter().map(custom_budget).collect();
    let (cases, solvers, budgets) = (
        suite.tower_cases.clone(),
        suite.tower_solvers.clone(),
        suite.tower_budgets.clone(),
    );
    push(suite, &cases, &solvers, &budgets);
}

/// The scene scaling family (the plan's smallest) × every scene solver, budget `default`.
fn scene_scaling_jobs(suite: &mut Suite, scenes: &[PathBuf], plan: &Plan) {
    let mut family = scaling_scenes(scenes);
    family.sort_by_cached_key(|p| {
        lcpbench_contact::scene::Scene::load(p).map_or(usize::MAX, |s| s.bodies.len())
    });
    suite.scene_scaling_cases = family
        .iter()
        .take(plan.scaling_scenes)
        .map(|p| Case::scene(p, Some(plan.scaling_steps)))
        .collect();
    let cases = suite.scene_scaling_cases.clone();
    push(
        suite,
        &cases,
        &scene_solvers(),
        &[preset(BudgetName::Default)],
    );
}

/// The FCLIB problems (the plan's smallest, by file size) × every matrix solver, budget
/// [`FCLIB_BUDGET`] and [`FCLIB_FINE_BUDGET`].
fn fclib_jobs(suite: &mut Suite, scenes: &[PathBuf], count: usize) {
    let mut files = fclib_files(scenes);
    if count < files.len() {
        files.sort_by_key(|p| std::fs::metadata(p).map_or(u64::MAX, |m| m.len()));
        files.truncate(count);
    }
    suite.fclib_cases = files.into_iter().map(Case::File).collect();
    let cases = suite.fclib_cases.clone();
    push(
        suite,
        &cases,
        &all_solvers(),
        &[fclib_budget(), custom_budget(FCLIB_FINE_BUDGET)],
    );
}

/// The FC3D collection × every cone solver (cold), budget [`FC3D_BUDGET`]: the FCLIB files,
/// the exported scene LCPs, and `steps` of each large scene (those of
/// [`FC3D_EXCLUDED_SCENES`] left out) and of each scene of `fc3d_only`, each in its exact-cone
/// form (every contact's normal and two tangent rows as one Coulomb cone); the cone solvers'
/// performance profiles.
fn fc3d_jobs(suite: &mut Suite, large_scenes: &[Case], fc3d_only: &[PathBuf], steps: &[usize]) {
    let mut cases = suite.fclib_cases.clone();
    cases.extend(suite.exported_cases.iter().cloned());
    let large = large_scenes.iter().filter_map(|scene| match scene {
        Case::Scene { path, .. } => Some(path),
        _ => None,
    });
    for path in large.chain(fc3d_only) {
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        if FC3D_EXCLUDED_SCENES
            .iter()
            .any(|x| stem.as_deref() == Some(*x))
        {
            continue;
        }
        for &step in steps {
            cases.push(Case::SceneStep {
                path: path.clone(),
                step,
            });
        }
    }
    suite.fc3d_cases = cases.clone();
    push(suite, &cases, &cone_solvers(), &[fc3d_budget()]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suites_have_no_duplicate_jobs_that_matter() {
        for quick in [true, false] {
            let s = default_suite(quick, &[], &[]);
            assert!(!s.jobs.is_empty());
            assert!(s.matrix_cases.iter().all(|c| c.size().is_some()));
        }
        assert!(
            default_suite(true, &[], &[]).jobs.len() < default_suite(false, &[], &[]).jobs.len()
        );
    }

    /// A huge scene runs the solvers of [`huge_scene_solvers`], cold and warm, under every
    /// scene budget; a large one below the threshold runs every scene solver.
    #[test]
    fn huge_scenes_run_the_solvers_that_need_no_assembled_matrix() {
        let huge = PathBuf::from("bench_scenes/pyramid_3d_5525.toml");
        let large = PathBuf::from("bench_scenes/pyramid_3d_1015.toml");
        assert!(is_huge_scene(&huge) && !is_huge_scene(&large));
        let s = default_suite(false, &[huge.clone(), large.clone()], &[]);
        let specs_on = |path: &PathBuf| {
            let mut v: Vec<String> = s
                .jobs
                .iter()
                .filter(
                    |j| matches!(&j.case, Case::Scene { path: p, friction: None, .. } if p == path),
                )
                .map(|j| j.solver.to_string())
                .collect();
            v.sort();
            v.dedup();
            v
        };
        let on_huge = specs_on(&huge);
        let huge_names: Vec<String> = huge_scene_solvers().iter().map(|s| s.to_string()).collect();
        assert!(on_huge.iter().all(|spec| huge_names
            .iter()
            .any(|h| h == spec.trim_end_matches("+warm"))));
        for wanted in ["pgs", "pgs+warm", "sor+warm", "si", "si+warm"] {
            assert!(
                on_huge.iter().any(|s| s == wanted),
                "{wanted} in {on_huge:?}"
            );
        }
        let on_large = specs_on(&large);
        assert!(on_large.len() > on_huge.len() && on_large.iter().any(|s| s == "lemke"));
    }

    /// Every scene runs the 1e-6 budget with the warm-started iterative solvers, and no other
    /// solver; that adds fewer than one run in six to the scene runs.
    #[test]
    fn scenes_run_the_1e6_budget_warm_started() {
        let scenes = [PathBuf::from("bench_scenes/tower_40_60hz.toml")];
        let s = default_suite(false, &scenes, &[]);
        let on_scene = |j: &&Job| matches!(&j.case, Case::Scene { friction: None, .. });
        let mid: Vec<&Job> = s
            .jobs
            .iter()
            .filter(on_scene)
            .filter(|j| j.budget.name.as_str() == SCENE_MID_BUDGET)
            .collect();
        assert!(!mid.is_empty());
        assert!(mid
            .iter()
            .all(|j| j.solver.warm() && j.solver.is_iterative()));
        let presets = s
            .jobs
            .iter()
            .filter(on_scene)
            .filter(|j| SCENE_BUDGETS.contains(&j.budget.name))
            .filter(|j| s.scene_cases.contains(&j.case))
            .count();
        assert!(mid.len() * 6 < presets, "{} of {presets}", mid.len());
    }

    /// The two more costs of a substepping solver: its substeps at the first two of 4, 8, 20,
    /// 2 other than the default and within range; its iterations when it takes one substep by
    /// default; nothing without either key.
    #[test]
    fn engine_costs_vary_substeps_or_iterations() {
        const SUBSTEPPING: &[ParamSpec] = &[
            ParamSpec::count("substeps", 4, 1, 64, "substeps"),
            ParamSpec::count("iterations", 1, 1, 100, "iterations"),
        ];
        const ONE_STEP: &[ParamSpec] = &[
            ParamSpec::count("substeps", 1, 1, 64, "substeps"),
            ParamSpec::count("iterations", 8, 1, 100, "iterations"),
        ];
        const SMALL: &[ParamSpec] = &[ParamSpec::count("substeps", 8, 1, 10, "substeps")];
        const NONE: &[ParamSpec] = &[ParamSpec::real("hertz", 30.0, 0.0, 1e4, "stiffness")];
        let text = |specs| -> Vec<String> {
            cost_variants(specs)
                .iter()
                .map(ToString::to_string)
                .collect()
        };
        assert_eq!(text(SUBSTEPPING), ["substeps=8", "substeps=20"]);
        assert_eq!(text(ONE_STEP), ["iterations=4", "iterations=20"]);
        // 20 is out of range: the next value stands in.
        assert_eq!(text(SMALL), ["substeps=4", "substeps=2"]);
        assert!(text(NONE).is_empty());
    }

    /// The engine comparison runs every substepping solver (its defaults first, warm-started
    /// when it iterates) and the warm Gauss–Seidel baselines at 8, 16 and 40 sweeps, on the
    /// engine scenes present, each with its steps.
    #[test]
    fn the_engine_comparison_runs_the_substepping_solvers_and_the_baselines() {
        let specs = engine_solver_specs();
        let kinds: Vec<BodySolverKind> = BodySolverKind::all()
            .into_iter()
            .filter(|k| k.substeps())
            .collect();
        for spec in &specs {
            let Some(kind) = spec.body_kind() else {
                panic!("{spec} is not a body-level solver");
            };
            assert!(kinds.contains(&kind), "{spec}");
            assert_eq!(spec.warm(), kind.is_iterative(), "{spec}");
        }
        for kind in &kinds {
            let first = specs.iter().find(|s| s.body_kind() == Some(*kind)).unwrap();
            assert_eq!(first.clone().cold(), SolverSpec::body(*kind));
        }
        let runs: Vec<String> = engine_runs()
            .iter()
            .filter(|(s, _)| !specs.contains(s))
            .map(|(s, b)| format!("{s} {}", b.name))
            .collect();
        assert_eq!(
            runs,
            [
                "pgs+warm 1e-6:8:1",
                "pgs+warm 1e-6:16:1",
                "pgs+warm 1e-6:40:1",
                "si+warm 1e-6:8:1",
                "si+warm 1e-6:16:1",
                "si+warm 1e-6:40:1",
            ]
        );
        let scenes = [
            PathBuf::from("bench_scenes/tower_40_60hz.toml"),
            PathBuf::from("bench_scenes/rush.toml"),
            PathBuf::from("bench_scenes/pyramid_3d_1015.toml"),
            PathBuf::from("bench_scenes/sphere_stack.toml"),
        ];
        let s = default_suite(false, &scenes, &[]);
        let keys: Vec<String> = s.engine_cases.iter().map(|c| c.to_string()).collect();
        assert_eq!(keys.len(), ENGINE_SCENES.len(), "{keys:?}");
        // The suite's own cases: the tower's whole run, the joint scenes' whole runs, the
        // scene part's steps (100; large scenes and the sphere stack their own); a scene not
        // among the scene files
        // given (pyramid_20, 210 boxes: large) as the scene part would run it.
        for key in [
            "scene:bench_scenes/tower_40_60hz.toml",
            "scene:bench_scenes/joints/chain_20_1e3.toml",
            "scene:bench_scenes/pyramid_3d_1015.toml?steps=10",
            "scene:bench_scenes/rush.toml?steps=60",
            "scene:bench_scenes/sphere_stack.toml?steps=150",
            "scene:bench_scenes/pyramid_20.toml?steps=20",
        ] {
            assert!(keys.contains(&key.to_string()), "{key} in {keys:?}");
        }
        let own: Vec<&Case> = s
            .tower_cases
            .iter()
            .chain(&s.joint_cases)
            .chain(&s.scene_cases)
            .collect();
        let given = |c: &Case| {
            scenes
                .iter()
                .any(|p| c.short_name() == p.file_stem().unwrap().to_string_lossy())
        };
        for case in s.engine_cases.iter().filter(|c| given(c)) {
            assert!(
                own.contains(&case),
                "{case} is not one of the suite's cases"
            );
        }
        let quick = default_suite(true, &scenes, &[]);
        let quick_keys: Vec<String> = quick.engine_cases.iter().map(|c| c.to_string()).collect();
        assert_eq!(
            quick_keys,
            [
                "scene:bench_scenes/tower_40_60hz.toml?steps=5",
                "scene:bench_scenes/joints/chain_20_1e3.toml?steps=5",
            ]
        );
    }

    /// The engine scaling family: six pyramids of 6 to 35 layers, each with `N` boxes
    /// (`N = L (L + 1) (2L + 1) / 6`) and the ground, kept out of the scene scaling family;
    /// the smallest rests on 1,024 contacts (four on the ground under each bottom box, four on
    /// each of the four boxes under every other). The full suite runs all six with the three
    /// runs, the quick one the two smallest, each with the sampled residual.
    #[test]
    fn the_engine_scaling_family_is_six_pyramids_apart_from_the_walls() {
        let first =
            vec![PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("bench_scenes/tower_5.toml")];
        let family = engine_scaling_scenes(&first);
        let boxes: Vec<usize> = family.iter().filter_map(|p| pyramid_boxes(p)).collect();
        assert_eq!(boxes, [91, 385, 1015, 2870, 5525, 14910]);
        for (path, layers) in family.iter().zip([6, 10, 14, 20, 25, 35]) {
            let scene = lcpbench_contact::scene::Scene::load(path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let dynamic = scene.bodies.iter().filter(|b| !b.is_static).count();
            assert_eq!(dynamic, layers * (layers + 1) * (2 * layers + 1) / 6);
            assert_eq!(Some(dynamic), pyramid_boxes(path));
            assert_eq!(scene.bodies.len(), dynamic + 1);
            assert_eq!(scene.metrics.expected_top_height, Some(layers as f64 - 0.5));
        }
        let walls = scaling_scenes(&first);
        assert!(!walls.is_empty());
        assert!(
            walls.iter().all(|p| pyramid_boxes(p).is_none()),
            "{walls:?}"
        );
        let mut world = lcpbench_contact::scene::Scene::load(&family[0])
            .unwrap()
            .world();
        world.set_solver(lcpbench_contact::ContactSolver::from_name("si").unwrap());
        world.settings.residual = ResidualSchedule::None;
        assert_eq!(world.step().contacts, 4 * 36 + 16 * (91 - 36));
        let full = default_suite(false, &first, &[]);
        assert_eq!(full.engine_scaling_cases.len(), 6);
        assert_eq!(full.engine_scaling_runs.len(), 3);
        for case in &full.engine_scaling_cases {
            assert!(
                case.to_string().ends_with("?steps=10&residual=sample=5"),
                "{case}"
            );
            let jobs = full.jobs.iter().filter(|j| j.case == *case).count();
            assert_eq!(jobs, 3, "{case}");
        }
        assert!(full
            .scene_scaling_cases
            .iter()
            .all(|c| !c.to_string().contains("pyramid")));
        let quick = default_suite(true, &first, &[]);
        let keys: Vec<String> = quick
            .engine_scaling_cases
            .iter()
            .map(|c| c.short_name())
            .collect();
        assert_eq!(keys, ["pyramid_3d_91", "pyramid_3d_385"]);
    }

    #[test]
    fn the_fc3d_collection_has_the_fclib_files_exported_steps_and_large_scene_steps() {
        let scenes = [
            PathBuf::from("bench_scenes/tower_5.toml"),
            PathBuf::from("bench_scenes/pyramid_3d_1015.toml"),
            PathBuf::from("bench_scenes/pyramid_3d_5525.toml"),
        ];
        let exported = [PathBuf::from("reports/lcps/tower_5_step30.json")];
        let s = default_suite(false, &scenes, &exported);
        let keys: Vec<String> = s.fc3d_cases.iter().map(|c| c.to_string()).collect();
        // Five FCLIB files, one exported step, two steps of each of pyramid_3d_1015 and
        // fc3d/pyramid_3d_385.
        assert_eq!(keys.len(), 5 + 1 + 2 + 2, "{keys:?}");
        assert!(keys.contains(&"file:reports/lcps/tower_5_step30.json".to_string()));
        for (scene, step) in ["pyramid_3d_1015", "fc3d/pyramid_3d_385"]
            .iter()
            .flat_map(|s| [(s, 1), (s, 10)])
        {
            let key = format!("step:bench_scenes/{scene}.toml?step={step}");
            assert!(keys.contains(&key), "{key} in {keys:?}");
            assert_eq!(key.parse::<Case>().unwrap().to_string(), key);
        }
        assert!(!keys.iter().any(|k| k.contains("pyramid_3d_5525")));
        let cone_jobs: Vec<&Job> = s
            .jobs
            .iter()
            .filter(|j| j.solver.create_cone().is_some())
            .collect();
        assert_eq!(cone_jobs.len(), keys.len() * ConeSolverKind::all().len());
        assert!(cone_jobs
            .iter()
            .all(|j| j.budget.name.as_str() == FC3D_BUDGET && s.fc3d_cases.contains(&j.case)));
    }

    #[test]
    fn the_full_suite_runs_every_matrix_solver_on_the_fclib_files() {
        let scenes = [PathBuf::from("bench_scenes/tower_5.toml")];
        let s = default_suite(false, &scenes, &[]);
        let names: Vec<String> = s.fclib_cases.iter().map(|c| c.to_string()).collect();
        assert_eq!(names.len(), 5, "{names:?}");
        assert!(names.contains(&"file:bench_scenes/fclib/Capsules-i125-1213.hdf5".to_string()));
        let jobs = s
            .jobs
            .iter()
            .filter(|j| s.fclib_cases.contains(&j.case) && j.solver.create_cone().is_none())
            .inspect(|j| {
                let budget = j.budget.name.as_str();
                assert!(
                    budget == FCLIB_BUDGET || budget == FCLIB_FINE_BUDGET,
                    "{budget}"
                );
            })
            .count();
        assert_eq!(jobs, 2 * 5 * SolverKind::all().len());
        // The quick suite keeps the smallest file.
        let quick: Vec<String> = default_suite(true, &scenes, &[])
            .fclib_cases
            .iter()
            .map(|c| c.to_string())
            .collect();
        assert_eq!(
            quick,
            ["file:bench_scenes/fclib/Box_Stacks-i0122-82-5.hdf5"]
        );
    }

    #[test]
    fn friction_cases_cover_each_model_of_the_scenes_present() {
        let scenes: Vec<PathBuf> = [
            "bench_scenes/tower_10_60hz.toml",
            "bench_scenes/tower_5.toml",
        ]
        .iter()
        .map(PathBuf::from)
        .collect();
        let s = default_suite(true, &scenes, &[]);
        let keys: Vec<String> = s.friction_cases.iter().map(|c| c.to_string()).collect();
        assert_eq!(
            keys,
            [
                "scene:bench_scenes/tower_10_60hz.toml?steps=5&friction=box",
                "scene:bench_scenes/tower_10_60hz.toml?steps=5&friction=pyramid",
                "scene:bench_scenes/tower_10_60hz.toml?steps=5&friction=cone",
            ]
        );
        let cone_jobs: Vec<String> = s
            .jobs
            .iter()
            .filter(|j| j.case == s.friction_cases[2])
            .map(|j| j.solver.to_string())
            .collect();
        assert_eq!(
            cone_jobs,
            ["nsgs-cone+warm", "newton-ac+warm", "clarabel-socp"]
        );
    }
}

#[cfg(test)]
mod impact_budget_tests {
    use super::*;

    /// The time-of-impact runs of the shipped scenes keep to the stated budget: every scene
    /// under Timewarp and 60 Hz, no 1 kHz run past 100 balls, no 240 Hz or backtracking run past
    /// 1,000, and the quick suite nothing past 100 balls.
    #[test]
    fn impact_runs_keep_to_their_budget() {
        let scenes =
            vec![PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("bench_scenes/tower_5.toml")];
        let full = impact_cases(&scenes, false);
        let quick = impact_cases(&scenes, true);
        let count = |cases: &[ImpactCase], stem: &str| {
            cases
                .iter()
                .filter(|c| c.scene.file_stem().is_some_and(|s| s == stem))
                .map(|c| c.mode)
                .collect::<Vec<_>>()
        };
        assert_eq!(count(&full, "bouncing_10").len(), 6);
        assert_eq!(count(&full, "fast_sphere_walls").len(), 6);
        assert_eq!(count(&full, "bouncing_1000").len(), 5);
        assert_eq!(
            count(&full, "bouncing_9999"),
            [ImpactMode::Fixed { hz: 60 }, ImpactMode::Timewarp]
        );
        assert!(count(&quick, "bouncing_1000").is_empty());
        assert_eq!(count(&quick, "bouncing_100").len(), 6);
        assert_eq!(bouncing_balls(Path::new("x/bouncing_42.toml")), Some(42));
        assert_eq!(bouncing_balls(Path::new("x/cradle.toml")), None);
    }
}
