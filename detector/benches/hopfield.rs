//! Frames per second of the Hopfield detector, fast and reference implementations, at
//! n = 64, 128 and 256 (`cargo bench -p loomlab-detector --bench hopfield`), and of the fast
//! implementation with the adapted front end and winner readout (`fast_adapted/<n>`; it should
//! cost less than 10 % over `fast/<n>`).
//!
//! Input: the last 24 frames of the paper's Fig. 3a stimulus (striped disk over a drifting
//! horizontal grating, the hardest case for retrieval: several iterations, spurious winners),
//! fed in a loop; one iteration = one `step_hopfield` call. The reference at n = 256 uses a
//! small sample so the whole bench finishes in a few minutes.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use loomlab_detector::Frame;
use loomlab_detector::hopfield::{Hopfield, HopfieldConfig, Implementation};
use loomlab_detector::stimulus::StimulusSpec;

fn frames(n: usize) -> Vec<Frame> {
    let toml = format!(
        "[stimulus]\nsize = {n}\n[object]\ntexture = \"grating\"\n\
         [background]\nkind = \"grating\"\ncycles = 8.0\norientation_deg = 0.0\ndrift_hz = 8.0\n"
    );
    let spec = StimulusSpec::from_toml_str(&toml, Path::new("<bench>")).expect("valid stimulus");
    let count = spec.frame_count();
    (count - 24..count).map(|t| spec.render_frame(t).frame).collect()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("hopfield");
    group.throughput(Throughput::Elements(1));
    for n in [64, 128, 256] {
        let frames = frames(n);
        for implementation in [Implementation::Fast, Implementation::Reference] {
            let slow = implementation == Implementation::Reference && n >= 128;
            if slow {
                group.sample_size(10);
                group.warm_up_time(Duration::from_secs(1));
                group.measurement_time(Duration::from_secs(if n >= 256 { 8 } else { 4 }));
            } else {
                group.sample_size(50);
                group.warm_up_time(Duration::from_secs(1));
                group.measurement_time(Duration::from_secs(3));
            }
            let cfg = HopfieldConfig::for_size(n).with_implementation(implementation);
            let mut det = Hopfield::new(cfg).expect("valid config");
            let mut k = 0;
            group.bench_with_input(BenchmarkId::new(implementation.as_str(), n), &n, |b, _| {
                b.iter(|| {
                    k = (k + 1) % frames.len();
                    black_box(det.step_hopfield(black_box(&frames[k])).expect("frame size"))
                })
            });
        }
        group.sample_size(50);
        group.warm_up_time(Duration::from_secs(1));
        group.measurement_time(Duration::from_secs(3));
        let mut det = Hopfield::new(HopfieldConfig::adapted_for_size(n)).expect("valid config");
        let mut k = 0;
        group.bench_with_input(BenchmarkId::new("fast_adapted", n), &n, |b, _| {
            b.iter(|| {
                k = (k + 1) % frames.len();
                black_box(det.step_hopfield(black_box(&frames[k])).expect("frame size"))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
