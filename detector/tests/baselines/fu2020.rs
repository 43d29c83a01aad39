//! `fu2020` ("FuHuPe20", two LGMD2 instances): tests of docs/detectors.md, fu2020 §5, at n = 128.

use loomlab_detector::Detector;
use loomlab_detector::baselines::{Fu2020, Fu2020Config};

use crate::stimuli::{Id, get};
use crate::{argmax, aux, max, outputs, run};

const N: usize = 128;

struct Run {
    z: Vec<f64>,
    on: Vec<f64>,
    off: Vec<f64>,
}

fn run_fu(id: Id) -> Run {
    let mut m = Fu2020::new(Fu2020Config::default()).unwrap();
    let s = run(&mut m, &get(id, N));
    let r = Run {
        z: outputs(&s),
        on: aux(&s, "z_on"),
        off: aux(&s, "z_off"),
    };
    // Invariant of fu2020 §5 item 8, on every stimulus: spikes ∈ {0, 1, 2}, 0 ≤ z ≤ 4.2.
    for v in r.on.iter().chain(&r.off) {
        assert!([0.0, 1.0, 2.0].contains(v), "{id:?}: spike count {v}");
    }
    assert!(r.z.iter().all(|&z| (0.0..=4.2).contains(&z)), "{id:?}");
    r
}

fn first_spike(s: &[f64]) -> Option<usize> {
    s.iter().position(|&v| v > 0.0)
}

fn spike_string(s: &[f64]) -> String {
    s.iter().map(|&v| char::from(b'0' + v as u8)).collect()
}

#[test]
fn fu2020_coefficients_match_the_spec_table() {
    let c = Fu2020Config::default().coefficients();
    let close = |a: f64, b: f64| (a - b).abs() < 5e-7;
    assert!(close(c.frame_interval_ms, 1000.0 / 120.0));
    for (got, want) in c.a_on.iter().zip([0.357143, 0.217391, 0.156250]) {
        assert!(close(*got, want), "{got} {want}");
    }
    for (got, want) in c.a_off.iter().zip([0.121951, 0.064935, 0.044248]) {
        assert!(close(*got, want), "{got} {want}");
    }
    assert!(close(c.a_pm, 0.084746) && close(c.h_sfa, 0.989691));
    // C# integer division: Δt = 8 ms.
    let c = Fu2020Config {
        integer_frame_interval: true,
        ..Fu2020Config::default()
    }
    .coefficients();
    assert_eq!(c.frame_interval_ms, 8.0);
    for (got, want) in c.a_on.iter().zip([0.347826, 0.210526, 0.150943]) {
        assert!(close(*got, want), "{got} {want}");
    }
    for (got, want) in c.a_off.iter().zip([0.117647, 0.0625, 0.042553]) {
        assert!(close(*got, want), "{got} {want}");
    }
    assert!(close(c.a_pm, 0.081633) && close(c.h_sfa, 0.990099));
}

/// fu2020 §5 item 1: static scenes — no spikes, z = 0.
#[test]
fn fu2020_static_scenes_give_no_spikes() {
    for id in [Id::Uniform, Id::S0] {
        let r = run_fu(id);
        assert!(r.z.iter().chain(&r.on).chain(&r.off).all(|&v| v == 0.0), "{id:?}");
    }
}

/// fu2020 §5 item 2: dark disk on white (S1) — only the OFF instance spikes, late.
#[test]
fn fu2020_dark_approach_drives_only_the_off_instance() {
    let r = run_fu(Id::S1);
    let t = r.z.len();
    println!(
        "fu2020 S1: first OFF spike t = {:?} of {t}; spikes t=68..: {}; max z {:.4}",
        first_spike(&r.off),
        spike_string(&r.off[68.min(t)..]),
        max(&r.z)
    );
    assert!(r.on.iter().all(|&v| v == 0.0));
    let first = first_spike(&r.off).expect("OFF spikes");
    assert!(first as f64 >= 0.7 * t as f64, "first spike {first}");
    assert!(r.off[3 * t / 4..].iter().any(|&v| v >= 1.0));
    assert!(max(&r.z) <= 0.1);
    // Prototype at n = 128 (fu2020 §5 item 2): first spike t = 68, then exactly these counts, max z 0.085.
    assert_eq!(first, 68);
    assert_eq!(spike_string(&r.off[68..]), "111112222211111110");
    assert!((max(&r.z) - 0.085).abs() < 0.001, "max z {}", max(&r.z));
}

/// fu2020 §5 item 3: light disk on black (S1') — mirror image.
#[test]
fn fu2020_light_approach_drives_only_the_on_instance() {
    let r = run_fu(Id::S1Light);
    let t = r.z.len();
    println!(
        "fu2020 S1': first ON spike t = {:?}; max z {:.4}",
        first_spike(&r.on),
        max(&r.z)
    );
    assert!(r.off.iter().all(|&v| v == 0.0));
    let first = first_spike(&r.on).expect("ON spikes");
    assert!(first as f64 >= 0.7 * t as f64, "first spike {first}");
    assert!(r.on[3 * t / 4..].iter().any(|&v| v >= 1.0));
    assert!(max(&r.z) <= 0.1);
}

/// fu2020 §5 item 4: checkerboard disk (S2) — both instances spike in the final phase, product term active.
#[test]
fn fu2020_checker_approach_drives_both_instances() {
    let r = run_fu(Id::S2);
    let t = r.z.len();
    let (f_on, f_off) = (
        first_spike(&r.on).expect("ON spikes"),
        first_spike(&r.off).expect("OFF spikes"),
    );
    println!(
        "fu2020 S2: first spikes on {f_on} off {f_off} of {t}; max z {:.3} at t = {}",
        max(&r.z),
        argmax(&r.z)
    );
    assert!(f_on as f64 >= 0.8 * t as f64 && f_off as f64 >= 0.8 * t as f64);
    assert!(max(&r.z) > 1.0);
    // Prototype: max z 3.57 at t = 81.
    assert!(
        (max(&r.z) - 3.57).abs() < 0.01 && argmax(&r.z) == 81,
        "{} at {}",
        max(&r.z),
        argmax(&r.z)
    );
}

/// fu2020 §5 item 5: receding checkerboard disk (S3) — spikes only at the start.
#[test]
fn fu2020_receding_disk_spikes_only_at_the_start() {
    let r = run_fu(Id::S3);
    let last = r.on.iter().zip(&r.off).rposition(|(a, b)| a + b > 0.0);
    println!("fu2020 S3: last spike t = {last:?}");
    assert!(last.is_none_or(|t| t <= 10));
    assert!(r.z[40..].iter().all(|&z| z < 1e-3));
}

/// fu2020 §5 item 6: drifting grating (S6) — only the onset artefact spikes.
#[test]
fn fu2020_drifting_grating_is_suppressed_after_onset() {
    let r = run_fu(Id::S6);
    println!(
        "fu2020 S6: ON {} OFF {}",
        spike_string(&r.on[..10]),
        spike_string(&r.off[..10])
    );
    assert!(r.on[5..].iter().chain(&r.off[5..]).all(|&v| v == 0.0));
    assert!(r.z[30..].iter().all(|&z| z < 0.01));
}

/// fu2020 §5 item 7: translating checkerboard disk (S5) — SFA silences it.
#[test]
fn fu2020_translation_is_silenced_by_sfa() {
    let r = run_fu(Id::S5);
    let last = r.on.iter().zip(&r.off).rposition(|(a, b)| a + b > 0.0);
    println!("fu2020 S5: last spike t = {last:?}");
    assert!(r.on[30..].iter().chain(&r.off[30..]).all(|&v| v == 0.0));
    // Prototype at n = 128: spikes at t = 1…19, then silence.
    assert_eq!(last, Some(19));
}

/// fu2020 §5 item 7 at n = 256: the relatively smaller disk never spikes; fu2020 §5 item 2 at
/// 256: the first OFF spike comes at most one frame earlier than at 128, and z_on stays 0.
#[test]
fn fu2020_at_256() {
    let mut m = Fu2020::new(Fu2020Config::default()).unwrap();
    let s = run(&mut m, &get(Id::S5, 256));
    let spikes: f64 = aux(&s, "z_on").iter().chain(&aux(&s, "z_off")).sum();
    println!("fu2020 S5 n=256: {spikes} spikes");
    assert_eq!(spikes, 0.0);
    let s = run(&mut m, &get(Id::S1, 256));
    let first = first_spike(&aux(&s, "z_off")).expect("OFF spikes");
    println!("fu2020 S1 n=256: first OFF spike t = {first}");
    assert!((67..=68).contains(&first));
    assert!(aux(&s, "z_on").iter().all(|&v| v == 0.0));
}

/// fu2020 §3 and §6: the C# integer frame interval changes at most isolated frames (none of the tests).
#[test]
fn fu2020_integer_frame_interval_gives_nearly_the_same_spikes() {
    let frames = get(Id::S2, N);
    let mut a = Fu2020::new(Fu2020Config::default()).unwrap();
    let mut b = Fu2020::new(Fu2020Config {
        integer_frame_interval: true,
        ..Fu2020Config::default()
    })
    .unwrap();
    let (sa, sb) = (run(&mut a, &frames), run(&mut b, &frames));
    let differ = aux(&sa, "z_off")
        .iter()
        .zip(aux(&sb, "z_off"))
        .filter(|(x, y)| **x != *y)
        .count();
    println!("fu2020 S2: integer Δt changes {differ} OFF spike counts");
    assert!(differ <= 2);
    assert_eq!(a.id(), "fu2020");
}
