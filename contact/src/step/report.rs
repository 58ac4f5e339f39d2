//! What a step reports: the [`StepReport`] with its [`PhaseTimes`] (read off one
//! [`PhaseClock`]), the per-contact [`ContactRecord`]s, and the energy, momentum, penetration
//! and friction-cone figures measured at the end of the step.

use super::solve::Solved;
use super::World;
use crate::builder::{ContactSystem, Partition};
use crate::integrate;
use crate::joint::{summarise_errors, JointError, JointKind};
use crate::substep::StepCost;
use lcpbench_solvers::{ConeProblem, HistoryPoint, Problem, Residuals, Status};
use nalgebra::Vector3;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// A contact and its impulse, for recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactRecord {
    /// Names of the two bodies.
    pub bodies: [Arc<str>; 2],
    /// Indices of the two bodies in [`World::bodies`] at the step's end.
    #[serde(skip)]
    pub body_indices: [usize; 2],
    /// World contact point.
    pub point: [f64; 3],
    /// Unit normal from the first body to the second.
    pub normal: [f64; 3],
    /// Signed gap at detection (negative: penetration).
    pub dist: f64,
    /// Total impulse on the second body (normal plus friction), world frame.
    pub impulse: [f64; 3],
    /// Normal impulse `f_n`.
    pub normal_impulse: f64,
    /// Tangential (friction) impulse on the second body, world frame.
    pub tangent_impulse: [f64; 3],
    /// Velocity of the second body's material point relative to the first's at the contact
    /// point after the step, world frame (its normal part is positive when separating).
    pub relative_velocity: [f64; 3],
    /// Friction coefficient of the contact.
    pub mu: f64,
    /// `w_n`: the normal row of `w = A f + b` at the solved impulse (separation rate the
    /// solver aimed for, bias terms included).
    pub normal_rate: f64,
    /// Complementarity of the normal row, `min(f_n, w_n / A_nn)` in impulse units: zero when
    /// `0 <= f_n ⟂ w_n >= 0` holds, non-zero when it is violated.
    pub complementarity: f64,
}

/// A joint at the end of a step, for recording and drawing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointRecord {
    /// Joint name.
    pub name: Arc<str>,
    /// Kind (`ball`, `hinge`, `fixed`, `distance`).
    pub kind: &'static str,
    /// World anchor of each side at the step's end.
    pub anchors: [[f64; 3]; 2],
    /// Its error at the step's end ([`Joint::error`](crate::joint::Joint::error)).
    pub error: JointError,
    /// Magnitude of the linear impulse of its rows on side b this step, N·s (the rows along
    /// the world axes, or the distance row; 0 when the joint had no rows).
    pub impulse: f64,
}

/// Wall time of the phases of one step, seconds. The phases follow one another and are read off
/// one clock, so they add up to [`StepReport::step_time_s`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct PhaseTimes {
    /// Scheduled events and collision detection: broad plus narrow phase.
    pub collision: f64,
    /// Of `collision`: the broad phase (candidate pairs).
    pub broad_phase: f64,
    /// Of `collision`: the narrow phase (contact manifolds).
    pub narrow_phase: f64,
    /// Free velocities, the contact system (`J`'s rows, `b`, bounds) and the problems the
    /// solver is given (`A = J M⁻¹ Jᵀ` of each island, or of the whole step).
    pub assembly: f64,
    /// The partition of the contacts into islands.
    pub islands: f64,
    /// The solver calls, their own residual measurements excluded.
    pub solve: f64,
    /// Measuring the solved impulse: the shared residual (the solvers' final measurement, and
    /// the assembled `A` body-level solvers are measured on), the contact records and the
    /// step's energy, momentum and penetration figures.
    pub residual: f64,
    /// Split-impulse correction, impulses applied, positions integrated (time of impact
    /// included), warm-start cache updated.
    pub integration: f64,
}

impl PhaseTimes {
    /// The phases' names, as the JSON keys and the report's columns give them.
    pub const NAMES: [&'static str; 6] = [
        "collision",
        "assembly",
        "islands",
        "solve",
        "residual",
        "integration",
    ];

    /// The top-level phases in the order of [`PhaseTimes::NAMES`].
    pub fn values(&self) -> [f64; 6] {
        [
            self.collision,
            self.assembly,
            self.islands,
            self.solve,
            self.residual,
            self.integration,
        ]
    }

    /// Sum of the top-level phases: the step's wall time.
    pub fn total(&self) -> f64 {
        self.values().iter().sum()
    }

    /// Add `other` phase by phase.
    pub fn add(&mut self, other: &PhaseTimes) {
        self.collision += other.collision;
        self.broad_phase += other.broad_phase;
        self.narrow_phase += other.narrow_phase;
        self.assembly += other.assembly;
        self.islands += other.islands;
        self.solve += other.solve;
        self.residual += other.residual;
        self.integration += other.integration;
    }

    /// Split the solve phase's wall time `solve_wall` of `solved`: its shares of assembling the
    /// solvers' problems and of measuring residuals go to those phases, the rest is the solve.
    pub(super) fn add_solve_phase(&mut self, solve_wall: f64, solved: &Solved) {
        let assembly = solved.assembly_s.min(solve_wall);
        let measure = solved.measure_s.min(solve_wall - assembly);
        self.assembly += assembly;
        self.residual += measure;
        self.solve = solve_wall - assembly - measure;
    }

    /// Every phase multiplied by `k` (a mean from a sum).
    pub fn scaled(&self, k: f64) -> PhaseTimes {
        PhaseTimes {
            collision: self.collision * k,
            broad_phase: self.broad_phase * k,
            narrow_phase: self.narrow_phase * k,
            assembly: self.assembly * k,
            islands: self.islands * k,
            solve: self.solve * k,
            residual: self.residual * k,
            integration: self.integration * k,
        }
    }
}

/// A clock read once per phase boundary: each lap is the time since the previous one, so the
/// laps add up to the time since the start.
pub(super) struct PhaseClock {
    start: Instant,
    last: Instant,
}

impl PhaseClock {
    pub(super) fn start() -> Self {
        let now = Instant::now();
        Self {
            start: now,
            last: now,
        }
    }

    pub(super) fn lap(&mut self) -> f64 {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        dt
    }

    fn total(&self) -> f64 {
        self.last.duration_since(self.start).as_secs_f64()
    }
}

/// What one step did and measured.
#[derive(Debug, Clone, Serialize)]
pub struct StepReport {
    /// Step index (0-based).
    pub step: usize,
    /// Simulated time at the end of the step, s.
    pub time: f64,
    /// Contacts detected.
    pub contacts: usize,
    /// Rows of the contact system.
    pub rows: usize,
    /// Solver name.
    pub solver: &'static str,
    /// Solver outcome (decided by the shared residual when one was measured).
    pub status: Status,
    /// Iterations, pivots or sweeps (for a substepping solver: sweeps summed over its
    /// substeps and passes).
    pub iterations: usize,
    /// Substeps the solver split the step into (1 for the solvers that do not substep).
    pub substeps: usize,
    /// The LCP the residual and status are of: `None` for the step's LCP; for a substepping
    /// solver, its last solve (`"relax pass of substep 4 of 4"`), whose LCP has the step's `A`
    /// and that solve's `b`.
    pub residual_of: Option<String>,
    /// Work counted as Catto's solver comparison counts it: constraint-row updates and body
    /// passes. Substepping solvers count their own; for the others it is sweeps × rows and
    /// one body pass (pivoting and interior-point solvers' work is not row updates: their
    /// iterations × rows is a stand-in).
    pub cost: StepCost,
    /// Solver time, s: the sum over islands of each solver call's own time (the work; islands
    /// solved in parallel take less wall time, see `solve_wall_s`).
    pub solve_time_s: f64,
    /// Wall time of the solve phase, s: island extraction and assembly of the sub-problems
    /// plus the (parallel) solver calls.
    pub solve_wall_s: f64,
    /// Independent islands of the step's contacts (contacts sharing no dynamic body).
    pub islands: usize,
    /// Rows of each island, in the order of their first contact.
    pub island_rows: Vec<usize>,
    /// Whole step wall time, s (the sum of [`StepReport::phases`]).
    pub step_time_s: f64,
    /// Wall time of each phase of the step.
    pub phases: PhaseTimes,
    /// Shared residuals of the impulse for the step's LCP (when measured).
    pub residuals: Option<Residuals>,
    /// True when the step's shared residual was measured (`residuals` is set), or the step had
    /// no rows (nothing to solve: its residual is zero). False for a step the schedule
    /// ([`SimSettings::residual`](super::SimSettings::residual)) left out, or whose residual
    /// could not be measured: such a step's status is never `converged`.
    pub residual_measured: bool,
    /// Deepest penetration at detection, m (`>= 0`).
    pub max_penetration: f64,
    /// Mean penetration over contacts, m.
    pub mean_penetration: f64,
    /// Kinetic energy after the step, J.
    pub kinetic_energy: f64,
    /// Potential energy after the step, J.
    pub potential_energy: f64,
    /// Total linear momentum after the step.
    pub linear_momentum: [f64; 3],
    /// Total angular momentum about the origin after the step.
    pub angular_momentum: [f64; 3],
    /// Largest `‖f_t‖ − mu f_n` over contacts (`>= 0`), impulse units.
    pub friction_cone_violation: f64,
    /// With continuous collision detection: the time of impact the step was cut to, s.
    pub time_of_impact: Option<f64>,
    /// Contacts with their impulses.
    pub contact_records: Vec<ContactRecord>,
    /// Joints of the world.
    pub joints: usize,
    /// Equality rows of the joints in the step's problem.
    pub joint_rows: usize,
    /// Largest joint error at the step's end, m: the anchors' separation (ball, hinge, fixed)
    /// or the distance error (distance) ([`Joint::error`](crate::joint::Joint::error)).
    pub joint_drift_max: f64,
    /// Mean of the same over the joints, m.
    pub joint_drift_mean: f64,
    /// Largest angular joint error at the step's end (hinge axes, fixed orientation), rad.
    pub joint_angle_max: f64,
    /// Joints with their anchors and impulses.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub joint_records: Vec<JointRecord>,
    /// The solver's convergence history, when
    /// [`SimSettings::record_history`](super::SimSettings::record_history) is set and the solver
    /// records one (matrix solvers).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub history: Vec<HistoryPoint>,
    /// The step's LCP, when [`SimSettings::keep_problem`](super::SimSettings::keep_problem) is
    /// set (and the solver is not a cone solver).
    #[serde(skip)]
    pub problem: Option<Problem>,
    /// The step's cone problem, when
    /// [`SimSettings::keep_problem`](super::SimSettings::keep_problem) is set and a cone solver
    /// solved the step (friction model `cone`).
    #[serde(skip)]
    pub cone_problem: Option<ConeProblem>,
    /// The warm start the step's matrix or cone solver was given, when
    /// [`SimSettings::keep_problem`](super::SimSettings::keep_problem) is set and the solver was
    /// warm-started.
    #[serde(skip)]
    pub warm_start: Option<Vec<f64>>,
}

impl World {
    /// Per contact: impulses, post-step relative velocity and normal-row complementarity.
    fn contact_records(&self, system: &ContactSystem, f: &[f64]) -> Vec<ContactRecord> {
        if f.len() != system.n() {
            return Vec::new();
        }
        let op = system.operator();
        // Velocity the solve produced: u = u* + M⁻¹ Jᵀ f, so w = J u + bias.
        let mut u = system.free_velocity.clone();
        op.add_response(f, &mut u);
        // One shared name per body, not one copy per contact.
        let names: Vec<Arc<str>> = self
            .bodies
            .iter()
            .map(|b| Arc::from(b.name.as_str()))
            .collect();
        let name = |i: usize| names.get(i).cloned().unwrap_or_else(|| Arc::from(""));
        let velocity = |i: usize, p| {
            self.bodies
                .get(i)
                .map_or(Vector3::zeros(), |b| b.velocity_at(p))
        };
        system
            .contacts
            .iter()
            .enumerate()
            .map(|(c, ct)| {
                let imp = system.contact_impulse(c, f);
                let info = &system.info[c];
                let row = info.normal_row;
                let w_n = op.row_dot(row, &u) + system.bias[row];
                let a_nn = op.diagonal(row);
                let scaled = if a_nn > 0.0 { w_n / a_nn } else { w_n };
                let rel = velocity(ct.body_b, &ct.point) - velocity(ct.body_a, &ct.point);
                ContactRecord {
                    bodies: [name(ct.body_a), name(ct.body_b)],
                    body_indices: [ct.body_a, ct.body_b],
                    point: ct.point.coords.into(),
                    normal: ct.normal.into(),
                    dist: ct.dist,
                    impulse: (ct.normal * imp.normal + imp.tangent).into(),
                    normal_impulse: imp.normal,
                    tangent_impulse: imp.tangent.into(),
                    relative_velocity: rel.into(),
                    mu: info.mu,
                    normal_rate: w_n,
                    complementarity: imp.normal.min(scaled),
                }
            })
            .collect()
    }

    /// Per joint: world anchors, error and the linear impulse of its rows.
    fn joint_records(&self, system: &ContactSystem, f: &[f64]) -> Vec<JointRecord> {
        let mut impulse = vec![0.0; self.joints.len()];
        if f.len() == system.n() {
            for j in &system.joints {
                let linear = match self.joints[j.joint].kind {
                    JointKind::Distance => 1,
                    _ => 3,
                };
                let rows = j.rows.clone().take(linear);
                impulse[j.joint] = rows.map(|i| f[i] * f[i]).sum::<f64>().sqrt();
            }
        }
        self.joints
            .iter()
            .zip(impulse)
            .map(|(j, impulse)| JointRecord {
                name: Arc::from(j.name.as_str()),
                kind: j.kind.name(),
                anchors: [0, 1].map(|k| j.world_anchor(&self.bodies, k).coords.into()),
                error: j.error(&self.bodies),
                impulse,
            })
            .collect()
    }

    pub(super) fn report(
        &self,
        system: &ContactSystem,
        partition: &Partition,
        solved: Solved,
        time_of_impact: Option<f64>,
        mut clock: PhaseClock,
        mut phases: PhaseTimes,
    ) -> StepReport {
        let gravity = self.settings.gravity;
        let pen: Vec<f64> = system.contacts.iter().map(|c| (-c.dist).max(0.0)).collect();
        let max_penetration = pen.iter().copied().fold(0.0, f64::max);
        let mean_penetration = if pen.is_empty() {
            0.0
        } else {
            pen.iter().sum::<f64>() / pen.len() as f64
        };
        let mut lin = Vector3::zeros();
        let mut ang = Vector3::zeros();
        let (mut ke, mut pe) = (0.0, 0.0);
        for b in self.bodies.iter().filter(|b| !b.is_static) {
            lin += b.linear_momentum;
            ang += b.position.coords.cross(&b.linear_momentum) + b.angular_momentum;
            ke += integrate::kinetic_energy(b);
            pe += integrate::potential_energy(b, &gravity);
        }
        let f = &solved.f;
        let contact_records = self.contact_records(system, f);
        let joint_records = self.joint_records(system, f);
        let errors: Vec<JointError> = joint_records.iter().map(|j| j.error).collect();
        let (joint_drift_max, joint_drift_mean, joint_angle_max) = summarise_errors(&errors);
        let friction_cone_violation = if f.len() == system.n() {
            system.friction_cone_violation(f)
        } else {
            0.0
        };
        phases.residual += clock.lap();
        let residual_measured = solved.residuals.is_some() || system.n() == 0;
        // Only the shared residual says `converged`: a step without it never does (the solve
        // paths already decide so; this keeps it true of every path).
        let status = if residual_measured || !solved.status.is_converged() {
            solved.status
        } else {
            Status::Stalled {
                reason: "the shared residual of this step was not measured".into(),
            }
        };
        StepReport {
            step: self.step_index - 1,
            time: self.time,
            contacts: system.contacts.len(),
            rows: system.n(),
            solver: self.settings.solver.name(),
            status,
            iterations: solved.iterations,
            substeps: solved.substepped.as_ref().map_or(1, |s| s.substeps),
            residual_of: solved.substepped.as_ref().map(|s| s.residual_of.clone()),
            cost: solved.substepped.as_ref().map_or(
                StepCost {
                    row_updates: (solved.iterations * system.n()) as u64,
                    body_passes: 1,
                },
                |s| s.cost,
            ),
            solve_time_s: solved.time_s,
            solve_wall_s: solved.wall_s,
            islands: partition.len(),
            island_rows: partition.islands.iter().map(|i| i.rows.len()).collect(),
            step_time_s: clock.total(),
            phases,
            residuals: solved.residuals,
            residual_measured,
            max_penetration,
            mean_penetration,
            kinetic_energy: ke,
            potential_energy: pe,
            linear_momentum: lin.into(),
            angular_momentum: ang.into(),
            friction_cone_violation,
            contact_records,
            joints: self.joints.len(),
            joint_rows: system.joint_row_count(),
            joint_drift_max,
            joint_drift_mean,
            joint_angle_max,
            joint_records,
            history: solved.history,
            time_of_impact,
            problem: if self.settings.keep_problem {
                solved.problem
            } else {
                None
            },
            cone_problem: if self.settings.keep_problem {
                solved.cone_problem
            } else {
                None
            },
            warm_start: solved.warm_start,
        }
    }
}
