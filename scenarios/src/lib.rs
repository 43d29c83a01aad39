//! Scenario schema, closed-loop runner and scoring (design §6).

pub mod episodes_csv;
pub mod metrics;
pub mod regression;
pub mod report;
pub mod stats;
