//! The Hopfield detector in a cluttered scene: a dark disk approaching in front of static,
//! high-contrast clutter (a checkerboard ground and a horizontal-grating backdrop), filmed at
//! 30 frames/s with a 60° field of view and 8-bit luminance — the situation of a robot camera
//! in a rendered world, where the paper front end stays silent for most of the approach.
//!
//! Set `HOPFIELD_TRACE=1` to print the per-frame responses.
//!
//! What these tests pin down:
//! - Paper front end: the static clutter's edges dominate the unit query and the delayed
//!   frame matches them almost perfectly, so z stays at 1 until the disk is large.
//! - Adapted front end (temporal high-pass): the clutter fades from the query, z leaves its
//!   rest state while the disk is still small, and the winner readout's θ̂ follows the true θ.

use loomlab_detector::Frame;
use loomlab_detector::hopfield::{FrontEnd, Hopfield, HopfieldConfig, HopfieldSignals, Implementation};

const FPS: f64 = 30.0;
const FOV_DEG: f64 = 60.0;
/// Disk diameter (m), start distance (m), end distance (m) and speed (m/s).
const DIAMETER_M: f64 = 0.5;
const START_M: f64 = 12.0;
const END_M: f64 = 0.42;
const SPEED_MPS: f64 = 4.0;

/// True angular size (degrees) of the disk at frame t.
fn theta_deg(t: usize) -> f64 {
    let d = START_M - SPEED_MPS * t as f64 / FPS;
    2.0 * (0.5 * DIAMETER_M / d).atan().to_degrees()
}

fn frame_count() -> usize {
    ((START_M - END_M) / SPEED_MPS * FPS).floor() as usize + 1
}

/// Static clutter at pixel-plane position (x right, y down, in pixels from the top left).
fn background(n: usize, x: f64, y: f64) -> f64 {
    let nf = n as f64;
    let cell = nf / 20.0;
    if y > 0.55 * nf {
        // Ground: checkerboard of 0.15 / 0.85.
        let (cx, cy) = ((x / cell).floor() as i64, ((y - 0.55 * nf) / cell).floor() as i64);
        if (cx + cy).rem_euclid(2) == 0 { 0.85 } else { 0.15 }
    } else {
        // Backdrop: horizontal square-wave grating 0.3 / 0.75 with a few vertical posts.
        let stripes = if ((y / (0.8 * cell)).floor() as i64).rem_euclid(2) == 0 {
            0.75
        } else {
            0.3
        };
        let post = ((x / (3.3 * cell)).floor() as i64).rem_euclid(3) == 0 && (x / (3.3 * cell)).fract() < 0.25;
        if post { 0.05 } else { stripes }
    }
}

/// Frame t of the approach at side n: the disk (luminance 0.05, centred) over the clutter,
/// 4×4 supersampled, quantised to 8 bits.
fn render(n: usize, t: usize) -> Frame {
    let f = n as f64 / 2.0 / (FOV_DEG / 2.0).to_radians().tan();
    let r = f * (theta_deg(t) / 2.0).to_radians().tan();
    let c = n as f64 / 2.0;
    const SS: usize = 4;
    let data = (0..n * n)
        .map(|k| {
            let (i, j) = (k / n, k % n);
            let mut acc = 0.0;
            for a in 0..SS {
                for b in 0..SS {
                    let y = i as f64 + (a as f64 + 0.5) / SS as f64;
                    let x = j as f64 + (b as f64 + 0.5) / SS as f64;
                    acc += if (x - c).powi(2) + (y - c).powi(2) <= r * r {
                        0.05
                    } else {
                        background(n, x, y)
                    };
                }
            }
            ((acc / (SS * SS) as f64 * 255.0).round() / 255.0) as f32
        })
        .collect();
    Frame::from_f32(n, data).expect("square frame")
}

fn video(n: usize) -> Vec<Frame> {
    (0..frame_count()).map(|t| render(n, t)).collect()
}

fn run(cfg: HopfieldConfig, frames: &[Frame], label: &str) -> Vec<HopfieldSignals> {
    let mut det = Hopfield::new(cfg).expect("valid config");
    let out: Vec<HopfieldSignals> = frames.iter().map(|f| det.step_hopfield(f).expect("size")).collect();
    if std::env::var_os("HOPFIELD_TRACE").is_some() {
        println!("--- {label}");
        for (t, s) in out.iter().enumerate() {
            println!(
                "{t:3} θ={:6.2}° z={:9.2} on={:6.2} off={:6.2} win=({:3},{:3}) θ̂={:5.1}° it=({},{})",
                theta_deg(t),
                s.z,
                s.z_on,
                s.z_off,
                s.winner_on,
                s.winner_off,
                s.angular_size_deg,
                s.iterations_on,
                s.iterations_off
            );
        }
    }
    out
}

/// True θ at the first frame where z leaves its rest value 1.
fn onset_deg(s: &[HopfieldSignals]) -> Option<f64> {
    s.iter().position(|s| s.z > 1.0 + 1e-9).map(theta_deg)
}

/// Median of |θ̂ − θ|/θ over the frames with θ in [lo, hi] degrees.
fn median_rel_error(s: &[HopfieldSignals], lo: f64, hi: f64) -> f64 {
    let mut e: Vec<f64> = (0..s.len())
        .filter(|&t| (lo..=hi).contains(&theta_deg(t)))
        .map(|t| (s[t].angular_size_deg - theta_deg(t)).abs() / theta_deg(t))
        .collect();
    e.sort_by(f64::total_cmp);
    e[e.len() / 2]
}

fn configs(n: usize) -> (HopfieldConfig, HopfieldConfig) {
    let paper = HopfieldConfig {
        fov_deg: FOV_DEG,
        frame_rate_hz: FPS,
        ..HopfieldConfig::for_size(n)
    };
    let adapted = HopfieldConfig {
        fov_deg: FOV_DEG,
        frame_rate_hz: FPS,
        ..HopfieldConfig::adapted_for_size(n)
    };
    (paper, adapted)
}

#[test]
fn paper_front_end_stays_silent_adapted_front_end_responds_early_and_reads_theta() {
    for n in [64, 128] {
        let frames = video(n);
        let (paper, adapted) = configs(n);
        let p = run(paper, &frames, &format!("paper n={n}"));
        let a = run(adapted, &frames, &format!("adapted n={n}"));
        let (onset_paper, onset_adapted) = (onset_deg(&p), onset_deg(&a));
        let err = median_rel_error(&a, 10.0, 60.0);
        println!(
            "n = {n}: onset paper {onset_paper:?}, adapted {onset_adapted:?}; median |θ̂ − θ|/θ (10°–60°) {err:.3}"
        );
        // The paper front end: the clutter wins, z stays at 1 far into the approach.
        assert!(
            onset_paper.is_none_or(|th| th >= 40.0),
            "n = {n}: paper front end left rest at θ = {onset_paper:?}"
        );
        // The adapted front end: no activity while the disk is tiny, rest left by 15°.
        let onset = onset_adapted.expect("the adapted front end responds");
        assert!(
            (5.0..=15.0).contains(&onset),
            "n = {n}: adapted onset at θ = {onset:.1}°"
        );
        // … and its winner readout follows θ.
        assert!(err <= 0.3, "n = {n}: median relative θ̂ error {err:.3}");
        // z keeps rising through the approach.
        let at = |deg: f64| (0..frames.len()).find(|&t| theta_deg(t) >= deg).expect("reached");
        let z = |t: usize| a[t].z;
        assert!(
            z(at(30.0)) > 2.0 * z(at(15.0)) && z(at(15.0)) > z(at(onset + 1.0)),
            "n = {n}: z(onset + 1°) = {}, z(15°) = {}, z(30°) = {}",
            z(at(onset + 1.0)),
            z(at(15.0)),
            z(at(30.0))
        );
    }
}

#[test]
fn fast_equals_reference_in_clutter() {
    let n = 64;
    let frames = video(n);
    let (paper, adapted) = configs(n);
    for cfg in [
        adapted,
        paper,
        HopfieldConfig {
            front_end: FrontEnd::Adapted,
            ..paper
        },
    ] {
        let fast = run(cfg, &frames, "fast");
        let reference = run(cfg.with_implementation(Implementation::Reference), &frames, "reference");
        for (t, (f, r)) in fast.iter().zip(&reference).enumerate() {
            for (what, x, y) in [
                ("z", f.z, r.z),
                ("z_on", f.z_on, r.z_on),
                ("z_off", f.z_off, r.z_off),
                ("θ̂", f.angular_size_deg, r.angular_size_deg),
            ] {
                let rel = (x - y).abs() / x.abs().max(y.abs()).max(1e-300);
                assert!(
                    rel <= 1e-6,
                    "{:?} frame {t}: {what} fast {x} vs reference {y}",
                    cfg.front_end
                );
            }
            assert_eq!(
                (f.winner_on, f.winner_off, f.iterations_on, f.iterations_off),
                (r.winner_on, r.winner_off, r.iterations_on, r.iterations_off),
                "frame {t}"
            );
        }
    }
}

#[test]
fn blank_and_saturated_frames_in_a_static_cluttered_scene_raise_nothing() {
    // A dropped (black) and a saturated (white) frame in a static textured scene: before the
    // fix, the blank frame was stored as a zero delayed column and `delay` frames later every
    // template beat it (θ̂ = 6.7° at n = 64 from a static scene).
    for n in [64, 128] {
        let still = render(n, 0);
        let mut frames = vec![still.clone(); 8];
        frames.push(Frame::uniform(n, 0.0));
        frames.extend(vec![still.clone(); 8]);
        frames.push(Frame::uniform(n, 1.0));
        frames.extend(vec![still.clone(); 10]);
        // A camera that starts on a black frame.
        frames.insert(0, Frame::uniform(n, 0.0));
        let (paper, adapted) = configs(n);
        for base in [
            paper,
            adapted,
            HopfieldConfig {
                front_end: FrontEnd::Adapted,
                ..paper
            },
        ] {
            for implementation in [Implementation::Fast, Implementation::Reference] {
                let cfg = base.with_implementation(implementation);
                for (t, s) in run(cfg, &frames, "blanks").iter().enumerate() {
                    assert_eq!(
                        (s.z_on, s.z_off, s.z, s.angular_size_deg),
                        (1.0, 1.0, 1.0, 0.0),
                        "n = {n} {implementation} {:?}/{:?} frame {t}",
                        cfg.front_end,
                        cfg.readout
                    );
                }
            }
        }
    }
}
