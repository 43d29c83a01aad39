//! Ego-motion compensation: predicting where the static world seen in an earlier frame appears now,
//! from the robot's own motion ([`EfferenceCopy`]) alone.
//!
//! A pixel of the current frame looks along the ray `d = (1, −x·t, y·t)` in camera axes (x forward,
//! y left, z up; `x, y` its normalised image coordinates, `t = tan(fov/2)`). The static world point
//! it shows is predicted as
//! - **below the horizon** (the ray meets the ground, `up · d < −`[`HORIZON_MARGIN`], with the
//!   camera's pose above the ground known): the ground point `P = d · h / (−up · d)` — the
//!   ground-plane homography, exact for a flat ground;
//! - **elsewhere** (above the horizon, or the pose unknown) — the documented fallback: a point at
//!   infinity along `d`, which only the camera's rotation moves. It is exact for rotation and for
//!   distant scenery; a near object above the horizon (a wall, a pole) leaves a residual from the
//!   camera's translation, as an independently moving object would.
//!
//! The point is then expressed in the earlier camera's axes (`P' = R·P + T`, the camera's rotation
//! `R` and displacement `T` between the two frames, composed from the per-frame increments of the
//! efference copies) and projected; the earlier frame is sampled there bilinearly. The **residual**
//! of a pixel is the current luminance minus this prediction; pixels whose prediction falls outside
//! the earlier frame have none (0). Pure rotation of a static scene leaves no residual up to the
//! bilinear interpolation; a translation over the textured ground leaves the interpolation error
//! of its texture only. The documented bounds, on the analytic scenes of the tests
//! (`detector/tests/compensation.rs`: 96² frames, 60°, a smooth ground and sky texture of
//! luminance contrast ±0.15–0.3, compared with the frame 8 frames = 67 ms earlier): after
//! 0.5 rad/s of yaw and 0.2 rad/s of pitch the mean |residual| is below 2·10⁻³ and the largest
//! below 0.04 (uncompensated: 0.024 and 0.1); after 2 m/s forward at 0.35 m above the ground, below
//! 4·10⁻³ and 0.06.

use crate::EfferenceCopy;

/// Rays less than this far below the horizon (`up · d` with `d` of unit x component) take the
/// at-infinity fallback: their ground points are too far to move measurably and too sensitive to
/// the pitch.
pub const HORIZON_MARGIN: f64 = 1e-3;

/// A 3×3 rotation matrix, rows first.
pub type Mat3 = [[f64; 3]; 3];

pub(crate) const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation matrix of a rotation vector (Rodrigues' formula).
pub fn rotation_matrix(w: [f64; 3]) -> Mat3 {
    let theta = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    if theta < 1e-12 {
        return [[1.0, -w[2], w[1]], [w[2], 1.0, -w[0]], [-w[1], w[0], 1.0]];
    }
    let k = [w[0] / theta, w[1] / theta, w[2] / theta];
    let (s, c) = theta.sin_cos();
    let v = 1.0 - c;
    [
        [
            c + k[0] * k[0] * v,
            k[0] * k[1] * v - k[2] * s,
            k[0] * k[2] * v + k[1] * s,
        ],
        [
            k[1] * k[0] * v + k[2] * s,
            c + k[1] * k[1] * v,
            k[1] * k[2] * v - k[0] * s,
        ],
        [
            k[2] * k[0] * v - k[1] * s,
            k[2] * k[1] * v + k[0] * s,
            c + k[2] * k[2] * v,
        ],
    ]
}

pub(crate) fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

pub(crate) fn apply(a: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2],
        a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
        a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2],
    ]
}

pub(crate) fn apply_t(a: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        a[0][0] * v[0] + a[1][0] * v[1] + a[2][0] * v[2],
        a[0][1] * v[0] + a[1][1] * v[1] + a[2][1] * v[2],
        a[0][2] * v[0] + a[1][2] * v[1] + a[2][2] * v[2],
    ]
}

fn transpose_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[k][i] * b[k][j]).sum();
        }
    }
    m
}

/// The camera's pose in its own odometry frame (the axes of the first frame since the last reset):
/// integrated from the efference copies' increments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryPose {
    /// Orientation: columns are the camera's axes in odometry coordinates.
    pub rotation: Mat3,
    /// Position (m).
    pub position: [f64; 3],
}

impl Default for OdometryPose {
    fn default() -> Self {
        Self {
            rotation: IDENTITY,
            position: [0.0; 3],
        }
    }
}

impl OdometryPose {
    /// This pose moved by one frame's increments of `ego` (unchanged when its motion is unknown).
    pub fn advanced(&self, ego: &EfferenceCopy) -> Self {
        if !ego.knows_motion() {
            return *self;
        }
        let step = apply(&self.rotation, ego.translation_m);
        Self {
            rotation: mul(&self.rotation, &rotation_matrix(ego.rotation_rad)),
            position: [
                self.position[0] + step[0],
                self.position[1] + step[1],
                self.position[2] + step[2],
            ],
        }
    }

    /// The motion from `earlier` to this pose: `(R, T)` with a point's coordinates in the earlier
    /// camera's axes `P' = R·P + T` for its coordinates `P` in this camera's axes.
    pub fn relative_to(&self, earlier: &OdometryPose) -> (Mat3, [f64; 3]) {
        let r = transpose_mul(&earlier.rotation, &self.rotation);
        let d = [
            self.position[0] - earlier.position[0],
            self.position[1] - earlier.position[1],
            self.position[2] - earlier.position[2],
        ];
        (r, apply_t(&earlier.rotation, d))
    }
}

/// Per-pixel viewing rays of an n×n camera and the warp of an earlier frame into the current view.
#[derive(Debug, Clone)]
pub struct Warper {
    n: usize,
    tan_half_fov: f64,
    /// `(−x·t, y·t)` of every pixel (the ray is `(1, ·, ·)`).
    rays: Vec<[f64; 2]>,
}

impl Warper {
    /// Rays of an n×n camera of full field of view `fov_deg`.
    pub fn new(n: usize, fov_deg: f64) -> Self {
        let t = crate::Pinhole::new(fov_deg).tan_half_fov();
        let mut rays = Vec::with_capacity(n * n);
        for i in 0..n {
            let y = 1.0 - (2 * i + 1) as f64 / n as f64;
            for j in 0..n {
                let x = (2 * j + 1) as f64 / n as f64 - 1.0;
                rays.push([-x * t, y * t]);
            }
        }
        Self {
            n,
            tan_half_fov: t,
            rays,
        }
    }

    /// Frame side n.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Writes into `out` (n·n) the prediction of the current frame from `earlier` (n·n, the frame
    /// seen at the earlier pose) under the camera motion `(r, t)` ([`OdometryPose::relative_to`]),
    /// with `ego` the current frame's pose above the ground; `NaN` where the prediction falls
    /// outside the earlier frame.
    pub fn predict(&self, earlier: &[f32], r: &Mat3, t: [f64; 3], ego: &EfferenceCopy, out: &mut [f32]) {
        assert_eq!(out.len(), self.n * self.n, "prediction buffer of n·n pixels");
        self.predict_rows(earlier, r, t, ego, |start, pred| {
            out[start..start + pred.len()].copy_from_slice(pred);
        });
    }

    /// [`Self::predict`], handing the prediction to `sink` row by row instead of writing a buffer:
    /// `sink(start, values)` receives the predictions of pixels `start..start + n` (one row, rows
    /// in order). How it is fast:
    /// - a pixel's predicted point, up to a positive factor, is linear in its column along a row:
    ///   `R·d` above the horizon, and `h·R·d − (up·d)·T` on the ground (the ground point
    ///   `P = (h·R·d − (up·d)·T) / (−up·d)`, whose positive factor the projection cancels), so
    ///   each row needs its start and step only (computed in `f64`), and each pixel one
    ///   multiplication and one addition per coordinate and one division, in `f32` without
    ///   branches, which the compiler vectorises sixteen or eight wide (AVX-512 or AVX2 where the
    ///   CPU has it, chosen at run time; the same bits every way); coordinates inside the image
    ///   are non-negative, so truncation replaces `floor`;
    /// - `up · d` is monotone along a row, so the ground is a prefix or a suffix of it: each row
    ///   is split where the case changes (found by bisection on the same `f32` expression), and
    ///   each part computes its own case only;
    /// - the bilinear samples of [`GROUP`] pixels whose top-left pixels are consecutive (the
    ///   usual case: the static world's image moves smoothly) take contiguous loads.
    ///
    /// The sample coordinates agree with the module docs' formula evaluated per pixel in `f64` to
    /// 10⁻⁴ pixel (about 10⁻⁵ measured: `f32` rounding of coordinates up to n; this module's
    /// tests), far below the interpolation error of any texture. Without any motion (`r` the
    /// identity, `t` zero) the prediction is `earlier` itself.
    pub fn predict_rows(
        &self,
        earlier: &[f32],
        r: &Mat3,
        t: [f64; 3],
        ego: &EfferenceCopy,
        mut sink: impl FnMut(usize, &[f32]),
    ) {
        let n = self.n;
        assert_eq!(earlier.len(), n * n, "earlier frame of n·n pixels");
        if n == 0 {
            return;
        }
        if *r == IDENTITY && t == [0.0; 3] {
            // no motion: the earlier frame itself, the formula's exact answer (the `f32`
            // coordinates would blend in ~10⁻⁶ of neighbouring pixels, and a standing camera's
            // static scene would leave a residual of that size instead of none)
            for (i, row) in earlier.chunks_exact(n).enumerate() {
                sink(i * n, row);
            }
            return;
        }
        let setup = self.setup(r, t, ego);
        #[cfg(target_arch = "x86_64")]
        {
            if crate::simd::has_avx512() {
                // SAFETY: the CPU supports AVX-512 F and VL (checked just above).
                unsafe { predict_avx512(&setup, &self.rays, earlier, sink) };
                return;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2 (checked just above).
                unsafe { predict_avx2(&setup, &self.rays, earlier, sink) };
                return;
            }
        }
        predict_generic(&setup, &self.rays, earlier, sink);
    }

    /// The constants of one warp.
    fn setup(&self, r: &Mat3, t: [f64; 3], ego: &EfferenceCopy) -> Setup {
        let n = self.n;
        let step_a = if n > 1 { self.rays[1][0] - self.rays[0][0] } else { 0.0 };
        Setup {
            n,
            inv_t: 1.0 / self.tan_half_fov,
            ground: ego.knows_ground(),
            h: ego.height_m,
            up: ego.up_in_camera(),
            r: *r,
            t,
            step_a,
        }
    }
}

/// The per-frame constants of one warp.
struct Setup {
    n: usize,
    inv_t: f64,
    ground: bool,
    h: f64,
    up: [f64; 3],
    r: Mat3,
    t: [f64; 3],
    step_a: f64,
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn predict_avx2(setup: &Setup, rays: &[[f64; 2]], earlier: &[f32], sink: impl FnMut(usize, &[f32])) {
    predict_kernel(setup, rays, earlier, sink);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2")]
unsafe fn predict_avx512(setup: &Setup, rays: &[[f64; 2]], earlier: &[f32], sink: impl FnMut(usize, &[f32])) {
    predict_kernel(setup, rays, earlier, sink);
}

fn predict_generic(setup: &Setup, rays: &[[f64; 2]], earlier: &[f32], sink: impl FnMut(usize, &[f32])) {
    predict_kernel(setup, rays, earlier, sink);
}

/// One row's predicted points, up to a positive factor: `start + c · step` at column `c`, for the
/// at-infinity fallback (`sky`) and the ground (`ground`), each `[x, y, z]`; and `up · d`, whose
/// sign picks the case.
struct RowLines {
    sky: [[f32; 2]; 3],
    ground: [[f32; 2]; 3],
    s: [f32; 2],
}

/// The per-warp constants of a row's geometry: image coordinates `j = α − β·y/x`,
/// `i = α − β·z/x`, inside `[0, n − 1]`.
struct Geometry<'a> {
    alpha: f32,
    beta: f32,
    n: usize,
    /// `c as f32` of every column `c`.
    columns: &'a [f32],
}

impl Geometry<'_> {
    /// The top-left pixels (`corner`, see [`sample_row`]) and weights (`fi`, `fj`) of the columns
    /// `cols` of one row, all on the ground (`GROUND`) or all above the horizon; without branches
    /// (vectorised).
    #[inline(always)]
    fn segment<const GROUND: bool>(
        &self,
        line: &RowLines,
        cols: std::ops::Range<usize>,
        (corner, fi, fj): (&mut [i32], &mut [f32], &mut [f32]),
    ) {
        let &Self {
            alpha,
            beta,
            n,
            columns,
        } = self;
        let max = (n - 1) as f32;
        let lines = if GROUND { &line.ground } else { &line.sky };
        let edge = (n - 1) as i32;
        let (corner, fi, fj) = (&mut corner[cols.clone()], &mut fi[cols.clone()], &mut fj[cols.clone()]);
        for (((&cf, corner), fi), fj) in columns[cols].iter().zip(corner).zip(fi).zip(fj) {
            let x = lines[0][0] + cf * lines[0][1];
            let y = lines[1][0] + cf * lines[1][1];
            let z = lines[2][0] + cf * lines[2][1];
            // in front of the earlier camera: the point's x above 1e-9 (the ground's divided by
            // −up·d > 0)
            let front = if GROUND {
                1e-9 * -(line.s[0] + cf * line.s[1])
            } else {
                1e-9
            };
            let q = beta / x;
            let jf = alpha - y * q;
            let i_f = alpha - z * q;
            let inside = (x > front) & (jf >= 0.0) & (jf <= max) & (i_f >= 0.0) & (i_f <= max);
            // inside the image the coordinates are non-negative: truncation is the floor
            let (i_in, j_in) = if inside { (i_f, jf) } else { (0.0, 0.0) };
            // SAFETY: `i_in` and `j_in` lie in [0, n − 1] (checked just above), and n < 2³⁰ (the
            // n² rays of `Warper::new`, 16 bytes each, fit in memory), so their truncations are
            // representable as i32.
            let (i0, j0): (i32, i32) = unsafe { (i_in.to_int_unchecked(), j_in.to_int_unchecked()) };
            // the top-left pixel's index; −1: no prediction; ≤ −2: on the last row or column
            let index = i0 * n as i32 + j0;
            *corner = if !inside {
                -1
            } else if (i0 < edge) & (j0 < edge) {
                index
            } else {
                -2 - index
            };
            *fi = i_in - i0 as f32;
            *fj = j_in - j0 as f32;
        }
    }
}

/// The warp of [`Warper::predict_rows`]; inlined into each instruction-set variant.
#[inline(always)]
fn predict_kernel(setup: &Setup, rays: &[[f64; 2]], earlier: &[f32], mut sink: impl FnMut(usize, &[f32])) {
    let &Setup {
        n,
        inv_t,
        ground,
        h,
        up,
        r,
        t,
        step_a,
    } = setup;
    let col = |c: usize| [r[0][c], r[1][c], r[2][c]];
    let (r0, r1, r2) = (col(0), col(1), col(2));
    // image coordinates: j = α − β·y/x, i = α − β·z/x
    let alpha = (n as f64 / 2.0 - 0.5) as f32;
    let beta = (inv_t * n as f64 / 2.0) as f32;
    let ground_below = if ground {
        -(HORIZON_MARGIN as f32)
    } else {
        f32::NEG_INFINITY
    };
    let columns: Vec<f32> = (0..n).map(|c| c as f32).collect();
    let mut corner = vec![0i32; n];
    let mut fiv = vec![0.0f32; n];
    let mut fjv = vec![0.0f32; n];
    let mut pred = vec![0.0f32; n];
    let geometry = Geometry {
        alpha,
        beta,
        n,
        columns: &columns,
    };
    for i in 0..n {
        let [a0, b] = rays[i * n];
        // (plain loops: closures over arrays here cost a function call per row)
        let s = [up[0] + up[1] * a0 + up[2] * b, up[1] * step_a];
        let mut line = RowLines {
            sky: [[0.0; 2]; 3],
            ground: [[0.0; 2]; 3],
            s: [s[0] as f32, s[1] as f32],
        };
        for k in 0..3 {
            let sky = [r0[k] + a0 * r1[k] + b * r2[k], step_a * r1[k]];
            line.sky[k] = [sky[0] as f32, sky[1] as f32];
            line.ground[k] = [(h * sky[0] - s[0] * t[k]) as f32, (h * sky[1] - s[1] * t[k]) as f32];
        }
        // `up · d` is monotone along the row (so is its `f32` evaluation: rounding is monotone),
        // so the ground is a prefix or a suffix of the row: find where the case changes, by
        // bisection on the same expression, and run each part's geometry without the other's
        let s_at = |c: usize| line.s[0] + columns[c] * line.s[1];
        let first_on_ground = s_at(0) < ground_below;
        let switch = if (s_at(n - 1) < ground_below) == first_on_ground {
            n
        } else {
            // the first column of the other case: in (lo, hi]
            let (mut lo, mut hi) = (0, n - 1);
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if (s_at(mid) < ground_below) == first_on_ground {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            hi
        };
        let (head, tail) = (0..switch, switch..n);
        let (on_ground, above) = if first_on_ground { (head, tail) } else { (tail, head) };
        geometry.segment::<true>(&line, on_ground, (&mut corner, &mut fiv, &mut fjv));
        geometry.segment::<false>(&line, above, (&mut corner, &mut fiv, &mut fjv));
        sample_row(earlier, n, &corner, &fiv, &fjv, &mut pred);
        sink(i * n, &pred);
    }
}

/// Pixels sampled together where their top-left pixels are consecutive (the usual case: the
/// static world's image moves smoothly).
pub const GROUP: usize = 8;

/// The bilinear samples of one row of an n×n image `img`: `corner[c]` the top-left pixel's index
/// (−1: none, NaN; ≤ −2: `−2 − index` on the image's last row or column), `fi`, `fj` the weights.
/// Runs of [`GROUP`] consecutive top-left pixels inside take contiguous loads.
#[inline(always)]
fn sample_row(img: &[f32], n: usize, corner: &[i32], fi: &[f32], fj: &[f32], out: &mut [f32]) {
    let mut c = 0;
    while c < n {
        if c + GROUP <= n {
            let first = corner[c];
            let run = &corner[c..c + GROUP];
            // consecutive from a pixel inside: all inside, none on the last row or column
            let consecutive = (0..GROUP).fold(true, |ok, k| ok & (run[k] == first.wrapping_add(k as i32)));
            if first >= 0 && consecutive {
                let b = first as usize;
                let (top, top1) = (&img[b..b + GROUP], &img[b + 1..b + 1 + GROUP]);
                let (bottom, bottom1) = (&img[b + n..b + n + GROUP], &img[b + n + 1..b + n + 1 + GROUP]);
                let (wi, wj) = (&fi[c..c + GROUP], &fj[c..c + GROUP]);
                for (k, o) in out[c..c + GROUP].iter_mut().enumerate() {
                    let a = top[k] + (top1[k] - top[k]) * wj[k];
                    let b = bottom[k] + (bottom1[k] - bottom[k]) * wj[k];
                    *o = a + (b - a) * wi[k];
                }
                c += GROUP;
                continue;
            }
        }
        let end = (c + GROUP).min(n);
        for k in c..end {
            let index = corner[k];
            out[k] = if index >= 0 {
                let b = index as usize;
                let (top, bottom) = (&img[b..b + 2], &img[b + n..b + n + 2]);
                let a = top[0] + (top[1] - top[0]) * fj[k];
                let b = bottom[0] + (bottom[1] - bottom[0]) * fj[k];
                a + (b - a) * fi[k]
            } else if index == -1 {
                f32::NAN
            } else {
                let index = (-2 - index) as usize;
                bilinear_at(img, n, index / n, index % n, fi[k], fj[k])
            };
        }
        c = end;
    }
}

/// Bilinear sample of an n×n image with top-left pixel (`i0`, `j0`) and weights `fi`, `fj` (the
/// coordinates' fractional parts); the same numbers as [`bilinear`].
#[inline(always)]
fn bilinear_at(img: &[f32], n: usize, i0: usize, j0: usize, fi: f32, fj: f32) -> f32 {
    let i1 = (i0 + 1).min(n - 1);
    let j1 = (j0 + 1).min(n - 1);
    let (top, bottom) = (&img[i0 * n..i0 * n + n], &img[i1 * n..i1 * n + n]);
    let a = top[j0] + (top[j1] - top[j0]) * fj;
    let b = bottom[j0] + (bottom[j1] - bottom[j0]) * fj;
    a + (b - a) * fi
}

/// Bilinear sample of an n×n image at (row `i`, column `j`), both in `[0, n−1]`.
#[cfg(test)]
fn bilinear(img: &[f32], n: usize, i: f64, j: f64) -> f32 {
    let i0 = (i.floor() as usize).min(n - 1);
    let j0 = (j.floor() as usize).min(n - 1);
    let i1 = (i0 + 1).min(n - 1);
    let j1 = (j0 + 1).min(n - 1);
    let fi = (i - i0 as f64) as f32;
    let fj = (j - j0 as f64) as f32;
    let a = img[i0 * n + j0] + (img[i0 * n + j1] - img[i0 * n + j0]) * fj;
    let b = img[i1 * n + j0] + (img[i1 * n + j1] - img[i1 * n + j0]) * fj;
    a + (b - a) * fi
}

/// The ego-motion-compensated temporal difference: the current frame minus the frame `baseline`
/// frames earlier warped to the current view (see the module docs). Keeps the last `baseline`
/// frames and their odometry poses.
#[derive(Debug, Clone)]
pub struct CompensatedDifference {
    warper: Warper,
    baseline: usize,
    /// Ring of (frame, pose), oldest first.
    history: std::collections::VecDeque<(Vec<f32>, OdometryPose)>,
    pose: OdometryPose,
}

impl CompensatedDifference {
    /// For n×n frames of a camera of `fov_deg`, comparing with the frame `baseline` (≥ 1) frames back.
    pub fn new(n: usize, fov_deg: f64, baseline: usize) -> Self {
        Self {
            warper: Warper::new(n, fov_deg),
            baseline: baseline.max(1),
            history: std::collections::VecDeque::with_capacity(baseline.max(1) + 1),
            pose: OdometryPose::default(),
        }
    }

    /// Forgets every frame.
    pub fn reset(&mut self) {
        self.history.clear();
        self.pose = OdometryPose::default();
    }

    /// Adds `frame` (n·n) with its efference copy; writes `current − predicted` into `residual`
    /// (0 where there is no prediction) and returns false when there is no earlier frame yet
    /// (residual all 0). Until `baseline` frames have been seen, the oldest frame is used.
    pub fn step(&mut self, frame: &[f32], ego: &EfferenceCopy, residual: &mut [f32]) -> bool {
        self.pose = self.pose.advanced(ego);
        let have = match self.history.front() {
            Some((earlier, earlier_pose)) => {
                let (r, t) = self.pose.relative_to(earlier_pose);
                let n2 = frame.len();
                assert_eq!(residual.len(), n2, "residual buffer of n·n pixels");
                self.warper.predict_rows(earlier, &r, t, ego, |start, pred| {
                    let end = start + pred.len();
                    for ((o, &c), &p) in residual[start..end].iter_mut().zip(&frame[start..end]).zip(pred) {
                        *o = if p.is_nan() { 0.0 } else { c - p };
                    }
                });
                true
            }
            None => {
                residual.iter_mut().for_each(|o| *o = 0.0);
                false
            }
        };
        let recycled = if self.history.len() >= self.baseline {
            self.history.pop_front().map(|(v, _)| v)
        } else {
            None
        };
        let mut buf = recycled.unwrap_or_default();
        buf.clear();
        buf.extend_from_slice(frame);
        self.history.push_back((buf, self.pose));
        have
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The module docs' formula evaluated literally for one pixel, each ray on its own: the
    /// prediction, or `None` outside the earlier frame, and how far (in pixels, or in the ray's
    /// terms) the pixel is from a case boundary (the image border, the horizon margin, the plane
    /// x = 1e-9), where rounding may legitimately decide differently.
    fn predict_literal(
        n: usize,
        fov_deg: f64,
        earlier: &[f32],
        r: &Mat3,
        t: [f64; 3],
        ego: &EfferenceCopy,
        (i, j): (usize, usize),
    ) -> (Option<f32>, f64) {
        let tan = crate::Pinhole::new(fov_deg).tan_half_fov();
        let x = (2 * j + 1) as f64 / n as f64 - 1.0;
        let y = 1.0 - (2 * i + 1) as f64 / n as f64;
        let d = [1.0, -x * tan, y * tan];
        let up = ego.up_in_camera();
        let s = up[0] * d[0] + up[1] * d[1] + up[2] * d[2];
        let mut margin = (s + HORIZON_MARGIN).abs();
        let p = if ego.knows_ground() && s < -HORIZON_MARGIN {
            let g = d.map(|v| v * ego.height_m / -s);
            let rg = apply(r, g);
            [rg[0] + t[0], rg[1] + t[1], rg[2] + t[2]]
        } else {
            apply(r, d)
        };
        margin = margin.min((p[0] - 1e-9).abs());
        if p[0] <= 1e-9 {
            return (None, margin);
        }
        let jf = (1.0 - p[1] / p[0] / tan) * n as f64 / 2.0 - 0.5;
        let i_f = (1.0 - p[2] / p[0] / tan) * n as f64 / 2.0 - 0.5;
        let max = (n - 1) as f64;
        for v in [jf, i_f, max - jf, max - i_f] {
            margin = margin.min(v.abs());
        }
        if !(jf >= 0.0 && jf <= max && i_f >= 0.0 && i_f <= max) {
            return (None, margin);
        }
        (Some(bilinear(earlier, n, i_f, jf)), margin)
    }

    /// Random camera motions and poses: small and large rotations (parts of the view leave the
    /// earlier frame or fall behind it), translations, pitch and roll, ground known or not.
    fn cases(rng: &mut ChaCha8Rng) -> Vec<(Mat3, [f64; 3], EfferenceCopy)> {
        (0..40)
            .map(|k| {
                let big = if k % 4 == 0 { 2.0 } else { 0.1 };
                let w = [0, 1, 2].map(|_| rng.random_range(-big..big));
                let t = [0, 1, 2].map(|_| rng.random_range(-0.3..0.3));
                let ego = EfferenceCopy {
                    dt_s: 1.0 / 120.0,
                    height_m: if k % 5 == 1 { 0.0 } else { rng.random_range(0.05..1.5) },
                    pitch_rad: rng.random_range(-0.6..0.6),
                    roll_rad: if k % 3 == 0 { rng.random_range(-0.3..0.3) } else { 0.0 },
                    ..EfferenceCopy::default()
                };
                (rotation_matrix(w), t, ego)
            })
            .collect()
    }

    /// Sample coordinates may differ from the literal formula's by this much (pixels): `f32`
    /// rounding of coordinates up to n (the rows' lines and the projection's ratio).
    const COORDINATE_TOLERANCE_PX: f64 = 1e-4;

    /// Compares `got`, the warp of `earlier`, with the literal formula at every pixel farther than the
    /// tolerance from a case boundary, where rounding may decide either way; returns the pixels
    /// compared inside the frame and outside it. The values may differ by the tolerance times
    /// the largest difference between neighbouring pixels in each direction.
    fn compare_with_literal(
        n: usize,
        fov: f64,
        earlier: &[f32],
        r: &Mat3,
        t: [f64; 3],
        ego: &EfferenceCopy,
        got: &[f32],
    ) -> (usize, usize) {
        let steepest = (0..n * n)
            .flat_map(|p| {
                [(p + 1, p % n + 1 < n), (p + n, p + n < n * n)]
                    .map(|(q, ok)| if ok { (earlier[q] - earlier[p]).abs() } else { 0.0 })
            })
            .fold(0.0f32, f32::max);
        let bound = COORDINATE_TOLERANCE_PX * 2.0 * f64::from(steepest) + 1e-6;
        let (mut inside, mut outside) = (0, 0);
        for i in 0..n {
            for j in 0..n {
                let (want, margin) = predict_literal(n, fov, earlier, r, t, ego, (i, j));
                if margin < COORDINATE_TOLERANCE_PX {
                    continue; // rounding may decide either way here
                }
                let v = got[i * n + j];
                match want {
                    None => {
                        assert!(v.is_nan(), "n {n}, pixel ({i}, {j}): {v}, literal: outside");
                        outside += 1;
                    }
                    Some(want) => {
                        let error = f64::from((v - want).abs());
                        assert!(
                            error <= bound,
                            "n {n}, pixel ({i}, {j}): {v} vs literal {want} (bound {bound})"
                        );
                        inside += 1;
                    }
                }
            }
        }
        (inside, outside)
    }

    #[test]
    fn the_warp_agrees_with_the_literal_formula_at_every_size() {
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        // sizes around the vector width and the suite's 96
        for (n, fov) in [
            (1, 60.0),
            (2, 90.0),
            (7, 60.0),
            (63, 45.0),
            (64, 60.0),
            (96, 60.0),
            (130, 100.0),
        ] {
            let w = Warper::new(n, fov);
            let earlier: Vec<f32> = (0..n * n).map(|_| rng.random_range(0.0..1.0f32)).collect();
            let (mut inside, mut outside) = (0, 0);
            for (r, t, ego) in cases(&mut rng) {
                let mut got = vec![0.0f32; n * n];
                w.predict(&earlier, &r, t, &ego, &mut got);
                let (a, b) = compare_with_literal(n, fov, &earlier, &r, t, &ego, &got);
                inside += a;
                outside += b;
                // every instruction-set variant gives the same bits (`predict` takes the widest
                // one the CPU has)
                let setup = w.setup(&r, t, &ego);
                let mut variants: Vec<(&str, Vec<f32>)> = vec![("generic", vec![0.0f32; n * n])];
                predict_generic(&setup, &w.rays, &earlier, |start, pred| {
                    variants[0].1[start..start + pred.len()].copy_from_slice(pred)
                });
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    let mut v = vec![0.0f32; n * n];
                    // SAFETY: the CPU supports AVX2 (checked just above).
                    unsafe {
                        predict_avx2(&setup, &w.rays, &earlier, |start, pred| {
                            v[start..start + pred.len()].copy_from_slice(pred)
                        })
                    };
                    variants.push(("avx2", v));
                }
                for (name, v) in &variants {
                    for (k, (a, g)) in got.iter().zip(v).enumerate() {
                        assert_eq!(a.to_bits(), g.to_bits(), "n {n}, pixel {k}, {name}: {g} vs {a}");
                    }
                }
                // the rows of predict_rows cover every pixel once, in order
                let mut next = 0;
                w.predict_rows(&earlier, &r, t, &ego, |start, pred| {
                    assert_eq!(start, next);
                    assert!(start % n == 0 && pred.len() == n);
                    next += pred.len();
                });
                assert_eq!(next, n * n);
            }
            // (a 1- or 2-pixel camera is hit only by chance)
            assert!(
                n < 7 || (inside > 0 && outside > 0),
                "n {n}: the cases reach both inside and outside the frame ({inside}, {outside})"
            );
        }
    }

    #[test]
    fn without_motion_the_prediction_is_the_earlier_frame() {
        let mut rng = ChaCha8Rng::seed_from_u64(27);
        for (_, _, ego) in cases(&mut rng) {
            for (n, fov) in [(7, 60.0), (96, 60.0)] {
                let earlier: Vec<f32> = (0..n * n).map(|_| rng.random_range(0.0..1.0f32)).collect();
                let mut got = vec![0.0f32; n * n];
                Warper::new(n, fov).predict(&earlier, &rotation_matrix([0.0; 3]), [0.0; 3], &ego, &mut got);
                assert!(got.iter().zip(&earlier).all(|(a, b)| a.to_bits() == b.to_bits()));
            }
        }
    }

    #[test]
    fn the_warp_agrees_with_the_literal_formula_of_every_pixel() {
        let mut rng = ChaCha8Rng::seed_from_u64(25);
        let (n, fov) = (96, 60.0);
        let w = Warper::new(n, fov);
        let earlier: Vec<f32> = (0..n * n).map(|_| rng.random_range(0.0..1.0f32)).collect();
        let mut compared = 0;
        for (r, t, ego) in cases(&mut rng) {
            let mut got = vec![0.0f32; n * n];
            w.predict(&earlier, &r, t, &ego, &mut got);
            compared += compare_with_literal(n, fov, &earlier, &r, t, &ego, &got).0;
        }
        assert!(compared > 100_000, "compared {compared} pixels");
    }
}
