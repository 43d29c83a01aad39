//! The step loop: advancing one camera period under a command (either physics model) and reporting it.

use super::{Sim, StepOutput};
use crate::SimError;
use crate::dynamics::PhysicsMode;
use crate::robot::Command;
use crate::truth::Contact;

impl Sim {
    /// Advances one camera period under `command`, renders the new view and computes ground truth.
    ///
    /// With dynamic physics the command is the drive's target velocity (reached within the robot's
    /// acceleration limits), except at the first step: an episode starts in steady state, the robot
    /// already moving with its first command (clamped to its speed limits).
    pub fn step(&mut self, command: &Command) -> Result<StepOutput, SimError> {
        let new_contacts = self.advance(command)?;
        self.render_current()?;
        Ok(self.output(new_contacts))
    }

    /// Advances the world one camera period under `command` (physics and contacts, no rendering);
    /// returns the contacts that started.
    pub(super) fn advance(&mut self, command: &Command) -> Result<Vec<Contact>, SimError> {
        command.validate()?;
        // the view before the step enters the perception queue first (an episode's first frame
        // fills it, whether or not it was observed)
        self.sync_views();
        // actuation latency: the command given now acts that many frames later
        let command = if self.world.actuation_delay > 0 {
            *self.commands.push(*command)
        } else {
            *command
        };
        self.command = command;
        let mut new_contacts = match self.world.physics {
            PhysicsMode::Analytic => self.advance_analytic(&command),
            PhysicsMode::Dynamic => self.advance_dynamic(&command),
        };
        // perception latency: every view enters the queue (physics-only replays included, so
        // that a renderer attached later draws the delayed views)
        self.sync_views();
        new_contacts.sort_by(|a, b| a.t_s.total_cmp(&b.t_s).then(a.object_id.cmp(&b.object_id)));
        self.contacts.extend(new_contacts.iter().cloned());
        Ok(new_contacts)
    }

    /// The output of a step that found `new_contacts`, with the current frame.
    pub(super) fn output(&self, new_contacts: Vec<Contact>) -> StepOutput {
        StepOutput {
            t_s: self.t,
            frame_index: self.step_index,
            n: self.world.camera.n,
            frame: self.frame.clone(),
            truth: if self.ground_truth {
                self.truth(&self.robot_velocity.as_command())
            } else {
                Vec::new()
            },
            contacts: new_contacts,
            robot: self.robot_state(),
        }
    }

    /// The end time of substep `s` (1-based) of the current step.
    pub(super) fn substep_time(&self, s: u64) -> f64 {
        let substeps = u64::from(self.world.substeps);
        ((self.step_index * substeps + s) as f64) / (substeps as f64 / self.world.dt)
    }

    /// Renders and reports the current state without advancing time (e.g. the frame at t = 0).
    pub fn observe(&mut self) -> Result<StepOutput, SimError> {
        self.render_current()?;
        Ok(self.observation())
    }

    /// What [`Sim::observe`] reports, with the current frame.
    pub(super) fn observation(&self) -> StepOutput {
        StepOutput {
            t_s: self.t,
            frame_index: self.step_index,
            n: self.world.camera.n,
            frame: self.frame.clone(),
            truth: self.truth(&self.robot_velocity.as_command()),
            contacts: Vec::new(),
            robot: self.robot_state(),
        }
    }
}
