//! Glue of `loomlab.evaluate`: a suite's episodes for an environment (expanded as `loomlab run`
//! expands them) and the report of a policy's episodes next to the suite's detectors and reference
//! rows, scored by [`loomlab_scenarios::Runner`] (one place for scoring).

use std::path::{Path, PathBuf};

use pyo3::prelude::*;

use loomlab_env::{EnvError, EnvOptions, ScenarioEpisodes};
use loomlab_scenarios::metrics::DetectorEpisode;
use loomlab_scenarios::reference::is_reference;
use loomlab_scenarios::report::{Report, ReportMeta};
use loomlab_scenarios::{LoadOptions, load_suite};

use crate::errors::{self, Seed};
use crate::scenarios;

/// The episodes of `suite` expanded with `seed` (first `limit`) and the frame size and detectors of
/// `options`, as `loomlab run SUITE --seed SEED --size N --detectors IDS --limit LIMIT` expands
/// them (the options' `thresholds` replace the detectors' thresholds): a shipped scenario name (`None`: the default scenario) or a path to a suite folder, list
/// file or scenario file. Returns the suite's name as written (reports use it) and the episodes.
pub fn suite_episodes(
    suite: Option<&str>,
    seed: u64,
    limit: Option<usize>,
    options: &EnvOptions,
) -> Result<(PathBuf, ScenarioEpisodes), EnvError> {
    let shipped = suite.is_none_or(|s| scenarios::builtin(s).is_ok());
    let (source, mut episodes) = if shipped {
        let sc = scenarios::load(suite, None)?;
        let source = sc.path.clone();
        (source, sc.load(options, seed)?)
    } else {
        let path = PathBuf::from(suite.unwrap_or_default());
        if !path.exists() {
            return Err(EnvError::Scenario(format!(
                "suite `{}` is neither a shipped scenario ({:?}) nor an existing folder or file",
                path.display(),
                scenarios::BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>()
            )));
        }
        let opts = LoadOptions {
            seed,
            size: options.frame_size,
            detectors: options.detectors.clone(),
            detector_entries: None,
            ..Default::default()
        };
        let s = load_suite(&path, &opts)?;
        let episodes = s
            .episodes()
            .take(limit.unwrap_or(usize::MAX))
            .collect::<Result<Vec<_>, _>>()?;
        let name = s.scenarios.first().map(|sc| sc.name.clone()).unwrap_or_default();
        (path, ScenarioEpisodes { name, episodes })
    };
    if limit == Some(0) {
        return Err(EnvError::Scenario(
            "invalid `limit` = 0: must be >= 1 (or None: every episode)".into(),
        ));
    }
    if let Some(l) = limit {
        episodes.episodes.truncate(l);
    }
    // the options' thresholds hold for the runner's rows too (one threshold per detector)
    for ep in &mut episodes.episodes {
        for d in &mut ep.detectors {
            if let Some(&t) = options.thresholds.get(&d.label) {
                d.threshold = t;
            }
        }
    }
    Ok((source, episodes))
}

/// The report of a policy evaluated on `suite` (see `loomlab.evaluate`): the suite's episodes
/// (expanded as [`suite_episodes`] does for each seed) run by the scenario runner, as `loomlab
/// run` runs them (detector rows and the reference rows `null`, `oracle`, `ideal_theta`, `ideal_tau`, `ideal_course`), plus the
/// policy's row `label` from `agent_rows_json`: a JSON list with, per seed and episode in order, the
/// `outcome["agent"]` dict that the environment scored when the policy ran that episode. Returns
/// the report's JSON (the keys of `report.json`) over the episodes of every seed; its `seed` is the
/// first seed (with one seed the report is `loomlab run SUITE --seed SEED`'s plus the policy's row).
#[pyfunction]
#[allow(clippy::too_many_arguments)] // the Python keyword arguments
#[pyo3(signature = (suite, seeds, label, agent_rows_json, limit = None, options_json = "{}", jobs = None))]
pub fn evaluation_report(
    py: Python<'_>,
    suite: Option<String>,
    seeds: Vec<Seed>,
    label: String,
    agent_rows_json: &str,
    limit: Option<usize>,
    options_json: &str,
    jobs: Option<usize>,
) -> PyResult<String> {
    if seeds.is_empty() {
        return Err(errors::ScenarioError::new_err(
            "seeds is empty: give at least one seed (the suite is expanded once per seed)",
        ));
    }
    if is_reference(&label) {
        return Err(errors::ScenarioError::new_err(format!(
            "label `{label}` is a reference row's name; choose another label for the policy (e.g. `ppo`)"
        )));
    }
    let options = EnvOptions::from_json(options_json).map_err(errors::to_py)?;
    let rows: Vec<DetectorEpisode> = serde_json::from_str(agent_rows_json)
        .map_err(|e| errors::LoomlabError::new_err(format!("agent_rows_json: not a list of agent rows ({e})")))?;
    py.detach(|| -> PyResult<String> {
        let runner = crate::sweep::runner(jobs).map_err(crate::sweep::run_to_py)?;
        let mut rows = rows.into_iter();
        let started = std::time::Instant::now();
        let mut outcomes = Vec::new();
        let mut meta = None;
        for &Seed(seed) in &seeds {
            let (source, eps) = suite_episodes(suite.as_deref(), seed, limit, &options).map_err(errors::to_py)?;
            let specs: Vec<_> = eps.episodes.iter().collect();
            let runs = runner.run(&specs, |_, _| Ok(())).map_err(crate::sweep::run_to_py)?;
            for run in runs {
                let mut outcome = run.outcome;
                let Some(mut row) = rows.next() else {
                    return Err(errors::LoomlabError::new_err(format!(
                        "agent_rows_json has too few rows: none for seed {seed}, episode {} of `{}`",
                        outcome.episode,
                        source.display()
                    )));
                };
                check_same_episode(&row, &outcome.detectors[0], seed, outcome.episode, &source)?;
                if outcome.detectors.iter().any(|d| d.detector == label) {
                    return Err(errors::ScenarioError::new_err(format!(
                        "label `{label}` is already a detector of the suite; choose another label for the policy"
                    )));
                }
                row.detector = label.clone();
                outcome.detectors.push(row);
                outcomes.push(outcome);
            }
            meta.get_or_insert(ReportMeta {
                suite: source.display().to_string(),
                seed,
                wall_time_s: 0.0,
                lead_margin_s: eps.episodes.first().map_or(0.0, |e| e.scoring.lead_margin_s),
            });
        }
        let extra = rows.count();
        if extra > 0 {
            return Err(errors::LoomlabError::new_err(format!(
                "agent_rows_json has {extra} rows more than the suite has episodes"
            )));
        }
        let mut meta = meta.expect("seeds is not empty");
        let tiers = suite_tiers(suite.as_deref());
        meta.wall_time_s = started.elapsed().as_secs_f64();
        Ok(Report::from_tiered_episodes(&meta, &outcomes, &tiers).to_json())
    })
}

/// The difficulty tier of each scenario of a suite folder or file (empty for a shipped scenario or
/// a suite whose files state no `tier`), so that the report pools each tier as `loomlab run` does.
fn suite_tiers(suite: Option<&str>) -> std::collections::BTreeMap<String, u8> {
    match suite {
        Some(s) if scenarios::builtin(s).is_err() => load_suite(std::path::Path::new(s), &LoadOptions::default())
            .map(|suite| suite.tiers())
            .unwrap_or_default(),
        _ => Default::default(),
    }
}

/// The policy's row must come from the same episode as the runner's (same ground truth).
fn check_same_episode(
    agent: &DetectorEpisode,
    runner: &DetectorEpisode,
    seed: u64,
    episode: usize,
    source: &Path,
) -> PyResult<()> {
    let same_time = match (agent.t_contact_s, runner.t_contact_s) {
        (Some(a), Some(b)) => (a - b).abs() <= 1e-9,
        (None, None) => true,
        _ => false,
    };
    if agent.threat != runner.threat || !same_time || agent.t_deadline_s != runner.t_deadline_s {
        return Err(errors::LoomlabError::new_err(format!(
            "the policy's row for seed {seed}, episode {episode} of `{}` has other ground truth than the \
             runner's (threat {} / {}, t_contact_s {:?} / {:?}, t_deadline_s {:?} / {:?}): the rows must be \
             given in episode order, from environments made by EscapeEnv.from_suite with the same suite, seed \
             and options",
            source.display(),
            agent.threat,
            runner.threat,
            agent.t_contact_s,
            runner.t_contact_s,
            agent.t_deadline_s,
            runner.t_deadline_s
        )));
    }
    Ok(())
}

/// Calibrates the suite's detectors (see `loomlab run --calibrate`): runs the episodes of `suite`
/// for every seed (expanded as [`suite_episodes`] does) and returns, per detector label, the
/// smallest threshold whose false-alarm rate over the non-threat episodes is at most
/// `false_alarm_rate` (`None` where no non-threat episode has a finite score). Use other seeds than
/// the ones you report.
#[pyfunction]
#[pyo3(signature = (suite, seeds, false_alarm_rate, limit = None, options_json = "{}", jobs = None))]
pub fn calibrate_thresholds(
    py: Python<'_>,
    suite: Option<String>,
    seeds: Vec<Seed>,
    false_alarm_rate: f64,
    limit: Option<usize>,
    options_json: &str,
    jobs: Option<usize>,
) -> PyResult<std::collections::BTreeMap<String, Option<f64>>> {
    if !(0.0..=1.0).contains(&false_alarm_rate) {
        return Err(errors::ScenarioError::new_err(format!(
            "false_alarm_rate = {false_alarm_rate}: must be in [0, 1] (e.g. 0.1)"
        )));
    }
    if seeds.is_empty() {
        return Err(errors::ScenarioError::new_err("seeds is empty: give at least one seed"));
    }
    let options = EnvOptions::from_json(options_json).map_err(errors::to_py)?;
    py.detach(|| {
        let runner = crate::sweep::runner(jobs).map_err(crate::sweep::run_to_py)?;
        let mut outcomes = Vec::new();
        for &Seed(seed) in &seeds {
            let (_, eps) = suite_episodes(suite.as_deref(), seed, limit, &options).map_err(errors::to_py)?;
            let specs: Vec<_> = eps.episodes.iter().collect();
            let runs = runner.run(&specs, |_, _| Ok(())).map_err(crate::sweep::run_to_py)?;
            outcomes.extend(runs.into_iter().map(|r| r.outcome));
        }
        Ok(loomlab_scenarios::calibrate::calibrate(&outcomes, false_alarm_rate)
            .into_iter()
            .filter(|c| !is_reference(&c.label))
            .map(|c| (c.label, c.threshold))
            .collect())
    })
}
