//! The builder's parameters: materials, the friction models, the position correction and
//! [`BuilderParams`], with their names in scene files and on the command line.

use serde::Serialize;

/// A material: Coulomb friction and Newton restitution coefficients.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Material {
    /// Name from the scene file.
    pub name: String,
    /// Friction coefficient `mu >= 0`. A contact uses `sqrt(mu_a mu_b)`.
    pub mu: f64,
    /// Restitution coefficient `e` in `[0, 1]`. A contact uses `max(e_a, e_b)`.
    pub restitution: f64,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            mu: 0.5,
            restitution: 0.0,
        }
    }
}

/// How friction is modelled in the LCP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FrictionModel {
    /// Frictionless: normal rows only.
    None,
    /// Two tangent rows per contact bounded by `±mu f_n` (a boxed LCP with friction rows).
    Box,
    /// `directions` friction directions and a slack row per contact (Stewart–Trinkle standard
    /// LCP).
    Pyramid {
        /// Number of directions `k >= 3`.
        directions: usize,
    },
    /// The exact Coulomb cone: the rows of [`FrictionModel::Box`] (normal and two tangents per
    /// contact), solved as an FC3D [`ConeProblem`] by a cone solver.
    Cone,
}

impl FrictionModel {
    /// The name used in scene files, case keys and on the command line: `none`, `box`,
    /// `pyramid` (4 directions) or `pyramid-K`, `cone`.
    pub fn name(&self) -> String {
        match self {
            FrictionModel::None => "none".into(),
            FrictionModel::Box => "box".into(),
            FrictionModel::Pyramid { directions: 4 } => "pyramid".into(),
            FrictionModel::Pyramid { directions } => format!("pyramid-{directions}"),
            FrictionModel::Cone => "cone".into(),
        }
    }

    /// Inverse of [`FrictionModel::name`] (`pyramid-K` for `K` in 3 to 64).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::parse(name, 4).ok()
    }

    /// The one parser of friction-model names, for scene files and the command line: `none`,
    /// `box`, `cone`, `pyramid` with `pyramid_directions` directions, or `pyramid-K`. The
    /// error says which part is wrong: `Err((true, message))` for the directions,
    /// `Err((false, message))` for the name.
    pub fn parse(name: &str, pyramid_directions: usize) -> Result<Self, (bool, String)> {
        let directions = |k: usize| {
            if (3..=MAX_PYRAMID_DIRECTIONS).contains(&k) {
                Ok(FrictionModel::Pyramid { directions: k })
            } else {
                Err((
                    true,
                    format!("must be between 3 and {MAX_PYRAMID_DIRECTIONS}, got {k}"),
                ))
            }
        };
        let unknown = || {
            (
                false,
                format!(
                    "unknown model \"{name}\" (expected \"none\", \"box\", \"pyramid\" or \"cone\")"
                ),
            )
        };
        match name {
            "none" => Ok(FrictionModel::None),
            "box" => Ok(FrictionModel::Box),
            "cone" => Ok(FrictionModel::Cone),
            "pyramid" => directions(pyramid_directions),
            _ => match name.strip_prefix("pyramid-").map(str::parse::<usize>) {
                Some(Ok(k)) => directions(k).map_err(|_| unknown()),
                _ => Err(unknown()),
            },
        }
    }

    /// The names [`FrictionModel::from_name`] takes, for messages.
    pub const NAMES: &'static str =
        "none, box, pyramid (4 directions), pyramid-K (K = 3 to 64), cone";
}

/// How penetration is corrected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PositionCorrection {
    /// No correction: penetration stays.
    None,
    /// Baumgarte stabilisation in the velocity problem: `b_n += (β/h) min(0, dist + slop)`.
    Baumgarte,
    /// Split impulses: the same term drives a separate pseudo-velocity solve that moves positions
    /// but adds no momentum.
    Split,
}

impl PositionCorrection {
    /// The method of a scene file's `position_correction` (`none`, `baumgarte`, `split`), or
    /// why not.
    pub fn from_name(name: &str) -> Result<Self, String> {
        match name {
            "none" => Ok(PositionCorrection::None),
            "baumgarte" => Ok(PositionCorrection::Baumgarte),
            "split" => Ok(PositionCorrection::Split),
            other => Err(format!(
                "unknown method \"{other}\" (expected \"baumgarte\", \"split\" or \"none\")"
            )),
        }
    }
}

/// Largest number of pyramid friction directions: each contact of the pyramid model has
/// `directions + 2` rows.
pub const MAX_PYRAMID_DIRECTIONS: usize = 64;

/// Parameters of the builder. Defaults in brackets.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BuilderParams {
    /// Friction model \[`Box`\].
    pub friction_model: FrictionModel,
    /// Closing speeds below this get no restitution, m/s \[`0.1`\].
    pub restitution_threshold: f64,
    /// Position correction \[`Baumgarte`\].
    pub position_correction: PositionCorrection,
    /// Baumgarte factor `β` in `[0, 1]` \[`0.2`\].
    pub baumgarte: f64,
    /// Penetration allowed without correction, m \[`0.001`\].
    pub slop: f64,
}

impl Default for BuilderParams {
    fn default() -> Self {
        Self {
            friction_model: FrictionModel::Box,
            restitution_threshold: 0.1,
            position_correction: PositionCorrection::Baumgarte,
            baumgarte: 0.2,
            slop: 0.001,
        }
    }
}
