//! Tests of the analytic stimulus renderer (`loomlab_detector::stimulus`).

use std::path::{Path, PathBuf};

use loomlab_detector::DetectorError;
use loomlab_detector::stimulus::{
    BackgroundKind, CorruptionSection, ForegroundSection, NoiseDistribution, Shape, StimulusSpec, Texture,
};

fn spec(n: usize) -> StimulusSpec {
    let mut s = StimulusSpec::default();
    s.stimulus.size = n;
    s
}

fn white_on_black(n: usize) -> StimulusSpec {
    let mut s = spec(n);
    s.object.luminance = 1.0;
    s.background.luminance = 0.0;
    s
}

fn parse(text: &str) -> Result<StimulusSpec, DetectorError> {
    StimulusSpec::from_toml_str(text, Path::new("test.toml"))
}

fn err_text(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => {
            assert!(matches!(e, DetectorError::Stimulus { .. }), "wrong variant: {e:?}");
            let msg = e.to_string();
            assert!(msg.starts_with("test.toml:"), "error does not name the file: {msg}");
            msg
        }
    }
}

/// Sum of pixel luminance (area in px² for a white object on black).
fn area(frame: &loomlab_detector::Frame) -> f64 {
    frame.data().iter().map(|&v| v as f64).sum()
}

/// Luminance-weighted centroid (x = column, y = row; pixel centres at k + ½).
fn centroid(frame: &loomlab_detector::Frame) -> (f64, f64) {
    let n = frame.n();
    let (mut sx, mut sy, mut s) = (0.0, 0.0, 0.0);
    for i in 0..n {
        for j in 0..n {
            let v = frame.get(i, j) as f64;
            sx += v * (j as f64 + 0.5);
            sy += v * (i as f64 + 0.5);
            s += v;
        }
    }
    (sx / s, sy / s)
}

#[test]
fn paper_approach_has_86_frames() {
    let s = StimulusSpec::default();
    assert_eq!(s.frame_count(), 86);
    assert_eq!(s.render().len(), 86);
    assert!(s.distance_m(85) >= 0.1);
    assert!(s.distance_m(86) < 0.1);
}

#[test]
fn frame_count_includes_an_exactly_reached_end() {
    let mut s = spec(16);
    s.object.speed_kmh = 3.6; // 1 m/s
    s.stimulus.fps = 10.0;
    s.object.start_distance_m = 2.0;
    s.object.end_distance_m = 1.0;
    assert_eq!(s.frame_count(), 11);
    assert!((s.distance_m(10) - 1.0).abs() < 1e-12);
}

#[test]
fn true_angle_matches_two_atan() {
    let s = spec(32);
    for (t, f) in s.render().iter().enumerate() {
        let d = 10.0 - (50.0 / 3.6) * t as f64 / 120.0;
        assert!((f.distance_m - d).abs() < 1e-12);
        assert!((f.t_s - t as f64 / 120.0).abs() < 1e-15);
        let theta = 2.0 * (0.25 / d).atan().to_degrees();
        assert!(
            (f.theta_true_deg - theta).abs() < 1e-10,
            "frame {t}: {} vs {theta}",
            f.theta_true_deg
        );
    }
    // The image radius matches the angle through the focal length.
    let t = 50;
    let f_px = 64.0 / 30f64.to_radians().tan() / 4.0; // n = 32
    let r = s.object_radius_px(t);
    assert!((r - f_px * (s.theta_true_deg(t).to_radians() / 2.0).tan()).abs() < 1e-9);
}

#[test]
fn rendered_disk_area_matches_pi_r_squared() {
    let s = white_on_black(128);
    let mut checked = 0;
    for t in (0..s.frame_count()).step_by(3) {
        let r = s.object_radius_px(t);
        if r > 60.0 {
            break; // the disk must stay inside the frame
        }
        let a = area(&s.render_frame(t).frame);
        let expected = std::f64::consts::PI * r * r;
        // Sub-pixel accurate: within 0.1 px² + 0.2 %.
        assert!(
            (a - expected).abs() < 0.1 + 2e-3 * expected,
            "t = {t}, r = {r:.3}: area {a:.3} vs πr² = {expected:.3}"
        );
        checked += 1;
    }
    assert!(checked > 15);
}

#[test]
fn rendered_square_area_matches_side_squared() {
    let mut s = white_on_black(128);
    s.object.shape = Shape::Square;
    s.object.focus_x = 0.013; // off the pixel grid
    for t in [0, 20, 40, 60, 70] {
        let h = s.object_radius_px(t);
        let a = area(&s.render_frame(t).frame);
        assert!(
            (a - 4.0 * h * h).abs() < 1e-3 * (1.0 + 4.0 * h * h),
            "t = {t}: {a} vs {}",
            4.0 * h * h
        );
    }
}

#[test]
fn disk_area_grows_smoothly() {
    // No frame-to-frame jumps from pixel quantisation: area ratios follow (r_t+1 / r_t)².
    let s = white_on_black(64);
    for t in 0..40 {
        let (a0, a1) = (area(&s.render_frame(t).frame), area(&s.render_frame(t + 1).frame));
        let ratio = (s.object_radius_px(t + 1) / s.object_radius_px(t)).powi(2);
        assert!((a1 / a0 - ratio).abs() < 0.02, "t = {t}: {} vs {ratio}", a1 / a0);
    }
}

#[test]
fn every_texture_and_background_stays_in_unit_range() {
    let textures = [
        Texture::Uniform,
        Texture::Checker,
        Texture::Noise,
        Texture::Grating,
        Texture::Circular,
        Texture::Starburst,
    ];
    let backgrounds = [
        BackgroundKind::Uniform,
        BackgroundKind::Grating,
        BackgroundKind::RotatingGrating,
        BackgroundKind::Noise,
    ];
    for &texture in &textures {
        for &kind in &backgrounds {
            let mut s = spec(48);
            s.object.texture = texture;
            s.object.orientation_deg = 30.0;
            s.background.kind = kind;
            s.background.luminance = 0.7; // contrast 1 would exceed 1: must be clamped
            s.object.opacity = 0.8;
            s.foreground = Some(ForegroundSection {
                cycles: 5.0,
                ..Default::default()
            });
            for t in [0, 50, 75, 85] {
                let f = s.render_frame(t).frame;
                assert!(
                    f.data().iter().all(|v| (0.0..=1.0).contains(v)),
                    "{texture:?} over {kind:?} at t = {t} leaves [0, 1]"
                );
                assert_eq!(f.invalid_pixels(), 0);
            }
        }
    }
}

#[test]
fn textures_differ_and_scale_with_the_object() {
    // A textured disk close to the camera: the pattern is visible and not uniform.
    for texture in [
        Texture::Checker,
        Texture::Noise,
        Texture::Grating,
        Texture::Circular,
        Texture::Starburst,
    ] {
        let mut s = spec(64);
        s.object.texture = texture;
        s.object.cycles = 4.0;
        let f = s.render_frame(80).frame; // r ≈ 18.7 px
        let inside: Vec<f32> = (24..40)
            .flat_map(|i| (24..40).map(move |j| (i, j)))
            .map(|(i, j)| f.get(i, j))
            .collect();
        let bright = inside.iter().filter(|&&v| v > 0.5).count();
        assert!(
            bright > 10 && bright < inside.len() - 10,
            "{texture:?}: {bright} of {} bright",
            inside.len()
        );
    }
}

/// Bright↔dark transitions along the vertical line through the disk centre, inside the disk.
fn transitions_along_centre_column(f: &loomlab_detector::Frame, r: f64) -> usize {
    let n = f.n();
    let c = n / 2;
    let rows: Vec<bool> = (0..n)
        .filter(|&i| ((i as f64 + 0.5) - n as f64 / 2.0).abs() < r - 1.0)
        .map(|i| f.get(i, c) > 0.5)
        .collect();
    rows.windows(2).filter(|w| w[0] != w[1]).count()
}

#[test]
fn grating_has_cycles_per_diameter_and_a_bright_centre() {
    for cycles in [2.0, 3.0] {
        let mut s = spec(128);
        s.object.texture = Texture::Grating;
        s.object.cycles = cycles;
        let t = 80; // r ≈ 37 px
        let f = s.render_frame(t).frame;
        let r = s.object_radius_px(t);
        assert!(r > 35.0 && r < 64.0);
        assert_eq!(
            transitions_along_centre_column(&f, r),
            2 * cycles as usize,
            "cycles = {cycles}"
        );
        // Default phase 0.25: the centre lies in the middle of a bright stripe, symmetric about it.
        assert!(f.get(63, 64) > 0.99 && f.get(64, 64) > 0.99);
        // Horizontal stripes: constant along a row inside the disk.
        assert!((50..78).all(|j| f.get(60, j) == f.get(60, 64)));
    }
    // Phase 0.75: a dark stripe in the middle.
    let mut s = spec(128);
    s.object.texture = Texture::Grating;
    s.object.phase = 0.75;
    let f = s.render_frame(80).frame;
    assert!(f.get(63, 64) < 0.01 && f.get(64, 64) < 0.01);
}

#[test]
fn grating_orientation_90_gives_vertical_stripes() {
    let mut s = spec(64);
    s.object.texture = Texture::Grating;
    s.object.orientation_deg = 90.0;
    let f = s.render_frame(80).frame; // r ≈ 18.7 px
    assert!((24..40).all(|i| f.get(i, 30) == f.get(32, 30)));
    assert!((20..44).any(|j| f.get(32, j) != f.get(32, 32)));
}

#[test]
fn opacity_blends_object_and_background() {
    let mut s = white_on_black(64);
    s.object.opacity = 0.5;
    let f = s.render_frame(80).frame;
    assert!((f.get(32, 32) - 0.5).abs() < 1e-6);
    assert_eq!(f.get(0, 0), 0.0);
}

#[test]
fn background_grating_drifts_from_bottom_to_top() {
    let mut s = spec(64);
    s.object.opacity = 0.0; // background only
    s.background.kind = BackgroundKind::Grating;
    s.background.cycles = 8.0; // 8 px wavelength
    s.background.drift_hz = 15.0; // 1/8 cycle per frame at 120 fps = 1 px per frame
    let f0 = s.render_frame(0).frame;
    let f1 = s.render_frame(1).frame;
    // Horizontal stripes, sine wave between 0 and 1.
    assert!((0..64).all(|j| f0.get(10, j) == f0.get(10, 0)));
    let (lo, hi) = f0.data().iter().fold((1f32, 0f32), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(lo < 0.05 && hi > 0.95);
    // Content moves up one row per frame: row i at t+1 = row i+1 at t.
    for i in 0..63 {
        assert!((f1.get(i, 5) - f0.get(i + 1, 5)).abs() < 1e-5, "row {i}");
    }
}

#[test]
fn rotating_grating_is_phase_reversed_after_180_degrees() {
    let mut s = spec(64);
    s.object.opacity = 0.0;
    s.background.kind = BackgroundKind::RotatingGrating;
    s.background.drift_hz = 0.0;
    s.background.rotation_deg_per_frame = 90.0;
    let (f0, f1, f2) = (
        s.render_frame(0).frame,
        s.render_frame(1).frame,
        s.render_frame(2).frame,
    );
    assert!(f0.data().iter().zip(f2.data()).all(|(a, b)| (a + b - 1.0).abs() < 1e-5));
    // Frame 1 has vertical stripes.
    assert!((0..64).all(|i| (f1.get(i, 7) - f1.get(0, 7)).abs() < 1e-6));
    assert!((0..64).any(|j| (f1.get(7, j) - f1.get(7, 0)).abs() > 0.1));
}

#[test]
fn noise_background_is_dynamic_or_static() {
    let mut s = spec(32);
    s.background.kind = BackgroundKind::Noise;
    s.object.opacity = 0.0;
    let (a, b) = (s.render_frame(3).frame, s.render_frame(4).frame);
    assert_ne!(a, b);
    let mean = a.data().iter().map(|&v| v as f64).sum::<f64>() / 1024.0;
    assert!((mean - 0.5).abs() < 0.05);
    s.background.dynamic = false;
    assert_eq!(s.render_frame(3).frame, s.render_frame(4).frame);
    s.background.noise = NoiseDistribution::Binary;
    assert!(s.render_frame(0).frame.data().iter().all(|&v| v == 0.0 || v == 1.0));
}

#[test]
fn noise_texture_is_fixed_to_the_object() {
    let mut s = spec(64);
    s.object.texture = Texture::Noise;
    s.object.noise = NoiseDistribution::Binary;
    s.object.noise_cells = 4;
    // The same cells appear at the same object coordinates as the object grows (static per
    // episode, scaling with the object): sample the centre of each cell inside the disk.
    let cell_values = |t: usize| -> Vec<f32> {
        let f = s.render_frame(t).frame;
        let d = 2.0 * s.object_radius_px(t);
        let mut v = Vec::new();
        for (ka, kb) in [(1, 1), (1, 2), (2, 1), (2, 2), (0, 1), (3, 2), (1, 0), (2, 3)] {
            let (a, b) = (-0.375 + 0.25 * ka as f64, 0.375 - 0.25 * kb as f64);
            let (x, y) = (32.0 + a * d, 32.0 - b * d);
            v.push(f.get(y.floor() as usize, x.floor() as usize));
        }
        v
    };
    let early = cell_values(79); // r ≈ 15 px
    let late = cell_values(80); // r ≈ 18.7 px
    assert_eq!(early, late);
    // Binary cells: 0 or 1, and both occur.
    assert!(early.iter().all(|&v| v == 0.0 || v == 1.0));
    assert!(early.contains(&0.0) && early.contains(&1.0), "{early:?}");
}

#[test]
fn same_seed_same_frames_different_seed_different_noise() {
    let mut s = spec(32);
    s.object.texture = Texture::Noise;
    s.background.kind = BackgroundKind::Noise;
    s.corruption = Some(CorruptionSection { dropout: 0.05 });
    let a = s.render();
    let b = s.clone().render();
    assert_eq!(a, b);
    // A single frame rendered alone equals the same frame of the whole video.
    assert_eq!(s.render_frame(40), a[40]);
    let mut other = s.clone();
    other.stimulus.seed = 2;
    assert_ne!(other.render_frame(40).frame, a[40].frame);
    // Object noise alone also depends on the seed.
    let mut obj = spec(32);
    obj.object.texture = Texture::Noise;
    let mut obj2 = obj.clone();
    obj2.stimulus.seed = 99;
    assert_ne!(obj.render_frame(80).frame, obj2.render_frame(80).frame);
}

#[test]
fn focus_offset_moves_the_centroid() {
    let n = 128;
    let mut s = white_on_black(n);
    let t = 40; // r ≈ 9 px
    let (x0, y0) = centroid(&s.render_frame(t).frame);
    assert!((x0 - 64.0).abs() < 1e-3 && (y0 - 64.0).abs() < 1e-3, "{x0} {y0}");
    s.object.focus_x = 0.5;
    let (x, y) = centroid(&s.render_frame(t).frame);
    assert!((x - 96.0).abs() < 1e-3 && (y - 64.0).abs() < 1e-3, "{x} {y}");
    s.object.focus_x = -0.25;
    s.object.focus_y = 0.5; // up
    let (x, y) = centroid(&s.render_frame(t).frame);
    assert!((x - 48.0).abs() < 1e-3 && (y - 32.0).abs() < 1e-3, "{x} {y}");
}

#[test]
fn dropout_fraction_matches_probability() {
    let mut s = spec(128);
    s.background.luminance = 1.0;
    s.object.luminance = 1.0;
    s.corruption = Some(CorruptionSection { dropout: 0.05 });
    let mut zeros = 0usize;
    let frames = 4;
    for t in 0..frames {
        zeros += s.render_frame(t).frame.data().iter().filter(|&&v| v == 0.0).count();
    }
    let frac = zeros as f64 / (frames * 128 * 128) as f64;
    assert!((frac - 0.05).abs() < 0.004, "dropout fraction {frac}");
    // Different pixels in different frames.
    assert_ne!(s.render_frame(0).frame, s.render_frame(1).frame);
}

#[test]
fn foreground_bars_cover_the_scene() {
    let mut s = white_on_black(64);
    s.object.opacity = 0.0;
    s.background.luminance = 0.0;
    s.foreground = Some(ForegroundSection {
        cycles: 8.0,
        luminance: 0.75,
        duty: 0.25,
        ..Default::default()
    });
    let f = s.render_frame(0).frame;
    let covered = f.data().iter().filter(|&&v| v == 0.75).count();
    assert_eq!(covered + f.data().iter().filter(|&&v| v == 0.0).count(), 64 * 64);
    assert_eq!(covered, 64 * 64 / 4);
    // Horizontal bars: whole rows.
    assert!((0..64).all(|i| (0..64).all(|j| f.get(i, j) == f.get(i, 0))));
}

#[test]
fn toml_defaults_match_design() {
    let s = parse("").unwrap();
    assert_eq!(s, StimulusSpec::default());
    assert_eq!(s.stimulus.size, 256);
    assert_eq!(s.stimulus.fps, 120.0);
    assert_eq!(s.object.diameter_m, 0.5);
    assert_eq!(s.object.shape, Shape::Disk);
    assert_eq!(s.background.cycles, 16.0);
    assert!(s.foreground.is_none() && s.corruption.is_none());
    let s = parse("[foreground]\n[corruption]\n").unwrap();
    assert_eq!(s.foreground, Some(ForegroundSection::default()));
    assert_eq!(s.corruption.unwrap().dropout, 0.01);
    let s = parse("[object]\ntexture = \"starburst\"\nshape = \"square\"\n[background]\nkind = \"rotating_grating\"\n")
        .unwrap();
    assert_eq!(s.object.texture, Texture::Starburst);
    assert_eq!(s.background.kind, BackgroundKind::RotatingGrating);
}

#[test]
fn unknown_keys_are_errors_naming_the_key() {
    let msg = err_text("[stimulus]\nsize = 64\n\n[object]\nspeed = 3.0\n");
    assert!(msg.contains("object.speed"), "{msg}");
    assert!(msg.contains("line 5"), "{msg}");
    assert!(msg.contains("unknown field"), "{msg}");
    let msg = err_text("[objekt]\nspeed_kmh = 3.0\n");
    assert!(msg.contains("objekt"), "{msg}");
}

#[test]
fn wrong_types_are_errors_naming_the_key_and_line() {
    let msg = err_text("[object]\ndiameter_m = 0.5\nspeed_kmh = \"fast\"\n");
    assert!(msg.contains("object.speed_kmh") && msg.contains("line 3"), "{msg}");
    let msg = err_text("[object]\ntexture = \"plaid\"\n");
    assert!(msg.contains("object.texture") && msg.contains("plaid"), "{msg}");
    let msg = err_text("[stimulus]\nsize = -3\n");
    assert!(msg.contains("stimulus.size"), "{msg}");
    let msg = err_text("[stimulus\nsize = 3\n");
    assert!(msg.contains("line 1"), "{msg}");
}

#[test]
fn out_of_range_values_are_errors_naming_the_key() {
    let cases = [
        ("[stimulus]\nsize = 0\n", "stimulus.size"),
        ("[stimulus]\nfps = 0.0\n", "stimulus.fps"),
        ("[stimulus]\nfov_deg = 180.0\n", "stimulus.fov_deg"),
        ("[object]\nspeed_kmh = -5.0\n", "object.speed_kmh"),
        ("[object]\ndiameter_m = 0.0\n", "object.diameter_m"),
        ("[object]\nend_distance_m = 12.0\n", "object.end_distance_m"),
        ("[object]\nend_distance_m = 0.0\n", "object.end_distance_m"),
        ("[object]\nopacity = 1.5\n", "object.opacity"),
        ("[object]\nluminance = -0.1\n", "object.luminance"),
        ("[object]\nfocus_x = 1.5\n", "object.focus_x"),
        ("[object]\ncycles = 0.0\n", "object.cycles"),
        ("[object]\nnoise_cells = 0\n", "object.noise_cells"),
        ("[background]\nluminance = 2.0\n", "background.luminance"),
        ("[background]\ncycles = -1.0\n", "background.cycles"),
        ("[background]\ndrift_hz = nan\n", "background.drift_hz"),
        ("[foreground]\nduty = 1.5\n", "foreground.duty"),
        ("[corruption]\ndropout = 1.5\n", "corruption.dropout"),
        ("[object]\nspeed_kmh = 1e-9\n", "object.speed_kmh"),
    ];
    for (text, key) in cases {
        let msg = err_text(text);
        assert!(msg.contains(&format!("`{key}`")), "{text:?}: {msg}");
        assert!(
            msg.contains("must"),
            "{text:?}: error should say what is allowed: {msg}"
        );
    }
}

#[test]
fn validate_catches_programmatic_mistakes() {
    let mut s = StimulusSpec::default();
    s.object.opacity = -1.0;
    let msg = s.validate().unwrap_err().to_string();
    assert!(msg.contains("object.opacity"), "{msg}");
    // Rendering an invalid spec does not panic.
    s.stimulus.size = 0;
    assert_eq!(s.render_frame(0).frame.n(), 1);
}

#[test]
fn load_reports_missing_file() {
    let e = StimulusSpec::load(Path::new("/nonexistent/stimulus.toml")).unwrap_err();
    assert!(matches!(e, DetectorError::Io { .. }));
    assert!(e.to_string().contains("/nonexistent/stimulus.toml"));
}

fn stimuli_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../stimuli")
}

#[test]
fn every_shipped_stimulus_file_loads_and_renders() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(stimuli_dir())
        .expect("stimuli/ exists at the repository root")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(
        files.len() >= 14,
        "expected the paper's stimulus files, found {files:?}"
    );
    for file in &files {
        let s = StimulusSpec::load(file).unwrap_or_else(|e| panic!("{e}"));
        // The paper's approach (86 frames at 120 fps); Fig. 1 is filmed at 180 fps.
        let expected = if file.ends_with("fig1_uniform_disk.toml") {
            129
        } else {
            86
        };
        assert_eq!(s.frame_count(), expected, "{}", file.display());
        let last = s.render_frame(s.frame_count() - 1);
        assert_eq!(last.frame.n(), s.stimulus.size);
    }
    for name in [
        "white_disk_black.toml",
        "fig7b_noise_patch_noise.toml",
        "fig8_focus_x_0.5.toml",
    ] {
        assert!(files.iter().any(|f| f.ends_with(name)), "missing {name}");
    }
}

/// Mean absolute temporal contrast per pixel between frames t−1 and t (SOC / n²).
fn soc(frames: &[loomlab_detector::stimulus::StimulusFrame], t: usize) -> f64 {
    let (a, b) = (frames[t - 1].frame.data(), frames[t].frame.data());
    a.iter().zip(b).map(|(x, y)| (x - y).abs() as f64).sum::<f64>() / a.len() as f64
}

#[test]
fn noise_patch_contrast_decides_whether_temporal_contrast_rises() {
    // Design §4 / paper Fig. 7b: over uniform dynamic noise (mean |Δ| = 1/3 per pixel) a
    // uniform-[0, 1] patch keeps SOC flat, a binary patch makes it rise towards 1/2.
    let mut s = spec(64);
    s.object.texture = Texture::Noise;
    s.background.kind = BackgroundKind::Noise;
    s.object.noise = NoiseDistribution::Uniform;
    let uniform = s.render();
    s.object.noise = NoiseDistribution::Binary;
    let binary = s.render();
    for t in [20, 60, 80, 82, 84] {
        assert!(
            (soc(&uniform, t) - 1.0 / 3.0).abs() < 0.03,
            "uniform patch, t = {t}: {}",
            soc(&uniform, t)
        );
    }
    assert!((soc(&binary, 20) - 1.0 / 3.0).abs() < 0.03);
    assert!(soc(&binary, 83) > 0.45, "binary patch: {}", soc(&binary, 83));
}
