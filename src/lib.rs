//! The `loomlab` command-line tool's library: subcommand implementations and plots.
//!
//! The binary (`src/main.rs`) only parses arguments and maps errors to exit codes.

pub mod cli;
pub mod plot;
