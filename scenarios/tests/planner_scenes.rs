//! The manoeuvre planner in the closed loop, on scenes of the default suite where the reference
//! rows' own manoeuvres used to collide.

use std::path::Path;

use loomlab_scenarios::metrics::Outcome;
use loomlab_scenarios::{LoadOptions, Runner, load_scenario};

/// `car_crossing`'s episodes 0 and 2: a car (4 × 1.8 m) crosses the cruising robot's path at 28°,
/// cut off by the image's right border when `ideal_course` alarms (2.31 s). Every candidate then
/// looked like a collision: the car's footprint was a square as deep as its cut-off image was wide,
/// its scale the assumed closing speed's, and a stop or a reversal resumed the cruise after 0.6 s,
/// into the car's diagonal sweep; the planner took the sidestep, which collided. With the oriented
/// footprint reaching beyond the border, the ground hypothesis of its scale and the wait after a
/// stop or a reversal, `ideal_course` and `ideal_tau` evade as the oracle does.
#[test]
fn the_reference_rows_evade_a_car_crossing_obliquely_without_colliding() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("suites/default/car_crossing.toml");
    let scenario = load_scenario(&file, None, &LoadOptions::default()).unwrap();
    let runner = Runner::new(Some(1)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    for episode in [0, 2] {
        let run = runner.run_episode(&scenario.episode(episode).unwrap()).unwrap();
        for label in ["oracle", "ideal_tau", "ideal_course"] {
            let row = run.outcome.detectors.iter().find(|d| d.detector == label).unwrap();
            assert_eq!(row.outcome, Outcome::Hit, "episode {episode}: {label}");
            assert!(!row.collision, "episode {episode}: {label}'s manoeuvre collided");
        }
    }
}
