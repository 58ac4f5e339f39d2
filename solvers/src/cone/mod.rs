//! The exact Coulomb cone ([`ConeProblem`]), its residual, and the solvers that take it:
//! NSGS over contacts, the global Alart–Curnier Newton method and Anitescu's SOCP relaxation.

pub(crate) mod alart_curnier;
pub(crate) mod clarabel_socp;
pub(crate) mod newton_ac;
pub(crate) mod nsgs_cone;
mod problem;

pub use problem::*;
