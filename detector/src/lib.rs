//! Looming detectors: frames in, scalar signals out.
//!
//! This crate knows nothing about rendering or physics. It holds
//! - [`Frame`], the n×n grayscale image every detector consumes,
//! - the [`Detector`] trait that every model implements,
//! - the modern-Hopfield looming detector of Keil (paper §2.2) and the
//!   classic temporal-contrast baselines it is compared with,
//! - the paper's artificial approach videos ([`stimulus`]) and video input ([`video`]).

pub mod baselines;
pub mod error;
pub mod frame;
pub mod hopfield;
pub mod registry;
pub mod signals;
pub mod stimulus;
pub mod video;

pub use baselines::{BASELINE_IDS, BaselineConfigs, baseline_by_id};
pub use error::DetectorError;
pub use frame::{Frame, NonSquare};
pub use hopfield::{Hopfield, HopfieldConfig, HopfieldSignals, Implementation};
pub use registry::{DETECTOR_IDS, DetectorSet, parse_detector_list};
pub use signals::{Detector, Signals};
