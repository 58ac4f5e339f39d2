//! Velocity-level time stepping (Stewart–Trinkle 1996, Anitescu–Potra 1997).
//!
//! One step of size `h`, in [`World::step`]:
//!
//! 1. **detect** contacts at the current positions (with a prediction distance, so resting and
//!    approaching contacts are in the problem before they touch; bodies joined by a joint do
//!    not collide with each other);
//! 2. **build** the contact system at the free velocity `u* = u + h M⁻¹ f_ext`, the joints'
//!    equality rows after the contacts' ([`builder::build_with_joints`]);
//! 3. **solve** it for the impulse `f` with the chosen solver (a matrix solver on
//!    `A = J M⁻¹ Jᵀ`, a body-level solver on the matrix-free operator, or, for the friction
//!    model `cone`, a cone solver on the FC3D problem `W = A`, `q = b`); islands are solved
//!    separately, in parallel;
//! 4. **apply** the impulses to the momenta and **integrate** the positions
//!    ([`integrate`]: symplectic Euler for bodies that received an impulse, RK4 for free
//!    flight), moving by the split-impulse pseudo-velocity too when that correction is chosen;
//! 5. **measure**: a [`StepReport`] with contacts, rows, solver status and residuals,
//!    penetration, energy, momenta and friction-cone violation.
//!
//! This module holds the [`World`], its step loop, events, and the apply-and-integrate phase;
//! the other phases and types live in modules of their own, re-exported here: `settings`
//! ([`SimSettings`]), `contact_solver` ([`ContactSolver`]: the solver instance and what it
//! takes), `solve` (the solve phase: warm start, deadline, per-island solves in parallel) and
//! `report` ([`StepReport`], [`PhaseTimes`], [`ContactRecord`]).
//!
//! ```
//! use lcpbench_contact::{ContactSolver, Scene};
//! use std::path::Path;
//!
//! let scene = Scene::parse(
//!     r#"
//!     [settings]
//!     dt = 0.01
//!     [[bodies]]
//!     name = "ground"
//!     shape = { type = "plane", normal = [0.0, 0.0, 1.0] }
//!     static = true
//!     [[bodies]]
//!     name = "box"
//!     shape = { type = "box", half_extents = [0.5, 0.5, 0.5] }
//!     position = [0.0, 0.0, 0.5]
//!     "#,
//!     Path::new("example.toml"),
//! )
//! .unwrap();
//! let mut world = scene.world();
//! world.set_solver(ContactSolver::from_name("si").unwrap());
//! let report = world.step();
//! assert_eq!(report.contacts, 4); // one face on the ground: four contact points
//! assert!(report.status.is_converged());
//! assert!((world.bodies[1].position.z - 0.5).abs() < 1e-9); // it rests
//! ```

mod contact_solver;
mod island_solvers;
mod report;
mod settings;
mod solve;

pub use contact_solver::ContactSolver;
pub use report::{ContactRecord, JointRecord, PhaseTimes, StepReport};
pub use settings::{ResidualSchedule, SimSettings, MAX_RESIDUAL_SAMPLE};

use crate::body::RigidBody;
use crate::builder::PositionCorrection;
use crate::builder::{self, BodyVelocity, ContactSystem, Material, WarmStartCache};
use crate::collision::broad_phase::TooManyPairs;
use crate::collision::toi::{first_impact, ToiSettings};
use crate::collision::{CollisionPipeline, Contact};
use crate::integrate;
use crate::joint::Joint;
use island_solvers::IslandSolvers;
use lcpbench_solvers::{ProjectedSor, Solver, Status};
use report::PhaseClock;
use serde::Serialize;
use solve::Solved;

/// A scheduled change to the scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Event {
    /// Applied before step `at_step` (0-based).
    pub at_step: usize,
    /// Remove the body of this name (or every copy of a repeated body of this name).
    pub remove: String,
}

/// Bodies, materials, settings and the state carried between steps.
pub struct World {
    /// The bodies.
    pub bodies: Vec<RigidBody>,
    /// For each body, the scene entry it came from (the name events refer to).
    pub groups: Vec<String>,
    /// Materials, indexed by [`RigidBody::material`].
    pub materials: Vec<Material>,
    /// Settings.
    pub settings: SimSettings,
    /// Scheduled events.
    pub events: Vec<Event>,
    /// Joints between the bodies ([`crate::joint`]), solved with the contacts.
    pub joints: Vec<Joint>,
    /// Collision detection with its manifold cache.
    pub pipeline: CollisionPipeline,
    /// Impulses of the last step, by contact key.
    pub warm: WarmStartCache,
    /// Steps taken.
    pub step_index: usize,
    /// Simulated time, s.
    pub time: f64,
    /// The working copy of `settings.solver` for whole-step solves (it keeps its workspace
    /// from step to step).
    whole: ContactSolver,
    /// The instances of `settings.solver` that solved the last step's islands, kept for the
    /// islands of the next step with the same bodies and rows (each keeps its workspace); a
    /// new island gets a fresh clone of `settings.solver`.
    island_solvers: IslandSolvers,
}

impl World {
    /// A world at time 0.
    pub fn new(bodies: Vec<RigidBody>, materials: Vec<Material>, settings: SimSettings) -> Self {
        let groups = bodies.iter().map(|b| b.name.clone()).collect();
        let whole = settings.solver.clone();
        Self {
            bodies,
            groups,
            materials,
            settings,
            events: Vec::new(),
            joints: Vec::new(),
            pipeline: CollisionPipeline::new(),
            warm: WarmStartCache::default(),
            step_index: 0,
            time: 0.0,
            whole,
            island_solvers: IslandSolvers::default(),
        }
    }

    /// Switch the contact solver (keeps the warm-start cache, drops the solver instances kept
    /// between steps).
    pub fn set_solver(&mut self, solver: impl Into<ContactSolver>) {
        self.settings.solver = solver.into();
        self.whole = self.settings.solver.clone();
        self.island_solvers.clear();
    }

    /// Islands of the last step solved by a solver instance kept from the step before (with
    /// its workspace), rather than by a fresh clone of `settings.solver`.
    pub fn reused_island_solvers(&self) -> usize {
        self.island_solvers.reused()
    }

    /// Solver instances kept for the next step's islands.
    pub fn kept_island_solvers(&self) -> usize {
        self.island_solvers.len()
    }

    /// Drop the solver instances kept between steps, so that the next step solves every
    /// island with a fresh clone of `settings.solver` (a kept instance answers as a fresh one:
    /// this changes the work, not the results).
    pub fn forget_island_solvers(&mut self) {
        self.island_solvers.clear();
    }

    /// Index of the body named `name`.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// One time step: detect, build, solve, apply and integrate, measure.
    ///
    /// A step past one of the stated limits (candidate pairs, contacts, entries of `A`: see
    /// [`broad_phase::MAX_PAIRS`](crate::collision::broad_phase::MAX_PAIRS),
    /// [`narrow_phase::MAX_CONTACTS`](crate::collision::narrow_phase::MAX_CONTACTS),
    /// [`builder::MAX_DELASSUS_ENTRIES`]) is not solved: it applies no contact impulse and
    /// reports `Unsupported` with the limit as the reason.
    pub fn step(&mut self) -> StepReport {
        let mut clock = PhaseClock::start();
        let mut phases = PhaseTimes::default();
        self.apply_events();
        let (contacts, detection_refused) = self.detect();
        phases.collision = clock.lap();
        let timings = self.pipeline.timings();
        (phases.broad_phase, phases.narrow_phase) = (timings.broad_phase, timings.narrow_phase);
        let system = self.build(&contacts);
        phases.assembly = clock.lap();
        let partition = system.islands();
        phases.islands = clock.lap();
        let refused = detection_refused.or_else(|| self.size_refusal(&system));
        let mut solved = match &refused {
            Some(reason) => {
                self.warm.clear();
                Solved::unsupported(system.n(), reason.clone())
            }
            None => self.solve(&system, &partition),
        };
        phases.add_solve_phase(clock.lap(), &solved);
        let toi = self.advance(&system, &mut solved, refused.is_none());
        phases.integration = clock.lap();
        self.report(&system, &partition, solved, toi, clock, phases)
    }

    /// Run `n` steps, returning their reports.
    pub fn run(&mut self, n: usize) -> Vec<StepReport> {
        (0..n).map(|_| self.step()).collect()
    }

    fn apply_events(&mut self) {
        let now = self.step_index;
        let due: Vec<String> = self
            .events
            .iter()
            .filter(|e| e.at_step == now)
            .map(|e| e.remove.clone())
            .collect();
        if due.is_empty() {
            return;
        }
        for name in due {
            let keep: Vec<bool> = (0..self.bodies.len())
                .map(|i| self.bodies[i].name != name && self.groups[i] != name)
                .collect();
            let mut it = keep.iter();
            self.bodies.retain(|_| *it.next().unwrap_or(&true));
            let mut it = keep.iter();
            self.groups.retain(|_| *it.next().unwrap_or(&true));
            // A joint goes with either of its bodies; the others follow the new numbering.
            self.joints = self
                .joints
                .iter()
                .filter_map(|j| j.renumbered(&keep))
                .collect();
        }
        // Body indices changed: cached manifolds, contact keys and island patterns no longer
        // match.
        self.pipeline.clear();
        self.warm.clear();
        self.island_solvers.clear();
    }

    /// Why the step's contact problem is too large, when it is: the matrix and cone solvers, a
    /// kept problem and split impulses assemble (part of) `A`; a body-level solver without them
    /// works on the bodies alone (its shared residual, which visits each entry of `A`, is then
    /// left unmeasured past the limit, see `World::measures_step`).
    fn size_refusal(&self, system: &ContactSystem) -> Option<String> {
        let assembles = !matches!(self.settings.solver, ContactSolver::Body(_))
            || self.settings.keep_problem
            || self.settings.builder.position_correction == PositionCorrection::Split;
        if !assembles {
            return None;
        }
        system.check_delassus_size(&self.bodies).err()
    }

    /// Contacts at the current positions, or none and the reason when detection is past one of
    /// its limits.
    fn detect(&mut self) -> (Vec<Contact>, Option<String>) {
        self.pipeline.narrow_phase_mut().persistent_manifolds = self.settings.persistent_manifolds;
        match self
            .pipeline
            .detect(&self.bodies, self.settings.prediction_distance)
        {
            Ok(contacts) if self.joints.is_empty() => (contacts, None),
            Ok(mut contacts) => {
                // Bodies joined by a joint do not collide with each other (as in ODE, Bullet
                // and Rapier): their shapes meet at the joint by design.
                let joined: std::collections::HashSet<(usize, usize)> = self
                    .joints
                    .iter()
                    .filter_map(|j| match j.bodies {
                        [Some(a), Some(b)] => Some((a.min(b), a.max(b))),
                        _ => None,
                    })
                    .collect();
                contacts.retain(|c| {
                    !joined.contains(&(c.body_a.min(c.body_b), c.body_a.max(c.body_b)))
                });
                (contacts, None)
            }
            Err(e) => (Vec::new(), Some(format!("collision detection: {e}"))),
        }
    }

    /// The contact system of `contacts` at the free velocities `u* = u + h M⁻¹ f_ext`.
    fn build(&self, contacts: &[Contact]) -> ContactSystem {
        let (h, gravity) = (self.settings.dt, self.settings.gravity);
        let free = builder::free_velocities(&self.bodies, &gravity, h);
        builder::build_with_joints(
            &self.bodies,
            &self.materials,
            contacts,
            &self.joints,
            free,
            &self.settings.builder,
            h,
        )
    }

    /// Apply the solved impulses (and the split-impulse correction, unless the step was
    /// refused) and move the bodies and the clock by one step. Returns the time of impact the
    /// motion was cut to; a continuous collision detection past its limit makes the step's
    /// status `Unsupported`.
    fn advance(
        &mut self,
        system: &ContactSystem,
        solved: &mut Solved,
        solvable: bool,
    ) -> Option<f64> {
        if let Some(sub) = &solved.substepped {
            // A substepping solver moved the bodies itself (no split impulses, no continuous
            // collision detection: its substeps are its answer to fast motion).
            self.apply_motion(&sub.state);
            self.step_index += 1;
            self.time += self.settings.dt;
            return None;
        }
        let pseudo = if solvable {
            self.split_impulse_velocities(system)
        } else {
            None
        };
        let toi = match self.integrate(system, &solved.f, pseudo.as_deref()) {
            Ok(toi) => toi,
            Err(e) => {
                solved.status = Status::Unsupported {
                    reason: format!("continuous collision detection: {e}"),
                };
                None
            }
        };
        self.step_index += 1;
        self.time += self.settings.dt;
        toi
    }

    /// Set every dynamic body to the state a substepping solver ended the step with: its pose
    /// moved by the solver's translation and rotation, its momenta from the solver's
    /// velocities (`P = m v`, `L = I(q) ω` at the new orientation).
    fn apply_motion(&mut self, state: &crate::substep::SolverState) {
        for (body, s) in self.bodies.iter_mut().zip(&state.bodies) {
            if body.is_static {
                continue;
            }
            body.position += s.dp;
            body.orientation = s.dq * body.orientation;
            body.linear_momentum = s.v * body.mass;
            body.angular_momentum = body.inertia_world() * s.w;
        }
    }

    /// Split impulses: pseudo-velocities from a projected Gauss–Seidel solve of the normal rows
    /// with `b = position error term`, the same for every contact solver.
    fn split_impulse_velocities(&self, system: &ContactSystem) -> Option<Vec<BodyVelocity>> {
        if self.settings.builder.position_correction != PositionCorrection::Split {
            return None;
        }
        let zero = vec![BodyVelocity::default(); system.inv_mass.len()];
        let (problem, normals) = system.position_problem(&zero)?;
        let settings = self.solver_settings(self.solve_deadline());
        let result = ProjectedSor::pgs().solve(&problem, &settings);
        let mut f = vec![0.0; system.n()];
        for (&row, &v) in normals.iter().zip(&result.f) {
            if v.is_finite() {
                f[row] = v;
            }
        }
        Some(system.velocity_change(&f))
    }

    /// Apply the impulses and move the bodies; returns the time of impact the motion was cut to
    /// when continuous collision detection found one. When its broad phase is past its limit,
    /// the bodies move the whole step and the error says so.
    fn integrate(
        &mut self,
        system: &ContactSystem,
        f: &[f64],
        pseudo: Option<&[BodyVelocity]>,
    ) -> Result<Option<f64>, TooManyPairs> {
        let (h, gravity) = (self.settings.dt, self.settings.gravity);
        let dp = system.momentum_change(f);
        if let Some(method) = self.settings.ccd {
            for (body, (dl_lin, dl_ang)) in self.bodies.iter_mut().zip(&dp) {
                integrate::apply_momentum(body, h, &gravity, dl_lin, dl_ang);
            }
            let impact = first_impact(&self.bodies, h, method, &ToiSettings::default());
            let h_pose = impact.map_or(h, |i| i.map_or(h, |i| i.toi.time));
            for (k, body) in self.bodies.iter_mut().enumerate() {
                integrate::advance_pose(body, h_pose, pseudo.map(|p| &p[k]));
            }
            return impact.map(|i| i.map(|i| i.toi.time));
        }
        for (k, body) in self.bodies.iter_mut().enumerate() {
            let (dl_lin, dl_ang) = &dp[k];
            let moved = pseudo
                .is_some_and(|p| p[k].linear.norm_squared() + p[k].angular.norm_squared() > 0.0);
            if dl_lin.norm_squared() + dl_ang.norm_squared() > 0.0 || moved {
                integrate::symplectic_euler(
                    body,
                    h,
                    &gravity,
                    dl_lin,
                    dl_ang,
                    pseudo.map(|p| &p[k]),
                );
            } else {
                integrate::rk4_free_flight(body, h, &gravity);
            }
        }
        Ok(None)
    }
}
