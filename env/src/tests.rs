//! Tests of the step-by-step environment (they render with the system's GPU adapter, e.g. lavapipe).

use loomlab_agents::DiscreteAction;

use super::*;
use loomlab_scenarios::metrics::Outcome;

/// A ball thrown head-on at the robot cruising at 1 m/s (contact after about 0.5 s), in front of a
/// grating wall; 1.2 s episodes at n = 32.
const HEAD_ON: &str = r#"
name = "head_on"
[episode]
duration_s = 1.2
seed = 3
[robot]
forward_mps = 1.0
[[detectors]]
id = "hopfield"
[[detectors]]
id = "soc"
[world]
camera = { n = 32 }
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

fn scenario() -> EnvScenario {
    EnvScenario::from_toml(HEAD_ON, "head_on.toml")
}

fn options(kind: ActionKind) -> EnvOptions {
    EnvOptions {
        observe_frames: true,
        action_kind: kind,
        ..Default::default()
    }
}

fn run(env: &mut EscapeEnv, seed: u64, action: impl Fn(usize) -> Action) -> Vec<StepResult> {
    env.reset(Some(seed)).unwrap();
    let mut out = Vec::new();
    for i in 0.. {
        let r = env.step(action(i)).unwrap();
        let done = r.terminated || r.truncated;
        out.push(r);
        if done {
            break;
        }
    }
    out
}

#[test]
fn cruising_into_a_ball_is_a_threat_a_collision_and_scored() {
    let mut env = EscapeEnv::new(scenario(), options(ActionKind::Discrete)).unwrap();
    let (obs, info) = env.reset(Some(3)).unwrap();
    assert!(info.threat);
    let tc = info.t_contact_s.unwrap();
    assert!((0.5..0.8).contains(&tc), "contact at {tc}");
    // detectors see their first frame in the first step
    assert!(obs.signals.iter().flatten().all(|&v| v == 0.0) && obs.alarm == vec![false, false]);
    assert_eq!(obs.signals.len(), 2);
    assert_eq!(obs.signals[0].len(), env.signal_names()[0].len());
    assert_eq!(obs.frame.as_ref().unwrap().len(), 32 * 32);
    assert_eq!(env.detector_ids(), vec!["hopfield", "soc"]);

    let steps = run(&mut env, 3, |_| Action::Discrete(0));
    let last = steps.last().unwrap();
    assert!(last.terminated && !last.truncated);
    assert!(last.info.collision);
    assert!(last.reward < -9.0, "collision penalty: {}", last.reward);
    // the contact is reported in the frame of the open-loop contact or the next (rapier finds a
    // contact in the narrow phase that opens a step)
    assert!(
        last.info.t_s >= tc && last.info.t_s - tc <= 2.0 * env.dt() + 1e-9,
        "{} vs {tc}",
        last.info.t_s
    );
    let outcome = last.info.outcome.as_ref().unwrap();
    assert!(outcome.threat && outcome.collision && !outcome.evaded);
    assert_eq!(outcome.detectors.len(), 2);
    assert!(
        outcome
            .detectors
            .iter()
            .all(|d| matches!(d.outcome, Outcome::Hit | Outcome::Miss))
    );
    assert!(steps[..steps.len() - 1].iter().all(|s| s.info.outcome.is_none()));
    // the ball was on a collision course all along, and it grew
    let first = &steps[0].info;
    assert!(first.ttc_s.is_some() && first.angular_size_deg.unwrap() < last.info.angular_size_deg.unwrap());
    // stepping after the end is an error until reset
    assert_eq!(env.step(Action::Discrete(0)).unwrap_err().kind(), ErrorKind::Other);
}

#[test]
fn dodging_left_evades_and_is_scored_as_evaded() {
    let mut env = EscapeEnv::new(scenario(), options(ActionKind::Discrete)).unwrap();
    let left = DiscreteAction::DodgeLeft.index() as i64;
    let steps = run(&mut env, 5, |_| Action::Discrete(left));
    let last = steps.last().unwrap();
    assert!(last.terminated && !last.info.collision);
    assert!(last.info.outcome.as_ref().unwrap().evaded);
    assert!(steps.iter().all(|s| s.info.dodging));
    // survival minus effort, never the unnecessary-dodge cost (it was a real threat)
    assert!(steps.iter().all(|s| s.info.reward_terms.unnecessary_dodge == 0.0));
    assert!(last.obs.robot[1] > 1.0, "moved left: {:?}", last.obs.robot);
    assert_eq!(env.duration_steps(), 144);
    assert_eq!(steps.len(), 144);
}

#[test]
fn same_seed_and_actions_repeat_exactly_and_snapshots_replay() {
    let act = |i: usize| Action::Continuous([0.3, if i % 7 == 0 { 0.5 } else { -0.2 }, (i as f32 * 0.37).sin()]);
    let mut a = EscapeEnv::new(scenario(), options(ActionKind::Continuous)).unwrap();
    let mut b = EscapeEnv::new(scenario(), options(ActionKind::Continuous)).unwrap();
    let ra = run(&mut a, 11, act);
    let rb = run(&mut b, 11, act);
    assert_eq!(ra, rb);

    // snapshot mid-episode, restore into a fresh environment, continue identically
    a.reset(Some(12)).unwrap();
    for i in 0..20 {
        a.step(act(i)).unwrap();
    }
    let snap = a.snapshot();
    let mut c = EscapeEnv::new(scenario(), options(ActionKind::Continuous)).unwrap();
    c.restore(&snap).unwrap();
    for i in 20..40 {
        assert_eq!(a.step(act(i)).unwrap(), c.step(act(i)).unwrap());
    }
    // and the seed stream continues identically after the episode
    assert_eq!(a.reset(None).unwrap(), c.reset(None).unwrap());
}

/// Resets that find their episode prepared in the background (`episode::prefetch`) equal resets
/// that compute it inline, step for step to the episode's end (the escape deadline included: the
/// episode summary's scores depend on it), for threats and near misses of the Gymnasium
/// environment's default scenario.
#[test]
fn prefetched_resets_equal_inline_ones() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../python/python/loomlab/scenarios/escape_default.toml");
    let scenario = EnvScenario::from_file(&path).unwrap();
    let options = EnvOptions {
        frame_size: Some(32),
        ..Default::default()
    };
    let mut a = EscapeEnv::new(scenario.clone(), options.clone()).unwrap();
    a.reset(Some(5)).unwrap();
    let action = Action::Continuous([0.0, 0.0, 0.0]);
    let (mut threats, mut deadlines) = (0, 0);
    for episode in 0..4 {
        // b starts from a's seed stream with nothing prepared
        let mut b = EscapeEnv::new(scenario.clone(), options.clone()).unwrap();
        let stream = EpisodeSnapshot {
            start: None,
            actions: Vec::new(),
            ..a.snapshot()
        };
        b.restore(&stream).unwrap();
        assert_eq!(a.reset(None).unwrap(), b.reset(None).unwrap(), "episode {episode}");
        assert_eq!(b.prefetched_resets(), 0);
        loop {
            let (x, y) = (a.step(action).unwrap(), b.step(action).unwrap());
            assert_eq!(x, y, "episode {episode}");
            if let Some(out) = &x.info.outcome {
                threats += usize::from(out.threat);
                deadlines += usize::from(out.agent.t_deadline_s.is_some());
                break;
            }
        }
    }
    assert_eq!(a.prefetched_resets(), 4);
    assert!(
        threats >= 1 && deadlines >= 1,
        "{threats} threats, {deadlines} deadlines"
    );
}

#[test]
fn bad_actions_are_action_errors_and_change_nothing() {
    let mut env = EscapeEnv::new(scenario(), options(ActionKind::Continuous)).unwrap();
    assert_eq!(
        env.step(Action::Continuous([0.0; 3])).unwrap_err().kind(),
        ErrorKind::Other
    );
    env.reset(Some(1)).unwrap();
    for bad in [
        Action::Continuous([1.5, 0.0, 0.0]),
        Action::Continuous([f32::NAN, 0.0, 0.0]),
        Action::Discrete(1),
    ] {
        let e = env.step(bad).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Action, "{e}");
    }
    assert!(env.snapshot().actions.is_empty());
    let mut d = EscapeEnv::new(scenario(), options(ActionKind::Discrete)).unwrap();
    d.reset(Some(1)).unwrap();
    let e = d.step(Action::Discrete(4)).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Action);
    assert!(e.to_string().contains("0..4"), "{e}");
}

#[test]
fn options_are_validated_with_the_key() {
    let bad = EnvOptions {
        frame_size: Some(4),
        ..Default::default()
    };
    let e = EscapeEnv::new(scenario(), bad).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Scenario);
    assert!(e.to_string().contains("frame_size"), "{e}");
    let e = EnvOptions::from_json(r#"{"frame_sise": 64}"#).unwrap_err().to_string();
    assert!(e.contains("frame_sise"), "{e}");
    let unknown = EnvOptions {
        detectors: Some(vec!["hopfeld".into()]),
        ..Default::default()
    };
    let e = EscapeEnv::new(scenario(), unknown).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Detector);
}

#[test]
fn vector_env_equals_single_envs_with_next_step_autoreset() {
    let opts = EnvOptions {
        max_episode_steps: Some(8),
        ..options(ActionKind::Continuous)
    };
    // two groups (9 + 8 views) of the pipelined step: one group's detectors run while the next
    // renders, and auto-resets alongside
    let n = 17;
    let mut vec = EscapeVectorEnv::new(scenario(), opts.clone(), n).unwrap();
    let mut singles: Vec<EscapeEnv> = (0..n)
        .map(|_| EscapeEnv::new(scenario(), opts.clone()).unwrap())
        .collect();
    let v0 = vec.reset(Some(100)).unwrap();
    for (i, s) in singles.iter_mut().enumerate() {
        assert_eq!(v0[i], s.reset(Some(100 + i as u64)).unwrap());
    }
    let mut pending = vec![false; n];
    let mut resets = 0;
    for t in 0..20 {
        let actions: Vec<Action> = (0..n)
            .map(|i| Action::Continuous([0.2 * (i % 5) as f32, 0.1, ((t + i) as f32 * 0.3).sin()]))
            .collect();
        let got = vec.step(&actions).unwrap();
        for i in 0..n {
            let want = if pending[i] {
                resets += 1;
                let (obs, info) = singles[i].reset(None).unwrap();
                StepResult {
                    obs,
                    reward: 0.0,
                    terminated: false,
                    truncated: false,
                    info,
                }
            } else {
                singles[i].step(actions[i]).unwrap()
            };
            pending[i] = want.terminated || want.truncated;
            assert_eq!(got[i], want, "env {i} step {t}");
        }
    }
    assert!(resets >= n, "every env auto-reset at least once ({resets})");
    let e = vec.step(&[Action::Continuous([0.0; 3])]).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Action);
}

/// The batched step (one render batch per camera period, the periods of all environments in
/// lockstep) equals single environments and the unbatched vector step, with steps that last
/// different numbers of periods (action repeat, a held dodge) and episodes that end within a step.
#[test]
fn batched_vector_env_with_repeats_and_held_dodges_equals_single_envs() {
    let opts = EnvOptions {
        max_episode_steps: Some(12),
        action_repeat: 2,
        dodge_hold_s: 0.2,
        ..options(ActionKind::Discrete)
    };
    let n = 4;
    let mut batched = EscapeVectorEnv::new(scenario(), opts.clone(), n).unwrap();
    let mut unbatched = EscapeVectorEnv::new(scenario(), opts.clone(), n).unwrap();
    unbatched.set_batched(false);
    let mut singles: Vec<EscapeEnv> = (0..n)
        .map(|_| EscapeEnv::new(scenario(), opts.clone()).unwrap())
        .collect();
    let b0 = batched.reset(Some(7)).unwrap();
    assert_eq!(b0, unbatched.reset(Some(7)).unwrap());
    for (i, s) in singles.iter_mut().enumerate() {
        assert_eq!(b0[i], s.reset(Some(7 + i as u64)).unwrap());
    }
    let mut pending = vec![false; n];
    let mut resets = 0;
    for t in 0..20 {
        let actions: Vec<Action> = (0..n).map(|i| Action::Discrete((((t * 3 + i) % 5) % 3) as _)).collect();
        let got = batched.step(&actions).unwrap();
        assert_eq!(
            got,
            unbatched.step(&actions).unwrap(),
            "step {t}: batched and unbatched"
        );
        for i in 0..n {
            let want = if pending[i] {
                resets += 1;
                let (obs, info) = singles[i].reset(None).unwrap();
                StepResult {
                    obs,
                    reward: 0.0,
                    terminated: false,
                    truncated: false,
                    info,
                }
            } else {
                singles[i].step(actions[i]).unwrap()
            };
            pending[i] = want.terminated || want.truncated;
            assert_eq!(got[i], want, "env {i} step {t}");
        }
    }
    assert!(resets >= n, "every env auto-reset at least once ({resets})");
    assert_eq!(batched.snapshot(), unbatched.snapshot());
}

/// A sweep of [`HEAD_ON`] over the miss distance: threats hit head-on or off-centre, and a near
/// miss (no threat).
const MISS_SWEEP: &str = "\n[sweep]\n\"world.projectiles.0.miss_distance_m\" = [0.0, 0.35, 1.5]\n";

/// The scenario runner, for the whole process: its worker threads keep renderers in thread-local
/// pools, whose destruction at thread exit panics inside wgpu (noted for the runner's owner), so
/// episodes are run on its pool threads, which never exit.
fn runner() -> &'static loomlab_scenarios::Runner {
    static RUNNER: std::sync::OnceLock<loomlab_scenarios::Runner> = std::sync::OnceLock::new();
    RUNNER.get_or_init(|| loomlab_scenarios::Runner::with_context(shared_gpu_context().unwrap(), Some(1)).unwrap())
}

/// Runs scenario episode `index` to its end, choosing each action from the last step's info.
fn run_episode(env: &mut EscapeEnv, index: usize, policy: impl Fn(&StepInfo) -> Action) -> StepResult {
    let (_, mut info) = env.reset_to_episode(index, None).unwrap();
    assert_eq!(info.episode, index);
    loop {
        let r = env.step(policy(&info)).unwrap();
        if r.terminated || r.truncated {
            return r;
        }
        info = r.info;
    }
}

#[test]
fn cruising_reproduces_the_runner_open_loop_scores() {
    let text = format!("{HEAD_ON}{MISS_SWEEP}");
    let mut env = EscapeEnv::new(
        EnvScenario::from_toml(text, "sweep.toml"),
        options(ActionKind::Discrete),
    )
    .unwrap();
    assert_eq!(env.episodes().len(), 3);
    for index in [0, 2] {
        let spec = env.episodes()[index].clone();
        let run = runner().run(&[&spec], |_, _| Ok(())).unwrap().remove(0);
        let last = run_episode(&mut env, index, |_| Action::Discrete(0));
        let out = last.info.outcome.unwrap();
        assert_eq!(out.threat, index == 0);
        for (mine, theirs) in out.detectors.iter().zip(&run.outcome.detectors) {
            assert_eq!(mine.detector, theirs.detector);
            assert_eq!(mine.outcome, theirs.outcome, "episode {index} {}", mine.detector);
            assert_eq!(mine.t_contact_s, theirs.t_contact_s);
            assert_eq!(mine.t_alarm_s, theirs.t_alarm_s);
            assert_eq!(mine.max_signal, theirs.max_signal);
            assert_eq!(mine.ttc_at_alarm_s, theirs.ttc_at_alarm_s);
            assert_eq!(mine.angular_size_at_alarm_deg, theirs.angular_size_at_alarm_deg);
        }
    }
}

/// The threshold baseline: feeding the shadow escape controller (`info.controller_continuous` /
/// `controller_discrete`) back as the action drives the robot as the runner's closed loop of the
/// first detector does, so the collision outcome (and its time, within a frame) is the runner's.
/// Every episode of [`MISS_SWEEP`] (3) as it is and with a slower ball (6 m/s from 6 m) and a 1°
/// threshold, with continuous and with discrete actions. (At n = 32 hopfield's θ̂ crosses its
/// threshold only a few frames before contact, so these controllers trigger but do not evade: the
/// post-alarm tails are compared, an evasion is not exercised here.)
#[test]
fn threshold_agent_reproduces_the_runner_closed_loop() {
    let slow = HEAD_ON
        .replacen("id = \"hopfield\"", "id = \"hopfield\"\nthreshold = 1.0", 1)
        .replace("launch_distance_m = 8.0", "launch_distance_m = 6.0")
        .replace("speed_mps = 10.0", "speed_mps = 6.0");
    let (mut tails, mut hit) = (0, 0);
    for head_on in [HEAD_ON.to_string(), slow] {
        let (t, h) = threshold_agent_matches_runner(&format!("{head_on}{MISS_SWEEP}"));
        tails += t;
        hit += h;
    }
    assert!(tails >= 2, "the runner simulated post-alarm tails ({tails})");
    assert!(hit >= 1, "some threat hits the robot despite the controller ({hit})");
}

/// Runs every episode of a scenario with the threshold agent and the runner; returns how many
/// episodes had a simulated post-alarm tail and how many ended in a collision.
fn threshold_agent_matches_runner(text: &str) -> (usize, usize) {
    let sc = EnvScenario::from_toml(text, "sweep.toml");
    let mut cont = EscapeEnv::new(sc.clone(), options(ActionKind::Continuous)).unwrap();
    let mut disc = EscapeEnv::new(sc, options(ActionKind::Discrete)).unwrap();
    let (mut tails, mut hit) = (0, 0);
    for index in 0..cont.episodes().len() {
        let spec = cont.episodes()[index].clone();
        let run = runner().run(&[&spec], |_, _| Ok(())).unwrap().remove(0);
        let theirs = &run.closed_loop[0];
        assert_eq!(theirs.label, cont.detector_labels()[0]);
        tails += usize::from(theirs.simulated);
        let threat = run.outcome.detectors[0].threat;
        hit += usize::from(theirs.collision.is_some());
        let runs = [
            run_episode(&mut cont, index, |i| Action::Continuous(i.controller_continuous)),
            run_episode(&mut disc, index, |i| {
                Action::Discrete(i.controller_discrete.index() as i64)
            }),
        ];
        for last in runs {
            let out = last.info.outcome.as_ref().unwrap();
            assert_eq!(out.threat, threat, "episode {index}");
            assert_eq!(
                out.collision,
                theirs.collision.is_some(),
                "episode {index}: env collision {} at {} s, runner {:?} ({theirs:?})",
                out.collision,
                last.info.t_s,
                theirs.collision.map(|i| i.t_s)
            );
            assert_eq!(out.detectors[0].collision, run.outcome.detectors[0].collision);
            // the agent's own row: its first departure from cruising is the detector's first
            // alarm, so it is classified as the runner classifies the detector
            let (agent, det) = (&out.agent, &run.outcome.detectors[0]);
            assert_eq!(agent.detector, AGENT_LABEL);
            assert_eq!(
                agent.outcome, det.outcome,
                "episode {index}: agent {agent:?}, runner {det:?}"
            );
            assert_eq!(agent.t_alarm_s, det.t_alarm_s, "episode {index}");
            assert_eq!(agent.t_deadline_s, det.t_deadline_s, "episode {index}");
            assert_eq!(agent.collision, det.collision, "episode {index}");
            if let Some(tc) = theirs.collision.map(|i| i.t_s) {
                // reported in the contact's frame or the next (see above)
                assert!(
                    last.info.t_s >= tc && last.info.t_s - tc <= 2.0 * cont.dt() + 1e-9,
                    "episode {index}: {} vs {tc}",
                    last.info.t_s
                );
            }
        }
    }
    (tails, hit)
}

#[test]
fn dodging_without_a_threat_costs_the_unnecessary_dodge_penalty() {
    let text = HEAD_ON.replace("radius_m = 0.2", "radius_m = 0.2\nmiss_distance_m = 2.0");
    let mut env = EscapeEnv::new(EnvScenario::from_toml(text, "miss.toml"), options(ActionKind::Discrete)).unwrap();
    let (_, info) = env.reset(Some(0)).unwrap();
    assert!(!info.threat && info.t_contact_s.is_none());
    assert!(info.angular_size_deg.is_some(), "the ball is the reference object");
    let cruise = env.step(Action::Discrete(0)).unwrap();
    assert_eq!(cruise.info.reward_terms.unnecessary_dodge, 0.0);
    assert!(!cruise.info.dodging);
    let dodge = env.step(Action::Discrete(2)).unwrap();
    assert!(dodge.info.dodging);
    assert!((dodge.info.reward_terms.unnecessary_dodge + env.dt()).abs() < 1e-12);
}

#[test]
fn option_errors_name_the_key_the_value_and_what_is_expected() {
    let e = EnvOptions::from_json(r#"{"reward": {"effort_per_s": "abc"}}"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`reward.effort_per_s` = \"abc\""), "{e}");
    assert!(e.contains("expected f64") && !e.contains("(json)"), "{e}");
    let e = EnvOptions::from_json(r#"{"frame_size": 2.5}"#).unwrap_err().to_string();
    assert!(e.contains("`frame_size` = 2.5") && e.contains("expected u32"), "{e}");
    let e = EnvOptions::from_json(r#"{"thresholds": {"hopfield": NaN}}"#).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Scenario);
    assert!(e.to_string().contains("finite numbers"), "{e}");
}

#[test]
fn vector_seeds_never_wrap_around() {
    let mut vec = EscapeVectorEnv::new(scenario(), options(ActionKind::Continuous), 2).unwrap();
    assert_eq!(vec.seeds(u64::MAX - 1).unwrap(), vec![u64::MAX - 1, u64::MAX]);
    let e = vec.reset(Some(u64::MAX)).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Seed);
    let msg = e.to_string();
    assert!(
        msg.contains(&u64::MAX.to_string()) && msg.contains("2 environments"),
        "{msg}"
    );
}

#[test]
fn vector_errors_name_the_environment() {
    let mut vec = EscapeVectorEnv::new(scenario(), options(ActionKind::Continuous), 3).unwrap();
    let e = vec.step(&[Action::Continuous([0.0; 3]); 3]).unwrap_err();
    assert!(e.kind() == ErrorKind::Other && e.env_index().is_some(), "{e}");
    vec.reset(Some(1)).unwrap();
    let mut actions = [Action::Continuous([0.0; 3]); 3];
    actions[2] = Action::Continuous([0.0, 2.0, 0.0]);
    let e = vec.step(&actions).unwrap_err();
    assert_eq!((e.kind(), e.env_index()), (ErrorKind::Action, Some(2)), "{e}");
    assert!(
        e.to_string().starts_with("environment 2 of the vector environment: "),
        "{e}"
    );
}

#[test]
fn vector_snapshots_replay_every_environment() {
    let opts = EnvOptions {
        max_episode_steps: Some(12),
        ..options(ActionKind::Continuous)
    };
    let action = |t: usize, i: usize| Action::Continuous([0.3, 0.1 * i as f32, (t as f32 * 0.7).sin()]);
    let mut a = EscapeVectorEnv::new(scenario(), opts.clone(), 2).unwrap();
    a.reset(Some(40)).unwrap();
    for t in 0..12 {
        a.step(&[action(t, 0), action(t, 1)]).unwrap();
    }
    let snap = a.snapshot();
    assert_eq!(
        snap.autoreset,
        vec![true, true],
        "both episodes were truncated in the last step"
    );
    let mut b = EscapeVectorEnv::new(scenario(), opts.clone(), 2).unwrap();
    let last = b.restore(&snap).unwrap();
    assert!(last.iter().all(Option::is_some));
    for t in 12..30 {
        let actions = [action(t, 0), action(t, 1)];
        assert_eq!(b.step(&actions).unwrap(), a.step(&actions).unwrap(), "step {t}");
    }
    let mut wrong = EscapeVectorEnv::new(scenario(), opts, 3).unwrap();
    assert_eq!(wrong.restore(&snap).unwrap_err().kind(), ErrorKind::Scenario);
}

/// Steps every episode of `env` (by index, with its own seed) with an agent that cruises, dodges
/// left or right, stops and wobbles (the behaviour chosen by `first_index + index`, so that a suite
/// split into chunks is walked exactly as a whole), and checks that every normalized feature is
/// finite and within its declared bounds; returns the number of steps checked.
/// `numbers[i]`: the number by which episode `i` of `env` is named in messages; it also picks the
/// episode's behaviour.
fn assert_features_in_bounds(env: &mut EscapeEnv, what: &str, numbers: &[usize]) -> usize {
    let specs = env.feature_specs();
    let mut checked = 0;
    let check = |obs: &Observation, where_: &str| {
        let f = obs.features.as_ref().expect("normalized observations carry features");
        assert_eq!(f.len(), specs.len(), "{where_}");
        for (v, s) in f.iter().zip(&specs) {
            assert!(
                v.is_finite() && *v >= s.low && *v <= s.high,
                "{where_}: feature {} = {v} outside its declared bounds [{}, {}]",
                s.name,
                s.low,
                s.high
            );
        }
    };
    assert_eq!(numbers.len(), env.episodes().len(), "a number per episode");
    for (index, &number) in numbers.iter().enumerate() {
        let (obs, _) = env.reset_to_episode(index, None).unwrap();
        check(&obs, &format!("{what} episode {number} reset"));
        for t in 0.. {
            // a different behaviour per episode: cruise, dodge left, right, stop, alternate
            let a = match number % 5 {
                4 => (t / 15 % 4) as i64,
                k => k as i64,
            };
            let r = env.step(Action::Discrete(a)).unwrap();
            check(&r.obs, &format!("{what} episode {number} step {t}"));
            checked += 1;
            if r.terminated || r.truncated {
                break;
            }
        }
    }
    checked
}

/// The env's default scenario set (`escape_default`, the scenario of `loomlab/Escape-v0`), with a
/// few random expansions, and the default suite of `loomlab run` at n = 32 (every scenario's first
/// episode and every eleventh episode of the suite: each scenario and each of the five behaviours is
/// walked; the whole suite took 80 s of the CI's test time, every third episode 34 s): every
/// normalized feature stays within its declared bounds.
#[test]
fn normalized_features_stay_in_bounds_on_the_default_scenarios() {
    let opts = EnvOptions {
        obs_mode: ObsMode::Normalized,
        action_kind: ActionKind::Discrete,
        frame_size: Some(32),
        ..Default::default()
    };
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let escape = EnvScenario::from_file(&root.join("python/python/loomlab/scenarios/escape_default.toml")).unwrap();
    let ctx = shared_gpu_context().unwrap();
    let mut steps = 0;
    {
        let seed = 0;
        let eps = escape.load(&opts, seed).unwrap();
        let mut env = EscapeEnv::for_episodes(&escape.path, eps, opts.clone(), ctx.clone()).unwrap();
        let numbers: Vec<usize> = (0..env.episodes().len()).collect();
        steps += assert_features_in_bounds(&mut env, &format!("escape_default seed {seed}"), &numbers);
    }
    let suite_path = root.join(loomlab_scenarios::DEFAULT_SUITE);
    let load = loomlab_scenarios::LoadOptions {
        seed: 0,
        size: Some(32),
        detectors: None,
        detector_entries: None,
        ..Default::default()
    };
    let suite = loomlab_scenarios::load_suite(&suite_path, &load).unwrap();
    let episodes = suite.episodes().collect::<Result<Vec<_>, _>>().unwrap();
    assert!(episodes.len() > 100, "the whole default suite ({})", episodes.len());
    let scenarios: std::collections::BTreeSet<String> = episodes.iter().map(|e| e.scenario.clone()).collect();
    let walked: Vec<(usize, _)> = episodes.into_iter().enumerate().filter(|(_, e)| e.index == 0).collect();
    let walked_scenarios: std::collections::BTreeSet<&String> = walked.iter().map(|(_, e)| &e.scenario).collect();
    assert_eq!(
        walked_scenarios.len(),
        scenarios.len(),
        "every scenario of the suite is walked"
    );
    // The episodes are walked in contiguous chunks on parallel threads (one renderer each), with
    // the same agent per episode as one serial walk.
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(2, 8);
    let chunk = walked.len().div_ceil(threads);
    steps += std::thread::scope(|scope| {
        let walkers: Vec<_> = walked
            .chunks(chunk)
            .map(|part| {
                let (opts, ctx, suite_path) = (opts.clone(), ctx.clone(), &suite_path);
                let numbers: Vec<usize> = part.iter().map(|(k, _)| *k).collect();
                let eps = ScenarioEpisodes {
                    name: "default".into(),
                    episodes: part.iter().map(|(_, e)| e.clone()).collect(),
                };
                scope.spawn(move || {
                    let mut env = EscapeEnv::for_episodes(suite_path, eps, opts, ctx).unwrap();
                    assert_features_in_bounds(&mut env, "default suite", &numbers)
                })
            })
            .collect();
        walkers.into_iter().map(|w| w.join().unwrap()).sum::<usize>()
    });
    assert!(steps > 2_500, "{steps} steps checked");
}

#[test]
fn normalized_features_follow_the_raw_observation() {
    let mut raw = EscapeEnv::new(scenario(), options(ActionKind::Discrete)).unwrap();
    let mut norm = EscapeEnv::new(
        scenario(),
        EnvOptions {
            obs_mode: ObsMode::Normalized,
            ..options(ActionKind::Discrete)
        },
    )
    .unwrap();
    let names: Vec<String> = norm.feature_specs().into_iter().map(|f| f.name).collect();
    let at = |name: &str| names.iter().position(|n| n == name).unwrap();
    let a = run(&mut raw, 5, |_| Action::Discrete(0));
    let b = run(&mut norm, 5, |_| Action::Discrete(0));
    assert_eq!(a.len(), b.len());
    let mut last_theta = 0.0;
    for (x, y) in a.iter().zip(&b) {
        assert!(x.obs.features.is_none());
        let f = y.obs.features.as_ref().unwrap();
        assert_eq!(x.obs.signals, y.obs.signals, "the raw part is unchanged");
        let expect = features::log_compress(x.obs.signals[0][0]) as f32;
        assert_eq!(f[at("hopfield.log_output")], expect);
        let theta = f64::from(x.obs.theta_hat_deg).to_radians();
        assert!((f64::from(f[at("theta_hat_rad")]) - theta).abs() < 1e-6);
        let rate = ((theta - last_theta) / raw.dt()).clamp(-10.0, 10.0);
        assert!((f64::from(f[at("theta_hat_rate_rps")]) - rate).abs() < 1e-3, "{rate}");
        last_theta = theta;
        assert_eq!(f[at("soc.alarm")], f32::from(u8::from(x.obs.alarm[1])));
        assert!((f[at("robot.x")] - (x.obs.robot[0] / 5.0).clamp(-1.0, 1.0)).abs() < 1e-6);
        assert!((f[at("robot.time")] - x.obs.robot[6] / (raw.duration_steps() as f32 * raw.dt() as f32)).abs() < 1e-5);
    }
}

#[test]
fn reset_envs_resets_now_and_cancels_the_pending_autoreset() {
    let opts = EnvOptions {
        max_episode_steps: Some(5),
        ..options(ActionKind::Discrete)
    };
    let mut a = EscapeVectorEnv::new(scenario(), opts.clone(), 2).unwrap();
    a.reset(Some(7)).unwrap();
    let mut last = Vec::new();
    for _ in 0..5 {
        last = a.step(&[Action::Discrete(0); 2]).unwrap();
    }
    assert!(last.iter().all(|r| r.truncated));
    let fresh = a.reset_envs(&[1]).unwrap();
    assert_eq!(fresh.len(), 1);
    assert_eq!(fresh[0].1.step, 0);
    let next = a.step(&[Action::Discrete(0); 2]).unwrap();
    assert_eq!(next[0].info.step, 0, "environment 0 auto-resets (its action ignored)");
    assert_eq!(next[1].info.step, 1, "environment 1 was reset already: it steps");
    assert_eq!(a.reset_envs(&[2]).unwrap_err().kind(), ErrorKind::Scenario);
}

/// An action repeated over k camera periods is exactly k single steps of it: the same last
/// observation and info, the summed reward and reward terms; the episode ends as early.
#[test]
fn action_repeat_equals_that_many_single_steps() {
    let base = EnvOptions {
        obs_mode: ObsMode::Normalized,
        ..options(ActionKind::Discrete)
    };
    let mut single = EscapeEnv::new(scenario(), base.clone()).unwrap();
    let mut repeated = EscapeEnv::new(
        scenario(),
        EnvOptions {
            action_repeat: 4,
            ..base
        },
    )
    .unwrap();
    // dodge left from the 2nd decision on (before the escape deadline): the ball is evaded
    let action = |i: usize| Action::Discrete(if i >= 1 { 1 } else { 0 });
    let singles = run(&mut single, 11, |i| action(i / 4));
    let repeats = run(&mut repeated, 11, action);
    assert_eq!(repeats.len(), singles.len().div_ceil(4), "one decision per 4 frames");
    for (k, r) in repeats.iter().enumerate() {
        let chunk = &singles[4 * k..(4 * k + 4).min(singles.len())];
        let last = chunk.last().unwrap();
        assert_eq!(r.obs, last.obs, "decision {k}: the last frame's observation");
        assert_eq!((r.terminated, r.truncated), (last.terminated, last.truncated));
        let sum: f64 = chunk.iter().map(|s| s.reward).sum();
        assert!((r.reward - sum).abs() < 1e-9, "decision {k}: {} vs {sum}", r.reward);
        assert_eq!(r.info.step, last.info.step);
        assert_eq!(r.info.outcome, last.info.outcome);
    }
    let outcome = repeats.last().unwrap().info.outcome.as_ref().unwrap();
    assert!(outcome.threat && outcome.evaded, "{outcome:?}");
    // a held dodge: one step of 0.1 s (12 periods) for a dodge, 4 periods for cruising
    let mut held = EscapeEnv::new(
        scenario(),
        EnvOptions {
            action_repeat: 4,
            dodge_hold_s: 0.1,
            obs_mode: ObsMode::Normalized,
            ..options(ActionKind::Discrete)
        },
    )
    .unwrap();
    held.reset(Some(11)).unwrap();
    assert_eq!(held.step(Action::Discrete(0)).unwrap().info.step, 4);
    let dodge = held.step(Action::Discrete(1)).unwrap();
    assert_eq!(dodge.info.step, 16);
    assert_eq!(dodge.obs, singles[15].obs, "the same frames as 12 single dodging steps");
    let e = EnvOptions {
        action_repeat: 0,
        ..Default::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(e.contains("action_repeat") && e.contains("0"), "{e}");
}

/// The privileged observation is the true percept of the ball: its θ and 1/τ grow as it
/// approaches, its features stay within their declared bounds, and the observation does not depend
/// on the detectors.
#[test]
fn privileged_features_follow_the_true_percept_of_the_ball() {
    let opts = EnvOptions {
        obs_mode: ObsMode::Privileged,
        ..options(ActionKind::Discrete)
    };
    let mut env = EscapeEnv::new(scenario(), opts.clone()).unwrap();
    let specs = env.feature_specs();
    assert_eq!(specs.len(), features::PRIVILEGED_FEATURES);
    assert_eq!(specs[0].name, "threat.theta_rad");
    let steps = run(&mut env, 5, |_| Action::Discrete(0));
    let mut thetas = Vec::new();
    for s in &steps {
        let f = s.obs.features.as_ref().unwrap();
        assert_eq!(f.len(), specs.len());
        for (v, spec) in f.iter().zip(&specs) {
            assert!(
                (spec.low..=spec.high).contains(v),
                "{} = {v} outside [{}, {}]",
                spec.name,
                spec.low,
                spec.high
            );
        }
        thetas.push((f[0], f[2]));
    }
    // the ball is 8 m away at 10 m/s closing plus the robot's 1 m/s: θ and 1/τ grow as it
    // approaches (after the contact the ball is behind the camera and the wall is the percept)
    let last = steps.last().unwrap();
    assert!(last.info.collision, "the cruising robot is hit");
    let (theta_end, inv_tau_end) = thetas[2 * thetas.len() / 3];
    let (theta_mid, inv_tau_mid) = thetas[thetas.len() / 3];
    assert!(theta_end > theta_mid && inv_tau_end > inv_tau_mid, "{thetas:?}");
    // 1/τ of the true percept: about the closing speed over the distance
    let ttc = steps[thetas.len() / 3].info.ttc_s.unwrap();
    assert!(
        (f64::from(inv_tau_mid) * ttc - 1.0).abs() < 0.25,
        "1/τ {inv_tau_mid} vs ttc {ttc}"
    );
    // the same episode with another detector: the same privileged observation
    let mut other = EscapeEnv::new(
        scenario(),
        EnvOptions {
            detectors: Some(vec!["soc".into()]),
            ..opts
        },
    )
    .unwrap();
    let again = run(&mut other, 5, |_| Action::Discrete(0));
    assert_eq!(
        again.iter().map(|s| s.obs.features.clone()).collect::<Vec<_>>(),
        steps.iter().map(|s| s.obs.features.clone()).collect::<Vec<_>>()
    );
}

/// The timely-dodge bonus is paid once, on the first dodging step in the window before the escape
/// deadline, and not for a dodge after it.
#[test]
fn the_timely_dodge_bonus_is_paid_for_a_dodge_in_time_only() {
    let opts = EnvOptions {
        reward: RewardConfig {
            timely_dodge_bonus: 3.0,
            timely_dodge_window_s: 10.0,
            ..Default::default()
        },
        ..options(ActionKind::Discrete)
    };
    let mut env = EscapeEnv::new(scenario(), opts).unwrap();
    let early = run(&mut env, 7, |i| Action::Discrete(if i >= 2 { 1 } else { 0 }));
    let bonus: Vec<f64> = early.iter().map(|s| s.info.reward_terms.timely_dodge).collect();
    assert_eq!(bonus.iter().filter(|&&b| b != 0.0).count(), 1, "{bonus:?}");
    assert_eq!(bonus[2], 3.0);
    assert_eq!(
        early.last().unwrap().info.outcome.as_ref().unwrap().agent.outcome,
        Outcome::Hit
    );
    // a short dodge long before the deadline, outside a short window: no bonus
    let mut short = EscapeEnv::new(
        scenario(),
        EnvOptions {
            reward: RewardConfig {
                timely_dodge_bonus: 3.0,
                timely_dodge_window_s: 0.02,
                ..Default::default()
            },
            ..options(ActionKind::Discrete)
        },
    )
    .unwrap();
    let too_early = run(&mut short, 7, |i| {
        Action::Discrete(if (2..5).contains(&i) { 1 } else { 0 })
    });
    assert!(too_early.iter().all(|s| s.info.reward_terms.timely_dodge == 0.0));
    // a dodge one frame before contact is past the deadline: no bonus
    let cruise = run(&mut env, 7, |_| Action::Discrete(0));
    let late_at = cruise.len() - 2;
    let late = run(&mut env, 7, |i| Action::Discrete(if i >= late_at { 1 } else { 0 }));
    assert!(late.iter().all(|s| s.info.reward_terms.timely_dodge == 0.0));
    assert_ne!(
        late.last().unwrap().info.outcome.as_ref().unwrap().agent.outcome,
        Outcome::Hit
    );
}

/// Every efference copy a recording detector was handed, per detector built (in build order).
static EGO_RECORDS: std::sync::Mutex<Vec<std::sync::Arc<std::sync::Mutex<Vec<loomlab_detector::EfferenceCopy>>>>> =
    std::sync::Mutex::new(Vec::new());

/// A detector that records its efference copies and never alarms.
struct EgoRecorder(std::sync::Arc<std::sync::Mutex<Vec<loomlab_detector::EfferenceCopy>>>);

impl loomlab_detector::Detector for EgoRecorder {
    fn id(&self) -> &'static str {
        "ego_recorder"
    }
    fn reset(&mut self) {
        self.0.lock().unwrap().clear();
    }
    fn step(
        &mut self,
        frame: &loomlab_detector::Frame,
    ) -> Result<loomlab_detector::Signals, loomlab_detector::DetectorError> {
        self.step_moving(frame, &loomlab_detector::EfferenceCopy::default())
    }
    fn step_moving(
        &mut self,
        _frame: &loomlab_detector::Frame,
        ego: &loomlab_detector::EfferenceCopy,
    ) -> Result<loomlab_detector::Signals, loomlab_detector::DetectorError> {
        self.0.lock().unwrap().push(*ego);
        Ok(loomlab_detector::Signals::default())
    }
}

#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
struct EgoRecorderConfig {}

impl loomlab_detector::registry::DetectorConfig for EgoRecorderConfig {
    fn validate(&self) -> Result<(), loomlab_detector::DetectorError> {
        Ok(())
    }
    fn build(&self, _n: usize) -> Result<Box<dyn loomlab_detector::Detector>, loomlab_detector::DetectorError> {
        let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        EGO_RECORDS.lock().unwrap().push(std::sync::Arc::clone(&seen));
        Ok(Box::new(EgoRecorder(seen)))
    }
}

/// The efference copy reaches a detector identically in the env and in the runner: a robot
/// cruising and turning under camera shake, the env driven by the cruise action.
#[test]
fn the_env_hands_detectors_the_runners_efference_copy() {
    use loomlab_detector::registry::{Registration, Signal};
    let registry = loomlab_detector::Registry::builtin()
        .clone()
        .with(Registration::of::<EgoRecorderConfig>(
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
duration_s = 0.3
seed = 5
[world]
camera = { n = 32, pitch_deg = -5.0, shake = { rotation_deg = 1.0, translation_m = 0.002, frequency_hz = 4.0 } }
[robot]
forward_mps = 1.0
yaw_rate_rps = 0.5
[[detectors]]
id = "ego_recorder"
threshold = 1e9
"#;
    let opts = loomlab_scenarios::LoadOptions {
        registry,
        ..loomlab_scenarios::LoadOptions::default()
    };
    let path = std::path::Path::new("cruise.toml");
    let s = loomlab_scenarios::parse_scenario(text, path, None, &opts).unwrap();
    let spec = s.episode(0).unwrap();
    EGO_RECORDS.lock().unwrap().clear();
    runner().run(&[&spec], |_, _| Ok(())).unwrap();
    let from_runner = EGO_RECORDS.lock().unwrap()[0].lock().unwrap().clone();
    let episodes = ScenarioEpisodes {
        name: "cruise".into(),
        episodes: vec![spec],
    };
    let mut env = EscapeEnv::for_episodes(
        path,
        episodes,
        options(ActionKind::Discrete),
        shared_gpu_context().unwrap(),
    )
    .unwrap();
    let last = EGO_RECORDS.lock().unwrap().len() - 1;
    run_episode(&mut env, 0, |_| Action::Discrete(0));
    let from_env = EGO_RECORDS.lock().unwrap()[last].lock().unwrap().clone();
    assert_eq!(from_runner.len(), 36, "every frame after the first observation");
    assert!(from_runner[5].rotation_rad[2] > 1e-3 && from_runner[5].translation_m[0] > 1e-3);
    assert_eq!(from_env, from_runner);
}

/// `close()` and dropping an environment join its prefetch thread (one still rendering on lavapipe
/// while the process exits crashed it: exit 139), the vector environment's too.
#[test]
fn close_joins_the_prefetch_thread() {
    let mut env = EscapeEnv::new(scenario(), options(ActionKind::Continuous)).unwrap();
    env.reset(Some(1)).unwrap(); // starts preparing the next episode
    env.step(Action::Continuous([0.0; 3])).unwrap();
    env.close();
    assert_eq!(env.background_threads(), 0);
    assert!(!env.is_running());
    // still usable after close: the next reset computes inline
    env.reset(Some(2)).unwrap();
    let alive = env.background_thread_count();
    drop(env);
    assert_eq!(alive.load(std::sync::atomic::Ordering::SeqCst), 0, "dropping joins");

    let mut vec = EscapeVectorEnv::new(scenario(), options(ActionKind::Continuous), 2).unwrap();
    vec.reset(Some(1)).unwrap();
    let counts: Vec<_> = vec.envs().iter().map(EscapeEnv::background_thread_count).collect();
    vec.close();
    assert!(vec.envs().iter().all(|e| e.background_threads() == 0));
    vec.reset(Some(3)).unwrap();
    drop(vec);
    assert!(counts.iter().all(|c| c.load(std::sync::atomic::Ordering::SeqCst) == 0));
}

/// A vector environment holds at most `MAX_NUM_ENVS` environments; the error says how many were
/// asked for, the bound and what to do instead (100 000 ran past 300 s building).
#[test]
fn vector_env_count_is_bounded() {
    let e = EscapeVectorEnv::new(scenario(), options(ActionKind::Continuous), 100_000).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Scenario);
    let msg = e.to_string();
    assert!(
        msg.contains("`num_envs` = 100000")
            && msg.contains(&format!("1..={MAX_NUM_ENVS}"))
            && msg.contains("processes"),
        "{msg}"
    );
    let e = EscapeVectorEnv::new(scenario(), options(ActionKind::Continuous), 0).unwrap_err();
    assert!(e.to_string().contains("`num_envs` = 0"), "{e}");
}

/// The continuous action's scales are clamped to the robot's drive limits, so that the command
/// the observation reports is the one the robot drives (the default 3 m/s drove at 2); absurd
/// scales are refused with the key.
#[test]
fn action_scales_are_clamped_to_the_robots_limits() {
    // the head-on scenario without its ball: nothing ends the episode early
    let calm = HEAD_ON.split("[[world.projectiles]]").next().unwrap().to_string();
    let mut env = EscapeEnv::new(
        EnvScenario::from_toml(calm, "calm.toml"),
        options(ActionKind::Continuous),
    )
    .unwrap();
    let robot = env.episodes()[0].world.robot.clone();
    let cfg = &env.options().action;
    assert_eq!(cfg.max_forward_mps, f64::from(robot.max_speed_mps));
    assert_eq!(cfg.max_lateral_mps, 1.5);
    assert_eq!(cfg.max_yaw_rate_rps, 1.5);
    env.reset(Some(1)).unwrap();
    let mut last = None;
    for _ in 0..60 {
        last = Some(env.step(Action::Continuous([1.0, 0.0, 0.0])).unwrap());
    }
    let obs = last.unwrap().obs;
    let forward = ROBOT_FIELDS.iter().position(|f| *f == "forward_mps").unwrap();
    assert_eq!(
        obs.robot[forward], robot.max_speed_mps,
        "the observation reports the command driven"
    );
    // after 0.5 s at full throttle (2.5 m/s², from 1 m/s) the robot drives at the reported speed
    let x0 = obs.robot[0];
    let r = env.step(Action::Continuous([1.0, 0.0, 0.0])).unwrap();
    let speed = (r.obs.robot[0] - x0) / env.dt() as f32;
    assert!((speed - robot.max_speed_mps).abs() < 0.05, "{speed}");

    for (key, json) in [
        ("action.max_forward_mps", r#"{"action": {"max_forward_mps": 1e9}}"#),
        ("action.max_yaw_rate_rps", r#"{"action": {"max_yaw_rate_rps": 1000}}"#),
    ] {
        let opts = EnvOptions::from_json(json).unwrap();
        let e = EscapeEnv::new(scenario(), opts).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Scenario);
        assert!(e.to_string().contains(&format!("`{key}`")), "{e}");
    }
}
