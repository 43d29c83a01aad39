//! `loomlab run` as a library: a [`RunSession`] runs a scenario suite closed-loop, scores it,
//! writes the report and plots and (with a baseline) checks it for regressions. The command line
//! (`cli::run`) and the Python package (`loomlab.run_suite`, `python -m loomlab run`) both fill a
//! [`RunRequest`] and run a session; neither goes through the other's arguments.
//!
//! The session goes plan → run → outputs → report → bless, one function each:
//! - plan ([`RunSession::new`], `plan.rs`): the request checked ([`RunRequest::check`], `request.rs`),
//!   the suite loaded, the baseline read;
//! - folder (`folder.rs`): the run's fingerprint and its folder prepared (`run_dir.rs`,
//!   `run_lock.rs`: refuse, resume or overwrite an earlier run);
//! - run (`episodes.rs`): the episodes not finished yet, each saved as it finishes;
//! - outputs (`outputs.rs`, `html.rs`): report.json (or report.partial.json), the plots, the page;
//! - report and bless (`summary.rs`): the tables printed, the baseline written or compared.
//!
//! Outputs in the run folder (`--out`, default `out/run`; a request without one writes nothing):
//! - `episodes.csv`: one row per episode × detector, appended and flushed as episodes finish, so an
//!   interrupted run keeps every finished episode;
//! - `report.json`: the suite report (design §7 keys, see `loomlab_scenarios::report`);
//! - `roc.png` (ROC curve per detector), `rates.png` (share of correct decisions per scenario and
//!   detector), `collisions.png` (collision rate per scenario and detector), `trace.png` (a sample
//!   threat episode: θ̂ and the true angular size over time, and every detector's response against
//!   the true angular size); with difficulty tiers, `tier_evasion.png` and `tier_false_alarms.png`
//!   (evasion and false-alarm rate per tier and row);
//! - `report.html` (unless `--no-html`): the page a person reads, with every table and plot and,
//!   per scenario, a few exemplary episodes (GIFs of the robot's view in `exemplars/`, traces);
//!   see `loomlab_report`.
//!
//! Exit codes ([`RunEnd::exit_code`], [`crate::cli::report_failure`]): 0 done (no regression), 1
//! regressions against the baseline (each one listed), 2 bad input (unreadable or invalid
//! scenario, unknown key, missing file, bad option), 3 an output could not be written (disk full,
//! permissions: the run stays resumable), 130 interrupted.

mod episodes;
mod folder;
mod heartbeat;
mod html;
mod interrupt;
mod outputs;
mod plan;
mod request;
pub mod run_dir;
pub mod run_lock;
mod summary;

use std::sync::Arc;

use loomlab_detector::Registry;
use loomlab_scenarios::Runner;
use loomlab_scenarios::report::Report;
use loomlab_scenarios::schema::DetectorDesc;
use loomlab_sim::GpuContext;

pub use interrupt::Interrupt;
pub use plan::RunPlan;
pub use request::{EntryTable, EntryValue, Field, RequestError, RunRequest};

/// Episodes expanded and run at a time (bounds memory; large enough that the workers rarely wait
/// at a chunk's end).
const CHUNK: usize = 1024;

/// What a caller adds to a [`RunRequest`]: the detectors its ids resolve to and how the run is
/// stopped.
#[derive(Default)]
pub struct RunContext {
    /// The detector registry the suite's ids resolve to (default: the built-in detectors).
    pub registry: Registry,
    /// Detector entries run in every scenario next to the suite's (or the request's) rows; their
    /// ids are in `registry` (the Python package's Python detectors).
    pub added_detectors: Vec<DetectorDesc>,
    /// How the run is stopped.
    pub interrupt: Interrupt,
}

/// How a session ended.
#[derive(Debug)]
// returned once per run: its size does not matter, and boxing the report would only add noise
#[allow(clippy::large_enum_variant)]
pub enum RunEnd {
    /// Every episode done and every output written.
    Complete {
        /// The run's report.
        report: Report,
        /// Regressions against the baseline (listed on stderr).
        regressions: usize,
    },
    /// Stopped by an interrupt (what is saved, and how to go on, printed).
    Interrupted,
}

impl RunEnd {
    /// The command line's exit code: 0 done, 1 regressions, 130 interrupted.
    pub fn exit_code(&self) -> i32 {
        match self {
            RunEnd::Complete { regressions: 0, .. } => 0,
            RunEnd::Complete { .. } => 1,
            RunEnd::Interrupted => 130,
        }
    }
}

/// A session that stopped on an error.
#[derive(Debug)]
pub struct RunFailure {
    /// What went wrong.
    pub error: anyhow::Error,
    /// How to resume the run, when its folder holds finished episodes.
    pub resume: Option<String>,
}

/// The runner and its GPU context (the page's exemplar GIFs are rendered on it).
pub(crate) struct Engine {
    runner: Arc<Runner>,
    gpu: Option<Arc<GpuContext>>,
}

/// One `loomlab run`: a [`RunPlan`] and how to stop it.
pub struct RunSession {
    plan: RunPlan,
    interrupt: Interrupt,
    runner: Option<Arc<Runner>>,
}

impl RunSession {
    /// The plan step: checks `request` and loads its suite; bad input is refused here, before
    /// anything is written.
    pub fn new(request: RunRequest, context: RunContext) -> anyhow::Result<Self> {
        let RunContext {
            registry,
            added_detectors,
            interrupt,
        } = context;
        let plan = RunPlan::new(request, registry, added_detectors)?;
        Ok(Self {
            plan,
            interrupt,
            runner: None,
        })
    }

    /// Runs a session without a run folder on `runner` (the Python package keeps one per
    /// process) instead of one of its own; its episodes in flight finish when interrupted.
    pub fn with_runner(mut self, runner: Arc<Runner>) -> Self {
        self.runner = Some(runner);
        self
    }

    /// The plan.
    pub fn plan(&self) -> &RunPlan {
        &self.plan
    }

    /// Runs the session: folder → run → outputs → report → bless.
    pub fn run(self) -> Result<RunEnd, RunFailure> {
        let interrupt = self.interrupt.clone();
        self.steps().map_err(|error| RunFailure {
            error,
            resume: interrupt.take_resume_hint(),
        })
    }

    fn steps(&self) -> anyhow::Result<RunEnd> {
        let opened = match &self.plan.request.out {
            Some(out) => match self.open_folder(out)? {
                Some(opened) => Some(opened),
                None => return Ok(RunEnd::Interrupted),
            },
            None => None,
        };
        let resumed = opened.as_ref().map_or(0, |o| o.done.len());
        if resumed > 0 && !self.plan.request.quiet {
            outln!(
                "resuming {}: {resumed} of {} episodes were done, running the other {}",
                opened
                    .as_ref()
                    .map_or_else(String::new, |o| o.dir.dir.display().to_string()),
                self.plan.total,
                self.plan.total - resumed
            );
        }
        let engine = self.engine()?;
        let r = &self.plan.request;
        let (mut writers, done) = match opened {
            Some(o) => {
                let (w, done) = o.writers(r.traces, r.resume)?;
                (Some(w), done)
            }
            None => (None, Vec::new()),
        };
        let ran = self.run_episodes(&engine.runner, writers.as_ref(), done)?;
        let meta = self.meta(writers.as_mut(), &ran);
        if ran.outcomes.len() < self.plan.total {
            self.save_interrupted(writers.as_mut(), &ran, &meta)?;
            return Ok(RunEnd::Interrupted);
        }
        let Some(written) = self.write_outputs(&engine, writers.as_mut(), &ran, &meta)? else {
            return Ok(RunEnd::Interrupted);
        };
        self.print_summary(&engine, &ran, &written);
        self.bless(written.report)
    }

    /// The runner: the caller's (a run without a folder), else one of the session's own whose
    /// episodes in flight give up when the run is interrupted.
    fn engine(&self) -> anyhow::Result<Engine> {
        if let (Some(runner), None) = (&self.runner, &self.plan.request.out) {
            return Ok(Engine {
                runner: Arc::clone(runner),
                gpu: None,
            });
        }
        let jobs = self.plan.request.workers();
        let gpu = GpuContext::new()?;
        let runner = Runner::with_context(Arc::clone(&gpu), jobs)?.with_cancel(Arc::clone(self.interrupt.flag()));
        if let Some(jobs) = jobs
            && jobs > runner.jobs()
            && !self.plan.request.quiet
        {
            errln!(
                "note: --jobs {jobs} clamped to {} (the number of CPUs, twice that when rendering on the CPU)",
                runner.jobs()
            );
        }
        Ok(Engine {
            runner: Arc::new(runner),
            gpu: Some(gpu),
        })
    }
}

#[cfg(test)]
mod tests {
    /// The length in lines of every function in `text` (from its `fn` line to the closing brace
    /// at the same indentation), with its name.
    fn function_lengths(text: &str) -> Vec<(usize, String)> {
        let lines: Vec<&str> = text.lines().collect();
        let mut found = Vec::new();
        for (i, line) in lines.iter().enumerate() {
            let body = line.trim_start();
            let indent = line.len() - body.len();
            let Some(rest) = ["fn ", "pub fn ", "pub(crate) fn ", "pub(super) fn "]
                .iter()
                .find_map(|p| body.strip_prefix(p))
            else {
                continue;
            };
            let close = format!("{}}}", " ".repeat(indent));
            if let Some(end) = lines[i..].iter().position(|l| l.trim_end() == close) {
                let name = rest.split(['(', '<']).next().unwrap_or(rest).to_string();
                found.push((end + 1, name));
            }
        }
        found
    }

    #[test]
    fn no_function_of_the_cli_the_run_session_or_the_runner_is_over_150_lines() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut counted = 0;
        for dir in ["src/cli", "src/run", "scenarios/src/runner"] {
            for entry in std::fs::read_dir(root.join(dir)).unwrap() {
                let path = entry.unwrap().path();
                if path.extension().is_some_and(|e| e == "rs") {
                    for (len, name) in function_lengths(&std::fs::read_to_string(&path).unwrap()) {
                        counted += 1;
                        assert!(len <= 150, "{}: fn {name} is {len} lines (at most 150)", path.display());
                    }
                }
            }
        }
        assert!(counted > 50, "only {counted} functions found");
        let long = format!("fn long() {{\n{}}}\n", "    x();\n".repeat(200));
        assert_eq!(function_lengths(&long), vec![(202, "long".to_string())]);
    }
}
