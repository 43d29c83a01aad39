//! The measurement of a region: its size (the disc fit's size range) and the object's appearance.

use super::fit::BoxSample;
use super::region::{Blob, ring_of};
use super::{
    APPEARANCE_MIN_SPAN, APPEARANCE_WIDEN_PX, DISC_CENTRE_SEARCH_PX, DISC_CENTRE_STEP_PX, MAX_DISC_EDGE_PIXELS,
    MIN_SOLID_FILL, Tracker,
};

impl Tracker {
    /// The measurement of a region: its box, and — for the object's current image that fills its
    /// box like a solid shape (at least [`MIN_SOLID_FILL`] of it) — the square root of its area as
    /// its size and its centroid as its centre: whole-pixel edges jump by a pixel at a time, while
    /// the area of a growing object grows by one pixel at a time.
    pub(super) fn measure(&self, b: &Blob, n: usize) -> BoxSample {
        self.measure_at(b, n, self.clock, |p| self.mask[p] != 0.0)
    }

    /// [`Self::measure`] at frame `clock` of a track's fit, a pixel `p` (`i·n + j`) being the
    /// region's when `marked(p)` (the changed pixels: `mask` ≠ 0, for the primary track).
    pub(super) fn measure_at(&self, b: &Blob, n: usize, clock: usize, marked: impl Fn(usize) -> bool) -> BoxSample {
        let [i0, i1, j0, j1] = b.bbox;
        let (h, w) = ((i1 - i0 + 1) as f64, (j1 - j0 + 1) as f64);
        let area = b.pixels as f64;
        let c = n as f64 / 2.0;
        let k = clock as f64;
        if !b.current || area < MIN_SOLID_FILL * w * h || b.mass <= 0.0 {
            return BoxSample::of(k, (w * h).sqrt(), [(i0 + i1 + 1) as f64 / 2.0 - c, (j0 + j1 + 1) as f64 / 2.0 - c], w, h, false);
        }
        let centroid = [b.sum_i / b.mass + 0.5 - c, b.sum_j / b.mass + 0.5 - c];
        let range = Self::size_range(b, n, marked);
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
    fn size_range(b: &Blob, n: usize, marked: impl Fn(usize) -> bool) -> Option<[f64; 2]> {
        let [i0, i1, j0, j1] = b.bbox;
        if i0 == 0 || j0 == 0 || i1 + 1 >= n || j1 + 1 >= n {
            return None;
        }
        // a neighbour outside the image (i − 1 or j − 1 of the border, wrapped) is not marked
        let marked = |i: usize, j: usize| i < n && j < n && marked(i * n + j);
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
                    let (up, left) = (i.wrapping_sub(1), j.wrapping_sub(1));
                    if !(marked(up, j) && marked(i + 1, j) && marked(i, left) && marked(i, j + 1)) {
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
    pub(super) fn appearance(&mut self, frame: &[f32], n: usize, bbox: [usize; 4], region: Option<&Blob>) -> Option<Blob> {
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
}
