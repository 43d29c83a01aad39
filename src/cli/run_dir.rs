//! The output folder of `loomlab run`: what a run writes there, its manifest, and the rules that
//! keep earlier results: a folder holding another run is refused unless the user says `--resume`
//! (continue it: only the missing episodes run) or `--overwrite` (delete its files first).
//!
//! `manifest.json` records what the folder holds: the run's fingerprint (a hash of every episode
//! as built and the options that change rows, see `loomlab_scenarios::fingerprint`), its options,
//! the command line and a state (`running`, `interrupted`, `complete`). `report.json` is written
//! (atomically) only when every episode is done; an interrupted run leaves `report.partial.json`.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use loomlab_scenarios::episodes_csv::{EpisodesCsvWriter, format_rows, header_line, parse_episodes_csv};
use loomlab_scenarios::metrics::EpisodeOutcome;
use loomlab_scenarios::report::LOOMLAB_VERSION;
use serde::{Deserialize, Serialize};

/// The manifest's file name.
pub const MANIFEST: &str = "manifest.json";
/// The per-episode rows.
pub const EPISODES_CSV: &str = "episodes.csv";
/// The report of a complete run.
pub const REPORT: &str = "report.json";
/// The report of the episodes an interrupted run finished.
pub const PARTIAL_REPORT: &str = "report.partial.json";
/// Every file and folder a run writes (what `--overwrite` removes; nothing else is touched).
pub const RUN_FILES: [&str; 14] = [
    MANIFEST,
    EPISODES_CSV,
    REPORT,
    PARTIAL_REPORT,
    "roc.png",
    "rates.png",
    "collisions.png",
    "lv.png",
    "theta_required.png",
    "theta_hat.png",
    "trace.png",
    "traces",
    loomlab_report::REPORT_HTML,
    loomlab_report::EXEMPLARS_DIR,
];

/// How far a run in a folder got.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunState {
    /// Started (or killed without a chance to say so).
    Running,
    /// Stopped by Ctrl-C / SIGTERM after finishing the episodes in flight.
    Interrupted,
    /// Every episode done and report.json written.
    Complete,
}

/// `manifest.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// `loomlab run`.
    pub tool: String,
    /// The loomlab version that wrote the folder.
    pub version: String,
    /// Hash of every episode as built and the options that change rows.
    pub fingerprint: String,
    /// The suite as given.
    pub suite: String,
    /// Episodes the run consists of.
    pub episodes: usize,
    /// The command line (to print how to resume).
    pub command: Vec<String>,
    /// How far it got.
    pub state: RunState,
    /// Wall time spent on the run so far, over all its invocations (s).
    #[serde(default)]
    pub wall_time_s: f64,
}

impl Manifest {
    /// A new manifest of a run starting now.
    pub fn new(fingerprint: String, suite: &Path, episodes: usize) -> Self {
        Self {
            tool: "loomlab run".into(),
            version: LOOMLAB_VERSION.into(),
            fingerprint,
            suite: suite.display().to_string(),
            episodes,
            command: std::env::args().collect(),
            state: RunState::Running,
            wall_time_s: 0.0,
        }
    }

    /// The command that resumes this run.
    pub fn resume_command(&self) -> String {
        let mut args: Vec<String> = self
            .command
            .iter()
            .filter(|a| *a != "--overwrite" && *a != "--resume")
            .map(|a| shell_quote(a))
            .collect();
        args.push("--resume".into());
        args.join(" ")
    }

    /// Writes the manifest atomically.
    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        write_atomic(&dir.join(MANIFEST), text.as_bytes())
    }

    fn read(dir: &Path) -> anyhow::Result<Option<Self>> {
        let path = dir.join(MANIFEST);
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
        let m = serde_json::from_str(&text).with_context(|| {
            format!(
                "{}: not a loomlab run manifest; use --overwrite or another --out",
                path.display()
            )
        })?;
        Ok(Some(m))
    }
}

/// What to do with a folder that holds an earlier run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Existing {
    /// Refuse (exit 2) with a hint.
    Refuse,
    /// Continue it.
    Resume,
    /// Delete its files first.
    Overwrite,
}

/// The output folder of a run and its manifest.
pub struct RunDir {
    /// The folder.
    pub dir: PathBuf,
    /// The manifest (state `running` once prepared).
    pub manifest: Manifest,
}

/// A prepared output folder: the episodes an earlier (interrupted) run finished, when resuming,
/// and the episodes.csv writer positioned after them.
pub struct Prepared {
    /// The folder and its manifest.
    pub dir: RunDir,
    /// Outcomes of the episodes finished earlier.
    pub done: Vec<EpisodeOutcome>,
    /// Appends to episodes.csv.
    pub csv: EpisodesCsvWriter,
}

impl RunDir {
    /// Prepares `dir` for the run `manifest` describes. `labels(scenario, episode)` gives the row
    /// labels a finished episode has (its detectors and reference rows), or `None` for an episode
    /// that is not part of the run; a resumed episode missing any of its rows runs again.
    pub fn prepare(
        dir: &Path,
        mut manifest: Manifest,
        existing: Existing,
        labels: impl Fn(&str, usize) -> Option<BTreeSet<String>>,
    ) -> anyhow::Result<Prepared> {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let found: Vec<&str> = RUN_FILES.iter().copied().filter(|f| dir.join(f).exists()).collect();
        let earlier = Manifest::read(dir)?;
        let mut done = Vec::new();
        match (existing, found.is_empty()) {
            (_, true) => {}
            (Existing::Refuse, false) => {
                let what = match &earlier {
                    Some(m) => format!(
                        "{} run of {} ({} episodes)",
                        match m.state {
                            RunState::Complete => "a complete",
                            RunState::Interrupted => "an interrupted",
                            RunState::Running => "a started (possibly killed)",
                        },
                        m.suite,
                        m.episodes
                    ),
                    None => format!("results of an earlier run ({})", found.join(", ")),
                };
                bail!(
                    "{} already holds {what}; nothing was changed. Use --resume to continue it (only missing \
                     episodes run), --overwrite to replace it, or another --out",
                    dir.display()
                );
            }
            (Existing::Overwrite, false) => {
                for f in &found {
                    let p = dir.join(f);
                    let r = if p.is_dir() {
                        std::fs::remove_dir_all(&p)
                    } else {
                        std::fs::remove_file(&p)
                    };
                    r.with_context(|| format!("cannot remove {}", p.display()))?;
                }
            }
            (Existing::Resume, false) => {
                let Some(earlier) = earlier else {
                    bail!(
                        "{}: no {MANIFEST}, so the results there cannot be resumed (written by an older version?); \
                         use --overwrite or another --out",
                        dir.display()
                    );
                };
                if earlier.fingerprint != manifest.fingerprint {
                    bail!(
                        "{} holds a different run (suite {}, {} episodes, loomlab {}): its episodes or options \
                         differ from this command's. Resume it with its own command:\n  {}\nor use --overwrite \
                         or another --out",
                        dir.display(),
                        earlier.suite,
                        earlier.episodes,
                        earlier.version,
                        earlier.resume_command()
                    );
                }
                done = finished_episodes(&dir.join(EPISODES_CSV), &labels)?;
                manifest.wall_time_s = earlier.wall_time_s;
            }
        }
        // episodes.csv holds exactly the finished episodes: rewritten atomically, then appended to
        let csv_path = dir.join(EPISODES_CSV);
        let mut text = header_line();
        for e in &done {
            text += &format_rows(e);
        }
        write_atomic(&csv_path, text.as_bytes())?;
        let _ = std::fs::remove_file(dir.join(REPORT));
        manifest.write(dir)?;
        Ok(Prepared {
            dir: Self {
                dir: dir.into(),
                manifest,
            },
            done,
            csv: EpisodesCsvWriter::append(&csv_path)?,
        })
    }

    /// Records the run's state in the manifest.
    pub fn set_state(&mut self, state: RunState) -> anyhow::Result<()> {
        self.manifest.state = state;
        self.manifest.write(&self.dir)
    }
}

/// The complete episodes of an earlier run's episodes.csv (a final line cut short is dropped; an
/// episode missing any of its rows, or not part of this run, is dropped).
fn finished_episodes(
    path: &Path,
    labels: &impl Fn(&str, usize) -> Option<BTreeSet<String>>,
) -> anyhow::Result<Vec<EpisodeOutcome>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
    };
    let whole = &text[..text.rfind('\n').map_or(0, |i| i + 1)];
    let outcomes = parse_episodes_csv(whole, path)
        .with_context(|| "cannot resume from it; use --overwrite or another --out".to_string())?;
    let mut seen = BTreeSet::new();
    Ok(outcomes
        .into_iter()
        .filter(|e| {
            let have: BTreeSet<String> = e.detectors.iter().map(|d| d.detector.clone()).collect();
            labels(&e.scenario, e.episode).is_some_and(|want| want == have)
                && seen.insert((e.scenario.clone(), e.episode))
        })
        .collect())
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a reader
/// (or a crash) never sees half a file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp"));
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// `arg` quoted for a POSIX shell when it needs it.
fn shell_quote(arg: &str) -> String {
    if !arg.is_empty()
        && arg
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=,:@+".contains(c))
    {
        arg.to_string()
    } else {
        format!("'{}'", arg.replace('\'', r"'\''"))
    }
}
