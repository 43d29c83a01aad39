//! The Hopfield detector on a rendered cluttered scene (needs a GPU adapter; lavapipe is enough):
//! a dark ball thrown head-on at a standing robot on a checkered ground in front of a grating wall
//! (`scenarios/scenes/head_on_ball.toml`). The paper's front end stays silent until the ball spans
//! ~47°; the adapted front end responds by 15° and its θ̂ tracks θ. And the suite's cruising
//! `head_on_ball`: the high-pass front ends give no θ̂ from their own start-up, and with the
//! tracker's attention the compensated front end reads the ball from a few degrees.

use std::path::Path;

use loomlab_detector::Frame;
use loomlab_scenarios::{LoadOptions, parse_scenario};
use loomlab_sim::Sim;

/// The scene (`scenarios/scenes/head_on_ball.toml`, a standing robot) as a scenario with frame
/// size `n` and one Hopfield detector with `params`.
fn episode(n: u32, params: &str) -> loomlab_scenarios::EpisodeSpec {
    scenario(&format!(
        r#"
name = "head_on_ball_scene"
[episode]
duration_s = 2.0
seed = 1
[world]
sky_luminance = 0.8
camera = {{ n = {n}, fov_deg = 60.0 }}
ground = {{ texture = {{ kind = "checker", size_m = 1.0, dark = 0.35, light = 0.55 }} }}
[[world.scenery]]
kind = "wall"
name = "backdrop"
start = [25.0, -15.0]
end = [25.0, 15.0]
height_m = 6.0
texture = {{ kind = "square_grating", period_m = 1.0, orientation_deg = 90.0, dark = 0.3, light = 0.7 }}
[[world.projectiles]]
name = "ball"
radius_m = 0.2
target = "camera"
launch_distance_m = 15.0
speed_mps = 10.0
arrival_time_s = 1.7
texture = {{ kind = "uniform", luminance = 0.1 }}
[robot]
forward_mps = 0.0
[[detectors]]
id = "hopfield"
params = {params}
"#
    ))
}

/// The default suite's `head_on_ball` (its first episode: the robot cruising at 1 m/s over a
/// checkered ground, the ball resting 11 m ahead until its launch at 0.1 s), with the suite's
/// camera and sky, and one Hopfield detector with `params`.
fn cruising_episode(params: &str) -> loomlab_scenarios::EpisodeSpec {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("suites/default/head_on_ball.toml");
    let text = std::fs::read_to_string(file).unwrap();
    scenario(&format!(
        "{text}\n[world]\nsky_luminance = 0.8\ncamera = {{ n = 96, fov_deg = 60.0 }}\n\n[[detectors]]\nid = \"hopfield\"\nparams = {params}\n"
    ))
}

fn scenario(text: &str) -> loomlab_scenarios::EpisodeSpec {
    let sc = parse_scenario(text, Path::new("scene.toml"), None, &LoadOptions::default()).unwrap();
    sc.episode(0).unwrap()
}

struct Response {
    /// True angular size of the ball from which z stays above rest to the contact (degrees).
    sustained_onset_deg: Option<f64>,
    /// Median |θ̂ − θ|/θ over the frames with θ in [10°, 60°].
    median_rel_err: f64,
    /// The largest θ̂ in the first 0.1 s, before the ball is launched (degrees).
    largest_estimate_before_launch_deg: f64,
    /// True angular size of the ball at the first frame after the launch with θ̂ > 0 (degrees).
    first_estimate_deg: Option<f64>,
}

fn respond(ep: loomlab_scenarios::EpisodeSpec) -> Response {
    let n = ep.world.camera.n;
    let mut det = ep.detectors[0].build(n as usize).unwrap();
    let mut sim = Sim::new(&ep.world, ep.seed).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    let mut rows = Vec::new();
    let mut largest_before_launch = 0.0f64;
    // the efference copy, as the runner gives it (only the compensated front end reads it)
    let mut motion_sensor = loomlab_agents::CameraMotionSensor::default();
    for _ in 0..ep.frames() {
        let cmd = ep.cruise.command_at(sim.time());
        let out = sim.step(&cmd.to_sim()).unwrap();
        let ego = motion_sensor.sense(cmd, out.t_s, &sim.camera_pose());
        let theta = out.truth.iter().find(|o| o.name == "ball").unwrap().angular_size_deg as f64;
        let s = det
            .step_moving(&Frame::from_f32(n as usize, out.frame).unwrap(), &ego)
            .unwrap();
        if out.t_s < 0.1 {
            largest_before_launch = largest_before_launch.max(s.angular_size_deg.unwrap_or(f64::NAN));
        }
        rows.push((theta, s.output, s.angular_size_deg.unwrap_or(f64::NAN), out.t_s));
        if !out.contacts.is_empty() {
            break;
        }
    }
    let sustained = (0..rows.len()).find(|&i| rows[i..].iter().all(|r| r.1 > 1.01));
    let mut errors: Vec<f64> = rows
        .iter()
        .filter(|r| (10.0..=60.0).contains(&r.0))
        .map(|r| (r.2 - r.0).abs() / r.0)
        .collect();
    assert!(errors.len() >= 5, "too few frames in 10–60°: {}", errors.len());
    errors.sort_by(f64::total_cmp);
    Response {
        sustained_onset_deg: sustained.map(|i| rows[i].0),
        median_rel_err: errors[errors.len() / 2],
        largest_estimate_before_launch_deg: largest_before_launch,
        first_estimate_deg: rows.iter().find(|r| r.3 >= 0.1 && r.2 > 0.0).map(|r| r.0),
    }
}

const ADAPTED: &str = r#"{ front_end = "adapted", readout = "winner", readout_alpha = 0.5 }"#;
const COMPENSATED: &str = r#"{ front_end = "compensated", readout = "winner", readout_alpha = 0.5 }"#;
/// The default suite's `hopfield_attended_tau_persistent` row's parameters.
const ATTENDED: &str = r#"{ front_end = "compensated", readout = "template", readout_alpha = 0.7, attention = "tracker", template = { kind = "uniform_disk", schedule = "footnote", scale_start_px = 3.0, scale_step = 0.005208333 } }"#;

#[test]
fn high_pass_front_ends_give_no_estimate_from_their_start_up_on_a_cruising_robot() {
    // The ball rests until 0.1 s: nothing moves on its own before. Without the high-pass's
    // warm-up (`warm_up_frames`), the first query to meet one of the start's in the delayed
    // memory retrieved a template there: the adapted front end's θ̂ = 32° at 0.06 s, for a ball
    // of 2.6° (the suite's "first estimate" of both rows on `head_on_ball` was that frame's θ).
    for params in [ADAPTED, COMPENSATED] {
        let r = respond(cruising_episode(params));
        assert_eq!(
            r.largest_estimate_before_launch_deg, 0.0,
            "{params}: θ̂ before the launch"
        );
    }
}

#[test]
fn adapted_front_end_responds_by_15_degrees_and_tracks_theta_paper_stays_silent() {
    for n in [128, 256] {
        let paper = respond(episode(n, "{}"));
        let adapted = respond(episode(n, ADAPTED));
        // the paper's front end: silent in the clutter until the ball dominates the edge image
        assert!(
            paper.sustained_onset_deg.is_some_and(|t| t > 30.0),
            "n = {n}: paper onset {:?}",
            paper.sustained_onset_deg
        );
        // the adapted front end: a response from ≤ 15° on, θ̂ within 30 % (median) over 10–60°
        assert!(
            adapted.sustained_onset_deg.is_some_and(|t| t <= 15.0),
            "n = {n}: adapted onset {:?}",
            adapted.sustained_onset_deg
        );
        assert!(
            adapted.median_rel_err <= 0.3,
            "n = {n}: adapted median |θ̂−θ|/θ {}",
            adapted.median_rel_err
        );
    }
}

#[test]
fn attention_gives_the_compensated_front_end_the_cruising_head_on_ball_from_a_few_degrees() {
    // Issue 23's check on the suite's own episode: θ̂ leaves 0 by θ = 10° and its median error
    // over 10°–60° is within 30 %. The compensated front end alone reads nothing until θ ≈ 15°
    // (its templates are centred discs; the ball is a few pixels off centre): error 1.0.
    let attended = respond(cruising_episode(ATTENDED));
    let first = attended.first_estimate_deg.expect("an estimate");
    assert!(first <= 10.0, "attended: first θ̂ at θ = {first}°");
    assert!(
        attended.median_rel_err <= 0.3,
        "attended: median error {}",
        attended.median_rel_err
    );
    let plain = respond(cruising_episode(COMPENSATED));
    assert!(
        plain.median_rel_err >= 0.5,
        "compensated alone: median error {}",
        plain.median_rel_err
    );
}
