//! `loomlab figures`: regenerate the paper's artificial-video experiments (Figs. 3–8) as PNG + CSV.
//!
//! Every figure is a set of conditions (one stimulus each) and a set of detectors. Each condition
//! becomes one panel with the detectors' responses, normalised as in the paper's §3.2, and the
//! normalised true angular size (dashed). `FIG.csv` holds the raw outputs (`<condition>/<id>`
//! columns) and `summary.csv` a few numbers per curve (see [`CurveSummary`]).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use loomlab_detector::stimulus::{BackgroundKind, CorruptionSection, ForegroundSection, NoiseDistribution, Texture};
use loomlab_detector::stimulus::{StimulusFrame, StimulusSpec};
use loomlab_detector::{DETECTOR_IDS, DetectorSet, HopfieldConfig};
use rayon::prelude::*;

use super::detect::display_normalise;
use crate::plot::{LineChart, Series, line_chart_grid};

/// Arguments of `loomlab figures`.
#[derive(Debug, Args)]
pub struct FiguresArgs {
    /// Output folder for the PNG and CSV files.
    #[arg(long, short, default_value = "out/figures")]
    pub out: PathBuf,
    /// Frame size n (the paper uses 256; smaller is faster).
    #[arg(long, default_value_t = 256)]
    pub size: usize,
    /// Only these figures (comma-separated, e.g. `fig3a,fig7`); default all.
    #[arg(long, value_name = "FIG[,FIG...]")]
    pub only: Option<String>,
    /// Seed of the noise textures and dropout.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

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
        detectors: DETECTOR_IDS.to_vec(),
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
pub fn run_condition(frames: &[StimulusFrame], detectors: &[&str], set: &DetectorSet) -> anyhow::Result<Vec<Vec<f64>>> {
    let n = frames.first().map(|f| f.frame.n()).context("stimulus has no frames")?;
    detectors
        .iter()
        .map(|id| {
            let mut det = set.build(id, n)?;
            frames.iter().map(|f| Ok(det.step(&f.frame)?.output)).collect()
        })
        .collect()
}

/// Runs `loomlab figures`.
pub fn run(args: FiguresArgs) -> anyhow::Result<i32> {
    if args.size < 16 {
        bail!("--size must be at least 16 pixels, got {}", args.size);
    }
    let mut figs = paper_figures(args.size, args.seed);
    if let Some(only) = &args.only {
        let wanted: Vec<&str> = only.split(',').map(str::trim).collect();
        let known: Vec<&str> = figs.iter().map(|f| f.id).collect();
        if let Some(bad) = wanted.iter().find(|w| !known.contains(w)) {
            bail!("unknown figure `{bad}` in --only; known: {}", known.join(", "));
        }
        figs.retain(|f| wanted.contains(&f.id));
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let set = DetectorSet {
        hopfield: HopfieldConfig::for_size(args.size),
        ..Default::default()
    };
    let total: usize = figs.iter().map(|f| f.conditions.len()).sum();
    let bar = super::progress(total as u64, "figures");
    let summary_path = args.out.join("summary.csv");
    let mut summary = BufWriter::new(File::create(&summary_path)?);
    writeln!(
        summary,
        "figure,condition,detector,early_mean,peak,peak_frame,corr_theta"
    )?;
    for fig in &figs {
        let results: Vec<(Vec<StimulusFrame>, Vec<Vec<f64>>)> = fig
            .conditions
            .par_iter()
            .map(|c| {
                let frames = c.spec.render();
                let out = run_condition(&frames, &fig.detectors, &set);
                bar.inc(1);
                out.map(|o| (frames, o))
            })
            .collect::<anyhow::Result<_>>()?;
        write_figure(&args, fig, &results, &set)?;
        for (c, (frames, outputs)) in fig.conditions.iter().zip(&results) {
            let theta: Vec<f64> = frames.iter().map(|f| f.theta_true_deg).collect();
            for (id, out) in fig.detectors.iter().zip(outputs) {
                let s = summarise(out, &theta);
                writeln!(
                    summary,
                    "{},{},{},{:.6},{:.6},{},{:.4}",
                    fig.id, c.label, id, s.early_mean, s.peak, s.peak_frame, s.corr_theta
                )?;
            }
        }
    }
    bar.finish_and_clear();
    summary.flush()?;
    println!(
        "wrote {} figures (PNG + CSV) and {} to {}",
        figs.len(),
        summary_path.display(),
        args.out.display()
    );
    Ok(0)
}

fn write_figure(
    args: &FiguresArgs,
    fig: &FigureDef,
    results: &[(Vec<StimulusFrame>, Vec<Vec<f64>>)],
    set: &DetectorSet,
) -> anyhow::Result<()> {
    let memory_columns = set.hopfield.template.template_count(args.size) + 1;
    let csv_path = args.out.join(format!("{}.csv", fig.id));
    let mut csv = BufWriter::new(File::create(&csv_path)?);
    let mut header = vec!["frame".to_string(), "t_s".into(), "theta_true_deg".into()];
    for c in &fig.conditions {
        header.extend(fig.detectors.iter().map(|id| format!("{}/{id}", c.label)));
    }
    writeln!(csv, "{}", header.join(","))?;
    let frames = &results[0].0;
    for (k, f) in frames.iter().enumerate() {
        let mut row = vec![
            k.to_string(),
            format!("{:.6}", f.t_s),
            format!("{:.6}", f.theta_true_deg),
        ];
        for (_, outputs) in results {
            row.extend(outputs.iter().map(|o| format!("{:.9}", o[k])));
        }
        writeln!(csv, "{}", row.join(","))?;
    }
    csv.flush()?;

    let skip = fig.skip_frames.min(frames.len().saturating_sub(1));
    let charts: Vec<LineChart> = fig
        .conditions
        .iter()
        .zip(results)
        .map(|(c, (frames, outputs))| {
            let t: Vec<f64> = frames[skip..].iter().map(|f| f.t_s).collect();
            let theta: Vec<f64> = frames[skip..].iter().map(|f| f.theta_true_deg).collect();
            let cols: Vec<(&str, &[f64])> = fig
                .detectors
                .iter()
                .zip(outputs)
                .map(|(id, o)| (*id, &o[skip..]))
                .collect();
            let (scaled, theta) = display_normalise(&cols, Some(&theta), memory_columns);
            let mut series: Vec<Series> = scaled
                .into_iter()
                .map(|(id, y)| Series::new(id, t.clone(), y))
                .collect();
            series.push(Series::new("θ", t.clone(), theta.unwrap_or_default()).dashed());
            LineChart {
                title: format!("{} — {}", fig.id, c.label),
                x_label: "t [s]".into(),
                y_label: "normalised response".into(),
                series,
                ..Default::default()
            }
        })
        .collect();
    let cols = if charts.len() > 4 { 3 } else { 2 };
    line_chart_grid(&args.out.join(format!("{}.png", fig.id)), &charts, cols, (520, 340))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_numbers() {
        let s = summarise(&[1.0, 1.0, 2.0, 8.0], &[1.0, 2.0, 6.0, 20.0]);
        assert_eq!(s.early_mean, 1.0);
        assert_eq!((s.peak, s.peak_frame), (8.0, 3));
        assert!(s.corr_theta > 0.99);
    }

    #[test]
    fn every_figure_is_defined() {
        let ids: Vec<_> = paper_figures(64, 1).iter().map(|f| f.id).collect();
        assert_eq!(
            ids,
            ["fig3a", "fig3b", "fig4", "fig5a", "fig5b", "fig6", "fig7", "fig8"]
        );
    }
}
