//! `compensate = true` on the SOC-family baselines: without an efference copy nothing changes (the
//! paper's models); with the camera's rotation known, a static scene's image motion cancels.

use loomlab_detector::baselines::{
    Cizek2019, Cizek2019Config, Fu2020, Fu2020Config, Keil2004, Keil2004Config, Soc, SocConfig,
};
use loomlab_detector::{Detector, EfferenceCopy, Frame};

use crate::stimuli::{Id, get};
use crate::{outputs, run};

const FOV_DEG: f64 = 60.0;

/// The four models, plain or compensated.
fn models(compensate: bool) -> Vec<Box<dyn Detector>> {
    vec![
        Box::new(
            Soc::new(SocConfig {
                compensate,
                ..SocConfig::default()
            })
            .unwrap(),
        ),
        Box::new(
            Keil2004::new(Keil2004Config {
                compensate,
                ..Keil2004Config::default()
            })
            .unwrap(),
        ),
        Box::new(
            Cizek2019::new(Cizek2019Config {
                compensate,
                ..Cizek2019Config::default()
            })
            .unwrap(),
        ),
        Box::new(
            Fu2020::new(Fu2020Config {
                compensate,
                ..Fu2020Config::default()
            })
            .unwrap(),
        ),
    ]
}

#[test]
fn compensation_without_an_efference_copy_is_the_paper_model() {
    for id in [Id::S1, Id::S2, Id::S7] {
        let frames = get(id, 64);
        for (mut plain, mut compensated) in models(false).into_iter().zip(models(true)) {
            let a = outputs(&run(plain.as_mut(), &frames));
            let b = outputs(&run(compensated.as_mut(), &frames));
            let scale = a.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            for (k, (x, y)) in a.iter().zip(&b).enumerate() {
                // the compensated difference is taken in f32, the paper's in f64
                assert!(
                    (x - y).abs() <= 1e-5 * scale,
                    "{} on {id:?}, frame {k}: {x} vs {y}",
                    plain.id()
                );
            }
        }
    }
}

/// A camera at a fixed point turning left at `yaw_rate_rps` under a textured sky (a scene at
/// infinity: its image motion is the rotation's alone), 120 Hz, n = 64, with the efference copies.
fn turning_under_a_textured_sky(yaw_rate_rps: f64) -> Vec<(Frame, EfferenceCopy)> {
    let n = 64;
    let dt = 1.0 / 120.0;
    let tan_half = (FOV_DEG.to_radians() / 2.0).tan();
    (0..40)
        .map(|k| {
            let yaw = yaw_rate_rps * dt * f64::from(k);
            let mut data = Vec::with_capacity(n * n);
            for i in 0..n {
                for j in 0..n {
                    // the pixel's ray in camera axes (x forward, y left, z up), then in the world
                    let xi = 2.0 * (j as f64 + 0.5) / n as f64 - 1.0;
                    let yi = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                    let (y, z) = (-xi * tan_half, yi * tan_half);
                    let azimuth = y.atan2(1.0) + yaw;
                    let elevation = z.atan2(y.hypot(1.0));
                    let v = 0.5 + 0.35 * (9.0 * azimuth).sin() * (7.0 * elevation).cos();
                    data.push(v as f32);
                }
            }
            let ego = EfferenceCopy {
                yaw_rate_rps,
                dt_s: if k == 0 { 0.0 } else { dt },
                rotation_rad: [0.0, 0.0, if k == 0 { 0.0 } else { yaw_rate_rps * dt }],
                ..EfferenceCopy::default()
            };
            (Frame::from_f32(n, data).unwrap(), ego)
        })
        .collect()
}

#[test]
fn compensation_cancels_the_image_motion_of_a_turning_camera() {
    let frames = turning_under_a_textured_sky(3.0);
    for (mut plain, mut compensated) in models(false).into_iter().zip(models(true)) {
        let peak = |det: &mut Box<dyn Detector>| {
            det.reset();
            frames
                .iter()
                .map(|(f, e)| {
                    let s = det.step_moving(f, e).unwrap();
                    // cizek2019's output is gated by its mean contrast, which a whole-field motion
                    // raises with every cell's: its front end's response is that mean, `t_s`
                    match det.id() {
                        "cizek2019" => s.aux.iter().find(|(k, _)| *k == "t_s").unwrap().1,
                        _ => s.output.abs(),
                    }
                })
                .skip(5)
                .fold(0.0f64, f64::max)
        };
        let (p, c) = (peak(&mut plain), peak(&mut compensated));
        println!("{}: peak output plain {p:.3e}, compensated {c:.3e}", plain.id());
        assert!(
            p > 0.0,
            "{}: the turning camera must excite the plain model",
            plain.id()
        );
        assert!(c < 0.1 * p, "{}: compensated {c} vs plain {p}", plain.id());
    }
}
