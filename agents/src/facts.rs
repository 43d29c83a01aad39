//! [`RobotFacts`]: what the robot knows about itself and its camera, given to the escape controller,
//! the escape agent and the decider when they are built (not keys of the `[controller]` table).

use loomlab_detector::Pinhole;
use loomlab_sim::RobotBase;

use crate::AgentError;
use crate::decision::BodyExtent;
use crate::escape::invalid;

/// The robot's and its camera's facts: its drive, its body's extent about the camera and the
/// camera's pinhole model. The scenario loader builds them once per episode from the world
/// (`world.robot.base`, `world.robot.body`, `world.camera.position` and `world.camera.fov_deg`);
/// the escape controller reads the drive (what a dodge is), the decider the body (the course
/// gate) and the pinhole (image x ↔ azimuth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotFacts {
    /// The robot's drive, which decides what a dodge is (default holonomic).
    pub base: RobotBase,
    /// Where the robot's body extends about its camera (the course gate's target).
    pub body: BodyExtent,
    /// The robot's camera: image coordinates ↔ angles (default a 60° field of view).
    pub pinhole: Pinhole,
    /// Largest change of the forward and lateral speeds (m/s², > 0; default 2.5; infinite for a
    /// drive that follows its commands at once): the manoeuvre planner's model of the drive.
    pub accel_mps2: f64,
    /// Largest change of the yaw rate (rad/s², > 0; default 3.2; infinite as above).
    pub yaw_accel_rps2: f64,
}

impl Default for RobotFacts {
    fn default() -> Self {
        Self {
            base: RobotBase::Holonomic,
            body: BodyExtent::default(),
            pinhole: Pinhole::new(60.0),
            accel_mps2: 2.5,
            yaw_accel_rps2: 3.2,
        }
    }
}

impl RobotFacts {
    /// Check every value; the error names the world key the value comes from, the value and the
    /// valid range.
    pub fn validate(&self) -> Result<(), AgentError> {
        let half_width = self.body.half_width_m;
        if !(half_width.is_finite() && half_width >= 0.0) {
            return Err(invalid(
                "world.robot.body (half-width)",
                half_width,
                "must be a finite number of metres >= 0",
            ));
        }
        for (key, v) in [
            ("world.robot.body (reach above the camera)", self.body.above_camera_m),
            ("world.robot.body (reach below the camera)", self.body.below_camera_m),
        ] {
            if !v.is_finite() {
                return Err(invalid(key, v, "must be a finite number of metres"));
            }
        }
        for (key, v) in [
            (
                "world.robot.body (reach ahead of the camera)",
                self.body.ahead_of_camera_m,
            ),
            ("world.robot.body (reach behind the camera)", self.body.behind_camera_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(key, v, "must be a finite number of metres >= 0"));
            }
        }
        for (key, v) in [
            ("world.robot.max_accel_mps2", self.accel_mps2),
            ("world.robot.max_yaw_accel_rps2", self.yaw_accel_rps2),
        ] {
            if v.is_nan() || v <= 0.0 {
                return Err(invalid(
                    key,
                    v,
                    "must be > 0 (infinite: the drive follows its commands at once)",
                ));
            }
        }
        let fov = self.pinhole.fov_deg();
        if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
            return Err(invalid("world.camera.fov_deg", fov, "must lie in (0, 180) degrees"));
        }
        Ok(())
    }
}
