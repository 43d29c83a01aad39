//! Subcommands of the `loomlab` CLI.
