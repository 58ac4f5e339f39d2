//! Sharded sweeps: the K-th of N deterministic parts of one sweep, so a sweep too large for one
//! machine runs as N independent processes (a Slurm array, GNU parallel, a shell loop) whose
//! output directories [`merge`](crate::harness::merge) joins into exactly the rows of the
//! unsharded sweep.
//!
//! **Same parts whatever runs them.** The jobs are taken once each (by run key) in the sweep's
//! order, and each gets an expected cost from [`CostModel`], which reads only the sweep's own
//! inputs (case keys, budgets, scene and problem files). The costs are assigned to the N shards
//! by greedy longest-processing-time scheduling ([`partition`]): jobs by decreasing cost (ties
//! by position), each to the shard with the least cost so far (ties to the lower shard). Every
//! worker computes the same assignment, whatever its `--jobs`, and a shard runs its jobs in the
//! sweep's order.
//!
//! **Balanced by expected cost, not by count.** One scene run at budget `default` can cost as
//! much as a thousand small LCP solves, so equal counts would leave one shard with most of the
//! work. The model, in seconds, with `iterations` the budget's iteration cap up to 10,000:
//!
//! ```text
//! every run   START_S = 0.01                                (child process, loading the case)
//! LCP, n rows + timed(min(budget seconds, 1e-9 · n² · iterations))   (dense O(n²) sweeps)
//! scene       + steps · (2e-5 · bodies                                (detection, integration)
//!                        + min(budget seconds, 1.2e-8 · bodies² · iterations))  (one solve)
//! ```
//!
//! with `timed(s)` the solver seconds of timing a solve of `s` seconds by repeating it
//! ([`crate::harness::timing::expected_seconds`]: `s` itself from 20 ms on, else `s` plus
//! about 20 ms of repeats), `n` from the case key (generated families) or the problem file,
//! and `steps` (the planned steps) and `bodies` (the dynamic bodies) from the scene file. A solve's cost grows
//! with the square of the bodies because a taller stack has both more contact rows and needs
//! more sweeps; the constant matches the median run over the solvers of the 10- and 40-box
//! towers in the quick report on a 2-core machine. A case whose file does not load costs
//! `START_S` (its run records the error at once). Greedy LPT ends each shard within the largest
//! single job of the mean (and within 4/3 of the best possible balance).
//!
//! **Each shard directory says what it is.** `shard.json` ([`ShardManifest`]) records the
//! sweep's identity ([`ShardPlan::sweep_id`]: a hash of the kind of sweep and the ordered list of
//! run keys), the kind (`bench`, `report-quick`, `report-full`), the lcpbench commit, K, N, the
//! job count and this shard's keys with their positions in the sweep. The report's LCPs
//! exported from scenes live under the output directory, so their `file:` keys are written
//! with the directory as `$OUT` ([`portable_case`]): shards written to different directories
//! are parts of the same sweep.

use crate::harness::case::Case;
use crate::harness::record::RunKey;
use crate::harness::sweep::Job;
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet};
use std::fmt;
use std::path::{Path, PathBuf};

/// File name of a shard directory's manifest.
pub const MANIFEST: &str = "shard.json";

/// What the output directory stands for in the `file:` keys of a report's exported LCPs.
pub const OUT_PLACEHOLDER: &str = "$OUT";

/// Largest `shard.json` read, bytes (a shard of a million runs lists them in about 150 MB).
pub const MAX_MANIFEST_BYTES: u64 = 256_000_000;

/// Seconds every run costs in the cost model: starting the child process and loading the case.
pub const START_S: f64 = 0.01;

/// Errors of sharded sweeps.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    /// `--shard` is not `K/N` with `1 <= K <= N`.
    #[error("`{0}` is not K/N with 1 <= K <= N (e.g. 2/8, the second of eight parts)")]
    BadSpec(String),
    /// A manifest could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A manifest is not valid JSON of a shard.
    #[error("{path} is not an lcpbench shard manifest: {source}")]
    BadManifest {
        /// The file.
        path: PathBuf,
        /// Why.
        source: serde_json::Error,
    },
    /// The directory already holds another shard, or the same shard of another sweep.
    #[error("{dir} holds {existing}; this run is {new}: give this shard its own output directory")]
    Mismatch {
        /// The directory.
        dir: PathBuf,
        /// What its manifest says.
        existing: String,
        /// What this run is.
        new: String,
    },
    /// The directory holds rows of a sweep run without `--shard`.
    #[error(
        "{dir} holds the rows of a sweep run without --shard; give shard {shard} its own output \
         directory"
    )]
    UnshardedRows {
        /// The directory.
        dir: PathBuf,
        /// The shard to be run.
        shard: Shard,
    },
    /// A sweep without `--shard` was pointed at a shard's directory.
    #[error(
        "{dir} holds shard {shard} of a sharded sweep ({manifest}); run it with --shard {shard} \
         to resume it, or choose another output directory"
    )]
    ShardDirectory {
        /// The directory.
        dir: PathBuf,
        /// Its shard.
        shard: Shard,
        /// The manifest's path.
        manifest: PathBuf,
    },
}

/// The K-th of N parts of a sweep (1-based, as Slurm numbers the tasks of `--array=1-N`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Shard {
    /// K, from 1.
    pub index: usize,
    /// N, at least 1.
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = ShardError;

    fn from_str(s: &str) -> Result<Self, ShardError> {
        let bad = || ShardError::BadSpec(s.to_owned());
        let (k, n) = s.trim().split_once('/').ok_or_else(bad)?;
        let index: usize = k.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(out, "{}/{}", self.index, self.count)
    }
}

/// What a sweep is, which fixes the layout of its directory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SweepKind {
    /// `lcpbench bench`: `results.csv` and `histories.csv` in the directory itself.
    Bench,
    /// `lcpbench report --quick`: `data/results.csv`, `data/histories.csv` and `lcps/`.
    ReportQuick,
    /// `lcpbench report`: the same layout.
    ReportFull,
}

impl SweepKind {
    /// The report's suite, quick or full.
    pub fn report(quick: bool) -> Self {
        if quick {
            SweepKind::ReportQuick
        } else {
            SweepKind::ReportFull
        }
    }

    /// The name written in manifests.
    pub fn name(self) -> &'static str {
        match self {
            SweepKind::Bench => "bench",
            SweepKind::ReportQuick => "report-quick",
            SweepKind::ReportFull => "report-full",
        }
    }

    /// Where `results.csv` and `histories.csv` are in a directory of this kind.
    pub fn data_dir(self, dir: &Path) -> PathBuf {
        match self {
            SweepKind::Bench => dir.to_owned(),
            SweepKind::ReportQuick | SweepKind::ReportFull => dir.join("data"),
        }
    }

    /// Where the LCPs exported from scenes are (report sweeps only).
    pub fn exports_dir(self, dir: &Path) -> Option<PathBuf> {
        match self {
            SweepKind::Bench => None,
            SweepKind::ReportQuick | SweepKind::ReportFull => Some(dir.join("lcps")),
        }
    }
}

impl fmt::Display for SweepKind {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        out.pad(self.name())
    }
}

/// A case key with the output directory `out` written as [`OUT_PLACEHOLDER`], for a `file:`
/// case under `out`; other keys unchanged.
pub fn portable_case(case: &str, out: &Path) -> String {
    let Some(path) = case.strip_prefix("file:") else {
        return case.to_owned();
    };
    match Path::new(path).strip_prefix(out) {
        Ok(rel) if !rel.as_os_str().is_empty() => {
            format!("file:{OUT_PLACEHOLDER}/{}", rel.display())
        }
        _ => case.to_owned(),
    }
}

/// The inverse of [`portable_case`]: a `file:$OUT/…` key with `$OUT` replaced by `out`.
pub fn rooted_case(case: &str, out: &Path) -> String {
    match case.strip_prefix(&format!("file:{OUT_PLACEHOLDER}/")) {
        Some(rel) => format!("file:{}", out.join(rel).display()),
        None => case.to_owned(),
    }
}

/// A run key in its portable form (see [`portable_case`]).
fn portable_key(key: &RunKey, out: &Path) -> RunKey {
    RunKey::new(&portable_case(&key.case, out), &key.solver, &key.budget)
}

/// The expected cost of runs (see the module documentation), with the scene and problem files
/// it reads loaded once each.
#[derive(Debug, Default)]
pub struct CostModel {
    /// Per scene file: dynamic bodies and the scene's own step count (`None`: does not load).
    scenes: HashMap<PathBuf, Option<(usize, usize)>>,
    /// Per problem file: its rows (`None`: does not load).
    files: HashMap<PathBuf, Option<usize>>,
}

impl CostModel {
    /// Expected seconds of one run.
    pub fn seconds(&mut self, job: &Job) -> f64 {
        let budget = &job.budget.budget;
        let iterations = budget.max_iterations.min(10_000) as f64;
        let time_s = budget.time_s;
        START_S
            + match &job.case {
                Case::Generated { n, .. } => lcp_seconds(*n, iterations, time_s),
                Case::File(path) => {
                    let rows = *self
                        .files
                        .entry(path.clone())
                        .or_insert_with(|| job.case.load_lcp().ok().map(|lcp| lcp.problem.n()));
                    rows.map_or(0.0, |n| lcp_seconds(n, iterations, time_s))
                }
                Case::SceneStep { path, step } => {
                    // The steps before it simulated, then a problem of about
                    // `ROWS_PER_BODY` rows per dynamic body solved.
                    const ROWS_PER_BODY: usize = 30;
                    self.scene(path).map_or(0.0, |(bodies, _)| {
                        let simulate = (*step as f64 + 1.0) * 2e-5 * bodies as f64;
                        simulate + lcp_seconds(ROWS_PER_BODY * bodies, iterations, time_s)
                    })
                }
                Case::Scene { path, steps, .. } => self.scene(path).map_or(0.0, |(bodies, own)| {
                    let steps = steps.map_or(own, |cap| cap.min(own)) as f64;
                    let bodies = bodies as f64;
                    let solve = (1.2e-8 * bodies * bodies * iterations).min(time_s);
                    steps * (2e-5 * bodies + solve)
                }),
            }
    }

    /// Dynamic bodies and own step count of the scene at `path`, loaded once.
    fn scene(&mut self, path: &std::path::Path) -> Option<(usize, usize)> {
        *self.scenes.entry(path.to_path_buf()).or_insert_with(|| {
            lcpbench_contact::scene::Scene::load(path).ok().map(|s| {
                let bodies = s.bodies.iter().filter(|b| !b.is_static).count();
                (bodies, s.settings.steps)
            })
        })
    }

    /// Expected cost of one run in whole microseconds (integers, so that every machine sums
    /// them to the same loads).
    pub fn micros(&mut self, job: &Job) -> u64 {
        (self.seconds(job) * 1e6).round() as u64
    }
}

/// Seconds of timing a solve of `n` rows: a dense sweep per iteration, at most the budget's
/// seconds, repeated as [`crate::harness::timing`] repeats it. (The iteration count is the
/// cap, so the model ranks solves by their worst case.)
fn lcp_seconds(n: usize, iterations: f64, time_s: f64) -> f64 {
    let n = n as f64;
    crate::harness::timing::expected_seconds((1e-9 * n * n * iterations).min(time_s))
}

/// Greedy longest-processing-time assignment of jobs with `costs` to `count` shards: jobs by
/// decreasing cost (ties by position), each to the shard with the least total so far (ties to
/// the lower shard). Returns each job's shard, 0-based.
///
/// Memory is that of the jobs, whatever `count`: with more shards than jobs, the jobs in
/// decreasing cost take shards 1, 2, … in turn (every earlier shard holds more), and shards
/// past the job count get no job, so only the first `min(count, jobs)` shards are kept.
pub fn partition(costs: &[u64], count: usize) -> Vec<usize> {
    let count = count.clamp(1, costs.len().max(1));
    let mut order: Vec<usize> = (0..costs.len()).collect();
    order.sort_by_key(|&i| (Reverse(costs[i]), i));
    let mut loads: BinaryHeap<Reverse<(u64, usize)>> =
        (0..count).map(|s| Reverse((0, s))).collect();
    let mut shard_of = vec![0; costs.len()];
    for i in order {
        if let Some(Reverse((load, s))) = loads.pop() {
            shard_of[i] = s;
            loads.push(Reverse((load + costs[i], s)));
        }
    }
    shard_of
}

/// 64-bit FNV-1a: a stable hash (the same on every machine and Rust release), for naming a
/// sweep; not a defence against a crafted collision.
fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The identity of a sweep: the hash of its kind and ordered run keys (portable form), as 16
/// hexadecimal digits.
pub fn sweep_id<'a>(kind: SweepKind, keys: impl IntoIterator<Item = &'a RunKey>) -> String {
    let mut text = format!("lcpbench sweep\n{}\n", kind.name());
    for k in keys {
        text.push_str(&format!("{}\u{1f}{}\u{1f}{}\n", k.case, k.solver, k.budget));
    }
    format!("{:016x}", fnv1a(text.into_bytes()))
}

/// A sweep split into parts: its jobs once each, in order, their portable keys, expected costs
/// and identity.
#[derive(Debug, Clone)]
pub struct ShardPlan {
    kind: SweepKind,
    out: PathBuf,
    jobs: Vec<Job>,
    keys: Vec<RunKey>,
    costs: Vec<u64>,
    id: String,
}

impl ShardPlan {
    /// Plan the sweep of `jobs` (a job repeating an earlier one's key is dropped, as the sweep
    /// drops it) written to `out`.
    pub fn new(kind: SweepKind, jobs: Vec<Job>, out: &Path) -> Self {
        let mut seen = HashSet::new();
        let jobs: Vec<Job> = jobs.into_iter().filter(|j| seen.insert(j.key())).collect();
        let keys: Vec<RunKey> = jobs
            .iter()
            .map(|j| match kind {
                SweepKind::Bench => j.key(),
                _ => portable_key(&j.key(), out),
            })
            .collect();
        let mut model = CostModel::default();
        let costs = jobs.iter().map(|j| model.micros(j)).collect();
        let id = sweep_id(kind, &keys);
        Self {
            kind,
            out: out.to_owned(),
            jobs,
            keys,
            costs,
            id,
        }
    }

    /// The sweep's identity (see [`sweep_id`]).
    pub fn sweep_id(&self) -> &str {
        &self.id
    }

    /// Jobs of the sweep, once each.
    pub fn len(&self) -> usize {
        self.jobs.len()
    }

    /// True when the sweep has no jobs.
    pub fn is_empty(&self) -> bool {
        self.jobs.is_empty()
    }

    /// Expected cost of each job, microseconds.
    pub fn costs(&self) -> &[u64] {
        &self.costs
    }

    /// Positions (in the sweep) of the jobs of `shard`, increasing.
    pub fn positions(&self, shard: Shard) -> Vec<usize> {
        partition(&self.costs, shard.count)
            .into_iter()
            .enumerate()
            .filter(|&(_, s)| s + 1 == shard.index)
            .map(|(i, _)| i)
            .collect()
    }

    /// The jobs of `shard`, in the sweep's order.
    pub fn jobs(&self, shard: Shard) -> Vec<Job> {
        self.positions(shard)
            .into_iter()
            .map(|i| self.jobs[i].clone())
            .collect()
    }

    /// The manifest of `shard` for a sweep run at lcpbench commit `commit`.
    pub fn manifest(&self, shard: Shard, commit: &str) -> ShardManifest {
        let positions = self.positions(shard);
        let micros: u64 = positions.iter().map(|&i| self.costs[i]).sum();
        ShardManifest {
            sweep: self.id.clone(),
            kind: self.kind,
            commit: commit.to_owned(),
            shard: shard.index,
            shards: shard.count,
            jobs: self.jobs.len(),
            out: self.out.to_string_lossy().into_owned(),
            expected_s: micros as f64 * 1e-6,
            keys: positions
                .into_iter()
                .map(|i| ShardKey {
                    index: i,
                    case: self.keys[i].case.clone(),
                    solver: self.keys[i].solver.clone(),
                    budget: self.keys[i].budget.clone(),
                })
                .collect(),
        }
    }
}

/// `shard.json`: what a shard directory holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardManifest {
    /// Identity of the whole sweep ([`sweep_id`]).
    pub sweep: String,
    /// Kind of sweep (and layout of the directory).
    pub kind: SweepKind,
    /// The lcpbench commit the shard ran at (`+dirty` for a tree with changes).
    pub commit: String,
    /// K.
    pub shard: usize,
    /// N.
    pub shards: usize,
    /// Jobs of the whole sweep.
    pub jobs: usize,
    /// The output directory as the shard's run keys name it (what `$OUT` stands for).
    pub out: String,
    /// Expected seconds of this shard's runs under the cost model.
    pub expected_s: f64,
    /// This shard's run keys (portable form) and their positions in the sweep, in order.
    pub keys: Vec<ShardKey>,
}

/// One run of a shard: its position in the sweep and its key.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardKey {
    /// Position in the sweep's job list, from 0.
    pub index: usize,
    /// Case key (portable form).
    pub case: String,
    /// Solver specification.
    pub solver: String,
    /// Budget name.
    pub budget: String,
}

impl ShardKey {
    /// The run key (portable form).
    pub fn key(&self) -> RunKey {
        RunKey::new(&self.case, &self.solver, &self.budget)
    }
}

impl ShardManifest {
    /// Which shard.
    pub fn shard(&self) -> Shard {
        Shard {
            index: self.shard,
            count: self.shards,
        }
    }

    /// One line saying what this is, for messages.
    pub fn describe(&self) -> String {
        format!(
            "shard {} of {} sweep {} at commit {}",
            self.shard(),
            self.kind,
            self.sweep,
            self.commit
        )
    }

    /// The output directory the run keys name.
    pub fn out_dir(&self) -> PathBuf {
        PathBuf::from(&self.out)
    }

    /// Write to `dir/shard.json`.
    pub fn write(&self, dir: &Path) -> Result<(), ShardError> {
        let path = dir.join(MANIFEST);
        let text =
            serde_json::to_string_pretty(self).map_err(|source| ShardError::BadManifest {
                path: path.clone(),
                source,
            })?;
        std::fs::write(&path, text + "\n").map_err(|source| ShardError::Io { path, source })
    }
}

/// The manifest in `dir`, if it has one.
pub fn read_manifest(dir: &Path) -> Result<Option<ShardManifest>, ShardError> {
    let path = dir.join(MANIFEST);
    // A regular file within a bound (a link to a device or a huge file is refused unread).
    let text = match lcpbench_solvers::io::input::read_input_file(&path, MAX_MANIFEST_BYTES) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(ShardError::Io { path, source }),
    };
    serde_json::from_slice(&text)
        .map(Some)
        .map_err(|source| ShardError::BadManifest { path, source })
}

/// Make `dir` the directory of the shard `manifest` describes, whose rows go to `data_dir`
/// (the caller holds the sweep's lock on it): a directory without a manifest and without rows
/// gets `manifest`; one whose manifest names the same shard of the same sweep at the same commit
/// is resumed; anything else is refused.
pub fn claim(dir: &Path, data_dir: &Path, manifest: &ShardManifest) -> Result<(), ShardError> {
    match read_manifest(dir)? {
        Some(existing) => {
            let (was, is) = (existing.describe(), manifest.describe());
            if existing.keys == manifest.keys && was == is {
                Ok(())
            } else if was == is {
                // Same names, other runs: the build changed without a new commit (`+dirty`).
                Err(ShardError::Mismatch {
                    dir: dir.to_owned(),
                    existing: format!("{was} with other runs"),
                    new: is,
                })
            } else {
                Err(ShardError::Mismatch {
                    dir: dir.to_owned(),
                    existing: was,
                    new: is,
                })
            }
        }
        None => {
            let results = data_dir.join("results.csv");
            if std::fs::metadata(&results).is_ok_and(|m| m.len() > 0) {
                return Err(ShardError::UnshardedRows {
                    dir: dir.to_owned(),
                    shard: manifest.shard(),
                });
            }
            manifest.write(dir)
        }
    }
}

/// Refuse to run a sweep without `--shard` in a shard's directory `dir`.
pub fn refuse_shard_directory(dir: &Path) -> Result<(), ShardError> {
    match read_manifest(dir)? {
        Some(m) => Err(ShardError::ShardDirectory {
            dir: dir.to_owned(),
            shard: m.shard(),
            manifest: dir.join(MANIFEST),
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::cross_product;
    use crate::harness::{NamedBudget, SolverSpec};

    fn named(spec: &str) -> NamedBudget {
        spec.parse().unwrap()
    }

    fn sweep() -> Vec<Job> {
        let cases: Vec<Case> = [10, 50, 200, 400]
            .iter()
            .flat_map(|&n| (1..=3).map(move |seed| Case::spd(n, 1e4, seed)))
            .chain([Case::scene("bench_scenes/tower_10.toml", Some(20))])
            .collect();
        let solvers: Vec<SolverSpec> = ["pgs", "lemke", "newton-fb", "sor@1.3"]
            .iter()
            .map(|s| s.parse().unwrap())
            .collect();
        cross_product(&cases, &solvers, &[named("default"), named("tight")])
    }

    #[test]
    fn shard_specs_parse_and_refuse_what_is_not_k_of_n() {
        assert_eq!(
            "2/8".parse::<Shard>().unwrap(),
            Shard { index: 2, count: 8 }
        );
        assert_eq!("1/1".parse::<Shard>().unwrap().to_string(), "1/1");
        for bad in ["0/3", "4/3", "3", "a/3", "1/0", "-1/3", "1/3/4", ""] {
            let err = bad.parse::<Shard>().unwrap_err();
            assert!(err.to_string().contains("is not K/N"), "{bad}: {err}");
        }
    }

    /// Every job in exactly one shard, the same assignment on every call, and each shard's
    /// expected cost within the largest job of the mean (greedy list scheduling's bound), for
    /// several shard counts; a count-balanced split of the same jobs is much worse.
    #[test]
    fn the_partition_is_deterministic_complete_and_balanced_by_cost() {
        let plan = ShardPlan::new(SweepKind::Bench, sweep(), Path::new("out"));
        let costs = plan.costs();
        let total: u64 = costs.iter().sum();
        let largest = *costs.iter().max().unwrap();
        assert!(largest > 5 * costs.iter().min().unwrap(), "{costs:?}");
        for count in [1, 2, 3, 7, 40] {
            let mut seen = vec![0; plan.len()];
            let mut loads = Vec::new();
            for index in 1..=count {
                let shard = Shard { index, count };
                let positions = plan.positions(shard);
                assert_eq!(positions, plan.positions(shard));
                assert!(positions.windows(2).all(|w| w[0] < w[1]));
                for &i in &positions {
                    seen[i] += 1;
                }
                loads.push(positions.iter().map(|&i| costs[i]).sum::<u64>());
                let again = ShardPlan::new(SweepKind::Bench, sweep(), Path::new("elsewhere"));
                assert_eq!(again.jobs(shard), plan.jobs(shard));
            }
            assert!(seen.iter().all(|&c| c == 1), "count {count}: {seen:?}");
            assert_eq!(loads.iter().sum::<u64>(), total);
            let mean = total / count as u64;
            for load in &loads {
                assert!(*load <= mean + largest, "count {count}: {loads:?}");
            }
        }
        // Three shards by count (consecutive thirds) against by cost.
        let count_split = costs
            .chunks(costs.len().div_ceil(3))
            .map(|c| c.iter().sum::<u64>())
            .max()
            .unwrap();
        let cost_split = (1..=3)
            .map(|index| {
                plan.positions(Shard { index, count: 3 })
                    .iter()
                    .map(|&i| costs[i])
                    .sum::<u64>()
            })
            .max()
            .unwrap();
        assert!(
            cost_split * 10 < count_split * 9,
            "{cost_split} {count_split}"
        );
        assert!(cost_split <= total / 3 + largest);
    }

    /// More shards than jobs: the assignment is that of one shard per job, shards past the job
    /// count are empty, and nothing is allocated per shard (a count of `usize::MAX` would
    /// otherwise overflow, and one of 1e9 would take gigabytes).
    #[test]
    fn a_huge_shard_count_costs_no_memory_and_leaves_the_later_shards_empty() {
        let costs = [5, 1, 9, 3];
        let per_job = partition(&costs, costs.len());
        assert_eq!(partition(&costs, 1_000_000_000), per_job);
        assert_eq!(partition(&costs, usize::MAX), per_job);
        // Decreasing cost takes shards 0, 1, 2, 3 in turn.
        assert_eq!(per_job, vec![1, 3, 0, 2]);
        let plan = ShardPlan::new(SweepKind::Bench, sweep(), Path::new("out"));
        let huge = |index| Shard {
            index,
            count: usize::MAX,
        };
        let firsts: usize = (1..=plan.len())
            .map(|k| plan.positions(huge(k)).len())
            .sum();
        assert_eq!(firsts, plan.len());
        assert!(plan.jobs(huge(usize::MAX)).is_empty());
        assert!(plan.manifest(huge(plan.len() + 1), "abc").keys.is_empty());
        let spec = format!("1/{}", usize::MAX);
        assert_eq!(spec.parse::<Shard>().unwrap(), huge(1));
    }

    #[test]
    fn greedy_assignment_puts_the_largest_jobs_apart() {
        // Two large jobs and six small ones on two shards: one large job each, small ones split.
        let costs = [1, 100, 1, 1, 100, 1, 1, 1];
        let shards = partition(&costs, 2);
        assert_ne!(shards[1], shards[4]);
        let load = |s| {
            costs
                .iter()
                .zip(&shards)
                .filter(|(_, &t)| t == s)
                .map(|(c, _)| c)
                .sum::<u64>()
        };
        assert_eq!((load(0), load(1)), (103, 103));
        assert_eq!(partition(&[], 3), Vec::<usize>::new());
    }

    #[test]
    fn the_cost_model_grows_with_size_budget_and_steps() {
        let mut model = CostModel::default();
        let job = |case: &str, budget: &str| Job {
            case: case.parse().unwrap(),
            solver: "pgs".parse().unwrap(),
            budget: named(budget),
        };
        let small = model.seconds(&job("spd:n=10:cond=1e2:seed=1", "default"));
        let large = model.seconds(&job("spd:n=400:cond=1e2:seed=1", "default"));
        let realtime = model.seconds(&job("spd:n=400:cond=1e2:seed=1", "realtime"));
        assert!(
            small < large && realtime < large,
            "{small} {large} {realtime}"
        );
        // Capped by the budget's seconds.
        let capped = model.seconds(&job("spd:n=4000:cond=1e2:seed=1", "1e-8:10000:0.5"));
        assert!((capped - (START_S + 0.5)).abs() < 1e-12, "{capped}");
        let short = model.seconds(&job("scene:bench_scenes/tower_40.toml?steps=5", "default"));
        let long = model.seconds(&job("scene:bench_scenes/tower_40.toml?steps=20", "default"));
        let few = model.seconds(&job("scene:bench_scenes/tower_5.toml?steps=20", "default"));
        assert!(short < long && few < long, "{short} {long} {few}");
        assert!(long > large, "{long} {large}");
        // A file that does not load costs the start only.
        assert_eq!(model.seconds(&job("file:no/such.json", "default")), START_S);
    }

    #[test]
    fn exported_lcp_keys_name_the_output_directory_as_a_placeholder() {
        let out = Path::new("shards/3");
        let key = "file:shards/3/lcps/arch_step30.json";
        let portable = portable_case(key, out);
        assert_eq!(portable, "file:$OUT/lcps/arch_step30.json");
        assert_eq!(
            rooted_case(&portable, Path::new("merged")),
            "file:merged/lcps/arch_step30.json"
        );
        for other in ["file:bench_scenes/fclib/a.hdf5", "spd:n=8:cond=1e2:seed=1"] {
            assert_eq!(portable_case(other, out), other);
            assert_eq!(rooted_case(other, out), other);
        }
        // Two report shards in different directories are the same sweep.
        let jobs = |dir: &str| {
            let cases = [Case::File(Path::new(dir).join("lcps").join("a_step3.json"))];
            cross_product(&cases, &["pgs".parse().unwrap()], &[named("default")])
        };
        let a = ShardPlan::new(SweepKind::ReportQuick, jobs("a"), Path::new("a"));
        let b = ShardPlan::new(SweepKind::ReportQuick, jobs("b"), Path::new("b"));
        assert_eq!(a.sweep_id(), b.sweep_id());
        let c = ShardPlan::new(SweepKind::ReportFull, jobs("a"), Path::new("a"));
        assert_ne!(a.sweep_id(), c.sweep_id());
    }

    #[test]
    fn a_directory_is_claimed_by_one_shard_of_one_sweep() {
        let dir = tempfile::tempdir().unwrap();
        let plan = ShardPlan::new(SweepKind::Bench, sweep(), dir.path());
        let first = plan.manifest(Shard { index: 1, count: 3 }, "abc");
        claim(dir.path(), dir.path(), &first).unwrap();
        assert_eq!(read_manifest(dir.path()).unwrap(), Some(first.clone()));
        // The same shard resumes; another shard or commit is refused.
        claim(dir.path(), dir.path(), &first).unwrap();
        let second = plan.manifest(Shard { index: 2, count: 3 }, "abc");
        let err = claim(dir.path(), dir.path(), &second)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("holds shard 1/3") && err.contains("this run is shard 2/3"),
            "{err}"
        );
        let later = plan.manifest(Shard { index: 1, count: 3 }, "def");
        assert!(claim(dir.path(), dir.path(), &later).is_err());
        let mut other_runs = first.clone();
        other_runs.keys.pop();
        let err = claim(dir.path(), dir.path(), &other_runs)
            .unwrap_err()
            .to_string();
        assert!(err.contains("with other runs"), "{err}");
        assert!(refuse_shard_directory(dir.path()).is_err());
        // A directory with rows of an unsharded sweep is refused.
        let other = tempfile::tempdir().unwrap();
        std::fs::write(other.path().join("results.csv"), "case\n").unwrap();
        let err = claim(other.path(), other.path(), &first)
            .unwrap_err()
            .to_string();
        assert!(err.contains("without --shard"), "{err}");
        assert!(refuse_shard_directory(other.path()).is_ok());
    }
}
