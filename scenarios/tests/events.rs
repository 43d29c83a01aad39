//! The event camera in the runner (`--sensor events`, `[world.camera] kind = "events"`): the
//! frame rows read the same frames and give the same rows as without it; the event rows read the
//! camera's events (not the events made from frames); the same seed gives the same run (needs a
//! GPU adapter; lavapipe is enough).

use std::path::Path;

use loomlab_scenarios::{EpisodeRun, LoadOptions, Runner, parse_scenario};
use loomlab_sim::SensorProfile;

/// A ball thrown at a standing robot; frame rows and event rows at thresholds that alarm.
const SCENARIO: &str = r#"
name = "ball"
[episode]
duration_s = 2.0
seed = 5
[world]
sky_luminance = 0.5
camera = { n = 32 }
ground = { enabled = false }
[[world.projectiles]]
name = "ball"
target = "camera"
radius_m = 0.15
speed_mps = 4.0
launch_distance_m = 5.0
launch_time_s = 0.3
texture = { kind = "uniform", luminance = 0.0 }
[robot]
forward_mps = 0.0
[[detectors]]
id = "soc"
threshold = 5.0
[[detectors]]
id = "hopfield"
[[detectors]]
id = "event_soc"
threshold = 20.0
[[detectors]]
id = "event_lgmd"
threshold = 50.0
"#;

fn run(profile: &str) -> EpisodeRun {
    let opts = LoadOptions {
        sensor: Some(SensorProfile::named(profile).unwrap()),
        ..LoadOptions::default()
    };
    let s = parse_scenario(SCENARIO, Path::new("ball.toml"), None, &opts).unwrap();
    let runner = Runner::new(Some(1)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    runner.run_episode(&s.episode(0).unwrap()).unwrap()
}

#[test]
fn frame_rows_are_unchanged_and_event_rows_read_the_event_camera() {
    let (frames, events, again) = (run("ideal"), run("events"), run("events"));
    for label in ["soc", "hopfield"] {
        let row = |r: &EpisodeRun| {
            let i = r.trace.detectors.iter().position(|d| d.label == label).unwrap();
            (
                r.trace.detectors[i].clone(),
                r.outcome.detectors[i].clone(),
                r.closed_loop[i].clone(),
            )
        };
        assert_eq!(row(&frames), row(&events), "{label}");
    }
    for label in ["event_soc", "event_lgmd"] {
        let output = |r: &EpisodeRun| {
            r.trace
                .detectors
                .iter()
                .find(|d| d.label == label)
                .unwrap()
                .output
                .clone()
        };
        // the camera's events (sub-frames, thresholds with mismatch, noise) are not the events
        // made from frames
        assert_ne!(output(&frames), output(&events), "{label}");
        assert!(output(&events).iter().any(|&v| v > 0.0), "{label}");
    }
    // the same seed, the same run (all but the wall time)
    assert_eq!(
        (&events.outcome, &events.trace, &events.closed_loop),
        (&again.outcome, &again.trace, &again.closed_loop)
    );
}
