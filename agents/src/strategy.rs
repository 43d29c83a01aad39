//! Decision strategies: how one frame's percept becomes the scalar the escape controller compares
//! with its alarm threshold.
//!
//! # Perceptual inputs
//! A strategy sees, per frame, a [`Percept`] and what the robot knows about itself:
//! - `theta_deg`: the looming object's angular size θ̂ (degrees) — the driving detector's
//!   estimate, or (reference rows only) an object's true angular size;
//! - `azimuth_deg` / `elevation_deg`: the object's image position as angles from the optical axis
//!   (degrees, azimuth positive to the right, elevation positive up). A real detector's agent
//!   converts the looming side (the x centroid of the temporal contrast, image x in [−1, 1]) into
//!   an azimuth with the camera's field of view; it has no elevation;
//! - the robot's own yaw rate (the command it applied during the last camera period) and its body's
//!   half-width ([`EscapeConfig::body_half_width_m`](crate::EscapeConfig)).
//!
//! No strategy reads distances, velocities or contact predictions of other objects.
//!
//! # `trigger = "tau"`: time to contact from θ̂
//! Each frame appends `(t, ln θ̂)` to a window of the last `tau_window_s` seconds (frames with
//! θ̂ below `min_angular_size_deg`, ≤ 0 or NaN are skipped: a detector's θ̂ of 10⁻²⁹° that jumps to
//! 5° in one frame is no estimate followed by one, not a relative expansion rate, and its ln θ̂
//! slope would give a τ̂ of 1 ms). The least-squares slope `b` of ln θ̂ against t over the window is the
//! relative expansion rate θ̇/θ at the window's mean time `t̄` (where the fit passes through
//! `θ̄ = exp(mean ln θ̂)`). The optical τ = θ/θ̇ = 1/b is the time to contact of the object's
//! *centre*; for a sphere (`sin(θ/2) = R/d`) the time until its *surface* reaches the camera is
//! `κ(θ̄)/b` with `κ(θ) = 2·tan(θ/2)·(1 − sin(θ/2))/θ` ([`surface_factor`]; κ ≈ 1 − θ/2 for small
//! θ). Under a constant closing speed the time to contact falls by one second per second, so the
//! estimate for *now* is `τ̂ = κ(θ̄)/b − (t − t̄)` (lag compensation; causal: only past and present
//! frames, no look-ahead). The strategy's
//! decision value is the **urgency** `1/τ̂` (s⁻¹; a τ̂ ≤ 1 ms counts as 1 ms) when θ̂ ≥
//! `min_angular_size_deg`, `b > 0` and the window holds at least [`MIN_SAMPLES`] frames, else 0;
//! the controller alarms when the urgency is ≥ `1 / tau_threshold_s`, i.e. τ̂ ≤ `tau_threshold_s`.
//!
//! **Jumps.** A θ̂ that changes by more than [`JUMP_RATIO`] (1.3) from one frame to the next
//! empties the window (of the τ fit and of the course gate): such a step is a relative expansion
//! rate whose τ (a frame period over ln 1.3: 32 ms at 120 Hz) no escape could answer, so it is no
//! object's growth but another percept — a tracked region that merged with another one or split,
//! a read-out that switched objects. Fitted across the step, ln θ̂ gives a τ̂ of a few frames and
//! the edges' rates a course through the body (in the default suite: cars braking short, static
//! obstacles beside the path, receding objects).
//!
//! # `course = "image"`: the collision-course gate
//! The gate lets an alarm through only when the object's image says it will touch the robot's
//! body. It reads the object's image over the last `course_window_s` seconds (longer than the τ
//! window: a bearing rate is a small difference): its angular size θ, the direction of its
//! reference point and, when the percept has one, its image extent (the edges' azimuths and
//! elevations). Directions are first corrected for the camera's own rotation (the robot's yaw
//! rate and the camera shake its inertial sensor measures, [`Ego`]).
//!
//! **Where it arrives.** The image gives no scale: it gives offsets in units of the object's
//! distance. The gate converts them with an assumed closing speed v̂ (`course_closing_speed_mps`,
//! or the robot's forward speed when larger): a point at image direction `u = tan a` moving at
//! constant velocity arrives (reaches the camera's depth) at a lateral offset `x = v̂ · τ² · u̇`,
//! with τ the time to contact at the window's mean time. With an image extent, τ comes from the
//! growth of the object's vertical extent (the time to contact of its nearest face, whatever its
//! shape) and the four edges are extrapolated: the object is on a collision course when its
//! predicted extent overlaps the body's (half-width beside the camera, its reach above and below
//! the camera). An object whose edges all move as those of an object standing in the world
//! (`u̇ · τ = u` within [`STANDING_TOLERANCE`]) closes at the robot's own speed, which then replaces
//! v̂. Without an extent (a detector row), the object is taken as a sphere: its centre arrives
//! `R · μ` beside the camera with `μ = 2·β̇/θ̇` (the miss in object radii; |μ| < 1 iff both edges
//! diverge) and `R̂ = sin(θ/2) · τ̂ · v̂`; the gate needs `(|μ| − 1) · R̂` ≤ the body's half-width.
//!
//! **Vertically**, the elevation in object radii `sin(e)/sin(θ/2)` is linear in time on a straight
//! course at constant speed and a parabola under gravity. When it deviates from a straight line by
//! more than [`STRAIGHT_COURSE_MAX_RADII`] at the predicted contact, the course is curved (a lob)
//! and its parabola is followed to the time the object's distance ahead reaches zero (or τ̂, if
//! sooner: a course that bends because the object was just launched); otherwise the edges (or
//! the centre) are extrapolated straight. Until the window holds enough elevations to tell, the
//! gate stays closed.
//!
//! **Stopping short.** An object braking hard enough to stop before it arrives has dτ/dt ≥
//! [`STOPPING_TAU_RATE`] (−1 at a constant speed; Lee 1976); the gate closes for it (dτ/dt from a
//! parabola fitted to ln θ; not judged on curved courses, whose distance shrinks unevenly).
//!
//! **Limits.** An object closing faster than v̂ looks nearer the axis than it is (a fast near pass
//! may get through); a slower one farther (a slow graze of the body's edge may be gated out). An
//! object whose extreme edges lie at different depths (the side of a long vehicle) looks nearer the
//! axis than it is. Without an image position over the window (fewer than [`MIN_SAMPLES`] frames)
//! the gate is closed.
//!
//! **Escape side.** The gate also gives the side on which the object will arrive
//! ([`Decision::pass_side`], when it arrives at least [`PASS_SIDE_MIN_RADII`] half-sizes off the
//! axis): the `ideal_course` reference row escapes from it (an object seen on the left that will
//! cross to the right is dodged to the left), and so do detector rows whose detector localises the
//! object (`tracker`: the gate extrapolates its box's edges). Other detector rows escape from the
//! looming side: a μ from the temporal-contrast centroid is too noisy to choose a side (with it, 4
//! hits of `hopfield_adapted_tau` in `multi_object` dodged into an object).
//!
//! # Persistence (`persistence_frames`, `persistence_window_frames`)
//! With `persistence_frames = K > 1` the decision value is the smallest of the last K frames'
//! values (after the τ rule and the gate; 0 — NaN for an output — until K frames have been seen
//! or while one of them is NaN): the controller alarms only when the value has been at or above
//! its threshold on K consecutive frames. As a minimum it means that for any threshold, so a
//! threshold calibrated on the decision values (`--calibrate`) calibrates the persistent rule. It
//! trades hits for false alarms: an alarm comes K − 1 frames later, and a percept that is wrong for
//! fewer frames raises none.
//!
//! With a window `persistence_window_frames = M > K` the value is the K-th largest of the last M
//! frames' values that are numbers (idle while fewer than K are): the controller alarms once the
//! value has been at or above its threshold on any K of the last M frames (a K-of-M confirmation,
//! as radar trackers confirm a track) — again for any threshold. A percept that flickers (a
//! noisy τ̂ that leaves the threshold for a frame or two on its way down) still raises an alarm,
//! where K consecutive frames would start counting afresh; M = K is the rule above.
//!
//! # `trigger = "angular_size"` / `"output"`
//! Stateless: the value is θ̂ (degrees) or the detector's output, compared with `threshold`; the
//! course gate, when on, sets the value to 0 (θ̂) or NaN (output) while closed.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

/// A θ̂ that changes by more than this factor from one frame to the next starts the window afresh
/// (module docs, "Jumps").
pub const JUMP_RATIO: f64 = 1.3;

/// Fewest frames in the window for a τ or bearing-rate estimate.
pub const MIN_SAMPLES: usize = 3;

/// The collision-course gate (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Course {
    /// No gate: every alarm goes through.
    #[default]
    Off,
    /// The gate from the object's image position and angular size and the robot's body.
    Image,
}

/// What a strategy sees of one object in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Percept {
    /// Angular size θ̂ (degrees; NaN when unknown) — or the detector's output for output triggers.
    pub value: f64,
    /// Azimuth of the object from the optical axis (degrees, positive right), when known.
    pub azimuth_deg: Option<f64>,
    /// Elevation of the object (degrees, positive up), when known.
    pub elevation_deg: Option<f64>,
    /// The object's image extent, when known (the ideal rows; detectors give none).
    pub extent: Option<ImageExtent>,
}

/// Where an object's image begins and ends, as angles from the optical axis (degrees).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ImageExtent {
    /// Azimuths of its left and right edges (positive right; `[min, max]`).
    pub azimuth_deg: [f64; 2],
    /// Elevations of its bottom and top edges (positive up; `[min, max]`).
    pub elevation_deg: [f64; 2],
}

/// What the robot knows about itself in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ego {
    /// Yaw rate applied during the last camera period (rad/s, positive = turning left).
    pub yaw_rate_rps: f64,
    /// Forward speed applied during the last camera period (m/s).
    pub forward_mps: f64,
    /// The camera's yaw relative to its mount in this frame (rad, positive = left: camera shake as
    /// the robot's inertial sensor measures it); image azimuths are corrected by it.
    pub camera_yaw_rad: f64,
    /// The camera's pitch relative to its mount in this frame (rad, positive = up); image
    /// elevations are corrected by it.
    pub camera_pitch_rad: f64,
}

impl Ego {
    /// The robot's own motion during a camera period in which it applied `command`, its camera
    /// turned by `shake_rad` relative to its mount at the period's end (`[yaw, pitch, roll]`, as
    /// [`crate::CameraSense::shake_rad`]; zeros for a rigid mount).
    pub fn of(command: crate::VelocityCommand, shake_rad: [f64; 3]) -> Self {
        Self {
            yaw_rate_rps: command.yaw_rate_rps,
            forward_mps: command.forward_mps,
            camera_yaw_rad: shake_rad[0],
            camera_pitch_rad: shake_rad[1],
        }
    }
}

/// Parameters of a strategy (the subset of [`crate::EscapeConfig`] it reads).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrategyParams {
    /// τ trigger (true) or stateless value (false).
    pub tau: bool,
    /// Smallest θ̂ (degrees) for a τ alarm, and for a frame to enter the τ̂ fit.
    pub min_angular_size_deg: f64,
    /// Length of the estimation window (s).
    pub window_s: f64,
    /// The course gate.
    pub course: Course,
    /// Persistence: the value is the K-th largest (K = this) of the last
    /// `persistence_window_frames` frames' values (1: none).
    pub persistence_frames: usize,
    /// The persistence window M (frames, ≥ `persistence_frames`; equal: K consecutive frames).
    pub persistence_window_frames: usize,
    /// Closing speed assumed by the gate (m/s).
    pub closing_speed_mps: f64,
    /// Length of the window over which the gate estimates the bearing and expansion rates (s).
    pub course_window_s: f64,
    /// Half-width of the robot's body (m).
    pub body_half_width_m: f64,
    /// How far the body reaches above the camera (m).
    pub body_above_camera_m: f64,
    /// How far the body reaches below the camera (m).
    pub body_below_camera_m: f64,
    /// Whether the value is an angle (θ̂ or urgency: 0 when gated) or an output (NaN when gated).
    pub angle_valued: bool,
}

/// One frame's decision quantities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// The value compared with the controller's alarm threshold (urgency 1/τ̂ for τ triggers).
    pub value: f64,
    /// τ̂ (s), when estimated.
    pub tau_s: Option<f64>,
    /// Predicted lateral miss in object radii μ (signed: positive = the object arrives to the
    /// right of the camera), when estimated.
    pub miss_radii: Option<f64>,
    /// Predicted vertical miss in object radii (positive = above the camera), when the window
    /// holds elevations of an object flying straight (see the module docs).
    pub vertical_miss_radii: Option<f64>,
    /// The side (−1 left, +1 right, as image x) on which the object is predicted to arrive, when
    /// it arrives at least [`PASS_SIDE_MIN_RADII`] object radii off the camera's axis.
    pub pass_side: Option<f32>,
    /// Where the object's edges are predicted to be when it reaches the camera (m, from the image
    /// extent): `[left, right, bottom, top]` relative to the camera (lateral positive = right).
    pub arrival_extent_m: Option<[f64; 4]>,
    /// The rate of change of the optical time to contact dτ/dt over the gate's window (−1 at a
    /// constant closing speed), when estimated.
    pub tau_rate: Option<f64>,
    /// Whether the course gate is open (always true with `course = "off"`).
    pub gate_open: bool,
}

/// The rate of change of the time to contact, dτ/dt, at or above which an approaching object
/// decelerates hard enough to stop before it arrives (Lee 1976: −1 at constant speed, −0.5 for
/// a deceleration that stops it just at contact): the gate closes for it.
pub const STOPPING_TAU_RATE: f64 = -0.5;

/// Relative tolerance within which an object's edges move as those of an object standing in the
/// world (`d(tan a)/dt · τ = tan a`): the gate then scales the image by the robot's own speed.
pub const STANDING_TOLERANCE: f64 = 0.1;

/// Smallest predicted lateral miss (object radii) for which [`Decision::pass_side`] is given.
pub const PASS_SIDE_MIN_RADII: f64 = 0.5;

/// Largest deviation (object radii, at the predicted contact) of the object's vertical course
/// from a straight line for which the gate's vertical test applies; a more curved course (a
/// ballistic lob) is judged laterally only.
pub const STRAIGHT_COURSE_MAX_RADII: f64 = 0.5;

impl Decision {
    /// A decision with `value` and nothing estimated.
    fn unestimated(value: f64, gate_open: bool) -> Self {
        Self {
            value,
            tau_s: None,
            miss_radii: None,
            vertical_miss_radii: None,
            pass_side: None,
            arrival_extent_m: None,
            tau_rate: None,
            gate_open,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f64,
    theta_rad: f64,
    azimuth_rad: Option<f64>,
    elevation_rad: Option<f64>,
    /// tan of the edge azimuths and elevations `[left, right, bottom, top]`.
    edges_tan: Option<[f64; 4]>,
}

/// A causal filter from percepts to decision values (see the module docs).
#[derive(Debug, Clone)]
pub struct Strategy {
    params: StrategyParams,
    window: VecDeque<Sample>,
    /// The last `persistence_window_frames` values before the persistence step.
    recent: VecDeque<f64>,
    /// Scratch space of the persistence step (the window's values that are numbers).
    ranked: Vec<f64>,
}

/// Least-squares fit of `y` against `x`: `(slope, mean x, mean y)` (None with fewer than
/// [`MIN_SAMPLES`] points or no spread).
fn slope(points: impl Iterator<Item = (f64, f64)>) -> Option<(f64, f64, f64)> {
    let pts: Vec<(f64, f64)> = points.collect();
    if pts.len() < MIN_SAMPLES {
        return None;
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| (sxy / sxx, mx, my))
}

/// A least-squares parabola `y = a + b·u + c·u²` in `u = x − mean_x`.
#[derive(Debug, Clone, Copy)]
struct Parabola {
    mean_x: f64,
    a: f64,
    b: f64,
    c: f64,
}

impl Parabola {
    fn at(&self, x: f64) -> f64 {
        let u = x - self.mean_x;
        self.a + self.b * u + self.c * u * u
    }
}

/// Least-squares fit of a parabola (None with fewer than [`MIN_SAMPLES`] + 1 points or a
/// degenerate spread).
fn parabola(points: impl Iterator<Item = (f64, f64)>) -> Option<Parabola> {
    let pts: Vec<(f64, f64)> = points.collect();
    if pts.len() < MIN_SAMPLES + 1 {
        return None;
    }
    let n = pts.len() as f64;
    let mean_x = pts.iter().map(|p| p.0).sum::<f64>() / n;
    // moments of the centred x
    let (mut s2, mut s3, mut s4, mut sy, mut sxy, mut sx2y) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y) in &pts {
        let u = x - mean_x;
        s2 += u * u;
        s3 += u * u * u;
        s4 += u * u * u * u;
        sy += y;
        sxy += u * y;
        sx2y += u * u * y;
    }
    // normal equations with Σu = 0: [n 0 s2; 0 s2 s3; s2 s3 s4]·[a b c] = [sy sxy sx2y] (Cramer)
    let det = n * (s2 * s4 - s3 * s3) - s2 * s2 * s2;
    if det.abs() < 1e-300 {
        return None;
    }
    Some(Parabola {
        mean_x,
        a: (sy * (s2 * s4 - s3 * s3) + s2 * (sxy * s3 - s2 * sx2y)) / det,
        b: (n * (sxy * s4 - s3 * sx2y) + sy * s3 * s2 - s2 * s2 * sxy) / det,
        c: (n * (s2 * sx2y - s3 * sxy) - sy * s2 * s2) / det,
    })
}

/// `κ(θ)`: the time to contact of the surface of a sphere seen at angular size θ (radians) is
/// `κ(θ) · θ/θ̇` (`sin(θ/2) = R/d` gives `d/v = 2·tan(θ/2)/θ̇` and the surface is `R` nearer:
/// `κ = 2·tan(θ/2)·(1 − sin(θ/2))/θ`; κ → 1 for small θ).
pub fn surface_factor(theta_rad: f64) -> f64 {
    let half = (theta_rad / 2.0).clamp(1e-9, 1.5);
    2.0 * half.tan() * (1.0 - half.sin()) / theta_rad.max(2e-9)
}

impl Strategy {
    /// A fresh strategy.
    pub fn new(params: StrategyParams) -> Self {
        Self {
            params,
            window: VecDeque::new(),
            recent: VecDeque::with_capacity(params.persistence_window_frames.clamp(1, 64)),
            ranked: Vec::new(),
        }
    }

    /// The parameters.
    pub fn params(&self) -> &StrategyParams {
        &self.params
    }

    /// Forget the history (new episode).
    pub fn reset(&mut self) {
        self.window.clear();
        self.recent.clear();
    }

    /// Whether this strategy keeps state (τ trigger, course gate or persistence): only then does
    /// `update` differ from the raw value.
    pub fn is_stateful(&self) -> bool {
        self.params.tau || self.params.course != Course::Off || self.persistence_window() > 1
    }

    /// The persistence window M (at least K).
    fn persistence_window(&self) -> usize {
        self.params
            .persistence_window_frames
            .max(self.params.persistence_frames)
    }

    /// Take this frame's percept at time `t_s` and return the decision quantities.
    pub fn update(&mut self, t_s: f64, percept: Percept, ego: Ego) -> Decision {
        let p = self.params;
        if !self.is_stateful() {
            return Decision::unestimated(percept.value, true);
        }
        if !t_s.is_finite() {
            return Decision::unestimated(if p.angle_valued { 0.0 } else { f64::NAN }, false);
        }
        let theta_rad = if p.tau || p.angle_valued {
            percept.value.to_radians()
        } else {
            f64::NAN
        };
        // a θ̂ that jumps by more than JUMP_RATIO in one frame is another percept, not growth
        // (module docs, "Jumps"): the window starts afresh
        if self.window.back().is_some_and(|last| {
            last.theta_rad > 0.0 && theta_rad > 0.0 && (theta_rad / last.theta_rad).ln().abs() > JUMP_RATIO.ln()
        }) {
            self.window.clear();
        }
        let keep_s = p.window_s.max(p.course_window_s);
        while self.window.front().is_some_and(|s| s.t < t_s - keep_s - 1e-9) {
            self.window.pop_front();
        }
        let finite = |v: Option<f64>| v.filter(|x| x.is_finite()).map(f64::to_radians);
        // directions in the camera mount's frame: the camera's own rotation removed
        let (yaw, pitch) = (ego.camera_yaw_rad, ego.camera_pitch_rad);
        self.window.push_back(Sample {
            t: t_s,
            theta_rad,
            azimuth_rad: finite(percept.azimuth_deg).map(|a| a - yaw),
            elevation_rad: finite(percept.elevation_deg).map(|e| e + pitch),
            edges_tan: percept
                .extent
                .map(|e| {
                    let [l, r] = e.azimuth_deg.map(|a| a.to_radians() - yaw);
                    let [b, u] = e.elevation_deg.map(|a| a.to_radians() + pitch);
                    [l, r, b, u].map(|a| a.clamp(-1.55, 1.55).tan())
                })
                .filter(|e| e.iter().all(|v| v.is_finite())),
        });
        let valid_theta = |s: &&Sample| s.theta_rad.is_finite() && s.theta_rad > 0.0;
        let tau_from = t_s - p.window_s - 1e-9;
        let min_theta_rad = p.min_angular_size_deg.to_radians();
        let course_from = t_s - p.course_window_s - 1e-9;
        // τ̂ from the slope of ln θ, compensated for the window's lag.
        let tau_s = slope(
            self.window
                .iter()
                .filter(|s| s.t >= tau_from)
                .filter(valid_theta)
                .filter(|s| s.theta_rad >= min_theta_rad)
                .map(|s| (s.t, s.theta_rad.ln())),
        )
        .filter(|&(b, _, _)| b > 0.0)
        .map(|(b, t_mean, ln_theta_mean)| surface_factor(ln_theta_mean.exp()) / b - (t_s - t_mean));
        // μ from the bearing rates against the expansion rate.
        let course = || self.window.iter().filter(|s| s.t >= course_from);
        let theta_fit = slope(course().filter(valid_theta).map(|s| (s.t, s.theta_rad))).filter(|v| v.0 > 0.0);
        let theta_dot = theta_fit.map(|v| v.0);
        let az_dot = slope(course().filter_map(|s| s.azimuth_rad.map(|a| (s.t, a)))).map(|v| v.0 - ego.yaw_rate_rps);
        let miss_radii = theta_dot.zip(az_dot).map(|(td, az)| 2.0 * az / td);
        // the elevation in object radii, sin(e)/sin(θ/2), is linear in t on a straight course at
        // constant speed and quadratic under gravity
        let has_elevation = course().any(|s| s.elevation_rad.is_some());
        let height_radii = parabola(
            course()
                .filter(valid_theta)
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
        let speed = p.closing_speed_mps.max(ego.forward_mps);
        // the edges' predicted offsets when the object reaches the camera (m): at the window's
        // mean time, x = d·τ·d(tan a)/dt with the distance d = v̂·τ and τ = θ/θ̇ the optical time
        // to contact of the centre
        // τ from the growth of the object's vertical extent (tan top − tan bottom ∝ height/depth of
        // its nearest face: the time to contact of that face, whatever the object's shape), else θ/θ̇
        let extent_tau = slope(course().filter_map(|s| s.edges_tan.map(|e| (s.t, e[3] - e[2]))))
            .filter(|&(rate, _, mean)| rate > 0.0 && mean > 0.0)
            .map(|(rate, _, mean)| mean / rate);
        let predicted_edges = extent_tau
            .or(theta_fit.map(|(td, _, theta_mean)| theta_mean / td))
            .and_then(|tau_c| {
                let rate =
                    |i: usize| slope(course().filter_map(|s| s.edges_tan.map(|e| (s.t, e[i])))).map(|(b, _, m)| (b, m));
                let edges = [rate(0)?, rate(1)?, rate(2)?, rate(3)?];
                // an object that stands in the world, seen from a robot driving straight, has
                // d(tan a)/dt = tan a / τ at every edge: then it closes at the robot's own speed
                let standing = ego.forward_mps > 0.0
                    && ego.yaw_rate_rps == 0.0
                    && edges
                        .iter()
                        .all(|&(rate, mean)| (rate * tau_c - mean).abs() <= STANDING_TOLERANCE * mean.abs().max(0.05));
                let closing = if standing { ego.forward_mps } else { speed };
                let scale = closing * tau_c.powi(2);
                let lateral = |(rate, mean): (f64, f64)| scale * (rate - ego.yaw_rate_rps * (1.0 + mean * mean));
                Some((
                    [lateral(edges[0]), lateral(edges[1])],
                    [scale * edges[2].0, scale * edges[3].0],
                ))
            });
        let pass_side = match predicted_edges {
            Some(([l, r], _)) => {
                let (centre, half) = ((l + r) / 2.0, (r - l).abs() / 2.0);
                (centre.abs() >= PASS_SIDE_MIN_RADII * half).then_some(centre.signum() as f32)
            }
            None => miss_radii
                .filter(|mu| mu.abs() >= PASS_SIDE_MIN_RADII)
                .map(|mu| mu.signum() as f32),
        };
        // dτ/dt from ln θ = a + b·t + c·t²: τ = 1/(b + 2ct), so dτ/dt = −2c/b² at the window's mean
        let tau_rate = slope(course().filter(valid_theta).map(|s| (s.t, s.theta_rad.ln())))
            .filter(|v| v.0 > 0.0)
            .zip(parabola(course().filter(valid_theta).map(|s| (s.t, s.theta_rad.ln()))))
            .map(|((b, _, _), ln_theta)| -2.0 * ln_theta.c / (b * b));
        let overlaps = |[a, b]: [f64; 2], low: f64, high: f64| a.min(b) <= high && a.max(b) >= low;
        let gate_open = match (p.course, tau_s) {
            (Course::Off, _) => true,
            (Course::Image, None) => false,
            // elevations seen, but too few to tell a straight course from a lob yet: wait
            (Course::Image, Some(_)) if has_elevation && straight.is_none() => false,
            // braking to a stop before it arrives (a lob's distance shrinks unevenly: not judged)
            (Course::Image, Some(_)) if tau_rate.is_some_and(|r| r >= STOPPING_TAU_RATE) && straight != Some(false) => {
                false
            }
            (Course::Image, Some(tau)) => {
                let radius = (theta_rad / 2.0).min(std::f64::consts::FRAC_PI_2).sin() * tau.max(0.0) * speed;
                let within_body_height = |centre_radii: f64| {
                    (centre_radii - 1.0) * radius <= p.body_above_camera_m
                        && (centre_radii + 1.0) * radius >= -p.body_below_camera_m
                };
                // a curved course (a lob) is extrapolated along its parabola to the time its
                // distance ahead, in object radii cos(e)·cos(a)/sin(θ/2), reaches zero (a lob's
                // distance shrinks unevenly, so τ̂ overestimates its arrival time), or to τ̂ when
                // that is sooner (a course that bends because the object was just launched)
                let curved_course_ok = match (straight, height_radii) {
                    (Some(false), Some(h)) => {
                        let ahead = slope(course().filter(valid_theta).filter_map(|s| {
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
                    && match (predicted_edges, miss_radii) {
                        (Some((lateral, vertical)), _) => {
                            overlaps(lateral, -p.body_half_width_m, p.body_half_width_m)
                                && (straight != Some(true)
                                    || overlaps(vertical, -p.body_below_camera_m, p.body_above_camera_m))
                        }
                        (None, Some(mu)) => {
                            (mu.abs() - 1.0) * radius <= p.body_half_width_m
                                && vertical_miss_radii.is_none_or(within_body_height)
                        }
                        (None, None) => false,
                    }
            }
        };
        let idle = if p.angle_valued || p.tau { 0.0 } else { f64::NAN };
        let value = if p.tau {
            match tau_s {
                Some(tau) if gate_open && percept.value >= p.min_angular_size_deg => 1.0 / tau.max(1e-3),
                _ => 0.0,
            }
        } else if gate_open {
            percept.value
        } else {
            idle
        };
        let value = self.persist(value, idle);
        Decision {
            value,
            tau_s,
            miss_radii,
            vertical_miss_radii,
            pass_side,
            arrival_extent_m: predicted_edges.map(|([l, r], [b, t])| [l, r, b, t]),
            tau_rate,
            gate_open,
        }
    }

    /// The persistence step (module docs, "Persistence"): the K-th largest of the last M values
    /// that are numbers (`idle` while fewer than K are); with M = K the smallest of the last K
    /// values (`idle` while fewer have been seen, or when one is NaN).
    fn persist(&mut self, value: f64, idle: f64) -> f64 {
        let (k, m) = (self.params.persistence_frames.max(1), self.persistence_window());
        if m <= 1 {
            return value;
        }
        if self.recent.len() == m {
            self.recent.pop_front();
        }
        self.recent.push_back(value);
        self.ranked.clear();
        self.ranked.extend(self.recent.iter().copied().filter(|v| !v.is_nan()));
        if self.ranked.len() < k {
            return idle;
        }
        // the K-th largest: index K − 1 in descending order
        let (_, kth, _) = self.ranked.select_nth_unstable_by(k - 1, |a, b| b.total_cmp(a));
        *kth
    }
}
