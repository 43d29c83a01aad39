//! Projectiles: spheres launched at an aim point with a chosen miss distance.
//!
//! Every projectile has a planned *analytic* path (straight line, or an exact parabola with gravity)
//! through its aim point. It waits at its launch point until the launch time, then:
//! - with dynamic physics (the default) it becomes a rapier dynamic sphere that starts with its
//!   planned position and velocity and is integrated from there: gravity (when `gravity = true`),
//!   bounces (`restitution`), friction, continuous collision detection against fast tunnelling, and
//!   impacts that push the robot;
//! - with analytic physics it follows the planned path exactly (the predicted contact time is exact)
//!   and, with `stop_at_ground`, comes to rest where it reaches the ground; it passes through
//!   whatever it touches.

use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::dynamics::BallDynamics;
use crate::glam::{DMat3, DQuat, DVec3};
use crate::object::{ObjectKind, ObjectSpec};
use crate::shape::{Part, ShapeDesc};
use crate::texture::Texture;
use crate::trajectory::{Motion, Pose64, Trajectory};

/// What a projectile is aimed at (before the miss offset).
///
/// TOML: `target = "robot"`, `target = "camera"` or `target = [x, y, z]` (metres, in the robot's start
/// frame: origin at the body centre, x forward, y left, z up).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Target {
    /// A named point: the robot's body centre or its camera, at the start.
    Named(NamedTarget),
    /// A point in the robot's start frame.
    Point([f32; 3]),
}

impl<'de> Deserialize<'de> for Target {
    /// `"robot"`, `"camera"` or `[x, y, z]`, with a message that says so (not serde's "did not
    /// match any variant of untagged enum").
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        const WANT: &str = "\"robot\", \"camera\" or a point [x, y, z] in metres";
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Target;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(WANT)
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Target, E> {
                match v {
                    "robot" => Ok(Target::Named(NamedTarget::Robot)),
                    "camera" => Ok(Target::Named(NamedTarget::Camera)),
                    other => Err(E::custom(format!("unknown target `{other}`: expected {WANT}"))),
                }
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Target, A::Error> {
                let mut p = [0.0f32; 3];
                for (i, c) in p.iter_mut().enumerate() {
                    *c = seq.next_element()?.ok_or_else(|| {
                        serde::de::Error::custom(format!("a target point has 3 numbers [x, y, z], got {i}"))
                    })?;
                }
                if seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                    return Err(serde::de::Error::custom(
                        "a target point has 3 numbers [x, y, z], got more",
                    ));
                }
                Ok(Target::Point(p))
            }
        }
        d.deserialize_any(V)
    }
}

/// Named aim points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NamedTarget {
    /// The robot's body centre at the start.
    Robot,
    /// The robot's camera at the start.
    Camera,
}

/// A projectile (TOML array of tables `[[world.projectiles]]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProjectileDesc {
    /// Name used in ground truth and contacts (default `projectile<i>`).
    pub name: Option<String>,
    /// Sphere radius (m). Default 0.15.
    pub radius_m: f32,
    /// Surface texture (default uniform 0.1: a dark ball). Sphere texture coordinates are a planar
    /// projection across the flight direction (see [`ShapeDesc`]): seen head-on, u runs to the observer's
    /// right and v up, so `orientation_deg = 0` shows horizontal stripes like the paper's disk stimuli.
    pub texture: Texture,
    /// Aim point before the miss offset. Default `"robot"`.
    pub target: Target,
    /// Perpendicular offset of the aim point from the target (m). Default 0: a direct hit.
    pub miss_distance_m: f32,
    /// Direction of the miss offset around the flight line (degrees): 0 = horizontal, to the left of the
    /// flight direction; 90 = up; 180 = right; 270 = down. Default 0.
    pub miss_angle_deg: f32,
    /// Launch point distance from the target (m), used when `launch_position` is absent. Default 20.
    pub launch_distance_m: f32,
    /// Direction of the launch point seen from the target, in the robot's start frame (degrees,
    /// 0 = straight ahead, 90 = to the left). Default 0: head-on.
    pub launch_azimuth_deg: f32,
    /// Elevation of the launch point seen from the target (degrees). Default 0.
    pub launch_elevation_deg: f32,
    /// Explicit launch point in the robot's start frame (overrides distance/azimuth/elevation).
    pub launch_position: Option<[f32; 3]>,
    /// Launch speed (m/s). Default 10.
    pub speed_mps: f32,
    /// Launch time (s). Give at most one of `launch_time_s` and `arrival_time_s`; default: launch at 0.
    pub launch_time_s: Option<f32>,
    /// Time at which the projectile passes the aim point (s).
    pub arrival_time_s: Option<f32>,
    /// Fly a ballistic parabola under the world's gravity (the launch velocity is solved so that the path
    /// passes through the aim point, on the low arc). Default false: a straight line.
    pub gravity: bool,
    /// Analytic physics: stop where the sphere reaches the ground (when the world has one). Default
    /// true. (With dynamic physics a ball bounces by its `restitution`; 0 makes it stay down.)
    pub stop_at_ground: bool,
    /// Mass (kg; dynamic physics). Default 0.45, a football.
    pub mass_kg: f32,
    /// Bounce ratio (dynamic physics): the normal speed after an impact over the one before, against
    /// anything (the ground, scenery, vehicles, the robot), in [0, 1]. Default 0.6.
    pub restitution: f32,
    /// Coulomb friction coefficient (dynamic physics). Default 0.5.
    pub friction: f32,
}

impl Default for ProjectileDesc {
    fn default() -> Self {
        ProjectileDesc {
            name: None,
            radius_m: 0.15,
            texture: Texture::uniform(0.1),
            target: Target::Named(NamedTarget::Robot),
            miss_distance_m: 0.0,
            miss_angle_deg: 0.0,
            launch_distance_m: 20.0,
            launch_azimuth_deg: 0.0,
            launch_elevation_deg: 0.0,
            launch_position: None,
            speed_mps: 10.0,
            launch_time_s: None,
            arrival_time_s: None,
            gravity: false,
            stop_at_ground: true,
            mass_kg: 0.45,
            restitution: 0.6,
            friction: 0.5,
        }
    }
}

/// Everything about the robot's start that aiming needs.
pub(crate) struct AimFrame {
    /// Robot body-centre pose at t = 0.
    pub robot: Pose64,
    /// Camera position at t = 0 (without shake).
    pub camera: DVec3,
    /// Gravity (m/s²).
    pub gravity: f64,
    /// Whether there is a ground plane at z = 0.
    pub ground: bool,
}

fn finite(key: &str, v: f32) -> Result<f64, SimError> {
    if v.is_finite() {
        Ok(v.into())
    } else {
        Err(SimError::invalid(key, v, "must be finite"))
    }
}

fn v3(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0].into(), a[1].into(), a[2].into())
}

impl ProjectileDesc {
    /// Builds the projectile's trajectory and body; `index` is its position in `world.projectiles`.
    pub(crate) fn build(&self, index: usize, frame: &AimFrame, seed: u32) -> Result<ObjectSpec, SimError> {
        let key = format!("world.projectiles[{index}]");
        let k = |name: &str| format!("{key}.{name}");
        let part = Part::new(
            &ShapeDesc::Sphere {
                radius_m: self.radius_m,
            },
            [0.0; 3],
            0.0,
            &self.texture,
            &key,
            seed,
        )?;
        let radius = f64::from(self.radius_m);
        let mass_kg = finite(&k("mass_kg"), self.mass_kg)?;
        if mass_kg <= 0.0 {
            return Err(SimError::invalid(k("mass_kg"), mass_kg, "must be > 0"));
        }
        let restitution = finite(&k("restitution"), self.restitution)?;
        if !(0.0..=1.0).contains(&restitution) {
            return Err(SimError::invalid(k("restitution"), restitution, "must be in [0, 1]"));
        }
        let friction = finite(&k("friction"), self.friction)?;
        if friction < 0.0 {
            return Err(SimError::invalid(k("friction"), friction, "must be >= 0"));
        }
        let speed = finite(&k("speed_mps"), self.speed_mps)?;
        if speed <= 0.0 {
            return Err(SimError::invalid(k("speed_mps"), speed, "must be > 0"));
        }
        let miss = finite(&k("miss_distance_m"), self.miss_distance_m)?;
        if miss < 0.0 {
            return Err(SimError::invalid(
                k("miss_distance_m"),
                miss,
                "must be >= 0 (use miss_angle_deg for the side)",
            ));
        }
        let target = match &self.target {
            Target::Named(NamedTarget::Robot) => frame.robot.position,
            Target::Named(NamedTarget::Camera) => frame.camera,
            Target::Point(p) => {
                for (i, v) in p.iter().enumerate() {
                    finite(&format!("{key}.target[{i}]"), *v)?;
                }
                frame.robot.transform_point(v3(*p))
            }
        };
        let launch = match self.launch_position {
            Some(p) => {
                for (i, v) in p.iter().enumerate() {
                    finite(&format!("{key}.launch_position[{i}]"), *v)?;
                }
                frame.robot.transform_point(v3(p))
            }
            None => {
                let d = finite(&k("launch_distance_m"), self.launch_distance_m)?;
                if d <= 0.0 {
                    return Err(SimError::invalid(k("launch_distance_m"), d, "must be > 0"));
                }
                let az = finite(&k("launch_azimuth_deg"), self.launch_azimuth_deg)?.to_radians();
                let el = finite(&k("launch_elevation_deg"), self.launch_elevation_deg)?.to_radians();
                let dir_local = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
                target + frame.robot.rotation * dir_local * d
            }
        };
        let line = target - launch;
        if line.length() < 1e-6 {
            return Err(SimError::invalid(
                k("launch_position"),
                format!("[{:.3}, {:.3}, {:.3}]", launch.x, launch.y, launch.z),
                "launch point equals the target",
            ));
        }
        let d = line.normalize();
        let left = {
            let h = d.cross(DVec3::Z);
            if h.length() < 1e-6 {
                frame.robot.rotation * DVec3::Y
            } else {
                h.normalize()
            }
        };
        let up = left.cross(d);
        let a = finite(&k("miss_angle_deg"), self.miss_angle_deg)?.to_radians();
        let aim = target + miss * (a.cos() * left + a.sin() * up);
        if frame.ground && launch.z < radius - 1e-9 {
            let why = format!(
                "the ball (radius_m = {radius}) would start partly below the ground: its launch point is at \
                 z = {:.3} m, and z must be >= radius_m",
                launch.z
            );
            // blame what the user wrote: an explicit launch point, else the radius
            return Err(match self.launch_position {
                Some(p) => SimError::invalid(k("launch_position"), format!("[{}, {}, {}]", p[0], p[1], p[2]), why),
                None => SimError::invalid(k("radius_m"), radius, why),
            });
        }

        let delta = aim - launch;
        let (motion, flight_time) = if self.gravity && frame.gravity > 0.0 {
            let g = frame.gravity;
            let horiz = DVec3::new(delta.x, delta.y, 0.0);
            let dist = horiz.length();
            let h = delta.z;
            if dist < 1e-6 {
                return Err(SimError::invalid(
                    k("gravity"),
                    true,
                    "a ballistic launch needs a horizontal distance to the aim point",
                ));
            }
            let s2 = speed * speed;
            let disc = s2 * s2 - g * (g * dist * dist + 2.0 * h * s2);
            if disc < 0.0 {
                let min_speed = (g * (h + (h * h + dist * dist).sqrt())).sqrt();
                return Err(SimError::invalid(
                    k("speed_mps"),
                    speed,
                    format!("too slow to reach the aim point under gravity; need at least {min_speed:.2} m/s"),
                ));
            }
            let tan = (s2 - disc.sqrt()) / (g * dist); // low arc
            let cos = 1.0 / (1.0 + tan * tan).sqrt();
            let hd = horiz / dist;
            let v0 = speed * (cos * hd + (tan * cos) * DVec3::Z);
            (
                Motion::Ballistic {
                    velocity: v0,
                    gravity: g,
                },
                dist / (speed * cos),
            )
        } else {
            (
                Motion::Linear {
                    velocity: d_or(delta) * speed,
                },
                delta.length() / speed,
            )
        };
        let t_launch = match (self.launch_time_s, self.arrival_time_s) {
            (Some(_), Some(_)) => {
                return Err(SimError::invalid(
                    k("arrival_time_s"),
                    "(both set)",
                    "give at most one of launch_time_s and arrival_time_s",
                ));
            }
            (Some(t), None) => finite(&k("launch_time_s"), t)?,
            (None, Some(t)) => {
                let t_launch = finite(&k("arrival_time_s"), t)? - flight_time;
                if t_launch < 0.0 {
                    return Err(SimError::invalid(
                        k("arrival_time_s"),
                        t,
                        format!("the flight takes {flight_time:.3} s, so arrival must be >= that (launch at t >= 0)"),
                    ));
                }
                t_launch
            }
            (None, None) => 0.0,
        };
        if t_launch < 0.0 {
            return Err(SimError::invalid(k("launch_time_s"), t_launch, "must be >= 0"));
        }
        let velocity0 = match motion {
            Motion::Linear { velocity } | Motion::Ballistic { velocity, .. } => velocity,
            _ => DVec3::X,
        };
        // body frame: x along the flight, z as close to world up as possible; seen head-on, the texture's
        // u runs to the observer's right and v up
        let x = velocity0.normalize();
        let y = DVec3::Z.cross(x);
        let y = if y.length() < 1e-6 {
            frame.robot.rotation * DVec3::Y
        } else {
            y.normalize()
        };
        let rotation = DQuat::from_mat3(&DMat3::from_cols(x, y, x.cross(y))).normalize();
        let pose = Pose64 {
            position: launch,
            rotation,
        };
        let land = if self.stop_at_ground && frame.ground {
            landing_time(launch.z - radius, motion).map(|tau| t_launch + tau)
        } else {
            None
        };
        Ok(ObjectSpec {
            name: self.name.clone().unwrap_or_else(|| format!("projectile{index}")),
            kind: ObjectKind::Projectile,
            parts: vec![part],
            trajectory: Trajectory::hold_move_hold(pose, t_launch, motion, land.unwrap_or(f64::INFINITY)),
            ball: Some(BallDynamics {
                mass_kg,
                restitution,
                friction,
                launch_s: t_launch,
                gravity: matches!(motion, Motion::Ballistic { .. }),
            }),
        })
    }
}

fn d_or(v: DVec3) -> DVec3 {
    v.normalize_or(DVec3::X)
}

/// Time after launch at which the centre has descended by `height` (the sphere touches the ground).
fn landing_time(height: f64, motion: Motion) -> Option<f64> {
    match motion {
        Motion::Linear { velocity } if velocity.z < 0.0 => Some(height / -velocity.z),
        Motion::Ballistic { velocity, gravity } if gravity > 0.0 => {
            Some((velocity.z + (velocity.z * velocity.z + 2.0 * gravity * height).sqrt()) / gravity)
        }
        _ => None,
    }
}
