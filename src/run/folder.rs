//! The session's folder steps: the run's fingerprint (every episode checked, or taken over from the
//! run `--resume` continues), the folder prepared ([`RunDir::prepare`]: refuse, resume or
//! overwrite an earlier run) and the writers of the files episodes append to as they finish.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use anyhow::Context as _;
use loomlab_report::EXEMPLARS_DIR;
use loomlab_scenarios::Suite;
use loomlab_scenarios::episodes_csv::EpisodesCsvWriter;
use loomlab_scenarios::fingerprint::Fingerprint;
use loomlab_scenarios::metrics::EpisodeOutcome;
use loomlab_scenarios::report::LOOMLAB_VERSION;

use super::heartbeat::Heartbeat;
use super::run_dir::{
    CannotWrite, EPISODES_CSV, Existing, Manifest, Outputs, PARTIAL_REPORT, Prepared, REPORT, RunDir, open_append,
};
use super::run_lock::RunLock;
use super::{CHUNK, RunSession};

/// Every finished episode's plot samples (θ̂ points, sample rank), one JSON line each: a resumed
/// run draws its plots from all of them, the same as an uninterrupted run's.
pub(super) const PLOT_SAMPLES: &str = "plot_samples.jsonl";

/// The folder of `--traces`.
pub(super) const TRACES_DIR: &str = "traces";

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

/// A prepared run folder: its [`RunDir`], the episodes.csv writer and the episodes an earlier
/// invocation finished (with their positions in the run).
pub(super) struct Opened {
    /// The folder.
    pub dir: RunDir,
    /// Appends to episodes.csv.
    pub csv: EpisodesCsvWriter,
    /// The episodes finished earlier (`--resume`), by position.
    pub done: Vec<(usize, EpisodeOutcome)>,
}

/// The writers the finished episodes go to, opened once the runner is up.
pub(super) struct Writers {
    /// The folder.
    pub dir: RunDir,
    /// Appends to episodes.csv.
    pub csv: Mutex<EpisodesCsvWriter>,
    /// `plot_samples.jsonl`.
    pub samples_path: PathBuf,
    /// Appends to `plot_samples.jsonl`.
    pub samples_file: Mutex<File>,
    /// `traces/` (created with `--traces`).
    pub traces_dir: PathBuf,
}

impl RunSession {
    /// The folder step: takes the folder's lock, fingerprints the run and prepares the folder.
    /// `None`: interrupted while checking the episodes (the message printed, nothing changed).
    pub(super) fn open_folder(&self, out: &Path) -> anyhow::Result<Option<Opened>> {
        let r = &self.plan.request;
        let existing = match (r.resume, r.overwrite) {
            (true, _) => Existing::Resume,
            (false, true) => Existing::Overwrite,
            (false, false) => Existing::Refuse,
        };
        let mut manifest = Manifest::new(String::new(), &self.plan.suite_path, self.plan.total);
        manifest.traces = r.traces;
        manifest.sensor = self.plan.suite.sensor.unwrap_or_default().to_string();
        if let Some(command) = &r.command {
            manifest.command = command.clone();
        }
        // the handler first: an interrupt while the episodes are checked, and from the moment the
        // manifest says `running`, is handled
        self.interrupt.arm();
        // a folder in use by another run is refused before the (possibly long) check
        let lock = if out.is_dir() {
            Some(RunLock::acquire(out)?)
        } else {
            None
        };
        // Check every episode to run and fingerprint them, unless --resume continues a run of the
        // same definition (checked when it started): a resume costs O(its finished episodes).
        manifest.definition = definition_fingerprint(&self.plan.suite, self.plan.total)?;
        manifest.fingerprint = match self.run_fingerprint(out, &manifest)? {
            Some(fingerprint) => fingerprint,
            None => return Ok(None),
        };
        let is_episode_file = |name: &str, ext: &str| -> bool {
            let Some((scenario, index)) = name.strip_suffix(ext).and_then(|stem| stem.rsplit_once('_')) else {
                return false;
            };
            index
                .parse::<usize>()
                .is_ok_and(|i| format!("{i:04}") == index && self.plan.position(scenario, i).is_some())
        };
        let is_trace = |name: &str| is_episode_file(name, ".csv");
        let is_gif = |name: &str| is_episode_file(name, ".gif");
        let outputs = Outputs {
            files: self.output_files(),
            folders: [
                (r.traces).then_some((TRACES_DIR, &is_trace as &dyn Fn(&str) -> bool)),
                (!r.no_html).then_some((EXEMPLARS_DIR, &is_gif as &dyn Fn(&str) -> bool)),
            ]
            .into_iter()
            .flatten()
            .collect(),
        };
        let labels = |scenario: &str, episode: usize| self.plan.labels(scenario, episode);
        let active = self.interrupt.active().clone();
        let Prepared { dir, done, csv } = RunDir::prepare(out, manifest, existing, &outputs, lock, labels, active)?;
        let done = done
            .into_iter()
            .filter_map(|o| Some((self.plan.position(&o.scenario, o.episode)?, o)))
            .collect();
        Ok(Some(Opened { dir, csv, done }))
    }

    /// The top-level files the run may write in its folder (checked before it starts; the
    /// sub-folders' files are checked by name).
    fn output_files(&self) -> Vec<String> {
        let r = &self.plan.request;
        let mut files: Vec<String> = [EPISODES_CSV, REPORT, PARTIAL_REPORT, PLOT_SAMPLES]
            .map(String::from)
            .to_vec();
        if !r.no_html {
            files.push(loomlab_report::REPORT_HTML.into());
        }
        if !r.no_plots {
            for f in FIGURES {
                files.push(format!("{f}.png"));
                files.push(format!(".{f}.tmp.png"));
            }
        }
        files
    }

    /// The fingerprint of the run `manifest` describes: the one of the run in `out` when `--resume`
    /// continues a run of the same definition (its episodes were checked when it started), else
    /// every episode checked and fingerprinted now. `None`: interrupted while checking (the
    /// message printed).
    fn run_fingerprint(&self, out: &Path, manifest: &Manifest) -> anyhow::Result<Option<String>> {
        let r = &self.plan.request;
        let earlier = if r.resume {
            Manifest::read(out).ok().flatten()
        } else {
            None
        };
        if let Some(m) = earlier.as_ref().filter(|m| m.sensor != manifest.sensor) {
            let name = |s: &str| {
                if s.is_empty() {
                    "none (the scenario files' own)".to_string()
                } else {
                    format!("`{s}`")
                }
            };
            anyhow::bail!(
                "{}: the run there ran under sensor profile {}, this one asks for {}; resume it with the same \
                 --sensor (or suite `sensor` key), or start over with --overwrite",
                out.display(),
                name(&m.sensor),
                name(&manifest.sensor)
            );
        }
        if let Some(m) = earlier.filter(|m| m.definition == manifest.definition && m.episodes == manifest.episodes) {
            if !r.quiet {
                errln!(
                    "the suite is defined as when the run started: its {} episodes were checked then, not again",
                    manifest.episodes
                );
            }
            return Ok(Some(m.fingerprint));
        }
        let checked = self.check_episodes(manifest.episodes)?;
        if checked.is_none() {
            errln!(
                "interrupted while checking the suite's episodes: nothing was run{}",
                if r.resume {
                    format!(
                        "; the run in {} is unchanged. Resume with:\n  {}",
                        out.display(),
                        manifest.resume_command()
                    )
                } else {
                    " or written".to_string()
                }
            );
        }
        Ok(checked)
    }

    /// Expands and checks the run's `total` episodes one at a time (none is kept) and returns
    /// their fingerprint; `None` when interrupted (Ctrl-C) first. A suite of millions of episodes
    /// shows its progress (a bar, or a line every few seconds without a terminal).
    fn check_episodes(&self, total: usize) -> anyhow::Result<Option<String>> {
        let mut fingerprint = Fingerprint::new();
        fingerprint.add(format!("{LOOMLAB_VERSION}\nloomlab run\n").as_bytes());
        let large = !self.plan.request.quiet && total >= CHECK_PROGRESS_FROM;
        let checked = Arc::new(AtomicUsize::new(0));
        let bar = if large {
            crate::cli::progress(total as u64, "checking")
        } else {
            indicatif::ProgressBar::hidden()
        };
        let heartbeat = Heartbeat::unless_terminal(!large, &checked, total, "checked");
        for (i, ep) in self.plan.suite.episodes().take(total).enumerate() {
            if i % CHUNK == 0 {
                if self.interrupt.stopped() {
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
}

impl Opened {
    /// Opens the files the finished episodes are appended to (`traces/` created with `--traces`,
    /// `plot_samples.jsonl` emptied unless resuming).
    pub(super) fn writers(self, traces: bool, resume: bool) -> anyhow::Result<(Writers, Vec<(usize, EpisodeOutcome)>)> {
        let Opened { dir, csv, done } = self;
        let out = dir.dir.clone();
        let traces_dir = if traces {
            dir.create_dir(TRACES_DIR)?
        } else {
            out.join(TRACES_DIR)
        };
        // every finished episode's plot samples, kept so that a resumed run draws the same plots
        dir.record(PLOT_SAMPLES)?;
        let samples_path = out.join(PLOT_SAMPLES);
        let samples_file = open_append(&samples_path)
            .and_then(|f| {
                if !resume {
                    f.set_len(0)?;
                }
                Ok(f)
            })
            .with_context(|| CannotWrite(format!("cannot write {}", samples_path.display())))?;
        let writers = Writers {
            dir,
            csv: Mutex::new(csv),
            samples_path,
            samples_file: Mutex::new(samples_file),
            traces_dir,
        };
        Ok((writers, done))
    }
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
