//! `loomlab detect`: camera-owned Hopfield keys are rejected, the stimulus's field of view is used,
//! and nothing is written when the input is invalid.

use std::path::{Path, PathBuf};
use std::process::Command;

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A small, quick stimulus with a field of view other than the Hopfield default of 60°.
const STIMULUS: &str = "[stimulus]\nsize = 64\nfov_deg = 20.0\n\n[object]\nstart_distance_m = 6.0\nend_distance_m = 2.0\n\n[background]\nluminance = 0.0\n";

fn detect(stimulus: &Path, out: &Path, extra: &[&str]) -> (Option<i32>, String) {
    let mut args = vec![
        "detect",
        "--stimulus",
        stimulus.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = Command::new(env!("CARGO_BIN_EXE_loomlab"))
        .args(&args)
        .output()
        .unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn detect_hopfield_config_rejects_camera_keys() {
    let tmp = scratch("detect_cli_camera_keys");
    let stim = tmp.join("stim.toml");
    std::fs::write(&stim, STIMULUS).unwrap();
    let out = tmp.join("o");
    for (key, origin) in [
        ("fov_deg = 60.0", "stimulus.fov_deg"),
        ("frame_rate_hz = 120.0", "stimulus.fps"),
        ("n = 64", "stimulus.size"),
    ] {
        let cfg = tmp.join("hopfield.toml");
        std::fs::write(&cfg, format!("alpha = 0.85\n{key}\n")).unwrap();
        let (code, err) = detect(&stim, &out, &["--hopfield-config", cfg.to_str().unwrap()]);
        assert_eq!(code, Some(2), "{key}: {err}");
        let name = key.split(' ').next().unwrap();
        assert!(
            err.contains("hopfield.toml") && err.contains(&format!("`{name}`")) && err.contains(origin),
            "{key}: the error names the file, the key and where the value comes from: {err}"
        );
        assert!(!out.exists(), "{key}: nothing may be written");
    }
}

#[test]
fn detect_hopfield_config_keeps_the_stimulus_field_of_view() {
    let tmp = scratch("detect_cli_fov");
    let stim = tmp.join("stim.toml");
    std::fs::write(&stim, STIMULUS).unwrap();
    let cfg = tmp.join("defaults.toml");
    std::fs::write(&cfg, "alpha = 0.85\nbeta = 500.0\n").unwrap();
    let (code, err) = detect(&stim, &tmp.join("plain"), &[]);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = detect(&stim, &tmp.join("cfg"), &["--hopfield-config", cfg.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{err}");
    let plain = std::fs::read_to_string(tmp.join("plain").join("responses.csv")).unwrap();
    let with_cfg = std::fs::read_to_string(tmp.join("cfg").join("responses.csv")).unwrap();
    assert_eq!(
        plain, with_cfg,
        "a config of default values changes nothing (θ̂ uses the stimulus's 20°)"
    );
}

#[test]
fn detect_rejects_stimuli_smaller_than_the_detectors_take_before_writing() {
    let tmp = scratch("detect_cli_min_size");
    let stim = tmp.join("tiny.toml");
    std::fs::write(&stim, STIMULUS.replace("size = 64", "size = 12")).unwrap();
    let out = tmp.join("o");
    let (code, err) = detect(&stim, &out, &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("tiny.toml") && err.contains("stimulus.size") && err.contains("12") && err.contains("20"),
        "{err}"
    );
    assert!(!out.exists(), "nothing may be written");
}
