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

use std::collections::VecDeque;

use loomlab_detector::EfferenceCopy;
use loomlab_sim::glam::DVec3;
use loomlab_sim::trajectory::Pose64;

use crate::VelocityCommand;

/// What the robot's odometry and the inertial sensor on its camera know about the camera when a
/// frame is taken: its world pose, and its rotation relative to its mount on the body (the
/// camera's shake; zero for a rigidly mounted camera).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensedCamera {
    /// When the frame the robot is given was taken (s): the simulation time less the perception
    /// latency (the same as the time without one).
    pub t_s: f64,
    /// The camera's world pose then (x = optical axis, z = up; the shake included).
    pub pose: Pose64,
    /// The camera's rotation relative to its mount, `[yaw, pitch, roll]` (rad; yaw positive = left,
    /// pitch positive = up).
    pub shake_rad: [f64; 3],
}

impl SensedCamera {
    /// The camera of `sim` when the frame it shows now was taken ([`loomlab_sim::Sim::shown_camera`]:
    /// under a perception latency, that many frames ago; the robot's odometry and inertial sensor
    /// are time-stamped, so the robot knows where its camera was then).
    pub fn of(sim: &loomlab_sim::Sim) -> Self {
        let (t_s, pose) = sim.shown_camera();
        Self {
            t_s,
            pose,
            shake_rad: sim.camera().shake_rotation(t_s),
        }
    }
}

/// Senses the camera's motion between frames from its successive poses and joins it with the
/// commanded motion into efference copies (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct CameraMotionSensor {
    previous: Option<(f64, Pose64)>,
    /// The commands applied in the periods from the shown frame's to now, `(end of period (s),
    /// command)`: with a perception latency a frame's copy holds the command of its own period.
    commands: VecDeque<(f64, VelocityCommand)>,
}

impl CameraMotionSensor {
    /// Forgets the previous pose and commands (a new episode: the next copy has no motion).
    pub fn reset(&mut self) {
        self.previous = None;
        self.commands.clear();
    }

    /// The efference copy of the frame the robot is given now (taken at `camera.t_s`), with
    /// `command` the command applied during the period that ends now at `now_s`: the camera's
    /// motion between the frames shown and the command of the shown frame's period (under a
    /// perception latency an earlier one; without one, `command`). Bounded: only the commands
    /// since the shown frame are kept.
    pub fn sense_frame(&mut self, now_s: f64, command: VelocityCommand, camera: &SensedCamera) -> EfferenceCopy {
        const SAME_TIME_S: f64 = 1e-9;
        self.commands.push_back((now_s, command));
        while self.commands.len() > 1 && self.commands[0].0 < camera.t_s - SAME_TIME_S {
            self.commands.pop_front();
        }
        let applied = self.commands[0].1;
        self.sense(applied, camera.t_s, &camera.pose)
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

/// The detectors' view of the event camera's `packet` for one period
/// ([`loomlab_detector::EventInput`]), its events converted into `buf` (cleared first; reuse it
/// from period to period): the one conversion the runner and the env share.
pub fn event_input<'a>(
    packet: &'a loomlab_sim::EventPacket,
    buf: &'a mut Vec<loomlab_detector::Event>,
) -> loomlab_detector::EventInput<'a> {
    buf.clear();
    buf.extend(packet.events.iter().map(|e| loomlab_detector::Event {
        t_s: e.t_s,
        x: e.x,
        y: e.y,
        polarity: e.polarity,
    }));
    loomlab_detector::EventInput {
        n: packet.n as usize,
        t_start_s: packet.t_start_s,
        t_end_s: packet.t_end_s,
        events: buf,
        on_counts: &packet.on_counts,
        off_counts: &packet.off_counts,
    }
}
