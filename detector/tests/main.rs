//! Integration tests of the detectors: one test binary, one module per concern (the baselines have their own binary, `tests/baselines/main.rs`).

mod bounds;
mod compensation;
mod hopfield_clutter;
mod hopfield_stimuli;
mod paper_findings;
mod snapshot;
mod stimulus;
mod tracker;
mod tracker_objects;
mod video;
