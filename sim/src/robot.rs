//! The robot: a body driven by velocity commands, holonomic or a differential drive.
//!
//! With dynamic physics (the default, [`crate::PhysicsMode`]) the robot is a rapier dynamic body of
//! `mass_kg` that slides on the ground plane (height, roll and pitch locked) and is driven by the
//! velocity-tracking controller of [`crate::dynamics`] within its speed and acceleration limits;
//! what hits it pushes it. With analytic physics it is a kinematic body whose pose is integrated
//! exactly (circular arcs for constant forward speed and yaw rate over a step) and its collider is a
//! rapier *sensor*: nothing pushes it. It is invisible to its own camera either way.
//!
//! Default limits are those of a small mobile robot: ROS 2 Nav2's velocity-smoother defaults
//! (2.5 m/s² acceleration and deceleration, 3.2 rad/s² yaw acceleration, 2.0 rad/s yaw rate) and the
//! top speed of a Clearpath Jackal-class field robot (2.0 m/s); 10 kg, between a TurtleBot 4
//! (3.9 kg) and a Jackal (17 kg).

use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::dynamics::{DriveLimits, RobotBase};
use crate::glam::DVec3;
use crate::shape::{Prim, PrimKind, ShapeDesc};
use crate::trajectory::{Motion, Pose64, Segment};

/// A velocity command, in the robot's body frame (x forward, y left).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Command {
    /// Forward speed (m/s; negative = backwards).
    pub forward_mps: f32,
    /// Yaw rate (rad/s; positive = turn left / counter-clockwise seen from above).
    pub yaw_rate_rps: f32,
    /// Lateral speed (m/s; positive = to the left), for holonomic bases.
    pub lateral_mps: f32,
}

impl Command {
    /// A command with only a forward speed.
    pub fn forward(forward_mps: f32) -> Self {
        Command {
            forward_mps,
            ..Default::default()
        }
    }

    /// Checks that every component is finite.
    pub fn validate(&self) -> Result<(), SimError> {
        for (k, v) in [
            ("forward_mps", self.forward_mps),
            ("yaw_rate_rps", self.yaw_rate_rps),
            ("lateral_mps", self.lateral_mps),
        ] {
            if !v.is_finite() {
                return Err(SimError::invalid(format!("command.{k}"), v, "must be finite"));
            }
        }
        Ok(())
    }

    /// The motion segment of a robot at `pose` (body-origin pose) from time `t` on under this command.
    pub fn motion_from(&self, pose: Pose64, t: f64) -> Segment {
        let (v, l, w) = (
            f64::from(self.forward_mps),
            f64::from(self.lateral_mps),
            f64::from(self.yaw_rate_rps),
        );
        let motion = if w.abs() < 1e-9 {
            if v == 0.0 && l == 0.0 {
                Motion::Hold
            } else {
                Motion::Linear {
                    velocity: pose.rotation * DVec3::new(v, l, 0.0),
                }
            }
        } else {
            // instantaneous centre of rotation in the body frame: (-l/w, v/w)
            Motion::Arc {
                center: pose.transform_point(DVec3::new(-l / w, v / w, 0.0)),
                yaw_rate: w,
            }
        };
        Segment {
            t0: t,
            t1: f64::INFINITY,
            pose0: pose,
            motion,
        }
    }
}

/// The robot's body and start pose (TOML table `[world.robot]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotDesc {
    /// Body shape (`box` or `cylinder`). Default: a 0.5 × 0.4 × 0.3 m box.
    pub body: ShapeDesc,
    /// Start position `[x, y]` on the ground (m). Default: the origin.
    pub start: [f32; 2],
    /// Start heading (degrees from +x, counter-clockwise). Default 0: driving along +x.
    pub yaw_deg: f32,
    /// Gap between the ground and the bottom of the body (m). Default 0.05.
    pub ground_clearance_m: f32,
    /// The drive: `"holonomic"` (can sidestep; default) or `"diff_drive"` (cannot move sideways).
    pub base: RobotBase,
    /// Mass (kg; dynamic physics). Default 10.
    pub mass_kg: f32,
    /// Coulomb friction coefficient of the body's surface (dynamic physics). Default 0.5.
    pub friction: f32,
    /// Largest forward and lateral speed (m/s; dynamic physics). Default 2.0.
    pub max_speed_mps: f32,
    /// Largest yaw rate (rad/s; dynamic physics). Default 2.0.
    pub max_yaw_rate_rps: f32,
    /// Largest acceleration of the forward and lateral speeds (m/s²; dynamic physics). Default 2.5.
    pub max_accel_mps2: f32,
    /// Largest deceleration (braking) of the forward and lateral speeds (m/s²; dynamic physics).
    /// Default 2.5.
    pub max_decel_mps2: f32,
    /// Largest yaw acceleration (rad/s²; dynamic physics). Default 3.2.
    pub max_yaw_accel_rps2: f32,
    /// Actuation latency (s): a command takes effect this much later, quantised to camera frames
    /// ([`crate::latency`]). Default 0 (left out when written).
    #[serde(skip_serializing_if = "is_zero")]
    pub actuation_latency_s: f32,
}

/// `true` for 0 (keys left out of written descriptions at their default).
pub(crate) fn is_zero(v: &f32) -> bool {
    *v == 0.0
}

impl Default for RobotDesc {
    fn default() -> Self {
        RobotDesc {
            body: ShapeDesc::Box { size: [0.5, 0.4, 0.3] },
            start: [0.0, 0.0],
            yaw_deg: 0.0,
            ground_clearance_m: 0.05,
            base: RobotBase::Holonomic,
            mass_kg: 10.0,
            friction: 0.5,
            max_speed_mps: 2.0,
            max_yaw_rate_rps: 2.0,
            max_accel_mps2: 2.5,
            max_decel_mps2: 2.5,
            max_yaw_accel_rps2: 3.2,
            actuation_latency_s: 0.0,
        }
    }
}

impl RobotDesc {
    /// Validates the description and returns the body primitive.
    pub fn body_prim(&self) -> Result<Prim, SimError> {
        let prim = self.body.to_prim("world.robot.body")?;
        if prim.kind == PrimKind::Sphere {
            return Err(SimError::invalid(
                "world.robot.body.kind",
                "sphere",
                "the robot body must be a box or a cylinder",
            ));
        }
        if !(self.ground_clearance_m.is_finite() && self.ground_clearance_m >= 0.0) {
            return Err(SimError::invalid(
                "world.robot.ground_clearance_m",
                self.ground_clearance_m,
                "must be >= 0",
            ));
        }
        if self.start.iter().any(|v| !v.is_finite()) || !self.yaw_deg.is_finite() {
            return Err(SimError::invalid(
                "world.robot.start",
                format!("{:?}", self.start),
                "must be finite",
            ));
        }
        for (key, v) in [
            ("mass_kg", self.mass_kg),
            ("max_speed_mps", self.max_speed_mps),
            ("max_yaw_rate_rps", self.max_yaw_rate_rps),
            ("max_accel_mps2", self.max_accel_mps2),
            ("max_decel_mps2", self.max_decel_mps2),
            ("max_yaw_accel_rps2", self.max_yaw_accel_rps2),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimError::invalid(
                    format!("world.robot.{key}"),
                    v,
                    "must be a finite number > 0",
                ));
            }
        }
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(SimError::invalid("world.robot.friction", self.friction, "must be >= 0"));
        }
        Ok(prim)
    }

    /// The first of a command's speeds that exceeds the drive's limits, which the dynamic physics
    /// would silently clamp it to: `(command key, value, limit key, limit)`, e.g.
    /// `("forward_mps", 3.0, "max_speed_mps", 2.0)`.
    pub fn exceeded_limit(
        &self,
        forward_mps: f64,
        yaw_rate_rps: f64,
        lateral_mps: f64,
    ) -> Option<(&'static str, f64, &'static str, f64)> {
        [
            ("forward_mps", forward_mps, "max_speed_mps", self.max_speed_mps),
            ("lateral_mps", lateral_mps, "max_speed_mps", self.max_speed_mps),
            ("yaw_rate_rps", yaw_rate_rps, "max_yaw_rate_rps", self.max_yaw_rate_rps),
        ]
        .into_iter()
        .map(|(key, value, limit_key, limit)| (key, value, limit_key, f64::from(limit)))
        .find(|&(_, value, _, limit)| value.abs() > limit + 1e-9)
    }

    /// The drive's limits.
    pub fn limits(&self) -> DriveLimits {
        DriveLimits {
            max_speed_mps: self.max_speed_mps.into(),
            max_yaw_rate_rps: self.max_yaw_rate_rps.into(),
            max_accel_mps2: self.max_accel_mps2.into(),
            max_decel_mps2: self.max_decel_mps2.into(),
            max_yaw_accel_rps2: self.max_yaw_accel_rps2.into(),
        }
    }

    /// Pose of the body centre at the start.
    pub fn start_pose(&self, prim: &Prim) -> Pose64 {
        Pose64::from_xyz_yaw(
            DVec3::new(
                self.start[0].into(),
                self.start[1].into(),
                f64::from(self.ground_clearance_m + prim.height() / 2.0),
            ),
            f64::from(self.yaw_deg).to_radians(),
        )
    }
}

/// The robot's state after a step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RobotState {
    /// Simulation time (s).
    pub t_s: f64,
    /// Body centre x (m).
    pub x_m: f64,
    /// Body centre y (m).
    pub y_m: f64,
    /// Heading (rad, counter-clockwise from +x).
    pub yaw_rad: f64,
    /// The command applied during the last step.
    pub command: Command,
    /// World velocity of the body centre (m/s).
    pub velocity_mps: [f64; 3],
    /// Yaw rate (rad/s, counter-clockwise).
    pub yaw_rate_rps: f64,
}
