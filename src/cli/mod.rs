//! Subcommands of the `loomlab` CLI, one module each; `src/main.rs` only dispatches.

pub mod detect;
pub mod figures;
pub mod render;
pub mod run;
pub mod run_dir;
pub mod table;

use indicatif::{ProgressBar, ProgressStyle};

/// A progress bar on stderr (hidden automatically when stderr is not a terminal).
pub fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})")
            .expect("static template is valid")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}
