//! Read-only accessors: the robot's state, object poses, time, camera, frame, contacts and description.

use super::{Sim, SimObject, pose64};
use crate::camera::Camera;
use crate::dynamics::PhysicsMode;
use crate::render::{Renderer, frame_to_u8};
use crate::robot::RobotState;
use crate::trajectory::Pose64;
use crate::truth::Contact;
use crate::world::WorldDesc;

impl Sim {
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
    pub(super) fn pose_now(&self, o: &SimObject) -> Pose64 {
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
