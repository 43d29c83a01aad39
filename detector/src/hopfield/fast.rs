//! The fast implementation: the same numbers as [`super::reference`] (to rounding, ~1e-12)
//! with far less work, through exact identities (design §2):
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
//! Per frame: the separable S_odd convolution with the mask, centring and normalisation, the
//! Laplacian with prefix sums, ~Σ s_i·n run lookups, one d-long dot product ξ(t−delay)ᵀξ(t),
//! and a few (N+1)² products — all in f64.

use super::config::HopfieldConfig;
use super::processing::FrameProcessor;
use super::templates::TemplateBank;
use super::{Retrieval, softmax_in_place};

/// Fast pattern retrieval, numerically equivalent to [`super::ReferenceHopfield`].
#[derive(Debug, Clone)]
pub struct FastHopfield {
    n: usize,
    beta: f64,
    delay: usize,
    tolerance: f64,
    max_iterations: usize,
    processor: FrameProcessor,
    bank: TemplateBank,
    /// Current query ξ(t), row-major.
    query: Vec<f64>,
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
        let bank = TemplateBank::new(n, &cfg.template)?;
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
            prefix: vec![0.0; n * (n + 1)],
            s: vec![0.0; count],
            ring_query: Vec::with_capacity(cfg.delay),
            ring_s: Vec::with_capacity(cfg.delay),
            ring_norm2: vec![0.0; cfg.delay],
            head: 0,
            filled: 0,
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

    /// The query ξ(t) of the last processed frame (row-major). Valid until the next frame.
    pub fn last_query(&self) -> &[f64] {
        // After a frame the query buffer was swapped into the ring at the newest slot.
        let newest = (self.head + self.ring_query.len() - 1) % self.ring_query.len().max(1);
        self.ring_query.get(newest).map_or(&self.query[..], |v| &v[..])
    }

    /// Forgets all past frames.
    pub fn reset(&mut self) {
        self.head = 0;
        self.filled = 0;
        self.ring_query.clear();
        self.ring_s.clear();
    }

    /// Processes one frame of n·n pixels (checked by the caller).
    pub fn retrieve(&mut self, frame: &[f32]) -> Retrieval {
        let n = self.n;
        let evidence = self.processor.query(frame, &mut self.query).is_some();
        let qq: f64 = if evidence {
            self.query.iter().map(|v| v * v).sum()
        } else {
            0.0
        };
        if evidence {
            lap_prefix(&self.query, n, &mut self.prefix);
            self.bank.project(&self.prefix, &mut self.s);
        } else {
            self.s.fill(0.0);
        }

        // The delayed column ξ_d: ξ(t − delay), or ξ(t) itself while fewer frames were seen.
        let full = self.filled == self.delay;
        let (dq, dd) = if !full {
            (qq, qq)
        } else {
            let old = &self.ring_query[self.head];
            let dot = if evidence { dot(old, &self.query) } else { 0.0 };
            (dot, self.ring_norm2[self.head])
        };

        let retrieval = if evidence {
            let s_d: &[f64] = if full { &self.ring_s[self.head] } else { &self.s };
            let (it_on, it_off);
            {
                let w = &mut self.work;
                it_on = iterate(
                    &self.bank,
                    self.beta,
                    self.tolerance,
                    self.max_iterations,
                    1.0,
                    dq,
                    dd,
                    qq,
                    &self.s,
                    s_d,
                    w,
                );
                w.p_on.copy_from_slice(&w.p);
                it_off = iterate(
                    &self.bank,
                    self.beta,
                    self.tolerance,
                    self.max_iterations,
                    -1.0,
                    dq,
                    dd,
                    qq,
                    &self.s,
                    s_d,
                    w,
                );
            }
            Retrieval::from_channels(self.work.p_on.clone(), self.work.p.clone(), it_on, it_off)
        } else {
            let m = self.bank.len() + 1;
            let mut p = vec![0.0; m];
            p[0] = 1.0;
            Retrieval::from_channels(p.clone(), p, 0, 0)
        };

        // Store ξ(t), s(t) in the ring (swapping buffers, no copies once the ring is full).
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

/// Row prefix sums of L·ξ (5-point Laplacian, zero outside), fused in one pass.
fn lap_prefix(q: &[f64], n: usize, prefix: &mut [f64]) {
    for r in 0..n {
        let row = &q[r * n..(r + 1) * n];
        let dst = &mut prefix[r * (n + 1)..(r + 1) * (n + 1)];
        dst[0] = 0.0;
        let mut acc = 0.0;
        // Vertical neighbours (zero outside).
        let up = if r > 0 { Some(&q[(r - 1) * n..r * n]) } else { None };
        let down = if r + 1 < n {
            Some(&q[(r + 1) * n..(r + 2) * n])
        } else {
            None
        };
        for c in 0..n {
            let mut v = -4.0 * row[c];
            if c > 0 {
                v += row[c - 1];
            }
            if c + 1 < n {
                v += row[c + 1];
            }
            if let Some(u) = up {
                v += u[c];
            }
            if let Some(d) = down {
                v += d[c];
            }
            acc += v;
            dst[c + 1] = acc;
        }
    }
}

#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    // Four partial sums let the compiler vectorise without reassociation flags.
    let mut acc = [0.0; 4];
    let chunks_a = a.chunks_exact(4);
    let chunks_b = b.chunks_exact(4);
    let (ra, rb) = (chunks_a.remainder(), chunks_b.remainder());
    for (x, y) in chunks_a.zip(chunks_b) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut sum = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (x, y) in ra.iter().zip(rb) {
        sum += x * y;
    }
    sum
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

/// eq. 5–6 in pattern space for one channel; leaves p of the last update in `w.p`.
#[allow(clippy::too_many_arguments)]
fn iterate(
    bank: &TemplateBank,
    beta: f64,
    tolerance: f64,
    max_iterations: usize,
    sign: f64,
    dq: f64,
    dd: f64,
    qq: f64,
    s: &[f64],
    s_d: &[f64],
    w: &mut Work,
) -> usize {
    // a(0) = Xᵀξ(0) = [ξ_dᵀξ, sign·s].
    w.a[0] = dq;
    for (a, si) in w.a[1..].iter_mut().zip(s) {
        *a = sign * si;
    }
    let mut iterations = 0;
    loop {
        for (p, a) in w.p.iter_mut().zip(&w.a) {
            *p = beta * a;
        }
        softmax_in_place(&mut w.p);
        iterations += 1;
        let last = iterations >= max_iterations;
        if last {
            break; // the distance no longer matters
        }
        gram_product(bank, sign, dd, s_d, &w.p, &mut w.a_next);
        let dist2 = if iterations == 1 {
            // ‖X p − ξ‖² = pᵀGp − 2 pᵀXᵀξ + ξᵀξ
            let pgp: f64 = w.p.iter().zip(&w.a_next).map(|(p, a)| p * a).sum();
            let pa: f64 = w.p.iter().zip(&w.a).map(|(p, a)| p * a).sum();
            pgp - 2.0 * pa + qq
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
