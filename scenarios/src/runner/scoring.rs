//! Steps 3 and 4 of an episode: each row's closed loop (from the open loop, a replay or a
//! simulated tail) and its scores.

use loomlab_agents::{EscapeController, TriggerSignal};

use super::Ctx;
use super::head_on::HeadOnApproach;
use super::reference::ideal_tail;
use super::rows::{Row, Tail};
use super::trace::ClosedLoop;
use crate::deadline::{EscapeDeadline, controller_for, manoeuvre_set, replay_trigger};
use crate::error::RunError;
use crate::metrics::{DetectorEpisode, GroundTruth, ThetaAccuracy, TraceSample, score_detector_episode};
use crate::truth::EpisodeTruth;

/// What every row of an episode is scored against.
pub(super) struct EpisodeScoring<'a> {
    /// Frame times (s).
    pub(super) t_s: &'a [f64],
    /// The reference object's true time to contact per frame (s).
    pub(super) ref_ttc: &'a [Option<f64>],
    /// The reference object's true angular size per frame (degrees; NaN without one).
    pub(super) ref_theta: &'a [f64],
    /// The first time the threat is in the camera's view (s; `None`: no threat, or not in view
    /// before contact).
    pub(super) t_in_view_s: Option<f64>,
    pub(super) ground_truth: &'a GroundTruth,
    pub(super) episode_truth: &'a EpisodeTruth,
    pub(super) deadline: Option<&'a EscapeDeadline>,
    pub(super) approach: Option<&'a HeadOnApproach>,
    /// The open loop's first contact frame.
    pub(super) contact_frame: Option<usize>,
    /// The open loop's looming side per frame.
    pub(super) sides: &'a [Option<f32>],
}

impl EpisodeScoring<'_> {
    /// The closed loop of `row` with first alarm `first_alarm` (step 4 of the module docs of
    /// [`super`]): it follows from the open loop when the row never alarms or alarms at or after
    /// the contact frame; else the oracle's deadline replay, an ideal row's physics-only tail, or
    /// the detector's simulated tail `tail` (run in lockstep beforehand).
    pub(super) fn closed_loop(
        &self,
        c: &Ctx<'_>,
        row: &Row<'_>,
        first_alarm: Option<usize>,
        escape: &EscapeController,
        truth: &[Vec<loomlab_sim::ObjectTruth>],
        tail: Option<ClosedLoop>,
    ) -> Result<ClosedLoop, RunError> {
        let ep = c.ep;
        let from_open_loop = |triggers| ClosedLoop {
            label: row.label.clone(),
            simulated: false,
            triggers,
            collision: self.episode_truth.impact(),
            frames_rendered: 0,
        };
        Ok(match (first_alarm, self.contact_frame) {
            (None, _) => from_open_loop(0),
            (Some(ka), Some(kc)) if ka >= kc => from_open_loop(1),
            (Some(ka), _) => match &row.tail {
                Tail::Replay => ClosedLoop {
                    label: row.label.clone(),
                    simulated: true,
                    triggers: 1,
                    collision: self.oracle_replay(ep, escape, ka).map_err(|e| c.sim(e))?,
                    frames_rendered: 0,
                },
                Tail::Ideal(kind) => ideal_tail(c, &row.label, *kind, truth, ka)?,
                Tail::Detector(_) => tail.ok_or(RunError::Interrupted)?,
            },
        })
    }

    /// The oracle's closed loop from its alarm at frame `ka` (the deadline frame): the manoeuvre of
    /// the set that evades from there, else the controller's own rule.
    fn oracle_replay(
        &self,
        ep: &crate::schema::EpisodeSpec,
        escape: &EscapeController,
        ka: usize,
    ) -> Result<Option<crate::truth::Impact>, loomlab_sim::SimError> {
        match self.deadline.and_then(|d| d.manoeuvre) {
            Some(candidate) => {
                let looming = manoeuvre_set(escape, self.sides[ka])
                    .into_iter()
                    .find(|(c, _)| c.same_as(&candidate))
                    .and_then(|(_, side)| side);
                replay_trigger(ep, ep.seed, &controller_for(escape, candidate), ka, looming)
            }
            None => replay_trigger(ep, ep.seed, escape, ka, self.sides[ka]),
        }
    }

    /// The scores of `row` with closed loop `cl` (a row that names its objects is scored on its
    /// alarms about the threat).
    pub(super) fn score(&self, c: &Ctx<'_>, row: &Row<'_>, cl: &ClosedLoop) -> Result<DetectorEpisode, RunError> {
        let ep = c.ep;
        let scored_signal = row.about_threat.as_ref().unwrap_or(&row.signal);
        let samples: Vec<TraceSample> = (0..self.t_s.len())
            .map(|k| TraceSample {
                t_s: self.t_s[k],
                signal: scored_signal[k],
                ttc_s: self.ref_ttc[k],
                angular_size_deg: Some(self.ref_theta[k]).filter(|v| v.is_finite()),
            })
            .collect();
        let mut d = score_detector_episode(&row.label, row.threshold, &samples, self.ground_truth, &ep.scoring)
            .map_err(|source| RunError::Scoring {
                scenario: ep.scenario.clone(),
                episode: ep.index,
                source,
            })?;
        let first_alarm_about_threat = scored_signal.iter().position(|&s| s >= row.threshold);
        d.collision = cl.collision.is_some();
        d.impact_speed_mps = cl.collision.map(|i| i.impact_speed_mps);
        d.impulse_ns = cl.collision.and_then(|i| i.impulse_ns);
        d.triggers = cl.triggers as u64;
        d.theta_required_deg = self
            .deadline
            .and_then(|dl| dl.frame)
            .and_then(|k| self.ref_theta.get(k).copied())
            .filter(|v| v.is_finite());
        d.t_in_view_s = self.t_in_view_s;
        if let Some(a) = self.approach {
            d.l_over_v_s = Some(a.l_over_v_s);
            d.eye_ttc_at_alarm_s = first_alarm_about_threat.and_then(|k| a.eye_ttc_s(k));
        }
        let theta_hat = match (&row.tail, row.trigger) {
            (Tail::Detector(_), TriggerSignal::AngularSizeDeg | TriggerSignal::Tau) => {
                Some(row.raw.as_ref().unwrap_or(&row.signal))
            }
            _ => None,
        };
        if self.ground_truth.threat
            && let Some(theta_hat) = theta_hat
        {
            let pairs: Vec<(f64, f64)> = theta_hat.iter().copied().zip(self.ref_theta.iter().copied()).collect();
            (
                d.theta_rel_err_median,
                d.theta_rel_err_p90,
                d.theta_at_first_estimate_deg,
            ) = ThetaAccuracy::episode(&pairs);
        }
        Ok(d)
    }
}
