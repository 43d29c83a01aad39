//! Subcommands of the `loomlab` CLI, one module each; `src/main.rs` only dispatches.

pub mod calibrate;
pub mod detect;
pub mod efference;
pub mod figures;
pub mod render;
pub mod run;
pub mod run_dir;
pub mod run_lock;
pub mod table;

use indicatif::{ProgressBar, ProgressStyle};

/// Reports a failed command on stderr and returns its exit code: the chain of causes, each once (a
/// message that already quotes its cause, like "cannot read F: No such file", is not followed by
/// the cause again), then how to resume an interrupted run; 3 when an output could not be written
/// (disk full, permissions), 2 for bad input.
pub fn report_error(e: &anyhow::Error) -> i32 {
    let mut text = String::new();
    for cause in e.chain() {
        let c = cause.to_string();
        if !text.contains(&c) {
            if !text.is_empty() {
                text += ": ";
            }
            text += &c;
        }
    }
    crate::errln!("error: {text}");
    if let Some(cmd) = run_dir::RESUME_HINT.lock().unwrap_or_else(|e| e.into_inner()).take() {
        crate::errln!("the finished episodes are saved; resume with:\n  {cmd}");
    }
    if e.downcast_ref::<run_dir::CannotWrite>().is_some() {
        3
    } else {
        2
    }
}

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
