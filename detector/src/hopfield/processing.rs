//! Video frame processing (paper §2.2.1, eq. 3–4) and image-to-vector conversion (§2.2.2).
//!
//! F(t) = R_oi ⊙ [F̃(t) ∗ S_odd]: the frame is convolved with the horizontal-edge kernel
//! S_odd (a true convolution, i.e. the kernel flipped: the result is positive where luminance
//! increases downwards) and multiplied pixel-wise with the region-of-interest mask. The vector
//! ξ(t) is F(t) with its mean subtracted, divided by its Euclidean norm.
//!
//! Decisions where the paper is silent:
//! - Convolution border: [`FrameBorder`] (default replicate, so a uniform frame has no edges).
//! - Mask geometry: pixel (i, j) has its centre at (j + ½, i + ½); the mask disk is centred at
//!   (n/2, n/2) and contains the pixel centres within radius ρ = `radius_frac`·n/2; the blur is
//!   a normalised Gaussian truncated at ⌈4σ⌉ pixels, applied to the disk drawn on an infinite
//!   black plane (so pixels near the border see the true disk, not a padded one).
//! - A processed frame whose centred norm is ≤ [`MIN_QUERY_NORM`] (a blank or constant frame,
//!   no edges inside the mask) carries no evidence: normalising it would divide zero by zero.
//!   Both implementations then report the delayed column as retrieved (ẑ = 1, the floor), its
//!   query is the zero vector, and it is *not* stored as a delayed memory column: the memory
//!   keeps the queries of the last `delay` frames with evidence, so a dropped (black,
//!   saturated or uniform) frame neither wins nor loses against anything `delay` frames later
//!   (see `hopfield/mod.rs`).
//!
//! # Adapted front end
//! With `front_end = "adapted"` the query is built from G(t) = F(t) − M(t−1) instead of F(t),
//! where M is a per-pixel running mean of the processed frames, M(t) = M(t−1) + w·G(t),
//! w = [`HopfieldConfig::adaptation_weight`]. Processing (convolution, border padding and
//! mask) is linear and the same every frame, so high-passing the processed frame is the same
//! as processing the high-passed camera image; doing it after the convolution lets the camera
//! frame's own edges decide whether it is blank:
//! - a camera frame whose F(t) has no edges (‖F‖ ≤ [`MIN_QUERY_NORM`]: black, saturated
//!   or uniform, e.g. a dropped frame) is skipped entirely — no activity, nothing stored, and M
//!   is not updated (otherwise the frame would come out as the negative of the whole scene);
//! - M starts as the first non-blank F, so the first high-passed frame is exactly zero;
//! - a G(t) with no structure (a static scene: exactly zero) is blank as well: no activity and
//!   not stored, but M is updated. A static scene therefore never leaves the rest state.
//!
//! - Element order of the vectors: the paper maps V_ij to v_{i+(j−1)n} (column-major); the
//!   reference implementation does exactly that, the fast one uses row-major order. Every
//!   quantity the detector uses is a dot product between vectors with the same ordering, so
//!   the results are identical.

#[cfg(doc)]
use super::config::HopfieldConfig;
use super::config::{FrameBorder, MaskConfig};
use crate::memo::Memo;
use std::sync::Arc;

/// The modified Sobel–Feldman kernel S_odd of eq. 3 (rows top to bottom).
pub const S_ODD: [[f64; 3]; 3] = [
    [3.0 / 16.0, 10.0 / 16.0, 3.0 / 16.0],
    [0.0, 0.0, 0.0],
    [-3.0 / 16.0, -10.0 / 16.0, -3.0 / 16.0],
];

/// A processed frame with a centred Euclidean norm at or below this (in luminance units) is
/// treated as blank ("no evidence"). Real 8-bit content has steps of 1/255, giving norms
/// above 1e-4, so this only catches frames without edges and floating-point noise.
pub const MIN_QUERY_NORM: f64 = 1e-6;

/// Reads a frame pixel as f64, guarding against non-finite values (frames constructed through
/// [`crate::Frame`] never hold them; a NaN would otherwise poison every dot product).
#[inline]
pub(crate) fn pixel(v: f32) -> f64 {
    if v.is_finite() { v as f64 } else { 0.0 }
}

/// The region-of-interest mask R_oi as an n×n row-major image; all ones for `None`. The blur
/// is [`MaskConfig::blur_sigma_for`] pixels (absolute, or proportional to n).
pub fn roi_mask(n: usize, mask: Option<&MaskConfig>) -> Vec<f64> {
    let Some(m) = mask else {
        return vec![1.0; n * n];
    };
    let rho = m.radius_frac * n as f64 / 2.0;
    let centre = n as f64 / 2.0;
    let sigma = m.blur_sigma_for(n);
    let k = if sigma > 0.0 { (4.0 * sigma).ceil() as usize } else { 0 };
    // Gaussian weights, normalised.
    let mut w: Vec<f64> = (0..=2 * k)
        .map(|i| {
            let x = i as f64 - k as f64;
            if sigma > 0.0 {
                (-x * x / (2.0 * sigma * sigma)).exp()
            } else {
                1.0
            }
        })
        .collect();
    let sum: f64 = w.iter().sum();
    w.iter_mut().for_each(|v| *v /= sum);
    // The disk on an (n + 2k)² canvas, then separable blur, then crop.
    let m_ext = n + 2 * k;
    let disk = |i: usize, j: usize| -> f64 {
        let y = i as f64 - k as f64 + 0.5 - centre;
        let x = j as f64 - k as f64 + 0.5 - centre;
        if x * x + y * y <= rho * rho { 1.0 } else { 0.0 }
    };
    // Horizontal pass on the extended rows, kept only for the n output columns.
    let mut horiz = vec![0.0; m_ext * n];
    for i in 0..m_ext {
        for j in 0..n {
            let mut acc = 0.0;
            for (t, wt) in w.iter().enumerate() {
                acc += wt * disk(i, j + t);
            }
            horiz[i * n + j] = acc;
        }
    }
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let mut acc = 0.0;
            for (t, wt) in w.iter().enumerate() {
                acc += wt * horiz[(i + t) * n + j];
            }
            out[i * n + j] = acc;
        }
    }
    out
}

/// Literal eq. 4 without the mask: the true 2-D convolution F̃ ∗ S_odd, "same" size, with the
/// given border padding. Row-major n×n in, row-major out. Used by the reference implementation.
pub fn convolve_s_odd(frame: &[f32], n: usize, border: FrameBorder) -> Vec<f64> {
    let at = |i: isize, j: isize| -> f64 {
        let inside = (0..n as isize).contains(&i) && (0..n as isize).contains(&j);
        match border {
            FrameBorder::Zero if !inside => 0.0,
            _ => {
                let ii = i.clamp(0, n as isize - 1) as usize;
                let jj = j.clamp(0, n as isize - 1) as usize;
                pixel(frame[ii * n + jj])
            }
        }
    };
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let mut acc = 0.0;
            // (F ∗ S)[i, j] = Σ_{a,b} S[a][b] · F[i − (a − 1), j − (b − 1)]
            for (a, row) in S_ODD.iter().enumerate() {
                for (b, s) in row.iter().enumerate() {
                    acc += s * at(i as isize + 1 - a as isize, j as isize + 1 - b as isize);
                }
            }
            out[i * n + j] = acc;
        }
    }
    out
}

/// Subtracts the mean and divides by the Euclidean norm in place (§2.2.2, properties 2–3).
/// Returns the centred norm; if it is ≤ [`MIN_QUERY_NORM`] the vector is set to zero instead
/// and `None` is returned (the "no evidence" query).
pub fn center_and_normalize(v: &mut [f64]) -> Option<f64> {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    v.iter_mut().for_each(|x| *x -= mean);
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !(norm.is_finite() && norm > MIN_QUERY_NORM) {
        v.iter_mut().for_each(|x| *x = 0.0);
        return None;
    }
    let inv = 1.0 / norm;
    v.iter_mut().for_each(|x| *x *= inv);
    Some(norm)
}

/// Row-major n×n image → the paper's column-major vector (v_{i+(j−1)n} = V_ij).
pub fn image_to_vector(image: &[f64], n: usize) -> Vec<f64> {
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            v[i + j * n] = image[i * n + j];
        }
    }
    v
}

/// The fast path's frame processing: the same F(t) and ξ(t) with reused buffers, in f64.
///
/// The S_odd convolution is computed separably — a [3, 10, 3]/16 horizontal smoothing of each
/// row, then the difference of the smoothed rows below and above — with a rolling buffer of
/// three smoothed rows, fused with the mask and with the sums Σ F and Σ F² needed for the
/// normalisation. Loops are written so that the compiler vectorises them (padded rows,
/// eight independent accumulators for the sums).
#[derive(Debug, Clone)]
pub struct FrameProcessor {
    n: usize,
    border: FrameBorder,
    mask: Arc<Vec<f64>>,
    /// Three smoothed rows (rolling), n each.
    smooth: Vec<f64>,
    /// One frame row in f64 with one padding pixel at each end.
    row: Vec<f64>,
}

/// Number of independent accumulators in the reductions (breaks the add latency chain).
pub(crate) const LANES: usize = 8;

/// Mean and 1/norm of a processed frame F, from Σ F and Σ F² (or two-pass when the one-pass
/// formula would cancel). `None` for a blank frame (centred norm ≤ [`MIN_QUERY_NORM`]).
pub(crate) fn normalisation(f: &[f64], sum: f64, sumsq: f64) -> Option<(f64, f64)> {
    let d = f.len() as f64;
    let mean = sum / d;
    let mut var = sumsq - sum * mean;
    if var.is_nan() || var <= 1e-3 * sumsq {
        // The mean dominates (or the frame is blank): recompute Σ(F − μ)² without cancellation.
        let mut acc = [0.0; LANES];
        let chunks = f.chunks_exact(LANES);
        var = chunks.remainder().iter().map(|v| (v - mean) * (v - mean)).sum();
        for c in chunks {
            for k in 0..LANES {
                let v = c[k] - mean;
                acc[k] += v * v;
            }
        }
        var += acc.iter().sum::<f64>();
    }
    let norm = var.sqrt();
    if norm.is_finite() && norm > MIN_QUERY_NORM {
        Some((mean, 1.0 / norm))
    } else {
        None
    }
}

/// Results of one sweep of [`FrameProcessor::processed`] (`sum`, `sumsq` of F) or
/// [`FrameProcessor::processed_adapted`] (of G, and Σ F² for [`camera_frame_is_blank`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptedSums {
    /// Σ F² of the processed camera frame (adapted sweep only).
    pub raw_sumsq: f64,
    /// Σ G (Σ F for the paper sweep).
    pub sum: f64,
    /// Σ G² (Σ F² for the paper sweep).
    pub sumsq: f64,
}

/// The adapted front end's test for a blank (dropped) camera frame, given Σ F² of its
/// processed frame: ‖F‖ ≤ [`MIN_QUERY_NORM`], no edges inside the mask. A black, saturated or
/// uniform frame gives F ≡ 0 exactly (with the default replicate border). (The paper front
/// end's test uses the centred norm; the two differ only for a constant nonzero F, which
/// needs a luminance ramp and no mask.)
pub fn camera_frame_is_blank(raw_sumsq: f64) -> bool {
    let norm = raw_sumsq.sqrt();
    !(norm.is_finite() && norm > MIN_QUERY_NORM)
}

/// The adapted front end's running-mean update M ← M + w·G.
pub(crate) fn update_running_mean(running_mean: &mut [f64], g: &[f64], weight: f64) {
    for (m, g) in running_mean.iter_mut().zip(g) {
        *m += weight * g;
    }
}

/// Undoes [`update_running_mean`] (M ← M − w·G) after a camera frame turned out blank; exact
/// up to one rounding per pixel, far below [`MIN_QUERY_NORM`].
pub(crate) fn undo_running_mean(running_mean: &mut [f64], g: &[f64], weight: f64) {
    for (m, g) in running_mean.iter_mut().zip(g) {
        *m -= weight * g;
    }
}

/// How many frames a high-pass front end (adapted, compensated) withholds its output after its
/// running mean starts from the first frame: two of the mean's time constants, `−2 / ln(1 − w)`
/// frames for the per-frame weight `w` (rounded; 24 frames, 0.2 s, for τ = 0.1 s at 120 Hz).
///
/// Until then the high-pass is not yet what it will be: started from one frame, the mean has
/// followed the scene for a few frames only, so the high-pass holds a shorter history of the
/// image's changes than it will later, and its structure changes from frame to frame. Queries
/// of that period fill the delayed memory, and the first frame that meets one of them there (the
/// delay later) retrieves a template instead — a one-frame θ̂ of tens of degrees, decaying
/// through the read-out filter, that no object caused. During the warm-up the mean follows the
/// frames as usual and the query is blank: no evidence, nothing stored.
pub fn warm_up_frames(weight: f64) -> usize {
    if !(weight > 0.0 && weight < 1.0) {
        return 0;
    }
    (-2.0 / (-weight).ln_1p()).round() as usize
}

/// The frames of a high-pass front end's warm-up still to come ([`warm_up_frames`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct WarmUp {
    left: usize,
}

impl WarmUp {
    /// A warm-up for a running mean of per-frame weight `weight` that starts now.
    pub fn start(weight: f64) -> Self {
        Self {
            left: warm_up_frames(weight),
        }
    }

    /// Whether this (non-dropped) frame's output is withheld; counts it.
    pub fn withholds(&mut self) -> bool {
        let withheld = self.left > 0;
        self.left = self.left.saturating_sub(1);
        withheld
    }
}

/// The adapted front end's state, shared by both implementations: the running mean M of the
/// processed frames (row-major; empty until the first non-blank frame), its weight and the
/// frames of its warm-up still to come ([`warm_up_frames`]).
#[derive(Debug, Clone)]
pub struct Adaptation {
    /// Update weight w per frame.
    pub weight: f64,
    /// M, row-major n×n, or empty before the first non-blank frame.
    pub running_mean: Vec<f64>,
    /// The warm-up after M started.
    pub warm_up: WarmUp,
}

/// What the adapted front end makes of one processed frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdaptedFrame {
    /// The camera frame itself is blank: skip it (M unchanged).
    Dropped,
    /// A query (possibly blank) was formed from G; M was updated.
    Query,
}

impl Adaptation {
    /// A fresh state with update weight `weight`.
    pub fn new(weight: f64) -> Self {
        Self {
            weight,
            running_mean: Vec::new(),
            warm_up: WarmUp::default(),
        }
    }

    /// Forgets the running mean.
    pub fn reset(&mut self) {
        self.running_mean.clear();
        self.warm_up = WarmUp::default();
    }

    /// Starts M from the processed frame `f` (the first non-blank one), and the warm-up.
    pub fn start(&mut self, f: &[f64]) {
        self.running_mean = f.to_vec();
        self.warm_up = WarmUp::start(self.weight);
    }

    /// The literal high-pass, for the reference implementation: turns the processed frame `f`
    /// (row-major, any order as long as it is the same every frame) into G = F − M in place and
    /// updates M. A blank F is dropped: `f` is left as it is and M is not touched.
    pub fn high_pass(&mut self, f: &mut [f64]) -> AdaptedFrame {
        let sumsq = f.iter().map(|v| v * v).sum::<f64>();
        if camera_frame_is_blank(sumsq) {
            return AdaptedFrame::Dropped;
        }
        if self.running_mean.is_empty() {
            self.start(f);
            f.fill(0.0);
            return AdaptedFrame::Query;
        }
        for (v, m) in f.iter_mut().zip(&self.running_mean) {
            *v -= m;
        }
        update_running_mean(&mut self.running_mean, f, self.weight);
        if self.warm_up.withholds() {
            f.fill(0.0);
        }
        AdaptedFrame::Query
    }
}

impl FrameProcessor {
    /// Builds the processor (the mask is computed once per process for each `n` and mask
    /// configuration, see `crate::memo`).
    pub fn new(n: usize, mask: Option<&MaskConfig>, border: FrameBorder) -> Self {
        static MASKS: Memo<(usize, Option<[u64; 2]>), Vec<f64>> = Memo::new();
        let key = (
            n,
            mask.map(|m| [m.radius_frac.to_bits(), m.blur_sigma_for(n).to_bits()]),
        );
        let Ok(mask) = MASKS.get_or_try_insert(key, || Ok::<_, std::convert::Infallible>(roi_mask(n, mask)));
        Self {
            n,
            border,
            mask,
            smooth: vec![0.0; 3 * n],
            row: vec![0.0; n + 2],
        }
    }

    /// The mask R_oi (row-major).
    pub fn mask(&self) -> &[f64] {
        &self.mask
    }

    /// Smoothed row `i` of the frame into slot `slot` of the rolling buffer.
    #[inline]
    fn smooth_row(&mut self, frame: &[f32], i: usize, slot: usize) {
        const A: f64 = 3.0 / 16.0;
        const B: f64 = 10.0 / 16.0;
        let n = self.n;
        let src = &frame[i * n..(i + 1) * n];
        let row = &mut self.row;
        for (d, &v) in row[1..=n].iter_mut().zip(src) {
            *d = pixel(v);
        }
        let (left, right) = match self.border {
            FrameBorder::Replicate => (row[1], row[n]),
            FrameBorder::Zero => (0.0, 0.0),
        };
        row[0] = left;
        row[n + 1] = right;
        let dst = &mut self.smooth[slot * n..(slot + 1) * n];
        for (j, d) in dst.iter_mut().enumerate() {
            *d = A * (row[j] + row[j + 2]) + B * row[j + 1];
        }
    }

    /// The processed frame F(t) = R_oi ⊙ (F̃ ∗ S_odd) into `out` (row-major), returning
    /// (Σ F, Σ F²).
    pub fn processed(&mut self, frame: &[f32], out: &mut [f64]) -> (f64, f64) {
        let s = self.processed_impl::<false>(frame, out, &mut [], 0.0);
        (s.sum, s.sumsq)
    }

    /// The adapted front end's G(t) = F(t) − M(t−1) into `out` (row-major), the update
    /// M(t) = M(t−1) + `weight`·G(t) of `running_mean`, Σ G, Σ G² and Σ F², in one sweep.
    /// If the camera frame turns out blank the caller undoes the update
    /// (`undo_running_mean`).
    pub fn processed_adapted(
        &mut self,
        frame: &[f32],
        out: &mut [f64],
        running_mean: &mut [f64],
        weight: f64,
    ) -> AdaptedSums {
        assert_eq!(running_mean.len(), self.n * self.n);
        self.processed_impl::<true>(frame, out, running_mean, weight)
    }

    fn processed_impl<const ADAPT: bool>(
        &mut self,
        frame: &[f32],
        out: &mut [f64],
        running_mean: &mut [f64],
        weight: f64,
    ) -> AdaptedSums {
        let n = self.n;
        assert_eq!(frame.len(), n * n);
        assert_eq!(out.len(), n * n);
        // Slots hold smoothed rows i − 1, i, i + 1 at (i + 2) % 3, i % 3, (i + 1) % 3.
        self.smooth_row(frame, 0, 0);
        match self.border {
            FrameBorder::Replicate => self.smooth.copy_within(0..n, 2 * n),
            FrameBorder::Zero => self.smooth[2 * n..3 * n].fill(0.0),
        }
        let mut sum = [0.0; LANES];
        let mut sq = [0.0; LANES];
        let (mut sum_rest, mut sq_rest) = (0.0, 0.0);
        let mut g_sum = [0.0; LANES];
        let mut g_sq = [0.0; LANES];
        let (mut g_sum_rest, mut g_sq_rest) = (0.0, 0.0);
        for i in 0..n {
            let (above, below) = ((i + 2) % 3, (i + 1) % 3);
            if i + 1 < n {
                self.smooth_row(frame, i + 1, below);
            } else {
                match self.border {
                    FrameBorder::Replicate => {
                        let cur = i % 3;
                        self.smooth.copy_within(cur * n..(cur + 1) * n, below * n);
                    }
                    FrameBorder::Zero => self.smooth[below * n..(below + 1) * n].fill(0.0),
                }
            }
            // F = mask ⊙ (row below − row above): true convolution puts S_odd's top row on i + 1.
            let b = &self.smooth[below * n..(below + 1) * n];
            let a = &self.smooth[above * n..(above + 1) * n];
            let m = &self.mask[i * n..(i + 1) * n];
            let o = &mut out[i * n..(i + 1) * n];
            let mut oc = o.chunks_exact_mut(LANES);
            let mut mc = m.chunks_exact(LANES);
            let mut bc = b.chunks_exact(LANES);
            let mut ac = a.chunks_exact(LANES);
            for (((oo, mm), bb), aa) in (&mut oc).zip(&mut mc).zip(&mut bc).zip(&mut ac) {
                for k in 0..LANES {
                    let v = mm[k] * (bb[k] - aa[k]);
                    oo[k] = v;
                    sum[k] += v;
                    sq[k] += v * v;
                }
            }
            let rest = oc.into_remainder();
            for (((oo, mm), bb), aa) in rest
                .iter_mut()
                .zip(mc.remainder())
                .zip(bc.remainder())
                .zip(ac.remainder())
            {
                let v = mm * (bb - aa);
                *oo = v;
                sum_rest += v;
                sq_rest += v * v;
            }
            if ADAPT {
                // G = F − M and M += w·G on the row just written (still in L1), in a loop of
                // its own so that neither loop runs out of registers.
                let r = &mut running_mean[i * n..(i + 1) * n];
                let o = &mut out[i * n..(i + 1) * n];
                let mut oc = o.chunks_exact_mut(LANES);
                let mut rc = r.chunks_exact_mut(LANES);
                for (oo, rr) in (&mut oc).zip(&mut rc) {
                    for k in 0..LANES {
                        let g = oo[k] - rr[k];
                        oo[k] = g;
                        rr[k] += weight * g;
                        g_sum[k] += g;
                        g_sq[k] += g * g;
                    }
                }
                for (oo, rr) in oc.into_remainder().iter_mut().zip(rc.into_remainder()) {
                    let g = *oo - *rr;
                    *oo = g;
                    *rr += weight * g;
                    g_sum_rest += g;
                    g_sq_rest += g * g;
                }
            }
        }
        let total = |acc: &[f64], rest: f64| acc.iter().sum::<f64>() + rest;
        if ADAPT {
            AdaptedSums {
                raw_sumsq: total(&sq, sq_rest),
                sum: total(&g_sum, g_sum_rest),
                sumsq: total(&g_sq, g_sq_rest),
            }
        } else {
            AdaptedSums {
                raw_sumsq: total(&sq, sq_rest),
                sum: total(&sum, sum_rest),
                sumsq: total(&sq, sq_rest),
            }
        }
    }

    /// Computes ξ(t) row-major into `query` (length n²). Returns the centred norm of F(t), or
    /// `None` (and a zero `query`) for a blank frame.
    pub fn query(&mut self, frame: &[f32], query: &mut [f64]) -> Option<f64> {
        let (sum, sumsq) = self.processed(frame, query);
        match normalisation(query, sum, sumsq) {
            Some((mean, inv)) => {
                query.iter_mut().for_each(|v| *v = (*v - mean) * inv);
                Some(1.0 / inv)
            }
            None => {
                query.fill(0.0);
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stripes(n: usize) -> Vec<f32> {
        (0..n * n)
            .map(|k| {
                if (k / n) % 7 < 3 {
                    0.9
                } else {
                    0.1 + 0.001 * (k % n) as f32
                }
            })
            .collect()
    }

    #[test]
    fn kernel_sign_convention_brighter_below_is_positive() {
        let n = 16;
        let f: Vec<f32> = (0..n * n).map(|k| if k / n >= 8 { 1.0 } else { 0.0 }).collect();
        let c = convolve_s_odd(&f, n, FrameBorder::Replicate);
        assert!((c[7 * n + 5] - 1.0).abs() < 1e-15 && (c[8 * n + 5] - 1.0).abs() < 1e-15);
        assert_eq!(c[3 * n + 5], 0.0);
    }

    #[test]
    fn fast_processing_matches_literal_convolution() {
        for border in [FrameBorder::Replicate, FrameBorder::Zero] {
            for mask in [
                None,
                Some(MaskConfig {
                    radius_frac: 0.9,
                    blur_sigma_px: 3.0,
                    ..Default::default()
                }),
            ] {
                let n = 32;
                let f = stripes(n);
                let lit = convolve_s_odd(&f, n, border);
                let r = roi_mask(n, mask.as_ref());
                let mut lit: Vec<f64> = lit.iter().zip(&r).map(|(a, b)| a * b).collect();
                center_and_normalize(&mut lit).unwrap();
                let mut fp = FrameProcessor::new(n, mask.as_ref(), border);
                let mut q = vec![0.0; n * n];
                fp.query(&f, &mut q).unwrap();
                for (a, b) in lit.iter().zip(&q) {
                    assert!((a - b).abs() < 1e-14, "{border:?} {mask:?}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn mask_is_a_blurred_centred_disk() {
        let n = 64;
        let m = roi_mask(
            n,
            Some(&MaskConfig {
                radius_frac: 0.5,
                blur_sigma_px: 2.0,
                ..Default::default()
            }),
        );
        let c = n / 2;
        assert!((m[c * n + c] - 1.0).abs() < 1e-9);
        assert!(m[0] < 1e-9);
        // Symmetric about the centre (pixel k ↔ n−1−k).
        for i in 0..n {
            for j in 0..n {
                assert!((m[i * n + j] - m[(n - 1 - i) * n + (n - 1 - j)]).abs() < 1e-12);
                assert!((m[i * n + j] - m[j * n + i]).abs() < 1e-12);
            }
        }
        // Half height at the disk radius (16 px from the centre).
        let edge = m[c * n + c + 16];
        assert!((0.3..0.7).contains(&edge), "{edge}");
        let sharp = roi_mask(
            n,
            Some(&MaskConfig {
                radius_frac: 0.5,
                blur_sigma_px: 0.0,
                ..Default::default()
            }),
        );
        assert!(sharp.iter().all(|&v| v == 0.0 || v == 1.0));
        assert!(roi_mask(n, None).iter().all(|&v| v == 1.0));
    }

    #[test]
    fn blank_frames_give_the_zero_query() {
        let n = 16;
        for lum in [0.0f32, 0.3, 1.0] {
            let mut fp = FrameProcessor::new(n, Some(&MaskConfig::default()), FrameBorder::Replicate);
            let mut q = vec![1.0; n * n];
            assert!(fp.query(&vec![lum; n * n], &mut q).is_none());
            assert!(q.iter().all(|&v| v == 0.0));
        }
        let mut v = vec![0.25; 9];
        assert!(center_and_normalize(&mut v).is_none());
        let mut v = vec![f64::NAN; 9];
        assert!(center_and_normalize(&mut v).is_none());
        assert!(v.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn column_major_mapping() {
        let img = [1.0, 2.0, 3.0, 4.0]; // [[1, 2], [3, 4]]
        assert_eq!(image_to_vector(&img, 2), vec![1.0, 3.0, 2.0, 4.0]);
    }

    #[test]
    fn mask_blur_can_scale_with_n() {
        for n in [32, 64, 256] {
            let frac = MaskConfig {
                blur_sigma_frac: Some(0.078125),
                ..Default::default()
            };
            let px = MaskConfig {
                blur_sigma_px: 0.078125 * n as f64,
                ..Default::default()
            };
            assert_eq!(roi_mask(n, Some(&frac)), roi_mask(n, Some(&px)), "n = {n}");
        }
        // At n = 256 the fraction reproduces the paper's 20 px.
        assert_eq!(
            roi_mask(
                256,
                Some(&MaskConfig {
                    blur_sigma_frac: Some(20.0 / 256.0),
                    ..Default::default()
                })
            ),
            roi_mask(256, Some(&MaskConfig::default()))
        );
    }
}

/// The compensated front end's high-pass on the camera image (`front_end = "compensated"`, see
/// [`super::config`]): a per-pixel running mean of the camera images, warped every frame by the
/// static world's predicted image motion before it is subtracted. Shared by both implementations
/// (it runs before them).
#[derive(Debug, Clone)]
pub struct EgoHighPass {
    warper: crate::compensation::Warper,
    weight: f64,
    /// The warm-up after M̃ started.
    warm_up: WarmUp,
    mean: Vec<f32>,
    /// The next running mean while a frame is processed (swapped with `mean` after it).
    next: Vec<f32>,
    out: Vec<f32>,
}

impl EgoHighPass {
    /// For n×n frames of a camera of `fov_deg`, with the running mean's per-frame weight `weight`.
    pub fn new(n: usize, fov_deg: f64, weight: f64) -> Self {
        Self {
            warper: crate::compensation::Warper::new(n, fov_deg),
            weight,
            warm_up: WarmUp::default(),
            mean: Vec::new(),
            next: vec![0.0; n * n],
            out: vec![0.0; n * n],
        }
    }

    /// Forgets the running mean.
    pub fn reset(&mut self) {
        self.mean.clear();
        self.warm_up = WarmUp::default();
    }

    /// G̃ = F̃ − warp(M̃) of the camera frame `frame` (n·n) with its efference copy, updating M̃
    /// (all zero on the first frame, on a uniform, dropped frame, which leaves M̃ unchanged, and
    /// during the warm-up after the first frame, [`warm_up_frames`], which updates M̃).
    pub fn high_pass(&mut self, frame: &[f32], ego: &crate::EfferenceCopy) -> &[f32] {
        // uniform: every pixel that is a number equal to the first (NaN pixels ignored, as by a
        // min/max over the frame); stops at the first block of 64 pixels that differs (a block
        // is tested without branches: rendered frames often start with rows of uniform sky)
        let uniform = match frame.iter().find(|v| !v.is_nan()) {
            Some(&first) => frame
                .chunks(64)
                .all(|block| block.iter().fold(true, |same, &v| same & ((v == first) | v.is_nan()))),
            None => true,
        };
        if self.mean.is_empty() || uniform {
            if self.mean.is_empty() && !uniform {
                self.mean = frame.to_vec();
                self.warm_up = WarmUp::start(self.weight);
            }
            self.out.fill(0.0);
            return &self.out;
        }
        let w = self.weight as f32;
        // G̃ and the next M̃ of the pixels `start..` from their predictions `pred` (NaN: none)
        let update = |start: usize, pred: &[f32], out: &mut [f32], next: &mut [f32]| {
            let end = start + pred.len();
            let pixels = out[start..end].iter_mut().zip(&mut next[start..end]);
            for (((o, m), &p), &f) in pixels.zip(pred).zip(&frame[start..end]) {
                let prior = if p.is_nan() { f } else { p };
                let g = f - prior;
                *o = g;
                *m = prior + w * g;
            }
        };
        let (mean, out, next) = (&self.mean, &mut self.out, &mut self.next);
        if ego.knows_motion() {
            let r = crate::compensation::rotation_matrix(ego.rotation_rad);
            self.warper
                .predict_rows(mean, &r, ego.translation_m, ego, |start, pred| {
                    update(start, pred, out, next)
                });
        } else {
            update(0, mean, out, next);
        }
        std::mem::swap(&mut self.mean, &mut self.next);
        if self.warm_up.withholds() {
            self.out.fill(0.0);
        }
        &self.out
    }
}
