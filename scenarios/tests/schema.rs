//! Scenario schema, expansion and suite loading (no GPU needed).

use std::path::{Path, PathBuf};

use loomlab_agents::TriggerSignal;
use loomlab_detector::HopfieldConfig;
use loomlab_scenarios::reference::REFERENCE_LABELS;
use loomlab_scenarios::schema::{
    DetectorDesc, camera_facts, default_camera, parse_detector_entries, registration, resolve_detector,
};
use loomlab_scenarios::{DEFAULT_SUITE, LoadOptions, ScenarioError, load_scenario, load_suite, parse_scenario};

const BASE: &str = r#"
name = "ball"
[episode]
duration_s = 1.0
seed = 3
[world]
camera = { n = 32 }
[[world.projectiles]]
speed_mps = 8.0
[robot]
forward_mps = 1.0
"#;

/// Parses and expands every episode (loading checks the first; the others are checked as they
/// are expanded, as `loomlab run` does for the episodes it runs before starting).
fn parse(text: &str) -> Result<loomlab_scenarios::Scenario, ScenarioError> {
    let s = parse_scenario(text, Path::new("dir/test.toml"), None, &LoadOptions::default())?;
    s.expand_all()?;
    Ok(s)
}

fn err(text: &str) -> String {
    let e = parse(text).expect_err("should be rejected");
    e.to_string()
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("loomlab-schema-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn a_plain_scenario_is_one_episode_with_all_detectors() {
    let s = parse(BASE).unwrap();
    assert_eq!(s.name, "ball");
    assert_eq!(s.len(), 1);
    let ep = &s.episode(0).unwrap();
    assert_eq!(ep.frames(), 120);
    assert_eq!(ep.cruise.command_at(0.5).forward_mps, 1.0);
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
            "event_lgmd"
        ]
    );
    for d in &ep.detectors {
        assert_eq!(Some(d.threshold), registration(&d.id).map(|r| r.default_threshold));
    }
    assert_eq!(ep.detectors[0].trigger, TriggerSignal::AngularSizeDeg);
    assert_eq!(ep.detectors[1].trigger, TriggerSignal::Output);
    // the Hopfield readout uses the camera's size and field of view
    assert_eq!(ep.detectors[0].params.config::<HopfieldConfig>().unwrap().n, 32);
    assert_eq!(ep.detectors[0].params.config::<HopfieldConfig>().unwrap().fov_deg, 60.0);
    // the calibrated defaults (scenarios/README.md) are a contract of the registry
    let defaults: Vec<f64> = ep.detectors.iter().map(|d| d.threshold).collect();
    assert_eq!(defaults, [10.0, 270.0, 0.000095, 0.0172, 2.47, 10.0, 2480.0, 940.0]);
}

#[test]
fn the_name_defaults_to_the_file_stem() {
    let text = BASE.replace("name = \"ball\"", "");
    assert_eq!(parse(&text).unwrap().name, "test");
}

#[test]
fn unknown_keys_are_errors_naming_file_and_key_path() {
    let e = err(&BASE.replace("speed_mps = 8.0", "sped_mps = 8.0"));
    assert!(e.starts_with("dir/test.toml: "), "{e}");
    assert!(e.contains("`world.projectiles[0].sped_mps`"), "{e}");
    assert!(e.contains("unknown field"), "{e}");

    let e = err(&format!("{BASE}\n[controler]\nduration_s = 1.0\n"));
    assert!(e.contains("`controler`") && e.contains("unknown field"), "{e}");

    let e = err(&format!("{BASE}\n[scoring]\nlead_min = 0.1\n"));
    assert!(e.contains("`scoring.lead_min`"), "{e}");

    let e = err(&format!(
        "{BASE}\n[[detectors]]\nid = \"hopfield\"\nparams = {{ beta2 = 3 }}\n"
    ));
    assert!(e.contains("`detectors[0].params.beta2`"), "{e}");

    let e = err(&format!(
        "{BASE}\n[[detectors]]\nid = \"soc\"\nparams = {{ gain = 3 }}\n"
    ));
    assert!(e.contains("`detectors[0].params.gain`"), "{e}");
}

#[test]
fn wrong_types_and_values_name_the_key() {
    let e = err(&BASE.replace("speed_mps = 8.0", "speed_mps = \"fast\""));
    assert!(
        e.contains("`world.projectiles[0].speed_mps`") && e.contains("invalid type"),
        "{e}"
    );

    let e = err(&BASE.replace("duration_s = 1.0", "duration_s = -1.0"));
    assert!(e.contains("`episode.duration_s`") && e.contains("-1"), "{e}");
    // one cap on frames per episode, shared with `loomlab render`
    let e = err(&BASE.replace("duration_s = 1.0", "duration_s = 1e9"));
    assert!(
        e.contains("`episode.duration_s`") && e.contains("MAX_EPISODE_FRAMES"),
        "{e}"
    );
    let e = err(&BASE
        .replace("duration_s = 1.0", "duration_s = 3000.0")
        .replace("[world]", "[world]\ncamera_hz = 240.0"));
    assert!(e.contains("720000 frames at 240 Hz"), "{e}");

    let e = err(&BASE.replace("speed_mps = 8.0", "speed_mps = -8.0"));
    assert!(
        e.contains("`world.projectiles[0].speed_mps`") && e.contains("> 0"),
        "{e}"
    );

    let e = err(&BASE.replace("forward_mps = 1.0", "forward_mps = nan"));
    assert!(e.contains("`robot.forward_mps`"), "{e}");

    let e = err(&format!("{BASE}\n[[detectors]]\nid = \"hopfeld\"\n"));
    assert!(e.contains("`detectors[0].id`") && e.contains("known ids"), "{e}");

    let e = err(&format!(
        "{BASE}\n[[detectors]]\nid = \"soc\"\n[[detectors]]\nid = \"soc\"\n"
    ));
    assert!(e.contains("`detectors[1].label`") && e.contains("twice"), "{e}");

    let e = err(&format!(
        "{BASE}\n[[detectors]]\nid = \"hopfield\"\nparams = {{ n = 64 }}\n"
    ));
    assert!(
        e.contains("`detectors[0].params.n`") && e.contains("world.camera"),
        "{e}"
    );

    let e = err(&format!("{BASE}\n[controller]\nthreshold = 5.0\n"));
    assert!(
        e.contains("`controller.threshold`") && e.contains("[[detectors]]"),
        "{e}"
    );

    let e = err(&format!("{BASE}\n[controller]\nduration_s = 0.0\n"));
    assert!(e.contains("`controller`") && e.contains("duration_s"), "{e}");

    let e = err(&BASE.replace("[world]", "[world]\ncamera_hz = -5"));
    assert!(e.contains("`world.camera_hz`"), "{e}");

    let e = err("[world\n");
    assert!(
        e.starts_with("dir/test.toml: invalid TOML") && e.contains("line 1"),
        "{e}"
    );

    let e = err("[episode]\nduration_s = 1.0\n");
    assert!(e.contains("missing field `world`"), "{e}");
}

#[test]
fn a_missing_file_is_an_error_naming_it() {
    let e = load_scenario(Path::new("no/such/scenario.toml"), None, &LoadOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, ScenarioError::Io { .. }));
    assert!(
        msg.contains("no/such/scenario.toml") && msg.contains("cannot read"),
        "{msg}"
    );
    let e = load_suite(Path::new("no/such/suite"), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("no/such/suite"), "{e}");
}

#[test]
fn sweeps_and_random_ranges_expand_to_the_product() {
    let text = format!(
        "{BASE}\n[sweep]\n\"world.projectiles.0.speed_mps\" = [4, 8, 12]\n\"robot.forward_mps\" = [0.0, 1.0]\n\
         [random]\nsamples = 4\n\"world.projectiles.0.miss_distance_m\" = {{ min = 0.0, max = 2.0 }}\n"
    )
    .replace("seed = 3", "seed = 3\nrepeats = 2");
    let s = parse(&text).unwrap();
    assert_eq!(s.len(), 3 * 2 * 4 * 2);
    for (i, ep) in s.expand_all().unwrap().iter().enumerate() {
        assert_eq!(ep.index, i);
    }
    // values land in the typed episodes
    let speeds: Vec<f32> = s
        .expand_all()
        .unwrap()
        .iter()
        .map(|e| e.world.projectiles[0].speed_mps)
        .collect();
    // keys in sorted order, the last fastest: robot.forward_mps outer, the speed inner, then draws, repeats
    assert_eq!(speeds[0], 4.0);
    assert_eq!(speeds[8], 8.0);
    assert_eq!(speeds[16], 12.0);
    assert_eq!(speeds[24], 4.0);
    assert_eq!(s.episode(24).unwrap().cruise.forward_mps, 1.0);
    assert!(
        s.expand_all()
            .unwrap()
            .iter()
            .all(|e| (0.0..2.0).contains(&e.world.projectiles[0].miss_distance_m))
    );
    // parameters are recorded, repeats have their own simulator seeds
    let p = &s.episode(1).unwrap().params;
    assert_eq!(p["world.projectiles.0.speed_mps"], "4");
    assert_eq!(p["repeat"], "1");
    assert!(p.contains_key("world.projectiles.0.miss_distance_m"));
    assert_ne!(s.episode(0).unwrap().seed, s.episode(1).unwrap().seed);
    // deterministic
    let again = parse(&text).unwrap();
    let seeds = |s: &loomlab_scenarios::Scenario| s.expand_all().unwrap().iter().map(|e| e.seed).collect::<Vec<_>>();
    assert_eq!(seeds(&s), seeds(&again));
    // a suite seed changes the draws and the simulator seeds
    let other = parse_scenario(
        &text,
        Path::new("dir/test.toml"),
        None,
        &LoadOptions {
            seed: 9,
            ..LoadOptions::default()
        },
    )
    .unwrap();
    assert_ne!(seeds(&s), seeds(&other));
    assert_ne!(
        s.episode(0).unwrap().world.projectiles[0].miss_distance_m,
        other.episode(0).unwrap().world.projectiles[0].miss_distance_m
    );
}

#[test]
fn sweep_errors_name_the_path_and_the_episode() {
    let e = err(&format!("{BASE}\n[sweep]\n\"world.projectile.0.speed_mps\" = [1, 2]\n"));
    assert!(
        e.contains("world.projectile.0.speed_mps") && e.contains("projectile"),
        "{e}"
    );

    let e = err(&format!(
        "{BASE}\n[sweep]\n\"world.projectiles.3.speed_mps\" = [1, 2]\n"
    ));
    assert!(e.contains("index 3 does not exist"), "{e}");

    // an invalid swept value: names the episode, its parameters and the key
    let e = err(&format!(
        "{BASE}\n[sweep]\n\"world.projectiles.0.speed_mps\" = [8, -1]\n"
    ));
    assert!(e.contains("episode 1"), "{e}");
    assert!(e.contains("world.projectiles.0.speed_mps = -1"), "{e}");
    assert!(e.contains("`world.projectiles[0].speed_mps`"), "{e}");

    // a misspelt leaf is added, then rejected by the typed parse with its path
    let e = err(&format!("{BASE}\n[sweep]\n\"world.projectiles.0.sped_mps\" = [1, 2]\n"));
    assert!(e.contains("sped_mps") && e.contains("unknown field"), "{e}");
}

#[test]
fn cruise_schedule_changes_the_command() {
    let text = format!("{BASE}\n[[robot.schedule]]\nat_s = 0.5\nforward_mps = 2.0\nyaw_rate_rps = 0.1\n");
    let s = parse(&text).unwrap();
    let c = &s.episode(0).unwrap().cruise;
    assert_eq!(c.command_at(0.0).forward_mps, 1.0);
    assert_eq!(c.command_at(0.5).forward_mps, 2.0);
    assert_eq!(c.command_at(0.9).yaw_rate_rps, 0.1);
    let e = err(&format!(
        "{BASE}\n[[robot.schedule]]\nat_s = 0.5\n[[robot.schedule]]\nat_s = 0.2\n"
    ));
    assert!(e.contains("`robot.schedule[1].at_s`"), "{e}");
}

#[test]
fn a_cruise_command_beyond_the_drives_limits_is_refused() {
    // the dynamic physics clamps commands to world.robot's limits: a 3 m/s cruise would silently
    // run at 2 m/s (the default max_speed_mps)
    let fast = BASE.replace("forward_mps = 1.0", "forward_mps = 3.0");
    let e = err(&fast);
    assert!(
        e.contains("robot.forward_mps") && e.contains("world.robot.max_speed_mps (2)"),
        "{e}"
    );
    let e = err(&format!(
        "{BASE}\n[[robot.schedule]]\nat_s = 0.5\nyaw_rate_rps = -2.5\n"
    ));
    assert!(
        e.contains("robot.schedule[0].yaw_rate_rps") && e.contains("max_yaw_rate_rps"),
        "{e}"
    );
    // a swept value names its episode
    let e = err(&format!("{BASE}\n[sweep]\n\"robot.forward_mps\" = [2.0, 3.0]\n"));
    assert!(e.contains("episode 1") && e.contains("max_speed_mps"), "{e}");
    // raising the limit, or closed-form physics (no drive model), accepts it
    parse(&format!("{fast}\n[world.robot]\nmax_speed_mps = 3.0\n")).unwrap();
    parse(&fast.replace("[world]\n", "[world]\nphysics = \"analytic\"\n")).unwrap();
}

#[test]
fn load_options_override_size_and_detectors() {
    let text = format!("{BASE}\n[[detectors]]\nid = \"soc\"\nthreshold = 3.0\n[[detectors]]\nid = \"hopfield\"\n");
    let opts = LoadOptions {
        size: Some(48),
        detectors: Some(vec!["soc".into(), "fu2020".into()]),
        ..LoadOptions::default()
    };
    let s = parse_scenario(&text, Path::new("t.toml"), None, &opts).unwrap();
    let ep = &s.episode(0).unwrap();
    assert_eq!(ep.world.camera.n, 48);
    let got: Vec<(&str, f64)> = ep.detectors.iter().map(|d| (d.label.as_str(), d.threshold)).collect();
    assert_eq!(
        got,
        [
            ("soc", 3.0),
            ("fu2020", registration("fu2020").unwrap().default_threshold)
        ]
    );
}

#[test]
fn labels_let_a_detector_run_twice() {
    let text = format!(
        "{BASE}\n[[detectors]]\nid = \"hopfield\"\nlabel = \"hopfield_8\"\nthreshold = 8.0\n\
         [[detectors]]\nid = \"hopfield\"\nlabel = \"hopfield_12\"\nthreshold = 12.0\nparams = {{ beta = 300.0 }}\n"
    );
    let s = parse(&text).unwrap();
    let d = &s.episode(0).unwrap().detectors;
    assert_eq!(d[0].label, "hopfield_8");
    assert_eq!(d[1].threshold, 12.0);
    assert_eq!(d[1].params.config::<HopfieldConfig>().unwrap().beta, 300.0);
}

#[test]
fn suites_merge_defaults_and_reject_duplicate_names() {
    let dir = tmp_dir("suite");
    std::fs::write(
        dir.join("suite.toml"),
        "description = \"t\"\n[defaults]\nworld.camera = { n = 40 }\nscoring.lead_margin_s = 0.3\n",
    )
    .unwrap();
    std::fs::write(dir.join("a.toml"), BASE.replace("name = \"ball\"", "")).unwrap();
    std::fs::write(
        dir.join("b.toml"),
        BASE.replace("name = \"ball\"", "")
            .replace("[world]\ncamera = { n = 32 }", "[world]"),
    )
    .unwrap();
    let suite = load_suite(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(suite.description, "t");
    assert_eq!(suite.scenarios.len(), 2);
    assert_eq!(suite.scenarios[0].name, "a");
    assert_eq!(
        suite.scenarios[0].episode(0).unwrap().world.camera.n,
        32,
        "the scenario's value wins"
    );
    assert_eq!(
        suite.scenarios[1].episode(0).unwrap().world.camera.n,
        40,
        "the default fills in"
    );
    assert_eq!(suite.scenarios[1].episode(0).unwrap().scoring.lead_margin_s, 0.3);
    assert_eq!(suite.scenarios[1].episode(0).unwrap().scoring.lead_min_s, None);
    assert_eq!(suite.episode_count(), 2);

    // a list file
    let list = dir.join("list.toml");
    std::fs::write(
        &list,
        "scenarios = [\"b.toml\"]\n[defaults]\nworld.camera = { n = 24 }\n",
    )
    .unwrap();
    let suite = load_suite(&list, &LoadOptions::default()).unwrap();
    assert_eq!(suite.scenarios.len(), 1);
    assert_eq!(suite.scenarios[0].episode(0).unwrap().world.camera.n, 24);

    // a typo in [defaults] is blamed on the file that holds it, with the key as written there
    std::fs::write(
        &list,
        "scenarios = [\"b.toml\"]\n[defaults]\nworld.camra = { n = 24 }\n",
    )
    .unwrap();
    let e = load_suite(&list, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("{}: `defaults.world.camra`", list.display())),
        "{e}"
    );
    assert!(e.contains("unknown field") && e.contains("b.toml"), "{e}");
    std::fs::write(dir.join("suite.toml"), "[defaults]\nscoring.lead_margin_s = \"soon\"\n").unwrap();
    let e = load_suite(&dir, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "{}: `defaults.scoring.lead_margin_s`",
            dir.join("suite.toml").display()
        )),
        "{e}"
    );
    // a value the scenario file writes itself is the scenario file's
    std::fs::write(dir.join("suite.toml"), "[defaults]\nworld.camera = { n = 40 }\n").unwrap();
    std::fs::write(
        dir.join("b.toml"),
        BASE.replace("camera = { n = 32 }", "camera = { n = -3 }"),
    )
    .unwrap();
    let e = load_suite(&dir, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("b.toml: `world.camera.n`"), "{e}");
    std::fs::write(
        dir.join("b.toml"),
        BASE.replace("name = \"ball\"", "")
            .replace("[world]\ncamera = { n = 32 }", "[world]"),
    )
    .unwrap();

    // a single scenario file is a suite of one
    let suite = load_suite(&dir.join("a.toml"), &LoadOptions::default()).unwrap();
    assert_eq!(suite.scenarios[0].name, "a");

    // unknown keys in suite files
    std::fs::write(&list, "scenarios = [\"b.toml\"]\ndefault = {}\n").unwrap();
    let e = load_suite(&list, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("`default`") && e.contains("unknown field"), "{e}");

    // duplicate names
    std::fs::remove_file(&list).unwrap();
    std::fs::write(dir.join("c.toml"), BASE.replace("name = \"ball\"", "name = \"a\"")).unwrap();
    let e = load_suite(&dir, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("`a`") && e.contains("unique"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_default_suite_loads_with_at_least_300_episodes() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(DEFAULT_SUITE);
    let suite = load_suite(&path, &LoadOptions::default()).unwrap();
    assert!(suite.scenarios.len() >= 15, "{} scenarios", suite.scenarios.len());
    assert!(suite.episode_count() >= 300, "{} episodes", suite.episode_count());
    for s in &suite.scenarios {
        assert!(!s.description.is_empty(), "{} has no description", s.name);
        let text = std::fs::read_to_string(&s.file).unwrap();
        assert!(
            text.starts_with('#'),
            "{} starts without a comment header",
            s.file.display()
        );
    }
}

#[test]
fn the_scoring_margin_defaults_to_zero_and_is_checked() {
    let s = parse(BASE).unwrap();
    assert_eq!(s.episode(0).unwrap().scoring.lead_margin_s, 0.0);
    assert_eq!(s.episode(0).unwrap().scoring.lead_min_s, None);
    let s = parse(&format!("{BASE}\n[scoring]\nlead_margin_s = 0.05\n")).unwrap();
    assert_eq!(s.episode(0).unwrap().scoring.lead_margin_s, 0.05);
    s.episode(0).unwrap().scoring.validate().unwrap();
    for bad in ["-0.1", "nan", "inf"] {
        let e = err(&format!("{BASE}\n[scoring]\nlead_margin_s = {bad}\n"));
        assert!(
            e.contains("`scoring.lead_margin_s`") && e.contains(">= 0"),
            "{bad}: {e}"
        );
    }
}

#[test]
fn the_removed_lead_min_s_is_an_error_naming_its_replacement() {
    let e = err(&format!("{BASE}\n[scoring]\nlead_min_s = 0.2\n"));
    assert!(e.starts_with("dir/test.toml: "), "{e}");
    assert!(e.contains("`scoring.lead_min_s`"), "{e}");
    assert!(e.contains("lead_margin_s") && e.contains("deadline"), "{e}");
    // also beside a valid margin, and when it comes from a suite's defaults
    let e = err(&format!("{BASE}\n[scoring]\nlead_margin_s = 0.1\nlead_min_s = 0.2\n"));
    assert!(e.contains("`scoring.lead_min_s`") && e.contains("lead_margin_s"), "{e}");
    let dir = tmp_dir("lead-min");
    std::fs::write(
        dir.join("suite.toml"),
        "description = \"old\"\n[defaults]\nscoring.lead_min_s = 0.3\n",
    )
    .unwrap();
    std::fs::write(dir.join("a.toml"), BASE).unwrap();
    let e = load_suite(&dir, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        e.contains("suite.toml") && e.contains("`defaults.scoring.lead_min_s`") && e.contains("lead_margin_s"),
        "{e}"
    );
    // swept: the error names the episode and the key
    let e = err(&format!(
        "{BASE}\n[scoring]\nlead_margin_s = 0.0\n[sweep]\n\"scoring.lead_min_s\" = [0.1, 0.2]\n"
    ));
    assert!(
        e.contains("episode 0") && e.contains("`scoring.lead_min_s`") && e.contains("lead_margin_s"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn reference_labels_are_reserved_for_detectors() {
    for label in REFERENCE_LABELS {
        let e = err(&format!(
            "{BASE}\n[[detectors]]\nid = \"soc\"\n[[detectors]]\nid = \"hopfield\"\nlabel = \"{label}\"\n"
        ));
        assert!(e.contains("`detectors[1].label`"), "{label}: {e}");
        assert!(
            e.contains(&format!("`{label}`")) && e.contains("reserved"),
            "{label}: {e}"
        );
        assert!(e.contains("null, oracle, ideal_theta"), "{e}");
    }
    // the detectors-file form (`loomlab run --detectors-file`, sweep points) too
    let e = parse_detector_entries(
        "[[detectors]]\nid = \"soc\"\nlabel = \"oracle\"\n",
        Path::new("points.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("points.toml") && e.contains("`detectors[0].label`") && e.contains("reserved"),
        "{e}"
    );
    // and resolve_detector itself, for any camera
    let desc = |label: &str| DetectorDesc {
        label: Some(label.into()),
        ..DetectorDesc::of_id("hopfield")
    };
    let (key, reason) = resolve_detector(&desc("oracle"), default_camera(32)).unwrap_err();
    assert_eq!(key, "label");
    assert!(reason.contains("reserved"), "{reason}");
    let ok = resolve_detector(&desc("oracle_2"), default_camera(32)).unwrap();
    assert_eq!(ok.label, "oracle_2");
    // a near miss of a reserved label is fine, and so is the id as a label
    let s = parse(&format!(
        "{BASE}\n[[detectors]]\nid = \"hopfield\"\nlabel = \"Oracle\"\n"
    ))
    .unwrap();
    assert_eq!(s.episode(0).unwrap().detectors[0].label, "Oracle");
}

#[test]
fn detectors_are_built_for_the_camera_facts() {
    let world: loomlab_sim::WorldDesc =
        toml::from_str("camera = { n = 48, fov_deg = 90.0 }\ncamera_hz = 60.0\n").unwrap();
    let facts = camera_facts(&world);
    assert_eq!((facts.n, facts.fov_deg, facts.frame_rate_hz), (48, 90.0, 60.0));
    let d = DetectorDesc::of_id("hopfield");
    let spec = resolve_detector(&d, facts).unwrap();
    let h = &spec.params.config::<HopfieldConfig>().unwrap();
    assert_eq!((h.n, h.fov_deg, h.frame_rate_hz), (48, 90.0, 60.0));
    // and a scenario passes its world's camera: the frame rate may not be set per detector
    let e = err(&format!(
        "{BASE}\n[[detectors]]\nid = \"hopfield\"\nparams = {{ frame_rate_hz = 30.0 }}\n"
    ));
    assert!(
        e.contains("`detectors[0].params.frame_rate_hz`") && e.contains("world.camera"),
        "{e}"
    );
    let default = default_camera(20);
    assert_eq!((default.n, default.fov_deg), (20, 60.0));
}

#[test]
fn an_invalid_sweep_point_names_its_episode_and_parameters_at_any_key() {
    // the swept speed makes a fixed arrival time unreachable: the error is at a key that is not
    // swept itself, and still names the episode and the swept values
    let text = format!(
        "{}\n[sweep]\n\"world.projectiles.0.speed_mps\" = [8.0, 0.5]\n",
        BASE.replace(
            "speed_mps = 8.0",
            "speed_mps = 8.0\nlaunch_distance_m = 10.0\narrival_time_s = 2.0"
        )
    );
    let e = err(&text);
    assert!(
        e.contains("episode 1") && e.contains("world.projectiles.0.speed_mps = 0.5"),
        "{e}"
    );
    assert!(e.contains("arrival_time_s"), "{e}");
}

#[test]
fn a_million_episode_scenario_loads_lazily() {
    let values: Vec<String> = (0..1000).map(|i| format!("{}", 5.0 + f64::from(i) * 0.001)).collect();
    let list = values.join(", ");
    // cruises up to 6 m/s: within the drive's limit
    let text = format!(
        "{BASE}\n[world.robot]\nmax_speed_mps = 6.0\n[sweep]\n\"world.projectiles.0.speed_mps\" = [{list}]\n\"robot.forward_mps\" = [{list}]\n"
    );
    let started = std::time::Instant::now();
    let s = parse_scenario(&text, Path::new("big.toml"), None, &LoadOptions::default()).unwrap();
    assert_eq!(s.len(), 1_000_000);
    // any episode on its own, equal to the same episode of an in-order expansion
    let last = s.episode(999_999).unwrap();
    assert_eq!(last.index, 999_999);
    assert_eq!(last.world.projectiles[0].speed_mps, 5.999);
    assert_eq!(last.cruise.forward_mps, 5.999);
    let third = s.episodes().nth(2).unwrap().unwrap();
    assert_eq!(third.seed, s.episode(2).unwrap().seed);
    assert_eq!(third.params, s.episode(2).unwrap().params);
    assert!(s.episode(1_000_000).is_err());
    // loading is not an expansion of every episode (generous bound: this is not a timing test,
    // an eager expansion takes tens of seconds)
    assert!(started.elapsed().as_secs() < 10);

    // the suite cap
    let text = format!(
        "{}\n[sweep]\n\"world.projectiles.0.speed_mps\" = [{list}]\n\"robot.forward_mps\" = [{list}]\n",
        BASE.replace("seed = 3", "seed = 3\nrepeats = 11")
    );
    let e = parse_scenario(&text, Path::new("big.toml"), None, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("11000000 episodes") && e.contains("10000000"), "{e}");
}

#[test]
fn tau_and_course_strategies_need_theta_and_their_own_keys() {
    let s = parse(&format!(
        "{BASE}\n[[detectors]]\nid = \"hopfield\"\nlabel = \"hop_tau\"\ntrigger = \"tau\"\ntau_threshold_s = 0.8\nmin_angular_size_deg = 2.0\ncourse = \"image\"\n"
    ))
    .unwrap();
    let ep = s.episode(0).unwrap();
    let d = &ep.detectors[0];
    assert_eq!(d.trigger, TriggerSignal::Tau);
    assert!(
        (d.threshold - 1.0 / 0.8).abs() < 1e-12,
        "the row's threshold is the urgency 1/τ"
    );
    let c = d.controller(&ep.controller).decision;
    assert!((c.tau_threshold_s - 0.8).abs() < 1e-12);
    assert_eq!(c.min_angular_size_deg, 2.0);
    assert_eq!(c.course, loomlab_agents::Course::Image);
    assert!(d.is_stateful());
    assert_eq!(c.persistence_frames, 1);
    // persistence makes any row a strategy row, and reaches its controller
    let s = parse(&format!(
        "{BASE}\n[[detectors]]\nid = \"soc\"\npersistence_frames = 5\n"
    ))
    .unwrap();
    let ep = s.episode(0).unwrap();
    assert!(ep.detectors[0].is_stateful());
    assert_eq!(
        ep.detectors[0].controller(&ep.controller).decision.persistence_frames,
        5
    );
    // a persistence window reaches it too (absent: the consecutive rule, M = K)
    assert_eq!(
        ep.detectors[0]
            .controller(&ep.controller)
            .decision
            .persistence_window_frames,
        Some(5)
    );
    let s = parse(&format!(
        "{BASE}\n[[detectors]]\nid = \"soc\"\npersistence_frames = 8\npersistence_window_frames = 11\n"
    ))
    .unwrap();
    let ep = s.episode(0).unwrap();
    let c = ep.detectors[0].controller(&ep.controller).decision;
    assert_eq!((c.persistence_frames, c.persistence_window_frames), (8, Some(11)));
    let s = parse(&format!(
        "{BASE}\n[[detectors]]\nid = \"soc\"\npersistence_window_frames = 4\n"
    ))
    .unwrap();
    assert!(
        s.episode(0).unwrap().detectors[0].is_stateful(),
        "1 of 4 frames is a strategy"
    );
    // `angular_size` is today's trigger
    let s = parse(&format!(
        "{BASE}\n[[detectors]]\nid = \"hopfield\"\ntrigger = \"angular_size\"\n"
    ))
    .unwrap();
    assert_eq!(
        s.episode(0).unwrap().detectors[0].trigger,
        TriggerSignal::AngularSizeDeg
    );
    assert!(!s.episode(0).unwrap().detectors[0].is_stateful());
    for (entry, key, needle) in [
        ("id = \"soc\"\ntrigger = \"tau\"", "trigger", "θ̂"),
        ("id = \"fu2020\"\ncourse = \"image\"", "course", "θ̂"),
        (
            "id = \"hopfield\"\ntrigger = \"tau\"\nthreshold = 0.5",
            "threshold",
            "tau_threshold_s",
        ),
        (
            "id = \"hopfield\"\ntrigger = \"tau\"\ntau_threshold_s = 0.0",
            "tau_threshold_s",
            "> 0",
        ),
        (
            "id = \"hopfield\"\ntau_threshold_s = 0.5",
            "tau_threshold_s",
            "only used with",
        ),
        (
            "id = \"hopfield\"\ntrigger = \"output\"\ncourse = \"image\"",
            "course",
            "θ̂",
        ),
        ("id = \"soc\"\npersistence_frames = 0", "persistence_frames", "from 1"),
        (
            "id = \"soc\"\npersistence_frames = 20000",
            "persistence_frames",
            "10000",
        ),
        (
            "id = \"soc\"\npersistence_frames = 6\npersistence_window_frames = 5",
            "persistence_window_frames",
            "from persistence_frames (6)",
        ),
    ] {
        let e = parse(&format!("{BASE}\n[[detectors]]\n{entry}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key) && e.contains(needle), "{entry}: {e}");
    }
    // the strategy keys belong to the detector rows, not to [controller]
    let e = parse(&format!("{BASE}\n[controller]\ncourse = \"image\"\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("controller.course") && e.contains("[[detectors]]"), "{e}");
}

/// Every non-threat of the default suite is decided within its episode: no object is still on a
/// collision course with the robot when the episode ends (such an episode is a threat cut short,
/// and an alarm on it would be scored as a false alarm).
#[test]
fn default_suite_non_threats_are_not_threats_cut_short() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(DEFAULT_SUITE);
    let suite = load_suite(&path, &LoadOptions::default()).unwrap();
    let mut cut = Vec::new();
    for ep in suite.episodes() {
        let ep = ep.unwrap();
        let truth = loomlab_scenarios::truth::open_loop_truth(&ep, ep.seed).unwrap();
        if let Some((object, ttc)) = truth.cut_short {
            cut.push(format!(
                "{}#{} ({object}: contact {ttc:.2} s after the end)",
                ep.scenario, ep.index
            ));
        }
    }
    assert!(
        cut.is_empty(),
        "non-threats that end on a collision course (lengthen episode.duration_s or change the scene): {}",
        cut.join(", ")
    );
}

#[test]
fn one_key_varied_under_two_spellings_is_refused() {
    // `a.0.b` and `a[0].b` name one value: only one of the two would be used
    let e = err(&format!(
        "{BASE}[sweep]\n\"world.projectiles.0.speed_mps\" = [6.0, 9.0]\n\"world.projectiles[0].speed_mps\" = [7.0, 8.0]\n"
    ));
    assert!(e.contains("varied twice") && e.contains("the same key"), "{e}");
    let e = err(&format!(
        "{BASE}[sweep]\n\"world.projectiles.0.speed_mps\" = [6.0, 9.0]\n[random]\n\"world.projectiles[0].speed_mps\" = {{ min = 5.0, max = 7.0 }}\n"
    ));
    assert!(e.contains("varied twice"), "{e}");
    // one spelling holding the other's table is refused whichever way each is written
    let e = err(&format!(
        "{BASE}[sweep]\n\"world.projectiles.0\" = [{{ speed_mps = 6.0 }}]\n\"world.projectiles[0].speed_mps\" = [7.0, 8.0]\n"
    ));
    assert!(e.contains("holds the varied key"), "{e}");
}

#[test]
fn the_name_and_tier_cannot_be_varied() {
    for (table, value) in [("sweep", "[\"a\", \"b\"]"), ("random", "{ choices = [\"a\", \"b\"] }")] {
        let e = err(&format!("{BASE}[{table}]\nname = {value}\n"));
        assert!(
            e.contains("dir/test.toml")
                && e.contains(&format!("{table}.\"name\""))
                && e.contains("one per scenario file"),
            "{e}"
        );
    }
    let e = err(&format!("tier = 1\n{BASE}[sweep]\ntier = [1, 2]\n"));
    assert!(e.contains("sweep.\"tier\"") && e.contains("one file per tier"), "{e}");
}

#[test]
fn a_random_range_wider_than_the_largest_number_is_refused() {
    let e = err(&format!(
        "{BASE}[random]\n\"world.projectiles.0.speed_mps\" = {{ min = -1.7e308, max = 1.7e308 }}\n"
    ));
    assert!(
        e.contains("random.\"world.projectiles.0.speed_mps\"") && e.contains("wider than the largest number"),
        "{e}"
    );
}

#[test]
fn a_decision_rule_that_can_never_fire_is_refused() {
    // 1 s at 120 Hz: 121 frames (frame 0 and 120 steps)
    let detectors = |entry: &str| format!("{BASE}[[detectors]]\n{entry}\n");
    let e = err(&detectors("id = \"tracker\"\npersistence_frames = 10000"));
    assert!(
        e.contains("detectors[0].persistence_frames") && e.contains("10000") && e.contains("never fire"),
        "{e}"
    );
    let e = err(&detectors(
        "id = \"tracker\"\ntrigger = \"tau\"\nmin_angular_size_deg = 200.0",
    ));
    assert!(
        e.contains("detectors[0].min_angular_size_deg") && e.contains("field of view (60°)"),
        "{e}"
    );
    let e = err(&detectors(
        "id = \"tracker\"\ntrigger = \"angular_size_deg\"\nthreshold = 75.0",
    ));
    assert!(e.contains("detectors[0].threshold") && e.contains("never alarm"), "{e}");
    // the bounds themselves are fine
    parse(&detectors(
        "id = \"tracker\"\npersistence_frames = 100\nthreshold = 10.0\ntrigger = \"angular_size_deg\"",
    ))
    .unwrap();
}

#[cfg(unix)]
#[test]
fn a_loop_of_links_in_a_suite_is_named_as_such() {
    let dir = tmp_dir("link-loop");
    std::fs::write(dir.join("ok.toml"), BASE).unwrap();
    std::os::unix::fs::symlink("b.toml", dir.join("a.toml")).unwrap();
    std::os::unix::fs::symlink("a.toml", dir.join("b.toml")).unwrap();
    let e = load_suite(&dir, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        e.contains("cannot be followed") && e.contains("loop") && !e.contains("does not exist"),
        "{e}"
    );
}

#[test]
fn the_robots_facts_come_from_the_world_once_per_episode() {
    let text = format!(
        "{BASE}\n[world.robot]\nbase = \"diff_drive\"\nbody = {{ kind = \"cylinder\", radius_m = 0.3, height_m = 0.5 }}\n"
    );
    let text = text.replace(
        "camera = { n = 32 }",
        "camera = { n = 32, fov_deg = 90.0, position = [0.0, 0.0, 0.1] }",
    );
    let ep = parse(&text).unwrap().episode(0).unwrap();
    assert_eq!(ep.facts.base, loomlab_sim::RobotBase::DiffDrive);
    assert_eq!(ep.facts.body.half_width_m, 0.30000001192092896);
    assert!((ep.facts.body.above_camera_m - 0.15).abs() < 1e-6, "{:?}", ep.facts);
    assert!((ep.facts.body.below_camera_m - 0.35).abs() < 1e-6, "{:?}", ep.facts);
    assert_eq!(ep.facts.pinhole.fov_deg(), 90.0);
    assert_eq!(ep.facts, loomlab_scenarios::schema::robot_facts(&ep.world));
}
