//! Rigid-body dynamics: which physics model a world uses, the robot's base and drive limits, and the
//! velocity-tracking controller that turns a velocity command into the body's velocity.
//!
//! # Physics modes
//! - [`PhysicsMode::Dynamic`] (the default): rapier3d integrates the world. The robot is a dynamic
//!   body driven by its velocity command through [`track_velocity`] (bounded accelerations); projectiles
//!   are dynamic spheres with gravity, restitution, friction and continuous collision detection, which
//!   bounce off the ground, scenery, vehicles and the robot and push the robot on impact; vehicles stay
//!   kinematic (scripted drivers, infinite mass: they push whatever they touch); scenery is fixed.
//!   Ground truth is predicted from the bodies' current states (see [`crate::ObjectTruth::ttc_s`]).
//! - [`PhysicsMode::Analytic`]: every body follows closed-form motion (the robot integrates its
//!   command exactly, balls fly on exact lines or parabolas and pass through what they hit) and
//!   rapier only detects contacts. For detector-only studies where exact paths matter.
//!
//! # The drive: velocity tracking with bounded accelerations
//! Each physics substep of length `h` the drive reads the robot's actual velocity in its body frame
//! (forward `v_x`, lateral `v_y`, yaw rate `ω`; after any impact of the previous substep) and moves
//! each component towards the command's, clamped to the base's limits, by at most `a·h`, where `a`
//! is `max_accel_mps2` when the speed grows in magnitude and `max_decel_mps2` when it shrinks or
//! changes sign (`max_yaw_accel_rps2` for `ω`). The new velocity is given to the body directly, so
//! the motor's force is implicitly bounded by `mass_kg · max_accel_mps2`; collisions act on the
//! body in between and the drive recovers from them at the same bounded rates. This is the model of
//! ROS 2 Nav2's velocity smoother: per-axis acceleration and deceleration limits on a tracked
//! velocity.
//!
//! A [`RobotBase::DiffDrive`] base cannot move sideways: its lateral velocity is held at zero (the
//! wheels do not slip sideways; the lateral part of an impact is taken by the wheels), so it turns
//! and drives to escape. A [`RobotBase::Holonomic`] (omnidirectional) base tracks all three
//! components.

use serde::{Deserialize, Serialize};

use crate::robot::Command;

/// Which physics model a world uses (TOML `world.physics`, see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PhysicsMode {
    /// rapier3d integrates the robot and the projectiles (the default).
    #[default]
    Dynamic,
    /// Closed-form motion for every body; rapier only detects contacts.
    Analytic,
}

/// The robot's drive (TOML `world.robot.base`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RobotBase {
    /// An omnidirectional base: forward, lateral and yaw velocities are all commanded (it can
    /// sidestep). The default.
    #[default]
    Holonomic,
    /// A differential drive: forward speed and yaw rate only; it cannot move sideways.
    DiffDrive,
}

impl RobotBase {
    /// `"holonomic"` or `"diff_drive"`.
    pub fn as_str(self) -> &'static str {
        match self {
            RobotBase::Holonomic => "holonomic",
            RobotBase::DiffDrive => "diff_drive",
        }
    }

    /// Whether the base can move sideways.
    pub fn can_sidestep(self) -> bool {
        self == RobotBase::Holonomic
    }
}

/// Speed and acceleration limits of the drive (all ≥ 0; see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveLimits {
    /// Largest forward and lateral speed (m/s).
    pub max_speed_mps: f64,
    /// Largest yaw rate (rad/s).
    pub max_yaw_rate_rps: f64,
    /// Largest rate at which a speed grows in magnitude (m/s²).
    pub max_accel_mps2: f64,
    /// Largest rate at which a speed shrinks in magnitude (m/s², braking).
    pub max_decel_mps2: f64,
    /// Largest yaw acceleration (rad/s²).
    pub max_yaw_accel_rps2: f64,
}

/// A velocity in the robot's body frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyVelocity {
    /// Forward speed (m/s).
    pub forward_mps: f64,
    /// Lateral speed (m/s, positive to the left).
    pub lateral_mps: f64,
    /// Yaw rate (rad/s, positive counter-clockwise).
    pub yaw_rate_rps: f64,
}

impl BodyVelocity {
    /// The command that keeps this velocity.
    pub fn as_command(&self) -> Command {
        Command {
            forward_mps: self.forward_mps as f32,
            yaw_rate_rps: self.yaw_rate_rps as f32,
            lateral_mps: self.lateral_mps as f32,
        }
    }
}

/// One component moved from `current` towards `target` by at most `accel·h` when its magnitude
/// grows and `decel·h` when it shrinks (a sign change first brakes to zero at `decel`).
fn approach(current: f64, target: f64, accel: f64, decel: f64, h: f64) -> f64 {
    if target == current {
        return current;
    }
    let shrinking = current != 0.0 && (target.signum() != current.signum() || target.abs() < current.abs());
    if shrinking {
        // brake towards max(target, 0) in the current direction first
        let stop_at = if target.signum() == current.signum() {
            target
        } else {
            0.0
        };
        let braked = if current > 0.0 {
            (current - decel * h).max(stop_at)
        } else {
            (current + decel * h).min(stop_at)
        };
        if braked != 0.0 || stop_at != 0.0 {
            return braked;
        }
        // reached zero within the substep: the rest of the substep accelerates (no time lost)
        let used = current.abs() / decel.max(f64::MIN_POSITIVE);
        let rest = (h - used).max(0.0);
        return target.signum() * (accel * rest).min(target.abs());
    }
    let step = accel * h;
    if target > current {
        (current + step).min(target)
    } else {
        (current - step).max(target)
    }
}

/// The drive's velocity after one substep of `h` seconds (see the module docs): `current` moved towards
/// `command` (clamped to the limits; no lateral motion on a differential drive) at the bounded rates.
pub fn track_velocity(
    current: BodyVelocity,
    command: &Command,
    base: RobotBase,
    limits: &DriveLimits,
    h: f64,
) -> BodyVelocity {
    let speed = limits.max_speed_mps;
    let target_lateral = if base.can_sidestep() {
        f64::from(command.lateral_mps).clamp(-speed, speed)
    } else {
        0.0
    };
    BodyVelocity {
        forward_mps: approach(
            current.forward_mps,
            f64::from(command.forward_mps).clamp(-speed, speed),
            limits.max_accel_mps2,
            limits.max_decel_mps2,
            h,
        ),
        lateral_mps: if base.can_sidestep() {
            approach(
                current.lateral_mps,
                target_lateral,
                limits.max_accel_mps2,
                limits.max_decel_mps2,
                h,
            )
        } else {
            0.0
        },
        yaw_rate_rps: approach(
            current.yaw_rate_rps,
            f64::from(command.yaw_rate_rps).clamp(-limits.max_yaw_rate_rps, limits.max_yaw_rate_rps),
            limits.max_yaw_accel_rps2,
            limits.max_yaw_accel_rps2,
            h,
        ),
    }
}

/// Material and mass of a dynamic projectile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BallDynamics {
    /// Mass (kg).
    pub mass_kg: f64,
    /// Bounce ratio against anything (rapier's `Max` combine rule: the other surfaces have 0).
    pub restitution: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Launch time (s): the ball waits at its launch point, then starts with its planned velocity.
    pub launch_s: f64,
    /// Whether gravity acts on it (`gravity = true` in its description).
    pub gravity: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: DriveLimits = DriveLimits {
        max_speed_mps: 2.0,
        max_yaw_rate_rps: 3.0,
        max_accel_mps2: 2.0,
        max_decel_mps2: 4.0,
        max_yaw_accel_rps2: 5.0,
    };

    #[test]
    fn approach_respects_accel_and_decel() {
        assert!((approach(0.0, 1.0, 2.0, 4.0, 0.1) - 0.2).abs() < 1e-12);
        assert!((approach(0.95, 1.0, 2.0, 4.0, 0.1) - 1.0).abs() < 1e-12);
        assert!((approach(1.0, 0.0, 2.0, 4.0, 0.1) - 0.6).abs() < 1e-12);
        assert!((approach(-1.0, 0.0, 2.0, 4.0, 0.1) + 0.6).abs() < 1e-12);
        // a sign change brakes at decel, then accelerates at accel for the rest of the substep
        let v = approach(0.2, -1.0, 2.0, 4.0, 0.1);
        assert!((v - -(2.0 * 0.05)).abs() < 1e-12, "{v}");
    }

    #[test]
    fn diff_drive_never_moves_sideways_and_limits_clamp() {
        let cmd = Command {
            forward_mps: 5.0,
            yaw_rate_rps: -9.0,
            lateral_mps: 1.5,
        };
        let mut v = BodyVelocity::default();
        for _ in 0..1000 {
            v = track_velocity(v, &cmd, RobotBase::DiffDrive, &LIMITS, 0.01);
            assert_eq!(v.lateral_mps, 0.0);
        }
        assert_eq!(v.forward_mps, 2.0);
        assert_eq!(v.yaw_rate_rps, -3.0);
        let v = track_velocity(BodyVelocity::default(), &cmd, RobotBase::Holonomic, &LIMITS, 0.01);
        assert!((v.lateral_mps - 0.02).abs() < 1e-12);
    }
}
