//! The efference copy reaches a detector identically in the runner's open-loop pass and in its
//! closed-loop tail (which replays the cached frames through the escape agent up to the alarm):
//! both build it with `loomlab_agents::CameraMotionSensor` from the camera's pose. A detector defined here
//! records every copy it is handed.

use std::path::Path;
use std::sync::{Arc, Mutex};

use loomlab_detector::registry::{DetectorConfig, Registration, Signal};
use loomlab_detector::{Detector, DetectorError, EfferenceCopy, Frame, Registry, Signals};
use loomlab_scenarios::{LoadOptions, Runner, parse_scenario};
use loomlab_sim::{SensorDesc, SensorProfile};
use serde::Deserialize;

/// Every recorder built, in build order, with the copies it was handed.
static RECORDS: Mutex<Vec<Arc<Mutex<Vec<EfferenceCopy>>>>> = Mutex::new(Vec::new());

/// Parameters of [`Recorder`] (none).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct RecorderConfig {}

impl DetectorConfig for RecorderConfig {
    fn validate(&self) -> Result<(), DetectorError> {
        Ok(())
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        let seen = Arc::new(Mutex::new(Vec::new()));
        RECORDS.lock().unwrap().push(Arc::clone(&seen));
        Ok(Box::new(Recorder { seen }))
    }
}

/// Output: the number of frames seen so far (so a threshold alarms at a chosen frame).
struct Recorder {
    seen: Arc<Mutex<Vec<EfferenceCopy>>>,
}

impl Detector for Recorder {
    fn id(&self) -> &'static str {
        "ego_recorder"
    }

    fn reset(&mut self) {
        self.seen.lock().unwrap().clear();
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        self.step_moving(frame, &EfferenceCopy::default())
    }

    fn step_moving(&mut self, _frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        let mut seen = self.seen.lock().unwrap();
        seen.push(*ego);
        Ok(Signals {
            output: seen.len() as f64,
            ..Signals::default()
        })
    }
}

/// The copies the recorder was handed in the open loop and in the closed-loop tail of a robot
/// cruising at 1 m/s over the ground with a shaking camera (the recorder alarms at frame 30), under
/// a perception latency of `perception_latency_s`.
fn recorded(perception_latency_s: f32) -> (Vec<EfferenceCopy>, Vec<EfferenceCopy>) {
    let registry = Registry::builtin()
        .clone()
        .with(Registration::of::<RecorderConfig>(
            "ego_recorder",
            "Records its efference copies (a test detector)",
            &[Signal::Output],
            Signal::Output,
            1.0,
        ))
        .unwrap();
    let text = r#"
name = "cruise"
[episode]
duration_s = 0.5
seed = 5
[world]
camera = { n = 32, pitch_deg = -5.0, shake = { rotation_deg = 1.0, translation_m = 0.002, frequency_hz = 4.0 } }
[robot]
forward_mps = 1.0
[[detectors]]
id = "ego_recorder"
threshold = 30.0
"#;
    let opts = LoadOptions {
        registry,
        sensor: Some(SensorProfile {
            name: "test",
            sensor: SensorDesc::default(),
            perception_latency_s,
            actuation_latency_s: 0.0,
            camera_kind: loomlab_sim::CameraKind::Frames,
        }),
        ..LoadOptions::default()
    };
    let s = parse_scenario(text, Path::new("cruise.toml"), None, &opts).unwrap();
    let ep = s.episode(0).unwrap();
    let runner = Runner::new(Some(1)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    let mut records = RECORDS.lock().unwrap();
    records.clear();
    drop(records);
    let run = runner.run(&[&ep], |_, _| Ok(())).unwrap().remove(0);
    assert_eq!(run.closed_loop[0].triggers, 1, "the recorder alarmed and its tail ran");
    let records = RECORDS.lock().unwrap();
    assert_eq!(records.len(), 2, "one recorder for the open loop, one for the tail");
    let open = records[0].lock().unwrap().clone();
    let tail = records[1].lock().unwrap().clone();
    (open, tail)
}

/// Both tests use the one list of recorders: one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

#[test]
fn the_open_loop_and_the_closed_loop_tail_hand_detectors_the_same_efference_copy() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (open, tail) = recorded(0.0);
    // up to and including the alarm frame (index 29) the tail replays the open loop exactly
    assert!(tail.len() > 30 && open.len() > 30);
    assert_eq!(open[..30], tail[..30]);
    // and the copies carry the camera's motion and pose: none on the first frame, then the
    // 1 m/s drive (8.3 mm per 120 Hz frame, shake included), the height and the pitch
    assert_eq!(open[0].dt_s, 0.0);
    for e in &open[1..30] {
        assert!((e.dt_s - 1.0 / 120.0).abs() < 1e-9, "{e:?}");
        assert!((e.translation_m[0] - 1.0 / 120.0).abs() < 2e-3, "{e:?}");
        assert!(e.height_m > 0.1 && e.pitch_rad.to_degrees() < -3.0, "{e:?}");
        assert_eq!(e.forward_mps, 1.0);
    }
    assert!(
        open[1..30]
            .iter()
            .any(|e| e.rotation_rad.iter().any(|r| r.abs() > 1e-4)),
        "the shake rotates the camera"
    );
}

/// Under a perception latency of d frames a detector is handed the copy of the frame it sees —
/// the camera's motion and pose when that frame was taken, d frames ago — not the copy of now
/// (25 ms: 3 frames at 120 Hz), in the open loop and the tail alike.
#[test]
fn under_a_perception_latency_the_copy_is_the_shown_frames() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (ideal, _) = recorded(0.0);
    let (late, late_tail) = recorded(0.025);
    assert_eq!(late[..30], late_tail[..30], "the tail replays the open loop");
    // while the line fills the view before the first step is shown: no motion
    for e in &late[..3] {
        assert_eq!(e.dt_s, 0.0, "{e:?}");
    }
    for k in 4..30 {
        assert_eq!(late[k], ideal[k - 3], "frame {k}: the copy of frame {}", k - 3);
    }
}
