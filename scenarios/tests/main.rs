//! Integration tests of the scenario layer: one test binary, one module per concern.

mod deadline;
mod efference;
mod events;
mod hopfield_rendered;
mod latency;
mod parser_fuzz;
mod planner_scenes;
mod reference;
mod registry;
mod runner;
mod schema;
mod scoring;
mod sweep;
mod tiers;
