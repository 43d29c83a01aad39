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
//!   the true angular size).
//!
//! Exit codes: 0 done (no regression), 1 regressions against `--baseline` (each one listed),
//! 2 bad input (unreadable or invalid scenario, unknown key, missing file, bad option).

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use loomlab_detector::parse_detector_list;
use loomlab_scenarios::calibrate::calibrate;
use loomlab_scenarios::episodes_csv::EpisodesCsvWriter;
use loomlab_scenarios::metrics::{EpisodeOutcome, Outcome};
use loomlab_scenarios::regression::{Tolerances, compare};
use loomlab_scenarios::report::{Report, ReportMeta};
use loomlab_scenarios::schema::load_detector_entries;
use loomlab_scenarios::{DEFAULT_SUITE, EpisodeRun, EpisodeSpec, LoadOptions, Runner, load_suite};

use crate::plot::{LineChart, Series, line_chart, line_chart_grid, rate_bars};

/// Arguments of `loomlab run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Suite: a folder of scenario files, a list file (TOML with `scenarios = [...]`) or one
    /// scenario file. Default: the default suite, scenarios/suites/default.
    #[arg(value_name = "SUITE")]
    pub suite: Option<PathBuf>,
    /// Output folder for report.json, episodes.csv and the plots (created if missing).
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

/// Runs `loomlab run`.
pub fn run(args: RunArgs) -> anyhow::Result<i32> {
    let detectors = match &args.detectors {
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
    let mut episodes: Vec<&EpisodeSpec> = suite.episodes().collect();
    if let Some(limit) = args.limit {
        episodes.truncate(limit);
    }
    if episodes.is_empty() {
        bail!("{}: no episodes to run", suite_path.display());
    }

    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let csv = Mutex::new(EpisodesCsvWriter::create(&args.out.join("episodes.csv"))?);
    let runner = Runner::new(args.jobs)?;
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        super::progress(episodes.len() as u64, "episodes")
    };
    let started = Instant::now();
    let traces_dir = args.out.join("traces");
    if args.traces {
        std::fs::create_dir_all(&traces_dir).with_context(|| format!("cannot create {}", traces_dir.display()))?;
    }
    let runs = runner.run(&episodes, |_, run| {
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
    bar.finish_and_clear();
    let wall_time_s = started.elapsed().as_secs_f64();

    let outcomes = runs_outcomes(&runs);
    let meta = ReportMeta {
        suite: suite_path.display().to_string(),
        seed: args.seed,
        wall_time_s,
        lead_margin_s: episodes[0].scoring.lead_margin_s,
    };
    let report = Report::from_episodes(&meta, &outcomes);
    let report_path = args.out.join("report.json");
    report.write_json(&report_path)?;
    if !args.no_plots {
        write_plots(&args.out, &report, &runs)?;
    }

    if !args.quiet {
        let frames: usize = runs.iter().map(|r| r.frames_rendered).sum();
        let replays: usize = runs.iter().filter_map(|r| r.deadline.as_ref()).map(|d| d.replays).sum();
        let deadline_s: f64 = runs.iter().map(|r| r.deadline_s).sum();
        println!("{}", report.format_table(!args.brief).trim_end());
        println!(
            "\nescape deadlines: {replays} physics-only replays for {} threats, {deadline_s:.1} s of worker time",
            runs.iter().filter(|r| r.deadline.is_some()).count()
        );
        println!(
            "\n{} episodes, {frames} frames rendered in {wall_time_s:.1} s on {} ({} workers)",
            runs.len(),
            runner.adapter(),
            runner.jobs()
        );
        println!(
            "wrote {} and episodes.csv, plots in {}",
            report_path.display(),
            args.out.display()
        );
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

/// The scored outcomes of `runs`.
fn runs_outcomes(runs: &[EpisodeRun]) -> Vec<EpisodeOutcome> {
    runs.iter().map(|r| r.outcome.clone()).collect()
}

/// Writes one episode's open-loop trace as CSV.
fn write_trace(dir: &Path, run: &EpisodeRun) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let tr = &run.trace;
    let mut text = String::from("t_s,theta_true_deg,ttc_true_s");
    for d in &tr.detectors {
        let _ = write!(text, ",{0}_signal,{0}_output", d.label);
    }
    text.push('\n');
    let opt = |v: Option<f64>| v.filter(|v| v.is_finite()).map_or(String::new(), |v| v.to_string());
    for k in 0..tr.t_s.len() {
        let _ = write!(
            text,
            "{},{},{}",
            tr.t_s[k],
            opt(Some(tr.angular_size_deg[k])),
            opt(tr.ttc_s[k])
        );
        for d in &tr.detectors {
            let _ = write!(text, ",{},{}", opt(Some(d.signal[k])), opt(Some(d.output[k])));
        }
        text.push('\n');
    }
    let name = format!("{}_{:04}.csv", run.outcome.scenario, run.outcome.episode);
    std::fs::write(dir.join(name), text)
}

fn write_plots(out: &Path, report: &Report, runs: &[EpisodeRun]) -> anyhow::Result<()> {
    // ROC curves.
    let mut series: Vec<Series> = report
        .detectors
        .iter()
        .filter(|(_, s)| !s.roc.is_empty())
        .map(|(id, s)| {
            let auc = s.auc.map_or(String::new(), |a| format!(" (AUC {a:.2})"));
            Series::new(
                format!("{id}{auc}"),
                s.roc.iter().map(|p| p.fpr).collect(),
                s.roc.iter().map(|p| p.tpr).collect(),
            )
        })
        .collect();
    series.push(Series::new("", vec![0.0, 1.0], vec![0.0, 1.0]).dashed());
    line_chart(
        &out.join("roc.png"),
        &LineChart {
            title: "ROC: threshold sweep over the open-loop alarms".into(),
            x_label: "false-alarm rate".into(),
            y_label: "hit rate".into(),
            series,
            x_range: Some((0.0, 1.0)),
            y_range: Some((0.0, 1.0)),
        },
        (640, 560),
    )?;

    // Rates per scenario.
    let scenarios: Vec<String> = report.scenarios.keys().cloned().collect();
    let labels: Vec<String> = report.detectors.keys().cloned().collect();
    let per = |f: &dyn Fn(&loomlab_scenarios::metrics::DetectorSummary) -> Option<f64>| -> Vec<(String, Vec<f64>)> {
        labels
            .iter()
            .map(|id| {
                let v = scenarios
                    .iter()
                    .map(|s| report.scenarios[s].detectors.get(id).and_then(f).unwrap_or(f64::NAN))
                    .collect();
                (id.clone(), v)
            })
            .collect()
    };
    // wide enough for the (horizontal) scenario names under each group of bars
    let width = (160 + 120 * scenarios.len() as u32).max(640);
    rate_bars(
        &out.join("rates.png"),
        "correct decisions (hits + correct rejections) / decidable episodes, per scenario",
        &scenarios,
        &per(&|s| {
            let decided = s.hits + s.misses + s.false_alarms + s.correct_rejections;
            (decided > 0).then(|| (s.hits + s.correct_rejections) as f64 / decided as f64)
        }),
        (width, 520),
    )?;
    rate_bars(
        &out.join("collisions.png"),
        "closed-loop collision rate per scenario",
        &scenarios,
        &per(&|s| s.collision_rate),
        (width, 520),
    )?;

    // The l/|v| analysis: alarm time to collision against half-size / closing speed, with the fit.
    let outcomes = runs_outcomes(runs);
    let lv: Vec<Series> = report
        .detectors
        .iter()
        .map(|(id, s)| {
            let (x, y): (Vec<f64>, Vec<f64>) = loomlab_scenarios::report::detector_episodes(&outcomes, id)
                .filter_map(|d| Some((d.l_over_v_s?, d.eye_ttc_at_alarm_s?)))
                .unzip();
            let name = match &s.lv_fit {
                Some(f) => format!(
                    "{id}: θ_th {} δ {:.3} s R² {:.2} (n={})",
                    f.theta_th_deg.map_or("n/a".into(), |t| format!("{t:.1}°")),
                    f.delay_s,
                    f.r2,
                    f.episodes
                ),
                None => format!("{id}: no fit ({} alarms)", x.len()),
            };
            Series::new(name, x, y).scatter(s.lv_fit.map(|f| (f.slope, f.intercept_s)))
        })
        .collect();
    line_chart(
        &out.join("lv.png"),
        &LineChart {
            title: "l/|v| analysis: constant-speed head-on threats".into(),
            x_label: "l/|v|: half-size / closing speed (s)".into(),
            y_label: "time to collision at the alarm (s)".into(),
            series: lv,
            x_range: None,
            y_range: None,
        },
        (760, 600),
    )?;

    // θ̂ against the true angular size of the threat, every frame of every threat episode.
    let mut theta_hat: Vec<Series> = report
        .detectors
        .keys()
        .filter(|id| !loomlab_scenarios::reference::is_reference(id))
        .filter_map(|id| {
            let (x, y): (Vec<f64>, Vec<f64>) = runs
                .iter()
                .filter(|r| r.outcome.detectors.first().is_some_and(|d| d.threat))
                .flat_map(|r| {
                    let tr = &r.trace;
                    tr.detectors
                        .iter()
                        .filter(|d| &d.label == id && d.trigger == loomlab_agents::TriggerSignal::AngularSizeDeg)
                        .flat_map(move |d| tr.angular_size_deg.iter().copied().zip(d.signal.iter().copied()))
                })
                .filter(|(t, e)| t.is_finite() && e.is_finite() && *t <= 90.0)
                .unzip();
            // at most ~4000 markers per detector keep the plot readable and quick to draw
            let every = x.len().div_ceil(4000).max(1);
            let (x, y): (Vec<f64>, Vec<f64>) = x.into_iter().zip(y).step_by(every).unzip();
            let acc = report.detectors[id].theta_accuracy.map_or(String::new(), |a| {
                format!(" (median |θ̂−θ|/θ {:.2}, p90 {:.2})", a.median_rel_err, a.p90_rel_err)
            });
            (!x.is_empty()).then(|| Series::new(format!("{id}{acc}"), x, y).scatter(None))
        })
        .collect();
    if !theta_hat.is_empty() {
        theta_hat.push(Series::new("θ̂ = θ", vec![0.0, 90.0], vec![0.0, 90.0]).dashed());
        line_chart(
            &out.join("theta_hat.png"),
            &LineChart {
                title: "angular-size estimate θ̂ against the threat's true angular size (threat episodes)".into(),
                x_label: "true angular size θ (deg)".into(),
                y_label: "θ̂ (deg)".into(),
                series: theta_hat,
                x_range: Some((0.0, 90.0)),
                y_range: Some((0.0, 90.0)),
            },
            (760, 640),
        )?;
    }

    // A sample episode: the first threat the first detector hits, else the first threat, else the first.
    let sample = runs
        .iter()
        .find(|r| r.outcome.detectors.first().is_some_and(|d| d.outcome == Outcome::Hit))
        .or_else(|| {
            runs.iter()
                .find(|r| r.outcome.detectors.first().is_some_and(|d| d.threat))
        })
        .or_else(|| runs.first());
    if let Some(run) = sample {
        let tr = &run.trace;
        let object = tr.reference_object.clone().unwrap_or_else(|| "object".into());
        let mut over_time = vec![
            Series::new(
                format!("true θ ({object})"),
                tr.t_s.clone(),
                tr.angular_size_deg.clone(),
            )
            .dashed(),
        ];
        for d in &tr.detectors {
            if d.trigger == loomlab_agents::TriggerSignal::AngularSizeDeg {
                over_time.push(Series::new(format!("{} θ̂", d.label), tr.t_s.clone(), d.signal.clone()));
                over_time.push(
                    Series::new(
                        format!("{} threshold", d.label),
                        vec![tr.t_s[0], *tr.t_s.last().unwrap_or(&tr.t_s[0])],
                        vec![d.threshold; 2],
                    )
                    .dashed(),
                );
            }
        }
        let y_max = tr
            .detectors
            .iter()
            .filter(|d| d.trigger == loomlab_agents::TriggerSignal::AngularSizeDeg)
            .flat_map(|d| d.signal.iter().copied())
            .chain(tr.angular_size_deg.iter().copied())
            .filter(|v| v.is_finite())
            .fold(1.0f64, f64::max)
            .min(90.0);
        let responses: Vec<Series> = tr
            .detectors
            .iter()
            .map(|d| {
                let max = d
                    .output
                    .iter()
                    .copied()
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, f64::max);
                let y = d.output.iter().map(|v| if max > 0.0 { v / max } else { 0.0 }).collect();
                Series::new(d.label.clone(), tr.angular_size_deg.clone(), y)
            })
            .collect();
        let title = format!(
            "{} episode {} ({})",
            run.outcome.scenario,
            run.outcome.episode,
            if run.outcome.detectors.first().is_some_and(|d| d.threat) {
                "threat"
            } else {
                "no threat"
            }
        );
        line_chart_grid(
            &out.join("trace.png"),
            &[
                LineChart {
                    title: format!("{title}: angular size"),
                    x_label: "time (s)".into(),
                    y_label: "degrees".into(),
                    series: over_time,
                    y_range: Some((0.0, y_max * 1.05)),
                    x_range: None,
                },
                LineChart {
                    title: "detector responses vs true angular size".into(),
                    x_label: "true angular size (deg)".into(),
                    y_label: "response / episode maximum".into(),
                    series: responses,
                    y_range: Some((0.0, 1.05)),
                    x_range: Some((0.0, y_max)),
                },
            ],
            2,
            (640, 480),
        )?;
    }
    Ok(())
}
