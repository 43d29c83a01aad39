//! What the decider sees in one frame: the object's [`Percept`] and the robot's own motion
//! ([`SelfMotion`]).

use loomlab_detector::{ImageRegion, Pinhole};

use crate::VelocityCommand;

/// What the decider sees of one object in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Percept {
    /// Angular size θ̂ (degrees; NaN when unknown) — or the detector's output for output triggers.
    pub value: f64,
    /// Azimuth of the object from the optical axis (degrees, positive right), when known.
    pub azimuth_deg: Option<f64>,
    /// Elevation of the object (degrees, positive up), when known.
    pub elevation_deg: Option<f64>,
    /// The object's image extent, when known (the ideal rows and detectors that localise the
    /// object).
    pub extent: Option<ImageExtent>,
}

/// Where an object's image begins and ends, as angles from the optical axis (degrees).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ImageExtent {
    /// Azimuths of its left and right edges (positive right; `[min, max]`).
    pub azimuth_deg: [f64; 2],
    /// Elevations of its bottom and top edges (positive up; `[min, max]`).
    pub elevation_deg: [f64; 2],
}

impl Percept {
    /// Nothing seen: no value (NaN), no position.
    pub fn unknown() -> Self {
        Self {
            value: f64::NAN,
            ..Self::default()
        }
    }

    /// The percept of a real detector: its trigger-signal `value` (θ̂, or the output for output
    /// triggers), and, when it localises the object (`region`, e.g. `tracker`; a non-finite
    /// region counts as none), the middle of its image extent as azimuth and elevation and the
    /// extent as angles; else the looming side (image x in [−1, 1]) as an azimuth. Image
    /// coordinates become angles through the camera's `pinhole`.
    pub fn of_detector(value: f64, looming_side: Option<f32>, region: Option<&ImageRegion>, pinhole: &Pinhole) -> Self {
        let finite = |r: &&ImageRegion| r.x.iter().chain(&r.y).all(|v| v.is_finite());
        match region.filter(finite) {
            None => Self {
                value,
                azimuth_deg: looming_side
                    .filter(|x| x.is_finite())
                    .map(|x| pinhole.angle_deg(f64::from(x))),
                elevation_deg: None,
                extent: None,
            },
            Some(r) => Self {
                value,
                azimuth_deg: Some(pinhole.angle_deg((r.x[0] + r.x[1]) / 2.0)),
                elevation_deg: Some(pinhole.angle_deg((r.y[0] + r.y[1]) / 2.0)),
                extent: Some(ImageExtent {
                    azimuth_deg: r.x.map(|x| pinhole.angle_deg(x)),
                    elevation_deg: r.y.map(|y| pinhole.angle_deg(y)),
                }),
            },
        }
    }
}

/// What the decider knows of the robot's own motion in one frame: the **command** it applied
/// during the last camera period (its efference: forward speed and yaw rate) and the camera's
/// rotation relative to its mount as the inertial sensor on the camera **sensed** it (camera
/// shake). The detectors' counterpart, with the camera's sensed motion and pose, is
/// [`loomlab_detector::EfferenceCopy`]; both come from a [`VelocityCommand`] and a
/// [`crate::SensedCamera`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SelfMotion {
    /// Commanded yaw rate during the last camera period (rad/s, positive = turning left).
    pub yaw_rate_rps: f64,
    /// Commanded forward speed during the last camera period (m/s).
    pub forward_mps: f64,
    /// Sensed yaw of the camera relative to its mount in this frame (rad, positive = left: camera
    /// shake); image azimuths are corrected by it.
    pub camera_yaw_rad: f64,
    /// Sensed pitch of the camera relative to its mount in this frame (rad, positive = up); image
    /// elevations are corrected by it.
    pub camera_pitch_rad: f64,
}

impl SelfMotion {
    /// The robot's own motion during a camera period in which it applied `command`, its camera
    /// turned by `shake_rad` relative to its mount at the period's end (`[yaw, pitch, roll]`, as
    /// [`crate::SensedCamera::shake_rad`]; zeros for a rigid mount).
    pub fn of(command: VelocityCommand, shake_rad: [f64; 3]) -> Self {
        Self {
            yaw_rate_rps: command.yaw_rate_rps,
            forward_mps: command.forward_mps,
            camera_yaw_rad: shake_rad[0],
            camera_pitch_rad: shake_rad[1],
        }
    }
}
