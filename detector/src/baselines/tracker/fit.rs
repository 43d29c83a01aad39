//! The tracked box's fit: its measurements ([`BoxSample`]) and their fading-memory lines.

use super::{AREA_WEIGHT, DIFFERENCE_MEMORY_DIVISOR};

/// One frame's measurement of the tracked object, as the quantities that change linearly in time
/// for an object moving at a constant velocity: with its size `s` (pixels: the square root of its
/// area, or of its box's) and its centre `(cx, cy)` relative to the image centre, `1/s` (∝ the
/// object's depth) and `cx/s`, `cy/s` (∝ its lateral and vertical offsets); its box's shape
/// `width/s`, `height/s` (constant for a rigid object).
#[derive(Debug, Clone, Copy)]
pub(super) struct BoxSample {
    /// Frames since the track started.
    pub(super) k: f64,
    pub(super) inverse_size: f64,
    /// The range `[low, high]` of `1/s` that the region's pixels allow (see
    /// `Tracker::size_range`); `[1/s, 1/s]` when they give none: the measurement itself.
    pub(super) inverse_range: [f64; 2],
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) width: f64,
    pub(super) height: f64,
    /// Whether it measured the object's current image (else a difference of two frames).
    pub(super) current: bool,
}

impl BoxSample {
    /// The sample of frame `k` of a box of size `size`, centre `[row, column]` relative to the
    /// image centre, width `w` and height `h` (pixels).
    pub(super) fn of(k: f64, size: f64, [ci, cj]: [f64; 2], w: f64, h: f64, current: bool) -> Self {
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
pub(super) fn fit_box(samples: &std::collections::VecDeque<BoxSample>, k: usize, memory: f64, n: usize, baseline: f64) -> [f64; 4] {
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
pub(super) struct Lines {
    now: f64,
    mean_k: f64,
    mean: [f64; 5],
    /// Slopes (per frame; 0 when the samples span a single frame).
    slope: [f64; 5],
}

impl Lines {
    pub(super) fn fit(
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
    pub(super) fn at(&self, q: usize) -> f64 {
        self.mean[q] + self.slope[q] * (self.now - self.mean_k)
    }
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
}
