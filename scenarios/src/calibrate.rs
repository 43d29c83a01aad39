//! Threshold calibration: the smallest alarm threshold whose false-alarm rate over a set of
//! non-threat episodes stays at or below a target.
//!
//! An episode false-alarms at threshold θ iff its ROC score (the maximum signal over the episode,
//! `DetectorEpisode::max_signal`) is ≥ θ. With the non-threat scores sorted in decreasing order
//! s₁ ≥ s₂ ≥ … ≥ s_N and k = ⌊target·N⌋ false alarms allowed, every θ > s_{k+1} qualifies; the
//! calibrated threshold is s_{k+1} rounded *up* to three significant digits (strictly above it),
//! a readable number at (or just above) the smallest qualifying threshold. Run it on held-out
//! episodes (e.g. the default suite with another `--seed`), not on the ones you report.

use std::collections::BTreeMap;

use crate::metrics::{EpisodeOutcome, Outcome};

/// The calibrated threshold of one detector.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Detector label.
    pub label: String,
    /// The threshold; `None` when no non-threat episode has a finite score (any threshold gives
    /// no false alarm).
    pub threshold: Option<f64>,
    /// Non-threat episodes used.
    pub non_threats: usize,
    /// False-alarm rate over them at `threshold`.
    pub false_alarm_rate: f64,
    /// Hit rate over the threat episodes at `threshold` (`None` without threats).
    pub hit_rate: Option<f64>,
    /// False-alarm rate over the same non-threat episodes at the threshold they were run with
    /// (their recorded outcomes), for comparison.
    pub run_false_alarm_rate: f64,
    /// Hit rate over the evadable threats at the threshold they were run with (`None` without
    /// threats).
    pub run_hit_rate: Option<f64>,
}

/// Rounds `x` up to 3 significant digits, strictly above `x`.
fn round_up_3(x: f64) -> f64 {
    if x == 0.0 {
        return 1e-9;
    }
    let mag = 10f64.powf(x.abs().log10().floor() - 2.0);
    let mut r = (x / mag).ceil() * mag;
    if r <= x {
        r += mag;
    }
    r
}

/// The smallest readable threshold with a false-alarm rate ≤ `target` over the non-threat `scores`
/// (see the module docs); `None` if no score is finite.
pub fn threshold_for_false_alarm_rate(scores: &[f64], target: f64) -> Option<f64> {
    let mut s: Vec<f64> = scores.iter().copied().filter(|v| v.is_finite()).collect();
    if s.is_empty() {
        return None;
    }
    s.sort_by(|a, b| b.total_cmp(a));
    let allowed = (target.clamp(0.0, 1.0) * scores.len() as f64 + 1e-9).floor() as usize;
    // Episodes without a finite score never alarm, so only the finite ones can be false alarms.
    if allowed >= s.len() {
        return Some(s[s.len() - 1]);
    }
    Some(round_up_3(s[allowed]))
}

/// One row's ROC scores — of the evadable threats and of the non-threats — and how many of each
/// the threshold the episodes were run with alarmed on in time (hits) or at all (false alarms).
#[derive(Default)]
struct RowScores {
    threats: Vec<f64>,
    non_threats: Vec<f64>,
    run_hits: usize,
    run_false_alarms: usize,
}

/// Calibrates every detector of `episodes` to `target` false-alarm rate over its non-threat episodes.
pub fn calibrate(episodes: &[EpisodeOutcome], target: f64) -> Vec<Calibration> {
    let mut by: BTreeMap<&str, RowScores> = BTreeMap::new();
    for e in episodes {
        // reference rows are not calibrated; positives are the evadable threats (the ROC's)
        for d in e
            .detectors
            .iter()
            .filter(|d| !crate::reference::is_reference(&d.detector))
        {
            let row = by.entry(&d.detector).or_default();
            if d.evadable() {
                row.threats.push(d.roc_score());
                row.run_hits += usize::from(d.outcome == Outcome::Hit);
            } else if !d.threat {
                row.non_threats.push(d.roc_score());
                row.run_false_alarms += usize::from(d.outcome == Outcome::FalseAlarm);
            }
        }
    }
    by.into_iter()
        .map(|(label, row)| {
            let (pos, neg) = (&row.threats, &row.non_threats);
            let threshold = threshold_for_false_alarm_rate(neg, target);
            let rate = |v: &[f64]| match threshold {
                Some(t) => v.iter().filter(|&&s| s >= t).count() as f64 / v.len().max(1) as f64,
                None => 0.0,
            };
            Calibration {
                label: label.to_string(),
                threshold,
                non_threats: neg.len(),
                false_alarm_rate: rate(neg),
                hit_rate: (!pos.is_empty()).then(|| rate(pos)),
                run_false_alarm_rate: row.run_false_alarms as f64 / neg.len().max(1) as f64,
                run_hit_rate: (!pos.is_empty()).then(|| row.run_hits as f64 / pos.len() as f64),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_up_strictly() {
        assert_eq!(round_up_3(1.234), 1.24);
        assert!((round_up_3(12.0) - 12.1).abs() < 1e-12);
        assert!((round_up_3(0.0456) - 0.0457).abs() < 1e-12);
    }

    #[test]
    fn threshold_allows_the_target_share() {
        // 10 non-threats; 10 % allowed → 1 may alarm: threshold just above the 2nd largest.
        let scores = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];
        let t = threshold_for_false_alarm_rate(&scores, 0.1).unwrap();
        assert!(t > 9.0 && t <= 10.0, "{t}");
        assert_eq!(scores.iter().filter(|&&s| s >= t).count(), 1);
        // 0 % → above the maximum
        let t = threshold_for_false_alarm_rate(&scores, 0.0).unwrap();
        assert!(t > 10.0);
        // no finite score → no threshold needed
        assert_eq!(threshold_for_false_alarm_rate(&[f64::NEG_INFINITY], 0.1), None);
    }
}
