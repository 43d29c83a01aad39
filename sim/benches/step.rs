//! A full simulator step (physics + ground truth + render + readback) at n = 64, 128, 256 on whatever
//! adapter is found (lavapipe in CI; `LOOMLAB_ADAPTER=llvmpipe` forces it), and a physics-only step.
//!
//! `batch/n{N}_b{B}`: B simulators stepped in lockstep, their B views rendered in one submission
//! (`Sim::step_batch`), B = 1, 4, 16, 64 at n = 64 and 128; throughput in steps (views) per second.
//!
//! Run: `cargo bench -p loomlab-sim --bench step`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_sim::{Command, GpuContext, Renderer, Sim, WorldDesc};

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

fn bench_batch(c: &mut Criterion) {
    let ctx = GpuContext::new().expect("a GPU adapter (apt-get install mesa-vulkan-drivers)");
    let mut group = c.benchmark_group("batch");
    let cmd = Command::forward(0.5);
    for n in [64u32, 128] {
        let mut desc = WorldDesc::default();
        desc.camera.n = n;
        let mut renderer = Renderer::with_context(ctx.clone(), n).expect("renderer");
        for b in [1usize, 4, 16, 64] {
            let mut sims: Vec<Sim> = (0..b)
                .map(|i| Sim::new_physics_only(&desc, i as u64).expect("sim"))
                .collect();
            let commands = vec![cmd; b];
            group.throughput(Throughput::Elements(b as u64));
            group.bench_function(format!("n{n}_b{b}"), |bench| {
                bench.iter(|| {
                    for (i, sim) in sims.iter_mut().enumerate() {
                        if sim.time() > 20.0 {
                            sim.reset(&desc, i as u64).unwrap();
                        }
                    }
                    let mut refs: Vec<&mut Sim> = sims.iter_mut().collect();
                    black_box(Sim::step_batch(&mut refs, &commands, &mut renderer).unwrap());
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_step, bench_batch);
criterion_main!(benches);
