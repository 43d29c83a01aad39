//! Frames per second of the `tracker` following one and three objects at once, at 96 × 96 (the
//! default suite's frame size), the camera standing (the background-model path):
//! - `tracker_objects/96/1`: one disc drifting sideways and growing;
//! - `tracker_objects/96/3`: three discs at once, two of them crossing each other's path.
//!
//! Input: a cycle of 240 frames (2 s at 120 Hz) that runs forth and back again (frame k and frame
//! 479 − k are equal), so the tracks live on across the cycle; discs of luminance 0.1, 0.9 and 0.3
//! on a uniform 0.6 background. Throughput is one frame per iteration, so criterion reports
//! frames/s as "elem/s".

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_detector::{EfferenceCopy, Frame, Registry};

const N: usize = 96;
const CYCLE: usize = 240;

/// The discs of frame k (of a cycle of `CYCLE` frames): `(centre [row, column], radius, value)`
/// in pixels, the first `count` of three.
fn discs(k: usize, count: usize) -> Vec<([f64; 2], f64, f32)> {
    let u = k as f64 / CYCLE as f64;
    let all = [
        ([40.0, 20.0 + 50.0 * u], 4.0 + 6.0 * u, 0.1),
        ([62.0, 76.0 - 50.0 * u], 5.0 + 3.0 * u, 0.9),
        ([20.0 + 30.0 * u, 70.0], 3.0 + 2.0 * u, 0.3),
    ];
    all[..count].to_vec()
}

fn frame(k: usize, count: usize) -> Frame {
    let d = discs(k, count);
    let data = (0..N * N)
        .map(|p| {
            let (i, j) = ((p / N) as f64 + 0.5, (p % N) as f64 + 0.5);
            d.iter()
                .find(|([ci, cj], r, _)| (i - ci).powi(2) + (j - cj).powi(2) <= r * r)
                .map_or(0.6, |d| d.2)
        })
        .collect();
    Frame::from_f32(N, data).expect("n*n pixels")
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("tracker_objects");
    group.throughput(Throughput::Elements(1));
    let standing = EfferenceCopy {
        dt_s: 1.0 / 120.0,
        height_m: 0.35,
        ..EfferenceCopy::default()
    };
    for count in [1, 3] {
        let mut det = Registry::builtin()
            .get("tracker")
            .expect("registered")
            .default_params(N)
            .expect("defaults")
            .build(N)
            .expect("builds");
        // forth and back: no jump at the cycle's end
        let frames: Vec<Frame> = (0..2 * CYCLE)
            .map(|k| frame(if k < CYCLE { k } else { 2 * CYCLE - 1 - k }, count))
            .collect();
        let mut k = 0usize;
        group.bench_function(format!("{N}/{count}"), |b| {
            b.iter(|| {
                k += 1;
                black_box(
                    det.step_moving(black_box(&frames[k % frames.len()]), &standing)
                        .expect("same size"),
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
