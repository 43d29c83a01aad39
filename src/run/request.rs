//! The request: what a caller asks `loomlab run` to do, as plain data (ripgrep's `LowArgs`). The
//! command line fills it from its flags (`cli::run::RunArgs`), Python's `loomlab.run_suite` from
//! its keyword arguments (a `loomlab._native.RunRequest`); [`RunRequest::check`] is the one place
//! where either is refused, before anything is loaded, written or run.

use std::path::PathBuf;

use loomlab_detector::Registry;

/// A `[[detectors]]` entry given in memory (a Python dict), as its keys were written.
pub type EntryTable = toml::Table;

/// A value of an [`EntryTable`].
pub use toml::Value as EntryValue;

/// What `loomlab run` is asked to do. Integers are signed so that a negative count is refused
/// with the value given, whoever gave it.
#[derive(Debug, Clone, Default)]
pub struct RunRequest {
    /// The suite (a folder, a list file or one scenario file); `None`: the default suite.
    pub suite: Option<PathBuf>,
    /// The run folder; `None`: nothing is written (no report file, no plots, no page).
    pub out: Option<PathBuf>,
    /// Compare with this baseline report (or, with `bless`, write it).
    pub baseline: Option<PathBuf>,
    /// Write this run's report to `baseline` instead of comparing.
    pub bless: bool,
    /// Run only these detector ids (`all` for every registered one); `None`: the suite's.
    pub detectors: Option<Vec<String>>,
    /// Run the `[[detectors]]` entries of this TOML file instead of each scenario's own list.
    pub detectors_file: Option<PathBuf>,
    /// Entries run after `detectors_file`'s (or alone), instead of each scenario's own list.
    pub detector_entries: Vec<EntryTable>,
    /// Episodes run in parallel (`None`: one per CPU).
    pub jobs: Option<i64>,
    /// Suite seed mixed into every scenario's seed.
    pub seed: u64,
    /// Frame size for every episode.
    pub size: Option<i64>,
    /// The sensor profile every world runs under (`ideal`, `robot`; `None`: the suite's `sensor`
    /// key, else each scenario file's own sensor).
    pub sensor: Option<String>,
    /// Only the scenarios of these difficulty tiers (`0,2`).
    pub tier: Option<String>,
    /// Only the suite's first episodes.
    pub limit: Option<i64>,
    /// Continue the run in `out`.
    pub resume: bool,
    /// Replace the run in `out`.
    pub overwrite: bool,
    /// Print only regressions and errors.
    pub quiet: bool,
    /// Print only the pooled table.
    pub brief: bool,
    /// Write every episode's trace to `out/traces/`.
    pub traces: bool,
    /// Draw no PNG plot.
    pub no_plots: bool,
    /// Write no report.html.
    pub no_html: bool,
    /// Print the calibrated thresholds at this false-alarm rate.
    pub calibrate: Option<f64>,
    /// The command a resume message shows (`None`: this process's command line).
    pub command: Option<Vec<String>>,
}

/// A field of a [`RunRequest`], for a refusal to name as its caller spells it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// `jobs`.
    Jobs,
    /// `limit`.
    Limit,
}

impl Field {
    /// The command line's flag (`--jobs`).
    pub fn flag(self) -> &'static str {
        match self {
            Field::Jobs => "--jobs",
            Field::Limit => "--limit",
        }
    }

    /// The name of the keyword argument (`jobs`).
    pub fn keyword(self) -> &'static str {
        match self {
            Field::Jobs => "jobs",
            Field::Limit => "limit",
        }
    }

    /// What the field means (for a refusal).
    pub fn meaning(self) -> &'static str {
        match self {
            Field::Jobs => "episodes run in parallel; None: one per CPU",
            Field::Limit => "the number of episodes to run; None: all of them",
        }
    }
}

/// Why a [`RunRequest`] is refused (bad input: exit code 2). The messages name the command
/// line's flags; the Python binding names its keyword arguments instead.
#[derive(Debug, thiserror::Error)]
pub enum RequestError {
    /// A count below 1.
    #[error("{} must be at least 1", field.flag())]
    AtLeastOne {
        /// Which count.
        field: Field,
        /// The value given.
        value: i64,
    },
    /// A frame size out of range.
    #[error(
        "--size {0}: must be in {min}..={max} pixels (the detectors need frames of at least {min}×{min})",
        min = loomlab_sim::MIN_FRAME_SIZE,
        max = loomlab_sim::MAX_N
    )]
    Size(i64),
    /// A false-alarm rate outside [0, 1].
    #[error("--calibrate takes a false-alarm rate in [0, 1], got {0}")]
    Calibrate(f64),
    /// `resume` without a run folder.
    #[error("--resume continues the run in --out; give --out (the folder of the interrupted run)")]
    ResumeWithoutOut,
    /// `resume` and `overwrite` together.
    #[error("--resume continues the run in --out and --overwrite replaces it; give one of them")]
    ResumeAndOverwrite,
    /// `bless` without a baseline file.
    #[error("--bless writes the --baseline file; give --baseline")]
    BlessWithoutBaseline,
    /// A detector id that is not registered.
    #[error("unknown detector `{id}`; known ids: {known} (or `all`)")]
    UnknownDetector {
        /// The id as given.
        id: String,
        /// Every registered id, comma-separated.
        known: String,
    },
    /// A number in an in-memory detector entry that is NaN or infinite.
    #[error(
        "detectors entry {index} (`{name}`): {key} = {value}; numbers must be finite (give a finite threshold, or \
         leave the key out for the detector's default)"
    )]
    NotFinite {
        /// The entry's position among the in-memory entries.
        index: usize,
        /// The entry's label, else its id.
        name: String,
        /// The key as written (`params.k[1]`).
        key: String,
        /// The value (`nan`, `inf`, `-inf`).
        value: String,
    },
}

impl RunRequest {
    /// Refuses what cannot be run, before anything is loaded or written; `registry` is where the
    /// detector ids resolve. Returns the detector ids resolved (`all` expanded, duplicates
    /// dropped, order kept).
    pub fn check(&self, registry: &Registry) -> Result<Option<Vec<String>>, RequestError> {
        for (index, entry) in self.detector_entries.iter().enumerate() {
            check_finite(index, entry)?;
        }
        for (field, value) in [(Field::Limit, self.limit), (Field::Jobs, self.jobs)] {
            if let Some(value) = value.filter(|&v| v < 1) {
                return Err(RequestError::AtLeastOne { field, value });
            }
        }
        if let Some(n) = self.size
            && !(i64::from(loomlab_sim::MIN_FRAME_SIZE)..=i64::from(loomlab_sim::MAX_N)).contains(&n)
        {
            return Err(RequestError::Size(n));
        }
        if let Some(fa) = self.calibrate
            && !(0.0..=1.0).contains(&fa)
        {
            return Err(RequestError::Calibrate(fa));
        }
        if self.resume && self.out.is_none() {
            return Err(RequestError::ResumeWithoutOut);
        }
        if self.resume && self.overwrite {
            return Err(RequestError::ResumeAndOverwrite);
        }
        if self.bless && self.baseline.is_none() {
            return Err(RequestError::BlessWithoutBaseline);
        }
        self.detectors
            .as_deref()
            .map(|ids| resolve_ids(ids, registry))
            .transpose()
    }

    /// The frame size, once [checked](Self::check).
    pub(super) fn frame_size(&self) -> Option<u32> {
        self.size.and_then(|n| u32::try_from(n).ok())
    }

    /// The episode limit, once [checked](Self::check).
    pub(super) fn episode_limit(&self) -> Option<usize> {
        self.limit.map(|n| usize::try_from(n).unwrap_or(usize::MAX))
    }

    /// The number of workers, once [checked](Self::check).
    pub fn workers(&self) -> Option<usize> {
        self.jobs.map(|n| usize::try_from(n).unwrap_or(usize::MAX))
    }
}

/// The ids `ids` name in `registry`: `all` is every one, duplicates are dropped (order kept).
fn resolve_ids(ids: &[String], registry: &Registry) -> Result<Vec<String>, RequestError> {
    let mut resolved: Vec<String> = Vec::new();
    let unknown = |id: &str| RequestError::UnknownDetector {
        id: id.to_string(),
        known: registry.ids().join(", "),
    };
    for id in ids.iter().map(|id| id.trim()).filter(|id| !id.is_empty()) {
        let found: Vec<String> = if id == "all" {
            registry.ids().into_iter().map(String::from).collect()
        } else {
            vec![registry.find(id).ok_or_else(|| unknown(id))?.id.clone()]
        };
        for f in found {
            if !resolved.contains(&f) {
                resolved.push(f);
            }
        }
    }
    if resolved.is_empty() {
        return Err(unknown(&ids.join(",")));
    }
    Ok(resolved)
}

/// Refuses a NaN or infinite number anywhere in entry `index`, naming the key as written.
fn check_finite(index: usize, entry: &EntryTable) -> Result<(), RequestError> {
    fn walk(key: String, v: &EntryValue, bad: &mut Option<(String, f64)>) {
        match v {
            EntryValue::Float(x) if !x.is_finite() && bad.is_none() => *bad = Some((key, *x)),
            EntryValue::Table(t) => t.iter().for_each(|(k, x)| walk(format!("{key}.{k}"), x, bad)),
            EntryValue::Array(a) => a
                .iter()
                .enumerate()
                .for_each(|(i, x)| walk(format!("{key}[{i}]"), x, bad)),
            _ => {}
        }
    }
    let mut bad = None;
    for (k, v) in entry {
        walk(k.clone(), v, &mut bad);
    }
    let Some((key, x)) = bad else { return Ok(()) };
    let name = [entry.get("label"), entry.get("id")]
        .into_iter()
        .flatten()
        .find_map(|v| v.as_str().map(String::from))
        .unwrap_or_else(|| "?".into());
    let value = if x.is_nan() {
        "nan".to_string()
    } else if x > 0.0 {
        "inf".to_string()
    } else {
        "-inf".to_string()
    };
    Err(RequestError::NotFinite {
        index,
        name,
        key,
        value,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_below_one_are_refused_with_the_value() {
        let registry = Registry::builtin();
        for (limit, jobs, field) in [(Some(0), None, Field::Limit), (None, Some(-2), Field::Jobs)] {
            let r = RunRequest {
                limit,
                jobs,
                ..Default::default()
            };
            match r.check(registry) {
                Err(RequestError::AtLeastOne { field: f, value }) => {
                    assert_eq!(f, field);
                    assert_eq!(Some(value), limit.or(jobs));
                }
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn resume_needs_a_folder_and_ids_resolve_in_the_registry() {
        let registry = Registry::builtin();
        let r = RunRequest {
            resume: true,
            ..Default::default()
        };
        assert!(matches!(r.check(registry), Err(RequestError::ResumeWithoutOut)));
        let ids = |list: &[&str]| RunRequest {
            detectors: Some(list.iter().map(|s| s.to_string()).collect()),
            ..Default::default()
        };
        assert_eq!(
            ids(&["soc", " soc", "hopfield"]).check(registry).unwrap(),
            Some(vec!["soc".to_string(), "hopfield".to_string()])
        );
        let e = ids(&["soc", "nosuch"]).check(registry).unwrap_err().to_string();
        assert!(e.starts_with("unknown detector `nosuch`; known ids: hopfield"), "{e}");
        assert_eq!(
            ids(&["all"]).check(registry).unwrap().unwrap().len(),
            registry.ids().len()
        );
    }

    #[test]
    fn a_non_finite_entry_value_is_named_by_its_key() {
        let entry: EntryTable = toml::from_str("id = \"soc\"\nlabel = \"lo\"\nparams = { k = [1.0, inf] }").unwrap();
        let r = RunRequest {
            detector_entries: vec![EntryTable::new(), entry],
            ..Default::default()
        };
        let e = r.check(Registry::builtin()).unwrap_err().to_string();
        assert!(
            e.starts_with("detectors entry 1 (`lo`): params.k[1] = inf; numbers must be finite"),
            "{e}"
        );
    }
}
