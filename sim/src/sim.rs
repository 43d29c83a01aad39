//! The simulator: advances the world one camera period per step, renders the robot's view and reports
//! ground truth and contacts.
//!
//! Two physics models ([`PhysicsMode`], see [`crate::dynamics`]):
//! - **dynamic** (default): each physics substep the robot's drive sets its velocity within its
//!   limits, kinematic vehicles are moved to their scripted poses, and rapier integrates the dynamic
//!   bodies (robot, launched projectiles) and resolves contacts. Contacts with the robot are
//!   rapier's collision events; their exact time within the substep comes from a time-of-impact
//!   query on the bodies' states at the substep's start.
//! - **analytic**: every body is kinematic and follows closed-form motion ([`crate::trajectory`]);
//!   each substep moves the bodies to their exact poses and runs rapier's broad and narrow phase;
//!   the robot's collider is a sensor whose collision events are the contacts. Nothing is integrated
//!   numerically.
//!
//! Either way the same description and seed give bit-identical trajectories and contacts on one
//! machine whatever else runs (each simulator owns its rapier world; rendering and ground truth only
//! read it), and frames that are identical on the same adapter.

use std::sync::{Arc, Mutex};

use rapier3d::parry::shape::SharedShape;
use rapier3d::prelude::{
    ActiveCollisionTypes, ActiveEvents, CoefficientCombineRule, ColliderBuilder, ColliderHandle, ColliderSet,
    CollisionEvent, ContactPair, EventHandler, Group, InteractionGroups, InteractionTestMode, LockedAxes, PhysicsWorld,
    Pose, RigidBodyBuilder, RigidBodyHandle, RigidBodySet, SoftBodySet, SoftBodyTearEvent,
};

use crate::SimError;
use crate::camera::Camera;
use crate::dynamics::{BodyVelocity, PhysicsMode, track_velocity};
use crate::glam::{DVec3, Vec3};
use crate::object::ObjectSpec;
use crate::render::{FrameDesc, GpuContext, PendingViews, RenderInstance, Renderer, frame_to_u8};
use crate::robot::{Command, RobotState};
use crate::shape::{AngularPrimitive, collider_shape};
use crate::trajectory::{Motion, PlacedShape, Pose64, Segment, Trajectory, time_of_impact};
use crate::truth::{Contact, ObjectTruth, angular_extent, angular_size};
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

impl StepOutput {
    /// The first contact of this step that is a collision (not [`Contact::harmless`]), if any.
    pub fn first_collision(&self) -> Option<&Contact> {
        self.contacts.iter().find(|c| !c.harmless)
    }
}

#[derive(Clone)]
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
    /// Dynamic physics: a projectile's body is a dynamic one, enabled from its launch on.
    dynamic: bool,
    launched: bool,
}

/// Dynamic physics: the robot's and the projectiles' predicted motions from the start of a substep.
#[derive(Clone)]
struct SubstepStart {
    t_s: f64,
    robot: Segment,
    /// Per object: a projectile's predicted path (`None`: not dynamic, its planned path holds).
    balls: Vec<Option<Trajectory>>,
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
    /// The robot's velocity in its body frame after the last step.
    robot_velocity: BodyVelocity,
    /// Dynamic physics: the state at the start of the last substep.
    previous_substep: Option<SubstepStart>,
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

/// The robot's view at one moment, captured to be rendered later ([`Sim::capture_view`]): several
/// frames of one open-loop pass can then be rendered in one batch ([`Renderer::render_batch`] of
/// their [`CapturedView::desc`]), each frame bit-identical to the one [`Sim::step`] would have
/// rendered then.
#[derive(Clone, Debug)]
pub struct CapturedView {
    camera_position: DVec3,
    camera_rotation: crate::glam::DQuat,
    fov_rad: f64,
    near_m: f32,
    sky: f32,
    ground: Option<crate::texture::ResolvedTexture>,
    t_s: f64,
    instances: Vec<RenderInstance>,
}

impl CapturedView {
    /// The frame description to render.
    pub fn desc(&self) -> FrameDesc<'_> {
        FrameDesc {
            camera_position: self.camera_position,
            camera_rotation: self.camera_rotation,
            fov_rad: self.fov_rad,
            near_m: self.near_m,
            sky: self.sky,
            ground: self.ground.as_ref(),
            t_s: self.t_s,
            instances: &self.instances,
        }
    }

    /// Simulation time of the view (s).
    pub fn t_s(&self) -> f64 {
        self.t_s
    }
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

    /// A physics-only copy of this simulator as it stands (no renderer: its steps return empty
    /// frames): stepping the copy gives exactly what stepping this simulator would (test
    /// `a_fork_steps_as_its_original`). Replays that share a prefix (the escape deadline's search)
    /// fork from it instead of simulating it again. rapier's pipelines are workspaces rebuilt each
    /// step and start fresh; every piece of state (bodies, colliders, broad and narrow phase with
    /// their contact caches, islands) is cloned.
    pub fn fork_physics_only(&self) -> Sim {
        let p = &self.physics;
        let mut physics = PhysicsWorld::new();
        physics.gravity = p.gravity;
        physics.integration_parameters = p.integration_parameters;
        physics.islands = p.islands.clone();
        physics.broad_phase = p.broad_phase.clone();
        physics.narrow_phase = p.narrow_phase.clone();
        physics.bodies = p.bodies.clone();
        physics.colliders = p.colliders.clone();
        physics.impulse_joints = p.impulse_joints.clone();
        physics.multibody_joints = p.multibody_joints.clone();
        physics.soft_bodies = p.soft_bodies.clone();
        let pending = self.events.0.lock().unwrap_or_else(|e| e.into_inner()).clone();
        Sim {
            desc: self.desc.clone(),
            seed: self.seed,
            world: self.world.clone(),
            step_index: self.step_index,
            t: self.t,
            robot_pose: self.robot_pose,
            robot_velocity: self.robot_velocity,
            previous_substep: self.previous_substep.clone(),
            command: self.command,
            robot_shape: self.robot_shape.clone(),
            robot_local: self.robot_local,
            robot_radius: self.robot_radius,
            physics,
            robot_body: self.robot_body,
            robot_collider: self.robot_collider,
            objects: self.objects.clone(),
            events: EventLog(Mutex::new(pending)),
            renderer: None,
            frame: Vec::new(),
            instances: Vec::new(),
            contacts: self.contacts.clone(),
            ground_truth: self.ground_truth,
        }
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
        let dynamic = world.physics == PhysicsMode::Dynamic;
        let mut physics = PhysicsWorld::new();
        physics.gravity = if dynamic {
            Vec3::new(0.0, 0.0, -(world.gravity as f32))
        } else {
            Vec3::ZERO
        };
        physics.integration_parameters.dt = (world.dt / f64::from(world.substeps)) as f32;

        // collision groups: the ground (group 1) touches everything but the robot (group 2), which
        // slides above it with its height locked
        let ground_groups = InteractionGroups::new(Group::GROUP_1, Group::ALL, InteractionTestMode::And);
        let robot_groups =
            InteractionGroups::new(Group::GROUP_2, Group::ALL ^ Group::GROUP_1, InteractionTestMode::And);
        if dynamic && world.ground.is_some() {
            physics.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::new(SharedShape::halfspace(Vec3::Z))
                    .friction(world.ground_friction as f32)
                    .restitution(0.0)
                    .collision_groups(ground_groups),
            );
        }

        let robot_parts = [crate::shape::Part {
            prim: world.robot_prim,
            offset: DVec3::ZERO,
            rotation: crate::glam::DQuat::IDENTITY,
            texture: crate::texture::Texture::uniform(0.5).resolve("robot", None, 0)?,
        }];
        let (robot_shape, robot_local) = collider_shape(&robot_parts);
        let origin = DVec3::ZERO;
        let robot_start = world.robot_start.to_parry(origin);
        let (robot_body, robot_collider) = if dynamic {
            physics.insert(
                RigidBodyBuilder::dynamic()
                    .pose(robot_start)
                    .locked_axes(
                        LockedAxes::TRANSLATION_LOCKED_Z
                            | LockedAxes::ROTATION_LOCKED_X
                            | LockedAxes::ROTATION_LOCKED_Y,
                    )
                    .can_sleep(false),
                ColliderBuilder::new(robot_shape.clone())
                    .position(robot_local)
                    .mass(world.robot.mass_kg)
                    .friction(world.robot.friction)
                    .restitution(0.0)
                    .collision_groups(robot_groups)
                    .active_collision_types(ActiveCollisionTypes::all())
                    .active_events(ActiveEvents::COLLISION_EVENTS),
            )
        } else {
            physics.insert(
                RigidBodyBuilder::kinematic_position_based().pose(robot_start),
                ColliderBuilder::new(robot_shape.clone())
                    .position(robot_local)
                    .sensor(true)
                    .active_collision_types(ActiveCollisionTypes::all())
                    .active_events(ActiveEvents::COLLISION_EVENTS),
            )
        };
        let mut objects = Vec::with_capacity(world.objects.len());
        for spec in &world.objects {
            let (shape, local) = collider_shape(&spec.parts);
            let moving = !spec.trajectory.is_static();
            let pose0 = spec.trajectory.pose_at(0.0).to_parry(origin);
            let collider = ColliderBuilder::new(shape.clone())
                .position(local)
                .active_collision_types(ActiveCollisionTypes::all());
            let ball = spec.ball.filter(|_| dynamic);
            let (body, collider) = match ball {
                Some(b) => physics.insert(
                    RigidBodyBuilder::dynamic()
                        .pose(pose0)
                        .ccd_enabled(true)
                        .gravity_scale(if b.gravity { 1.0 } else { 0.0 })
                        .enabled(false),
                    collider
                        .mass(b.mass_kg as f32)
                        .restitution(b.restitution as f32)
                        .restitution_combine_rule(CoefficientCombineRule::Max)
                        .friction(b.friction as f32),
                ),
                None if moving => physics.insert(RigidBodyBuilder::kinematic_position_based().pose(pose0), collider),
                None => physics.insert(RigidBodyBuilder::fixed().pose(pose0), collider),
            };
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
                dynamic: ball.is_some(),
                launched: false,
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
            robot_velocity: BodyVelocity::default(),
            previous_substep: None,
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
        if !dynamic {
            // initial contact state (objects touching the robot at t = 0 are reported by the first step)
            sim.physics.detect_collisions(&(), &sim.events);
        }
        Ok(sim)
    }

    /// Advances one camera period under `command`, renders the new view and computes ground truth.
    ///
    /// With dynamic physics the command is the drive's target velocity (reached within the robot's
    /// acceleration limits), except at the first step: an episode starts in steady state, the robot
    /// already moving with its first command (clamped to its speed limits).
    pub fn step(&mut self, command: &Command) -> Result<StepOutput, SimError> {
        let new_contacts = self.advance(command)?;
        self.render_current()?;
        Ok(self.output(new_contacts))
    }

    /// Steps every simulator `sims[i]` by one camera period under `commands[i]` (as [`Sim::step`]
    /// does) and renders all their new views with `renderer` in one batch: one submission and one
    /// readback ([`Renderer::render_batch`]) instead of one per simulator. The outputs equal what
    /// [`Sim::step`] of each would give, frames included (bit-identical: each view is rendered
    /// exactly as it would be alone); the simulators' own renderers, if any, are not used. Every
    /// command is validated and every simulator's frame size checked against the renderer's before
    /// anything moves.
    pub fn step_batch(
        sims: &mut [&mut Sim],
        commands: &[Command],
        renderer: &mut Renderer,
    ) -> Result<Vec<StepOutput>, SimError> {
        if commands.len() != sims.len() {
            return Err(SimError::invalid(
                "step_batch commands",
                commands.len(),
                format!("must be one per simulator ({} simulators)", sims.len()),
            ));
        }
        Self::check_batch(sims, renderer)?;
        for c in commands {
            c.validate()?;
        }
        // In groups: the device renders one group's views while this thread steps the next
        // group's physics (each simulator's steps and view are independent of the others').
        let group = pipeline_group(sims.len(), renderer.max_batch());
        let mut contacts = Vec::with_capacity(sims.len());
        Self::render_in_groups(sims, renderer, group, |i, sim| {
            contacts.push(sim.advance(&commands[i])?);
            Ok(())
        })?;
        Ok(sims.iter().zip(contacts).map(|(sim, c)| sim.output(c)).collect())
    }

    /// [`Sim::observe`] of every simulator, their views rendered in one batch (see
    /// [`Sim::step_batch`]).
    pub fn observe_batch(sims: &mut [&mut Sim], renderer: &mut Renderer) -> Result<Vec<StepOutput>, SimError> {
        Self::check_batch(sims, renderer)?;
        Self::render_views(sims, renderer)?;
        Ok(sims.iter().map(|sim| sim.observation()).collect())
    }

    fn check_batch(sims: &[&mut Sim], renderer: &Renderer) -> Result<(), SimError> {
        match sims.iter().find(|s| s.world.camera.n != renderer.n()) {
            Some(s) => Err(SimError::SizeMismatch {
                renderer_n: renderer.n(),
                world_n: s.world.camera.n,
            }),
            None => Ok(()),
        }
    }

    /// Renders the current views of `sims` in one batch into their frames.
    fn render_views(sims: &mut [&mut Sim], renderer: &mut Renderer) -> Result<(), SimError> {
        let group = renderer.max_batch();
        Self::render_in_groups(sims, renderer, group, |_, _| Ok(()))
    }

    /// Renders the views of `sims` into their frames in submissions of `group` views: first
    /// `before(i, sims[i])` for each simulator of a group, then the group's submission; the frames
    /// are read back once every group is submitted.
    fn render_in_groups(
        sims: &mut [&mut Sim],
        renderer: &mut Renderer,
        group: usize,
        mut before: impl FnMut(usize, &mut Sim) -> Result<(), SimError>,
    ) -> Result<(), SimError> {
        let mut pending = Vec::with_capacity(sims.len().div_ceil(group));
        for (g, sims) in sims.chunks_mut(group).enumerate() {
            for (k, sim) in sims.iter_mut().enumerate() {
                before(g * group + k, sim)?;
            }
            pending.push(Self::submit_views(sims, renderer)?);
        }
        for (sims, views) in sims.chunks_mut(group).zip(pending) {
            Self::collect_views(sims, renderer, views)?;
        }
        Ok(())
    }

    /// Submits the current views of `sims` (at most [`Renderer::max_batch`]) for rendering.
    fn submit_views(sims: &mut [&mut Sim], renderer: &mut Renderer) -> Result<PendingViews, SimError> {
        for sim in sims.iter_mut() {
            sim.prepare_instances();
        }
        let descs: Vec<FrameDesc<'_>> = sims.iter().map(|s| s.frame_desc()).collect();
        renderer.submit_batch(&descs)
    }

    /// Reads the views of [`Sim::submit_views`] back into the simulators' frames.
    fn collect_views(sims: &mut [&mut Sim], renderer: &mut Renderer, views: PendingViews) -> Result<(), SimError> {
        let mut outs: Vec<Vec<f32>> = sims.iter_mut().map(|s| std::mem::take(&mut s.frame)).collect();
        let result = renderer.collect_batch(views, &mut outs);
        for (sim, out) in sims.iter_mut().zip(outs) {
            sim.frame = out;
        }
        result
    }

    /// Advances the world one camera period under `command` (physics and contacts, no rendering);
    /// returns the contacts that started.
    fn advance(&mut self, command: &Command) -> Result<Vec<Contact>, SimError> {
        command.validate()?;
        self.command = *command;
        let mut new_contacts = match self.world.physics {
            PhysicsMode::Analytic => self.advance_analytic(command),
            PhysicsMode::Dynamic => self.advance_dynamic(command),
        };
        new_contacts.sort_by(|a, b| a.t_s.total_cmp(&b.t_s).then(a.object_id.cmp(&b.object_id)));
        self.contacts.extend(new_contacts.iter().cloned());
        Ok(new_contacts)
    }

    /// The output of a step that found `new_contacts`, with the current frame.
    fn output(&self, new_contacts: Vec<Contact>) -> StepOutput {
        StepOutput {
            t_s: self.t,
            frame_index: self.step_index,
            n: self.world.camera.n,
            frame: self.frame.clone(),
            truth: if self.ground_truth {
                self.truth(&self.robot_velocity.as_command())
            } else {
                Vec::new()
            },
            contacts: new_contacts,
            robot: self.robot_state(),
        }
    }

    /// The end time of substep `s` (1-based) of the current step.
    fn substep_time(&self, s: u64) -> f64 {
        let substeps = u64::from(self.world.substeps);
        ((self.step_index * substeps + s) as f64) / (substeps as f64 / self.world.dt)
    }

    fn robot_placed(&self) -> PlacedShape<'_> {
        PlacedShape {
            shape: &*self.robot_shape,
            local: self.robot_local,
            bounding_radius: self.robot_radius,
        }
    }

    fn contact(
        &self,
        id: usize,
        ts: f64,
        exact_t_s: Option<f64>,
        impact_speed_mps: f64,
        impulse_ns: Option<f64>,
    ) -> Contact {
        let o = &self.objects[id];
        Contact {
            t_s: ts,
            frame: self.step_index + 1,
            object_id: id,
            name: o.spec.name.clone(),
            kind: o.spec.kind,
            exact_t_s,
            impact_speed_mps,
            impulse_ns,
            harmless: impact_speed_mps < self.world.harmless_impact_speed_mps,
        }
    }

    /// The object touched by the robot in a collision event that started, if any.
    fn robot_contact_started(&self, ev: CollisionEvent) -> Option<usize> {
        let CollisionEvent::Started(a, b, _) = ev else {
            return None;
        };
        let other = if a == self.robot_collider {
            b
        } else if b == self.robot_collider {
            a
        } else {
            return None;
        };
        self.objects.iter().position(|o| o.collider == other)
    }

    fn take_events(&self) -> Vec<CollisionEvent> {
        std::mem::take(&mut *self.events.0.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// Analytic physics: every body on its closed-form path; rapier detects the contacts.
    fn advance_analytic(&mut self, command: &Command) -> Vec<Contact> {
        let seg = command.motion_from(self.robot_pose, self.t);
        let mut new_contacts = Vec::new();
        let mut t_prev = self.t;
        for s in 1..=u64::from(self.world.substeps) {
            let ts = self.substep_time(s);
            self.physics.bodies[self.robot_body].set_position(seg.pose_at(ts).to_parry(DVec3::ZERO), true);
            for o in self.objects.iter().filter(|o| o.moving) {
                let pose = o.spec.trajectory.pose_at(ts);
                self.physics.bodies[o.body].set_position(pose.to_parry(DVec3::ZERO), true);
            }
            self.physics.detect_collisions(&(), &self.events);
            for ev in self.take_events() {
                let Some(id) = self.robot_contact_started(ev) else {
                    continue;
                };
                let o = &self.objects[id];
                let placed = o.placed();
                let exact = time_of_impact(
                    &seg,
                    &self.robot_placed(),
                    &o.spec.trajectory,
                    &placed,
                    t_prev,
                    ts - t_prev,
                )
                .filter(|&t| t > t_prev);
                let t_hit = exact.unwrap_or(ts);
                let speed = (o.spec.trajectory.velocity_at(t_hit) - seg.velocity_at(t_hit)).length();
                new_contacts.push(self.contact(id, ts, exact, speed, None));
            }
            t_prev = ts;
        }
        self.step_index += 1;
        self.t = (self.step_index as f64) * self.world.dt;
        self.robot_pose = seg.pose_at(self.t);
        self.robot_velocity = BodyVelocity {
            forward_mps: command.forward_mps.into(),
            lateral_mps: command.lateral_mps.into(),
            yaw_rate_rps: command.yaw_rate_rps.into(),
        };
        new_contacts
    }

    /// Dynamic physics: the drive sets the robot's velocity, projectiles launch, kinematic vehicles
    /// move on, rapier integrates and reports the contacts.
    fn advance_dynamic(&mut self, command: &Command) -> Vec<Contact> {
        let h = self.world.dt / f64::from(self.world.substeps);
        let base = self.world.robot.base;
        let limits = self.world.robot.limits();
        let mut new_contacts = Vec::new();
        let mut t_prev = self.t;
        for s in 1..=u64::from(self.world.substeps) {
            let ts = self.substep_time(s);
            // launches: a projectile starts at the first substep boundary at or after its launch time,
            // with its planned (exact) pose and velocity there
            for o in self.objects.iter_mut().filter(|o| o.dynamic && !o.launched) {
                if o.spec.ball.is_some_and(|b| b.launch_s <= t_prev) {
                    let body = &mut self.physics.bodies[o.body];
                    body.set_enabled(true);
                    body.set_position(o.spec.trajectory.pose_at(t_prev).to_parry(DVec3::ZERO), true);
                    body.set_linvel(o.spec.trajectory.velocity_at(t_prev).as_vec3(), true);
                    o.launched = true;
                }
            }
            // the drive
            let current = self.body_velocity();
            let next = if self.step_index == 0 && s == 1 {
                track_velocity(current, command, base, &limits, f64::INFINITY)
            } else {
                track_velocity(current, command, base, &limits, h)
            };
            let yaw = self.robot_pose_now().yaw();
            let (sin, cos) = yaw.sin_cos();
            let world_v = DVec3::new(
                next.forward_mps * cos - next.lateral_mps * sin,
                next.forward_mps * sin + next.lateral_mps * cos,
                0.0,
            );
            let robot = &mut self.physics.bodies[self.robot_body];
            robot.set_linvel(world_v.as_vec3(), true);
            robot.set_angvel(Vec3::new(0.0, 0.0, next.yaw_rate_rps as f32), true);
            for o in self.objects.iter().filter(|o| o.moving && !o.dynamic) {
                let pose = o.spec.trajectory.pose_at(ts);
                self.physics.bodies[o.body].set_next_kinematic_position(pose.to_parry(DVec3::ZERO));
            }
            // the state at the substep's start, for the exact contact times and impact speeds
            let start = SubstepStart {
                t_s: t_prev,
                robot: self.predicted_robot(t_prev),
                balls: self
                    .objects
                    .iter()
                    .map(|o| o.dynamic.then(|| self.predicted_ball(o, t_prev)))
                    .collect(),
            };
            self.physics.step_with_events(&(), &self.events);
            for ev in self.take_events() {
                let Some(id) = self.robot_contact_started(ev) else {
                    continue;
                };
                // rapier finds a contact in the narrow phase that opens a step, so the touch may
                // have happened in the previous substep (always, when CCD stopped a fast ball there):
                // search it from that substep's start first, then from this one's
                let contact = [self.previous_substep.as_ref(), Some(&start)]
                    .into_iter()
                    .flatten()
                    .find_map(|from| {
                        let o = &self.objects[id];
                        let traj = from.balls[id].as_ref().unwrap_or(&o.spec.trajectory);
                        time_of_impact(
                            &from.robot,
                            &self.robot_placed(),
                            traj,
                            &o.placed(),
                            from.t_s,
                            ts - from.t_s,
                        )
                        .filter(|&t| t > from.t_s)
                        .map(|t| (t, (traj.velocity_at(t) - from.robot.velocity_at(t)).length()))
                    });
                let (exact, speed) = match contact {
                    Some((t, speed)) => (Some(t), speed),
                    None => {
                        let traj = start.balls[id].as_ref().unwrap_or(&self.objects[id].spec.trajectory);
                        (
                            None,
                            (traj.velocity_at(t_prev) - start.robot.velocity_at(t_prev)).length(),
                        )
                    }
                };
                let impulse = self
                    .physics
                    .contact_pair(self.robot_collider, self.objects[id].collider)
                    .map(|p| f64::from(p.total_impulse().length()));
                new_contacts.push(self.contact(id, ts, exact, speed, impulse));
            }
            self.previous_substep = Some(start);
            t_prev = ts;
        }
        self.step_index += 1;
        self.t = (self.step_index as f64) * self.world.dt;
        self.robot_pose = self.robot_pose_now();
        self.robot_velocity = self.body_velocity();
        new_contacts
    }

    /// Dynamic physics: the robot body's pose.
    fn robot_pose_now(&self) -> Pose64 {
        pose64(self.physics.bodies[self.robot_body].position())
    }

    /// Dynamic physics: the robot body's velocity in its body frame.
    fn body_velocity(&self) -> BodyVelocity {
        let body = &self.physics.bodies[self.robot_body];
        let v = body.linvel().as_dvec3();
        let (sin, cos) = self.robot_pose_now().yaw().sin_cos();
        BodyVelocity {
            forward_mps: v.x * cos + v.y * sin,
            lateral_mps: -v.x * sin + v.y * cos,
            yaw_rate_rps: f64::from(body.angvel().z),
        }
    }

    /// Dynamic physics: the robot's motion from time `t` on if it keeps its current velocity.
    fn predicted_robot(&self, t: f64) -> Segment {
        self.body_velocity().as_command().motion_from(self.robot_pose_now(), t)
    }

    /// Dynamic physics: a projectile's path from time `t` on as predicted from its current state:
    /// its plan before launch; after launch free flight (a parabola under gravity, exact until the
    /// next contact), or a straight roll while it rests on the ground.
    fn predicted_ball(&self, o: &SimObject, t: f64) -> Trajectory {
        if !o.launched {
            return o.spec.trajectory.clone();
        }
        let body = &self.physics.bodies[o.body];
        let pose = pose64(body.position());
        let v = body.linvel().as_dvec3();
        let gravity = if o.spec.ball.is_some_and(|b| b.gravity) {
            self.world.gravity
        } else {
            0.0
        };
        let on_ground = self.world.ground.is_some()
            && pose.position.z - o.bounding_radius <= ON_GROUND_M
            && v.z.abs() <= ON_GROUND_MPS;
        let motion = if on_ground || gravity == 0.0 {
            let v = if on_ground { DVec3::new(v.x, v.y, 0.0) } else { v };
            if v.length() < 1e-6 {
                Motion::Hold
            } else {
                Motion::Linear { velocity: v }
            }
        } else {
            Motion::Ballistic { velocity: v, gravity }
        };
        Trajectory::from_segment(Segment {
            t0: t,
            t1: f64::INFINITY,
            pose0: pose,
            motion,
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
        Ok(self.observation())
    }

    /// What [`Sim::observe`] reports, with the current frame.
    fn observation(&self) -> StepOutput {
        StepOutput {
            t_s: self.t,
            frame_index: self.step_index,
            n: self.world.camera.n,
            frame: self.frame.clone(),
            truth: self.truth(&self.robot_velocity.as_command()),
            contacts: Vec::new(),
            robot: self.robot_state(),
        }
    }

    /// Fills `instances` with the parts to draw now, relative to the camera.
    fn prepare_instances(&mut self) {
        let cam = self.world.camera.pose(&self.robot_pose, self.t);
        let mut instances = std::mem::take(&mut self.instances);
        instances.clear();
        for o in &self.objects {
            let pose = self.pose_now(o);
            for p in &o.spec.parts {
                instances.push(RenderInstance {
                    prim: p.prim.kind,
                    position: (pose.transform_point(p.offset) - cam.position).as_vec3(),
                    rotation: (pose.rotation * p.rotation).normalize().as_quat(),
                    size: p.prim.size,
                    texture: p.texture,
                });
            }
        }
        self.instances = instances;
    }

    /// Captures the current view (what [`Sim::observe`] would render now) to render it later,
    /// e.g. in a batch with other moments of the same episode. Works without a renderer.
    pub fn capture_view(&mut self) -> CapturedView {
        self.prepare_instances();
        let d = self.frame_desc();
        CapturedView {
            camera_position: d.camera_position,
            camera_rotation: d.camera_rotation,
            fov_rad: d.fov_rad,
            near_m: d.near_m,
            sky: d.sky,
            ground: d.ground.copied(),
            t_s: d.t_s,
            instances: d.instances.to_vec(),
        }
    }

    /// The view now (after [`Self::prepare_instances`]).
    fn frame_desc(&self) -> FrameDesc<'_> {
        let cam = self.world.camera.pose(&self.robot_pose, self.t);
        FrameDesc {
            camera_position: cam.position,
            camera_rotation: cam.rotation,
            fov_rad: self.world.camera.fov_rad,
            near_m: self.world.camera.near_m,
            sky: self.world.sky,
            ground: self.world.ground.as_ref(),
            t_s: self.t,
            instances: &self.instances,
        }
    }

    fn render_current(&mut self) -> Result<(), SimError> {
        let Some(mut renderer) = self.renderer.take() else {
            self.frame.clear();
            return Ok(());
        };
        self.prepare_instances();
        let mut frame = std::mem::take(&mut self.frame);
        let result = renderer.render(&self.frame_desc(), &mut frame);
        self.frame = frame;
        self.renderer = Some(renderer);
        result
    }

    /// Ground truth for every object at the current time, assuming the robot keeps `command` (its
    /// body-frame velocity) from now on and every object its planned path (vehicles, scenery,
    /// projectiles with analytic physics or before launch) or, for a flying projectile with dynamic
    /// physics, its free flight from its current state (exact until its next contact).
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
                let predicted = o.dynamic.then(|| self.predicted_ball(o, t));
                let traj: &Trajectory = predicted.as_ref().unwrap_or(&o.spec.trajectory);
                let pose = traj.pose_at(t);
                let shape_pose = pose.to_parry(origin) * o.local;
                let distance = o
                    .shape
                    .distance_to_point(&shape_pose, (cam.position - origin).as_vec3(), true);
                let theta = angular_size(&o.angular, &pose, cam.position);
                let theta_minus = angular_size(&o.angular, &traj.pose_at(t - RATE_EPS_S), cam_minus);
                let theta_plus = angular_size(&o.angular, &traj.pose_at(t + RATE_EPS_S), cam_plus);
                let rate = (theta_plus - theta_minus) / (2.0 * RATE_EPS_S);
                let placed = o.placed();
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
                let (azimuth_extent, elevation_extent) = angular_extent(&o.angular, &pose, &cam);
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
                let in_contact = match self.world.physics {
                    PhysicsMode::Analytic => self
                        .physics
                        .intersection_pair(self.robot_collider, o.collider)
                        .unwrap_or(false),
                    PhysicsMode::Dynamic => self
                        .physics
                        .contact_pair(self.robot_collider, o.collider)
                        .is_some_and(ContactPair::has_any_active_contact),
                };
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
                    azimuth_extent_deg: azimuth_extent.map(|v| v as f32),
                    elevation_extent_deg: elevation_extent.map(|v| v as f32),
                    in_view,
                    in_contact,
                }
            })
            .collect()
    }

    /// The robot's current state.
    pub fn robot_state(&self) -> RobotState {
        let seg = self.robot_velocity.as_command().motion_from(self.robot_pose, self.t);
        let v = seg.velocity_at(self.t);
        RobotState {
            t_s: self.t,
            x_m: self.robot_pose.position.x,
            y_m: self.robot_pose.position.y,
            yaw_rad: self.robot_pose.yaw(),
            command: self.command,
            velocity_mps: [v.x, v.y, v.z],
            yaw_rate_rps: self.robot_velocity.yaw_rate_rps,
        }
    }

    /// The pose of an object now: with dynamic physics a projectile's body pose, else its path's.
    fn pose_now(&self, o: &SimObject) -> Pose64 {
        if o.dynamic {
            pose64(self.physics.bodies[o.body].position())
        } else {
            o.spec.trajectory.pose_at(self.t)
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

    /// The camera's world pose now (x = optical axis, z = up; shake included): where the last frame
    /// was taken from. What the robot's odometry and inertial sensor know about its camera.
    pub fn camera_pose(&self) -> crate::trajectory::Pose64 {
        self.world.camera.pose(&self.robot_pose, self.t)
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

    /// Pose of object `id` now (with dynamic physics: where rapier has it; world frame).
    pub fn object_pose_now(&self, id: usize) -> Option<Pose64> {
        self.objects.get(id).map(|o| self.pose_now(o))
    }

    /// The physics model of this world.
    pub fn physics(&self) -> PhysicsMode {
        self.world.physics
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

impl SimObject {
    fn placed(&self) -> PlacedShape<'_> {
        PlacedShape {
            shape: &*self.shape,
            local: self.local,
            bounding_radius: self.bounding_radius,
        }
    }
}

/// A rapier pose in double precision.
fn pose64(p: &Pose) -> Pose64 {
    Pose64 {
        position: p.translation.as_dvec3(),
        rotation: p.rotation.as_dquat().normalize(),
    }
}

/// Height of a ball's bottom above the ground (m) and vertical speed (m/s) under which it counts as
/// resting or rolling on the ground for ground-truth prediction (a straight roll, not free fall).
const ON_GROUND_M: f64 = 2e-3;
const ON_GROUND_MPS: f64 = 0.05;

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
        Motion::Braking { .. } | Motion::Ballistic { .. } => false,
    }
}

/// Groups a large batch of [`Sim::step_batch`] is split into: the device renders one group's views
/// while the stepping thread advances the next group's physics. On lavapipe with `LP_NUM_THREADS=0`
/// (its queue thread rasterises) a batch of 64 views at 64² went from 6 130 to 7 214 steps/s
/// (`render_bench`, medians of 3 alternating runs on 2 CPUs; docs/benchmarks.md).
const PIPELINE_GROUPS: usize = 4;

/// The fewest views a group of [`Sim::step_batch`] has: each submission costs a wait and a map, so
/// small batches stay whole (splitting the default suite's closed-loop tails, a few views each, into
/// groups made the suite ~15 s slower).
const MIN_GROUP_VIEWS: usize = 8;

/// How many of a batch's `views` [`Sim::step_batch`] submits together: up to [`PIPELINE_GROUPS`]
/// groups of at least [`MIN_GROUP_VIEWS`], each at most `max_batch` views (the renderer's limit).
fn pipeline_group(views: usize, max_batch: usize) -> usize {
    let groups = (views / MIN_GROUP_VIEWS).clamp(1, PIPELINE_GROUPS);
    views.div_ceil(groups).clamp(1, max_batch.max(1))
}
