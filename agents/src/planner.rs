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
//! forecast holds relative to the motion the robot had over the gate's window, so it is only taken
//! while that motion was steady (no command change during the window): during a manoeuvre the
//! object's image moves with the robot, and the last steady forecast is extrapolated instead. An
//! object moves at a constant velocity: its nearest face closes at the forecast's closing speed, its
//! edges move laterally from where they are to where they arrive. An object whose vertical course
//! is straight and passes above or below the body is no obstacle. A forecast is forgotten
//! [`FORECAST_MEMORY_S`] after it was last refreshed.
//!
//! # Scale
//! The image gives no scale: a forecast's metres hold for the closing speed the gate assumed. An
//! object the gate recognised as standing in the world closes at the robot's own speed and is
//! exact; every other object is checked under four hypotheses of its closing speed: the assumed one
//! times each of [`SCALE_HYPOTHESES`] (0.5, 1, 1.6), and the robot's own speed (an object standing
//! in the world that the gate did not recognise as one, e.g. a pole whose foot is hidden).
//!
//! # Candidates and choice
//! Each candidate is a manoeuvre held for the controller's `duration_s`, then the cruise command:
//! a sidestep (holonomic base) or an arc (differential drive) to either side, a stop, and reversing.
//! Each is rolled out over [`PLAN_STEP_S`] steps with the drive's acceleration limits, the lateral
//! excursion bounded by `max_dodge_offset_m` (the lane or corridor the robot knows it is in), to a
//! horizon after the last object has passed (at most [`MAX_HORIZON_S`]). Its **clearance** under a
//! hypothesis is the smallest gap over the horizon between the body's footprint and any object's
//! (the object taken as deep as it is wide; negative: they overlap); its **score** is the mean of
//! its clearances capped at `clearance_margin_m`, weighted by [`HYPOTHESIS_WEIGHTS`] (the assumed
//! speed twice). Clearances above the margin count as safe and equal, so among the candidates with
//! the best score the controller's preference decides — the sidestep away from the alarming object
//! (the fixed rule's choice), the other side, stopping, reversing. While a manoeuvre runs it is
//! replaced only when another candidate's score is larger by [`SWITCH_MARGIN_M`].
//!
//! Cost per decision (criterion, `cargo bench -p loomlab-agents --bench strategy`, 2-core machine
//! under load): 0.09 ms with one object, 0.25 ms with three, 0.9 ms with eight; it runs only at an
//! alarm and while one lasts during a manoeuvre.
//!
//! The planner keeps at most [`MAX_PLANNED_OBJECTS`] forecasts in buffers reserved at
//! construction: a decision allocates nothing.

use crate::decision::CourseForecast;
use crate::escape::{DodgeSide, Manoeuvre};
use crate::{EscapeConfig, RobotFacts, VelocityCommand};

/// Most objects the planner remembers at once (the most urgent are kept).
pub const MAX_PLANNED_OBJECTS: usize = 16;
/// Time step of the rollouts (s).
pub const PLAN_STEP_S: f64 = 1.0 / 120.0;
/// Longest rollout (s).
pub const MAX_HORIZON_S: f64 = 3.0;
/// How long a forecast that is no longer refreshed is extrapolated (s).
pub const FORECAST_MEMORY_S: f64 = 3.0;
/// The closing speeds, as factors of the forecast's, under which a candidate must clear an object
/// that does not stand in the world: the image gives no scale, so the forecast's metres hold for
/// the assumed closing speed only (module docs, "Prediction").
pub const SCALE_HYPOTHESES: [f64; 3] = [0.5, 1.0, 1.6];
/// How many closing-speed hypotheses a candidate is checked under: [`SCALE_HYPOTHESES`] and the
/// robot's own speed (`Remembered::scales`).
pub const HYPOTHESES: usize = 4;
/// The weights of the hypotheses in a candidate's score (the assumed closing speed counts twice).
pub const HYPOTHESIS_WEIGHTS: [f64; HYPOTHESES] = [1.0, 2.0, 1.0, 1.0];
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

/// One remembered object: its last steady forecast and the robot's pose it was made from.
#[derive(Debug, Clone, Copy)]
struct Remembered {
    id: usize,
    forecast: CourseForecast,
    /// The robot's pose at the forecast's time, and its velocity then (the motion the forecast is
    /// relative to).
    origin: Odometry,
    refreshed_s: f64,
}

impl Remembered {
    /// The object's footprint at time `t_s` in the odometry frame: centre and half-extents along
    /// the origin's axes (forward, left), or `None` when it passes above or below the body.
    fn footprint(&self, t_s: f64, scale: f64) -> ([f64; 2], [f64; 2]) {
        let f = &self.forecast;
        let s = t_s - f.t_s;
        let progress = s / f.tau_s;
        let edge = |i: usize| scale * (f.lateral_m[i] + (f.arrival_lateral_m[i] - f.lateral_m[i]) * progress);
        // image lateral is positive right; the odometry frame's y is positive left
        let (right, left) = (-edge(0).min(edge(1)), -edge(0).max(edge(1)));
        let half_width = ((right - left).abs() / 2.0).max(0.02);
        let half_depth = half_width.clamp(0.02, 2.5);
        let nearest = scale * f.closing_mps * (f.tau_s - s);
        let [vf, vl, _] = self.origin.velocity;
        let centre = self
            .origin
            .point_in_odometry(nearest + half_depth + vf * s, (left + right) / 2.0 + vl * s);
        (centre, [half_depth, half_width])
    }

    /// The factors on the forecast's metres under which the object is checked: 1 for an object
    /// standing in the world; else [`SCALE_HYPOTHESES`] and the factor that makes it close at the
    /// robot's own speed (an object standing in the world that the gate did not recognise as one).
    fn scales(&self) -> [f64; HYPOTHESES] {
        let f = &self.forecast;
        if f.standing {
            return [1.0; HYPOTHESES];
        }
        let own_speed = (self.origin.velocity[0] / f.closing_mps).clamp(0.0, 1.0);
        let [a, b, c] = SCALE_HYPOTHESES;
        [a, b, c, if own_speed > 0.0 { own_speed } else { b }]
    }

    /// Whether the object passes above or below the body (a straight vertical course that misses).
    fn passes_over_or_under(&self, facts: &RobotFacts) -> bool {
        let [b, t] = self.forecast.arrival_vertical_m;
        self.forecast.straight == Some(true)
            && (b.min(t) > facts.body.above_camera_m || b.max(t) < -facts.body.below_camera_m)
    }

    /// When the object will have passed the robot's body under the reference motion (s).
    fn passed_s(&self, facts: &RobotFacts) -> f64 {
        let f = &self.forecast;
        let depth = (f.arrival_lateral_m[1] - f.arrival_lateral_m[0]).abs().clamp(0.04, 5.0);
        let slowest = self.scales().into_iter().fold(1.0, f64::min);
        f.t_s + f.tau_s + (facts.body.behind_camera_m + depth) / (slowest * f.closing_mps).max(0.1)
    }
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
    /// The lateral offset its dodges have accumulated (m, + left).
    pub dodge_offset_m: f64,
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

    /// Take object `id`'s forecast made at `t_s`, the robot's odometry now being `now` and its
    /// motion steady since `steady_since_s` (the forecast is taken only when its window, twice
    /// its distance from now before now, lies within the steady motion).
    pub fn observe(&mut self, id: usize, forecast: &CourseForecast, t_s: f64, now: &Odometry, steady_since_s: f64) {
        let window_start = 2.0 * forecast.t_s - t_s;
        let usable = forecast.tau_s.is_finite()
            && forecast.tau_s > 0.0
            && forecast.closing_mps.is_finite()
            && forecast.closing_mps > 0.0
            && forecast
                .lateral_m
                .iter()
                .chain(&forecast.arrival_lateral_m)
                .all(|v| v.is_finite())
            && window_start >= steady_since_s - 1e-9;
        if !usable {
            return;
        }
        // the pose at the forecast's time: back along the steady motion
        let mut origin = *now;
        let back = t_s - forecast.t_s;
        let [vf, vl, w] = now.velocity;
        origin.heading_rad -= w * back;
        let (s, c) = origin.heading_rad.sin_cos();
        origin.position_m[0] -= (vf * c - vl * s) * back;
        origin.position_m[1] -= (vf * s + vl * c) * back;
        let entry = Remembered {
            id,
            forecast: *forecast,
            origin,
            refreshed_s: t_s,
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

    /// Forget forecasts not refreshed for [`FORECAST_MEMORY_S`] and objects that have passed.
    pub fn forget_old(&mut self, t_s: f64) {
        let facts = self.facts;
        self.objects
            .retain(|o| t_s - o.refreshed_s <= FORECAST_MEMORY_S && o.passed_s(&facts) >= t_s);
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
        let margin = ctx.config.clearance_margin_m;
        let total: f64 = HYPOTHESIS_WEIGHTS.iter().sum();
        self.clearances(candidate, ctx)
            .iter()
            .zip(HYPOTHESIS_WEIGHTS)
            .map(|(c, w)| c.min(margin) * w)
            .sum::<f64>()
            / total
    }

    /// The clearance of `candidate` under each closing-speed hypothesis.
    fn clearances(&self, candidate: Candidate, ctx: &PlanContext<'_>) -> [f64; HYPOTHESES] {
        let facts = &self.facts;
        let end = self
            .objects
            .iter()
            .filter(|o| !o.passes_over_or_under(facts))
            .map(|o| o.passed_s(facts))
            .fold(f64::NEG_INFINITY, f64::max)
            .min(ctx.t_s + MAX_HORIZON_S);
        let mut clearance = [f64::INFINITY; HYPOTHESES];
        if end <= ctx.t_s {
            return clearance;
        }
        let body = &facts.body;
        let mut pose = ctx.odometry;
        let mut offset = ctx.dodge_offset_m;
        let mut t = ctx.t_s;
        let manoeuvre = ctx.config.command(candidate, ctx.cruise, facts.base);
        while t < end {
            let mut command = if t - ctx.t_s < ctx.config.duration_s {
                manoeuvre
            } else {
                ctx.cruise
            };
            if let Some(limit) = ctx.config.max_dodge_offset_m
                && (command.lateral_mps - ctx.cruise.lateral_mps) * offset.signum() > 0.0
                && offset.abs() >= limit
            {
                command.lateral_mps = ctx.cruise.lateral_mps;
            }
            let before = pose.velocity[1];
            pose.advance(&command, PLAN_STEP_S, facts);
            offset += (before + pose.velocity[1]) / 2.0 * PLAN_STEP_S - ctx.cruise.lateral_mps * PLAN_STEP_S;
            t += PLAN_STEP_S;
            for o in self.objects.iter().filter(|o| !o.passes_over_or_under(facts)) {
                for (scale, c) in o.scales().into_iter().zip(clearance.iter_mut()) {
                    let (centre, half) = o.footprint(t, scale);
                    let rel = pose.point_in_body(centre);
                    let gap_forward =
                        (rel[0] - half[0] - body.ahead_of_camera_m).max(-body.behind_camera_m - (rel[0] + half[0]));
                    let gap_lateral = rel[1].abs() - half[1] - body.half_width_m;
                    *c = c.min(gap_forward.max(gap_lateral));
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
