//! The joint figures of a run: joint drift (the largest and the mean joint error over the
//! steps) and the sag of a named body (its drop below its starting height, along gravity), as
//! `simulate` prints them and the harness records them.

use crate::step::{StepReport, World};
use nalgebra::Vector3;
use serde::Serialize;

/// Joint figures accumulated over the steps of a run ([`JointMetrics::observe`]).
#[derive(Debug, Clone)]
pub struct JointMetrics {
    /// The sag body's name, its starting height along `up`, and `up`.
    sag: Option<(String, f64, Vector3<f64>)>,
    summary: JointSummary,
    sum_mean: f64,
    steps: usize,
}

/// What [`JointMetrics`] measured.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct JointSummary {
    /// Joints of the world at the start.
    pub joints: usize,
    /// Largest joint error over every joint and step, m.
    pub drift_max: f64,
    /// Mean over steps of the mean joint error, m.
    pub drift_mean: f64,
    /// Largest angular joint error over every joint and step, rad.
    pub angle_max: f64,
    /// Largest drop of the sag body below its starting height, m (`None` without one).
    pub sag_max: Option<f64>,
    /// Its drop at the end of the run, m.
    pub sag_final: Option<f64>,
}

impl JointMetrics {
    /// Start measuring `world`; `sag_body` names the body whose drop is measured (the scene's
    /// `[metrics] sag_body`), ignored when no body has that name.
    pub fn new(world: &World, sag_body: Option<&str>) -> Self {
        let up = world.settings.up();
        let sag = sag_body.and_then(|name| world.body_index(name)).map(|i| {
            let b = &world.bodies[i];
            (b.name.clone(), b.position.coords.dot(&up), up)
        });
        Self {
            summary: JointSummary {
                joints: world.joints.len(),
                sag_max: sag.as_ref().map(|_| 0.0),
                sag_final: sag.as_ref().map(|_| 0.0),
                ..JointSummary::default()
            },
            sag,
            sum_mean: 0.0,
            steps: 0,
        }
    }

    /// Take in one step's report and the world after it.
    pub fn observe(&mut self, report: &StepReport, world: &World) {
        let s = &mut self.summary;
        s.drift_max = s.drift_max.max(report.joint_drift_max);
        s.angle_max = s.angle_max.max(report.joint_angle_max);
        self.sum_mean += report.joint_drift_mean;
        self.steps += 1;
        s.drift_mean = self.sum_mean / self.steps as f64;
        if let Some((name, h0, up)) = &self.sag {
            if let Some(i) = world.body_index(name) {
                let drop = h0 - world.bodies[i].position.coords.dot(up);
                s.sag_max = Some(s.sag_max.unwrap_or(0.0).max(drop));
                s.sag_final = Some(drop);
            }
        }
    }

    /// The figures so far.
    pub fn summary(&self) -> JointSummary {
        self.summary
    }
}
