//! Helpers shared by the CLI's integration tests: scratch folders and running the binary.
#![allow(dead_code)] // each test binary uses a part

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh scratch folder `<tmp>/loomlab-<test>-<pid>-<name>`.
pub fn tmp(test: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("loomlab-{test}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The `loomlab` binary, run from the repository root.
pub fn loomlab_command() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_loomlab"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// Runs `loomlab ARGS` to completion.
pub fn loomlab(args: &[&str]) -> Output {
    loomlab_command().args(args).output().expect("run the loomlab binary")
}

/// Process output as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A path as `&str`.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A slow ball at a standing robot (32×32 frames, `hopfield` and `soc`), hitting it or passing
/// 2 m to its right: two episodes.
pub const BALL: &str = r#"description = "slow ball"
[episode]
duration_s = 2.2
seed = 1
[world]
sky_luminance = 0.5
camera = { n = 32 }
ground = { enabled = false }
[[world.projectiles]]
target = "camera"
radius_m = 0.15
speed_mps = 3.0
launch_distance_m = 5.0
launch_time_s = 0.2
miss_angle_deg = 180.0
texture = { kind = "uniform", luminance = 0.0 }
[[detectors]]
id = "hopfield"
[[detectors]]
id = "soc"
threshold = 0.01
[sweep]
"world.projectiles.0.miss_distance_m" = [0.0, 2.0]
"#;

/// A suite folder with two scenarios of two episodes each.
pub fn tiny_suite(dir: &Path) -> PathBuf {
    let suite = dir.join("suite");
    std::fs::create_dir_all(&suite).unwrap();
    std::fs::write(suite.join("ball.toml"), BALL).unwrap();
    std::fs::write(
        suite.join("fast_ball.toml"),
        BALL.replace("speed_mps = 3.0", "speed_mps = 5.0"),
    )
    .unwrap();
    suite
}
