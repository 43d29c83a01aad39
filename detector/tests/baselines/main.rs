//! Tests of the baseline looming detectors (`soc`, `keil2004`, `cizek2019`, `fu2020`)
//! against the behaviours and golden numbers of `docs/detectors.md`.
//!
//! Stimuli are the reference stimuli of docs/detectors.md, test-stimuli §2, rendered in [`stimuli`].
//! Thresholds are the spec's; measured values are printed (`--nocapture`) for the report.

mod cizek2019;
mod common;
mod compensate;
mod fu2020;
mod golden;
mod keil2004;
mod paper_stimuli;
mod reference;
mod soc;
mod stimuli;

use loomlab_detector::{Detector, Frame, Signals};

/// Runs a fresh detector over `frames` (resetting it first).
pub fn run(det: &mut dyn Detector, frames: &[Frame]) -> Vec<Signals> {
    det.reset();
    frames
        .iter()
        .map(|f| det.step(f).expect("frame of the right size"))
        .collect()
}

/// The `output` series.
pub fn outputs(s: &[Signals]) -> Vec<f64> {
    s.iter().map(|s| s.output).collect()
}

/// The series of auxiliary signal `name`.
pub fn aux(s: &[Signals], name: &str) -> Vec<f64> {
    s.iter()
        .map(|s| {
            s.aux
                .iter()
                .find(|(k, _)| *k == name)
                .unwrap_or_else(|| panic!("no aux `{name}`"))
                .1
        })
        .collect()
}

/// Index of the (first) maximum.
pub fn argmax(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        if x > v[best] {
            best = i;
        }
    }
    best
}

/// Maximum of `v` (0 for an empty slice).
pub fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}
