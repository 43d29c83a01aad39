//! [`EscapeAgent`]: the decision half of the closed loop, in one place.
//!
//! One camera frame goes through exactly this path, in the scenario runner's closed-loop tails,
//! in its escape-deadline replays and in every Gymnasium step:
//!
//! 1. every detector of the agent steps on the frame ([`Detector::step_moving`], with the efference
//!    copy of the period that ended with it: the command the agent returned for it and, when the
//!    caller gives the camera's pose ([`EscapeAgent::step_posed`]), the camera's motion and pose
//!    above the ground, from [`CameraMotionSensor`]);
//! 2. the looming side is estimated from this frame and the previous one
//!    ([`LoomingSideEstimator`], the x centroid of the temporal contrast) — or, when the driving
//!    detector localises the object ([`Signals::region`]), it is the middle of its image extent;
//! 3. the escape controller reads the **driving** detector's trigger signal (the first detector;
//!    θ̂ or the output, per [`DecisionRule::trigger`](crate::DecisionRule::trigger)), runs its decider on it
//!    ([`crate::decision`]: θ̂ itself, or the urgency 1/τ̂, optionally gated by the collision-course
//!    gate fed with the looming side as the object's azimuth) and returns the velocity command to
//!    apply during the next camera period. When the driving detector numbers its tracks
//!    ([`ImageRegion::track`](loomlab_detector::ImageRegion::track), `tracker`), the controller is
//!    told which track the value is about ([`EscapeController::set_object`]): an alarm about
//!    another track is dodged afresh instead of being taken for a re-trigger.
//!
//! The runner and the environment are orchestration around this type: they own the simulator,
//! the ground truth and the scoring, and never restate this step.
//!
//! An agent can also be driven by a decision value that does not come from a detector and a given
//! looming side, without any frame (the ground-truth reference rows and the physics-only replays
//! of the runner), through [`EscapeAgent::act_on_value`]; the controller is the same.

use loomlab_detector::{Detector, DetectorError, EfferenceCopy, Frame, Signals};

use crate::decision::{Decision, Percept};
use crate::{
    AgentError, CameraMotionSensor, ControllerEvent, EscapeConfig, EscapeController, LoomingSideEstimator, RobotFacts,
    SensedCamera, VelocityCommand,
};

/// What one [`EscapeAgent::step`] produced.
#[derive(Debug, Clone, PartialEq)]
pub struct AgentStep {
    /// Every detector's signals on this frame, in the agent's detector order.
    pub signals: Vec<Signals>,
    /// The driving detector's decision value: its trigger signal after the decider
    /// (θ̂, the output, or the urgency 1/τ̂; NaN when it gives none).
    pub trigger_value: f64,
    /// The looming object's image x in [-1, 1] from this frame and the previous one (`None`:
    /// first frame, no usable change or no frame).
    pub looming_side: Option<f32>,
    /// The command to apply during the next camera period.
    pub command: VelocityCommand,
    /// What the escape controller did.
    pub event: ControllerEvent,
}

/// Detectors, looming-side estimator and escape controller: frame in, velocity command out (see
/// the module docs).
pub struct EscapeAgent {
    detectors: Vec<Box<dyn Detector>>,
    side: LoomingSideEstimator,
    controller: EscapeController,
    /// The command the last step returned: applied during the period that ends with the next
    /// frame, the detectors' efference copy (`None`: no step since the last reset; then the cruise
    /// command).
    applied: Option<VelocityCommand>,
    /// Turns the camera's poses into the detectors' efference copies.
    efference_sensor: CameraMotionSensor,
}

impl std::fmt::Debug for EscapeAgent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EscapeAgent")
            .field("detectors", &self.detectors.iter().map(|d| d.id()).collect::<Vec<_>>())
            .field("controller", self.controller.config())
            .finish()
    }
}

impl EscapeAgent {
    /// An agent whose first detector drives the controller of `controller` for the robot of
    /// `facts` (`detectors` may be empty when the agent is only driven through
    /// [`act_on_value`](Self::act_on_value)).
    pub fn new(
        detectors: Vec<Box<dyn Detector>>,
        controller: EscapeConfig,
        facts: RobotFacts,
    ) -> Result<Self, AgentError> {
        Ok(Self {
            detectors,
            side: LoomingSideEstimator::default(),
            controller: EscapeController::new(controller, facts)?,
            applied: None,
            efference_sensor: CameraMotionSensor::default(),
        })
    }

    /// An agent from detectors and an already validated controller (reset to its initial state).
    pub fn from_parts(detectors: Vec<Box<dyn Detector>>, mut controller: EscapeController) -> Self {
        controller.reset();
        Self {
            detectors,
            side: LoomingSideEstimator::default(),
            controller,
            applied: None,
            efference_sensor: CameraMotionSensor::default(),
        }
    }

    /// Starts a new episode: detectors, looming side and controller back to their initial state.
    pub fn reset(&mut self) {
        for d in &mut self.detectors {
            d.reset();
        }
        self.side.reset();
        self.controller.reset();
        self.applied = None;
        self.efference_sensor.reset();
    }

    /// Replaces the detector at `index` (e.g. rebuilt with other parameters).
    ///
    /// # Panics
    /// If `index` is out of range.
    pub fn replace_detector(&mut self, index: usize, detector: Box<dyn Detector>) {
        self.detectors[index] = detector;
    }

    /// Replaces the controller configuration and the robot's facts (validated) and resets the
    /// controller.
    pub fn set_controller(&mut self, config: EscapeConfig, facts: RobotFacts) -> Result<(), AgentError> {
        self.controller = EscapeController::new(config, facts)?;
        Ok(())
    }

    /// The escape controller.
    pub fn controller(&self) -> &EscapeController {
        &self.controller
    }

    /// Number of detectors.
    pub fn detector_count(&self) -> usize {
        self.detectors.len()
    }

    /// One closed-loop decision at episode time `t_s` on `frame`, with `cruise` the command the
    /// robot follows when nothing threatens it. The detectors' efference copy holds the applied
    /// command only ([`Self::step_posed`] adds the camera's motion).
    pub fn step(&mut self, t_s: f64, frame: &Frame, cruise: VelocityCommand) -> Result<AgentStep, DetectorError> {
        self.step_posed(t_s, frame, cruise, None)
    }

    /// [`Self::step`] with the camera's state at `t_s` (`camera`, as the robot's odometry and
    /// inertial sensor know it): the detectors' efference copy then also holds the camera's motion
    /// since the previous step and its pose above the ground ([`CameraMotionSensor`]), and the decision
    /// decider removes the camera's shake from image directions ([`crate::SelfMotion`]).
    pub fn step_posed(
        &mut self,
        t_s: f64,
        frame: &Frame,
        cruise: VelocityCommand,
        camera: Option<&SensedCamera>,
    ) -> Result<AgentStep, DetectorError> {
        self.step_posed_events(t_s, frame, None, cruise, camera)
    }

    /// [`Self::step_posed`] with the events of the camera period that ended with `frame`, when
    /// the camera is an event camera: every detector gets them ([`Detector::step_events`]; the
    /// frame rows ignore them). `None` is [`Self::step_posed`].
    pub fn step_posed_events(
        &mut self,
        t_s: f64,
        frame: &Frame,
        events: Option<&loomlab_detector::EventInput<'_>>,
        cruise: VelocityCommand,
        camera: Option<&SensedCamera>,
    ) -> Result<AgentStep, DetectorError> {
        let efference = self.efference_copy(t_s, cruise, camera);
        let mut signals = Vec::with_capacity(self.detectors.len());
        for d in &mut self.detectors {
            signals.push(match events {
                Some(events) => d.step_events(frame, events, &efference)?,
                None => d.step_moving(frame, &efference)?,
            });
        }
        let contrast_side = self.side.update(frame);
        Ok(self.decide_on_signals(t_s, cruise, camera, signals, contrast_side))
    }

    /// [`Self::step_posed`] with what the agent's perception gives on this frame already known:
    /// `signals`, those of detectors identical to the agent's stepped on the same frames with the
    /// same efference copies, and `contrast_side`, what a [`LoomingSideEstimator`] gave on the same
    /// frames (the scenario runner's open-loop pass, replayed up to an alarm). The detectors are
    /// not stepped and the estimator only remembers the frame; the efference copy, decider
    /// and controller advance exactly as in [`Self::step_posed`].
    pub fn step_posed_with_signals(
        &mut self,
        t_s: f64,
        frame: &Frame,
        cruise: VelocityCommand,
        camera: Option<&SensedCamera>,
        signals: Vec<Signals>,
        contrast_side: Option<f32>,
    ) -> AgentStep {
        self.efference_copy(t_s, cruise, camera);
        self.side.remember(frame);
        self.decide_on_signals(t_s, cruise, camera, signals, contrast_side)
    }

    /// The efference copy of the camera period that ends at `t_s` (advances the efference sensor).
    fn efference_copy(&mut self, t_s: f64, cruise: VelocityCommand, camera: Option<&SensedCamera>) -> EfferenceCopy {
        let applied = self.applied.unwrap_or(cruise);
        match camera {
            Some(camera) => self.efference_sensor.sense_frame(t_s, applied, camera),
            None => applied.efference_copy(),
        }
    }

    /// Everything of a step after the detectors and the contrast side: looming side, decision
    /// decider, controller.
    fn decide_on_signals(
        &mut self,
        t_s: f64,
        cruise: VelocityCommand,
        camera: Option<&SensedCamera>,
        signals: Vec<Signals>,
        contrast_side: Option<f32>,
    ) -> AgentStep {
        let looming_side = signals.first().and_then(region_side).or(contrast_side);
        let shake_rad = camera.map_or([0.0; 3], |c| c.shake_rad);
        let decision = match signals.first() {
            Some(s) => self
                .controller
                .perceive_signals(t_s, s, looming_side, cruise, shake_rad),
            None => self.controller.perceive(t_s, Percept::unknown(), cruise, shake_rad),
        };
        let region = signals.first().and_then(|s| s.region);
        let object = region.and_then(|r| r.track);
        self.controller.observe(t_s, object.unwrap_or(0), &decision, cruise);
        // every other object the detector lists: its own decider; the alarm is raised by any
        let others = signals.first().map_or(f64::NAN, |s| {
            self.controller
                .perceive_objects(t_s, &s.objects, object, cruise, shake_rad)
        });
        let trigger_value = if others > decision.value {
            others
        } else {
            decision.value
        };
        // a detector that localises the object escapes from the side on which the collision-course
        // gate predicts it to arrive (as `ideal_course` does), else from where it is now
        let looming_side = decision.escape_side(looming_side, region.is_some());
        let mut step = self.act_on_value(t_s, looming_side, trigger_value, object, cruise);
        step.signals = signals;
        self.applied = Some(step.command);
        step
    }

    /// Tell the controller's planner what a decider outside this agent decided about object `id`
    /// at `t_s` (the reference rows' ideal observers; call before [`Self::act_on_value`]).
    pub fn observe(&mut self, t_s: f64, id: usize, decision: &Decision, cruise: VelocityCommand) {
        self.controller.observe(t_s, id, decision, cruise);
    }

    /// The controller's step on a decision value that does not come from the agent's detectors
    /// and a given looming side, with no frame (the physics-only escape-deadline replays, which
    /// force a trigger and take the side from the open-loop frames; the reference rows, whose
    /// deciders run on ground truth), naming the object the value comes from when the caller knows
    /// it (`object`; a re-trigger keeps the dodge side only for the same object). The detectors,
    /// the looming-side estimator and the decider are not updated.
    pub fn act_on_value(
        &mut self,
        t_s: f64,
        looming_side: Option<f32>,
        trigger_value: f64,
        object: Option<usize>,
        cruise: VelocityCommand,
    ) -> AgentStep {
        self.controller.set_object(object);
        let (command, event) = self.controller.step(t_s, trigger_value, looming_side, cruise);
        AgentStep {
            signals: Vec::new(),
            trigger_value,
            looming_side,
            command,
            event,
        }
    }
}

/// The looming side (image x in [−1, 1]) of a detector that localises the object: the middle of
/// its image extent (`None` without a region).
pub fn region_side(signals: &Signals) -> Option<f32> {
    signals
        .region
        .map(|r| ((r.x[0] + r.x[1]) / 2.0) as f32)
        .filter(|x| x.is_finite())
}
