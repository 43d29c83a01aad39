//! Nothing lost: `loomlab run` refuses to overwrite an earlier run, stops cleanly on SIGINT
//! keeping every finished episode, and `--resume` runs only the missing episodes to the same
//! report as an uninterrupted run. Needs a GPU adapter (lavapipe).

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::{loomlab, loomlab_command, s, text};
use std::time::{Duration, Instant};

/// A ball at a standing robot, at six miss distances (two of them threats).
const BALL: &str = r#"description = "slow ball"
[episode]
duration_s = 1.5
seed = 1
[world]
sky_luminance = 0.5
camera = { n = 32 }
ground = { enabled = false }
[[world.projectiles]]
target = "camera"
radius_m = 0.15
speed_mps = 4.0
launch_distance_m = 5.0
launch_time_s = 0.1
miss_angle_deg = 180.0
texture = { kind = "uniform", luminance = 0.0 }
[[detectors]]
id = "soc"
threshold = 0.01
[sweep]
"world.projectiles.0.miss_distance_m" = [0.0, 0.1, 0.6, 1.0, 1.5, 2.0]
"#;

const EPISODES: usize = 12;

fn tmp(name: &str) -> PathBuf {
    common::tmp("run-resume", name)
}

/// Two scenarios of six episodes.
fn suite(dir: &Path) -> PathBuf {
    let suite = dir.join("suite");
    std::fs::create_dir_all(&suite).unwrap();
    std::fs::write(suite.join("ball.toml"), BALL).unwrap();
    std::fs::write(
        suite.join("fast_ball.toml"),
        BALL.replace("speed_mps = 4.0", "speed_mps = 6.0"),
    )
    .unwrap();
    suite
}

/// report.json without its wall time.
fn report(dir: &Path, name: &str) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join(name)).unwrap()).unwrap();
    v.as_object_mut().unwrap().remove("wall_time_s");
    v
}

/// Rows of episodes.csv (without the header).
fn rows(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("episodes.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(String::from)
        .collect()
}

fn manifest_state(dir: &Path) -> String {
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap();
    m["state"].as_str().unwrap().to_string()
}

#[test]
fn an_interrupted_run_resumes_to_the_uninterrupted_report() {
    let dir = tmp("interrupt");
    let suite = suite(&dir);
    let common = ["--jobs", "1", "--no-plots", "--quiet"];

    let full = dir.join("full");
    let o = loomlab(&[&["run", s(&suite), "--out", s(&full)][..], &common].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(manifest_state(&full), "complete");
    let rows_per_episode = rows(&full).len() / EPISODES;

    // interrupt after the first finished episode
    let part = dir.join("part");
    let child = loomlab_command()
        .args([&["run", s(&suite), "--out", s(&part)][..], &common].concat())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !part.join("episodes.csv").exists() || rows(&part).is_empty() {
        assert!(started.elapsed() < Duration::from_secs(120), "no episode finished");
        std::thread::sleep(Duration::from_millis(5));
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let o = child.wait_with_output().unwrap();
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("interrupted:") && stderr.contains("--resume"),
        "{stderr}"
    );
    assert_eq!(manifest_state(&part), "interrupted");
    assert!(!part.join("report.json").exists(), "no report.json for a partial run");
    let done_rows = rows(&part);
    let done = done_rows.len() / rows_per_episode;
    assert_eq!(done_rows.len() % rows_per_episode, 0, "whole episodes only");
    assert!((1..EPISODES).contains(&done), "{done} episodes done");
    assert_eq!(report(&part, "report.partial.json")["episodes"], done);

    // a plain rerun is refused, and so is a resume with other options
    let o = loomlab(&[&["run", s(&suite), "--out", s(&part)][..], &common].concat());
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("already holds an interrupted run"),
        "{}",
        text(&o.stderr)
    );
    let o = loomlab(
        &[
            &["run", s(&suite), "--out", s(&part), "--resume", "--seed", "3"][..],
            &common,
        ]
        .concat(),
    );
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(e.contains("holds a different run") && e.contains("--resume"), "{e}");
    assert_eq!(rows(&part), done_rows, "nothing changed");

    // --resume runs only the missing episodes; the report equals the uninterrupted run's
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&part),
        "--resume",
        "--jobs",
        "1",
        "--no-plots",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(
        stdout.contains(&format!(
            "{done} of {EPISODES} episodes were done, running the other {}",
            EPISODES - done
        )),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!("\n{} episodes (plus {done}", EPISODES - done)),
        "{stdout}"
    );
    let all = rows(&part);
    assert_eq!(all.len(), EPISODES * rows_per_episode);
    assert_eq!(
        all[..done_rows.len()],
        done_rows[..],
        "finished episodes are kept, not recomputed"
    );
    assert_eq!(report(&part, "report.json"), report(&full, "report.json"));
    // report.html chooses its exemplary episodes from every episode, the earlier invocation's too:
    // the same as the uninterrupted run's, with the same GIFs
    let gifs = |d: &Path| -> Vec<String> {
        let html = std::fs::read_to_string(d.join("report.html")).unwrap();
        html.split("<img class=\"view\" src=\"")
            .skip(1)
            .map(|r| r[..r.find('"').unwrap()].to_string())
            .collect()
    };
    assert!(!gifs(&full).is_empty());
    assert_eq!(gifs(&part), gifs(&full));
    for g in gifs(&full) {
        assert_eq!(
            std::fs::read(part.join(&g)).unwrap(),
            std::fs::read(full.join(&g)).unwrap(),
            "{g}"
        );
    }
    assert!(!part.join("report.partial.json").exists());
    assert_eq!(manifest_state(&part), "complete");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_row_cut_short_is_run_again_and_overwrite_keeps_other_files() {
    let dir = tmp("cut");
    let suite = suite(&dir);
    let out = dir.join("out");
    let base = [
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--jobs",
        "1",
        "--no-plots",
        "--quiet",
    ];
    let args = [&base[..], &["--limit", "4"]].concat();
    let o = loomlab(&args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let full = report(&out, "report.json");

    // a crash in the middle of writing the last episode: its rows are incomplete
    let csv = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    let cut = csv.trim_end().rfind('\n').unwrap() + 10;
    std::fs::write(out.join("episodes.csv"), &csv[..cut]).unwrap();
    let o = loomlab(&[&args[..], &["--resume"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(report(&out, "report.json"), full);
    assert_eq!(
        std::fs::read_to_string(out.join("episodes.csv"))
            .unwrap()
            .lines()
            .count(),
        csv.lines().count()
    );

    // --overwrite deletes the run's files, nothing else
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = loomlab(&[&base[..], &["--overwrite", "--limit", "2"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(report(&out, "report.json")["episodes"], 2);
    assert_eq!(std::fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn jobs_are_clamped_to_the_cpus_with_a_note() {
    let dir = tmp("jobs");
    let suite = suite(&dir);
    let out = dir.join("out");
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--jobs",
        "100000",
        "--limit",
        "1",
        "--no-plots",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let e = text(&o.stderr);
    assert!(e.contains("--jobs 100000 clamped to"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
