//! The `[settings]` table checked and converted: clock and gravity, friction model, position
//! correction, solver, penalty parameters, tolerance and limits, into [`SimSettings`] and the
//! scene's [`Penalty`].

use super::file::{finite_vector, magnitude, SettingsFile};
use super::{check_solver, ContactSolver, SimSettings};
use super::{
    default_solver, readable, solver_from_name, FieldError, DT_RANGE, MAX_CONTACT_DISTANCE,
    MAX_GRAVITY, MAX_PENALTY_DAMPING_RATIO, MAX_PENALTY_OMEGA_H, MAX_PENALTY_STIFFNESS, MAX_SPEED,
    MAX_STEPS,
};
use crate::body_solvers::Penalty;
use crate::builder::{BuilderParams, FrictionModel, PositionCorrection};
use crate::collision::toi::ToiMethod;
use lcpbench_solvers::metrics::MIN_TOLERANCE;

/// `settings.{field}` must be a positive finite number.
pub(super) fn positive(field: &str, v: f64) -> Result<f64, FieldError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err((
            format!("settings.{field}"),
            format!("must be a positive number, got {v}"),
        ))
    }
}

/// `settings.{field}` must be a finite number `>= 0`.
pub(super) fn non_negative(field: &str, v: f64) -> Result<f64, FieldError> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err((
            format!("settings.{field}"),
            format!("must be >= 0, got {v}"),
        ))
    }
}

/// `settings.{field}` must be a distance from 0 to [`MAX_CONTACT_DISTANCE`].
pub(super) fn contact_distance(field: &str, v: f64) -> Result<f64, FieldError> {
    let v = non_negative(field, v)?;
    if v > MAX_CONTACT_DISTANCE {
        return Err((
            format!("settings.{field}"),
            format!(
                "must be at most {MAX_CONTACT_DISTANCE} m, got {} m",
                readable(v)
            ),
        ));
    }
    Ok(v)
}

/// `dt`, `steps` and `gravity` within their limits; returns `dt`.
pub(super) fn check_clock(s: &SettingsFile) -> Result<f64, FieldError> {
    let err = |f: &str, m: String| (format!("settings.{f}"), m);
    let dt = positive("dt", s.dt)?;
    if !(DT_RANGE.0..=DT_RANGE.1).contains(&dt) {
        return Err(err(
            "dt",
            format!(
                "must be between {} and {} s, got {}",
                readable(DT_RANGE.0),
                DT_RANGE.1,
                readable(dt)
            ),
        ));
    }
    if s.steps == 0 || s.steps > MAX_STEPS {
        return Err(err(
            "steps",
            format!("must be between 1 and {MAX_STEPS}, got {}", s.steps),
        ));
    }
    let g = magnitude(s.gravity);
    if !(g.is_finite() && g <= MAX_GRAVITY) {
        return Err(err(
            "gravity",
            format!(
                "magnitude must be at most {} m/s², got {}",
                readable(MAX_GRAVITY),
                readable(g)
            ),
        ));
    }
    // After the bound, which names the limit: within it the length cannot overflow.
    finite_vector("gravity", s.gravity).map_err(|(f, m)| err(&f, m))?;
    Ok(dt)
}

pub(super) fn convert_settings(s: &SettingsFile) -> Result<(SimSettings, Penalty), FieldError> {
    let err = |f: &str, m: String| (format!("settings.{f}"), m);
    let dt = check_clock(s)?;
    let friction_model = FrictionModel::parse(&s.friction_model, s.pyramid_directions).map_err(
        |(directions, m)| {
            let field = if directions {
                "pyramid_directions"
            } else {
                "friction_model"
            };
            err(field, m)
        },
    )?;
    let position_correction = PositionCorrection::from_name(&s.position_correction)
        .map_err(|m| err("position_correction", m))?;
    let penalty = Penalty {
        omega_h: at_most(
            "penalty_omega_h",
            positive("penalty_omega_h", s.penalty_omega_h)?,
            MAX_PENALTY_OMEGA_H,
            "",
        )?,
        damping_ratio: at_most(
            "penalty_damping_ratio",
            s.penalty_damping_ratio,
            MAX_PENALTY_DAMPING_RATIO,
            "",
        )?,
        stiffness: s.penalty_stiffness,
    };
    let solver = match &s.solver {
        None => default_solver(friction_model),
        Some(name) => solver_from_name(name, penalty)
            .map_err(|m| err("solver", m))?
            .ok_or_else(|| {
                err(
                    "solver",
                    format!(
                        "unknown solver \"{name}\" (known: {})",
                        ContactSolver::all_names()
                    ),
                )
            })?,
    };
    check_solver(&solver, friction_model).map_err(|m| err("solver", m))?;
    let baumgarte = non_negative("baumgarte", s.baumgarte)?;
    if baumgarte > 1.0 {
        return Err(err(
            "baumgarte",
            format!("must be in [0, 1], got {baumgarte}"),
        ));
    }
    if let Some(k) = s.penalty_stiffness {
        at_most(
            "penalty_stiffness",
            positive("penalty_stiffness", k)?,
            MAX_PENALTY_STIFFNESS,
            " N/m",
        )?;
    }
    let ccd = ToiMethod::from_ccd_name(&s.ccd).map_err(|m| err("ccd", m))?;
    let residual: crate::step::ResidualSchedule =
        s.residual.parse().map_err(|m| err("residual", m))?;
    if s.max_iterations == 0 {
        return Err(err("max_iterations", "must be at least 1".into()));
    }
    let settings = SimSettings {
        dt,
        steps: s.steps,
        gravity: s.gravity.into(),
        solver,
        tolerance: tolerance(s.tolerance).map_err(|m| err("tolerance", m))?,
        max_iterations: s.max_iterations,
        warm_start: s.warm_start,
        islands: s.islands,
        prediction_distance: contact_distance("prediction_distance", s.prediction_distance)?,
        persistent_manifolds: s.persistent_manifolds,
        builder: BuilderParams {
            friction_model,
            restitution_threshold: at_most(
                "restitution_threshold",
                s.restitution_threshold,
                MAX_SPEED,
                " m/s",
            )?,
            position_correction,
            baumgarte,
            slop: contact_distance("slop", s.slop)?,
        },
        ccd,
        keep_problem: false,
        residual,
        record_history: false,
        step_time_budget: None,
        deadline: None,
    };
    Ok((settings, penalty))
}

/// A tolerance on the relative residual: a number in `(0, 1)` (a relative residual of 1 is met
/// by a zero impulse, so a tolerance of 1 or more would claim convergence for nothing), and at
/// least [`MIN_TOLERANCE`] (below it the relative residual of a correctly rounded solution is
/// round-off, so the tolerance would be met only by chance).
pub fn tolerance(tol: f64) -> Result<f64, String> {
    if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
        Err(format!(
            "must be a number in (0, 1) on the relative residual, got {}",
            readable(tol)
        ))
    } else if tol < MIN_TOLERANCE {
        Err(format!(
            "{} is below {MIN_TOLERANCE:e}: the relative residual of a correctly rounded \
             solution is about 4 (nnz + 1) ε per row, so a smaller tolerance would be met only by \
             chance",
            readable(tol)
        ))
    } else {
        Ok(tol)
    }
}

/// `settings.{field}`, a number in `[0, max]`.
pub(super) fn at_most(field: &str, v: f64, max: f64, unit: &str) -> Result<f64, FieldError> {
    let v = non_negative(field, v)?;
    if v > max {
        return Err((
            format!("settings.{field}"),
            format!(
                "must be at most {}{unit}, got {}",
                readable(max),
                readable(v)
            ),
        ));
    }
    Ok(v)
}
