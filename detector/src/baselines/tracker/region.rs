//! Segmentation: changed pixels, their runs and the union-find grouping into regions ([`Blob`]).

use super::{MAX_BAND_ASPECT, Tracker};

/// One region of changed pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Blob {
    pub(super) pixels: usize,
    pub(super) mass: f64,
    pub(super) sum_i: f64,
    pub(super) sum_j: f64,
    /// `[i_min, i_max, j_min, j_max]` (inclusive pixel indices).
    pub(super) bbox: [usize; 4],
    /// Whether the region is the object's current image (a standing camera's background
    /// subtraction, [`Tracker::refine_standing`]) rather than a difference of two frames.
    pub(super) current: bool,
}

impl Blob {
    /// The region of the one pixel `(i, j)` weighing `w`, of the object's current image.
    pub(super) fn pixel(i: usize, j: usize, w: f64) -> Self {
        Blob {
            pixels: 1,
            mass: w,
            sum_i: w * i as f64,
            sum_j: w * j as f64,
            bbox: [i, i, j, j],
            current: true,
        }
    }

    pub(super) fn merge(&mut self, o: &Blob) {
        self.pixels += o.pixels;
        self.mass += o.mass;
        self.sum_i += o.sum_i;
        self.sum_j += o.sum_j;
        self.current &= o.current;
        self.bbox = box_union(self.bbox, o.bbox);
    }

    /// Which image borders the region touches in an n × n frame: `[top, bottom, left, right]`.
    pub(super) fn touches(&self, n: usize) -> [bool; 4] {
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

    pub(super) fn overlaps(&self, b: [usize; 4], margin: usize) -> bool {
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
pub(super) struct Grouping {
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
pub(super) fn box_union(a: [usize; 4], b: [usize; 4]) -> [usize; 4] {
    [a[0].min(b[0]), a[1].max(b[1]), a[2].min(b[2]), a[3].max(b[3])]
}

/// Collects into `ring` the values of `image` (n·n) on the pixels just outside `bbox`
/// (`[i0, i1, j0, j1]`, inclusive), inside the image.
pub(super) fn ring_of(image: &[f32], n: usize, [i0, i1, j0, j1]: [usize; 4], ring: &mut Vec<f32>) {
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

impl Tracker {
    /// Marks changed pixels (`mask` = |residual| where changed, else 0): a residual above the
    /// threshold, and above it by more than `tolerance_px` times the frame's local gradient (the
    /// larger of its central differences, one-sided at the border), is a change.
    pub(super) fn segment(&mut self, frame: &[f32], n: usize, tolerance_px: f64) {
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
    pub(super) fn group(&mut self, n: usize, min_pixels: usize) {
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
}

#[cfg(test)]
mod tests {
    use super::super::TrackerConfig;
    use super::*;

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
