//! `loomlab calibrate --false-alarm-rate FA RUN_DIR...`: detector thresholds calibrated on the
//! non-threat episodes of several runs pooled — held-out draws of a suite run with different
//! seeds (`loomlab run --seed 7 --out out/seed7`, `--seed 8`, …) — where `loomlab run --calibrate`
//! sees one run's. A false-alarm rate measured on n non-threats has a standard error of about
//! √(p(1 − p)/n): 0.02 near 0.10 for the default suite's 200, so pooling three runs shrinks it to
//! 0.012.
//!
//! Per detector row it prints the smallest threshold (three significant digits) with at most that
//! false-alarm rate over the pooled non-threats, the hit rate there, and both rates at the
//! threshold the runs were made with. Reference rows are not calibrated. Exit codes: 0 done, 2 bad
//! input (a folder without `episodes.csv`, an unreadable file, an episode in two runs).

use std::collections::BTreeSet;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use loomlab_scenarios::calibrate::calibrate;
use loomlab_scenarios::episodes_csv::read_episodes_csv;
use loomlab_scenarios::metrics::EpisodeOutcome;

/// Arguments of `loomlab calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// The largest false-alarm rate allowed over the pooled non-threat episodes, in [0, 1]
    /// (e.g. 0.1).
    #[arg(long, value_name = "FA_RATE")]
    pub false_alarm_rate: f64,
    /// Output folders of `loomlab run` (each holding its episodes.csv), e.g. the suite run with
    /// --seed 7, 8 and 9. Not the run you report.
    #[arg(value_name = "RUN_DIR", required = true)]
    pub runs: Vec<PathBuf>,
}

/// Runs `loomlab calibrate`.
pub fn run(args: CalibrateArgs) -> anyhow::Result<i32> {
    let target = args.false_alarm_rate;
    if !(0.0..=1.0).contains(&target) {
        bail!("--false-alarm-rate takes a rate in [0, 1], got {target}");
    }
    let mut outcomes: Vec<EpisodeOutcome> = Vec::new();
    let mut seen = BTreeSet::new();
    for dir in &args.runs {
        let path = dir.join("episodes.csv");
        if !path.is_file() {
            bail!(
                "{}: no episodes.csv there; give the output folders of `loomlab run` (its --out)",
                dir.display()
            );
        }
        let episodes = read_episodes_csv(&path).with_context(|| format!("cannot read {}", path.display()))?;
        for e in &episodes {
            if !seen.insert((e.scenario.clone(), e.episode, e.seed)) {
                bail!(
                    "{}: episode {} of `{}` (seed {}) is in an earlier run too; pool runs of different --seed",
                    path.display(),
                    e.episode,
                    e.scenario,
                    e.seed
                );
            }
        }
        outcomes.extend(episodes);
    }
    print_calibrations(
        &outcomes,
        target,
        &format!("the non-threat episodes of {} runs pooled", args.runs.len()),
    );
    Ok(0)
}

/// Prints, per detector row of `outcomes`, the threshold calibrated to at most `target` false
/// alarms over `what` (the pooled runs here, one run for `loomlab run --calibrate`).
pub fn print_calibrations(outcomes: &[EpisodeOutcome], target: f64, what: &str) {
    outln!("thresholds for a false-alarm rate <= {target} over {what}:");
    let calibrations = calibrate(outcomes, target);
    let width = calibrations.iter().map(|c| c.label.chars().count()).max().unwrap_or(0);
    for c in calibrations {
        // three significant digits in the shortest form (0.000095, 2.47, 270)
        let sig3 = |t: f64| {
            format!("{t:.2e}")
                .parse::<f64>()
                .map_or(t.to_string(), |v| v.to_string())
        };
        let t = c.threshold.map_or("any (no finite score)".to_string(), sig3);
        let rate = |r: Option<f64>, digits: usize| r.map_or("n/a".to_string(), |h| format!("{h:.digits$}"));
        outln!(
            "  {:<width$} threshold {t:<12} FA rate {:.2} over {} non-threats, hit rate {} (at the run's threshold: FA rate {:.3}, hit rate {})",
            c.label,
            c.false_alarm_rate,
            c.non_threats,
            rate(c.hit_rate, 2),
            c.run_false_alarm_rate,
            rate(c.run_hit_rate, 3)
        );
    }
}
