//! The trace figure of an exemplar episode: every detector's signal against the true geometry.

use loomlab_scenarios::EpisodeRun;
use loomlab_scenarios::reference::is_reference;

use crate::plot::{LineChart, Series};
use crate::run_plots::{Figure, FigureKind};

/// The trace plot of an episode: every detector's trigger signal divided by its threshold (an
/// alarm where it reaches 1; reference rows are not drawn, their outcomes are in the page's
/// table), and the reference object's true angular size and time to contact,
/// with the escape deadline and the contact marked.
pub fn trace_figure(run: &EpisodeRun) -> Figure {
    /// Signal / threshold is drawn up to this (the alarm is at 1).
    const CLIP: f64 = 3.0;
    let tr = &run.trace;
    let t0 = tr.t_s.first().copied().unwrap_or(0.0);
    let t1 = tr.t_s.last().copied().unwrap_or(1.0);
    let contact = run.outcome.detectors.first().and_then(|d| d.t_contact_s);
    let marks = |y_max: f64| {
        let mut v = Vec::new();
        if let Some(dl) = tr.t_deadline_s {
            v.push(Series::new(format!("escape deadline {dl:.2} s"), vec![dl, dl], vec![0.0, y_max]).dashed());
        }
        if let Some(c) = contact {
            v.push(Series::new(format!("contact {c:.2} s"), vec![c, c], vec![0.0, y_max]).dashed());
        }
        v
    };
    let mut signals: Vec<Series> = tr
        .detectors
        .iter()
        .filter(|d| !is_reference(&d.label))
        .map(|d| {
            let y = d
                .signal
                .iter()
                .map(|&v| {
                    if d.threshold > 0.0 {
                        (v / d.threshold).min(CLIP)
                    } else {
                        f64::NAN
                    }
                })
                .collect();
            Series::new(d.label.clone(), tr.t_s.clone(), y)
        })
        .collect();
    signals.push(Series::new("alarm threshold", vec![t0, t1], vec![1.0, 1.0]).dashed());
    signals.extend(marks(CLIP));
    let theta_max = tr
        .angular_size_deg
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(1.0f64, f64::max)
        .min(180.0);
    let object = tr.reference_object.clone().unwrap_or_else(|| "reference object".into());
    let mut theta = vec![Series::new(
        format!("true angular size of {object}"),
        tr.t_s.clone(),
        tr.angular_size_deg.clone(),
    )];
    theta.extend(marks(theta_max * 1.05));
    let ttc: Vec<f64> = tr.ttc_s.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
    let ttc_max = ttc.iter().copied().filter(|v| v.is_finite()).fold(0.0f64, f64::max);
    let mut ttc_series = vec![Series::new(
        format!("true time to contact of {object}"),
        tr.t_s.clone(),
        ttc,
    )];
    let x_range = Some((t0, t1.max(t0 + 1e-3)));
    let mut charts = vec![
        LineChart {
            title: "trigger signal / alarm threshold".into(),
            x_label: "time (s)".into(),
            y_label: "signal / threshold".into(),
            series: signals,
            x_range,
            y_range: Some((0.0, CLIP)),
        },
        LineChart {
            title: "true angular size".into(),
            x_label: "time (s)".into(),
            y_label: "θ (deg)".into(),
            series: theta,
            x_range,
            y_range: Some((0.0, theta_max * 1.05)),
        },
    ];
    if ttc_max > 0.0 {
        ttc_series.extend(marks(ttc_max * 1.05));
        charts.push(LineChart {
            title: "true time to contact".into(),
            x_label: "time (s)".into(),
            y_label: "TTC (s)".into(),
            series: ttc_series,
            x_range,
            y_range: Some((0.0, ttc_max * 1.05)),
        });
    }
    Figure {
        name: "exemplar_trace",
        caption: String::new(),
        kind: FigureKind::Lines {
            charts,
            cols: 1,
            panel: (560, 220),
        },
    }
}
