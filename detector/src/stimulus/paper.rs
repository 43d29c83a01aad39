//! The paper's artificial-video experiments (Figs. 3–8) as data: every figure is a set of
//! conditions (one stimulus each) and the detectors drawn for it. `loomlab figures` renders them
//! as plots and CSV; the paper-findings tests check the qualitative results on them.

use crate::stimulus::{BackgroundKind, CorruptionSection, ForegroundSection, NoiseDistribution, Texture};
use crate::stimulus::{StimulusFrame, StimulusSpec};
use crate::{DetectorError, DetectorSet, detector_ids};

/// One stimulus of a figure.
pub struct Condition {
    /// Panel title and CSV column prefix, e.g. `ks=8`.
    pub label: String,
    /// The stimulus.
    pub spec: StimulusSpec,
}

/// One of the paper's figures.
pub struct FigureDef {
    /// File stem, e.g. `fig3a`.
    pub id: &'static str,
    /// What the figure shows.
    pub title: &'static str,
    /// Detector ids drawn in every panel.
    pub detectors: Vec<&'static str>,
    /// The conditions, one panel each.
    pub conditions: Vec<Condition>,
    /// Frames skipped at the start when plotting (the paper starts Fig. 7 at t = 10).
    pub skip_frames: usize,
}

/// The paper's approach (Fig. 3 caption): a 0.5 m disk with a horizontal square-wave grating of
/// 2 cycles per disk, 50 km/h from 10 m to 0.1 m, 120 fps, 86 frames.
fn paper_base(n: usize, seed: u64) -> StimulusSpec {
    let mut s = StimulusSpec::default();
    s.stimulus.size = n;
    s.stimulus.seed = seed;
    s.object.texture = Texture::Grating;
    s.object.cycles = 2.0;
    s
}

fn drifting(mut s: StimulusSpec, cycles: f64, orientation_deg: f64, drift_hz: f64) -> StimulusSpec {
    s.background.kind = BackgroundKind::Grating;
    s.background.cycles = cycles;
    s.background.orientation_deg = orientation_deg;
    s.background.drift_hz = drift_hz;
    s
}

const SPATIAL: [f64; 5] = [2.0, 4.0, 8.0, 16.0, 32.0];
const TEMPORAL: [f64; 5] = [0.0, 4.0, 8.0, 16.0, 32.0];

/// All figures for frame size `n`.
pub fn paper_figures(n: usize, seed: u64) -> Vec<FigureDef> {
    let base = paper_base(n, seed);
    let cond = |label: String, spec: StimulusSpec| Condition { label, spec };
    let mut figs = Vec::new();
    figs.push(FigureDef {
        id: "fig3a",
        title: "Fig. 3a: striped disk over a drifting horizontal grating (k_t = 8 Hz), k_s varies",
        detectors: vec!["hopfield"],
        conditions: SPATIAL
            .iter()
            .map(|&ks| cond(format!("ks={ks}"), drifting(base.clone(), ks, 0.0, 8.0)))
            .collect(),
        skip_frames: 0,
    });
    figs.push(FigureDef {
        id: "fig3b",
        title: "Fig. 3b: striped disk over a drifting vertical grating (k_s = 16), k_t varies",
        detectors: vec!["hopfield"],
        conditions: TEMPORAL
            .iter()
            .map(|&kt| cond(format!("kt={kt}"), drifting(base.clone(), 16.0, 90.0, kt)))
            .collect(),
        skip_frames: 0,
    });
    figs.push(FigureDef {
        id: "fig4",
        title: "Fig. 4: horizontal grating (k_s = 16), drift k_t varies: SOC and Hopfield",
        detectors: vec!["soc", "hopfield"],
        conditions: TEMPORAL
            .iter()
            .map(|&kt| cond(format!("kt={kt}"), drifting(base.clone(), 16.0, 0.0, kt)))
            .collect(),
        skip_frames: 0,
    });
    figs.push(FigureDef {
        id: "fig5a",
        title: "Fig. 5a: occluding drifting horizontal foreground grating (k_t = 8 Hz), k_s varies",
        detectors: vec!["hopfield"],
        conditions: SPATIAL
            .iter()
            .map(|&ks| {
                let mut s = base.clone();
                s.foreground = Some(ForegroundSection {
                    cycles: ks,
                    orientation_deg: 0.0,
                    drift_hz: 8.0,
                    ..Default::default()
                });
                cond(format!("ks={ks}"), s)
            })
            .collect(),
        skip_frames: 0,
    });
    figs.push(FigureDef {
        id: "fig5b",
        title: "Fig. 5b: rotating grating (8°/frame), 1 % dropout, semi-transparent disk, k_s varies",
        detectors: vec!["hopfield"],
        conditions: SPATIAL
            .iter()
            .map(|&ks| {
                let mut s = base.clone();
                s.background.kind = BackgroundKind::RotatingGrating;
                s.background.cycles = ks;
                s.background.drift_hz = 0.0;
                s.background.rotation_deg_per_frame = 8.0;
                s.object.opacity = 0.5;
                s.corruption = Some(CorruptionSection { dropout: 0.01 });
                cond(format!("ks={ks}"), s)
            })
            .collect(),
        skip_frames: 0,
    });
    let textures = [
        ("constant", Texture::Uniform),
        ("chess", Texture::Checker),
        ("noise", Texture::Noise),
        ("linear", Texture::Grating),
        ("circular", Texture::Circular),
        ("starburst", Texture::Starburst),
    ];
    figs.push(FigureDef {
        id: "fig6",
        title: "Fig. 6: six object textures over a drifting horizontal grating (k_s = 8, k_t = 8 Hz)",
        detectors: vec!["hopfield", "soc"],
        conditions: textures
            .iter()
            .map(|&(name, tex)| {
                let mut s = drifting(base.clone(), 8.0, 0.0, 8.0);
                s.object.texture = tex;
                s.object.noise = NoiseDistribution::Binary;
                cond(name.to_string(), s)
            })
            .collect(),
        skip_frames: 0,
    });
    let noise_floor = |mut s: StimulusSpec| {
        s.background.kind = BackgroundKind::Noise;
        s.background.noise = NoiseDistribution::Uniform;
        s.background.dynamic = true;
        s
    };
    let mut uniform = noise_floor(base.clone());
    uniform.object.texture = Texture::Uniform;
    uniform.object.luminance = 0.5;
    let mut patch = noise_floor(base.clone());
    patch.object.texture = Texture::Noise;
    patch.object.noise = NoiseDistribution::Binary;
    figs.push(FigureDef {
        id: "fig7",
        title: "Fig. 7: dynamic noise floor — (a) uniform disk of luminance 0.5, (b) noise patch; all models",
        // the frame models (the event rows, which read an event camera, are not the paper's)
        detectors: detector_ids()
            .into_iter()
            .filter(|id| !crate::baselines::EVENT_IDS.contains(id))
            .collect(),
        conditions: vec![
            cond("a uniform disk".into(), uniform),
            cond("b noise patch".into(), patch),
        ],
        skip_frames: 10,
    });
    figs.push(FigureDef {
        id: "fig8",
        title: "Fig. 8: focus of expansion x_foe = 0…1 (checkerboard disk on gray): SOC and Hopfield",
        detectors: vec!["soc", "hopfield"],
        conditions: [0.0, 0.25, 0.5, 0.75, 1.0]
            .iter()
            .map(|&x| {
                let mut s = base.clone();
                s.object.texture = Texture::Checker;
                s.object.focus_x = x;
                cond(format!("foe={x}"), s)
            })
            .collect(),
        skip_frames: 0,
    });
    figs
}

/// Numbers describing one response curve of a figure.
#[derive(Debug, Clone)]
pub struct CurveSummary {
    /// Mean output while the true angular size is below 5° (spurious "early" activity).
    pub early_mean: f64,
    /// Maximum output over the whole approach.
    pub peak: f64,
    /// Frame of the maximum.
    pub peak_frame: usize,
    /// Pearson correlation of the output with the true angular size.
    pub corr_theta: f64,
}

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    if saa > 0.0 && sbb > 0.0 {
        sab / (saa * sbb).sqrt()
    } else {
        0.0
    }
}

/// Summarises a response curve against the true angular size.
pub fn summarise(output: &[f64], theta_deg: &[f64]) -> CurveSummary {
    let early: Vec<f64> = output
        .iter()
        .zip(theta_deg)
        .filter(|(_, t)| **t < 5.0)
        .map(|(o, _)| *o)
        .collect();
    let (peak_frame, peak) = output
        .iter()
        .copied()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |b, (i, v)| if v > b.1 { (i, v) } else { b });
    CurveSummary {
        early_mean: if early.is_empty() {
            f64::NAN
        } else {
            early.iter().sum::<f64>() / early.len() as f64
        },
        peak,
        peak_frame,
        corr_theta: pearson(output, theta_deg),
    }
}

/// Runs the figure's detectors on one condition's frames: one output vector per detector.
pub fn run_condition(
    frames: &[StimulusFrame],
    detectors: &[&str],
    set: &DetectorSet,
) -> Result<Vec<Vec<f64>>, DetectorError> {
    let Some(n) = frames.first().map(|f| f.frame.n()) else {
        return Ok(vec![Vec::new(); detectors.len()]);
    };
    detectors
        .iter()
        .map(|id| {
            let mut det = set.build(id, n)?;
            frames.iter().map(|f| Ok(det.step(&f.frame)?.output)).collect()
        })
        .collect()
}
