//! What a sweep optimises: the `[objective]` table and its metrics.

use serde::{Deserialize, Serialize};

use crate::metrics::DetectorSummary;

/// What the sweep optimises (`[objective] metric`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    /// Best hit rate over all thresholds with a false-alarm rate ≤ `false_alarm_budget`, read off
    /// the ROC curve (threshold-free: ranks the detector's parameters, not its threshold).
    RocHitRate,
    /// Area under the ROC curve (threshold-free).
    Auc,
    /// Hit rate at the point's threshold (with `false_alarm_budget`: points above it rank last).
    HitRate,
    /// Hit rate − false-alarm rate at the point's threshold (Youden's J).
    Youden,
    /// Closed-loop escape rate: evaded / evadable threats at the point's threshold.
    EvasionRate,
    /// Closed-loop collision rate (lower is better).
    CollisionRate,
    /// False-alarm rate (lower is better).
    FalseAlarmRate,
}

impl Metric {
    /// Whether larger values are better.
    pub fn maximise(self) -> bool {
        !matches!(self, Self::CollisionRate | Self::FalseAlarmRate)
    }

    /// The metric's value for a summary (`None` where it is undefined, e.g. no threats).
    pub fn value(self, s: &DetectorSummary, budget: Option<f64>) -> Option<f64> {
        match self {
            Self::RocHitRate => {
                let budget = budget.unwrap_or(1.0);
                s.roc
                    .iter()
                    .filter(|p| p.fpr <= budget + 1e-12)
                    .map(|p| p.tpr)
                    .max_by(f64::total_cmp)
            }
            Self::Auc => s.auc,
            Self::HitRate => s.hit_rate,
            Self::Youden => Some(s.hit_rate? - s.false_alarm_rate?),
            Self::EvasionRate => s.evasion_rate,
            Self::CollisionRate => s.collision_rate,
            Self::FalseAlarmRate => s.false_alarm_rate,
        }
    }
}

/// `[objective]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Objective {
    /// The metric (default `roc_hit_rate`).
    #[serde(default = "d_metric")]
    pub metric: Metric,
    /// False-alarm budget in [0, 1] (default 0.1): the ROC operating point of `roc_hit_rate`, a
    /// constraint for the other metrics (points above it rank after every point within it).
    #[serde(default = "d_budget")]
    pub false_alarm_budget: Option<f64>,
}

fn d_metric() -> Metric {
    Metric::RocHitRate
}
fn d_budget() -> Option<f64> {
    Some(0.1)
}

impl Default for Objective {
    fn default() -> Self {
        Self {
            metric: d_metric(),
            false_alarm_budget: d_budget(),
        }
    }
}
