//! The temporal-contrast ("SOC-based") baseline looming detectors that Keil 2025 compares
//! the Hopfield detector with (paper subsection "Benchmark Models"; full specification in
//! `docs/detectors.md`).
//!
//! | id | model | status |
//! |---|---|---|
//! | `soc` | [`Soc`]: sum of absolute temporal contrast (paper Fig. `FigApproachCurves`) | exact |
//! | `keil2004` | [`Keil2004`]: "Advanced", Keil, Roca-Moreno & Rodríguez-Vázquez 2004 | output stage exact, **front end reconstructed** (docs/detectors.md, keil2004 §1) |
//! | `cizek2019` | [`Cizek2019`]: "CizFai19", Čížek & Faigl 2019 + Keil's adaptive thresholds | thresholds exact, presynaptic chain in standard LGMD1 form, `W_I` assumed (docs/detectors.md, cizek2019 §1) |
//! | `fu2020` | [`Fu2020`]: "FuHuPe20", LGMD2 of Fu et al. 2020, ON/OFF instances combined | from the authors' reference code (docs/detectors.md, fu2020 §1) |
//! | `event_soc` | [`EventSoc`]: events per camera period (reads events) | an event camera's SOC |
//! | `event_lgmd` | [`EventLgmd`]: event-driven LGMD network after Salt, Indiveri & Sandamirskaya 2017 (reads events) | structure from the paper, parameter values ours (docs/detectors.md, event_lgmd) |
//! | `tracker` | [`Tracker`]: ego-motion-compensated change segmentation and bounding-box tracking | an engineering reference, not an insect model and not in the paper's comparison |
//!
//! Common conventions (docs/detectors.md#common): frames in [0, 1], computations in f64; the first
//! frame after construction or [`Detector::reset`] fixes the frame size n and only stores the
//! frame (output 0); a later frame of another size is [`DetectorError::FrameSize`]; 3×3
//! operations clamp at the borders; lowpasses update first, then are read.
//! Every model returns its output in [`crate::Signals::output`] and intermediate signals in
//! `aux` (fixed names, the same on every frame).

#[macro_use]
mod common;
mod lowpass;
mod stencil;

/// The registered baseline models, in display order after `hopfield`: one line each. A name
/// declares the module `<name>.rs` of this folder and registers its `registration()` (see
/// [`crate::registry`] and docs/adding-a-detector.md).
macro_rules! models {
    ($($model:ident),* $(,)?) => {
        $(mod $model;)*

        /// The registrations of the baseline models, in display order.
        pub(crate) fn registrations() -> Vec<crate::registry::Registration> {
            vec![$($model::registration()),*]
        }
    };
}

models! {
    soc,
    keil2004,
    cizek2019,
    fu2020,
    tracker,
    event_soc,
    event_lgmd,
}

pub use cizek2019::{Cizek2019, Cizek2019Config};
pub use event_lgmd::{EventLgmd, EventLgmdConfig};
pub use event_soc::{EventSoc, EventSocConfig};
pub use fu2020::{Fu2020, Fu2020Coefficients, Fu2020Config};
pub use keil2004::{KEIL2004_MAX_ITERATIONS, Keil2004, Keil2004Config};
pub use lowpass::LowPass;
pub use soc::{Soc, SocConfig, SocPooling};
pub use tracker::{MAX_TRACKS, MERGED_HOLD_FACTOR, Tracker, TrackerConfig};

use serde::Deserialize;

use crate::{Detector, DetectorError};

/// Ids of the registered rows that read an event camera's events ([`crate::Detector::reads_events`]).
pub const EVENT_IDS: [&str; 2] = ["event_soc", "event_lgmd"];

/// Ids of the paper's baseline detectors, in the order of its comparison (the members of
/// [`BaselineConfigs`]; other registered models are not part of this bundle).
pub const BASELINE_IDS: [&str; 4] = ["soc", "keil2004", "cizek2019", "fu2020"];

/// Parameters of all baselines, e.g. a `[baselines]` table with optional
/// `[baselines.keil2004]`-style sub-tables. Missing tables/keys take the spec defaults;
/// unknown keys are errors.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaselineConfigs {
    /// Parameters of `soc`.
    pub soc: SocConfig,
    /// Parameters of `keil2004`.
    pub keil2004: Keil2004Config,
    /// Parameters of `cizek2019`.
    pub cizek2019: Cizek2019Config,
    /// Parameters of `fu2020`.
    pub fu2020: Fu2020Config,
}

impl BaselineConfigs {
    /// Validates all four configurations.
    pub fn validate(&self) -> Result<(), DetectorError> {
        self.soc.validate()?;
        self.keil2004.validate()?;
        self.cizek2019.validate()?;
        self.fu2020.validate()
    }

    /// Builds the baseline `id` (one of [`BASELINE_IDS`]) with these parameters.
    pub fn build(&self, id: &str) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(match id {
            "soc" => Box::new(Soc::new(self.soc)?),
            "keil2004" => Box::new(Keil2004::new(self.keil2004)?),
            "cizek2019" => Box::new(Cizek2019::new(self.cizek2019)?),
            "fu2020" => Box::new(Fu2020::new(self.fu2020)?),
            other => return Err(DetectorError::UnknownDetector(other.to_string())),
        })
    }
}

/// Builds the baseline `id` (`soc`, `keil2004`, `cizek2019` or `fu2020`) with the spec
/// default parameters; any other id is [`DetectorError::UnknownDetector`].
pub fn baseline_by_id(id: &str) -> Result<Box<dyn Detector>, DetectorError> {
    BaselineConfigs::default().build(id)
}
