//! Frames per second of the ego-motion-compensated detectors, with a camera that moves every frame
//! (so the compensation warps on every frame):
//! - `tracker/96`: the `tracker` at 96 × 96 (the default suite's frame size);
//! - `hopfield_paper/128` vs `hopfield_compensated/128`: the Hopfield detector (fast
//!   implementation, winner readout) behind the paper and the compensated front end at n = 128.
//!
//! Input: a cycle of 32 frames of a growing checkerboard disk over a drifting grating, each with an
//! efference copy of a camera turning at 0.3 rad/s and driving at 1 m/s, 0.35 m above the ground
//! (the grating changes most pixels: the tracker's worst case). `tracker_cruise/96` runs the
//! tracker on a scene closer to the suite's: 32 frames ray-cast from a camera cruising at 1 m/s
//! over a textured ground under a plain sky, a ball approaching (few pixels change);
//! `tracker_standing/96` the same scene from a standing camera (the background-model path).
//! Throughput is one frame per iteration, so criterion reports frames/s as "elem/s".

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_detector::hopfield::{FrontEnd, Readout};
use loomlab_detector::{Detector, EfferenceCopy, Frame, Hopfield, HopfieldConfig, Registry};

mod common;
use common::{ego, frame};

/// Frame k of a camera driving at `speed` (m/s), 0.35 m above a textured ground (pitch −3°), a
/// ball of radius 0.2 m approaching from 8 m at 6 m/s, 60° field of view.
fn cruise_frame(n: usize, k: usize, speed: f64) -> Frame {
    let t = k as f64 / 120.0;
    let (cx, h) = (speed * t, 0.35);
    let ball = [8.0 - 6.0 * t, 0.2, 0.4];
    let tan = (30f64).to_radians().tan();
    let (sp, cp) = (-0.03f64).sin_cos();
    let data = (0..n * n)
        .map(|p| {
            let (i, j) = (p / n, p % n);
            let y = 1.0 - (2 * i + 1) as f64 / n as f64;
            let x = (2 * j + 1) as f64 / n as f64 - 1.0;
            // camera ray (1, −x·t, y·t) pitched by −3° into world axes
            let (dx, dy, dz0) = (1.0, -x * tan, y * tan);
            let (dx, dz) = (cp * dx - sp * dz0, sp * dx + cp * dz0);
            let o = [cx - ball[0], -ball[1], h - ball[2]];
            let b = 2.0 * (o[0] * dx + o[1] * dy + o[2] * dz);
            let c = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - 0.04;
            let a = dx * dx + dy * dy + dz * dz;
            let v = if b < 0.0 && b * b >= 4.0 * a * c {
                0.1
            } else if dz < 0.0 {
                let s = h / -dz;
                let (gx, gy) = (cx + s * dx, s * dy);
                if ((gx.floor() + gy.floor()) as i64).rem_euclid(2) == 0 {
                    0.3
                } else {
                    0.5
                }
            } else {
                0.8
            };
            v as f32
        })
        .collect();
    Frame::from_f32(n, data).expect("n*n pixels")
}

fn run(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    mut det: Box<dyn Detector>,
    n: usize,
) {
    let frames: Vec<Frame> = (0..32).map(|k| frame(n, k)).collect();
    let e = ego();
    let mut k = 0usize;
    group.bench_function(format!("{name}/{n}"), |b| {
        b.iter(|| {
            k += 1;
            black_box(
                det.step_moving(black_box(&frames[k % frames.len()]), &e)
                    .expect("same size"),
            )
        })
    });
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("compensated");
    group.throughput(Throughput::Elements(1));
    let tracker = || {
        Registry::builtin()
            .get("tracker")
            .expect("registered")
            .default_params(96)
            .expect("defaults")
            .build(96)
            .expect("builds")
    };
    run(&mut group, "tracker", tracker(), 96);
    {
        let mut det = tracker();
        let frames: Vec<Frame> = (0..32).map(|k| cruise_frame(96, k, 1.0)).collect();
        let e = EfferenceCopy {
            yaw_rate_rps: 0.0,
            rotation_rad: [0.0; 3],
            ..ego()
        };
        let mut k = 0usize;
        group.bench_function("tracker_cruise/96", |b| {
            b.iter(|| {
                k += 1;
                black_box(
                    det.step_moving(black_box(&frames[k % frames.len()]), &e)
                        .expect("same size"),
                )
            })
        });
    }
    {
        // the same scene seen by a standing camera: the tracker's background-model path
        let mut det = tracker();
        let frames: Vec<Frame> = (0..32).map(|k| cruise_frame(96, k, 0.0)).collect();
        let e = EfferenceCopy {
            forward_mps: 0.0,
            yaw_rate_rps: 0.0,
            rotation_rad: [0.0; 3],
            translation_m: [0.0; 3],
            ..ego()
        };
        let mut k = 0usize;
        group.bench_function("tracker_standing/96", |b| {
            b.iter(|| {
                k += 1;
                black_box(
                    det.step_moving(black_box(&frames[k % frames.len()]), &e)
                        .expect("same size"),
                )
            })
        });
    }
    for (name, front_end) in [
        ("hopfield_paper", FrontEnd::Paper),
        ("hopfield_compensated", FrontEnd::Compensated),
    ] {
        let cfg = HopfieldConfig {
            front_end,
            readout: Readout::Winner,
            readout_alpha: 0.5,
            ..HopfieldConfig::for_size(128)
        };
        run(&mut group, name, Box::new(Hopfield::new(cfg).expect("valid")), 128);
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
