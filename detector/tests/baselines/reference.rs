//! Literal per-pixel ports of the per-frame algorithms of docs/detectors.md, keil2004 §2,
//! cizek2019 §2 and fu2020 §2 / `lgmd2OpenSource.cs`: clamped indices, no buffers
//! reused, no fused passes. The optimised models must agree with them bit for bit, which
//! shows that the row-slice stencils and fused loops do not change any result.

use loomlab_detector::Frame;
use loomlab_detector::baselines::{Cizek2019, Cizek2019Config, Fu2020, Fu2020Config, Keil2004, Keil2004Config};

use crate::stimuli::{Id, get};
use crate::{aux, outputs, run};

fn at(a: &[f64], n: usize, i: isize, j: isize) -> f64 {
    let c = |x: isize| x.clamp(0, n as isize - 1) as usize;
    a[c(i) * n + c(j)]
}

fn to64(f: &Frame) -> Vec<f64> {
    f.data().iter().map(|&v| f64::from(v)).collect()
}

fn keil2004_reference(frames: &[Frame], cfg: Keil2004Config) -> Vec<(f64, f64, f64)> {
    let n = frames[0].n();
    let mut prev = to64(&frames[0]);
    let mut v = [vec![0.0; n * n], vec![0.0; n * n]];
    let mut z = 0.0;
    let mut out = vec![(0.0, 0.0, 0.0)];
    for f in &frames[1..] {
        let cur = to64(f);
        let p: Vec<f64> = cur.iter().zip(&prev).map(|(a, b)| a - b).collect();
        prev = cur;
        let mut zc = [0.0; 2];
        for (c, sign) in [1.0, -1.0].into_iter().enumerate() {
            let x: Vec<f64> = p
                .iter()
                .zip(&v[c])
                .map(|(&p, &vv)| ((sign * p).max(0.0) - vv).max(0.0))
                .collect();
            let mut u = x.clone();
            for _ in 0..cfg.iterations {
                let mut next = vec![0.0; n * n];
                for i in 0..n as isize {
                    for j in 0..n as isize {
                        let cc = at(&u, n, i, j);
                        let lap = at(&u, n, i - 1, j) + at(&u, n, i + 1, j) + at(&u, n, i, j - 1) + at(&u, n, i, j + 1)
                            - 4.0 * cc;
                        next[i as usize * n + j as usize] = cc + cfg.kappa * lap;
                    }
                }
                u = next;
            }
            for (vv, uu) in v[c].iter_mut().zip(&u) {
                *vv = cfg.a_v * *vv + cfg.b * uu;
            }
            zc[c] = x.iter().sum::<f64>() / (n * n) as f64;
        }
        z = cfg.alpha * z + (1.0 - cfg.alpha) * (zc[0] * zc[1] + cfg.epsilon * (zc[0] + zc[1]));
        out.push((z, zc[0], zc[1]));
    }
    out
}

fn cizek2019_reference(frames: &[Frame], cfg: Cizek2019Config) -> Vec<f64> {
    let n = frames[0].n();
    let w = [[0.125, 0.25, 0.125], [0.25, 0.0, 0.25], [0.125, 0.25, 0.125]];
    let mut prev = to64(&frames[0]);
    let mut p_prev = vec![0.0; n * n];
    let (mut ts, mut tl) = (0.0, 0.0);
    let mut out = vec![0.0];
    for f in &frames[1..] {
        let cur = to64(f);
        let p: Vec<f64> = cur.iter().zip(&prev).map(|(a, b)| a - b).collect();
        prev = cur;
        ts = cfg.alpha_s * ts + (1.0 - cfg.alpha_s) * (p.iter().map(|v| v.abs()).sum::<f64>() / (n * n) as f64);
        let mut sum = 0.0;
        for i in 0..n as isize {
            for j in 0..n as isize {
                let mut inh = 0.0;
                for di in -1..=1isize {
                    for dj in -1..=1isize {
                        inh += at(&p_prev, n, i + di, j + dj) * w[(di + 1) as usize][(dj + 1) as usize];
                    }
                }
                let mut s = p[i as usize * n + j as usize] - cfg.w_i * inh;
                if cfg.absolute_summation {
                    s = s.abs();
                }
                if s > cfg.threshold_factor * ts {
                    sum += s.abs();
                }
            }
        }
        p_prev = p;
        let z_hat = sum / (n * n) as f64;
        tl = cfg.alpha_l * tl + (1.0 - cfg.alpha_l) * z_hat;
        out.push(if z_hat > cfg.gate_factor * tl { z_hat } else { 0.0 });
    }
    out
}

/// One LGMD2 instance, structured like `LGMD2_Processing` of `lgmd2OpenSource.cs`.
struct Lgmd2Reference {
    n: usize,
    ons: [Vec<f64>; 2],
    offs: [Vec<f64>; 2],
    pm: f64,
    smp: f64,
    sfa: f64,
    t: usize,
}

impl Lgmd2Reference {
    fn new(n: usize) -> Self {
        let z = vec![0.0; n * n];
        Self {
            n,
            ons: [z.clone(), z.clone()],
            offs: [z.clone(), z],
            pm: 0.0,
            smp: 0.0,
            sfa: 0.0,
            t: 0,
        }
    }

    fn step(&mut self, p: &[f64], cfg: &Fu2020Config) -> f64 {
        let n = self.n;
        let co = cfg.coefficients();
        let (cur, pre) = ((self.t + 1) % 2, self.t % 2);
        self.t += 1;
        let mean = p.iter().map(|v| v.abs()).sum::<f64>() / (n * n) as f64;
        let pm = co.a_pm * mean + (1.0 - co.a_pm) * self.pm;
        let w_i_on = (pm / cfg.t_pm).max(cfg.w_i_on_base);
        let w_i_off = (pm / cfg.t_pm).max(cfg.w_i_off_base);
        for (idx, &q) in p.iter().enumerate() {
            let (on_p, off_p) = (self.ons[pre][idx], self.offs[pre][idx]);
            self.ons[cur][idx] = if q >= cfg.clip_point {
                q + cfg.dc * on_p
            } else {
                cfg.dc * on_p
            };
            self.offs[cur][idx] = if q < cfg.clip_point {
                q.abs() + cfg.dc * off_p
            } else {
                cfg.dc * off_p
            };
        }
        let conv = |maps: &[Vec<f64>; 2], kernel: [f64; 3], a: [f64; 3], i: isize, j: isize| {
            let mut tmp = 0.0;
            for di in -1..=1isize {
                for dj in -1..=1isize {
                    let class = if di == 0 && dj == 0 {
                        0
                    } else if di == 0 || dj == 0 {
                        1
                    } else {
                        2
                    };
                    let lp = a[class] * at(&maps[cur], n, i + di, j + dj)
                        + (1.0 - a[class]) * at(&maps[pre], n, i + di, j + dj);
                    tmp += lp * kernel[class];
                }
            }
            tmp
        };
        let s_cell = |exc: f64, inh: f64, w: f64| if exc - inh * w <= 0.0 { 0.0 } else { exc - inh * w };
        let mut scells = vec![0.0; n * n];
        for i in 0..n as isize {
            for j in 0..n as isize {
                let idx = i as usize * n + j as usize;
                let s_on = s_cell(
                    self.ons[cur][idx],
                    conv(&self.ons, cfg.kernel_on, co.a_on, i, j),
                    w_i_on,
                );
                let s_off = s_cell(
                    self.offs[cur][idx],
                    conv(&self.offs, cfg.kernel_off, co.a_off, i, j),
                    w_i_off,
                );
                scells[idx] = cfg.w_on * s_on + cfg.w_off * s_off + cfg.w_onoff * s_on * s_off;
            }
        }
        let mut gcells = vec![0.0; n * n];
        let mut max = 0.0f64;
        for i in 0..n as isize {
            for j in 0..n as isize {
                let mut tmp = 0.0;
                for di in -1..=1isize {
                    for dj in -1..=1isize {
                        tmp += at(&scells, n, i + di, j + dj) * (1.0 / 9.0);
                    }
                }
                gcells[i as usize * n + j as usize] = tmp;
                max = max.max(tmp.abs());
            }
        }
        let omega = cfg.delta_c + max / cfg.c_w;
        let mut mp = 0.0;
        for idx in 0..n * n {
            let g = scells[idx] * gcells[idx] / omega;
            if g * cfg.c_de >= cfg.t_de {
                mp += g;
            }
        }
        let smp = 1.0 / (1.0 + (-mp / ((n * n) as f64 * cfg.c_sig)).exp());
        let diff = smp - self.smp;
        let sfa = if diff <= cfg.t_sfa {
            co.h_sfa * (self.sfa + diff)
        } else {
            co.h_sfa * smp
        };
        let sfa = if sfa < 0.5 { 0.5 } else { sfa };
        self.pm = pm;
        self.smp = smp;
        self.sfa = sfa;
        (cfg.c_spi * (sfa - cfg.t_sp)).exp().floor()
    }
}

fn fu2020_reference(frames: &[Frame], cfg: Fu2020Config) -> Vec<(f64, f64, f64)> {
    let n = frames[0].n();
    let (mut on, mut off) = (Lgmd2Reference::new(n), Lgmd2Reference::new(n));
    let mut prev = to64(&frames[0]);
    let mut z = 0.0;
    let mut out = vec![(0.0, 0.0, 0.0)];
    for f in &frames[1..] {
        let cur = to64(f);
        let p: Vec<f64> = cur
            .iter()
            .zip(&prev)
            .map(|(a, b)| cfg.contrast_scale * (a - b))
            .collect();
        prev = cur;
        let neg: Vec<f64> = p.iter().map(|v| -v).collect();
        let z_off = off.step(&p, &cfg);
        let z_on = on.step(&neg, &cfg);
        z = cfg.alpha * z + (1.0 - cfg.alpha) * (z_on * z_off + cfg.epsilon * (z_on + z_off));
        out.push((z, z_on, z_off));
    }
    out
}

/// A short random video (values in [0, 1]) of size n: exercises every border case.
fn random_video(n: usize, len: usize) -> Vec<Frame> {
    let mut s = 12345u64 + n as u64;
    (0..len)
        .map(|_| {
            let data = (0..n * n)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    (s >> 40) as f32 / (1u64 << 24) as f32
                })
                .collect();
            Frame::from_f32(n, data).unwrap()
        })
        .collect()
}

fn videos() -> Vec<(String, Vec<Frame>)> {
    let mut v: Vec<(String, Vec<Frame>)> = [1usize, 2, 3, 5]
        .iter()
        .map(|&n| (format!("random n={n}"), random_video(n, 12)))
        .collect();
    v.push(("S7 n=64".into(), get(Id::S7, 64).to_vec()));
    v.push(("S5 n=64".into(), get(Id::S5, 64).to_vec()));
    v
}

#[test]
fn keil2004_equals_literal_reference_bitwise() {
    let cfg = Keil2004Config::default();
    for (name, frames) in videos() {
        let s = run(&mut Keil2004::new(cfg).unwrap(), &frames);
        let want = keil2004_reference(&frames, cfg);
        let got: Vec<_> = outputs(&s)
            .into_iter()
            .zip(aux(&s, "z_on"))
            .zip(aux(&s, "z_off"))
            .map(|((a, b), c)| (a, b, c))
            .collect();
        assert_eq!(got, want, "{name}");
    }
}

#[test]
fn cizek2019_equals_literal_reference_bitwise() {
    for absolute_summation in [false, true] {
        let cfg = Cizek2019Config {
            absolute_summation,
            ..Cizek2019Config::default()
        };
        for (name, frames) in videos() {
            let got = outputs(&run(&mut Cizek2019::new(cfg).unwrap(), &frames));
            assert_eq!(got, cizek2019_reference(&frames, cfg), "{name} {cfg:?}");
        }
    }
}

#[test]
fn fu2020_equals_literal_reference_bitwise() {
    let cfg = Fu2020Config::default();
    for (name, frames) in videos() {
        let s = run(&mut Fu2020::new(cfg).unwrap(), &frames);
        let got: Vec<_> = outputs(&s)
            .into_iter()
            .zip(aux(&s, "z_on"))
            .zip(aux(&s, "z_off"))
            .map(|((a, b), c)| (a, b, c))
            .collect();
        assert_eq!(got, fu2020_reference(&frames, cfg), "{name}");
    }
}
