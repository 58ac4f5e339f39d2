//! Solvers of the boxed LCP ([`crate::Problem`]), one module per method: projected sweeps (PGS and
//! SOR, NSGS, NNCG, micro-impulses), first-order and Newton methods (APGD, semismooth Newton),
//! pivoting (Lemke, Dantzig), enumeration, and an interior-point QP (Clarabel); the elimination
//! of free (equality) rows that Lemke and enumeration run first.

pub(crate) mod apgd;
pub(crate) mod clarabel_qp;
pub(crate) mod dantzig;
pub(crate) mod enumeration;
pub(crate) mod free_rows;
pub(crate) mod lemke;
pub(crate) mod local;
pub(crate) mod micro_impulse;
pub(crate) mod newton;
pub(crate) mod nncg;
pub(crate) mod nsgs;
pub(crate) mod pgs;
pub(crate) mod ray;
