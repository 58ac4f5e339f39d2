//! # lcpbench-contact
//!
//! The physics half of lcpbench: rigid bodies and shapes, collision detection (parry), the
//! contact-matrix builder (`J`, the Delassus matrix `A = J M⁻¹ Jᵀ`, `b`, bounds and friction
//! rows), time stepping and scene files.
//!
//! Data flow: scene file → bodies + shapes → broad phase → narrow phase (manifolds) →
//! contact-matrix builder → solver → impulses → integrator.
#![warn(missing_docs)]

// Geometry and detection: shapes and mass properties (`shape`), rigid-body state (`body`),
// broad phase, narrow phase and time of impact (`collision`).
pub mod body;
pub mod collision;
pub mod shape;

// Dynamics: builder, solvers on bodies, stepping, scenes.
pub mod body_solvers;
pub mod builder;
pub mod discontinuity;
pub mod integrate;
pub mod joint;
pub mod registry;
pub mod scene;
pub mod step;
pub mod substep;
pub mod timewarp;

pub use body::{MassSpec, RigidBody};
pub use collision::{candidate_pairs, CollisionPipeline, Contact};
pub use shape::{MassProperties, Shape, ShapeError};

pub use body_solvers::{
    AveragedImpulse, BodySolver, BodySolverKind, MicroImpulses, Penalty, SequentialImpulses,
};
pub use builder::{
    BuilderParams, ContactSystem, DelassusForm, DelassusOperator, FrictionModel, Material,
    PositionCorrection,
};
pub use joint::{Joint, JointKind};
pub use scene::{Scene, SceneError, SceneMetrics};
pub use step::{ContactSolver, SimSettings, StepReport, World};
