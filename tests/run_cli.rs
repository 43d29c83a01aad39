//! End-to-end tests of `loomlab run` on a tiny suite (4 episodes, 32×32 frames): outputs, the
//! report contract (design §7), regression mode and exit codes. Needs a GPU adapter (lavapipe).

use crate::common;

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
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .ends_with(",impulse_ns,theta_required_deg,collision_caused,t_in_view_s")
    );
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

/// The default suite against its committed baseline (minutes: `make suite-check` runs the same check
/// with the same release build; here `cargo test --release --workspace --test cli -- --ignored
/// default_suite`).
#[test]
#[ignore = "runs the whole default suite (about 2 min in release on 2 cores); make suite-check"]
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

// ---- issue 29: nothing lost, nothing escapes, nothing silent ----

/// One scenario file: the slow ball of `BALL` (2 episodes) under `name`.
fn named_suite(dir: &std::path::Path, name: &str) -> PathBuf {
    let suite = dir.join("suite");
    std::fs::create_dir_all(&suite).unwrap();
    let text = format!("name = {}\n{BALL}", toml::Value::String(name.into()));
    std::fs::write(suite.join("ball.toml"), text).unwrap();
    suite
}

/// Every file under `dir` (relative paths).
fn files_under(dir: &std::path::Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn overwrite_deletes_only_the_files_the_run_wrote() {
    let dir = tmp("overwrite");
    let suite = tiny_suite(&dir);
    let out = dir.join("out");
    // the user's own files, in the folders a run writes to, before any run
    std::fs::create_dir_all(out.join("traces")).unwrap();
    std::fs::create_dir_all(out.join("exemplars")).unwrap();
    std::fs::write(out.join("traces/mine.csv"), "keep").unwrap();
    std::fs::write(out.join("exemplars/mine.gif"), "keep").unwrap();
    std::fs::create_dir_all(out.join("traces/sub")).unwrap();
    std::fs::write(out.join("traces/sub/deep.txt"), "keep").unwrap();
    let base = ["run", s(&suite), "--out", s(&out), "--limit", "2", "--traces"];
    // user files alone are not a run: no refusal, and they survive the run
    let o = loomlab(&base);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(out.join("traces/ball_0000.csv").is_file() && out.join("report.html").is_file());
    let listed = std::fs::read_to_string(out.join("written.txt")).unwrap();
    assert!(listed.lines().any(|l| l == "traces/ball_0000.csv"), "{listed}");
    assert!(!listed.contains("mine"), "{listed}");
    // a rerun is refused, and the message says what --overwrite deletes
    let o = loomlab(&base);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(e.contains("deletes only the files that run wrote"), "{e}");
    // --overwrite (without --traces this time): the run's traces go, the user's files stay
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--limit",
        "1",
        "--overwrite",
        "--no-html",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    for f in ["traces/mine.csv", "exemplars/mine.gif", "traces/sub/deep.txt"] {
        assert_eq!(std::fs::read_to_string(out.join(f)).unwrap(), "keep", "{f}");
    }
    assert!(!out.join("traces/ball_0000.csv").exists() && !out.join("report.html").exists());
    assert!(
        files_under(&out.join("exemplars")) == ["mine.gif"],
        "{:?}",
        files_under(&out.join("exemplars"))
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_of_the_users_where_a_run_writes_is_never_replaced() {
    let dir = tmp("userfiles");
    let suite = tiny_suite(&dir);
    for (i, rel) in [
        "traces/ball_0000.csv",
        "traces/.ball_0001.csv.tmp",
        "exemplars/ball_0001.gif",
        "plot_samples.jsonl",
        ".report.json.tmp",
        ".manifest.json.tmp",
        "tier_evasion.png",
    ]
    .into_iter()
    .enumerate()
    {
        let out = dir.join(format!("out{i}"));
        let mine = out.join(rel);
        std::fs::create_dir_all(mine.parent().unwrap()).unwrap();
        std::fs::write(&mine, "mine").unwrap();
        let o = loomlab(&["run", s(&suite), "--out", s(&out), "--limit", "2", "--traces"]);
        let e = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{rel}: {e}");
        assert!(
            e.contains(&mine.display().to_string()) && e.contains("a file of yours"),
            "{rel}: {e}"
        );
        assert_eq!(std::fs::read_to_string(&mine).unwrap(), "mine", "{rel}");
        assert!(!out.join("manifest.json").exists(), "{rel}: nothing written");
    }
    // files that the run does not write are no obstacle (other names, other episodes)
    let out = dir.join("others");
    for rel in [
        "traces/ball_0003.csv",
        "traces/ball_00000.csv",
        "exemplars/other_0000.gif",
        "notes.png",
    ] {
        std::fs::create_dir_all(out.join(rel).parent().unwrap()).unwrap();
        std::fs::write(out.join(rel), "mine").unwrap();
    }
    let o = loomlab(&["run", s(&suite), "--out", s(&out), "--limit", "2", "--traces"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(out.join("traces/ball_0000.csv").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn links_in_the_output_folder_never_lead_a_write_or_a_delete_outside_it() {
    use std::os::unix::fs::symlink;
    let dir = tmp("links");
    let suite = tiny_suite(&dir);
    let outside = dir.join("outside");
    std::fs::create_dir_all(outside.join("traces")).unwrap();
    std::fs::create_dir_all(outside.join("exemplars")).unwrap();
    let nothing_outside = |what: &str| {
        let mut found = Vec::new();
        for sub in ["", "traces", "exemplars"] {
            for e in std::fs::read_dir(outside.join(sub)).unwrap() {
                let p = e.unwrap().path();
                if p.is_file() {
                    found.push(p.display().to_string());
                }
            }
        }
        assert!(found.is_empty(), "{what}: written outside --out: {found:?}");
    };
    // a dangling link at a file the run writes, links at the folders it writes into
    for (i, (rel, target)) in [
        ("plot_samples.jsonl", outside.join("samples.jsonl")),
        ("episodes.csv", outside.join("episodes.csv")),
        (".manifest.json.tmp", outside.join("manifest.json")),
        ("traces", outside.join("traces")),
        ("exemplars", outside.join("exemplars")),
    ]
    .into_iter()
    .enumerate()
    {
        let out = dir.join(format!("out{i}"));
        std::fs::create_dir_all(&out).unwrap();
        symlink(&target, out.join(rel)).unwrap();
        for extra in [&[][..], &["--overwrite"]] {
            let o = loomlab(
                &[
                    &["run", s(&suite), "--out", s(&out), "--limit", "2", "--traces"][..],
                    extra,
                ]
                .concat(),
            );
            let e = text(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{rel} {extra:?}: {e}");
            // a link at a run file makes the folder look like an earlier run's: refused as such
            assert!(
                (e.contains(&out.join(rel).display().to_string()) && e.contains("symbolic link"))
                    || (extra.is_empty() && e.contains("already holds")),
                "{rel} {extra:?}: {e}"
            );
            nothing_outside(rel);
            assert!(
                std::fs::symlink_metadata(out.join(rel))
                    .unwrap()
                    .file_type()
                    .is_symlink()
            );
        }
    }
    // --overwrite after the run's traces folder became a link: the files out there stay
    let out = dir.join("overwrite");
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--limit",
        "2",
        "--traces",
        "--no-html",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    std::fs::remove_dir_all(out.join("traces")).unwrap();
    symlink(outside.join("traces"), out.join("traces")).unwrap();
    std::fs::write(outside.join("traces/ball_0000.csv"), "precious").unwrap();
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--limit",
        "1",
        "--overwrite",
        "--no-html",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(outside.join("traces/ball_0000.csv")).unwrap(),
        "precious"
    );
    assert!(
        std::fs::symlink_metadata(out.join("traces"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_name_with_a_path_is_refused_before_anything_is_written() {
    let dir = tmp("escape");
    for name in [
        "../../escape/evil",
        "sub/x",
        "<script>alert(1)</script>",
        "..",
        ".hidden",
        "a b",
    ] {
        let suite = named_suite(&dir, name);
        let out = dir.join("deep/er/out");
        let o = loomlab(&["run", s(&suite), "--out", s(&out), "--traces"]);
        assert_eq!(o.status.code(), Some(2), "{name}: {}", text(&o.stderr));
        let e = text(&o.stderr);
        assert!(e.contains("name") && e.contains("ball.toml"), "{name}: {e}");
        assert!(!out.exists(), "{name}: nothing written");
        assert!(!dir.join("escape").exists() && !dir.join("deep/escape").exists());
    }
    // an unusual but valid name: the whole run, report.html included
    let suite = named_suite(&dir, "Ball_1.2+fast-v3");
    let out = dir.join("ok");
    let o = loomlab(&["run", s(&suite), "--out", s(&out), "--traces", "--limit", "1"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(out.join("report.html").is_file());
    assert!(out.join("traces/Ball_1.2+fast-v3_0000.csv").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn random_scenario_names_never_make_a_path_outside_the_output_folder() {
    // property test (seeded, bounded): every name the schema accepts gives trace and exemplar
    // files directly inside their folder of --out; the others are refused
    use loomlab_report::run_plots::trace_file_name;
    use loomlab_scenarios::schema::check_file_name;
    use std::path::Component;
    let alphabet: Vec<char> = "aZ09_-.+/\\:<>&\"' \u{0}\n~$*?é…".chars().collect();
    let mut state: u64 = 0x2929_2929;
    let mut next = |n: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % n as u64) as usize
    };
    let (mut accepted, mut refused) = (0, 0);
    for _ in 0..20_000 {
        let len = next(12);
        let name: String = (0..len).map(|_| alphabet[next(alphabet.len())]).collect();
        let ok = check_file_name(&name).is_ok();
        // what the schema says agrees: a scenario file with this name loads iff the check passes
        if next(50) == 0 {
            let text = format!("name = {}\n{BALL}", toml::Value::String(name.clone()));
            let parsed = loomlab_scenarios::parse_scenario(
                &text,
                std::path::Path::new("x.toml"),
                None,
                &loomlab_scenarios::LoadOptions::default(),
            );
            assert_eq!(parsed.is_ok(), ok, "{name:?}: {:?}", parsed.err());
        }
        if !ok {
            refused += 1;
            continue;
        }
        accepted += 1;
        for file in [trace_file_name(&name, 7), format!("{name}_0007.gif")] {
            let p = std::path::Path::new(&file);
            let parts: Vec<Component> = p.components().collect();
            assert!(
                parts.len() == 1 && matches!(parts[0], Component::Normal(_)) && !file.starts_with('.'),
                "{name:?} gives {file:?}"
            );
        }
    }
    assert!(
        accepted > 100 && refused > 100,
        "{accepted} accepted, {refused} refused"
    );
}

#[test]
fn a_closed_stdout_never_panics_nor_changes_the_run_state() {
    use std::process::Stdio;
    let dir = tmp("pipe");
    let suite = tiny_suite(&dir);
    let out = dir.join("out");
    let run = |extra: &[&str]| {
        let mut child = common::loomlab_command()
            .args(["run", s(&suite), "--out", s(&out), "--limit", "2", "--no-html"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take()); // the reader is gone (`| head -1` after its line, `| true`)
        child.wait_with_output().unwrap()
    };
    let o = run(&[]);
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert!(!e.contains("panicked") && !e.contains("Broken pipe"), "{e}");
    let state = |d: &std::path::Path| -> String {
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("manifest.json")).unwrap()).unwrap();
        m["state"].as_str().unwrap().to_string()
    };
    assert_eq!(state(&out), "complete");
    // a resume of an interrupted run with a closed stdout: it resumes, to the truth
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    m["state"] = "interrupted".into();
    std::fs::write(out.join("manifest.json"), m.to_string()).unwrap();
    let csv = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    let keep: Vec<&str> = csv.lines().take(1 + (csv.lines().count() - 1) / 2).collect();
    std::fs::write(out.join("episodes.csv"), keep.join("\n") + "\n").unwrap();
    let o = run(&["--resume"]);
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(state(&out), "complete");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn combinations_that_cannot_work_are_refused() {
    let dir = tmp("refuse");
    let suite = tiny_suite(&dir);
    let out = dir.join("out");
    let bad = |args: &[&str], want: &[&str]| {
        let o = loomlab(args);
        let e = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        for w in want {
            assert!(e.contains(w), "{args:?}: `{w}` not in {e}");
        }
    };
    // a θ̂ trigger on a detector without θ̂ would never alarm
    let soc = dir.join("soc.toml");
    std::fs::write(
        &soc,
        BALL.replace("threshold = 0.01", "threshold = 0.01\ntrigger = \"angular_size_deg\""),
    )
    .unwrap();
    bad(
        &["run", s(&soc), "--out", s(&out)],
        &["detectors[1].trigger", "soc", "θ̂"],
    );
    // a dangling symlink in a suite folder is an error, not a smaller suite
    #[cfg(unix)]
    {
        let linked = dir.join("linked");
        std::fs::create_dir_all(&linked).unwrap();
        std::fs::write(linked.join("ball.toml"), BALL).unwrap();
        std::os::unix::fs::symlink(dir.join("gone.toml"), linked.join("gone.toml")).unwrap();
        bad(
            &["run", s(&linked), "--out", s(&out)],
            &["gone.toml", "symbolic link", "does not exist"],
        );
    }
    // speeds the simulator cannot resolve (an object passing through the robot between two
    // physics substeps) are refused, naming the substeps that would resolve them
    let fast = dir.join("fast.toml");
    std::fs::write(&fast, BALL.replace("speed_mps = 3.0", "speed_mps = 3000.0")).unwrap();
    bad(
        &["run", s(&fast), "--out", s(&out)],
        &[
            "world.projectiles[0].speed_mps",
            "3000",
            "physics_substeps to at least 42",
        ],
    );
    let car = dir.join("car.toml");
    std::fs::write(
        &car,
        "[world]\ncamera = { n = 32 }\n[[world.vehicles]]\nstart = [10.0, 0.0]\nheading_deg = 180.0\nspeed_mps = 1e7\nparts = [{ shape = { kind = \"box\", size = [1.0, 1.0, 1.0] } }]\n",
    )
    .unwrap();
    bad(
        &["run", s(&car), "--out", s(&out)],
        &["world.vehicles[0].speed_mps", "lower the speed"],
    );
    // a list file listing a list file
    let inner = dir.join("inner.toml");
    std::fs::write(&inner, "scenarios = [\"suite/ball.toml\"]\n").unwrap();
    let outer = dir.join("outer.toml");
    std::fs::write(&outer, "scenarios = [\"inner.toml\"]\n").unwrap();
    bad(&["run", s(&outer), "--out", s(&out)], &["inner.toml", "list file"]);
    // --bless with --limit would replace the baseline with a part of the suite
    let baseline = dir.join("base.json");
    bad(
        &[
            "run",
            s(&suite),
            "--out",
            s(&out),
            "--baseline",
            s(&baseline),
            "--bless",
            "--limit",
            "2",
        ],
        &["--bless", "--limit 2", "drop --limit"],
    );
    assert!(!baseline.exists() && !out.exists());
    // a baseline of another suite is not compared
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--no-html",
        "--no-plots",
        "--baseline",
        s(&baseline),
        "--bless",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let other = dir.join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("ball.toml"), BALL).unwrap();
    bad(
        &[
            "run",
            s(&other),
            "--out",
            s(&dir.join("o2")),
            "--baseline",
            s(&baseline),
        ],
        &["another suite", "fast_ball"],
    );
    bad(
        &[
            "run",
            s(&other),
            "--out",
            s(&dir.join("o2")),
            "--baseline",
            s(&baseline),
            "--bless",
        ],
        &["another suite", "refusing to replace it"],
    );
    // --resume without the --traces the run was started with
    let t = dir.join("t");
    let mut child = common::loomlab_command();
    let o = child
        .args([
            "run",
            s(&suite),
            "--out",
            s(&t),
            "--limit",
            "1",
            "--traces",
            "--no-html",
            "--no-plots",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t.join("manifest.json")).unwrap()).unwrap();
    m["state"] = "interrupted".into();
    std::fs::write(t.join("manifest.json"), m.to_string()).unwrap();
    bad(
        &[
            "run",
            s(&suite),
            "--out",
            s(&t),
            "--limit",
            "1",
            "--no-html",
            "--no-plots",
            "--resume",
        ],
        &["--traces", "Resume it with its own command"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn messages_name_the_right_key_and_value() {
    let dir = tmp("messages");
    let out = dir.join("out");
    let check = |edit: &dyn Fn(&str) -> String, extra: &[&str], want: &[&str], not: &[&str]| {
        let f = dir.join("m.toml");
        std::fs::write(&f, edit(BALL)).unwrap();
        let o = loomlab(&[&["run", s(&f), "--out", s(&out)][..], extra].concat());
        let e = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        for w in want {
            assert!(e.contains(w), "`{w}` not in {e}");
        }
        for n in not {
            assert!(!e.contains(n), "`{n}` in {e}");
        }
    };
    check(
        &|t| t.replace("camera = { n = 32 }", "camera = { n = 32, pitch_deg = nan }"),
        &[],
        &["world.camera.pitch_deg", "NaN"],
        &["world.camera.position"],
    );
    check(
        &|t| {
            t.replace(
                "camera = { n = 32 }",
                "camera = { n = 32, shake = { translation_m = 1e9 } }",
            )
        },
        &[],
        &["world.camera.shake.translation_m"],
        &["launch_position"],
    );
    check(
        &|t| format!("{t}\n[[world.projectiles]]\nname = \"b\"\n[[world.projectiles]]\nname = \"b\"\n"),
        &[],
        &["world.projectiles[2].name", "world.projectiles[1].name", "`b`"],
        &["`world.name`"],
    );
    check(
        &|t| {
            t.replace("ground = { enabled = false }", "")
                .replace("radius_m = 0.15", "radius_m = 1e9")
        },
        &[],
        &["world.projectiles[0].radius_m", "1000000000"],
        &["launch_position"],
    );
    check(
        &|t| t.to_string(),
        &["--size", "1"],
        &["--size 1", "20..=2048"],
        &["world.camera.n"],
    );
    check(
        &|t| t.replace("target = \"camera\"", "target = \"robott\""),
        &[],
        &[
            "world.projectiles[0].target",
            "unknown target `robott`",
            "\"robot\", \"camera\"",
        ],
        &["untagged"],
    );
    // an OS error is printed once
    let o = loomlab(&["run", s(&dir.join("missing")), "--out", s(&out)]);
    let e = text(&o.stderr);
    assert_eq!(e.matches("os error").count(), 1, "{e}");
    // no "plots in" with --no-plots
    let suite = tiny_suite(&dir);
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&dir.join("np")),
        "--limit",
        "1",
        "--no-plots",
        "--no-html",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(!text(&o.stdout).contains("plots in"), "{}", text(&o.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--traces` writes what a row's decision strategy saw (θ̂ before it, the tracker's region, the
/// looming side, the robot's own motion), and replaying the strategy from those columns gives the
/// recorded decision values bit for bit (`loomlab_scenarios::replay`); other parameters give other
/// values.
#[test]
fn traces_hold_the_strategy_inputs_and_replay_reproduces_the_decisions() {
    let dir = tmp("replay");
    let scenario = dir.join("ball.toml");
    std::fs::create_dir_all(&dir).unwrap();
    let tau_rows = r#"[[detectors]]
id = "tracker"
label = "tracker_tau"
trigger = "tau"
course = "image"
[[detectors]]
id = "hopfield"
label = "hopfield_tau"
trigger = "tau"
course = "image"
params = { front_end = "adapted", readout = "winner" }
"#;
    let text_of = BALL.replace(
        "[[detectors]]\nid = \"hopfield\"",
        &format!("{tau_rows}[[detectors]]\nid = \"hopfield\""),
    );
    // a shaking camera: the strategies remove its shake (the trace's ego_camera_* columns)
    let shaken = "n = 64, shake = { rotation_deg = 0.5, translation_m = 0.0, frequency_hz = 3.0 }";
    std::fs::write(&scenario, text_of.replace("n = 32", shaken)).unwrap();
    let out = dir.join("out");
    let o = loomlab(&[
        "run",
        s(&scenario),
        "--out",
        s(&out),
        "--traces",
        "--no-html",
        "--no-plots",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let trace = std::fs::read_to_string(out.join("traces/ball_0000.csv")).unwrap();
    let header: Vec<&str> = trace.lines().next().unwrap().split(',').collect();
    for column in [
        "looming_side",
        "ego_forward_mps",
        "ego_camera_yaw_rad",
        "ego_camera_pitch_rad",
        "tracker_tau_theta_hat_deg",
        "tracker_tau_tau_s",
        "tracker_tau_gate_open",
        "tracker_tau_left",
        "tracker_tau_track",
        "tracker_tau_about_threat",
        "hopfield_tau_tau_s",
    ] {
        assert!(header.contains(&column), "{column} in {header:?}");
    }
    assert!(
        !header.contains(&"soc_tau_s") && !header.contains(&"hopfield_tau_left"),
        "{header:?}"
    );
    let yaw = header.iter().position(|c| *c == "ego_camera_yaw_rad").unwrap();
    assert!(
        trace
            .lines()
            .skip(1)
            .any(|l| l.split(',').nth(yaw).is_some_and(|v| v.parse::<f64>().unwrap() != 0.0)),
        "the camera's shake is recorded"
    );
    let config = loomlab_agents::EscapeConfig {
        decision: loomlab_agents::DecisionRule {
            trigger: loomlab_agents::TriggerSignal::Tau,
            course: loomlab_agents::Course::Image,
            ..loomlab_agents::DecisionRule::default()
        },
        ..Default::default()
    };
    for label in ["tracker_tau", "hopfield_tau"] {
        let r = loomlab_scenarios::replay::replay_run(&out, label, &config, &loomlab_agents::RobotFacts::default())
            .unwrap();
        assert_eq!(r.episodes, 2, "{label}");
        assert!(r.frames > 200, "{label}: {r:?}");
        assert_eq!(r.differing, 0, "{label}: {r:?}");
        assert_eq!(r.recorded, r.replayed, "{label}");
    }
    // the threat is evadable and the tracker sees it in time; a strategy that ignores θ̂ below 60°
    // decides otherwise and alarms too late
    let r = loomlab_scenarios::replay::replay_run(&out, "tracker_tau", &config, &loomlab_agents::RobotFacts::default())
        .unwrap();
    assert_eq!((r.recorded.evadable, r.recorded.hits), (1, 1), "{r:?}");
    let late = loomlab_agents::EscapeConfig {
        decision: loomlab_agents::DecisionRule {
            min_angular_size_deg: 60.0,
            ..config.decision
        },
        ..config.clone()
    };
    let r = loomlab_scenarios::replay::replay_run(&out, "tracker_tau", &late, &loomlab_agents::RobotFacts::default())
        .unwrap();
    assert!(r.differing > 0 && r.replayed.hits == 0 && r.recorded.hits == 1, "{r:?}");
    // a row without a stateful strategy cannot be replayed, and says why
    let e = loomlab_scenarios::replay::replay_run(&out, "soc", &config, &loomlab_agents::RobotFacts::default())
        .unwrap_err();
    assert!(e.contains("no column soc_theta_hat_deg"), "{e}");
}
