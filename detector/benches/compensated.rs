//! Frames per second of the ego-motion-compensated detectors, with a camera that moves every frame
//! (so the compensation warps on every frame):
//! - `tracker/96`: the `tracker` at 96 × 96 (the default suite's frame size);
//! - `hopfield_paper/128` vs `hopfield_compensated/128`: the Hopfield detector (fast
//!   implementation, winner readout) behind the paper and the compensated front end at n = 128.
//!
//! Input: a cycle of 32 frames of a growing checkerboard disk over a drifting grating, each with an
//! efference copy of a camera turning at 0.3 rad/s and driving at 1 m/s, 0.35 m above the ground.
//! Throughput is one frame per iteration, so criterion reports frames/s as "elem/s".

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_detector::hopfield::{FrontEnd, Readout};
use loomlab_detector::{Detector, EfferenceCopy, Frame, Hopfield, HopfieldConfig, Registry};

/// Frame k of a checkerboard disk (radius growing with k) over a drifting sine grating.
fn frame(n: usize, k: usize) -> Frame {
    let c = n as f64 / 2.0;
    let r = n as f64 * (0.05 + 0.012 * k as f64);
    let data = (0..n * n)
        .map(|p| {
            let (i, j) = ((p / n) as f64 + 0.5, (p % n) as f64 + 0.5);
            let (u, v) = ((j - c) / r, (i - c) / r);
            let value = if u * u + v * v <= 1.0 {
                (((2.0 * (u + 1.0)).floor() + (2.0 * (v + 1.0)).floor()) as i64).rem_euclid(2) as f64
            } else {
                0.5 + 0.5 * (2.0 * std::f64::consts::PI * (8.0 * i / n as f64 - 8.0 * k as f64 / 120.0)).sin()
            };
            value as f32
        })
        .collect();
    Frame::from_f32(n, data).expect("n*n pixels")
}

/// The efference copy of one 120 Hz camera period of a camera turning and driving.
fn ego() -> EfferenceCopy {
    let dt = 1.0 / 120.0;
    EfferenceCopy {
        forward_mps: 1.0,
        yaw_rate_rps: 0.3,
        dt_s: dt,
        rotation_rad: [0.0, 0.0, 0.3 * dt],
        translation_m: [dt, 0.0, 0.0],
        height_m: 0.35,
        pitch_rad: -0.03,
        ..EfferenceCopy::default()
    }
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
    let tracker = Registry::builtin()
        .get("tracker")
        .expect("registered")
        .default_params(96)
        .expect("defaults")
        .build(96)
        .expect("builds");
    run(&mut group, "tracker", tracker, 96);
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
