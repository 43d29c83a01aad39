//! A detector defined here, in the test, and registered with one line: the scenario schema, the
//! detectors-file entries, detector lists, the runner and the report know it by its id like a
//! built-in detector (docs/adding-a-detector.md). This file plays the role of the one new file of
//! the recipe; `registry()` holds the one registration line.

use std::path::Path;

use loomlab_agents::TriggerSignal;
use loomlab_detector::registry::{DetectorConfig, Registration, Signal};
use loomlab_detector::{Detector, DetectorError, Frame, Registry, Signals};
use loomlab_scenarios::report::{Report, ReportMeta};
use loomlab_scenarios::schema::{camera_facts, resolve_detector_in};
use loomlab_scenarios::{LoadOptions, Runner, parse_scenario};
use serde::Deserialize;

// ---- the new file: a model, its config and its registration ----

/// Parameters of [`MeanChange`].
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct MeanChangeConfig {
    /// Gain applied to |mean(F_t) − mean(F_{t−1})|.
    gain: f64,
}

impl Default for MeanChangeConfig {
    fn default() -> Self {
        Self { gain: 100.0 }
    }
}

impl DetectorConfig for MeanChangeConfig {
    fn validate(&self) -> Result<(), DetectorError> {
        if self.gain.is_finite() && self.gain > 0.0 {
            Ok(())
        } else {
            Err(DetectorError::InvalidParameter {
                name: "mean_change.gain",
                value: self.gain.to_string(),
                reason: "must be a finite number > 0 (default 100)".into(),
            })
        }
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(MeanChange {
            gain: self.gain,
            previous: None,
        }))
    }
}

/// Output: gain × the change of the frame's mean luminance since the previous frame.
struct MeanChange {
    gain: f64,
    previous: Option<f64>,
}

impl Detector for MeanChange {
    fn id(&self) -> &'static str {
        "mean_change"
    }

    fn reset(&mut self) {
        self.previous = None;
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        let mean = frame.data().iter().map(|&v| f64::from(v)).sum::<f64>() / frame.data().len() as f64;
        let output = self.previous.map_or(0.0, |p| self.gain * (mean - p).abs());
        self.previous = Some(mean);
        Ok(Signals {
            output,
            angular_size_deg: None,
            aux: Vec::new(),
            region: None,
            objects: Vec::new(),
        })
    }
}

fn registration() -> Registration {
    Registration::of::<MeanChangeConfig>(
        "mean_change",
        "Change of the mean luminance (a test detector)",
        &[Signal::Output],
        Signal::Output,
        0.05,
    )
}

// ---- the one registration line ----

fn registry() -> Registry {
    Registry::builtin().clone().with(registration()).unwrap()
}

// ---- it appears everywhere ----

/// A ball thrown at a standing robot on a dark ground, 32×32 frames.
fn scenario_text(detectors: &str) -> String {
    format!(
        r#"
name = "ball"
[episode]
duration_s = 1.5
seed = 3
[world]
sky_luminance = 0.5
camera = {{ n = 32 }}
ground = {{ enabled = false }}
[[world.projectiles]]
name = "ball"
target = "camera"
radius_m = 0.15
speed_mps = 4.0
launch_distance_m = 4.0
launch_time_s = 0.2
texture = {{ kind = "uniform", luminance = 0.0 }}
{detectors}
"#
    )
}

fn opts() -> LoadOptions {
    LoadOptions {
        registry: registry(),
        ..LoadOptions::default()
    }
}

#[test]
fn a_registered_detector_is_a_detector_everywhere() {
    let r = registry();
    // detector lists: `all` and by id
    assert_eq!(r.parse_list("all").unwrap().last(), Some(&"mean_change"));
    assert_eq!(r.parse_list("soc,mean_change").unwrap(), ["soc", "mean_change"]);
    // the schema: the default set of a scenario without [[detectors]] includes it, at its defaults
    let path = Path::new("ball.toml");
    let s = parse_scenario(&scenario_text(""), path, None, &opts()).unwrap();
    let ep = s.episode(0).unwrap();
    let labels: Vec<&str> = ep.detectors.iter().map(|d| d.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "hopfield",
            "soc",
            "keil2004",
            "cizek2019",
            "fu2020",
            "tracker",
            "event_soc",
            "event_lgmd",
            "mean_change"
        ]
    );
    let row = ep.detectors.last().unwrap();
    assert_eq!((row.threshold, row.trigger), (0.05, TriggerSignal::Output));
    // entries with params, checked against its config type
    let entry = "[[detectors]]\nid = \"mean_change\"\nlabel = \"mc\"\nparams = { gain = 50.0 }\n";
    let s = parse_scenario(&scenario_text(entry), path, None, &opts()).unwrap();
    let spec = &s.episode(0).unwrap().detectors[0];
    assert_eq!(spec.params.config::<MeanChangeConfig>().unwrap().gain, 50.0);
    let bad = "[[detectors]]\nid = \"mean_change\"\nparams = { gian = 50.0 }\n";
    let e = parse_scenario(&scenario_text(bad), path, None, &opts())
        .unwrap_err()
        .to_string();
    assert!(e.contains("detectors[0].params.gian") && e.contains("gain"), "{e}");
    let bad = "[[detectors]]\nid = \"mean_change\"\nparams = { gain = -1.0 }\n";
    let e = parse_scenario(&scenario_text(bad), path, None, &opts())
        .unwrap_err()
        .to_string();
    assert!(e.contains("mean_change.gain") && e.contains("> 0"), "{e}");
    // it gives no θ̂: the θ̂ trigger is refused, naming the detectors that give it
    let bad = "[[detectors]]\nid = \"mean_change\"\ntrigger = \"angular_size\"\n";
    let e = parse_scenario(&scenario_text(bad), path, None, &opts())
        .unwrap_err()
        .to_string();
    assert!(e.contains("hopfield") && e.contains("mean_change"), "{e}");
    // without the registration the id is unknown, and the message lists the known ids
    let e = parse_scenario(&scenario_text(entry), path, None, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown detector `mean_change`") && e.contains("fu2020"),
        "{e}"
    );
    // one entry resolved on its own (detectors files, sweeps)
    let desc = loomlab_scenarios::schema::DetectorDesc {
        threshold: Some(0.2),
        ..loomlab_scenarios::schema::DetectorDesc::of_id("mean_change")
    };
    let world = ep.world.clone();
    assert_eq!(
        resolve_detector_in(&r, &desc, camera_facts(&world)).unwrap().threshold,
        0.2
    );
}

#[test]
fn the_runner_runs_and_scores_a_registered_detector() {
    let entries = "[[detectors]]\nid = \"soc\"\n[[detectors]]\nid = \"mean_change\"\n";
    let s = parse_scenario(&scenario_text(entries), Path::new("ball.toml"), None, &opts()).unwrap();
    let ep = s.episode(0).unwrap();
    let runner = Runner::new(Some(1)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    let run = runner.run(&[&ep], |_, _| Ok(())).unwrap().remove(0);
    let trace = run.trace.detectors.iter().find(|d| d.label == "mean_change").unwrap();
    assert!(trace.output.iter().any(|&v| v > 0.0), "the ball changes the mean");
    let meta = ReportMeta {
        suite: "ball".into(),
        seed: 0,
        wall_time_s: 0.0,
        lead_margin_s: 0.0,
    };
    let report = Report::from_episodes(&meta, &[run.outcome]);
    let (mine, soc) = (&report.detectors["mean_change"], &report.detectors["soc"]);
    assert_eq!(mine.episodes, 1);
    // the same report keys as a built-in row
    let json: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
    let keys = |label: &str| -> Vec<String> { json["detectors"][label].as_object().unwrap().keys().cloned().collect() };
    assert_eq!(keys("mean_change"), keys("soc"));
    assert_eq!(soc.episodes, 1);
}
