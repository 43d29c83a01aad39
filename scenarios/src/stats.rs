//! Statistics for scoring: Wilson score intervals for rates and ROC curves / AUC for detectors.
//!
//! # ROC from per-episode scores
//! The alarm rule is `signal >= threshold` (see [`crate::metrics`]). For one episode, let its
//! **score** be the maximum of the detector's signal over the window in which an alarm counts
//! (evadable threats: up to `t_dl − lead_margin`; non-threats: the whole episode). Then, for any threshold θ,
//! "the episode is a hit / false alarm at θ" ⇔ "score ≥ θ". So sweeping θ over all distinct scores
//! gives every achievable (false-alarm rate, hit rate) pair exactly — the ROC curve — from one run,
//! and its trapezoid area equals the Mann–Whitney statistic P(S₊ > S₋) + ½·P(S₊ = S₋).
//!
//! In closed loop this is exact for thresholds at or below the operating threshold (the signal up
//! to the earlier alarm is the same whatever the controller does later); above it, the episode's
//! trajectory after the operating trigger differs from the one a higher threshold would have
//! produced, so those points are an open-loop approximation.
//!
//! Episodes without any finite score (NaN signals, no frame in the window) never alarm: they count
//! as score −∞, tied with each other, and reach the curve only at its final (1, 1) point.

use serde::{Deserialize, Serialize};

/// The two-sided 95 % normal quantile, Φ⁻¹(0.975).
pub const Z_95: f64 = 1.959_963_984_540_054;

/// A closed interval `[lower, upper]` within [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
}

impl Interval {
    /// `upper − lower`.
    pub fn width(&self) -> f64 {
        self.upper - self.lower
    }

    /// Whether `x` lies in the interval (bounds included).
    pub fn contains(&self, x: f64) -> bool {
        self.lower <= x && x <= self.upper
    }
}

/// `successes / trials`, or `None` when there are no trials (never NaN).
pub fn rate(successes: u64, trials: u64) -> Option<f64> {
    (trials > 0).then(|| successes as f64 / trials as f64)
}

/// Wilson score interval for a binomial proportion at normal quantile `z`; `None` for 0 trials.
///
/// centre = (p̂ + z²/2n)/(1 + z²/n), half-width = z/(1 + z²/n)·√(p̂(1−p̂)/n + z²/4n²),
/// clamped into [0, 1] (the exact bounds are 0 for 0 successes and 1 for n successes; the clamp
/// only removes rounding). Panics never; `successes > trials` is treated as `trials`.
pub fn wilson_interval(successes: u64, trials: u64, z: f64) -> Option<Interval> {
    if trials == 0 {
        return None;
    }
    let n = trials as f64;
    let k = successes.min(trials);
    let p = k as f64 / n;
    let z2 = z * z;
    let denom = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denom;
    let half = z / denom * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    let lower = if k == 0 { 0.0 } else { (centre - half).clamp(0.0, 1.0) };
    let upper = if k == trials {
        1.0
    } else {
        (centre + half).clamp(0.0, 1.0)
    };
    Some(Interval { lower, upper })
}

/// The 95 % Wilson score interval ([`wilson_interval`] with [`Z_95`]).
pub fn wilson_95(successes: u64, trials: u64) -> Option<Interval> {
    wilson_interval(successes, trials, Z_95)
}

/// One point of a ROC curve: alarm iff score ≥ `threshold`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RocPoint {
    /// The threshold; `null` for the end points (above every score: (0, 0); below every finite
    /// score, reached only when some episodes have no finite score: (1, 1)).
    pub threshold: Option<f64>,
    /// False-alarm rate at this threshold.
    pub fpr: f64,
    /// Hit rate at this threshold.
    pub tpr: f64,
}

fn clean(s: f64) -> f64 {
    if s.is_nan() { f64::NEG_INFINITY } else { s }
}

/// The ROC curve of scores of threat episodes (`positives`) and non-threat episodes
/// (`negatives`), from (0, 0) to (1, 1) with one point per distinct finite score, in order of
/// decreasing threshold. Empty when either set is empty (the curve is undefined).
pub fn roc_curve(positives: &[f64], negatives: &[f64]) -> Vec<RocPoint> {
    if positives.is_empty() || negatives.is_empty() {
        return Vec::new();
    }
    let mut all: Vec<(f64, bool)> = positives
        .iter()
        .map(|&s| (clean(s), true))
        .chain(negatives.iter().map(|&s| (clean(s), false)))
        .collect();
    all.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (np, nn) = (positives.len() as f64, negatives.len() as f64);
    let mut points = vec![RocPoint {
        threshold: None,
        fpr: 0.0,
        tpr: 0.0,
    }];
    let (mut tp, mut fp) = (0usize, 0usize);
    let mut i = 0;
    while i < all.len() {
        let s = all[i].0;
        while i < all.len() && all[i].0 == s {
            if all[i].1 {
                tp += 1
            } else {
                fp += 1
            }
            i += 1;
        }
        let threshold = s.is_finite().then_some(s);
        points.push(RocPoint {
            threshold,
            fpr: fp as f64 / nn,
            tpr: tp as f64 / np,
        });
    }
    points
}

/// Area under a ROC curve by the trapezoid rule (points in order of increasing FPR, as
/// [`roc_curve`] returns them). Ties between positives and negatives give a diagonal segment,
/// i.e. count one half.
pub fn auc_trapezoid(points: &[RocPoint]) -> f64 {
    points
        .windows(2)
        .map(|w| (w[1].fpr - w[0].fpr) * (w[1].tpr + w[0].tpr) / 2.0)
        .sum()
}

/// AUC of the scores ([`roc_curve`] + [`auc_trapezoid`]); `None` when either set is empty.
pub fn auc(positives: &[f64], negatives: &[f64]) -> Option<f64> {
    let roc = roc_curve(positives, negatives);
    (!roc.is_empty()).then(|| auc_trapezoid(&roc))
}

/// The Mann–Whitney form of the AUC, P(S₊ > S₋) + ½·P(S₊ = S₋), by direct pair counting
/// (O(n·m); a reference for [`auc`], which it equals). `None` when either set is empty.
pub fn auc_mann_whitney(positives: &[f64], negatives: &[f64]) -> Option<f64> {
    if positives.is_empty() || negatives.is_empty() {
        return None;
    }
    let mut wins = 0.0;
    for &p in positives {
        for &n in negatives {
            let (p, n) = (clean(p), clean(n));
            wins += if p > n {
                1.0
            } else if p == n {
                0.5
            } else {
                0.0
            };
        }
    }
    Some(wins / (positives.len() as f64 * negatives.len() as f64))
}
