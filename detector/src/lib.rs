//! Looming detectors: frames in, scalar signals out.
//!
//! This crate knows nothing about rendering or physics. It holds
//! - [`Frame`], the n×n grayscale image every detector consumes,
//! - the [`Detector`] trait that every model implements,
//! - the modern-Hopfield looming detector of Keil (paper §2.2) and the
//!   classic temporal-contrast baselines it is compared with,
//! - the paper's artificial approach videos ([`stimulus`]) and video input ([`video`]).

pub mod baselines;
pub mod compensation;
pub mod error;
pub mod events;
pub mod frame;
pub mod geometry;
pub mod hopfield;
mod memo;
pub mod registry;
pub mod signals;
mod simd;
pub mod stimulus;
pub mod video;

/// Smallest frame side (pixels) that every detector accepts at its default settings: 20.
///
/// This is the one statement of the minimum frame size; the simulator's camera
/// (`loomlab_sim::MIN_FRAME_SIZE`, checked equal by a test) and the stimulus loader enforce it. It
/// comes from the Hopfield detector's paper template schedule: the first template disk is
/// [`hopfield::config::PAPER_SCALE_START`]·n = 0.1·n pixels wide and needs at least
/// [`hopfield::config::MIN_TEMPLATE_DIAMETER_PX`] = 2 pixels (a narrower disk has no outline), so
/// n ≥ 2 / 0.1 = 20. (With `template.schedule = "footnote"` the Hopfield detector alone runs down to
/// n = 16, but a camera or stimulus smaller than 20 cannot feed every detector.)
pub const MIN_FRAME_SIZE: usize = 20;

pub use baselines::{BASELINE_IDS, BaselineConfigs, baseline_by_id};
pub use error::DetectorError;
pub use events::{Event, EventInput, FrameEvents};
pub use frame::{Frame, NonSquare};
pub use geometry::{LineFit, Pinhole};
pub use hopfield::{Hopfield, HopfieldConfig, HopfieldSignals, Implementation};
pub use registry::{
    CameraFacts, ConfiguredDetector, DetectorConfig, DetectorParams, DetectorSet, Registration, Registry, Signal,
    detector_ids, parse_detector_list,
};
pub use signals::{Detector, EfferenceCopy, ImageRegion, PerceivedObject, Signals};
