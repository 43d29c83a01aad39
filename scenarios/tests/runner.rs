//! The closed-loop runner on small rendered episodes (needs a GPU adapter; lavapipe is enough).

use std::path::Path;
use std::sync::Mutex;

use loomlab_scenarios::metrics::Outcome;
use loomlab_scenarios::{EpisodeRun, LoadOptions, Runner, Scenario, parse_scenario};

/// A ball thrown slowly at a standing robot on a uniform background (no ground: before the launch
/// nothing in the image changes). `{miss}` is the miss distance (to the robot's right), `{detectors}`
/// the detector list.
fn scenario(miss: f64, detectors: &str) -> Scenario {
    let text = format!(
        r#"
name = "slow_ball"
[episode]
duration_s = 2.4
seed = 5
[world]
sky_luminance = 0.5
camera = {{ n = 32 }}
ground = {{ enabled = false }}
[[world.projectiles]]
name = "ball"
target = "camera"
radius_m = 0.15
speed_mps = 3.0
launch_distance_m = 5.0
launch_time_s = 0.3
miss_distance_m = {miss}
miss_angle_deg = 180.0
texture = {{ kind = "uniform", luminance = 0.0 }}
[robot]
forward_mps = 0.0
[controller]
dodge_speed_mps = 1.5
duration_s = 0.6
[scoring]
lead_min_s = 0.2
{detectors}
"#
    );
    parse_scenario(&text, Path::new("slow_ball.toml"), None, &LoadOptions::default()).unwrap()
}

/// `soc` twice: `early` alarms on the first motion of the ball, `never` never alarms.
const EARLY_AND_NEVER: &str = r#"
[[detectors]]
id = "soc"
label = "early"
threshold = 0.01
[[detectors]]
id = "soc"
label = "never"
threshold = 1e12
"#;

fn runner(jobs: usize) -> Runner {
    Runner::new(Some(jobs)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)")
}

fn run_one(r: &Runner, s: &Scenario) -> EpisodeRun {
    r.run_episode(&s.episodes[0]).unwrap()
}

#[test]
fn an_early_alarm_evades_and_no_alarm_collides() {
    let s = scenario(0.0, EARLY_AND_NEVER);
    let run = run_one(&runner(1), &s);
    let [early, never] = &run.outcome.detectors[..] else {
        panic!("two detectors")
    };
    // ground truth: the ball would hit the standing robot
    assert!(early.threat && never.threat);
    let t_c = early.t_contact_s.unwrap();
    // launched 5 m away at 3 m/s at 0.3 s; it touches the front face before reaching the camera
    assert!(t_c > 1.6 && t_c < 2.0, "t_c = {t_c}");
    assert_eq!(run.trace.reference_object.as_deref(), Some("ball"));

    // `early` alarms well before contact, dodges and evades
    assert_eq!(early.outcome, Outcome::Hit);
    let t_a = early.t_alarm_s.unwrap();
    assert!(t_a < t_c - 0.4, "t_a = {t_a}");
    assert!(!early.collision, "the dodge should evade a 3 m/s ball");
    let cl = &run.closed_loop[0];
    assert!(cl.simulated && cl.triggers >= 1 && cl.collision_t_s.is_none(), "{cl:?}");
    assert!(cl.frames_rendered > 0);
    // TTC and angular size at the alarm: the reference object's truth at that frame
    let ttc = early.ttc_at_alarm_s.unwrap();
    assert!((ttc - (t_c - t_a)).abs() < 0.02, "ttc {ttc} vs t_c - t_a {}", t_c - t_a);
    let theta = early.angular_size_at_alarm_deg.unwrap();
    assert!(theta > 1.0 && theta < 20.0, "θ at alarm {theta}");
    assert_eq!(early.lead_s(), Some(t_c - t_a));

    // `never` never alarms: the closed loop equals the open loop, a collision
    assert_eq!(never.outcome, Outcome::Miss);
    assert!(never.t_alarm_s.is_none() && never.collision);
    assert!(!run.closed_loop[1].simulated);
    assert_eq!(run.closed_loop[1].collision_t_s, Some(t_c));

    // the open-loop pass ends at the contact
    assert!(*run.trace.t_s.last().unwrap() >= t_c - 1e-9);
    assert!(*run.trace.t_s.last().unwrap() < t_c + 1.0 / 120.0 + 1e-9);
}

#[test]
fn a_miss_is_not_a_threat() {
    // The ball passes 2 m to the robot's right; `early`'s false alarm makes it dodge left, away.
    let s = scenario(2.0, EARLY_AND_NEVER);
    let run = run_one(&runner(1), &s);
    let [early, never] = &run.outcome.detectors[..] else {
        panic!("two detectors")
    };
    assert!(!early.threat && early.t_contact_s.is_none());
    assert!(run.closed_loop[0].simulated && run.closed_loop[0].triggers >= 1);
    assert_eq!(early.outcome, Outcome::FalseAlarm);
    assert_eq!(never.outcome, Outcome::CorrectRejection);
    assert!(!early.collision && !never.collision);
    // the whole episode was simulated: 2.4 s at 120 Hz
    assert_eq!(run.trace.t_s.len(), 288);
    // no contact, so no TTC; the reference object is the ball (the closest object)
    assert_eq!(run.trace.reference_object.as_deref(), Some("ball"));
}

#[test]
fn all_detectors_see_the_same_frames_and_runs_are_deterministic() {
    let both = scenario(
        0.0,
        "[[detectors]]\nid = \"hopfield\"\n[[detectors]]\nid = \"soc\"\n[[detectors]]\nid = \"soc\"\nlabel = \"soc_again\"\n",
    );
    let only_soc = scenario(0.0, "[[detectors]]\nid = \"soc\"\n");
    let r = runner(1);
    let a = run_one(&r, &both);
    let b = run_one(&r, &only_soc);
    let soc = &a.trace.detectors[1];
    assert_eq!(soc.signal, a.trace.detectors[2].signal, "two instances, same frames");
    assert_eq!(
        soc.signal, b.trace.detectors[0].signal,
        "same frames whatever else runs"
    );
    assert_eq!(a.trace.t_s, b.trace.t_s);
    assert!(soc.signal.iter().any(|&v| v > 0.0), "the ball changes the image");
    // hopfield reports θ̂ as its trigger signal
    assert!(a.trace.detectors[0].signal.iter().all(|v| v.is_finite() && *v >= 0.0));
    // the same episode again gives the same result
    let again = run_one(&r, &both);
    assert_eq!(a.outcome, again.outcome);
    assert_eq!(a.trace, again.trace);
}

#[test]
fn parallel_runs_keep_order_and_results() {
    let text_scenario = |miss: f64| scenario(miss, EARLY_AND_NEVER).episodes.remove(0);
    let mut eps = [text_scenario(0.0), text_scenario(2.0), text_scenario(0.0)];
    for (i, e) in eps.iter_mut().enumerate() {
        e.index = i;
    }
    let refs: Vec<_> = eps.iter().collect();
    let seen = Mutex::new(Vec::new());
    let parallel = runner(2)
        .run(&refs, |i, run| {
            assert_eq!(run.outcome.episode, i);
            seen.lock().unwrap().push(i);
            Ok(())
        })
        .unwrap();
    let mut seen = seen.into_inner().unwrap();
    seen.sort();
    assert_eq!(seen, [0, 1, 2], "the callback sees every episode once");
    let serial = runner(1).run(&refs, |_, _| Ok(())).unwrap();
    assert_eq!(parallel.len(), 3);
    for (p, s) in parallel.iter().zip(&serial) {
        assert_eq!(p.outcome, s.outcome);
    }
    assert!(parallel[0].outcome.detectors[0].threat && !parallel[1].outcome.detectors[0].threat);
    // a failing callback stops the run with its message
    let e = runner(1).run(&refs, |_, _| Err("disk full".into())).unwrap_err();
    assert!(e.to_string().contains("disk full"), "{e}");
}
