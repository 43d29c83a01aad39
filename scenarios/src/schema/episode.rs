//! One fully specified episode ([`EpisodeSpec`]) and the robot's facts its controller gets
//! ([`robot_facts`]).

use std::collections::BTreeMap;
use std::path::PathBuf;

use loomlab_agents::{BodyExtent, EscapeConfig, RobotFacts};
use loomlab_detector::Pinhole;
use loomlab_sim::WorldDesc;

use super::detector::DetectorSpec;
use super::document::CruiseDesc;
use crate::metrics::ScoringConfig;

/// Half the lateral extent of the robot's body (m): half a box's y size, a cylinder's radius.
pub fn body_half_width_m(world: &WorldDesc) -> f64 {
    match &world.robot.body {
        loomlab_sim::ShapeDesc::Box { size } => f64::from(size[1]) / 2.0,
        loomlab_sim::ShapeDesc::Cylinder { radius_m, .. } => f64::from(*radius_m),
        loomlab_sim::ShapeDesc::Sphere { radius_m } => f64::from(*radius_m),
    }
}

/// How far the robot's body reaches above and below the camera (m): `(above, below)` from the
/// body's half-height and the camera's height over the body's centre (`world.camera.position`).
pub fn body_extent_about_camera_m(world: &WorldDesc) -> (f64, f64) {
    let half_height = match &world.robot.body {
        loomlab_sim::ShapeDesc::Box { size } => f64::from(size[2]) / 2.0,
        loomlab_sim::ShapeDesc::Cylinder { height_m, .. } => f64::from(*height_m) / 2.0,
        loomlab_sim::ShapeDesc::Sphere { radius_m } => f64::from(*radius_m),
    };
    let camera_z = f64::from(world.camera.position[2]);
    (half_height - camera_z, half_height + camera_z)
}

/// The robot's and its camera's facts in `world`: its drive (`world.robot.base`), its body's
/// extent about the camera ([`body_half_width_m`], [`body_extent_about_camera_m`]) and the
/// camera's pinhole (`world.camera.fov_deg`).
pub fn robot_facts(world: &WorldDesc) -> RobotFacts {
    let (above_camera_m, below_camera_m) = body_extent_about_camera_m(world);
    let half_length = match &world.robot.body {
        loomlab_sim::ShapeDesc::Box { size } => f64::from(size[0]) / 2.0,
        loomlab_sim::ShapeDesc::Cylinder { radius_m, .. } | loomlab_sim::ShapeDesc::Sphere { radius_m } => {
            f64::from(*radius_m)
        }
    };
    let camera_x = f64::from(world.camera.position[0]);
    let robot = &world.robot;
    // with analytic physics the robot follows its commands at once
    let (accel_mps2, yaw_accel_rps2) = match world.physics {
        loomlab_sim::PhysicsMode::Dynamic => (
            f64::from(robot.max_accel_mps2.min(robot.max_decel_mps2)),
            f64::from(robot.max_yaw_accel_rps2),
        ),
        loomlab_sim::PhysicsMode::Analytic => (f64::INFINITY, f64::INFINITY),
    };
    RobotFacts {
        base: robot.base,
        body: BodyExtent {
            half_width_m: body_half_width_m(world),
            above_camera_m,
            below_camera_m,
            ahead_of_camera_m: (half_length - camera_x).max(0.0),
            behind_camera_m: (half_length + camera_x).max(0.0),
        },
        pinhole: Pinhole::new(f64::from(world.camera.fov_deg)),
        accel_mps2,
        yaw_accel_rps2,
    }
}

/// One episode, fully specified.
#[derive(Debug, Clone)]
pub struct EpisodeSpec {
    /// Scenario name.
    pub scenario: String,
    /// Scenario file.
    pub file: PathBuf,
    /// Index within the scenario.
    pub index: usize,
    /// Simulator seed.
    pub seed: u64,
    /// Swept / sampled values, `key path → TOML text` (plus `repeat` when repeats > 1).
    pub params: BTreeMap<String, String>,
    /// The world.
    pub world: WorldDesc,
    /// Cruise command.
    pub cruise: CruiseDesc,
    /// Episode length (s).
    pub duration_s: f64,
    /// Detectors (all see the same frames).
    pub detectors: Vec<DetectorSpec>,
    /// Escape controller (trigger and threshold are set per detector): the `[controller]` table.
    pub controller: EscapeConfig,
    /// The robot's and its camera's facts the controller is built with ([`robot_facts`] of
    /// `world`).
    pub facts: RobotFacts,
    /// Scoring parameters.
    pub scoring: ScoringConfig,
}

impl EpisodeSpec {
    /// Number of camera frames of the episode: round(duration · camera_hz), at least 1.
    pub fn frames(&self) -> usize {
        ((self.duration_s * f64::from(self.world.camera_hz)).round() as usize).max(1)
    }

    /// Time between two camera frames (s).
    pub fn frame_period_s(&self) -> f64 {
        1.0 / f64::from(self.world.camera_hz)
    }

    /// `key = value, …` of the episode's parameters (for messages).
    pub fn params_text(&self) -> String {
        params_text(&self.params)
    }
}

pub(super) fn params_text(p: &BTreeMap<String, String>) -> String {
    if p.is_empty() {
        return "no parameters".into();
    }
    p.iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}
