//! `tracker` — an engineered reference detector, **not an insect model**: it segments the
//! independently moving region of the image after removing the robot's own motion, tracks it and
//! reports its angular size θ̂ and image position and extent.
//!
//! Per frame (docs/detectors.md, tracker):
//! 1. **Residual.** *A standing camera* (no motion in its efference copy, or none known) compares
//!    the frame with a **background model**: a running average of the frames (time constant
//!    `background_frames`) that follows the scene [`FROZEN_BACKGROUND_SLOWDOWN`] times more slowly
//!    inside the tracked object's box, so the residual `frame − model` is the object's *current*
//!    image, however slowly it grows. *A moving camera* takes the **compensated difference**
//!    ([`crate::compensation`]): the frame minus the frame `baseline_frames` earlier warped to the
//!    current view by the camera's motion in between (rotation exactly, translation through the
//!    ground-plane homography below the horizon, at-infinity elsewhere); the static world cancels,
//!    and what moves on its own, or stands near the robot above the horizon, remains — the union of
//!    where the object is and where it was.
//! 2. **Segmentation**: a pixel changed when `|residual| > threshold + tolerance · |∇F|` (`|∇F|`:
//!    the frame's central-difference gradient; `tolerance` = `edge_tolerance_px` for the
//!    compensated difference, whose prediction errs by a fraction of a pixel at edges of the static
//!    texture, and 0 against the background model). Changed pixels closer than `link_px`
//!    (Chebyshev distance) form one region; regions of fewer than `min_pixels` pixels
//!    (`standing_min_pixels` against the background model) are noise,
//!    regions more than [`MAX_BAND_ASPECT`] times wider than high are the aliased far ground
//!    along the horizon, and regions that touch a side border (left or right) and the top or
//!    bottom one are cut in both directions — a wall or the ground beside the robot filling a
//!    corner of the view — and have no measurable size: all are left out.
//! 3. **Tracking**: while an object is tracked, the region overlapping its last bounding box
//!    (grown by a quarter of its size, at least `link_px`) with the largest summed |residual| is
//!    the object, joined by every other region that touches it — and, for a moving camera, by
//!    every region overlapping that grown box: the compensated difference of an object that moves
//!    across the image falls apart into where it is now and where it was, with the object's
//!    uniform inside, unchanged, between them. Without a tracked object, the largest region starts
//!    a new track. A standing camera's region is then cleaned of what the background model
//!    got wrong: an object in view from the first frame is in the
//!    model (its imprint is replaced by the background around it when that is uniform), and where
//!    the object was, the frame shows background again. **A moving camera's object by its
//!    appearance** (`appearance`, default on): the compensated difference of a far object holds
//!    only the few pixels whose centres its edge crossed over the baseline — from frame to frame
//!    a crescent, a ring or nothing. Where the object stands out from its surround (a ball against
//!    the sky), it is measured in the frame itself instead (`Tracker::appearance`): around the
//!    region and the track's last box, the pixels within the threshold of the object's luminance
//!    (the median of the region's changed pixels that differ from the surround's median now) and
//!    beyond it from the surround, when they form a solid shape enclosed by the box (widened up to
//!    [`APPEARANCE_WIDEN_PX`] a side) spanning most of the region; else the region is measured as
//!    it is. Such a measurement continues a track while the difference shows no region for up to
//!    [`APPEARANCE_HOLD_FACTOR`] × `hold_frames` frames, and a track switching between the two
//!    kinds of measurement starts its fit afresh. **Validation gate**: once the track holds
//!    [`GATE_MIN_SAMPLES`] measurements, a region whose box is larger or smaller by more than
//!    `size_gate_ratio` (and [`GATE_SLACK_PX`]) than the size that the line through the track's
//!    recent box sizes predicts (the square root of the box's area) is not the object's image in
//!    this frame — it merged with another region (a second object, the ground's texture)
//!    or lost part of itself — and is not measured. A track without a region (none overlaps its
//!    box, or the gate refused it) keeps its fitted box for `hold_frames` frames, then ends: a
//!    region elsewhere does not take over a track, it starts a new one once the track has ended —
//!    except a region on a collision course (within [`TAKE_OVER_COURSE_WIDTHS`] of its widths of
//!    the image centre) while the tracked object will pass beside (more than
//!    [`TAKE_OVER_BESIDE_WIDTHS`] of its widths beside the centre: an object on a straight course
//!    keeps its lateral offset in widths), which ends the track and starts a new one
//!    (`take_over`, default on).
//!    A track is reported once it has lasted `confirm_frames` frames, or a moving camera's once
//!    its last [`APPEARANCE_CONFIRM_FRAMES`] measurements were all of the object's appearance.
//!    Each track has a number
//!    ([`ImageRegion::track`](crate::ImageRegion)), a new one whenever a track starts.
//! 4. **Fit**: each frame's measurement — the object's size `s` (the square root of the region's
//!    area when it is the object's current image and fills its box like a solid shape, else of its
//!    box's area; for the image of a disc, the middle of the range of sizes its pixels allow,
//!    `Tracker::size_range`, with a disc's shape), centre and box shape — enters least-squares
//!    lines through `1/s` (kept within those ranges, `fit_within_ranges`),
//!    `cx/s` and `cy/s` against time with an exponentially fading memory of `fit_frames` frames:
//!    for an object moving at a constant velocity these are exactly linear (its depth and its
//!    offsets in units of its size), so the fit has no lag, while the renderer's whole-pixel edges
//!    (no anti-aliasing) are averaged out. The centres are taken in the view of the track's first
//!    frame: the camera's rotation since then (the efference copies' rotations composed: a turning
//!    robot, a shaking camera) is undone on each measured centre (`Tracker::stabilise`) and
//!    re-applied to the fitted box (`Tracker::destabilise`), so the lines hold the object's own
//!    motion and the box follows its image in every frame.
//! 5. **Outputs**: θ̂ = the larger of the fitted box's angular width and height (degrees; 0 while
//!    nothing is reported, and while the region reaches from one image border to the opposite one:
//!    the scene itself moves there, a drifting wall or the ground) — but only the height while the region touches the image's left or
//!    right border and only the width while it touches the top or bottom one (the border cuts the
//!    object: a vehicle entering the view from the side widens as more of it comes into view, not
//!    as it nears; the fitted box keeps the region's mean shape, so a cut region's height reads
//!    large, but it does not grow with the width) — as `output` and `angular_size_deg`; the
//!    fitted box and the region's residual-weighted centroid as
//!    [`Signals::region`](crate::Signals::region) (what the collision-course gate needs); `aux`:
//!    `pixels` (changed pixels of the object), `x`, `y` (centroid).
//! 6. **Several objects** (`objects.rs`): the track of steps 3–5 is the *primary* track, the one
//!    the single-object outputs above follow; beside it the tracker holds up to
//!    [`MAX_TRACKS`] − 1 *other* tracks, each with its own fit of step 4. Per frame, after the
//!    primary track's step, the regions that are not part of the primary track's region (those
//!    overlapping its box) are **assigned** to the other tracks, cheapest pair first (greedy): a
//!    region is a candidate of a track when it overlaps the track's predicted box (its fitted box
//!    moved as it moved in the last frame) grown by a quarter of its size (at least `link_px`) and
//!    passes the track's validation gate; the cost is the distance between the two boxes' centres
//!    in units of the track's size. An assigned region is joined by the free regions touching it
//!    (and, for a moving camera, overlapping the predicted box), a standing camera's cleaned of
//!    the background it uncovered without changing the model (which follows the primary track
//!    only; a region that is all uncovered background — where an object was, or stood when the
//!    model started — is no measurement and starts no track), and measured and fitted as in step 4 (a moving camera's other tracks are measured on
//!    the difference's regions, not by the object's appearance). A track is **born** tentative on
//!    each region left free that does not overlap a tracked box grown by its margin, heaviest
//!    first, while fewer than [`MAX_TRACKS`] tracks are held; it is **confirmed** once it has
//!    lasted `confirm_frames`; a tentative track is **lost** at its first frame without a region,
//!    a confirmed one after `hold_frames` frames without one — [`MERGED_HOLD_FACTOR`] times that
//!    while its box overlaps another track's (two objects crossing: their regions merged, the
//!    gate refuses the merged region, each track holds on its fitted motion). Every track has its
//!    own number from one count: when the primary track starts on the region of another track, it
//!    continues that track (its number, and it is listed at once when that track was confirmed),
//!    and when a region takes the primary track over (`take_over`), the object passing beside
//!    lives on as another track. [`Signals::objects`](crate::Signals::objects) lists the primary
//!    track when reported (or continued from a confirmed track) first, then every confirmed other
//!    track, each with its region and θ̂ of step 5; the single-object outputs are the primary
//!    track's alone, exactly as without the other tracks.

mod background;
mod config;
mod fit;
mod measure;
mod objects;
mod region;
mod track;

use crate::compensation::{CompensatedDifference, IDENTITY, Mat3, rotation_matrix};
use crate::registry::{Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, ImageRegion, Signals};

use fit::{BoxSample, fit_box};
use region::{Blob, Grouping, box_union};

pub use config::TrackerConfig;
pub use objects::{MAX_TRACKS, MERGED_HOLD_FACTOR};

/// A region more than this many times wider than high is ignored: a thin horizontal band is the
/// far ground at the horizon, whose texture is finer than a pixel there and changes unpredictably
/// from frame to frame (aliasing), not an object.
pub const MAX_BAND_ASPECT: usize = 4;

/// Smallest fraction of its box that a region of the object's current image must fill to be
/// measured by its area (a disc fills π/4 of its box; the ring of an object that the background
/// model still holds fills less).
pub const MIN_SOLID_FILL: f64 = 0.5;

/// The fit of the tracked box keeps the samples of the last `FIT_SPAN · fit_frames` frames (older
/// ones weigh less than `exp(−FIT_SPAN)` = 2 %).
pub const FIT_SPAN: usize = 4;

/// Boxes of the compensated difference (a moving camera) are fitted with a memory this many times
/// shorter than `fit_frames`: their size is fitted directly, which lags a growing object.
pub const DIFFERENCE_MEMORY_DIVISOR: f64 = 6.0;

/// Fewest measurements a track holds before its validation gate (`size_gate_ratio`) applies: a
/// line through fewer box sizes is no prediction yet.
pub const GATE_MIN_SAMPLES: usize = 8;

/// The validation gate's allowance for whole-pixel boxes (pixels): a region within
/// `size_gate_ratio` of its predicted size, give or take this, passes (a box a few pixels across
/// changes by more than the ratio when an edge crosses a pixel centre).
pub const GATE_SLACK_PX: f64 = 2.0;

/// How many pixels each side of the box in which a moving camera's object is measured by its
/// appearance may be widened to enclose the object (`Tracker::appearance`): the compensated
/// difference's region may be a crescent of it.
pub const APPEARANCE_WIDEN_PX: usize = 4;

/// A moving camera's track measured by its appearance while the compensated difference shows no
/// region of it survives this many times `hold_frames` frames: a far object's edge crosses a
/// pixel centre only every few frames, and between those crossings its difference is empty.
pub const APPEARANCE_HOLD_FACTOR: usize = 4;

/// A moving camera's track whose last this many measurements (at least) were all of the object's
/// appearance is reported without waiting for `confirm_frames`: a solid shape standing out from
/// its surround, found where the compensated difference changed, is no speck of noise.
pub const APPEARANCE_CONFIRM_FRAMES: usize = 8;

/// The smallest fraction of the compensated difference's region's width and height that the
/// object measured by its appearance must span (`Tracker::appearance`): a smaller shape is a
/// detail inside the region (a texture's patch), not the object.
pub const APPEARANCE_MIN_SPAN: f64 = 0.6;

/// A tracked object whose box's centre lies more than this many of its own widths beside the
/// image centre will pass beside the camera (its lateral offset in units of its width stays
/// constant as it approaches on a straight course), and a region on a collision course may take
/// its track over (`take_over`; `Tracker::take_over`). A pole 2 m beside the path is 8–9 widths
/// off; the suite's rows are the same for 2–5.
pub const TAKE_OVER_BESIDE_WIDTHS: f64 = 3.0;

/// A region whose box's centre lies within this many of its own widths of the image centre is on
/// a collision course with the camera (it arrives at most half a width beside the axis), and may
/// take over the track of an object passing beside (`Tracker::take_over`).
pub const TAKE_OVER_COURSE_WIDTHS: f64 = 1.0;

/// Inside the tracked object's box the standing camera's background model follows the frames this
/// many times more slowly than elsewhere: the object must not become background while it is
/// tracked, but an object that stops for good does, after several seconds.
pub const FROZEN_BACKGROUND_SLOWDOWN: f32 = 8.0;

/// A camera whose rotation (rad) and displacement (m) since the previous frame are both below this
/// counts as standing: the residual is taken against the background model (module docs, step 1).
pub const STANDING_MOTION: f64 = 1e-7;

/// Regions with more edge pixels than this (a disc some 60 pixels across) are not fitted as discs
/// (`Tracker::size_range`): their area is accurate to a fraction of a per cent, and the search's
/// cost grows with them.
pub const MAX_DISC_EDGE_PIXELS: usize = 400;

/// How far from a region's centroid `Tracker::size_range` looks for a disc's centre (pixels).
pub const DISC_CENTRE_SEARCH_PX: f64 = 0.75;

/// The grid step of that search (pixels).
pub const DISC_CENTRE_STEP_PX: f64 = 0.05;

/// How much a sample's measured `1/s` weighs against its range in `fit_within_ranges`: a line
/// inside every range is the one nearest the measurements; one that leaves a range pays for the
/// distance `1 / AREA_WEIGHT` = 10 times as much as for its distance from the measurement.
pub const AREA_WEIGHT: f64 = 0.1;

/// The tracker (see the module docs).
#[derive(Debug, Clone)]
pub struct Tracker {
    config: TrackerConfig,
    n: Option<usize>,
    diff: Option<CompensatedDifference>,
    residual: Vec<f32>,
    mask: Vec<f32>,
    grouping: Grouping,
    /// The standing camera's imprint fill: pixels already taken ([`Tracker::refine_standing`]).
    filled: Vec<bool>,
    stack: Vec<usize>,
    /// A moving camera's tracked object's luminance ([`Tracker::appearance`]).
    object_luminance: Option<f32>,
    blobs: Vec<Blob>,
    track: Option<Blob>,
    /// Tracks started since the last reset, the primary one's and the others' (`others`): the last
    /// track number given ([`ImageRegion::track`]).
    tracks: usize,
    /// The primary track's number: a new one whenever it starts following another region, that of
    /// the other track it continues when it starts on that track's region (`Tracker::adopt`).
    primary_id: usize,
    /// Whether the primary track continues a confirmed other track: it is listed in
    /// [`Signals::objects`] before it has lasted `confirm_frames` (its single-object outputs wait).
    primary_inherited: bool,
    /// The primary track's fitted box one frame earlier (its motion when it is handed to `others`).
    previous_edges: [f64; 4],
    /// The tracks beside the primary one (module docs, step 6).
    others: objects::Others,
    missed: usize,
    /// Frames the current track has lasted.
    age: usize,
    /// The track's measured boxes over the last `fit_frames` frames ([`BoxSample`]).
    samples: std::collections::VecDeque<BoxSample>,
    /// Frames since the track started.
    clock: usize,
    /// The fitted box's edges `[top, bottom, left, right]` (pixel borders, sub-pixel).
    edges: [f64; 4],
    /// The standing camera's background model (n·n; empty until a standing frame initialises it).
    background: Vec<f32>,
    /// Whether the previous frame came from a moving camera (the compensated difference's history
    /// is then current).
    moving: bool,
    /// The camera's rotation since the track's first measurement, from the efference copies:
    /// directions in the current camera's axes to those of that first frame (module docs, step 4).
    turn: Mat3,
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
            grouping: Grouping::default(),
            filled: Vec::new(),
            stack: Vec::new(),
            object_luminance: None,
            blobs: Vec::new(),
            track: None,
            tracks: 0,
            primary_id: 0,
            primary_inherited: false,
            previous_edges: [0.0; 4],
            others: objects::Others::default(),
            missed: 0,
            age: 0,
            samples: std::collections::VecDeque::new(),
            clock: 0,
            edges: [0.0; 4],
            background: Vec::new(),
            moving: false,
            turn: IDENTITY,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// Focal length of n×n frames (pixels).
    fn focal_px(&self, n: usize) -> f64 {
        crate::Pinhole::new(self.config.fov_deg).focal_px(n)
    }

    /// `sample`'s centre moved from the current camera's view to that of the track's first
    /// measurement (the camera's rotation since then undone), so that the fit sees the object's
    /// own motion and not the camera's turning or shake (module docs, step 4).
    fn stabilise(&self, sample: BoxSample, n: usize) -> BoxSample {
        self.stabilise_by(&self.turn, sample, n)
    }

    /// [`Self::stabilise`] for a track whose camera rotation since its first measurement is `turn`.
    fn stabilise_by(&self, turn: &Mat3, mut sample: BoxSample, n: usize) -> BoxSample {
        if *turn == IDENTITY {
            return sample;
        }
        let (f, size) = (self.focal_px(n), 1.0 / sample.inverse_size);
        let d = crate::compensation::apply(turn, [1.0, -sample.x * size / f, -sample.y * size / f]);
        if d[0] > 1e-6 {
            sample.x = -f * d[1] / d[0] / size;
            sample.y = -f * d[2] / d[0] / size;
        }
        sample
    }

    /// The fitted box `[top, bottom, left, right]` (pixels) moved from the view of the track's
    /// first measurement to the current camera's: [`Self::stabilise`] undone at its centre.
    fn destabilise(&self, edges: [f64; 4], n: usize) -> [f64; 4] {
        self.destabilise_by(&self.turn, edges, n)
    }

    /// [`Self::destabilise`] for a track whose camera rotation since its first measurement is `turn`.
    fn destabilise_by(&self, turn: &Mat3, [top, bottom, left, right]: [f64; 4], n: usize) -> [f64; 4] {
        if *turn == IDENTITY {
            return [top, bottom, left, right];
        }
        let (f, c) = (self.focal_px(n), n as f64 / 2.0);
        let (ci, cj) = ((top + bottom) / 2.0 - c, (left + right) / 2.0 - c);
        let d = crate::compensation::apply_t(turn, [1.0, -cj / f, -ci / f]);
        if d[0] <= 1e-6 {
            return [top, bottom, left, right];
        }
        let (di, dj) = (-f * d[2] / d[0] - ci, -f * d[1] / d[0] - cj);
        [top + di, bottom + di, left + dj, right + dj]
    }

    /// What the track of region `t`, fitted box `edges` (`[top, bottom, left, right]`, pixels) and
    /// number `id` shows (module docs, step 5): its image region and θ̂ (degrees); None while the
    /// region reaches from one image border to the opposite one.
    fn percept(&self, t: &Blob, [top, bottom, left, right]: [f64; 4], id: usize, n: usize) -> Option<(ImageRegion, f64)> {
        // a region from one image border to the opposite one is the scene moving (a drifting wall,
        // the ground), not an object with a size
        let [cut_top, cut_bottom, cut_left, cut_right] = t.touches(n);
        if (cut_top && cut_bottom) || (cut_left && cut_right) {
            return None;
        }
        let nf = n as f64;
        let x_of = |j: f64| 2.0 * j / nf - 1.0;
        let y_of = |i: f64| 1.0 - 2.0 * i / nf;
        let [i0, i1, j0, j1] = t.bbox;
        let (ci, cj) = if t.mass > 0.0 {
            (t.sum_i / t.mass + 0.5, t.sum_j / t.mass + 0.5)
        } else {
            ((i0 + i1 + 1) as f64 / 2.0, (j0 + j1 + 1) as f64 / 2.0)
        };
        let region = ImageRegion {
            centroid: [x_of(cj), y_of(ci)],
            x: [x_of(left), x_of(right.max(left))],
            y: [y_of(bottom.max(top)), y_of(top)],
            track: Some(id),
        };
        let [w, h] = region.angular_size_deg(self.config.fov_deg);
        // an image border cuts the object: only the extent along it measures the object's size
        let theta = match (cut_left || cut_right, cut_top || cut_bottom) {
            (true, false) => h,
            (false, true) => w,
            _ => w.max(h),
        };
        Some((region, theta))
    }

    fn signals(&self, n: usize) -> Signals {
        let reported = self.age >= self.config.confirm_frames || self.confirmed_by_appearance();
        let primary = self
            .track
            .as_ref()
            .filter(|_| reported || self.primary_inherited)
            .and_then(|t| Some((t, self.percept(t, self.edges, self.primary_id, n)?)));
        let objects = self.objects(n, primary.map(|(_, p)| p));
        let Some((t, (region, theta))) = primary.filter(|_| reported) else {
            return Signals {
                output: 0.0,
                angular_size_deg: Some(0.0),
                aux: vec![("pixels", 0.0), ("x", f64::NAN), ("y", f64::NAN)],
                region: None,
                objects,
            };
        };
        Signals {
            output: theta,
            angular_size_deg: Some(theta),
            aux: vec![
                ("pixels", t.pixels as f64),
                ("x", region.centroid[0]),
                ("y", region.centroid[1]),
            ],
            region: Some(region),
            objects,
        }
    }
}

impl Detector for Tracker {
    fn id(&self) -> &'static str {
        "tracker"
    }

    fn snapshot(&self) -> Option<Box<dyn Detector>> {
        Some(Box::new(self.clone()))
    }

    fn reset(&mut self) {
        if let Some(d) = &mut self.diff {
            d.reset();
        }
        self.track = None;
        self.tracks = 0;
        self.primary_id = 0;
        self.primary_inherited = false;
        self.others.clear();
        self.missed = 0;
        self.age = 0;
        self.background.clear();
        self.moving = false;
        self.object_luminance = None;
        self.turn = IDENTITY;
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
                self.filled = vec![false; n * n];
            }
        }
        if ego.knows_motion() && ego.rotation_rad.iter().any(|&r| r != 0.0) {
            let rotation = rotation_matrix(ego.rotation_rad);
            self.turn = crate::compensation::mul(&self.turn, &rotation);
            self.others.turn(&rotation);
        }
        let standing = !ego.knows_motion()
            || (ego.rotation_rad.iter().all(|r| r.abs() < STANDING_MOTION)
                && ego.translation_m.iter().all(|t| t.abs() < STANDING_MOTION));
        let tolerance_px = if standing {
            if self.background.len() != n * n {
                // the first standing frame: the background model starts from it
                self.background.clear();
                self.background.extend_from_slice(frame.data());
                self.moving = false;
                self.residual.iter_mut().for_each(|r| *r = 0.0);
                return Ok(self.signals(n));
            }
            for ((r, &f), &b) in self.residual.iter_mut().zip(frame.data()).zip(&self.background) {
                *r = f - b;
            }
            self.moving = false;
            // the background model holds exact earlier frames: no prediction error at edges
            0.0
        } else {
            let diff = self.diff.as_mut().expect("set on the first frame");
            if !self.moving {
                // the history was not kept while the camera stood
                diff.reset();
                self.moving = true;
            }
            self.background.clear();
            if !diff.step(frame.data(), ego, &mut self.residual) {
                return Ok(self.signals(n));
            }
            self.config.edge_tolerance_px
        };
        self.segment(frame.data(), n, tolerance_px);
        let min_pixels = if standing {
            self.config.standing_min_pixels
        } else {
            self.config.min_pixels
        };
        self.group(n, min_pixels);
        let taken_over = if self.config.take_over { self.take_over(n) } else { None };
        let chosen = match taken_over {
            Some(b) => {
                // the object passing beside lives on as one of the other tracks
                self.hand_over_primary();
                self.track = None;
                self.age = 0;
                self.missed = 0;
                Some(b)
            }
            None => self.choose(),
        };
        if let Some(b) = chosen.filter(|_| self.track.is_none()) {
            // a new track: another number (or that of the other track it continues), and its
            // object's luminance is not known yet
            self.adopt(&b);
            self.object_luminance = None;
        }
        // the regions the primary track's region is made of are not the other tracks'
        let claimed = chosen.map(|b| b.bbox);
        // whether this frame's measurement is of the object's appearance alone (no region)
        let mut appearance_only = false;
        let chosen = if standing {
            let starting = self.track.is_none();
            chosen.map(|b| self.refine_standing(frame.data(), n, b, starting))
        } else if self.config.appearance {
            // around the region and the track's last box together: the region may be a crescent
            let around = match (chosen.map(|b| b.bbox), self.track.map(|t| t.bbox)) {
                (Some(a), Some(t)) => Some(box_union(a, t)),
                (a, t) => a.or(t),
            };
            match around.and_then(|bbox| self.appearance(frame.data(), n, bbox, chosen.as_ref())) {
                Some(a) => {
                    appearance_only = chosen.is_none();
                    Some(a)
                }
                None => chosen,
            }
        } else {
            chosen
        };
        let chosen = chosen.filter(|b| self.passes_gate(b));
        match chosen {
            Some(b) => {
                // a moving camera's track switching between the difference's boxes and the
                // object's appearance starts its fit afresh (the two kinds of box differ)
                let switched = !standing && self.samples.back().is_some_and(|s| s.current != b.current);
                if self.track.is_none() || switched {
                    self.samples.clear();
                    self.clock = 0;
                    self.turn = IDENTITY;
                }
                if self.samples.len() >= FIT_SPAN * self.config.fit_frames {
                    self.samples.pop_front();
                }
                let measured = self.stabilise(self.measure(&b, n), n);
                self.samples.push_back(measured);
                self.track = Some(b);
                if appearance_only {
                    self.missed += 1;
                    if self.missed > APPEARANCE_HOLD_FACTOR * self.config.hold_frames {
                        self.track = None;
                        self.age = 0;
                    }
                } else {
                    self.missed = 0;
                }
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
        if self.track.is_none() {
            self.primary_inherited = false;
        }
        if self.track.is_some() {
            self.previous_edges = self.edges;
            self.edges = self.destabilise(fit_box(
                &self.samples,
                self.clock,
                self.config.fit_frames as f64,
                n,
                // only the compensated difference (a moving camera) spans baseline_frames: a
                // standing camera's residual is the object's image now
                if self.moving { self.config.baseline_frames as f64 } else { 0.0 },
            ), n);
            self.clock += 1;
        }
        self.follow_others(frame.data(), n, standing, claimed);
        if standing {
            self.update_background(frame.data(), n);
            self.update_others_background(frame.data(), n);
        }
        Ok(self.signals(n))
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
