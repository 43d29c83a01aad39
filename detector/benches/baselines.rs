//! Frames per second of the four baseline detectors at n = 128 and 256.
//!
//! Input: a cycle of 32 frames of a growing checkerboard disk over a drifting grating
//! (every stage of every model has work to do). Throughput is one frame per iteration,
//! so criterion reports frames/s as "elem/s".

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_detector::{BASELINE_IDS, Frame, baseline_by_id};

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

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("baselines");
    group.throughput(Throughput::Elements(1));
    for n in [128usize, 256] {
        let frames: Vec<Frame> = (0..32).map(|k| frame(n, k)).collect();
        for id in BASELINE_IDS {
            let mut det = baseline_by_id(id).expect("baseline id");
            let mut k = 0usize;
            group.bench_function(format!("{id}/{n}"), |b| {
                b.iter(|| {
                    k += 1;
                    black_box(det.step(black_box(&frames[k % frames.len()])).expect("same size"))
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
