//! Frames per second of the four baseline detectors at n = 128 and 256.
//!
//! Input: a cycle of 32 frames of a growing checkerboard disk over a drifting grating
//! (every stage of every model has work to do). Throughput is one frame per iteration,
//! so criterion reports frames/s as "elem/s".

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_detector::{BASELINE_IDS, Frame, baseline_by_id};

mod common;
use common::frame;

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
