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
//!
//! Nothing else is ever replaced or deleted: before anything in the folder changes, the run takes
//! the folder's lock ([`super::run_lock`]: one run per folder) and checks every path it will write
//! ([`Outputs`]): a file there that the run did not write (not listed in `written.txt`) is refused,
//! and so is a symbolic link at any output path or output folder, so that no write and no delete
//! follows a link out of `--out`. `--overwrite` deletes only regular files, never through a link.
//!
//! After an I/O failure (disk full, permissions) the run records the state `interrupted` if it still
//! can (else the manifest stays as it was), removes its temporary files and prints how to resume.
//! The test hook [`DISK_BYTES_ENV`] simulates a full disk for the run's own writers.

use std::collections::BTreeSet;
use std::io::Write as _;
use std::os::unix::fs::OpenOptionsExt as _;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, LazyLock, Mutex};

use anyhow::{Context, bail};
use loomlab_scenarios::episodes_csv::{EpisodesCsvWriter, format_rows, header_line, parse_episodes_csv};
use loomlab_scenarios::metrics::EpisodeOutcome;
use loomlab_scenarios::report::LOOMLAB_VERSION;
use serde::{Deserialize, Serialize};

use super::run_lock::RunLock;

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
    /// A hash of the suite's definition (every scenario as loaded, with its sweeps, draws and the
    /// options, and its first and last episode as built; see `loomlab_scenarios::fingerprint`):
    /// a `--resume` whose definition is the same takes the run's `fingerprint` over without
    /// expanding every episode again (empty: an older version's run, or not computed).
    #[serde(default)]
    pub definition: String,
    /// The sensor profile the run's worlds ran under (`--sensor`, the suite's `sensor` key; empty:
    /// each scenario file's own): a `--resume` under another profile is refused.
    #[serde(default)]
    pub sensor: String,
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
            definition: String::new(),
            sensor: String::new(),
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
    ///
    /// When a full disk refuses the temporary file, an existing manifest is rewritten in place
    /// (`rewrite_in_place`): its state changes by a few bytes, which fit in the blocks the file
    /// already has, so a run that fails for want of space still records `interrupted`.
    pub fn write(&self, dir: &Path) -> anyhow::Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        let path = dir.join(MANIFEST);
        write_atomic(&path, text.as_bytes()).or_else(|e| rewrite_in_place(&path, text.as_bytes()).map_err(|_| e))
    }

    /// The manifest in `dir`, if there is one (an error for a file that is not a manifest).
    pub fn read(dir: &Path) -> anyhow::Result<Option<Self>> {
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

/// The run in progress, shared between its [`RunDir`] and whoever stops it (the interrupt
/// handler of [`super::Interrupt`]: a second Ctrl-C records the state `interrupted` before
/// exiting): its folder and manifest as on disk, guarding every manifest write, and the resume
/// command of a run that stopped on an error (for the caller to print after the error).
#[derive(Debug, Clone, Default)]
pub struct ActiveRun {
    run: Arc<Mutex<Option<(PathBuf, Manifest)>>>,
    resume_hint: Arc<Mutex<Option<String>>>,
}

impl ActiveRun {
    /// Stops the run in progress at once (a second Ctrl-C): records the state `interrupted` (the
    /// finished episodes are in episodes.csv), deletes a stale `report.partial.json`, and returns
    /// the resume command.
    pub fn abandon(&self) -> Option<String> {
        let mut guard = self.run.lock().unwrap_or_else(|e| e.into_inner());
        let (dir, m) = guard.as_mut()?;
        if m.state != RunState::Running {
            return None;
        }
        m.state = RunState::Interrupted;
        let _ = m.write(dir);
        let _ = remove_regular(dir, PARTIAL_REPORT);
        Some(m.resume_command())
    }

    /// The resume command of a run that stopped on an error (once).
    pub fn take_resume_hint(&self) -> Option<String> {
        self.resume_hint.lock().unwrap_or_else(|e| e.into_inner()).take()
    }
}

/// An output file or folder could not be written or read back (exit code 3: not bad input).
#[derive(Debug)]
pub struct CannotWrite(pub String);

impl std::fmt::Display for CannotWrite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
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

/// Every path a run may write in its folder, checked before anything there changes.
pub struct Outputs<'a> {
    /// Top-level files, as passed to [`RunDir::record`] (their temporary files are checked too).
    pub files: Vec<String>,
    /// Sub-folders the run writes into, each with whether the run may write a file of that name
    /// there (`traces/` with `--traces`, `exemplars/` unless `--no-html`).
    pub folders: Vec<(&'static str, IsOutput<'a>)>,
}

/// Whether a run may write a file of this name (in one of its sub-folders).
pub type IsOutput<'a> = &'a dyn Fn(&str) -> bool;

/// The output folder of a run and its manifest.
pub struct RunDir {
    /// The folder.
    pub dir: PathBuf,
    /// The manifest (state `running` once prepared).
    pub manifest: Manifest,
    /// `written.txt`: the paths listed so far and the file, open for appending.
    written: Mutex<(BTreeSet<String>, std::fs::File)>,
    /// The folder's lock, held until the run is dropped (after its last write).
    _lock: RunLock,
    /// The run as the interrupt handler sees it.
    active: ActiveRun,
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

/// The files a run keeps its books in (never listed in `written.txt`).
const BOOKKEEPING: [&str; 2] = [MANIFEST, WRITTEN];

impl RunDir {
    /// Prepares `dir` for the run `manifest` describes: takes the folder's lock (unless `lock` is
    /// it, taken earlier), checks every path
    /// of `outputs` (nothing of the user's is written over, no link is written through), then
    /// deletes an earlier run's files (`--overwrite`) or reads its finished episodes (`--resume`).
    /// `labels(scenario, episode)` gives the row labels a finished episode has (its detectors and
    /// reference rows), or `None` for an episode that is not part of the run; a resumed episode
    /// missing any of its rows runs again. `active` is where the interrupt handler finds the run.
    pub fn prepare(
        dir: &Path,
        mut manifest: Manifest,
        existing: Existing,
        outputs: &Outputs<'_>,
        lock: Option<RunLock>,
        labels: impl Fn(&str, usize) -> Option<BTreeSet<String>>,
        active: ActiveRun,
    ) -> anyhow::Result<Prepared> {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let lock = match lock {
            Some(lock) => lock,
            None => RunLock::acquire(dir)?,
        };
        let found: Vec<&str> = RUN_FILES
            .iter()
            .copied()
            .filter(|f| std::fs::symlink_metadata(dir.join(f)).is_ok_and(|m| !m.is_dir()))
            .collect();
        let earlier = Manifest::read(dir)?;
        let mut done = Vec::new();
        // the paths the earlier run wrote (its to replace or continue); none for a fresh run
        let owned = if found.is_empty() {
            BTreeSet::new()
        } else {
            match existing {
                Existing::Refuse => refuse_earlier_run(dir, earlier.as_ref(), &found)?,
                Existing::Resume => check_resumable(dir, earlier.as_ref(), &manifest)?,
                Existing::Overwrite => {}
            }
            earlier_run_files(dir, &found)?
        };
        check_outputs(dir, outputs, &owned)?;
        let resuming = existing == Existing::Resume && !found.is_empty();
        if existing == Existing::Overwrite && !found.is_empty() {
            remove_run_files(dir, &found)?;
        }
        if resuming {
            done = finished_episodes(&dir.join(EPISODES_CSV), &labels)?;
            manifest.wall_time_s = earlier.map_or(0.0, |m| m.wall_time_s);
        }
        // written.txt: kept when resuming (an older version's run: its files), else started afresh
        let written_path = dir.join(WRITTEN);
        let mut listed = BTreeSet::new();
        let mut text = String::new();
        if resuming {
            match std::fs::read_to_string(&written_path) {
                Ok(t) => listed.extend(t.lines().filter(|l| !l.is_empty()).map(String::from)),
                Err(_) => {
                    for rel in owned.iter().filter(|r| !BOOKKEEPING.contains(&r.as_str())) {
                        listed.insert(rel.clone());
                        text += rel;
                        text.push('\n');
                    }
                }
            }
        }
        let mut file = std::fs::OpenOptions::new()
            .append(true)
            .create(true)
            .custom_flags(libc::O_NOFOLLOW)
            .open(&written_path)
            .and_then(|f| {
                if !resuming {
                    f.set_len(0)?;
                }
                Ok(f)
            })
            .with_context(|| CannotWrite(format!("cannot write {}", written_path.display())))?;
        append(&mut file, text.as_bytes())
            .with_context(|| CannotWrite(format!("cannot write {}", written_path.display())))?;
        let run_dir = Self {
            dir: dir.into(),
            manifest,
            written: Mutex::new((listed, file)),
            _lock: lock,
            active,
        };
        // episodes.csv holds exactly the finished episodes: rewritten atomically, then appended to
        run_dir.record(EPISODES_CSV)?;
        let csv_path = dir.join(EPISODES_CSV);
        let mut text = header_line();
        for e in &done {
            text += &format_rows(e);
        }
        write_atomic(&csv_path, text.as_bytes())?;
        remove_regular(dir, REPORT)?;
        run_dir.write_manifest()?;
        Ok(Prepared {
            dir: run_dir,
            done,
            csv: EpisodesCsvWriter::append(&csv_path)?,
        })
    }

    /// Lists `rel` (a path relative to the folder; a folder ends in `/`) in `written.txt`, before
    /// the caller creates it; also the temporary file [`write_atomic`] writes it through. A path
    /// not listed yet must be free: a file there is the user's, and a link is never written through.
    pub fn record(&self, rel: &str) -> anyhow::Result<()> {
        let mut guard = self.written.lock().unwrap_or_else(|e| e.into_inner());
        let (listed, file) = &mut *guard;
        let mut lines = String::new();
        let tmp = tmp_name(rel);
        for r in [rel, tmp.as_str()] {
            if !r.is_empty() && !listed.contains(r) {
                check_free(&self.dir, r)?;
                listed.insert(r.to_string());
                lines += r;
                lines.push('\n');
            }
        }
        if !lines.is_empty() {
            append(file, lines.as_bytes())
                .with_context(|| CannotWrite(format!("cannot write {}", self.dir.join(WRITTEN).display())))?;
        }
        Ok(())
    }

    /// Creates the sub-folder `rel` of the run folder, listing it in `written.txt` if the run
    /// creates it (a folder that was there before is never removed by `--overwrite`).
    pub fn create_dir(&self, rel: &str) -> anyhow::Result<PathBuf> {
        let path = self.dir.join(rel);
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_symlink()) {
            bail!(
                "{}: a symbolic link where this run writes a folder; loomlab run never writes through a link \
                 (it could lead outside {}). Remove the link, or use another --out",
                path.display(),
                self.dir.display()
            );
        }
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

    /// Deletes the file `rel` this run (or the run it continues) wrote, if it is a regular file
    /// inside the folder (never through a link); a file not listed in `written.txt` is kept.
    pub fn remove_written(&self, rel: &str) -> anyhow::Result<()> {
        if self.written().contains(rel) {
            remove_regular(&self.dir, rel)?;
        }
        Ok(())
    }

    /// Records the run's state in the manifest (the state stays as it was if that fails).
    pub fn set_state(&mut self, state: RunState) -> anyhow::Result<()> {
        let before = self.manifest.state;
        self.manifest.state = state;
        let written = self.write_manifest();
        if written.is_err() {
            self.manifest.state = before;
        }
        written
    }

    /// Writes the manifest (under the lock the interrupt handler takes).
    fn write_manifest(&self) -> anyhow::Result<()> {
        let mut guard = self.active.run.lock().unwrap_or_else(|e| e.into_inner());
        let written = self.manifest.write(&self.dir);
        let mut on_disk = self.manifest.clone();
        if written.is_err() {
            on_disk.state = RunState::Running;
        }
        *guard = Some((self.dir.clone(), on_disk));
        written
    }
}

impl Drop for RunDir {
    /// A run left in the state `running` stopped on an error: record `interrupted` if the disk
    /// still takes it (every finished episode is in episodes.csv) and leave the resume command for
    /// the caller to print ([`ActiveRun::take_resume_hint`]; a run whose manifest still says
    /// `running` resumes as well). No temporary file stays behind. The folder's lock is released
    /// after this.
    fn drop(&mut self) {
        let mut guard = self.active.run.lock().unwrap_or_else(|e| e.into_inner());
        if self.manifest.state == RunState::Running {
            self.manifest.state = RunState::Interrupted;
            if self.manifest.write(&self.dir).is_err() {
                self.manifest.state = RunState::Running;
            }
            *self.active.resume_hint.lock().unwrap_or_else(|e| e.into_inner()) = Some(self.manifest.resume_command());
        }
        *guard = None;
        for rel in self.written() {
            if is_tmp(&rel) {
                let _ = remove_regular(&self.dir, &rel);
            }
        }
    }
}

/// The refusal of a folder that holds an earlier run (neither `--resume` nor `--overwrite`).
fn refuse_earlier_run(dir: &Path, earlier: Option<&Manifest>, found: &[&str]) -> anyhow::Result<()> {
    let what = match earlier {
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

/// Whether the earlier run in `dir` can be continued by the run `manifest` describes (`--resume`);
/// the refusal says what works instead.
fn check_resumable(dir: &Path, earlier: Option<&Manifest>, manifest: &Manifest) -> anyhow::Result<()> {
    let Some(earlier) = earlier else {
        bail!(
            "{}: no {MANIFEST}, so the results there cannot be resumed (written by an older version?); \
             use --overwrite or another --out",
            dir.display()
        );
    };
    if earlier.fingerprint != manifest.fingerprint {
        let what = format!(
            "{} holds a different run (suite {}, {} episodes, loomlab {}): its episodes or options differ from \
             this command's",
            dir.display(),
            earlier.suite,
            earlier.episodes,
            earlier.version
        );
        if earlier.resume_command() == manifest.resume_command() {
            // the same command: the suite's files (or loomlab) changed since that run started
            bail!(
                "{what}. It was started with this very command, so its suite's files (or their [defaults], or \
                 loomlab itself) changed since: it cannot be continued. Use --overwrite to start it afresh \
                 (deletes only the files that run wrote), or another --out to keep it"
            );
        }
        bail!(
            "{what}. Resume it with its own command (if its suite's files are unchanged since):\n  {}\nor use \
             --overwrite (deletes only the files that run wrote) or another --out",
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
    Ok(())
}

/// The paths (relative, folders ending in `/`) the earlier run in `dir` wrote: those its
/// `written.txt` lists, else (an older version's run) its top-level run files `found`; with its
/// bookkeeping files.
fn earlier_run_files(dir: &Path, found: &[&str]) -> anyhow::Result<BTreeSet<String>> {
    let list = dir.join(WRITTEN);
    let mut owned: BTreeSet<String> = match std::fs::read_to_string(&list) {
        Ok(text) => text.lines().filter(|l| inside(l).is_some()).map(String::from).collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => found.iter().map(|f| f.to_string()).collect(),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", list.display())),
    };
    for f in BOOKKEEPING {
        owned.insert(f.to_string());
        owned.insert(tmp_name(f));
    }
    Ok(owned)
}

/// Checks every path of `outputs` in `dir` before anything there changes: a symbolic link at an
/// output path or output folder is refused (a write through it could land outside the folder), and
/// so is a file there that the earlier run did not write (`owned`): the user's, never replaced.
fn check_outputs(dir: &Path, outputs: &Outputs<'_>, owned: &BTreeSet<String>) -> anyhow::Result<()> {
    let mut planned: Vec<String> = Vec::new();
    for f in outputs.files.iter().map(String::as_str).chain(BOOKKEEPING) {
        planned.push(f.to_string());
        planned.push(tmp_name(f));
    }
    for (folder, wanted) in &outputs.folders {
        let path = dir.join(folder);
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.file_type().is_symlink() => bail!(
                "{}: a symbolic link where this run writes a folder; loomlab run never writes through a link \
                 (it could lead outside {}). Nothing was changed: remove the link, or use another --out",
                path.display(),
                dir.display()
            ),
            Ok(m) if m.is_dir() => {
                let entries = std::fs::read_dir(&path).with_context(|| format!("cannot read {}", path.display()))?;
                for entry in entries {
                    let entry = entry.with_context(|| format!("cannot read {}", path.display()))?;
                    let Some(name) = entry.file_name().to_str().map(String::from) else {
                        continue;
                    };
                    let base = name
                        .strip_prefix('.')
                        .and_then(|n| n.strip_suffix(".tmp"))
                        .unwrap_or(&name);
                    if wanted(base) {
                        planned.push(format!("{folder}/{name}"));
                    }
                }
            }
            _ => {}
        }
    }
    for rel in planned {
        let path = dir.join(&rel);
        let Ok(m) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        if m.file_type().is_symlink() {
            bail!(
                "{}: a symbolic link where this run writes a file; loomlab run never writes through a link (it \
                 could lead outside {}). Nothing was changed: remove the link, or use another --out",
                path.display(),
                dir.display()
            );
        }
        // a folder in the way cannot be written over: that write fails later (exit 3, resumable)
        if !m.is_dir() && !owned.contains(&rel) {
            bail!(
                "{}: a file of yours (no loomlab run in {} wrote it: it is not listed in {WRITTEN}) is where this \
                 run writes; nothing was changed. Move it away, or use another --out",
                path.display(),
                dir.display()
            );
        }
    }
    Ok(())
}

/// Checks that the run may create `rel` (not listed in `written.txt`): nothing is there, and no
/// folder on the way is a link. A folder (`rel` ending in `/`) may exist already.
fn check_free(dir: &Path, rel: &str) -> anyhow::Result<()> {
    let Some(path) = safe_path(dir, rel) else {
        bail!(
            "{}: a folder on the way is a symbolic link; loomlab run never writes through a link (it could \
             lead outside {}). Remove the link, or use another --out",
            dir.join(rel).display(),
            dir.display()
        );
    };
    match std::fs::symlink_metadata(&path) {
        Ok(m) if m.file_type().is_symlink() => bail!(
            "{}: a symbolic link where this run writes; loomlab run never writes through a link (it could \
             lead outside {}). Remove the link, or use another --out",
            path.display(),
            dir.display()
        ),
        Ok(m) if !m.is_dir() && !rel.ends_with('/') => bail!(
            "{}: a file of yours (not listed in {WRITTEN}) is where this run writes; it was not changed. Move \
             it away, or use another --out",
            path.display()
        ),
        _ => Ok(()),
    }
}

/// `dir/rel` if `rel` is a path inside the folder whose every folder on the way, below `dir`, is
/// a real folder or missing (never a symbolic link or a file).
fn safe_path(dir: &Path, rel: &str) -> Option<PathBuf> {
    let rel = inside(rel)?;
    let mut path = dir.to_path_buf();
    let parts: Vec<Component> = rel.components().collect();
    for part in &parts[..parts.len().saturating_sub(1)] {
        path.push(part);
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.is_dir() => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            _ => return None,
        }
    }
    Some(dir.join(rel))
}

/// Deletes `dir/rel` if it is a regular file inside the folder, reached without a link.
fn remove_regular(dir: &Path, rel: &str) -> anyhow::Result<()> {
    let Some(path) = safe_path(dir, rel) else {
        return Ok(());
    };
    match std::fs::symlink_metadata(&path) {
        Ok(m) if m.is_file() => {
            std::fs::remove_file(&path).with_context(|| format!("cannot remove {}", path.display()))
        }
        _ => Ok(()),
    }
}

/// Whether `rel` names one of the run's temporary files (`.NAME.tmp`, `.NAME.tmp.png`).
fn is_tmp(rel: &str) -> bool {
    let name = rel.rsplit('/').next().unwrap_or(rel);
    name.starts_with('.') && (name.ends_with(".tmp") || name.contains(".tmp."))
}

/// The environment variable of the full-disk test hook: with `LOOMLAB_TEST_DISK_BYTES=N`, the
/// run's own writers (the manifest, `written.txt`, `plot_samples.jsonl`, every file written through
/// [`write_atomic`]) behave as on a disk with N bytes free: a write that does not fit fails with
/// "No space left on device" (its file created, nothing written) and every later one fails too.
/// Only the tests set it (`tests/run_resume.rs`); unset, nothing changes.
pub const DISK_BYTES_ENV: &str = "LOOMLAB_TEST_DISK_BYTES";

/// Takes `len` bytes from the simulated free space of [`DISK_BYTES_ENV`] (always fine unset).
fn take_disk_space(len: usize) -> std::io::Result<()> {
    static LEFT: LazyLock<Option<AtomicU64>> =
        LazyLock::new(|| std::env::var(DISK_BYTES_ENV).ok()?.parse().ok().map(AtomicU64::new));
    let Some(left) = &*LEFT else {
        return Ok(());
    };
    if left
        .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |l| l.checked_sub(len as u64))
        .is_err()
    {
        left.store(0, Ordering::SeqCst);
        return Err(std::io::Error::from_raw_os_error(libc::ENOSPC));
    }
    Ok(())
}

/// Appends `bytes` to a run file (through the full-disk test hook, see [`DISK_BYTES_ENV`]).
pub fn append(file: &mut std::fs::File, bytes: &[u8]) -> std::io::Result<()> {
    take_disk_space(bytes.len())?;
    file.write_all(bytes)
}

/// Opens the run file `path` for appending (created if missing), never through a link.
pub fn open_append(path: &Path) -> std::io::Result<std::fs::File> {
    std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .custom_flags(libc::O_NOFOLLOW)
        .open(path)
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
pub fn tmp_name(rel: &str) -> String {
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
/// only the top-level run files `found`. Never a folder's contents that the run did not write, and
/// only regular files reached without a symbolic link (a link is never followed, nor deleted).
fn remove_run_files(dir: &Path, found: &[&str]) -> anyhow::Result<()> {
    let list = dir.join(WRITTEN);
    match std::fs::read_to_string(&list) {
        Ok(text) => {
            let mut folders = Vec::new();
            for line in text.lines() {
                if inside(line).is_none() {
                    continue;
                }
                if line.ends_with('/') {
                    folders.push(line);
                } else {
                    remove_regular(dir, line)?;
                }
            }
            // deepest first; `remove_dir` only removes an empty folder (and never a link)
            folders.sort_by_key(|f| std::cmp::Reverse(f.matches('/').count()));
            for f in folders {
                if let Some(path) = safe_path(dir, f)
                    && std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir())
                {
                    let _ = std::fs::remove_dir(path);
                }
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            for f in found {
                remove_regular(dir, f)?;
            }
        }
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", list.display())),
    }
    remove_regular(dir, WRITTEN)?;
    remove_regular(dir, MANIFEST)
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a reader
/// (or a crash) never sees half a file. Never writes through a link; a failed write leaves no
/// temporary file (through the full-disk test hook, see [`DISK_BYTES_ENV`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp"));
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .custom_flags(libc::O_NOFOLLOW)
        .open(&tmp)
        .with_context(|| CannotWrite(format!("cannot write {}", tmp.display())))?;
    let written = take_disk_space(bytes.len())
        .and_then(|()| file.write_all(bytes))
        .with_context(|| CannotWrite(format!("cannot write {}", tmp.display())))
        .and_then(|()| {
            drop(file);
            std::fs::rename(&tmp, path).with_context(|| CannotWrite(format!("cannot write {}", path.display())))
        });
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// Rewrites the existing regular file `path` in place (no temporary file, never through a link):
/// the fallback of [`write_atomic`] on a full disk for a small file that does not outgrow the
/// blocks it has (through the full-disk test hook, which counts only the growth past them). One
/// `write` of a few hundred bytes: a crash in it is as unlikely as between two appends.
fn rewrite_in_place(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    /// The block size the growth is counted in (the common file-system block).
    const BLOCK: u64 = 4096;
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_NOFOLLOW)
        .open(path)
        .with_context(|| CannotWrite(format!("cannot write {}", path.display())))?;
    let allocated = file.metadata()?.len().next_multiple_of(BLOCK);
    take_disk_space((bytes.len() as u64).saturating_sub(allocated) as usize)
        .and_then(|()| file.write_all(bytes))
        .and_then(|()| file.set_len(bytes.len() as u64))
        .and_then(|()| file.sync_data())
        .with_context(|| CannotWrite(format!("cannot write {}", path.display())))
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
