//! The decision: how one frame's percept becomes the scalar the escape controller compares with its
//! alarm threshold, and the side it escapes from.
//!
//! A [`Decider`] configured by a [`DecisionRule`] runs four stages, each in its own file:
//! 1. **τ estimator** (`tau.rs`): the time to contact τ̂ from θ̂ over the rule's window;
//! 2. **course gate** (`course.rs`): whether the object's image says it will touch the robot's
//!    body, and on which side it arrives;
//! 3. **persistence** (`persistence.rs`): K-of-M confirmation of the value;
//! 4. **manoeuvre choice** (`manoeuvre.rs`): the image side to escape from.
//!
//! [`Decider::decide`] is the only place where a percept becomes a decision: the escape agent, the
//! scenario runner's open-loop pass, the trace replays, the reference rows' ideal observers and the
//! Gymnasium env all call it (a test, `agents/tests/decision_call_path.rs`, keeps it so). A real
//! detector's percept is built by [`Percept::of_detector`] (`percept.rs`) with the camera's
//! [`Pinhole`].
//!
//! # Perceptual inputs
//! The decider sees, per frame, a [`Percept`] and what the robot knows about itself ([`SelfMotion`]):
//! - `theta_deg`: the looming object's angular size θ̂ (degrees) — the driving detector's
//!   estimate, or (reference rows only) an object's true angular size;
//! - `azimuth_deg` / `elevation_deg`: the object's image position as angles from the optical axis
//!   (degrees, azimuth positive to the right, elevation positive up). A real detector's agent
//!   converts the looming side (the x centroid of the temporal contrast, image x in [−1, 1]) into
//!   an azimuth with the camera's field of view; it has no elevation;
//! - the robot's own yaw rate (the command it applied during the last camera period) and its body's
//!   extent about the camera ([`BodyExtent`], given at construction).
//!
//! The decider reads no distances, velocities or contact predictions of other objects.
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
//! frames, no look-ahead). The decision
//! value is the **urgency** `1/τ̂` (s⁻¹; a τ̂ ≤ 1 ms counts as 1 ms) when θ̂ ≥
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
//! rate and the camera shake its inertial sensor measures, [`SelfMotion`]).
//!
//! **Where it arrives.** The image gives no scale: it gives offsets in units of the object's
//! distance. The gate converts them with an assumed closing speed v̂ (`course_closing_speed_mps`,
//! or the robot's forward speed when larger): a point at image direction `u = tan a` moving at
//! constant velocity arrives (reaches the camera's depth) at a lateral offset `x = v̂ · τ² · u̇`,
//! with τ the time to contact at the window's mean time. With an image extent, τ comes from the
//! growth of the object's vertical extent (the time to contact of its nearest face, whatever its
//! shape) and the four edges are extrapolated: the object is on a collision course when its
//! predicted extent overlaps the body's (half-width beside the camera, its reach above and below
//! the camera), laterally over the whole length of the body (the edges' straight course from the
//! body's front to its rear: an oblique object that passes the camera's depth beside the body can
//! still strike its flank). An object whose edges all move as those of an object standing in the world
//! (`u̇ · τ = u` within [`STANDING_TOLERANCE`]) closes at the robot's own speed, which then replaces
//! v̂. Without an extent (a detector row), the object is taken as a sphere: its centre arrives
//! `R · μ` beside the camera with `μ = 2·β̇/θ̇` (the miss in object radii; |μ| < 1 iff both edges
//! diverge) and `R̂ = sin(θ/2) · τ̂ · v̂`; the gate needs `(|μ| − 1) · R̂` ≤ the body's half-width.
//!
//! **Standing or moving.** Radial expansion does not prove that an object stands: a ball flying
//! along the robot's heading expands the same way, and read as standing it looks small and close,
//! on the robot's path (a false alarm for a ball passing beside). A decider bound to one object
//! ([`Decider::for_one_object`]: each reference object of `ideal_course`, each of a tracker's other
//! tracks) remembers where the object stood while it was read as standing; once it comes nearer
//! than half of what the robot's own travel allows, it has moved in the world (a ball leaving the
//! thrower's hand) and is never read as standing again, and the decider restarts its window (the
//! frames before show another course). Its distance while it stood also gave its height, and its
//! height now gives its distance: the closing speed is then measured, not assumed, and the metres
//! exact ([`CourseForecast::closing_measured`]; the planner then checks that one scale only)
//! (`standing.rs`). A detector's driving percept, which may switch objects, keeps the plain reading.
//! Any decider also asks the ground: an object coming along its line of sight (a vehicle in the
//! next lane) expands exactly as one standing nearer does, but read as standing its bottom would
//! float just below the horizon; when that bottom is less than [`FLOATING_BOTTOM_FRACTION`] of the
//! body's reach below the camera down, the object is read as moving.
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

mod course;
mod fit;
mod manoeuvre;
mod percept;
mod persistence;
mod rule;
mod standing;
mod tau;
mod window;

pub use course::{
    CourseForecast, FLOATING_BOTTOM_FRACTION, PASS_SIDE_MIN_RADII, STANDING_TOLERANCE, STOPPING_TAU_RATE,
    STRAIGHT_COURSE_MAX_RADII,
};
pub use percept::{ImageExtent, Percept, SelfMotion};
pub use rule::{BodyExtent, Course, DecisionRule, MAX_PERSISTENCE_FRAMES, TriggerSignal};
pub use tau::surface_factor;

use loomlab_detector::{ImageRegion, Pinhole};

use crate::RobotFacts;

use persistence::Persistence;
use standing::WorldMotionMemory;
use window::SampleWindow;

/// A θ̂ that changes by more than this factor from one frame to the next starts the window afresh
/// (module docs, "Jumps").
pub const JUMP_RATIO: f64 = 1.3;

/// Fewest frames in the window for a τ or bearing-rate estimate.
pub const MIN_SAMPLES: usize = 3;

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
    /// The object's predicted course in metres, when the percept has an image extent over the
    /// gate's window (what the manoeuvre planner reads).
    pub forecast: Option<CourseForecast>,
}

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
            forecast: None,
        }
    }
}

/// The decision pipeline of one row (see the module docs): a causal filter from percepts to
/// decisions.
#[derive(Debug, Clone)]
pub struct Decider {
    rule: DecisionRule,
    body: BodyExtent,
    pinhole: Pinhole,
    window: SampleWindow,
    persistence: Persistence,
    /// The object's motion in the world, for a decider bound to one object (`standing.rs`).
    world_motion: Option<WorldMotionMemory>,
}

impl Decider {
    /// A fresh decider of `rule` for the robot of `facts`: its body's extent about the camera (the
    /// course gate) and its camera's pinhole (which turns a detector's image coordinates into
    /// angles).
    pub fn new(rule: DecisionRule, facts: &RobotFacts) -> Self {
        Self {
            persistence: Persistence::new(rule.persistence_frames, rule.persistence_window()),
            rule,
            body: facts.body,
            pinhole: facts.pinhole,
            window: SampleWindow::default(),
            world_motion: None,
        }
    }

    /// This decider for one object only (an object id's, never another's): it remembers whether the
    /// object was seen to move in the world, which the course gate reads (module docs, **Standing
    /// or moving**). A decider whose percept may come from different objects over time (a
    /// detector's driving percept) must not remember it.
    pub fn for_one_object(mut self) -> Self {
        self.world_motion = Some(WorldMotionMemory::default());
        self
    }

    /// The rule.
    pub fn rule(&self) -> &DecisionRule {
        &self.rule
    }

    /// The K-of-M count after the last [`Self::decide`]: how many of the last M frames' values
    /// (after the τ rule and the gate, before persistence) are at or above the rule's alarm
    /// threshold, and K (`None` without a persistence window, M ≤ 1). Read-only: the decisions do
    /// not depend on it (the Gymnasium env's decision features read it).
    pub fn confirmations(&self) -> Option<(usize, usize)> {
        self.persistence.confirmations(self.rule.alarm_threshold())
    }

    /// Forget the history (new episode).
    pub fn reset(&mut self) {
        self.window.clear();
        self.persistence.clear();
        if let Some(m) = &mut self.world_motion {
            *m = WorldMotionMemory::default();
        }
    }

    /// Whether this decider keeps state ([`DecisionRule::is_stateful`]): only then does a
    /// decision's value differ from the percept's.
    pub fn is_stateful(&self) -> bool {
        self.rule.is_stateful()
    }

    /// [`Self::decide`] on a real detector's percept: its trigger-signal `value` (θ̂, or the output
    /// for output triggers; NaN when it gives none), its image `region` when it localises the
    /// object, else the `looming_side` (image x), turned into angles ([`Percept::of_detector`]).
    pub fn decide_on_detector(
        &mut self,
        t_s: f64,
        value: f64,
        looming_side: Option<f32>,
        region: Option<&ImageRegion>,
        motion: SelfMotion,
    ) -> Decision {
        let percept = Percept::of_detector(value, looming_side, region, &self.pinhole);
        self.decide(t_s, percept, motion)
    }

    /// Stages 1 and 2 on the window at `t_s`: τ̂ and the course gate's assessment.
    fn estimate(&self, t_s: f64, theta_rad: f64, motion: &SelfMotion) -> (Option<f64>, course::CourseAssessment) {
        let rule = &self.rule;
        let tau_s = tau::estimate(
            &self.window,
            t_s,
            rule.tau_window_s,
            rule.min_angular_size_deg.to_radians(),
        );
        let course = course::assess(
            &self.window,
            t_s,
            theta_rad,
            tau_s,
            motion,
            rule,
            &self.body,
            self.world_motion.as_ref(),
        );
        (tau_s, course)
    }

    /// Tell the memory of a decider bound to one object what the gate read; whether the object was
    /// seen to move in the world for the first time.
    fn remember_world_motion(&mut self, course: &course::CourseAssessment, motion: &SelfMotion) -> bool {
        let (Some(memory), Some(f)) = (&mut self.world_motion, &course.forecast) else {
            return false;
        };
        let moved_before = memory.moved();
        memory.record(
            f.t_s,
            motion.forward_mps,
            f.standing
                .then_some(course.extent_tan)
                .flatten()
                .map(|extent| (f.closing_mps * f.tau_s, extent)),
            course.seen_moving,
        );
        memory.moved() && !moved_before
    }

    /// Take this frame's percept at time `t_s` and return the decision: τ estimator → course gate →
    /// persistence (see the module docs).
    pub fn decide(&mut self, t_s: f64, percept: Percept, motion: SelfMotion) -> Decision {
        let rule = self.rule;
        let reads_angle = rule.trigger.reads_angular_size();
        if !self.is_stateful() {
            return Decision::unestimated(percept.value, true);
        }
        // the value while nothing is decided: no urgency (angles), no output (NaN)
        let idle = if reads_angle { 0.0 } else { f64::NAN };
        if !t_s.is_finite() {
            return Decision::unestimated(idle, false);
        }
        let theta_rad = if reads_angle {
            percept.value.to_radians()
        } else {
            f64::NAN
        };
        let keep_s = rule.tau_window_s.max(rule.course_window_s);
        self.window.push(t_s, theta_rad, &percept, &motion, keep_s);
        let (mut tau_s, mut course) = self.estimate(t_s, theta_rad, &motion);
        if self.remember_world_motion(&course, &motion) {
            // the object was just seen to start moving (a ball leaving the hand): the window's
            // earlier frames show another course and predict nothing of this one
            self.window.clear();
            self.window.push(t_s, theta_rad, &percept, &motion, keep_s);
            (tau_s, course) = self.estimate(t_s, theta_rad, &motion);
        }
        let value = if rule.trigger == TriggerSignal::Tau {
            match tau_s {
                Some(tau) if course.gate_open && percept.value >= rule.min_angular_size_deg => 1.0 / tau.max(1e-3),
                _ => 0.0,
            }
        } else if course.gate_open {
            percept.value
        } else {
            idle
        };
        Decision {
            value: self.persistence.apply(value, idle),
            tau_s,
            miss_radii: course.miss_radii,
            vertical_miss_radii: course.vertical_miss_radii,
            pass_side: course.pass_side,
            arrival_extent_m: course.arrival_extent_m,
            tau_rate: course.tau_rate,
            gate_open: course.gate_open,
            forecast: course.forecast,
        }
    }
}
