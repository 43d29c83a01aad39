//! Rendering speed of the analytic stimuli at the paper's n = 256.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use loomlab_detector::stimulus::{BackgroundKind, StimulusSpec, Texture};

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("stimulus_render_256");
    let cases = [
        ("uniform_disk_uniform_bg", Texture::Uniform, BackgroundKind::Uniform),
        ("grating_disk_grating_bg", Texture::Grating, BackgroundKind::Grating),
        (
            "starburst_disk_rotating_bg",
            Texture::Starburst,
            BackgroundKind::RotatingGrating,
        ),
        ("noise_disk_noise_bg", Texture::Noise, BackgroundKind::Noise),
    ];
    for (name, texture, kind) in cases {
        let mut spec = StimulusSpec::default();
        spec.object.texture = texture;
        spec.background.kind = kind;
        // Frame 80: the object covers about half the frame.
        group.bench_function(name, |b| b.iter(|| black_box(spec.render_frame(black_box(80)))));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
