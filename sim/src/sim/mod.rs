//! The simulator: advances the world one camera period per step, renders the robot's view and reports
//! ground truth and contacts.
//!
//! Two physics models ([`PhysicsMode`](crate::dynamics::PhysicsMode), see [`crate::dynamics`]):
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

mod accessors;
mod analytic_physics;
mod batch;
mod contacts;
mod dynamic_physics;
mod ground_truth;
mod lifecycle;
mod step;
mod view;

use rapier3d::parry::shape::SharedShape;
use rapier3d::prelude::{ColliderHandle, PhysicsWorld, Pose, RigidBodyHandle};

use crate::dynamics::BodyVelocity;
use crate::glam::DVec3;
use crate::object::ObjectSpec;
use crate::render::{RenderInstance, Renderer};
use crate::robot::{Command, RobotState};
use crate::shape::AngularPrimitive;
use crate::trajectory::{PlacedShape, Pose64};
use crate::truth::{Contact, ObjectTruth};
use crate::world::{BuiltWorld, WorldDesc};

use contacts::EventLog;
use dynamic_physics::SubstepStart;

pub use batch::SubmittedSteps;
pub use view::{CapturedView, EventStream, SubframePlan};

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
    /// Dynamic physics: objects whose pair with the robot rapier reported without a touch (its
    /// speculative margin); they become a contact when they touch, and leave when rapier reports
    /// the pair stopped.
    grazing: Vec<usize>,
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
    /// The view shown by the last render when views are tracked ([`Sim::tracks_views`]).
    shown: Option<CapturedView>,
    /// Commands waiting out the actuation latency ([`crate::latency`]).
    commands: crate::latency::DelayLine<Command>,
    /// The states of the views waiting out the perception latency, and the one before them (for
    /// the exposure's blur): a delay line one longer than the latency.
    views: crate::latency::DelayLine<view::ViewState>,
    /// The event camera with `[world.camera] kind = "events"` ([`crate::events`]).
    dvs: Option<Box<view::EventStream>>,
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
