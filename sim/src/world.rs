//! The world description: a plain, serde-deserialisable struct (scenario files embed it as `[world]`).
//!
//! Coordinates: right-handed, metres, z up, ground plane z = 0. The robot starts at `robot.start` (default
//! the origin) heading along `robot.yaw_deg` (default 0: driving along +x, so +y is to its left). Angles
//! are in degrees in descriptions, counter-clockwise about +z. Scenery and vehicles are placed in world
//! coordinates; projectiles are aimed in the robot's start frame.

use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::camera::{Camera, CameraDesc};
use crate::dynamics::PhysicsMode;
use crate::object::ObjectSpec;
use crate::projectile::{AimFrame, ProjectileDesc};
use crate::robot::RobotDesc;
use crate::scenery::{OverpassDesc, PoleDesc, SceneryDesc, WallDesc};
use crate::shape::Prim;
use crate::texture::{GratingDesc, ResolvedTexture, Texture};
use crate::trajectory::Pose64;
use crate::vehicle::VehicleDesc;

/// The smallest full extent of a shape (m): a box's shortest edge, a sphere's diameter, the
/// smaller of a cylinder's diameter and height.
fn min_extent(shape: &crate::shape::ShapeDesc) -> f64 {
    use crate::shape::ShapeDesc;
    f64::from(match *shape {
        ShapeDesc::Box { size } => size[0].min(size[1]).min(size[2]),
        ShapeDesc::Sphere { radius_m } => 2.0 * radius_m,
        ShapeDesc::Cylinder { radius_m, height_m } => (2.0 * radius_m).min(height_m),
    })
}

fn d_camera_hz() -> f32 {
    120.0
}
fn d_substeps() -> u32 {
    1
}
fn d_gravity() -> f32 {
    9.81
}
fn d_horizon() -> f32 {
    10.0
}
fn d_sky() -> f32 {
    0.8
}
fn d_harmless() -> f32 {
    0.2
}
fn d_ground_friction() -> f32 {
    0.6
}

/// The ground plane z = 0 (TOML table `[world.ground]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GroundDesc {
    /// Draw the ground (and stop projectiles on it). Default true.
    pub enabled: bool,
    /// Ground texture in world `(u, v) = (x, y)` (default: 1 m checker, luminance 0.3 / 0.5).
    pub texture: Texture,
    /// Coulomb friction coefficient of the ground (dynamic physics: rolling and sliding balls).
    /// Default 0.6.
    #[serde(default = "d_ground_friction")]
    pub friction: f32,
}

impl Default for GroundDesc {
    fn default() -> Self {
        GroundDesc {
            enabled: true,
            texture: Texture::Checker {
                size_m: 1.0,
                dark: 0.3,
                light: 0.5,
            },
            friction: d_ground_friction(),
        }
    }
}

/// A whole simulated world (TOML table `[world]`).
///
/// `WorldDesc::default()` is a small demo scene (a ball thrown head-on at the robot, a grating wall, a
/// pole and a passing car). When deserialising, absent keys take their *individual* defaults and absent
/// object lists are empty, so a file lists exactly the objects it wants ([`WorldDesc::empty`] is the
/// same thing in code).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldDesc {
    /// Physics model: `"dynamic"` (default: rapier integrates the robot within its drive limits and
    /// the projectiles, which bounce and push) or `"analytic"` (closed-form paths, rapier only detects
    /// contacts). See [`crate::dynamics`].
    #[serde(default)]
    pub physics: PhysicsMode,
    /// Contacts whose impact speed (the relative speed of the two bodies when they first touch) is
    /// below this are harmless ([`crate::Contact::harmless`]): not a collision (m/s). Default 0.2,
    /// e.g. a ball rolling against a wheel.
    #[serde(default = "d_harmless")]
    pub harmless_impact_speed_mps: f32,
    /// Camera frame rate (Hz); one [`crate::Sim::step`] advances 1/camera_hz seconds. Default 120.
    #[serde(default = "d_camera_hz")]
    pub camera_hz: f32,
    /// Physics steps per camera frame (contact detection, and integration with dynamic physics).
    /// Default 1.
    #[serde(default = "d_substeps")]
    pub physics_substeps: u32,
    /// Gravity for ballistic projectiles (m/s²). Default 9.81.
    #[serde(default = "d_gravity")]
    pub gravity_mps2: f32,
    /// How far ahead collision courses are predicted (s). Default 10.
    #[serde(default = "d_horizon")]
    pub prediction_horizon_s: f32,
    /// Sky luminance (everything above the horizon that no object covers). Default 0.8.
    #[serde(default = "d_sky")]
    pub sky_luminance: f32,
    /// The ground plane.
    #[serde(default)]
    pub ground: GroundDesc,
    /// The robot.
    #[serde(default)]
    pub robot: RobotDesc,
    /// The robot's camera.
    #[serde(default)]
    pub camera: CameraDesc,
    /// Static scenery.
    #[serde(default)]
    pub scenery: Vec<SceneryDesc>,
    /// Projectiles.
    #[serde(default)]
    pub projectiles: Vec<ProjectileDesc>,
    /// Vehicles.
    #[serde(default)]
    pub vehicles: Vec<VehicleDesc>,
}

impl Default for WorldDesc {
    fn default() -> Self {
        WorldDesc {
            scenery: vec![
                SceneryDesc::Wall(WallDesc {
                    texture: Texture::SquareGrating(GratingDesc {
                        period_m: Some(0.5),
                        orientation_deg: 90.0,
                        dark: 0.2,
                        light: 0.8,
                        ..Default::default()
                    }),
                    ..Default::default()
                }),
                SceneryDesc::Pole(PoleDesc::default()),
                SceneryDesc::Overpass(OverpassDesc {
                    position: [40.0, 0.0],
                    ..Default::default()
                }),
            ],
            projectiles: vec![ProjectileDesc {
                launch_time_s: Some(0.5),
                ..Default::default()
            }],
            vehicles: vec![VehicleDesc {
                start: [25.0, -12.0],
                heading_deg: Some(90.0),
                ..Default::default()
            }],
            ..WorldDesc::empty()
        }
    }
}

/// A validated world: everything [`crate::Sim`] needs, in resolved form.
#[derive(Clone, Debug)]
pub(crate) struct BuiltWorld {
    pub physics: PhysicsMode,
    pub harmless_impact_speed_mps: f64,
    pub ground_friction: f64,
    pub gravity: f64,
    pub dt: f64,
    pub substeps: u32,
    pub horizon: f64,
    pub sky: f32,
    pub ground: Option<ResolvedTexture>,
    pub camera: Camera,
    /// The camera's sensor; `None` for the ideal camera.
    pub sensor: Option<crate::sensor::Sensor>,
    /// The event camera's parameters, validated, with `[world.camera] kind = "events"`.
    pub events: Option<crate::events::EventCameraDesc>,
    /// Perception latency in camera frames.
    pub perception_delay: usize,
    /// Actuation latency in camera frames.
    pub actuation_delay: usize,
    pub robot: RobotDesc,
    pub robot_prim: Prim,
    pub robot_start: Pose64,
    pub objects: Vec<ObjectSpec>,
}

/// Mixes the simulation seed with a stream id into a 32-bit texture seed.
pub(crate) fn sub_seed(seed: u64, stream: u64) -> u32 {
    let mut z = seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as u32
}

impl WorldDesc {
    /// A world with ground, sky, robot and camera at their defaults and no objects.
    pub fn empty() -> Self {
        WorldDesc {
            physics: PhysicsMode::default(),
            harmless_impact_speed_mps: d_harmless(),
            camera_hz: d_camera_hz(),
            physics_substeps: d_substeps(),
            gravity_mps2: d_gravity(),
            prediction_horizon_s: d_horizon(),
            sky_luminance: d_sky(),
            ground: GroundDesc::default(),
            robot: RobotDesc::default(),
            camera: CameraDesc::default(),
            scenery: Vec::new(),
            projectiles: Vec::new(),
            vehicles: Vec::new(),
        }
    }

    /// Checks every value; the error names the offending key.
    pub fn validate(&self) -> Result<(), SimError> {
        self.build(0).map(|_| ())
    }

    /// The speed bound of the simulator: an object's speed plus the robot's `max_speed_mps` must
    /// not exceed (the object's smallest extent + the robot body's smallest extent) × `camera_hz`
    /// × `physics_substeps`. At the defaults (120 Hz, 1 substep, the 0.5 × 0.4 × 0.3 m body,
    /// 2 m/s) a ball of radius 0.15 m may fly at up to 70 m/s; 20 substeps allow 1438 m/s. Why:
    /// contacts are detected at the
    /// physics substeps (`camera_hz × physics_substeps` per second), so an object that moves
    /// farther than its own smallest size plus the robot's in one substep (relative to the robot,
    /// which moves at up to `robot.max_speed_mps`) can pass through it unseen and be scored as a
    /// correct rejection. Such speeds are refused, naming the substeps that would resolve them.
    fn check_resolvable_speeds(&self) -> Result<(), SimError> {
        let rate = f64::from(self.camera_hz) * f64::from(self.physics_substeps);
        let robot_size = min_extent(&self.robot.body);
        let robot_speed = f64::from(self.robot.max_speed_mps).max(0.0);
        let check = |key: String, speed: f32, size: f64| -> Result<(), SimError> {
            let relative = f64::from(speed).abs() + robot_speed;
            let max = (size + robot_size) * rate;
            if relative <= max {
                return Ok(());
            }
            let need = (relative / ((size + robot_size) * f64::from(self.camera_hz))).ceil();
            let fix = if need <= 1000.0 {
                format!("raise world.physics_substeps to at least {need} or lower the speed")
            } else {
                "lower the speed (more than 1000 substeps per frame would be needed)".to_string()
            };
            Err(SimError::invalid(
                key,
                speed,
                format!(
                    "is faster than the simulator resolves: contacts are detected every physics substep \
                     (camera_hz {} × physics_substeps {} = {rate} per second), and an object moving more than \
                     its smallest size plus the robot's ({size:.3} m + {robot_size:.3} m) per substep, relative to \
                     the robot (up to robot.max_speed_mps {robot_speed} m/s), can pass through it unseen; the \
                     bound here is {:.1} m/s: {fix}",
                    self.camera_hz,
                    self.physics_substeps,
                    max - robot_speed
                ),
            ))
        };
        for (i, p) in self.projectiles.iter().enumerate() {
            check(
                format!("world.projectiles[{i}].speed_mps"),
                p.speed_mps,
                2.0 * f64::from(p.radius_m),
            )?;
        }
        for (i, v) in self.vehicles.iter().enumerate() {
            let size = v
                .parts
                .iter()
                .map(|p| min_extent(&p.shape))
                .fold(f64::INFINITY, f64::min);
            if size.is_finite() {
                check(format!("world.vehicles[{i}].speed_mps"), v.speed_mps, size)?;
            }
        }
        Ok(())
    }

    /// Camera period (s).
    pub fn dt(&self) -> f64 {
        1.0 / f64::from(self.camera_hz)
    }

    pub(crate) fn build(&self, seed: u64) -> Result<BuiltWorld, SimError> {
        if !(self.camera_hz.is_finite() && self.camera_hz > 0.0 && self.camera_hz <= 100_000.0) {
            return Err(SimError::invalid(
                "world.camera_hz",
                self.camera_hz,
                "must be in (0, 100000]",
            ));
        }
        if !(1..=1000).contains(&self.physics_substeps) {
            return Err(SimError::invalid(
                "world.physics_substeps",
                self.physics_substeps,
                "must be in 1..=1000",
            ));
        }
        if !(self.gravity_mps2.is_finite() && self.gravity_mps2 >= 0.0) {
            return Err(SimError::invalid(
                "world.gravity_mps2",
                self.gravity_mps2,
                "must be >= 0",
            ));
        }
        if !(self.prediction_horizon_s.is_finite() && self.prediction_horizon_s >= 0.0) {
            return Err(SimError::invalid(
                "world.prediction_horizon_s",
                self.prediction_horizon_s,
                "must be >= 0",
            ));
        }
        if !(self.harmless_impact_speed_mps.is_finite() && self.harmless_impact_speed_mps >= 0.0) {
            return Err(SimError::invalid(
                "world.harmless_impact_speed_mps",
                self.harmless_impact_speed_mps,
                "must be >= 0 (m/s; 0 counts every contact)",
            ));
        }
        if !(self.ground.friction.is_finite() && self.ground.friction >= 0.0) {
            return Err(SimError::invalid(
                "world.ground.friction",
                self.ground.friction,
                "must be >= 0",
            ));
        }
        if !(0.0..=1.0).contains(&self.sky_luminance) {
            return Err(SimError::invalid(
                "world.sky_luminance",
                self.sky_luminance,
                "luminance must be in [0, 1]",
            ));
        }
        let ground = if self.ground.enabled {
            Some(
                self.ground
                    .texture
                    .resolve("world.ground.texture", None, sub_seed(seed, 1))?,
            )
        } else {
            None
        };
        let camera = self.camera.build(seed)?;
        let sensor = self.camera.sensor.build(self.dt())?;
        let events = self.camera.event_camera()?;
        let perception_delay = crate::latency::latency_frames(
            "world.camera.perception_latency_s",
            self.camera.perception_latency_s,
            self.dt(),
        )?;
        let actuation_delay = crate::latency::latency_frames(
            "world.robot.actuation_latency_s",
            self.robot.actuation_latency_s,
            self.dt(),
        )?;
        let robot_prim = self.robot.body_prim()?;
        let robot_start = self.robot.start_pose(&robot_prim);
        let frame = AimFrame {
            robot: robot_start,
            camera: camera.pose(&robot_start, 0.0).position,
            gravity: f64::from(self.gravity_mps2),
            ground: self.ground.enabled,
        };
        let mut objects = Vec::new();
        for (i, s) in self.scenery.iter().enumerate() {
            objects.push(s.build(i, sub_seed(seed, 1000 + i as u64))?);
        }
        for (i, v) in self.vehicles.iter().enumerate() {
            objects.push(v.build(i, sub_seed(seed, 100_000 + 100 * i as u64))?);
        }
        for (i, p) in self.projectiles.iter().enumerate() {
            objects.push(p.build(i, &frame, sub_seed(seed, 200_000 + i as u64))?);
        }
        // objects are built in this order: scenery, vehicles, projectiles
        let keys = (0..self.scenery.len())
            .map(|i| format!("world.scenery[{i}].name"))
            .chain((0..self.vehicles.len()).map(|i| format!("world.vehicles[{i}].name")))
            .chain((0..self.projectiles.len()).map(|i| format!("world.projectiles[{i}].name")));
        let mut names = std::collections::HashMap::new();
        for (o, key) in objects.iter().zip(keys) {
            if let Some(first) = names.insert(o.name.as_str(), key.clone()) {
                return Err(SimError::invalid(
                    key,
                    &o.name,
                    format!("object names must be unique; {first} is `{}` too", o.name),
                ));
            }
        }
        self.check_resolvable_speeds()?;
        Ok(BuiltWorld {
            physics: self.physics,
            harmless_impact_speed_mps: self.harmless_impact_speed_mps.into(),
            ground_friction: self.ground.friction.into(),
            gravity: self.gravity_mps2.into(),
            dt: self.dt(),
            substeps: self.physics_substeps,
            horizon: f64::from(self.prediction_horizon_s),
            sky: self.sky_luminance,
            ground,
            camera,
            sensor,
            events,
            perception_delay,
            actuation_delay,
            robot: self.robot.clone(),
            robot_prim,
            robot_start,
            objects,
        })
    }
}
