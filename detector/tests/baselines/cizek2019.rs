//! `cizek2019` ("CizFai19"): tests of docs/detectors.md, cizek2019 §5, at n = 128.

use loomlab_detector::baselines::{Cizek2019, Cizek2019Config};
use loomlab_detector::{Detector, Frame};

use crate::stimuli::{Id, get};
use crate::{argmax, aux, max, outputs, run};

const N: usize = 128;

fn configs() -> Vec<Cizek2019Config> {
    // cizek2019 §5: the tests hold for W_I ∈ {0.3, 0.4, 0.6, 1.0} and both sign variants.
    let mut v = Vec::new();
    for w_i in [0.3, 0.4, 0.6, 1.0] {
        for absolute_summation in [false, true] {
            v.push(Cizek2019Config {
                w_i,
                absolute_summation,
                ..Cizek2019Config::default()
            });
        }
    }
    v
}

fn z_of(cfg: Cizek2019Config, id: Id) -> Vec<f64> {
    outputs(&run(&mut Cizek2019::new(cfg).unwrap(), &get(id, N)))
}

/// cizek2019 §5 item 1: static scenes give z = ẑ = 0 and T_s → 0.
#[test]
fn cizek2019_static_scenes_give_exactly_zero() {
    for id in [Id::Uniform, Id::S0] {
        let s = run(&mut Cizek2019::new(Cizek2019Config::default()).unwrap(), &get(id, N));
        assert!(
            outputs(&s)
                .iter()
                .chain(&aux(&s, "z_hat"))
                .chain(&aux(&s, "t_s"))
                .all(|&z| z == 0.0),
            "{id:?}"
        );
    }
}

/// cizek2019 §5 item 2: approaches of either polarity and the checker disk peak at the end.
#[test]
fn cizek2019_approach_either_polarity_peaks_at_the_end() {
    for cfg in configs() {
        for id in [Id::S1, Id::S1Light, Id::S2] {
            let z = z_of(cfg, id);
            let t = z.len();
            let early = max(&z[5..t / 2]);
            if cfg == Cizek2019Config::default() {
                println!(
                    "cizek2019 {id:?}: argmax {} of {t}, max {:.3e}, max early {early:.3e}",
                    argmax(&z),
                    max(&z)
                );
            }
            assert!(argmax(&z) >= t - 4, "{cfg:?} {id:?}: argmax {}", argmax(&z));
            assert!(max(&z) >= 100.0 * early, "{cfg:?} {id:?}");
        }
    }
}

/// cizek2019 §5 item 3: receding disks respond only at the start.
#[test]
fn cizek2019_receding_responds_only_at_the_start() {
    for cfg in configs() {
        for id in [Id::S3, Id::S3Dark] {
            let z = z_of(cfg, id);
            let t = z.len();
            assert!(argmax(&z) <= 5, "{cfg:?} {id:?}: argmax {}", argmax(&z));
            assert!(max(&z[3 * t / 4..]) < 0.01 * max(&z), "{cfg:?} {id:?}");
        }
    }
}

/// cizek2019 §5 item 4: a translating disk gives < 5 % of the approach maximum.
#[test]
fn cizek2019_translation_is_weak() {
    for cfg in configs() {
        let (tr, ap) = (max(&z_of(cfg, Id::S4)), max(&z_of(cfg, Id::S1)));
        if cfg == Cizek2019Config::default() {
            println!("cizek2019 S4 max {tr:.3e} vs S1 max {ap:.3e} (ratio {:.4})", tr / ap);
        }
        assert!(tr < 0.05 * ap, "{cfg:?}: {tr} vs {ap}");
    }
}

/// cizek2019 §5 item 5: a drifting grating passes at most the onset frame.
#[test]
fn cizek2019_uniform_background_motion_is_gated_out() {
    for cfg in configs() {
        let z = z_of(cfg, Id::S6);
        assert!(z[3..].iter().all(|&v| v == 0.0), "{cfg:?}: {z:?}");
    }
}

/// cizek2019 §5 item 6: approach over the drifting grating peaks in the last two frames.
#[test]
fn cizek2019_detects_approach_over_drifting_grating() {
    for cfg in configs() {
        let z = z_of(cfg, Id::S7);
        assert!(argmax(&z) >= z.len() - 2, "{cfg:?}: argmax {}", argmax(&z));
    }
}

/// cizek2019 §3: scaling the luminance by k scales z by k; the zero pattern is unchanged.
#[test]
fn cizek2019_output_scales_linearly_with_luminance() {
    let frames = get(Id::S2, 64);
    let half: Vec<Frame> = frames
        .iter()
        .map(|f| Frame::from_f32(f.n(), f.data().iter().map(|&v| v * 0.5).collect()).unwrap())
        .collect();
    let mut m = Cizek2019::new(Cizek2019Config::default()).unwrap();
    let a = outputs(&run(&mut m, &frames));
    let b = outputs(&run(&mut m, &half));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(*x == 0.0, *y == 0.0);
        assert!((0.5 * x - y).abs() <= 1e-12 * x.abs().max(1e-300), "{x} {y}");
    }
    assert_eq!(m.id(), "cizek2019");
}

/// Sign variant: absolute summation makes dark and light approaches respond alike.
#[test]
fn cizek2019_absolute_variant_is_polarity_symmetric() {
    let cfg = Cizek2019Config {
        absolute_summation: true,
        ..Cizek2019Config::default()
    };
    let (d, l) = (z_of(cfg, Id::S1), z_of(cfg, Id::S1Light));
    for (x, y) in d.iter().zip(&l) {
        assert!((x - y).abs() <= 1e-9 * x.abs().max(1e-12), "{x} {y}");
    }
}
