//! Dynamic physics: one step with rapier integrating the robot and projectiles, and the bodies' predicted motions.

use super::{Sim, SimObject, pose64};
use crate::dynamics::{BodyVelocity, track_velocity};
use crate::glam::{DVec3, Vec3};
use crate::robot::Command;
use crate::trajectory::{Motion, Pose64, Segment, Trajectory, time_of_impact};
use crate::truth::Contact;

/// Two colliders this close (m) touch: a contact rapier reports between bodies farther apart that
/// exchanged no impulse is speculative (its narrow phase reports pairs within a margin that grows
/// with their speeds) and is no contact until they touch.
const TOUCH_M: f64 = 1e-3;

/// Dynamic physics: the robot's and the projectiles' predicted motions from the start of a substep.
#[derive(Clone)]
pub(super) struct SubstepStart {
    t_s: f64,
    robot: Segment,
    /// Per object: a projectile's predicted path (`None`: not dynamic, its planned path holds).
    balls: Vec<Option<Trajectory>>,
}

impl Sim {
    /// Dynamic physics: the drive sets the robot's velocity, projectiles launch, kinematic vehicles
    /// move on, rapier integrates and reports the contacts.
    pub(super) fn advance_dynamic(&mut self, command: &Command) -> Vec<Contact> {
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
            // pairs rapier reported earlier that had not touched yet: they may touch now
            for id in std::mem::take(&mut self.grazing) {
                match self.touch(id, ts, &start) {
                    Some(contact) => new_contacts.push(contact),
                    None => self.grazing.push(id),
                }
            }
            for ev in self.take_events() {
                let Some(id) = self.robot_pair(ev) else {
                    continue;
                };
                if ev.stopped() {
                    self.grazing.retain(|&g| g != id);
                } else if let Some(contact) = self.touch(id, ts, &start) {
                    new_contacts.push(contact);
                } else if !self.grazing.contains(&id) {
                    self.grazing.push(id);
                }
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

    /// The contact of the robot with object `id` in the substep ending at `ts` that began at
    /// `start`, if the two touch: a time of impact in this substep or the previous one (rapier
    /// finds a contact in the narrow phase that opens a step, so the touch may have happened in the
    /// previous substep: always, when CCD stopped a fast ball there), the two bodies overlapping
    /// where a search starts or touching now, or rapier's solver pushing them apart (an impulse:
    /// the simulated world deflected the object). `None`: rapier reported the pair from its
    /// speculative margin (a fast object passing within about its motion over a substep) and
    /// nothing touched or pushed.
    fn touch(&self, id: usize, ts: f64, start: &SubstepStart) -> Option<Contact> {
        let o = &self.objects[id];
        // the first touch, and whether the bodies already overlapped where a search started (a
        // fast ball may pass through the body between two substep ends)
        let (mut impact, mut overlapped) = (None, false);
        for from in [self.previous_substep.as_ref(), Some(start)].into_iter().flatten() {
            let traj = from.balls[id].as_ref().unwrap_or(&o.spec.trajectory);
            let toi = time_of_impact(
                &from.robot,
                &self.robot_placed(),
                traj,
                &o.placed(),
                from.t_s,
                ts - from.t_s,
            );
            match toi {
                Some(t) if t > from.t_s => {
                    impact = Some((t, (traj.velocity_at(t) - from.robot.velocity_at(t)).length()));
                    break;
                }
                Some(_) => overlapped = true,
                None => {}
            }
        }
        let impulse = self
            .physics
            .contact_pair(self.robot_collider, o.collider)
            .map(|p| f64::from(p.total_impulse().length()));
        let (exact, speed) = match impact {
            Some((t, speed)) => (Some(t), speed),
            None if overlapped || impulse.is_some_and(|i| i > 0.0) || self.bodies_touch(id) => {
                let traj = start.balls[id].as_ref().unwrap_or(&o.spec.trajectory);
                (
                    None,
                    (traj.velocity_at(start.t_s) - start.robot.velocity_at(start.t_s)).length(),
                )
            }
            None => return None,
        };
        Some(self.contact(id, ts, exact, speed, impulse))
    }

    /// Whether the robot's and object `id`'s colliders overlap or lie within [`TOUCH_M`] of each
    /// other now.
    pub(super) fn bodies_touch(&self, id: usize) -> bool {
        let colliders = &self.physics.colliders;
        let (robot, other) = (&colliders[self.robot_collider], &colliders[self.objects[id].collider]);
        rapier3d::parry::query::distance(robot.position(), robot.shape(), other.position(), other.shape())
            .is_ok_and(|d| f64::from(d.distance) <= TOUCH_M)
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
    pub(super) fn predicted_ball(&self, o: &SimObject, t: f64) -> Trajectory {
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
}

/// Height of a ball's bottom above the ground (m) and vertical speed (m/s) under which it counts as
/// resting or rolling on the ground for ground-truth prediction (a straight roll, not free fall).
const ON_GROUND_M: f64 = 2e-3;
const ON_GROUND_MPS: f64 = 0.05;
