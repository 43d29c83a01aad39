//! The fast implementation: the same numbers as [`super::reference`] (to rounding, ~1e-12)
//! with far less work, through exact identities:
//!
//! 1. **One product serves both channels.** OFF's static columns are −ON's, so
//!    OFFᵀξ = [ξ_dᵀξ, −Tᵀξ] with T = [x_1 … x_N]: s = Tᵀξ is computed once per frame.
//! 2. **Iteration in pattern space.** ξ(τ+1) = X·p(τ), so Xᵀξ(τ+1) = G·p(τ) with the Gram
//!    matrix G = XᵀX = [[ξ_dᵀξ_d, ±sᵀ_d], [±s_d, TᵀT]]: TᵀT is fixed (built once), and
//!    s_d = Tᵀξ(t−delay) was computed `delay` frames ago (kept in a ring with the queries).
//!    ‖ξ(τ+1) − ξ(τ)‖² = (p(τ) − p(τ−1))ᵀ(G·p(τ) − G·p(τ−1)) for τ ≥ 1 and
//!    p(0)ᵀG·p(0) − 2·p(0)ᵀXᵀξ + ξᵀξ for τ = 0, all from products already at hand:
//!    one (N+1)² matrix–vector product per iteration instead of two d×(N+1) ones.
//! 3. **Sparse templates.** With ξ zero-mean, x_iᵀξ = v_iᵀξ/‖v_i − v̄_i‖ with v_i = ∇²P̃_i, and
//!    because the zero-padded Laplacian L is symmetric, v_iᵀξ = P̃_iᵀ(L·ξ). P̃_i is stored as
//!    row runs, so with the row prefix sums of L·ξ (one pass over the frame) each template
//!    costs one subtraction per run (≈ s·n runs).
//!
//! Per frame: the separable S_odd convolution with the mask (fused with the running-mean
//! subtraction of the adapted front end), centring and normalisation, the
//! Laplacian with prefix sums, ~Σ s_i·n run lookups, one d-long dot product ξ(t−delay)ᵀξ(t),
//! and a few (N+1)² products — all in f64.

use std::sync::Arc;

use super::config::{FrontEnd, HopfieldConfig, TemplateConfig};
use super::processing::{Adaptation, FrameProcessor, LANES, camera_frame_is_blank, normalisation, undo_running_mean};
use super::templates::TemplateBank;
use super::{Retrieval, softmax_in_place};
use crate::memo::Memo;

/// Rows processed together when forming the row prefix sums of L·ξ (independent add chains).
const ROW_BLOCK: usize = 4;

/// Fast pattern retrieval, numerically equivalent to [`super::ReferenceHopfield`].
#[derive(Debug, Clone)]
pub struct FastHopfield {
    n: usize,
    beta: f64,
    delay: usize,
    tolerance: f64,
    max_iterations: usize,
    processor: FrameProcessor,
    bank: Arc<TemplateBank>,
    /// Current query ξ(t), row-major.
    query: Vec<f64>,
    /// L·ξ for one block of rows.
    lap_block: Vec<f64>,
    /// A row of zeros (the Laplacian's outside).
    zero_row: Vec<f64>,
    /// Row prefix sums of L·ξ(t), n rows of n + 1.
    prefix: Vec<f64>,
    /// s(t) = Tᵀξ(t).
    s: Vec<f64>,
    /// Ring of the last `delay` queries, their s vectors and squared norms; `head` is the
    /// oldest entry (= the next slot to overwrite) once `filled == delay`.
    ring_query: Vec<Vec<f64>>,
    ring_s: Vec<Vec<f64>>,
    ring_norm2: Vec<f64>,
    head: usize,
    filled: usize,
    /// The adapted front end's running mean (`None` for the paper front end).
    adaptation: Option<Adaptation>,
    /// The last frame was blank (its query is the zero vector in `query`).
    last_blank: bool,
    work: Work,
}

/// Scratch vectors of length N + 1 for the pattern-space iteration.
#[derive(Debug, Clone)]
struct Work {
    a: Vec<f64>,
    a_next: Vec<f64>,
    p: Vec<f64>,
    p_prev: Vec<f64>,
    p_on: Vec<f64>,
}

impl FastHopfield {
    /// Builds the template bank and buffers (config must be valid).
    pub fn new(cfg: &HopfieldConfig) -> Result<Self, crate::DetectorError> {
        let n = cfg.n;
        let d = n * n;
        // built once per process for each n and template configuration (`crate::memo`)
        static BANKS: Memo<(usize, TemplateConfig), TemplateBank> = Memo::new();
        let bank = BANKS.get_or_try_insert((n, cfg.template), || TemplateBank::new(n, &cfg.template))?;
        let count = bank.len();
        let m = count + 1;
        Ok(Self {
            n,
            beta: cfg.beta,
            delay: cfg.delay,
            tolerance: cfg.tolerance,
            max_iterations: cfg.max_iterations,
            processor: FrameProcessor::new(n, cfg.mask.as_ref(), cfg.frame_border),
            bank,
            query: vec![0.0; d],
            lap_block: vec![0.0; ROW_BLOCK * n],
            zero_row: vec![0.0; n],
            prefix: vec![0.0; n * (n + 1)],
            s: vec![0.0; count],
            ring_query: Vec::with_capacity(cfg.delay),
            ring_s: Vec::with_capacity(cfg.delay),
            ring_norm2: vec![0.0; cfg.delay],
            head: 0,
            filled: 0,
            adaptation: match cfg.front_end {
                // the compensated front end's high-pass runs before the engine (`Hopfield`), which
                // then sees its output as the camera frame
                FrontEnd::Paper | FrontEnd::Compensated => None,
                FrontEnd::Adapted => Some(Adaptation::new(cfg.adaptation_weight())),
            },
            last_blank: false,
            work: Work {
                a: vec![0.0; m],
                a_next: vec![0.0; m],
                p: vec![0.0; m],
                p_prev: vec![0.0; m],
                p_on: vec![0.0; m],
            },
        })
    }

    /// The template bank (runs, norms, Gram matrix).
    pub fn templates(&self) -> &TemplateBank {
        &self.bank
    }

    /// The query ξ(t) of the last processed frame (row-major; zero for a blank frame).
    pub fn last_query(&self) -> &[f64] {
        // After a frame with evidence the query buffer was swapped into the ring at the newest
        // slot; after a blank one it holds the zero vector.
        let len = self.ring_query.len();
        if len == 0 || self.last_blank {
            return &self.query;
        }
        &self.ring_query[(self.head + len - 1) % len]
    }

    /// Tᵀξ(t) of the last processed frame: each template's cosine with the query, template 1
    /// first (all zero for a frame without evidence).
    pub fn last_template_cosines(&self) -> &[f64] {
        let len = self.ring_s.len();
        if len == 0 || self.last_blank {
            return &self.s;
        }
        &self.ring_s[(self.head + len - 1) % len]
    }

    /// Forgets all past frames.
    pub fn reset(&mut self) {
        self.head = 0;
        self.filled = 0;
        self.ring_query.clear();
        self.ring_s.clear();
        self.last_blank = false;
        if let Some(a) = &mut self.adaptation {
            a.reset();
        }
    }

    /// Forms the processed frame (paper) or its high-pass (adapted) in `self.query` and
    /// returns its mean and 1/norm, or `None` if there is no evidence this frame.
    fn front_end(&mut self, frame: &[f32]) -> Option<(f64, f64)> {
        let Some(adapt) = &mut self.adaptation else {
            let (sum, sumsq) = self.processor.processed(frame, &mut self.query);
            return normalisation(&self.query, sum, sumsq);
        };
        if adapt.running_mean.is_empty() {
            // Start-up: M = the first non-blank F, so G = 0 (no evidence).
            let (_, sumsq) = self.processor.processed(frame, &mut self.query);
            if !camera_frame_is_blank(sumsq) {
                adapt.start(&self.query);
            }
            return None;
        }
        let weight = adapt.weight;
        let sums = self
            .processor
            .processed_adapted(frame, &mut self.query, &mut adapt.running_mean, weight);
        if camera_frame_is_blank(sums.raw_sumsq) {
            // A dropped camera frame: M stays as it was.
            undo_running_mean(&mut adapt.running_mean, &self.query, weight);
            return None;
        }
        if adapt.warm_up.withholds() {
            return None;
        }
        normalisation(&self.query, sums.sum, sums.sumsq)
    }

    /// Processes one frame of n·n pixels (checked by the caller).
    pub fn retrieve(&mut self, frame: &[f32]) -> Retrieval {
        let n = self.n;
        let full = self.filled == self.delay;
        let normalised = self.front_end(frame);
        // ξ(t), ‖ξ(t)‖², ξ(t − delay)ᵀξ(t) and the prefix sums of L·ξ(t), in one pass.
        let (qq, dq_old) = match normalised {
            Some((mean, inv)) => {
                let delayed = if full {
                    Some(&self.ring_query[self.head][..])
                } else {
                    None
                };
                let sums = finish_query(
                    &mut self.query,
                    n,
                    mean,
                    inv,
                    delayed,
                    &mut self.lap_block,
                    &self.zero_row,
                    &mut self.prefix,
                );
                self.bank.project(&self.prefix, &mut self.s);
                sums
            }
            None => {
                self.query.fill(0.0);
                self.s.fill(0.0);
                (0.0, 0.0)
            }
        };

        // The delayed column ξ_d: ξ(t − delay), or ξ(t) itself while fewer frames were seen.
        let (dq, dd) = if full {
            (dq_old, self.ring_norm2[self.head])
        } else {
            (qq, qq)
        };

        let retrieval = if normalised.is_some() {
            let s_d: &[f64] = if full { &self.ring_s[self.head] } else { &self.s };
            let channel = Channel {
                bank: &self.bank,
                s: &self.s,
                s_d,
                dq,
                dd,
                qq,
            };
            let params = (self.beta, self.tolerance, self.max_iterations);
            let it_on = channel.iterate(1.0, params, &mut self.work);
            self.work.p_on.copy_from_slice(&self.work.p);
            let it_off = channel.iterate(-1.0, params, &mut self.work);
            Retrieval::from_channels(&self.work.p_on, &self.work.p, it_on, it_off)
        } else {
            let m = self.bank.len() + 1;
            let mut p = vec![0.0; m];
            p[0] = 1.0;
            Retrieval::from_channels(&p, &p, 0, 0)
        };

        // Store ξ(t), s(t) in the ring (swapping buffers, no copies once the ring is full).
        // A blank query is not stored: the ring keeps the last `delay` queries with evidence.
        self.last_blank = normalised.is_none();
        if self.last_blank {
            return retrieval;
        }
        if self.ring_query.len() < self.delay {
            self.ring_query.push(self.query.clone());
            self.ring_s.push(self.s.clone());
            self.ring_norm2[self.ring_query.len() - 1] = qq;
            self.filled = self.ring_query.len();
            self.head = self.filled % self.delay;
        } else {
            std::mem::swap(&mut self.ring_query[self.head], &mut self.query);
            std::mem::swap(&mut self.ring_s[self.head], &mut self.s);
            self.ring_norm2[self.head] = qq;
            self.head = (self.head + 1) % self.delay;
        }
        retrieval
    }
}

/// Turns the processed frame F in `q` into ξ = (F − mean)·inv in place and, in the same
/// row-block sweep, computes ‖ξ‖², ξ_oldᵀξ (if `delayed` is given) and the row prefix sums of
/// L·ξ (5-point Laplacian, zero outside): prefix[r·(n+1) + c] = Σ_{k<c} (L·ξ)[r, k].
#[allow(clippy::too_many_arguments)]
fn finish_query(
    q: &mut [f64],
    n: usize,
    mean: f64,
    inv: f64,
    delayed: Option<&[f64]>,
    lap: &mut [f64],
    zero: &[f64],
    prefix: &mut [f64],
) -> (f64, f64) {
    let mut qq = [0.0; LANES];
    let mut dq = [0.0; LANES];
    let (mut qq_rest, mut dq_rest) = (0.0, 0.0);
    let mut scale_row = |q: &mut [f64], r: usize| {
        let row = &mut q[r * n..(r + 1) * n];
        let mut rc = row.chunks_exact_mut(LANES);
        match delayed {
            Some(old) => {
                let old = &old[r * n..(r + 1) * n];
                let mut oc = old.chunks_exact(LANES);
                for (x, o) in (&mut rc).zip(&mut oc) {
                    for k in 0..LANES {
                        let v = (x[k] - mean) * inv;
                        x[k] = v;
                        qq[k] += v * v;
                        dq[k] += v * o[k];
                    }
                }
                for (x, o) in rc.into_remainder().iter_mut().zip(oc.remainder()) {
                    let v = (*x - mean) * inv;
                    *x = v;
                    qq_rest += v * v;
                    dq_rest += v * o;
                }
            }
            None => {
                for x in &mut rc {
                    for k in 0..LANES {
                        let v = (x[k] - mean) * inv;
                        x[k] = v;
                        qq[k] += v * v;
                    }
                }
                for x in rc.into_remainder() {
                    let v = (*x - mean) * inv;
                    *x = v;
                    qq_rest += v * v;
                }
            }
        }
    };
    let stride = n + 1;
    let mut scaled = 0;
    let mut r0 = 0;
    while r0 < n {
        let r1 = (r0 + ROW_BLOCK).min(n);
        // The Laplacian of rows r0..r1 needs ξ up to row r1 (inclusive, if it exists).
        while scaled < (r1 + 1).min(n) {
            scale_row(q, scaled);
            scaled += 1;
        }
        for r in r0..r1 {
            let up = if r > 0 { &q[(r - 1) * n..r * n] } else { zero };
            let down = if r + 1 < n { &q[(r + 1) * n..(r + 2) * n] } else { zero };
            let row = &q[r * n..(r + 1) * n];
            let out = &mut lap[(r - r0) * n..(r - r0 + 1) * n];
            out[0] = (up[0] + down[0]) + row[1] - 4.0 * row[0];
            out[n - 1] = (up[n - 1] + down[n - 1]) + row[n - 2] - 4.0 * row[n - 1];
            let inner = out[1..n - 1]
                .iter_mut()
                .zip(&up[1..n - 1])
                .zip(&down[1..n - 1])
                .zip(row[..n - 2].iter().zip(&row[2..]))
                .zip(&row[1..n - 1]);
            for ((((o, u), d), (l, r)), c) in inner {
                *o = (u + d) + (l + r) - 4.0 * c;
            }
        }
        if r1 - r0 == ROW_BLOCK {
            let mut acc = [0.0; ROW_BLOCK];
            for k in 0..ROW_BLOCK {
                prefix[(r0 + k) * stride] = 0.0;
            }
            for c in 0..n {
                for k in 0..ROW_BLOCK {
                    acc[k] += lap[k * n + c];
                    prefix[(r0 + k) * stride + c + 1] = acc[k];
                }
            }
        } else {
            for r in r0..r1 {
                let mut acc = 0.0;
                prefix[r * stride] = 0.0;
                for c in 0..n {
                    acc += lap[(r - r0) * n + c];
                    prefix[r * stride + c + 1] = acc;
                }
            }
        }
        r0 = r1;
    }
    (qq.iter().sum::<f64>() + qq_rest, dq.iter().sum::<f64>() + dq_rest)
}

/// The pattern-space view of one frame's two memories.
struct Channel<'a> {
    bank: &'a TemplateBank,
    /// s = Tᵀξ(t).
    s: &'a [f64],
    /// s_d = Tᵀξ_d.
    s_d: &'a [f64],
    /// ξ_dᵀξ(t).
    dq: f64,
    /// ξ_dᵀξ_d.
    dd: f64,
    /// ξ(t)ᵀξ(t).
    qq: f64,
}

impl Channel<'_> {
    /// eq. 5–6 in pattern space for the memory with template sign `sign` (+1 ON, −1 OFF);
    /// leaves p of the last update in `w.p` and returns the number of updates.
    fn iterate(&self, sign: f64, (beta, tolerance, max_iterations): (f64, f64, usize), w: &mut Work) -> usize {
        // a(0) = Xᵀξ(0) = [ξ_dᵀξ, sign·s].
        w.a[0] = self.dq;
        for (a, si) in w.a[1..].iter_mut().zip(self.s) {
            *a = sign * si;
        }
        let mut iterations = 0;
        loop {
            for (p, a) in w.p.iter_mut().zip(&w.a) {
                *p = beta * a;
            }
            softmax_in_place(&mut w.p);
            iterations += 1;
            if iterations >= max_iterations {
                break; // the distance no longer matters
            }
            gram_product(self.bank, sign, self.dd, self.s_d, &w.p, &mut w.a_next);
            let dist2 = if iterations == 1 {
                // ‖X p − ξ‖² = pᵀGp − 2 pᵀXᵀξ + ξᵀξ
                let pgp: f64 = w.p.iter().zip(&w.a_next).map(|(p, a)| p * a).sum();
                let pa: f64 = w.p.iter().zip(&w.a).map(|(p, a)| p * a).sum();
                pgp - 2.0 * pa + self.qq
            } else {
                // ‖X (p − p_prev)‖² = (p − p_prev)ᵀ(G p − G p_prev)
                w.p.iter()
                    .zip(&w.p_prev)
                    .zip(w.a_next.iter().zip(&w.a))
                    .map(|((p, pp), (an, a))| (p - pp) * (an - a))
                    .sum()
            };
            if dist2.max(0.0).sqrt() <= tolerance {
                break;
            }
            std::mem::swap(&mut w.p_prev, &mut w.p);
            std::mem::swap(&mut w.a, &mut w.a_next);
        }
        iterations
    }
}

/// out = G·p for the memory with template sign `sign` (+1 ON, −1 OFF):
/// G = [[dd, sign·s_dᵀ], [sign·s_d, TᵀT]].
fn gram_product(bank: &TemplateBank, sign: f64, dd: f64, s_d: &[f64], p: &[f64], out: &mut [f64]) {
    let count = bank.len();
    let gram = bank.gram();
    let p0 = p[0];
    let (out0, rest) = out.split_first_mut().expect("N + 1 ≥ 1");
    let mut head = dd * p0;
    for (sd, r) in s_d.iter().zip(rest.iter_mut()) {
        *r = sign * sd * p0;
    }
    for j in 0..count {
        let pj = p[j + 1];
        if pj == 0.0 {
            continue; // exact: 0·g adds nothing
        }
        head += sign * s_d[j] * pj;
        // TᵀT is symmetric: row j = column j.
        let col = &gram[j * count..(j + 1) * count];
        for (r, g) in rest.iter_mut().zip(col) {
            *r += g * pj;
        }
    }
    *out0 = head;
}
