//! Difficulty tiers end to end: a suite of tier-2 files reports tier 2 only (terminal, report.json,
//! report.html), `--tier` runs a subset, a bad `--tier` is bad input, and the committed baseline of
//! the default suite is a ladder (every tier with >= 30 threats and >= 30 non-threats, >= 80 %
//! of its threats evadable, every row in every tier). Needs a GPU adapter (lavapipe).

use std::path::{Path, PathBuf};

use crate::common::{BALL, loomlab, s, text, tmp};

/// A suite folder of two scenarios (two episodes each) with the tiers given.
fn tiered_suite(dir: &Path, tiers: [u8; 2]) -> PathBuf {
    let suite = dir.join("suite");
    std::fs::create_dir_all(&suite).unwrap();
    std::fs::write(suite.join("ball.toml"), format!("tier = {}\n{BALL}", tiers[0])).unwrap();
    std::fs::write(
        suite.join("fast_ball.toml"),
        format!(
            "tier = {}\n{}",
            tiers[1],
            BALL.replace("speed_mps = 3.0", "speed_mps = 5.0")
        ),
    )
    .unwrap();
    suite
}

fn report_json(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

fn keys(v: &serde_json::Value) -> Vec<String> {
    v.as_object().unwrap().keys().cloned().collect()
}

#[test]
fn a_suite_of_tier_2_files_reports_tier_2_only_everywhere() {
    let dir = tmp("tiers", "all-2");
    let suite = tiered_suite(&dir, [2, 2]);
    let out = dir.join("out");
    let o = loomlab(&["run", s(&suite), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}{}", text(&o.stdout), text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(stdout.contains("\ntier 2 (ego-motion; 4 episodes)"), "{stdout}");
    for t in [0, 1, 3] {
        assert!(!stdout.contains(&format!("\ntier {t} (")), "{stdout}");
    }
    let report = report_json(&out);
    assert_eq!(keys(&report["tiers"]), ["2"]);
    let t2 = &report["tiers"]["2"];
    assert_eq!(
        (&t2["episodes"], &t2["threats"], &t2["non_threats"]),
        (&serde_json::json!(4), &serde_json::json!(2), &serde_json::json!(2))
    );
    // every row of the pooled table, reference rows included, with the pooled summary's keys
    assert_eq!(keys(&t2["detectors"]), keys(&report["detectors"]));
    for (label, pooled) in report["detectors"].as_object().unwrap() {
        assert_eq!(keys(&t2["detectors"][label]), keys(pooled), "{label}");
        // one tier holding every episode pools exactly like the suite
        assert_eq!(
            t2["detectors"][label]["evasion_rate"], pooled["evasion_rate"],
            "{label}"
        );
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("id=\"tiers\"") && html.contains("id=\"tier-2\""),
        "no tier section"
    );
    assert!(!html.contains("id=\"tier-0\"") && !html.contains("id=\"tier-3\""));
    for plot in ["plot-tier_evasion", "plot-tier_false_alarms"] {
        assert!(html.contains(plot), "{plot} missing from report.html");
    }
    assert!(out.join("tier_evasion.png").is_file() && out.join("tier_false_alarms.png").is_file());
}

#[test]
fn tier_option_runs_only_the_scenarios_of_those_tiers() {
    let dir = tmp("tiers", "select");
    let suite = tiered_suite(&dir, [0, 3]);
    let out = dir.join("out");
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--tier",
        "3",
        "--no-html",
        "--no-plots",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}{}", text(&o.stdout), text(&o.stderr));
    let report = report_json(&out);
    assert_eq!(report["episodes"], 2);
    assert_eq!(keys(&report["scenarios"]), ["fast_ball"]);
    assert_eq!(keys(&report["tiers"]), ["3"]);

    // both tiers: the whole suite, two tiers
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--overwrite",
        "--tier",
        "0,3",
        "--no-html",
        "--no-plots",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}{}", text(&o.stdout), text(&o.stderr));
    assert_eq!(keys(&report_json(&out)["tiers"]), ["0", "3"]);

    // bad input: exit 2, the value and the fix named, nothing run
    for (tier, needle) in [("4", "--tier 4"), ("1", "no scenario of the suite has that tier")] {
        let o = loomlab(&[
            "run",
            s(&suite),
            "--out",
            s(&dir.join("bad")),
            "--tier",
            tier,
            "--no-html",
        ]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{tier}: {err}");
        assert!(err.contains(needle), "{tier}: {err}");
    }
}

/// The committed baseline of the default suite is a ladder: four tiers, each with at least 30
/// threats (at least 80 % of them evadable) and 30 non-threats, and every detector and reference
/// row in each tier.
#[test]
fn the_default_baseline_has_four_balanced_tiers_with_every_row() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let report =
        loomlab_scenarios::report::Report::read_json(&root.join("scenarios/baseline/default-report.json")).unwrap();
    assert_eq!(report.tiers.keys().collect::<Vec<_>>(), ["0", "1", "2", "3"]);
    let mut episodes = 0;
    for (t, s) in &report.tiers {
        assert!(
            s.threats >= 30 && s.non_threats >= 30 && s.evadable_threats as f64 >= 0.8 * s.threats as f64,
            "tier {t}: {} threats ({} evadable), {} non-threats",
            s.threats,
            s.evadable_threats,
            s.non_threats
        );
        assert_eq!(
            s.detectors.keys().collect::<Vec<_>>(),
            report.detectors.keys().collect::<Vec<_>>(),
            "tier {t}"
        );
        episodes += s.episodes;
    }
    assert_eq!(
        episodes, report.episodes,
        "every episode of the default suite is in a tier"
    );
}
