//! Cost per frame of the Hopfield detector (fast, winner readout) behind the paper and the
//! compensated front end, and of the compensation's warp alone, at n = 128 on the input of
//! `benches/compensated.rs` (a growing checkerboard disk over a drifting grating, a camera turning
//! at 0.3 rad/s and driving at 1 m/s). Prints the best of many 20-frame windows, which is steadier
//! than a mean on a shared machine (the two front ends' windows alternate), and their ratio:
//!
//! `cargo run --profile release -p loomlab-detector --example front_end_cost [paper|compensated|warp] [FRAMES]`
use loomlab_detector::hopfield::{FrontEnd, Readout};
use loomlab_detector::{Detector, Frame, Hopfield, HopfieldConfig};
use std::hint::black_box;

#[path = "../benches/common/mod.rs"]
mod common;
use common::{ego, frame};

fn main() {
    let which = std::env::args().nth(1).unwrap_or_default();
    let iters: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse().expect("FRAMES must be a whole number"))
        .unwrap_or(3000);
    let n = 128;
    let e = ego();
    let frames: Vec<Frame> = (0..32).map(|k| frame(n, k)).collect();
    let detector = |front_end| {
        let cfg = HopfieldConfig {
            front_end,
            readout: Readout::Winner,
            readout_alpha: 0.5,
            ..HopfieldConfig::for_size(n)
        };
        Hopfield::new(cfg).unwrap()
    };
    let mut runs: Vec<(&str, Hopfield, f64)> = [("paper", FrontEnd::Paper), ("compensated", FrontEnd::Compensated)]
        .into_iter()
        .filter(|(name, _)| which.is_empty() || which == *name)
        .map(|(name, front_end)| (name, detector(front_end), f64::INFINITY))
        .collect();
    // windows of the two front ends alternate, so that a machine whose speed drifts (a shared
    // one) slows both alike
    for _rep in 0..iters / 20 {
        for (_, d, best) in &mut runs {
            let t0 = std::time::Instant::now();
            for k in 0..20 {
                black_box(d.step_moving(&frames[k % 32], &e).unwrap());
            }
            *best = best.min(t0.elapsed().as_secs_f64() / 20.0);
        }
    }
    for (name, _, best) in &runs {
        println!("{name}: best {:.1} µs", best * 1e6);
    }
    if let [(_, _, paper), (_, _, compensated)] = runs[..] {
        println!("compensated / paper: {:.2}", compensated / paper);
    }
    if which.is_empty() || which == "warp" {
        let w = loomlab_detector::compensation::Warper::new(n, 60.0);
        let r = loomlab_detector::compensation::rotation_matrix(e.rotation_rad);
        let mut out = vec![0.0f32; n * n];
        let mut best = f64::INFINITY;
        for _rep in 0..iters / 20 {
            let t0 = std::time::Instant::now();
            for k in 0..20 {
                w.predict(frames[k % 32].data(), &r, e.translation_m, &e, &mut out);
                black_box(&out);
            }
            best = best.min(t0.elapsed().as_secs_f64() / 20.0);
        }
        println!("warp: best {:.1} µs", best * 1e6);
    }
}
