//! The exact Coulomb cone: the three-dimensional frictional contact problem (FC3D, the form of
//! Siconos and FCLIB), its shared residual, and the interface of the solvers that take it.
//!
//! `n_c` contacts, each with three rows ordered (normal, tangent 1, tangent 2), a Delassus matrix
//! `W` (`3n_c × 3n_c`, dense or sparse), a free velocity `q` and a friction coefficient `mu_c`
//! per contact. Find reactions `r` and velocities `u = W r + q` satisfying Coulomb's law, in De
//! Saxcé's complementarity form, contact by contact:
//!
//! ```text
//! K_c ∋ r_c  ⟂  û_c ∈ K_c*,     û_c = u_c + mu_c ‖u_{c,T}‖ e_N,
//! K_c  = { r : ‖r_T‖ <= mu_c r_N },   K_c* = { v : mu_c ‖v_T‖ <= v_N }  (the dual cone).
//! ```
//!
//! A contact takes off (`r_c = 0`, `u_{c,N} >= 0`), sticks (`r_c ∈ K_c`, `u_c = 0`) or slides
//! (`‖r_T‖ = mu r_N`, `u_N = 0`, `r_T = −mu r_N u_T / ‖u_T‖`): the friction force opposes the
//! sliding velocity with the same magnitude in every tangent direction, which the box (and
//! pyramid) LCP approximations of [`crate::Problem`] do not.
//!
//! # The cone residual (the only status decider for cone solves)
//!
//! With the projection `P_K` onto the second-order cone ([`project_onto_cone`]), the natural map
//! `r − P_K(r − ρ û)` vanishes exactly at a solution, for any `ρ > 0`. Per contact `c`, with `d_c`
//! the [diagonal scale](crate::Problem::diagonal_scale_of) of its normal row (`W_nn` when
//! positive) and `ρ_c = 1 / d_c`:
//!
//! ```text
//! e_c   = ‖r_c − P_K(r_c − û_c / d_c)‖₂,
//! t_i   = |q_i| + Σ_j |W_ij r_j|                                  (i a row of c)
//! s_c   = ‖(t_N + mu_c ‖(t_1, t_2)‖₂,  t_1,  t_2)‖₂ / d_c,
//! rel   = max_c  e_c / s_c                                       (0/0 = 0, x/0 = ∞)
//! ```
//!
//! This is the per-row philosophy of [`crate::metrics`] lifted to contacts: each contact's step
//! is measured against the magnitudes of the terms that make up its own `û_c / d_c` (the
//! componentwise backward-error scale of Oettli and Prager, with `mu ‖u_T‖` bounded by
//! `mu ‖(t_1, t_2)‖`), so no other contact can hide a contact's error, and the measure is invariant
//! under positive scalings of each contact's rows and columns (`W → R W C`, `R`, `C` constant on
//! each contact's three rows: the cone is invariant under positive scaling). The absolute measure
//! reported next to it is Siconos' FC3D numerator `max_c ‖r_c − P_K(r_c − û_c)‖` (`ρ = 1`; Siconos
//! divides its sum by `1 + ‖q‖`). A cone result's [`Residuals`](crate::Residuals) hold:
//!
//! * `natural_map`: `max_c ‖r_c − P_K(r_c − û_c)‖₂`;
//! * `natural_map_rel`: `rel` above — `Converged` if and only if `rel <= tolerance`;
//! * `complementarity_gap`: `Σ_c |r_c · û_c|`;
//! * `bound_violation`: `max_c ‖r_c − P_K(r_c)‖₂`, the distance to the friction cone.
//!
//! References: G. De Saxcé, Z.-Q. Feng, *New inequality and functional for contact with
//! friction: the implicit standard material approach*, Mech. Struct. Mach. 19, 1991; P. Alart,
//! A. Curnier, *A mixed formulation for frictional contact problems prone to Newton like solution
//! methods*, CMAME 92, 1991; V. Acary, M. Brémond, O. Huber, *On solving contact problems with
//! Coulomb friction: formulations and numerical comparisons*, Advanced Topics in Nonsmooth
//! Dynamics, Springer 2018 (FC3D, FCLIB, the error measure).
//!
//! Solvers: NSGS over contacts ([`crate::NsgsCone`]), the global Newton methods on the
//! Alart–Curnier function, the second-order-cone Fischer–Burmeister function and the natural
//! map ([`crate::ConeNewton`]: `newton-ac`, `newton-fb-cone`, `newton-nm-cone`), the projection
//! methods on De Saxcé's map (extragradient, [`crate::ExtragradientCone`]; fixed-point
//! projection, [`crate::FixedPointProjectionCone`]), ADMM ([`crate::AdmmCone`]), the proximal
//! point method ([`crate::ProxCone`]), Anitescu's
//! SOCP relaxation ([`crate::ClarabelSocp`]) and, on problems that carry the factors of `W`,
//! SAP's Newton method on the body velocities of a regularised convex model ([`crate::Sap`]).

pub(crate) mod admm;
pub(crate) mod alart_curnier;
pub(crate) mod clarabel_socp;
pub(crate) mod extragradient;
pub(crate) mod fischer_burmeister;
pub(crate) mod fixed_point_projection;
pub(crate) mod natural_map;
pub(crate) mod newton;
pub(crate) mod nsgs_cone;
mod problem;
pub(crate) mod projected_step;
pub(crate) mod proximal;
mod residual;
pub(crate) mod sap;

pub use problem::*;
pub use residual::*;
