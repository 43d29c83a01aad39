//! Analytic physics: one step with every body on its closed-form path, rapier detecting the contacts.

use super::Sim;
use crate::dynamics::BodyVelocity;
use crate::glam::DVec3;
use crate::robot::Command;
use crate::trajectory::time_of_impact;
use crate::truth::Contact;

impl Sim {
    /// Analytic physics: every body on its closed-form path; rapier detects the contacts.
    pub(super) fn advance_analytic(&mut self, command: &Command) -> Vec<Contact> {
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
}
