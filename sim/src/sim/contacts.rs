//! Contacts: rapier's collision events, the robot's contacts they start and the records reported for them.

use std::sync::Mutex;

use rapier3d::prelude::{
    ColliderSet, CollisionEvent, ContactPair, EventHandler, RigidBodySet, SoftBodySet, SoftBodyTearEvent,
};

use super::Sim;
use crate::trajectory::PlacedShape;
use crate::truth::Contact;

#[derive(Default)]
pub(super) struct EventLog(pub(super) Mutex<Vec<CollisionEvent>>);

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

impl Sim {
    pub(super) fn robot_placed(&self) -> PlacedShape<'_> {
        PlacedShape {
            shape: &*self.robot_shape,
            local: self.robot_local,
            bounding_radius: self.robot_radius,
        }
    }

    pub(super) fn contact(
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
    pub(super) fn robot_contact_started(&self, ev: CollisionEvent) -> Option<usize> {
        if ev.stopped() {
            return None;
        }
        self.robot_pair(ev)
    }

    /// The object of a collision event (started or stopped) between it and the robot, if any.
    pub(super) fn robot_pair(&self, ev: CollisionEvent) -> Option<usize> {
        let (a, b) = (ev.collider1(), ev.collider2());
        let other = if a == self.robot_collider {
            b
        } else if b == self.robot_collider {
            a
        } else {
            return None;
        };
        self.objects.iter().position(|o| o.collider == other)
    }

    pub(super) fn take_events(&self) -> Vec<CollisionEvent> {
        std::mem::take(&mut *self.events.0.lock().unwrap_or_else(|e| e.into_inner()))
    }
}
