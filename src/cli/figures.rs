//! `loomlab figures`: regenerate the paper's artificial-video experiments (Figs. 3–8) as PNG + CSV.
//!
//! Every figure is a set of conditions (one stimulus each) and a set of detectors. Each condition
//! becomes one panel with the detectors' responses, normalised as in the paper's §3.2, and the
//! normalised true angular size (dashed). `FIG.csv` holds the raw outputs (`<condition>/<id>`
//! columns) and `summary.csv` a few numbers per curve (see `loomlab_detector::stimulus::paper::CurveSummary`).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use loomlab_detector::stimulus::StimulusFrame;
use loomlab_detector::stimulus::paper::{FigureDef, paper_figures, run_condition, summarise};
use loomlab_detector::{DetectorSet, HopfieldConfig};
use rayon::prelude::*;

use super::detect::display_normalise;
use loomlab_report::plot::{LineChart, Series, line_chart_grid};

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
            .collect::<Result<_, _>>()?;
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
    outln!(
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
