//! The reference test stimuli of docs/detectors.md, test-stimuli §2 (S0–S7) and the golden stimulus
//! GOLD-1 of test-stimuli §3, rendered analytically here so that these tests do not depend on the crate's
//! stimulus module.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use loomlab_detector::Frame;

/// Frames of one stimulus.
pub type Video = Arc<Vec<Frame>>;

/// Approach geometry of docs/detectors.md, test-stimuli §1: disk radius 0.25 m, 50 km/h, 10 m → 0.1 m, 120 Hz.
pub const FPS: f64 = 120.0;
const L: f64 = 0.25;
const S0: f64 = 10.0;
const S1: f64 = 0.1;

/// Speed in m/s.
fn speed() -> f64 {
    50.0 / 3.6
}

/// Number of approach frames `T = ⌊(s0 − s1)·120/v⌋ + 1` (= 86).
pub fn approach_frames() -> usize {
    ((S0 - S1) * FPS / speed()).floor() as usize + 1
}

/// Disk radius in pixels at approach frame k for frame size n (60° field of view).
pub fn approach_radius_px(n: usize, k: usize) -> f64 {
    let f = (n as f64 / 2.0) / (30f64.to_radians()).tan();
    let s = S0 - speed() * k as f64 / FPS;
    f * L / s
}

/// Disk texture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Texture {
    /// Uniform luminance.
    Uniform(f64),
    /// Two-cycle checkerboard scaled with the disk (S2).
    Checker,
}

/// Background.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Background {
    /// Uniform luminance.
    Uniform(f64),
    /// S6 drifting horizontal sine grating (frame index selects the phase).
    Grating,
}

/// S6 grating value at row i, frame k: `0.5 + 0.5 sin(2π(8·i/n − 8·k/120))`.
pub fn grating(n: usize, i: usize, k: usize) -> f64 {
    0.5 + 0.5 * (2.0 * std::f64::consts::PI * (8.0 * i as f64 / n as f64 - 8.0 * k as f64 / FPS)).sin()
}

/// One frame: a disk of radius `r` centred at `(cx, cy)` (x = column, y = row) over a
/// background, 4×4 supersampled (test-stimuli §1).
pub fn disk_frame(n: usize, cx: f64, cy: f64, r: f64, texture: Texture, bg: Background, k: usize) -> Frame {
    let mut data = vec![0f32; n * n];
    for i in 0..n {
        let bg_value = match bg {
            Background::Uniform(v) => v,
            Background::Grating => grating(n, i, k),
        };
        for j in 0..n {
            let mut acc = 0.0;
            for a in 0..4 {
                let y = i as f64 + (a as f64 + 0.5) / 4.0;
                for b in 0..4 {
                    let x = j as f64 + (b as f64 + 0.5) / 4.0;
                    let (dx, dy) = (x - cx, y - cy);
                    acc += if dx * dx + dy * dy <= r * r {
                        match texture {
                            Texture::Uniform(v) => v,
                            Texture::Checker => {
                                let (u, v) = (dx / r, dy / r);
                                (((2.0 * (u + 1.0)).floor() + (2.0 * (v + 1.0)).floor()) as i64).rem_euclid(2) as f64
                            }
                        }
                    } else {
                        bg_value
                    };
                }
            }
            data[i * n + j] = (acc / 16.0) as f32;
        }
    }
    Frame::from_f32(n, data).expect("n*n pixels")
}

/// An approach (S1, S1', S2, S7 depending on texture and background).
fn approach(n: usize, texture: Texture, bg: Background) -> Vec<Frame> {
    let c = n as f64 / 2.0;
    (0..approach_frames())
        .map(|k| disk_frame(n, c, c, approach_radius_px(n, k), texture, bg, k))
        .collect()
}

/// Stimulus ids of docs/detectors.md, test-stimuli §2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Id {
    /// Static random image, 30 frames.
    S0,
    /// Dark disk on white, approach.
    S1,
    /// Light disk on black, approach.
    S1Light,
    /// Checkerboard disk on gray, approach.
    S2,
    /// S2 reversed (receding).
    S3,
    /// S1 reversed (receding dark disk).
    S3Dark,
    /// Translating dark disk on white, r = 12 px, 45 frames.
    S4,
    /// Translating checkerboard disk on gray, r = 12 px, 45 frames.
    S5,
    /// Drifting grating, no object, 86 frames.
    S6,
    /// S2 disk over the S6 grating.
    S7,
    /// Static uniform gray, 30 frames.
    Uniform,
}

fn render(id: Id, n: usize) -> Vec<Frame> {
    let c = n as f64 / 2.0;
    match id {
        Id::S0 => {
            let mut s = 0x9e3779b97f4a7c15u64;
            let data: Vec<f32> = (0..n * n)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    (s >> 40) as f32 / (1u64 << 24) as f32
                })
                .collect();
            vec![Frame::from_f32(n, data).unwrap(); 30]
        }
        Id::Uniform => vec![Frame::uniform(n, 0.5); 30],
        Id::S1 => approach(n, Texture::Uniform(0.0), Background::Uniform(1.0)),
        Id::S1Light => approach(n, Texture::Uniform(1.0), Background::Uniform(0.0)),
        Id::S2 => approach(n, Texture::Checker, Background::Uniform(0.5)),
        Id::S3 => {
            let mut v = get(Id::S2, n).to_vec();
            v.reverse();
            v
        }
        Id::S3Dark => {
            let mut v = get(Id::S1, n).to_vec();
            v.reverse();
            v
        }
        Id::S4 => (0..45)
            .map(|k| {
                disk_frame(
                    n,
                    20.0 + 2.0 * k as f64,
                    c,
                    12.0,
                    Texture::Uniform(0.0),
                    Background::Uniform(1.0),
                    k,
                )
            })
            .collect(),
        Id::S5 => (0..45)
            .map(|k| {
                disk_frame(
                    n,
                    20.0 + 2.0 * k as f64,
                    c,
                    12.0,
                    Texture::Checker,
                    Background::Uniform(0.5),
                    k,
                )
            })
            .collect(),
        Id::S6 => (0..approach_frames())
            .map(|k| {
                let data = (0..n * n).map(|p| grating(n, p / n, k) as f32).collect();
                Frame::from_f32(n, data).unwrap()
            })
            .collect(),
        Id::S7 => approach(n, Texture::Checker, Background::Grating),
    }
}

/// The stimulus `id` at size n (rendered once per test binary and cached).
pub fn get(id: Id, n: usize) -> Video {
    static CACHE: OnceLock<Mutex<HashMap<(Id, usize), Video>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    if let Some(v) = cache.lock().unwrap().get(&(id, n)) {
        return v.clone();
    }
    // Render outside the lock (S3 recursively asks for S2).
    let v: Video = Arc::new(render(id, n));
    cache.lock().unwrap().entry((id, n)).or_insert(v).clone()
}

/// GOLD-1 of docs/detectors.md, test-stimuli §3: n = 32, 16 frames, four-quadrant checker disk on 0.5, exact (no AA).
pub fn gold1() -> Vec<Frame> {
    const R: [i64; 16] = [4, 5, 6, 7, 8, 10, 12, 14, 17, 20, 24, 29, 35, 42, 50, 60];
    let n = 32usize;
    R.iter()
        .map(|&r| {
            let mut data = vec![0.5f32; n * n];
            for i in 0..n {
                for j in 0..n {
                    let u = 2 * i as i64 + 1 - n as i64;
                    let w = 2 * j as i64 + 1 - n as i64;
                    if u * u + w * w <= r * r {
                        data[i * n + j] = if (u > 0) != (w > 0) { 1.0 } else { 0.0 };
                    }
                }
            }
            Frame::from_f32(n, data).unwrap()
        })
        .collect()
}
