//! Replaying a row's decider on the open-loop traces of a run (`loomlab run --traces`): the
//! percepts a detector row's decider saw — θ̂ before the decider, the detector's image region,
//! the looming side and the robot's own motion, all in the trace CSV — go through a
//! [`Decider`](loomlab_agents::Decider) again, with the same or other parameters, and the
//! open-loop alarms are scored against the run's `episodes.csv` (threat, escape deadline). With
//! the run's own parameters the replay reproduces the recorded decision values bit for bit
//! (tested), so a difference is the parameters' doing. `scenarios/examples/replay_strategy.rs` is
//! the command.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use loomlab_agents::{EscapeConfig, RobotFacts, SelfMotion};
use loomlab_detector::ImageRegion;

use crate::episodes_csv::read_episodes_csv;

/// Most trace files read (a run folder holds one per episode).
pub const MAX_TRACES: usize = 100_000;

/// One trace CSV: its header and rows of cells.
struct Trace {
    columns: BTreeMap<String, usize>,
    rows: Vec<Vec<String>>,
}

impl Trace {
    fn read(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let mut lines = text.lines();
        let header = lines.next().ok_or_else(|| format!("{}: empty file", path.display()))?;
        let columns = header.split(',').enumerate().map(|(i, c)| (c.to_string(), i)).collect();
        let rows = lines.map(|l| l.split(',').map(str::to_string).collect()).collect();
        Ok(Self { columns, rows })
    }

    /// The index of `column` (`None`: no such column).
    fn index(&self, column: &str) -> Option<usize> {
        self.columns.get(column).copied()
    }

    /// The number in column `i` of row `k` (`None`: an empty cell or no such column).
    fn get(&self, k: usize, i: Option<usize>) -> Option<f64> {
        self.rows[k].get(i?).and_then(|c| c.parse().ok())
    }
}

/// Open-loop hits and false alarms of one row over a run's episodes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tally {
    /// Evadable threats whose first alarm about the threat came no later than the escape deadline.
    pub hits: usize,
    /// Threats with an escape deadline.
    pub evadable: usize,
    /// Non-threats with any alarm.
    pub false_alarms: usize,
    /// Episodes without a threat.
    pub non_threats: usize,
}

impl Tally {
    /// Scores one episode: `alarms[k]` whether frame k alarms, `about[k]` whether it is about the
    /// threat.
    fn add(&mut self, t_s: &[f64], alarms: &[bool], about: &[bool], threat: bool, deadline: Option<f64>) {
        if threat {
            if let Some(deadline) = deadline {
                self.evadable += 1;
                let first = (0..alarms.len()).find(|&k| alarms[k] && about[k]);
                if first.is_some_and(|k| t_s[k] <= deadline + 1e-9) {
                    self.hits += 1;
                }
            }
        } else {
            self.non_threats += 1;
            if alarms.iter().any(|&a| a) {
                self.false_alarms += 1;
            }
        }
    }
}

impl std::fmt::Display for Tally {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let rate = |a: usize, b: usize| if b == 0 { f64::NAN } else { a as f64 / b as f64 };
        write!(
            f,
            "hits {} / {} evadable ({:.3}), false alarms {} / {} non-threats ({:.3})",
            self.hits,
            self.evadable,
            rate(self.hits, self.evadable),
            self.false_alarms,
            self.non_threats,
            rate(self.false_alarms, self.non_threats)
        )
    }
}

/// What [`replay_run`] found.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Replay {
    /// Episodes replayed.
    pub episodes: usize,
    /// The recorded decision values, scored.
    pub recorded: Tally,
    /// The replayed ones, scored.
    pub replayed: Tally,
    /// Frames replayed.
    pub frames: usize,
    /// Frames whose replayed decision value differs from the recorded one.
    pub differing: usize,
}

/// Replays the decider of row `label` of the run in `dir` (its `episodes.csv` and `traces/`)
/// with `config`'s decision rule for the robot of `facts` (its body and camera; see the module
/// docs).
pub fn replay_run(dir: &Path, label: &str, config: &EscapeConfig, facts: &RobotFacts) -> Result<Replay, String> {
    let episodes = read_episodes_csv(&dir.join("episodes.csv")).map_err(|e| e.to_string())?;
    let mut truth = BTreeMap::new();
    for ep in &episodes {
        if let Some(d) = ep.detectors.iter().find(|d| d.detector == label) {
            truth.insert((ep.scenario.clone(), ep.episode), (d.threat, d.t_deadline_s));
        }
    }
    if truth.is_empty() {
        return Err(format!(
            "{}: no row labelled {label:?}",
            dir.join("episodes.csv").display()
        ));
    }
    let traces = dir.join("traces");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&traces)
        .map_err(|e| {
            format!(
                "cannot read {} ({e}): was the run made with --traces?",
                traces.display()
            )
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .take(MAX_TRACES)
        .collect();
    files.sort();
    let column = |name: &str| format!("{label}_{name}");
    let threshold = config.alarm_threshold();
    let mut out = Replay::default();
    for path in &files {
        let Some((scenario, episode)) = path
            .file_stem()
            .and_then(|s| s.to_str())
            .and_then(|s| s.rsplit_once('_'))
        else {
            continue;
        };
        let Some(&(threat, deadline)) = episode
            .parse()
            .ok()
            .and_then(|e: usize| truth.get(&(scenario.to_string(), e)))
        else {
            continue;
        };
        let trace = Trace::read(path)?;
        if trace.index(&column("theta_hat_deg")).is_none() {
            return Err(format!(
                "{}: no column {}: the row {label:?} has no τ trigger or course gate, or the run is older than this tool",
                path.display(),
                column("theta_hat_deg")
            ));
        }
        out.episodes += 1;
        let mut decider = config.decider(facts);
        let n = trace.rows.len();
        let col = |name: &str| trace.index(&column(name));
        let (t_col, about_col, theta_col, signal_col, track_col) = (
            trace.index("t_s"),
            col("about_threat"),
            col("theta_hat_deg"),
            col("signal"),
            col("track"),
        );
        let edge_cols = ["left", "right", "bottom", "top"].map(col);
        let (side_col, forward_col, yaw_col, camera_yaw_col, camera_pitch_col) = (
            trace.index("looming_side"),
            trace.index("ego_forward_mps"),
            trace.index("ego_yaw_rate_rps"),
            trace.index("ego_camera_yaw_rad"),
            trace.index("ego_camera_pitch_rad"),
        );
        let t_s: Vec<f64> = (0..n).map(|k| trace.get(k, t_col).unwrap_or(f64::NAN)).collect();
        let about: Vec<bool> = (0..n)
            .map(|k| trace.get(k, about_col).is_none_or(|v| v == 1.0))
            .collect();
        let (mut was, mut now) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for (k, &t) in t_s.iter().enumerate() {
            let region = match edge_cols.map(|c| trace.get(k, c)) {
                [Some(l), Some(r), Some(b), Some(t)] => Some(ImageRegion {
                    centroid: [(l + r) / 2.0, (b + t) / 2.0],
                    x: [l, r],
                    y: [b, t],
                    track: trace.get(k, track_col).map(|v| v as usize),
                }),
                _ => None,
            };
            let side = trace.get(k, side_col).map(|v| v as f32);
            let theta = trace.get(k, theta_col).unwrap_or(f64::NAN);
            let motion = SelfMotion {
                forward_mps: trace.get(k, forward_col).unwrap_or(0.0),
                yaw_rate_rps: trace.get(k, yaw_col).unwrap_or(0.0),
                // absent from traces written before they were recorded: no shake known
                camera_yaw_rad: trace.get(k, camera_yaw_col).unwrap_or(0.0),
                camera_pitch_rad: trace.get(k, camera_pitch_col).unwrap_or(0.0),
            };
            let value = decider
                .decide_on_detector(t, theta, side, region.as_ref(), motion)
                .value;
            // the trace leaves a non-finite value's cell empty
            let old = trace.get(k, signal_col);
            out.frames += 1;
            if Some(value).filter(|v| v.is_finite()) != old {
                out.differing += 1;
            }
            was.push(old.is_some_and(|v| v >= threshold));
            now.push(value >= threshold);
        }
        out.recorded.add(&t_s, &was, &about, threat, deadline);
        out.replayed.add(&t_s, &now, &about, threat, deadline);
    }
    if out.episodes == 0 {
        return Err(format!("{}: no trace of an episode in episodes.csv", traces.display()));
    }
    Ok(out)
}
