//! Regression mode: compare a run's report with a baseline report.
//!
//! # What counts as a regression
//! For each detector of the baseline — pooled (`detectors.<id>`), per difficulty tier
//! (`tiers.<tier>.detectors.<id>`, a tier of the baseline missing now is a regression) and, if
//! [`Tolerances::per_scenario`], per scenario (`scenarios.<name>.detectors.<id>`):
//! - the detector (or scenario) is missing from the current report;
//! - `hit_rate` dropped, `false_alarm_rate` rose or `collision_rate` rose by more than the allowed
//!   change (below); or the rate was measured in the baseline but is `null` now;
//! - `auc` dropped by more than [`Tolerances::auc_drop`].
//!
//! The allowed change of a rate is `max(max_change, wilson distance)` where the Wilson distance is
//! how far the baseline's 95 % Wilson bound lies from its rate in the bad direction (rate − lower
//! bound for the hit rate, upper bound − rate for the others). So by default a change must be
//! larger than 5 percentage points **and** carry the current rate outside the baseline's 95 %
//! interval: changes a suite of that size cannot resolve are not flagged, while large suites get
//! tight checks down to the 5-point floor. For a deterministic suite in which every flipped episode
//! matters, set `wilson = false` and `max_change = 0`.
//! Improvements are never regressions; metrics that are `null` in the baseline are not compared.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::metrics::{DetectorSummary, ScoringError};
use crate::report::Report;
use crate::stats::Interval;

/// Allowed worsening of one rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RateTolerance {
    /// Absolute change (in rate units, 0..1) always allowed.
    pub max_change: f64,
    /// Also allow changes that stay within the baseline's 95 % Wilson interval.
    pub wilson: bool,
}

impl Default for RateTolerance {
    fn default() -> Self {
        Self {
            max_change: 0.05,
            wilson: true,
        }
    }
}

/// Tolerances of [`compare`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Tolerances {
    /// Allowed drop of the hit rate.
    pub hit_rate: RateTolerance,
    /// Allowed rise of the false-alarm rate.
    pub false_alarm_rate: RateTolerance,
    /// Allowed rise of the collision rate.
    pub collision_rate: RateTolerance,
    /// Allowed drop of the AUC (absolute); `None` disables the AUC check.
    pub auc_drop: Option<f64>,
    /// Also compare every scenario's per-detector summaries (not only the pooled ones).
    pub per_scenario: bool,
}

impl Default for Tolerances {
    fn default() -> Self {
        Self {
            hit_rate: RateTolerance::default(),
            false_alarm_rate: RateTolerance::default(),
            collision_rate: RateTolerance::default(),
            auc_drop: Some(0.05),
            per_scenario: true,
        }
    }
}

impl Tolerances {
    /// Check every value.
    pub fn validate(&self) -> Result<(), ScoringError> {
        let checks = [
            ("tolerances.hit_rate.max_change", Some(self.hit_rate.max_change)),
            (
                "tolerances.false_alarm_rate.max_change",
                Some(self.false_alarm_rate.max_change),
            ),
            (
                "tolerances.collision_rate.max_change",
                Some(self.collision_rate.max_change),
            ),
            ("tolerances.auc_drop", self.auc_drop),
        ];
        for (key, v) in checks {
            if let Some(v) = v
                && !(v.is_finite() && v >= 0.0)
            {
                return Err(ScoringError::InvalidConfig {
                    key,
                    value: v.to_string(),
                    reason: "must be a finite number >= 0".into(),
                });
            }
        }
        Ok(())
    }
}

/// What regressed.
#[derive(Debug, Clone, PartialEq)]
pub enum RegressionKind {
    /// The scenario is in the baseline but not in the current report.
    MissingScenario,
    /// The difficulty tier is in the baseline but not in the current report.
    MissingTier,
    /// The detector is in the baseline but not in the current report (or scenario).
    MissingDetector,
    /// A metric got worse than allowed, or is no longer measured (`current: None`).
    Metric {
        /// Metric name as in report.json (`hit_rate`, `false_alarm_rate`, `collision_rate`, `auc`).
        metric: &'static str,
        /// Baseline value.
        baseline: f64,
        /// Current value.
        current: Option<f64>,
        /// Allowed change that was exceeded.
        tolerance: f64,
    },
}

/// One regression against the baseline.
#[derive(Debug, Clone, PartialEq)]
pub struct Regression {
    /// Scenario name; `None` for the pooled (suite-wide or per-tier) summaries.
    pub scenario: Option<String>,
    /// Difficulty tier of a per-tier summary; `None` otherwise.
    pub tier: Option<u8>,
    /// Detector id; `None` for a missing scenario.
    pub detector: Option<String>,
    /// What regressed.
    pub kind: RegressionKind,
}

impl fmt::Display for Regression {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let scope = match (&self.scenario, self.tier) {
            (Some(s), _) => format!("scenario `{s}`"),
            (None, Some(t)) => format!("tier {t}"),
            (None, None) => "all scenarios".to_string(),
        };
        let det = self.detector.as_deref().unwrap_or("?");
        match &self.kind {
            RegressionKind::MissingScenario | RegressionKind::MissingTier => {
                write!(f, "{scope}: missing from the current report")
            }
            RegressionKind::MissingDetector => write!(f, "{scope} / detector `{det}`: missing from the current report"),
            RegressionKind::Metric {
                metric,
                baseline,
                current: Some(c),
                tolerance,
            } => {
                let dir = if metric.ends_with("hit_rate") || *metric == "auc" {
                    "drop"
                } else {
                    "rise"
                };
                write!(
                    f,
                    "{scope} / detector `{det}` / {metric}: {baseline:.3} → {c:.3} (allowed {dir} {tolerance:.3})"
                )
            }
            RegressionKind::Metric {
                metric,
                baseline,
                current: None,
                ..
            } => {
                write!(
                    f,
                    "{scope} / detector `{det}` / {metric}: {baseline:.3} → null (no longer measured)"
                )
            }
        }
    }
}

/// Compare `current` with `baseline`; an empty result means no regression (see the module docs).
pub fn compare(current: &Report, baseline: &Report, tol: &Tolerances) -> Vec<Regression> {
    let mut out = Vec::new();
    compare_detectors(None, None, &current.detectors, &baseline.detectors, tol, &mut out);
    for (key, base) in &baseline.tiers {
        let tier = key.parse::<u8>().ok();
        match current.tiers.get(key) {
            None => out.push(Regression {
                scenario: None,
                tier,
                detector: None,
                kind: RegressionKind::MissingTier,
            }),
            Some(cur) => compare_detectors(None, tier, &cur.detectors, &base.detectors, tol, &mut out),
        }
    }
    if tol.per_scenario {
        for (name, base) in &baseline.scenarios {
            match current.scenarios.get(name) {
                None => out.push(Regression {
                    scenario: Some(name.clone()),
                    tier: None,
                    detector: None,
                    kind: RegressionKind::MissingScenario,
                }),
                Some(cur) => compare_detectors(Some(name), None, &cur.detectors, &base.detectors, tol, &mut out),
            }
        }
    }
    out
}

fn compare_detectors(
    scenario: Option<&String>,
    tier: Option<u8>,
    current: &std::collections::BTreeMap<String, DetectorSummary>,
    baseline: &std::collections::BTreeMap<String, DetectorSummary>,
    tol: &Tolerances,
    out: &mut Vec<Regression>,
) {
    // reference rows are ground truth, not detectors: they are not regression-checked
    for (id, base) in baseline.iter().filter(|(id, _)| !crate::reference::is_reference(id)) {
        let reg = |kind| Regression {
            scenario: scenario.cloned(),
            tier,
            detector: Some(id.clone()),
            kind,
        };
        let Some(cur) = current.get(id) else {
            out.push(reg(RegressionKind::MissingDetector));
            continue;
        };
        let rates = [
            (
                "hit_rate",
                base.hit_rate,
                base.hit_rate_ci,
                cur.hit_rate,
                &tol.hit_rate,
                -1.0,
            ),
            (
                "false_alarm_rate",
                base.false_alarm_rate,
                base.false_alarm_rate_ci,
                cur.false_alarm_rate,
                &tol.false_alarm_rate,
                1.0,
            ),
            (
                "collision_rate",
                base.collision_rate,
                base.collision_rate_ci,
                cur.collision_rate,
                &tol.collision_rate,
                1.0,
            ),
        ];
        for (metric, b, b_ci, c, rt, bad_sign) in rates {
            let Some(b) = b else { continue };
            let tolerance = allowed_change(b, b_ci, rt, bad_sign);
            check(metric, b, c, tolerance, bad_sign, &mut |k| out.push(reg(k)));
        }
        if let (Some(max_drop), Some(b)) = (tol.auc_drop, base.auc) {
            check("auc", b, cur.auc, max_drop, -1.0, &mut |k| out.push(reg(k)));
        }
    }
}

/// `bad_sign` is −1 when a decrease is bad (hit rate, AUC), +1 when an increase is.
fn allowed_change(baseline: f64, ci: Option<Interval>, rt: &RateTolerance, bad_sign: f64) -> f64 {
    let wilson = match (rt.wilson, ci) {
        (true, Some(ci)) if bad_sign < 0.0 => baseline - ci.lower,
        (true, Some(ci)) => ci.upper - baseline,
        _ => 0.0,
    };
    rt.max_change.max(wilson)
}

fn check(
    metric: &'static str,
    baseline: f64,
    current: Option<f64>,
    tolerance: f64,
    bad_sign: f64,
    push: &mut dyn FnMut(RegressionKind),
) {
    // 1e-12 keeps rounding noise (e.g. 0.1 + 0.05) from turning an exactly-allowed change into a regression.
    let worse = match current {
        None => true,
        Some(c) => (c - baseline) * bad_sign > tolerance + 1e-12,
    };
    if worse {
        push(RegressionKind::Metric {
            metric,
            baseline,
            current,
            tolerance,
        });
    }
}
