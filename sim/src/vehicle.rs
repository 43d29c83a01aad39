//! Vehicles: boxes or composites driving a straight or circular path at constant speed.
//!
//! Like projectiles, vehicles are kinematic bodies on analytic paths (exact, reproducible). A vehicle
//! waits at its start until `start_time_s`, drives along a path of constant curvature (0 = straight) and,
//! with `travel_m`, stops after that distance. Whether it passes, stops short or hits the robot is a
//! matter of its path; the ground truth says which.

use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::glam::{DQuat, DVec3};
use crate::object::{ObjectKind, ObjectSpec};
use crate::shape::{Part, ShapeDesc};
use crate::texture::Texture;
use crate::trajectory::{Motion, Pose64, Trajectory};

/// One rigid part of a vehicle or composite scenery item.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PartDesc {
    /// The primitive.
    pub shape: ShapeDesc,
    /// Centre of the part in the vehicle frame (x forward, y left, z up from the ground under the
    /// vehicle's reference point). Default: `[0, 0, height/2]`, resting on the ground.
    pub offset: Option<[f32; 3]>,
    /// Rotation of the part about the vertical (degrees).
    pub yaw_deg: f32,
    /// Texture of the part.
    pub texture: Texture,
}

impl Default for PartDesc {
    fn default() -> Self {
        PartDesc {
            shape: ShapeDesc::Box { size: [4.0, 1.8, 1.5] },
            offset: None,
            yaw_deg: 0.0,
            texture: Texture::uniform(0.2),
        }
    }
}

impl PartDesc {
    /// Builds the part.
    pub(crate) fn build(&self, key: &str, seed: u32) -> Result<Part, SimError> {
        let prim = self.shape.to_prim(&format!("{key}.shape"))?;
        let offset = self.offset.unwrap_or([0.0, 0.0, prim.height() / 2.0]);
        Part::new(&self.shape, offset, self.yaw_deg, &self.texture, key, seed)
    }
}

/// A vehicle (TOML array of tables `[[world.vehicles]]`). Positions are world coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VehicleDesc {
    /// Name used in ground truth and contacts (default `vehicle<i>`).
    pub name: Option<String>,
    /// Rigid parts (default: one 4 × 1.8 × 1.5 m box of luminance 0.2, a car).
    pub parts: Vec<PartDesc>,
    /// Start position `[x, y]` of the reference point (m). Default `[30, 0]`.
    pub start: [f32; 2],
    /// Initial heading (degrees from +x, counter-clockwise). Give at most one of `heading_deg` and
    /// `toward`; default: towards the world origin.
    pub heading_deg: Option<f32>,
    /// A point `[x, y]` the vehicle initially heads for.
    pub toward: Option<[f32; 2]>,
    /// Path curvature (1/m; positive = turning left, 0 = straight). Default 0.
    pub curvature_per_m: f32,
    /// Speed (m/s). Default 10.
    pub speed_mps: f32,
    /// Time at which it starts driving (s). Default 0.
    pub start_time_s: f32,
    /// Distance after which it stops (m). Default: never stops.
    pub travel_m: Option<f32>,
    /// Deceleration with which it brakes to stand at the end of `travel_m` (m/s², > 0; straight
    /// paths only). Default: it stops at once (an infinite deceleration).
    pub brake_mps2: Option<f32>,
}

impl Default for VehicleDesc {
    fn default() -> Self {
        VehicleDesc {
            name: None,
            parts: vec![PartDesc::default()],
            start: [30.0, 0.0],
            heading_deg: None,
            toward: None,
            curvature_per_m: 0.0,
            speed_mps: 10.0,
            start_time_s: 0.0,
            travel_m: None,
            brake_mps2: None,
        }
    }
}

impl VehicleDesc {
    /// Builds the vehicle; `index` is its position in `world.vehicles`.
    pub(crate) fn build(&self, index: usize, seed: u32) -> Result<ObjectSpec, SimError> {
        let key = format!("world.vehicles[{index}]");
        let k = |name: &str| format!("{key}.{name}");
        if self.parts.is_empty() {
            return Err(SimError::invalid(k("parts"), "[]", "a vehicle needs at least one part"));
        }
        let parts = self
            .parts
            .iter()
            .enumerate()
            .map(|(i, p)| p.build(&format!("{key}.parts[{i}]"), seed.wrapping_add(i as u32)))
            .collect::<Result<Vec<_>, _>>()?;
        let nums = [
            ("start[0]", self.start[0]),
            ("start[1]", self.start[1]),
            ("curvature_per_m", self.curvature_per_m),
            ("speed_mps", self.speed_mps),
            ("start_time_s", self.start_time_s),
        ];
        for (name, v) in nums {
            if !v.is_finite() {
                return Err(SimError::invalid(k(name), v, "must be finite"));
            }
        }
        if self.speed_mps < 0.0 {
            return Err(SimError::invalid(k("speed_mps"), self.speed_mps, "must be >= 0"));
        }
        if self.start_time_s < 0.0 {
            return Err(SimError::invalid(k("start_time_s"), self.start_time_s, "must be >= 0"));
        }
        let start = DVec3::new(self.start[0].into(), self.start[1].into(), 0.0);
        let heading = match (self.heading_deg, self.toward) {
            (Some(_), Some(_)) => {
                return Err(SimError::invalid(
                    k("toward"),
                    "(both set)",
                    "give at most one of heading_deg and toward",
                ));
            }
            (Some(h), None) if h.is_finite() => f64::from(h).to_radians(),
            (Some(h), None) => return Err(SimError::invalid(k("heading_deg"), h, "must be finite")),
            (None, to) => {
                let to = to
                    .map(|p| DVec3::new(p[0].into(), p[1].into(), 0.0))
                    .unwrap_or(DVec3::ZERO);
                let d = to - start;
                if d.length() < 1e-9 {
                    return Err(SimError::invalid(
                        k("toward"),
                        format!("{to:?}"),
                        "the vehicle starts at the point it heads for",
                    ));
                }
                d.y.atan2(d.x)
            }
        };
        let pose = Pose64 {
            position: start,
            rotation: DQuat::from_rotation_z(heading),
        };
        let speed = f64::from(self.speed_mps);
        let kappa = f64::from(self.curvature_per_m);
        let motion = if speed == 0.0 {
            Motion::Hold
        } else if kappa == 0.0 {
            Motion::Linear {
                velocity: pose.rotation * DVec3::X * speed,
            }
        } else {
            Motion::Arc {
                center: pose.transform_point(DVec3::new(0.0, 1.0 / kappa, 0.0)),
                yaw_rate: speed * kappa,
            }
        };
        let t0 = f64::from(self.start_time_s);
        let t_end = match self.travel_m {
            Some(d) if !(d.is_finite() && d >= 0.0) => {
                return Err(SimError::invalid(k("travel_m"), d, "must be >= 0"));
            }
            Some(d) if speed > 0.0 => t0 + f64::from(d) / speed,
            _ => f64::INFINITY,
        };
        let trajectory = match (self.brake_mps2, self.travel_m, motion) {
            (None, ..) => Trajectory::hold_move_hold(pose, t0, motion, t_end),
            (Some(a), _, _) if !(a.is_finite() && a > 0.0) => {
                return Err(SimError::invalid(k("brake_mps2"), a, "must be a finite number > 0"));
            }
            (Some(a), Some(d), Motion::Linear { velocity }) => {
                let braking_m = speed * speed / (2.0 * f64::from(a));
                if braking_m > f64::from(d) {
                    return Err(SimError::invalid(
                        k("brake_mps2"),
                        a,
                        format!(
                            "braking from {speed} m/s takes {braking_m:.2} m, more than travel_m = {d}; brake harder or travel further"
                        ),
                    ));
                }
                let t_brake = t0 + (f64::from(d) - braking_m) / speed;
                Trajectory::hold_drive_brake_hold(pose, t0, velocity, t_brake, f64::from(a))
            }
            (Some(a), None, _) => {
                return Err(SimError::invalid(
                    k("brake_mps2"),
                    a,
                    "needs travel_m (where the vehicle stops)",
                ));
            }
            (Some(a), Some(_), _) => {
                return Err(SimError::invalid(
                    k("brake_mps2"),
                    a,
                    "braking needs a straight path with a speed > 0 (curvature_per_m = 0)",
                ));
            }
        };
        Ok(ObjectSpec {
            name: self.name.clone().unwrap_or_else(|| format!("vehicle{index}")),
            kind: ObjectKind::Vehicle,
            parts,
            trajectory,
            ball: None,
        })
    }
}
