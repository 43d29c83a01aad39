//! End-to-end tests of `loomlab run` on a tiny suite (4 episodes, 32×32 frames): outputs, the
//! report contract (design §7), regression mode and exit codes. Needs a GPU adapter (lavapipe).

mod common;

use std::path::PathBuf;

use common::{BALL, loomlab, s, text, tiny_suite};

fn tmp(name: &str) -> PathBuf {
    common::tmp("run-cli", name)
}

/// The report's detector labels, without the reference rows.
fn detector_labels(report: &serde_json::Value) -> Vec<String> {
    let rows = report["detectors"].as_object().unwrap().keys();
    rows.filter(|k| !loomlab_scenarios::reference::is_reference(k))
        .cloned()
        .collect()
}

#[test]
fn tiny_suite_writes_report_csv_plots_and_checks_regressions() {
    let dir = tmp("suite");
    let suite = tiny_suite(&dir);
    let out = dir.join("out");
    let baseline = dir.join("baseline").join("report.json");

    // --bless runs the suite and writes the baseline
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--baseline",
        s(&baseline),
        "--bless",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}{}", text(&o.stdout), text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(stdout.contains("hit rate [95% CI]") && stdout.contains("hopfield") && stdout.contains("soc"));
    assert!(
        stdout.contains("scenario ball") && stdout.contains("scenario fast_ball"),
        "{stdout}"
    );
    assert!(baseline.is_file());

    // report.json has the contract keys
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["episodes"], 4);
    for id in ["hopfield", "soc"] {
        let d = &report["detectors"][id];
        for key in [
            "episodes",
            "hits",
            "misses",
            "false_alarms",
            "correct_rejections",
            "hit_rate",
            "false_alarm_rate",
            "collisions",
            "collision_rate",
        ] {
            assert!(d.get(key).is_some(), "detectors.{id}.{key} missing");
        }
        assert_eq!(d["episodes"], 4);
        assert_eq!(
            d["hits"].as_u64().unwrap() + d["misses"].as_u64().unwrap(),
            2,
            "two threats"
        );
    }
    assert!(report["scenarios"]["ball"]["detectors"]["soc"].is_object());
    // the early soc alarm (threshold 0.01) evades the slow ball
    assert_eq!(report["scenarios"]["ball"]["detectors"]["soc"]["hits"], 1);

    // episodes.csv: a header and one row per episode and detector
    let csv = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    assert!(csv.starts_with("scenario,episode,seed,params,detector,threat,"));
    // two detectors and the five reference rows (null, oracle, ideal_theta, ideal_tau, ideal_course)
    assert_eq!(csv.lines().count(), 1 + 4 * (2 + 5));
    assert!(csv.lines().next().unwrap().ends_with(",impulse_ns,theta_required_deg"));
    assert_eq!(
        report["references"],
        serde_json::json!(["null", "oracle", "ideal_theta", "ideal_tau", "ideal_course"])
    );
    // the oracle alarms at every threat's deadline, the null row never
    assert_eq!(report["detectors"]["oracle"]["false_alarms"], 0);
    assert_eq!(report["detectors"]["null"]["hits"], 0);
    for png in ["roc.png", "rates.png", "collisions.png", "trace.png"] {
        assert!(out.join(png).metadata().unwrap().len() > 1000, "{png}");
    }

    // the same folder again: refused, nothing changed
    let before = std::fs::read(out.join("episodes.csv")).unwrap();
    let o = loomlab(&["run", s(&suite), "--out", s(&out), "--quiet"]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(
        e.contains("already holds a complete run") && e.contains("--resume") && e.contains("--overwrite"),
        "{e}"
    );
    assert_eq!(std::fs::read(out.join("episodes.csv")).unwrap(), before);

    // resumed when complete: nothing runs, the report is rebuilt from episodes.csv and has no
    // regression against the baseline written from the run itself
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--baseline",
        s(&baseline),
        "--resume",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(
        stdout.contains("4 of 4 episodes were done") && stdout.contains("\n0 episodes (plus 4"),
        "{stdout}"
    );
    assert!(stdout.contains("no regression"), "{stdout}");
    assert_eq!(std::fs::read(out.join("episodes.csv")).unwrap(), before);

    // a baseline that was better: exit 1, every regression listed
    let mut better: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&baseline).unwrap()).unwrap();
    for d in ["hopfield", "soc"] {
        let det = &mut better["detectors"][d];
        det["hit_rate"] = 1.0.into();
        det["hit_rate_ci"] = serde_json::json!({"lower": 1.0, "upper": 1.0});
        det["collision_rate"] = 0.0.into();
        det["collision_rate_ci"] = serde_json::json!({"lower": 0.0, "upper": 0.0});
    }
    let worse_base = dir.join("better.json");
    std::fs::write(&worse_base, serde_json::to_string_pretty(&better).unwrap()).unwrap();
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--baseline",
        s(&worse_base),
        "--quiet",
        "--no-plots",
        "--overwrite",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let stderr = text(&o.stderr);
    assert!(stderr.contains("regression"), "{stderr}");
    assert!(
        stderr.contains("`hopfield` / hit_rate") && stderr.contains("`hopfield` / collision_rate"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_exits_2_with_a_clear_message() {
    let dir = tmp("bad");
    let out = dir.join("out");
    let case = |name: &str, content: &str| {
        let p = dir.join(name);
        std::fs::write(&p, content).unwrap();
        p
    };

    let malformed = case("malformed.toml", "[world\ncamera = 3\n");
    let o = loomlab(&["run", s(&malformed), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(e.contains("malformed.toml") && e.contains("invalid TOML"), "{e}");

    let unknown = case("unknown.toml", &BALL.replace("radius_m = 0.15", "radius = 0.15"));
    let o = loomlab(&["run", s(&unknown), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(
        e.contains("unknown.toml") && e.contains("`world.projectiles[0].radius`"),
        "{e}"
    );
    assert!(e.contains("unknown field"), "{e}");

    let wrong_type = case(
        "wrong_type.toml",
        &BALL.replace("duration_s = 2.2", "duration_s = \"long\""),
    );
    let o = loomlab(&["run", s(&wrong_type), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(
        e.contains("wrong_type.toml") && e.contains("`episode.duration_s`") && e.contains("invalid type"),
        "{e}"
    );

    let missing = dir.join("no_such_suite");
    let o = loomlab(&["run", s(&missing), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(e.contains("no_such_suite") && e.contains("cannot read"), "{e}");

    let good = case("good.toml", BALL);
    let o = loomlab(&[
        "run",
        s(&good),
        "--out",
        s(&out),
        "--baseline",
        s(&dir.join("nope.json")),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("nope.json"), "{}", text(&o.stderr));

    let o = loomlab(&["run", s(&good), "--out", s(&out), "--detectors", "hopfeld"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("hopfeld"), "{}", text(&o.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn detectors_file_replaces_every_scenarios_detector_list() {
    let dir = tmp("detectors-file");
    let suite = tiny_suite(&dir);
    let entries = dir.join("detectors.toml");
    std::fs::write(
        &entries,
        "[[detectors]]\nid = \"soc\"\nlabel = \"soc-low\"\nthreshold = 0.01\n\n[[detectors]]\nid = \"soc\"\nlabel = \"soc-never\"\nthreshold = 1e12\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--quiet",
        "--no-plots",
        "--detectors-file",
        s(&entries),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(detector_labels(&report), ["soc-low", "soc-never"]);
    // the low threshold alarms in every episode, the other never
    assert_eq!(report["detectors"]["soc-never"]["hits"], 0);
    assert_eq!(report["detectors"]["soc-never"]["false_alarms"], 0);
    assert_eq!(report["detectors"]["soc-low"]["false_alarms"], 2);
    let episodes = loomlab_scenarios::episodes_csv::read_episodes_csv(&out.join("episodes.csv")).unwrap();
    let low: Vec<_> = episodes
        .iter()
        .flat_map(|e| &e.detectors)
        .filter(|d| d.detector == "soc-low")
        .collect();
    assert_eq!(low.len(), 4);
    assert!(low.iter().all(|d| d.t_alarm_s.is_some()), "{low:?}");

    // --detectors filters the file's entries (it never adds a detector the file does not list)
    let mixed = dir.join("mixed.toml");
    std::fs::write(
        &mixed,
        "[[detectors]]\nid = \"hopfield\"\n[[detectors]]\nid = \"soc\"\nlabel = \"soc-low\"\nthreshold = 0.01\n",
    )
    .unwrap();
    let only_soc = dir.join("only-soc");
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&only_soc),
        "--quiet",
        "--no-plots",
        "--limit",
        "1",
        "--detectors-file",
        s(&mixed),
        "--detectors",
        "soc",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(only_soc.join("report.json")).unwrap()).unwrap();
    assert_eq!(detector_labels(&report), ["soc-low"]);
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&dir.join("never")),
        "--detectors-file",
        s(&entries),
        "--detectors",
        "soc,hopfield",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(
        e.contains("--detectors hopfield") && e.contains("detectors.toml has no `hopfield` entry"),
        "{e}"
    );
    assert!(!dir.join("never").exists(), "nothing written for bad input");

    // a bad entry is named with its file and key
    std::fs::write(&entries, "[[detectors]]\nid = \"soc\"\nthreshhold = 1.0\n").unwrap();
    let o = loomlab(&["run", s(&suite), "--out", s(&out), "--detectors-file", s(&entries)]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(e.contains("detectors.toml") && e.contains("threshhold"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn no_suite_argument_runs_the_default_suite() {
    let dir = tmp("default");
    let out = dir.join("out");
    let o = loomlab(&[
        "run",
        "--limit",
        "2",
        "--size",
        "32",
        "--brief",
        "--no-plots",
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(
        stdout.contains("scenarios/suites/default") && stdout.contains("2 episodes"),
        "{stdout}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The default suite against its committed baseline (minutes: `make suite-check` runs it in a release
/// build; `cargo test -- --ignored default_suite` here).
#[test]
#[ignore = "runs the whole default suite (about 4 min in release on 2 cores); make suite-check"]
fn default_suite_does_not_regress() {
    let dir = tmp("default-suite");
    let o = loomlab(&[
        "run",
        "--out",
        s(&dir.join("out")),
        "--baseline",
        "scenarios/baseline/default-report.json",
        "--quiet",
        "--no-plots",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Lobbed balls that bounce on the ground before they reach a cruising robot (dynamic physics).
const LOB: &str = r#"description = "bouncing lob"
[episode]
duration_s = 1.6
seed = 5
[world]
camera = { n = 32 }
[[world.projectiles]]
target = [1.2, 0.0, -0.1]
radius_m = 0.12
speed_mps = 9.0
launch_distance_m = 7.0
launch_elevation_deg = 12.0
launch_time_s = 0.1
gravity = true
restitution = 0.7
texture = { kind = "uniform", luminance = 0.05 }
[robot]
forward_mps = 0.5
[[detectors]]
id = "soc"
threshold = 0.02
[sweep]
"world.projectiles.0.target" = [[1.2, 0.0, -0.1], [1.0, 0.6, -0.1], [1.4, -0.4, -0.1]]
"#;

#[test]
fn episodes_csv_is_identical_for_one_and_two_workers() {
    let dir = tmp("workers");
    let suite = dir.join("lob.toml");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(&suite, LOB).unwrap();
    let csv = |jobs: &str| {
        let out = dir.join(format!("jobs{jobs}"));
        let o = loomlab(&[
            "run",
            s(&suite),
            "--out",
            s(&out),
            "--jobs",
            jobs,
            "--quiet",
            "--no-plots",
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
        std::fs::read_to_string(out.join("episodes.csv")).unwrap()
    };
    let one = csv("1");
    assert_eq!(one, csv("2"), "episodes.csv differs between 1 and 2 workers");
    // the suite exercises the dynamics: some episode collides with a measured impact
    let episodes = loomlab_scenarios::episodes_csv::read_episodes_csv(&dir.join("jobs1").join("episodes.csv")).unwrap();
    assert_eq!(episodes.len(), 3);
    assert!(
        episodes
            .iter()
            .flat_map(|e| &e.detectors)
            .any(|d| d.collision && d.impact_speed_mps.is_some_and(|v| v > 1.0) && d.impulse_ns.is_some()),
        "{one}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
