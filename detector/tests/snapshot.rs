//! `Detector::snapshot`: a copy taken mid-video continues exactly as the original (the scenario
//! runner starts closed-loop tails from such copies instead of replaying the open-loop prefix).

use loomlab_detector::hopfield::FrontEnd;
use loomlab_detector::{
    Detector, DetectorSet, EfferenceCopy, Frame, Hopfield, HopfieldConfig, Implementation, Signals, detector_ids,
};

const N: usize = 48;

/// Frame `k`: a dark disc growing over a checkered background that drifts by a pixel every few
/// frames (as under the camera's own motion), in a uniform frame 2 pixels wide (the `tracker`
/// reports nothing for a region from one image border to the opposite one).
fn frame(k: usize) -> Frame {
    let radius = 2.0 + 0.4 * k as f64;
    let c = N as f64 / 2.0;
    let shift = k / 3;
    let data = (0..N * N)
        .map(|p| {
            let (i, j) = ((p / N) as f64 + 0.5, (p % N) as f64 + 0.5);
            let border = (p / N).min(p % N).min(N - 1 - p / N).min(N - 1 - p % N) < 2;
            if (i - c).hypot(j - c) < radius {
                0.1
            } else if border {
                0.55
            } else if ((p / N) / 4 + (p % N + shift) / 4) % 2 == 0 {
                0.7
            } else {
                0.4
            }
        })
        .collect();
    Frame::from_f32(N, data).unwrap()
}

/// The efference copy of frame `k`: standing for the first frames, then driving forward.
fn ego(k: usize) -> EfferenceCopy {
    if k < 8 {
        return EfferenceCopy::default();
    }
    EfferenceCopy {
        forward_mps: 1.0,
        dt_s: 1.0 / 120.0,
        translation_m: [0.0, 0.0, 1.0 / 120.0],
        height_m: 0.3,
        ..EfferenceCopy::default()
    }
}

fn run(d: &mut dyn Detector, frames: std::ops::Range<usize>) -> Vec<Signals> {
    frames.map(|k| d.step_moving(&frame(k), &ego(k)).unwrap()).collect()
}

fn assert_snapshot_continues_identically(mut original: Box<dyn Detector>) {
    let id = original.id();
    run(original.as_mut(), 0..20);
    let mut copy = original
        .snapshot()
        .unwrap_or_else(|| panic!("{id}: the built-in detectors copy themselves"));
    // the original first: a copy that shared state with it would continue from frame 36
    let expected = run(original.as_mut(), 20..36);
    let got = run(copy.as_mut(), 20..36);
    // bit for bit (Debug prints every f64 exactly, NaN included)
    assert_eq!(
        format!("{got:?}"),
        format!("{expected:?}"),
        "{id}: the copy continues differently"
    );
    // the frames after the snapshot do change the signals (the comparison above is not vacuous)
    let mut fresh = original.snapshot().unwrap();
    fresh.reset();
    assert_ne!(
        format!("{:?}", run(fresh.as_mut(), 20..36)),
        format!("{expected:?}"),
        "{id}: history matters"
    );
}

#[test]
fn every_builtin_detector_snapshot_continues_exactly_as_the_original() {
    let set = DetectorSet::default();
    for id in detector_ids() {
        assert_snapshot_continues_identically(set.build(id, N).unwrap());
    }
}

#[test]
fn hopfield_front_ends_and_implementations_snapshot_exactly() {
    for front_end in [FrontEnd::Paper, FrontEnd::Adapted, FrontEnd::Compensated] {
        for implementation in [Implementation::Fast, Implementation::Reference] {
            let config = HopfieldConfig {
                n: N,
                front_end,
                implementation,
                ..HopfieldConfig::default()
            };
            assert_snapshot_continues_identically(Box::new(Hopfield::new(config).unwrap()));
        }
    }
}
