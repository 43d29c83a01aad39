//! Template patterns of the static memory columns (paper §2.2.3, eq. 7).
//!
//! Template i (1 ≤ i ≤ N) is the gray-level image P̃(s_i) of a disk of diameter s_i·n pixels,
//! s_i = s_start + (i − 1)·Δs, edge-enhanced with the Laplacian, P(s_i) = ∇²P̃(s_i), then made a
//! zero-mean unit vector x_i.
//!
//! - Geometry: pixel (r, c) has its centre at (c + ½, r + ½); the disk is centred at
//!   (n/2, n/2 + `offset_px`) (below the frame centre for a positive offset) and contains the
//!   pixel centres within radius s·n/2. Luminance 1 inside (bright stripes), 0 outside and in
//!   the dark stripes. Stripes: bright where frac(cycles·b + phase) < ½, with
//!   b = (cy − y)/(s·n) the upward coordinate from the disk centre in diameters — the same
//!   convention as the stimulus `grating` texture.
//! - Laplacian: the 5-point stencil ∇²P[r, c] = P[r−1, c] + P[r+1, c] + P[r, c−1] + P[r, c+1]
//!   − 4·P[r, c], with black (0) outside the image. Its matrix L is symmetric, which the fast
//!   path uses: v_iᵀξ = (L·P̃_i)ᵀξ = P̃_iᵀ(L·ξ).
//! - Sparse storage ([`TemplateBank`]): P̃_i is piecewise constant along rows (a disk with
//!   horizontal stripes has at most one bright interval per row), so it is stored as row runs
//!   (row, first column, end column, value). With a per-frame row prefix sum of L·ξ, each run
//!   costs one subtraction: about s·n runs per template instead of the ~12·s·n nonzeros of the
//!   Laplacian itself.
//! - Because the query ξ has zero mean, x_iᵀξ = (v_i − v̄_i)ᵀξ/‖v_i − v̄_i‖ = v_iᵀξ/‖v_i − v̄_i‖:
//!   only the un-centred template and its centred norm are needed.

use super::config::{TemplateConfig, TemplateKind};

/// The gray-level template image P̃(s) (row-major n×n) for scale `scale`.
pub fn gray_template(n: usize, cfg: &TemplateConfig, scale: f64) -> Vec<f64> {
    let radius = scale * n as f64 / 2.0;
    let diameter = 2.0 * radius;
    let cx = n as f64 / 2.0;
    let cy = n as f64 / 2.0 + cfg.offset_px;
    let mut img = vec![0.0; n * n];
    for r in 0..n {
        let dy = r as f64 + 0.5 - cy;
        if dy.abs() > radius {
            continue;
        }
        let value = match cfg.kind {
            TemplateKind::UniformDisk => 1.0,
            TemplateKind::StripedDisk => {
                let b = -dy / diameter;
                let w = cfg.cycles * b + cfg.phase;
                if w - w.floor() < 0.5 { 1.0 } else { 0.0 }
            }
        };
        if value == 0.0 {
            continue;
        }
        for c in 0..n {
            let dx = c as f64 + 0.5 - cx;
            if dx * dx + dy * dy <= radius * radius {
                img[r * n + c] = value;
            }
        }
    }
    img
}

/// The 5-point Laplacian ∇² (eq. 7) of a row-major n×n image, black outside.
pub fn laplacian(img: &[f64], n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n * n];
    laplacian_into(img, n, &mut out);
    out
}

/// [`laplacian`] into a caller-provided buffer.
pub fn laplacian_into(img: &[f64], n: usize, out: &mut [f64]) {
    for r in 0..n {
        let row = &img[r * n..(r + 1) * n];
        let up = if r > 0 { Some(&img[(r - 1) * n..r * n]) } else { None };
        let down = if r + 1 < n {
            Some(&img[(r + 1) * n..(r + 2) * n])
        } else {
            None
        };
        let o = &mut out[r * n..(r + 1) * n];
        for c in 0..n {
            let mut acc = -4.0 * row[c];
            if c > 0 {
                acc += row[c - 1];
            }
            if c + 1 < n {
                acc += row[c + 1];
            }
            if let Some(u) = up {
                acc += u[c];
            }
            if let Some(d) = down {
                acc += d[c];
            }
            o[c] = acc;
        }
    }
}

/// One run of constant value in a row of a gray-level template: columns `start..end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Run {
    /// Row index.
    pub row: u32,
    /// First column.
    pub start: u32,
    /// One past the last column.
    pub end: u32,
    /// Luminance of the run (nonzero).
    pub value: f64,
}

/// Maximal runs of equal nonzero values in each row of a row-major n×n image.
pub fn row_runs(img: &[f64], n: usize) -> Vec<Run> {
    let mut runs = Vec::new();
    for r in 0..n {
        let row = &img[r * n..(r + 1) * n];
        let mut c = 0;
        while c < n {
            let v = row[c];
            if v == 0.0 {
                c += 1;
                continue;
            }
            let start = c;
            while c < n && row[c] == v {
                c += 1;
            }
            runs.push(Run {
                row: r as u32,
                start: start as u32,
                end: c as u32,
                value: v,
            });
        }
    }
    runs
}

/// Sum over the runs of `value · Σ_{c in run} y[row, c]`, where `prefix` holds the row prefix
/// sums of y: prefix[r·(n+1) + c] = Σ_{k<c} y[r, k].
#[inline]
pub fn runs_dot(runs: &[Run], prefix: &[f64], n: usize) -> f64 {
    let stride = n + 1;
    let term = |run: &Run| {
        let base = run.row as usize * stride;
        run.value * (prefix[base + run.end as usize] - prefix[base + run.start as usize])
    };
    // Four partial sums: independent add chains.
    let mut acc = [0.0; 4];
    let chunks = runs.chunks_exact(4);
    let mut s: f64 = chunks.remainder().iter().map(term).sum();
    for c in chunks {
        for k in 0..4 {
            acc[k] += term(&c[k]);
        }
    }
    s += (acc[0] + acc[1]) + (acc[2] + acc[3]);
    s
}

/// Row prefix sums of a row-major n×n image into `prefix` (length n·(n+1)).
#[inline]
pub fn row_prefix_sums(y: &[f64], n: usize, prefix: &mut [f64]) {
    for r in 0..n {
        let src = &y[r * n..(r + 1) * n];
        let dst = &mut prefix[r * (n + 1)..(r + 1) * (n + 1)];
        let mut acc = 0.0;
        dst[0] = 0.0;
        for c in 0..n {
            acc += src[c];
            dst[c + 1] = acc;
        }
    }
}

/// The error for a template image without edges (an empty disk, or stripes so wide that the
/// disk is uniformly dark): its Laplacian is zero and cannot be normalised.
pub fn no_edges_error(scale: f64) -> crate::DetectorError {
    crate::DetectorError::InvalidParameter {
        name: "template",
        value: format!("scale {scale}"),
        reason: "the template image has no edges (empty disk or a single stripe colour); \
                 change template.scale_start (or scale_start_px), template.cycles or template.phase"
            .into(),
    }
}

/// The N static templates in sparse form, with everything the fast path needs.
#[derive(Debug, Clone)]
pub struct TemplateBank {
    n: usize,
    scales: Vec<f64>,
    /// Runs of all templates, concatenated; template i owns `runs[offsets[i]..offsets[i+1]]`.
    runs: Vec<Run>,
    offsets: Vec<usize>,
    /// 1/‖v_i − v̄_i‖ with v_i = ∇²P̃_i.
    inv_norms: Vec<f64>,
    /// Means v̄_i (needed for the Gram matrix only).
    means: Vec<f64>,
    /// TᵀT, N×N row-major: entry (i, j) = x_iᵀx_j.
    gram: Vec<f64>,
}

impl TemplateBank {
    /// Builds the N templates of `cfg` for frames of side `n`.
    ///
    /// Errors with [`no_edges_error`] if a template image has no edges (possible only for odd
    /// stripe settings: validation guarantees disks at least two pixels wide).
    pub fn new(n: usize, cfg: &TemplateConfig) -> Result<Self, crate::DetectorError> {
        let count = cfg.template_count(n);
        let d = (n * n) as f64;
        let mut scales = Vec::with_capacity(count);
        let mut runs = Vec::new();
        let mut offsets = vec![0];
        let mut inv_norms = Vec::with_capacity(count);
        let mut means = Vec::with_capacity(count);
        for i in 1..=count {
            let s = cfg.scale(n, i);
            let img = gray_template(n, cfg, s);
            let v = laplacian(&img, n);
            let mean = v.iter().sum::<f64>() / d;
            let norm = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>().sqrt();
            if norm.is_nan() || norm <= 1e-12 {
                return Err(no_edges_error(s));
            }
            scales.push(s);
            runs.extend(row_runs(&img, n));
            offsets.push(runs.len());
            inv_norms.push(1.0 / norm);
            means.push(mean);
        }
        let mut bank = Self {
            n,
            scales,
            runs,
            offsets,
            inv_norms,
            means,
            gram: Vec::new(),
        };
        bank.gram = bank.compute_gram(cfg);
        Ok(bank)
    }

    /// x_iᵀx_j = (v_iᵀv_j − d·v̄_i·v̄_j)/(‖v_i − v̄_i‖·‖v_j − v̄_j‖), with
    /// v_iᵀv_j = P̃_iᵀ(L·v_j) evaluated on the runs of P̃_i.
    fn compute_gram(&self, cfg: &TemplateConfig) -> Vec<f64> {
        let n = self.n;
        let count = self.len();
        let d = (n * n) as f64;
        let mut gram = vec![0.0; count * count];
        let mut lv = vec![0.0; n * n];
        let mut prefix = vec![0.0; n * (n + 1)];
        for j in 0..count {
            let img = gray_template(n, cfg, self.scales[j]);
            let v = laplacian(&img, n);
            laplacian_into(&v, n, &mut lv);
            row_prefix_sums(&lv, n, &mut prefix);
            for i in 0..=j {
                let vv = runs_dot(self.runs(i), &prefix, n);
                let g = (vv - d * self.means[i] * self.means[j]) * self.inv_norms[i] * self.inv_norms[j];
                gram[i * count + j] = g;
                gram[j * count + i] = g;
            }
        }
        gram
    }

    /// Number of templates N.
    pub fn len(&self) -> usize {
        self.scales.len()
    }

    /// True if there are no templates (never for a validated config).
    pub fn is_empty(&self) -> bool {
        self.scales.is_empty()
    }

    /// Scales s_1..s_N.
    pub fn scales(&self) -> &[f64] {
        &self.scales
    }

    /// Runs of template i (0-based).
    pub fn runs(&self, i: usize) -> &[Run] {
        &self.runs[self.offsets[i]..self.offsets[i + 1]]
    }

    /// Total number of runs of all templates.
    pub fn total_runs(&self) -> usize {
        self.runs.len()
    }

    /// 1/‖v_i − v̄_i‖ of template i (0-based).
    pub fn inv_norm(&self, i: usize) -> f64 {
        self.inv_norms[i]
    }

    /// The Gram matrix TᵀT (N×N, row-major).
    pub fn gram(&self) -> &[f64] {
        &self.gram
    }

    /// s = Tᵀξ for a zero-mean query, given the row prefix sums of L·ξ.
    pub fn project(&self, lap_query_prefix: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = runs_dot(self.runs(i), lap_query_prefix, self.n) * self.inv_norms[i];
        }
    }
}

/// The dense unit template vector x_i (row-major) for scale `scale`: ∇²P̃ centred and
/// normalised. For tests and the reference implementation's cross-checks.
pub fn dense_template_vector(n: usize, cfg: &TemplateConfig, scale: f64) -> Vec<f64> {
    let mut v = laplacian(&gray_template(n, cfg, scale), n);
    super::processing::center_and_normalize(&mut v);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn striped_disk_has_two_cycles_and_a_bright_centre() {
        let n = 64;
        let cfg = TemplateConfig {
            offset_px: 0.0,
            ..Default::default()
        };
        let img = gray_template(n, &cfg, 0.5); // diameter 32 px, rows 16..48
        let col = 32;
        let column: Vec<f64> = (0..n).map(|r| img[r * n + col]).collect();
        assert_eq!(column[31], 1.0); // centre bright (phase 0.25)
        assert_eq!(column[32], 1.0);
        let transitions = column.windows(2).filter(|w| w[0] != w[1]).count();
        assert_eq!(transitions, 6, "{column:?}"); // bright cap, dark, bright centre, dark, bright cap
        // Symmetric about the centre for offset 0.
        for r in 0..n {
            assert_eq!(column[r], column[n - 1 - r]);
        }
        let uni = gray_template(
            n,
            &TemplateConfig {
                kind: TemplateKind::UniformDisk,
                ..cfg
            },
            0.5,
        );
        assert!((uni.iter().sum::<f64>() - std::f64::consts::PI * 256.0).abs() < 20.0);
    }

    #[test]
    fn offset_moves_the_disk_down() {
        let n = 64;
        let a = gray_template(
            n,
            &TemplateConfig {
                offset_px: 0.0,
                ..Default::default()
            },
            0.25,
        );
        let b = gray_template(
            n,
            &TemplateConfig {
                offset_px: 1.0,
                ..Default::default()
            },
            0.25,
        );
        for r in 1..n {
            for c in 0..n {
                assert_eq!(b[r * n + c], a[(r - 1) * n + c]);
            }
        }
    }

    #[test]
    fn runs_reconstruct_the_image_and_laplacian_is_self_adjoint() {
        let n = 32;
        let cfg = TemplateConfig::default();
        let img = gray_template(n, &cfg, 0.6);
        let runs = row_runs(&img, n);
        let mut rec = vec![0.0; n * n];
        for r in &runs {
            for c in r.start..r.end {
                rec[r.row as usize * n + c as usize] = r.value;
            }
        }
        assert_eq!(rec, img);
        // ⟨L·P, y⟩ = ⟨P, L·y⟩ via runs and prefix sums.
        let y: Vec<f64> = (0..n * n).map(|k| ((k * 7919) % 113) as f64 / 113.0 - 0.5).collect();
        let lp = laplacian(&img, n);
        let direct: f64 = lp.iter().zip(&y).map(|(a, b)| a * b).sum();
        let mut prefix = vec![0.0; n * (n + 1)];
        row_prefix_sums(&laplacian(&y, n), n, &mut prefix);
        assert!((runs_dot(&runs, &prefix, n) - direct).abs() < 1e-12);
    }

    #[test]
    fn bank_gram_matches_dense_dot_products() {
        let n = 32;
        let cfg = TemplateConfig::default();
        let bank = TemplateBank::new(n, &cfg).unwrap();
        assert_eq!(bank.len(), 1 + 3 * n / 5);
        let dense: Vec<Vec<f64>> = bank
            .scales()
            .iter()
            .map(|&s| dense_template_vector(n, &cfg, s))
            .collect();
        let count = bank.len();
        for i in 0..count {
            assert!((bank.gram()[i * count + i] - 1.0).abs() < 1e-12);
            for j in 0..count {
                let g: f64 = dense[i].iter().zip(&dense[j]).map(|(a, b)| a * b).sum();
                assert!((bank.gram()[i * count + j] - g).abs() < 1e-12, "({i},{j})");
            }
        }
    }
}
