//! The session's run step: the episodes not finished yet, run in chunks; each finished episode's
//! plot samples, trace and rows are saved as it finishes (when the run has a folder).

use std::collections::BTreeSet;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use loomlab_report::exemplar::ExemplarRuns;
use loomlab_report::run_plots::{EpisodeSamples, PlotSamples, trace_file_name, write_trace};
use loomlab_scenarios::metrics::EpisodeOutcome;
use loomlab_scenarios::{EpisodeRun, EpisodeSpec, RunError, Runner};

use super::folder::{TRACES_DIR, Writers};
use super::heartbeat::Heartbeat;
use super::run_dir::{CannotWrite, append};
use super::{CHUNK, RunSession};

/// Work done by this invocation (for the summary lines).
#[derive(Debug, Default)]
pub(super) struct RunWork {
    /// Episodes run.
    pub episodes: usize,
    /// Frames rendered.
    pub frames: usize,
    /// Physics-only replays for the escape deadlines.
    pub replays: usize,
    /// Threat episodes with a deadline.
    pub deadlines: usize,
    /// Worker time spent on the deadlines (s).
    pub deadline_s: f64,
}

impl RunWork {
    fn add(&mut self, run: &EpisodeRun) {
        self.episodes += 1;
        self.frames += run.frames_rendered;
        self.deadline_s += run.deadline_s;
        if let Some(d) = &run.deadline {
            self.replays += d.replays;
            self.deadlines += 1;
        }
    }
}

/// What the run step leaves: every finished episode (earlier invocations' too, in run order) and
/// what this invocation kept of its own.
pub(super) struct Ran {
    /// Every finished episode's outcome, in the suite's order.
    pub outcomes: Vec<EpisodeOutcome>,
    /// The positions of the episodes an earlier invocation finished.
    pub resumed: BTreeSet<usize>,
    /// This invocation's plot samples.
    pub samples: PlotSamples,
    /// Runs kept for the page's exemplars.
    pub exemplar_runs: ExemplarRuns,
    /// This invocation's work.
    pub work: RunWork,
    /// When the episodes started.
    pub started: Instant,
}

impl RunSession {
    /// The run step: runs every episode of the run not in `done` (position, outcome), saving each
    /// as it finishes into `writers` (none: nothing is written), until all are done or the run is
    /// interrupted.
    pub(super) fn run_episodes(
        &self,
        runner: &Runner,
        writers: Option<&Writers>,
        done: Vec<(usize, EpisodeOutcome)>,
    ) -> anyhow::Result<Ran> {
        let r = &self.plan.request;
        let total = self.plan.total;
        let mut outcomes = done;
        let resumed: BTreeSet<usize> = outcomes.iter().map(|(p, _)| *p).collect();
        let bar = if r.quiet {
            indicatif::ProgressBar::hidden()
        } else {
            crate::cli::progress((total - resumed.len()) as u64, "episodes")
        };
        let started = Instant::now();
        let finished = Arc::new(AtomicUsize::new(0));
        let heartbeat = Heartbeat::unless_terminal(r.quiet, &finished, total - resumed.len(), "done");
        let mut samples = PlotSamples::default();
        let mut exemplar_runs = ExemplarRuns::default();
        let mut work = RunWork::default();
        let mut pending = self
            .plan
            .suite
            .episodes()
            .take(total)
            .enumerate()
            .filter(|(pos, _)| !resumed.contains(pos));
        let stop = self.interrupt.flag();
        while !self.interrupt.stopped() {
            let chunk: Vec<(usize, EpisodeSpec)> = pending
                .by_ref()
                .take(CHUNK)
                .map(|(pos, ep)| ep.map(|ep| (pos, ep)))
                .collect::<Result<_, _>>()?;
            if chunk.is_empty() {
                break;
            }
            let specs: Vec<&EpisodeSpec> = chunk.iter().map(|(_, ep)| ep).collect();
            let runs = runner
                .run_until(&specs, stop, |_, run| {
                    if let Some(w) = writers {
                        w.save(run, r.traces)?;
                    }
                    bar.inc(1);
                    finished.fetch_add(1, Ordering::Relaxed);
                    Ok(())
                })
                .map_err(|e| match (e, writers) {
                    (RunError::Callback(m), Some(w)) => anyhow::Error::msg(m).context(CannotWrite(format!(
                        "cannot save a finished episode in {}",
                        w.dir.dir.display()
                    ))),
                    (other, _) => other.into(),
                })?;
            for ((pos, _), run) in chunk.iter().zip(runs) {
                if let Some(run) = run {
                    samples.add(&run);
                    if !r.no_html && writers.is_some() {
                        exemplar_runs.offer(&run);
                    }
                    work.add(&run);
                    outcomes.push((*pos, run.outcome));
                }
            }
        }
        bar.finish_and_clear();
        drop(heartbeat);
        outcomes.sort_by_key(|(pos, _)| *pos);
        Ok(Ran {
            outcomes: outcomes.into_iter().map(|(_, o)| o).collect(),
            resumed,
            samples,
            exemplar_runs,
            work,
            started,
        })
    }
}

impl Writers {
    /// Saves a finished episode: its plot samples, its trace (with `--traces`), then its rows.
    fn save(&self, run: &EpisodeRun, traces: bool) -> Result<(), String> {
        // the samples first: an episode in episodes.csv always has its samples
        let line = EpisodeSamples::of(run).to_line() + "\n";
        append(
            &mut self.samples_file.lock().unwrap_or_else(|e| e.into_inner()),
            line.as_bytes(),
        )
        .map_err(|e| format!("cannot write {}: {e}", self.samples_path.display()))?;
        // the trace before the row: an episode in episodes.csv has its whole trace (one cut short
        // by a failure is written again when the episode runs again on --resume)
        if traces {
            let name = trace_file_name(&run.outcome.scenario, run.outcome.episode);
            self.dir
                .record(&format!("{TRACES_DIR}/{name}"))
                .map_err(|e| format!("{e:#}"))?;
            write_trace(&self.traces_dir, run)
                .map_err(|e| format!("cannot write {}: {e}", self.traces_dir.join(&name).display()))?;
        }
        self.csv
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .write_episode(&run.outcome)
            .map_err(|e| e.to_string())
    }
}
