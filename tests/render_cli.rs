//! `loomlab render` on every shipped scene: PNG frames, a GIF and truth.csv come out; bad input exits 2.

use std::path::PathBuf;
use std::process::Command;

fn scenes() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join("scenes");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    assert!(v.len() >= 3, "expected the example scenes in {}", dir.display());
    v
}

#[test]
fn render_writes_frames_gif_and_truth_for_every_scene() {
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("render_cli");
    for scene in scenes() {
        let out = tmp.join(scene.file_stem().unwrap());
        let _ = std::fs::remove_dir_all(&out);
        let status = Command::new(env!("CARGO_BIN_EXE_loomlab"))
            .args([
                "render",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--frames",
                "12",
                "--size",
                "64",
            ])
            .status()
            .unwrap();
        assert!(status.success(), "{}: {status}", scene.display());
        let frames = std::fs::read_dir(out.join("frames")).unwrap().count();
        assert_eq!(frames, 13, "{}: frames 0..=12", scene.display());
        let img = image::open(out.join("frames").join("frame_00012.png")).unwrap();
        assert_eq!((img.width(), img.height()), (64, 64));
        assert!(std::fs::metadata(out.join("view.gif")).unwrap().len() > 0);
        let csv = std::fs::read_to_string(out.join("truth.csv")).unwrap();
        let mut lines = csv.lines();
        assert!(lines.next().unwrap().starts_with("frame,t_s,robot_x_m"));
        assert!(lines.count() >= 13, "{}: one row per object per frame", scene.display());
    }
}

#[test]
fn render_rejects_unknown_keys_with_exit_code_2() {
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("render_cli_bad");
    std::fs::create_dir_all(&tmp).unwrap();
    let bad = tmp.join("bad.toml");
    std::fs::write(&bad, "[world]\nsky_luminance = 0.5\ncolour = 3\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_loomlab"))
        .args([
            "render",
            bad.to_str().unwrap(),
            "--out",
            tmp.join("o").to_str().unwrap(),
            "--no-render",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("colour") && err.contains("bad.toml"), "{err}");
}

/// Runs `loomlab render SCENE --out OUT --no-render EXTRA…` and returns (exit code, stderr).
fn render_no_gpu(scene: &std::path::Path, out: &std::path::Path, extra: &[&str]) -> (Option<i32>, String) {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-render",
    ];
    args.extend_from_slice(extra);
    let o = Command::new(env!("CARGO_BIN_EXE_loomlab"))
        .args(&args)
        .output()
        .unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A 32×32 world with one pole (one truth.csv row per frame). `[robot_command]` may follow.
const SMALL_SCENE: &str =
    "[episode]\nduration_s = 0.1\n\n[world]\ncamera = { n = 32 }\n\n[[world.scenery]]\nkind = \"pole\"\n";

#[test]
fn render_caps_the_number_of_frames() {
    let tmp = scratch("render_cli_cap");
    let huge = tmp.join("huge.toml");
    std::fs::write(&huge, "[episode]\nduration_s = 1e9\n\n[world]\n").unwrap();
    let out = tmp.join("o");
    let (code, err) = render_no_gpu(&huge, &out, &[]);
    assert_eq!(code, Some(2), "{err}");
    for part in [
        "huge.toml",
        "episode.duration_s",
        "1000000000",
        "432000",
        "MAX_EPISODE_FRAMES",
    ] {
        assert!(err.contains(part), "missing `{part}` in: {err}");
    }
    assert!(!out.exists(), "nothing may be written");

    let ok = tmp.join("ok.toml");
    std::fs::write(&ok, SMALL_SCENE).unwrap();
    for seconds in ["inf", "nan", "-1", "0", "1e9"] {
        let (code, err) = render_no_gpu(&ok, &out, &[&format!("--seconds={seconds}")]);
        assert_eq!(code, Some(2), "--seconds={seconds}: {err}");
        assert!(err.contains("--seconds"), "--seconds={seconds}: {err}");
        assert!(!out.exists(), "--seconds={seconds}: nothing may be written");
    }
    let (code, err) = render_no_gpu(&ok, &out, &["--frames", "432001"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--frames") && err.contains("432000"), "{err}");
    assert!(!out.exists());

    let (code, err) = render_no_gpu(&ok, &out, &["--seconds", "0.05"]);
    assert_eq!(code, Some(0), "{err}");
    let rows = std::fs::read_to_string(out.join("truth.csv")).unwrap().lines().count();
    assert_eq!(rows, 1 + 7, "header + frames 0..=6 (one pole)");
}

#[test]
fn render_validates_everything_before_writing() {
    let tmp = scratch("render_cli_validate");
    let out = tmp.join("o");
    let nan = tmp.join("nan_command.toml");
    std::fs::write(&nan, format!("[robot_command]\nforward_mps = nan\n\n{SMALL_SCENE}")).unwrap();
    let (code, err) = render_no_gpu(&nan, &out, &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("nan_command.toml") && err.contains("robot_command.forward_mps"),
        "the error names the file and the key as written: {err}"
    );
    assert!(!out.exists(), "no frames, truth.csv or GIF may be left behind");

    // a cruise the drive cannot reach would be clamped silently by the dynamic physics
    let fast = tmp.join("fast_command.toml");
    std::fs::write(&fast, format!("[robot_command]\nforward_mps = 3.0\n\n{SMALL_SCENE}")).unwrap();
    let (code, err) = render_no_gpu(&fast, &out, &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("fast_command.toml")
            && err.contains("robot_command.forward_mps = 3")
            && err.contains("max_speed_mps"),
        "{err}"
    );
    assert!(!out.exists());
    let (code, err) = render_no_gpu(&fast, &out, &["--physics", "analytic"]);
    assert_eq!(code, Some(0), "closed-form motion has no drive limits: {err}");
}

#[test]
fn render_rejects_frames_smaller_than_the_detectors_take() {
    let tmp = scratch("render_cli_min_size");
    let out = tmp.join("o");
    let small = tmp.join("small.toml");
    std::fs::write(&small, "[world]\ncamera = { n = 8 }\n").unwrap();
    let (code, err) = render_no_gpu(&small, &out, &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("small.toml") && err.contains("world.camera.n") && err.contains("= 8") && err.contains("20"),
        "{err}"
    );
    let ok = tmp.join("ok.toml");
    std::fs::write(&ok, SMALL_SCENE).unwrap();
    let (code, err) = render_no_gpu(&ok, &out, &["--size", "19"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--size") && err.contains("19") && err.contains("20"),
        "{err}"
    );
    assert!(!out.exists());
}
