//! Tests of the environment on suites, the seed streams, the decision features and the manoeuvre
//! actions (they render with the system's GPU adapter, e.g. lavapipe).

use std::path::PathBuf;

use loomlab_agents::{Candidate, DodgeSide};
use loomlab_scenarios::schema::LoadOptions;
use loomlab_scenarios::suite::load_suite;

use super::*;

fn default_suite() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenarios/suites/default")
}

/// Small, fast options on the default suite: one cheap detector at the smallest frame size.
fn suite_options(tiers: Option<Vec<u8>>, stream: Option<SeedStream>) -> EnvOptions {
    EnvOptions {
        detectors: Some(vec!["soc".into()]),
        frame_size: Some(loomlab_sim::MIN_FRAME_SIZE),
        tiers,
        seed_stream: stream,
        max_episode_steps: Some(3),
        ..Default::default()
    }
}

#[test]
fn a_suite_folder_loads_every_scenario_and_the_tier_filter_keeps_its_tiers() {
    let suite = EnvScenario::open(&default_suite()).unwrap();
    assert!(suite.is_suite());
    let all = suite.load(&suite_options(None, None), 0).unwrap();
    let reference = load_suite(&default_suite(), &LoadOptions::default()).unwrap();
    assert_eq!(all.episodes.len(), reference.episode_count());
    assert_eq!(all.name, "default");
    let tiers = reference.tiers();
    let easy = suite.load(&suite_options(Some(vec![0]), None), 0).unwrap();
    assert!(!easy.episodes.is_empty() && easy.episodes.len() < all.episodes.len());
    assert!(easy.episodes.iter().all(|e| tiers.get(&e.scenario) == Some(&0)));
    // every reset draws from the filtered scenarios only
    let mut env = EscapeEnv::new(suite.clone(), suite_options(Some(vec![0]), Some(SeedStream::Train))).unwrap();
    for seed in 0..4 {
        env.reset(Some(seed)).unwrap();
        let name = &env.episode_spec().unwrap().scenario;
        assert_eq!(tiers.get(name), Some(&0), "{name}");
    }
    env.close();
    // a list of scenario files is a suite too
    let files = vec![
        default_suite().join("head_on_ball.toml"),
        default_suite().join("near_miss_ball.toml"),
    ];
    let two = EnvScenario::from_suite(files)
        .unwrap()
        .load(&suite_options(None, None), 0)
        .unwrap();
    let names: std::collections::BTreeSet<_> = two.episodes.iter().map(|e| e.scenario.as_str()).collect();
    assert_eq!(
        names.into_iter().collect::<Vec<_>>(),
        ["head_on_ball", "near_miss_ball"]
    );
}

#[test]
fn bad_suite_input_is_an_error_naming_the_key() {
    let suite = EnvScenario::open(&default_suite()).unwrap();
    let err = suite.load(&suite_options(Some(vec![]), None), 0);
    let err = match err {
        Ok(_) => EscapeEnv::new(suite.clone(), suite_options(Some(vec![]), None)).unwrap_err(),
        Err(e) => e,
    };
    assert!(err.to_string().contains("tiers"), "{err}");
    let err = EscapeEnv::new(suite.clone(), suite_options(Some(vec![7]), None)).unwrap_err();
    assert!(
        err.to_string().contains("tiers") && err.to_string().contains('7'),
        "{err}"
    );
    let one = EnvScenario::from_file(&default_suite().join("head_on_ball.toml")).unwrap();
    let err = EscapeEnv::new(one, suite_options(Some(vec![0]), None)).unwrap_err();
    assert!(
        err.to_string().contains("tiers") && err.to_string().contains("suite"),
        "{err}"
    );
    let err = EnvScenario::from_suite(vec![PathBuf::from("/no/such/suite")]).unwrap_err();
    assert!(err.to_string().contains("/no/such/suite"), "{err}");
    assert!(EnvOptions::from_json(r#"{"seed_stream": "test"}"#).is_err());
}

#[test]
fn train_and_eval_streams_never_draw_the_same_seeds_and_repeat_under_a_seed() {
    let suite = EnvScenario::open(&default_suite()).unwrap();
    let mut seeds = std::collections::BTreeMap::new();
    for stream in [SeedStream::Train, SeedStream::Eval] {
        let mut env = EscapeEnv::new(suite.clone(), suite_options(Some(vec![0]), Some(stream))).unwrap();
        let mut drawn = Vec::new();
        for seed in [0, 1] {
            env.reset(Some(seed)).unwrap();
            drawn.push(env.episode_seed().unwrap());
            for _ in 0..3 {
                env.reset(None).unwrap();
                drawn.push(env.episode_seed().unwrap());
            }
        }
        // the same seed gives the same episodes (and their first observation)
        env.reset(Some(0)).unwrap();
        assert_eq!(env.episode_seed(), Some(drawn[0]));
        env.close();
        seeds.insert(stream == SeedStream::Eval, drawn);
    }
    assert!(seeds[&false].iter().all(|s| s >> 63 == 0), "{:?}", seeds[&false]);
    assert!(seeds[&true].iter().all(|s| s >> 63 == 1), "{:?}", seeds[&true]);
}

/// A ball thrown head-on (as in `tests.rs`), seen by a τ row with the course gate and a K-of-M
/// persistence window, a plain θ̂ row and the tracker (its box and tracks).
const HEAD_ON_ROWS: &str = r#"
name = "head_on_rows"
[episode]
duration_s = 1.2
seed = 3
[robot]
forward_mps = 1.0
[[detectors]]
id = "tracker"
label = "tracker_tau_2of3"
trigger = "tau"
course = "image"
persistence_frames = 2
persistence_window_frames = 3
[[detectors]]
id = "hopfield"
[[detectors]]
id = "tracker"
label = "tracker_tau"
trigger = "tau"
[world]
camera = { n = 48 }
[[world.scenery]]
kind = "wall"
start = [20.0, -10.0]
end = [20.0, 10.0]
texture = { kind = "square_grating", period_m = 1.0, orientation_deg = 90.0 }
[[world.projectiles]]
launch_distance_m = 8.0
speed_mps = 10.0
radius_m = 0.2
"#;

fn feature(env: &EscapeEnv, features: &[f32], name: &str) -> f32 {
    let i = env
        .feature_specs()
        .iter()
        .position(|s| s.name == name)
        .unwrap_or_else(|| panic!("no feature {name}"));
    features[i]
}

#[test]
fn decision_features_hold_each_rows_decision_step() {
    let scenario = EnvScenario::from_toml(HEAD_ON_ROWS, "head_on_rows.toml");
    let options = |mode| EnvOptions {
        obs_mode: mode,
        ..Default::default()
    };
    let mut env = EscapeEnv::new(scenario.clone(), options(ObsMode::Decision)).unwrap();
    let specs = env.feature_specs();
    let labels = env.detector_labels().iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert_eq!(specs, features::decision_specs(&env.detector_labels()));
    let mut names: Vec<_> = specs.iter().map(|s| s.name.clone()).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), specs.len(), "feature names are unique");
    let (obs, _) = env.reset(Some(3)).unwrap();
    assert_eq!(obs.features.as_ref().unwrap().len(), specs.len());
    let tau_threshold_s = loomlab_agents::DecisionRule::default().tau_threshold_s;
    let (mut alarms, mut estimated, mut boxes, mut steps) = (0, 0, 0, Vec::new());
    loop {
        let r = env.step(Action::Continuous([1.0 / 3.0, 0.0, 0.0])).unwrap();
        let f = r.obs.features.clone().unwrap();
        for (i, s) in specs.iter().enumerate() {
            assert!(
                f[i] >= s.low && f[i] <= s.high,
                "{} = {} outside [{}, {}]",
                s.name,
                f[i],
                s.low,
                s.high
            );
        }
        for (row, label) in labels.iter().enumerate() {
            // the alarm is the row's decision (the one the scoring reads)
            assert_eq!(
                feature(&env, &f, &format!("{label}.alarm")) == 1.0,
                r.obs.alarm[row],
                "{label}"
            );
        }
        // the 2-of-3 row alarms exactly when 2 of its last 3 values reached the threshold
        let alarm = feature(&env, &f, "tracker_tau_2of3.alarm");
        assert_eq!(alarm == 1.0, feature(&env, &f, "tracker_tau_2of3.confirmations") == 1.0);
        alarms += usize::from(alarm == 1.0);
        // the plain θ̂ row estimates nothing: its course features are "unknown"
        assert_eq!(feature(&env, &f, "hopfield.inv_tau_ps"), 0.0);
        assert_eq!(feature(&env, &f, "hopfield.gate_open"), 1.0);
        assert_eq!(feature(&env, &f, "hopfield.arrival_s"), 1.0);
        // the tracker's τ row (no gate, no persistence): its value is its urgency 1/τ̂
        let inv_tau = feature(&env, &f, "tracker_tau.inv_tau_ps");
        let value = feature(&env, &f, "tracker_tau.value");
        if inv_tau > 0.0 && inv_tau < features::INV_TAU_LIMIT_PS as f32 && value > 0.0 {
            estimated += 1;
            let expected = (f64::from(inv_tau) * tau_threshold_s).min(features::VALUE_RATIO_LIMIT);
            assert!((f64::from(value) - expected).abs() < 1e-3, "{value} vs {expected}");
        }
        boxes += usize::from(feature(&env, &f, "track.seen") == 1.0);
        steps.push(f);
        if r.terminated || r.truncated {
            break;
        }
    }
    assert!(
        alarms > 0 && estimated > 0 && boxes > 0,
        "alarms {alarms}, τ̂ {estimated}, boxes {boxes}"
    );
    // the observation mode changes nothing of the episode, and a seed repeats it exactly
    let mut raw = EscapeEnv::new(scenario, options(ObsMode::Raw)).unwrap();
    raw.reset(Some(3)).unwrap();
    env.reset(Some(3)).unwrap();
    for f in &steps {
        let a = Action::Continuous([1.0 / 3.0, 0.0, 0.0]);
        let (x, y) = (env.step(a).unwrap(), raw.step(a).unwrap());
        assert_eq!(x.obs.features.as_ref(), Some(f));
        assert_eq!(
            (x.reward, x.terminated, &x.obs.alarm),
            (y.reward, y.terminated, &y.obs.alarm)
        );
        assert_eq!(x.info.outcome, y.info.outcome);
    }
}

/// An environment with manoeuvre actions on the scenario `text` (one cheap detector), reset with
/// seed 3.
fn manoeuvre_env(text: &str) -> EscapeEnv {
    let scenario = EnvScenario::from_toml(text, "head_on_rows.toml");
    let options = EnvOptions {
        detectors: Some(vec!["soc".into()]),
        action_kind: ActionKind::Manoeuvre,
        ..Default::default()
    };
    let mut env = EscapeEnv::new(scenario, options).unwrap();
    env.reset(Some(3)).unwrap();
    env
}

#[test]
fn manoeuvre_actions_run_the_controllers_manoeuvres() {
    let mut env = manoeuvre_env(HEAD_ON_ROWS);
    let episode = env.episodes()[0].clone();
    let (config, base) = (&episode.controller, episode.facts.base);
    let cruise = env.cruise();
    let expected = [
        cruise,
        config.command(Candidate::dodge(DodgeSide::Left), cruise, base),
        config.command(Candidate::dodge(DodgeSide::Right), cruise, base),
        loomlab_agents::VelocityCommand::STOP,
        config.command(Candidate::ALL[3], cruise, base),
        // no forecast yet: the plan is the fixed candidate, the dodge to the default side
        config.command(config.fixed_candidate(config.default_side), cruise, base),
    ];
    for (i, want) in expected.iter().enumerate() {
        assert_eq!(
            env.command_for(Action::Discrete(i as i64)).unwrap(),
            *want,
            "action {i}"
        );
    }
    assert!(expected[4].forward_mps < 0.0, "reverse drives backwards");
    let err = env.command_for(Action::Discrete(6)).unwrap_err().to_string();
    assert!(
        err.contains("manoeuvre action index 6") && err.contains("plan"),
        "{err}"
    );
    // each action moves the robot as named (robot = [x, y, yaw, …] from the start pose)
    let moved = |env: &mut EscapeEnv, i: i64| {
        env.reset(Some(3)).unwrap();
        let mut last = None;
        for _ in 0..12 {
            last = Some(env.step(Action::Discrete(i)).unwrap().obs.robot);
        }
        last.unwrap()
    };
    let [cruised, left, right, stopped, reversed] = [0, 1, 2, 3, 4].map(|i| moved(&mut env, i));
    assert!(left[1] > 0.02 && right[1] < -0.02, "sidesteps: {left:?} {right:?}");
    assert!(
        stopped[0] < cruised[0] && reversed[0] < stopped[0],
        "{cruised:?} {stopped:?} {reversed:?}"
    );
    // the same seed and actions repeat exactly
    assert_eq!(moved(&mut env, 5), moved(&mut env, 5));
}

#[test]
fn sidestep_actions_stop_at_the_scenes_max_dodge_offset_as_the_rows_dodges_do() {
    // the robot knows the corridor it drives in: 0.05 m to either side. Asked to sidestep left for
    // half a second, the body comes to rest 0.05 m off its path, as a row's dodge does (the same
    // `command_within_offset`: the sidestep is held once the body, braking, would stop at the
    // limit); without the limit it sidesteps all the way. A rule on the commanded sidestep alone
    // let the body run on to 0.47 m (robot = [x, y, yaw, …] from the start pose).
    let offset = |limit: &str| {
        let mut env = manoeuvre_env(&format!("{HEAD_ON_ROWS}\n[controller]\n{limit}\n"));
        // the episode starts at its first command's velocity: cruise first
        env.step(Action::Discrete(0)).unwrap();
        for _ in 0..60 {
            env.step(Action::Discrete(1)).unwrap();
        }
        // then cruise on for a quarter second at most (a body held at the limit is at rest
        // sideways; the ball may end the episode first)
        let mut robot = [0.0f32; 7];
        for _ in 0..30 {
            let step = env.step(Action::Discrete(0)).unwrap();
            robot = step.obs.robot;
            if step.terminated || step.truncated {
                break;
            }
        }
        f64::from(robot[1])
    };
    let held = offset("max_dodge_offset_m = 0.05");
    assert!((held - 0.05).abs() < 0.02, "sidestepped {held:.4} m");
    let free = offset("");
    assert!(free > 0.4, "without the limit {free:.4} m");
}
