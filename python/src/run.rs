//! `python -m loomlab run` and `loomlab.run_suite(out=...)`: the `loomlab run` of the CLI
//! (`loomlab::cli::run`), in this process, with Python detectors added to the suite's rows. It
//! writes the same run folder (episodes.csv, report.json, plots, report.html, manifest.json) and
//! resumes the same way.
//!
//! Ctrl-C: the run works on another thread while this one, holding the GIL only for a moment every
//! 50 ms, lets Python handle its signals; the first KeyboardInterrupt stops the run as the CLI's
//! first Ctrl-C does (no new episode starts, those in flight give up, every finished one is saved,
//! the folder says `interrupted` and `--resume` continues it). A second KeyboardInterrupt stops at
//! once as the CLI's second Ctrl-C does: the run in progress is marked `interrupted` (its finished
//! episodes are saved), the resume command is printed and the process exits with 130.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use clap::Parser;
use pyo3::prelude::*;

use loomlab::cli::run::{RunArgs, RunContext, run_with};

use crate::detectors::{PythonEntry, registry_with};

/// `loomlab run`'s arguments, parsed as the CLI parses them.
#[derive(Parser)]
#[command(
    name = "loomlab run",
    about = "Run a scenario suite closed-loop (see `loomlab run --help`)"
)]
struct RunCommand {
    #[command(flatten)]
    args: RunArgs,
}

/// Runs `f` on another thread while this one handles Python's signals; the first
/// KeyboardInterrupt (or other exception a signal handler raises) sets `stop` and is returned
/// with `f`'s result once `f` is done; a second one ends the process at once ([`second_interrupt`]).
pub(crate) fn interruptible<R: Send>(
    py: Python<'_>,
    stop: &Arc<AtomicBool>,
    f: impl FnOnce() -> R + Send,
) -> (R, Option<PyErr>) {
    let mut interrupt: Option<PyErr> = None;
    let result = py.detach(|| {
        std::thread::scope(|s| {
            let worker = s.spawn(f);
            while !worker.is_finished() {
                std::thread::sleep(Duration::from_millis(50));
                if let Err(e) = Python::attach(|py| py.check_signals()) {
                    if interrupt.is_some() {
                        second_interrupt();
                    }
                    stop.store(true, Ordering::SeqCst);
                    interrupt = Some(e);
                }
            }
            worker.join()
        })
    });
    match result {
        Ok(r) => (r, interrupt),
        Err(panic) => std::panic::resume_unwind(panic),
    }
}

/// A second interrupt while the work finishes: stop at once, as the CLI's second Ctrl-C does (a
/// run folder in progress is marked `interrupted` and its resume command printed), exit code 130.
fn second_interrupt() -> ! {
    match loomlab::cli::run_dir::abandon_active_run() {
        Some(cmd) => {
            eprintln!(
                "\nsecond interrupt: stopped; the finished episodes are saved in episodes.csv. Resume with:\n  {cmd}"
            )
        }
        None => eprintln!("\nsecond interrupt: stopped"),
    }
    // `_exit`, as the CLI: the workers are still running, and exit handlers (the software
    // renderer's LLVM) racing with them would abort the process instead of exiting with 130.
    // SAFETY: `_exit` only terminates the process.
    unsafe { libc::_exit(130) }
}

/// Runs `loomlab run ARGS…` in this process with the Python detectors `detectors`
/// (`loomlab.PythonDetector`s) added to every scenario's rows; returns the CLI's exit code (0 done,
/// 1 regressions, 2 bad input, 3 an output not written, 130 interrupted), printing what the CLI
/// prints, errors included. `command` is the command line a resume message shows.
#[pyfunction]
#[pyo3(signature = (args, detectors, command = None))]
pub fn run_cli(
    py: Python<'_>,
    args: Vec<String>,
    detectors: Vec<Bound<'_, PyAny>>,
    command: Option<Vec<String>>,
) -> PyResult<i32> {
    let parsed = match RunCommand::try_parse_from(std::iter::once("loomlab run".to_string()).chain(args)) {
        Ok(p) => p,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return Ok(code);
        }
    };
    let entries = detectors.iter().map(PythonEntry::read).collect::<PyResult<Vec<_>>>()?;
    let (registry, added_detectors) = registry_with(entries)?;
    let stop = Arc::new(AtomicBool::new(false));
    let context = RunContext {
        registry,
        added_detectors,
        stop: Some(Arc::clone(&stop)),
        command,
    };
    let (result, interrupt) = interruptible(py, &stop, move || run_with(parsed.args, context));
    Ok(match result {
        _ if interrupt.is_some() => 130,
        Ok(code) => code,
        // as the CLI reports it
        Err(e) => loomlab::cli::report_error(&e),
    })
}
