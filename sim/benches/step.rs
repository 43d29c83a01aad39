//! A full simulator step (physics + ground truth + render + readback) at n = 64, 128, 256 on whatever
//! adapter is found (lavapipe in CI; `LOOMLAB_ADAPTER=llvmpipe` forces it), and a physics-only step.
//!
//! Run: `cargo bench -p loomlab-sim --bench step`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use loomlab_sim::{Command, GpuContext, Sim, WorldDesc};

fn bench_step(c: &mut Criterion) {
    let ctx = GpuContext::new().expect("a GPU adapter (apt-get install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.describe());
    let mut group = c.benchmark_group("step");
    for n in [64u32, 128, 256] {
        let mut desc = WorldDesc::default();
        desc.camera.n = n;
        let mut sim = Sim::with_context(&desc, 1, ctx.clone()).expect("sim");
        let cmd = Command::forward(0.5);
        group.bench_function(format!("render_n{n}"), |b| {
            b.iter(|| {
                if sim.time() > 20.0 {
                    sim.reset(&desc, 1).unwrap();
                }
                black_box(sim.step(&cmd).unwrap());
            })
        });
    }
    let desc = WorldDesc::default();
    let mut sim = Sim::new_physics_only(&desc, 1).unwrap();
    group.bench_function("physics_only", |b| {
        b.iter(|| {
            if sim.time() > 20.0 {
                sim.reset(&desc, 1).unwrap();
            }
            black_box(sim.step(&Command::forward(0.5)).unwrap());
        })
    });
    group.finish();
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
