//! The output folder of `loomlab run`: what a run writes there, its manifest, and the rules that
//! keep earlier results: a folder holding another run is refused unless the user says `--resume`
//! (continue it: only the missing episodes run) or `--overwrite` (delete its files first).
//!
//! `manifest.json` records what the folder holds: the run's fingerprint (a hash of every episode
//! as built and the options that change rows, see `loomlab_scenarios::fingerprint`), its options,
//! the command line and a state (`running`, `interrupted`, `complete`). `report.json` is written
//! (atomically) only when every episode is done; an interrupted run leaves `report.partial.json`.
//!
//! `written.txt` (named by the manifest's `written` key) lists, one path per line relative to the
//! folder, every file and folder (`traces/`) the run wrote; a path is appended *before* its file
//! is created, so a crash never leaves an unlisted file. `--overwrite` deletes exactly the listed
//! files (then the listed folders, only if empty): a file of the user's in `traces/` or
//! `exemplars/`, or anywhere else in the folder, is never touched. A folder written by a version
//! without `written.txt` has only its top-level run files (`RUN_FILES`) deleted, no sub-folder.

use std::collections::BTreeSet;
use std::io::Write as _;
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

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
/// The list of every file the run wrote (see the module docs).
pub const WRITTEN: &str = "written.txt";
/// The top-level files a run writes: a folder holding one of them holds an earlier run; a folder
/// without `written.txt` (an older version's) has exactly these deleted by `--overwrite`.
pub const RUN_FILES: [&str; 13] = [
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
    loomlab_report::REPORT_HTML,
    WRITTEN,
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
    /// Whether the run writes `traces/` (`--traces`): a resumed run must too, or its traces stop.
    #[serde(default)]
    pub traces: bool,
    /// The file listing every file the run wrote (`written.txt`; empty: an older version's run).
    #[serde(default)]
    pub written: String,
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
            traces: false,
            written: WRITTEN.into(),
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
                "{}: not a loomlab run manifest (a file of yours?); nothing was changed, use another --out",
                path.display()
            )
        })?;
        Ok(Some(m))
    }
}

/// The run in progress: its folder and manifest, shared with the interrupt handler (a second
/// Ctrl-C records the state `interrupted` before exiting) and guarding every manifest write.
static ACTIVE: Mutex<Option<(PathBuf, Manifest)>> = Mutex::new(None);

/// The resume command of a run that stopped on an error (printed after the error by `main`).
pub static RESUME_HINT: Mutex<Option<String>> = Mutex::new(None);

/// An output file or folder could not be written or read back (exit code 3: not bad input).
#[derive(Debug)]
pub struct CannotWrite(pub String);

impl std::fmt::Display for CannotWrite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Stops the run in progress at once (a second Ctrl-C): records the state `interrupted` (the
/// finished episodes are in episodes.csv), deletes a stale `report.partial.json`, and returns
/// the resume command.
pub fn abandon_active_run() -> Option<String> {
    let mut guard = ACTIVE.lock().unwrap_or_else(|e| e.into_inner());
    let (dir, m) = guard.as_mut()?;
    if m.state != RunState::Running {
        return None;
    }
    m.state = RunState::Interrupted;
    let _ = m.write(dir);
    let _ = std::fs::remove_file(dir.join(PARTIAL_REPORT));
    Some(m.resume_command())
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
    /// `written.txt`: the paths listed so far and the file, open for appending.
    written: Mutex<(BTreeSet<String>, std::fs::File)>,
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
        let found: Vec<&str> = RUN_FILES
            .iter()
            .copied()
            .filter(|f| std::fs::symlink_metadata(dir.join(f)).is_ok_and(|m| !m.is_dir()))
            .collect();
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
                let overwrite = if dir.join(WRITTEN).is_file() {
                    format!(
                        "--overwrite to replace it (deletes only the files that run wrote, as listed in its \
                         {WRITTEN}; nothing else in the folder)"
                    )
                } else {
                    format!(
                        "--overwrite to replace it (deletes only {}; no sub-folder, nothing else)",
                        found.join(", ")
                    )
                };
                bail!(
                    "{} already holds {what}; nothing was changed. Use --resume to continue it (only missing \
                     episodes run), {overwrite}, or another --out",
                    dir.display()
                );
            }
            (Existing::Overwrite, false) => remove_run_files(dir, &found)?,
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
                if earlier.traces != manifest.traces {
                    bail!(
                        "{}: the run there was started {} --traces; resuming it {} would leave its traces \
                         incomplete. Resume it with its own command:\n  {}",
                        dir.display(),
                        if earlier.traces { "with" } else { "without" },
                        if manifest.traces { "with" } else { "without" },
                        earlier.resume_command()
                    );
                }
                done = finished_episodes(&dir.join(EPISODES_CSV), &labels)?;
                manifest.wall_time_s = earlier.wall_time_s;
            }
        }
        // written.txt: kept when resuming, else started afresh
        let written_path = dir.join(WRITTEN);
        let mut listed = BTreeSet::new();
        if existing == Existing::Resume
            && let Ok(text) = std::fs::read_to_string(&written_path)
        {
            listed.extend(text.lines().filter(|l| !l.is_empty()).map(String::from));
        } else {
            std::fs::write(&written_path, "")
                .with_context(|| CannotWrite(format!("cannot write {}", written_path.display())))?;
        }
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(&written_path)
            .with_context(|| CannotWrite(format!("cannot write {}", written_path.display())))?;
        let run_dir = Self {
            dir: dir.into(),
            manifest,
            written: Mutex::new((listed, file)),
        };
        // episodes.csv holds exactly the finished episodes: rewritten atomically, then appended to
        run_dir.record(EPISODES_CSV)?;
        let csv_path = dir.join(EPISODES_CSV);
        let mut text = header_line();
        for e in &done {
            text += &format_rows(e);
        }
        write_atomic(&csv_path, text.as_bytes())?;
        let _ = std::fs::remove_file(dir.join(REPORT));
        run_dir.write_manifest()?;
        Ok(Prepared {
            dir: run_dir,
            done,
            csv: EpisodesCsvWriter::append(&csv_path)?,
        })
    }

    /// Lists `rel` (a path relative to the folder; a folder ends in `/`) in `written.txt`, before
    /// the caller creates it; also the temporary file [`write_atomic`] writes it through.
    pub fn record(&self, rel: &str) -> anyhow::Result<()> {
        let mut guard = self.written.lock().unwrap_or_else(|e| e.into_inner());
        let (listed, file) = &mut *guard;
        let mut lines = String::new();
        let tmp = tmp_name(rel);
        for r in [rel, tmp.as_str()] {
            if !r.is_empty() && listed.insert(r.to_string()) {
                lines += r;
                lines.push('\n');
            }
        }
        if !lines.is_empty() {
            file.write_all(lines.as_bytes())
                .with_context(|| CannotWrite(format!("cannot write {}", self.dir.join(WRITTEN).display())))?;
        }
        Ok(())
    }

    /// Creates the sub-folder `rel` of the run folder, listing it in `written.txt` if the run
    /// creates it (a folder that was there before is never removed by `--overwrite`).
    pub fn create_dir(&self, rel: &str) -> anyhow::Result<PathBuf> {
        let path = self.dir.join(rel);
        if !path.is_dir() {
            self.record(&format!("{rel}/"))?;
            std::fs::create_dir_all(&path).with_context(|| CannotWrite(format!("cannot create {}", path.display())))?;
        }
        Ok(path)
    }

    /// The paths listed in `written.txt` so far.
    pub fn written(&self) -> BTreeSet<String> {
        self.written.lock().unwrap_or_else(|e| e.into_inner()).0.clone()
    }

    /// Records the run's state in the manifest.
    pub fn set_state(&mut self, state: RunState) -> anyhow::Result<()> {
        self.manifest.state = state;
        self.write_manifest()
    }

    /// Writes the manifest (under the lock the interrupt handler takes).
    fn write_manifest(&self) -> anyhow::Result<()> {
        let mut guard = ACTIVE.lock().unwrap_or_else(|e| e.into_inner());
        *guard = Some((self.dir.clone(), self.manifest.clone()));
        self.manifest.write(&self.dir)
    }
}

impl Drop for RunDir {
    /// A run left in the state `running` stopped on an error: record `interrupted` (every
    /// finished episode is in episodes.csv) and leave the resume command for `main` to print.
    fn drop(&mut self) {
        let mut guard = ACTIVE.lock().unwrap_or_else(|e| e.into_inner());
        if self.manifest.state == RunState::Running {
            self.manifest.state = RunState::Interrupted;
            if self.manifest.write(&self.dir).is_ok() {
                *RESUME_HINT.lock().unwrap_or_else(|e| e.into_inner()) = Some(self.manifest.resume_command());
            }
        }
        *guard = None;
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

/// The temporary file [`write_atomic`] writes `rel` through (empty for a folder).
fn tmp_name(rel: &str) -> String {
    if rel.ends_with('/') {
        return String::new();
    }
    match rel.rsplit_once('/') {
        Some((dir, name)) => format!("{dir}/.{name}.tmp"),
        None => format!(".{rel}.tmp"),
    }
}

/// `rel` as a path inside the run folder, if it is one (relative, no `..`, no root).
fn inside(rel: &str) -> Option<PathBuf> {
    let p = Path::new(rel.trim_end_matches('/'));
    (!rel.is_empty() && p.components().all(|c| matches!(c, Component::Normal(_)))).then(|| p.to_path_buf())
}

/// Deletes the files of the earlier run in `dir` (`--overwrite`): those its `written.txt` lists,
/// then the folders it lists if they are empty; without a `written.txt` (an older version's run),
/// only the top-level run files `found`. Never a folder's contents that the run did not write.
fn remove_run_files(dir: &Path, found: &[&str]) -> anyhow::Result<()> {
    let remove = |rel: &Path| -> anyhow::Result<()> {
        let p = dir.join(rel);
        match std::fs::symlink_metadata(&p) {
            Ok(m) if !m.is_dir() => std::fs::remove_file(&p).with_context(|| format!("cannot remove {}", p.display())),
            _ => Ok(()),
        }
    };
    let list = dir.join(WRITTEN);
    match std::fs::read_to_string(&list) {
        Ok(text) => {
            let mut folders = Vec::new();
            for line in text.lines() {
                let Some(rel) = inside(line) else { continue };
                if line.ends_with('/') {
                    folders.push(rel);
                } else {
                    remove(&rel)?;
                }
            }
            // deepest first; `remove_dir` only removes an empty folder
            folders.sort_by_key(|f| std::cmp::Reverse(f.components().count()));
            for f in folders {
                let _ = std::fs::remove_dir(dir.join(f));
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            for f in found {
                remove(Path::new(f))?;
            }
        }
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", list.display())),
    }
    remove(Path::new(WRITTEN))?;
    remove(Path::new(MANIFEST))
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a reader
/// (or a crash) never sees half a file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp"));
    std::fs::write(&tmp, bytes).with_context(|| CannotWrite(format!("cannot write {}", tmp.display())))?;
    std::fs::rename(&tmp, path).with_context(|| CannotWrite(format!("cannot write {}", path.display())))
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
