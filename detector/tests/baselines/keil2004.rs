//! `keil2004` ("Advanced", reconstruction R-A): tests of docs/detectors.md, keil2004 §5, at n = 128.

use loomlab_detector::Detector;
use loomlab_detector::baselines::{Keil2004, Keil2004Config};

use crate::stimuli::{Id, get};
use crate::{argmax, aux, max, outputs, run};

const N: usize = 128;

fn model() -> Keil2004 {
    Keil2004::new(Keil2004Config::default()).unwrap()
}

fn z_of(id: Id) -> Vec<f64> {
    outputs(&run(&mut model(), &get(id, N)))
}

/// keil2004 §5 item 1: exactly silent on any static scene.
#[test]
fn keil2004_static_scenes_give_exactly_zero() {
    for id in [Id::Uniform, Id::S0] {
        let s = run(&mut model(), &get(id, N));
        assert!(outputs(&s).iter().all(|&z| z == 0.0), "{id:?}");
        assert!(aux(&s, "z_on").iter().chain(&aux(&s, "z_off")).all(|&z| z == 0.0));
    }
}

/// keil2004 §5 item 2: approaching checkerboard disk (S2) — late, strong peak.
#[test]
fn keil2004_approach_peaks_at_the_end() {
    let z = z_of(Id::S2);
    let t = z.len();
    let early = max(&z[5..t / 2]);
    println!(
        "keil2004 S2: argmax {} of {t}, max {:.3e}, max early {early:.3e}",
        argmax(&z),
        max(&z)
    );
    assert!(argmax(&z) >= t - 5, "argmax {}", argmax(&z));
    assert!(max(&z) >= 100.0 * early);
    // Prototype values (keil2004 §5 item 2): max 2.15e−2, early max 3e−7.
    assert!((max(&z) / 2.15e-2 - 1.0).abs() < 0.01, "max {}", max(&z));
    assert!((2e-7..4e-7).contains(&early), "early {early}");
    // Rising over the final phase.
    assert!(z[t - 5] > z[t - 15] && z[t - 15] > z[t - 25]);
}

/// keil2004 §5 item 3: receding checkerboard disk (S3) — response only at the start.
#[test]
fn keil2004_receding_disk_responds_only_at_the_start() {
    let z = z_of(Id::S3);
    let t = z.len();
    let late = max(&z[3 * t / 4..]);
    println!(
        "keil2004 S3: argmax {}, max {:.3e}, late max {late:.3e}",
        argmax(&z),
        max(&z)
    );
    assert!(argmax(&z) <= 5);
    assert!(late <= 1e-3 * max(&z));
}

/// keil2004 §5 item 4: a uniform dark disk on white has no ON contrast; only the ε term responds.
#[test]
fn keil2004_single_polarity_uses_only_the_epsilon_term() {
    let s = run(&mut model(), &get(Id::S1, N));
    let (z, z_on, z_off) = (outputs(&s), aux(&s, "z_on"), aux(&s, "z_off"));
    assert!(z_on.iter().all(|&v| v == 0.0));
    let eps = Keil2004Config::default().epsilon;
    assert!(z.iter().all(|&v| v <= eps * max(&z_off) * (1.0 + 1e-12)));
    let s2 = max(&z_of(Id::S2));
    println!(
        "keil2004 S1 max {:.3e} vs S2 max {s2:.3e} (ratio {:.1})",
        max(&z),
        s2 / max(&z)
    );
    assert!(max(&z) * 50.0 <= s2);
    // Prototype (keil2004 §5 item 4): 2.1e−4.
    assert!((max(&z) / 2.1e-4 - 1.0).abs() < 0.02, "max {}", max(&z));
}

/// keil2004 §5 item 5: onset burst to a drifting grating (S6), then adaptation.
#[test]
fn keil2004_adapts_to_background_motion() {
    let z = z_of(Id::S6);
    println!("keil2004 S6: argmax {}, z(40)/max = {:.3}", argmax(&z), z[40] / max(&z));
    assert!(argmax(&z) <= 3);
    assert!(z[40] <= 0.35 * max(&z));
    // Prototype ratio 0.23.
    assert!((z[40] / max(&z) - 0.23).abs() < 0.01);
}

/// keil2004 §5 item 6: approach over the drifting grating (S7) still rises strongly at the end.
#[test]
fn keil2004_detects_approach_over_drifting_grating() {
    let z = z_of(Id::S7);
    let t = z.len();
    let ratio = max(&z[t - 5..]) / z[t / 2];
    println!("keil2004 S7: max(last 5)/z(T/2) = {ratio:.1}");
    assert!(ratio >= 10.0);
    // Prototype ≈ 39.
    assert!((ratio - 39.0).abs() < 1.5);
}

/// keil2004 §5 (last paragraph) and §6: the lateral (diffusion) part reduces the response to a translating disk.
#[test]
fn keil2004_diffusion_reduces_translation_response() {
    let frames = get(Id::S5, N);
    let with: f64 = outputs(&run(&mut model(), &frames)).iter().sum();
    let cfg = Keil2004Config {
        iterations: 0,
        ..Keil2004Config::default()
    };
    let without: f64 = outputs(&run(&mut Keil2004::new(cfg).unwrap(), &frames)).iter().sum();
    println!(
        "keil2004 S5 total response: K=10 {with:.3e}, K=0 {without:.3e} ({:.0} % less)",
        100.0 * (1.0 - with / without)
    );
    assert!(with < without);
}

/// Reset returns the model to its initial state: a rerun gives identical output.
#[test]
fn keil2004_reset_reproduces_output() {
    let frames = get(Id::S7, 64);
    let mut m = model();
    let a = outputs(&run(&mut m, &frames));
    let b = outputs(&run(&mut m, &frames));
    assert_eq!(a, b);
    assert_eq!(m.id(), "keil2004");
}
