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
    detect_input("--stimulus", stimulus, out, extra)
}

/// Runs `loomlab detect INPUT_FLAG INPUT --out OUT` with extra flags; (exit code, stderr).
fn detect_input(input_flag: &str, input: &Path, out: &Path, extra: &[&str]) -> (Option<i32>, String) {
    let mut args = vec![
        "detect",
        input_flag,
        input.to_str().unwrap(),
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
    use loomlab_agents::{CameraMotionSensor, VelocityCommand};
    use loomlab_scenarios::{LoadOptions, parse_scenario};

    let s = parse_scenario(TURNING, Path::new("turning.toml"), None, &LoadOptions::default()).unwrap();
    let ep = s.episode(0).unwrap();
    let mut sim = loomlab_sim::Sim::new_physics_only(&ep.world, ep.seed).unwrap();
    let mut sensor = CameraMotionSensor::default();
    let (mut poses, mut runner) = (Vec::new(), Vec::new());
    let mut command = VelocityCommand::STOP;
    for k in 0..30 {
        let t = if k == 0 {
            sim.observe().unwrap().t_s
        } else {
            sim.step(&command.to_sim()).unwrap().t_s
        };
        // what the runner hands a detector (agents::CameraMotionSensor on the camera's pose)
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

#[test]
fn efference_csv_with_ambiguous_duplicate_or_marked_columns() {
    use loomlab::cli::efference::read_poses;
    let dir = scratch("detect_efference_columns");
    let read = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        read_poses(&path, 2).map_err(|e| format!("{e:#}"))
    };
    // yaw in degrees and in radians: which one is meant is a guess
    let err = read("both_yaws.csv", "t_s,x,y,yaw_deg,yaw_rad\n0,0,0,90,0\n1,1,0,90,0\n").unwrap_err();
    assert!(
        err.contains("both_yaws.csv") && err.contains("`yaw_deg` and `yaw_rad`") && err.contains("ambiguous"),
        "{err}"
    );
    // two x columns
    let err = read("two_x.csv", "t_s,x,y,x,yaw_deg\n0,0,0,5,0\n1,1,0,6,0\n").unwrap_err();
    assert!(
        err.contains("two_x.csv") && err.contains("two columns named `x`") && err.contains("columns 2 and 4"),
        "{err}"
    );
    // two names of one quantity (`x` and `x_m`)
    let err = read("x_and_x_m.csv", "t_s,x,x_m,y,yaw_deg\n0,0,0,0,0\n1,1,1,0,0\n").unwrap_err();
    assert!(err.contains("`x_m` and `x`") || err.contains("`x` and `x_m`"), "{err}");
    // a spreadsheet's byte-order mark before the first column's name
    let poses = read("bom.csv", "\u{feff}t_s,x,y,yaw_deg\n0,0,0,0\n0.5,1,0,90\n").unwrap();
    assert_eq!(poses.len(), 2);
    assert!((poses[1].yaw_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
}

/// `loomlab detect --video VIDEO -d soc` with extra flags; (exit code, stderr).
fn detect_video(video: &Path, out: &Path, extra: &[&str]) -> (Option<i32>, String) {
    detect_input("--video", video, out, &[&["-d", "soc"], extra].concat())
}

#[test]
fn detect_bounds_video_frames_before_allocating_them() {
    let dir = scratch("detect_frame_bounds");
    // a 1 000 000 × 1 picture: a few hundred bytes as PNG, 4 TB as an embedded square frame
    let wide = dir.join("wide.png");
    image::GrayImage::from_pixel(1_000_000, 1, image::Luma([128u8]))
        .save(&wide)
        .unwrap();
    assert!(std::fs::metadata(&wide).unwrap().len() < 100_000);
    let (code, err) = detect_video(&wide, &dir.join("embed"), &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("wide.png") && err.contains("1000000×1000000") && err.contains("8192"),
        "{err}"
    );
    // cropped, it would be a 1 × 1 frame: smaller than any detector takes
    let (code, err) = detect_video(&wide, &dir.join("crop"), &["--non-square", "crop"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("1×1") && err.contains("at least 20×20"), "{err}");
    // a folder of frames is bounded as a whole, before the first frame is decoded
    let many = dir.join("many");
    std::fs::create_dir_all(&many).unwrap();
    for k in 0..20 {
        image::GrayImage::from_pixel(8000, 1, image::Luma([0u8]))
            .save(many.join(format!("f{k:02}.png")))
            .unwrap();
    }
    let (code, err) = detect_video(&many, &dir.join("many_out"), &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("20 frames of 8000×8000") && err.contains("at most"),
        "{err}"
    );
    assert!(!dir.join("embed").exists() && !dir.join("crop").exists() && !dir.join("many_out").exists());
}

#[test]
fn detect_refuses_numbered_frames_with_a_gap() {
    let dir = scratch("detect_frame_gap");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in [6, 7, 8, 10, 11] {
        image::GrayImage::from_pixel(24, 24, image::Luma([(k * 20) as u8]))
            .save(frames.join(format!("frame_{k:05}.png")))
            .unwrap();
    }
    let (code, err) = detect_video(&frames, &dir.join("out"), &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("frame_00008.png is followed by") && err.contains("frame_00010.png") && err.contains("missing"),
        "{err}"
    );
    // without the gap the same frames are read, one row per frame
    std::fs::remove_file(frames.join("frame_00006.png")).unwrap();
    image::GrayImage::from_pixel(24, 24, image::Luma([180u8]))
        .save(frames.join("frame_00009.png"))
        .unwrap();
    let (code, err) = detect_video(&frames, &dir.join("ok"), &[]);
    assert_eq!(code, Some(0), "{err}");
    let rows = std::fs::read_to_string(dir.join("ok/responses.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 5);
}

/// `--sensor robot` adds the profile's per-frame noise and 8-bit quantisation to the input frames,
/// drawn from `--seed`; an unknown profile is a clear error and writes nothing.
#[test]
fn detect_applies_the_sensor_profile_seeded() {
    let tmp = scratch("detect_cli_sensor");
    let stim = tmp.join("stim.toml");
    // a mid-grey background: shot noise of ~2 codes of 8 bits per pixel
    std::fs::write(&stim, STIMULUS.replace("luminance = 0.0", "luminance = 0.5")).unwrap();
    let responses = |name: &str, extra: &[&str]| {
        let out = tmp.join(name);
        let (code, err) = detect(&stim, &out, &[&["-d", "hopfield,soc"], extra].concat());
        assert_eq!(code, Some(0), "{name}: {err}");
        std::fs::read_to_string(out.join("responses.csv")).unwrap()
    };
    let ideal = responses("ideal", &[]);
    assert_eq!(
        ideal,
        responses("ideal_seed", &["--sensor", "ideal", "--seed", "5"]),
        "ideal: no noise"
    );
    let robot_1 = responses("robot_1", &["--sensor", "robot", "--seed", "1"]);
    assert_eq!(
        robot_1,
        responses("robot_1_again", &["--sensor", "robot", "--seed", "1"])
    );
    let robot_2 = responses("robot_2", &["--sensor", "robot", "--seed", "2"]);
    assert_ne!(robot_1, robot_2, "another seed draws other noise");
    assert_ne!(robot_1, ideal, "the robot camera is noisy");
    // the same rows and columns: only the detectors' outputs differ
    assert_eq!(robot_1.lines().count(), ideal.lines().count());
    assert_eq!(robot_1.lines().next(), ideal.lines().next());

    let out = tmp.join("unknown");
    let (code, err) = detect(&stim, &out, &["--sensor", "webcam"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--sensor webcam") && err.contains("ideal, robot"),
        "the error names the flag, the value and the known profiles: {err}"
    );
    assert!(!out.exists(), "nothing may be written");
}
