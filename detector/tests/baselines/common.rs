//! Properties shared by all four baselines: registry, floors on static scenes, rising
//! response to an approaching textured disk, frame-size handling, parameter validation.

use loomlab_detector::baselines::{
    BASELINE_IDS, BaselineConfigs, Cizek2019, Cizek2019Config, Fu2020, Fu2020Config, Keil2004, Keil2004Config,
    baseline_by_id,
};
use loomlab_detector::{DetectorError, Frame};

use crate::stimuli::{Id, approach_frames, get};
use crate::{argmax, max, outputs, run};

#[test]
fn registry_builds_every_baseline_with_its_id() {
    for id in BASELINE_IDS {
        let det = baseline_by_id(id).unwrap();
        assert_eq!(det.id(), id);
    }
    for bad in ["hopfield", "SOC", "", "fu"] {
        let err = baseline_by_id(bad).err().expect("unknown id");
        assert!(
            matches!(err, DetectorError::UnknownDetector(ref s) if s == bad),
            "{err}"
        );
    }
}

#[test]
fn every_baseline_is_at_its_floor_on_static_scenes() {
    for n in [64, 128] {
        for id in BASELINE_IDS {
            for scene in [Id::Uniform, Id::S0] {
                let z = outputs(&run(baseline_by_id(id).unwrap().as_mut(), &get(scene, n)));
                assert!(z.iter().all(|&v| v == 0.0), "{id} {scene:?} n={n}: {z:?}");
            }
        }
    }
}

#[test]
fn every_baseline_rises_for_an_approaching_textured_disk() {
    for n in [64, 128] {
        let frames = get(Id::S2, n);
        assert_eq!(frames.len(), approach_frames());
        for id in BASELINE_IDS {
            let z = outputs(&run(baseline_by_id(id).unwrap().as_mut(), &frames));
            let t = z.len();
            let (peak, first_half) = (max(&z[3 * t / 4..]), max(&z[5..t / 2]));
            println!(
                "{id} n={n}: argmax {} of {t}; max last quarter {peak:.3e}, max first half {first_half:.3e}",
                argmax(&z)
            );
            assert!(argmax(&z) >= 3 * t / 4, "{id} n={n}: argmax {}", argmax(&z));
            assert!(peak > 10.0 * first_half, "{id} n={n}");
            assert!(z.iter().all(|v| v.is_finite() && *v >= 0.0), "{id}");
        }
    }
}

#[test]
fn every_baseline_reports_zero_on_frame_zero_and_fixes_the_size() {
    for id in BASELINE_IDS {
        let mut det = baseline_by_id(id).unwrap();
        let first = det.step(&Frame::uniform(16, 0.2)).unwrap();
        assert_eq!(first.output, 0.0, "{id}");
        assert!(first.aux.iter().all(|(_, v)| *v == 0.0), "{id}");
        let names: Vec<_> = first.aux.iter().map(|(k, _)| *k).collect();
        let second = det.step(&Frame::uniform(16, 0.9)).unwrap();
        assert_eq!(
            names,
            second.aux.iter().map(|(k, _)| *k).collect::<Vec<_>>(),
            "{id}: aux names must be stable"
        );
        assert!(second.angular_size_deg.is_none());
        match det.step(&Frame::uniform(17, 0.5)) {
            Err(DetectorError::FrameSize { expected: 16, got: 17 }) => {}
            other => panic!("{id}: expected FrameSize error, got {other:?}"),
        }
        // After the error the model still works at its size; reset frees the size.
        det.step(&Frame::uniform(16, 0.9)).unwrap();
        det.reset();
        assert_eq!(det.step(&Frame::uniform(5, 0.9)).unwrap().output, 0.0);
        assert!(det.step(&Frame::uniform(5, 0.1)).is_ok());
        // Tiny frames work (1×1 clamps every neighbour to the pixel itself).
        det.reset();
        det.step(&Frame::uniform(1, 0.0)).unwrap();
        assert!(det.step(&Frame::uniform(1, 1.0)).unwrap().output.is_finite());
    }
}

fn invalid(err: DetectorError) -> (&'static str, String) {
    match err {
        DetectorError::InvalidParameter { name, value, reason } => {
            let msg = format!("{name} = {value}: {reason}");
            (name, msg)
        }
        other => panic!("expected InvalidParameter, got {other}"),
    }
}

#[test]
fn invalid_parameters_are_rejected_with_clear_errors() {
    let d = Keil2004Config::default();
    let (name, msg) = invalid(Keil2004::new(Keil2004Config { kappa: 0.3, ..d }).unwrap_err());
    assert_eq!(name, "keil2004.kappa");
    assert!(
        msg.contains("[0, 0.25]") && msg.contains("0.2") && msg.contains("unstable"),
        "{msg}"
    );
    let (name, msg) = invalid(Keil2004::new(Keil2004Config { a_v: 1.0, ..d }).unwrap_err());
    assert_eq!(name, "keil2004.a_v");
    assert!(msg.contains("[0, 1)"), "{msg}");
    assert_eq!(
        invalid(Keil2004::new(Keil2004Config { iterations: 5000, ..d }).unwrap_err()).0,
        "keil2004.iterations"
    );
    assert_eq!(
        invalid(Keil2004::new(Keil2004Config { alpha: f64::NAN, ..d }).unwrap_err()).0,
        "keil2004.alpha"
    );
    assert_eq!(
        invalid(Keil2004::new(Keil2004Config { b: -1.0, ..d }).unwrap_err()).0,
        "keil2004.b"
    );

    let c = Cizek2019Config::default();
    let (name, msg) = invalid(Cizek2019::new(Cizek2019Config { w_i: -0.6, ..c }).unwrap_err());
    assert_eq!(name, "cizek2019.w_i");
    assert!(msg.contains("-0.6") && msg.contains(">= 0"), "{msg}");
    assert_eq!(
        invalid(Cizek2019::new(Cizek2019Config { alpha_s: 1.5, ..c }).unwrap_err()).0,
        "cizek2019.alpha_s"
    );
    assert_eq!(
        invalid(Cizek2019::new(Cizek2019Config { alpha_l: -0.1, ..c }).unwrap_err()).0,
        "cizek2019.alpha_l"
    );
    let gate = Cizek2019Config {
        gate_factor: f64::INFINITY,
        ..c
    };
    assert_eq!(invalid(Cizek2019::new(gate).unwrap_err()).0, "cizek2019.gate_factor");

    let f = Fu2020Config::default();
    let (name, msg) = invalid(
        Fu2020::new(Fu2020Config {
            tau_on: [15.0, -30.0, 45.0],
            ..f
        })
        .unwrap_err(),
    );
    assert_eq!(name, "fu2020.tau_on");
    assert!(msg.contains("nearest") && msg.contains("-30"), "{msg}");
    assert_eq!(
        invalid(Fu2020::new(Fu2020Config { fps_model: 0.0, ..f }).unwrap_err()).0,
        "fu2020.fps_model"
    );
    let fast = Fu2020Config {
        fps_model: 2000.0,
        integer_frame_interval: true,
        ..f
    };
    assert_eq!(invalid(Fu2020::new(fast).unwrap_err()).0, "fu2020.fps_model");
    assert_eq!(
        invalid(Fu2020::new(Fu2020Config { delta_c: 0.0, ..f }).unwrap_err()).0,
        "fu2020.delta_c"
    );
    assert_eq!(
        invalid(Fu2020::new(Fu2020Config { n_ts: 0, ..f }).unwrap_err()).0,
        "fu2020.n_ts"
    );
    assert_eq!(
        invalid(Fu2020::new(Fu2020Config { alpha: 1.0, ..f }).unwrap_err()).0,
        "fu2020.alpha"
    );
    assert_eq!(
        invalid(Fu2020::new(Fu2020Config { dc: 1.0, ..f }).unwrap_err()).0,
        "fu2020.dc"
    );

    // The aggregate validates every member and refuses to build with a bad one.
    let bad = BaselineConfigs {
        fu2020: Fu2020Config { t_pm: 0.0, ..f },
        ..BaselineConfigs::default()
    };
    assert_eq!(invalid(bad.validate().unwrap_err()).0, "fu2020.t_pm");
    assert_eq!(invalid(bad.build("fu2020").err().unwrap()).0, "fu2020.t_pm");
    assert!(bad.build("soc").is_ok());
}

#[test]
fn configs_deserialize_with_defaults_and_reject_unknown_keys() {
    let cfg: BaselineConfigs = toml::from_str(
        "[keil2004]\nkappa = 0.1\n[cizek2019]\nw_i = 0.4\nabsolute_summation = true\n\
         [fu2020]\ntau_on = [10.0, 20.0, 30.0]\n[soc]\npooling = \"mean\"\n",
    )
    .unwrap();
    assert_eq!(
        cfg.keil2004,
        Keil2004Config {
            kappa: 0.1,
            ..Keil2004Config::default()
        }
    );
    assert_eq!(cfg.cizek2019.w_i, 0.4);
    assert!(cfg.cizek2019.absolute_summation);
    assert_eq!(cfg.fu2020.tau_on, [10.0, 20.0, 30.0]);
    assert_eq!(cfg.fu2020.tau_off, Fu2020Config::default().tau_off);
    cfg.validate().unwrap();
    let err = toml::from_str::<BaselineConfigs>("[keil2004]\nkapa = 0.1\n").unwrap_err();
    assert!(err.to_string().contains("kapa"), "{err}");
    assert!(toml::from_str::<BaselineConfigs>("[lgmd]\n").is_err());
    assert_eq!(
        toml::from_str::<BaselineConfigs>("").unwrap(),
        BaselineConfigs::default()
    );
}
