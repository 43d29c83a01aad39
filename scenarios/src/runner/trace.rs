//! What an episode produced: its open-loop traces, closed loops and scores.

use loomlab_agents::{SelfMotion, TriggerSignal};
use loomlab_detector::ImageRegion;

use crate::deadline::EscapeDeadline;
use crate::metrics::EpisodeOutcome;
use crate::truth::Impact;

/// One detector's signals over an episode's open-loop pass.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorTrace {
    /// Detector label.
    pub label: String,
    /// Which signal is compared with the threshold.
    pub trigger: TriggerSignal,
    /// Alarm threshold.
    pub threshold: f64,
    /// Trigger signal per frame (NaN where the detector gives none).
    pub signal: Vec<f64>,
    /// Primary output per frame.
    pub output: Vec<f64>,
    /// For a row with a stateful decider (τ trigger, course gate or persistence): what it decided
    /// on, frame by frame.
    pub decision: Option<DecisionTrace>,
    /// For a detector that localises the looming object (`tracker`): its image region per frame.
    pub regions: Option<Vec<Option<ImageRegion>>>,
    /// For such a detector in a threat episode: whether its region covers the threat's true image,
    /// per frame (the frames on whose alarms the row is scored; ground truth, for analysis only).
    pub about_threat: Option<Vec<bool>>,
}

/// A decider's inputs and estimates over an episode's open-loop pass.
#[derive(Debug, Clone, PartialEq)]
pub struct DecisionTrace {
    /// The detector's θ̂ (degrees; NaN where it gives none) before the decider.
    pub theta_hat_deg: Vec<f64>,
    /// The decider's time-to-contact estimate τ̂ (s), where it has one.
    pub tau_s: Vec<Option<f64>>,
    /// Whether the collision-course gate was open.
    pub gate_open: Vec<bool>,
}

/// The open-loop pass of an episode, frame by frame.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeTrace {
    /// Frame times (s).
    pub t_s: Vec<f64>,
    /// Name of the reference object (the threat, or the closest object).
    pub reference_object: Option<String>,
    /// True angular size of the reference object per frame (degrees).
    pub angular_size_deg: Vec<f64>,
    /// True time to contact of the reference object per frame (s), when on a collision course.
    pub ttc_s: Vec<Option<f64>>,
    /// The escape deadline of a threat (s; `None`: no threat, or unavoidable).
    pub t_deadline_s: Option<f64>,
    /// What the detectors' deciders knew of the robot's own motion per frame (its cruise command
    /// and the camera's sensed shake).
    pub self_motion: Vec<SelfMotion>,
    /// The looming side per frame (x centroid of the temporal contrast, image x in [−1, 1]).
    pub looming_side: Vec<Option<f32>>,
    /// Per detector.
    pub detectors: Vec<DetectorTrace>,
}

/// What happened in the closed loop of one detector.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoop {
    /// Detector label.
    pub label: String,
    /// Whether a post-alarm tail was simulated (false: the outcome follows from the open loop).
    pub simulated: bool,
    /// Number of escape manoeuvres started.
    pub triggers: usize,
    /// The robot's first collision, if any.
    pub collision: Option<Impact>,
    /// Frames rendered for the tail.
    pub frames_rendered: usize,
}

/// Everything one episode produced.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeRun {
    /// The scores (what `episodes.csv` and the report hold).
    pub outcome: EpisodeOutcome,
    /// Open-loop traces.
    pub trace: EpisodeTrace,
    /// Closed-loop details per detector (same order as `outcome.detectors`).
    pub closed_loop: Vec<ClosedLoop>,
    /// The escape deadline search of a threat.
    pub deadline: Option<EscapeDeadline>,
    /// Wall time of the deadline search (s).
    pub deadline_s: f64,
    /// Frames rendered in total (open loop + tails).
    pub frames_rendered: usize,
}
