//! The `loomlab` binary end to end: one test binary (linking wgpu and rapier once), one module per subcommand or concern.

mod calibrate_cli;
mod common;
mod detect_cli;
mod docs;
mod render_cli;
mod report_html;
mod run_cli;
mod run_resume;
mod tiers;
