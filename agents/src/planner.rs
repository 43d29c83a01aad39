//! The manoeuvre planner: which escape manoeuvre clears **every** perceived object.
//!
//! With `manoeuvre = "plan"` (the default) the escape controller does not run one fixed
//! manoeuvre about the object that raised the alarm. At the alarm, and at every frame while an
//! alarm lasts, it predicts where each perceived object will be and where the robot will be under
//! each candidate manoeuvre, and takes the candidate with the largest predicted clearance.
//!
//! # What it reads (percepts only)
//! Per object, the course that the decider's collision-course gate predicts from the object's
//! image over its window ([`CourseForecast`]): its time to contact τ̂, the lateral offsets of its
//! edges now and when it reaches the camera's depth, the vertical ones at arrival, all in metres
//! through the closing speed the gate assumes (the image has no scale). Per robot, what it knows of
//! itself ([`RobotFacts`]): its drive, its body's extent about the camera, its acceleration limits,
//! and the commands it gave. Nothing reads the world's state.
//!
//! # Prediction
//! Positions are kept in the robot's **odometry frame** (its start pose; x forward, y left),
//! integrated from its own commands through the drive's acceleration limits ([`Odometry`]). A
//! forecast holds relative to the motion the robot had over the gate's window (its pose and
//! velocity then come from the robot's recent odometry, [`OdometryTrail`]), so it replaces a
//! remembered one only while that motion was steady (no command change during the window): during
//! a manoeuvre the object's image moves with the robot (a standing object no longer reads as
//! standing), and the last steady forecast is extrapolated instead — unless the object is new or
//! its course has evidently changed (it now arrives in less than half the time the remembered
//! forecast says: a ball thrown while the robot dodged another). An object moves at a constant
//! velocity: its nearest face closes at the forecast's closing speed, its
//! edges move laterally from where they are to where they arrive. An object whose vertical course
//! is straight and passes above or below the body is no obstacle. A forecast is forgotten
//! [`FORECAST_MEMORY_S`] after it was last refreshed, or once the object has passed; an object
//! standing in the world stays where it was seen and is remembered until the robot has driven by
//! it (a robot standing before it sees no expansion and no new forecast).
//!
//! # Scale
//! The image gives no scale: a forecast's metres hold for the closing speed the gate assumed. An
//! object the gate recognised as standing in the world closes at the robot's own speed and is
//! exact; every other object is checked under five hypotheses of its closing speed: the assumed one
//! times each of [`SCALE_HYPOTHESES`] (0.5, 1, 1.6), the robot's own speed (an object standing
//! in the world that the gate did not recognise as one, e.g. a pole whose foot is hidden), and the
//! scale that puts the object's bottom edge on the ground (the robot knows its camera's height: an
//! object resting on the ground, a vehicle or a cart, is at the distance where its bottom meets the
//! ground; bounded to 0.25–3.2 times the assumed scale; for a ball in flight it is one wrong guess
//! among five).
//!
//! # Footprint
//! An object's footprint on the ground is a rectangle along its direction of motion over the
//! ground (its velocity relative to the robot, from the forecast, plus the robot's own): as broad as
//! it is high (at most as broad as its image is wide), and as long as makes its extent across the
//! line of sight the image's width, at most [`MAX_OBJECT_LENGTH_M`] where the image leaves that
//! open (an object coming head-on shows its breadth only). A car crossing obliquely is so a long,
//! narrow box at its angle, not a square as deep as its image is wide; a ball, or an object whose
//! motion is unknown, stays a square as deep as it is wide. The gap between two rectangles is the
//! largest separation along their four axes (separating axes).
//!
//! # Candidates and choice
//! Each candidate is a manoeuvre held for the controller's `duration_s`: a sidestep (holonomic
//! base) or an arc (differential drive) to either side, then the cruise command; a stop, or
//! reversing, then standing until cruising on is clear ([`Planner::keeps_waiting`]: the controller
//! stands while cruising on would run into an object standing in the world, and while waiting
//! scores better than cruising on, at most [`MAX_WAIT_S`], for moving ones; a robot that resumed
//! its cruise at once would drive into an object crossing its path obliquely). A rollout that
//! waited no longer checks objects standing in the world once it drives on: the robot would stand
//! for as long as one is in its way.
//! Each is rolled out over [`PLAN_STEP_S`] steps with the drive's acceleration limits, the lateral
//! excursion held within `max_dodge_offset_m` as the controller holds it (the lane or corridor the
//! robot knows it is in: the body, braking, comes to rest at it; [`crate::DodgeOffset`]), to a
//! horizon after the last object has passed (at most [`MAX_HORIZON_S`]). Its **clearance** under a
//! hypothesis is the smallest gap over the horizon between the body's footprint and any object's
//! (below; negative: they overlap); its **score** is the mean of
//! its clearances capped at `clearance_margin_m`, weighted by [`HYPOTHESIS_WEIGHTS`] (the assumed
//! speed twice). Clearances above the margin count as safe and equal, so among the candidates with
//! the best score the controller's preference decides — the sidestep away from the alarming object
//! (the fixed rule's choice), the other side, stopping, reversing. While a manoeuvre runs it is
//! replaced only when another candidate's score is larger by [`SWITCH_MARGIN_M`].
//!
//! Cost per decision (criterion, `cargo bench -p loomlab-agents --bench strategy`, 2-core machine;
//! docs/benchmarks.md): 0.41 ms with one object, 1.2 ms with three, 3.3 ms with eight; it runs only
//! at an alarm, while one lasts during a manoeuvre and while the robot waits.
//!
//! The planner keeps at most [`MAX_PLANNED_OBJECTS`] forecasts in buffers reserved at
//! construction: a decision allocates nothing.

use crate::decision::{BodyExtent, CourseForecast};
use crate::escape::{DodgeSide, Manoeuvre};
use crate::{DodgeOffset, EscapeConfig, RobotFacts, VelocityCommand};

/// Most objects the planner remembers at once (the most urgent are kept).
pub const MAX_PLANNED_OBJECTS: usize = 16;
/// Time step of the rollouts (s).
pub const PLAN_STEP_S: f64 = 1.0 / 120.0;
/// Longest rollout (s).
pub const MAX_HORIZON_S: f64 = 3.0;
/// Longest wait after a stop or a reversal (s).
pub const MAX_WAIT_S: f64 = 3.0;
/// How long a forecast that is no longer refreshed is extrapolated (s).
pub const FORECAST_MEMORY_S: f64 = 3.0;
/// The closing speeds, as factors of the forecast's, under which a candidate must clear an object
/// that does not stand in the world: the image gives no scale, so the forecast's metres hold for
/// the assumed closing speed only (module docs, "Prediction").
pub const SCALE_HYPOTHESES: [f64; 3] = [0.5, 1.0, 1.6];
/// How many closing-speed hypotheses a candidate is checked under: [`SCALE_HYPOTHESES`], the
/// robot's own speed and the object resting on the ground (`Remembered::scales`).
pub const HYPOTHESES: usize = 5;
/// The weights of the hypotheses in a candidate's score (the assumed closing speed and the ground
/// count twice).
pub const HYPOTHESIS_WEIGHTS: [f64; HYPOTHESES] = [1.0, 2.0, 1.0, 1.0, 2.0];
/// How much larger (m) another candidate's capped clearance must be to replace the running one.
pub const SWITCH_MARGIN_M: f64 = 0.05;

/// A candidate manoeuvre: what to do and, for a sidestep or an arc, to which side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Candidate {
    /// The manoeuvre (never [`Manoeuvre::Plan`]).
    pub manoeuvre: Manoeuvre,
    /// Its side (lateral dodges; ignored by the others).
    pub side: DodgeSide,
}

impl Candidate {
    /// Every candidate of the set, sidesteps first.
    pub const ALL: [Candidate; 4] = [
        Candidate {
            manoeuvre: Manoeuvre::DodgeLateral,
            side: DodgeSide::Left,
        },
        Candidate {
            manoeuvre: Manoeuvre::DodgeLateral,
            side: DodgeSide::Right,
        },
        Candidate {
            manoeuvre: Manoeuvre::Stop,
            side: DodgeSide::Left,
        },
        Candidate {
            manoeuvre: Manoeuvre::Reverse,
            side: DodgeSide::Left,
        },
    ];

    /// A lateral dodge to `side`.
    pub fn dodge(side: DodgeSide) -> Self {
        Self {
            manoeuvre: Manoeuvre::DodgeLateral,
            side,
        }
    }

    /// Whether the robot waits after this manoeuvre, standing, until cruising on is clear
    /// (stopping and reversing; module docs, "Candidates and choice"). A dodge moves the robot out
    /// of the way; cruising on after it is part of the plan.
    pub fn holds(&self) -> bool {
        matches!(self.manoeuvre, Manoeuvre::Stop | Manoeuvre::Reverse)
    }

    /// Whether two candidates do the same (the side matters for lateral dodges only).
    pub fn same_as(&self, other: &Candidate) -> bool {
        self.manoeuvre == other.manoeuvre && (self.manoeuvre != Manoeuvre::DodgeLateral || self.side == other.side)
    }
}

/// A robot pose and velocity in the odometry frame (x forward at the start, y left).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Odometry {
    /// Position (m).
    pub position_m: [f64; 2],
    /// Heading (rad, counter-clockwise).
    pub heading_rad: f64,
    /// Body velocity: forward (m/s), lateral (m/s, + left), yaw rate (rad/s).
    pub velocity: [f64; 3],
}

impl Odometry {
    /// Advance by `dt_s` towards the velocity `command` within the acceleration limits of `facts`.
    pub fn advance(&mut self, command: &VelocityCommand, dt_s: f64, facts: &RobotFacts) {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return;
        }
        let target = [command.forward_mps, command.lateral_mps, command.yaw_rate_rps];
        let limits = [facts.accel_mps2, facts.accel_mps2, facts.yaw_accel_rps2];
        for ((v, t), a) in self.velocity.iter_mut().zip(target).zip(limits) {
            let step = a * dt_s;
            *v = if (t - *v).abs() <= step {
                t
            } else {
                *v + step * (t - *v).signum()
            };
        }
        let (s, c) = self.heading_rad.sin_cos();
        let [f, l, w] = self.velocity;
        self.position_m[0] += (f * c - l * s) * dt_s;
        self.position_m[1] += (f * s + l * c) * dt_s;
        self.heading_rad += w * dt_s;
    }

    /// This pose `back_s` earlier along its current velocity.
    fn back(&self, back_s: f64) -> Odometry {
        let mut origin = *self;
        let [vf, vl, w] = self.velocity;
        origin.heading_rad -= w * back_s;
        let (s, c) = origin.heading_rad.sin_cos();
        origin.position_m[0] -= (vf * c - vl * s) * back_s;
        origin.position_m[1] -= (vf * s + vl * c) * back_s;
        origin
    }

    /// A point given in this pose's body frame (forward, left), in the odometry frame.
    fn point_in_odometry(&self, forward: f64, left: f64) -> [f64; 2] {
        let (s, c) = self.heading_rad.sin_cos();
        [
            self.position_m[0] + forward * c - left * s,
            self.position_m[1] + forward * s + left * c,
        ]
    }

    /// A point of the odometry frame in this pose's body frame (forward, left).
    fn point_in_body(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.heading_rad.sin_cos();
        let (dx, dy) = (p[0] - self.position_m[0], p[1] - self.position_m[1]);
        [dx * c + dy * s, -dx * s + dy * c]
    }
}

/// The robot's odometry over its last [`TRAIL_LENGTH`] steps, and since when its motion has been
/// steady: what the planner needs to place a forecast made over a window in the past (a fixed
/// buffer: pushing allocates nothing).
#[derive(Debug, Clone)]
pub struct OdometryTrail {
    samples: std::collections::VecDeque<(f64, Odometry)>,
    /// When the velocity last changed between two steps (s).
    steady_since_s: f64,
}

/// How many steps an [`OdometryTrail`] keeps (more than a gate's window at 120 Hz).
pub const TRAIL_LENGTH: usize = 128;

impl Default for OdometryTrail {
    fn default() -> Self {
        Self {
            samples: std::collections::VecDeque::with_capacity(TRAIL_LENGTH),
            steady_since_s: f64::NEG_INFINITY,
        }
    }
}

impl OdometryTrail {
    /// Forget everything (new episode).
    pub fn clear(&mut self) {
        self.samples.clear();
        self.steady_since_s = f64::NEG_INFINITY;
    }

    /// Record the odometry `odometry` at `t_s` (after the previous record's time).
    pub fn push(&mut self, t_s: f64, odometry: Odometry) {
        if let Some((_, last)) = self.samples.back()
            && last.velocity != odometry.velocity
        {
            self.steady_since_s = t_s;
        }
        if self.samples.len() == TRAIL_LENGTH {
            self.samples.pop_front();
        }
        self.samples.push_back((t_s, odometry));
    }

    /// The latest odometry (the start pose before any record).
    pub fn now(&self) -> Odometry {
        self.samples.back().map(|s| s.1).unwrap_or_default()
    }

    /// The time of the latest record (s; `None` before any).
    pub fn latest_s(&self) -> Option<f64> {
        self.samples.back().map(|s| s.0)
    }

    /// The odometry at `t_s`: the first record at or after it, taken back along its velocity (the
    /// earliest one taken back further when `t_s` is older than the trail; the latest when `t_s`
    /// is after it).
    pub fn at(&self, t_s: f64) -> Odometry {
        match self.samples.iter().find(|(t, _)| *t >= t_s) {
            Some((t, o)) => o.back(t - t_s),
            None => self.now(),
        }
    }
}

/// The fraction of its remembered time to contact below which an object's new forecast replaces
/// the remembered one even while the robot's motion changes: its course has changed (thrown).
pub const COURSE_CHANGE_TAU_FRACTION: f64 = 0.5;

/// One remembered object: its last steady forecast and the robot's pose it was made from.
#[derive(Debug, Clone, Copy)]
struct Remembered {
    id: usize,
    forecast: CourseForecast,
    /// The robot's pose at the forecast's time, and its velocity then (the motion the forecast is
    /// relative to).
    origin: Odometry,
    refreshed_s: f64,
    /// Whether its image's left and right edges lay at the image border (cut off by it).
    clipped: [bool; 2],
    /// The factor on the forecast's metres that puts the object's bottom on the ground (an object
    /// resting on it: a vehicle, a cart), when its bottom is below the camera.
    ground_scale: Option<f64>,
}

impl Remembered {
    /// What the object's footprint under closing-speed factor `scale` keeps over time: its
    /// velocity over the ground and so its direction and height (module docs, "Footprint").
    fn motion(&self, scale: f64) -> Motion {
        let f = &self.forecast;
        // the object's velocity over the ground in the origin's axes: its image motion relative
        // to the robot (that of its edges not cut off by the image border) plus the robot's own
        let [vf, vl, _] = self.origin.velocity;
        let edge_rate = |i: usize| -scale * (f.arrival_lateral_m[i] - f.lateral_m[i]) / f.tau_s;
        let lateral_rate = match self.clipped {
            [true, false] => edge_rate(1),
            [false, true] => edge_rate(0),
            _ => (edge_rate(0) + edge_rate(1)) / 2.0,
        };
        let ground = [vf - scale * f.closing_mps, vl + lateral_rate];
        let heading = ground[1].atan2(ground[0]);
        let (sin, cos) = heading.sin_cos();
        Motion {
            scale,
            heading,
            sin_cos: [sin.abs(), cos.abs()],
            moving: ground[0].hypot(ground[1]) >= STILL_MPS,
            height: scale * (f.arrival_vertical_m[1] - f.arrival_vertical_m[0]).abs(),
        }
    }

    /// The object's footprint at time `t_s` under `motion` (its [`Self::motion`] at a scale).
    fn footprint(&self, t_s: f64, motion: &Motion) -> Footprint {
        let (f, scale) = (&self.forecast, motion.scale);
        let s = t_s - f.t_s;
        let progress = s / f.tau_s;
        let edge = |i: usize| scale * (f.lateral_m[i] + (f.arrival_lateral_m[i] - f.lateral_m[i]) * progress);
        // the odometry y (positive left) of the image's left and right edges (image lateral is
        // positive right); an edge cut off by the image border stood still in the image, so it
        // moves with the other one, the width it had at the forecast's time apart
        let (mut y_left, mut y_right) = (-edge(0).min(edge(1)), -edge(0).max(edge(1)));
        let seen_width = scale * (f.lateral_m[1] - f.lateral_m[0]).abs();
        match self.clipped {
            [true, false] => y_left = y_right + seen_width,
            [false, true] => y_right = y_left - seen_width,
            _ => {}
        }
        // cut off by the border: as wide as the longest object at its direction of motion, the
        // unseen part beyond the border
        if self.clipped.contains(&true) {
            let width = (y_left - y_right).abs().max(0.04);
            let [sin, cos] = motion.sin_cos;
            let hidden = (MAX_OBJECT_LENGTH_M * sin + motion.height.min(width) * cos - width).max(0.0);
            let share = hidden / self.clipped.iter().filter(|&&c| c).count() as f64;
            if self.clipped[0] {
                y_left += share;
            }
            if self.clipped[1] {
                y_right -= share;
            }
        }
        let width = (y_left - y_right).abs().max(0.04);
        let (heading, [half_length, half_breadth], [sin, cos]) = match oriented_extent(width, motion) {
            Some(half) => (motion.heading, half, motion.sin_cos),
            None => (0.0, [width / 2.0; 2], [0.0, 1.0]),
        };
        let half_forward = half_length * cos + half_breadth * sin;
        let nearest = scale * f.closing_mps * (f.tau_s - s);
        let [vf, vl, _] = self.origin.velocity;
        let centre = self
            .origin
            .point_in_odometry(nearest + half_forward + vf * s, (y_left + y_right) / 2.0 + vl * s);
        Footprint {
            centre,
            heading_rad: self.origin.heading_rad + heading,
            half_extent: [half_length, half_breadth],
        }
    }

    /// The factors on the forecast's metres under which the object is checked: 1 for an object
    /// standing in the world or one whose closing speed is measured (its size known from when it
    /// stood); else [`SCALE_HYPOTHESES`], the factor that makes it close at the
    /// robot's own speed (an object standing in the world that the gate did not recognise as one)
    /// and the one that puts its bottom on the ground.
    fn scales(&self) -> [f64; HYPOTHESES] {
        let f = &self.forecast;
        if f.standing || f.closing_measured {
            return [1.0; HYPOTHESES];
        }
        let own_speed = (self.origin.velocity[0] / f.closing_mps).clamp(0.0, 1.0);
        let [a, b, c] = SCALE_HYPOTHESES;
        [
            a,
            b,
            c,
            if own_speed > 0.0 { own_speed } else { b },
            self.ground_scale.unwrap_or(b),
        ]
    }

    /// Whether the robot at `odometry` has driven by this object standing in the world (its
    /// footprint lies wholly behind the body's rear); always false for a moving object.
    fn passed_by(&self, odometry: &Odometry, facts: &RobotFacts) -> bool {
        if !self.forecast.standing {
            return false;
        }
        let footprint = self.footprint(self.forecast.t_s, &self.motion(1.0));
        let [forward, _] = odometry.point_in_body(footprint.centre);
        let reach = footprint.half_extent[0].max(footprint.half_extent[1]);
        forward + reach < -facts.body.behind_camera_m
    }

    /// Whether the object passes above or below the body (a straight vertical course that misses).
    fn passes_over_or_under(&self, facts: &RobotFacts) -> bool {
        let [b, t] = self.forecast.arrival_vertical_m;
        self.forecast.straight == Some(true)
            && (b.min(t) > facts.body.above_camera_m || b.max(t) < -facts.body.below_camera_m)
    }

    /// When the object will have passed the robot's body under the reference motion (s); never for
    /// an object standing in the world (it passes only as the robot drives by it: [`Self::passed_by`]).
    fn passed_s(&self, facts: &RobotFacts) -> f64 {
        let f = &self.forecast;
        if f.standing {
            return f64::INFINITY;
        }
        let depth = (f.arrival_lateral_m[1] - f.arrival_lateral_m[0]).abs().clamp(0.04, 5.0);
        let slowest = self.scales().into_iter().fold(1.0, f64::min);
        f.t_s + f.tau_s + (facts.body.behind_camera_m + depth) / (slowest * f.closing_mps).max(0.1)
    }
}

/// An object's footprint on the ground: a rectangle in the odometry frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Footprint {
    /// Centre (m).
    centre: [f64; 2],
    /// Direction of its length (rad, counter-clockwise from the odometry frame's x).
    heading_rad: f64,
    /// Half its length and half its breadth (m).
    half_extent: [f64; 2],
}

/// Longest object the planner assumes when the image leaves the length open (m): a head-on
/// object's image shows its breadth, not its length.
pub const MAX_OBJECT_LENGTH_M: f64 = 5.0;

/// How near the image border (in image coordinates, the border at ±1) an edge counts as cut off
/// by it: two pixels at 96².
pub const BORDER_MARGIN: f64 = 0.04;

/// Ground speed (m/s) below which an object's direction of motion is taken as unknown.
const STILL_MPS: f64 = 0.2;

/// What an object's footprint keeps over time under one closing-speed hypothesis
/// ([`Remembered::motion`]): computed once per rollout, not per step.
#[derive(Debug, Clone, Copy, Default)]
struct Motion {
    /// The factor on the forecast's metres.
    scale: f64,
    /// Direction of its motion over the ground from the origin's forward axis (rad).
    heading: f64,
    /// |sin| and |cos| of `heading` (its direction folded about the line of sight: a rectangle is
    /// symmetric).
    sin_cos: [f64; 2],
    /// Whether it moves over the ground (at least [`STILL_MPS`]): else its direction is unknown.
    moving: bool,
    /// Its height (m).
    height: f64,
}

/// An object's direction of motion relative to the origin's forward axis (rad) and its half
/// length and half breadth (m), from its image width `width` (its extent across the line of
/// sight) and its `motion` (velocity over the ground, height): it is taken as long as it moves and
/// as broad as it is high (at most as broad as its image is wide), its length the one whose
/// projection across the line of sight is the image width — bounded by [`MAX_OBJECT_LENGTH_M`]
/// where that projection leaves it open. `None` for a still object, or one whose length comes out
/// shorter than its breadth: a square as deep as its image is wide.
fn oriented_extent(width: f64, motion: &Motion) -> Option<[f64; 2]> {
    let height = motion.height;
    if !(motion.moving && height.is_finite() && height > 0.0) {
        return None;
    }
    let [sin, cos] = motion.sin_cos;
    let breadth = height.min(width);
    let length = if sin > 1e-6 {
        ((width - breadth * cos) / sin).min(MAX_OBJECT_LENGTH_M.max(width))
    } else {
        0.0
    };
    (length >= breadth).then_some([length / 2.0, breadth / 2.0])
}

/// The signed gap (m) between the robot's body at `pose` and the footprint `object`: the largest
/// separation along the four axes of the two rectangles (separating axes; negative: they overlap,
/// by at least that much along every axis).
fn gap(pose: &Odometry, body: &BodyExtent, object: &Footprint) -> f64 {
    let rel = pose.point_in_body(object.centre);
    let body_centre = [(body.ahead_of_camera_m - body.behind_camera_m) / 2.0, 0.0];
    let body_half = [(body.ahead_of_camera_m + body.behind_camera_m) / 2.0, body.half_width_m];
    let d = [rel[0] - body_centre[0], rel[1] - body_centre[1]];
    let (sin, cos) = (object.heading_rad - pose.heading_rad).sin_cos();
    let (u, v) = ([cos, sin], [-sin, cos]);
    let [hl, hb] = object.half_extent;
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    [[1.0, 0.0], [0.0, 1.0], u, v]
        .into_iter()
        .map(|axis| {
            let body_r = body_half[0] * axis[0].abs() + body_half[1] * axis[1].abs();
            let object_r = hl * dot(axis, u).abs() + hb * dot(axis, v).abs();
            dot(d, axis).abs() - body_r - object_r
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// A course of commands to predict: `manoeuvre` for `duration_s`, then standing for `wait_s`,
/// then the cruise command.
#[derive(Debug, Clone, Copy)]
struct Rollout {
    manoeuvre: VelocityCommand,
    duration_s: f64,
    wait_s: f64,
}

/// Which remembered objects a rollout is checked against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Objects {
    /// Every one.
    All,
    /// Those standing in the world.
    Standing,
}

impl Objects {
    fn includes(self, o: &Remembered) -> bool {
        self == Objects::All || o.forecast.standing
    }
}

/// The score of clearances under the hypotheses: their weighted mean, each capped at `margin`.
fn score_of(clearances: &[f64; HYPOTHESES], margin: f64) -> f64 {
    let total: f64 = HYPOTHESIS_WEIGHTS.iter().sum();
    clearances
        .iter()
        .zip(HYPOTHESIS_WEIGHTS)
        .map(|(c, w)| c.min(margin) * w)
        .sum::<f64>()
        / total
}

/// The planner's inputs about the robot for one decision.
#[derive(Debug, Clone, Copy)]
pub struct PlanContext<'a> {
    /// Now (s).
    pub t_s: f64,
    /// The robot's odometry now.
    pub odometry: Odometry,
    /// The command it follows when nothing threatens it.
    pub cruise: VelocityCommand,
    /// Where its dodges have taken it off its cruising path, and how fast it moves off it.
    pub dodge: DodgeOffset,
    /// The controller's configuration: the manoeuvres' speeds and `duration_s`,
    /// `max_dodge_offset_m` and `clearance_margin_m`.
    pub config: &'a EscapeConfig,
}

/// The manoeuvre planner (see the module docs).
#[derive(Debug, Clone)]
pub struct Planner {
    facts: RobotFacts,
    objects: Vec<Remembered>,
}

impl Planner {
    /// A planner for the robot of `facts`.
    pub fn new(facts: RobotFacts) -> Self {
        Self {
            facts,
            objects: Vec::with_capacity(MAX_PLANNED_OBJECTS),
        }
    }

    /// Forget every object (new episode).
    pub fn reset(&mut self) {
        self.objects.clear();
    }

    /// Whether any object is remembered.
    pub fn has_objects(&self) -> bool {
        !self.objects.is_empty()
    }

    /// The forecast remembered for object `id`.
    pub fn forecast(&self, id: usize) -> Option<&CourseForecast> {
        self.objects.iter().find(|o| o.id == id).map(|o| &o.forecast)
    }

    /// Take object `id`'s forecast made at `t_s`, the robot's odometry over the last moments being
    /// `trail` (module docs, "Prediction"): taken when the robot's motion was steady over the
    /// forecast's window (twice its distance from now before now), and otherwise only for an
    /// object not remembered yet or one whose course changed (it now arrives in less than
    /// [`COURSE_CHANGE_TAU_FRACTION`] of the time its remembered forecast says: a ball thrown
    /// while the robot dodged).
    pub fn observe(&mut self, id: usize, forecast: &CourseForecast, t_s: f64, trail: &OdometryTrail) {
        let window_start = 2.0 * forecast.t_s - t_s;
        let usable = forecast.tau_s.is_finite()
            && forecast.tau_s > 0.0
            && forecast.closing_mps.is_finite()
            && forecast.closing_mps > 0.0
            && forecast
                .lateral_m
                .iter()
                .chain(&forecast.arrival_lateral_m)
                .all(|v| v.is_finite());
        let steady = window_start >= trail.steady_since_s - 1e-9;
        if !usable || !(steady || self.course_changed(id, forecast)) {
            return;
        }
        let origin = if steady {
            // back along the steady motion
            trail.now().back(t_s - forecast.t_s)
        } else {
            trail.at(forecast.t_s)
        };
        // image coordinates of the edges at the forecast's time (the border is at ±1)
        let border =
            |lateral: f64| lateral / (forecast.closing_mps * forecast.tau_s) / self.facts.pinhole.tan_half_fov();
        let entry = Remembered {
            id,
            forecast: *forecast,
            origin,
            refreshed_s: t_s,
            clipped: [
                border(forecast.lateral_m[0]) <= -1.0 + BORDER_MARGIN,
                border(forecast.lateral_m[1]) >= 1.0 - BORDER_MARGIN,
            ],
            ground_scale: Some(self.facts.body.below_camera_m / -forecast.arrival_vertical_m[0])
                .filter(|s| s.is_finite() && *s > 0.0)
                .map(|s| s.clamp(SCALE_HYPOTHESES[0] / 2.0, SCALE_HYPOTHESES[2] * 2.0)),
        };
        if let Some(slot) = self.objects.iter_mut().find(|o| o.id == id) {
            *slot = entry;
        } else if self.objects.len() < MAX_PLANNED_OBJECTS {
            self.objects.push(entry);
        } else if let Some(latest) = self
            .objects
            .iter_mut()
            .max_by(|a, b| a.passed_s(&self.facts).total_cmp(&b.passed_s(&self.facts)))
        {
            // full: replace the object that passes last
            *latest = entry;
        }
    }

    /// Whether object `id` is not remembered, or `forecast` says it arrives much sooner than its
    /// remembered forecast does ([`COURSE_CHANGE_TAU_FRACTION`]).
    fn course_changed(&self, id: usize, forecast: &CourseForecast) -> bool {
        self.objects.iter().find(|o| o.id == id).is_none_or(|o| {
            let predicted = o.forecast.tau_s - (forecast.t_s - o.forecast.t_s);
            forecast.tau_s < COURSE_CHANGE_TAU_FRACTION * predicted
        })
    }

    /// Forget forecasts not refreshed for [`FORECAST_MEMORY_S`] and objects that have passed, the
    /// robot being at `odometry`. An object standing in the world stays where it was seen: it is
    /// remembered, refreshed or not (a robot that stands before it sees no expansion), until the
    /// robot has driven by it.
    pub fn forget_old(&mut self, t_s: f64, odometry: &Odometry) {
        let facts = self.facts;
        self.objects.retain(|o| {
            if o.forecast.standing {
                !o.passed_by(odometry, &facts)
            } else {
                t_s - o.refreshed_s <= FORECAST_MEMORY_S && o.passed_s(&facts) >= t_s
            }
        });
    }

    /// The clearance (m) of `candidate` from every remembered object (`f64::INFINITY` with none
    /// in its way).
    pub fn clearance(&self, candidate: Candidate, ctx: &PlanContext<'_>) -> f64 {
        self.clearances(candidate, ctx)
            .into_iter()
            .fold(f64::INFINITY, f64::min)
    }

    /// A candidate's score: the weighted mean over the closing-speed hypotheses of its clearance
    /// capped at `clearance_margin_m` ([`HYPOTHESIS_WEIGHTS`]).
    pub fn score(&self, candidate: Candidate, ctx: &PlanContext<'_>) -> f64 {
        score_of(&self.clearances(candidate, ctx), ctx.config.clearance_margin_m)
    }

    /// Whether a robot standing after a manoeuvre that [holds](Candidate::holds) should keep
    /// standing: cruising on now would run into an object standing in the world (it never passes a
    /// robot that waits: the robot stands for as long as it is in the way), or, `wait_s` more at
    /// most, waiting and then cruising on scores better than cruising on now by more than
    /// [`SWITCH_MARGIN_M`] (objects that move pass a robot that waits).
    pub fn keeps_waiting(&self, ctx: &PlanContext<'_>, wait_s: f64) -> bool {
        if self.objects.is_empty() {
            return false;
        }
        let cruise_on = Rollout {
            manoeuvre: ctx.cruise,
            duration_s: 0.0,
            wait_s: 0.0,
        };
        if self
            .rollout(&cruise_on, ctx, Objects::Standing)
            .iter()
            .any(|&c| c < 0.0)
        {
            return true;
        }
        let wait = Rollout {
            manoeuvre: VelocityCommand::STOP,
            duration_s: 0.0,
            wait_s,
        };
        let margin = ctx.config.clearance_margin_m;
        wait_s > 0.0
            && score_of(&self.rollout(&wait, ctx, Objects::All), margin)
                > score_of(&self.rollout(&cruise_on, ctx, Objects::All), margin) + SWITCH_MARGIN_M
    }

    /// The clearance of `candidate` under each closing-speed hypothesis: its manoeuvre for
    /// `duration_s`, then (if it [holds](Candidate::holds)) standing for [`MAX_WAIT_S`], then
    /// the cruise command.
    fn clearances(&self, candidate: Candidate, ctx: &PlanContext<'_>) -> [f64; HYPOTHESES] {
        let rollout = Rollout {
            manoeuvre: ctx.config.command(candidate, ctx.cruise, self.facts.base),
            duration_s: ctx.config.duration_s,
            wait_s: if candidate.holds() { MAX_WAIT_S } else { 0.0 },
        };
        self.rollout(&rollout, ctx, Objects::All)
    }

    /// The clearance of `rollout` from `objects` under each closing-speed hypothesis. Once a
    /// rollout that waited drives on, objects standing in the world no longer count: the robot
    /// stands for as long as one is in its way ([`Self::keeps_waiting`]).
    fn rollout(&self, rollout: &Rollout, ctx: &PlanContext<'_>, objects: Objects) -> [f64; HYPOTHESES] {
        let facts = &self.facts;
        // a robot that waited meets the moving objects later: the horizon moves with the wait
        let delay = if rollout.wait_s > 0.0 {
            rollout.duration_s + rollout.wait_s
        } else {
            0.0
        };
        let end = self
            .objects
            .iter()
            .filter(|o| !o.passes_over_or_under(facts) && objects.includes(o))
            .map(|o| o.passed_s(facts))
            .fold(f64::NEG_INFINITY, f64::max)
            .min(ctx.t_s + MAX_HORIZON_S)
            + delay;
        let mut clearance = [f64::INFINITY; HYPOTHESES];
        if end <= ctx.t_s {
            return clearance;
        }
        let body = &facts.body;
        // what each object's footprint keeps over time, per hypothesis (on the stack: a decision
        // allocates nothing)
        let mut motions = [[Motion::default(); HYPOTHESES]; MAX_PLANNED_OBJECTS];
        for (o, m) in self.objects.iter().zip(motions.iter_mut()) {
            *m = o.scales().map(|scale| o.motion(scale));
        }
        let mut pose = ctx.odometry;
        let mut dodge = ctx.dodge;
        let mut t = ctx.t_s;
        while t < end {
            let since = t - ctx.t_s;
            let mut command = if since < rollout.duration_s {
                rollout.manoeuvre
            } else if since < rollout.duration_s + rollout.wait_s {
                VelocityCommand::STOP
            } else {
                ctx.cruise
            };
            // held as the controller holds it (`EscapeConfig::command_within_offset`)
            let beyond_cruise = command.lateral_mps - ctx.cruise.lateral_mps;
            if let Some(limit) = ctx.config.max_dodge_offset_m
                && dodge.holds(beyond_cruise, limit, facts.accel_mps2)
            {
                command.lateral_mps = ctx.cruise.lateral_mps;
            }
            dodge.advance(
                command.lateral_mps - ctx.cruise.lateral_mps,
                PLAN_STEP_S,
                facts.accel_mps2,
            );
            pose.advance(&command, PLAN_STEP_S, facts);
            t += PLAN_STEP_S;
            let driving_on = rollout.wait_s > 0.0 && since >= rollout.duration_s + rollout.wait_s;
            for (o, motions) in self.objects.iter().zip(&motions) {
                if o.passes_over_or_under(facts) || !objects.includes(o) || (driving_on && o.forecast.standing) {
                    continue;
                }
                for (motion, c) in motions.iter().zip(clearance.iter_mut()) {
                    *c = c.min(gap(&pose, body, &o.footprint(t, motion)));
                }
            }
        }
        clearance
    }

    /// The candidate to run: the one with the largest clearance capped at
    /// `ctx.clearance_margin_m`, ties going to the earliest of `preference` (see the module docs).
    /// `running`: the candidate being run, kept unless another is better by [`SWITCH_MARGIN_M`].
    /// `None` when no object is remembered (the caller's fixed rule decides).
    pub fn choose(
        &self,
        ctx: &PlanContext<'_>,
        preference: &[Candidate],
        running: Option<Candidate>,
    ) -> Option<Candidate> {
        if self.objects.is_empty() {
            return None;
        }
        let mut best: Option<(Candidate, f64)> = None;
        // the running candidate's score, taken from the scan when it is among the preferences
        let mut running_score = None;
        for &c in preference {
            let score = self.score(c, ctx);
            if running.is_some_and(|r| r.same_as(&c)) {
                running_score = Some(score);
            }
            if best.is_none_or(|(_, b)| score > b + 1e-9) {
                best = Some((c, score));
            }
        }
        let (best, score) = best?;
        match running {
            Some(r) if running_score.unwrap_or_else(|| self.score(r, ctx)) + SWITCH_MARGIN_M >= score => Some(r),
            _ => Some(best),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use loomlab_detector::Pinhole;

    /// The corners of a rectangle (centre, heading, half extents) in the frame it is given in.
    fn corners(centre: [f64; 2], heading: f64, [hl, hb]: [f64; 2]) -> [[f64; 2]; 4] {
        let (s, c) = heading.sin_cos();
        [[1.0, 1.0], [1.0, -1.0], [-1.0, -1.0], [-1.0, 1.0]]
            .map(|[a, b]| [centre[0] + a * hl * c - b * hb * s, centre[1] + a * hl * s + b * hb * c])
    }

    /// Whether point `p` lies in the rectangle.
    fn inside(p: [f64; 2], centre: [f64; 2], heading: f64, [hl, hb]: [f64; 2]) -> bool {
        let (s, c) = heading.sin_cos();
        let d = [p[0] - centre[0], p[1] - centre[1]];
        (d[0] * c + d[1] * s).abs() <= hl + 1e-9 && (-d[0] * s + d[1] * c).abs() <= hb + 1e-9
    }

    /// The distance between two segments (0 when they cross).
    fn segment_distance(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> f64 {
        let cross =
            |o: [f64; 2], p: [f64; 2], q: [f64; 2]| (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
        let (d1, d2) = (cross(b[0], b[1], a[0]), cross(b[0], b[1], a[1]));
        let (d3, d4) = (cross(a[0], a[1], b[0]), cross(a[0], a[1], b[1]));
        if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
            return 0.0;
        }
        let point_segment = |p: [f64; 2], s: [[f64; 2]; 2]| {
            let v = [s[1][0] - s[0][0], s[1][1] - s[0][1]];
            let w = [p[0] - s[0][0], p[1] - s[0][1]];
            let t = ((w[0] * v[0] + w[1] * v[1]) / (v[0] * v[0] + v[1] * v[1])).clamp(0.0, 1.0);
            (w[0] - t * v[0]).hypot(w[1] - t * v[1])
        };
        point_segment(a[0], b)
            .min(point_segment(a[1], b))
            .min(point_segment(b[0], a))
            .min(point_segment(b[1], a))
    }

    #[test]
    fn a_trail_places_a_past_time_by_the_record_after_it_and_knows_when_motion_changed() {
        let facts = RobotFacts::default();
        let cruise = VelocityCommand {
            forward_mps: 1.0,
            ..VelocityCommand::STOP
        };
        let sidestep = VelocityCommand {
            lateral_mps: 1.5,
            ..cruise
        };
        let mut odometry = Odometry {
            velocity: [1.0, 0.0, 0.0],
            ..Odometry::default()
        };
        let mut trail = OdometryTrail::default();
        let dt = 1.0 / 120.0;
        for k in 0..=60 {
            let t = k as f64 * dt;
            if k > 0 {
                odometry.advance(if t > 0.3 { &sidestep } else { &cruise }, dt, &facts);
            }
            trail.push(t, odometry);
        }
        // the sidestep's acceleration changes the velocity at every step since it began
        assert!((trail.steady_since_s - 0.5).abs() < 1e-9, "{}", trail.steady_since_s);
        // before the sidestep: on the straight cruising path, a metre a second
        let before = trail.at(0.2);
        assert!((before.position_m[0] - 0.2).abs() < 1e-9 && before.position_m[1].abs() < 1e-12);
        // during it: the recorded pose of that step, not the pose now taken back
        let during = trail.at(40.0 * dt);
        let now = trail.now();
        assert!(during.position_m[1] > 0.0 && during.position_m[1] < now.position_m[1]);
        assert!(during.velocity[1] < now.velocity[1]);
        // older than the trail (it keeps TRAIL_LENGTH records): the earliest record taken back
        // along its velocity
        let mut long = OdometryTrail::default();
        for k in 0..(TRAIL_LENGTH + 10) {
            let t = k as f64 * dt;
            let cruising = Odometry {
                position_m: [t, 0.0],
                velocity: [1.0, 0.0, 0.0],
                ..Odometry::default()
            };
            long.push(t, cruising);
        }
        assert_eq!(long.samples.len(), TRAIL_LENGTH);
        assert!((long.at(0.01).position_m[0] - 0.01).abs() < 1e-9);
        assert_eq!(long.steady_since_s, f64::NEG_INFINITY);
    }

    #[test]
    fn a_crossing_car_is_a_long_narrow_box_along_its_motion_and_a_ball_a_square() {
        // a 4 × 1.8 m car (1.4 m high) driving at 29° to the line of sight: its image is as wide
        // as its projection across the line of sight
        // the motion of an object of `height` moving over the ground at `ground` (forward, left)
        let motion = |height: f64, ground: [f64; 2]| {
            let heading = ground[1].atan2(ground[0]);
            Motion {
                scale: 1.0,
                heading,
                sin_cos: [heading.sin().abs(), heading.cos().abs()],
                moving: ground[0].hypot(ground[1]) >= STILL_MPS,
                height,
            }
        };
        let heading = 29f64.to_radians();
        let width = 4.0 * heading.sin() + 1.4 * heading.cos();
        let car = motion(1.4, [-4.7 * heading.cos(), 4.7 * heading.sin()]);
        assert!((car.heading - (std::f64::consts::PI - heading)).abs() < 1e-9, "{car:?}");
        let [hl, hb] = oriented_extent(width, &car).unwrap();
        assert!((hl - 2.0).abs() < 1e-9 && (hb - 0.7).abs() < 1e-9, "{hl} {hb}");
        // a ball coming nearly head-on, or anything still: a square as deep as it is wide
        assert_eq!(oriented_extent(0.3, &motion(0.3, [-9.0, 0.5])), None);
        assert_eq!(oriented_extent(1.8, &motion(1.4, [0.05, 0.0])), None);
        // a car head-on: as long as the bound allows (its image shows its breadth only)
        let [hl, hb] = oriented_extent(1.8, &motion(1.4, [-8.0, 0.3])).unwrap();
        assert!(
            (hl - MAX_OBJECT_LENGTH_M / 2.0).abs() < 1e-9 && (hb - 0.7).abs() < 1e-9,
            "{hl} {hb}"
        );
    }

    #[test]
    fn the_gap_between_rectangles_separates_and_overlaps_as_their_corners_do() {
        let body = BodyExtent::default();
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let pose = Odometry {
                position_m: [next() * 2.0 - 1.0, next() * 2.0 - 1.0],
                heading_rad: next() * 6.3,
                velocity: [0.0; 3],
            };
            let object = Footprint {
                centre: [next() * 6.0 - 3.0, next() * 6.0 - 3.0],
                heading_rad: next() * 6.3,
                half_extent: [0.05 + next() * 2.0, 0.05 + next() * 1.0],
            };
            let g = gap(&pose, &body, &object);
            // the body's rectangle in the odometry frame
            let body_centre = pose.point_in_odometry((body.ahead_of_camera_m - body.behind_camera_m) / 2.0, 0.0);
            let body_half = [(body.ahead_of_camera_m + body.behind_camera_m) / 2.0, body.half_width_m];
            let (a, b) = (
                corners(body_centre, pose.heading_rad, body_half),
                corners(object.centre, object.heading_rad, object.half_extent),
            );
            let overlap = a
                .iter()
                .any(|&p| inside(p, object.centre, object.heading_rad, object.half_extent))
                || b.iter().any(|&p| inside(p, body_centre, pose.heading_rad, body_half))
                || (0..4)
                    .any(|i| (0..4).any(|j| segment_distance([a[i], a[(i + 1) % 4]], [b[j], b[(j + 1) % 4]]) == 0.0));
            let distance = (0..4)
                .flat_map(|i| (0..4).map(move |j| (i, j)))
                .map(|(i, j)| segment_distance([a[i], a[(i + 1) % 4]], [b[j], b[(j + 1) % 4]]))
                .fold(f64::INFINITY, f64::min);
            if overlap {
                assert!(g <= 1e-9, "overlapping rectangles, gap {g}");
            } else {
                // separating axes: positive, and never more than the true distance
                assert!(g > -1e-9 && g <= distance + 1e-9, "gap {g}, distance {distance}");
            }
        }
    }

    #[test]
    fn an_oblique_cars_footprint_follows_the_true_box() {
        // the car above, its centre 8 m ahead and 3.15 m right now, the robot cruising at 1 m/s:
        // the forecast the gate makes of it (edges now and at arrival, closing 5.7 m/s)
        let heading = 29f64.to_radians();
        let (ground, car_half) = ([-4.7 * heading.cos(), 4.7 * heading.sin()], [2.0, 0.7]);
        let half_forward = 2.0 * heading.cos() + 0.7 * heading.sin();
        let half_across = 2.0 * heading.sin() + 0.7 * heading.cos();
        let closing = 1.0 - ground[0];
        let tau = (8.0 - half_forward) / closing;
        let centre_at = |t: f64| [8.0 + (ground[0] - 1.0) * t, -3.15 + ground[1] * t];
        let right = |t: f64| -centre_at(t)[1];
        let forecast = CourseForecast {
            t_s: 0.0,
            tau_s: tau,
            closing_mps: closing,
            lateral_m: [right(0.0) - half_across, right(0.0) + half_across],
            arrival_lateral_m: [right(tau) - half_across, right(tau) + half_across],
            arrival_vertical_m: [-0.5, 0.9],
            straight: Some(true),
            standing: false,
            closing_measured: false,
        };
        let object = Remembered {
            id: 0,
            forecast,
            origin: Odometry {
                velocity: [1.0, 0.0, 0.0],
                ..Odometry::default()
            },
            refreshed_s: 0.0,
            clipped: [false; 2],
            ground_scale: None,
        };
        for t in [0.0, 0.5, tau, 1.5] {
            let f = object.footprint(t, &object.motion(1.0));
            // the true centre in the odometry frame (the robot moved 1 m/s · t forward)
            let truth = [centre_at(t)[0] + t, centre_at(t)[1]];
            assert!(
                (f.centre[0] - truth[0]).abs() < 1e-6 && (f.centre[1] - truth[1]).abs() < 1e-6,
                "{t}: {f:?}"
            );
            assert!(
                (f.heading_rad - (std::f64::consts::PI - heading)).sin().abs() < 1e-9,
                "{t}: {f:?}"
            );
            assert!((f.half_extent[0] - car_half[0]).abs() < 1e-6 && (f.half_extent[1] - car_half[1]).abs() < 1e-6);
        }
    }

    #[test]
    fn an_object_cut_off_by_the_image_border_reaches_beyond_it() {
        // the oblique car of the test above, its image cut off by the right border: its right
        // edge stands still in the image while its left edge moves left
        let heading = 29f64.to_radians();
        let closing = 1.0 + 4.7 * heading.cos();
        let tau = 1.0;
        let tan_border = Pinhole::new(60.0).tan_half_fov();
        let border_m = closing * tau * tan_border;
        let forecast = CourseForecast {
            t_s: 0.0,
            tau_s: tau,
            closing_mps: closing,
            lateral_m: [border_m - 1.2, border_m],
            arrival_lateral_m: [-1.7, 0.2],
            arrival_vertical_m: [-0.5, 0.9],
            straight: Some(true),
            standing: false,
            closing_measured: false,
        };
        let mut planner = Planner::new(RobotFacts::default());
        let now = Odometry {
            velocity: [1.0, 0.0, 0.0],
            ..Odometry::default()
        };
        let mut trail = OdometryTrail::default();
        trail.push(0.0, now);
        planner.observe(0, &forecast, 0.0, &trail);
        let seen = planner.objects[0];
        assert_eq!(seen.clipped, [false, true]);
        let whole = Remembered {
            clipped: [false; 2],
            ..seen
        };
        let right_most = |f: &Footprint| {
            corners(f.centre, f.heading_rad, f.half_extent)
                .iter()
                .map(|c| c[1])
                .fold(f64::INFINITY, f64::min)
        };
        let left_most = |f: &Footprint| {
            corners(f.centre, f.heading_rad, f.half_extent)
                .iter()
                .map(|c| c[1])
                .fold(f64::NEG_INFINITY, f64::max)
        };
        for t in [0.0, 0.5, 1.0] {
            let (cut, as_seen) = (
                seen.footprint(t, &seen.motion(1.0)),
                whole.footprint(t, &whole.motion(1.0)),
            );
            // the unseen part lies beyond the right border: the footprint reaches further right
            // (by metres: the longest object at the car's angle), its seen left edge moves as seen
            assert!(
                right_most(&cut) < right_most(&as_seen) - 1.0,
                "{t}: {cut:?} vs {as_seen:?}"
            );
            let seen_left = -(forecast.lateral_m[0] + (forecast.arrival_lateral_m[0] - forecast.lateral_m[0]) * t);
            assert!(left_most(&cut) >= seen_left - 1e-6, "{t}: {cut:?}");
        }
    }
}
