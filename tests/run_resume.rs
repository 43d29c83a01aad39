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

/// The manifest of `dir`, edited by `f`.
fn edit_manifest(dir: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("manifest.json")).unwrap()).unwrap();
    f(&mut m);
    std::fs::write(dir.join("manifest.json"), m.to_string()).unwrap();
}

const PLOTS: [&str; 5] = ["roc.png", "rates.png", "collisions.png", "theta_hat.png", "trace.png"];

#[test]
fn a_resumed_run_draws_the_plots_of_an_uninterrupted_run() {
    let dir = tmp("plots");
    let suite = suite(&dir);
    // θ̂ plots need a hopfield row
    for f in ["ball.toml", "fast_ball.toml"] {
        let p = suite.join(f);
        let t = std::fs::read_to_string(&p).unwrap();
        std::fs::write(
            &p,
            t.replace(
                "[[detectors]]\nid = \"soc\"",
                "[[detectors]]\nid = \"hopfield\"\n[[detectors]]\nid = \"soc\"",
            ),
        )
        .unwrap();
    }
    let full = dir.join("full");
    let args = |out: &Path| -> Vec<String> {
        ["run", s(&suite), "--out", s(out), "--jobs", "1", "--no-html", "--quiet"]
            .map(String::from)
            .to_vec()
    };
    let run = |a: Vec<String>| loomlab(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(args(&full));
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    for p in PLOTS {
        assert!(full.join(p).is_file(), "{p}");
    }
    // the same run, stopped after half of its episodes (their rows and samples kept)
    let part = dir.join("part");
    std::fs::create_dir_all(&part).unwrap();
    for f in ["manifest.json", "written.txt", "episodes.csv", "plot_samples.jsonl"] {
        std::fs::copy(full.join(f), part.join(f)).unwrap();
    }
    let csv = std::fs::read_to_string(part.join("episodes.csv")).unwrap();
    let per_episode = (csv.lines().count() - 1) / EPISODES;
    let half: Vec<&str> = csv.lines().take(1 + per_episode * EPISODES / 2).collect();
    std::fs::write(part.join("episodes.csv"), half.join("\n") + "\n").unwrap();
    let samples = std::fs::read_to_string(part.join("plot_samples.jsonl")).unwrap();
    let half: Vec<&str> = samples.lines().take(EPISODES / 2).collect();
    std::fs::write(part.join("plot_samples.jsonl"), half.join("\n") + "\n").unwrap();
    edit_manifest(&part, |m| m["state"] = "interrupted".into());
    let o = run([args(&part), vec!["--resume".into()]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    for p in PLOTS {
        assert!(
            std::fs::read(part.join(p)).unwrap() == std::fs::read(full.join(p)).unwrap(),
            "{p} of the resumed run differs from the uninterrupted run's"
        );
    }
    // nothing left to run: the plots are still drawn, the same
    for p in PLOTS {
        std::fs::remove_file(part.join(p)).unwrap();
    }
    let o = run([args(&part), vec!["--resume".into()]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    for p in PLOTS {
        assert!(
            std::fs::read(part.join(p)).unwrap() == std::fs::read(full.join(p)).unwrap(),
            "{p} (nothing left to run)"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 60-second episode (the ball arrives after about 36 s): long enough that an interrupt lands
/// while it runs.
fn long_suite(dir: &Path) -> PathBuf {
    let suite = dir.join("long");
    std::fs::create_dir_all(&suite).unwrap();
    let text = BALL
        .replace("duration_s = 1.5", "duration_s = 60.0")
        .replace("launch_time_s = 0.1", "launch_time_s = 35.0")
        .replace("[0.0, 0.1, 0.6, 1.0, 1.5, 2.0]", "[0.0]");
    std::fs::write(suite.join("long.toml"), text).unwrap();
    suite
}

/// Starts `loomlab run` and waits until its manifest says `running`.
fn start_running(args: &[&str], out: &Path) -> std::process::Child {
    let child = loomlab_command()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !out.join("manifest.json").exists() || !out.join("episodes.csv").exists() {
        assert!(started.elapsed() < Duration::from_secs(120), "the run did not start");
        std::thread::sleep(Duration::from_millis(5));
    }
    child
}

/// `loomlab run SUITE --out OUT` on one worker, without plots or page: the quickest full run.
fn quick_args<'a>(suite: &'a Path, out: &'a Path) -> [&'a str; 8] {
    [
        "run",
        s(suite),
        "--out",
        s(out),
        "--jobs",
        "1",
        "--no-html",
        "--no-plots",
    ]
}

fn interrupt(child: &std::process::Child) {
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
}

#[test]
fn an_interrupt_stops_an_episode_in_flight_and_a_second_one_keeps_the_state_true() {
    let dir = tmp("long");
    let suite = long_suite(&dir);
    // one interrupt: the episode in flight gives up, the run is interrupted (not finished)
    let out = dir.join("one");
    let args = quick_args(&suite, &out);
    let child = start_running(&args, &out);
    interrupt(&child);
    let o = child.wait_with_output().unwrap();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{e}");
    assert!(
        e.contains("interrupted: 0 of 1 episodes done") && e.contains("--resume"),
        "{e}"
    );
    assert!(!e.contains("finishing the episodes in flight"), "{e}");
    assert_eq!(manifest_state(&out), "interrupted");
    assert!(rows(&out).is_empty());
    // two interrupts: the state is `interrupted`, not `running`, and no stale partial report
    let out = dir.join("two");
    let args = quick_args(&suite, &out);
    let child = start_running(&args, &out);
    interrupt(&child);
    interrupt(&child);
    let o = child.wait_with_output().unwrap();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{e}");
    assert!(e.contains("--resume"), "{e}");
    assert_eq!(manifest_state(&out), "interrupted");
    assert!(!out.join("report.partial.json").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_write_failure_exits_3_with_the_state_and_a_resume_hint() {
    let dir = tmp("iofail");
    let suite = suite(&dir);
    // traces/ cannot be created (a file of the user's is in the way): I/O, not bad input
    let out = dir.join("traces_blocked");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("traces"), "mine").unwrap();
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
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(e.contains("traces") && e.contains("resume with"), "{e}");
    assert_eq!(manifest_state(&out), "interrupted");
    assert_eq!(std::fs::read_to_string(out.join("traces")).unwrap(), "mine");
    // a plot cannot be written after every episode is done: not `complete`, and resumable
    let out = dir.join("plot_blocked");
    std::fs::create_dir_all(out.join("roc.png")).unwrap();
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--limit",
        "2",
        "--no-html",
        "--jobs",
        "1",
    ]);
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(e.contains("roc.png") && e.contains("--resume"), "{e}");
    assert_eq!(manifest_state(&out), "interrupted");
    std::fs::remove_dir(out.join("roc.png")).unwrap();
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--limit",
        "2",
        "--no-html",
        "--jobs",
        "1",
        "--resume",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(manifest_state(&out), "complete");
    assert!(out.join("roc.png").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_long_run_without_a_terminal_prints_progress_lines() {
    // stderr is a pipe here (no progress bar): progress lines come while the long episode runs
    // (a minute simulated: 1.3–1.6 s of wall time on a fast day, lines every 0.2 s)
    let dir = tmp("progress");
    let suite = long_suite(&dir);
    let out = dir.join("out");
    let o = loomlab_command()
        .args([
            "run",
            s(&suite),
            "--out",
            s(&out),
            "--jobs",
            "1",
            "--no-html",
            "--no-plots",
        ])
        .env("LOOMLAB_PROGRESS_S", "0.2")
        .output()
        .unwrap();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert!(e.contains("progress: 0 of 1 episodes done in 0 min"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_interrupt_while_the_report_is_written_is_not_reported_as_a_finished_run() {
    // every episode done (report.json written), the page and its GIFs being written: an
    // interrupt stops there with 130 and `interrupted`, and --resume writes the rest
    let dir = tmp("report_phase");
    let suite = suite(&dir);
    for i in 0..4 {
        let t = std::fs::read_to_string(suite.join("ball.toml")).unwrap();
        std::fs::write(
            suite.join(format!("more_{i}.toml")),
            t.replace("camera = { n = 32 }", "camera = { n = 64 }"),
        )
        .unwrap();
    }
    let out = dir.join("out");
    let args = ["run", s(&suite), "--out", s(&out), "--no-plots"];
    let child = loomlab_command()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !out.join("report.json").exists() {
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "the episodes did not finish"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    interrupt(&child);
    let o = child.wait_with_output().unwrap();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{e}");
    assert!(!e.contains("finishing the episodes in flight"), "{e}");
    assert!(
        e.contains("interrupted while writing the report") && e.contains("--resume"),
        "{e}"
    );
    assert_eq!(manifest_state(&out), "interrupted");
    let o = loomlab(&[&args[..], &["--resume"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(manifest_state(&out), "complete");
    assert!(out.join("report.html").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Rows of episodes.csv, 0 while it does not exist yet.
fn row_count(dir: &Path) -> usize {
    std::fs::read_to_string(dir.join("episodes.csv")).map_or(0, |t| t.lines().count().saturating_sub(1))
}

/// Waits (at most `secs`) until `ready()`, failing with `what` otherwise.
fn wait_until(secs: u64, what: &str, mut ready: impl FnMut() -> bool) {
    let started = Instant::now();
    while !ready() {
        assert!(started.elapsed() < Duration::from_secs(secs), "{what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Every file name under `dir` (recursively) that holds `.tmp`.
fn tmp_files(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            out.extend(tmp_files(&p));
        } else if p.file_name().unwrap().to_string_lossy().contains(".tmp") {
            out.push(p.display().to_string());
        }
    }
    out
}

#[test]
fn a_second_run_into_a_folder_in_use_is_refused_and_the_first_stays_true() {
    let dir = tmp("locked");
    // 40 episodes at one worker: several seconds, while the other runs try the folder
    let suite = dir.join("suite");
    std::fs::create_dir_all(&suite).unwrap();
    let many: Vec<String> = (0..40).map(|i| format!("{:.2}", 0.05 * f64::from(i))).collect();
    std::fs::write(
        suite.join("ball.toml"),
        BALL.replace("[0.0, 0.1, 0.6, 1.0, 1.5, 2.0]", &format!("[{}]", many.join(", "))),
    )
    .unwrap();
    let out = dir.join("out");
    let args = [
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--jobs",
        "1",
        "--no-html",
        "--no-plots",
        "--quiet",
    ];
    let mut a = loomlab_command()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(120, "run A did not start its episodes", || row_count(&out) > 0);
    for extra in [&["--overwrite"][..], &["--resume"], &[]] {
        let o = loomlab(&[&args[..], extra].concat());
        let e = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {e}");
        assert!(
            e.contains(&format!(
                "{} is in use by another loomlab run (process {}",
                out.display(),
                a.id()
            )),
            "{extra:?}: {e}"
        );
        assert!(
            a.try_wait().unwrap().is_none(),
            "run A finished before the refused run: the test needs a longer suite"
        );
    }
    let o = a.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    // A's files are whole and its manifest tells the truth
    assert_eq!(manifest_state(&out), "complete");
    let episodes = report(&out, "report.json")["episodes"].as_u64().unwrap() as usize;
    assert_eq!(episodes, 40);
    let rows = rows(&out);
    let per_episode = rows.len() / episodes;
    assert!(
        per_episode > 0 && rows.len() == per_episode * episodes,
        "{} rows",
        rows.len()
    );
    assert!(
        !out.join(".loomlab-run.lock").exists(),
        "the lock file is deleted at the end"
    );

    // a lock file left by a dead run (kill -9) is taken over
    let stale = dir.join("stale");
    std::fs::create_dir_all(&stale).unwrap();
    std::fs::write(stale.join(".loomlab-run.lock"), "999999\n").unwrap();
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&stale),
        "--limit",
        "1",
        "--no-html",
        "--no-plots",
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(manifest_state(&stale), "complete");
    let listed = std::fs::read_to_string(stale.join("written.txt")).unwrap();
    assert!(!listed.contains("lock"), "{listed}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_full_disk_leaves_a_resumable_run_and_no_temporary_file() {
    // LOOMLAB_TEST_DISK_BYTES: the run's writers see a disk with that many bytes free (the
    // manifest, written.txt and episodes.csv fit, under 1 kB, then the first episode's plot
    // samples, about 5.6 kB); once full, every later write that needs new space fails too
    let dir = tmp("full");
    let suite = suite(&dir);
    let out = dir.join("out");
    let args = quick_args(&suite, &out);
    let o = loomlab_command()
        .args(args)
        .env("LOOMLAB_TEST_DISK_BYTES", "9000")
        .output()
        .unwrap();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(e.contains("No space left on device"), "{e}");
    assert!(e.contains("resume with:") && e.contains("--resume"), "{e}");
    assert_eq!(tmp_files(&out), Vec::<String>::new(), "temporary files left");
    // the manifest's last update fits in the blocks it has: rewritten in place, it says so
    assert_eq!(manifest_state(&out), "interrupted");
    let before = rows(&out);
    assert!(
        !before.is_empty(),
        "no episode was saved before the disk was full: raise the budget"
    );
    // with space again, --resume finishes the run: every episode once, the saved ones kept
    let o = loomlab(&[&args[..], &["--resume"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(manifest_state(&out), "complete");
    let all = rows(&out);
    assert_eq!(report(&out, "report.json")["episodes"], EPISODES);
    assert_eq!(all.len() % EPISODES, 0);
    assert_eq!(all[..before.len()], before[..]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_resume_after_the_suite_changed_suggests_what_works() {
    let dir = tmp("edited");
    let suite = suite(&dir);
    let out = dir.join("out");
    let args = [
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--limit",
        "2",
        "--jobs",
        "1",
        "--no-html",
        "--no-plots",
        "--quiet",
    ];
    let o = loomlab(&args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let file = suite.join("ball.toml");
    let t = std::fs::read_to_string(&file).unwrap();
    std::fs::write(&file, t.replace("speed_mps = 4.0", "speed_mps = 4.5")).unwrap();
    let o = loomlab(&[&args[..], &["--resume"]].concat());
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    // not the command that just failed again, but one that works
    assert!(
        !e.contains(&format!("{} --out {}", s(&suite), s(&out))),
        "suggests the same command again: {e}"
    );
    assert!(e.contains("changed") && e.contains("--overwrite"), "{e}");
    let o = loomlab(&[&args[..], &["--overwrite"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(manifest_state(&out), "complete");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_resume_of_a_huge_suite_starts_at_once_and_its_check_can_be_interrupted() {
    // 100 000 episodes (one random draw each): a fresh run checks every one before it starts
    // (seconds; 10 s for a million); a resume of the same suite continues without that check
    let dir = tmp("huge");
    let suite = dir.join("huge");
    std::fs::create_dir_all(&suite).unwrap();
    let huge = BALL.replace(
        "[sweep]\n\"world.projectiles.0.miss_distance_m\" = [0.0, 0.1, 0.6, 1.0, 1.5, 2.0]",
        "[random]\nsamples = 100000\n\"world.projectiles.0.miss_distance_m\" = { min = 0.0, max = 2.0 }",
    );
    assert!(huge.contains("samples = 100000"));
    std::fs::write(suite.join("huge.toml"), huge).unwrap();
    let out = dir.join("out");
    let args = quick_args(&suite, &out);

    // Ctrl-C while the episodes are checked: the normal interrupt, nothing written
    let early = dir.join("early");
    let child = loomlab_command()
        .args(["run", s(&suite), "--out", s(&early), "--jobs", "1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    interrupt(&child);
    let o = child.wait_with_output().unwrap();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{e}");
    assert!(e.contains("interrupted while checking the suite's episodes"), "{e}");
    assert!(!early.join("manifest.json").exists());

    // a fresh run, interrupted after its first episodes
    let child = loomlab_command()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(600, "the fresh run did not start its episodes", || row_count(&out) > 0);
    interrupt(&child);
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", text(&o.stderr));
    let done = row_count(&out);

    // --resume gets to episode work without a second check of the episodes (the bound only
    // guards against a hang)
    let child = loomlab_command()
        .args([&args[..], &["--resume"]].concat())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until(60, "the resume did not get to its episodes within 60 s", || {
        row_count(&out) > done
    });
    interrupt(&child);
    let o = child.wait_with_output().unwrap();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{e}");
    assert!(e.contains("interrupted:") && e.contains("--resume"), "{e}");
    assert!(
        e.contains("its 100000 episodes were checked then, not again") && !e.contains("checking"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
