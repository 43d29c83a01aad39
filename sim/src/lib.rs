//! loomlab-sim: a rapier3d world rendered offscreen by wgpu from a robot's camera, with exact ground
//! truth (docs/design.md §5).
//!
//! # Conventions
//! - World: right-handed, metres, seconds, **z up**, ground plane z = 0. The robot starts at the origin
//!   heading along **+x** (+y is its left) unless `world.robot` says otherwise. Angles in descriptions are
//!   degrees, counter-clockwise about +z; angular rates in commands are rad/s.
//! - Camera: x = optical axis, y = left, z = up, mounted on the robot ([`CameraDesc`]); frames are n × n
//!   `f32` luminances in [0, 1], row-major, **row 0 at the top**, column 0 at the left.
//! - Time: one [`Sim::step`] = one camera period (default 120 Hz), split into `physics_substeps`
//!   collision-detection steps.
//!
//! # Model
//! Every body follows closed-form motion (the robot integrates its velocity command exactly; projectiles
//! fly straight or on exact parabolas; vehicles drive straight lines or circles; scenery is fixed).
//! rapier3d detects contacts (the robot's collider is a sensor; its collision events are the
//! [`Contact`]s), parry's time-of-impact queries predict them ([`ObjectTruth::ttc_s`]), and wgpu draws
//! the view with procedural textures ([`Texture`]). Same description + seed ⇒ same trajectories and
//! contacts everywhere and same frames on the same adapter.
//!
//! ```no_run
//! use loomlab_sim::{Command, Sim, WorldDesc};
//! let mut sim = Sim::new(&WorldDesc::default(), 1)?;
//! let out = sim.step(&Command::forward(1.0))?;
//! println!("{} px, first object {:.2} deg", out.frame.len(), out.truth[0].angular_size_deg);
//! # Ok::<(), loomlab_sim::SimError>(())
//! ```

pub mod camera;
pub mod dynamics;
mod error;
pub mod events;
pub mod io;
pub mod latency;
mod limits;
mod object;
pub mod projectile;
pub mod render;
mod robot;
pub mod scenery;
pub mod sensor;
mod shape;
mod sim;
mod texture;
pub mod trajectory;
mod truth;
pub mod vehicle;
mod world;

/// The glam version rapier3d uses (re-exported so that callers need no second math crate).
pub use rapier3d::glamx::glam;

pub use camera::{Camera, CameraDesc, MAX_N, MIN_FRAME_SIZE, ShakeDesc};
pub use dynamics::{PhysicsMode, RobotBase};
pub use error::SimError;
pub use events::{CameraKind, Event, EventCamera, EventCameraDesc, EventPacket, MAX_EVENT_RENDERS};
pub use limits::{MAX_EPISODE_FRAMES, check_frame_count, episode_frames};
pub use object::ObjectKind;
pub use projectile::{NamedTarget, ProjectileDesc, Target};
pub use render::{GpuContext, Renderer, frame_to_u8};
pub use robot::{Command, RobotDesc, RobotState};
pub use scenery::{BoxDesc, OverpassDesc, PoleDesc, SceneryDesc, WallDesc};
pub use sensor::{SENSOR_PROFILES, Sensor, SensorDesc, SensorProfile};
pub use shape::{PrimKind, ShapeDesc};
pub use sim::{CapturedView, EventStream, Sim, StepOutput, SubframePlan, SubmittedSteps};
pub use texture::{GratingDesc, ResolvedTexture, Texture, TextureKind};
pub use truth::{Contact, ObjectTruth};
pub use vehicle::{PartDesc, VehicleDesc};
pub use world::{GroundDesc, WorldDesc};
