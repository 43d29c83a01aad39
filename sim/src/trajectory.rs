//! Analytic trajectories: every moving thing (robot under a constant command, projectiles, vehicles)
//! follows closed-form motion segments, so poses at any time and exact times of impact are available.
//!
//! Segment kinds: hold (static), linear (constant velocity), arc (constant yaw rate about a fixed vertical
//! axis: a vehicle on a circle, a robot turning with constant command) and ballistic (constant gravity).
//! The first three are rigid motions that parry's nonlinear time-of-impact query handles exactly; the
//! ballistic one is solved by conservative advancement on parry's exact distance query.

use rapier3d::parry::query::{self, NonlinearRigidMotion, ShapeCastOptions};
use rapier3d::parry::shape::Shape;
use rapier3d::prelude::Pose;

use crate::glam::{DQuat, DVec3, Vec3};

/// A rigid pose in double precision (world frame: right-handed, z up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose64 {
    /// Position of the body origin.
    pub position: DVec3,
    /// Orientation of the body.
    pub rotation: DQuat,
}

impl Pose64 {
    /// A pose from position and yaw about +z.
    pub fn from_xyz_yaw(position: DVec3, yaw_rad: f64) -> Self {
        Pose64 {
            position,
            rotation: DQuat::from_rotation_z(yaw_rad),
        }
    }

    /// Transforms a point from the body frame to the world frame.
    pub fn transform_point(&self, p: DVec3) -> DVec3 {
        self.position + self.rotation * p
    }

    /// Composition `self ∘ other` (other expressed in self's frame).
    pub fn mul(&self, other: &Pose64) -> Pose64 {
        Pose64 {
            position: self.transform_point(other.position),
            rotation: self.rotation * other.rotation,
        }
    }

    /// Single-precision parry pose, with positions taken relative to `origin` (keeps f32 precise).
    pub fn to_parry(&self, origin: DVec3) -> Pose {
        Pose::from_parts((self.position - origin).as_vec3(), self.rotation.normalize().as_quat())
    }

    /// Yaw angle about +z (radians) of the body's x axis.
    pub fn yaw(&self) -> f64 {
        let x = self.rotation * DVec3::X;
        x.y.atan2(x.x)
    }
}

/// How a segment moves its pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// Stays where it is.
    Hold,
    /// Constant linear velocity (m/s), no rotation.
    Linear {
        /// World velocity.
        velocity: DVec3,
    },
    /// Constant yaw rate about the vertical axis through `center` (a circle; a turning robot or vehicle).
    Arc {
        /// A point on the rotation axis (world).
        center: DVec3,
        /// Yaw rate (rad/s, positive = counter-clockwise seen from above).
        yaw_rate: f64,
    },
    /// Straight-line braking: starts at `velocity` and decelerates along it at `deceleration`
    /// until it stands (at `|velocity| / deceleration` after the segment start); orientation fixed.
    Braking {
        /// World velocity at the segment start.
        velocity: DVec3,
        /// Deceleration (m/s², > 0).
        deceleration: f64,
    },
    /// Free flight under gravity `-gravity · ẑ`; orientation fixed.
    Ballistic {
        /// Velocity at the segment start.
        velocity: DVec3,
        /// Gravitational acceleration (m/s², ≥ 0).
        gravity: f64,
    },
}

/// A time interval of a trajectory with closed-form motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Start time (s); may be `-inf` for the first segment.
    pub t0: f64,
    /// End time (s); may be `inf` for the last segment.
    pub t1: f64,
    /// Pose at `t0` (for a `-inf` start: the pose at every time, the motion must be `Hold`).
    pub pose0: Pose64,
    /// The motion.
    pub motion: Motion,
}

impl Segment {
    /// Pose at time `t` (extrapolates outside `[t0, t1]`).
    pub fn pose_at(&self, t: f64) -> Pose64 {
        let tau = if self.t0.is_finite() { t - self.t0 } else { 0.0 };
        match self.motion {
            Motion::Hold => self.pose0,
            Motion::Linear { velocity } => Pose64 {
                position: self.pose0.position + velocity * tau,
                rotation: self.pose0.rotation,
            },
            Motion::Arc { center, yaw_rate } => {
                let r = DQuat::from_rotation_z(yaw_rate * tau);
                let rel = self.pose0.position - center;
                Pose64 {
                    position: center + r * rel,
                    rotation: r * self.pose0.rotation,
                }
            }
            Motion::Braking { velocity, deceleration } => {
                let tau = tau.clamp(0.0, velocity.length() / deceleration);
                Pose64 {
                    position: self.pose0.position + velocity * tau
                        - velocity.normalize_or_zero() * (0.5 * deceleration * tau * tau),
                    rotation: self.pose0.rotation,
                }
            }
            Motion::Ballistic { velocity, gravity } => Pose64 {
                position: self.pose0.position + velocity * tau - DVec3::Z * (0.5 * gravity * tau * tau),
                rotation: self.pose0.rotation,
            },
        }
    }

    /// Linear velocity of the body origin at time `t`.
    pub fn velocity_at(&self, t: f64) -> DVec3 {
        let tau = if self.t0.is_finite() { t - self.t0 } else { 0.0 };
        match self.motion {
            Motion::Hold => DVec3::ZERO,
            Motion::Linear { velocity } => velocity,
            Motion::Arc { center, yaw_rate } => {
                let p = self.pose_at(t).position - center;
                DVec3::new(-yaw_rate * p.y, yaw_rate * p.x, 0.0)
            }
            Motion::Braking { velocity, deceleration } => {
                velocity.normalize_or_zero() * (velocity.length() - deceleration * tau.max(0.0)).max(0.0)
            }
            Motion::Ballistic { velocity, gravity } => velocity - DVec3::Z * (gravity * tau),
        }
    }

    /// The parry rigid motion equivalent to this segment with parry time 0 = world time `now`, positions
    /// relative to `origin`, for a shape sitting at `local` in the body frame. `None` for ballistic motion.
    fn parry_motion(&self, now: f64, origin: DVec3, local: &Pose) -> Option<NonlinearRigidMotion> {
        let start = self.pose_at(now).to_parry(origin) * *local;
        Some(match self.motion {
            Motion::Hold => NonlinearRigidMotion::constant_position(start),
            Motion::Linear { velocity } => NonlinearRigidMotion::new(start, Vec3::ZERO, velocity.as_vec3(), Vec3::ZERO),
            Motion::Arc { center, .. } if (self.pose_at(now).position - center).length() > MAX_ARC_RADIUS_M => {
                // nearly straight: f32 cannot place a far-away rotation centre precisely; the chord
                // deviates by (v·T)²/(2R), under 5 cm for 100 m of travel
                NonlinearRigidMotion::new(start, Vec3::ZERO, self.velocity_at(now).as_vec3(), Vec3::ZERO)
            }
            Motion::Arc { center, yaw_rate } => {
                let c = (center - origin).as_vec3();
                let local_center = start.inverse_transform_point(c);
                NonlinearRigidMotion::new(start, local_center, Vec3::ZERO, Vec3::new(0.0, 0.0, yaw_rate as f32))
            }
            Motion::Braking { .. } | Motion::Ballistic { .. } => return None,
        })
    }

    /// The velocity of a motion without rotation (hold: zero, linear), `None` for the others.
    fn translation_velocity(&self) -> Option<DVec3> {
        match self.motion {
            Motion::Hold => Some(DVec3::ZERO),
            Motion::Linear { velocity } => Some(velocity),
            Motion::Arc { .. } | Motion::Braking { .. } | Motion::Ballistic { .. } => None,
        }
    }

    /// Upper bound on the speed of any point within `radius` of the body origin over `[t0, t0 + span]`.
    fn speed_bound(&self, radius: f64, t: f64, span: f64) -> f64 {
        match self.motion {
            Motion::Hold => 0.0,
            Motion::Linear { velocity } => velocity.length(),
            Motion::Braking { .. } => self.velocity_at(t).length(),
            Motion::Arc { yaw_rate, .. } => self.velocity_at(t).length() + yaw_rate.abs() * radius,
            Motion::Ballistic { gravity, .. } => self.velocity_at(t).length() + gravity * span,
        }
    }
}

/// A piecewise closed-form trajectory covering all times.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    segments: Vec<Segment>,
}

impl Trajectory {
    /// A body that never moves.
    pub fn fixed(pose: Pose64) -> Self {
        Trajectory {
            segments: vec![Segment {
                t0: f64::NEG_INFINITY,
                t1: f64::INFINITY,
                pose0: pose,
                motion: Motion::Hold,
            }],
        }
    }

    /// One segment covering all times (extrapolated before its start).
    pub fn from_segment(segment: Segment) -> Self {
        Trajectory {
            segments: vec![Segment {
                t1: f64::INFINITY,
                ..segment
            }],
        }
    }

    /// Holds `pose` until `t_start`, moves with `motion` until `t_end` (may be `inf`), then holds.
    pub fn hold_move_hold(pose: Pose64, t_start: f64, motion: Motion, t_end: f64) -> Self {
        let mut segments = vec![Segment {
            t0: f64::NEG_INFINITY,
            t1: t_start,
            pose0: pose,
            motion: Motion::Hold,
        }];
        let moving = Segment {
            t0: t_start,
            t1: t_end,
            pose0: pose,
            motion,
        };
        segments.push(moving);
        if t_end.is_finite() {
            segments.push(Segment {
                t0: t_end,
                t1: f64::INFINITY,
                pose0: moving.pose_at(t_end),
                motion: Motion::Hold,
            });
        }
        Trajectory { segments }
    }

    /// Holds at `pose` until `t_start`, drives at `velocity` until `t_brake`, then brakes at
    /// `deceleration` (m/s², > 0) to a stop and holds there.
    pub fn hold_drive_brake_hold(pose: Pose64, t_start: f64, velocity: DVec3, t_brake: f64, deceleration: f64) -> Self {
        let drive = Segment {
            t0: t_start,
            t1: t_brake,
            pose0: pose,
            motion: Motion::Linear { velocity },
        };
        let t_stop = t_brake + velocity.length() / deceleration;
        let brake = Segment {
            t0: t_brake,
            t1: t_stop,
            pose0: drive.pose_at(t_brake),
            motion: Motion::Braking { velocity, deceleration },
        };
        Trajectory {
            segments: vec![
                Segment {
                    t0: f64::NEG_INFINITY,
                    t1: t_start,
                    pose0: pose,
                    motion: Motion::Hold,
                },
                drive,
                brake,
                Segment {
                    t0: t_stop,
                    t1: f64::INFINITY,
                    pose0: brake.pose_at(t_stop),
                    motion: Motion::Hold,
                },
            ],
        }
    }

    /// The segment active at time `t`.
    pub fn segment_at(&self, t: f64) -> &Segment {
        self.segments
            .iter()
            .find(|s| t < s.t1)
            .unwrap_or_else(|| self.segments.last().expect("non-empty"))
    }

    /// Pose at time `t`.
    pub fn pose_at(&self, t: f64) -> Pose64 {
        self.segment_at(t).pose_at(t)
    }

    /// Velocity of the body origin at time `t`.
    pub fn velocity_at(&self, t: f64) -> DVec3 {
        self.segment_at(t).velocity_at(t)
    }

    /// The segments, in time order.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// True when the body never moves.
    pub fn is_static(&self) -> bool {
        self.segments.iter().all(|s| matches!(s.motion, Motion::Hold))
    }
}

/// A body shape placed in its body frame, for time-of-impact queries.
pub struct PlacedShape<'a> {
    /// The shape.
    pub shape: &'a dyn Shape,
    /// Its pose in the body frame.
    pub local: Pose,
    /// Radius of a sphere about the body origin that contains the shape.
    pub bounding_radius: f64,
}

/// Turning radius above which time-of-impact queries treat an arc as a straight line (m).
const MAX_ARC_RADIUS_M: f64 = 1.0e5;

/// Distance within which the linear-cast filter of [`time_of_impact`] counts two translating bodies
/// as meeting, before the exact query (m).
const PREFILTER_DISTANCE_M: f32 = 1e-3;

/// Distance tolerance of the conservative advancement used for ballistic segments (m).
const BALLISTIC_TOLERANCE_M: f64 = 1e-4;

/// First time in `[now, now + horizon]` at which body `a` (moving with segment `a_motion` throughout) and
/// body `b` (following trajectory `b`) touch, or `None`. Returns `now` when they already overlap.
pub fn time_of_impact(
    a_motion: &Segment,
    a: &PlacedShape<'_>,
    b_traj: &Trajectory,
    b: &PlacedShape<'_>,
    now: f64,
    horizon: f64,
) -> Option<f64> {
    let end = now + horizon;
    let origin = a_motion.pose_at(now).position;
    for seg in b_traj.segments() {
        let s0 = seg.t0.max(now);
        let s1 = seg.t1.min(end);
        if s1 < s0 || (s1 == s0 && s0 > now) {
            continue;
        }
        // pure translations (hold / linear): parry's linear shape cast tells cheaply whether they
        // meet at all (the nonlinear cast bisects the whole horizon to say no); when they do, the
        // nonlinear cast below gives the time to its tighter tolerance
        if let (Some(va), Some(vb)) = (a_motion.translation_velocity(), seg.translation_velocity()) {
            let pa = a_motion.pose_at(s0).to_parry(origin) * a.local;
            let pb = seg.pose_at(s0).to_parry(origin) * b.local;
            // a generous filter: a touch within 1 mm counts (f32 misses touches exactly at s1)
            let options = ShapeCastOptions {
                stop_at_penetration: true,
                target_distance: PREFILTER_DISTANCE_M,
                ..ShapeCastOptions::with_max_time_of_impact((s1 - s0) as f32)
            };
            let hit = query::cast_shapes(&pa, va.as_vec3(), a.shape, &pb, vb.as_vec3(), b.shape, options)
                .ok()
                .flatten()
                .is_some();
            if !hit {
                continue;
            }
        }
        let hit = match (
            a_motion.parry_motion(now, origin, &a.local),
            seg.parry_motion(now, origin, &b.local),
        ) {
            (Some(ma), Some(mb)) => {
                query::cast_shapes_nonlinear(&ma, a.shape, &mb, b.shape, (s0 - now) as f32, (s1 - now) as f32, true)
                    .ok()
                    .flatten()
                    .map(|h| now + f64::from(h.time_of_impact))
            }
            _ => conservative_advancement(a_motion, a, seg, b, origin, s0, s1),
        };
        if hit.is_some() {
            return hit;
        }
    }
    None
}

/// Exact distance between the two bodies at time `t` (0 when overlapping).
pub fn distance_at(
    a_seg: &Segment,
    a: &PlacedShape<'_>,
    b_seg: &Segment,
    b: &PlacedShape<'_>,
    t: f64,
    origin: DVec3,
) -> f64 {
    let pa = a_seg.pose_at(t).to_parry(origin) * a.local;
    let pb = b_seg.pose_at(t).to_parry(origin) * b.local;
    query::distance(&pa, a.shape, &pb, b.shape)
        .map(|d| f64::from(d.distance))
        .unwrap_or(f64::INFINITY)
}

/// Root of the distance function by conservative advancement: step by distance / (bound on the closing
/// speed), which never steps past the first contact.
fn conservative_advancement(
    a_seg: &Segment,
    a: &PlacedShape<'_>,
    b_seg: &Segment,
    b: &PlacedShape<'_>,
    origin: DVec3,
    s0: f64,
    s1: f64,
) -> Option<f64> {
    let span = s1 - s0;
    let bound = a_seg.speed_bound(a.bounding_radius, s0, span) + b_seg.speed_bound(b.bounding_radius, s0, span);
    let mut t = s0;
    for _ in 0..20_000 {
        let d = distance_at(a_seg, a, b_seg, b, t, origin);
        if d <= BALLISTIC_TOLERANCE_M {
            return Some(t);
        }
        if bound <= 0.0 {
            return None;
        }
        t += d / bound;
        if t > s1 {
            return None;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use rapier3d::parry::shape::{Ball, Cuboid};

    #[test]
    fn arc_returns_after_full_turn() {
        let s = Segment {
            t0: 0.0,
            t1: f64::INFINITY,
            pose0: Pose64::from_xyz_yaw(DVec3::new(1.0, 0.0, 0.0), 0.0),
            motion: Motion::Arc {
                center: DVec3::ZERO,
                yaw_rate: 1.0,
            },
        };
        let p = s.pose_at(std::f64::consts::PI);
        assert!((p.position - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-12);
        assert!((s.velocity_at(0.0) - DVec3::new(0.0, 1.0, 0.0)).length() < 1e-12);
    }

    #[test]
    fn braking_stops_after_v2_over_2a_and_holds() {
        let v = DVec3::new(-6.0, 0.0, 0.0);
        let traj =
            Trajectory::hold_drive_brake_hold(Pose64::from_xyz_yaw(DVec3::new(20.0, 0.0, 0.0), 0.0), 0.5, v, 1.5, 4.0);
        // 6 m of driving, then 36 / 8 = 4.5 m of braking over 1.5 s
        assert!((traj.pose_at(1.5).position.x - 14.0).abs() < 1e-12);
        assert!((traj.pose_at(3.0).position.x - 9.5).abs() < 1e-12);
        assert!((traj.pose_at(10.0).position.x - 9.5).abs() < 1e-12);
        assert!((traj.velocity_at(2.25).x + 3.0).abs() < 1e-12);
        assert_eq!(traj.velocity_at(3.5), DVec3::ZERO);
        // the speed falls continuously
        assert!((traj.velocity_at(1.5 + 1e-9).x + 6.0).abs() < 1e-6);
    }

    #[test]
    fn linear_and_ballistic_toi_agree_with_closed_form() {
        let robot = Segment {
            t0: 0.0,
            t1: f64::INFINITY,
            pose0: Pose64::from_xyz_yaw(DVec3::ZERO, 0.0),
            motion: Motion::Hold,
        };
        let cube = Cuboid::new(Vec3::splat(0.5));
        let ball = Ball::new(0.1);
        let a = PlacedShape {
            shape: &cube,
            local: Pose::IDENTITY,
            bounding_radius: 0.87,
        };
        let b = PlacedShape {
            shape: &ball,
            local: Pose::IDENTITY,
            bounding_radius: 0.1,
        };
        // ball from x = 10.6 towards -x at 2 m/s: touches the face x = 0.5 when centre at 0.6 -> t = 5
        let start = Pose64::from_xyz_yaw(DVec3::new(10.6, 0.0, 0.0), 0.0);
        let lin = Trajectory::hold_move_hold(
            start,
            0.0,
            Motion::Linear {
                velocity: DVec3::new(-2.0, 0.0, 0.0),
            },
            f64::INFINITY,
        );
        let t = time_of_impact(&robot, &a, &lin, &b, 0.0, 20.0).unwrap();
        assert!((t - 5.0).abs() < 1e-3, "{t}");
        let bal = Trajectory::hold_move_hold(
            start,
            0.0,
            Motion::Ballistic {
                velocity: DVec3::new(-2.0, 0.0, 0.0),
                gravity: 0.0,
            },
            f64::INFINITY,
        );
        let t2 = time_of_impact(&robot, &a, &bal, &b, 0.0, 20.0).unwrap();
        assert!((t2 - 5.0).abs() < 1e-3, "{t2}");
        // 1 m to the side: no contact
        let side = Pose64::from_xyz_yaw(DVec3::new(10.6, 1.0, 0.0), 0.0);
        let miss = Trajectory::hold_move_hold(
            side,
            0.0,
            Motion::Linear {
                velocity: DVec3::new(-2.0, 0.0, 0.0),
            },
            f64::INFINITY,
        );
        assert!(time_of_impact(&robot, &a, &miss, &b, 0.0, 20.0).is_none());
    }
}
