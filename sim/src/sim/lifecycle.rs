//! Creating a simulator (building its rapier world), resetting and forking it, and handing its renderer over.

use std::sync::{Arc, Mutex};

use rapier3d::parry::shape::SharedShape;
use rapier3d::prelude::{
    ActiveCollisionTypes, ActiveEvents, CoefficientCombineRule, ColliderBuilder, Group, InteractionGroups,
    InteractionTestMode, LockedAxes, PhysicsWorld, RigidBodyBuilder,
};

use super::{EventLog, Sim, SimObject};
use crate::SimError;
use crate::dynamics::{BodyVelocity, PhysicsMode};
use crate::glam::{DVec3, Vec3};
use crate::render::{GpuContext, Renderer};
use crate::robot::Command;
use crate::shape::collider_shape;
use crate::world::WorldDesc;

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
            grazing: self.grazing.clone(),
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
            shown: None,
            commands: self.commands.clone(),
            views: self.views.clone(),
            dvs: self.dvs.clone(),
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
            grazing: Vec::new(),
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
            shown: None,
            commands: crate::latency::DelayLine::new(world.actuation_delay),
            views: crate::latency::DelayLine::new(world.perception_delay + 1),
            dvs: match world.events {
                Some(d) => Some(Box::new(super::view::EventStream::new(&d, world.camera.n, seed)?)),
                None => None,
            },
            world,
        };
        if !dynamic {
            // initial contact state (objects touching the robot at t = 0 are reported by the first step)
            sim.physics.detect_collisions(&(), &sim.events);
        }
        Ok(sim)
    }
}
