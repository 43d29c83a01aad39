//! `soc`: sum of absolute temporal contrast.

use loomlab_detector::baselines::{Soc, SocConfig, SocPooling};
use loomlab_detector::{Detector, Frame};

use crate::stimuli::{Id, get};
use crate::{argmax, aux, max, outputs, run};

#[test]
fn soc_is_the_sum_of_absolute_frame_differences() {
    let mut soc = Soc::new(SocConfig::default()).unwrap();
    let a = Frame::from_f32(2, vec![0.0, 0.5, 1.0, 0.25]).unwrap();
    let b = Frame::from_f32(2, vec![0.5, 0.5, 0.0, 0.5]).unwrap();
    let s = run(&mut soc, &[a.clone(), b, a]);
    assert_eq!(outputs(&s), vec![0.0, 1.75, 1.75]);
    assert_eq!(aux(&s, "mean"), vec![0.0, 0.4375, 0.4375]);
    let mut mean = Soc::new(SocConfig {
        pooling: SocPooling::Mean,
        ..SocConfig::default()
    })
    .unwrap();
    let frames = get(Id::S2, 64);
    let m = outputs(&run(&mut mean, &frames));
    let s = run(&mut soc, &frames);
    assert_eq!(m, aux(&s, "mean"));
}

#[test]
fn soc_is_silent_on_static_scenes() {
    for id in [Id::Uniform, Id::S0] {
        let mut soc = Soc::new(SocConfig::default()).unwrap();
        assert!(
            outputs(&run(&mut soc, &get(id, 64))).iter().all(|&z| z == 0.0),
            "{id:?}"
        );
    }
}

#[test]
fn soc_rises_for_an_approaching_checker_disk() {
    let mut soc = Soc::new(SocConfig::default()).unwrap();
    let z = outputs(&run(&mut soc, &get(Id::S2, 128)));
    let t = z.len();
    let early = max(&z[5..t / 2]);
    println!(
        "soc S2 n=128: argmax {} of {t}, max {:.4e}, max early {early:.4e}",
        argmax(&z),
        max(&z)
    );
    assert!(argmax(&z) >= t - 5, "argmax {}", argmax(&z));
    assert!(max(&z) >= 20.0 * early);
}

#[test]
fn soc_responds_to_background_motion() {
    // SOC is a temporal highpass: a drifting grating drives it all the time (paper §3.1).
    let mut soc = Soc::new(SocConfig::default()).unwrap();
    let z = outputs(&run(&mut soc, &get(Id::S6, 64)));
    assert!(z[1..].iter().all(|&v| v > 100.0), "{z:?}");
}

#[test]
fn soc_frame_size_is_fixed_by_the_first_frame_until_reset() {
    let mut soc = Soc::new(SocConfig::default()).unwrap();
    soc.step(&Frame::uniform(8, 0.5)).unwrap();
    assert!(soc.step(&Frame::uniform(9, 0.5)).is_err());
    soc.reset();
    assert_eq!(soc.step(&Frame::uniform(9, 0.5)).unwrap().output, 0.0);
}
