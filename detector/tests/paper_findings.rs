//! The paper's qualitative findings on the Hopfield model (and its comparison models), turned into
//! numbers on the same stimuli that `loomlab figures` draws (at n = 128 to keep the test fast).

use loomlab_detector::stimulus::BackgroundKind;
use loomlab_detector::stimulus::paper::{FigureDef, paper_figures, run_condition, summarise};
use loomlab_detector::{DetectorSet, HopfieldConfig};

const N: usize = 128;

fn set() -> DetectorSet {
    DetectorSet {
        hopfield: HopfieldConfig::for_size(N),
        ..Default::default()
    }
}

fn figure(id: &str) -> FigureDef {
    paper_figures(N, 1)
        .into_iter()
        .find(|f| f.id == id)
        .expect("figure defined")
}

/// Output of detector `id` for every condition of a figure.
fn outputs(fig: &FigureDef, id: &str) -> Vec<(String, Vec<f64>, Vec<f64>)> {
    let k = fig.detectors.iter().position(|d| *d == id).expect("detector in figure");
    fig.conditions
        .iter()
        .map(|c| {
            let frames = c.spec.render();
            let theta = frames.iter().map(|f| f.theta_true_deg).collect();
            let mut out = run_condition(&frames, &fig.detectors, &set()).unwrap();
            (c.label.clone(), out.swap_remove(k), theta)
        })
        .collect()
}

/// Fig. 3b and its caption: with a vertical background grating the template (horizontal stripes)
/// does not interfere — the Hopfield response hardly depends on k_s or on k_t.
#[test]
fn vertical_grating_does_not_interfere() {
    let mut fig = figure("fig3a");
    for c in &mut fig.conditions {
        c.spec.background.orientation_deg = 90.0; // same k_s sweep, vertical grating
    }
    let ks = outputs(&fig, "hopfield");
    let kt = outputs(&figure("fig3b"), "hopfield");
    let reference = &ks[0].1;
    for (label, out, theta) in ks.iter().chain(&kt) {
        let s = summarise(out, theta);
        assert!(s.early_mean < 1.05, "{label}: spurious early activity {}", s.early_mean);
        assert!(s.corr_theta > 0.9, "{label}: corr(z, θ) = {}", s.corr_theta);
        let mean_rel = out
            .iter()
            .zip(reference)
            .map(|(a, b)| (a - b).abs() / b.max(1.0))
            .sum::<f64>()
            / out.len() as f64;
        let peak_ratio = s.peak / summarise(reference, theta).peak;
        eprintln!("{label}: mean relative difference {mean_rel:.4}, peak ratio {peak_ratio:.4}");
        assert!(mean_rel < 0.1, "{label}: differs from k_s = 2 by {mean_rel} on average");
        assert!((0.9..1.1).contains(&peak_ratio), "{label}: peak ratio {peak_ratio}");
    }
}

/// Fig. 3a: with a horizontal grating, spurious activity before the final approach grows with k_s.
#[test]
fn horizontal_grating_interference_grows_with_spatial_frequency() {
    let fig = figure("fig3a");
    assert!(
        fig.conditions
            .iter()
            .all(|c| c.spec.background.kind == BackgroundKind::Grating)
    );
    let early: Vec<f64> = outputs(&fig, "hopfield")
        .iter()
        .map(|(_, o, t)| summarise(o, t).early_mean)
        .collect();
    // k_s = 2, 4, 8, 16, 32: non-decreasing (1 % slack) and a large overall increase.
    for w in early.windows(2) {
        assert!(w[1] >= 0.99 * w[0], "early activity not growing with k_s: {early:?}");
    }
    assert!(
        early[4] > 10.0 * early[0],
        "k_s = 32 should be far noisier than k_s = 2: {early:?}"
    );
}

/// Fig. 5b: even with a rotating grating, 1 % dropout and a semi-transparent disk, the rise in the
/// final approach stays clearly above the spurious activity before it.
#[test]
fn rotating_grating_final_rise_stays_distinguishable() {
    for (label, out, theta) in outputs(&figure("fig5b"), "hopfield") {
        let early_max = out
            .iter()
            .zip(&theta)
            .filter(|(_, t)| **t < 5.0)
            .map(|(o, _)| *o)
            .fold(0.0, f64::max);
        let final_max = out[out.len() - 10..].iter().copied().fold(0.0, f64::max);
        assert!(
            final_max > 2.0 * early_max,
            "{label}: final {final_max} vs early {early_max}"
        );
    }
}

/// Fig. 7a: a uniform disk of the background's mean luminance over dynamic noise — SOC does not
/// rise at the end of the approach (it falls as the disk occludes the noise); Hopfield does.
#[test]
fn noise_floor_uniform_disk_only_hopfield_rises() {
    let fig = figure("fig7");
    let late_over_mid = |out: &[f64]| {
        let mid = out[20..60].iter().sum::<f64>() / 40.0;
        let late = out[out.len() - 8..].iter().copied().fold(0.0, f64::max);
        late / mid
    };
    let hop = &outputs(&fig, "hopfield")[0].1;
    let soc = &outputs(&fig, "soc")[0].1;
    assert!(late_over_mid(hop) > 1.5, "hopfield late/mid = {}", late_over_mid(hop));
    assert!(late_over_mid(soc) < 1.1, "soc late/mid = {}", late_over_mid(soc));
}
