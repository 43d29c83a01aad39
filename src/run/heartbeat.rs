//! Progress lines on a non-terminal stderr (a log file, CI), where no progress bar is drawn.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

/// Seconds between two progress lines when stderr is not a terminal (no progress bar there);
/// the environment variable `LOOMLAB_PROGRESS_S` sets another interval (seconds, fractions
/// allowed: e.g. 60 for a log, 0.2 in a test).
const HEARTBEAT_S: f64 = 10.0;

/// Progress lines on a non-terminal stderr: `progress: 12 of 349 episodes done in 1 min 20 s`,
/// every [`HEARTBEAT_S`] seconds (or `LOOMLAB_PROGRESS_S`) while episodes run, even inside one
/// long episode.
pub(super) struct Heartbeat {
    done: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Heartbeat {
    /// Starts the lines: `finished` of `todo` episodes `what` (`done`, `checked`).
    pub(super) fn start(finished: Arc<AtomicUsize>, todo: usize, what: &'static str) -> Self {
        let done = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&done);
        let every = std::env::var("LOOMLAB_PROGRESS_S")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|s| s.is_finite() && *s > 0.0)
            .unwrap_or(HEARTBEAT_S);
        let poll = std::time::Duration::from_secs_f64(every.clamp(0.01, 0.2));
        let thread = std::thread::spawn(move || {
            let started = Instant::now();
            let mut next = every;
            while !flag.load(Ordering::SeqCst) {
                std::thread::park_timeout(poll);
                let elapsed = started.elapsed().as_secs_f64();
                if elapsed >= next && !flag.load(Ordering::SeqCst) {
                    next = elapsed + every;
                    let secs = elapsed as u64;
                    errln!(
                        "progress: {} of {todo} episodes {what} in {} min {} s",
                        finished.load(Ordering::Relaxed),
                        secs / 60,
                        secs % 60
                    );
                }
            }
        });
        Self {
            done,
            thread: Some(thread),
        }
    }

    /// Progress lines unless `quiet` or stderr is a terminal (which shows the bar instead).
    pub(super) fn unless_terminal(
        quiet: bool,
        finished: &Arc<AtomicUsize>,
        todo: usize,
        what: &'static str,
    ) -> Option<Self> {
        (!quiet && !std::io::IsTerminal::is_terminal(&std::io::stderr()))
            .then(|| Self::start(Arc::clone(finished), todo, what))
    }
}

impl Drop for Heartbeat {
    fn drop(&mut self) {
        self.done.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}
