//! The detector registry: every detector describes itself once, here, and every other crate, the
//! CLI, the Gymnasium env and Python read it.
//!
//! A [`Registration`] holds what the rest of loomlab needs to know about a detector: its id (CLI
//! flags, CSV columns, report keys, Python), a one-line label, the signals it gives
//! ([`Signal`]: its output, and for some an angular-size estimate θ̂), its default alarm
//! threshold and trigger signal, and how to turn a `params` table into a ready-to-build detector
//! (its config type, a [`DetectorConfig`]).
//!
//! [`Registry::builtin`] lists the built-in detectors in display order (`hopfield`, `soc`,
//! `keil2004`, `cizek2019`, `fu2020`: ids, file columns and report keys are contracts). A run can
//! use another registry ([`Registry::with`]: the built-ins plus detectors of its own, e.g. Python
//! detectors or a test's detector).
//!
//! # Adding a Rust detector (docs/adding-a-detector.md)
//! 1. One new file, `detector/src/baselines/<id>.rs`: the model (`impl Detector`), its config
//!    (`#[derive(Deserialize)] #[serde(default, deny_unknown_fields)]`, documented fields,
//!    `impl DetectorConfig`) and `pub(crate) fn registration() -> Registration`.
//! 2. One registration line: its module name in the `models!` list of `baselines/mod.rs`.
//!
//! Scenario `[[detectors]]` entries, detectors files, `loomlab run --detectors`, sweeps, the env's
//! `detectors` option and `loomlab.detector_ids()` then know it (`scenarios/tests/registry.rs`
//! shows it with a detector defined in the test).

use std::any::Any;
use std::collections::BTreeSet;
use std::fmt;
use std::sync::{Arc, LazyLock};

use serde::de::DeserializeOwned;
use toml::{Table, Value};

use crate::baselines::BaselineConfigs;
use crate::hopfield::{Hopfield, HopfieldConfig};
use crate::{Detector, DetectorError};

/// A signal a detector gives on every frame (the alarm's trigger reads one of them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Signal {
    /// The primary output ([`crate::Signals::output`]), in the detector's own units.
    Output,
    /// An estimate θ̂ of the looming object's angular size in degrees
    /// ([`crate::Signals::angular_size_deg`]): needed by the θ̂, τ and course-gate strategies.
    AngularSize,
}

impl Signal {
    /// The name used in files and messages (`output`, `angular_size_deg`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Output => "output",
            Self::AngularSize => "angular_size_deg",
        }
    }
}

/// The camera a detector is built for: some detectors take their frame size, field of view or frame
/// rate from it (they are never `params`; see [`DetectorConfig::CAMERA_KEYS`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraFacts {
    /// Frame side length (pixels).
    pub n: usize,
    /// Field of view (degrees).
    pub fov_deg: f64,
    /// Frame rate (Hz).
    pub frame_rate_hz: f64,
}

/// A bad `params` key of a detector entry: the key (relative to the entry, e.g. `params.alpha`)
/// and what is wrong with it, naming the fix.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    /// Key path relative to the detector entry (`params`, `params.alpha`, …).
    pub key: String,
    /// What is wrong and how to fix it.
    pub reason: String,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`: {}", self.key, self.reason)
    }
}

/// The configuration type of a registered detector: deserialised from a `params` table (missing
/// keys take the defaults, unknown keys are errors), checked, and built for n×n frames.
pub trait DetectorConfig: DeserializeOwned + Default + fmt::Debug + Clone + PartialEq + Send + Sync + 'static {
    /// Keys that come from the camera ([`CameraFacts`]) and may not be given as `params`.
    const CAMERA_KEYS: &'static [&'static str] = &[];

    /// This configuration for `camera` (sets the [`Self::CAMERA_KEYS`]; default: unchanged).
    fn for_camera(self, camera: &CameraFacts) -> Self {
        let _ = camera;
        self
    }

    /// Checks every value; the error names the parameter, its valid range and its default.
    fn validate(&self) -> Result<(), DetectorError>;

    /// A fresh detector of this configuration for n×n frames.
    fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError>;
}

/// A detector's validated parameters: builds fresh detectors (one per episode and closed-loop
/// tail, so implementations must give independent instances).
pub trait ConfiguredDetector: Send + Sync {
    /// A fresh detector for n×n frames.
    fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError>;
    /// Everything that determines the detector's responses, as text (equality of two
    /// configurations, run fingerprints, `Debug`).
    fn describe(&self) -> String;
    /// The value itself (to read a [`DetectorConfig`] back: [`DetectorParams::config`]).
    fn as_any(&self) -> &dyn Any;
}

/// A [`ConfiguredDetector`], shared: what a scenario's detector row holds. Two are equal when
/// their [`ConfiguredDetector::describe`] texts are.
#[derive(Clone)]
pub struct DetectorParams(Arc<dyn ConfiguredDetector>);

impl DetectorParams {
    /// Wraps a configured detector.
    pub fn new(configured: impl ConfiguredDetector + 'static) -> Self {
        Self(Arc::new(configured))
    }

    /// A fresh detector for n×n frames.
    pub fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        self.0.build(n)
    }

    /// The configuration, when these are parameters of the config type `C`.
    pub fn config<C: DetectorConfig>(&self) -> Option<&C> {
        self.0.as_any().downcast_ref::<Configured<C>>().map(|c| &c.0)
    }
}

impl fmt::Debug for DetectorParams {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0.describe())
    }
}

impl PartialEq for DetectorParams {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.0.describe() == other.0.describe()
    }
}

/// A [`DetectorConfig`] value as a [`ConfiguredDetector`].
#[derive(Debug, Clone)]
struct Configured<C>(C);

impl<C: DetectorConfig> ConfiguredDetector for Configured<C> {
    fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        self.0.build(n)
    }

    fn describe(&self) -> String {
        format!("{:?}", self.0)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// Turns an entry's `params` table (`None`: none given) into validated parameters for a camera.
pub type Configure = dyn Fn(Option<&Table>, &CameraFacts) -> Result<DetectorParams, ParamError> + Send + Sync;

/// What loomlab knows about one detector; see the module docs.
#[derive(Clone)]
pub struct Registration {
    /// Stable id: CLI flags, CSV columns, report keys and Python use it. ASCII letters, digits and
    /// `_`, starting with a letter.
    pub id: String,
    /// One line saying what the detector is (listings, docs).
    pub label: String,
    /// The signals it gives on every frame ([`Signal::Output`] always).
    pub signals: BTreeSet<Signal>,
    /// The signal compared with the threshold when a `[[detectors]]` entry gives no `trigger`.
    pub default_trigger: Signal,
    /// The alarm threshold when an entry gives none, in the default trigger's units.
    pub default_threshold: f64,
    configure: Arc<Configure>,
}

impl fmt::Debug for Registration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Registration")
            .field("id", &self.id)
            .field("label", &self.label)
            .field("signals", &self.signals)
            .field("default_trigger", &self.default_trigger)
            .field("default_threshold", &self.default_threshold)
            .finish_non_exhaustive()
    }
}

impl Registration {
    /// A detector whose parameters are the config type `C` (see [`DetectorConfig`]): `params`
    /// are deserialised into `C`, set for the camera and validated.
    pub fn of<C: DetectorConfig>(
        id: &str,
        label: &str,
        signals: &[Signal],
        default_trigger: Signal,
        default_threshold: f64,
    ) -> Self {
        Self::with_configure(
            id,
            label,
            signals,
            default_trigger,
            default_threshold,
            Arc::new(configure_with::<C>),
        )
    }

    /// A detector with its own way of turning `params` into a [`ConfiguredDetector`] (e.g. a
    /// Python object, which takes no params).
    pub fn with_configure(
        id: &str,
        label: &str,
        signals: &[Signal],
        default_trigger: Signal,
        default_threshold: f64,
        configure: Arc<Configure>,
    ) -> Self {
        let mut signals: BTreeSet<Signal> = signals.iter().copied().collect();
        signals.insert(Signal::Output);
        signals.insert(default_trigger);
        Self {
            id: id.to_string(),
            label: label.to_string(),
            signals,
            default_trigger,
            default_threshold,
            configure,
        }
    }

    /// Whether it gives `signal` on every frame.
    pub fn gives(&self, signal: Signal) -> bool {
        self.signals.contains(&signal)
    }

    /// Validated parameters from an entry's `params` table (`None`: the defaults) for `camera`.
    pub fn configure(&self, params: Option<&Table>, camera: &CameraFacts) -> Result<DetectorParams, ParamError> {
        (self.configure)(params, camera)
    }

    /// The default parameters for n×n frames of the default camera (60°, 120 Hz).
    pub fn default_params(&self, n: usize) -> Result<DetectorParams, DetectorError> {
        let camera = CameraFacts {
            n,
            fov_deg: 60.0,
            frame_rate_hz: 120.0,
        };
        self.configure(None, &camera)
            .map_err(|e| DetectorError::InvalidParameter {
                name: "params",
                value: self.id.clone(),
                reason: e.to_string(),
            })
    }

    /// Checks the registration itself (id syntax, threshold finite).
    fn check(&self) -> Result<(), DetectorError> {
        let ok_id = self.id.len() <= 64
            && self.id.starts_with(|c: char| c.is_ascii_alphabetic())
            && self.id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !ok_id {
            return Err(DetectorError::InvalidParameter {
                name: "id",
                value: format!("{:?}", self.id),
                reason: "a detector id has 1 to 64 ASCII letters, digits and `_`, starting with a letter \
                         (it names CSV columns and report keys)"
                    .into(),
            });
        }
        if !self.default_threshold.is_finite() {
            return Err(DetectorError::InvalidParameter {
                name: "default_threshold",
                value: self.default_threshold.to_string(),
                reason: format!("the default threshold of `{}` must be finite", self.id),
            });
        }
        Ok(())
    }
}

/// Deserialises `params` into `C` (errors at `params.<key>`), sets the camera keys, validates.
fn configure_with<C: DetectorConfig>(
    params: Option<&Table>,
    camera: &CameraFacts,
) -> Result<DetectorParams, ParamError> {
    let table = params.cloned().unwrap_or_default();
    for k in C::CAMERA_KEYS {
        if table.contains_key(*k) {
            return Err(ParamError {
                key: format!("params.{k}"),
                reason: format!("comes from world.camera (`{k}` of the camera); remove it here"),
            });
        }
    }
    let config: C = serde_path_to_error::deserialize(Value::Table(table)).map_err(|e| {
        let path = e.path().to_string();
        // the first line: toml appends an "in `table`" context line that repeats the path
        let reason = e.inner().to_string().lines().next().unwrap_or_default().to_string();
        ParamError {
            key: if path == "." {
                "params".into()
            } else {
                format!("params.{path}")
            },
            reason,
        }
    })?;
    let config = config.for_camera(camera);
    config.validate().map_err(|e| ParamError {
        key: "params".into(),
        reason: e.to_string(),
    })?;
    Ok(DetectorParams::new(Configured(config)))
}

/// An ordered set of [`Registration`]s with unique ids: the built-in detectors, plus any a run adds.
#[derive(Debug, Clone)]
pub struct Registry {
    entries: Vec<Arc<Registration>>,
}

/// Most detectors one registry holds (registrations come from code, so this only bounds mistakes).
pub const MAX_REGISTERED: usize = 256;

static BUILTIN: LazyLock<Registry> = LazyLock::new(|| {
    let mut registry = Registry { entries: Vec::new() };
    for r in std::iter::once(crate::hopfield::registration()).chain(crate::baselines::registrations()) {
        registry = registry
            .with(r)
            .expect("the built-in registrations are valid and unique");
    }
    registry
});

impl Default for Registry {
    fn default() -> Self {
        Self::builtin().clone()
    }
}

impl PartialEq for Registry {
    fn eq(&self, other: &Self) -> bool {
        self.entries.len() == other.entries.len()
            && self.entries.iter().zip(&other.entries).all(|(a, b)| Arc::ptr_eq(a, b))
    }
}

impl Registry {
    /// The built-in detectors, in display order.
    pub fn builtin() -> &'static Registry {
        &BUILTIN
    }

    /// This registry plus `registration` (after the others). Errors on an invalid registration,
    /// an id already registered, or more than [`MAX_REGISTERED`] detectors.
    pub fn with(mut self, registration: Registration) -> Result<Self, DetectorError> {
        registration.check()?;
        if self.find(&registration.id).is_some() {
            return Err(DetectorError::InvalidParameter {
                name: "id",
                value: registration.id.clone(),
                reason: format!(
                    "a detector `{}` is registered already (ids: {}); choose another id or label",
                    registration.id,
                    self.ids().join(", ")
                ),
            });
        }
        if self.entries.len() >= MAX_REGISTERED {
            return Err(DetectorError::InvalidParameter {
                name: "id",
                value: registration.id.clone(),
                reason: format!("a registry holds at most {MAX_REGISTERED} detectors"),
            });
        }
        self.entries.push(Arc::new(registration));
        Ok(self)
    }

    /// The registration of `id`.
    pub fn find(&self, id: &str) -> Option<&Registration> {
        self.entries.iter().map(|r| r.as_ref()).find(|r| r.id == id)
    }

    /// The registration of `id`, or [`DetectorError::UnknownDetector`] listing the known ids.
    pub fn get(&self, id: &str) -> Result<&Registration, DetectorError> {
        self.find(id)
            .ok_or_else(|| DetectorError::UnknownDetector(id.to_string()))
    }

    /// Every registration, in display order.
    pub fn iter(&self) -> impl Iterator<Item = &Registration> {
        self.entries.iter().map(|r| r.as_ref())
    }

    /// Every id, in display order.
    pub fn ids(&self) -> Vec<&str> {
        self.iter().map(|r| r.id.as_str()).collect()
    }

    /// Parses a detector list: `all`, or comma-separated ids (duplicates removed, order kept).
    pub fn parse_list(&self, spec: &str) -> Result<Vec<&str>, DetectorError> {
        let mut ids: Vec<&str> = Vec::new();
        for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            if part == "all" {
                ids.extend(self.ids());
                continue;
            }
            ids.push(self.get(part)?.id.as_str());
        }
        if ids.is_empty() {
            return Err(DetectorError::UnknownDetector(spec.to_string()));
        }
        let mut seen = Vec::new();
        ids.retain(|id| {
            let new = !seen.contains(id);
            seen.push(*id);
            new
        });
        Ok(ids)
    }
}

/// Every built-in detector id, in display order (`hopfield`, `soc`, `keil2004`, `cizek2019`,
/// `fu2020`, then any registered in `baselines/mod.rs`).
pub fn detector_ids() -> Vec<&'static str> {
    Registry::builtin().ids()
}

/// Parses a list of built-in detector ids: `all`, or comma-separated ids (duplicates removed,
/// order kept).
pub fn parse_detector_list(spec: &str) -> Result<Vec<&'static str>, DetectorError> {
    Registry::builtin().parse_list(spec)
}

/// Parameters of the paper's detectors, as one bundle (`loomlab detect`, the paper figures).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DetectorSet {
    /// Parameters of the Hopfield detector (its `n` is overridden by the frame size at build time).
    pub hopfield: HopfieldConfig,
    /// Parameters of the paper's baselines.
    pub baselines: BaselineConfigs,
}

impl DetectorSet {
    /// Builds detector `id` for n×n frames: the paper's detectors with these parameters, any other
    /// registered detector with its defaults.
    pub fn build(&self, id: &str, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        match id {
            "hopfield" => Ok(Box::new(Hopfield::new(HopfieldConfig { n, ..self.hopfield })?)),
            other if crate::baselines::BASELINE_IDS.contains(&other) => self.baselines.build(other),
            other => Registry::builtin().get(other)?.default_params(n)?.build(n),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_parse() {
        assert_eq!(parse_detector_list("all").unwrap(), detector_ids());
        assert_eq!(
            parse_detector_list("soc, hopfield,soc").unwrap(),
            vec!["soc", "hopfield"]
        );
        let e = parse_detector_list("hopfeld").unwrap_err().to_string();
        assert!(e.contains("hopfeld") && e.contains("known ids"), "{e}");
        assert!(parse_detector_list(" , ").is_err());
    }

    #[test]
    fn builds_every_id() {
        let set = DetectorSet::default();
        for id in detector_ids() {
            let d = set.build(id, 32).unwrap();
            assert_eq!(d.id(), id);
            let r = Registry::builtin().get(id).unwrap();
            assert_eq!(r.default_params(32).unwrap().build(32).unwrap().id(), id);
        }
    }

    #[test]
    fn the_builtin_ids_are_the_contract() {
        assert_eq!(
            detector_ids(),
            [
                "hopfield",
                "soc",
                "keil2004",
                "cizek2019",
                "fu2020",
                "tracker",
                "event_soc",
                "event_lgmd"
            ]
        );
    }

    #[test]
    fn duplicate_and_bad_ids_are_refused() {
        let soc = Registry::builtin().get("soc").unwrap().clone();
        let e = Registry::builtin().clone().with(soc.clone()).unwrap_err().to_string();
        assert!(e.contains("registered already"), "{e}");
        let mut bad = soc;
        bad.id = "9 lives".into();
        assert!(Registry::builtin().clone().with(bad).is_err());
    }
}
