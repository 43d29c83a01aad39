//! Perception and actuation latency (`world.camera.perception_latency_s`,
//! `world.robot.actuation_latency_s`, applied by the simulator: `loomlab_sim::latency`) in the
//! runner's closed loop, its deadline replays and its reference rows (needs a GPU adapter;
//! lavapipe is enough).

use std::path::Path;

use loomlab_scenarios::metrics::Outcome;
use loomlab_scenarios::reference::ORACLE;
use loomlab_scenarios::{EpisodeRun, LoadOptions, Runner, parse_scenario};
use loomlab_sim::{SensorDesc, SensorProfile};

/// A ball thrown slowly at a standing robot on a uniform background; `early` (soc at a tiny
/// threshold) alarms on the ball's first motion.
const SCENARIO: &str = r#"
name = "slow_ball"
[episode]
duration_s = 2.4
seed = 5
[world]
sky_luminance = 0.5
camera = { n = 32 }
ground = { enabled = false }
[[world.projectiles]]
name = "ball"
target = "camera"
radius_m = 0.15
speed_mps = 3.0
launch_distance_m = 5.0
launch_time_s = 0.3
texture = { kind = "uniform", luminance = 0.0 }
[robot]
forward_mps = 0.0
[controller]
dodge_speed_mps = 1.5
duration_s = 0.6
[scoring]
lead_margin_s = 0.0
[[detectors]]
id = "soc"
label = "early"
threshold = 0.01
"#;

/// The episode run with `perception` and `actuation` latency (s).
fn run(perception_latency_s: f32, actuation_latency_s: f32) -> EpisodeRun {
    let opts = LoadOptions {
        sensor: Some(SensorProfile {
            name: "test",
            sensor: SensorDesc::default(),
            perception_latency_s,
            actuation_latency_s,
            camera_kind: loomlab_sim::CameraKind::Frames,
        }),
        ..LoadOptions::default()
    };
    let s = parse_scenario(SCENARIO, Path::new("slow_ball.toml"), None, &opts).unwrap();
    let runner = Runner::new(Some(1)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    runner.run_episode(&s.episode(0).unwrap()).unwrap()
}

fn row<'a>(run: &'a EpisodeRun, label: &str) -> &'a loomlab_scenarios::metrics::DetectorEpisode {
    run.outcome
        .detectors
        .iter()
        .find(|d| d.detector == label)
        .unwrap_or_else(|| panic!("no row {label}"))
}

const FRAME_S: f64 = 1.0 / 120.0;

/// A perception latency L delays a row's first alarm by L quantised to frames (25 ms: 3 frames at
/// 120 Hz), and leaves the deadline (a decision time, found by physics) where it was.
#[test]
fn a_perception_latency_shifts_the_first_alarm_by_whole_frames() {
    let ideal = run(0.0, 0.0);
    let late = run(0.025, 0.0);
    let (a0, a1) = (
        row(&ideal, "early").t_alarm_s.expect("early alarms"),
        row(&late, "early").t_alarm_s.expect("early alarms late too"),
    );
    assert!((a1 - a0 - 3.0 * FRAME_S).abs() < 1e-9, "alarm {a0} → {a1}");
    // 20 ms is 2.4 frames: 2
    let rounded = run(0.020, 0.0);
    let a2 = row(&rounded, "early").t_alarm_s.unwrap();
    assert!((a2 - a0 - 2.0 * FRAME_S).abs() < 1e-9, "alarm {a0} → {a2}");
    assert_eq!(row(&ideal, ORACLE).t_deadline_s, row(&late, ORACLE).t_deadline_s);
}

/// Under an actuation latency the oracle still evades, and the deadline moves earlier by at least
/// the latency quantised to frames (the dodge starts that many frames later: 10 ms is 1 frame of
/// 8.3 ms at 120 Hz); with both latencies too.
#[test]
fn under_latency_the_oracle_evades_and_the_deadline_moves_earlier() {
    let ideal = run(0.0, 0.0);
    let d0 = row(&ideal, ORACLE).t_deadline_s.expect("an evadable threat");
    for (perception, actuation) in [(0.0, 0.025), (0.025, 0.010)] {
        let late = run(perception, actuation);
        let oracle = row(&late, ORACLE);
        let d1 = oracle.t_deadline_s.expect("still evadable");
        let frames = (f64::from(actuation) / FRAME_S).round();
        assert!(
            d1 <= d0 - frames * FRAME_S + 1e-9,
            "deadline {d0} → {d1} under {actuation} s of actuation latency"
        );
        assert_eq!(oracle.outcome, Outcome::Hit);
        assert!(
            !oracle.collision,
            "the oracle collided under latency ({perception}, {actuation})"
        );
    }
}
