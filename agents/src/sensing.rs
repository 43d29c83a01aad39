//! The robot's **sensed** self-motion: [`SensedCamera`], the camera's pose and shake as the
//! robot's odometry and the inertial sensor on the camera measure them, and
//! [`CameraMotionSensor`], which turns successive sensed poses into the camera's motion and joins
//! it with the **commanded** motion (the [`VelocityCommand`] the robot applied) into the efference
//! copy a detector gets ([`EfferenceCopy`], the detectors' contract).
//!
//! The runner's open-loop pass, its closed-loop tails, the escape-deadline replays and the
//! Gymnasium env all build a detector's [`EfferenceCopy`] with this one type, so a detector sees
//! the same self-knowledge wherever it runs; they take the camera's state from the simulator as one
//! [`SensedCamera`], whose shake also reaches the decider ([`crate::SelfMotion`]). Only the
//! robot's own camera enters it: never anything about other objects.

use loomlab_detector::EfferenceCopy;
use loomlab_sim::glam::DVec3;
use loomlab_sim::trajectory::Pose64;

use crate::VelocityCommand;

/// What the robot's odometry and the inertial sensor on its camera know about the camera when a
/// frame is taken: its world pose, and its rotation relative to its mount on the body (the
/// camera's shake; zero for a rigidly mounted camera).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensedCamera {
    /// The camera's world pose (x = optical axis, z = up; the shake included).
    pub pose: Pose64,
    /// The camera's rotation relative to its mount, `[yaw, pitch, roll]` (rad; yaw positive = left,
    /// pitch positive = up).
    pub shake_rad: [f64; 3],
}

impl SensedCamera {
    /// The camera of `sim` now (where its last frame was taken from).
    pub fn of(sim: &loomlab_sim::Sim) -> Self {
        Self {
            pose: sim.camera_pose(),
            shake_rad: sim.camera().shake_rotation(sim.time()),
        }
    }
}

/// Senses the camera's motion between frames from its successive poses and joins it with the
/// commanded motion into efference copies (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct CameraMotionSensor {
    previous: Option<(f64, Pose64)>,
}

impl CameraMotionSensor {
    /// Forgets the previous pose (a new episode: the next copy has no motion).
    pub fn reset(&mut self) {
        self.previous = None;
    }

    /// The efference copy of the camera period ending at time `t_s`, during which `command` was
    /// applied, with `camera` the camera's world pose at `t_s` (x = optical axis, z = up, the
    /// ground plane z = 0). The first call after a reset knows the pose but no motion (`dt_s = 0`).
    pub fn sense(&mut self, command: VelocityCommand, t_s: f64, camera: &Pose64) -> EfferenceCopy {
        let mut efference = command.efference_copy();
        let up = camera.rotation.inverse() * DVec3::Z;
        efference.height_m = camera.position.z;
        efference.pitch_rad = up.x.clamp(-1.0, 1.0).asin();
        efference.roll_rad = up.y.atan2(up.z);
        if let Some((t0, previous)) = &self.previous
            && t_s > *t0
        {
            let inverse = previous.rotation.inverse();
            let rotation = (inverse * camera.rotation).normalize().to_scaled_axis();
            let translation = inverse * (camera.position - previous.position);
            efference.dt_s = t_s - t0;
            efference.rotation_rad = rotation.to_array();
            efference.translation_m = translation.to_array();
        }
        self.previous = Some((t_s, *camera));
        efference
    }
}
