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
//!   the true angular size);
//! - `report.html` (unless `--no-html`): the page a person reads, with every table and plot and,
//!   per scenario, a few exemplary episodes (GIFs of the robot's view in `exemplars/`, traces);
//!   see `loomlab_report`.
//!
//! Exit codes: 0 done (no regression), 1 regressions against `--baseline` (each one listed),
//! 2 bad input (unreadable or invalid scenario, unknown key, missing file, bad option).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use loomlab_detector::parse_detector_list;
use loomlab_scenarios::calibrate::calibrate;
use loomlab_scenarios::fingerprint::Fingerprint;
use loomlab_scenarios::metrics::EpisodeOutcome;
use loomlab_scenarios::reference::REFERENCE_LABELS;
use loomlab_scenarios::regression::{Tolerances, compare};
use loomlab_scenarios::report::{LOOMLAB_VERSION, Report, ReportMeta};
use loomlab_scenarios::schema::{Scenario, load_detector_entries};
use loomlab_scenarios::{DEFAULT_SUITE, EpisodeRun, EpisodeSpec, LoadOptions, Runner, load_suite};

use super::run_dir::{
    EPISODES_CSV, Existing, Manifest, PARTIAL_REPORT, Prepared, REPORT, RunDir, RunState, write_atomic,
};
use loomlab_report::exemplar::{self, ExemplarRuns};
use loomlab_report::page::RunPage;
use loomlab_report::run_plots::{PlotSamples, run_figures, write_plots, write_trace};
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
    /// Episodes run in parallel (default: number of CPUs).
    #[arg(long, short)]
    pub jobs: Option<usize>,
    /// Suite seed mixed into every scenario's seed (0: the files' seeds as written).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Frame size n for every episode (overrides world.camera.n).
    #[arg(long, value_name = "N")]
    pub size: Option<u32>,
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
    /// Also write every episode's open-loop trace to DIR/traces/<scenario>_<episode>.csv (time,
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

/// Episodes expanded and run at a time (bounds memory; large enough that the workers rarely wait
/// at a chunk's end).
const CHUNK: usize = 1024;

/// Runs `loomlab run`.
pub fn run(args: RunArgs) -> anyhow::Result<i32> {
    let detectors: Option<Vec<String>> = match &args.detectors {
        Some(spec) => Some(parse_detector_list(spec)?.into_iter().map(String::from).collect()),
        None => None,
    };
    if args.jobs == Some(0) {
        bail!("--jobs must be at least 1");
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
    };
    let suite_path = args.suite.clone().unwrap_or_else(default_suite);
    let suite = load_suite(&suite_path, &opts)?;
    // Read the baseline before spending time on the run (a missing file is bad input).
    let baseline = match (&args.baseline, args.bless) {
        (Some(p), false) => Some(Report::read_json(p)?),
        _ => None,
    };

    // Check every episode to run (expanded one at a time, not kept) and fingerprint them.
    let limit = args.limit.unwrap_or(usize::MAX);
    let mut fingerprint = Fingerprint::new();
    fingerprint.add(format!("{LOOMLAB_VERSION}\nloomlab run\n").as_bytes());
    let mut lead_margin_s = None;
    let mut total = 0;
    for ep in suite.episodes().take(limit) {
        let ep = ep?;
        fingerprint.add_episode(&ep);
        fingerprint.add(format!("{:?}", ep.detectors).as_bytes());
        lead_margin_s.get_or_insert(ep.scoring.lead_margin_s);
        total += 1;
    }
    let Some(lead_margin_s) = lead_margin_s else {
        bail!("{}: no episodes to run", suite_path.display());
    };

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
    let manifest = Manifest::new(fingerprint.hex(), &suite_path, total);
    let Prepared {
        dir: mut run_dir,
        done,
        csv,
    } = RunDir::prepare(&args.out, manifest, existing, labels)?;
    let out = run_dir.dir.clone();
    let mut outcomes: Vec<(usize, EpisodeOutcome)> = done
        .into_iter()
        .filter_map(|o| Some((position(&o.scenario, o.episode)?, o)))
        .collect();
    let resumed: BTreeSet<usize> = outcomes.iter().map(|(p, _)| *p).collect();
    if !resumed.is_empty() && !args.quiet {
        println!(
            "resuming {}: {} of {total} episodes were done, running the other {}",
            out.display(),
            resumed.len(),
            total - resumed.len()
        );
    }

    let gpu = GpuContext::new()?;
    let runner = Runner::with_context(Arc::clone(&gpu), args.jobs)?;
    if let Some(jobs) = args.jobs
        && jobs > runner.jobs()
        && !args.quiet
    {
        eprintln!("note: --jobs {jobs} clamped to {} (the number of CPUs)", runner.jobs());
    }
    let stop = interrupt_flag();
    let csv = Mutex::new(csv);
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        super::progress((total - resumed.len()) as u64, "episodes")
    };
    let started = Instant::now();
    let traces_dir = out.join("traces");
    if args.traces {
        std::fs::create_dir_all(&traces_dir).with_context(|| format!("cannot create {}", traces_dir.display()))?;
    }
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
        let runs = runner.run_until(&specs, &stop, |_, run| {
            csv.lock()
                .unwrap_or_else(|e| e.into_inner())
                .write_episode(&run.outcome)
                .map_err(|e| e.to_string())?;
            if args.traces {
                write_trace(&traces_dir, run).map_err(|e| e.to_string())?;
            }
            bar.inc(1);
            Ok(())
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
            let partial = Report::from_episodes(&meta, &outcomes);
            write_atomic(&out.join(PARTIAL_REPORT), (partial.to_json() + "\n").as_bytes())?;
        }
        run_dir.set_state(RunState::Interrupted)?;
        eprintln!(
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

    let report = Report::from_episodes(&meta, &outcomes);
    let report_path = out.join(REPORT);
    write_atomic(&report_path, (report.to_json() + "\n").as_bytes())?;
    let _ = std::fs::remove_file(out.join(PARTIAL_REPORT));
    run_dir.set_state(RunState::Complete)?;
    if !args.no_plots {
        write_plots(&out, &report, &outcomes, &samples)?;
    }
    let html = if args.no_html {
        None
    } else {
        let started_html = Instant::now();
        let page = Html {
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
        let (path, rerun_count, exemplars) = page.write(&gpu, &rerun, &spec)?;
        Some((path, started_html.elapsed().as_secs_f64(), rerun_count, exemplars))
    };

    if !args.quiet {
        println!("{}", report.format_table(!args.brief).trim_end());
        println!(
            "\nescape deadlines: {} physics-only replays for {} threats, {:.1} s of worker time",
            work.replays, work.deadlines, work.deadline_s
        );
        let earlier = if resumed.is_empty() {
            String::new()
        } else {
            format!(" (plus {} episodes from the earlier run)", resumed.len())
        };
        println!(
            "\n{} episodes{earlier}, {} frames rendered in {:.1} s on {} ({} workers)",
            work.episodes,
            work.frames,
            started.elapsed().as_secs_f64(),
            runner.adapter(),
            runner.jobs()
        );
        println!(
            "wrote {} and episodes.csv, plots in {}",
            report_path.display(),
            out.display()
        );
        if let Some((path, secs, rerun, exemplars)) = &html {
            let again = if *rerun > 0 {
                format!(", {rerun} of them from the earlier run simulated again")
            } else {
                String::new()
            };
            println!(
                "wrote {} in {secs:.1} s ({:.1} % of this run's {:.1} s; {exemplars} exemplary episodes{again})",
                path.display(),
                100.0 * secs / started.elapsed().as_secs_f64(),
                started.elapsed().as_secs_f64()
            );
        }
    }
    if let Some(target) = args.calibrate {
        println!("\nthresholds for a false-alarm rate <= {target} over this run's non-threat episodes:");
        for c in calibrate(&outcomes, target) {
            // three significant digits in the shortest form (0.000095, 2.47, 270)
            let sig3 = |t: f64| {
                format!("{t:.2e}")
                    .parse::<f64>()
                    .map_or(t.to_string(), |v| v.to_string())
            };
            let t = c.threshold.map_or("any (no finite score)".to_string(), sig3);
            let hit = c.hit_rate.map_or("n/a".to_string(), |h| format!("{h:.2}"));
            println!(
                "  {:<10} threshold {t:<12} FA rate {:.2} over {} non-threats, hit rate {hit}",
                c.label, c.false_alarm_rate, c.non_threats
            );
        }
    }

    if let Some(path) = &args.baseline {
        if args.bless {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
            }
            report.write_json(path)?;
            if !args.quiet {
                println!("baseline written to {}", path.display());
            }
        } else if let Some(base) = &baseline {
            let regressions = compare(&report, base, &Tolerances::default());
            if !regressions.is_empty() {
                eprintln!("{} regression(s) against {}:", regressions.len(), path.display());
                for r in &regressions {
                    eprintln!("  {r}");
                }
                return Ok(1);
            }
            if !args.quiet {
                println!("no regression against {}", path.display());
            }
        }
    }
    Ok(0)
}

/// What `report.html` needs.
struct Html<'a> {
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
        let gif_dir = self.out.join(EXEMPLARS_DIR);
        if gif_dir.exists() {
            std::fs::remove_dir_all(&gif_dir).with_context(|| format!("cannot remove {}", gif_dir.display()))?;
        }
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

/// A flag set by the first Ctrl-C / SIGTERM: no new episode starts, those in flight finish and
/// are saved. A second one exits at once (finished episodes are already in episodes.csv).
fn interrupt_flag() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let installed = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            eprintln!(
                "
second interrupt: stopping now; finished episodes are saved in episodes.csv"
            );
            std::process::exit(130);
        }
        eprintln!(
            "
interrupt: finishing the episodes in flight (interrupt again to stop at once) ..."
        );
    });
    if let Err(e) = installed {
        eprintln!("note: Ctrl-C will not stop the run cleanly: {e}");
    }
    stop
}
