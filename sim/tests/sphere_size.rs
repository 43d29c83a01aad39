//! A sphere of known size at a known distance must render with the pixel diameter its true angular
//! size predicts (within 1 px), at n = 128 and 256, including odd sizes (row padding).

use crate::common;

use loomlab_sim::{Command, NamedTarget, ProjectileDesc, Target, Texture, WorldDesc};

fn sphere_world(n: u32, distance_m: f32, radius_m: f32) -> WorldDesc {
    let mut w = WorldDesc::empty();
    w.camera.n = n;
    w.ground.enabled = false;
    w.sky_luminance = 0.0;
    w.projectiles.push(ProjectileDesc {
        radius_m,
        texture: Texture::uniform(1.0),
        target: Target::Named(NamedTarget::Camera),
        launch_distance_m: distance_m,
        launch_time_s: Some(1.0e6), // waits at its launch point for the whole test
        stop_at_ground: false,
        ..Default::default()
    });
    w
}

/// Measures (area-equivalent diameter, widest row, tallest column, centroid) of the bright disk.
fn measure(frame: &[f32], n: usize) -> (f64, f64, f64, (f64, f64)) {
    let mut area = 0.0;
    let (mut cx, mut cy) = (0.0, 0.0);
    let mut widest: f64 = 0.0;
    let mut cols = vec![0.0f64; n];
    for r in 0..n {
        let row: f64 = frame[r * n..(r + 1) * n].iter().map(|&v| f64::from(v)).sum();
        widest = widest.max(row);
        for c in 0..n {
            let v = f64::from(frame[r * n + c]);
            area += v;
            cx += v * c as f64;
            cy += v * r as f64;
            cols[c] += v;
        }
    }
    let tallest = cols.iter().cloned().fold(0.0, f64::max);
    (
        (4.0 * area / std::f64::consts::PI).sqrt(),
        widest,
        tallest,
        (cx / area, cy / area),
    )
}

fn check(n: u32) {
    for (distance, radius) in [(4.0f32, 0.5f32), (8.0, 0.5), (15.0, 0.75)] {
        let desc = sphere_world(n, distance, radius);
        let mut sim = common::rendering_sim(&desc, 0);
        let out = sim.step(&Command::default()).expect("step");
        let theta = f64::from(out.truth[0].angular_size_deg).to_radians();
        let expected = 2.0 * sim.camera().focal_px() * (theta / 2.0).tan();
        // analytic check of the ground truth itself
        let analytic = 2.0 * (f64::from(radius) / f64::from(distance)).asin();
        assert!((theta - analytic).abs() < 1e-5, "truth {theta} vs analytic {analytic}");
        let (eq_diam, widest, tallest, (cx, cy)) = measure(&out.frame, n as usize);
        println!(
            "n={n} d={distance} r={radius}: expected {expected:.2} px, area-diameter {eq_diam:.2}, widest row {widest:.2}, tallest column {tallest:.2}"
        );
        assert!(
            (eq_diam - expected).abs() <= 1.0,
            "n={n} d={distance}: {eq_diam:.2} px vs {expected:.2} px"
        );
        assert!(
            (widest - expected).abs() <= 1.0,
            "n={n} d={distance}: row {widest:.2} px vs {expected:.2} px"
        );
        assert!(
            (tallest - expected).abs() <= 1.0,
            "n={n} d={distance}: column {tallest:.2} px vs {expected:.2} px"
        );
        let centre = (f64::from(n) - 1.0) / 2.0;
        assert!(
            (cx - centre).abs() < 0.25 && (cy - centre).abs() < 0.25,
            "disk centred at ({cx}, {cy})"
        );
        assert!(out.truth[0].in_view && out.truth[0].bearing.abs() < 1e-6);
    }
}

#[test]
fn sphere_diameter_matches_angular_size_n128() {
    check(128);
}

#[test]
fn sphere_diameter_matches_angular_size_n256() {
    check(256);
}

#[test]
fn odd_frame_sizes_read_back_unpadded() {
    // 100 * 4 = 400 bytes per row: padded to 512 in the readback buffer
    check(100);
}
