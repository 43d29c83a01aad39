//! `loomlab run [SUITE]`: the command line of a [`RunSession`]. Its flags ([`RunArgs`]) become a
//! [`RunRequest`] (no checking here: the session refuses bad input, the same for every caller),
//! the session runs with the Ctrl-C handler, and its end becomes the exit code (see
//! [`crate::run`] for the outputs and the codes).

use std::path::PathBuf;

use clap::Args;

use crate::run::{Interrupt, RunContext, RunRequest, RunSession};

/// Arguments of `loomlab run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Suite: a folder of scenario files, a list file (TOML with `scenarios = [...]`) or one
    /// scenario file. Default: the default suite, scenarios/suites/default.
    #[arg(value_name = "SUITE")]
    pub suite: Option<PathBuf>,
    /// Output folder for report.json, episodes.csv and the plots (created if missing). A folder
    /// holding an earlier run is refused unless --resume or --overwrite is given.
    #[arg(long, short, default_value = "out/run", value_name = "DIR")]
    pub out: PathBuf,
    /// Compare with this baseline report.json: exit 1 listing every regression.
    #[arg(long, value_name = "FILE")]
    pub baseline: Option<PathBuf>,
    /// Write this run's report to the --baseline file instead of comparing.
    #[arg(long, requires = "baseline")]
    pub bless: bool,
    /// Run only these detectors (comma-separated ids, or `all`), with the scenarios' settings for
    /// them where given.
    #[arg(long, value_name = "ID[,ID...]|all")]
    pub detectors: Option<String>,
    /// Run the `[[detectors]]` entries of this TOML file instead of each scenario's own list (the
    /// scenario syntax: id, label, threshold, trigger, params). A sweep writes one such file per
    /// parameter point, so `loomlab run SUITE --detectors-file points/<label>/detectors.toml`
    /// reruns that point. Combines with --detectors (filters the file's entries by id).
    #[arg(long, value_name = "FILE")]
    pub detectors_file: Option<PathBuf>,
    /// Episodes run in parallel (default and most: the number of CPUs, twice that when frames are
    /// rendered on the CPU, e.g. by lavapipe without a GPU).
    #[arg(long, short)]
    pub jobs: Option<usize>,
    /// Suite seed mixed into every scenario's seed (0: the files' seeds as written).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Frame size n for every episode (overrides world.camera.n).
    #[arg(long, value_name = "N")]
    pub size: Option<u32>,
    /// Run every world under this sensor profile (`ideal`, `robot`, `events`): the camera's sensor (blur,
    /// noise, quantisation) and the perception and actuation latencies; overrides the suite's
    /// `sensor` key and the scenario files' own (docs/reference.md#sensor-profiles).
    #[arg(long, value_name = "PROFILE")]
    pub sensor: Option<String>,
    /// Run only the scenarios of these difficulty tiers (comma-separated, 0 to 3: 0 the paper's
    /// conditions, 1 static clutter, 2 ego-motion, 3 hard; a file's top-level `tier`). Scenarios
    /// without a tier are left out. Applied before --limit.
    #[arg(long, value_name = "N[,M...]")]
    pub tier: Option<String>,
    /// Run only the first N episodes of the suite (quick checks).
    #[arg(long, value_name = "N")]
    pub limit: Option<usize>,
    /// Continue the run in --out (after an interruption): only its missing episodes run, then the
    /// report is built from all of them. The suite and options must be the same (checked).
    #[arg(long, conflicts_with = "overwrite")]
    pub resume: bool,
    /// Replace the run in --out (its files are deleted first; nothing else in the folder is).
    #[arg(long)]
    pub overwrite: bool,
    /// Print only regressions and errors (no progress bar, no table).
    #[arg(long, short)]
    pub quiet: bool,
    /// Print only the pooled table, not one table per scenario.
    #[arg(long)]
    pub brief: bool,
    /// Also write every episode's open-loop trace to DIR/traces/SCENARIO_EPISODE.csv (time,
    /// true angular size and TTC of the reference object, each detector's trigger signal and output).
    #[arg(long)]
    pub traces: bool,
    /// Do not draw the PNG plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Do not write report.html (and its exemplar GIFs: up to 3 episodes per scenario rendered
    /// again after the run).
    #[arg(long)]
    pub no_html: bool,
    /// Also print, per detector, the smallest threshold with at most this false-alarm rate over
    /// the run's non-threat episodes (e.g. 0.1); run it with another --seed than the one you report.
    #[arg(long, value_name = "FA_RATE")]
    pub calibrate: Option<f64>,
}

impl RunArgs {
    /// The request these flags make (`--detectors a,b` split at the commas); `command` is the
    /// command line a resume message shows (`None`: this process's).
    pub fn into_request(self, command: Option<Vec<String>>) -> RunRequest {
        let count = |n: usize| i64::try_from(n).unwrap_or(i64::MAX);
        RunRequest {
            suite: self.suite,
            out: Some(self.out),
            baseline: self.baseline,
            bless: self.bless,
            detectors: self
                .detectors
                .map(|spec| spec.split(',').map(|s| s.trim().to_string()).collect()),
            detectors_file: self.detectors_file,
            detector_entries: Vec::new(),
            jobs: self.jobs.map(count),
            seed: self.seed,
            size: self.size.map(i64::from),
            sensor: self.sensor,
            tier: self.tier,
            limit: self.limit.map(count),
            resume: self.resume,
            overwrite: self.overwrite,
            quiet: self.quiet,
            brief: self.brief,
            traces: self.traces,
            no_plots: self.no_plots,
            no_html: self.no_html,
            calibrate: self.calibrate,
            command,
        }
    }
}

/// Runs `loomlab run` (the Ctrl-C handler installed when the run starts); returns the exit code,
/// having printed an error the session stopped on.
pub fn run(args: RunArgs) -> anyhow::Result<i32> {
    let context = RunContext {
        interrupt: Interrupt::with_ctrlc_handler(),
        ..RunContext::default()
    };
    run_session(args.into_request(None), context)
}

/// Runs the session `request` and `context` make; returns the exit code, having printed an error
/// it stopped on (with how to resume) as the command line does.
pub fn run_session(request: RunRequest, context: RunContext) -> anyhow::Result<i32> {
    let session = RunSession::new(request, context)?;
    Ok(match session.run() {
        Ok(end) => end.exit_code(),
        Err(failure) => super::report_failure(&failure.error, failure.resume.as_deref()),
    })
}
