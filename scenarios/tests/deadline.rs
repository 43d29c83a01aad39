//! Escape deadlines against hand calculations (physics only: no GPU needed).
//!
//! Most cases use analytic physics, where the dodge reaches its speed at once and the geometry
//! below is exact; `a_dodge_limited_by_acceleration_needs_the_time_to_cover_w_plus_r` checks the
//! dynamic robot, whose dodge accelerates at `max_accel_mps2`.
//!
//! The geometry: a robot standing still (`forward_mps = 0`), a ball of radius `r` flying straight
//! at the robot's body centre along its forward axis at constant speed `V` (no gravity, no ground),
//! and the default escape manoeuvre, a lateral dodge at `v` = 1.5 m/s held for 1 s.
//!
//! # The hand calculation
//! The default robot body (`sim/src/robot.rs`, `RobotDesc::default`) is a box of 0.5 × 0.4 × 0.3 m
//! (x forward, y left, z up). A lateral dodge moves it along y, so the half-width across the dodge
//! direction is `w` = 0.4 / 2 = 0.2 m. The ball flies along x at the height of the body centre, so
//! only the (x, y) geometry matters.
//!
//! Open loop, the ball touches the front face (x = +0.25) at `t_c`, when its centre is at
//! x = 0.25 + r. A trigger at open-loop frame k (time `t_k`) makes the robot move sideways at `v`
//! from `t_k` on (the command decided after step k drives step k + 1; the robot is kinematic, so the
//! speed is reached at once). To evade, the body must have cleared the ball's path: in the frame of
//! the ball the box's near front corner moves along a line with velocity (V, v), and the ball misses
//! iff that line keeps the corner at least `r` from the ball's centre. With `D` the corner's lateral
//! distance from the flight line when the ball's centre reaches the front-face plane (at
//! `t_c + r/V`), that distance is `D·V/√(V² + v²)`, so evasion needs `D ≥ r·√(1 + (v/V)²)`, i.e.
//!
//! ```text
//! t_c − t_k ≥ L = (w + r·√(1 + (v/V)²)) / v − r/V.
//! ```
//!
//! The deadline is the latest frame satisfying this, so `t_c − t_dl` lies in `[L, L + 1 frame)`.
//! (The simple `(w + r)/v` is the limit of `L` for a ball much faster than the dodge; at finite `V`
//! the ball's own travel during the dodge (`r/V`) and the oblique pass of the corner shift it: by
//! −0.04 s for r = 0.15 m and −0.10 s for r = 0.4 m at V = 4 m/s, more than a frame, so the test
//! checks `L`, and `(w + r)/v` only for a ball fast enough for the correction to be below a frame.)
//! Contacts are detected at the physics steps, so a graze shorter than a step may go unseen: a
//! small tolerance covers it.

use std::path::Path;

use loomlab_agents::EscapeController;
use loomlab_scenarios::deadline::{
    CHECKPOINT_INTERVAL, EscapeDeadline, MAX_CHECKPOINTS, escape_deadline, escape_deadline_exhaustive, replay_trigger,
};
use loomlab_scenarios::truth::open_loop_truth;
use loomlab_scenarios::{EpisodeSpec, LoadOptions, parse_scenario};
use loomlab_sim::ShapeDesc;

/// Dodge speed (m/s): the controller default, also written into the scenario.
const DODGE_MPS: f64 = 1.5;
/// Launch: distance from the body centre (m) and time (s).
const LAUNCH_M: f64 = 4.0;
const LAUNCH_T_S: f64 = 0.2;
/// Slack for contacts missed between physics steps (s).
const TOL_S: f64 = 0.002;

/// The episode with analytic physics: ball of radius `r` at speed `speed`, `substeps` physics steps
/// per frame.
fn episode(r: f64, speed: f64, launch_m: f64, substeps: u32) -> EpisodeSpec {
    episode_with(r, speed, launch_m, substeps, "analytic")
}

fn episode_with(r: f64, speed: f64, launch_m: f64, substeps: u32, physics: &str) -> EpisodeSpec {
    let text = format!(
        r#"
name = "deadline_geometry"
[episode]
duration_s = 2.5
seed = 11
[world]
camera = {{ n = 32 }}
ground = {{ enabled = false }}
physics = "{physics}"
physics_substeps = {substeps}
[[world.projectiles]]
name = "ball"
target = "robot"
radius_m = {r}
speed_mps = {speed}
launch_distance_m = {launch_m}
launch_time_s = {LAUNCH_T_S}
[robot]
forward_mps = 0.0
[controller]
manoeuvre = "dodge_lateral"
dodge_speed_mps = {DODGE_MPS}
duration_s = 1.0
[[detectors]]
id = "soc"
"#
    );
    let s = parse_scenario(
        &text,
        Path::new("deadline_geometry.toml"),
        None,
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(s.len(), 1);
    s.episode(0).unwrap()
}

/// Half-width of the robot across a lateral dodge (m), read off the episode's body.
fn half_width(ep: &EpisodeSpec) -> f64 {
    match ep.world.robot.body {
        ShapeDesc::Box { size } => {
            assert_eq!(size, [0.5, 0.4, 0.3], "the default body");
            f64::from(size[1]) / 2.0
        }
        ref other => panic!("expected the default box body, got {other:?}"),
    }
}

/// The lead `t_c − t_dl` the hand calculation gives for an infinitely fine frame rate (see the
/// module docs).
fn hand_lead(w: f64, r: f64, speed: f64, dodge: f64) -> f64 {
    (w + r * (1.0 + (dodge / speed).powi(2)).sqrt()) / dodge - r / speed
}

struct Case {
    ep: EpisodeSpec,
    controller: EscapeController,
    t_s: Vec<f64>,
    t_c: f64,
    contact_frame: usize,
    deadline: EscapeDeadline,
}

/// Open-loop truth and the deadline of `ep`, the looming side fixed at `side` on every frame.
fn case(ep: EpisodeSpec, side: f32) -> Case {
    let truth = open_loop_truth(&ep, ep.seed).unwrap();
    let contact = truth.contact.clone().expect("the ball hits the standing robot");
    let hz = f64::from(ep.world.camera_hz);
    // frame k is the output of step k + 1, at time (k + 1)/hz
    let t_s: Vec<f64> = (0..=contact.frame).map(|k| (k + 1) as f64 / hz).collect();
    let sides = vec![Some(side); t_s.len()];
    let controller = EscapeController::new(ep.controller.clone(), ep.facts).unwrap();
    let deadline = escape_deadline_exhaustive(&ep, ep.seed, &controller, &sides, &t_s, contact.frame).unwrap();
    // the backward search stops at the same deadline, after fewer replays
    let fast = escape_deadline(&ep, ep.seed, &controller, &sides, &t_s, contact.frame).unwrap();
    assert_eq!(fast.frame, deadline.frame);
    assert_eq!(fast.t_s, deadline.t_s);
    assert!(fast.replays <= deadline.replays);
    Case {
        t_c: contact.t_s,
        contact_frame: contact.frame,
        ep,
        controller,
        t_s,
        deadline,
    }
}

fn check_geometry(r: f64, speed: f64) {
    let ep = episode(r, speed, LAUNCH_M, 1);
    let w = half_width(&ep);
    assert!((w - 0.2).abs() < 1e-6, "{w}");
    let frame_s = 1.0 / f64::from(ep.world.camera_hz);
    assert_eq!(ep.controller.dodge_speed_mps, DODGE_MPS);
    // object on the right of the image → dodge left
    let c = case(ep, 0.5);

    // the open-loop contact: the ball's front reaches the front face (x = 0.25)
    let t_c_hand = LAUNCH_T_S + (LAUNCH_M - 0.25 - r) / speed;
    assert!((c.t_c - t_c_hand).abs() < 1e-6, "r = {r}: t_c {} vs {t_c_hand}", c.t_c);
    assert!(c.t_s[c.contact_frame] >= c.t_c - 1e-9 && c.t_s[c.contact_frame] - frame_s < c.t_c);

    let d = &c.deadline;
    let dl = d.frame.expect("a 1.5 m/s dodge evades a ball seen from 4 m");
    assert!(d.evadable());
    assert_eq!(d.t_s, Some(c.t_s[dl]));
    let lead = c.t_c - c.t_s[dl];
    let hand = hand_lead(w, r, speed, DODGE_MPS);
    eprintln!(
        "r = {r} m, V = {speed} m/s: t_c = {:.4} s, deadline frame {dl} of {}, t_c − t_dl = {lead:.4} s, \
         hand {hand:.4} s, (w + r)/v = {:.4} s, {} replays",
        c.t_c,
        c.contact_frame,
        (w + r) / DODGE_MPS,
        d.replays
    );
    assert!(
        lead >= hand - TOL_S && lead < hand + frame_s + TOL_S,
        "r = {r}, V = {speed}: t_c − t_dl = {lead:.4} s, hand calculation {hand:.4} s (+ up to one frame {frame_s:.4} s)"
    );
    // the cruder (w + r)/v is off by more than a frame at this speed (see the module docs)
    let crude = (w + r) / DODGE_MPS;
    assert!(
        crude - lead > frame_s * 0.5,
        "r = {r}: crude {crude:.4}, lead {lead:.4}"
    );

    // every trigger up to the deadline evades, none after it: one range from frame 0
    assert!(d.monotone(), "{:?}", d.evading);
    assert_eq!(d.evading, vec![0..dl + 1]);
    assert!(d.evades_at(0) && d.evades_at(dl) && !d.evades_at(dl + 1));
    // the search replays every frame before the contact, once
    assert_eq!(d.replays, c.contact_frame);

    // replays: a trigger at the deadline frame evades, one frame later collides (after t_c, since
    // the dodge has started), and so does a trigger on the last frame before contact
    let side = Some(0.5);
    assert_eq!(replay_trigger(&c.ep, c.ep.seed, &c.controller, dl, side).unwrap(), None);
    let late = replay_trigger(&c.ep, c.ep.seed, &c.controller, dl + 1, side)
        .unwrap()
        .expect("one frame after the deadline collides")
        .t_s;
    assert!(late > c.t_c, "the dodge delays the contact: {late} vs t_c {}", c.t_c);
    assert!(
        replay_trigger(&c.ep, c.ep.seed, &c.controller, c.contact_frame - 1, side)
            .unwrap()
            .is_some()
    );
    assert_eq!(replay_trigger(&c.ep, c.ep.seed, &c.controller, 0, side).unwrap(), None);
    // never triggering: the open-loop contact
    let never = replay_trigger(&c.ep, c.ep.seed, &c.controller, usize::MAX, side)
        .unwrap()
        .expect("no escape collides");
    assert!((never.t_s - c.t_c).abs() < 1e-9);
    assert!(never.impact_speed_mps > 1.0, "{never:?}");

    // the dodge side does not matter for a ball on the axis: dodging right gives the same deadline
    let right = case(episode(r, speed, LAUNCH_M, 1), -0.5);
    assert_eq!(right.deadline.frame, d.frame);
    // nor does an unknown side (the controller's default side)
    let unknown = {
        let ep = episode(r, speed, LAUNCH_M, 1);
        let truth = open_loop_truth(&ep, ep.seed).unwrap();
        let k = truth.contact.unwrap().frame;
        let sides = vec![None; k + 1];
        escape_deadline_exhaustive(&ep, ep.seed, &c.controller, &sides, &c.t_s, k).unwrap()
    };
    assert_eq!(unknown.frame, d.frame);
}

#[test]
fn deadline_lead_of_a_small_ball_matches_the_hand_calculation() {
    check_geometry(0.15, 4.0);
}

#[test]
fn deadline_lead_of_a_large_ball_matches_the_hand_calculation() {
    check_geometry(0.4, 4.0);
}

#[test]
fn a_faster_ball_needs_a_longer_deadline_lead() {
    // The faster the ball, the less it travels during the dodge (r/V) and the more squarely it
    // passes the corner: the lead grows towards (w + r)/v (0.26, 0.28, 0.30 s here for r = 0.3 m).
    let w = 0.2;
    let mut leads = Vec::new();
    for speed in [3.0, 5.0, 8.0] {
        let c = case(episode(0.3, speed, 6.0, 1), 0.5);
        let lead = c.t_c - c.t_s[c.deadline.frame.unwrap()];
        let hand = hand_lead(w, 0.3, speed, DODGE_MPS);
        eprintln!("r = 0.3 m, V = {speed} m/s: t_c − t_dl = {lead:.4} s, hand {hand:.4} s");
        assert!(
            lead >= hand - TOL_S && lead < hand + 1.0 / 120.0 + TOL_S,
            "V = {speed}: {lead} vs {hand}"
        );
        leads.push(lead);
    }
    assert!(leads[0] < leads[2], "{leads:?}");
}

#[test]
fn a_ball_much_faster_than_the_dodge_needs_w_plus_r_over_v() {
    // At 60 m/s (with 20 physics steps per frame so that contacts are resolved to 2.5 cm) the
    // correction of the module docs is under one frame, and the simple hand calculation holds.
    for r in [0.15, 0.4] {
        let ep = episode(r, 60.0, 40.0, 20);
        let w = half_width(&ep);
        let frame_s = 1.0 / f64::from(ep.world.camera_hz);
        let c = case(ep, 0.5);
        let lead = c.t_c - c.t_s[c.deadline.frame.unwrap()];
        let crude = (w + r) / DODGE_MPS;
        assert!(
            (lead - crude).abs() <= frame_s + TOL_S,
            "r = {r}: t_c − t_dl = {lead:.4} s, (w + r)/v = {crude:.4} s"
        );
        let hand = hand_lead(w, r, 60.0, DODGE_MPS);
        eprintln!("r = {r} m, V = 60 m/s: t_c − t_dl = {lead:.4} s, hand {hand:.4} s, (w + r)/v = {crude:.4} s");
        assert!(
            lead >= hand - TOL_S && lead < hand + frame_s + TOL_S,
            "r = {r}: {lead} vs {hand}"
        );
        assert!(c.deadline.monotone());
    }
}

#[test]
fn a_dodge_limited_by_acceleration_needs_the_time_to_cover_w_plus_r() {
    // Dynamic physics: from rest, the sidestep accelerates at a = max_accel_mps2 (2.5 m/s²) to
    // v = 1.5 m/s (reached after v/a = 0.6 s, 0.45 m), so it covers y in τ(y) = √(2y/a) for
    // y ≤ 0.45 m and 0.6 s + (y − 0.45 m)/v beyond. Against a 60 m/s ball the lead is τ(w + r)
    // less r / 60 m/s: the contact time is when the ball's front reaches the body's front face,
    // but a ball passing beside has to clear the face's corner only when its centre passes it, r
    // later. (Before the ground truth left rapier's speculative contacts out, a ball passing within
    // their margin, 2.5 cm at 60 m/s, counted as a hit, which hid the r / v.)
    for r in [0.15, 0.4] {
        let ep = episode_with(r, 60.0, 40.0, 20, "dynamic");
        let a = f64::from(ep.world.robot.max_accel_mps2);
        assert_eq!(a, 2.5, "the default acceleration limit");
        let w = half_width(&ep);
        let frame_s = 1.0 / f64::from(ep.world.camera_hz);
        let c = case(ep, 0.5);
        let lead = c.t_c - c.t_s[c.deadline.frame.expect("evadable")];
        let y = w + r;
        let ramp = DODGE_MPS * DODGE_MPS / (2.0 * a);
        let hand = if y <= ramp {
            (2.0 * y / a).sqrt()
        } else {
            DODGE_MPS / a + (y - ramp) / DODGE_MPS
        } - r / 60.0;
        eprintln!("dynamic, r = {r} m: t_c − t_dl = {lead:.4} s, hand {hand:.4} s");
        assert!(
            lead >= hand - TOL_S && lead < hand + 2.0 * frame_s + TOL_S,
            "r = {r}: t_c − t_dl = {lead:.4} s, hand calculation {hand:.4} s (+ up to two frames: the \
             frame grid and the drive's rate limit applied per physics substep)"
        );
        // instant acceleration would need only (w + r)/v
        assert!(lead > y / DODGE_MPS + frame_s, "{lead} vs {}", y / DODGE_MPS);
        assert!(c.deadline.monotone());
    }
}

#[test]
fn a_ball_too_close_to_dodge_is_unavoidable() {
    // launched 1 m away at 10 m/s at 0.2 s: contact at 0.245 s, but the dodge needs 0.31 s
    // (hand calculation): no trigger, not even on the first frame, evades
    let ep = episode(0.3, 10.0, 1.0, 1);
    let c = case(ep, 0.5);
    let hand = hand_lead(0.2, 0.3, 10.0, DODGE_MPS);
    assert!(
        c.t_c - c.t_s[0] < hand,
        "contact comes sooner after the first frame than any dodge could clear the ball"
    );
    assert_eq!(c.deadline.frame, None);
    assert_eq!(c.deadline.t_s, None);
    assert!(!c.deadline.evadable() && c.deadline.evading.is_empty());
    assert!(c.deadline.monotone(), "an unavoidable threat counts as monotone");
    assert!(c.deadline.replays > 0);
}

/// The deadline of `ep` with the looming side `sides(k)` at frame k, from the backward search and
/// from the exhaustive scan.
fn both(ep: &EpisodeSpec, sides: impl Fn(usize) -> Option<f32>) -> (EscapeDeadline, EscapeDeadline) {
    let truth = open_loop_truth(ep, ep.seed).unwrap();
    let contact = truth.contact.expect("a threat");
    let hz = f64::from(ep.world.camera_hz);
    let t_s: Vec<f64> = (0..=contact.frame).map(|k| (k + 1) as f64 / hz).collect();
    let sides: Vec<Option<f32>> = (0..t_s.len()).map(sides).collect();
    let controller = EscapeController::new(ep.controller.clone(), ep.facts).unwrap();
    let fast = escape_deadline(ep, ep.seed, &controller, &sides, &t_s, contact.frame).unwrap();
    let all = escape_deadline_exhaustive(ep, ep.seed, &controller, &sides, &t_s, contact.frame).unwrap();
    (fast, all)
}

#[test]
fn the_backward_search_equals_the_exhaustive_scan_where_evasion_is_not_monotone() {
    // A ball aimed 0.15 m left of the body centre: near the deadline, dodging left (towards it)
    // needs more time than dodging right. Looming sides that alternate between left and right
    // (and unknown: the controller's default side) make evasion non-monotone in the trigger
    // frame; the backward search must still stop at the exhaustive scan's latest evading frame.
    let mut nonmonotone = 0;
    for (r, offset, angle, period) in [
        (0.15, 0.15, 0.0, 2),
        (0.3, 0.1, 0.0, 3),
        (0.15, 0.12, 180.0, 5),
        (0.2, 0.0, 0.0, 4),
    ] {
        let mut ep = episode(r, 4.0, LAUNCH_M, 1);
        ep.world.projectiles[0].miss_distance_m = offset as f32;
        ep.world.projectiles[0].miss_angle_deg = angle as f32;
        for pattern in 0..3 {
            let side = |k: usize| match (pattern, (k / period) % 3) {
                (0, 0) | (1, 1) => Some(0.5),
                (0, 1) | (2, 0) => Some(-0.5),
                _ => None,
            };
            let (fast, all) = both(&ep, side);
            assert_eq!(
                fast.frame, all.frame,
                "r {r}, offset {offset}, period {period}, pattern {pattern}: {:?}",
                all.evading
            );
            assert_eq!(fast.t_s, all.t_s);
            assert!(fast.replays <= all.replays);
            if !all.monotone() {
                nonmonotone += 1;
            }
        }
    }
    assert!(
        nonmonotone > 0,
        "the cases include evasion that is not monotone in the trigger frame"
    );
}

#[test]
fn the_backward_search_finds_an_unavoidable_threat_as_the_scan_does() {
    let ep = episode(0.3, 10.0, 1.0, 1);
    let (fast, all) = both(&ep, |_| Some(0.5));
    assert_eq!(fast.frame, None);
    assert_eq!(all.frame, None);
    assert_eq!(fast.replays, all.replays, "an unavoidable threat replays every frame");
}

#[test]
fn a_long_episode_with_a_late_contact_gets_the_exhaustive_deadline() {
    // 37 s, the ball launched 33 s in from 4 m at 1.1 m/s: contact at about 36 s. The backward
    // search replays only the frames between the deadline and the contact; the exhaustive scan
    // (every frame before contact, about 2200 at 60 Hz, each replayed from t = 0) gives the same
    // deadline. More frames than MAX_CHECKPOINTS × CHECKPOINT_INTERVAL (2048): the checkpoints
    // are spread further apart.
    let mut ep = episode(0.15, 1.1, 4.0, 1);
    ep.world.projectiles[0].launch_time_s = Some(33.0);
    ep.world.camera_hz = 60.0;
    // every replay runs to the episode's end: the episode ends soon after the contact
    ep.duration_s = 37.0;
    let (fast, all) = both(&ep, |_| Some(0.5));
    let t_c = open_loop_truth(&ep, ep.seed).unwrap().contact.unwrap().t_s;
    assert!((35.0..37.0).contains(&t_c), "t_c = {t_c}");
    assert_eq!(fast.frame, all.frame);
    assert!(fast.frame.is_some());
    assert!(fast.replays * 20 < all.replays, "{} vs {}", fast.replays, all.replays);
    assert!(
        all.replays > MAX_CHECKPOINTS * CHECKPOINT_INTERVAL,
        "{} frames",
        all.replays
    );
}
