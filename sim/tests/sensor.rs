//! The camera's sensor (`[world.camera.sensor]`, `loomlab_sim::sensor`): the noise model's
//! statistics, exposure blur against the analytic box-filtered edge, seeding, and that every way
//! of making a frame (step, batch, captured views) applies it the same.

use loomlab_sim::{Command, Renderer, SensorDesc, Sim, WorldDesc};

use crate::common;

/// Noise statistics over 128² = 16 384 pixels per luminance: mean and variance within 2 % of the
/// model's `gain · L` and `gain² · (L · full_well + read²) / full_well²`.
#[test]
fn noise_mean_and_variance_match_the_model() {
    let desc = SensorDesc {
        full_well_e: 2000.0,
        read_noise_e: 8.0,
        gain: 1.5,
        ..SensorDesc::default()
    };
    let sensor = desc.build(1.0 / 120.0).unwrap().expect("a noisy sensor is not ideal");
    for (i, l) in [0.02f64, 0.1, 0.3, 0.6].into_iter().enumerate() {
        let mut frame = vec![l as f32; 128 * 128];
        sensor.apply(&mut frame, 11, i as u64);
        let n = frame.len() as f64;
        let mean = frame.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let var = frame.iter().map(|&v| (f64::from(v) - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let mu = f64::from(l as f32) * desc.full_well_e;
        let model_mean = desc.gain * mu / desc.full_well_e;
        let model_var = desc.gain.powi(2) * (mu + desc.read_noise_e.powi(2)) / desc.full_well_e.powi(2);
        assert!(
            (mean / model_mean - 1.0).abs() < 0.02,
            "L {l}: mean {mean} against the model's {model_mean}"
        );
        assert!(
            (var / model_var - 1.0).abs() < 0.02,
            "L {l}: variance {var} against the model's {model_var}"
        );
    }
}

/// A world whose view is a tall thin board sliding right at 20 m/s, 5 m ahead, in front of the sky.
fn sliding_board(sensor: SensorDesc) -> WorldDesc {
    let toml = r#"
physics = "analytic"
camera_hz = 30.0
physics_substeps = 4
sky_luminance = 0.8
[ground]
enabled = false
[camera]
n = 64
[[vehicles]]
name = "board"
start = [5.3, 21.4]
heading_deg = -90.0
speed_mps = 20.0
parts = [ { shape = { kind = "box", size = [40.0, 0.05, 40.0] }, offset = [0.0, 0.0, 0.0], texture = { kind = "uniform", luminance = 0.2 } } ]
"#;
    let mut desc: WorldDesc = toml::from_str(toml).expect("world");
    desc.camera.sensor = sensor;
    desc
}

/// The board's leading edge in pixel columns (continuous; pixel c spans [c, c + 1]) at time `t_s`
/// for a camera at `cam_y` (m) looking along +x from `cam_x`: the board moves towards −y (right).
fn edge_column(t_s: f64, cam_x: f64, cam_y: f64, n: f64) -> f64 {
    let y_edge = 21.4 - 20.0 - 20.0 * t_s; // centre minus half the 40 m length
    let depth = 5.3 - 0.025 - cam_x;
    let x_norm = -(y_edge - cam_y) / depth / (30f64.to_radians()).tan();
    (x_norm + 1.0) / 2.0 * n
}

/// With a 20 ms exposure the board's edge is the analytic box filter of the sharp edge over the
/// exposure (each pixel sampled at its centre: the fraction of the exposure the board covered it)
/// within 1/255, with 256 sub-frames.
#[test]
fn a_moving_edge_is_blurred_as_the_box_filtered_edge() {
    let exposure_s = 0.02;
    let desc = sliding_board(SensorDesc {
        exposure_s,
        subframes: 256,
        ..SensorDesc::default()
    });
    let mut sim = common::rendering_sim(&desc, 3);
    let mut out = sim.step(&Command::default()).expect("step");
    for _ in 0..2 {
        out = sim.step(&Command::default()).expect("step");
    }
    let cam = sim.camera_pose().position;
    let n = sim.n() as usize;
    let t = out.t_s;
    let (at_end, at_start) = (
        edge_column(t, cam.x, cam.y, n as f64),
        edge_column(t - exposure_s, cam.x, cam.y, n as f64),
    );
    assert!(
        at_end - at_start > 3.0 && at_start > 8.0 && at_end < n as f64 - 8.0,
        "the edge moves {at_start:.2} → {at_end:.2} px during the exposure"
    );
    let row = n / 2;
    let mut worst = 0.0f64;
    for c in 0..n {
        let centre = c as f64 + 0.5;
        let covered = ((at_end - centre) / (at_end - at_start)).clamp(0.0, 1.0);
        let expected = 0.8 + (0.2 - 0.8) * covered;
        let got = f64::from(out.frame[row * n + c]);
        worst = worst.max((got - expected).abs());
    }
    assert!(
        worst <= 1.0 / 255.0,
        "largest difference from the box-filtered edge: {worst}"
    );
    // the ideal camera's edge is sharp: every pixel is board or sky
    let mut ideal = common::rendering_sim(&sliding_board(SensorDesc::default()), 3);
    let mut out = ideal.step(&Command::default()).expect("step");
    for _ in 0..2 {
        out = ideal.step(&Command::default()).expect("step");
    }
    let row = &out.frame[(n / 2) * n..(n / 2 + 1) * n];
    assert!(row.iter().all(|&v| v == 0.2 || v == 0.8), "{row:?}");
}

/// A noisy, blurred, quantised sensor on the golden world's moving objects.
fn noisy_world() -> WorldDesc {
    let mut desc = sliding_board(SensorDesc {
        exposure_s: 0.01,
        subframes: 3,
        full_well_e: 5000.0,
        read_noise_e: 6.0,
        gain: 1.2,
        bits: 8,
        gamma: 2.2,
    });
    desc.camera.n = 32;
    desc
}

fn frames(desc: &WorldDesc, seed: u64, steps: usize) -> Vec<Vec<f32>> {
    let mut sim = common::rendering_sim(desc, seed);
    let mut frames = vec![sim.observe().expect("observe").frame];
    for _ in 0..steps {
        frames.push(sim.step(&Command::default()).expect("step").frame);
    }
    frames
}

#[test]
fn the_same_seed_gives_the_same_noisy_frames_and_another_seed_others() {
    let desc = noisy_world();
    let a = frames(&desc, 5, 4);
    assert_eq!(a, frames(&desc, 5, 4));
    let b = frames(&desc, 6, 4);
    for (k, (fa, fb)) in a.iter().zip(&b).enumerate() {
        assert_ne!(fa, fb, "frame {k}: seeds 5 and 6 gave the same noise");
    }
    // quantised to 8 bits
    assert!(
        a.iter()
            .flatten()
            .all(|&v| ((v * 255.0).round() - v * 255.0).abs() < 1e-4)
    );
    // frames differ from frame to frame (a new draw per frame), not only between seeds
    assert_ne!(a[1], a[2]);
}

/// Sim::step, Sim::step_batch and captured views rendered later in one batch make the same
/// sensor frames bit for bit (the runner's open loop renders captured views; a tail steps).
#[test]
fn every_way_of_making_a_frame_applies_the_sensor_alike() {
    let desc = noisy_world();
    let stepped = frames(&desc, 9, 5);
    // step_batch of two simulators
    let mut a = common::rendering_sim(&desc, 9);
    let mut b = common::rendering_sim(&desc, 9);
    let mut renderer = Renderer::new(desc.camera.n).expect("renderer");
    for (k, expected) in stepped.iter().enumerate().skip(1) {
        let outs = Sim::step_batch(&mut [&mut a, &mut b], &[Command::default(); 2], &mut renderer).expect("batch");
        assert_eq!(&outs[0].frame, expected, "step_batch frame {k}");
        assert_eq!(&outs[1].frame, expected, "step_batch frame {k}");
    }
    // captured views of a physics-only simulator, rendered together afterwards
    let mut physics = Sim::new_physics_only(&desc, 9).expect("physics");
    let views: Vec<_> = (0..5)
        .map(|_| {
            physics.step(&Command::default()).expect("step");
            physics.capture_view()
        })
        .collect();
    let descs: Vec<_> = views.iter().map(|v| v.desc()).collect();
    let mut got = vec![Vec::new(); descs.len()];
    renderer.render_batch(&descs, &mut got).expect("render_batch");
    for (k, frame) in got.iter().enumerate() {
        assert_eq!(frame, &stepped[k + 1], "captured view {}", k + 1);
    }
}

/// The ideal sensor's table written out is the ideal camera: nothing applied, frames unchanged.
#[test]
fn an_explicit_ideal_sensor_changes_nothing() {
    let mut explicit = sliding_board(SensorDesc::default());
    explicit.camera.sensor.subframes = 8; // no exposure: sub-frames unused
    assert_eq!(
        frames(&explicit, 1, 3),
        frames(&sliding_board(SensorDesc::default()), 1, 3)
    );
}

/// With a perception latency of d frames a step's frame is the view of d frames earlier (the
/// first frame while the line fills), through every way of making a frame; ground truth is now's.
#[test]
fn a_perception_latency_delays_the_frames_by_whole_frames() {
    let ideal = sliding_board(SensorDesc::default());
    let mut late = ideal.clone();
    late.camera.perception_latency_s = 0.07; // 2.1 frames at 30 Hz: 2
    let (a, b) = (frames(&ideal, 2, 6), frames(&late, 2, 6));
    for k in 0..a.len() {
        assert_eq!(b[k], a[k.saturating_sub(2)], "frame {k}");
    }
    // a physics-only replay then rendering in a batch (the runner's closed-loop tails), and
    // captured views, give the same delayed frames
    let mut physics = Sim::new_physics_only(&late, 2).expect("physics");
    let views: Vec<_> = (0..3)
        .map(|_| {
            physics.step(&Command::default()).expect("step");
            physics.capture_view()
        })
        .collect();
    let mut renderer = Renderer::new(late.camera.n).expect("renderer");
    let descs: Vec<_> = views.iter().map(|v| v.desc()).collect();
    let mut got = vec![Vec::new(); descs.len()];
    renderer.render_batch(&descs, &mut got).expect("render_batch");
    for (k, frame) in got.iter().enumerate() {
        assert_eq!(frame, &b[k + 1], "captured view {}", k + 1);
    }
    for (k, expected) in b.iter().enumerate().skip(4) {
        let out = Sim::step_batch(&mut [&mut physics], &[Command::default()], &mut renderer).expect("batch");
        assert_eq!(&out[0].frame, expected, "tail frame {k}");
        assert!(
            (out[0].t_s - k as f64 / 30.0).abs() < 1e-12,
            "the output's time is now's"
        );
    }
}

/// With an actuation latency of d frames the robot's velocities are the ideal robot's d frames
/// later (dynamic physics: the drive tracks the delayed command).
#[test]
fn an_actuation_latency_delays_the_commands_by_whole_frames() {
    let mut ideal = WorldDesc::default();
    ideal.camera.n = 20;
    let mut late = ideal.clone();
    late.robot.actuation_latency_s = 0.025; // 3 frames at 120 Hz
    let commands: Vec<Command> = (0..20)
        .map(|k| {
            if k < 5 {
                Command::forward(1.0)
            } else {
                Command::forward(0.2)
            }
        })
        .collect();
    let speeds = |desc: &WorldDesc| {
        let mut sim = Sim::new_physics_only(desc, 1).expect("physics");
        commands
            .iter()
            .map(|c| sim.step(c).expect("step").robot.velocity_mps[0])
            .collect::<Vec<f64>>()
    };
    let (a, b) = (speeds(&ideal), speeds(&late));
    assert!(a[8] < a[4], "the slower command slows the robot: {a:?}");
    for k in 3..a.len() {
        assert_eq!(b[k], a[k - 3], "speed after step {k}");
    }
}
