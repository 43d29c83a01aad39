//! Controllers: the escape controller and RL action adapters (design §1).
//!
//! This crate turns detector [`Signals`](loomlab_detector::Signals) into velocity commands:
//! - [`decision`]: the one pipeline from a frame's percept to a decision ([`Decider`], configured by
//!   a [`DecisionRule`]);
//! - [`EscapeController`]: a threshold-triggered escape manoeuvre (lateral dodge, stop or reverse)
//!   with a fixed duration and a cooldown, configured by [`EscapeConfig`];
//! - [`DiscreteAction`] and [`ContinuousAction`]: the action spaces offered to external RL agents,
//!   mapped to [`VelocityCommand`]s through an [`ActionConfig`];
//! - [`LoomingSideEstimator`]: which side of the image the looming object is on (dodge direction).
//!
//! # Conventions
//! Commands are in the robot's body frame (REP 103): x forward, y left, z up. So
//! `lateral_mps > 0` moves the robot to its **left** and `yaw_rate_rps > 0` turns it to the left
//! (counter-clockwise seen from above). Image x runs from −1 (left edge of the camera image) to +1
//! (right edge). The simulator has its own command type; the scenario runner converts.

pub mod action;
pub mod agent;
pub mod command;
pub mod decision;
pub mod dodge_offset;
pub mod error;
pub mod escape;
pub mod facts;
pub mod looming_side;
pub mod planner;
pub mod sensing;

pub use action::{ActionConfig, ContinuousAction, DiscreteAction};
pub use agent::{AgentStep, EscapeAgent};
pub use command::VelocityCommand;
pub use decision::{
    BodyExtent, Course, Decider, Decision, DecisionRule, ImageExtent, Percept, SelfMotion, TriggerSignal,
};
pub use dodge_offset::DodgeOffset;
pub use error::AgentError;
pub use escape::{ControllerEvent, DodgeSide, EscapeConfig, EscapeController, Manoeuvre};
pub use facts::RobotFacts;
pub use looming_side::LoomingSideEstimator;
pub use planner::{Candidate, Planner};
pub use sensing::{CameraMotionSensor, SensedCamera, event_input};
