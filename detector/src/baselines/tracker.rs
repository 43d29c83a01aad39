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
//!    region elsewhere does not take over a track, it starts a new one once the track has ended.
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
//!    (no anti-aliasing) are averaged out.
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

use serde::Deserialize;

use super::common::{Range, check};
use crate::compensation::CompensatedDifference;
use crate::registry::{DetectorConfig, Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, ImageRegion, Signals};

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

/// Inside the tracked object's box the standing camera's background model follows the frames this
/// many times more slowly than elsewhere: the object must not become background while it is
/// tracked, but an object that stops for good does, after several seconds.
pub const FROZEN_BACKGROUND_SLOWDOWN: f32 = 8.0;

/// A camera whose rotation (rad) and displacement (m) since the previous frame are both below this
/// counts as standing: the residual is taken against the background model (module docs, step 1).
pub const STANDING_MOTION: f64 = 1e-7;

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
    /// Fewest changed pixels of a region of the compensated difference (a moving camera; pixels,
    /// ≥ 1). Default 4: the prediction's errors at the static texture's edges come in small specks.
    pub min_pixels: usize,
    /// Fewest changed pixels of a region against a standing camera's background model (pixels,
    /// ≥ 1). Default 2: the model has no prediction error, and a far object that grows by a
    /// fraction of a pixel changes its edge pixels one or two at a time.
    pub standing_min_pixels: usize,
    /// Frames a track survives without a region (frames). Default 6.
    pub hold_frames: usize,
    /// The track's validation gate (ratio, > 1): once the track holds 8
    /// measurements, a region whose box is larger or smaller than its predicted size by more than
    /// this factor (give or take 2 pixels) is not measured: a merge with another region
    /// or a split, not the object's growth (module docs, step 3). Default 1.3 (the decision
    /// strategies' jump ratio): at 120 Hz an object grows by 30 % in a frame only at a time to
    /// contact below 0.03 s.
    pub size_gate_ratio: f64,
    /// Frames a new track must last before it is reported (frames, ≥ 1): a box of a few pixels
    /// that appears and vanishes again is noise, and a decision strategy fitting the first frames
    /// of a track would read its jitter as motion. Default 30 (0.25 s at 120 Hz).
    pub confirm_frames: usize,
    /// Memory of the fit of the track's measurements (frames, ≥ 1): a measurement `j` frames old
    /// weighs `exp(−j/fit_frames)` in the least-squares lines through the object's inverse size and
    /// its centre in units of its size, which change linearly in time for an object moving at a
    /// constant velocity (module docs, step 4). Default 45 (0.375 s at 120 Hz).
    pub fit_frames: usize,
    /// Time constant of the background model of a standing camera (frames, ≥ 1): the background
    /// follows the frames by `1/background_frames` of their difference per frame outside the
    /// tracked object's box (and 8 times slower inside it). Default
    /// 60 (0.5 s at 120 Hz): a far object that grows by a pixel in half a second still differs
    /// from it, and a change the scene keeps (a light switched on) fades within about a second.
    pub background_frames: usize,
    /// Whether a moving camera measures the tracked object by its appearance in the frame when it
    /// stands out from its surround (module docs, step 3). Default true; false measures the
    /// compensated difference's regions only.
    pub appearance: bool,
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
            standing_min_pixels: 2,
            hold_frames: 6,
            size_gate_ratio: 1.3,
            confirm_frames: 30,
            fit_frames: 45,
            background_frames: 60,
            appearance: true,
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
            "tracker.size_gate_ratio",
            self.size_gate_ratio,
            Range::Closed(1.01, 100.0),
            1.3,
            "the track's validation gate (ratio of box sizes)",
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
            ("tracker.standing_min_pixels", self.standing_min_pixels, 1, 10_000, 2),
            ("tracker.hold_frames", self.hold_frames, 0, 1_000, 6),
            ("tracker.confirm_frames", self.confirm_frames, 1, 1_000, 30),
            ("tracker.fit_frames", self.fit_frames, 1, 1_000, 45),
            ("tracker.background_frames", self.background_frames, 1, 100_000, 60),
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
#[derive(Debug, Clone, Copy, PartialEq)]
struct Blob {
    pixels: usize,
    mass: f64,
    sum_i: f64,
    sum_j: f64,
    /// `[i_min, i_max, j_min, j_max]` (inclusive pixel indices).
    bbox: [usize; 4],
    /// Whether the region is the object's current image (a standing camera's background
    /// subtraction, [`Tracker::refine_standing`]) rather than a difference of two frames.
    current: bool,
}

impl Blob {
    /// The region of the one pixel `(i, j)` weighing `w`, of the object's current image.
    fn pixel(i: usize, j: usize, w: f64) -> Self {
        Blob {
            pixels: 1,
            mass: w,
            sum_i: w * i as f64,
            sum_j: w * j as f64,
            bbox: [i, i, j, j],
            current: true,
        }
    }

    fn merge(&mut self, o: &Blob) {
        self.pixels += o.pixels;
        self.mass += o.mass;
        self.sum_i += o.sum_i;
        self.sum_j += o.sum_j;
        self.current &= o.current;
        self.bbox = box_union(self.bbox, o.bbox);
    }

    /// Which image borders the region touches in an n × n frame: `[top, bottom, left, right]`.
    fn touches(&self, n: usize) -> [bool; 4] {
        let [i0, i1, j0, j1] = self.bbox;
        [i0 == 0, i1 + 1 >= n, j0 == 0, j1 + 1 >= n]
    }

    /// Whether an n×n image shows the region's extent along at least one axis: a region that
    /// touches the left or right border *and* the top or bottom one is cut in both directions (a
    /// wall or the ground beside the robot filling a corner of the view), so no size of it can be
    /// measured and it is left out.
    fn measurable(&self, n: usize) -> bool {
        let [top, bottom, left, right] = self.touches(n);
        !((top || bottom) && (left || right))
    }

    fn overlaps(&self, b: [usize; 4], margin: usize) -> bool {
        self.bbox[0] <= b[1] + margin
            && b[0] <= self.bbox[1] + margin
            && self.bbox[2] <= b[3] + margin
            && b[2] <= self.bbox[3] + margin
    }
}

/// A row's run of consecutive changed pixels: row `i`, columns `j0..=j1`.
#[derive(Debug, Clone, Copy)]
struct Run {
    i: usize,
    j0: usize,
    j1: usize,
}

/// The grouping's working memory ([`Tracker::group`]), kept between frames.
#[derive(Debug, Clone, Default)]
struct Grouping {
    runs: Vec<Run>,
    /// Index of each row's first run in `runs` (n + 1 entries).
    row_start: Vec<usize>,
    /// Union-find parents of the runs.
    parent: Vec<u32>,
    /// Each root run's region in `found` (`u32::MAX`: none yet).
    slot: Vec<u32>,
    /// Every region, before the size and shape filters.
    found: Vec<Blob>,
}

/// The root of run `r`'s set (path halving).
fn find(parent: &mut [u32], mut r: usize) -> usize {
    while parent[r] as usize != r {
        let grand = parent[parent[r] as usize];
        parent[r] = grand;
        r = grand as usize;
    }
    r
}

/// Joins the sets of runs `a` and `b` (the smaller root becomes the parent).
fn union(parent: &mut [u32], a: usize, b: usize) {
    let (a, b) = (find(parent, a), find(parent, b));
    if a != b {
        let (lo, hi) = (a.min(b), a.max(b));
        parent[hi] = lo as u32;
    }
}

/// The smallest box `[i0, i1, j0, j1]` (inclusive) holding boxes `a` and `b`.
fn box_union(a: [usize; 4], b: [usize; 4]) -> [usize; 4] {
    [a[0].min(b[0]), a[1].max(b[1]), a[2].min(b[2]), a[3].max(b[3])]
}

/// Collects into `ring` the values of `image` (n·n) on the pixels just outside `bbox`
/// (`[i0, i1, j0, j1]`, inclusive), inside the image.
fn ring_of(image: &[f32], n: usize, [i0, i1, j0, j1]: [usize; 4], ring: &mut Vec<f32>) {
    ring.clear();
    let (c0, c1) = (j0.saturating_sub(1), (j1 + 1).min(n - 1));
    if i0 > 0 {
        ring.extend(&image[(i0 - 1) * n + c0..=(i0 - 1) * n + c1]);
    }
    if i1 + 1 < n {
        ring.extend(&image[(i1 + 1) * n + c0..=(i1 + 1) * n + c1]);
    }
    for i in i0..=i1 {
        if j0 > 0 {
            ring.push(image[i * n + j0 - 1]);
        }
        if j1 + 1 < n {
            ring.push(image[i * n + j1 + 1]);
        }
    }
}

/// One frame's measurement of the tracked object, as the quantities that change linearly in time
/// for an object moving at a constant velocity: with its size `s` (pixels: the square root of its
/// area, or of its box's) and its centre `(cx, cy)` relative to the image centre, `1/s` (∝ the
/// object's depth) and `cx/s`, `cy/s` (∝ its lateral and vertical offsets); its box's shape
/// `width/s`, `height/s` (constant for a rigid object).
#[derive(Debug, Clone, Copy)]
struct BoxSample {
    /// Frames since the track started.
    k: f64,
    inverse_size: f64,
    /// The range `[low, high]` of `1/s` that the region's pixels allow (see
    /// `Tracker::size_range`); `[1/s, 1/s]` when they give none: the measurement itself.
    inverse_range: [f64; 2],
    x: f64,
    y: f64,
    width: f64,
    height: f64,
    /// Whether it measured the object's current image (else a difference of two frames).
    current: bool,
}

impl BoxSample {
    /// The sample of frame `k` of a box of size `size`, centre `[row, column]` relative to the
    /// image centre, width `w` and height `h` (pixels).
    fn of(k: f64, size: f64, [ci, cj]: [f64; 2], w: f64, h: f64, current: bool) -> Self {
        let s = size.max(1e-3);
        Self {
            current,
            k,
            inverse_size: 1.0 / s,
            inverse_range: [1.0 / s, 1.0 / s],
            x: cj / s,
            y: ci / s,
            width: w / s,
            height: h / s,
        }
    }
}

/// The box at frame `k` from the weighted least-squares lines through the samples' `1/s`, `cx/s`,
/// `cy/s` and their weighted mean shape (see [`BoxSample`]), a sample `j` frames old weighing
/// `exp(−j/memory)`: an exponentially fading memory changes the fit smoothly as samples age,
/// where a window of equal weights jumps whenever a sample leaves it. The samples' mean when they
/// span a single frame.
fn fit_box(samples: &std::collections::VecDeque<BoxSample>, k: usize, memory: f64, n: usize, baseline: f64) -> [f64; 4] {
    if samples.back().is_some_and(|s| !s.current) {
        return fit_difference_box(samples, k, memory / DIFFERENCE_MEMORY_DIVISOR, n, baseline);
    }
    let lines = Lines::fit(samples, k as f64, memory, |s| [s.inverse_size, s.x, s.y, s.width, s.height]);
    let inverse = fit_within_ranges(samples, k as f64, memory, &lines);
    // a fitted depth at or behind the camera (a box that grew explosively) keeps the last size
    let inverse = if inverse > 1e-6 {
        inverse
    } else {
        samples.back().map_or(1.0, |s| s.inverse_size)
    };
    let size = 1.0 / inverse;
    let (cx, cy) = (lines.at(1) * size + n as f64 / 2.0, lines.at(2) * size + n as f64 / 2.0);
    let (w, h) = (lines.mean[3] * size, lines.mean[4] * size);
    [cy - h / 2.0, cy + h / 2.0, cx - w / 2.0, cx + w / 2.0]
}

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

/// The fitted `1/s` at `now`: the line `1/s = a + b·(k − now)` that minimises, with the weights of
/// `Lines::fit`, each sample's squared distance from its range
/// (`BoxSample::inverse_range`) plus [`AREA_WEIGHT`] times its squared distance from the
/// measured `1/s` — the plain least-squares line when that stays inside every range. The
/// measured size of a small disc moves in steps of several pixels (module docs, step 4), and a
/// line through such steps lags behind the object's growth between them by up to a step; the
/// ranges say when the object's edge crossed each pixel centre. The objective is convex and
/// piecewise quadratic in `(a, b)`: Newton steps over the set of ranges the line leaves, until
/// that set stays the same.
fn fit_within_ranges(samples: &std::collections::VecDeque<BoxSample>, now: f64, memory: f64, lines: &Lines) -> f64 {
    let (mut a, mut b) = (lines.at(0), lines.slope[0]);
    let mut previous: Option<Vec<i8>> = None;
    let mut sides = Vec::with_capacity(samples.len());
    for _ in 0..32 {
        sides.clear();
        let (mut s0, mut s1, mut s2, mut t0, mut t1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (w, k, s) in fading(samples, now, memory) {
            let y = a + b * k;
            let [lo, hi] = s.inverse_range;
            let (side, weight, target) = if y < lo {
                (-1, w * (1.0 + AREA_WEIGHT), (lo + AREA_WEIGHT * s.inverse_size) / (1.0 + AREA_WEIGHT))
            } else if y > hi {
                (1, w * (1.0 + AREA_WEIGHT), (hi + AREA_WEIGHT * s.inverse_size) / (1.0 + AREA_WEIGHT))
            } else {
                (0, w * AREA_WEIGHT, s.inverse_size)
            };
            sides.push(side);
            s0 += weight;
            s1 += weight * k;
            s2 += weight * k * k;
            t0 += weight * target;
            t1 += weight * k * target;
        }
        if previous.as_ref() == Some(&sides) {
            break;
        }
        let det = s0 * s2 - s1 * s1;
        if s0 <= 0.0 {
            break;
        }
        if det > 1e-12 * s0 * s2.max(1.0) {
            b = (s0 * t1 - s1 * t0) / det;
            a = (t0 - b * s1) / s0;
        } else {
            (a, b) = (t0 / s0, 0.0);
        }
        previous = Some(sides.clone());
    }
    a
}

/// The box at frame `k` from boxes of the compensated difference: weighted least-squares lines
/// through the size `s`, the centre and the mean shape themselves (memory `memory` frames). Such a
/// box holds where the object was as well as where it is, so `1/s` is not linear in time and its
/// line would overshoot as the object nears; a line through `s` lags a little instead.
///
/// The box is then cut down to where the object is now. The difference spans `baseline` frames: an
/// image whose centre moves by `Δc` and whose extent grows by `Δw` over them leaves a union box
/// wider than its current extent by `excess = max(|Δc| − Δw/2, 0)` on the trailing side (`Δc` and
/// `Δw` from the fitted lines' slopes). Without this cut, the box's trailing edge is where the
/// object was `baseline` frames ago, and an object passing beside the robot, whose image moves
/// outwards while it grows, looks as if its near edge stood still or moved towards the axis.
fn fit_difference_box(
    samples: &std::collections::VecDeque<BoxSample>,
    k: usize,
    memory: f64,
    n: usize,
    baseline: f64,
) -> [f64; 4] {
    let lines = Lines::fit(samples, k as f64, memory, |s| {
        let size = 1.0 / s.inverse_size;
        [size, s.x * size, s.y * size, s.width, s.height]
    });
    let size = lines.at(0).max(1e-3);
    let (cx, cy) = (lines.at(1) + n as f64 / 2.0, lines.at(2) + n as f64 / 2.0);
    let (w, h) = (lines.mean[3] * size, lines.mean[4] * size);
    // the part of the union box that is where the object was: (extent, centre) now
    let current = |extent: f64, centre: f64, centre_rate: f64, extent_rate: f64| {
        // at most down to one pixel (and never a negative cut)
        let excess = (centre_rate.abs() * baseline - extent_rate.max(0.0) * baseline / 2.0)
            .min(extent - 1.0)
            .max(0.0);
        (extent - excess, centre + centre_rate.signum() * excess / 2.0)
    };
    let (w, cx) = current(w, cx, lines.slope[1], lines.mean[3] * lines.slope[0]);
    let (h, cy) = current(h, cy, lines.slope[2], lines.mean[4] * lines.slope[0]);
    [cy - h / 2.0, cy + h / 2.0, cx - w / 2.0, cx + w / 2.0]
}

/// The samples newest first, each with its fading-memory weight (1 for a sample at `now`, times
/// `exp(−1/memory)` per frame further back) and its frame relative to `now` (≤ 0).
fn fading(
    samples: &std::collections::VecDeque<BoxSample>,
    now: f64,
    memory: f64,
) -> impl Iterator<Item = (f64, f64, &BoxSample)> {
    let decay = (-1.0 / memory.max(1e-9)).exp();
    let (mut w, mut last_k) = (1.0, now);
    samples.iter().rev().map(move |s| {
        w *= decay.powi((last_k - s.k).round() as i32);
        last_k = s.k;
        (w, s.k - now, s)
    })
}

/// Weighted least-squares lines through five quantities of the samples against their frame, a
/// sample `j` frames before `now` weighing `exp(−j/memory)`.
struct Lines {
    now: f64,
    mean_k: f64,
    mean: [f64; 5],
    /// Slopes (per frame; 0 when the samples span a single frame).
    slope: [f64; 5],
}

impl Lines {
    fn fit(
        samples: &std::collections::VecDeque<BoxSample>,
        now: f64,
        memory: f64,
        values: impl Fn(&BoxSample) -> [f64; 5],
    ) -> Self {
        // one pass: weighted sums of 1, k, k², v and k·v (k relative to now, newest first)
        let (mut sw, mut sk, mut skk) = (0.0, 0.0, 0.0);
        let (mut sv, mut skv) = ([0.0; 5], [0.0; 5]);
        for (w, k, s) in fading(samples, now, memory) {
            let v = values(s);
            sw += w;
            sk += w * k;
            skk += w * k * k;
            for q in 0..5 {
                sv[q] += w * v[q];
                skv[q] += w * k * v[q];
            }
        }
        let sw = f64::max(sw, 1e-300);
        let mean_k = sk / sw;
        let var_k = skk - sk * mean_k;
        let mean = sv.map(|v| v / sw);
        let mut slope = [0.0; 5];
        if var_k > 1e-9 {
            for q in 0..5 {
                slope[q] = (skv[q] - sk * mean[q]) / var_k;
            }
        }
        Self {
            now: 0.0,
            mean_k,
            mean,
            slope,
        }
    }

    /// Line `q` at `now`.
    fn at(&self, q: usize) -> f64 {
        self.mean[q] + self.slope[q] * (self.now - self.mean_k)
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
    grouping: Grouping,
    /// The standing camera's imprint fill: pixels already taken ([`Tracker::refine_standing`]).
    filled: Vec<bool>,
    stack: Vec<usize>,
    /// A moving camera's tracked object's luminance ([`Tracker::appearance`]).
    object_luminance: Option<f32>,
    blobs: Vec<Blob>,
    track: Option<Blob>,
    /// Tracks started since the last reset: the current track's number ([`ImageRegion::track`]).
    tracks: usize,
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
            missed: 0,
            age: 0,
            samples: std::collections::VecDeque::new(),
            clock: 0,
            edges: [0.0; 4],
            background: Vec::new(),
            moving: false,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// Marks changed pixels (`mask` = |residual| where changed, else 0): a residual above the
    /// threshold, and above it by more than `tolerance_px` times the frame's local gradient (the
    /// larger of its central differences, one-sided at the border), is a change.
    fn segment(&mut self, frame: &[f32], n: usize, tolerance_px: f64) {
        let thr = self.config.threshold as f32;
        let tol = tolerance_px as f32;
        let mark = |r: f32, gx: f32, gy: f32| {
            let g = gx.abs().max(gy.abs());
            if (r > thr) & (r > thr + tol * g) { r } else { 0.0 }
        };
        for i in 0..n {
            let (iu, id) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dy = (id - iu).max(1) as f32;
            let row = &frame[i * n..(i + 1) * n];
            let (above, below) = (&frame[iu * n..(iu + 1) * n], &frame[id * n..(id + 1) * n]);
            let residual = &self.residual[i * n..(i + 1) * n];
            let mask = &mut self.mask[i * n..(i + 1) * n];
            // the border columns: one-sided differences (or none in a one-pixel frame)
            for j in [0, n - 1] {
                let (jl, jr) = (j.saturating_sub(1), (j + 1).min(n - 1));
                let gx = (row[jr] - row[jl]) / (jr - jl).max(1) as f32;
                mask[j] = mark(residual[j].abs(), gx, (below[j] - above[j]) / dy);
            }
            // the inner columns, without branches (vectorised)
            if n > 2 {
                let inner = mask[1..n - 1].iter_mut().zip(&residual[1..n - 1]).zip(row.windows(3));
                for (((m, &r), w), (&a, &b)) in inner.zip(above[1..n - 1].iter().zip(&below[1..n - 1])) {
                    *m = mark(r.abs(), (w[2] - w[0]) / 2.0, (b - a) / dy);
                }
            }
        }
    }

    /// Groups changed pixels into [`Blob`]s: the regions whose pixels lie at most `link_px` apart
    /// (Chebyshev), in the raster order of their first pixels, those of fewer than `min_pixels`
    /// pixels, wider than [`MAX_BAND_ASPECT`] times their height or cut by two adjacent image borders
    /// (`Blob::measurable`) left out.
    ///
    /// Works on runs of consecutive changed pixels in a row rather than on pixels: two runs belong
    /// to one region when they lie at most `link_px` rows apart and their columns, widened by
    /// `link_px` each side, overlap (a union-find over runs). On a textured scene most changed
    /// pixels lie in long runs, so this visits each pixel once instead of scanning each one's
    /// neighbourhood. The regions equal those of a flood fill over the same neighbourhood (unit
    /// test `runs_group_like_a_flood_fill`), and so are a region's sums, added in another order:
    /// each term is an `f32` residual times a pixel index, an exact `f64` product and a multiple
    /// of the threshold's last bit, and their sums stay exact while they are below 2⁵³ such bits
    /// (at the default threshold 0.06, for frames up to 256²; at smaller thresholds and larger
    /// frames they may differ from the fill's in the last bits).
    fn group(&mut self, n: usize, min_pixels: usize) {
        let link = self.config.link_px;
        let mask = &self.mask[..n * n];
        let Grouping { runs, row_start, parent, slot, found } = &mut self.grouping;
        runs.clear();
        row_start.clear();
        for (i, row) in mask.chunks_exact(n).enumerate() {
            row_start.push(runs.len());
            let mut j = 0;
            while j < n {
                if row[j] == 0.0 {
                    j += 1;
                    continue;
                }
                let j0 = j;
                while j < n && row[j] != 0.0 {
                    j += 1;
                }
                runs.push(Run { i, j0, j1: j - 1 });
            }
        }
        row_start.push(runs.len());
        parent.clear();
        parent.extend(0..runs.len() as u32);
        for i in 0..n {
            let here = row_start[i]..row_start[i + 1];
            // the same row: neighbouring runs at most `link` apart
            for r in here.start + 1..here.end {
                if runs[r].j0 - runs[r - 1].j1 <= link {
                    union(parent, r - 1, r);
                }
            }
            // the `link` rows above: runs whose widened columns overlap
            for above in i.saturating_sub(link)..i {
                let (mut k, end) = (row_start[above], row_start[above + 1]);
                for r in here.clone() {
                    let Run { j0, j1, .. } = runs[r];
                    while k < end && runs[k].j1 + link < j0 {
                        k += 1;
                    }
                    let mut q = k;
                    while q < end && runs[q].j0 <= j1 + link {
                        union(parent, q, r);
                        q += 1;
                    }
                }
            }
        }
        // each region's sums, regions numbered in the order of their first runs
        slot.clear();
        slot.resize(runs.len(), u32::MAX);
        found.clear();
        for (r, &Run { i, j0, j1 }) in runs.iter().enumerate() {
            let root = find(parent, r);
            if slot[root] == u32::MAX {
                slot[root] = found.len() as u32;
                found.push(Blob {
                    pixels: 0,
                    mass: 0.0,
                    sum_i: 0.0,
                    sum_j: 0.0,
                    bbox: [i, i, j0, j1],
                    current: false,
                });
            }
            let blob = &mut found[slot[root] as usize];
            blob.pixels += j1 - j0 + 1;
            for (j, &m) in (j0..=j1).zip(&mask[i * n + j0..=i * n + j1]) {
                let m = f64::from(m);
                blob.mass += m;
                blob.sum_i += m * i as f64;
                blob.sum_j += m * j as f64;
            }
            blob.bbox = [blob.bbox[0].min(i), blob.bbox[1].max(i), blob.bbox[2].min(j0), blob.bbox[3].max(j1)];
        }
        self.blobs.clear();
        self.blobs.extend(found.iter().filter(|b| {
            let (height, width) = (b.bbox[1] - b.bbox[0] + 1, b.bbox[3] - b.bbox[2] + 1);
            b.pixels >= min_pixels && width <= MAX_BAND_ASPECT * height && b.measurable(n)
        }));
    }

    /// Chooses the tracked object among this frame's blobs (see the module docs, step 3): with a
    /// track, the heaviest region overlapping its grown box (None when none does), joined by the
    /// regions touching it and, for a moving camera, by every region overlapping that box; without
    /// one, the heaviest region.
    fn choose(&self) -> Option<Blob> {
        let by_mass = |a: &&Blob, b: &&Blob| a.mass.total_cmp(&b.mass);
        let grown = self.track.as_ref().map(|t| {
            let [i0, i1, j0, j1] = t.bbox;
            (t.bbox, ((i1 - i0).max(j1 - j0) / 4).max(self.config.link_px))
        });
        let mut chosen = *match grown {
            Some((bbox, margin)) => self.blobs.iter().filter(|b| b.overlaps(bbox, margin)).max_by(by_mass)?,
            None => self.blobs.iter().max_by(by_mass)?,
        };
        let first = chosen;
        let joins_track = |b: &Blob| self.moving && grown.is_some_and(|(bbox, margin)| b.overlaps(bbox, margin));
        for b in &self.blobs {
            if b.bbox != first.bbox && (b.overlaps(chosen.bbox, self.config.link_px) || joins_track(b)) {
                chosen.merge(b);
            }
        }
        Some(chosen)
    }

    /// Whether region `b` passes the track's validation gate (module docs, step 3): its box's size
    /// (the square root of its area) within `size_gate_ratio` of the size predicted for this frame,
    /// give or take [`GATE_SLACK_PX`], once the track holds [`GATE_MIN_SAMPLES`] measurements
    /// (always, without a track). The prediction is the least-squares line through the measured
    /// boxes' sizes with the short memory of difference boxes (`fit_frames` /
    /// [`DIFFERENCE_MEMORY_DIVISOR`]): what the regions have been, not the fitted object box (a
    /// difference box's is cut to where the object is now).
    fn passes_gate(&self, b: &Blob) -> bool {
        if self.track.is_none() || self.samples.len() < GATE_MIN_SAMPLES {
            return true;
        }
        let memory = self.config.fit_frames as f64 / DIFFERENCE_MEMORY_DIVISOR;
        let lines = Lines::fit(&self.samples, self.clock as f64, memory, |s| {
            [(s.width * s.height).sqrt() / s.inverse_size, 0.0, 0.0, 0.0, 0.0]
        });
        let predicted = lines.at(0).max(1.0);
        let [i0, i1, j0, j1] = b.bbox;
        let measured = (((i1 - i0 + 1) * (j1 - j0 + 1)) as f64).sqrt();
        let g = self.config.size_gate_ratio;
        measured <= g * predicted + GATE_SLACK_PX && measured >= predicted / g - GATE_SLACK_PX
    }

    /// The measurement of a region: its box, and — for the object's current image that fills its
    /// box like a solid shape (at least [`MIN_SOLID_FILL`] of it) — the square root of its area as
    /// its size and its centroid as its centre: whole-pixel edges jump by a pixel at a time, while
    /// the area of a growing object grows by one pixel at a time.
    fn measure(&self, b: &Blob, n: usize) -> BoxSample {
        let [i0, i1, j0, j1] = b.bbox;
        let (h, w) = ((i1 - i0 + 1) as f64, (j1 - j0 + 1) as f64);
        let area = b.pixels as f64;
        let c = n as f64 / 2.0;
        let k = self.clock as f64;
        if !b.current || area < MIN_SOLID_FILL * w * h || b.mass <= 0.0 {
            return BoxSample::of(k, (w * h).sqrt(), [(i0 + i1 + 1) as f64 / 2.0 - c, (j0 + j1 + 1) as f64 / 2.0 - c], w, h, false);
        }
        let centroid = [b.sum_i / b.mass + 0.5 - c, b.sum_j / b.mass + 0.5 - c];
        let range = self.size_range(b, n);
        // a disc's size: the middle of the range its pixels allow
        let size = range.map_or(area.sqrt(), |[lo, hi]| (lo + hi) / 2.0);
        // and its box: a disc's diameter, `2/√π` times its size (its pixels' box is whole pixels
        // wide and high, which as a ratio to the size swings by a pixel over the size's steps)
        let (w, h) = match range {
            Some(_) => (size * 2.0 / std::f64::consts::PI.sqrt(), size * 2.0 / std::f64::consts::PI.sqrt()),
            None => (w, h),
        };
        let mut sample = BoxSample::of(k, size, centroid, w, h, true);
        if let Some([lo, hi]) = range {
            sample.inverse_range = [1.0 / hi.max(1e-3), 1.0 / lo.max(1e-3)];
        }
        sample
    }

    /// The sizes a region of the object's current image allows, `[low, high]` (pixels, the
    /// square root of an area like the measured size), when it is a disc's image; None for other
    /// shapes, regions of more than [`MAX_DISC_EDGE_PIXELS`] edge pixels (their area is accurate)
    /// and regions touching the image border (the object may be cut). The renderer marks a pixel
    /// as the object's when its centre is inside the object, so a disc of radius `r` centred at
    /// `c` holds every marked pixel centre and none of the unmarked ones around them. Over the
    /// centres `c` within [`DISC_CENTRE_SEARCH_PX`] of the region's centroid (a grid of
    /// [`DISC_CENTRE_STEP_PX`]) for which such a radius exists, `r` lies between the smallest
    /// distance to the farthest marked centre and the largest distance to the nearest unmarked
    /// one; the size is `√π · r`. A small disc's pixel count changes in steps of several pixels at
    /// once (a disc centred on a pixel corner gains 4 or 8 at a time), and its centroid is off
    /// its centre by a fraction of a pixel; the range holds the true size whatever the step.
    fn size_range(&self, b: &Blob, n: usize) -> Option<[f64; 2]> {
        let [i0, i1, j0, j1] = b.bbox;
        if i0 == 0 || j0 == 0 || i1 + 1 >= n || j1 + 1 >= n {
            return None;
        }
        let marked = |i: usize, j: usize| self.mask[i * n + j] != 0.0;
        let (mut count, mut sum_i, mut sum_j) = (0.0, 0.0, 0.0);
        // edge pixels: marked ones with an unmarked 4-neighbour, unmarked ones with a marked
        // 8-neighbour (the farthest marked and the nearest unmarked centres are among them)
        let (mut inside, mut outside) = (Vec::new(), Vec::new());
        for i in i0 - 1..=i1 + 1 {
            for j in j0 - 1..=j1 + 1 {
                if marked(i, j) {
                    count += 1.0;
                    sum_i += i as f64;
                    sum_j += j as f64;
                    if !(marked(i - 1, j) && marked(i + 1, j) && marked(i, j - 1) && marked(i, j + 1)) {
                        inside.push([i as f64, j as f64]);
                    }
                } else if (i.saturating_sub(1)..=(i + 1).min(n - 1))
                    .any(|a| (j.saturating_sub(1)..=(j + 1).min(n - 1)).any(|c| marked(a, c)))
                {
                    outside.push([i as f64, j as f64]);
                }
                if inside.len() + outside.len() > MAX_DISC_EDGE_PIXELS {
                    return None;
                }
            }
        }
        if count == 0.0 || outside.is_empty() {
            return None;
        }
        let (ci, cj) = (sum_i / count, sum_j / count);
        let steps = (DISC_CENTRE_SEARCH_PX / DISC_CENTRE_STEP_PX).round() as i32;
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for a in -steps..=steps {
            for c in -steps..=steps {
                let (pi, pj) = (ci + f64::from(a) * DISC_CENTRE_STEP_PX, cj + f64::from(c) * DISC_CENTRE_STEP_PX);
                let d2 = |[i, j]: &[f64; 2]| (i - pi).powi(2) + (j - pj).powi(2);
                let far = inside.iter().map(d2).fold(0.0, f64::max);
                let near = outside.iter().map(d2).fold(f64::INFINITY, f64::min);
                if far <= near {
                    low = low.min(far);
                    high = high.max(near);
                }
            }
        }
        (low <= high).then(|| [low.sqrt(), high.sqrt()].map(|r| r * std::f64::consts::PI.sqrt()))
    }

    /// A standing camera's object region `blob` without the background it uncovered: the model
    /// may hold the object where it was (an object in view from the first frame, or one that stood
    /// still for a while). With `b` the median of the model just outside the region's box, a
    /// changed pixel shows the object now when the frame differs more from `b` than the model
    /// does; otherwise it shows background again: the model takes its current value and it leaves
    /// the region.
    fn refine_standing(&mut self, frame: &[f32], n: usize, blob: Blob, starting: bool) -> Blob {
        let l = self.config.link_px;
        let [i0, i1, j0, j1] = blob.bbox;
        let (i0, i1, j0, j1) = (i0.saturating_sub(l), (i1 + l).min(n - 1), j0.saturating_sub(l), (j1 + l).min(n - 1));
        let mut ring = Vec::new();
        ring_of(&self.background, n, [i0, i1, j0, j1], &mut ring);
        if ring.is_empty() {
            return blob;
        }
        let mid = ring.len() / 2;
        let b = *ring.select_nth_unstable_by(mid, f32::total_cmp).1;
        let thr = self.config.threshold as f32;
        let (mut i0, mut i1, mut j0, mut j1) = (i0, i1, j0, j1);
        if starting {
            // a new track: the model may hold the object where it stood (an object in view from
            // the first frame). That imprint — the pixels of the model connected to the region
            // that differ from the median `b` around it — takes the value `b` when the model
            // around the imprint is uniform (at least three quarters of the ring around its box
            // within half the threshold of `b`): a uniform background hides nothing behind it.
            self.filled.fill(false);
            self.stack.clear();
            let mut imprint = Vec::new();
            for i in i0..=i1 {
                for j in j0..=j1 {
                    let p = i * n + j;
                    if (self.background[p] - b).abs() > thr {
                        self.filled[p] = true;
                        self.stack.push(p);
                    }
                }
            }
            let limit = n * n / 4;
            let mut bbox = [i0, i1, j0, j1];
            while let Some(p) = self.stack.pop() {
                if imprint.len() > limit {
                    break;
                }
                imprint.push(p);
                let (i, j) = (p / n, p % n);
                bbox = [bbox[0].min(i), bbox[1].max(i), bbox[2].min(j), bbox[3].max(j)];
                let neighbours = [
                    (i > 0).then(|| p - n),
                    (i + 1 < n).then(|| p + n),
                    (j > 0).then(|| p - 1),
                    (j + 1 < n).then(|| p + 1),
                ];
                for q in neighbours.into_iter().flatten() {
                    if !self.filled[q] && (self.background[q] - b).abs() > thr {
                        self.filled[q] = true;
                        self.stack.push(q);
                    }
                }
            }
            ring_of(&self.background, n, bbox, &mut ring);
            let uniform = imprint.len() <= limit
                && !ring.is_empty()
                && ring.iter().filter(|&&v| (v - b).abs() <= thr / 2.0).count() * 4 >= ring.len() * 3;
            if uniform {
                for &p in &imprint {
                    self.background[p] = b;
                    let r = frame[p] - b;
                    self.residual[p] = r;
                    self.mask[p] = if r.abs() > thr { r.abs() } else { 0.0 };
                }
                [i0, i1, j0, j1] = bbox;
            }
        }
        let mut kept: Option<Blob> = None;
        for i in i0..=i1 {
            for j in j0..=j1 {
                let p = i * n + j;
                let m = self.mask[p];
                if m == 0.0 {
                    continue;
                }
                // the object is where the frame, not the model, differs more from the background
                let model = frame[p] - self.residual[p];
                if (frame[p] - b).abs() <= (model - b).abs() {
                    self.background[p] = frame[p];
                    self.mask[p] = 0.0;
                    continue;
                }
                let one = Blob::pixel(i, j, f64::from(m));
                match kept.as_mut() {
                    Some(k) => k.merge(&one),
                    None => kept = Some(one),
                }
            }
        }
        kept.unwrap_or(blob)
    }

    /// A moving camera's object measured by its appearance in `frame` (module docs, step 3): the
    /// surround's luminance `b` is the median of the ring around `bbox` grown by a pixel and an
    /// eighth of its size; the object's luminance `l` is the median of the current values of the
    /// difference region's changed pixels that differ from `b` by more than the threshold (where
    /// the object arrived; kept from earlier frames when the region gives none). The object is
    /// the pixels within the threshold of `l` and beyond it from `b`, inside the box widened side
    /// by side (up to [`APPEARANCE_WIDEN_PX`]) until none lies on its outline. None — the region
    /// is measured as it is — when `l` is within twice the threshold of `b`, the object is not
    /// enclosed, fills less than [`MIN_SOLID_FILL`] of its box, or spans less than
    /// [`APPEARANCE_MIN_SPAN`] of the region.
    fn appearance(&mut self, frame: &[f32], n: usize, bbox: [usize; 4], region: Option<&Blob>) -> Option<Blob> {
        let [i0, i1, j0, j1] = bbox;
        if i0 == 0 || j0 == 0 || i1 + 1 >= n || j1 + 1 >= n {
            return None;
        }
        let m = 1 + (i1 - i0).max(j1 - j0) / 8;
        // the grown box keeps a ring inside the image
        let (mut gi0, mut gi1, mut gj0, mut gj1) =
            (i0.saturating_sub(m).max(1), (i1 + m).min(n - 2), j0.saturating_sub(m).max(1), (j1 + m).min(n - 2));
        let mut ring = Vec::new();
        ring_of(frame, n, [gi0, gi1, gj0, gj1], &mut ring);
        let mid = ring.len() / 2;
        let b = *ring.select_nth_unstable_by(mid, f32::total_cmp).1;
        let thr = self.config.threshold as f32;
        if let Some(r) = region {
            let [ri0, ri1, rj0, rj1] = r.bbox;
            let mut arrived: Vec<f32> = (ri0..=ri1)
                .flat_map(|i| (rj0..=rj1).map(move |j| i * n + j))
                .filter(|&p| self.mask[p] != 0.0 && (frame[p] - b).abs() > thr)
                .map(|p| frame[p])
                .collect();
            if !arrived.is_empty() {
                let mid = arrived.len() / 2;
                self.object_luminance = Some(*arrived.select_nth_unstable_by(mid, f32::total_cmp).1);
            }
        }
        let l = self.object_luminance?;
        if (l - b).abs() <= 2.0 * thr {
            return None;
        }
        let is_object = |v: f32| (v - b).abs() > thr && (v - l).abs() <= thr;
        let mut enclosed = false;
        for _ in 0..=APPEARANCE_WIDEN_PX {
            let row = |i: usize| (gj0..=gj1).any(|j| is_object(frame[i * n + j]));
            let col = |j: usize| (gi0..=gi1).any(|i| is_object(frame[i * n + j]));
            let sides = [row(gi0), row(gi1), col(gj0), col(gj1)];
            if !sides.contains(&true) {
                enclosed = true;
                break;
            }
            if gi0 == 0 || gj0 == 0 || gi1 + 1 >= n || gj1 + 1 >= n {
                break;
            }
            gi0 -= usize::from(sides[0]);
            gi1 += usize::from(sides[1]);
            gj0 -= usize::from(sides[2]);
            gj1 += usize::from(sides[3]);
        }
        if !enclosed {
            return None;
        }
        let mut kept: Option<Blob> = None;
        for i in gi0..=gi1 {
            for j in gj0..=gj1 {
                let v = frame[i * n + j];
                if !is_object(v) {
                    continue;
                }
                let one = Blob::pixel(i, j, f64::from((v - b).abs()));
                match kept.as_mut() {
                    Some(k) => k.merge(&one),
                    None => kept = Some(one),
                }
            }
        }
        let k = kept.filter(|k| k.pixels >= self.config.standing_min_pixels)?;
        let [ki0, ki1, kj0, kj1] = k.bbox;
        let (kh, kw) = ((ki1 - ki0 + 1) as f64, (kj1 - kj0 + 1) as f64);
        let spans = region.is_none_or(|r| {
            let [ri0, ri1, rj0, rj1] = r.bbox;
            kh >= APPEARANCE_MIN_SPAN * (ri1 - ri0 + 1) as f64 && kw >= APPEARANCE_MIN_SPAN * (rj1 - rj0 + 1) as f64
        });
        if (k.pixels as f64) < MIN_SOLID_FILL * kh * kw || !spans {
            return None;
        }
        // the object's pixels become the mask, which `size_range` reads
        for i in gi0..=gi1 {
            for j in gj0..=gj1 {
                let v = frame[i * n + j];
                self.mask[i * n + j] = if is_object(v) { (v - b).abs() } else { 0.0 };
            }
        }
        Some(k)
    }

    /// Whether the track is reported before `confirm_frames`: a moving camera's track whose last
    /// [`APPEARANCE_CONFIRM_FRAMES`] measurements or more were all of the object's appearance (its
    /// fit starts afresh whenever the kind of measurement changes, so its samples are of one kind).
    fn confirmed_by_appearance(&self) -> bool {
        self.moving
            && self.samples.len() >= APPEARANCE_CONFIRM_FRAMES
            && self.samples.back().is_some_and(|s| s.current)
    }

    /// Moves the standing camera's background model towards `frame`: by `1/background_frames` of
    /// the difference outside the tracked object's box grown by a quarter of its size (at least
    /// `link_px`), [`FROZEN_BACKGROUND_SLOWDOWN`] times less inside it.
    fn update_background(&mut self, frame: &[f32], n: usize) {
        let rate = 1.0 / self.config.background_frames as f32;
        let slow = rate / FROZEN_BACKGROUND_SLOWDOWN;
        let frozen = self.track.as_ref().map(|t| {
            let [i0, i1, j0, j1] = t.bbox;
            let m = ((i1 - i0).max(j1 - j0) / 4).max(self.config.link_px);
            [i0.saturating_sub(m), (i1 + m).min(n - 1), j0.saturating_sub(m), (j1 + m).min(n - 1)]
        });
        for (i, (brow, frow)) in self.background.chunks_exact_mut(n).zip(frame.chunks_exact(n)).enumerate() {
            match frozen {
                Some([i0, i1, j0, j1]) if (i0..=i1).contains(&i) => {
                    for (j, (b, &f)) in brow.iter_mut().zip(frow).enumerate() {
                        let k = if (j0..=j1).contains(&j) { slow } else { rate };
                        *b += (f - *b) * k;
                    }
                }
                _ => {
                    for (b, &f) in brow.iter_mut().zip(frow) {
                        *b += (f - *b) * rate;
                    }
                }
            }
        }
    }

    fn signals(&self, n: usize) -> Signals {
        // a region from one image border to the opposite one is the scene moving (a drifting wall,
        // the ground), not an object with a size
        let spans_image = |t: &Blob| {
            let [top, bottom, left, right] = t.touches(n);
            (top && bottom) || (left && right)
        };
        let confirmed = self
            .track
            .as_ref()
            .filter(|t| (self.age >= self.config.confirm_frames || self.confirmed_by_appearance()) && !spans_image(t));
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
        let [top, bottom, left, right] = self.edges;
        let (ci, cj) = if t.mass > 0.0 {
            (t.sum_i / t.mass + 0.5, t.sum_j / t.mass + 0.5)
        } else {
            ((i0 + i1 + 1) as f64 / 2.0, (j0 + j1 + 1) as f64 / 2.0)
        };
        let region = ImageRegion {
            centroid: [x_of(cj), y_of(ci)],
            x: [x_of(left), x_of(right.max(left))],
            y: [y_of(bottom.max(top)), y_of(top)],
            track: Some(self.tracks),
        };
        let [w, h] = region.angular_size_deg(self.config.fov_deg);
        // an image border cuts the object: only the extent along it measures the object's size
        let [cut_top, cut_bottom, cut_left, cut_right] = t.touches(n);
        let theta = match (cut_left || cut_right, cut_top || cut_bottom) {
            (true, false) => h,
            (false, true) => w,
            _ => w.max(h),
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
        self.missed = 0;
        self.age = 0;
        self.background.clear();
        self.moving = false;
        self.object_luminance = None;
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
        let chosen = self.choose();
        if chosen.is_some() && self.track.is_none() {
            // a new track: another number, and its object's luminance is not known yet
            self.tracks += 1;
            self.object_luminance = None;
        }
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
                }
                if self.samples.len() >= FIT_SPAN * self.config.fit_frames {
                    self.samples.pop_front();
                }
                let measured = self.measure(&b, n);
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
        if self.track.is_some() {
            self.edges = fit_box(
                &self.samples,
                self.clock,
                self.config.fit_frames as f64,
                n,
                // only the compensated difference (a moving camera) spans baseline_frames: a
                // standing camera's residual is the object's image now
                if self.moving { self.config.baseline_frames as f64 } else { 0.0 },
            );
            self.clock += 1;
        }
        if standing {
            self.update_background(frame.data(), n);
        }
        Ok(self.signals(n))
    }
}

impl DetectorConfig for TrackerConfig {
    fov_from_camera!();

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

#[cfg(test)]
mod tests {
    use super::*;

    /// The difference boxes (the union of the object's image now and `baseline` frames ago) of a
    /// square image `[top, bottom, left, right]` at frame `k` given by `at(k)`.
    fn union_samples(frames: usize, baseline: usize, at: impl Fn(f64) -> [f64; 4]) -> std::collections::VecDeque<BoxSample> {
        (baseline..frames)
            .map(|k| {
                let (now, then) = (at(k as f64), at((k - baseline) as f64));
                let [t, b, l, r] = [now[0].min(then[0]), now[1].max(then[1]), now[2].min(then[2]), now[3].max(then[3])];
                let (h, w) = (b - t, r - l);
                BoxSample::of(k as f64, (w * h).sqrt(), [(t + b) / 2.0 - 48.0, (l + r) / 2.0 - 48.0], w, h, false)
            })
            .collect()
    }

    #[test]
    fn a_difference_box_is_cut_to_where_the_object_is_now() {
        let (frames, baseline) = (60, 8);
        let k = frames - 1;
        // an 8-pixel image moving right by 0.5 px per frame: its union box is 4 pixels too wide
        let moving = |k: f64| [40.0, 48.0, 20.0 + 0.5 * k, 28.0 + 0.5 * k];
        let got = fit_difference_box(&union_samples(frames, baseline, moving), k, 7.5, 96, baseline as f64);
        let want = moving(k as f64);
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{got:?} vs {want:?}");
        }
        // without the cut the left edge would be where the object was 8 frames ago
        let uncut = fit_difference_box(&union_samples(frames, baseline, moving), k, 7.5, 96, 0.0);
        assert!((uncut[2] - (want[2] - 4.0)).abs() < 1e-6, "{uncut:?}");
        // an image growing about a fixed centre: its union box is its image now, left as it is
        let growing = |k: f64| [40.0 - 0.1 * k, 48.0 + 0.1 * k, 20.0 - 0.1 * k, 28.0 + 0.1 * k];
        let got = fit_difference_box(&union_samples(frames, baseline, growing), k, 7.5, 96, baseline as f64);
        let uncut = fit_difference_box(&union_samples(frames, baseline, growing), k, 7.5, 96, 0.0);
        assert_eq!(got, uncut);
    }

    /// The grouping as first written (the reference [`Tracker::group`] is checked against): a
    /// flood fill from each unlabelled changed pixel in raster order over the `link`-neighbourhood.
    fn flood_fill(mask: &[f32], n: usize, link: usize, min_pixels: usize) -> Vec<Blob> {
        let mut blobs = Vec::new();
        let mut label = vec![false; n * n];
        let mut stack = Vec::new();
        for start in 0..n * n {
            if mask[start] == 0.0 || label[start] {
                continue;
            }
            let (si, sj) = (start / n, start % n);
            let mut blob = Blob { pixels: 0, mass: 0.0, sum_i: 0.0, sum_j: 0.0, bbox: [si, si, sj, sj], current: false };
            label[start] = true;
            stack.push(start);
            while let Some(p) = stack.pop() {
                let (i, j) = (p / n, p % n);
                let m = f64::from(mask[p]);
                blob.pixels += 1;
                blob.mass += m;
                blob.sum_i += m * i as f64;
                blob.sum_j += m * j as f64;
                blob.bbox = [blob.bbox[0].min(i), blob.bbox[1].max(i), blob.bbox[2].min(j), blob.bbox[3].max(j)];
                for ii in i.saturating_sub(link)..=(i + link).min(n - 1) {
                    for jj in j.saturating_sub(link)..=(j + link).min(n - 1) {
                        let q = ii * n + jj;
                        if mask[q] != 0.0 && !label[q] {
                            label[q] = true;
                            stack.push(q);
                        }
                    }
                }
            }
            let (height, width) = (blob.bbox[1] - blob.bbox[0] + 1, blob.bbox[3] - blob.bbox[2] + 1);
            if blob.pixels >= min_pixels && width <= MAX_BAND_ASPECT * height && blob.measurable(n) {
                blobs.push(blob);
            }
        }
        blobs
    }

    /// The segmentation as first written (a branch per pixel), the reference of
    /// [`Tracker::segment`].
    fn segment_per_pixel(frame: &[f32], residual: &[f32], n: usize, thr: f32, tol: f32) -> Vec<f32> {
        let mut mask = vec![0.0; n * n];
        for i in 0..n {
            let (iu, id) = (i.saturating_sub(1), (i + 1).min(n - 1));
            for j in 0..n {
                let r = residual[i * n + j].abs();
                if r <= thr {
                    continue;
                }
                let (jl, jr) = (j.saturating_sub(1), (j + 1).min(n - 1));
                let gx = (frame[i * n + jr] - frame[i * n + jl]) / (jr - jl).max(1) as f32;
                let gy = (frame[id * n + j] - frame[iu * n + j]) / (id - iu).max(1) as f32;
                let g = gx.abs().max(gy.abs());
                mask[i * n + j] = if r > thr + tol * g { r } else { 0.0 };
            }
        }
        mask
    }

    #[test]
    fn segment_gives_the_bits_of_the_per_pixel_version() {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut changed = 0;
        for (case, n) in [1, 2, 3, 17, 96].into_iter().enumerate() {
            for tolerance_px in [0.0, 0.5, 3.0] {
                let mut frame: Vec<f32> = (0..n * n).map(|_| next()).collect();
                let mut residual: Vec<f32> = (0..n * n).map(|_| (next() - 0.5) * 0.4).collect();
                // NaN pixels in the frame and the residual take the same path
                if n > 2 {
                    frame[n + 1] = f32::NAN;
                    residual[case] = f32::NAN;
                }
                let mut tracker = Tracker::new(TrackerConfig::default()).expect("valid");
                tracker.residual = residual.clone();
                tracker.mask = vec![1.0; n * n];
                tracker.segment(&frame, n, tolerance_px);
                let want = segment_per_pixel(&frame, &residual, n, 0.06, tolerance_px as f32);
                for (k, (a, b)) in tracker.mask.iter().zip(&want).enumerate() {
                    assert_eq!(a.to_bits(), b.to_bits(), "n {n}, tolerance {tolerance_px}, pixel {k}: {a} vs {b}");
                }
                changed += want.iter().filter(|&&m| m != 0.0).count();
            }
        }
        assert!(changed > 1000, "the cases mark changes ({changed})");
    }

    #[test]
    fn runs_group_like_a_flood_fill() {
        // masks of scattered specks, bands and blocks at several densities, values above the
        // default threshold (an LCG: no dependency, the same masks every run)
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) as u32
        };
        let mut regions = 0;
        for case in 0..120 {
            let n = [5, 17, 32, 96][case % 4];
            let link = 1 + case % 4;
            let density = [2, 10, 30, 60][(case / 4) % 4];
            let mut mask = vec![0.0f32; n * n];
            for (p, m) in mask.iter_mut().enumerate() {
                let (i, j) = (p / n, p % n);
                let band = case % 3 == 0 && (i / 3 + j / 5 + case) % 4 == 0;
                if band || next() % 100 < density {
                    *m = 0.06 + (next() % 1000) as f32 / 1000.0;
                }
            }
            let config = TrackerConfig { link_px: link, ..TrackerConfig::default() };
            let mut tracker = Tracker::new(config).expect("valid");
            tracker.mask = mask.clone();
            for min_pixels in [1, 4] {
                tracker.group(n, min_pixels);
                let expected = flood_fill(&mask, n, link, min_pixels);
                assert_eq!(tracker.blobs, expected, "n {n}, link {link}, density {density}%");
                regions += expected.len();
            }
        }
        assert!(regions > 500, "the cases hold regions to compare ({regions})");
    }
}
