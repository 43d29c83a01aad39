//! What a step shows the agent: detectors and shadow controller, observation, info and the episode's scoring.

use loomlab_agents::{ContinuousAction, DiscreteAction, SelfMotion, SensedCamera, VelocityCommand};
use loomlab_detector::Frame;
use loomlab_scenarios::metrics::{GroundTruth, TraceSample, score_detector_episode};
use loomlab_scenarios::reference::INDICATOR_THRESHOLD;
use loomlab_sim::StepOutput;

use super::step::deviation;
use super::{AGENT_LABEL, EpisodeSummary, EscapeEnv, Observation, ROBOT_LIMIT, SIGNAL_LIMIT, StepInfo};
use crate::features::{DecisionFrame, ObsMode, RowDecision, decision_features};
use crate::{EnvError, RewardTerms};
use loomlab_detector::{ImageRegion, PerceivedObject};

/// A detector value for the observation: finite, clamped into ±[`SIGNAL_LIMIT`] (non-finite: 0).
fn finite_or_zero(v: f64) -> f32 {
    if v.is_finite() {
        (v as f32).clamp(-SIGNAL_LIMIT, SIGNAL_LIMIT)
    } else {
        0.0
    }
}

fn wrap_angle(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

/// 8-bit grey level of a luminance in [0, 1] (the simulator's rounding).
fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The manoeuvre action ([`crate::MANOEUVRE_ACTIONS`]) closest in meaning to `command` given the
/// cruise command: cruise, a dodge by the side it moves or turns to, reverse when it drives
/// backwards, else stop.
fn manoeuvre_index(command: VelocityCommand, cruise: VelocityCommand) -> usize {
    const EPS: f64 = 1e-9;
    if command == cruise {
        0
    } else if command.lateral_mps > cruise.lateral_mps + EPS || command.yaw_rate_rps > cruise.yaw_rate_rps + EPS {
        1
    } else if command.lateral_mps < cruise.lateral_mps - EPS || command.yaw_rate_rps < cruise.yaw_rate_rps - EPS {
        2
    } else if command.forward_mps < -EPS {
        4
    } else {
        3
    }
}

impl EscapeEnv {
    /// Steps the detectors (not on the reset frame), the shadow controller and the bookkeeping.
    /// The frame's pixels are moved into the detectors' frame (no copy): `out.frame` is empty
    /// afterwards.
    pub(super) fn process(
        &mut self,
        out: &mut StepOutput,
        done: bool,
        terms: RewardTerms,
    ) -> Result<(Observation, StepInfo), EnvError> {
        let n = self.n as usize;
        let r = self.running.as_ref().expect("process() runs inside an episode");
        let reference = r.reference.and_then(|id| out.truth.get(id));
        let ttc_s = reference.and_then(|t| t.ttc_s).map(f64::from);
        let angular_size_deg = reference.map(|t| f64::from(t.angular_size_deg));
        let cruise_now = r.spec.cruise.command_at(out.t_s);
        // the camera's pose and shake as the robot's odometry and inertial sensor know them (the
        // detectors' efference copy and the deciders' self-motion, as in the scenario runner)
        let camera = SensedCamera::of(&r.sim);
        let nd = self.detectors.len();
        let mut signals = Vec::with_capacity(nd);
        let mut alarm = Vec::with_capacity(nd);
        let mut theta_hat = None;
        let mut looming_side = None;
        let decision_mode = self.options.obs_mode == ObsMode::Decision;
        let mut rows: Vec<RowDecision> = Vec::new();
        let mut track: Option<ImageRegion> = None;
        let mut objects: Vec<PerceivedObject> = Vec::new();
        let (controller_continuous, controller_discrete, controller_manoeuvre);
        // the observed frame (when asked for) before the pixels move into the detectors' frame
        let frame_u8: Option<Vec<u8>> = self
            .options
            .observe_frames
            .then(|| out.frame.iter().map(|&v| to_u8(v)).collect());
        let events_u16: Option<Vec<u16>> =
            (self.options.observe_frames && r.sim.event_stream().is_some()).then(|| match r.sim.events() {
                Some(p) => p.on_counts.iter().chain(&p.off_counts).copied().collect(),
                None => vec![0; 2 * n * n],
            });
        if out.frame_index == 0 {
            // the reset frame: detectors see their first frame in the first step
            for (names, d) in self.signal_names.iter().zip(&self.detectors) {
                signals.push(vec![0.0; names.len()]);
                alarm.push(false);
                if decision_mode {
                    rows.push(RowDecision::idle(d.threshold));
                }
            }
            controller_continuous = self.normalised(cruise_now);
            controller_discrete = DiscreteAction::None;
            controller_manoeuvre = 0;
        } else {
            let frame = Frame::from_f32(n, std::mem::take(&mut out.frame))?;
            // the robot's own motion during the last period, as the agent's controller sees it
            let last = self.agent.controller().last_command().unwrap_or(cruise_now);
            let motion = SelfMotion::of(last, camera.shake_rad);
            // with an event camera every detector also gets the period's events (the frame rows
            // ignore them)
            let mut buf = Vec::new();
            let events = r.sim.events().map(|p| loomlab_agents::event_input(p, &mut buf));
            let step = self
                .agent
                .step_posed_events(out.t_s, &frame, events.as_ref(), cruise_now, Some(&camera))?;
            for d in self.detectors.iter_mut() {
                let s = &step.signals[d.instance];
                let raw = d.trigger.value(s).unwrap_or(f64::NAN);
                // a stateful row's value is its decider's, as the agent computes it
                let decided = d.decider.as_mut().map(|decider| {
                    let decision =
                        decider.decide_on_detector(out.t_s, raw, step.looming_side, s.region.as_ref(), motion);
                    (decision, decider.confirmations())
                });
                let value = decided.map_or(raw, |(decision, _)| decision.value);
                alarm.push(value >= d.threshold);
                if decision_mode {
                    rows.push(RowDecision {
                        value,
                        threshold: d.threshold,
                        theta_hat_deg: s.angular_size_deg,
                        decision: decided.map(|(decision, _)| decision),
                        confirmations: decided.and_then(|(_, c)| c),
                    });
                    if track.is_none() && s.region.is_some() {
                        track = s.region;
                        objects.clone_from(&s.objects);
                    }
                }
                d.trace.push(TraceSample {
                    t_s: out.t_s,
                    signal: value,
                    ttc_s,
                    angular_size_deg: angular_size_deg.filter(|v| v.is_finite()),
                });
                if theta_hat.is_none() {
                    theta_hat = s.angular_size_deg;
                }
                let mut v = Vec::with_capacity(1 + s.aux.len());
                v.push(finite_or_zero(s.output));
                v.extend(s.aux.iter().map(|(_, x)| finite_or_zero(*x)));
                signals.push(v);
            }
            looming_side = step.looming_side;
            controller_continuous = self.normalised(step.command);
            controller_discrete = DiscreteAction::from_command(step.command, cruise_now);
            controller_manoeuvre = manoeuvre_index(step.command, cruise_now);
        }
        let r = self.running.as_ref().expect("process() runs inside an episode");
        let (dx, dy) = (out.robot.x_m - r.start.x_m, out.robot.y_m - r.start.y_m);
        let (s0, c0) = r.start.yaw_rad.sin_cos();
        let cmd = r.last_command;
        let robot = [
            (dx * c0 + dy * s0) as f32,
            (-dx * s0 + dy * c0) as f32,
            wrap_angle(out.robot.yaw_rad - r.start.yaw_rad) as f32,
            cmd.forward_mps as f32,
            cmd.yaw_rate_rps as f32,
            cmd.lateral_mps as f32,
            out.t_s as f32,
        ]
        .map(|v| v.clamp(-ROBOT_LIMIT, ROBOT_LIMIT));
        let dodging = deviation(cmd, r.last_cruise)
            .iter()
            .any(|d| d.abs() > crate::reward::DODGE_TOLERANCE);
        let obs = Observation {
            signals,
            theta_hat_deg: theta_hat.map(finite_or_zero).unwrap_or(0.0),
            alarm,
            robot,
            frame: frame_u8,
            events: events_u16,
            features: None,
        };
        let obs = match self.options.obs_mode {
            ObsMode::Raw => obs,
            ObsMode::Privileged => {
                let dt = r.spec.world.dt();
                let duration_s = r.frames as f64 * dt;
                let features = self
                    .privileged
                    .features(&out.truth, &obs, dt, duration_s, &self.options.action, cmd);
                Observation {
                    features: Some(features),
                    ..obs
                }
            }
            ObsMode::Decision => {
                let dt = r.spec.world.dt();
                let duration_s = r.frames as f64 * dt;
                let frame = DecisionFrame {
                    t_s: out.t_s,
                    track: track.as_ref(),
                    objects: &objects,
                    looming_side,
                };
                let features = decision_features(&rows, &frame, &obs, duration_s, &self.options.action, cmd);
                Observation {
                    features: Some(features),
                    ..obs
                }
            }
            ObsMode::Normalized => {
                let dt = r.spec.world.dt();
                let duration_s = r.frames as f64 * dt;
                let features = self
                    .normalizer
                    .features(&obs, looming_side, dt, duration_s, &self.options.action, cmd);
                Observation {
                    features: Some(features),
                    ..obs
                }
            }
        };
        let outcome = if done {
            let truth = GroundTruth {
                threat: r.t_contact_s.is_some(),
                t_contact_s: r.t_contact_s,
                t_deadline_s: r.t_deadline_s,
                collision: r.collision,
            };
            let mut scored = Vec::with_capacity(nd);
            for d in &self.detectors {
                scored.push(score_detector_episode(
                    &d.label,
                    d.threshold,
                    &d.trace,
                    &truth,
                    &r.spec.scoring,
                )?);
            }
            let agent = score_detector_episode(
                AGENT_LABEL,
                INDICATOR_THRESHOLD,
                &r.agent_trace,
                &truth,
                &r.spec.scoring,
            )?;
            Some(EpisodeSummary {
                threat: truth.threat,
                t_contact_s: truth.t_contact_s,
                collision: r.collision,
                evaded: truth.threat && !r.collision,
                steps: r.steps,
                episode_return: r.episode_return,
                detectors: scored,
                agent,
            })
        } else {
            None
        };
        let info = StepInfo {
            t_s: out.t_s,
            step: r.steps,
            threat: r.t_contact_s.is_some(),
            t_contact_s: r.t_contact_s,
            ttc_s,
            angular_size_deg,
            collision: r.collision,
            episode: r.spec.index,
            dodging,
            controller_continuous,
            controller_discrete,
            controller_manoeuvre,
            reward_terms: terms,
            outcome,
        };
        if let Some(r) = self.running.as_mut() {
            r.last_t_s = out.t_s;
            r.last_ttc_s = ttc_s;
            r.last_angular_size_deg = angular_size_deg.filter(|v| v.is_finite());
            r.last_looming_side = looming_side;
        }
        Ok((obs, info))
    }

    /// A command as a normalised continuous action (clamped into [-1, 1]).
    fn normalised(&self, c: VelocityCommand) -> [f32; 3] {
        ContinuousAction::from_command(c, &self.options.action).0
    }
}
