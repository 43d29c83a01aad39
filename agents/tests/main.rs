//! Integration tests of the escape agent: one test binary, one module per concern.

mod action;
mod decision_call_path;
mod escape;
mod planner;
