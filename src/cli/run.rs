//! `loomlab run [SUITE]`: run a scenario suite closed-loop, score it, write the report and plots,
//! and (with `--baseline`) check it for regressions.
//!
//! Outputs in `--out` (default `out/run`):
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
//! Exit codes: 0 done (no regression), 1 regressions against `--baseline` (each one listed),
//! 2 bad input (unreadable or invalid scenario, unknown key, missing file, bad option), 3 an
//! output could not be written (disk full, permissions: the run stays resumable), 130 interrupted.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use loomlab_detector::Registry;
use loomlab_detector::parse_detector_list;
use loomlab_scenarios::fingerprint::Fingerprint;
use loomlab_scenarios::metrics::EpisodeOutcome;
use loomlab_scenarios::reference::REFERENCE_LABELS;
use loomlab_scenarios::regression::{Tolerances, compare};
use loomlab_scenarios::report::{LOOMLAB_VERSION, Report, ReportMeta};
use loomlab_scenarios::schema::{DetectorDesc, Scenario, load_detector_entries};
use loomlab_scenarios::{DEFAULT_SUITE, EpisodeRun, EpisodeSpec, LoadOptions, Runner, Suite, load_suite};

use super::run_dir::{
    CannotWrite, EPISODES_CSV, Existing, Manifest, Outputs, PARTIAL_REPORT, Prepared, REPORT, RunDir, RunState, append,
    open_append, write_atomic,
};
use loomlab_report::exemplar::{self, ExemplarRuns};
use loomlab_report::page::RunPage;
use loomlab_report::run_plots::{EpisodeSamples, PlotSamples, run_figures, trace_file_name, write_trace};
use loomlab_report::{EXEMPLARS_DIR, REPORT_HTML};
use loomlab_sim::GpuContext;
use rayon::prelude::*;

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

/// The default suite: `scenarios/suites/default` under the working directory, else under the
/// source tree this binary was built from.
fn default_suite() -> PathBuf {
    let here = PathBuf::from(DEFAULT_SUITE);
    if here.exists() {
        return here;
    }
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_SUITE);
    if built.exists() { built } else { here }
}

/// Every finished episode's plot samples (θ̂ points, sample rank), one JSON line each: a resumed
/// run draws its plots from all of them, the same as an uninterrupted run's.
const PLOT_SAMPLES: &str = "plot_samples.jsonl";

/// The folder of `--traces`.
const TRACES_DIR: &str = "traces";

/// Every plot a run may draw (`NAME.png`, see `loomlab_report::run_plots::run_figures`).
const FIGURES: [&str; 9] = [
    "roc",
    "rates",
    "collisions",
    "lv",
    "theta_required",
    "theta_hat",
    "trace",
    "tier_evasion",
    "tier_false_alarms",
];

/// Suites of at least this many episodes show a progress bar while they are checked.
const CHECK_PROGRESS_FROM: usize = 100_000;

/// Episodes expanded and run at a time (bounds memory; large enough that the workers rarely wait
/// at a chunk's end).
const CHUNK: usize = 1024;

/// What a caller embedding `loomlab run` adds (the Python package: its Python detectors, its own
/// Ctrl-C handling). The default is the command line's.
#[derive(Debug, Default)]
pub struct RunContext {
    /// The detector registry the suite's ids resolve to (default: the built-in detectors).
    pub registry: Registry,
    /// Detector entries run in every scenario next to the suite's (or `--detectors`' /
    /// `--detectors-file`'s) rows; their ids are in `registry`.
    pub added_detectors: Vec<DetectorDesc>,
    /// Set to stop the run as the first Ctrl-C does (`None`: install the Ctrl-C handler).
    pub stop: Option<Arc<AtomicBool>>,
    /// The command to print for resuming (`None`: this process's command line).
    pub command: Option<Vec<String>>,
}

/// Runs `loomlab run`.
pub fn run(args: RunArgs) -> anyhow::Result<i32> {
    run_with(args, RunContext::default())
}

/// Runs `loomlab run` with what an embedding caller adds ([`RunContext`]); returns the exit code.
pub fn run_with(args: RunArgs, context: RunContext) -> anyhow::Result<i32> {
    let detectors: Option<Vec<String>> = match &args.detectors {
        Some(spec) => Some(parse_detector_list(spec)?.into_iter().map(String::from).collect()),
        None => None,
    };
    if args.jobs == Some(0) {
        bail!("--jobs must be at least 1");
    }
    if let Some(n) = args.size
        && !(loomlab_sim::MIN_FRAME_SIZE..=loomlab_sim::MAX_N).contains(&n)
    {
        bail!(
            "--size {n}: must be in {}..={} pixels (the detectors need frames of at least {0}×{0})",
            loomlab_sim::MIN_FRAME_SIZE,
            loomlab_sim::MAX_N
        );
    }
    if let Some(fa) = args.calibrate
        && !(0.0..=1.0).contains(&fa)
    {
        bail!("--calibrate takes a false-alarm rate in [0, 1], got {fa}");
    }
    let detector_entries = match &args.detectors_file {
        Some(path) => Some(load_detector_entries(path)?),
        None => None,
    };
    // --detectors filters a detectors file's entries: every id must be there
    if let (Some(ids), Some(entries), Some(path)) = (&detectors, &detector_entries, &args.detectors_file) {
        for id in ids {
            if !entries.iter().any(|e| &e.id == id) {
                let have: BTreeSet<&str> = entries.iter().map(|e| e.id.as_str()).collect();
                bail!(
                    "--detectors {id}: {} has no `{id}` entry (it has {}); --detectors only filters the file's entries",
                    path.display(),
                    have.into_iter().collect::<Vec<_>>().join(", ")
                );
            }
        }
    }
    let opts = LoadOptions {
        seed: args.seed,
        size: args.size,
        detectors,
        detector_entries,
        added_detectors: context.added_detectors,
        registry: context.registry,
    };
    let suite_path = args.suite.clone().unwrap_or_else(default_suite);
    let mut suite = load_suite(&suite_path, &opts)?;
    if let Some(spec) = &args.tier {
        let tiers = loomlab_scenarios::tier::parse_tier_list(spec).map_err(anyhow::Error::msg)?;
        suite.retain_tiers(&tiers)?;
    }
    let tiers = suite.tiers();
    // Read the baseline before spending time on the run (a missing file is bad input).
    let baseline = match (&args.baseline, args.bless) {
        (Some(p), false) => Some(Report::read_json(p)?),
        _ => None,
    };

    // The run: the suite's first `limit` episodes.
    let suite_total: usize = suite.scenarios.iter().map(|s| s.len()).fold(0, usize::saturating_add);
    let total = suite_total.min(args.limit.unwrap_or(usize::MAX));
    let lead_margin_s = match suite.episodes().take(total).next() {
        Some(ep) => ep?.scoring.lead_margin_s,
        None => bail!("{}: no episodes to run", suite_path.display()),
    };
    // A baseline is of the same suite and selection, or comparing (or replacing) it means nothing.
    let mut counts: BTreeMap<&str, u64> = BTreeMap::new();
    let mut left = total;
    for s in &suite.scenarios {
        let n = s.len().min(left);
        if n > 0 {
            counts.insert(s.name.as_str(), n as u64);
        }
        left -= n;
    }
    if let Some(path) = &args.baseline {
        if args.bless && total < suite_total {
            bail!(
                "--bless with --limit {total}: the baseline would hold only {total} of the suite's {suite_total} episodes; \
                 bless the whole suite (drop --limit)"
            );
        }
        let existing = match &baseline {
            Some(b) => Some(b.clone()),
            // --bless replaces a baseline only with a run of the same suite
            None if path.exists() => Report::read_json(path).ok(),
            None => None,
        };
        if let Some(base) = existing
            && let Err(why) = same_suite(&base, &counts, args.seed)
        {
            let what = if args.bless {
                format!(
                    "refusing to replace it (delete {} first to start a new baseline)",
                    path.display()
                )
            } else {
                "compare with a baseline of the same suite, --seed and --limit".to_string()
            };
            bail!(
                "--baseline {}: a baseline of another suite or selection ({why}); {what}",
                path.display()
            );
        }
    }

    // The output folder: refuse to touch an earlier run unless told to resume or overwrite it.
    let offsets: BTreeMap<&str, (usize, &Scenario)> = suite
        .scenarios
        .iter()
        .scan(0usize, |offset, s| {
            let here = *offset;
            *offset += s.len();
            Some((s.name.as_str(), (here, s)))
        })
        .collect();
    let position = |scenario: &str, episode: usize| -> Option<usize> {
        let (offset, s) = offsets.get(scenario)?;
        (episode < s.len() && offset + episode < total).then_some(offset + episode)
    };
    let labels = |scenario: &str, episode: usize| -> Option<BTreeSet<String>> {
        position(scenario, episode)?;
        let spec = offsets[scenario].1.episode(episode).ok()?;
        Some(
            spec.detectors
                .iter()
                .map(|d| d.label.clone())
                .chain(REFERENCE_LABELS.iter().map(|l| l.to_string()))
                .collect(),
        )
    };
    let existing = match (args.resume, args.overwrite) {
        (true, _) => Existing::Resume,
        (false, true) => Existing::Overwrite,
        (false, false) => Existing::Refuse,
    };
    let mut manifest = Manifest::new(String::new(), &suite_path, total);
    manifest.traces = args.traces;
    if let Some(command) = context.command {
        manifest.command = command;
    }
    // the handler first: an interrupt while the episodes are checked, and from the moment the
    // manifest says `running`, is handled
    let stop = match context.stop {
        Some(stop) => stop,
        None => interrupt_flag(),
    };
    // a folder in use by another run is refused before the (possibly long) check
    let lock = if args.out.is_dir() {
        Some(super::run_lock::RunLock::acquire(&args.out)?)
    } else {
        None
    };
    // Check every episode to run and fingerprint them, unless --resume continues a run of the
    // same definition (checked when it started): a resume costs O(its finished episodes).
    manifest.definition = definition_fingerprint(&suite, total)?;
    manifest.fingerprint = match run_fingerprint(&args, &suite, &manifest, &stop)? {
        Some(fingerprint) => fingerprint,
        None => return Ok(130),
    };
    let is_episode_file = |name: &str, ext: &str| -> bool {
        let Some((scenario, index)) = name.strip_suffix(ext).and_then(|stem| stem.rsplit_once('_')) else {
            return false;
        };
        index
            .parse::<usize>()
            .is_ok_and(|i| format!("{i:04}") == index && position(scenario, i).is_some())
    };
    let is_trace = |name: &str| is_episode_file(name, ".csv");
    let is_gif = |name: &str| is_episode_file(name, ".gif");
    let outputs = Outputs {
        files: output_files(&args),
        folders: [
            (args.traces).then_some((TRACES_DIR, &is_trace as &dyn Fn(&str) -> bool)),
            (!args.no_html).then_some((EXEMPLARS_DIR, &is_gif as &dyn Fn(&str) -> bool)),
        ]
        .into_iter()
        .flatten()
        .collect(),
    };
    let Prepared {
        dir: mut run_dir,
        done,
        csv,
    } = RunDir::prepare(&args.out, manifest, existing, &outputs, lock, labels)?;
    let out = run_dir.dir.clone();
    let mut outcomes: Vec<(usize, EpisodeOutcome)> = done
        .into_iter()
        .filter_map(|o| Some((position(&o.scenario, o.episode)?, o)))
        .collect();
    let resumed: BTreeSet<usize> = outcomes.iter().map(|(p, _)| *p).collect();
    if !resumed.is_empty() && !args.quiet {
        outln!(
            "resuming {}: {} of {total} episodes were done, running the other {}",
            out.display(),
            resumed.len(),
            total - resumed.len()
        );
    }

    let gpu = GpuContext::new()?;
    let runner = Runner::with_context(Arc::clone(&gpu), args.jobs)?.with_cancel(Arc::clone(&stop));
    if let Some(jobs) = args.jobs
        && jobs > runner.jobs()
        && !args.quiet
    {
        errln!(
            "note: --jobs {jobs} clamped to {} (the number of CPUs, twice that when rendering on the CPU)",
            runner.jobs()
        );
    }
    let csv = Mutex::new(csv);
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        super::progress((total - resumed.len()) as u64, "episodes")
    };
    let started = Instant::now();
    let finished = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let heartbeat = (!args.quiet && !std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .then(|| Heartbeat::start(Arc::clone(&finished), total - resumed.len(), "done"));
    let traces_dir = if args.traces {
        run_dir.create_dir(TRACES_DIR)?
    } else {
        out.join(TRACES_DIR)
    };
    // every finished episode's plot samples, kept so that a resumed run draws the same plots
    run_dir.record(PLOT_SAMPLES)?;
    let samples_path = out.join(PLOT_SAMPLES);
    let samples_file = open_append(&samples_path)
        .and_then(|f| {
            if !args.resume {
                f.set_len(0)?;
            }
            Ok(f)
        })
        .with_context(|| CannotWrite(format!("cannot write {}", samples_path.display())))?;
    let samples_file = Mutex::new(samples_file);
    let mut samples = PlotSamples::default();
    let mut exemplar_runs = ExemplarRuns::default();
    let mut work = RunWork::default();
    let mut pending = suite
        .episodes()
        .take(total)
        .enumerate()
        .filter(|(pos, _)| !resumed.contains(pos));
    while !stop.load(Ordering::SeqCst) {
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
            .run_until(&specs, &stop, |_, run| {
                // the samples first: an episode in episodes.csv always has its samples
                {
                    let line = EpisodeSamples::of(run).to_line() + "\n";
                    append(
                        &mut samples_file.lock().unwrap_or_else(|e| e.into_inner()),
                        line.as_bytes(),
                    )
                    .map_err(|e| format!("cannot write {}: {e}", samples_path.display()))?;
                }
                // the trace before the row: an episode in episodes.csv has its whole trace (one cut
                // short by a failure is written again when the episode runs again on --resume)
                if args.traces {
                    let name = trace_file_name(&run.outcome.scenario, run.outcome.episode);
                    run_dir
                        .record(&format!("{TRACES_DIR}/{name}"))
                        .map_err(|e| format!("{e:#}"))?;
                    write_trace(&traces_dir, run)
                        .map_err(|e| format!("cannot write {}: {e}", traces_dir.join(&name).display()))?;
                }
                csv.lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .write_episode(&run.outcome)
                    .map_err(|e| e.to_string())?;
                bar.inc(1);
                finished.fetch_add(1, Ordering::Relaxed);
                Ok(())
            })
            .map_err(|e| match e {
                loomlab_scenarios::RunError::Callback(m) => anyhow::Error::msg(m).context(CannotWrite(format!(
                    "cannot save a finished episode in {}",
                    out.display()
                ))),
                other => other.into(),
            })?;
        for ((pos, _), run) in chunk.iter().zip(runs) {
            if let Some(run) = run {
                samples.add(&run);
                if !args.no_html {
                    exemplar_runs.offer(&run);
                }
                work.add(&run);
                outcomes.push((*pos, run.outcome));
            }
        }
    }
    bar.finish_and_clear();
    drop(heartbeat);
    let wall_time_s = run_dir.manifest.wall_time_s + started.elapsed().as_secs_f64();
    outcomes.sort_by_key(|(pos, _)| *pos);
    let outcomes: Vec<EpisodeOutcome> = outcomes.into_iter().map(|(_, o)| o).collect();
    let meta = ReportMeta {
        suite: suite_path.display().to_string(),
        seed: args.seed,
        wall_time_s,
        lead_margin_s,
    };
    run_dir.manifest.wall_time_s = wall_time_s;

    if outcomes.len() < total {
        // interrupted: keep what is done, say how to go on
        if !outcomes.is_empty() {
            let partial = Report::from_tiered_episodes(&meta, &outcomes, &tiers);
            run_dir.record(PARTIAL_REPORT)?;
            write_atomic(&out.join(PARTIAL_REPORT), (partial.to_json() + "\n").as_bytes())?;
        }
        run_dir.set_state(RunState::Interrupted)?;
        errln!(
            "interrupted: {} of {total} episodes done ({} this time), saved in {}; {} holds their scores. Resume with:\n  {}",
            outcomes.len(),
            work.episodes,
            out.join(EPISODES_CSV).display(),
            if outcomes.is_empty() {
                "nothing yet"
            } else {
                PARTIAL_REPORT
            },
            run_dir.manifest.resume_command()
        );
        return Ok(130);
    }

    let report = Report::from_tiered_episodes(&meta, &outcomes, &tiers);
    let report_path = out.join(REPORT);
    run_dir.record(REPORT)?;
    write_atomic(&report_path, (report.to_json() + "\n").as_bytes())?;
    let _ = std::fs::remove_file(out.join(PARTIAL_REPORT));
    // every episode is done: an interrupt now stops the report writing (the run stays resumable)
    WRITING_REPORT.store(true, Ordering::SeqCst);
    let stopped = |run_dir: &mut RunDir| -> anyhow::Result<Option<i32>> {
        if !stop.load(Ordering::SeqCst) {
            return Ok(None);
        }
        run_dir.set_state(RunState::Interrupted)?;
        errln!(
            "interrupted while writing the report: all {total} episodes are saved in {}. Write the rest with:\n  {}",
            out.join(EPISODES_CSV).display(),
            run_dir.manifest.resume_command()
        );
        Ok(Some(130))
    };
    if let Some(code) = stopped(&mut run_dir)? {
        return Ok(code);
    }
    // the plots' samples from every episode, this invocation's and earlier ones' (in suite order)
    let samples = {
        let text = std::fs::read_to_string(&samples_path)
            .with_context(|| CannotWrite(format!("cannot read {}", samples_path.display())))?;
        let mut by_pos: BTreeMap<usize, EpisodeSamples> = BTreeMap::new();
        for line in text.lines() {
            if let Some(es) = EpisodeSamples::from_line(line)
                && let Some(p) = position(&es.scenario, es.episode)
            {
                by_pos.insert(p, es); // a later line (an episode run again) replaces an earlier one
            }
        }
        let mut all = PlotSamples::default();
        for es in by_pos.values() {
            all.add_points(es);
        }
        // the sample episode (trace.png, the page's trace plot), unless nothing is drawn
        if let Some(best) = by_pos.values().min_by_key(|es| es.rank)
            && !(args.no_plots && args.no_html)
        {
            let live = samples
                .sample()
                .filter(|r| r.outcome.scenario == best.scenario && r.outcome.episode == best.episode);
            let run = match live {
                Some(r) => r.clone(),
                // the sample episode ran in an earlier invocation: simulate it again (deterministic)
                None => match runner.run_episode(&offsets[best.scenario.as_str()].1.episode(best.episode)?) {
                    Ok(r) => r,
                    Err(e) => {
                        if let Some(code) = stopped(&mut run_dir)? {
                            return Ok(code);
                        }
                        return Err(e.into());
                    }
                },
            };
            all.set_sample(run);
        }
        all
    };
    if !args.no_plots {
        for f in run_figures(&report, &outcomes, Some(&samples)) {
            // through a temporary file (same extension: the encoder goes by it), listed first
            let name = format!("{}.png", f.name);
            let tmp = format!(".{}.tmp.png", f.name);
            run_dir.record(&name)?;
            run_dir.record(&tmp)?;
            f.write_png(&out.join(&tmp))
                .with_context(|| CannotWrite(format!("cannot write {}", out.join(&name).display())))?;
            std::fs::rename(out.join(&tmp), out.join(&name))
                .with_context(|| CannotWrite(format!("cannot write {}", out.join(&name).display())))?;
            if let Some(code) = stopped(&mut run_dir)? {
                return Ok(code);
            }
        }
    }
    let html = if args.no_html {
        None
    } else {
        let started_html = Instant::now();
        let page = Html {
            run_dir: &run_dir,
            out: &out,
            report: &report,
            outcomes: &outcomes,
            samples: &samples,
            exemplar_runs: &exemplar_runs,
            baseline: match (&args.baseline, &baseline) {
                (Some(p), Some(b)) => Some((p.display().to_string(), b)),
                _ => None,
            },
        };
        let rerun = |scenario: &str, episode: usize| -> anyhow::Result<EpisodeRun> {
            let (_, s) = offsets
                .get(scenario)
                .with_context(|| format!("exemplar: scenario `{scenario}` is not in the suite"))?;
            Ok(runner.run_episode(&s.episode(episode)?)?)
        };
        let spec = |scenario: &str, episode: usize| -> anyhow::Result<EpisodeSpec> {
            let (_, s) = offsets
                .get(scenario)
                .with_context(|| format!("exemplar: scenario `{scenario}` is not in the suite"))?;
            Ok(s.episode(episode)?)
        };
        let written = page.write(&gpu, &rerun, &spec);
        if written.is_err()
            && let Some(code) = stopped(&mut run_dir)?
        {
            return Ok(code);
        }
        let (path, rerun_count, exemplars) = written?;
        Some((path, started_html.elapsed().as_secs_f64(), rerun_count, exemplars))
    };
    if let Some(code) = stopped(&mut run_dir)? {
        return Ok(code);
    }
    run_dir.set_state(RunState::Complete)?;

    if !args.quiet {
        outln!("{}", report.format_table(!args.brief).trim_end());
        outln!(
            "\nescape deadlines: {} physics-only replays for {} threats, {:.1} s of worker time",
            work.replays,
            work.deadlines,
            work.deadline_s
        );
        let earlier = if resumed.is_empty() {
            String::new()
        } else {
            format!(" (plus {} episodes from the earlier run)", resumed.len())
        };
        outln!(
            "\n{} episodes{earlier}, {} frames rendered in {:.1} s on {} ({} workers)",
            work.episodes,
            work.frames,
            started.elapsed().as_secs_f64(),
            runner.adapter(),
            runner.jobs()
        );
        if args.no_plots {
            outln!(
                "wrote {} and episodes.csv (no plots: --no-plots)",
                report_path.display()
            );
        } else {
            outln!(
                "wrote {} and episodes.csv, plots in {}",
                report_path.display(),
                out.display()
            );
        }
        if let Some((path, secs, rerun, exemplars)) = &html {
            let again = if *rerun > 0 {
                format!(", {rerun} of them from the earlier run simulated again")
            } else {
                String::new()
            };
            outln!(
                "wrote {} in {secs:.1} s ({:.1} % of this run's {:.1} s; {exemplars} exemplary episodes{again})",
                path.display(),
                100.0 * secs / started.elapsed().as_secs_f64(),
                started.elapsed().as_secs_f64()
            );
        }
    }
    if let Some(target) = args.calibrate {
        outln!();
        super::calibrate::print_calibrations(&outcomes, target, "this run's non-threat episodes");
    }

    if let Some(path) = &args.baseline {
        if args.bless {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
            }
            report.write_json(path)?;
            if !args.quiet {
                outln!("baseline written to {}", path.display());
            }
        } else if let Some(base) = &baseline {
            let regressions = compare(&report, base, &Tolerances::default());
            if !regressions.is_empty() {
                errln!("{} regression(s) against {}:", regressions.len(), path.display());
                for r in &regressions {
                    errln!("  {r}");
                }
                return Ok(1);
            }
            if !args.quiet {
                outln!("no regression against {}", path.display());
            }
        }
    }
    Ok(0)
}

/// The top-level files the run may write in its folder (checked before it starts; the sub-folders'
/// files are checked by name).
fn output_files(args: &RunArgs) -> Vec<String> {
    let mut files: Vec<String> = [EPISODES_CSV, REPORT, PARTIAL_REPORT, PLOT_SAMPLES]
        .map(String::from)
        .to_vec();
    if !args.no_html {
        files.push(REPORT_HTML.into());
    }
    if !args.no_plots {
        for f in FIGURES {
            files.push(format!("{f}.png"));
            files.push(format!(".{f}.tmp.png"));
        }
    }
    files
}

/// The fingerprint of the run's definition: the version, its number of episodes and every
/// scenario as loaded (see [`Fingerprint::add_definition`]). O(scenarios), not O(episodes).
fn definition_fingerprint(suite: &Suite, total: usize) -> anyhow::Result<String> {
    let mut f = Fingerprint::new();
    f.add(format!("{LOOMLAB_VERSION}\nloomlab run definition\n{total}\n").as_bytes());
    for s in &suite.scenarios {
        f.add_definition(s)?;
    }
    Ok(f.hex())
}

/// The fingerprint of the run `manifest` describes: the one of the run in `--out` when `--resume`
/// continues a run of the same definition (its episodes were checked when it started), else every
/// episode checked and fingerprinted now. `None`: interrupted while checking (the message printed).
fn run_fingerprint(
    args: &RunArgs,
    suite: &Suite,
    manifest: &Manifest,
    stop: &AtomicBool,
) -> anyhow::Result<Option<String>> {
    let earlier = if args.resume {
        Manifest::read(&args.out).ok().flatten()
    } else {
        None
    };
    if let Some(m) = earlier.filter(|m| m.definition == manifest.definition && m.episodes == manifest.episodes) {
        if !args.quiet {
            errln!(
                "the suite is defined as when the run started: its {} episodes were checked then, not again",
                manifest.episodes
            );
        }
        return Ok(Some(m.fingerprint));
    }
    let checked = check_episodes(suite, manifest.episodes, stop, args.quiet)?;
    if checked.is_none() {
        errln!(
            "interrupted while checking the suite's episodes: nothing was run{}",
            if args.resume {
                format!(
                    "; the run in {} is unchanged. Resume with:\n  {}",
                    args.out.display(),
                    manifest.resume_command()
                )
            } else {
                " or written".to_string()
            }
        );
    }
    Ok(checked)
}

/// Expands and checks the run's `total` episodes one at a time (none is kept) and returns their
/// fingerprint; `None` when interrupted (Ctrl-C) first. A suite of millions of episodes shows its
/// progress (a bar, or a line every few seconds without a terminal).
fn check_episodes(suite: &Suite, total: usize, stop: &AtomicBool, quiet: bool) -> anyhow::Result<Option<String>> {
    let mut fingerprint = Fingerprint::new();
    fingerprint.add(format!("{LOOMLAB_VERSION}\nloomlab run\n").as_bytes());
    let large = !quiet && total >= CHECK_PROGRESS_FROM;
    let checked = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let bar = if large {
        super::progress(total as u64, "checking")
    } else {
        indicatif::ProgressBar::hidden()
    };
    let heartbeat = (large && !std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .then(|| Heartbeat::start(Arc::clone(&checked), total, "checked"));
    for (i, ep) in suite.episodes().take(total).enumerate() {
        if i % CHUNK == 0 {
            if stop.load(Ordering::SeqCst) {
                bar.finish_and_clear();
                return Ok(None);
            }
            bar.set_position(i as u64);
            checked.store(i, Ordering::Relaxed);
        }
        let ep = ep?;
        fingerprint.add_episode(&ep);
        fingerprint.add(format!("{:?}", ep.detectors).as_bytes());
    }
    bar.finish_and_clear();
    drop(heartbeat);
    Ok(Some(fingerprint.hex()))
}

/// Whether `base` is a report of the episodes `counts` (per scenario) with suite seed `seed`.
fn same_suite(base: &Report, counts: &BTreeMap<&str, u64>, seed: u64) -> Result<(), String> {
    let theirs: BTreeMap<&str, u64> = base.scenarios.iter().map(|(k, v)| (k.as_str(), v.episodes)).collect();
    if base.seed != seed {
        return Err(format!("baseline --seed {}, this run --seed {seed}", base.seed));
    }
    if &theirs != counts {
        let show = |m: &BTreeMap<&str, u64>| {
            let n: u64 = m.values().sum();
            let names: Vec<&str> = m.keys().copied().take(6).collect();
            let more = if m.len() > 6 { ", …" } else { "" };
            format!("{n} episodes of {} scenarios: {}{more}", m.len(), names.join(", "))
        };
        return Err(format!("baseline {}; this run {}", show(&theirs), show(counts)));
    }
    Ok(())
}

/// What `report.html` needs.
struct Html<'a> {
    run_dir: &'a RunDir,
    out: &'a Path,
    report: &'a Report,
    outcomes: &'a [EpisodeOutcome],
    samples: &'a PlotSamples,
    exemplar_runs: &'a ExemplarRuns,
    baseline: Option<(String, &'a Report)>,
}

impl Html<'_> {
    /// Chooses the exemplary episodes from every episode, renders their GIFs (in parallel) and
    /// writes the page. `rerun` runs an episode that this invocation did not (a resumed run), `spec`
    /// gives an episode's specification. Returns the page's path, the episodes run again and the
    /// number of exemplars.
    fn write(
        &self,
        gpu: &Arc<GpuContext>,
        rerun: &(dyn Fn(&str, usize) -> anyhow::Result<EpisodeRun> + Sync),
        spec: &(dyn Fn(&str, usize) -> anyhow::Result<EpisodeSpec> + Sync),
    ) -> anyhow::Result<(PathBuf, usize, usize)> {
        let choices = exemplar::choose(self.outcomes);
        // the GIFs an earlier invocation of this run wrote go (never another file in the folder)
        for rel in self.run_dir.written() {
            if rel.starts_with(&format!("{EXEMPLARS_DIR}/")) && !rel.ends_with('/') {
                self.run_dir.remove_written(&rel)?;
            }
        }
        let gif_dir = if choices.is_empty() {
            self.out.join(EXEMPLARS_DIR)
        } else {
            self.run_dir.create_dir(EXEMPLARS_DIR)?
        };
        for c in &choices {
            self.run_dir.record(&format!("{EXEMPLARS_DIR}/{}", c.gif_name()))?;
        }
        self.run_dir.record(REPORT_HTML)?;
        let rerun_count = choices
            .iter()
            .filter(|c| self.exemplar_runs.get(&c.scenario, c.episode).is_none())
            .count();
        let exemplars = choices
            .par_iter()
            .map(|c| -> anyhow::Result<exemplar::Exemplar> {
                let again;
                let run = match self.exemplar_runs.get(&c.scenario, c.episode) {
                    Some(r) => r,
                    None => {
                        again = rerun(&c.scenario, c.episode)?;
                        &again
                    }
                };
                let spec = spec(&c.scenario, c.episode)?;
                Ok(exemplar::build(gpu, &spec, run, c, &gif_dir, EXEMPLARS_DIR)?)
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let count = exemplars.len();
        let page = RunPage {
            report: self.report,
            title: format!("loomlab run: {}", self.report.suite),
            facts: vec![("command".into(), std::env::args().collect::<Vec<_>>().join(" "))],
            figures: run_figures(self.report, self.outcomes, Some(self.samples)),
            exemplars,
            baseline: self.baseline.clone(),
            notes: Vec::new(),
        };
        let path = page.write(self.out)?;
        debug_assert!(path.ends_with(REPORT_HTML));
        Ok((path, rerun_count, count))
    }
}

/// Seconds between two progress lines when stderr is not a terminal (no progress bar there);
/// the environment variable `LOOMLAB_PROGRESS_S` sets another interval (e.g. for a log).
const HEARTBEAT_S: u64 = 10;

/// Progress lines on a non-terminal stderr (a log file, CI): `progress: 12 of 349 episodes done
/// in 1 min 20 s`, every [`HEARTBEAT_S`] seconds (or `LOOMLAB_PROGRESS_S`) while episodes run,
/// even inside one long episode.
struct Heartbeat {
    done: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Heartbeat {
    fn start(finished: Arc<std::sync::atomic::AtomicUsize>, todo: usize, what: &'static str) -> Self {
        let done = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&done);
        let every = std::env::var("LOOMLAB_PROGRESS_S")
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
            .filter(|&s| s > 0)
            .unwrap_or(HEARTBEAT_S);
        let thread = std::thread::spawn(move || {
            let started = Instant::now();
            let mut next = every;
            while !flag.load(Ordering::SeqCst) {
                std::thread::park_timeout(std::time::Duration::from_millis(200));
                let secs = started.elapsed().as_secs();
                if secs >= next && !flag.load(Ordering::SeqCst) {
                    next = secs + every;
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

/// Work done by this invocation (for the summary lines).
#[derive(Debug, Default)]
struct RunWork {
    episodes: usize,
    frames: usize,
    replays: usize,
    deadlines: usize,
    deadline_s: f64,
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

/// Set once every episode is done and the report is being written (the interrupt message).
static WRITING_REPORT: AtomicBool = AtomicBool::new(false);

/// A flag set by the first Ctrl-C / SIGTERM: no new episode starts and those in flight give up
/// within about a second (they run again on `--resume`); the finished ones are saved and the
/// manifest says `interrupted`. A second one exits at once, recording the state `interrupted`
/// first (finished episodes are already in episodes.csv).
fn interrupt_flag() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let installed = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            match super::run_dir::abandon_active_run() {
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
            unsafe { libc::_exit(130) };
        }
        if WRITING_REPORT.load(Ordering::SeqCst) {
            errln!("\ninterrupt: every episode is saved; stopping after the file being written ...");
        } else {
            errln!("\ninterrupt: stopping (finished episodes are saved; those in flight run again on --resume) ...");
        }
    });
    if let Err(e) = installed {
        errln!("note: Ctrl-C will not stop the run cleanly: {e}");
    }
    stop
}
