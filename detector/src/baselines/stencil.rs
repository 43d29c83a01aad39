//! 3×3 neighbourhood operations with clamp-to-edge borders (docs/detectors.md, common §4).
//!
//! All operations are correlations `(K ⋆ A)(i,j) = Σ K[di,dj]·A(i+di, j+dj)` where an
//! out-of-range index is replaced by the nearest valid one. Sums are accumulated in
//! row-major neighbour order `(−1,−1), (−1,0), (−1,+1), (0,−1), …, (+1,+1)`, the order of
//! the FuHuPe20 reference code; the unit tests check that the row-slice implementations
//! here give bit-identical results to naive per-pixel clamped loops.

use crate::simd::simd_dispatch;

/// A symmetric 3×3 kernel given by position class.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SymKernel {
    /// Weight of the centre pixel.
    pub centre: f64,
    /// Weight of each of the 4 nearest neighbours.
    pub near: f64,
    /// Weight of each of the 4 diagonal neighbours.
    pub diag: f64,
}

/// Row `i` and its clamped upper and lower neighbour rows.
#[inline(always)]
fn rows(a: &[f64], n: usize, i: usize) -> (&[f64], &[f64], &[f64]) {
    let up = i.saturating_sub(1);
    let dn = (i + 1).min(n - 1);
    (&a[up * n..up * n + n], &a[i * n..i * n + n], &a[dn * n..dn * n + n])
}

/// Correlation at one pixel: `c_row` is the centre-class row, `n_rows`/`d_rows` the
/// (up, mid, down) rows of the near/diagonal class maps, `l, c, r` the clamped columns.
#[inline(always)]
fn corr_at(k: SymKernel, c_row: &[f64], n_rows: [&[f64]; 3], d_rows: [&[f64]; 3], l: usize, c: usize, r: usize) -> f64 {
    let [nu, nm, nd] = n_rows;
    let [du, _, dd] = d_rows;
    // Row-major order, each term `value · weight` as in the reference code.
    du[l] * k.diag
        + nu[c] * k.near
        + du[r] * k.diag
        + nm[l] * k.near
        + c_row[c] * k.centre
        + nm[r] * k.near
        + dd[l] * k.diag
        + nd[c] * k.near
        + dd[r] * k.diag
}

/// Computes one output row of [`corr3_classes_rows`] into `out` (length n ≥ 2).
#[inline(always)]
fn corr_row(k: SymKernel, c_row: &[f64], n_rows: [&[f64]; 3], d_rows: [&[f64]; 3], out: &mut [f64]) {
    let n = out.len();
    out[0] = corr_at(k, c_row, n_rows, d_rows, 0, 0, 1);
    out[n - 1] = corr_at(k, c_row, n_rows, d_rows, n - 2, n - 1, n - 1);
    // Interior columns 1..n-1 as nine shifted slices of equal length m, so that the
    // loop has no bounds checks and vectorises; same terms, same order as `corr_at`.
    let m = n - 2;
    let [nu, nm, nd] = n_rows;
    let [du, _, dd] = d_rows;
    let (ul, uc, ur) = (&du[..m], &nu[1..m + 1], &du[2..m + 2]);
    let (ml, mc, mr) = (&nm[..m], &c_row[1..m + 1], &nm[2..m + 2]);
    let (dl, dc, dr) = (&dd[..m], &nd[1..m + 1], &dd[2..m + 2]);
    let out = &mut out[1..m + 1];
    for c in 0..m {
        out[c] = ul[c] * k.diag
            + uc[c] * k.near
            + ur[c] * k.diag
            + ml[c] * k.near
            + mc[c] * k.centre
            + mr[c] * k.near
            + dl[c] * k.diag
            + dc[c] * k.near
            + dr[c] * k.diag;
    }
}

simd_dispatch! {
    /// Correlation of a symmetric kernel where each position class reads its own map
    /// (`centre_map` for the centre, `near_map` for the 4 nearest neighbours, `diag_map` for
    /// the diagonals); with all three maps equal this is an ordinary correlation. Each
    /// output row is computed into `row` (length n) and handed to `emit(start, row)`, where
    /// `start = i·n` is the index of the row's first pixel, in row order.
    pub(crate) fn corr3_classes_rows(
        n: usize,
        k: SymKernel,
        centre_map: &[f64],
        near_map: &[f64],
        diag_map: &[f64],
        row: &mut [f64],
        emit: impl FnMut(usize, &[f64]),
    ) {
        let mut emit = emit;
        assert!(centre_map.len() == n * n && near_map.len() == n * n && diag_map.len() == n * n && row.len() == n);
        for i in 0..n {
            let (_, c_row, _) = rows(centre_map, n, i);
            let (nu, nm, nd) = rows(near_map, n, i);
            let (du, dm, dd) = rows(diag_map, n, i);
            if n == 1 {
                row[0] = corr_at(k, c_row, [nu, nm, nd], [du, dm, dd], 0, 0, 0);
            } else {
                corr_row(k, c_row, [nu, nm, nd], [du, dm, dd], row);
            }
            emit(i * n, row);
        }
    }
}

/// Ordinary correlation of one map with a symmetric kernel, see [`corr3_classes_rows`].
pub(crate) fn corr3_rows(n: usize, k: SymKernel, a: &[f64], row: &mut [f64], emit: impl FnMut(usize, &[f64])) {
    corr3_classes_rows(n, k, a, a, a, row, emit);
}

/// `max(start, max_i |values_i|)` for non-NaN input. Max is exact in any order, so this
/// uses four independent lanes (vectorisable) and still equals the sequential maximum.
pub(crate) fn max_abs(values: &[f64], start: f64) -> f64 {
    let mut lanes = [start; 4];
    let chunks = values.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for (lane, &v) in lanes.iter_mut().zip(c) {
            let a = v.abs();
            if a > *lane {
                *lane = a;
            }
        }
    }
    for &v in rest {
        let a = v.abs();
        if a > lanes[0] {
            lanes[0] = a;
        }
    }
    lanes.into_iter().fold(start, |m, v| if v > m { v } else { m })
}

simd_dispatch! {
    /// One explicit-Euler diffusion step with the 5-point Laplacian and clamp-to-edge
    /// (zero-flux) borders: `dst = src + κ·(up + down + left + right − 4·src)`.
    pub(crate) fn diffuse_step(n: usize, kappa: f64, src: &[f64], dst: &mut [f64]) {
        assert!(src.len() == n * n && dst.len() == n * n);
        let cell = |u: f64, d: f64, l: f64, r: f64, c: f64| c + kappa * (u + d + l + r - 4.0 * c);
        if n == 1 {
            dst[0] = cell(src[0], src[0], src[0], src[0], src[0]);
            return;
        }
        let m = n - 2;
        for i in 0..n {
            let (up, mid, dn) = rows(src, n, i);
            let out = &mut dst[i * n..i * n + n];
            out[0] = cell(up[0], dn[0], mid[0], mid[1], mid[0]);
            out[n - 1] = cell(up[n - 1], dn[n - 1], mid[n - 2], mid[n - 1], mid[n - 1]);
            // Interior as shifted slices of equal length (no bounds checks, vectorises).
            let (u, d, l, r, c) = (&up[1..m + 1], &dn[1..m + 1], &mid[..m], &mid[2..m + 2], &mid[1..m + 1]);
            let out = &mut out[1..m + 1];
            for j in 0..m {
                out[j] = cell(u[j], d[j], l[j], r[j], c[j]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clamp(i: isize, n: usize) -> usize {
        i.clamp(0, n as isize - 1) as usize
    }

    fn pseudo_random(len: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..len)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.3
            })
            .collect()
    }

    /// Naive per-pixel clamped correlation with class maps, row-major accumulation from 0.
    fn naive_classes(n: usize, k: SymKernel, maps: [&[f64]; 3]) -> Vec<f64> {
        let mut out = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let mut acc = 0.0;
                for di in -1isize..=1 {
                    for dj in -1isize..=1 {
                        let (w, m) = match (di, dj) {
                            (0, 0) => (k.centre, maps[0]),
                            (0, _) | (_, 0) => (k.near, maps[1]),
                            _ => (k.diag, maps[2]),
                        };
                        let r = clamp(i as isize + di, n);
                        let c = clamp(j as isize + dj, n);
                        acc += m[r * n + c] * w;
                    }
                }
                out[i * n + j] = acc;
            }
        }
        out
    }

    #[test]
    fn corr3_classes_matches_naive_bitwise() {
        let k = SymKernel {
            centre: 2.0,
            near: 0.5,
            diag: 0.25,
        };
        for n in [1usize, 2, 3, 4, 7, 16] {
            let a = pseudo_random(n * n, 1);
            let b = pseudo_random(n * n, 2);
            let c = pseudo_random(n * n, 3);
            let mut got = vec![f64::NAN; n * n];
            let mut row = vec![0.0; n];
            corr3_classes_rows(n, k, &a, &b, &c, &mut row, |st, r| got[st..st + n].copy_from_slice(r));
            assert_eq!(got, naive_classes(n, k, [&a, &b, &c]), "n = {n}");
            let k9 = SymKernel {
                centre: 1.0 / 9.0,
                near: 1.0 / 9.0,
                diag: 1.0 / 9.0,
            };
            corr3_rows(n, k9, &a, &mut row, |st, r| got[st..st + n].copy_from_slice(r));
            assert_eq!(got, naive_classes(n, k9, [&a, &a, &a]), "n = {n}");
        }
    }

    #[test]
    fn max_abs_equals_sequential_maximum() {
        for len in [0usize, 1, 3, 4, 5, 17, 64] {
            let a = pseudo_random(len, 9);
            let want = a.iter().fold(0.25f64, |m, v| m.max(v.abs()));
            assert_eq!(max_abs(&a, 0.25), want, "len = {len}");
        }
    }

    #[test]
    fn diffuse_step_matches_naive_bitwise_and_conserves_mass() {
        let kappa = 0.2;
        for n in [1usize, 2, 3, 5, 16] {
            let a = pseudo_random(n * n, 7);
            let mut got = vec![f64::NAN; n * n];
            diffuse_step(n, kappa, &a, &mut got);
            let mut want = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    let g = |di: isize, dj: isize| a[clamp(i as isize + di, n) * n + clamp(j as isize + dj, n)];
                    let c = a[i * n + j];
                    want[i * n + j] = c + kappa * (g(-1, 0) + g(1, 0) + g(0, -1) + g(0, 1) - 4.0 * c);
                }
            }
            assert_eq!(got, want, "n = {n}");
            // Zero-flux borders conserve the total.
            let (s0, s1): (f64, f64) = (a.iter().sum(), got.iter().sum());
            assert!((s0 - s1).abs() < 1e-12, "n = {n}: {s0} vs {s1}");
        }
    }
}
