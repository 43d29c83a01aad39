//! Exact per-frame ground truth: distance, angular size and its rate, time to contact, collision course.

use serde::Serialize;

use crate::glam::DVec3;
use crate::object::ObjectKind;
use crate::shape::AngularPrimitive;
use crate::trajectory::Pose64;

/// Ground truth for one object at one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectTruth {
    /// Index of the object (scenery first, then vehicles, then projectiles, each in file order).
    pub id: usize,
    /// The object's name.
    pub name: String,
    /// The object's kind.
    pub kind: ObjectKind,
    /// Distance from the camera to the nearest point of the object's surface (m; 0 inside it).
    pub distance_m: f32,
    /// Distance from the camera to the object's reference point (sphere centre, vehicle reference point).
    pub center_distance_m: f32,
    /// True angular size: the largest angle between two points of the object seen from the camera
    /// (a sphere: `2·asin(r/d)`), in degrees; 180 when the camera is inside it.
    pub angular_size_deg: f32,
    /// Time derivative of `angular_size_deg` (degrees/s; positive = looming), from the exact motions.
    pub angular_rate_deg_s: f32,
    /// Optical time to contact θ / θ̇ (s), when the object is looming (θ̇ > 0).
    pub tau_s: Option<f32>,
    /// Time until the object touches the robot's body (s) if the robot keeps its current command and the
    /// object its planned path; `None` if not within the prediction horizon. Exact (parry time of
    /// impact on the analytic motions), 0 while touching.
    pub ttc_s: Option<f32>,
    /// Whether `ttc_s` is `Some`: the object is on a collision course with the robot's body.
    pub on_collision_course: bool,
    /// Horizontal image position of the object's reference point: −1 at the left image border, +1 at the
    /// right, clamped to [−1, 1] (objects outside the view or behind the camera report the side they
    /// are on). An escape controller turns away from its sign.
    pub bearing: f32,
    /// Azimuth of the reference point from the optical axis (degrees, positive = right, ±180 behind).
    pub bearing_deg: f32,
    /// Elevation of the reference point (degrees, positive = up).
    pub elevation_deg: f32,
    /// Azimuths of the object's left and right image edges (degrees, positive = right; `[min, max]`):
    /// the extremes over its vertices and spheres.
    pub azimuth_extent_deg: [f32; 2],
    /// Elevations of the object's bottom and top image edges (degrees, positive = up; `[min, max]`):
    /// `atan` of the image's vertical coordinate z/x, like the azimuths.
    pub elevation_extent_deg: [f32; 2],
    /// Whether the reference point projects inside the image.
    pub in_view: bool,
    /// Whether the object touches the robot's body now (rapier's narrow phase, its speculative
    /// contacts left out: the two within 1 mm).
    pub in_contact: bool,
}

/// A contact between the robot's body and an object, reported by rapier's collision events.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Contact {
    /// Time of the physics (sub)step at whose end rapier found the bodies touching (s).
    pub t_s: f64,
    /// Frame index (1-based step count) during which it happened.
    pub frame: u64,
    /// The object's id (see [`ObjectTruth::id`]).
    pub object_id: usize,
    /// The object's name.
    pub name: String,
    /// The object's kind.
    pub kind: ObjectKind,
    /// Exact time of first touch within that (sub)step, from a time-of-impact query on the bodies'
    /// motions over the substep (analytic physics: their closed-form paths; dynamic physics: their
    /// poses and velocities at the substep's start) (`None` when the bodies already overlapped at its
    /// start).
    pub exact_t_s: Option<f64>,
    /// Relative speed of the two bodies' centres when they first touched (m/s): at the start of the
    /// substep in which the contact began.
    pub impact_speed_mps: f64,
    /// Dynamic physics: the magnitude of the contact impulse exchanged in the substep in which the
    /// contact began (N·s); `None` with analytic physics (nothing pushes).
    pub impulse_ns: Option<f64>,
    /// Whether the impact was below the world's `harmless_impact_speed_mps` (not a collision).
    pub harmless: bool,
}

impl Contact {
    /// The contact time (s): the exact time of first touch when known, else the time of the
    /// substep in which rapier found the bodies touching.
    pub fn time_s(&self) -> f64 {
        self.exact_t_s.unwrap_or(self.t_s)
    }
}

/// The angular diameter (rad) of a set of primitives (in the body frame at `pose`) seen from `eye`.
pub(crate) fn angular_size(prims: &[AngularPrimitive], pose: &Pose64, eye: DVec3) -> f64 {
    let pi = std::f64::consts::PI;
    let mut dirs: Vec<(DVec3, f64)> = Vec::with_capacity(prims.len());
    for p in prims {
        match p {
            AngularPrimitive::Point(q) => {
                let d = pose.transform_point(*q) - eye;
                let len = d.length();
                if len < 1e-12 {
                    return pi;
                }
                dirs.push((d / len, 0.0));
            }
            AngularPrimitive::Sphere(c, r) => {
                let d = pose.transform_point(*c) - eye;
                let len = d.length();
                if len <= *r {
                    return pi;
                }
                dirs.push((d / len, (r / len).asin()));
            }
        }
    }
    let mut best = 0.0f64;
    let mut min_dot_points = 1.0f64;
    for (i, (u, a)) in dirs.iter().enumerate() {
        best = best.max(2.0 * a);
        for (v, b) in &dirs[i + 1..] {
            let dot = u.dot(*v).clamp(-1.0, 1.0);
            if *a == 0.0 && *b == 0.0 {
                min_dot_points = min_dot_points.min(dot);
            } else {
                best = best.max(dot.acos() + a + b);
            }
        }
    }
    best.max(min_dot_points.acos()).min(pi)
}

/// The azimuth and elevation extents (degrees, `[min, max]` each) of a set of primitives (in the
/// body frame at `pose`) seen from the camera at `cam` (x forward, y left, z up): the extremes of
/// the vertices' image coordinates, `atan(−y/x)` and `atan(z/x)` (the pinhole image's box, as
/// angles), and of each sphere's centre ± its angular radius. Points behind the camera count at
/// ±90°.
pub(crate) fn angular_extent(prims: &[AngularPrimitive], pose: &Pose64, cam: &Pose64) -> ([f64; 2], [f64; 2]) {
    let to_cam = cam.rotation.inverse();
    let mut az = [f64::INFINITY, f64::NEG_INFINITY];
    let mut el = [f64::INFINITY, f64::NEG_INFINITY];
    let mut include = |c: DVec3, radius: f64| {
        let rel = to_cam * (pose.transform_point(c) - cam.position);
        let len = rel.length();
        let half = if len <= radius {
            90.0
        } else {
            (radius / len).asin().to_degrees()
        };
        let a = (-rel.y).atan2(rel.x.max(0.0)).to_degrees();
        // the pinhole image's vertical coordinate is z/x (not the elevation above the horizontal
        // plane, atan(z/√(x² + y²)), which differs at an object's off-axis corners: a wide box
        // near the robot would grow at another rate in height than in width)
        let e = rel.z.atan2(rel.x.max(0.0)).to_degrees();
        az = [az[0].min(a - half), az[1].max(a + half)];
        el = [el[0].min(e - half), el[1].max(e + half)];
    };
    for p in prims {
        match p {
            AngularPrimitive::Point(q) => include(*q, 0.0),
            AngularPrimitive::Sphere(c, r) => include(*c, *r),
        }
    }
    (az, el)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::glam::DQuat;

    #[test]
    fn extents_of_a_sphere_and_a_box() {
        let pose = Pose64 {
            position: DVec3::new(10.0, -1.0, 0.5),
            rotation: DQuat::IDENTITY,
        };
        let cam = Pose64 {
            position: DVec3::ZERO,
            rotation: DQuat::IDENTITY,
        };
        let (az, el) = angular_extent(&[AngularPrimitive::Sphere(DVec3::ZERO, 0.5)], &pose, &cam);
        let (a, e) = (1.0f64.atan2(10.0).to_degrees(), 0.5f64.atan2(10.0).to_degrees());
        let half = (0.5 / 101.25f64.sqrt()).asin().to_degrees();
        assert!(
            (az[0] - (a - half)).abs() < 1e-9 && (az[1] - (a + half)).abs() < 1e-9,
            "{az:?}"
        );
        assert!(
            (el[0] - (e - half)).abs() < 1e-9 && (el[1] - (e + half)).abs() < 1e-9,
            "{el:?}"
        );
        // a unit cube: its far inner and near outer edges bound the azimuths
        let corners: Vec<AngularPrimitive> = (0..8)
            .map(|i| {
                let c = |b: usize| if i & b == 0 { -0.5 } else { 0.5 };
                AngularPrimitive::Point(DVec3::new(c(1), c(2), c(4)))
            })
            .collect();
        let (az, el) = angular_extent(&corners, &pose, &cam);
        assert!((az[0] - 0.5f64.atan2(10.5).to_degrees()).abs() < 1e-9, "{az:?}");
        assert!((az[1] - 1.5f64.atan2(9.5).to_degrees()).abs() < 1e-9, "{az:?}");
        // the image's vertical coordinate z/x: the near top edge, whatever its azimuth
        assert!((el[1] - 1.0f64.atan2(9.5).to_degrees()).abs() < 1e-9, "{el:?}");
        assert!(el[0].abs() < 1e-9, "{el:?}");
    }

    #[test]
    fn sphere_angular_size_is_two_asin() {
        let prims = [AngularPrimitive::Sphere(DVec3::ZERO, 0.5)];
        let pose = Pose64::from_xyz_yaw(DVec3::new(10.0, 0.0, 0.0), 0.0);
        let a = angular_size(&prims, &pose, DVec3::ZERO);
        assert!((a - 2.0 * (0.05f64).asin()).abs() < 1e-12);
        assert_eq!(
            angular_size(&prims, &pose, DVec3::new(9.8, 0.0, 0.0)),
            std::f64::consts::PI
        );
    }

    #[test]
    fn box_angular_size_from_corners() {
        // a 2 m wide, flat board at 10 m: width subtends 2·atan(1/10) (its depth is negligible)
        let mut prims = Vec::new();
        for (y, z) in [(-1.0, -1e-3), (1.0, -1e-3), (-1.0, 1e-3), (1.0, 1e-3)] {
            prims.push(AngularPrimitive::Point(DVec3::new(0.0, y, z)));
        }
        let pose = Pose64::from_xyz_yaw(DVec3::new(10.0, 0.0, 0.0), 0.0);
        let a = angular_size(&prims, &pose, DVec3::ZERO);
        assert!((a - 2.0 * (0.1f64).atan()).abs() < 1e-6, "{a}");
    }
}
