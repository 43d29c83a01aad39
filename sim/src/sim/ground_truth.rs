//! Ground truth: per-object distances, angular sizes and rates, bearings and predicted times to collision.

use rapier3d::prelude::ContactPair;

use super::Sim;
use crate::camera::Camera;
use crate::dynamics::PhysicsMode;
use crate::glam::DVec3;
use crate::robot::Command;
use crate::trajectory::{Motion, PlacedShape, Segment, Trajectory, time_of_impact};
use crate::truth::{ObjectTruth, angular_extent, angular_size};

/// Half-width of the central difference used for angular rates (s).
const RATE_EPS_S: f64 = 1e-3;

impl Sim {
    /// Whether [`step`](Self::step) computes per-object ground truth ([`StepOutput::truth`]; on by
    /// default). Replays that only need contacts (escape-deadline searches) turn it off: the
    /// time-of-impact predictions are most of a physics-only step's cost. Contacts are unaffected.
    ///
    /// [`StepOutput::truth`]: super::StepOutput::truth
    pub fn set_ground_truth(&mut self, on: bool) {
        self.ground_truth = on;
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
                    // rapier's active contacts include its speculative ones: a pair within a
                    // margin that grows with the speeds, not touching yet
                    PhysicsMode::Dynamic => {
                        self.physics
                            .contact_pair(self.robot_collider, o.collider)
                            .is_some_and(ContactPair::has_any_active_contact)
                            && self.bodies_touch(id)
                    }
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
        Motion::Braking { .. } | Motion::Ballistic { .. } => false,
    }
}
