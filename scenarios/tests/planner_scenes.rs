//! The manoeuvre planner in the closed loop, on scenes of the default suite where the reference
//! rows' own manoeuvres used to collide.

use std::path::Path;

use loomlab_scenarios::metrics::Outcome;
use loomlab_scenarios::{LoadOptions, Runner, load_scenario};

/// `car_crossing`'s episodes 0 and 2: a car (4 × 1.8 m) crosses the cruising robot's path at 28°.
/// An earlier version of the scene ended at 3.6 s, and there the reference rows "evaded" these
/// threats as the oracle did: by a stop or a reversal that held the robot back until the episode
/// ended, 0.1 s before the car's slanted front reached it (with image-exact elevations the planner
/// forecasts the car well and predicts, rightly, that every candidate collides). The scene now
/// lasts until the car has crossed, and no manoeuvre of the set evades it: the threats are
/// unavoidable for every row, the oracle included, and no row's manoeuvre is counted as causing
/// the collision.
#[test]
fn a_car_crossing_obliquely_is_unavoidable_once_the_scene_lasts_until_it_has_crossed() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("suites/default/car_crossing.toml");
    let scenario = load_scenario(&file, None, &LoadOptions::default()).unwrap();
    let runner = Runner::new(Some(1)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    for episode in [0, 2] {
        let run = runner.run_episode(&scenario.episode(episode).unwrap()).unwrap();
        for label in ["oracle", "ideal_tau", "ideal_course"] {
            let row = run.outcome.detectors.iter().find(|d| d.detector == label).unwrap();
            assert_eq!(row.outcome, Outcome::Unavoidable, "episode {episode}: {label}");
            assert!(!row.collision_caused(), "episode {episode}: {label}");
        }
    }
}
