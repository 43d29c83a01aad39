//! The Hopfield detector on the paper's artificial approach videos (rendered by
//! `loomlab_detector::stimulus`): the qualitative behaviour of paper §2.2/§3.1 and the
//! agreement of the fast and reference implementations.
//!
//! Set `HOPFIELD_TRACE=1` to print the per-frame responses.
//!
//! Findings these tests pin down (see also `hopfield/mod.rs`):
//! - A uniform white disk approaching over black stays at the floor z = 1 while it is small
//!   and rises steeply in the final approach; the winning template's diameter follows the
//!   disk's. Once the disk overfills the frame (the last 2–3 frames of the paper's approach,
//!   θ > 60°), the masked frame has almost no edges left and the final frames are blank: by
//!   definition no evidence, so the detector holds its last activity there. The correlation
//!   with θ holds over the whole approach.
//! - A striped disk (horizontal grating, 2 cycles per disk, gray background) with the default
//!   phase 0.25 rises the same way; with phase 0 (a stripe edge through the centre) z stays at
//!   1 for the whole approach.
//! - A template concentric with the disk (offset 0) is orthogonal to its query: z stays at 1.

use std::path::Path;

use loomlab_detector::hopfield::{Hopfield, HopfieldConfig, HopfieldSignals, Implementation, TemplateConfig};
use loomlab_detector::stimulus::{StimulusFrame, StimulusSpec};
use loomlab_detector::{Detector, Frame};

fn stimulus(toml: &str) -> Vec<StimulusFrame> {
    StimulusSpec::from_toml_str(toml, Path::new("<test>"))
        .expect("valid stimulus")
        .render()
}

/// The paper's approach (0.5 m disk, 50 km/h, 10 m → 0.1 m, 120 frames/s, 60°) at size n.
fn approach(n: usize, object: &str, background: &str) -> Vec<StimulusFrame> {
    stimulus(&format!(
        "[stimulus]\nsize = {n}\n[object]\n{object}\n[background]\n{background}\n"
    ))
}

fn white_disk_over_black(n: usize) -> Vec<StimulusFrame> {
    approach(
        n,
        "texture = \"uniform\"\nluminance = 1.0",
        "kind = \"uniform\"\nluminance = 0.0",
    )
}

fn striped_disk_over_gray(n: usize, phase: f64) -> Vec<StimulusFrame> {
    approach(
        n,
        &format!("texture = \"grating\"\ncycles = 2.0\norientation_deg = 0.0\nphase = {phase}"),
        "kind = \"uniform\"\nluminance = 0.5",
    )
}

fn run(cfg: HopfieldConfig, frames: &[StimulusFrame]) -> Vec<HopfieldSignals> {
    let mut det = Hopfield::new(cfg).expect("valid config");
    let out: Vec<HopfieldSignals> = frames
        .iter()
        .map(|f| det.step_hopfield(&f.frame).expect("size"))
        .collect();
    if std::env::var_os("HOPFIELD_TRACE").is_some() {
        for (t, (f, s)) in frames.iter().zip(&out).enumerate() {
            println!(
                "{t:3} θ={:6.2}° z={:9.2} on={:6.2} off={:6.2} win=({:3},{:3}) θ̂={:5.1}° it=({},{})",
                f.theta_true_deg,
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

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

/// Diameter (pixels) of template column `w` (≥ 1) of a detector for size n.
fn template_diameter_px(cfg: &HopfieldConfig, w: usize) -> f64 {
    cfg.template.scale(cfg.n, w) * cfg.n as f64
}

/// Diameter (pixels) of the disk at true angular size θ in a frame of side n, fov 60°.
fn disk_diameter_px(n: usize, theta_deg: f64) -> f64 {
    let f = n as f64 / 2.0 / 30f64.to_radians().tan();
    2.0 * f * (theta_deg / 2.0).to_radians().tan()
}

#[test]
fn white_disk_over_black_floor_then_steep_rise_tracking_theta() {
    let n = 128;
    let cfg = HopfieldConfig::for_size(n);
    let frames = white_disk_over_black(n);
    assert_eq!(frames.len(), 86);
    let s = run(cfg, &frames);
    let theta: Vec<f64> = frames.iter().map(|f| f.theta_true_deg).collect();
    let z: Vec<f64> = s.iter().map(|s| s.z).collect();

    // (i) No activity while the disk is small.
    for (t, (&th, &zt)) in theta.iter().zip(&z).enumerate() {
        if th < 5.0 {
            assert!(zt < 1.0 + 1e-9, "frame {t}: θ = {th:.2}° but z = {zt}");
        }
    }
    // (ii) Steep, super-linear rise in the final approach, while the disk is in view.
    let in_view: Vec<usize> = (0..frames.len()).filter(|&t| theta[t] <= 60.0).collect();
    let last = *in_view.last().unwrap();
    let at = |deg: f64| (0..frames.len()).find(|&t| theta[t] >= deg).unwrap();
    let (t10, t25) = (at(10.0), at(25.0));
    assert!(z[last] > 500.0, "z at the last in-view frame = {}", z[last]);
    assert!(
        z[last] > 4.0 * z[t25] && z[t25] > 4.0 * z[t10],
        "z(10°) = {}, z(25°) = {}, z(end) = {}",
        z[t10],
        z[t25],
        z[last]
    );
    // (iii) The response follows the angular size.
    let r = pearson(&z, &theta);
    assert!(r >= 0.9, "corr(z, θ) over the whole approach = {r:.3}");
    // Blank final frames (the disk overfills the view) hold the activity.
    assert!(
        z[frames.len() - 1] >= z[last],
        "z at the end {} < z at the last in-view frame {}",
        z[frames.len() - 1],
        z[last]
    );
    // The winning templates have (about) the disk's diameter from θ ≈ 15° on.
    for t in at(15.0)..=last {
        for w in [s[t].winner_on, s[t].winner_off] {
            let want = disk_diameter_px(n, theta[t]);
            let got = template_diameter_px(&cfg, w.max(1));
            assert!(
                w >= 1 && (got - want).abs() <= 0.1 * want + 2.0,
                "frame {t}: template {w} ({got:.1} px) for a {want:.1} px disk"
            );
        }
    }
    // Once the disk covers the whole frame there is nothing to retrieve: z decays from its
    // maximum but never leaves its range.
    let top = cfg.memory_columns() as f64;
    assert!(z.iter().all(|&v| (1.0..=top * top).contains(&v)));
}

#[test]
fn striped_disk_rises_with_phase_quarter_and_stays_at_floor_with_edge_through_centre() {
    let n = 128;
    let cfg = HopfieldConfig::for_size(n);
    let quarter = run(cfg, &striped_disk_over_gray(n, 0.25));
    let z_end = quarter.iter().map(|s| s.z).fold(0.0, f64::max);
    assert!(z_end > 500.0, "striped disk (phase 0.25): max z = {z_end}");
    let frames = striped_disk_over_gray(n, 0.25);
    for (f, s) in frames.iter().zip(&quarter) {
        if f.theta_true_deg < 5.0 {
            assert!(s.z < 1.0 + 1e-9, "θ = {:.2}°: z = {}", f.theta_true_deg, s.z);
        }
    }
    // Phase 0: a stripe edge through the centre stays put as the disk grows, the delayed frame
    // keeps winning and z stays at (about) 1.
    let zero = run(cfg, &striped_disk_over_gray(n, 0.0));
    let z_max = zero.iter().map(|s| s.z).fold(0.0, f64::max);
    assert!(z_max < 2.0, "striped disk (phase 0): max z = {z_max}");
}

#[test]
fn template_concentric_with_the_disk_sees_nothing() {
    // Odd (Sobel) query vs even (Laplacian) template: exactly orthogonal when both are
    // symmetric about the same centre — why the default template centre is offset. With every
    // template score at 0 only the delayed frame can win; once it decorrelates (fast growth at
    // the end) the softmax spreads over all templates and z drifts up a little, unrelated to
    // the disk's size.
    let n = 64;
    let frames = white_disk_over_black(n);
    let cfg = HopfieldConfig {
        template: TemplateConfig {
            offset_px: 0.0,
            ..Default::default()
        },
        ..HopfieldConfig::for_size(n)
    };
    let concentric = run(cfg, &frames);
    let default = run(HopfieldConfig::for_size(n), &frames);
    let max = |s: &[HopfieldSignals]| s.iter().map(|s| s.z).fold(0.0, f64::max);
    for (f, s) in frames.iter().zip(&concentric) {
        if f.theta_true_deg < 20.0 {
            assert!(s.z < 1.0 + 1e-9, "θ = {:.1}°: z = {}", f.theta_true_deg, s.z);
        }
    }
    assert!(
        max(&default) > 200.0 && max(&concentric) < 0.05 * max(&default),
        "{} vs {}",
        max(&concentric),
        max(&default)
    );
}

#[test]
fn static_scene_stays_at_the_floor() {
    let n = 64;
    let frames = striped_disk_over_gray(n, 0.25);
    for t in [20, 60, 80] {
        let still: Vec<StimulusFrame> = std::iter::repeat_n(frames[t].clone(), 20).collect();
        for s in run(HopfieldConfig::for_size(n), &still) {
            assert_eq!((s.z_on, s.z_off, s.z), (1.0, 1.0, 1.0), "still frame {t}");
        }
    }
}

#[test]
fn reference_and_fast_agree_on_the_paper_stimuli() {
    let n = 64;
    let files = [
        "fig3a_horizontal_grating.toml",
        "fig5b_rotating_grating.toml",
        "fig6_noise.toml",
        "fig7a_uniform_disk_noise.toml",
        "fig6_checker.toml",
    ];
    let stimuli_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../stimuli");
    let mut videos: Vec<(String, Vec<StimulusFrame>)> = vec![
        ("white disk over black".into(), white_disk_over_black(n)),
        ("striped disk over gray".into(), striped_disk_over_gray(n, 0.25)),
    ];
    for file in files {
        let mut spec = StimulusSpec::load(&stimuli_dir.join(file)).expect("paper stimulus file");
        spec.stimulus.size = n;
        videos.push((file.into(), spec.render()));
    }
    let mut compared = 0;
    for (name, frames) in &videos {
        let cfg = HopfieldConfig::for_size(n);
        let fast = run(cfg, frames);
        let reference = run(cfg.with_implementation(Implementation::Reference), frames);
        for (t, (f, r)) in fast.iter().zip(&reference).enumerate() {
            for (what, a, b) in [("z_on", f.z_on, r.z_on), ("z_off", f.z_off, r.z_off), ("z", f.z, r.z)] {
                let rel = (a - b).abs() / a.abs().max(b.abs());
                assert!(
                    rel <= 1e-6,
                    "{name} frame {t}: {what} fast {a} vs reference {b} (rel {rel:e})"
                );
            }
            assert_eq!(
                (f.winner_on, f.winner_off),
                (r.winner_on, r.winner_off),
                "{name} frame {t}"
            );
            compared += 1;
        }
    }
    assert!(compared >= 7 * 80);
}

#[test]
fn detector_trait_reports_z_theta_and_channels() {
    let n = 64;
    let frames = white_disk_over_black(n);
    let mut det = Hopfield::new(HopfieldConfig::for_size(n)).unwrap();
    let mut twin = Hopfield::new(HopfieldConfig::for_size(n)).unwrap();
    for f in &frames {
        let sig = det.step(&f.frame).unwrap();
        let h = twin.step_hopfield(&f.frame).unwrap();
        assert_eq!(sig.output, h.z);
        assert_eq!(sig.angular_size_deg, Some(h.angular_size_deg));
        assert_eq!(sig.aux, vec![("on", h.z_on), ("off", h.z_off)]);
    }
    assert!(det.step(&Frame::uniform(32, 0.5)).is_err());
}
