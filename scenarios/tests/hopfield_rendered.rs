//! The Hopfield detector on a rendered cluttered scene (needs a GPU adapter; lavapipe is enough):
//! a dark ball thrown head-on at a standing robot on a checkered ground in front of a grating wall
//! (`scenarios/scenes/head_on_ball.toml`). The paper's front end stays silent until the ball spans
//! ~47°; the adapted front end responds by 15° and its θ̂ tracks θ.

use std::path::Path;

use loomlab_detector::Frame;
use loomlab_scenarios::{LoadOptions, parse_scenario};
use loomlab_sim::Sim;

/// The scene as a scenario with frame size `n` and one Hopfield detector with `params`.
fn episode(n: u32, params: &str) -> loomlab_scenarios::EpisodeSpec {
    let text = format!(
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
    );
    let sc = parse_scenario(
        &text,
        Path::new("head_on_ball_scene.toml"),
        None,
        &LoadOptions::default(),
    )
    .unwrap();
    sc.episode(0).unwrap()
}

struct Response {
    /// True angular size of the ball from which z stays above rest to the contact (degrees).
    sustained_onset_deg: Option<f64>,
    /// Median |θ̂ − θ|/θ over the frames with θ in [10°, 60°].
    median_rel_err: f64,
}

fn respond(n: u32, params: &str) -> Response {
    let ep = episode(n, params);
    let mut det = ep.detectors[0].build(n as usize).unwrap();
    let mut sim = Sim::new(&ep.world, ep.seed).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    let mut rows = Vec::new();
    for _ in 0..ep.frames() {
        let out = sim.step(&ep.cruise.command_at(sim.time()).to_sim()).unwrap();
        let theta = out.truth.iter().find(|o| o.name == "ball").unwrap().angular_size_deg as f64;
        let s = det.step(&Frame::from_f32(n as usize, out.frame).unwrap()).unwrap();
        rows.push((theta, s.output, s.angular_size_deg.unwrap_or(f64::NAN)));
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
    }
}

const ADAPTED: &str = r#"{ front_end = "adapted", readout = "winner", readout_alpha = 0.5 }"#;

#[test]
fn adapted_front_end_responds_by_15_degrees_and_tracks_theta_paper_stays_silent() {
    for n in [128, 256] {
        let paper = respond(n, "{}");
        let adapted = respond(n, ADAPTED);
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
