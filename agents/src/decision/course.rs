//! Stage 2, the collision-course gate (module docs, "`course = "image"`"): where the object will
//! arrive relative to the robot's body, on which side it passes, whether it stops short, and
//! whether the gate lets an alarm through.

use super::fit::{Parabola, parabola, slope};
use super::percept::SelfMotion;
use super::rule::{BodyExtent, Course, DecisionRule};
use super::standing::WorldMotionMemory;
use super::window::{Sample, SampleWindow};

/// The rate of change of the time to contact, dτ/dt, at or above which an approaching object
/// decelerates hard enough to stop before it arrives (Lee 1976: −1 at constant speed, −0.5 for
/// a deceleration that stops it just at contact): the gate closes for it.
pub const STOPPING_TAU_RATE: f64 = -0.5;

/// Relative tolerance within which an object's edges move as those of an object standing in the
/// world (`d(tan a)/dt · τ = tan a`): the gate then scales the image by the robot's own speed.
pub const STANDING_TOLERANCE: f64 = 0.1;

/// An object whose edges move as a standing one's is not read as standing when, at the distance
/// standing would put it, its bottom edge lies below the horizon but less than this fraction of the
/// body's reach below the camera (the camera's height, nearly) down: it would float just under the
/// camera's height. A vehicle coming along its line of sight moves in the image exactly as an
/// object standing nearer does; only the ground tells them apart (a car closing at 11 m/s on a
/// robot at 1 m/s, its bottom 0.15 m below the camera: 1.4 cm at the standing distance). Small, so
/// that an object standing on a raised surface (a table, a bumper) is still read as standing.
pub const FLOATING_BOTTOM_FRACTION: f64 = 0.25;

/// Smallest predicted lateral miss (object radii) for which
/// [`Decision::pass_side`](super::Decision::pass_side) is given.
pub const PASS_SIDE_MIN_RADII: f64 = 0.5;

/// Largest deviation (object radii, at the predicted contact) of the object's vertical course
/// from a straight line for which the gate's vertical test applies; a more curved course (a
/// ballistic lob) is judged laterally only.
pub const STRAIGHT_COURSE_MAX_RADII: f64 = 0.5;

/// The object's course as the gate predicts it from the image over its window, in metres through
/// the assumed closing speed: what the manoeuvre planner ([`crate::planner`]) extrapolates. Relative
/// to the robot continuing the motion it had over the window; lateral offsets positive to the
/// right of the camera, vertical ones positive up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CourseForecast {
    /// The window's mean time (s), at which [`Self::tau_s`] and [`Self::lateral_m`] hold.
    pub t_s: f64,
    /// Time to contact of the object's nearest face at [`Self::t_s`] (s, > 0).
    pub tau_s: f64,
    /// The closing speed the image offsets were scaled with (m/s): the assumed one, or the
    /// robot's own forward speed for an object standing in the world.
    pub closing_mps: f64,
    /// Lateral offsets of the object's left and right edges at [`Self::t_s`] (m).
    pub lateral_m: [f64; 2],
    /// Lateral offsets of its left and right edges when it reaches the camera's depth (m).
    pub arrival_lateral_m: [f64; 2],
    /// Vertical offsets of its bottom and top edges when it reaches the camera's depth (m).
    pub arrival_vertical_m: [f64; 2],
    /// Whether its vertical course is straight (`Some(false)`: a lob; `None`: not yet known).
    pub straight: Option<bool>,
    /// Whether its edges move as those of an object standing in the world: then the closing speed
    /// is the robot's own and the metres are exact; else they scale with the assumed speed.
    pub standing: bool,
    /// Whether the closing speed is measured, not assumed: the object was seen standing before it
    /// moved, which gave its size, and its size gives its distance now (`standing.rs`). Then the
    /// metres are exact too.
    pub closing_measured: bool,
}

/// What the gate found in one frame (the course fields of [`super::Decision`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct CourseAssessment {
    pub(super) forecast: Option<CourseForecast>,
    pub(super) miss_radii: Option<f64>,
    pub(super) vertical_miss_radii: Option<f64>,
    pub(super) pass_side: Option<f32>,
    pub(super) arrival_extent_m: Option<[f64; 4]>,
    pub(super) tau_rate: Option<f64>,
    pub(super) gate_open: bool,
    /// The object, remembered standing, came nearer than a standing one could have
    /// (`standing.rs`): it moves in the world.
    pub(super) seen_moving: bool,
    /// The object's vertical extent in the image (`tan top − tan bottom`) at the forecast's time.
    pub(super) extent_tan: Option<f64>,
}

/// The edges' predicted lateral `[left, right]` and vertical `[bottom, top]` offsets (m) when the
/// object reaches the camera.
type ArrivalEdges = ([f64; 2], [f64; 2]);

/// The arrival edges with the window's mean time, τ there, the closing speed and the lateral
/// edges at the mean time (a [`CourseForecast`] but for `straight`).
struct EdgeForecast {
    edges: ArrivalEdges,
    t_s: f64,
    tau_s: f64,
    closing_mps: f64,
    lateral_m: [f64; 2],
    standing: bool,
    seen_moving: bool,
    closing_measured: bool,
    extent_tan: f64,
}

/// The estimates over the gate's window (`course_window_s`) that the gate's tests read.
struct CourseEstimates {
    miss_radii: Option<f64>,
    vertical_miss_radii: Option<f64>,
    height_radii: Option<Parabola>,
    straight: Option<bool>,
    has_elevation: bool,
    predicted_edges: Option<ArrivalEdges>,
    edge_forecast: Option<EdgeForecast>,
    tau_rate: Option<f64>,
    speed: f64,
}

/// The course gate on the window at `t_s` (this frame's θ `theta_rad`, τ̂ `tau_s`), with what the
/// decider remembers of its object's motion in the world (`None`: a decider not bound to one object).
#[allow(clippy::too_many_arguments)]
pub(super) fn assess(
    window: &SampleWindow,
    t_s: f64,
    theta_rad: f64,
    tau_s: Option<f64>,
    motion: &SelfMotion,
    rule: &DecisionRule,
    body: &BodyExtent,
    world_motion: Option<&WorldMotionMemory>,
) -> CourseAssessment {
    let course_from = t_s - rule.course_window_s - 1e-9;
    let course = || window.since(course_from);
    let e = estimate(course, tau_s, motion, rule, body, world_motion);
    let pass_side = match e.predicted_edges {
        Some(([l, r], _)) => {
            let (centre, half) = ((l + r) / 2.0, (r - l).abs() / 2.0);
            (centre.abs() >= PASS_SIDE_MIN_RADII * half).then_some(centre.signum() as f32)
        }
        None => e
            .miss_radii
            .filter(|mu| mu.abs() >= PASS_SIDE_MIN_RADII)
            .map(|mu| mu.signum() as f32),
    };
    let gate_open = match (rule.course, tau_s) {
        (Course::Off, _) => true,
        (Course::Image, None) => false,
        // elevations seen, but too few to tell a straight course from a lob yet: wait
        (Course::Image, Some(_)) if e.has_elevation && e.straight.is_none() => false,
        // braking to a stop before it arrives (a lob's distance shrinks unevenly: not judged)
        (Course::Image, Some(_)) if e.tau_rate.is_some_and(|r| r >= STOPPING_TAU_RATE) && e.straight != Some(false) => {
            false
        }
        (Course::Image, Some(tau)) => arrives_at_body(course, t_s, theta_rad, tau, &e, body),
    };
    CourseAssessment {
        forecast: e.edge_forecast.as_ref().map(|f| CourseForecast {
            t_s: f.t_s,
            tau_s: f.tau_s,
            closing_mps: f.closing_mps,
            lateral_m: f.lateral_m,
            arrival_lateral_m: f.edges.0,
            arrival_vertical_m: f.edges.1,
            straight: e.straight,
            standing: f.standing,
            closing_measured: f.closing_measured,
        }),
        miss_radii: e.miss_radii,
        vertical_miss_radii: e.vertical_miss_radii,
        pass_side,
        arrival_extent_m: e.predicted_edges.map(|([l, r], [b, t])| [l, r, b, t]),
        tau_rate: e.tau_rate,
        gate_open,
        seen_moving: e.edge_forecast.as_ref().is_some_and(|f| f.seen_moving),
        extent_tan: e.edge_forecast.as_ref().map(|f| f.extent_tan),
    }
}

/// The bearing and expansion rates, the vertical course and the edges' arrival over the window.
fn estimate<'a, I>(
    course: impl Fn() -> I,
    tau_s: Option<f64>,
    motion: &SelfMotion,
    rule: &DecisionRule,
    body: &BodyExtent,
    world_motion: Option<&WorldMotionMemory>,
) -> CourseEstimates
where
    I: Iterator<Item = &'a Sample> + Clone,
{
    // μ from the bearing rates against the expansion rate.
    let theta_fit = slope(course().filter(|s| s.has_theta()).map(|s| (s.t, s.theta_rad))).filter(|v| v.0 > 0.0);
    let theta_dot = theta_fit.map(|v| v.0);
    let az_dot = slope(course().filter_map(|s| s.azimuth_rad.map(|a| (s.t, a)))).map(|v| v.0 - motion.yaw_rate_rps);
    let miss_radii = theta_dot.zip(az_dot).map(|(td, az)| 2.0 * az / td);
    // the elevation in object radii, sin(e)/sin(θ/2), is linear in t on a straight course at
    // constant speed and quadratic under gravity
    let has_elevation = course().any(|s| s.elevation_rad.is_some());
    let height_radii = parabola(
        course()
            .filter(|s| s.has_theta())
            .filter_map(|s| s.elevation_rad.map(|e| (s.t, e.sin() / (s.theta_rad / 2.0).sin()))),
    );
    let straight = tau_s
        .zip(height_radii)
        .map(|(tau, h)| (h.c * tau * tau).abs() <= STRAIGHT_COURSE_MAX_RADII);
    let el_dot = slope(course().filter_map(|s| s.elevation_rad.map(|e| (s.t, e)))).map(|v| v.0);
    let vertical_miss_radii = match (theta_dot, el_dot, straight) {
        (Some(td), Some(ed), Some(true)) => Some(2.0 * ed / td),
        _ => None,
    };
    let speed = rule.course_closing_speed_mps.max(motion.forward_mps);
    let edge_forecast = arrival_edges(&course, theta_fit, speed, motion, body, world_motion);
    let predicted_edges = edge_forecast.as_ref().map(|f| f.edges);
    // dτ/dt from ln θ = a + b·t + c·t²: τ = 1/(b + 2ct), so dτ/dt = −2c/b² at the window's mean
    let ln_theta = || course().filter(|s| s.has_theta()).map(|s| (s.t, s.theta_rad.ln()));
    let tau_rate = slope(ln_theta())
        .filter(|v| v.0 > 0.0)
        .zip(parabola(ln_theta()))
        .map(|((b, _, _), ln_theta)| -2.0 * ln_theta.c / (b * b));
    CourseEstimates {
        miss_radii,
        vertical_miss_radii,
        height_radii,
        straight,
        has_elevation,
        predicted_edges,
        edge_forecast,
        tau_rate,
        speed,
    }
}

/// The edges' predicted offsets when the object reaches the camera (m): at the window's mean
/// time, x = d·τ·d(tan a)/dt with the distance d = v̂·τ and τ the optical time to contact — from
/// the growth of the object's vertical extent (tan top − tan bottom ∝ height/depth of its nearest
/// face: the time to contact of that face, whatever the object's shape), else θ/θ̇ (`theta_fit`).
fn arrival_edges<'a, I>(
    course: &impl Fn() -> I,
    theta_fit: Option<(f64, f64, f64)>,
    speed: f64,
    motion: &SelfMotion,
    body: &BodyExtent,
    world_motion: Option<&WorldMotionMemory>,
) -> Option<EdgeForecast>
where
    I: Iterator<Item = &'a Sample> + Clone,
{
    let extent_tau = slope(course().filter_map(|s| s.edges_tan.map(|e| (s.t, e[3] - e[2]))))
        .filter(|&(rate, _, mean)| rate > 0.0 && mean > 0.0)
        .map(|(rate, _, mean)| mean / rate);
    let tau_c = extent_tau.or(theta_fit.map(|(td, _, theta_mean)| theta_mean / td))?;
    let rate = |i: usize| slope(course().filter_map(|s| s.edges_tan.map(|e| (s.t, e[i])))).map(|(b, _, m)| (b, m));
    let edges = [rate(0)?, rate(1)?, rate(2)?, rate(3)?];
    // an object that stands in the world, seen from a robot driving straight, has
    // d(tan a)/dt = tan a / τ at every edge: then it closes at the robot's own speed
    let radial = motion.forward_mps > 0.0
        && motion.yaw_rate_rps == 0.0
        && edges
            .iter()
            .all(|&(rate, mean)| (rate * tau_c - mean).abs() <= STANDING_TOLERANCE * mean.abs().max(0.05));
    let (n, t_sum) = course()
        .filter(|s| s.edges_tan.is_some())
        .fold((0.0, 0.0), |(n, sum), s| (n + 1.0, sum + s.t));
    let t_mean = t_sum / n;
    // radial expansion reads as standing unless the object, remembered standing, came nearer than a
    // standing one could (standing.rs)
    let nearer_than_standing = world_motion
        .and_then(|m| m.min_standing_tau_s(t_mean, motion.forward_mps))
        .is_some_and(|least| tau_c < least);
    // read as standing, its bottom would float above the ground just below the horizon: it comes
    // along its line of sight from farther away instead (the ground's height tells)
    let floats = {
        let below_camera_m = -motion.forward_mps * tau_c * edges[2].1;
        below_camera_m > 0.0 && below_camera_m < FLOATING_BOTTOM_FRACTION * body.below_camera_m
    };
    let standing = radial && !nearer_than_standing && !floats;
    // a moving object whose height was measured while it stood: its distance in each frame is that
    // height over its vertical extent, and the distance falls at the closing speed (a line fitted
    // to the distances: fitting the extent instead, which grows as 1/distance, biases it low)
    let extent_tan = edges[3].1 - edges[2].1;
    let measured = world_motion
        .and_then(WorldMotionMemory::height_m)
        .filter(|_| !standing)
        .and_then(|h| slope(course().filter_map(|s| s.edges_tan.map(|e| (s.t, h / (e[3] - e[2]))))))
        .map(|(rate, _, _)| -rate)
        .filter(|v| v.is_finite() && *v > 0.0);
    let closing = if standing {
        motion.forward_mps
    } else {
        measured.unwrap_or(speed)
    };
    let scale = closing * tau_c.powi(2);
    let lateral = |(rate, mean): (f64, f64)| scale * (rate - motion.yaw_rate_rps * (1.0 + mean * mean));
    Some(EdgeForecast {
        edges: (
            [lateral(edges[0]), lateral(edges[1])],
            [scale * edges[2].0, scale * edges[3].0],
        ),
        t_s: t_mean,
        tau_s: tau_c,
        closing_mps: closing,
        lateral_m: [closing * tau_c * edges[0].1, closing * tau_c * edges[1].1],
        standing,
        seen_moving: nearer_than_standing,
        closing_measured: measured.is_some(),
        extent_tan,
    })
}

/// The lateral span `[left, right]` (m) the object's edges sweep on their straight course while it
/// passes the body's length, from `ahead_of_camera_m` in front of the camera to `behind_camera_m`
/// behind it: an oblique object that passes the camera's depth beside the body can still strike its
/// side further back.
fn swept_lateral(f: &EdgeForecast, body: &BodyExtent) -> [f64; 2] {
    let depth = f.closing_mps * f.tau_s;
    if depth.is_nan() || depth <= 0.0 {
        return f.edges.0;
    }
    // an edge's offset `d` metres ahead of the camera (negative: behind it)
    let at = |i: usize, d: f64| f.edges.0[i] - (f.edges.0[i] - f.lateral_m[i]) / depth * d;
    let ends = [
        at(0, body.ahead_of_camera_m),
        at(1, body.ahead_of_camera_m),
        at(0, -body.behind_camera_m),
        at(1, -body.behind_camera_m),
    ];
    [
        ends.into_iter().fold(f64::INFINITY, f64::min),
        ends.into_iter().fold(f64::NEG_INFINITY, f64::max),
    ]
}

/// Whether an object with τ̂ `tau` will touch the body (the open gate's test).
fn arrives_at_body<'a, I>(
    course: impl Fn() -> I,
    t_s: f64,
    theta_rad: f64,
    tau: f64,
    e: &CourseEstimates,
    body: &BodyExtent,
) -> bool
where
    I: Iterator<Item = &'a Sample> + Clone,
{
    let overlaps = |[a, b]: [f64; 2], low: f64, high: f64| a.min(b) <= high && a.max(b) >= low;
    let radius = (theta_rad / 2.0).min(std::f64::consts::FRAC_PI_2).sin() * tau.max(0.0) * e.speed;
    let within_body_height = |centre_radii: f64| {
        (centre_radii - 1.0) * radius <= body.above_camera_m && (centre_radii + 1.0) * radius >= -body.below_camera_m
    };
    // a curved course (a lob) is extrapolated along its parabola to the time its distance ahead,
    // in object radii cos(e)·cos(a)/sin(θ/2), reaches zero (a lob's distance shrinks unevenly, so
    // τ̂ overestimates its arrival time), or to τ̂ when that is sooner (a course that bends because
    // the object was just launched)
    let curved_course_ok = match (e.straight, e.height_radii) {
        (Some(false), Some(h)) => {
            let ahead = slope(course().filter(|s| s.has_theta()).filter_map(|s| {
                let (a, e) = (s.azimuth_rad?, s.elevation_rad?);
                Some((s.t, e.cos() * a.cos() / (s.theta_rad / 2.0).sin()))
            }));
            match ahead {
                Some((rate, t_mean, mean)) if rate < 0.0 => {
                    let arrival_s = (-(mean + rate * (t_s - t_mean)) / rate).min(tau);
                    within_body_height(h.at(t_s + arrival_s.max(0.0)))
                }
                _ => false,
            }
        }
        _ => true,
    };
    curved_course_ok
        && match (e.predicted_edges, e.miss_radii) {
            (Some((lateral, vertical)), _) => {
                let swept = e.edge_forecast.as_ref().map_or(lateral, |f| swept_lateral(f, body));
                overlaps(swept, -body.half_width_m, body.half_width_m)
                    && (e.straight != Some(true) || overlaps(vertical, -body.below_camera_m, body.above_camera_m))
            }
            (None, Some(mu)) => {
                (mu.abs() - 1.0) * radius <= body.half_width_m && e.vertical_miss_radii.is_none_or(within_body_height)
            }
            (None, None) => false,
        }
}
