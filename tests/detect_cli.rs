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

/// A robot turning left while it drives and sidesteps, its camera 0.25 m ahead of the robot's
/// origin and 0.1 m above it (0.3 m above the ground), pitched 5° up. As a scenario, and as a
/// `loomlab render` scene with `[robot_command]`.
const TURNING: &str = r#"
[episode]
duration_s = 0.3
seed = 3
[world]
camera = { n = 32, position = [0.25, 0.0, 0.1], pitch_deg = 5.0 }
[robot]
forward_mps = 1.0
yaw_rate_rps = 0.8
lateral_mps = 0.3
"#;

#[test]
fn efference_copies_from_planar_poses_equal_the_runners() {
    use loomlab::cli::efference::{CameraMount, PlanarPose, efference_copies};
    use loomlab_agents::{EgoSensor, VelocityCommand};
    use loomlab_scenarios::{LoadOptions, parse_scenario};

    let s = parse_scenario(TURNING, Path::new("turning.toml"), None, &LoadOptions::default()).unwrap();
    let ep = s.episode(0).unwrap();
    let mut sim = loomlab_sim::Sim::new_physics_only(&ep.world, ep.seed).unwrap();
    let mut sensor = EgoSensor::default();
    let (mut poses, mut runner) = (Vec::new(), Vec::new());
    let mut command = VelocityCommand::STOP;
    for k in 0..30 {
        let t = if k == 0 {
            sim.observe().unwrap().t_s
        } else {
            sim.step(&command.to_sim()).unwrap().t_s
        };
        // what the runner hands a detector (agents::EgoSensor on the camera's pose)
        runner.push(sensor.sense(command, t, &sim.camera_pose()));
        let r = sim.robot_state();
        poses.push(PlanarPose {
            t_s: r.t_s,
            x_m: r.x_m,
            y_m: r.y_m,
            yaw_rad: r.yaw_rad,
        });
        command = ep.cruise.command_at(t);
    }
    let mount = CameraMount {
        forward_m: 0.25,
        height_m: Some(0.3),
        pitch_rad: 5f64.to_radians(),
    };
    let cli = efference_copies(&poses, mount);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * (1.0 + b.abs());
    assert!(
        runner[5].rotation_rad[2] > 0.005 && runner[5].translation_m[0] > 0.005,
        "{:?}",
        runner[5]
    );
    for (k, (c, r)) in cli.iter().zip(&runner).enumerate() {
        let pairs = [
            (c.dt_s, r.dt_s),
            (c.height_m, r.height_m),
            (c.pitch_rad, r.pitch_rad),
            (c.roll_rad, r.roll_rad),
            (c.forward_mps, r.forward_mps),
            (c.yaw_rate_rps, r.yaw_rate_rps),
            (c.lateral_mps, r.lateral_mps),
        ];
        let rot = c.rotation_rad.iter().zip(&r.rotation_rad);
        let tr = c.translation_m.iter().zip(&r.translation_m);
        for (a, b) in pairs.into_iter().chain(rot.chain(tr).map(|(a, b)| (*a, *b))) {
            assert!(close(a, b), "frame {k}: {c:?}\nvs the runner's {r:?}");
        }
    }
}

#[test]
fn detect_reads_the_efference_copy_of_a_rendered_video_from_its_truth_csv() {
    let dir = scratch("detect_efference");
    let scene = dir.join("turning.toml");
    // a pole ahead so that truth.csv has a row per frame
    let scene_text = TURNING.replace("[robot]", "[robot_command]")
        + "[[world.scenery]]\nkind = \"pole\"\nname = \"pole\"\nposition = [6.0, 1.0]\nheight_m = 2.0\n";
    std::fs::write(&scene, scene_text).unwrap();
    let video = dir.join("video");
    let o = Command::new(env!("CARGO_BIN_EXE_loomlab"))
        .args([
            "render",
            scene.to_str().unwrap(),
            "--out",
            video.to_str().unwrap(),
            "--no-gif",
        ])
        .env(
            "XDG_RUNTIME_DIR",
            std::env::var("XDG_RUNTIME_DIR").unwrap_or("/tmp".into()),
        )
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run = |csv: &Path, out: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_loomlab"))
            .args([
                "detect",
                "--video",
                video.join("frames").to_str().unwrap(),
                "--efference",
                csv.to_str().unwrap(),
                "--camera-forward-m",
                "0.25",
                "--camera-height-m",
                "0.3",
                "--camera-pitch-deg",
                "5",
                "-d",
                "tracker",
                "--out",
                dir.join(out).to_str().unwrap(),
            ])
            .output()
            .unwrap();
        (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (code, err) = run(&video.join("truth.csv"), "ok");
    assert_eq!(code, Some(0), "{err}");
    let responses = std::fs::read_to_string(dir.join("ok/responses.csv")).unwrap();
    assert_eq!(
        responses.lines().count(),
        1 + 37,
        "a row per frame (0.3 s at 120 Hz, and frame 0)"
    );

    // a CSV without a yaw column, and one pose short: clear errors, nothing written
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "t_s,x,y\n0,0,0\n").unwrap();
    let (code, err) = run(&bad, "bad");
    assert_eq!(code, Some(2));
    assert!(
        err.contains("bad.csv has no yaw column") && err.contains("yaw_deg"),
        "{err}"
    );
    let truth = std::fs::read_to_string(video.join("truth.csv")).unwrap();
    let short = dir.join("short.csv");
    std::fs::write(&short, truth.lines().take(10).collect::<Vec<_>>().join("\n")).unwrap();
    let (code, err) = run(&short, "short");
    assert_eq!(code, Some(2));
    assert!(err.contains("has 9 poses") && err.contains("37 frames"), "{err}");
    assert!(!dir.join("bad").exists() && !dir.join("short").exists());
}
