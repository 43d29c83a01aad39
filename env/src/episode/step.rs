//! Stepping: actions to velocity commands, one camera period, reward and termination.

#[cfg(doc)]
use loomlab_agents::EscapeConfig;
use loomlab_agents::{Candidate, ContinuousAction, DiscreteAction, DodgeOffset, DodgeSide, VelocityCommand};
use loomlab_scenarios::metrics::{TIME_EPS_S, TraceSample};
use loomlab_scenarios::reference::INDICATOR_THRESHOLD;
use loomlab_sim::{Sim, StepOutput};

use super::{Action, EscapeEnv, StepInfo, StepResult};
#[cfg(doc)]
use crate::EnvOptions;
use crate::reward::StepFacts;
use crate::{ActionKind, EnvError};

/// The result of two consecutive periods of one [`EscapeEnv::step`]: the second's observation and
/// info, the summed reward terms.
pub(crate) fn combine_steps(r: StepResult, next: StepResult) -> StepResult {
    let terms = r.info.reward_terms.plus(&next.info.reward_terms);
    StepResult {
        reward: terms.total(),
        info: StepInfo {
            reward_terms: terms,
            ..next.info
        },
        ..next
    }
}

pub(super) fn deviation(a: VelocityCommand, b: VelocityCommand) -> [f64; 3] {
    [
        a.forward_mps - b.forward_mps,
        a.yaw_rate_rps - b.yaw_rate_rps,
        a.lateral_mps - b.lateral_mps,
    ]
}

impl EscapeEnv {
    /// Applies an agent action for [`EnvOptions::action_repeat`] camera periods (a discrete dodge
    /// or stop for [`EnvOptions::dodge_hold_s`] when set; fewer when the episode ends first): the
    /// detectors see every frame, the result holds the last observation and info, the summed
    /// reward and reward terms.
    pub fn step(&mut self, action: Action) -> Result<StepResult, EnvError> {
        let command = self.command_for(action)?;
        let mut r = self.step_command(command)?;
        if let Some(run) = self.running.as_mut() {
            run.actions.push(action);
        }
        for _ in 1..self.hold_for(action) {
            if r.terminated || r.truncated {
                break;
            }
            // the discrete actions follow the cruise command of each period
            let next = self.step_command(self.command_for(action)?)?;
            r = combine_steps(r, next);
        }
        Ok(r)
    }

    /// Camera periods one [`step`](Self::step) with `action` lasts (fewer when the episode ends).
    pub(crate) fn hold_for(&self, action: Action) -> u32 {
        match action {
            Action::Discrete(i) if i != 0 && self.options.dodge_hold_s > 0.0 => {
                let dt = self.dt();
                ((self.options.dodge_hold_s / dt).round() as u32).max(self.options.action_repeat)
            }
            _ => self.options.action_repeat,
        }
    }

    /// Records `action` as the one the last [`step`](Self::step) was given (for
    /// [`snapshot`](Self::snapshot)): what the vector environment's batched step does after the
    /// first period.
    pub(crate) fn record_action(&mut self, action: Action) {
        if let Some(run) = self.running.as_mut() {
            run.actions.push(action);
        }
    }

    /// The velocity command an action maps to now (validating it).
    pub fn command_for(&self, action: Action) -> Result<VelocityCommand, EnvError> {
        let cfg = &self.options.action;
        match (self.options.action_kind, action) {
            (ActionKind::Continuous, Action::Continuous(a)) => {
                let a = ContinuousAction(a);
                Ok(if self.options.clip_actions {
                    a.to_command_clamped(cfg)?
                } else {
                    a.to_command(cfg)?
                })
            }
            (ActionKind::Discrete, Action::Discrete(i)) => {
                Ok(DiscreteAction::from_index(i)?.to_command(self.cruise(), cfg))
            }
            (ActionKind::Manoeuvre, Action::Discrete(i)) => self.manoeuvre_command(i),
            (kind, a) => Err(EnvError::ActionKind {
                expected: kind.as_str(),
                got: a.kind_name(),
            }),
        }
    }

    /// The command of manoeuvre action `index` now ([`crate::MANOEUVRE_ACTIONS`]): the scenario's
    /// escape controller's command for that manoeuvre, its sidestep held at the scene's
    /// `max_dodge_offset_m` as the rows' are ([`EscapeConfig::command_within_offset`], the first
    /// row's configuration, the episode's robot base, the offset the agent's commands have taken
    /// the robot to); `plan` runs the candidate the shadow controller's
    /// planner chooses now, preferring the dodge away from the looming side
    /// ([`loomlab_agents::EscapeController::planned_candidate`]).
    pub(crate) fn manoeuvre_command(&self, index: i64) -> Result<VelocityCommand, EnvError> {
        let cruise = self.cruise();
        let count = crate::MANOEUVRE_ACTIONS.len();
        let Some(i) = usize::try_from(index).ok().filter(|&i| i < count) else {
            return Err(EnvError::InvalidManoeuvre { index });
        };
        let controller = self.agent.controller();
        let config = controller.config();
        let (facts, t_s, seen, dodge) = match &self.running {
            Some(r) => (r.spec.facts, r.last_t_s, r.last_looming_side, r.dodge),
            None => (*controller.facts(), 0.0, None, DodgeOffset::default()),
        };
        let candidate = match i {
            0 => return Ok(cruise),
            1 => Candidate::dodge(DodgeSide::Left),
            2 => Candidate::dodge(DodgeSide::Right),
            3 => Candidate::ALL[2],
            4 => Candidate::ALL[3],
            _ => {
                let side = DodgeSide::away_from(seen, config.side_deadband, config.default_side);
                controller.planned_candidate(t_s, side, cruise)
            }
        };
        Ok(config.command_within_offset(candidate, cruise, &facts, &dodge))
    }

    /// Applies a velocity command for one camera period (the Rust-side interface; only actions
    /// given to [`step`](Self::step) are recorded for [`snapshot`](Self::snapshot)).
    pub fn step_command(&mut self, command: VelocityCommand) -> Result<StepResult, EnvError> {
        let cruise = self.begin_command(command)?;
        let r = self.running.as_mut().expect("begin_command checked the episode");
        let out = r.sim.step(&command.to_sim())?;
        self.finish_command(command, cruise, out)
    }

    /// The simulator of the running episode (the vector environment steps them in one batch
    /// between [`Self::begin_command`] and [`Self::finish_command`]).
    pub(crate) fn sim_mut(&mut self) -> Option<&mut Sim> {
        self.running.as_mut().map(|r| &mut r.sim)
    }

    /// [`step_command`](Self::step_command) up to the simulator step: checks the command and the
    /// episode's state, records the agent sample; returns the cruise command of the period.
    pub(crate) fn begin_command(&mut self, command: VelocityCommand) -> Result<VelocityCommand, EnvError> {
        if !command.is_finite() {
            return Err(EnvError::option(
                "command",
                format!("{command:?}"),
                "velocity commands must be finite",
            ));
        }
        let r = match self.running.as_mut() {
            None => return Err(EnvError::State("step() called before reset(); call reset() first")),
            Some(r) if r.done => {
                return Err(EnvError::State(
                    "step() called after the episode ended (terminated or truncated); call reset()",
                ));
            }
            Some(r) => r,
        };
        let cruise = r.spec.cruise.command_at(r.sim.time());
        let departed = deviation(command, cruise)
            .iter()
            .any(|d| d.abs() > crate::reward::DODGE_TOLERANCE);
        r.agent_trace.push(TraceSample {
            t_s: r.last_t_s,
            signal: if departed { INDICATOR_THRESHOLD } else { 0.0 },
            ttc_s: r.last_ttc_s,
            angular_size_deg: r.last_angular_size_deg,
        });
        Ok(cruise)
    }

    /// [`step_command`](Self::step_command) after the simulator step `out`: reward, termination,
    /// the detectors and the observation.
    pub(crate) fn finish_command(
        &mut self,
        command: VelocityCommand,
        cruise: VelocityCommand,
        mut out: StepOutput,
    ) -> Result<StepResult, EnvError> {
        let max_steps = self.options.max_episode_steps;
        let Some(r) = self.running.as_mut() else {
            return Err(EnvError::State("step() called before reset(); call reset() first"));
        };
        let dt = r.spec.world.dt();
        r.steps += 1;
        r.dodge
            .advance(command.lateral_mps - cruise.lateral_mps, dt, r.spec.facts.accel_mps2);
        r.last_command = command;
        r.last_cruise = cruise;
        let collision = !r.collision && out.first_collision().is_some();
        r.collision |= collision;
        let (s0, c0) = r.start.yaw_rad.sin_cos();
        let progress_m = (out.robot.x_m - r.last_robot.x_m) * c0 + (out.robot.y_m - r.last_robot.y_m) * s0;
        r.last_robot = out.robot;
        let first_dodge = !r.agent_trace[..r.agent_trace.len() - 1]
            .iter()
            .any(|s| s.signal >= INDICATOR_THRESHOLD);
        let window_s = self.options.reward.timely_dodge_window_s;
        let in_window = r.t_contact_s.is_some()
            && r.t_deadline_s.is_some_and(|td| {
                let end = td - r.spec.scoring.lead_margin_s + TIME_EPS_S;
                r.last_t_s <= end && r.last_t_s >= end - window_s - 2.0 * TIME_EPS_S
            });
        let facts = StepFacts {
            dt,
            collision,
            progress_m,
            deviation: deviation(command, cruise),
            threat: r.t_contact_s.is_some(),
            first_dodge,
            in_window,
            bonus_unpaid: !r.timely_paid,
        };
        let terms = self.options.reward.terms(&facts);
        r.timely_paid |= terms.timely_dodge > 0.0;
        r.episode_return += terms.total();
        let terminated = r.collision || r.steps >= r.frames;
        let truncated = !terminated && max_steps.is_some_and(|m| r.steps >= m);
        r.done = terminated || truncated;
        let done = r.done;
        let (obs, info) = self.process(&mut out, done, terms)?;
        Ok(StepResult {
            obs,
            reward: terms.total(),
            terminated,
            truncated,
            info,
        })
    }
}
