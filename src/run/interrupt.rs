//! Stopping a run: the flag a caller passes in ([`Interrupt`]), set by the command line's Ctrl-C
//! handler or by the Python binding's KeyboardInterrupt, and what a second interrupt does.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use super::run_dir::ActiveRun;

/// How a run is stopped. The first interrupt ([`Interrupt::stop`]) lets no new episode start and
/// those in flight give up within about a second (they run again on `--resume`); the finished ones
/// are saved and the manifest says `interrupted`. A second one ([`Interrupt::second`]) exits at
/// once, recording the state `interrupted` first (finished episodes are already in episodes.csv).
#[derive(Debug, Clone, Default)]
pub struct Interrupt {
    stop: Arc<AtomicBool>,
    /// Set once every episode is done and the report is being written (the interrupt message).
    writing_report: Arc<AtomicBool>,
    /// The run folder in progress, for the second interrupt.
    active: ActiveRun,
    /// Whether the run installs the Ctrl-C / SIGTERM handler when it starts ([`Self::arm`]).
    handler: bool,
}

impl Interrupt {
    /// An interrupt the caller triggers itself ([`Self::stop`], [`Self::second`]).
    pub fn new() -> Self {
        Self::default()
    }

    /// The command line's: the run installs a Ctrl-C / SIGTERM handler when it starts.
    pub fn with_ctrlc_handler() -> Self {
        Self {
            handler: true,
            ..Self::default()
        }
    }

    /// The flag the workers watch.
    pub fn flag(&self) -> &Arc<AtomicBool> {
        &self.stop
    }

    /// Whether the run was asked to stop.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// The first interrupt: asks the run to stop; returns whether it had been asked already.
    pub fn stop(&self) -> bool {
        self.stop.swap(true, Ordering::SeqCst)
    }

    /// The run folder in progress (shared with its [`super::run_dir::RunDir`]).
    pub(super) fn active(&self) -> &ActiveRun {
        &self.active
    }

    /// Says that every episode is done and the report is being written.
    pub(super) fn writing_report(&self) {
        self.writing_report.store(true, Ordering::SeqCst);
    }

    /// The resume command of a run that stopped on an error (once).
    pub fn take_resume_hint(&self) -> Option<String> {
        self.active.take_resume_hint()
    }

    /// A second interrupt: stops at once (a run folder in progress is marked `interrupted` and its
    /// resume command printed), exit code 130.
    pub fn second(&self) -> ! {
        match self.active.abandon() {
            Some(cmd) => errln!(
                "\nsecond interrupt: stopped; the finished episodes are saved in episodes.csv. Resume with:\n  {cmd}"
            ),
            None => errln!("\nsecond interrupt: stopped"),
        }
        // `_exit`, not `std::process::exit`: the workers are still running, and exit handlers
        // (static destructors of the software renderer's LLVM) racing with a worker compiling a
        // shader abort the process ("CommandLine Error: Option ... registered more than once")
        // instead of exiting with 130. Everything that must survive is written already.
        // SAFETY: `_exit` only terminates the process.
        unsafe { libc::_exit(130) }
    }

    /// Installs the Ctrl-C / SIGTERM handler if this interrupt has one (the run calls it where an
    /// interrupt starts to be handled: before its episodes are checked).
    pub(super) fn arm(&self) {
        if !self.handler {
            return;
        }
        let this = self.clone();
        let installed = ctrlc::set_handler(move || {
            if this.stop() {
                this.second();
            }
            if this.writing_report.load(Ordering::SeqCst) {
                errln!("\ninterrupt: every episode is saved; stopping after the file being written ...");
            } else {
                errln!(
                    "\ninterrupt: stopping (finished episodes are saved; those in flight run again on --resume) ..."
                );
            }
        });
        if let Err(e) = installed {
            errln!("note: Ctrl-C will not stop the run cleanly: {e}");
        }
    }
}
