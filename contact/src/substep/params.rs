//! Parameters of the substepping solvers (`soft-step@substeps=8,hertz=60`): the registry's
//! [`ParamSpec`] and [`Params`] of `lcpbench-solvers`, which every solver's parameters follow,
//! re-exported where the substepping solvers' tables use them.

pub use lcpbench_solvers::registry::{ParamSpec, Params, MAX_PARAMS};
