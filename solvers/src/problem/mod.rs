//! What a solver is given and how its answer is measured: the boxed LCP with friction rows
//! ([`Problem`]), its shared natural-map residual ([`metrics`]), the Farkas certificate of
//! infeasibility ([`certificate`]) and generated test problems ([`generate`]).

mod boxed;
pub mod certificate;
pub(crate) mod diagonal;
pub mod generate;
pub mod metrics;

pub use boxed::*;
