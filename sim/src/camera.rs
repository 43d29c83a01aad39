//! The robot's camera: mount pose, field of view, resolution and optional shake.
//!
//! Camera frame: x = optical axis (forward), y = left, z = up. The image is n × n, row 0 at the top,
//! column 0 at the left; the field of view is the full angle across the image width (and height).
//! Image coordinates in [`crate::ObjectTruth`] are normalised: x ∈ [-1, 1] left to right, y ∈ [-1, 1]
//! bottom to top, ±1 at the image border, so a pixel column is `(x + 1) / 2 · n`.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::glam::{DQuat, DVec3};
use crate::sensor::SensorDesc;
use crate::trajectory::Pose64;

/// Camera description (TOML table `[world.camera]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraDesc {
    /// Image size in pixels (n × n), [`MIN_FRAME_SIZE`]`..=`[`MAX_N`] (20..=2048). Default 128.
    pub n: u32,
    /// Full field of view across the image (degrees). Default 60.
    pub fov_deg: f32,
    /// Camera position relative to the robot body centre, body frame `[x fwd, y left, z up]` (m).
    /// Default `[0.25, 0.0, 0.1]`: at the front face of the default body, 0.1 m above its centre.
    pub position: [f32; 3],
    /// Pan relative to the body (degrees, positive = left). Default 0.
    pub yaw_deg: f32,
    /// Tilt (degrees, positive = up). Default 0.
    pub pitch_deg: f32,
    /// Near clipping distance (m). Default 0.01.
    pub near_m: f32,
    /// Optional camera shake (default: none).
    pub shake: Option<ShakeDesc>,
    /// The sensor (`[world.camera.sensor]`: exposure blur, noise, gain, gamma, quantisation;
    /// [`crate::sensor`]). Default: the ideal camera (left out when written).
    #[serde(skip_serializing_if = "SensorDesc::is_ideal")]
    pub sensor: SensorDesc,
    /// Perception latency (s): a step's frame is the view this much earlier, quantised to camera
    /// frames ([`crate::latency`]). Default 0 (left out when written).
    #[serde(skip_serializing_if = "crate::robot::is_zero")]
    pub perception_latency_s: f32,
    /// What the camera delivers: `"frames"` (default) or `"events"` (frames and, each period, an
    /// event camera's events on the same view; [`crate::events`]). Left out when `"frames"`.
    #[serde(skip_serializing_if = "crate::events::CameraKind::is_frames")]
    pub kind: crate::events::CameraKind,
    /// The event camera's parameters (`[world.camera.events]`, read with `kind = "events"`).
    /// Default: [`crate::events::EventCameraDesc::default`] (left out when written).
    #[serde(skip_serializing_if = "crate::events::EventCameraDesc::is_default")]
    pub events: crate::events::EventCameraDesc,
}

impl CameraDesc {
    /// The event camera's validated parameters with `kind = "events"`, `None` with `"frames"`;
    /// an error for parameters set without `kind = "events"` or beside a non-ideal frame sensor.
    pub(crate) fn event_camera(&self) -> Result<Option<crate::events::EventCameraDesc>, SimError> {
        match self.kind {
            crate::events::CameraKind::Frames if !self.events.is_default() => Err(SimError::invalid(
                "world.camera.events",
                "a table of event camera parameters",
                "is read only with world.camera.kind = \"events\": set it, or remove the table",
            )),
            crate::events::CameraKind::Frames => Ok(None),
            crate::events::CameraKind::Events if !self.sensor.is_ideal() => Err(SimError::invalid(
                "world.camera.kind",
                "\"events\"",
                "needs the ideal frame sensor (the event camera has its own noise model): remove \
                 [world.camera.sensor] or use the ideal sensor profile",
            )),
            crate::events::CameraKind::Events => {
                self.events.validate()?;
                Ok(Some(self.events))
            }
        }
    }
}

impl Default for CameraDesc {
    fn default() -> Self {
        CameraDesc {
            n: 128,
            fov_deg: 60.0,
            position: [0.25, 0.0, 0.1],
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            near_m: 0.01,
            shake: None,
            sensor: SensorDesc::default(),
            perception_latency_s: 0.0,
            kind: crate::events::CameraKind::Frames,
            events: crate::events::EventCameraDesc::default(),
        }
    }
}

/// Camera shake: smooth pseudo-random rotation and translation jitter of the camera on its mount.
///
/// Each of the six axes is a sum of three sinusoids with frequencies drawn from U(0.5, 1.5) ×
/// `frequency_hz` and random phases (from the simulation seed), scaled so that its RMS equals the given
/// amplitude. Ground truth uses the shaken camera pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShakeDesc {
    /// RMS rotation per axis (degrees). Default 0.5.
    pub rotation_deg: f32,
    /// RMS translation per axis (m). Default 0.
    pub translation_m: f32,
    /// Typical frequency (Hz). Default 8.
    pub frequency_hz: f32,
}

impl Default for ShakeDesc {
    fn default() -> Self {
        ShakeDesc {
            rotation_deg: 0.5,
            translation_m: 0.0,
            frequency_hz: 8.0,
        }
    }
}

/// Largest supported image size.
pub const MAX_N: u32 = 2048;

/// Largest camera shake rotation amplitude (degrees).
pub const MAX_SHAKE_ROTATION_DEG: f32 = 45.0;
/// Largest camera shake translation amplitude (m).
pub const MAX_SHAKE_TRANSLATION_M: f32 = 1.0;

/// Smallest camera image side (pixels) that every detector of loomlab accepts: 20.
///
/// The requirement is the detectors' (`loomlab_detector::MIN_FRAME_SIZE`, where it is derived from
/// the Hopfield detector's paper template schedule: its first template disk is 0.1·n wide and needs
/// at least 2 pixels). The simulator does not depend on the detector crate (both are level 0, see
/// docs/architecture.md), so this is the simulator's statement of that one number; a test of this
/// crate (`tests/bounds.rs`, with the detector crate as a dev-dependency) fails if they ever differ.
pub const MIN_FRAME_SIZE: u32 = 20;

/// A validated camera, ready to compute poses and projections.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Image size.
    pub n: u32,
    /// Full field of view (rad).
    pub fov_rad: f64,
    /// Near clipping distance (m).
    pub near_m: f32,
    mount: Pose64,
    /// `[axis][component] = (amplitude, angular frequency, phase)`; axes: yaw, pitch, roll, x, y, z.
    shake: Option<[[(f64, f64, f64); 3]; 6]>,
}

/// Where a world point appears to the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// Azimuth from the optical axis (degrees, positive = right), in (-180, 180].
    pub bearing_deg: f64,
    /// Elevation above the optical axis' horizontal plane (degrees, positive = up).
    pub elevation_deg: f64,
    /// Normalised image x (−1 left border, +1 right border); `None` behind the camera.
    pub image_x: Option<f64>,
    /// Normalised image y (−1 bottom, +1 top); `None` behind the camera.
    pub image_y: Option<f64>,
    /// Distance along the optical axis (m; negative behind the camera).
    pub depth_m: f64,
}

impl CameraDesc {
    /// Validates the description; `seed` draws the shake phases.
    pub fn build(&self, seed: u64) -> Result<Camera, SimError> {
        if !(MIN_FRAME_SIZE..=MAX_N).contains(&self.n) {
            return Err(SimError::invalid(
                "world.camera.n",
                self.n,
                format!(
                    "must be in {MIN_FRAME_SIZE}..={MAX_N} pixels (the detectors need frames of at least \
                     {MIN_FRAME_SIZE}×{MIN_FRAME_SIZE})"
                ),
            ));
        }
        if !(self.fov_deg.is_finite() && self.fov_deg > 0.5 && self.fov_deg < 170.0) {
            return Err(SimError::invalid(
                "world.camera.fov_deg",
                self.fov_deg,
                "must be in (0.5, 170) degrees",
            ));
        }
        if !(self.near_m.is_finite() && self.near_m > 0.0) {
            return Err(SimError::invalid("world.camera.near_m", self.near_m, "must be > 0"));
        }
        if self.position.iter().any(|v| !v.is_finite()) {
            let [x, y, z] = self.position;
            return Err(SimError::invalid(
                "world.camera.position",
                format!("[{x}, {y}, {z}]"),
                "must be finite",
            ));
        }
        for (k, v) in [("yaw_deg", self.yaw_deg), ("pitch_deg", self.pitch_deg)] {
            if !v.is_finite() {
                return Err(SimError::invalid(format!("world.camera.{k}"), v, "must be finite"));
            }
        }
        let mount = Pose64 {
            position: DVec3::new(
                self.position[0].into(),
                self.position[1].into(),
                self.position[2].into(),
            ),
            rotation: DQuat::from_rotation_z(f64::from(self.yaw_deg).to_radians())
                * DQuat::from_rotation_y(-f64::from(self.pitch_deg).to_radians()),
        };
        let shake = match &self.shake {
            None => None,
            Some(s) => {
                for (k, v) in [
                    ("rotation_deg", s.rotation_deg),
                    ("translation_m", s.translation_m),
                    ("frequency_hz", s.frequency_hz),
                ] {
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(SimError::invalid(format!("world.camera.shake.{k}"), v, "must be >= 0"));
                    }
                }
                // a shake is a jitter of the mount, not a move of the camera somewhere else (a
                // larger one would move the aim point of `target = "camera"` and blame that)
                for (k, v, max) in [
                    ("rotation_deg", s.rotation_deg, MAX_SHAKE_ROTATION_DEG),
                    ("translation_m", s.translation_m, MAX_SHAKE_TRANSLATION_M),
                ] {
                    if v > max {
                        return Err(SimError::invalid(
                            format!("world.camera.shake.{k}"),
                            v,
                            format!("must be <= {max} (a shake of the camera on its mount)"),
                        ));
                    }
                }
                let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5348_414b_4521);
                let comp_scale = (2.0f64 / 3.0).sqrt();
                let mut axes = [[(0.0, 0.0, 0.0); 3]; 6];
                for (i, axis) in axes.iter_mut().enumerate() {
                    let amp = if i < 3 {
                        f64::from(s.rotation_deg).to_radians()
                    } else {
                        f64::from(s.translation_m)
                    };
                    for c in axis.iter_mut() {
                        let f = f64::from(s.frequency_hz) * rng.random_range(0.5..1.5);
                        let phase = rng.random_range(0.0..std::f64::consts::TAU);
                        *c = (amp * comp_scale, std::f64::consts::TAU * f, phase);
                    }
                }
                Some(axes)
            }
        };
        Ok(Camera {
            n: self.n,
            fov_rad: f64::from(self.fov_deg).to_radians(),
            near_m: self.near_m,
            mount,
            shake,
        })
    }
}

impl Camera {
    /// Focal length in pixels: `f = (n/2) / tan(fov/2)`.
    pub fn focal_px(&self) -> f64 {
        f64::from(self.n) / 2.0 / (self.fov_rad / 2.0).tan()
    }

    /// World pose of the camera (x = optical axis, z = up) for a robot body pose at time `t`.
    pub fn pose(&self, body: &Pose64, t: f64) -> Pose64 {
        let mounted = body.mul(&self.mount);
        match &self.shake {
            None => mounted,
            Some(axes) => {
                let v = |i: usize| axes[i].iter().map(|(a, w, p)| a * (w * t + p).sin()).sum::<f64>();
                let jitter = Pose64 {
                    position: DVec3::new(v(3), v(4), v(5)),
                    rotation: DQuat::from_rotation_z(v(0))
                        * DQuat::from_rotation_y(-v(1))
                        * DQuat::from_rotation_x(v(2)),
                };
                mounted.mul(&jitter)
            }
        }
    }

    /// The shake's rotation of the camera relative to its mount at time `t`: `[yaw, pitch, roll]`
    /// (rad; yaw positive = left, pitch positive = up; zeros without shake) — what the robot's
    /// inertial sensor measures.
    pub fn shake_rotation(&self, t: f64) -> [f64; 3] {
        match &self.shake {
            None => [0.0; 3],
            Some(axes) => {
                let v = |i: usize| axes[i].iter().map(|(a, w, p)| a * (w * t + p).sin()).sum::<f64>();
                [v(0), v(1), v(2)]
            }
        }
    }

    /// Projects a world point into the camera at `cam`.
    pub fn project(&self, cam: &Pose64, p: DVec3) -> Projection {
        let rel = cam.rotation.inverse() * (p - cam.position);
        let (x, y, z) = (rel.x, rel.y, rel.z);
        let t = (self.fov_rad / 2.0).tan();
        let (image_x, image_y) = if x > 1e-9 {
            (Some(-y / x / t), Some(z / x / t))
        } else {
            (None, None)
        };
        Projection {
            bearing_deg: (-y).atan2(x).to_degrees(),
            elevation_deg: z.atan2(x.hypot(y)).to_degrees(),
            image_x,
            image_y,
            depth_m: x,
        }
    }
}
