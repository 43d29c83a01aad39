//! `tracker` — an engineered reference detector, **not an insect model**: it segments the
//! independently moving region of the image after removing the robot's own motion, tracks its
//! bounding box and reports its angular size θ̂ and image position and extent.
//!
//! Per frame (docs/detectors.md, tracker):
//! 1. **Compensated difference** ([`crate::compensation`]): the current frame minus the frame
//!    `baseline_frames` earlier warped to the current view by the camera's motion in between (from
//!    the efference copies: rotation exactly, translation through the ground-plane homography below
//!    the horizon, at-infinity elsewhere). The static world cancels; what moves on its own, or
//!    stands near the robot above the horizon, remains.
//! 2. **Segmentation**: a pixel changed when `|residual| > threshold + edge_tolerance_px · |∇F|`
//!    (`|∇F|`: the current frame's central-difference gradient per pixel — a sub-pixel error of the
//!    prediction at an edge of the static texture leaves a residual proportional to it). Changed
//!    pixels closer than `link_px` (Chebyshev distance) form one region; regions of fewer than
//!    `min_pixels` pixels are noise, and regions more than [`MAX_BAND_ASPECT`] times wider than
//!    high are the aliased far ground along the horizon.
//! 3. **Tracking**: while an object is tracked, the region overlapping its last bounding box
//!    (grown by a quarter of its size, at least `link_px`) with the largest summed |residual| is
//!    the object, joined by every other region that touches it; with none, the largest region
//!    starts a new track. A track without a region keeps its last box for `hold_frames` frames,
//!    then ends. A track is reported once it has lasted `confirm_frames` frames.
//! 4. **Outputs**: each edge of the box is smoothed by an α-β filter ([`EDGE_ALPHA`],
//!    [`EDGE_BETA`]: sub-pixel positions, no lag at a constant edge velocity); θ̂ = the larger of
//!    the smoothed box's angular width and height (degrees; 0 while nothing is tracked) as `output` and `angular_size_deg`; the box and the residual-weighted centroid as
//!    [`Signals::region`](crate::Signals::region) (what the collision-course gate needs); `aux`:
//!    `pixels` (changed pixels of the object), `x`, `y` (centroid).
//!
//! An expanding ring of change marks an approaching uniform object (its interior does not change);
//! its box is the object's current extent. θ̂ grows as the object nears; the τ strategy reads the
//! growth, the course gate the box's drift.

use serde::Deserialize;

use super::common::{Range, check};
use crate::compensation::CompensatedDifference;
use crate::registry::{CameraFacts, DetectorConfig, Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, ImageRegion, Signals};

/// Gain of the α-β filter that smooths each edge of the tracked box (position correction per
/// frame): a box measured in whole pixels jumps by a pixel at a time, which a τ estimate from a few
/// frames would read as motion.
pub const EDGE_ALPHA: f64 = 0.35;

/// Velocity gain of the edges' α-β filter (per frame).
pub const EDGE_BETA: f64 = 0.05;

/// A region more than this many times wider than high is ignored: a thin horizontal band is the
/// far ground at the horizon, whose texture is finer than a pixel there and changes unpredictably
/// from frame to frame (aliasing), not an object.
pub const MAX_BAND_ASPECT: usize = 4;

/// Parameters of [`Tracker`].
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackerConfig {
    /// Full field of view of the camera (degrees): from `world.camera`, never a param. Default 60.
    pub fov_deg: f64,
    /// How many frames back the compensated difference compares with (frames, ≥ 1). Default 8
    /// (67 ms at 120 Hz): a far object's edge moves a fraction of a pixel per frame.
    pub baseline_frames: usize,
    /// Residual above which a pixel counts as changed (luminance, in (0, 1)). Default 0.06.
    pub threshold: f64,
    /// Prediction error allowed at edges, as pixels times the local gradient (pixels, ≥ 0).
    /// Default 0.5.
    pub edge_tolerance_px: f64,
    /// Changed pixels at most this far apart (Chebyshev, pixels, 1–8) belong to one region.
    /// Default 2.
    pub link_px: usize,
    /// Fewest changed pixels of a region (pixels, ≥ 1). Default 4.
    pub min_pixels: usize,
    /// Frames a track survives without a region (frames). Default 6.
    pub hold_frames: usize,
    /// Frames a new track must last before it is reported (frames, ≥ 1): a box of a few pixels
    /// that appears and vanishes again is noise, and a decision strategy fitting the first frames
    /// of a track would read its jitter as motion. Default 12 (0.1 s at 120 Hz).
    pub confirm_frames: usize,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        Self {
            fov_deg: 60.0,
            baseline_frames: 8,
            threshold: 0.06,
            edge_tolerance_px: 0.5,
            link_px: 2,
            min_pixels: 4,
            hold_frames: 6,
            confirm_frames: 12,
        }
    }
}

impl TrackerConfig {
    /// Checks every value (the error names the parameter, its range and its default).
    pub fn validate(&self) -> Result<(), DetectorError> {
        check("tracker.fov_deg", self.fov_deg, Range::Closed(0.5, 170.0), 60.0, "the camera's field of view")?;
        check(
            "tracker.threshold",
            self.threshold,
            Range::Closed(1e-6, 1.0),
            0.06,
            "the residual above which a pixel counts as changed",
        )?;
        check(
            "tracker.edge_tolerance_px",
            self.edge_tolerance_px,
            Range::Closed(0.0, 10.0),
            0.5,
            "the prediction error allowed at edges (pixels)",
        )?;
        for (name, value, lo, hi, default) in [
            ("tracker.baseline_frames", self.baseline_frames, 1, 120, 8),
            ("tracker.link_px", self.link_px, 1, 8, 2),
            ("tracker.min_pixels", self.min_pixels, 1, 10_000, 4),
            ("tracker.hold_frames", self.hold_frames, 0, 1_000, 6),
            ("tracker.confirm_frames", self.confirm_frames, 1, 1_000, 12),
        ] {
            if !(lo..=hi).contains(&value) {
                return Err(DetectorError::InvalidParameter {
                    name,
                    value: value.to_string(),
                    reason: format!("it must be an integer in {lo}..={hi} (default {default})"),
                });
            }
        }
        Ok(())
    }
}

/// One region of changed pixels.
#[derive(Debug, Clone, Copy)]
struct Blob {
    pixels: usize,
    mass: f64,
    sum_i: f64,
    sum_j: f64,
    /// `[i_min, i_max, j_min, j_max]` (inclusive pixel indices).
    bbox: [usize; 4],
}

impl Blob {
    fn merge(&mut self, o: &Blob) {
        self.pixels += o.pixels;
        self.mass += o.mass;
        self.sum_i += o.sum_i;
        self.sum_j += o.sum_j;
        self.bbox = [
            self.bbox[0].min(o.bbox[0]),
            self.bbox[1].max(o.bbox[1]),
            self.bbox[2].min(o.bbox[2]),
            self.bbox[3].max(o.bbox[3]),
        ];
    }

    fn overlaps(&self, b: [usize; 4], margin: usize) -> bool {
        self.bbox[0] <= b[1] + margin
            && b[0] <= self.bbox[1] + margin
            && self.bbox[2] <= b[3] + margin
            && b[2] <= self.bbox[3] + margin
    }
}

/// The tracker (see the module docs).
#[derive(Debug, Clone)]
pub struct Tracker {
    config: TrackerConfig,
    n: Option<usize>,
    diff: Option<CompensatedDifference>,
    residual: Vec<f32>,
    mask: Vec<f32>,
    label: Vec<u32>,
    stack: Vec<usize>,
    blobs: Vec<Blob>,
    track: Option<Blob>,
    missed: usize,
    /// Frames the current track has lasted.
    age: usize,
    /// The box's smoothed edges `[top, bottom + 1, left, right + 1]` (pixel borders) and their
    /// velocities (pixels per frame), per α-β filter.
    edges: [(f64, f64); 4],
}

impl Tracker {
    /// Builds the model after validating `config`; the first frame fixes n.
    pub fn new(config: TrackerConfig) -> Result<Self, DetectorError> {
        config.validate()?;
        Ok(Self {
            config,
            n: None,
            diff: None,
            residual: Vec::new(),
            mask: Vec::new(),
            label: Vec::new(),
            stack: Vec::new(),
            blobs: Vec::new(),
            track: None,
            missed: 0,
            age: 0,
            edges: [(0.0, 0.0); 4],
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// Marks changed pixels (`mask` = |residual| where changed, else 0).
    fn segment(&mut self, frame: &[f32], n: usize) {
        let thr = self.config.threshold as f32;
        let tol = self.config.edge_tolerance_px as f32;
        for i in 0..n {
            let (iu, id) = (i.saturating_sub(1), (i + 1).min(n - 1));
            for j in 0..n {
                let r = self.residual[i * n + j].abs();
                if r <= thr {
                    // below the threshold whatever the gradient
                    self.mask[i * n + j] = 0.0;
                    continue;
                }
                let (jl, jr) = (j.saturating_sub(1), (j + 1).min(n - 1));
                let gx = (frame[i * n + jr] - frame[i * n + jl]) / (jr - jl).max(1) as f32;
                let gy = (frame[id * n + j] - frame[iu * n + j]) / (id - iu).max(1) as f32;
                let g = gx.abs().max(gy.abs());
                self.mask[i * n + j] = if r > thr + tol * g { r } else { 0.0 };
            }
        }
    }

    /// Groups changed pixels into [`Blob`]s (flood fill with the `link_px` neighbourhood).
    fn group(&mut self, n: usize) {
        let link = self.config.link_px as isize;
        self.blobs.clear();
        self.label.iter_mut().for_each(|l| *l = 0);
        for start in 0..n * n {
            if self.mask[start] == 0.0 || self.label[start] != 0 {
                continue;
            }
            let id = self.blobs.len() as u32 + 1;
            let (si, sj) = (start / n, start % n);
            let mut blob = Blob {
                pixels: 0,
                mass: 0.0,
                sum_i: 0.0,
                sum_j: 0.0,
                bbox: [si, si, sj, sj],
            };
            self.label[start] = id;
            self.stack.clear();
            self.stack.push(start);
            while let Some(p) = self.stack.pop() {
                let (i, j) = (p / n, p % n);
                let m = f64::from(self.mask[p]);
                blob.pixels += 1;
                blob.mass += m;
                blob.sum_i += m * i as f64;
                blob.sum_j += m * j as f64;
                blob.bbox = [
                    blob.bbox[0].min(i),
                    blob.bbox[1].max(i),
                    blob.bbox[2].min(j),
                    blob.bbox[3].max(j),
                ];
                for di in -link..=link {
                    let ii = i as isize + di;
                    if ii < 0 || ii >= n as isize {
                        continue;
                    }
                    for dj in -link..=link {
                        let jj = j as isize + dj;
                        if jj < 0 || jj >= n as isize {
                            continue;
                        }
                        let q = ii as usize * n + jj as usize;
                        if self.mask[q] != 0.0 && self.label[q] == 0 {
                            self.label[q] = id;
                            self.stack.push(q);
                        }
                    }
                }
            }
            let (height, width) = (blob.bbox[1] - blob.bbox[0] + 1, blob.bbox[3] - blob.bbox[2] + 1);
            if blob.pixels >= self.config.min_pixels && width <= MAX_BAND_ASPECT * height {
                self.blobs.push(blob);
            }
        }
    }

    /// Chooses the tracked object among this frame's blobs (see the module docs, step 3).
    fn choose(&mut self) -> Option<Blob> {
        let by_mass = |a: &&Blob, b: &&Blob| a.mass.total_cmp(&b.mass);
        let chosen = match &self.track {
            Some(t) => {
                let [i0, i1, j0, j1] = t.bbox;
                let margin = ((i1 - i0).max(j1 - j0) / 4).max(self.config.link_px);
                self.blobs
                    .iter()
                    .filter(|b| b.overlaps(t.bbox, margin))
                    .max_by(by_mass)
                    .or_else(|| self.blobs.iter().max_by(by_mass))
            }
            None => self.blobs.iter().max_by(by_mass),
        };
        let mut chosen = *chosen?;
        let first = chosen;
        for b in &self.blobs {
            if b.bbox != first.bbox && b.overlaps(chosen.bbox, self.config.link_px) {
                chosen.merge(b);
            }
        }
        Some(chosen)
    }

    fn signals(&self, n: usize) -> Signals {
        let confirmed = self.track.as_ref().filter(|_| self.age >= self.config.confirm_frames);
        let Some(t) = confirmed else {
            return Signals {
                output: 0.0,
                angular_size_deg: Some(0.0),
                aux: vec![("pixels", 0.0), ("x", f64::NAN), ("y", f64::NAN)],
                region: None,
            };
        };
        let nf = n as f64;
        let x_of = |j: f64| 2.0 * j / nf - 1.0;
        let y_of = |i: f64| 1.0 - 2.0 * i / nf;
        let [i0, i1, j0, j1] = t.bbox;
        let [top, bottom, left, right] = self.edges.map(|(p, _)| p);
        let (ci, cj) = if t.mass > 0.0 {
            (t.sum_i / t.mass + 0.5, t.sum_j / t.mass + 0.5)
        } else {
            ((i0 + i1 + 1) as f64 / 2.0, (j0 + j1 + 1) as f64 / 2.0)
        };
        let region = ImageRegion {
            centroid: [x_of(cj), y_of(ci)],
            x: [x_of(left), x_of(right.max(left))],
            y: [y_of(bottom.max(top)), y_of(top)],
        };
        let [w, h] = region.angular_size_deg(self.config.fov_deg);
        let theta = w.max(h);
        Signals {
            output: theta,
            angular_size_deg: Some(theta),
            aux: vec![
                ("pixels", t.pixels as f64),
                ("x", region.centroid[0]),
                ("y", region.centroid[1]),
            ],
            region: Some(region),
        }
    }
}

impl Detector for Tracker {
    fn id(&self) -> &'static str {
        "tracker"
    }

    fn reset(&mut self) {
        if let Some(d) = &mut self.diff {
            d.reset();
        }
        self.track = None;
        self.missed = 0;
        self.age = 0;
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        self.step_moving(frame, &EfferenceCopy::default())
    }

    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        let n = frame.n();
        match self.n {
            Some(expected) if expected != n => return Err(DetectorError::FrameSize { expected, got: n }),
            Some(_) => {}
            None => {
                self.n = Some(n);
                self.diff = Some(CompensatedDifference::new(n, self.config.fov_deg, self.config.baseline_frames));
                self.residual = vec![0.0; n * n];
                self.mask = vec![0.0; n * n];
                self.label = vec![0; n * n];
            }
        }
        let diff = self.diff.as_mut().expect("set on the first frame");
        if !diff.step(frame.data(), ego, &mut self.residual) {
            return Ok(self.signals(n));
        }
        self.segment(frame.data(), n);
        self.group(n);
        match self.choose() {
            Some(b) => {
                let [i0, i1, j0, j1] = b.bbox;
                let measured = [i0 as f64, i1 as f64 + 1.0, j0 as f64, j1 as f64 + 1.0];
                if self.track.is_none() {
                    self.edges = measured.map(|m| (m, 0.0));
                } else {
                    for ((p, v), m) in self.edges.iter_mut().zip(measured) {
                        let predicted = *p + *v;
                        let r = m - predicted;
                        *p = predicted + EDGE_ALPHA * r;
                        *v += EDGE_BETA * r;
                    }
                }
                self.track = Some(b);
                self.missed = 0;
                self.age += 1;
            }
            None if self.track.is_some() => {
                self.missed += 1;
                self.age += 1;
                if self.missed > self.config.hold_frames {
                    self.track = None;
                    self.age = 0;
                }
            }
            None => {}
        }
        Ok(self.signals(n))
    }
}

impl DetectorConfig for TrackerConfig {
    const CAMERA_KEYS: &'static [&'static str] = &["fov_deg"];

    fn for_camera(self, camera: &CameraFacts) -> Self {
        Self {
            fov_deg: camera.fov_deg,
            ..self
        }
    }

    fn validate(&self) -> Result<(), DetectorError> {
        TrackerConfig::validate(self)
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(Tracker::new(*self)?))
    }
}

/// `tracker` in the registry: an engineering reference, triggered on θ̂ by default (degrees; the
/// default threshold is the 10°, not calibrated — its suite row uses the τ strategy).
pub(crate) fn registration() -> Registration {
    Registration::of::<TrackerConfig>(
        "tracker",
        "Engineered reference: ego-motion-compensated change segmentation and box tracking (not an insect model)",
        &[Signal::Output, Signal::AngularSize],
        Signal::AngularSize,
        10.0,
    )
}
