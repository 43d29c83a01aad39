//! The scenario file schema (design §6) and its expansion into [`EpisodeSpec`]s.
//!
//! A scenario file is TOML (every key is documented in `scenarios/README.md`):
//!
//! ```toml
//! name = "head_on_ball"            # default: the file name without .toml
//! description = "A ball thrown straight at the robot."
//!
//! [episode]
//! duration_s = 3.0                 # simulated time per episode (it ends earlier at the first contact)
//! seed = 1                         # seeds the random ranges and every episode's simulator seed
//! repeats = 1                      # episodes per parameter point (each with its own simulator seed)
//!
//! [world]                          # the simulator's WorldDesc, verbatim (see loomlab_sim::WorldDesc)
//! camera = { n = 64 }
//! [[world.projectiles]]
//! speed_mps = 8.0
//!
//! [robot]                          # the cruise command (the body and start pose are in [world.robot])
//! forward_mps = 1.0
//!
//! [[detectors]]                    # default: every registered detector at its default threshold
//! id = "hopfield"
//! threshold = 10.0                 # degrees of θ̂ for hopfield, output units for the baselines
//!
//! [controller]                     # loomlab_agents::EscapeConfig without trigger/threshold
//! dodge_speed_mps = 2.0
//!
//! [scoring]
//! lead_margin_s = 0.0              # a hit alarms this long before the escape deadline
//!
//! [sweep]                          # see crate::expand
//! "world.projectiles.0.speed_mps" = [6, 9, 12]
//! ```
//!
//! Unknown keys are errors everywhere; every error names the file, the key path and the reason.

mod detector;
mod document;
mod episode;
mod expansion;
mod load;
mod resolve;

pub use loomlab_detector::CameraFacts;

pub use detector::{
    DetectorSpec, angular_size_ids, camera_facts, default_camera, load_detector_entries, parse_detector_entries,
    registration, resolve_detector, resolve_detector_in, trigger_of,
};
pub use document::{CruiseChange, CruiseDesc, DetectorDesc, EpisodeDesc, ScoringDesc};
pub use episode::{EpisodeSpec, body_extent_about_camera_m, body_half_width_m, robot_facts};
pub use expansion::Scenario;
pub(crate) use load::typed;
pub use load::{LoadOptions, MAX_FILE_NAME, SuiteDefaults, check_file_name, load_scenario, parse_scenario};
