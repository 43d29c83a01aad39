//! The smallest frame every detector takes ([`loomlab_detector::MIN_FRAME_SIZE`]) is what the
//! Hopfield detector's default (paper) template schedule needs, and the stimulus loader enforces it.

use std::path::Path;

use loomlab_detector::stimulus::StimulusSpec;
use loomlab_detector::{DetectorSet, HopfieldConfig, MIN_FRAME_SIZE, detector_ids};

#[test]
fn min_frame_size_is_what_the_default_detectors_need() {
    let ok = HopfieldConfig {
        n: MIN_FRAME_SIZE,
        ..HopfieldConfig::default()
    };
    ok.validate().unwrap();
    let too_small = HopfieldConfig {
        n: MIN_FRAME_SIZE - 1,
        ..HopfieldConfig::default()
    };
    let e = too_small.validate().unwrap_err().to_string();
    assert!(e.contains("n ≥ 20") && e.contains("MIN_FRAME_SIZE"), "{e}");
    for id in detector_ids() {
        DetectorSet::default().build(id, MIN_FRAME_SIZE).unwrap();
    }
}

#[test]
fn stimulus_rejects_frames_smaller_than_the_detectors_take() {
    let origin = Path::new("small.toml");
    for n in [1, 8, MIN_FRAME_SIZE - 1] {
        let e = StimulusSpec::from_toml_str(&format!("[stimulus]\nsize = {n}\n"), origin)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("small.toml") && e.contains(&format!("`stimulus.size` = {n}:")) && e.contains("20..=8192"),
            "{e}"
        );
    }
    StimulusSpec::from_toml_str(&format!("[stimulus]\nsize = {MIN_FRAME_SIZE}\n"), origin).unwrap();
}

#[test]
fn stimulus_video_size_is_bounded() {
    // 8192² pixels × 1e6 frames passed validation and `loomlab detect` tried to hold it in memory.
    let text = "[stimulus]\nsize = 8192\nfps = 100000.0\n[object]\nspeed_kmh = 36.0\nstart_distance_m = 100.0\n";
    let e = StimulusSpec::from_toml_str(text, Path::new("huge.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("huge.toml") && e.contains("`stimulus.size` = 8192") && e.contains("MAX_TOTAL_PIXELS"),
        "{e}"
    );
    for f in ["stimuli/fig1_uniform_disk.toml", "stimuli/white_disk_black.toml"] {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(f);
        StimulusSpec::load(&p).unwrap();
    }
}

#[test]
fn a_tiny_template_step_is_an_error_not_an_overflow() {
    // Found by scenarios/tests/parser_fuzz.rs: 1 + (∞ as usize) overflowed in template_count.
    for step in ["5e-324", "1e-300"] {
        let e = HopfieldConfig::from_toml_str(&format!("[template]\nscale_step = {step}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("template"), "{e}");
    }
}
