//! The literal implementation: dense d×(N+1) pattern matrices ON and OFF, every equation of
//! paper §2.2 as written, in f64 (with the adapted front end's high-pass written out as
//! well). It is the executable specification the fast path
//! ([`super::fast`]) is tested against; it needs 2·d·(N+1) f64 (≈ 160 MB at n = 256) and runs
//! at tens of frames per second at n = 256.

use super::config::{FrontEnd, HopfieldConfig};
use super::processing::{Adaptation, AdaptedFrame, center_and_normalize, convolve_s_odd, image_to_vector, roi_mask};
use super::templates::{gray_template, no_edges_error};
use super::{Retrieval, softmax_in_place};

/// Literal dense implementation of pattern retrieval (eq. 4–9).
#[derive(Debug, Clone)]
pub struct ReferenceHopfield {
    cfg: HopfieldConfig,
    d: usize,
    columns: usize,
    mask: Vec<f64>,
    /// ON = [ξ(t−delay), x_1, …, x_N], column-major d×(N+1).
    on: Vec<f64>,
    /// OFF = [ξ(t−delay), −x_1, …, −x_N], column-major d×(N+1).
    off: Vec<f64>,
    /// Past queries, oldest first (at most `delay`).
    history: std::collections::VecDeque<Vec<f64>>,
    last_query: Vec<f64>,
    /// The adapted front end's running mean (`None` for the paper front end).
    adaptation: Option<Adaptation>,
}

impl ReferenceHopfield {
    /// Builds the dense pattern memories (config must be valid). Errors if a template image
    /// has no edges (see [`super::templates::no_edges_error`]).
    pub fn new(cfg: &HopfieldConfig) -> Result<Self, crate::DetectorError> {
        let n = cfg.n;
        let d = n * n;
        let count = cfg.template_count();
        let columns = count + 1;
        let mut on = vec![0.0; d * columns];
        let mut off = vec![0.0; d * columns];
        for i in 1..=count {
            // eq. 7: P(s) = ∇² P̃(s), literally as a 3×3 convolution with zero padding.
            let scale = cfg.template.scale(n, i);
            let img = gray_template(n, &cfg.template, scale);
            let lap = laplacian_literal(&img, n);
            let mut x = image_to_vector(&lap, n);
            if center_and_normalize(&mut x).is_none() {
                return Err(no_edges_error(scale));
            }
            on[i * d..(i + 1) * d].copy_from_slice(&x);
            for (o, v) in off[i * d..(i + 1) * d].iter_mut().zip(&x) {
                *o = -v;
            }
        }
        Ok(Self {
            cfg: *cfg,
            d,
            columns,
            mask: roi_mask(n, cfg.mask.as_ref()),
            on,
            off,
            history: Default::default(),
            last_query: vec![0.0; d],
            adaptation: match cfg.front_end {
                // the compensated front end's high-pass runs before the engine (`Hopfield`), which
                // then sees its output as the camera frame
                FrontEnd::Paper | FrontEnd::Compensated => None,
                FrontEnd::Adapted => Some(Adaptation::new(cfg.adaptation_weight())),
            },
        })
    }

    /// The ON pattern memory (column-major d×(N+1)); column 0 is the delayed query of the last
    /// processed frame.
    pub fn pattern_memory_on(&self) -> &[f64] {
        &self.on
    }

    /// The OFF pattern memory (column-major d×(N+1)).
    pub fn pattern_memory_off(&self) -> &[f64] {
        &self.off
    }

    /// Number of memory columns N + 1.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// The query ξ(t) of the last processed frame (paper's column-major order).
    pub fn last_query(&self) -> &[f64] {
        &self.last_query
    }

    /// x_iᵀξ(t) of the last processed frame for the templates i = 1..=N: each template's cosine
    /// with the query (all zero for a frame without evidence).
    pub fn last_template_cosines(&self) -> Vec<f64> {
        let d = self.d;
        (1..self.columns)
            .map(|i| {
                self.on[i * d..(i + 1) * d]
                    .iter()
                    .zip(&self.last_query)
                    .map(|(x, q)| x * q)
                    .sum()
            })
            .collect()
    }

    /// Forgets all past frames.
    pub fn reset(&mut self) {
        self.history.clear();
        if let Some(a) = &mut self.adaptation {
            a.reset();
        }
    }

    /// eq. 4 + §2.2.2: ξ(t) = unit, zero-mean vec(R_oi ⊙ (F̃ ∗ S_odd)) — of its temporal
    /// high-pass for the adapted front end; `false` if blank (no evidence).
    fn query(&mut self, frame: &[f32]) -> (Vec<f64>, bool) {
        let n = self.cfg.n;
        let conv = convolve_s_odd(frame, n, self.cfg.frame_border);
        let mut processed: Vec<f64> = conv.iter().zip(&self.mask).map(|(c, r)| r * c).collect();
        if let Some(a) = &mut self.adaptation
            && a.high_pass(&mut processed) == AdaptedFrame::Dropped
        {
            return (vec![0.0; n * n], false);
        }
        let mut xi = image_to_vector(&processed, n);
        let ok = center_and_normalize(&mut xi).is_some();
        (xi, ok)
    }

    /// Processes one frame (of side n, checked by the caller).
    pub fn retrieve(&mut self, frame: &[f32]) -> Retrieval {
        let (xi, evidence) = self.query(frame);
        // Dynamic first column: ξ(t − delay), or ξ(t) itself while fewer frames were seen.
        let delayed = if self.history.len() == self.cfg.delay {
            self.history[0].clone()
        } else {
            xi.clone()
        };
        self.on[..self.d].copy_from_slice(&delayed);
        self.off[..self.d].copy_from_slice(&delayed);
        let (on, off) = if evidence {
            (self.iterate(&self.on, &xi), self.iterate(&self.off, &xi))
        } else {
            (Channel::no_evidence(self.columns), Channel::no_evidence(self.columns))
        };
        // Only queries with evidence are remembered (a blank one would be a zero column).
        if evidence {
            if self.history.len() == self.cfg.delay {
                self.history.pop_front();
            }
            self.history.push_back(xi.clone());
        }
        self.last_query = xi;
        Retrieval::from_channels(&on.p, &off.p, on.iterations, off.iterations)
    }

    /// eq. 5–6 for one memory X: ξ(τ+1) = X·p(τ), p(τ) = softmax(β Xᵀξ(τ)), until
    /// ‖ξ(τ+1) − ξ(τ)‖ ≤ tol or `max_iterations` updates. Returns p of the last update.
    fn iterate(&self, x: &[f64], query: &[f64]) -> Channel {
        let d = self.d;
        let m = self.columns;
        let mut xi = query.to_vec();
        let mut p = vec![0.0; m];
        let mut next = vec![0.0; d];
        let mut iterations = 0;
        loop {
            // p(τ) = softmax(β Xᵀ ξ(τ))
            for (k, pk) in p.iter_mut().enumerate() {
                let col = &x[k * d..(k + 1) * d];
                *pk = self.cfg.beta * col.iter().zip(&xi).map(|(a, b)| a * b).sum::<f64>();
            }
            softmax_in_place(&mut p);
            // ξ(τ+1) = X p(τ)
            next.fill(0.0);
            for (k, pk) in p.iter().enumerate() {
                let col = &x[k * d..(k + 1) * d];
                for (o, a) in next.iter_mut().zip(col) {
                    *o += a * pk;
                }
            }
            iterations += 1;
            let dist = next.iter().zip(&xi).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
            if dist <= self.cfg.tolerance || iterations >= self.cfg.max_iterations {
                break;
            }
            std::mem::swap(&mut xi, &mut next);
        }
        Channel { p, iterations }
    }
}

/// Result of one channel's retrieval.
struct Channel {
    p: Vec<f64>,
    iterations: usize,
}

impl Channel {
    fn no_evidence(m: usize) -> Self {
        let mut p = vec![0.0; m];
        p[0] = 1.0;
        Self { p, iterations: 0 }
    }
}

/// eq. 7's Laplacian, literally: 3×3 kernel [[0, 1, 0], [1, −4, 1], [0, 1, 0]], zero padding.
fn laplacian_literal(img: &[f64], n: usize) -> Vec<f64> {
    const K: [[f64; 3]; 3] = [[0.0, 1.0, 0.0], [1.0, -4.0, 1.0], [0.0, 1.0, 0.0]];
    let mut out = vec![0.0; n * n];
    for i in 0..n as isize {
        for j in 0..n as isize {
            let mut acc = 0.0;
            for (a, row) in K.iter().enumerate() {
                for (b, k) in row.iter().enumerate() {
                    let (ii, jj) = (i + 1 - a as isize, j + 1 - b as isize);
                    if (0..n as isize).contains(&ii) && (0..n as isize).contains(&jj) {
                        acc += k * img[ii as usize * n + jj as usize];
                    }
                }
            }
            out[i as usize * n + j as usize] = acc;
        }
    }
    out
}
