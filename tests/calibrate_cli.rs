//! `loomlab calibrate`: thresholds calibrated on several runs' non-threat episodes pooled.

use loomlab_scenarios::calibrate::threshold_for_false_alarm_rate;
use loomlab_scenarios::episodes_csv::read_episodes_csv;

use crate::common::{loomlab, s, text, tiny_suite, tmp};

/// The printed threshold of `label` in `loomlab calibrate`'s output.
fn printed_threshold(out: &str, label: &str) -> f64 {
    let line = out
        .lines()
        .find(|l| l.split_whitespace().next() == Some(label))
        .unwrap_or_else(|| panic!("no line for {label}:\n{out}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = words.iter().position(|w| *w == "threshold").unwrap();
    words[at + 1].parse().unwrap_or_else(|_| panic!("{line}"))
}

#[test]
fn thresholds_are_calibrated_on_the_runs_non_threats_pooled() {
    let dir = tmp("calibrate", "pooled");
    let suite = tiny_suite(&dir);
    let runs: Vec<_> = [3, 4]
        .iter()
        .map(|seed| {
            let out = dir.join(format!("seed{seed}"));
            let o = loomlab(&[
                "run",
                s(&suite),
                "--seed",
                &seed.to_string(),
                "--out",
                s(&out),
                "--quiet",
                "--no-plots",
                "--no-html",
            ]);
            assert!(o.status.success(), "{}", text(&o.stderr));
            out
        })
        .collect();
    let o = loomlab(&["calibrate", "--false-alarm-rate", "0.25", s(&runs[0]), s(&runs[1])]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.contains("the non-threat episodes of 2 runs pooled"), "{out}");
    // the same threshold as the library's calibration over both runs' non-threats together
    let non_threat_scores = |label: &str| -> Vec<f64> {
        runs.iter()
            .flat_map(|r| read_episodes_csv(&r.join("episodes.csv")).unwrap())
            .flat_map(|e| e.detectors)
            .filter(|d| d.detector == label && !d.threat)
            .map(|d| d.roc_score())
            .collect()
    };
    for label in ["hopfield", "soc"] {
        let scores = non_threat_scores(label);
        assert_eq!(scores.len(), 4, "two non-threats per run and scenario pair");
        assert!(out.contains(&format!("over {} non-threats", scores.len())), "{out}");
        if let Some(expected) = threshold_for_false_alarm_rate(&scores, 0.25) {
            let printed = printed_threshold(&out, label);
            assert!(
                (printed - expected).abs() <= 1e-9 * expected.abs().max(1.0),
                "{label}: {printed} vs {expected}"
            );
            // at most one of the four pooled non-threats reaches it
            assert!(
                scores.iter().filter(|&&v| v >= printed).count() <= 1,
                "{label}: {scores:?}"
            );
        }
    }
    // reference rows are not calibrated
    assert!(!out.lines().any(|l| l.trim_start().starts_with("oracle")), "{out}");
}

#[test]
fn bad_input_is_refused_with_the_folder_named() {
    let dir = tmp("calibrate", "bad");
    let suite = tiny_suite(&dir);
    let run = dir.join("run");
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&run),
        "--quiet",
        "--no-plots",
        "--no-html",
        "--limit",
        "2",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // the same run twice would count its episodes twice
    let o = loomlab(&["calibrate", "--false-alarm-rate", "0.1", s(&run), s(&run)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("is in an earlier run too"),
        "{}",
        text(&o.stderr)
    );
    // a folder that holds no run
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = loomlab(&["calibrate", "--false-alarm-rate", "0.1", s(&empty)]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(err.contains(s(&empty)) && err.contains("no episodes.csv"), "{err}");
    // a rate outside [0, 1]
    let o = loomlab(&["calibrate", "--false-alarm-rate", "1.5", s(&run)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("[0, 1], got 1.5"), "{}", text(&o.stderr));
}
