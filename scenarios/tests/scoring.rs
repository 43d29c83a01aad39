//! Scoring: per-episode metrics, Wilson intervals, ROC/AUC, report JSON, episodes.csv, regression.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use loomlab_scenarios::episodes_csv::{self, EpisodesCsvWriter, HEADER};
use loomlab_scenarios::metrics::{
    self, DetectorEpisode, DetectorSummary, EpisodeOutcome, GroundTruth, Outcome, ScoringConfig, ScoringError,
    TraceSample,
};
use loomlab_scenarios::regression::{self, RateTolerance, RegressionKind, Tolerances};
use loomlab_scenarios::report::{self, Report, ReportMeta};
use loomlab_scenarios::stats::{self, RocPoint};

// ---------------------------------------------------------------- helpers

fn sample(t_s: f64, signal: f64) -> TraceSample {
    TraceSample {
        t_s,
        signal,
        ttc_s: Some(10.0 - t_s),
        angular_size_deg: Some(t_s * 4.0),
    }
}

/// A trace at 10 Hz from 0 to `end` whose signal is `f(t)`.
fn trace(end: f64, f: impl Fn(f64) -> f64) -> Vec<TraceSample> {
    (0..=(end * 10.0).round() as usize)
        .map(|k| k as f64 / 10.0)
        .map(|t| sample(t, f(t)))
        .collect()
}

fn cfg(lead_min_s: f64) -> ScoringConfig {
    ScoringConfig {
        lead_min_s,
        keep_traces: false,
    }
}

fn threat(t_c: f64) -> GroundTruth {
    GroundTruth {
        threat: true,
        t_contact_s: Some(t_c),
        collision: false,
    }
}

const NO_THREAT: GroundTruth = GroundTruth {
    threat: false,
    t_contact_s: None,
    collision: false,
};

/// A hand-built episode of one detector, classified by `metrics::classify`.
fn ep(threat: bool, t_c: Option<f64>, t_a: Option<f64>, collision: bool, max_signal: Option<f64>) -> DetectorEpisode {
    DetectorEpisode {
        detector: "hopfield".into(),
        threat,
        t_contact_s: t_c,
        t_alarm_s: t_a,
        outcome: metrics::classify(threat, t_c, t_a, 0.1).unwrap(),
        collision,
        ttc_at_alarm_s: t_a.map(|a| 1.0 + a),
        angular_size_at_alarm_deg: t_a.map(|_| 10.0),
        max_signal,
        trace: None,
    }
}

fn episode(scenario: &str, index: usize, detectors: Vec<DetectorEpisode>) -> EpisodeOutcome {
    EpisodeOutcome {
        scenario: scenario.into(),
        episode: index,
        seed: 1000 + index as u64,
        params: BTreeMap::from([("speed_kmh".to_string(), format!("{}", 10 * index))]),
        detectors,
    }
}

fn with_detector(mut d: DetectorEpisode, id: &str) -> DetectorEpisode {
    d.detector = id.into();
    d
}

/// A small suite: two scenarios, two detectors; `hopfield` good, `soc` worse.
fn suite_episodes() -> Vec<EpisodeOutcome> {
    let mut out = Vec::new();
    for i in 0..10 {
        let is_threat = i % 2 == 0;
        let (t_c, h_alarm, s_alarm) = if is_threat {
            (Some(3.0), Some(2.0), (i % 4 == 0).then_some(2.5))
        } else {
            (None, None, (i == 3).then_some(1.0))
        };
        let scenario = if i < 6 { "approach, frontal" } else { "pass \"by\"" };
        out.push(episode(
            scenario,
            i,
            vec![
                with_detector(
                    ep(
                        is_threat,
                        t_c,
                        h_alarm,
                        false,
                        Some(if is_threat { 20.0 + i as f64 } else { 2.0 + i as f64 }),
                    ),
                    "hopfield",
                ),
                with_detector(
                    ep(
                        is_threat,
                        t_c,
                        s_alarm,
                        is_threat && s_alarm.is_none(),
                        Some(if is_threat { 5.0 } else { 4.0 + i as f64 * 0.1 }),
                    ),
                    "soc",
                ),
            ],
        ));
    }
    out
}

fn meta() -> ReportMeta {
    ReportMeta {
        suite: "suites/test".into(),
        seed: 7,
        wall_time_s: 1.25,
        lead_min_s: 0.1,
    }
}

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scoring-tests");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    let _ = std::fs::remove_file(&p);
    p
}

fn assert_close(a: f64, b: f64, tol: f64) {
    assert!((a - b).abs() <= tol, "{a} vs {b}");
}

// ---------------------------------------------------------------- per-episode metrics

#[test]
fn early_alarm_on_threat_is_hit() {
    // Signal crosses 10 at t = 1.0 (signal = 10·t); contact at 3 s, lead_min 0.5 s.
    let d =
        metrics::score_detector_episode("hopfield", 10.0, &trace(3.0, |t| 10.0 * t), &threat(3.0), &cfg(0.5)).unwrap();
    assert_eq!(d.outcome, Outcome::Hit);
    assert_eq!(d.t_alarm_s, Some(1.0));
    assert_close(d.lead_s().unwrap(), 2.0, 1e-12);
    // TTC and angular size come from the alarm frame.
    assert_eq!(d.ttc_at_alarm_s, Some(9.0));
    assert_eq!(d.angular_size_at_alarm_deg, Some(4.0));
}

#[test]
fn lead_min_boundary_equality_counts_as_hit() {
    // Exactly representable: t_a = 1.5 = 2.0 − 0.5.
    assert_eq!(
        metrics::classify(true, Some(2.0), Some(1.5), 0.5).unwrap(),
        Outcome::Hit
    );
    // Not exactly representable: 0.3 − 0.1 = 0.19999999999999998 < 0.2, still a hit.
    let (tc, lead) = (std::hint::black_box(0.3), std::hint::black_box(0.1));
    assert!(tc - lead < 0.2);
    assert_eq!(
        metrics::classify(true, Some(0.3), Some(0.2), 0.1).unwrap(),
        Outcome::Hit
    );
    // One frame later is a miss.
    assert_eq!(
        metrics::classify(true, Some(2.0), Some(1.5 + 1.0 / 120.0), 0.5).unwrap(),
        Outcome::Miss
    );
    // Via the trace, alarm exactly at the boundary frame.
    let d = metrics::score_detector_episode(
        "x",
        1.0,
        &trace(2.0, |t| if t >= 1.5 { 1.0 } else { 0.0 }),
        &threat(2.0),
        &cfg(0.5),
    )
    .unwrap();
    assert_eq!((d.t_alarm_s, d.outcome), (Some(1.5), Outcome::Hit));
    assert_eq!(d.max_signal, Some(1.0), "the boundary frame is inside the ROC window");
}

#[test]
fn late_alarm_is_miss() {
    // Alarm at 2.8 s, before contact (3 s) but after t_c − lead_min = 2.5 s.
    let d = metrics::score_detector_episode(
        "x",
        1.0,
        &trace(3.0, |t| if t >= 2.8 { 5.0 } else { 0.0 }),
        &threat(3.0),
        &cfg(0.5),
    )
    .unwrap();
    assert_eq!(d.outcome, Outcome::Miss);
    assert_eq!(d.t_alarm_s, Some(2.8));
    assert_eq!(d.lead_s(), None);
    assert_eq!(
        d.max_signal,
        Some(0.0),
        "samples after t_c − lead_min are outside the ROC window"
    );
}

#[test]
fn no_alarm_on_threat_is_miss() {
    let d = metrics::score_detector_episode("x", 10.0, &trace(3.0, |t| t), &threat(3.0), &cfg(0.1)).unwrap();
    assert_eq!(d.outcome, Outcome::Miss);
    assert_eq!(
        (d.t_alarm_s, d.ttc_at_alarm_s, d.angular_size_at_alarm_deg),
        (None, None, None)
    );
}

#[test]
fn alarm_without_threat_is_false_alarm() {
    let d = metrics::score_detector_episode(
        "x",
        10.0,
        &trace(3.0, |t| if t > 2.9 { 50.0 } else { 0.0 }),
        &NO_THREAT,
        &cfg(0.1),
    )
    .unwrap();
    assert_eq!(d.outcome, Outcome::FalseAlarm);
    assert_eq!(
        d.max_signal,
        Some(50.0),
        "non-threats are scored over the whole episode"
    );
}

#[test]
fn no_alarm_without_threat_is_correct_rejection() {
    let d = metrics::score_detector_episode("x", 10.0, &trace(3.0, |_| 9.99), &NO_THREAT, &cfg(0.1)).unwrap();
    assert_eq!(d.outcome, Outcome::CorrectRejection);
    assert_eq!(d.max_signal, Some(9.99));
}

#[test]
fn nan_signal_never_alarms_and_is_not_a_score() {
    let d = metrics::score_detector_episode("x", 0.0, &trace(1.0, |_| f64::NAN), &NO_THREAT, &cfg(0.1)).unwrap();
    assert_eq!(d.outcome, Outcome::CorrectRejection);
    assert_eq!(d.max_signal, None);
    assert_eq!(d.roc_score(), f64::NEG_INFINITY);
}

#[test]
fn unsorted_samples_give_the_earliest_alarm() {
    let mut s = trace(2.0, |t| if t >= 1.0 { 20.0 } else { 0.0 });
    s.reverse();
    let d = metrics::score_detector_episode("x", 10.0, &s, &threat(2.0), &cfg(0.1)).unwrap();
    assert_eq!(d.t_alarm_s, Some(1.0));
}

#[test]
fn traces_are_kept_only_on_request() {
    let s = trace(1.0, |t| t);
    let keep = ScoringConfig {
        lead_min_s: 0.1,
        keep_traces: true,
    };
    assert_eq!(
        metrics::score_detector_episode("x", 5.0, &s, &NO_THREAT, &keep)
            .unwrap()
            .trace
            .as_deref(),
        Some(&s[..])
    );
    assert_eq!(
        metrics::score_detector_episode("x", 5.0, &s, &NO_THREAT, &cfg(0.1))
            .unwrap()
            .trace,
        None
    );
}

#[test]
fn inconsistent_ground_truth_is_an_error_naming_the_detector() {
    let bad_threat = GroundTruth {
        threat: true,
        t_contact_s: None,
        collision: false,
    };
    let e = metrics::score_detector_episode("soc", 1.0, &[], &bad_threat, &cfg(0.1)).unwrap_err();
    assert!(
        matches!(e, ScoringError::GroundTruth { .. })
            && e.to_string().contains("`soc`")
            && e.to_string().contains("contact time"),
        "{e}"
    );
    let bad_non_threat = GroundTruth {
        threat: false,
        t_contact_s: Some(1.0),
        collision: false,
    };
    assert!(metrics::score_detector_episode("soc", 1.0, &[], &bad_non_threat, &cfg(0.1)).is_err());
    assert!(metrics::score_detector_episode("soc", f64::NAN, &[], &NO_THREAT, &cfg(0.1)).is_err());
    assert!(metrics::score_detector_episode("soc", 1.0, &[], &NO_THREAT, &cfg(-1.0)).is_err());
    assert!(metrics::score_detector_episode("soc", 1.0, &[sample(f64::NAN, 0.0)], &NO_THREAT, &cfg(0.1)).is_err());
}

// ---------------------------------------------------------------- aggregation

#[test]
fn summary_counts_rates_and_collision_rate() {
    let eps = [
        ep(true, Some(3.0), Some(1.0), false, Some(30.0)), // hit, lead 2.0
        ep(true, Some(3.0), Some(2.95), true, Some(8.0)),  // late → miss, collision
        ep(true, Some(3.0), None, true, Some(5.0)),        // no alarm → miss, collision
        ep(true, Some(2.0), Some(1.9), false, Some(12.0)), // boundary → hit, lead 0.1
        ep(false, None, Some(0.5), false, Some(15.0)),     // false alarm
        ep(false, None, None, false, Some(3.0)),           // correct rejection
        ep(false, None, None, true, Some(4.0)),            // correct rejection, collision
        ep(false, None, None, false, None),                // correct rejection, no score
    ];
    let s = DetectorSummary::from_episodes(&eps);
    assert_eq!(
        (
            s.episodes,
            s.hits,
            s.misses,
            s.false_alarms,
            s.correct_rejections,
            s.collisions
        ),
        (8, 2, 2, 1, 3, 3)
    );
    assert_eq!(s.hit_rate, Some(0.5));
    assert_eq!(s.false_alarm_rate, Some(0.25));
    assert_eq!(s.collision_rate, Some(3.0 / 8.0));
    assert_eq!(s.hit_rate_ci, stats::wilson_95(2, 4));
    assert_eq!(s.false_alarm_rate_ci, stats::wilson_95(1, 4));
    assert_eq!(s.collision_rate_ci, stats::wilson_95(3, 8));
    assert_close(s.mean_lead_s.unwrap(), 1.05, 1e-12);
    assert_eq!(s.mean_angular_size_at_alarm_deg, Some(10.0));
    // AUC by hand: positives {30, 8, 5, 12}, negatives {15, 3, 4, −∞}: wins 3+3+3+4 ... count pairs.
    let wins: f64 = [30.0, 8.0, 5.0, 12.0]
        .iter()
        .map(|p: &f64| [15.0, 3.0, 4.0, f64::NEG_INFINITY].iter().filter(|&&n| *p > n).count() as f64)
        .sum();
    assert_eq!(wins, 13.0);
    assert_close(s.auc.unwrap(), 13.0 / 16.0, 1e-12);
}

#[test]
fn rates_without_denominator_are_none_not_nan() {
    let only_non_threats = [
        ep(false, None, None, false, Some(1.0)),
        ep(false, None, Some(1.0), false, Some(2.0)),
    ];
    let s = DetectorSummary::from_episodes(&only_non_threats);
    assert_eq!(
        (s.hit_rate, s.hit_rate_ci, s.auc, s.mean_lead_s),
        (None, None, None, None)
    );
    assert_eq!(s.false_alarm_rate, Some(0.5));
    assert!(s.roc.is_empty());
    let json = serde_json::to_string(&s).unwrap();
    assert!(json.contains("\"hit_rate\":null"), "{json}");
    assert!(!json.contains("NaN") && !json.contains("inf"));
    let s = DetectorSummary::from_episodes(&[ep(true, Some(1.0), None, false, None)]);
    assert_eq!((s.false_alarm_rate, s.hit_rate), (None, Some(0.0)));
}

#[test]
fn roc_at_the_operating_threshold_reproduces_hit_and_false_alarm_rates() {
    // Deterministic pseudo-random episodes; score each at threshold θ and compare with the ROC.
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as f64 / (1u64 << 31) as f64
    };
    let lead = 0.25;
    let mut cases = Vec::new();
    for i in 0..60 {
        let is_threat = i % 3 != 0;
        let t_c = 2.0 + next();
        let (a, b) = (next() * 20.0, next() * 4.0);
        let samples: Vec<TraceSample> = (0..=40)
            .map(|k| k as f64 / 12.0)
            .map(|t| sample(t, a * t / 3.0 + b * (t * 7.0).sin()))
            .collect();
        let truth = if is_threat { threat(t_c) } else { NO_THREAT };
        cases.push((samples, truth));
    }
    for theta in [0.5, 3.0, 6.0, 9.0, 12.0] {
        let eps: Vec<DetectorEpisode> = cases
            .iter()
            .map(|(s, g)| metrics::score_detector_episode("x", theta, s, g, &cfg(lead)).unwrap())
            .collect();
        let summary = DetectorSummary::from_episodes(&eps);
        // The ROC point for θ is the one with the smallest threshold ≥ θ (or (0,0) if none).
        let point = summary
            .roc
            .iter()
            .rfind(|p| p.threshold.is_some_and(|t| t >= theta))
            .copied()
            .unwrap_or(RocPoint {
                threshold: None,
                fpr: 0.0,
                tpr: 0.0,
            });
        assert_close(point.tpr, summary.hit_rate.unwrap(), 1e-12);
        assert_close(point.fpr, summary.false_alarm_rate.unwrap(), 1e-12);
    }
}

#[test]
fn summarize_by_detector_groups_by_id() {
    let by = metrics::summarize_by_detector(&suite_episodes());
    assert_eq!(by.keys().collect::<Vec<_>>(), ["hopfield", "soc"]);
    assert_eq!(by["hopfield"].episodes, 10);
    assert_eq!((by["hopfield"].hits, by["hopfield"].false_alarms), (5, 0));
    assert_eq!(
        (
            by["soc"].hits,
            by["soc"].misses,
            by["soc"].false_alarms,
            by["soc"].collisions
        ),
        (3, 2, 1, 2)
    );
}

// ---------------------------------------------------------------- Wilson, ROC, AUC

#[test]
fn wilson_interval_matches_independent_reference_values() {
    // Reference values: the Wilson bounds are the roots p of (p̂ − p)² = z²·p(1 − p)/n, i.e. of
    // (1 + z²/n)p² − (2p̂ + z²/n)p + p̂² = 0, solved with the quadratic formula in Python's
    // `decimal` at 50 digits, z = 1.959963984540054 (a different formula from the closed form in
    // stats.rs). 81/263 agrees with statsmodels' proportion_confint(81, 263, method="wilson").
    let cases = [
        (0, 10, 0.0, 0.277532799862889),
        (5, 10, 0.236593090512564, 0.763406909487436),
        (10, 10, 0.722467200137111, 1.0),
        (81, 263, 0.255288519878274, 0.366209576982800),
        (1, 1, 0.206549314377237, 1.0),
        (3, 50, 0.020614970348974, 0.162170916888382),
    ];
    for (k, n, lo, hi) in cases {
        let ci = stats::wilson_95(k, n).unwrap();
        assert_close(ci.lower, lo, 1e-12);
        assert_close(ci.upper, hi, 1e-12);
        assert!(ci.contains(k as f64 / n as f64));
    }
    assert_eq!(stats::wilson_95(0, 0), None);
    assert_eq!(stats::rate(0, 0), None);
}

#[test]
fn wilson_interval_is_symmetric_under_swapping_successes_and_failures() {
    for n in [1u64, 7, 30] {
        for k in 0..=n {
            let a = stats::wilson_95(k, n).unwrap();
            let b = stats::wilson_95(n - k, n).unwrap();
            assert_close(a.lower, 1.0 - b.upper, 1e-12);
            assert_close(a.upper, 1.0 - b.lower, 1e-12);
        }
    }
}

#[test]
fn roc_curve_of_a_small_example() {
    // positives {0.9, 0.8, 0.4}, negatives {0.5, 0.3, 0.2}: only 0.4 < 0.5 is misordered.
    let roc = stats::roc_curve(&[0.9, 0.8, 0.4], &[0.5, 0.3, 0.2]);
    let pts: Vec<(Option<f64>, f64, f64)> = roc.iter().map(|p| (p.threshold, p.fpr, p.tpr)).collect();
    let third = 1.0 / 3.0;
    assert_eq!(
        pts,
        vec![
            (None, 0.0, 0.0),
            (Some(0.9), 0.0, third),
            (Some(0.8), 0.0, 2.0 * third),
            (Some(0.5), third, 2.0 * third),
            (Some(0.4), third, 1.0),
            (Some(0.3), 2.0 * third, 1.0),
            (Some(0.2), 1.0, 1.0),
        ]
    );
    assert_close(stats::auc_trapezoid(&roc), 8.0 / 9.0, 1e-12);
}

#[test]
fn auc_with_ties_counts_one_half() {
    // Pairs: (1,2)=0 (1,0)=1 (2,2)=½ (2,0)=1 (3,2)=1 (3,0)=1 → 4.5/6.
    assert_close(stats::auc(&[1.0, 2.0, 3.0], &[2.0, 0.0]).unwrap(), 0.75, 1e-12);
    assert_eq!(stats::auc(&[1.0, 1.0], &[1.0]), Some(0.5));
    assert_eq!(stats::auc(&[2.0], &[1.0]), Some(1.0));
    assert_eq!(stats::auc(&[1.0], &[2.0]), Some(0.0));
    assert_eq!(stats::auc(&[], &[1.0]), None);
    assert_eq!(stats::auc_mann_whitney(&[1.0], &[]), None);
}

#[test]
fn auc_equals_the_mann_whitney_statistic() {
    let mut state = 99u64;
    let mut next = |m: u64| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) % m
    };
    for trial in 0..200 {
        let (np, nn) = (1 + next(12) as usize, 1 + next(12) as usize);
        // Few distinct values → many ties; some NaN and −∞ (no score).
        let mut draw = |bias: u64| match next(10) {
            0 => f64::NAN,
            1 => f64::NEG_INFINITY,
            _ => (next(6) + bias) as f64 * 0.5,
        };
        let pos: Vec<f64> = (0..np).map(|_| draw(trial % 3)).collect();
        let neg: Vec<f64> = (0..nn).map(|_| draw(0)).collect();
        let roc = stats::roc_curve(&pos, &neg);
        assert_eq!((roc.first().unwrap().fpr, roc.first().unwrap().tpr), (0.0, 0.0));
        assert_eq!((roc.last().unwrap().fpr, roc.last().unwrap().tpr), (1.0, 1.0));
        assert!(
            roc.windows(2).all(|w| w[1].fpr >= w[0].fpr && w[1].tpr >= w[0].tpr),
            "monotone"
        );
        assert_close(
            stats::auc(&pos, &neg).unwrap(),
            stats::auc_mann_whitney(&pos, &neg).unwrap(),
            1e-12,
        );
    }
}

// ---------------------------------------------------------------- report

#[test]
fn report_json_has_the_contract_keys_and_no_nan() {
    let mut eps = suite_episodes();
    // A scenario without threats: its hit rate must be null, not NaN.
    eps.push(episode(
        "empty road",
        20,
        vec![with_detector(ep(false, None, None, false, Some(1.0)), "hopfield")],
    ));
    let report = Report::from_episodes(&meta(), &eps);
    let text = report.to_json();
    assert!(!text.contains("NaN") && !text.contains("Infinity"), "{text}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "loomlab_version",
        "suite",
        "seed",
        "episodes",
        "wall_time_s",
        "lead_min_s",
    ] {
        assert!(v.get(key).is_some(), "metadata key {key}");
    }
    assert_eq!(v["episodes"], 11);
    assert_eq!(v["loomlab_version"], report::LOOMLAB_VERSION);
    let contract = [
        "episodes",
        "hits",
        "misses",
        "false_alarms",
        "correct_rejections",
        "hit_rate",
        "false_alarm_rate",
        "collisions",
        "collision_rate",
    ];
    let mut objects = vec![&v["detectors"]["hopfield"], &v["detectors"]["soc"]];
    for s in ["approach, frontal", "pass \"by\"", "empty road"] {
        objects.push(&v["scenarios"][s]["detectors"]["hopfield"]);
    }
    for o in objects {
        for key in contract {
            assert!(o.get(key).is_some(), "missing contract key {key} in {o}");
        }
        for key in [
            "hit_rate_ci",
            "false_alarm_rate_ci",
            "collision_rate_ci",
            "auc",
            "mean_lead_s",
        ] {
            assert!(o.get(key).is_some(), "missing extra key {key}");
        }
    }
    assert_eq!(
        v["scenarios"]["empty road"]["detectors"]["hopfield"]["hit_rate"],
        serde_json::Value::Null
    );
    assert_eq!(v["detectors"]["hopfield"]["hit_rate"], 1.0);
    assert_eq!(v["scenarios"]["approach, frontal"]["episodes"], 6);
    // Round trip.
    assert_eq!(Report::from_json(&text, Path::new("mem")).unwrap(), report);
}

#[test]
fn report_file_round_trip_and_errors_name_the_file() {
    let report = Report::from_episodes(&meta(), &suite_episodes());
    let p = tmp("report.json");
    report.write_json(&p).unwrap();
    assert_eq!(Report::read_json(&p).unwrap(), report);
    std::fs::write(&p, "{\"suite\": 3}").unwrap();
    let e = Report::read_json(&p).unwrap_err();
    assert!(e.to_string().contains("report.json"), "{e}");
    let e = Report::read_json(&tmp("missing.json")).unwrap_err();
    assert!(matches!(e, ScoringError::Io { .. }));
}

#[test]
fn non_finite_metadata_does_not_leak_into_json() {
    let m = ReportMeta {
        wall_time_s: f64::NAN,
        ..meta()
    };
    let text = Report::from_episodes(&m, &suite_episodes()).to_json();
    assert!(!text.contains("null,\n  \"lead") && !text.contains("NaN"));
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["wall_time_s"], 0.0);
}

#[test]
fn terminal_table_is_aligned() {
    let mut eps = suite_episodes();
    eps.push(episode(
        "empty road",
        20,
        vec![with_detector(
            ep(false, None, None, false, Some(1.0)),
            "a_long_detector_id",
        )],
    ));
    let report = Report::from_episodes(&meta(), &eps);
    let table = report::format_summary_table(&report.detectors);
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), 2 + 3);
    assert!(lines[0].starts_with("detector") && lines[0].contains("hit rate [95% CI]") && lines[0].ends_with("AUC"));
    let width = lines[0].chars().count();
    assert!(lines.iter().all(|l| l.chars().count() == width), "\n{table}");
    assert!(
        lines[2].starts_with("a_long_detector_id") && lines[2].contains("n/a"),
        "\n{table}"
    );
    // hopfield: 5/5 hits → "1.00 [0.57, 1.00]".
    assert!(lines[3].contains("1.00 [0.57, 1.00]"), "\n{table}");
    let full = report.format_table(true);
    assert!(full.contains("scenario empty road (1 episodes)"), "{full}");
}

// ---------------------------------------------------------------- episodes.csv

fn strip_traces(mut eps: Vec<EpisodeOutcome>) -> Vec<EpisodeOutcome> {
    for e in &mut eps {
        for d in &mut e.detectors {
            d.trace = None;
        }
    }
    eps
}

#[test]
fn csv_round_trip_is_exact() {
    let mut eps = suite_episodes();
    eps[0].params.insert("note".into(), "a, \"quoted\"\nvalue".into());
    eps[1].detectors[0].max_signal = Some(1e-7);
    eps[1].detectors[0].t_alarm_s = None;
    eps[2].detectors[0].t_alarm_s = Some(0.1 + 0.2);
    eps[2].detectors[0].ttc_at_alarm_s = Some(0.30000000000000004);
    let p = tmp("roundtrip.csv");
    let mut w = EpisodesCsvWriter::create(&p).unwrap();
    for e in &eps {
        w.write_episode(e).unwrap();
    }
    drop(w);
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.starts_with(&(HEADER.join(",") + "\n")));
    assert_eq!(text.matches("scenario,episode").count(), 1, "header written once");
    let back = episodes_csv::read_episodes_csv(&p).unwrap();
    assert_eq!(back, strip_traces(eps.clone()));
    assert_eq!(
        Report::from_episodes(&meta(), &back),
        Report::from_episodes(&meta(), &eps)
    );
}

#[test]
fn csv_partial_last_line_is_dropped_and_append_resumes() {
    let eps = suite_episodes();
    let p = tmp("partial.csv");
    let mut w = EpisodesCsvWriter::create(&p).unwrap();
    for e in &eps[..3] {
        w.write_episode(e).unwrap();
    }
    drop(w);
    // Simulate a crash in the middle of the fourth episode's first row.
    let row = episodes_csv::format_rows(&eps[3]);
    let mut text = std::fs::read_to_string(&p).unwrap();
    text += &row[..row.len() / 3];
    std::fs::write(&p, &text).unwrap();
    assert_eq!(episodes_csv::read_episodes_csv(&p).unwrap(), eps[..3].to_vec());
    // Resume: the partial line is removed, no second header.
    let mut w = EpisodesCsvWriter::append(&p).unwrap();
    for e in &eps[3..] {
        w.write_episode(e).unwrap();
    }
    drop(w);
    let text = std::fs::read_to_string(&p).unwrap();
    assert_eq!(text.matches("scenario,episode").count(), 1);
    assert_eq!(episodes_csv::read_episodes_csv(&p).unwrap(), eps);
}

#[test]
fn csv_append_to_missing_file_writes_header_and_rejects_foreign_header() {
    let p = tmp("fresh.csv");
    let mut w = EpisodesCsvWriter::append(&p).unwrap();
    w.write_episode(&suite_episodes()[0]).unwrap();
    drop(w);
    assert_eq!(episodes_csv::read_episodes_csv(&p).unwrap().len(), 1);
    let q = tmp("foreign.csv");
    std::fs::write(&q, "a,b,c\n1,2,3\n").unwrap();
    let e = EpisodesCsvWriter::append(&q).unwrap_err();
    assert!(
        e.to_string().contains("foreign.csv:1") && e.to_string().contains("new output folder"),
        "{e}"
    );
}

#[test]
fn csv_errors_name_file_line_and_column() {
    let good = episodes_csv::format_rows(&suite_episodes()[0]);
    let head = HEADER.join(",") + "\n";
    let bad_outcome = good.replacen(",hit,", ",hitt,", 1);
    let e = episodes_csv::parse_episodes_csv(&(head.clone() + &bad_outcome), Path::new("ep.csv")).unwrap_err();
    assert!(
        e.to_string().starts_with("ep.csv:2:") && e.to_string().contains("outcome"),
        "{e}"
    );
    let bad_number = good.replacen(",3,", ",three,", 1);
    let e = episodes_csv::parse_episodes_csv(&(head.clone() + &bad_number), Path::new("ep.csv")).unwrap_err();
    assert!(
        e.to_string().contains("t_contact_s") && e.to_string().contains("three"),
        "{e}"
    );
    let e = episodes_csv::parse_episodes_csv("scenario,episode\n", Path::new("ep.csv")).unwrap_err();
    assert!(e.to_string().contains("missing column `seed`"), "{e}");
    let e = episodes_csv::parse_episodes_csv(&(head + "a,b\n"), Path::new("ep.csv")).unwrap_err();
    assert!(e.to_string().contains("ep.csv:2: 2 fields"), "{e}");
}

// ---------------------------------------------------------------- regression

fn report_of(eps: &[EpisodeOutcome]) -> Report {
    Report::from_episodes(&meta(), eps)
}

/// `n` threat episodes of `scenario` for `hopfield` with `hits` hits and `collisions` collisions,
/// plus `n` non-threat episodes with `fas` false alarms.
fn block(scenario: &str, n: usize, hits: usize, fas: usize, collisions: usize) -> Vec<EpisodeOutcome> {
    let mut out = Vec::new();
    for i in 0..n {
        let d = ep(
            true,
            Some(3.0),
            (i < hits).then_some(1.0),
            i < collisions,
            Some(if i < hits { 20.0 } else { 1.0 }),
        );
        out.push(episode(scenario, i, vec![d]));
        let d = ep(
            false,
            None,
            (i < fas).then_some(1.0),
            false,
            Some(if i < fas { 20.0 } else { 0.5 }),
        );
        out.push(episode(scenario, n + i, vec![d]));
    }
    out
}

#[test]
fn identical_or_improved_reports_have_no_regressions() {
    let base = report_of(&block("s", 50, 40, 5, 5));
    assert!(regression::compare(&base, &base, &Tolerances::default()).is_empty());
    let better = report_of(&block("s", 50, 48, 1, 0));
    assert!(regression::compare(&better, &base, &Tolerances::default()).is_empty());
    let strict = Tolerances {
        hit_rate: RateTolerance {
            max_change: 0.0,
            wilson: false,
        },
        false_alarm_rate: RateTolerance {
            max_change: 0.0,
            wilson: false,
        },
        collision_rate: RateTolerance {
            max_change: 0.0,
            wilson: false,
        },
        auc_drop: Some(0.0),
        per_scenario: true,
    };
    assert!(regression::compare(&base, &base, &strict).is_empty());
    assert!(regression::compare(&better, &base, &strict).is_empty());
}

#[test]
fn worsened_report_yields_named_regressions() {
    let base = report_of(&block("s", 50, 45, 2, 2));
    let worse = report_of(&block("s", 50, 30, 15, 12));
    let regs = regression::compare(&worse, &base, &Tolerances::default());
    let metrics: Vec<(Option<&str>, &str)> = regs
        .iter()
        .map(|r| match &r.kind {
            RegressionKind::Metric { metric, .. } => (r.scenario.as_deref(), *metric),
            k => panic!("unexpected {k:?}"),
        })
        .collect();
    for scope in [None, Some("s")] {
        for m in ["hit_rate", "false_alarm_rate", "collision_rate", "auc"] {
            assert!(metrics.contains(&(scope, m)), "{scope:?} {m} not flagged: {metrics:?}");
        }
    }
    let line = regs[0].to_string();
    assert_eq!(
        line, "all scenarios / detector `hopfield` / hit_rate: 0.900 → 0.600 (allowed drop 0.114)",
        "{line}"
    );
    assert!(regs.iter().any(|r| {
        r.to_string()
            .starts_with("scenario `s` / detector `hopfield` / false_alarm_rate: 0.040 → 0.300 (allowed rise")
    }));
}

#[test]
fn small_changes_within_the_wilson_interval_are_not_regressions() {
    // 20 threats: 18 → 16 hits is a 10-point drop, but 0.8 lies inside the baseline's
    // 95 % interval [0.699, 0.972]; with the Wilson allowance off it is flagged.
    let base = report_of(&block("s", 20, 18, 0, 0));
    let cur = report_of(&block("s", 20, 16, 0, 0));
    let lower = base.detectors["hopfield"].hit_rate_ci.unwrap().lower;
    assert!(lower < 0.8);
    let tol = Tolerances {
        auc_drop: None,
        ..Tolerances::default()
    };
    assert!(regression::compare(&cur, &base, &tol).is_empty());
    let no_wilson = Tolerances {
        hit_rate: RateTolerance {
            max_change: 0.05,
            wilson: false,
        },
        ..tol
    };
    let regs = regression::compare(&cur, &base, &no_wilson);
    assert_eq!(regs.len(), 2, "pooled and per scenario: {regs:?}");
    assert!(regs[0].to_string().contains("allowed drop 0.050"));
}

#[test]
fn missing_detectors_scenarios_and_metrics_are_regressions() {
    let mut base_eps = block("s", 10, 8, 1, 1);
    base_eps.extend(block("t", 10, 8, 1, 1));
    let base = report_of(&base_eps);
    // Scenario t gone.
    let regs = regression::compare(&report_of(&block("s", 10, 8, 1, 1)), &base, &Tolerances::default());
    assert_eq!(regs.len(), 1, "{regs:?}");
    assert_eq!(regs[0].kind, RegressionKind::MissingScenario);
    assert_eq!(regs[0].to_string(), "scenario `t`: missing from the current report");
    // Detector renamed.
    let renamed: Vec<EpisodeOutcome> = base_eps
        .iter()
        .cloned()
        .map(|mut e| {
            e.detectors[0].detector = "soc".into();
            e
        })
        .collect();
    let regs = regression::compare(&report_of(&renamed), &base, &Tolerances::default());
    assert_eq!(regs.len(), 3, "pooled + 2 scenarios: {regs:?}");
    assert!(regs.iter().all(|r| r.kind == RegressionKind::MissingDetector));
    assert_eq!(
        regs[0].to_string(),
        "all scenarios / detector `hopfield`: missing from the current report"
    );
    // Threat episodes gone: hit rate (and AUC) no longer measured.
    let no_threats: Vec<EpisodeOutcome> = base_eps.iter().filter(|e| !e.detectors[0].threat).cloned().collect();
    let regs = regression::compare(
        &report_of(&no_threats),
        &base,
        &Tolerances {
            per_scenario: false,
            ..Default::default()
        },
    );
    assert_eq!(regs.len(), 2, "{regs:?}");
    assert!(
        regs[0]
            .to_string()
            .ends_with("hit_rate: 0.800 → null (no longer measured)"),
        "{}",
        regs[0]
    );
}

#[test]
fn tolerances_parse_and_validate() {
    let t: Tolerances = serde_json::from_str(r#"{"hit_rate": {"max_change": 0.1}, "auc_drop": null}"#).unwrap();
    assert_eq!(
        t.hit_rate,
        RateTolerance {
            max_change: 0.1,
            wilson: true
        }
    );
    assert_eq!(t.auc_drop, None);
    assert!(serde_json::from_str::<Tolerances>(r#"{"hit_rate_drop": 0.1}"#).is_err());
    let e = Tolerances {
        collision_rate: RateTolerance {
            max_change: -0.1,
            wilson: true,
        },
        ..Default::default()
    }
    .validate()
    .unwrap_err();
    assert!(e.to_string().contains("tolerances.collision_rate.max_change"), "{e}");
    Tolerances::default().validate().unwrap();
}
