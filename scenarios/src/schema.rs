//! The scenario file schema (design §6) and its expansion into [`EpisodeSpec`]s.
//!
//! A scenario file is TOML (every key is documented in `scenarios/README.md`):
//!
//! ```toml
//! name = "head_on_ball"            # default: the file name without .toml
//! description = "A ball thrown straight at the robot."
//!
//! [episode]
//! duration_s = 3.0                 # simulated time per episode (it ends earlier at the first contact)
//! seed = 1                         # seeds the random ranges and every episode's simulator seed
//! repeats = 1                      # episodes per parameter point (each with its own simulator seed)
//!
//! [world]                          # the simulator's WorldDesc, verbatim (see loomlab_sim::WorldDesc)
//! camera = { n = 64 }
//! [[world.projectiles]]
//! speed_mps = 8.0
//!
//! [robot]                          # the cruise command (the body and start pose are in [world.robot])
//! forward_mps = 1.0
//!
//! [[detectors]]                    # default: every registered detector at its default threshold
//! id = "hopfield"
//! threshold = 10.0                 # degrees of θ̂ for hopfield, output units for the baselines
//!
//! [controller]                     # loomlab_agents::EscapeConfig without trigger/threshold
//! dodge_speed_mps = 2.0
//!
//! [scoring]
//! lead_margin_s = 0.0              # a hit alarms this long before the escape deadline
//!
//! [sweep]                          # see crate::expand
//! "world.projectiles.0.speed_mps" = [6, 9, 12]
//! ```
//!
//! Unknown keys are errors everywhere; every error names the file, the key path and the reason.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use loomlab_agents::escape::MAX_PERSISTENCE_FRAMES;
use loomlab_agents::{Course, EscapeConfig, TriggerSignal, VelocityCommand};
pub use loomlab_detector::CameraFacts;
use loomlab_detector::{Detector, DetectorError, DetectorParams, Registration, Registry, Signal};
use loomlab_sim::WorldDesc;
use serde::{Deserialize, Serialize};
use toml::{Table, Value};

use crate::error::ScenarioError;
use crate::expand::{KeyPath, MAX_EPISODES_PER_SUITE, Variation, merge_defaults, mix_seed};
use crate::metrics::ScoringConfig;

/// The trigger signal of a registry signal ([`Signal::Output`] → `output`, [`Signal::AngularSize`]
/// → `angular_size_deg`).
pub fn trigger_of(signal: Signal) -> TriggerSignal {
    match signal {
        Signal::Output => TriggerSignal::Output,
        Signal::AngularSize => TriggerSignal::AngularSizeDeg,
    }
}

/// Half the lateral extent of the robot's body (m): half a box's y size, a cylinder's radius.
pub fn body_half_width_m(world: &WorldDesc) -> f64 {
    match &world.robot.body {
        loomlab_sim::ShapeDesc::Box { size } => f64::from(size[1]) / 2.0,
        loomlab_sim::ShapeDesc::Cylinder { radius_m, .. } => f64::from(*radius_m),
        loomlab_sim::ShapeDesc::Sphere { radius_m } => f64::from(*radius_m),
    }
}

/// How far the robot's body reaches above and below the camera (m): `(above, below)` from the
/// body's half-height and the camera's height over the body's centre (`world.camera.position`).
pub fn body_extent_about_camera_m(world: &WorldDesc) -> (f64, f64) {
    let half_height = match &world.robot.body {
        loomlab_sim::ShapeDesc::Box { size } => f64::from(size[2]) / 2.0,
        loomlab_sim::ShapeDesc::Cylinder { height_m, .. } => f64::from(*height_m) / 2.0,
        loomlab_sim::ShapeDesc::Sphere { radius_m } => f64::from(*radius_m),
    };
    let camera_z = f64::from(world.camera.position[2]);
    (half_height - camera_z, half_height + camera_z)
}

fn d_duration() -> f64 {
    3.0
}
fn d_repeats() -> u32 {
    1
}

/// `[episode]`: length, seed and repetitions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodeDesc {
    /// Simulated time per episode in seconds (default 3). The open-loop pass stops earlier at the
    /// first contact, a closed-loop pass at its first contact.
    #[serde(default = "d_duration")]
    pub duration_s: f64,
    /// Seed of the random ranges and of the episodes' simulator seeds (default 0).
    #[serde(default)]
    pub seed: u64,
    /// Episodes per parameter point, each with its own simulator seed (default 1).
    #[serde(default = "d_repeats")]
    pub repeats: u32,
}

impl Default for EpisodeDesc {
    fn default() -> Self {
        Self {
            duration_s: d_duration(),
            seed: 0,
            repeats: d_repeats(),
        }
    }
}

/// One change of the cruise command in `[[robot.schedule]]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CruiseChange {
    /// From this time on (s) the robot cruises with the command below.
    pub at_s: f64,
    /// Forward speed (m/s; default 0).
    #[serde(default)]
    pub forward_mps: f64,
    /// Yaw rate (rad/s, positive = left; default 0).
    #[serde(default)]
    pub yaw_rate_rps: f64,
    /// Lateral speed (m/s, positive = left; default 0).
    #[serde(default)]
    pub lateral_mps: f64,
}

/// `[robot]`: the cruise command, what the robot does when nothing threatens it (the open-loop
/// pass follows it for the whole episode; the escape controller passes it through when armed).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CruiseDesc {
    /// Forward speed (m/s; default 0: standing still).
    #[serde(default)]
    pub forward_mps: f64,
    /// Yaw rate (rad/s, positive = left; default 0).
    #[serde(default)]
    pub yaw_rate_rps: f64,
    /// Lateral speed (m/s, positive = left; default 0).
    #[serde(default)]
    pub lateral_mps: f64,
    /// Later changes of the cruise command, in increasing `at_s` (default none).
    #[serde(default)]
    pub schedule: Vec<CruiseChange>,
}

impl CruiseDesc {
    /// The cruise command in effect at time `t_s`.
    pub fn command_at(&self, t_s: f64) -> VelocityCommand {
        let mut c = VelocityCommand {
            forward_mps: self.forward_mps,
            yaw_rate_rps: self.yaw_rate_rps,
            lateral_mps: self.lateral_mps,
        };
        for s in &self.schedule {
            if s.at_s <= t_s + 1e-9 {
                c = VelocityCommand {
                    forward_mps: s.forward_mps,
                    yaw_rate_rps: s.yaw_rate_rps,
                    lateral_mps: s.lateral_mps,
                };
            }
        }
        c
    }

    /// Checks every value; with dynamic physics also that no command exceeds the drive's limits
    /// (`limits`: `world.robot`), which the physics would silently clamp it to.
    fn validate(&self, limits: Option<&loomlab_sim::RobotDesc>) -> Result<(), (String, String)> {
        let base = [
            ("robot.forward_mps", self.forward_mps),
            ("robot.yaw_rate_rps", self.yaw_rate_rps),
            ("robot.lateral_mps", self.lateral_mps),
        ];
        for (k, v) in base {
            if !v.is_finite() {
                return Err((k.into(), format!("{v} must be finite")));
            }
        }
        let mut last = f64::NEG_INFINITY;
        for (i, s) in self.schedule.iter().enumerate() {
            for (k, v) in [
                ("at_s", s.at_s),
                ("forward_mps", s.forward_mps),
                ("yaw_rate_rps", s.yaw_rate_rps),
                ("lateral_mps", s.lateral_mps),
            ] {
                if !v.is_finite() {
                    return Err((format!("robot.schedule[{i}].{k}"), format!("{v} must be finite")));
                }
            }
            if s.at_s < 0.0 || s.at_s < last {
                return Err((
                    format!("robot.schedule[{i}].at_s"),
                    format!("{} must be >= 0 and not before the previous change", s.at_s),
                ));
            }
            last = s.at_s;
        }
        let Some(robot) = limits else { return Ok(()) };
        let commands = [(
            String::from("robot"),
            self.forward_mps,
            self.yaw_rate_rps,
            self.lateral_mps,
        )]
        .into_iter()
        .chain(self.schedule.iter().enumerate().map(|(i, s)| {
            (
                format!("robot.schedule[{i}]"),
                s.forward_mps,
                s.yaw_rate_rps,
                s.lateral_mps,
            )
        }));
        for (key, forward, yaw, lateral) in commands {
            if let Some((name, value, limit_key, limit)) = robot.exceeded_limit(forward, yaw, lateral) {
                return Err((
                    format!("{key}.{name}"),
                    format!(
                        "{value} exceeds world.robot.{limit_key} ({limit}), the drive's limit: the physics would \
                         run the robot at {limit} instead; lower it or raise world.robot.{limit_key}"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// One `[[detectors]]` entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorDesc {
    /// Detector id: one of the registry's ([`Registry`]: `hopfield`, `soc`, `keil2004`,
    /// `cizek2019`, `fu2020`, …).
    pub id: String,
    /// Name in reports and CSV (default: the id). Lets one scenario run a detector twice, e.g.
    /// `hopfield` at two thresholds.
    #[serde(default)]
    pub label: Option<String>,
    /// Alarm threshold (default: the detector's [`Registration::default_threshold`]).
    #[serde(default)]
    pub threshold: Option<f64>,
    /// Which signal is compared with the threshold (default: the detector's
    /// [`Registration::default_trigger`], `angular_size_deg` for hopfield, `output` for the
    /// baselines; `tau` for the time-to-contact strategy, which needs θ̂).
    #[serde(default)]
    pub trigger: Option<TriggerSignal>,
    /// `trigger = "tau"`: alarm when the estimated time to contact is at most this (s; default
    /// `EscapeConfig::default().tau_threshold_s`). Replaces `threshold` for τ rows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau_threshold_s: Option<f64>,
    /// `trigger = "tau"`: the smallest θ̂ (degrees) for an alarm (default
    /// `EscapeConfig::default().min_angular_size_deg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_angular_size_deg: Option<f64>,
    /// The collision-course gate: `"off"` (default) or `"image"` (needs θ̂).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub course: Option<Course>,
    /// Persistence: an alarm needs the decision value at or above the threshold on this many
    /// consecutive frames (1–10 000; default 1: at once; `EscapeConfig::persistence_frames`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub persistence_frames: Option<usize>,
    /// Detector parameters: keys of the detector's config type (its
    /// [`loomlab_detector::DetectorConfig`], e.g. `HopfieldConfig` except `n`, `fov_deg` and
    /// `frame_rate_hz`, which come from `world.camera`, or `SocConfig`).
    #[serde(default)]
    pub params: Option<Table>,
}

/// `[scoring]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScoringDesc {
    /// Extra margin (s): a threat's alarm must come at least this long before its escape deadline
    /// to be a hit (default: `ScoringConfig::default().lead_margin_s`, 0).
    #[serde(default = "d_margin")]
    pub lead_margin_s: f64,
    /// Removed (replaced by the escape deadline); rejected with a message naming the replacement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead_min_s: Option<f64>,
}

fn d_margin() -> f64 {
    ScoringConfig::default().lead_margin_s
}

impl Default for ScoringDesc {
    fn default() -> Self {
        Self {
            lead_margin_s: d_margin(),
            lead_min_s: None,
        }
    }
}

/// The typed form of one expanded scenario tree.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioDoc {
    #[serde(default)]
    #[allow(dead_code)] // read from the tree before typing
    name: Option<String>,
    #[serde(default)]
    description: String,
    #[serde(default)]
    episode: EpisodeDesc,
    world: WorldDesc,
    #[serde(default)]
    robot: CruiseDesc,
    #[serde(default)]
    detectors: Option<Vec<DetectorDesc>>,
    #[serde(default)]
    controller: EscapeConfig,
    #[serde(default)]
    scoring: ScoringDesc,
}

/// A detector of an episode, ready to build.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorSpec {
    /// Name in reports (the id unless the scenario gave a label).
    pub label: String,
    /// Detector id (a registry id).
    pub id: String,
    /// Which signal is compared with the threshold.
    pub trigger: TriggerSignal,
    /// Alarm threshold: an alarm is `signal >= threshold`, the signal being the decision value of
    /// the row's strategy (for `trigger = "tau"` the urgency 1/τ̂, so this is `1 / tau_threshold_s`
    /// in s⁻¹).
    pub threshold: f64,
    /// `trigger = "tau"`: the smallest θ̂ for an alarm (degrees; `None`: the controller's).
    pub min_angular_size_deg: Option<f64>,
    /// The collision-course gate.
    pub course: Course,
    /// Consecutive frames the decision value must stay at or above the threshold (1: none).
    pub persistence_frames: usize,
    /// Validated parameters (camera keys such as the Hopfield `n` and `fov_deg` already match the
    /// camera).
    pub params: DetectorParams,
}

impl DetectorSpec {
    /// Builds a fresh detector for n×n frames.
    pub fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        self.params.build(n)
    }

    /// The escape controller's configuration for this detector.
    pub fn controller(&self, base: &EscapeConfig) -> EscapeConfig {
        EscapeConfig {
            trigger: self.trigger,
            threshold: self.threshold,
            tau_threshold_s: if self.trigger == TriggerSignal::Tau {
                1.0 / self.threshold
            } else {
                base.tau_threshold_s
            },
            min_angular_size_deg: self.min_angular_size_deg.unwrap_or(base.min_angular_size_deg),
            course: self.course,
            persistence_frames: self.persistence_frames,
            ..base.clone()
        }
    }

    /// Whether this row runs a stateful decision strategy (τ, the course gate or persistence): its
    /// decision value is not the raw trigger signal.
    pub fn is_strategy(&self) -> bool {
        self.trigger == TriggerSignal::Tau || self.course != Course::Off || self.persistence_frames > 1
    }
}

/// One episode, fully specified.
#[derive(Debug, Clone)]
pub struct EpisodeSpec {
    /// Scenario name.
    pub scenario: String,
    /// Scenario file.
    pub file: PathBuf,
    /// Index within the scenario.
    pub index: usize,
    /// Simulator seed.
    pub seed: u64,
    /// Swept / sampled values, `key path → TOML text` (plus `repeat` when repeats > 1).
    pub params: BTreeMap<String, String>,
    /// The world.
    pub world: WorldDesc,
    /// Cruise command.
    pub cruise: CruiseDesc,
    /// Episode length (s).
    pub duration_s: f64,
    /// Detectors (all see the same frames).
    pub detectors: Vec<DetectorSpec>,
    /// Escape controller (trigger and threshold are set per detector).
    pub controller: EscapeConfig,
    /// Scoring parameters.
    pub scoring: ScoringConfig,
}

impl EpisodeSpec {
    /// Number of camera frames of the episode: round(duration · camera_hz), at least 1.
    pub fn frames(&self) -> usize {
        ((self.duration_s * f64::from(self.world.camera_hz)).round() as usize).max(1)
    }

    /// Time between two camera frames (s).
    pub fn frame_period_s(&self) -> f64 {
        1.0 / f64::from(self.world.camera_hz)
    }

    /// `key = value, …` of the episode's parameters (for messages).
    pub fn params_text(&self) -> String {
        params_text(&self.params)
    }
}

fn params_text(p: &BTreeMap<String, String>) -> String {
    if p.is_empty() {
        return "no parameters".into();
    }
    p.iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A loaded scenario. Its episodes are expanded on demand ([`Scenario::episode`],
/// [`Scenario::episodes`]), so loading costs the same for one episode or millions.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Name (unique within a suite).
    pub name: String,
    /// Description.
    pub description: String,
    /// The file it came from.
    pub file: PathBuf,
    /// Its difficulty tier (top-level `tier`, 0 ..= [`crate::tier::MAX_TIER`]; `None`: not stated).
    pub tier: Option<u8>,
    expansion: Arc<Expansion>,
}

/// Options applied while loading (command-line overrides).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadOptions {
    /// Suite seed mixed into every scenario's `episode.seed` (0: the files' seeds unchanged).
    pub seed: u64,
    /// Frame size n overriding every `world.camera.n`.
    pub size: Option<u32>,
    /// Run exactly these detector ids (the scenario's settings for them when it lists them,
    /// defaults otherwise); `None`: the scenario's list (default every registered detector). With
    /// `detector_entries` it only filters those entries by id.
    pub detectors: Option<Vec<String>>,
    /// Use these `[[detectors]]` entries instead of every scenario's own list (a detectors file,
    /// or the parameter points of a sweep); `detectors` then filters them by id.
    pub detector_entries: Option<Vec<DetectorDesc>>,
    /// Entries run in addition to the rows chosen above, in every scenario (Python detectors);
    /// their ids must be in `registry`.
    pub added_detectors: Vec<DetectorDesc>,
    /// The detectors that ids resolve to (default: [`Registry::builtin`]; a run adds its own, e.g.
    /// Python detectors, with [`Registry::with`]).
    pub registry: Registry,
}

/// A suite's `[defaults]` table and the file it is written in (errors at keys that come from it
/// name that file and `defaults.<key>`).
#[derive(Debug, Clone, PartialEq)]
pub struct SuiteDefaults {
    /// The `[defaults]` table.
    pub table: Table,
    /// The suite file holding it (`suite.toml` or the list file).
    pub file: PathBuf,
}

/// Reads and expands one scenario file (`defaults`: a suite's `[defaults]`, merged under it).
pub fn load_scenario(
    path: &Path,
    defaults: Option<&SuiteDefaults>,
    opts: &LoadOptions,
) -> Result<Scenario, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
        path: path.into(),
        source,
    })?;
    parse_scenario(&text, path, defaults, opts)
}

/// Deserialises `value`, reporting errors as `(key path under prefix, first line of the reason)`.
pub(crate) fn typed<T: serde::de::DeserializeOwned>(value: Value, prefix: &str) -> Result<T, (String, String)> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let key = e.path().to_string();
        // the first line: toml appends an "in `table`" context line that repeats the path
        let reason = e.inner().to_string().lines().next().unwrap_or_default().to_string();
        let key = match (prefix.is_empty(), key.as_str()) {
            (true, ".") => "<root>".to_string(),
            (true, _) => key,
            (false, ".") => prefix.to_string(),
            (false, _) => format!("{prefix}.{key}"),
        };
        (key, reason)
    })
}

/// Longest name that becomes a file name (a scenario's, a sweep's, a sweep point's label).
pub const MAX_FILE_NAME: usize = 100;

/// Checks a name that becomes (part of) a file name: a scenario's name names its trace CSVs and
/// exemplar GIFs (`traces/<name>_0003.csv`), a sweep's and a sweep point's name their folders. The
/// safe set: 1 to [`MAX_FILE_NAME`] ASCII letters, digits, `_`, `-`, `.` and `+`, starting with a
/// letter, digit or `_` (so never `..`, a hidden file, an option-like `-x`, a path separator or a
/// character that HTML, a shell or a CSV file would treat specially). Returns the reason otherwise.
pub fn check_file_name(name: &str) -> Result<(), String> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || "_-.+".contains(c);
    if name.is_empty() {
        return Err("a name must not be empty".into());
    }
    if name.len() > MAX_FILE_NAME {
        return Err(format!(
            "a name has at most {MAX_FILE_NAME} characters, this one {}",
            name.chars().count()
        ));
    }
    if let Some(bad) = name.chars().find(|&c| !allowed(c)) {
        return Err(format!(
            "{bad:?} is not allowed in a name (it names files): use ASCII letters, digits, `_`, `-`, `.` and `+`"
        ));
    }
    if !name.starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_') {
        return Err("a name starts with an ASCII letter, a digit or `_` (it names files)".into());
    }
    Ok(())
}

/// Parses and expands scenario text; `path` names the file in errors and gives the default name.
pub fn parse_scenario(
    text: &str,
    path: &Path,
    defaults: Option<&SuiteDefaults>,
    opts: &LoadOptions,
) -> Result<Scenario, ScenarioError> {
    let mut tree: Table = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
        path: path.into(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let origin = KeyOrigin {
        file: path.into(),
        defaults: defaults.map(|d| (tree.clone(), d.clone())),
    };
    if let Some(d) = defaults {
        merge_defaults(&mut tree, &d.table);
    }
    let kerr = |(k, r): (String, String)| origin.key_error(k, r);
    if let Some(Value::Table(c)) = tree.get("controller") {
        for k in [
            "threshold",
            "trigger",
            "tau_threshold_s",
            "min_angular_size_deg",
            "course",
            "persistence_frames",
        ] {
            if c.contains_key(k) {
                return Err(ScenarioError::key(
                    path,
                    format!("controller.{k}"),
                    format!("set the alarm {k} per detector, in [[detectors]] {k} = …"),
                ));
            }
        }
    }
    let name = match tree.get("name") {
        None => {
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scenario".into());
            check_file_name(&stem).map_err(|reason| {
                ScenarioError::key(
                    path,
                    "name",
                    format!(
                        "the file name `{stem}` is the scenario's name by default, but {reason}; set `name = \"…\"` in the file"
                    ),
                )
            })?;
            stem
        }
        Some(Value::String(s)) => {
            check_file_name(s).map_err(|reason| ScenarioError::key(path, "name", format!("{s:?}: {reason}")))?;
            s.clone()
        }
        Some(other) => {
            return Err(ScenarioError::key(
                path,
                "name",
                format!("must be a non-empty string, not {other}"),
            ));
        }
    };
    if defaults.is_some_and(|d| d.table.contains_key("tier")) {
        let file = &defaults.expect("checked").file;
        return Err(ScenarioError::key(
            file,
            "defaults.tier",
            "a difficulty tier belongs to each scenario file, not to the suite's [defaults]: remove it here and \
             write `tier = N` at the top of every scenario file",
        ));
    }
    let tier = match tree.remove("tier") {
        None => None,
        Some(v) => Some(crate::tier::parse_tier_value(&v).map_err(|reason| ScenarioError::key(path, "tier", reason))?),
    };
    let variation = Variation::take_from(&mut tree).map_err(kerr)?;
    if variation
        .sweep
        .iter()
        .flat_map(|(_, ps, _)| ps.iter().map(KeyPath::canonical))
        .chain(variation.random.iter().map(|(_, p, _)| p.canonical()))
        .any(|k| k == "tier")
    {
        return Err(ScenarioError::key(
            path,
            "sweep.tier",
            "the tier is one per scenario file and cannot be swept or sampled: split the file into one file per tier",
        ));
    }
    let episode: EpisodeDesc = typed(
        tree.get("episode").cloned().unwrap_or(Value::Table(Table::new())),
        "episode",
    )
    .map_err(kerr)?;
    if !(episode.duration_s.is_finite() && episode.duration_s > 0.0) {
        return Err(ScenarioError::key(
            path,
            "episode.duration_s",
            format!("{} must be a finite number of seconds > 0", episode.duration_s),
        ));
    }
    if episode.repeats == 0 {
        return Err(ScenarioError::key(path, "episode.repeats", "must be >= 1"));
    }
    let count = variation.points().saturating_mul(episode.repeats as usize);
    if count > MAX_EPISODES_PER_SUITE {
        return Err(ScenarioError::key(
            path,
            if variation.points() > 1 {
                "sweep"
            } else {
                "episode.repeats"
            },
            format!(
                "expands to {count} episodes (more than {MAX_EPISODES_PER_SUITE}); use fewer values, samples or repeats"
            ),
        ));
    }
    let base_seed = if opts.seed == 0 {
        episode.seed
    } else {
        mix_seed(episode.seed, opts.seed)
    };
    let expansion = Expansion {
        file: path.into(),
        origin,
        name,
        varied: variation
            .sweep
            .iter()
            .flat_map(|(_, ps, _)| ps.iter().map(KeyPath::canonical))
            .chain(variation.random.iter().map(|(_, p, _)| p.canonical()))
            .collect(),
        tree,
        variation,
        base_seed,
        repeats: episode.repeats as usize,
        count,
        opts: opts.clone(),
    };
    // the first point is checked (and gives the description) now; the others as they are expanded
    let (first, description) = expansion.point(0)?;
    drop(first);
    Ok(Scenario {
        name: expansion.name.clone(),
        description,
        file: path.into(),
        tier,
        expansion: Arc::new(expansion),
    })
}

/// Where a scenario's keys were written: the scenario file, or the suite's `[defaults]`.
#[derive(Debug)]
struct KeyOrigin {
    file: PathBuf,
    /// The scenario file's own tree (before the merge) and the defaults merged under it.
    defaults: Option<(Table, SuiteDefaults)>,
}

impl KeyOrigin {
    /// The suite's defaults, if `key` was not written in the scenario file but in them.
    fn defaults_of(&self, key: &str) -> Option<&SuiteDefaults> {
        let (own, defaults) = self.defaults.as_ref()?;
        let path = KeyPath::parse(key).ok()?;
        (path.get(own).is_none() && path.get(&defaults.table).is_some()).then_some(defaults)
    }

    /// A key error, naming the file the key was written in.
    fn key_error(&self, key: String, reason: String) -> ScenarioError {
        match self.defaults_of(&key) {
            Some(d) => ScenarioError::key(
                &d.file,
                format!("defaults.{key}"),
                format!("{reason} (in [defaults], merged under {})", self.file.display()),
            ),
            None => ScenarioError::key(&self.file, key, reason),
        }
    }
}

/// A scenario's tree and variation: expands any one of its episodes on demand.
#[derive(Debug)]
struct Expansion {
    file: PathBuf,
    origin: KeyOrigin,
    name: String,
    /// The file's tree (with the suite's defaults merged, without `[sweep]` and `[random]`).
    tree: Table,
    variation: Variation,
    /// Canonical key paths of the varied keys.
    varied: Vec<String>,
    base_seed: u64,
    repeats: usize,
    count: usize,
    opts: LoadOptions,
}

impl Expansion {
    /// The episodes of parameter point `point` (all its repeats) and the scenario description.
    fn point(&self, point: usize) -> Result<(Vec<EpisodeSpec>, String), ScenarioError> {
        let path = self.file.as_path();
        let (t, params) = self.variation.point(&self.tree, self.base_seed, point);
        let first_index = point * self.repeats;
        // In a scenario with varied keys an error can be specific to this point (also at a key
        // that is not varied itself, e.g. an arrival time the swept speed cannot reach): the
        // message names the episode and its parameters.
        let err = |(k, r): (String, String)| {
            if self.varied.is_empty() || self.origin.defaults_of(&k).is_some() {
                self.origin.key_error(k, r)
            } else {
                ScenarioError::Episode {
                    path: path.into(),
                    episode: first_index,
                    params: params_text(&params),
                    reason: format!("`{k}`: {r}"),
                }
            }
        };
        let doc: ScenarioDoc = typed(Value::Table(t), "").map_err(&err)?;
        let (world, detectors) = resolve(&doc, &self.opts).map_err(&err)?;
        let (above_camera, below_camera) = body_extent_about_camera_m(&world);
        let scoring = ScoringConfig {
            lead_margin_s: doc.scoring.lead_margin_s,
            ..ScoringConfig::default()
        };
        let episodes = (0..self.repeats)
            .map(|r| {
                let index = first_index + r;
                let mut params = params.clone();
                if self.repeats > 1 {
                    params.insert("repeat".into(), r.to_string());
                }
                EpisodeSpec {
                    scenario: self.name.clone(),
                    file: path.into(),
                    index,
                    seed: mix_seed(self.base_seed, index as u64),
                    params,
                    world: world.clone(),
                    cruise: doc.robot.clone(),
                    duration_s: doc.episode.duration_s,
                    detectors: detectors.clone(),
                    controller: EscapeConfig {
                        base: world.robot.base,
                        body_half_width_m: body_half_width_m(&world),
                        body_above_camera_m: above_camera,
                        body_below_camera_m: below_camera,
                        camera_fov_deg: f64::from(world.camera.fov_deg),
                        ..doc.controller.clone()
                    },
                    scoring: scoring.clone(),
                }
            })
            .collect();
        Ok((episodes, doc.description))
    }
}

impl Scenario {
    /// Number of episodes (Π len(sweep lists) × samples × repeats).
    pub fn len(&self) -> usize {
        self.expansion.count
    }

    /// Whether the scenario has no episodes (never: every scenario has at least one).
    pub fn is_empty(&self) -> bool {
        self.expansion.count == 0
    }

    /// Episode `index` (0 ≤ index < [`Self::len`]), expanded now; an error names the file, the
    /// episode and its parameters.
    pub fn episode(&self, index: usize) -> Result<EpisodeSpec, ScenarioError> {
        if index >= self.len() {
            return Err(ScenarioError::key(
                &self.file,
                "episode",
                format!("episode {index} does not exist (the scenario has {})", self.len()),
            ));
        }
        let repeats = self.expansion.repeats;
        let (mut episodes, _) = self.expansion.point(index / repeats)?;
        Ok(episodes.swap_remove(index % repeats))
    }

    /// Every episode in order, expanded one parameter point at a time.
    pub fn episodes(&self) -> impl Iterator<Item = Result<EpisodeSpec, ScenarioError>> + '_ {
        let points = self.len() / self.expansion.repeats;
        (0..points).flat_map(move |p| match self.expansion.point(p) {
            Ok((episodes, _)) => episodes.into_iter().map(Ok).collect::<Vec<_>>(),
            Err(e) => vec![Err(e)],
        })
    }

    /// Every episode, expanded (for small scenarios: tests, the Gymnasium env).
    pub fn expand_all(&self) -> Result<Vec<EpisodeSpec>, ScenarioError> {
        self.episodes().collect()
    }
}

/// Validates a typed scenario and builds its world and detector specs.
fn resolve(doc: &ScenarioDoc, opts: &LoadOptions) -> Result<(WorldDesc, Vec<DetectorSpec>), (String, String)> {
    let mut world = doc.world.clone();
    if let Some(n) = opts.size {
        world.camera.n = n;
    }
    world.validate().map_err(|e| match e {
        loomlab_sim::SimError::InvalidDesc { key, value, reason } => {
            let key = if key.starts_with("world.") {
                key
            } else {
                format!("world.{key}")
            };
            (key, format!("{value}: {reason}"))
        }
        other => ("world".to_string(), other.to_string()),
    })?;
    // one cap on frames per episode, shared with `loomlab render`
    loomlab_sim::episode_frames("episode.duration_s", doc.episode.duration_s, world.dt()).map_err(|e| match e {
        loomlab_sim::SimError::Duration { key, value, reason } => (key, format!("{value}: {reason}")),
        other => ("episode.duration_s".into(), other.to_string()),
    })?;
    let dynamic = world.physics == loomlab_sim::PhysicsMode::Dynamic;
    doc.robot.validate(dynamic.then_some(&world.robot))?;
    doc.controller
        .validate()
        .map_err(|e| ("controller".to_string(), e.to_string()))?;
    if let Some(v) = doc.scoring.lead_min_s {
        return Err((
            "scoring.lead_min_s".into(),
            format!(
                "{v}: the key was removed: a hit is now an alarm no later than the threat's escape deadline \
                 (found by physics-only replays of the escape manoeuvre); delete it, or use \
                 `scoring.lead_margin_s` for an extra margin before the deadline"
            ),
        ));
    }
    let margin = doc.scoring.lead_margin_s;
    if !(margin.is_finite() && margin >= 0.0) {
        return Err((
            "scoring.lead_margin_s".into(),
            format!("{margin} must be a number of seconds >= 0"),
        ));
    }
    let entries = opts.detector_entries.as_ref().or(doc.detectors.as_ref());
    let listed: Vec<(usize, DetectorDesc)> = match entries {
        Some(list) => list.iter().cloned().enumerate().collect(),
        None => Vec::new(),
    };
    let wanted: Vec<(Option<usize>, DetectorDesc)> = match (&opts.detectors, entries) {
        (None, Some(_)) => listed.into_iter().map(|(i, d)| (Some(i), d)).collect(),
        (None, None) => opts.registry.ids().into_iter().map(|id| (None, bare(id))).collect(),
        // a detectors file: --detectors only filters its entries
        (Some(ids), Some(_)) if opts.detector_entries.is_some() => listed
            .into_iter()
            .filter(|(_, d)| ids.contains(&d.id))
            .map(|(i, d)| (Some(i), d))
            .collect(),
        (Some(ids), _) => {
            let mut out = Vec::new();
            for id in ids {
                let mine: Vec<_> = listed.iter().filter(|(_, d)| &d.id == id).cloned().collect();
                if mine.is_empty() {
                    out.push((None, bare(id)));
                } else {
                    out.extend(mine.into_iter().map(|(i, d)| (Some(i), d)));
                }
            }
            out
        }
    };
    let added = opts.added_detectors.iter().map(|d| (None, d.clone()));
    let wanted: Vec<(Option<usize>, DetectorDesc)> = wanted.into_iter().chain(added).collect();
    if wanted.is_empty() {
        return Err((
            "detectors".into(),
            "the list is empty; give at least one detector".into(),
        ));
    }
    let mut specs: Vec<DetectorSpec> = Vec::with_capacity(wanted.len());
    for (i, d) in wanted {
        let key = |k: &str| match i {
            Some(i) => format!("detectors[{i}].{k}"),
            None => format!("detectors.{k}"),
        };
        let spec = resolve_detector_in(&opts.registry, &d, camera_facts(&world)).map_err(|(k, r)| (key(&k), r))?;
        if specs.iter().any(|s| s.label == spec.label) {
            return Err((
                key("label"),
                format!(
                    "detector `{}` is listed twice; give the entries different labels",
                    spec.label
                ),
            ));
        }
        specs.push(spec);
    }
    Ok((world, specs))
}

/// The camera facts of a world's camera (what detectors take from the camera).
pub fn camera_facts(world: &WorldDesc) -> CameraFacts {
    CameraFacts {
        n: world.camera.n as usize,
        fov_deg: f64::from(world.camera.fov_deg),
        frame_rate_hz: f64::from(world.camera_hz),
    }
}

/// The default camera's facts with frame side `n` (for validating detector lists that are not tied
/// to a world yet).
pub fn default_camera(n: usize) -> CameraFacts {
    CameraFacts {
        n,
        ..camera_facts(&WorldDesc::default())
    }
}

/// Validates one `[[detectors]]` entry for `camera` against the built-in registry and builds its
/// spec. Errors are `(key, reason)` with the key relative to the entry (`threshold`,
/// `params.alpha`, …).
pub fn resolve_detector(d: &DetectorDesc, camera: CameraFacts) -> Result<DetectorSpec, (String, String)> {
    resolve_detector_in(Registry::builtin(), d, camera)
}

/// [`resolve_detector`] against `registry`.
pub fn resolve_detector_in(
    registry: &Registry,
    d: &DetectorDesc,
    camera: CameraFacts,
) -> Result<DetectorSpec, (String, String)> {
    let Some(reg) = registry.find(&d.id) else {
        return Err((
            "id".into(),
            format!("unknown detector `{}`; known ids: {}", d.id, registry.ids().join(", ")),
        ));
    };
    let id = reg.id.as_str();
    let threshold = d.threshold.unwrap_or(reg.default_threshold);
    if !threshold.is_finite() {
        return Err(("threshold".into(), format!("{threshold} must be finite")));
    }
    let label = d.label.clone().unwrap_or_else(|| id.to_string());
    if label.is_empty() || label.contains([',', '"', '\n']) {
        return Err((
            "label".into(),
            "must be non-empty, without commas, quotes or newlines".into(),
        ));
    }
    if crate::reference::is_reference(&label) {
        return Err((
            "label".into(),
            format!(
                "`{label}` is reserved for a reference row ({}); choose another label",
                crate::reference::REFERENCE_LABELS.join(", ")
            ),
        ));
    }
    let trigger = d.trigger.unwrap_or_else(|| trigger_of(reg.default_trigger));
    let gives_theta = reg.gives(Signal::AngularSize);
    let with_theta = || angular_size_ids(registry).join(", ");
    // a trigger on θ̂ needs a detector that estimates it: any other detector would never alarm
    if trigger == TriggerSignal::AngularSizeDeg && !gives_theta {
        return Err((
            "trigger".into(),
            format!(
                "\"angular_size_deg\" needs a detector that estimates the angular size θ̂ ({}); \
                 `{id}` gives none, so it would never alarm: use trigger = \"output\"",
                with_theta()
            ),
        ));
    }
    let course = d.course.unwrap_or_default();
    let needs_theta = trigger == TriggerSignal::Tau || course != Course::Off;
    if needs_theta && !gives_theta {
        let key = if trigger == TriggerSignal::Tau {
            "trigger"
        } else {
            "course"
        };
        return Err((
            key.into(),
            format!(
                "`{}` needs an angular-size estimate θ̂, which `{id}` does not give (detectors with θ̂: {})",
                if trigger == TriggerSignal::Tau {
                    "trigger = \"tau\""
                } else {
                    "course = \"image\""
                },
                with_theta()
            ),
        ));
    }
    if course != Course::Off && trigger == TriggerSignal::Output {
        return Err((
            "course".into(),
            "the collision-course gate needs θ̂: use trigger = \"tau\" or \"angular_size\"".into(),
        ));
    }
    let threshold = if trigger == TriggerSignal::Tau {
        if d.threshold.is_some() {
            return Err((
                "threshold".into(),
                "with trigger = \"tau\" the alarm threshold is tau_threshold_s (seconds)".into(),
            ));
        }
        let tau = d.tau_threshold_s.unwrap_or(EscapeConfig::default().tau_threshold_s);
        if !(tau.is_finite() && tau > 0.0) {
            return Err((
                "tau_threshold_s".into(),
                format!("{tau} must be a finite number of seconds > 0"),
            ));
        }
        1.0 / tau
    } else {
        for (key, given) in [
            ("tau_threshold_s", d.tau_threshold_s.is_some()),
            ("min_angular_size_deg", d.min_angular_size_deg.is_some()),
        ] {
            if given {
                return Err((key.into(), "only used with trigger = \"tau\"".into()));
            }
        }
        threshold
    };
    if let Some(m) = d.min_angular_size_deg
        && !(m.is_finite() && m >= 0.0)
    {
        return Err((
            "min_angular_size_deg".into(),
            format!("{m} must be a finite number >= 0"),
        ));
    }
    let persistence_frames = d.persistence_frames.unwrap_or(1);
    if !(1..=MAX_PERSISTENCE_FRAMES).contains(&persistence_frames) {
        return Err((
            "persistence_frames".into(),
            format!(
                "{persistence_frames} must be a whole number of frames from 1 (alarm at once) to {MAX_PERSISTENCE_FRAMES}"
            ),
        ));
    }
    let params = reg
        .configure(d.params.as_ref(), &camera)
        .map_err(|e| (e.key, e.reason))?;
    Ok(DetectorSpec {
        label,
        id: id.to_string(),
        trigger,
        threshold,
        min_angular_size_deg: d.min_angular_size_deg,
        course,
        persistence_frames,
        params,
    })
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DetectorsDoc {
    detectors: Vec<DetectorDesc>,
}

/// Parses a detectors file: TOML holding only `[[detectors]]` entries (the scenario syntax), as
/// `loomlab run --detectors-file` takes and a sweep writes for each parameter point. Every entry is
/// checked (at a 64×64, 60° camera; the real camera is checked when the suite loads).
pub fn parse_detector_entries(text: &str, path: &Path) -> Result<Vec<DetectorDesc>, ScenarioError> {
    let tree: Table = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
        path: path.into(),
        message: e.to_string().trim_end().to_string(),
    })?;
    let doc: DetectorsDoc = typed(Value::Table(tree), "").map_err(|(k, r)| ScenarioError::key(path, k, r))?;
    if doc.detectors.is_empty() {
        return Err(ScenarioError::key(
            path,
            "detectors",
            "the list is empty; give at least one [[detectors]] entry",
        ));
    }
    let mut labels = Vec::new();
    for (i, d) in doc.detectors.iter().enumerate() {
        let spec = resolve_detector(d, default_camera(64))
            .map_err(|(k, r)| ScenarioError::key(path, format!("detectors[{i}].{k}"), r))?;
        if labels.contains(&spec.label) {
            return Err(ScenarioError::key(
                path,
                format!("detectors[{i}].label"),
                format!(
                    "detector `{}` is listed twice; give the entries different labels",
                    spec.label
                ),
            ));
        }
        labels.push(spec.label);
    }
    Ok(doc.detectors)
}

/// Reads a detectors file (see [`parse_detector_entries`]).
pub fn load_detector_entries(path: &Path) -> Result<Vec<DetectorDesc>, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
        path: path.into(),
        source,
    })?;
    parse_detector_entries(&text, path)
}

fn bare(id: &str) -> DetectorDesc {
    DetectorDesc {
        id: id.to_string(),
        label: None,
        threshold: None,
        trigger: None,
        tau_threshold_s: None,
        min_angular_size_deg: None,
        course: None,
        persistence_frames: None,
        params: None,
    }
}

/// The ids of the detectors in `registry` that give θ̂.
pub fn angular_size_ids(registry: &Registry) -> Vec<&str> {
    registry
        .iter()
        .filter(|r| r.gives(Signal::AngularSize))
        .map(|r| r.id.as_str())
        .collect()
}

/// The registration of a built-in detector id (its default threshold and trigger, …).
pub fn registration(id: &str) -> Option<&'static Registration> {
    Registry::builtin().find(id)
}
