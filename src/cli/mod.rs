//! Subcommands of the `loomlab` CLI, one module each; `src/main.rs` only dispatches.

pub mod calibrate;
pub mod detect;
pub mod efference;
pub mod figures;
pub mod render;
pub mod run;
pub mod table;

use indicatif::{ProgressBar, ProgressStyle};

/// Reports a failed command on stderr and returns its exit code (see [`report_failure`]).
pub fn report_error(e: &anyhow::Error) -> i32 {
    report_failure(e, None)
}

/// Reports a failed command on stderr and returns its exit code: the chain of causes, each once (a
/// message that already quotes its cause, like "cannot read F: No such file", is not followed by
/// the cause again), then how to resume an interrupted run (`resume`: its command); 3 when an
/// output could not be written (disk full, permissions), 2 for bad input.
pub fn report_failure(e: &anyhow::Error, resume: Option<&str>) -> i32 {
    crate::errln!("error: {}", error_text(e));
    if let Some(cmd) = resume {
        crate::errln!("the finished episodes are saved; resume with:\n  {cmd}");
    }
    if e.downcast_ref::<crate::run::run_dir::CannotWrite>().is_some() {
        3
    } else {
        2
    }
}

/// The chain of causes of `e`, each once (a message that already quotes its cause is not followed
/// by the cause again), joined by `: `.
pub fn error_text(e: &anyhow::Error) -> String {
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
    text
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
