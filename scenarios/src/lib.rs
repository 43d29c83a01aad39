//! Scenario schema, closed-loop runner and scoring (design §6).

pub mod calibrate;
pub mod deadline;
pub mod episodes_csv;
pub mod error;
pub mod expand;
pub mod fingerprint;
pub mod lv;
pub mod metrics;
pub mod reference;
pub mod regression;
pub mod replay;
pub mod report;
pub mod runner;
pub mod schema;
pub mod stats;
pub mod suite;
pub mod sweep;
pub mod tier;
pub mod truth;

pub use error::{RunError, ScenarioError};
pub use runner::{EpisodeRun, Runner};
pub use schema::{EpisodeSpec, LoadOptions, Scenario, load_scenario, parse_scenario};
pub use suite::{DEFAULT_SUITE, Suite, load_suite};
