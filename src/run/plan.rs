//! The plan: a checked [`RunRequest`] with its suite loaded, its episodes counted and its baseline
//! read (ripgrep's `HiArgs`). Everything the request can be refused for is refused here, before
//! the run folder is touched.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use anyhow::bail;
use loomlab_detector::Registry;
use loomlab_scenarios::reference::REFERENCE_LABELS;
use loomlab_scenarios::report::Report;
use loomlab_scenarios::schema::{DetectorDesc, Scenario, load_detector_entries};
use loomlab_scenarios::{DEFAULT_SUITE, EpisodeSpec, LoadOptions, ScenarioError, Suite, load_suite};
use serde::Deserialize as _;

use super::request::{EntryValue, RunRequest};

/// A run, planned: what [`super::RunSession`] runs.
pub struct RunPlan {
    /// The request, checked.
    pub request: RunRequest,
    /// The suite as given (or the default suite).
    pub suite_path: PathBuf,
    /// The suite, loaded (and filtered by tier).
    pub suite: Suite,
    /// Every scenario's tier.
    pub tiers: BTreeMap<String, u8>,
    /// The baseline to compare with (not when blessing).
    pub baseline: Option<Report>,
    /// The episodes the run consists of: the suite's first `total`.
    pub total: usize,
    /// The first episode's lead margin (the report's).
    pub lead_margin_s: f64,
    /// Per scenario name: the position of its first episode in the suite and its index.
    offsets: BTreeMap<String, (usize, usize)>,
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

impl RunPlan {
    /// Checks `request` and loads its suite with the detectors of `registry` (and `added`, run in
    /// every scenario next to the suite's rows).
    pub fn new(request: RunRequest, registry: Registry, added: Vec<DetectorDesc>) -> anyhow::Result<Self> {
        let detectors = request.check(&registry)?;
        let suite_path = request.suite.clone().unwrap_or_else(default_suite);
        let detector_entries = entries(&request, &suite_path, detectors.as_deref())?;
        let opts = LoadOptions {
            seed: request.seed,
            size: request.frame_size(),
            sensor: request
                .sensor
                .as_deref()
                .map(loomlab_sim::SensorProfile::named)
                .transpose()
                .map_err(|e| anyhow::anyhow!("--sensor: {e}"))?,
            detectors,
            detector_entries,
            added_detectors: added,
            registry,
        };
        let mut suite = load_suite(&suite_path, &opts)?;
        if let Some(spec) = &request.tier {
            let tiers = loomlab_scenarios::tier::parse_tier_list(spec).map_err(anyhow::Error::msg)?;
            suite.retain_tiers(&tiers)?;
        }
        let tiers = suite.tiers();
        // Read the baseline before spending time on the run (a missing file is bad input).
        let baseline = match (&request.baseline, request.bless) {
            (Some(p), false) => Some(Report::read_json(p)?),
            _ => None,
        };
        let suite_total: usize = suite.scenarios.iter().map(|s| s.len()).fold(0, usize::saturating_add);
        let total = suite_total.min(request.episode_limit().unwrap_or(usize::MAX));
        let lead_margin_s = match suite.episodes().take(total).next() {
            Some(ep) => ep?.scoring.lead_margin_s,
            None => bail!("{}: no episodes to run", suite_path.display()),
        };
        let offsets = suite
            .scenarios
            .iter()
            .enumerate()
            .scan(0usize, |offset, (i, s)| {
                let here = *offset;
                *offset += s.len();
                Some((s.name.clone(), (here, i)))
            })
            .collect();
        let plan = Self {
            request,
            suite_path,
            suite,
            tiers,
            baseline,
            total,
            lead_margin_s,
            offsets,
        };
        plan.check_baseline(suite_total)?;
        Ok(plan)
    }

    /// A baseline is of the same suite and selection, or comparing (or replacing) it means nothing.
    fn check_baseline(&self, suite_total: usize) -> anyhow::Result<()> {
        let (Some(path), r) = (&self.request.baseline, &self.request) else {
            return Ok(());
        };
        let total = self.total;
        if r.bless && total < suite_total {
            bail!(
                "--bless with --limit {total}: the baseline would hold only {total} of the suite's {suite_total} episodes; \
                 bless the whole suite (drop --limit)"
            );
        }
        let existing = match &self.baseline {
            Some(b) => Some(b.clone()),
            // --bless replaces a baseline only with a run of the same suite
            None if path.exists() => Report::read_json(path).ok(),
            None => None,
        };
        if let Some(base) = existing
            && let Err(why) = same_suite(&base, &self.counts(), r.seed)
        {
            let what = if r.bless {
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
        Ok(())
    }

    /// The run's episodes per scenario.
    fn counts(&self) -> BTreeMap<&str, u64> {
        let mut counts = BTreeMap::new();
        let mut left = self.total;
        for s in &self.suite.scenarios {
            let n = s.len().min(left);
            if n > 0 {
                counts.insert(s.name.as_str(), n as u64);
            }
            left -= n;
        }
        counts
    }

    /// The scenario named `name`.
    pub fn scenario(&self, name: &str) -> Option<&Scenario> {
        self.offsets.get(name).map(|&(_, i)| &self.suite.scenarios[i])
    }

    /// The position in the run of episode `episode` of scenario `scenario`; `None`: not in the run.
    pub fn position(&self, scenario: &str, episode: usize) -> Option<usize> {
        let &(offset, i) = self.offsets.get(scenario)?;
        (episode < self.suite.scenarios[i].len() && offset + episode < self.total).then_some(offset + episode)
    }

    /// The row labels a finished episode has (its detectors and the reference rows); `None`: an
    /// episode that is not part of the run.
    pub fn labels(&self, scenario: &str, episode: usize) -> Option<BTreeSet<String>> {
        self.position(scenario, episode)?;
        let spec = self.scenario(scenario)?.episode(episode).ok()?;
        Some(
            spec.detectors
                .iter()
                .map(|d| d.label.clone())
                .chain(REFERENCE_LABELS.iter().map(|l| l.to_string()))
                .collect(),
        )
    }

    /// Episode `episode` of scenario `scenario`, built.
    pub fn spec(&self, scenario: &str, episode: usize) -> anyhow::Result<EpisodeSpec> {
        let Some(s) = self.scenario(scenario) else {
            bail!("exemplar: scenario `{scenario}` is not in the suite");
        };
        Ok(s.episode(episode)?)
    }
}

/// The `[[detectors]]` entries the run uses instead of each scenario's list: the detectors file's,
/// then the in-memory ones; `ids` (the detectors asked for) must each have one.
fn entries(request: &RunRequest, suite: &Path, ids: Option<&[String]>) -> anyhow::Result<Option<Vec<DetectorDesc>>> {
    let mut entries = match &request.detectors_file {
        Some(path) => Some(load_detector_entries(path)?),
        None => None,
    };
    for table in &request.detector_entries {
        let given = DetectorDesc::deserialize(EntryValue::Table(table.clone())).map_err(|e| {
            ScenarioError::key(
                suite,
                "detectors",
                format!("a detector entry (dict) is not valid: {e}; its keys are those of a [[detectors]] table"),
            )
        })?;
        entries.get_or_insert_with(Vec::new).push(given);
    }
    // --detectors filters the entries: every id must be there
    if let (Some(ids), Some(entries)) = (ids, &entries) {
        let source = match &request.detectors_file {
            Some(path) => path.display().to_string(),
            None => "the detector entries given".to_string(),
        };
        for id in ids {
            if !entries.iter().any(|e| &e.id == id) {
                let have: BTreeSet<&str> = entries.iter().map(|e| e.id.as_str()).collect();
                bail!(
                    "--detectors {id}: {source} has no `{id}` entry (it has {}); --detectors only filters the file's entries",
                    have.into_iter().collect::<Vec<_>>().join(", ")
                );
            }
        }
    }
    Ok(entries)
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
