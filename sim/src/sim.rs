//! The simulator: advances the world one camera period per step, renders the robot's view and reports
//! ground truth and contacts.
//!
//! Physics model: every body is kinematic and follows closed-form motion (see [`crate::trajectory`]):
//! the robot integrates its velocity command exactly, projectiles and vehicles follow their planned
//! paths, scenery is fixed. rapier3d provides collision detection: each physics substep moves the bodies
//! to their exact poses and runs rapier's broad and narrow phase; the robot's collider is a sensor whose
//! collision events are the contacts. Because nothing is integrated numerically, a world description and
//! seed give bit-identical trajectories on every machine, and frames that are identical on the same
//! adapter.

use std::sync::{Arc, Mutex};

use rapier3d::parry::shape::SharedShape;
use rapier3d::prelude::{
    ActiveCollisionTypes, ActiveEvents, ColliderBuilder, ColliderHandle, ColliderSet, CollisionEvent, ContactPair,
    EventHandler, PhysicsWorld, Pose, RigidBodyBuilder, RigidBodyHandle, RigidBodySet, SoftBodySet, SoftBodyTearEvent,
};

use crate::SimError;
use crate::camera::Camera;
use crate::glam::{DVec3, Vec3};
use crate::object::ObjectSpec;
use crate::render::{FrameDesc, GpuContext, RenderInstance, Renderer, frame_to_u8};
use crate::robot::{Command, RobotState};
use crate::shape::{AngularPrimitive, collider_shape};
use crate::trajectory::{Motion, PlacedShape, Pose64, Segment, Trajectory, time_of_impact};
use crate::truth::{Contact, ObjectTruth, angular_size};
use crate::world::{BuiltWorld, WorldDesc};

/// Half-width of the central difference used for angular rates (s).
const RATE_EPS_S: f64 = 1e-3;

/// What one [`Sim::step`] produced.
#[derive(Clone, Debug, PartialEq)]
pub struct StepOutput {
    /// Simulation time of this frame (s).
    pub t_s: f64,
    /// Number of steps taken so far (1 for the first step; 0 for [`Sim::observe`] before any step).
    pub frame_index: u64,
    /// Frame size (n × n).
    pub n: u32,
    /// The camera image: n·n luminances in [0, 1], row-major, row 0 at the top. Empty in physics-only mode.
    pub frame: Vec<f32>,
    /// Ground truth for every object, in id order.
    pub truth: Vec<ObjectTruth>,
    /// Contacts that started during this step.
    pub contacts: Vec<Contact>,
    /// The robot after the step.
    pub robot: RobotState,
}

struct SimObject {
    spec: ObjectSpec,
    shape: SharedShape,
    local: Pose,
    bounding_radius: f64,
    angular: Vec<AngularPrimitive>,
    /// Reference point for bearing and centre distance, in the body frame.
    center: DVec3,
    body: RigidBodyHandle,
    collider: ColliderHandle,
    moving: bool,
}

#[derive(Default)]
struct EventLog(Mutex<Vec<CollisionEvent>>);

impl EventHandler for EventLog {
    fn handle_collision_event(
        &self,
        _: &RigidBodySet,
        _: &ColliderSet,
        event: CollisionEvent,
        _: Option<&ContactPair>,
    ) {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).push(event);
    }
    fn handle_contact_force_event(&self, _: f32, _: &RigidBodySet, _: &ColliderSet, _: &ContactPair, _: f32) {}
    fn handle_soft_body_tear_event(&self, _: &SoftBodySet, _: &SoftBodyTearEvent) {}
}

/// A running simulation of one world.
pub struct Sim {
    desc: WorldDesc,
    seed: u64,
    world: BuiltWorld,
    step_index: u64,
    t: f64,
    robot_pose: Pose64,
    command: Command,
    robot_shape: SharedShape,
    robot_local: Pose,
    robot_radius: f64,
    physics: PhysicsWorld,
    robot_body: RigidBodyHandle,
    robot_collider: ColliderHandle,
    objects: Vec<SimObject>,
    events: EventLog,
    renderer: Option<Renderer>,
    frame: Vec<f32>,
    instances: Vec<RenderInstance>,
    contacts: Vec<Contact>,
    ground_truth: bool,
}

impl std::fmt::Debug for Sim {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sim")
            .field("t", &self.t)
            .field("objects", &self.objects.len())
            .field("renderer", &self.renderer)
            .finish()
    }
}

impl Sim {
    /// Builds the world and a renderer (creating a GPU device: prefer [`Sim::with_renderer`] or
    /// [`Sim::with_context`] when running many episodes).
    pub fn new(desc: &WorldDesc, seed: u64) -> Result<Sim, SimError> {
        desc.validate()?;
        let renderer = Renderer::new(desc.camera.n)?;
        Sim::build(desc, seed, Some(renderer))
    }

    /// Builds the world around an existing renderer (its `n` must equal `desc.camera.n`).
    pub fn with_renderer(desc: &WorldDesc, seed: u64, renderer: Renderer) -> Result<Sim, SimError> {
        if renderer.n() != desc.camera.n {
            return Err(SimError::SizeMismatch {
                renderer_n: renderer.n(),
                world_n: desc.camera.n,
            });
        }
        Sim::build(desc, seed, Some(renderer))
    }

    /// Builds the world with a new renderer on an existing GPU context.
    pub fn with_context(desc: &WorldDesc, seed: u64, ctx: Arc<GpuContext>) -> Result<Sim, SimError> {
        desc.validate()?;
        let renderer = Renderer::with_context(ctx, desc.camera.n)?;
        Sim::build(desc, seed, Some(renderer))
    }

    /// Builds the world without rendering: steps return empty frames but full ground truth and contacts
    /// (cheap open-loop passes).
    pub fn new_physics_only(desc: &WorldDesc, seed: u64) -> Result<Sim, SimError> {
        Sim::build(desc, seed, None)
    }

    /// Starts over with a new world and seed, keeping the renderer when the frame size allows.
    pub fn reset(&mut self, desc: &WorldDesc, seed: u64) -> Result<(), SimError> {
        let renderer = self.renderer.take();
        let renderer = match renderer {
            Some(r) if r.n() != desc.camera.n => Some(Renderer::with_context(Arc::clone(r.context()), desc.camera.n)?),
            other => other,
        };
        *self = Sim::build(desc, seed, renderer)?;
        Ok(())
    }

    /// Gives the renderer back (to reuse it for the next episode).
    pub fn into_renderer(self) -> Option<Renderer> {
        self.renderer
    }

    /// Takes the renderer out, leaving a physics-only simulator (later steps return empty frames).
    pub fn take_renderer(&mut self) -> Option<Renderer> {
        self.frame.clear();
        self.renderer.take()
    }

    /// Attaches a renderer to a running simulator, so that the following steps render (e.g. after a
    /// cheap physics-only replay up to some frame: physics does not depend on rendering, so the state is
    /// the same as if it had rendered all along). Its `n` must equal `world.camera.n`. Returns the
    /// renderer it replaces, if any.
    pub fn attach_renderer(&mut self, renderer: Renderer) -> Result<Option<Renderer>, SimError> {
        if renderer.n() != self.world.camera.n {
            return Err(SimError::SizeMismatch {
                renderer_n: renderer.n(),
                world_n: self.world.camera.n,
            });
        }
        Ok(self.renderer.replace(renderer))
    }

    fn build(desc: &WorldDesc, seed: u64, renderer: Option<Renderer>) -> Result<Sim, SimError> {
        let world = desc.build(seed)?;
        let mut physics = PhysicsWorld::new();
        physics.gravity = Vec3::ZERO;
        physics.integration_parameters.dt = (world.dt / f64::from(world.substeps)) as f32;

        let robot_parts = [crate::shape::Part {
            prim: world.robot_prim,
            offset: DVec3::ZERO,
            rotation: crate::glam::DQuat::IDENTITY,
            texture: crate::texture::Texture::uniform(0.5).resolve("robot", None, 0)?,
        }];
        let (robot_shape, robot_local) = collider_shape(&robot_parts);
        let origin = DVec3::ZERO;
        let (robot_body, robot_collider) = physics.insert(
            RigidBodyBuilder::kinematic_position_based().pose(world.robot_start.to_parry(origin)),
            ColliderBuilder::new(robot_shape.clone())
                .position(robot_local)
                .sensor(true)
                .active_collision_types(ActiveCollisionTypes::all())
                .active_events(ActiveEvents::COLLISION_EVENTS),
        );
        let mut objects = Vec::with_capacity(world.objects.len());
        for spec in &world.objects {
            let (shape, local) = collider_shape(&spec.parts);
            let moving = !spec.trajectory.is_static();
            let builder = if moving {
                RigidBodyBuilder::kinematic_position_based()
            } else {
                RigidBodyBuilder::fixed()
            };
            let (body, collider) = physics.insert(
                builder.pose(spec.trajectory.pose_at(0.0).to_parry(origin)),
                ColliderBuilder::new(shape.clone())
                    .position(local)
                    .active_collision_types(ActiveCollisionTypes::all()),
            );
            let center = spec.parts.iter().map(|p| p.offset).sum::<DVec3>() / spec.parts.len() as f64;
            objects.push(SimObject {
                bounding_radius: spec.bounding_radius(),
                angular: spec.angular_primitives(),
                spec: spec.clone(),
                shape,
                local,
                center,
                body,
                collider,
                moving,
            });
        }
        let robot_radius = f64::from(world.robot_prim.bounding_radius());
        let n = world.camera.n as usize;
        let mut sim = Sim {
            desc: desc.clone(),
            seed,
            step_index: 0,
            t: 0.0,
            robot_pose: world.robot_start,
            command: Command::default(),
            robot_shape,
            robot_local,
            robot_radius,
            physics,
            robot_body,
            robot_collider,
            objects,
            events: EventLog::default(),
            renderer,
            frame: Vec::with_capacity(n * n),
            instances: Vec::new(),
            contacts: Vec::new(),
            ground_truth: true,
            world,
        };
        // initial contact state (objects touching the robot at t = 0 are reported by the first step)
        sim.physics.detect_collisions(&(), &sim.events);
        Ok(sim)
    }

    /// Advances one camera period under `command`, renders the new view and computes ground truth.
    pub fn step(&mut self, command: &Command) -> Result<StepOutput, SimError> {
        command.validate()?;
        self.command = *command;
        let seg = command.motion_from(self.robot_pose, self.t);
        let substeps = u64::from(self.world.substeps);
        let hz = 1.0 / self.world.dt;
        let mut new_contacts = Vec::new();
        let mut t_prev = self.t;
        for s in 1..=substeps {
            let ts = ((self.step_index * substeps + s) as f64) / (hz * substeps as f64);
            let robot = seg.pose_at(ts);
            self.physics.bodies[self.robot_body].set_position(robot.to_parry(DVec3::ZERO), true);
            for o in self.objects.iter().filter(|o| o.moving) {
                let pose = o.spec.trajectory.pose_at(ts);
                self.physics.bodies[o.body].set_position(pose.to_parry(DVec3::ZERO), true);
            }
            self.physics.detect_collisions(&(), &self.events);
            let events: Vec<CollisionEvent> =
                std::mem::take(&mut *self.events.0.lock().unwrap_or_else(|e| e.into_inner()));
            for ev in events {
                let CollisionEvent::Started(a, b, _) = ev else { continue };
                let other = if a == self.robot_collider {
                    b
                } else if b == self.robot_collider {
                    a
                } else {
                    continue;
                };
                let Some(id) = self.objects.iter().position(|o| o.collider == other) else {
                    continue;
                };
                let o = &self.objects[id];
                let exact = time_of_impact(
                    &seg,
                    &PlacedShape {
                        shape: &*self.robot_shape,
                        local: self.robot_local,
                        bounding_radius: self.robot_radius,
                    },
                    &o.spec.trajectory,
                    &PlacedShape {
                        shape: &*o.shape,
                        local: o.local,
                        bounding_radius: o.bounding_radius,
                    },
                    t_prev,
                    ts - t_prev,
                )
                .filter(|&t| t > t_prev);
                new_contacts.push(Contact {
                    t_s: ts,
                    frame: self.step_index + 1,
                    object_id: id,
                    name: o.spec.name.clone(),
                    kind: o.spec.kind,
                    exact_t_s: exact,
                });
            }
            t_prev = ts;
        }
        new_contacts.sort_by(|a, b| a.t_s.total_cmp(&b.t_s).then(a.object_id.cmp(&b.object_id)));
        self.step_index += 1;
        self.t = (self.step_index as f64) / hz;
        self.robot_pose = seg.pose_at(self.t);
        self.contacts.extend(new_contacts.iter().cloned());
        self.render_current()?;
        Ok(StepOutput {
            t_s: self.t,
            frame_index: self.step_index,
            n: self.world.camera.n,
            frame: self.frame.clone(),
            truth: if self.ground_truth {
                self.truth(command)
            } else {
                Vec::new()
            },
            contacts: new_contacts,
            robot: self.robot_state(),
        })
    }

    /// Whether [`step`](Self::step) computes per-object ground truth ([`StepOutput::truth`]; on by
    /// default). Replays that only need contacts (escape-deadline searches) turn it off: the
    /// time-of-impact predictions are most of a physics-only step's cost. Contacts are unaffected.
    pub fn set_ground_truth(&mut self, on: bool) {
        self.ground_truth = on;
    }

    /// Renders and reports the current state without advancing time (e.g. the frame at t = 0).
    pub fn observe(&mut self) -> Result<StepOutput, SimError> {
        self.render_current()?;
        let command = self.command;
        Ok(StepOutput {
            t_s: self.t,
            frame_index: self.step_index,
            n: self.world.camera.n,
            frame: self.frame.clone(),
            truth: self.truth(&command),
            contacts: Vec::new(),
            robot: self.robot_state(),
        })
    }

    fn render_current(&mut self) -> Result<(), SimError> {
        let Some(renderer) = self.renderer.as_mut() else {
            self.frame.clear();
            return Ok(());
        };
        let t = self.t;
        let cam = self.world.camera.pose(&self.robot_pose, t);
        self.instances.clear();
        for o in &self.objects {
            let pose = o.spec.trajectory.pose_at(t);
            for p in &o.spec.parts {
                self.instances.push(RenderInstance {
                    prim: p.prim.kind,
                    position: (pose.transform_point(p.offset) - cam.position).as_vec3(),
                    rotation: (pose.rotation * p.rotation).normalize().as_quat(),
                    size: p.prim.size,
                    texture: p.texture,
                });
            }
        }
        let frame = FrameDesc {
            camera_position: cam.position,
            camera_rotation: cam.rotation,
            fov_rad: self.world.camera.fov_rad,
            near_m: self.world.camera.near_m,
            sky: self.world.sky,
            ground: self.world.ground.as_ref(),
            t_s: t,
            instances: &self.instances,
        };
        renderer.render(&frame, &mut self.frame)
    }

    /// Ground truth for every object at the current time, assuming the robot keeps `command` from now on.
    pub fn truth(&self, command: &Command) -> Vec<ObjectTruth> {
        let t = self.t;
        let seg = command.motion_from(self.robot_pose, t);
        let camera: &Camera = &self.world.camera;
        let cam = camera.pose(&self.robot_pose, t);
        let cam_minus = camera.pose(&seg.pose_at(t - RATE_EPS_S), t - RATE_EPS_S).position;
        let cam_plus = camera.pose(&seg.pose_at(t + RATE_EPS_S), t + RATE_EPS_S).position;
        let origin = self.robot_pose.position;
        let robot = PlacedShape {
            shape: &*self.robot_shape,
            local: self.robot_local,
            bounding_radius: self.robot_radius,
        };
        self.objects
            .iter()
            .enumerate()
            .map(|(id, o)| {
                let traj: &Trajectory = &o.spec.trajectory;
                let pose = traj.pose_at(t);
                let shape_pose = pose.to_parry(origin) * o.local;
                let distance = o
                    .shape
                    .distance_to_point(&shape_pose, (cam.position - origin).as_vec3(), true);
                let theta = angular_size(&o.angular, &pose, cam.position);
                let theta_minus = angular_size(&o.angular, &traj.pose_at(t - RATE_EPS_S), cam_minus);
                let theta_plus = angular_size(&o.angular, &traj.pose_at(t + RATE_EPS_S), cam_plus);
                let rate = (theta_plus - theta_minus) / (2.0 * RATE_EPS_S);
                let placed = PlacedShape {
                    shape: &*o.shape,
                    local: o.local,
                    bounding_radius: o.bounding_radius,
                };
                let ttc = if !o.moving
                    && cannot_reach(
                        &seg,
                        self.robot_radius,
                        pose.transform_point(o.center),
                        o.bounding_radius,
                        self.world.horizon,
                    ) {
                    None
                } else {
                    time_of_impact(&seg, &robot, traj, &placed, t, self.world.horizon).map(|tc| (tc - t).max(0.0))
                };
                let center = pose.transform_point(o.center);
                let proj = camera.project(&cam, center);
                let in_view =
                    matches!((proj.image_x, proj.image_y), (Some(x), Some(y)) if x.abs() <= 1.0 && y.abs() <= 1.0);
                let bearing = match proj.image_x {
                    Some(x) => x.clamp(-1.0, 1.0),
                    None => {
                        if proj.bearing_deg >= 0.0 {
                            1.0
                        } else {
                            -1.0
                        }
                    }
                };
                let in_contact = self
                    .physics
                    .intersection_pair(self.robot_collider, o.collider)
                    .unwrap_or(false);
                ObjectTruth {
                    id,
                    name: o.spec.name.clone(),
                    kind: o.spec.kind,
                    distance_m: distance,
                    center_distance_m: (center - cam.position).length() as f32,
                    angular_size_deg: theta.to_degrees() as f32,
                    angular_rate_deg_s: rate.to_degrees() as f32,
                    tau_s: (rate > 1e-12).then(|| (theta / rate) as f32),
                    ttc_s: ttc.map(|v| v as f32),
                    on_collision_course: ttc.is_some(),
                    bearing: bearing as f32,
                    bearing_deg: proj.bearing_deg as f32,
                    elevation_deg: proj.elevation_deg as f32,
                    in_view,
                    in_contact,
                }
            })
            .collect()
    }

    /// The robot's current state.
    pub fn robot_state(&self) -> RobotState {
        let seg = self.command.motion_from(self.robot_pose, self.t);
        let v = seg.velocity_at(self.t);
        RobotState {
            t_s: self.t,
            x_m: self.robot_pose.position.x,
            y_m: self.robot_pose.position.y,
            yaw_rad: self.robot_pose.yaw(),
            command: self.command,
            velocity_mps: [v.x, v.y, v.z],
        }
    }

    /// Current simulation time (s).
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Steps taken so far.
    pub fn step_index(&self) -> u64 {
        self.step_index
    }

    /// Camera period (s).
    pub fn dt(&self) -> f64 {
        self.world.dt
    }

    /// Frame size n.
    pub fn n(&self) -> u32 {
        self.world.camera.n
    }

    /// The camera (focal length, projections).
    pub fn camera(&self) -> &Camera {
        &self.world.camera
    }

    /// The latest frame (empty before the first step/observe and in physics-only mode).
    pub fn frame(&self) -> &[f32] {
        &self.frame
    }

    /// The latest frame as 8-bit grey levels.
    pub fn frame_u8(&self) -> Vec<u8> {
        frame_to_u8(&self.frame)
    }

    /// Whether this simulator renders.
    pub fn renders(&self) -> bool {
        self.renderer.is_some()
    }

    /// The renderer's adapter, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, ...)`.
    pub fn adapter(&self) -> Option<String> {
        self.renderer.as_ref().map(|r| r.context().describe())
    }

    /// Cumulative render timings (profiling), if this simulator renders.
    pub fn render_timings(&self) -> Option<crate::render::RenderTimings> {
        self.renderer.as_ref().map(Renderer::timings)
    }

    /// All contacts so far.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// `(id, name, kind)` of every object.
    pub fn objects(&self) -> Vec<(usize, String, crate::ObjectKind)> {
        self.objects
            .iter()
            .enumerate()
            .map(|(i, o)| (i, o.spec.name.clone(), o.spec.kind))
            .collect()
    }

    /// Pose of object `id` at time `t_s` (its planned path; world frame).
    pub fn object_pose(&self, id: usize, t_s: f64) -> Option<Pose64> {
        self.objects.get(id).map(|o| o.spec.trajectory.pose_at(t_s))
    }

    /// The description this simulator was built from.
    pub fn desc(&self) -> &WorldDesc {
        &self.desc
    }

    /// The seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }
}

/// Conservative test that a robot moving with `seg` cannot touch a static object whose bounding sphere
/// is (`center`, `radius`) within `horizon` seconds.
fn cannot_reach(seg: &Segment, robot_radius: f64, center: DVec3, radius: f64, horizon: f64) -> bool {
    let reach = robot_radius + radius;
    let p0 = seg.pose0.position;
    match seg.motion {
        Motion::Hold => (center - p0).length() > reach,
        Motion::Linear { velocity } => {
            let d = velocity * horizon;
            let s = if d.length_squared() > 0.0 {
                ((center - p0).dot(d) / d.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (center - (p0 + d * s)).length() > reach
        }
        Motion::Arc { center: c, .. } => {
            let rho = ((p0 - c).truncate()).length();
            let dh = ((center - c).truncate()).length();
            let dz = center.z - p0.z;
            ((dh - rho).powi(2) + dz * dz).sqrt() > reach
        }
        Motion::Ballistic { .. } => false,
    }
}
