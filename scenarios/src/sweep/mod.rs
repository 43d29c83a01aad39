//! Detector-parameter sweeps: a suite × a grid (or seeded random search) of detector settings,
//! cut into shards that can run anywhere, and merged into one report per parameter point.
//!
//! A sweep file (documented in `scenarios/README.md`, example in `sweeps/`):
//!
//! ```toml
//! name = "hopfield_alpha"                 # default: the file name; output folder out/sweep/<name>
//! suite = "../scenarios/suites/default"   # relative to this file
//! seed = 0                                # suite seed, as `loomlab run --seed`
//! size = 64                               # frame size, as `loomlab run --size` (optional)
//! limit = 40                              # the first N episodes only, as `--limit` (optional)
//! episodes_per_shard = 8                  # default 16
//! points_per_shard = 0                    # parameter points per shard, 0 = all (default)
//! search_seed = 0                         # seeds the [random] draws
//!
//! [objective]
//! metric = "roc_hit_rate"                 # see [`Metric`]
//! false_alarm_budget = 0.1
//!
//! [[detectors]]                           # a scenario [[detectors]] entry ...
//! id = "hopfield"
//! threshold = 10.0
//! [detectors.sweep]                       # ... with the scenario [sweep] / [random] syntax
//! threshold = [6.0, 10.0, 14.0]
//! "params.alpha" = [0.8, 0.9]
//! ```
//!
//! Every parameter point becomes a labelled detector (`hopfield-003`), and all points of a shard
//! watch the same rendered frames of an episode. A point's report is built from exactly the rows
//! `loomlab run SUITE --seed S --size N --limit L --detectors-file points/<label>/detectors.toml`
//! writes, in the same order, so the two reports are identical but for `wall_time_s`.
//!
//! The output folder holds `manifest.json` (what the sweep is: its fingerprint must match to
//! resume), `shards/NNNNN.csv` (episodes.csv rows of finished shards, written atomically: a file
//! that exists is complete), and after merging `points/<label>/{report.json, episodes.csv,
//! detectors.toml}`, `ranking.csv` and `summary.json`.

mod error;
mod file;
mod objective;
mod out_dir;
mod plan;
mod ranking;

pub use error::SweepError;
pub use file::{MAX_POINTS, SweepFile, SweepPoint};
pub use objective::{Metric, Objective};
pub use out_dir::SweepDir;
pub use plan::{Shard, SweepPlan};
pub use ranking::{PointResult, format_ranking, rank};
