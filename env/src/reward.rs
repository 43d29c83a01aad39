//! The reward of the step-by-step environment ([`super::EscapeEnv`]).
//!
//! Per step of length `dt` (one camera period) the reward is the sum of
//! - `+ survival_per_s · dt` while the robot is untouched (also on the last step of an episode
//!   that ends without a collision; not on the collision step),
//! - `+ progress_per_m · Δs`, with Δs the distance travelled this step along the robot's start
//!   heading (negative when it backs up),
//! - `− effort_per_s · ‖u − u_cruise‖² · dt`, the control effort: squared deviation of the applied
//!   command `u = (forward m/s, yaw rate rad/s, lateral m/s)` from the scenario's cruise command,
//! - `− unnecessary_dodge_per_s · dt` on every step whose command deviates from the cruise command
//!   (by more than [`DODGE_TOLERANCE`] in any component) in an episode **without** a threat (ground
//!   truth), i.e. the cost of escaping from nothing,
//! - `− unnecessary_dodge_penalty` once, on the first such step of an episode without a threat
//!   (the cost of a false alarm as the scores count it: any departure from cruising),
//! - `− collision_penalty` once, on the step in which the robot is first touched,
//! - `+ timely_dodge_bonus` once, on the first dodging step of an episode with an evadable threat
//!   whose observation (the one the dodge was chosen on) lies in the last `timely_dodge_window_s`
//!   before the threat's escape deadline less the scoring's lead margin (a dodge there is a hit,
//!   and an informed one: an earlier dodge is a hit by luck, before the object could be seen to
//!   come). This credits a correct escape at the time of the decision: the collision it avoids is
//!   only paid (or not) up to ~1 s later, many decisions on. The escape deadline is the runner's,
//!   from physics-only replays (`loomlab_scenarios::deadline`): ground truth used only in the
//!   reward, never in the observation.
//!
//! Every term is reported separately in [`RewardTerms`] so that agents and tests can see where the
//! reward came from.

use serde::{Deserialize, Serialize};

use super::EnvError;

/// A command component that differs from the cruise command by more than this counts as a dodge.
pub const DODGE_TOLERANCE: f64 = 1e-6;

/// Weights of the reward terms (see the module docs). All must be finite and ≥ 0.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RewardConfig {
    /// Subtracted once when the robot is touched. Default 10.
    pub collision_penalty: f64,
    /// Reward per second without a collision. Default 1.
    pub survival_per_s: f64,
    /// Reward per metre travelled along the start heading. Default 0 (off).
    pub progress_per_m: f64,
    /// Cost per second of the squared deviation of the command from the cruise command. Default 0.05.
    pub effort_per_s: f64,
    /// Cost per second of dodging (deviating from the cruise command) in an episode without a threat.
    /// Default 1.
    pub unnecessary_dodge_per_s: f64,
    /// Subtracted once, on the first dodging step of an episode without a threat (a false alarm).
    /// Default 0 (off).
    pub unnecessary_dodge_penalty: f64,
    /// Added once, on the first dodging step of an episode with an evadable threat within
    /// `timely_dodge_window_s` before its escape deadline (see the module docs). Default 0 (off).
    pub timely_dodge_bonus: f64,
    /// The window before the escape deadline (less the lead margin) in which a dodge earns
    /// `timely_dodge_bonus` (s). Default 0.5.
    pub timely_dodge_window_s: f64,
}

impl Default for RewardConfig {
    fn default() -> Self {
        Self {
            collision_penalty: 10.0,
            survival_per_s: 1.0,
            progress_per_m: 0.0,
            effort_per_s: 0.05,
            unnecessary_dodge_per_s: 1.0,
            unnecessary_dodge_penalty: 0.0,
            timely_dodge_bonus: 0.0,
            timely_dodge_window_s: 0.5,
        }
    }
}

impl RewardConfig {
    /// Checks every weight; the error names the key.
    pub fn validate(&self) -> Result<(), EnvError> {
        for (key, v) in [
            ("reward.collision_penalty", self.collision_penalty),
            ("reward.survival_per_s", self.survival_per_s),
            ("reward.progress_per_m", self.progress_per_m),
            ("reward.effort_per_s", self.effort_per_s),
            ("reward.unnecessary_dodge_per_s", self.unnecessary_dodge_per_s),
            ("reward.unnecessary_dodge_penalty", self.unnecessary_dodge_penalty),
            ("reward.timely_dodge_bonus", self.timely_dodge_bonus),
            ("reward.timely_dodge_window_s", self.timely_dodge_window_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(EnvError::InvalidOption {
                    key: key.into(),
                    value: v.to_string(),
                    reason: "reward weights must be finite numbers >= 0 (the sign of each term is fixed)".into(),
                });
            }
        }
        Ok(())
    }
}

/// The terms of one step's reward (their sum is the reward).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RewardTerms {
    /// `−collision_penalty` on the collision step, else 0.
    pub collision: f64,
    /// Survival reward of this step.
    pub survival: f64,
    /// Progress reward of this step.
    pub progress: f64,
    /// Control-effort cost of this step (≤ 0).
    pub effort: f64,
    /// Unnecessary-dodge cost of this step (≤ 0).
    pub unnecessary_dodge: f64,
    /// The timely-dodge bonus of this step (≥ 0).
    pub timely_dodge: f64,
}

impl RewardTerms {
    /// The reward: the sum of the terms.
    pub fn total(&self) -> f64 {
        self.collision + self.survival + self.progress + self.effort + self.unnecessary_dodge + self.timely_dodge
    }

    /// The term-by-term sum of two steps' terms (the terms of an action repeated over several
    /// camera periods).
    pub fn plus(&self, o: &RewardTerms) -> RewardTerms {
        RewardTerms {
            collision: self.collision + o.collision,
            survival: self.survival + o.survival,
            progress: self.progress + o.progress,
            effort: self.effort + o.effort,
            unnecessary_dodge: self.unnecessary_dodge + o.unnecessary_dodge,
            timely_dodge: self.timely_dodge + o.timely_dodge,
        }
    }
}

/// What the reward of one step depends on.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepFacts {
    pub dt: f64,
    pub collision: bool,
    pub progress_m: f64,
    /// Applied command minus cruise command: (forward, yaw rate, lateral).
    pub deviation: [f64; 3],
    pub threat: bool,
    /// No earlier step of the episode dodged.
    pub first_dodge: bool,
    /// The threat is evadable and this step's observation lies in the bonus window before its
    /// escape deadline less the lead margin.
    pub in_window: bool,
    /// No earlier step of the episode earned the timely-dodge bonus.
    pub bonus_unpaid: bool,
}

impl StepFacts {
    pub fn dodging(&self) -> bool {
        self.deviation.iter().any(|d| d.abs() > DODGE_TOLERANCE)
    }
}

impl RewardConfig {
    pub(crate) fn terms(&self, f: &StepFacts) -> RewardTerms {
        let effort: f64 = f.deviation.iter().map(|d| d * d).sum();
        RewardTerms {
            collision: if f.collision { -self.collision_penalty } else { 0.0 },
            survival: if f.collision { 0.0 } else { self.survival_per_s * f.dt },
            progress: self.progress_per_m * f.progress_m,
            effort: -self.effort_per_s * effort * f.dt,
            unnecessary_dodge: if !f.threat && f.dodging() {
                -self.unnecessary_dodge_per_s * f.dt
                    - if f.first_dodge {
                        self.unnecessary_dodge_penalty
                    } else {
                        0.0
                    }
            } else {
                0.0
            },
            timely_dodge: if f.threat && f.bonus_unpaid && f.in_window && f.dodging() {
                self.timely_dodge_bonus
            } else {
                0.0
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facts() -> StepFacts {
        StepFacts {
            dt: 0.01,
            collision: false,
            progress_m: 0.02,
            deviation: [0.0; 3],
            threat: true,
            first_dodge: false,
            in_window: false,
            bonus_unpaid: true,
        }
    }

    #[test]
    fn terms_follow_the_documented_formulas() {
        let cfg = RewardConfig {
            progress_per_m: 2.0,
            ..Default::default()
        };
        let t = cfg.terms(&facts());
        assert_eq!(t.survival, 0.01);
        assert_eq!(t.progress, 0.04);
        assert_eq!((t.collision, t.effort, t.unnecessary_dodge), (0.0, 0.0, 0.0));
        assert!((t.total() - 0.05).abs() < 1e-15);

        let dodge = StepFacts {
            deviation: [0.0, 0.0, 1.5],
            threat: false,
            ..facts()
        };
        let t = cfg.terms(&dodge);
        assert!((t.effort + 0.05 * 2.25 * 0.01).abs() < 1e-15);
        assert_eq!(t.unnecessary_dodge, -0.01);
        // the same dodge against a real threat is not "unnecessary"
        assert_eq!(cfg.terms(&StepFacts { threat: true, ..dodge }).unnecessary_dodge, 0.0);
        // the one-time false-alarm penalty: on the first dodging step only, without a threat only
        let once = RewardConfig {
            unnecessary_dodge_penalty: 3.0,
            ..cfg.clone()
        };
        let first = StepFacts {
            first_dodge: true,
            ..dodge
        };
        assert_eq!(once.terms(&first).unnecessary_dodge, -3.01);
        assert_eq!(once.terms(&dodge).unnecessary_dodge, -0.01);
        assert_eq!(once.terms(&StepFacts { threat: true, ..first }).unnecessary_dodge, 0.0);
        assert_eq!(
            once.terms(&StepFacts {
                deviation: [0.0; 3],
                ..first
            })
            .unnecessary_dodge,
            0.0
        );

        let hit = cfg.terms(&StepFacts {
            collision: true,
            ..facts()
        });
        assert_eq!((hit.collision, hit.survival), (-10.0, 0.0));
    }

    #[test]
    fn the_timely_dodge_bonus_is_paid_once_for_a_dodge_in_time() {
        let cfg = RewardConfig {
            timely_dodge_bonus: 2.0,
            ..Default::default()
        };
        let first = StepFacts {
            deviation: [0.0, 0.0, 1.5],
            in_window: true,
            ..facts()
        };
        assert_eq!(cfg.terms(&first).timely_dodge, 2.0);
        assert!((cfg.terms(&first).total() - cfg.terms(&first).plus(&RewardTerms::default()).total()).abs() < 1e-15);
        for (what, f) in [
            (
                "once paid",
                StepFacts {
                    bonus_unpaid: false,
                    ..first
                },
            ),
            (
                "outside the window",
                StepFacts {
                    in_window: false,
                    ..first
                },
            ),
            ("without a threat", StepFacts { threat: false, ..first }),
            (
                "cruising",
                StepFacts {
                    deviation: [0.0; 3],
                    ..first
                },
            ),
        ] {
            assert_eq!(cfg.terms(&f).timely_dodge, 0.0, "{what}");
        }
        assert_eq!(
            RewardConfig::default().terms(&first).timely_dodge,
            0.0,
            "off by default"
        );
    }

    #[test]
    fn negative_weights_are_rejected_with_the_key() {
        let e = RewardConfig {
            effort_per_s: -1.0,
            ..Default::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("reward.effort_per_s"), "{e}");
    }
}
