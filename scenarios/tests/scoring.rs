//! Scoring: per-episode metrics (escape deadlines, unavoidable threats, late/silent misses), the
//! escape and collision aggregates, reference rows, the l/|v| fit, Wilson intervals, ROC/AUC,
//! report JSON, episodes.csv, calibration and regression.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use loomlab_scenarios::calibrate;
use loomlab_scenarios::episodes_csv::{self, EpisodesCsvWriter, HEADER};
use loomlab_scenarios::lv::{self, LvFit};
use loomlab_scenarios::metrics::{
    self, DetectorEpisode, DetectorSummary, EpisodeOutcome, GroundTruth, Outcome, ScoringConfig, ScoringError,
    TIME_EPS_S, TraceSample,
};
use loomlab_scenarios::reference::{self, IDEAL_THETA, NULL, ORACLE, REFERENCE_LABELS};
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

fn cfg(lead_margin_s: f64) -> ScoringConfig {
    ScoringConfig {
        lead_margin_s,
        ..ScoringConfig::default()
    }
}

/// An evadable threat with contact at `t_c` and escape deadline `t_dl`.
fn threat(t_c: f64, t_dl: f64) -> GroundTruth {
    GroundTruth {
        threat: true,
        t_contact_s: Some(t_c),
        t_deadline_s: Some(t_dl),
        collision: false,
    }
}

/// A threat that no trigger time evades (contact at `t_c`, no deadline).
fn unavoidable(t_c: f64) -> GroundTruth {
    GroundTruth {
        threat: true,
        t_contact_s: Some(t_c),
        t_deadline_s: None,
        collision: false,
    }
}

const NO_THREAT: GroundTruth = GroundTruth {
    threat: false,
    t_contact_s: None,
    t_deadline_s: None,
    collision: false,
};

/// The escape deadline `ep` gives a threat: 0.1 s before contact.
const EP_DEADLINE_LEAD_S: f64 = 0.1;

/// A hand-built episode of one detector (deadline `EP_DEADLINE_LEAD_S` before contact for a
/// threat), classified by `metrics::classify` with no margin.
fn ep(threat: bool, t_c: Option<f64>, t_a: Option<f64>, collision: bool, max_signal: Option<f64>) -> DetectorEpisode {
    ep_dl(
        threat,
        t_c,
        t_c.filter(|_| threat).map(|c| c - EP_DEADLINE_LEAD_S),
        t_a,
        collision,
        max_signal,
    )
}

/// As [`ep`] with an explicit deadline (`None` for a threat: unavoidable).
fn ep_dl(
    threat: bool,
    t_c: Option<f64>,
    t_dl: Option<f64>,
    t_a: Option<f64>,
    collision: bool,
    max_signal: Option<f64>,
) -> DetectorEpisode {
    let truth = GroundTruth {
        threat,
        t_contact_s: t_c,
        t_deadline_s: t_dl,
        collision,
    };
    // scored from an empty trace, then the alarm filled in by hand (no struct literal, so that
    // fields added to DetectorEpisode later keep their scorer defaults)
    let mut d = metrics::score_detector_episode("hopfield", 1.0, &[], &truth, &ScoringConfig::default()).unwrap();
    d.t_alarm_s = t_a;
    d.outcome = metrics::classify(&truth, t_a, 0.0).unwrap();
    d.ttc_at_alarm_s = t_a.map(|a| 1.0 + a);
    d.angular_size_at_alarm_deg = t_a.map(|_| 10.0);
    d.max_signal = max_signal;
    assert_eq!(
        (d.threat, d.t_contact_s, d.t_deadline_s, d.collision),
        (threat, t_c, t_dl, collision)
    );
    assert_eq!(
        (d.l_over_v_s, d.eye_ttc_at_alarm_s, d.trace.is_none()),
        (None, None, true)
    );
    d
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
        lead_margin_s: 0.0,
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
    // Signal crosses 10 at t = 1.0 (signal = 10·t); contact at 3 s, deadline at 2.5 s.
    let d = metrics::score_detector_episode(
        "hopfield",
        10.0,
        &trace(3.0, |t| 10.0 * t),
        &threat(3.0, 2.5),
        &cfg(0.0),
    )
    .unwrap();
    assert_eq!(d.outcome, Outcome::Hit);
    assert_eq!(d.t_alarm_s, Some(1.0));
    assert_eq!(d.t_deadline_s, Some(2.5));
    assert!(d.evadable());
    // the warning time is still measured to contact; the deadline lead is t_c − t_dl
    assert_close(d.lead_s().unwrap(), 2.0, 1e-12);
    assert_eq!(d.deadline_lead_s(), Some(0.5));
    assert!(!d.is_late_miss() && !d.is_silent_miss());
    // TTC and angular size come from the alarm frame.
    assert_eq!(d.ttc_at_alarm_s, Some(9.0));
    assert_eq!(d.angular_size_at_alarm_deg, Some(4.0));
    // the l/|v| fields are the runner's to fill in
    assert_eq!((d.l_over_v_s, d.eye_ttc_at_alarm_s), (None, None));
}

#[test]
fn deadline_boundary_equality_counts_as_hit() {
    // Exactly representable: t_a = t_dl = 1.5, no margin.
    assert_eq!(
        metrics::classify(&threat(2.0, 1.5), Some(1.5), 0.0).unwrap(),
        Outcome::Hit
    );
    // With a margin: t_a = 1.5 = t_dl − 0.5.
    assert_eq!(
        metrics::classify(&threat(2.5, 2.0), Some(1.5), 0.5).unwrap(),
        Outcome::Hit
    );
    // Not exactly representable: 0.3 − 0.1 = 0.19999999999999998 < 0.2, still a hit.
    let (td, margin) = (std::hint::black_box(0.3), std::hint::black_box(0.1));
    assert!(td - margin < 0.2);
    assert_eq!(
        metrics::classify(&threat(0.5, 0.3), Some(0.2), 0.1).unwrap(),
        Outcome::Hit
    );
    // One frame later is a miss (a late one).
    assert_eq!(
        metrics::classify(&threat(2.5, 2.0), Some(1.5 + 1.0 / 120.0), 0.5).unwrap(),
        Outcome::Miss
    );
    // Later than the deadline by more than the rounding tolerance: a miss.
    assert_eq!(
        metrics::classify(&threat(2.0, 1.5), Some(1.5 + 10.0 * TIME_EPS_S), 0.0).unwrap(),
        Outcome::Miss
    );
    // Via the trace, alarm exactly at the boundary frame.
    let d = metrics::score_detector_episode(
        "x",
        1.0,
        &trace(2.0, |t| if t >= 1.5 { 1.0 } else { 0.0 }),
        &threat(2.0, 1.5),
        &cfg(0.0),
    )
    .unwrap();
    assert_eq!((d.t_alarm_s, d.outcome), (Some(1.5), Outcome::Hit));
    assert_eq!(d.max_signal, Some(1.0), "the boundary frame is inside the ROC window");
}

#[test]
fn hit_iff_alarm_no_later_than_deadline_minus_margin() {
    // Alarm at every frame time of a 120 Hz episode, several deadlines and margins: a hit iff
    // t_a ≤ t_dl − margin (frame-count times, so equality happens and must count).
    let hz = 120.0;
    let t = |k: u32| f64::from(k) / hz;
    for (dl_frame, margin_frames) in [(60u32, 0u32), (60, 6), (37, 12), (1, 0), (200, 24)] {
        let (t_dl, margin) = (t(dl_frame), f64::from(margin_frames) / hz);
        let truth = threat(t_dl + 0.3, t_dl);
        for k in 0..=dl_frame + 5 {
            let o = metrics::classify(&truth, Some(t(k)), margin).unwrap();
            let want = if k + margin_frames <= dl_frame {
                Outcome::Hit
            } else {
                Outcome::Miss
            };
            assert_eq!(
                o, want,
                "deadline frame {dl_frame}, margin {margin_frames} frames, alarm frame {k}"
            );
        }
        // no alarm: a miss whatever the margin
        assert_eq!(metrics::classify(&truth, None, margin).unwrap(), Outcome::Miss);
    }
    // the alarm is compared with the deadline, not with the contact time: an alarm 0.4 s before
    // contact is a miss when the deadline is 0.5 s before contact, a hit when it is 0.3 s before
    assert_eq!(
        metrics::classify(&threat(3.0, 2.5), Some(2.6), 0.0).unwrap(),
        Outcome::Miss
    );
    assert_eq!(
        metrics::classify(&threat(3.0, 2.7), Some(2.6), 0.0).unwrap(),
        Outcome::Hit
    );
}

#[test]
fn late_alarm_is_a_late_miss() {
    // Alarm at 2.8 s, before contact (3 s) but after the deadline (2.5 s).
    let d = metrics::score_detector_episode(
        "x",
        1.0,
        &trace(3.0, |t| if t >= 2.8 { 5.0 } else { 0.0 }),
        &threat(3.0, 2.5),
        &cfg(0.0),
    )
    .unwrap();
    assert_eq!(d.outcome, Outcome::Miss);
    assert_eq!(d.t_alarm_s, Some(2.8));
    assert!(d.is_late_miss() && !d.is_silent_miss());
    assert_eq!(d.lead_s(), None);
    assert_eq!(
        d.max_signal,
        Some(0.0),
        "samples after the deadline are outside the ROC window"
    );
    // An alarm before the deadline but inside the margin is late too.
    let d = metrics::score_detector_episode(
        "x",
        1.0,
        &trace(3.0, |t| if t >= 2.3 { 5.0 } else { 0.0 }),
        &threat(3.0, 2.5),
        &cfg(0.25),
    )
    .unwrap();
    assert!(d.outcome == Outcome::Miss && d.is_late_miss(), "{d:?}");
    assert_eq!(d.max_signal, Some(0.0), "the ROC window ends at t_dl − margin");
}

#[test]
fn no_alarm_on_threat_is_a_silent_miss() {
    let d = metrics::score_detector_episode("x", 10.0, &trace(3.0, |t| t), &threat(3.0, 2.5), &cfg(0.0)).unwrap();
    assert_eq!(d.outcome, Outcome::Miss);
    assert!(d.is_silent_miss() && !d.is_late_miss());
    assert_eq!(
        (d.t_alarm_s, d.ttc_at_alarm_s, d.angular_size_at_alarm_deg),
        (None, None, None)
    );
    assert_eq!(d.max_signal, Some(2.5), "maximum up to the deadline");
}

#[test]
fn unavoidable_threats_are_neither_hits_nor_misses() {
    for t_a in [None, Some(0.1), Some(2.9), Some(3.5)] {
        assert_eq!(
            metrics::classify(&unavoidable(3.0), t_a, 0.0).unwrap(),
            Outcome::Unavoidable,
            "alarm {t_a:?}"
        );
        assert_eq!(
            metrics::classify(&unavoidable(3.0), t_a, 0.5).unwrap(),
            Outcome::Unavoidable
        );
    }
    let d = metrics::score_detector_episode(
        "x",
        0.5,
        &trace(3.5, |t| if t >= 0.5 { t } else { 0.0 }),
        &unavoidable(3.0),
        &cfg(0.0),
    )
    .unwrap();
    assert_eq!(d.outcome, Outcome::Unavoidable);
    assert!(d.threat && !d.evadable());
    assert_eq!((d.t_deadline_s, d.deadline_lead_s()), (None, None));
    assert!(!d.is_late_miss() && !d.is_silent_miss());
    assert_eq!(d.lead_s(), None, "only hits have a lead");
    assert_eq!(d.t_alarm_s, Some(0.5));
    assert_eq!(
        d.max_signal,
        Some(3.0),
        "an unavoidable threat's score window ends at contact"
    );
    assert_eq!(Outcome::Unavoidable.to_string(), "unavoidable");
    assert_eq!("unavoidable".parse::<Outcome>(), Ok(Outcome::Unavoidable));

    // In a summary they are counted apart: not in the hit rate, not ROC positives, not in the
    // evasion rate; they still count as episodes and collisions.
    let eps = [
        ep_dl(true, Some(3.0), None, Some(1.0), true, Some(50.0)), // unavoidable, alarmed early
        ep_dl(true, Some(3.0), None, None, true, Some(0.5)),       // unavoidable, silent
        ep(true, Some(3.0), Some(1.0), false, Some(20.0)),         // hit
        ep(true, Some(3.0), None, true, Some(1.0)),                // silent miss
        ep(false, None, None, false, Some(10.0)),                  // correct rejection
        ep(false, None, Some(2.0), false, Some(30.0)),             // false alarm
    ];
    let s = DetectorSummary::from_episodes(&eps);
    assert_eq!((s.episodes, s.unavoidable_threats, s.evadable_threats), (6, 2, 2));
    assert_eq!((s.hits, s.misses, s.silent_misses, s.late_misses), (1, 1, 1, 0));
    assert_eq!(s.hit_rate, Some(0.5));
    assert_eq!((s.evaded, s.evasion_rate), (1, Some(0.5)));
    assert_eq!((s.collisions, s.collision_rate), (3, Some(0.5)));
    // ROC positives {20, 1}, negatives {10, 30}: 1 of 4 pairs ordered → AUC 0.25. With the
    // unavoidable threats' scores (50, 0.5) as positives it would be 3/8 instead.
    assert_close(s.auc.unwrap(), 0.25, 1e-12);
    assert_eq!(s.roc.iter().filter(|p| p.threshold == Some(50.0)).count(), 0);
    // only unavoidable threats: no hit rate, no evasion rate, no ROC
    let s = DetectorSummary::from_episodes(&eps[..2]);
    assert_eq!(
        (s.hit_rate, s.evasion_rate, s.evasion_rate_ci, s.auc),
        (None, None, None, None)
    );
    assert!(s.roc.is_empty());
    assert_eq!(s.unavoidable_threats, 2);
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
    assert!(!d.evadable() && d.deadline_lead_s().is_none());
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
    let d = metrics::score_detector_episode("x", 10.0, &s, &threat(2.0, 1.5), &cfg(0.1)).unwrap();
    assert_eq!(d.t_alarm_s, Some(1.0));
    assert_eq!(d.outcome, Outcome::Hit);
}

#[test]
fn traces_are_kept_only_on_request() {
    let s = trace(1.0, |t| t);
    let keep = ScoringConfig {
        keep_traces: true,
        ..cfg(0.1)
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
        t_deadline_s: Some(1.0),
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
        t_deadline_s: None,
        collision: false,
    };
    assert!(metrics::score_detector_episode("soc", 1.0, &[], &bad_non_threat, &cfg(0.1)).is_err());
    // a non-threat with a deadline
    let deadline_without_threat = GroundTruth {
        t_deadline_s: Some(1.0),
        ..NO_THREAT
    };
    let e = metrics::score_detector_episode("soc", 1.0, &[], &deadline_without_threat, &cfg(0.1)).unwrap_err();
    assert!(
        e.to_string().contains("`soc`") && e.to_string().contains("deadline"),
        "{e}"
    );
    // a non-finite deadline
    let e = metrics::score_detector_episode("soc", 1.0, &[], &threat(2.0, f64::NAN), &cfg(0.1)).unwrap_err();
    assert!(e.to_string().contains("t_deadline_s"), "{e}");
    assert!(metrics::score_detector_episode("soc", f64::NAN, &[], &NO_THREAT, &cfg(0.1)).is_err());
    assert!(metrics::score_detector_episode("soc", 1.0, &[], &NO_THREAT, &cfg(-1.0)).is_err());
    assert!(metrics::score_detector_episode("soc", 1.0, &[], &NO_THREAT, &cfg(f64::INFINITY)).is_err());
    assert!(metrics::score_detector_episode("soc", 1.0, &[sample(f64::NAN, 0.0)], &NO_THREAT, &cfg(0.1)).is_err());
}

#[test]
fn lead_min_s_is_rejected_naming_lead_margin_s() {
    let old = ScoringConfig {
        lead_min_s: Some(0.2),
        ..ScoringConfig::default()
    };
    let e = old.validate().unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(
            e,
            ScoringError::InvalidConfig {
                key: "scoring.lead_min_s",
                ..
            }
        ),
        "{msg}"
    );
    assert!(msg.contains("lead_min_s") && msg.contains("lead_margin_s"), "{msg}");
    // scoring with it fails the same way
    let e = metrics::score_detector_episode("x", 1.0, &[], &NO_THREAT, &old).unwrap_err();
    assert!(e.to_string().contains("lead_margin_s"), "{e}");
    // config files: the old key still parses (to be rejected), and is never written back
    let parsed: ScoringConfig = serde_json::from_str(r#"{"lead_min_s": 0.2}"#).unwrap();
    assert_eq!(parsed.lead_min_s, Some(0.2));
    assert!(parsed.validate().is_err());
    let json = serde_json::to_string(&ScoringConfig::default()).unwrap();
    assert!(
        !json.contains("lead_min_s") && json.contains("\"lead_margin_s\":0.0"),
        "{json}"
    );
    ScoringConfig::default().validate().unwrap();
    assert_eq!(ScoringConfig::default().lead_margin_s, 0.0);
}

// ---------------------------------------------------------------- aggregation

#[test]
fn summary_counts_rates_and_collision_rate() {
    let eps = [
        // (deadlines 0.1 s before contact)
        ep(true, Some(3.0), Some(1.0), false, Some(30.0)), // hit, lead 2.0
        ep(true, Some(3.0), Some(2.95), true, Some(8.0)),  // late → miss, collision
        ep(true, Some(3.0), None, true, Some(5.0)),        // no alarm → silent miss, collision
        ep(true, Some(2.0), Some(1.9), false, Some(12.0)), // at the deadline → hit, lead 0.1
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
    // escape fields
    assert_eq!((s.evadable_threats, s.unavoidable_threats, s.evaded), (4, 0, 2));
    assert_eq!((s.evasion_rate, s.evasion_rate_ci), (Some(0.5), stats::wilson_95(2, 4)));
    assert_eq!((s.late_misses, s.silent_misses), (1, 1));
    assert_eq!(s.late_misses + s.silent_misses, s.misses);
    assert_eq!(
        (s.hit_collisions, s.false_alarm_collisions),
        (0, 0),
        "the collision of a correct rejection is neither"
    );
    assert_eq!(s.collision_reduction, None, "filled in only against a null row");
    assert_eq!(s.lv_fit, None);
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
    // Threats have deadlines 0.1–0.4 s before contact and are scored with a 0.1 s margin; every
    // fifth is unavoidable (not a ROC positive, not in the hit rate).
    let margin = 0.1;
    let mut cases = Vec::new();
    for i in 0..60 {
        let is_threat = i % 3 != 0;
        let t_c = 2.0 + next();
        let t_dl = t_c - 0.1 - 0.3 * next();
        let (a, b) = (next() * 20.0, next() * 4.0);
        let samples: Vec<TraceSample> = (0..=40)
            .map(|k| k as f64 / 12.0)
            .map(|t| sample(t, a * t / 3.0 + b * (t * 7.0).sin()))
            .collect();
        let truth = match (is_threat, i % 5 == 1) {
            (false, _) => NO_THREAT,
            (true, false) => threat(t_c, t_dl),
            (true, true) => unavoidable(t_c),
        };
        cases.push((samples, truth));
    }
    for theta in [0.5, 3.0, 6.0, 9.0, 12.0] {
        let eps: Vec<DetectorEpisode> = cases
            .iter()
            .map(|(s, g)| metrics::score_detector_episode("x", theta, s, g, &cfg(margin)).unwrap())
            .collect();
        let summary = DetectorSummary::from_episodes(&eps);
        assert!(summary.unavoidable_threats > 0 && summary.evadable_threats > 0);
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
        "lead_margin_s",
        "references",
    ] {
        assert!(v.get(key).is_some(), "metadata key {key}");
    }
    assert!(v.get("lead_min_s").is_none(), "the removed key is not written");
    assert_eq!(v["lead_margin_s"], 0.0);
    assert_eq!(
        v["references"],
        serde_json::json!([]),
        "no reference rows in these episodes"
    );
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
            "evadable_threats",
            "unavoidable_threats",
            "evaded",
            "evasion_rate",
            "evasion_rate_ci",
            "late_misses",
            "silent_misses",
            "hit_collisions",
            "false_alarm_collisions",
            "collision_reduction",
            "lv_fit",
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
    // a line counting the threats (of the first row's episodes), header, rule, three rows
    assert_eq!(lines.len(), 1 + 2 + 3, "\n{table}");
    assert_eq!(
        lines[0], "0 threats (0 evadable, 0 unavoidable), 1 non-threats",
        "\n{table}"
    );
    let rows = &lines[1..];
    assert!(
        rows[0].starts_with("detector")
            && rows[0].contains("hit rate [95% CI]")
            && rows[0].contains("evasion rate [95% CI]")
            && rows[0].contains("coll. reduction")
            && rows[0].ends_with("AUC"),
        "\n{table}"
    );
    let width = rows[0].chars().count();
    assert!(rows.iter().all(|l| l.chars().count() == width), "\n{table}");
    assert!(
        rows[2].starts_with("a_long_detector_id") && rows[2].contains("n/a"),
        "\n{table}"
    );
    // hopfield: 5/5 hits → "1.00 [0.57, 1.00]" (hit rate and, as none collided, evasion rate).
    assert_eq!(rows[3].matches("1.00 [0.57, 1.00]").count(), 2, "\n{table}");
    assert!(!table.contains("reference row"), "no footnote without reference rows");
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

// ---------------------------------------------------------------- escape and collision aggregates

#[test]
fn evasion_rate_is_evaded_over_evadable_threats_with_a_wilson_interval() {
    // 7 evadable threats of which 5 evaded (4 hits, one late miss that still got away), 2
    // unavoidable threats (one dodged anyway: not counted), 3 non-threats.
    let mut eps = vec![
        ep(true, Some(3.0), Some(1.0), false, Some(9.0)),
        ep(true, Some(3.0), Some(1.5), false, Some(9.0)),
        ep(true, Some(3.0), Some(2.0), false, Some(9.0)),
        ep(true, Some(3.0), Some(2.9), false, Some(9.0)), // at the deadline
        ep(true, Some(3.0), Some(2.95), false, Some(1.0)), // late, but evaded
        ep(true, Some(3.0), Some(2.95), true, Some(1.0)), // late, collided
        ep(true, Some(3.0), None, true, Some(1.0)),       // silent
        ep_dl(true, Some(1.0), None, Some(0.5), false, Some(9.0)),
        ep_dl(true, Some(1.0), None, None, true, Some(0.0)),
    ];
    for i in 0..3 {
        eps.push(ep(false, None, None, false, Some(f64::from(i))));
    }
    let s = DetectorSummary::from_episodes(&eps);
    assert_eq!((s.evadable_threats, s.unavoidable_threats), (7, 2));
    assert_eq!((s.hits, s.misses, s.late_misses, s.silent_misses), (4, 3, 2, 1));
    assert_eq!(s.evaded, 5);
    assert_eq!(s.evasion_rate, Some(5.0 / 7.0));
    assert_eq!(s.evasion_rate_ci, stats::wilson_95(5, 7));
    let ci = s.evasion_rate_ci.unwrap();
    assert!(ci.contains(5.0 / 7.0) && ci.lower > 0.0 && ci.upper < 1.0, "{ci:?}");
    // 5/7 by the quadratic-formula reference (as in wilson_interval_matches_independent_reference_values)
    let (n, p, z) = (7.0, 5.0 / 7.0, stats::Z_95);
    let (a, b, c) = (1.0 + z * z / n, -(2.0 * p + z * z / n), p * p);
    let disc = (b * b - 4.0 * a * c).sqrt();
    assert_close(ci.lower, (-b - disc) / (2.0 * a), 1e-12);
    assert_close(ci.upper, (-b + disc) / (2.0 * a), 1e-12);
    // evaded = evadable threats without a collision, whatever the outcome
    let manual = eps.iter().filter(|e| e.evadable() && !e.collision).count() as u64;
    assert_eq!(manual, s.evaded);
    // no evadable threat: no rate, no interval, no NaN in JSON
    let s = DetectorSummary::from_episodes(&eps[7..]);
    assert_eq!(
        (s.evadable_threats, s.evaded, s.evasion_rate, s.evasion_rate_ci),
        (0, 0, None, None)
    );
    let json = serde_json::to_string(&s).unwrap();
    assert!(
        json.contains("\"evasion_rate\":null") && !json.contains("NaN"),
        "{json}"
    );
}

#[test]
fn hit_collisions_and_false_alarm_collisions_are_counted() {
    let eps = [
        ep(true, Some(3.0), Some(1.0), true, Some(9.0)),  // hit that collided
        ep(true, Some(3.0), Some(1.0), true, Some(9.0)),  // another
        ep(true, Some(3.0), Some(1.0), false, Some(9.0)), // hit, evaded
        ep(true, Some(3.0), Some(2.95), true, Some(1.0)), // late miss, collided: not a hit collision
        ep(false, None, Some(1.0), true, Some(9.0)),      // false alarm escape into an object
        ep(false, None, Some(1.0), false, Some(9.0)),     // false alarm, harmless
        ep(false, None, None, true, Some(0.0)),           // correct rejection that collided: neither
        ep_dl(true, Some(1.0), None, Some(0.2), true, Some(9.0)), // unavoidable: neither
    ];
    let s = DetectorSummary::from_episodes(&eps);
    assert_eq!(s.hit_collisions, 2);
    assert_eq!(s.false_alarm_collisions, 1);
    assert_eq!(s.collisions, 6);
    assert_eq!((s.hits, s.false_alarms, s.evaded), (3, 2, 1));
    // the table shows the hits that collided
    let table = report::format_summary_table(&std::collections::BTreeMap::from([("hopfield".to_string(), s)]));
    assert!(table.lines().nth(1).unwrap().contains("hit+coll"), "{table}");
    assert!(table.lines().nth(3).unwrap().contains("  2 (0)  "), "{table}");
}

#[test]
fn collisions_caused_are_the_false_alarms_and_hits_that_collided() {
    let eps = [
        ep(true, Some(3.0), Some(1.0), true, Some(9.0)), // hit that collided: caused
        ep(true, Some(3.0), Some(1.0), false, Some(9.0)), // hit, evaded
        ep(true, Some(3.0), Some(2.95), true, Some(1.0)), // late miss: collides anyway, not caused
        ep(true, Some(3.0), None, true, Some(0.0)),      // silent miss: not caused
        ep(false, None, Some(1.0), true, Some(9.0)),     // false alarm into an object: caused
        ep(false, None, Some(1.0), true, Some(9.0)),     // another
        ep(false, None, Some(1.0), false, Some(9.0)),    // false alarm, harmless
        ep(false, None, None, true, Some(0.0)),          // correct rejection that collided: not caused
        ep_dl(true, Some(1.0), None, Some(0.2), true, Some(9.0)), // unavoidable: not caused
        ep(false, None, None, false, Some(0.0)),         // correct rejection
    ];
    let caused: Vec<bool> = eps.iter().map(|e| e.collision_caused()).collect();
    assert_eq!(
        caused,
        [true, false, false, false, true, true, false, false, false, false]
    );
    let s = DetectorSummary::from_episodes(&eps);
    assert_eq!((s.false_alarm_collisions, s.hit_collisions), (2, 1));
    assert_eq!(s.collisions_caused, 3);
    assert_eq!(s.collisions_caused_rate, Some(0.3), "over all 10 episodes of the row");
    let ci = s.collisions_caused_rate_ci.unwrap();
    assert!(ci.lower < 0.3 && 0.3 < ci.upper, "{ci:?}");
    // in report.json, and the terminal table's column
    let v: serde_json::Value = serde_json::to_value(&s).unwrap();
    assert_eq!(v["collisions_caused"], 3);
    assert_eq!(v["collisions_caused_rate"], 0.3);
    let table = report::format_summary_table(&BTreeMap::from([("hopfield".to_string(), s)]));
    assert!(
        table.lines().nth(1).unwrap().contains("caused coll. (FA+hit)"),
        "{table}"
    );
    assert!(table.lines().nth(3).unwrap().contains("  3 (2+1)  "), "{table}");
    // a row without episodes has no rate
    let empty = DetectorSummary::from_episodes(&[]);
    assert_eq!((empty.collisions_caused, empty.collisions_caused_rate), (0, None));
}

#[test]
fn reports_without_the_collisions_caused_keys_read_with_them_derived() {
    let mut eps = suite_episodes();
    eps.push(episode(
        "pass \"by\"",
        10,
        vec![
            with_detector(ep(false, None, Some(1.0), true, Some(9.0)), "hopfield"),
            with_detector(ep(false, None, None, false, Some(1.0)), "soc"),
        ],
    ));
    let tiers = BTreeMap::from([("approach, frontal".to_string(), 2), ("pass \"by\"".to_string(), 3)]);
    let report = Report::from_tiered_episodes(&meta(), &eps, &tiers);
    let mut v: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
    // an old report: the keys removed everywhere (pooled, per scenario, per tier)
    fn strip(v: &mut serde_json::Value) -> usize {
        let mut n = 0;
        match v {
            serde_json::Value::Object(m) => {
                for k in [
                    "collisions_caused",
                    "collisions_caused_rate",
                    "collisions_caused_rate_ci",
                ] {
                    n += usize::from(m.remove(k).is_some());
                }
                n += m.values_mut().map(strip).sum::<usize>();
            }
            serde_json::Value::Array(a) => n += a.iter_mut().map(strip).sum::<usize>(),
            _ => {}
        }
        n
    }
    assert!(
        strip(&mut v) >= 3 * report.detectors.len() * 2,
        "pooled and per-scenario keys removed"
    );
    let old = Report::from_json(&v.to_string(), Path::new("old.json")).unwrap();
    assert_eq!(old, report, "the derived values equal the ones written");
    assert!(old.detectors.values().any(|s| s.collisions_caused > 0));
}

/// One episode with a `null` row (no alarm) and a detector row, both scored from `truth`.
fn null_and_detector(
    index: usize,
    threat: bool,
    null_collides: bool,
    det_alarm: Option<f64>,
    det_collides: bool,
) -> EpisodeOutcome {
    let t_c = threat.then_some(3.0);
    let null = with_detector(ep(threat, t_c, None, null_collides, Some(0.0)), NULL);
    let det = with_detector(ep(threat, t_c, det_alarm, det_collides, Some(1.0)), "hopfield");
    episode(if index % 2 == 0 { "even" } else { "odd" }, index, vec![det, null])
}

#[test]
fn collision_reduction_is_measured_against_the_null_row() {
    // 6 threats (null collides in all), 4 non-threats; hopfield collides in 2 threats and 1
    // non-threat (a false-alarm escape): reduction 1 − 3/6.
    let mut eps = Vec::new();
    for i in 0..10 {
        let threat = i < 6;
        let collides = (threat && i < 2) || i == 9;
        let alarm = if i == 9 || (threat && i >= 2) { Some(1.0) } else { None };
        eps.push(null_and_detector(i, threat, threat, alarm, collides));
    }
    let by = metrics::summarize_by_detector(&eps);
    assert_eq!((by[NULL].collisions, by["hopfield"].collisions), (6, 3));
    assert_eq!(by["hopfield"].collision_reduction, Some(0.5));
    assert_eq!(by[NULL].collision_reduction, Some(0.0), "null against itself");
    assert_eq!(by["hopfield"].false_alarm_collisions, 1);
    // per scenario, against that scenario's null row: even = {0,2,4,6,8}, odd = {1,3,5,7,9}
    let report = Report::from_episodes(&meta(), &eps);
    assert_eq!(report.detectors["hopfield"].collision_reduction, Some(0.5));
    let even = &report.scenarios["even"].detectors;
    let odd = &report.scenarios["odd"].detectors;
    // even: null 3 collisions (0, 2, 4), hopfield 1 (0) → 2/3; odd: null 3 (1, 3, 5), hopfield 2 (1, 9) → 1/3
    assert_close(even["hopfield"].collision_reduction.unwrap(), 2.0 / 3.0, 1e-12);
    assert_close(odd["hopfield"].collision_reduction.unwrap(), 1.0 / 3.0, 1e-12);
    // a detector worse than null has a negative reduction
    let mut worse = eps.clone();
    for e in &mut worse {
        e.detectors[0].collision = true;
    }
    assert_close(
        metrics::summarize_by_detector(&worse)["hopfield"]
            .collision_reduction
            .unwrap(),
        1.0 - 10.0 / 6.0,
        1e-12,
    );

    // no null row: None
    let without_null: Vec<EpisodeOutcome> = eps
        .iter()
        .cloned()
        .map(|mut e| {
            e.detectors.retain(|d| d.detector != NULL);
            e
        })
        .collect();
    let by = metrics::summarize_by_detector(&without_null);
    assert_eq!(by["hopfield"].collision_reduction, None);
    assert_eq!(
        DetectorSummary::from_episodes(&[ep(true, Some(3.0), None, true, None)]).collision_reduction,
        None
    );

    // a null row that never collides (no threats): None, not a division by zero
    let no_threats: Vec<EpisodeOutcome> = (0..4)
        .map(|i| null_and_detector(i, false, false, Some(1.0), i == 0))
        .collect();
    let by = metrics::summarize_by_detector(&no_threats);
    assert_eq!(by[NULL].collisions, 0);
    assert_eq!(
        (by["hopfield"].collision_reduction, by[NULL].collision_reduction),
        (None, None)
    );
    let text = Report::from_episodes(&meta(), &no_threats).to_json();
    assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
}

/// A suite whose episodes carry the three reference rows beside `hopfield`.
fn episodes_with_references() -> Vec<EpisodeOutcome> {
    let mut out = Vec::new();
    for i in 0..8 {
        let threat = i % 2 == 0;
        let t_c = threat.then_some(3.0);
        let hop = ep(
            threat,
            t_c,
            threat.then_some(2.0),
            false,
            Some(if threat { 20.0 } else { 2.0 }),
        );
        // the oracle alarms exactly at each deadline; its indicator is 1 there
        let oracle = ep(
            threat,
            t_c,
            t_c.map(|c| c - EP_DEADLINE_LEAD_S),
            false,
            Some(if threat { 1.0 } else { 0.0 }),
        );
        let null = ep(threat, t_c, None, threat, Some(0.0));
        // ideal_theta: huge scores on non-threats, so that calibrating it would give a high threshold
        let ideal = ep(threat, t_c, Some(1.0), false, Some(if threat { 30.0 } else { 500.0 }));
        out.push(episode(
            "refs",
            i,
            vec![
                with_detector(hop, "hopfield"),
                with_detector(null, NULL),
                with_detector(oracle, ORACLE),
                with_detector(ideal, IDEAL_THETA),
            ],
        ));
    }
    out
}

#[test]
fn reference_labels_are_reserved_and_listed_in_table_order() {
    assert_eq!(
        REFERENCE_LABELS,
        ["null", "oracle", "ideal_theta", "ideal_tau", "ideal_course"]
    );
    for l in REFERENCE_LABELS {
        assert!(reference::is_reference(l));
    }
    for l in ["hopfield", "soc", "Oracle", "null_1", ""] {
        assert!(!reference::is_reference(l), "{l}");
    }
}

#[test]
fn report_lists_the_references_and_the_table_puts_them_last() {
    let eps = episodes_with_references();
    let report = Report::from_episodes(&meta(), &eps);
    assert_eq!(report.references, ["null", "oracle", "ideal_theta"]);
    let v: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
    assert_eq!(v["references"], serde_json::json!(["null", "oracle", "ideal_theta"]));
    // (these episodes carry three of the reference rows)
    for r in &REFERENCE_LABELS[..3] {
        assert!(
            v["detectors"].get(r).is_some() && v["scenarios"]["refs"]["detectors"].get(r).is_some(),
            "{r}"
        );
    }
    // only those present, still in table order
    let some: Vec<EpisodeOutcome> = eps
        .iter()
        .cloned()
        .map(|mut e| {
            e.detectors.retain(|d| d.detector != NULL);
            e.detectors.reverse();
            e
        })
        .collect();
    assert_eq!(
        Report::from_episodes(&meta(), &some).references,
        ["oracle", "ideal_theta"]
    );
    // round trip, and an old report without the key reads as no references
    let text = report.to_json();
    assert_eq!(Report::from_json(&text, Path::new("mem")).unwrap(), report);
    let mut old: serde_json::Value = serde_json::from_str(&text).unwrap();
    old.as_object_mut().unwrap().remove("references");
    let back = Report::from_json(&old.to_string(), Path::new("old.json")).unwrap();
    assert!(back.references.is_empty());
    // the terminal table: detectors first, then the reference rows marked `*`, then a footnote
    let table = report::format_summary_table(&report.detectors);
    let labels: Vec<&str> = table
        .lines()
        .skip(3)
        .take(4)
        .map(|l| l.split("  ").next().unwrap().trim_end())
        .collect();
    assert_eq!(labels, ["hopfield", "null *", "oracle *", "ideal_theta *"], "\n{table}");
    assert!(
        table
            .lines()
            .next()
            .unwrap()
            .starts_with("4 threats (4 evadable, 0 unavoidable), 4 non-threats"),
        "\n{table}"
    );
    assert!(
        table.trim_end().lines().last().unwrap().starts_with("* reference row"),
        "\n{table}"
    );
    // the oracle evades every evadable threat with no false alarm; null collides with every threat
    let (o, n) = (&report.detectors[ORACLE], &report.detectors[NULL]);
    assert_eq!((o.hits, o.misses, o.false_alarms, o.evasion_rate), (4, 0, 0, Some(1.0)));
    assert_eq!((n.hits, n.silent_misses, n.collision_rate), (0, 4, Some(0.5)));
    assert_eq!(o.collision_reduction, Some(1.0));
}

#[test]
fn calibration_reports_the_rates_at_the_runs_own_threshold_too() {
    // the run alarmed on both threats in time and on two of four non-threats (scores 5)
    let mut detectors = Vec::new();
    for (threat, alarm, score) in [
        (true, Some(2.0), 20.0),
        (true, Some(2.0), 3.0),
        (false, Some(1.0), 5.0),
        (false, Some(1.0), 5.0),
        (false, None, 1.0),
        (false, None, 1.0),
    ] {
        detectors.push(ep(threat, threat.then_some(3.0), alarm, false, Some(score)));
    }
    let eps: Vec<EpisodeOutcome> = detectors
        .into_iter()
        .enumerate()
        .map(|(i, d)| episode("own", i, vec![d]))
        .collect();
    let c = &calibrate::calibrate(&eps, 0.25)[0];
    // one false alarm of four allowed: just above the second-largest non-threat score (5)
    assert!(c.threshold.unwrap() > 5.0 && c.threshold.unwrap() <= 5.01, "{c:?}");
    assert_eq!((c.false_alarm_rate, c.hit_rate), (0.0, Some(0.5)));
    assert_eq!((c.run_false_alarm_rate, c.run_hit_rate), (0.5, Some(1.0)));
}

#[test]
fn references_are_excluded_from_calibration() {
    let eps = episodes_with_references();
    let cal = calibrate::calibrate(&eps, 0.1);
    let labels: Vec<&str> = cal.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(labels, ["hopfield"], "{cal:?}");
    // hopfield: 4 non-threats with score 2.0 → the threshold is just above 2; every threat hits
    let c = &cal[0];
    assert_eq!(c.non_threats, 4);
    assert!(c.threshold.unwrap() > 2.0 && c.threshold.unwrap() <= 2.01, "{c:?}");
    assert_eq!((c.false_alarm_rate, c.hit_rate), (0.0, Some(1.0)));
    // unavoidable threats are not positives of the calibration's hit rate either
    let mut with_unavoidable = eps.clone();
    with_unavoidable.push(episode(
        "refs",
        99,
        vec![ep_dl(true, Some(1.0), None, None, true, Some(0.0))],
    ));
    assert_eq!(calibrate::calibrate(&with_unavoidable, 0.1)[0].hit_rate, Some(1.0));
}

#[test]
fn references_are_not_regression_checked() {
    let base = report_of(&episodes_with_references());
    // the current run: the oracle got much worse (every threat a silent miss that collided), null
    // and ideal_theta are gone; hopfield unchanged
    let cur_eps: Vec<EpisodeOutcome> = episodes_with_references()
        .into_iter()
        .map(|mut e| {
            e.detectors.retain(|d| d.detector == "hopfield" || d.detector == ORACLE);
            for d in &mut e.detectors {
                if d.detector == ORACLE {
                    let worse = if d.threat {
                        ep(true, d.t_contact_s, None, true, Some(0.0)) // silent miss, collided
                    } else {
                        ep(false, None, Some(0.5), false, Some(5.0)) // false alarm
                    };
                    *d = with_detector(worse, ORACLE);
                }
            }
            e
        })
        .collect();
    let cur = report_of(&cur_eps);
    let (o_cur, o_base) = (&cur.detectors[ORACLE], &base.detectors[ORACLE]);
    assert!(o_cur.collision_rate > o_base.collision_rate && o_cur.hit_rate < o_base.hit_rate);
    assert!(o_cur.false_alarm_rate > o_base.false_alarm_rate && o_cur.auc < o_base.auc);
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
    let regs = regression::compare(&cur, &base, &strict);
    assert!(regs.is_empty(), "{regs:?}");
    // a detector regression is still found beside them
    let mut worse = cur_eps.clone();
    for e in &mut worse {
        let d = &mut e.detectors[0];
        if d.threat {
            *d = ep(true, d.t_contact_s, None, true, Some(0.0));
        }
    }
    let regs = regression::compare(&report_of(&worse), &base, &strict);
    assert!(!regs.is_empty());
    assert!(
        regs.iter().all(|r| r.detector.as_deref() == Some("hopfield")),
        "{regs:?}"
    );
}

// ---------------------------------------------------------------- l/|v|

/// A head-on threat for the l/|v| fit: `l_over_v` and the eye TTC at the alarm (`None`: no alarm).
fn lv_episode(l_over_v: Option<f64>, eye_ttc: Option<f64>) -> DetectorEpisode {
    let mut d = ep(true, Some(3.0), eye_ttc.map(|_| 1.0), false, Some(10.0));
    d.l_over_v_s = l_over_v;
    d.eye_ttc_at_alarm_s = eye_ttc;
    d
}

#[test]
fn lv_fit_is_in_the_summary_from_three_qualifying_episodes() {
    // a detector that fires at θ = 15° after a 40 ms delay: t = (l/|v|)/tan(7.5°) − 0.04
    let (theta_deg, delay) = (15.0f64, 0.04);
    let at = |x: f64| x / (theta_deg.to_radians() / 2.0).tan() - delay;
    let xs = [0.02, 0.035, 0.05, 0.08];
    let qualifying: Vec<DetectorEpisode> = xs.iter().map(|&x| lv_episode(Some(x), Some(at(x)))).collect();
    // episodes that do not qualify: no l/|v| (not head-on), or no alarm
    let others = [
        lv_episode(None, Some(0.7)),
        lv_episode(Some(0.06), None),
        ep(false, None, Some(1.0), false, Some(1.0)),
    ];
    assert_eq!(lv::MIN_FIT_EPISODES, 3);
    // two qualifying episodes: no fit
    let two: Vec<&DetectorEpisode> = qualifying[..2].iter().chain(&others).collect();
    assert_eq!(DetectorSummary::from_episodes(two).lv_fit, None);
    // three: a fit through them
    let three: Vec<&DetectorEpisode> = qualifying[..3].iter().chain(&others).collect();
    let f = DetectorSummary::from_episodes(three)
        .lv_fit
        .expect("three qualifying episodes");
    assert_eq!(f.episodes, 3);
    assert_close(f.theta_th_deg.unwrap(), theta_deg, 1e-9);
    assert_close(f.delay_s, delay, 1e-12);
    assert_close(f.r2, 1.0, 1e-12);
    assert_close(f.slope, 1.0 / (theta_deg.to_radians() / 2.0).tan(), 1e-9);
    assert_close(f.intercept_s, -delay, 1e-12);
    // all four, in a summary by detector and in the report JSON
    let mut eps: Vec<EpisodeOutcome> = qualifying
        .iter()
        .chain(&others)
        .enumerate()
        .map(|(i, d)| episode("lv", i, vec![d.clone()]))
        .collect();
    let report = Report::from_episodes(&meta(), &eps);
    let f = report.detectors["hopfield"].lv_fit.unwrap();
    assert_eq!(f.episodes, 4);
    assert_eq!(report.scenarios["lv"].detectors["hopfield"].lv_fit, Some(f));
    assert_eq!(Some(f), LvFit::fit(&xs.map(|x| (x, at(x)))));
    let v: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
    let j = &v["detectors"]["hopfield"]["lv_fit"];
    assert_eq!(j["episodes"], 4);
    for key in ["slope", "intercept_s", "theta_th_deg", "delay_s", "r2"] {
        assert!(j[key].is_number(), "lv_fit.{key}: {j}");
    }
    // noisy points: R² below 1, still a fit
    eps[1].detectors[0].eye_ttc_at_alarm_s = Some(at(0.035) + 0.05);
    let f = Report::from_episodes(&meta(), &eps).detectors["hopfield"]
        .lv_fit
        .unwrap();
    assert!(f.r2 < 1.0 && f.r2 > 0.5, "{f:?}");
    // no lv_fit: null in JSON
    let v: serde_json::Value =
        serde_json::from_str(&Report::from_episodes(&meta(), &suite_episodes()).to_json()).unwrap();
    assert_eq!(v["detectors"]["hopfield"]["lv_fit"], serde_json::Value::Null);
}

// ---------------------------------------------------------------- episodes.csv with deadlines

#[test]
fn csv_appends_new_columns_and_reads_files_without_them() {
    assert_eq!(
        HEADER[HEADER.len() - 2..],
        ["collision_caused", "t_in_view_s"],
        "new columns are appended"
    );
    assert_eq!(
        HEADER[HEADER.len() - 3],
        "theta_required_deg",
        "the columns before keep their order"
    );
    let caused = ep(false, None, Some(1.0), true, Some(9.0)); // a false alarm that collided
    let mut evaded = ep(true, Some(3.0), Some(1.0), false, Some(9.0));
    evaded.t_in_view_s = Some(0.25);
    let eps = vec![episode(
        "caused",
        0,
        vec![with_detector(caused, "hopfield"), with_detector(evaded, "soc")],
    )];
    let text = episodes_csv::header_line() + &episodes_csv::format_rows(&eps[0]);
    let last_two: Vec<Vec<&str>> = text.lines().map(|l| l.rsplitn(3, ',').take(2).collect()).collect();
    assert_eq!(
        last_two,
        [["t_in_view_s", "collision_caused"], ["", "true"], ["0.25", "false"]]
    );
    assert_eq!(
        episodes_csv::parse_episodes_csv(&text, Path::new("new.csv")).unwrap(),
        eps
    );
    // files written before the columns existed: every line without its last cell, then its last two
    let cut = |text: &str| -> String {
        text.lines()
            .map(|l| format!("{}\n", &l[..l.rfind(',').unwrap()]))
            .collect()
    };
    let before_in_view = cut(&text);
    assert!(!before_in_view.contains("t_in_view_s"));
    let mut unknown_in_view = eps.clone();
    unknown_in_view[0].detectors[1].t_in_view_s = None;
    assert_eq!(
        episodes_csv::parse_episodes_csv(&before_in_view, Path::new("old.csv")).unwrap(),
        unknown_in_view
    );
    let old = cut(&before_in_view);
    assert!(!old.contains("collision_caused"));
    assert_eq!(
        episodes_csv::parse_episodes_csv(&old, Path::new("old.csv")).unwrap(),
        unknown_in_view
    );
    // any other missing column is still an error naming it
    let bad = old.replacen("theta_required_deg", "theta_req", 1);
    let e = episodes_csv::parse_episodes_csv(&bad, Path::new("bad.csv"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing column `theta_required_deg`"), "{e}");
}

#[test]
fn evasion_in_view_counts_the_evadable_threats_seen_by_their_deadline() {
    // ep(): the deadline EP_DEADLINE_LEAD_S before contact
    let deadline = 3.0 - EP_DEADLINE_LEAD_S;
    let seen = |t_a: Option<f64>, collision: bool, t_in_view_s: Option<f64>| {
        let mut e = ep(true, Some(3.0), t_a, collision, Some(9.0));
        e.t_in_view_s = t_in_view_s;
        e
    };
    let eps = [
        seen(Some(1.0), false, Some(0.0)),                   // seen from the start, evaded
        seen(Some(deadline), true, Some(deadline)),          // in view exactly at its deadline: seen in time
        seen(Some(2.99), true, Some(deadline + 0.01)),       // first in view after its deadline: not counted
        seen(None, true, None),                              // never in view before contact: not counted
        ep(false, None, None, false, None),                  // no threat
        ep_dl(true, Some(1.0), None, None, true, Some(0.0)), // unavoidable
    ];
    let in_time: Vec<bool> = eps.iter().map(|e| e.seen_in_time()).collect();
    assert_eq!(in_time, [true, true, false, false, false, false]);
    let s = DetectorSummary::from_episodes(&eps);
    assert_eq!((s.evaded, s.evadable_threats), (1, 4));
    assert_eq!((s.evaded_in_view, s.evadable_in_view), (1, 2));
    assert_eq!(s.evasion_rate_in_view, Some(0.5));
    // reports written before the keys existed read them as zero
    let mut v: serde_json::Value = serde_json::to_value(&s).unwrap();
    for k in ["evadable_in_view", "evaded_in_view", "evasion_rate_in_view"] {
        v.as_object_mut().unwrap().remove(k);
    }
    let old: DetectorSummary = serde_json::from_value(v).unwrap();
    assert_eq!((old.evadable_in_view, old.evasion_rate_in_view), (0, None));
}

#[test]
fn csv_round_trip_keeps_the_deadline_and_lv_columns() {
    for name in [
        "t_deadline_s",
        "deadline_lead_s",
        "evadable",
        "l_over_v_s",
        "eye_ttc_at_alarm_s",
    ] {
        assert!(HEADER.contains(&name), "{name}");
    }
    let mut hit = ep_dl(true, Some(0.5), Some(0.1 + 0.2), Some(0.2), false, Some(9.0));
    assert_eq!(hit.outcome, Outcome::Hit);
    hit.l_over_v_s = Some(0.05);
    hit.eye_ttc_at_alarm_s = Some(2.0000000000000004);
    let late = ep(true, Some(2.5), Some(2.45), true, Some(1.0));
    let unav = ep_dl(true, Some(0.4), None, Some(0.2), true, Some(5.0));
    let non = ep(false, None, Some(1.0), false, Some(3.0));
    let eps = vec![episode(
        "deadlines",
        0,
        vec![
            with_detector(hit, "hopfield"),
            with_detector(late, "soc"),
            with_detector(unav, IDEAL_THETA),
            with_detector(non, ORACLE),
        ],
    )];
    let p = tmp("deadlines.csv");
    let mut w = EpisodesCsvWriter::create(&p).unwrap();
    w.write_episode(&eps[0]).unwrap();
    drop(w);
    let text = std::fs::read_to_string(&p).unwrap();
    let back = episodes_csv::read_episodes_csv(&p).unwrap();
    assert_eq!(back, eps);
    assert_eq!(back[0].detectors[0].t_deadline_s, Some(0.30000000000000004));
    // the written cells, by column name (no field of these rows holds a comma)
    let rows: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == HEADER.len()), "{text}");
    let col = |row: usize, name: &str| -> String {
        let i = HEADER.iter().position(|h| *h == name).unwrap();
        rows[row][i].to_string()
    };
    assert_eq!(col(0, "outcome"), "hit");
    assert_eq!(col(0, "t_deadline_s"), "0.30000000000000004");
    assert_eq!(col(0, "deadline_lead_s"), (0.5 - (0.1 + 0.2)).to_string());
    assert_eq!(col(0, "lead_s"), (0.5f64 - 0.2).to_string());
    assert_eq!(col(0, "evadable"), "true");
    assert_eq!(col(0, "l_over_v_s"), "0.05");
    assert_eq!(col(0, "eye_ttc_at_alarm_s"), "2.0000000000000004");
    assert_eq!(col(1, "outcome"), "miss");
    assert_eq!(
        col(1, "deadline_lead_s"),
        (2.5f64 - (2.5 - EP_DEADLINE_LEAD_S)).to_string()
    );
    assert_eq!(
        (col(1, "lead_s"), col(1, "l_over_v_s"), col(1, "eye_ttc_at_alarm_s")),
        (String::new(), String::new(), String::new())
    );
    assert_eq!(col(2, "outcome"), "unavoidable");
    assert_eq!(
        (col(2, "t_deadline_s"), col(2, "deadline_lead_s"), col(2, "evadable")),
        (String::new(), String::new(), "false".to_string())
    );
    assert_eq!(col(3, "outcome"), "false_alarm");
    assert_eq!(
        (col(3, "t_deadline_s"), col(3, "evadable")),
        (String::new(), "false".to_string())
    );
    // the derived columns are ignored on reading: a wrong value changes nothing
    let tampered = text.replacen(",true,0.05,", ",false,0.05,", 1);
    assert_ne!(tampered, text);
    assert_eq!(
        episodes_csv::parse_episodes_csv(&tampered, Path::new("t.csv")).unwrap(),
        eps
    );
    // the report rebuilt from the CSV equals the one from memory
    assert_eq!(
        Report::from_episodes(&meta(), &back),
        Report::from_episodes(&meta(), &eps)
    );
    // a file without the new columns (an older version's) is refused, naming the missing column
    let old_header = HEADER[..14].join(",");
    let e = episodes_csv::parse_episodes_csv(&format!("{old_header}\n"), Path::new("old.csv")).unwrap_err();
    assert!(e.to_string().contains("missing column `t_deadline_s`"), "{e}");
    let q = tmp("old.csv");
    std::fs::write(&q, format!("{old_header}\n")).unwrap();
    assert!(
        EpisodesCsvWriter::append(&q)
            .unwrap_err()
            .to_string()
            .contains("new output folder")
    );
    // a malformed deadline names its column
    let bad = text.replacen("0.30000000000000004", "soon", 1);
    let e = episodes_csv::parse_episodes_csv(&bad, Path::new("b.csv")).unwrap_err();
    assert!(
        e.to_string().contains("b.csv:2") && e.to_string().contains("t_deadline_s"),
        "{e}"
    );
}

// ---------------------------------------------------------------- difficulty tiers

fn tiered(eps: &[EpisodeOutcome], tiers: &[(&str, u8)]) -> Report {
    let map: std::collections::BTreeMap<String, u8> = tiers.iter().map(|(s, t)| (s.to_string(), *t)).collect();
    Report::from_tiered_episodes(&meta(), eps, &map)
}

#[test]
fn tiers_pool_their_scenarios_with_the_pooled_summary_keys() {
    let mut eps = block("easy", 10, 9, 1, 1);
    eps.extend(block("easy_too", 5, 5, 0, 0));
    eps.extend(block("hard", 8, 2, 6, 6));
    eps.extend(block("untiered", 3, 3, 0, 0));
    let r = tiered(&eps, &[("easy", 0), ("easy_too", 0), ("hard", 3)]);
    assert_eq!(r.tiers.keys().collect::<Vec<_>>(), ["0", "3"]);
    let t0 = &r.tiers["0"];
    assert_eq!(
        (t0.episodes, t0.threats, t0.non_threats, t0.evadable_threats),
        (30, 15, 15, 15)
    );
    assert_eq!(t0.detectors["hopfield"].hits, 14);
    assert_eq!(t0.detectors["hopfield"].false_alarms, 1);
    let t3 = &r.tiers["3"];
    assert_eq!((t3.episodes, t3.threats, t3.non_threats), (16, 8, 8));
    assert_eq!(t3.detectors["hopfield"].hit_rate, Some(0.25));
    // the pooled summary still holds every episode, the untiered scenario's too
    assert_eq!(r.detectors["hopfield"].episodes, 52);

    // report.json: `tiers.<t>` has exactly the documented keys, and each row the pooled keys
    let json: serde_json::Value = serde_json::from_str(&r.to_json()).unwrap();
    let tier = json["tiers"]["0"].as_object().unwrap();
    let mut keys: Vec<&str> = tier.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        ["detectors", "episodes", "evadable_threats", "non_threats", "threats"]
    );
    let pooled: Vec<&String> = json["detectors"]["hopfield"].as_object().unwrap().keys().collect();
    let per_tier: Vec<&String> = tier["detectors"]["hopfield"].as_object().unwrap().keys().collect();
    assert_eq!(pooled, per_tier);
    // it reads back, and a report of an older loomlab (no `tiers`) reads as untiered
    assert_eq!(Report::from_json(&r.to_json(), Path::new("r.json")).unwrap(), r);
    let mut old = json.clone();
    old.as_object_mut().unwrap().remove("tiers");
    assert!(
        Report::from_json(&old.to_string(), Path::new("old.json"))
            .unwrap()
            .tiers
            .is_empty()
    );
    // the terminal table has a pooled table per tier
    let table = r.format_table(false);
    assert!(table.contains("\ntier 0 (paper; 30 episodes)"), "{table}");
    assert!(table.contains("\ntier 3 (hard; 16 episodes)"), "{table}");
    assert!(!table.contains("tier 1"), "{table}");
    // without tiers the report has an empty `tiers` object
    let json: serde_json::Value = serde_json::from_str(&report_of(&eps).to_json()).unwrap();
    assert_eq!(json["tiers"], serde_json::json!({}));
}

#[test]
fn regressions_are_checked_per_tier() {
    // a tier that gets worse while the pooled rates stay within tolerance is flagged per tier
    let mut base_eps = block("a", 40, 36, 2, 2);
    base_eps.extend(block("b", 10, 9, 0, 0));
    let mut cur_eps = block("a", 40, 36, 2, 2);
    cur_eps.extend(block("b", 10, 3, 0, 0));
    let tiers = [("a", 1), ("b", 2)];
    let tol = Tolerances {
        per_scenario: false,
        ..Tolerances::default()
    };
    let regs = regression::compare(&tiered(&cur_eps, &tiers), &tiered(&base_eps, &tiers), &tol);
    assert!(
        regs.iter().any(|r| r.tier == Some(2)
            && r.scenario.is_none()
            && matches!(r.kind, RegressionKind::Metric { metric: "hit_rate", .. })),
        "{regs:?}"
    );
    assert!(regs.iter().all(|r| r.tier != Some(1)), "{regs:?}");
    let line = regs.iter().find(|r| r.tier == Some(2)).unwrap().to_string();
    assert!(
        line.starts_with("tier 2 / detector `hopfield` / hit_rate: 0.900 → 0.300"),
        "{line}"
    );
    // a tier of the baseline missing now is a regression
    let regs = regression::compare(&tiered(&base_eps, &[("a", 1)]), &tiered(&base_eps, &tiers), &tol);
    assert!(
        regs.iter()
            .any(|r| r.tier == Some(2) && r.kind == RegressionKind::MissingTier),
        "{regs:?}"
    );
    assert!(regression::compare(&tiered(&base_eps, &tiers), &tiered(&base_eps, &tiers), &tol).is_empty());
}
