//! Every plot loomlab draws: PNG files (plotters' bitmap backend, with an embedded font so no
//! system fonts are needed) and the same charts as SVG text for `report.html` (plotters' SVG
//! backend: line art stays crisp and small).
//!
//! Three chart kinds cover every plot: line charts (detector responses over time, ROC curves,
//! scatters with a fit), grids of line charts (one panel per condition, like the paper's figures)
//! and grouped bar charts (rates per scenario). Each is drawn by one function generic over the
//! backend, so a PNG and its SVG are the same drawing.

use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// Errors while drawing a plot.
#[derive(Debug, thiserror::Error)]
#[error("cannot write plot {path}: {reason}")]
pub struct PlotError {
    /// The PNG being written (`<svg>` for an SVG drawn into memory).
    pub path: String,
    /// What went wrong.
    pub reason: String,
}

/// One curve.
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// x values.
    pub x: Vec<f64>,
    /// y values (non-finite values are skipped).
    pub y: Vec<f64>,
    /// Draw dashed/thin (e.g. the true angular size or a chance diagonal).
    pub dashed: bool,
    /// Draw the points as markers, not joined, with this straight line `y = slope·x + intercept`
    /// in the same colour when given (a scatter with its fit).
    pub scatter: Option<Option<(f64, f64)>>,
}

impl Series {
    /// A solid curve.
    pub fn new(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Self {
            name: name.into(),
            x,
            y,
            dashed: false,
            scatter: None,
        }
    }

    /// The points as markers, with an optional fitted line `(slope, intercept)` in their colour.
    pub fn scatter(mut self, fit: Option<(f64, f64)>) -> Self {
        self.scatter = Some(fit);
        self
    }

    /// The same curve drawn thin and gray-ish as a reference line.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
}

/// A line chart.
#[derive(Debug, Clone, Default)]
pub struct LineChart {
    /// Title above the plot.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// The curves.
    pub series: Vec<Series>,
    /// Fixed y range; by default the data range with a margin.
    pub y_range: Option<(f64, f64)>,
    /// Fixed x range; by default the data range.
    pub x_range: Option<(f64, f64)>,
}

/// The colour of the `i`-th series (the same in every plot, the page and the GIF borders).
pub fn palette(i: usize) -> RGBColor {
    const C: [RGBColor; 8] = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(255, 127, 14),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(23, 190, 207),
    ];
    C[i % C.len()]
}

pub(crate) fn register_font() {
    REGISTER.call_once(|| {
        // The font is compiled in; failure would be a build defect, not user input.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

fn err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    (lo <= hi).then_some((lo, hi))
}

fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    if hi - lo < 1e-12 {
        (lo - 0.5, hi + 0.5)
    } else {
        let m = 0.05 * (hi - lo);
        (lo - m, hi + m)
    }
}

fn draw_line_chart<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, chart: &LineChart) -> Result<(), String> {
    let xr = chart
        .x_range
        .or_else(|| finite_range(chart.series.iter().flat_map(|s| s.x.iter().copied())))
        .unwrap_or((0.0, 1.0));
    let xr = if xr.1 - xr.0 < 1e-12 { padded(xr) } else { xr };
    let yr = chart
        .y_range
        .or_else(|| finite_range(chart.series.iter().flat_map(|s| s.y.iter().copied())).map(padded))
        .unwrap_or((0.0, 1.0));
    let mut ctx = ChartBuilder::on(area)
        .caption(&chart.title, ("sans-serif", 18))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(|e| e.to_string())?;
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .label_style(("sans-serif", 12))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    let mut solid = 0;
    for s in &chart.series {
        let pts: Vec<(f64, f64)> =
            s.x.iter()
                .zip(&s.y)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .map(|(&x, &y)| (x, y))
                .collect();
        let style = if s.dashed {
            RGBColor(90, 90, 90).stroke_width(1)
        } else {
            solid += 1;
            palette(solid - 1).stroke_width(2)
        };
        let anno = if let Some(fit) = s.scatter {
            let color = style.color;
            if let Some((slope, intercept)) = fit {
                let line = [xr.0, xr.1].map(|x| (x, slope * x + intercept));
                ctx.draw_series(LineSeries::new(line, color.stroke_width(1)))
                    .map_err(|e| e.to_string())?;
            }
            ctx.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))
                .map_err(|e| e.to_string())?
        } else if s.dashed {
            ctx.draw_series(DashedLineSeries::new(pts, 6, 4, style))
                .map_err(|e| e.to_string())?
        } else {
            ctx.draw_series(LineSeries::new(pts, style))
                .map_err(|e| e.to_string())?
        };
        if !s.name.is_empty() {
            anno.label(&s.name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
        }
    }
    if chart.series.iter().any(|s| !s.name.is_empty()) {
        ctx.configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .label_font(("sans-serif", 12))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Writes one line chart as a PNG of `size` pixels.
pub fn line_chart(path: &Path, chart: &LineChart, size: (u32, u32)) -> Result<(), PlotError> {
    line_chart_grid(path, std::slice::from_ref(chart), 1, size)
}

/// Writes a grid of line charts (`cols` panels per row) as one PNG; `panel` is one panel's size.
pub fn line_chart_grid(path: &Path, charts: &[LineChart], cols: usize, panel: (u32, u32)) -> Result<(), PlotError> {
    register_font();
    let size = grid_size(charts.len(), cols, panel);
    write_png(path, size, |root| draw_grid(root, charts, cols))
}

/// One line chart as SVG text (`<svg …>…</svg>`) of `size` pixels.
pub fn line_chart_svg(chart: &LineChart, size: (u32, u32)) -> Result<String, PlotError> {
    line_chart_grid_svg(std::slice::from_ref(chart), 1, size)
}

/// A grid of line charts (`cols` panels per row) as SVG text; `panel` is one panel's size.
pub fn line_chart_grid_svg(charts: &[LineChart], cols: usize, panel: (u32, u32)) -> Result<String, PlotError> {
    register_font();
    let size = grid_size(charts.len(), cols, panel);
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        draw_grid(&root, charts, cols).map_err(|e| err(Path::new("<svg>"), e))?;
    }
    Ok(text)
}

/// Draws a chart of `size` pixels into an RGB buffer and writes it as a PNG (with the `image`
/// crate the workspace already uses, not plotters' own encoder, which pulls in a second version of
/// it: one fewer dependency tree to compile).
fn write_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>,
) -> Result<(), PlotError> {
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(&root).map_err(|e| err(path, e))?;
    }
    image::save_buffer_with_format(
        path,
        &rgb,
        size.0,
        size.1,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| err(path, e))
}

fn grid_size(charts: usize, cols: usize, panel: (u32, u32)) -> (u32, u32) {
    let cols = cols.max(1);
    let rows = charts.div_ceil(cols).max(1);
    (panel.0 * cols as u32, panel.1 * rows as u32)
}

fn draw_grid<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    charts: &[LineChart],
    cols: usize,
) -> Result<(), String> {
    let cols = cols.max(1);
    let rows = charts.len().div_ceil(cols).max(1);
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let areas = root.split_evenly((rows, cols));
    for (area, chart) in areas.iter().zip(charts) {
        draw_line_chart(area, chart)?;
    }
    root.present().map_err(|e| e.to_string())
}

/// Writes a grouped bar chart as a PNG: one group of bars per category, one bar per named
/// series, values in [0, 1] (rates).
pub fn rate_bars(
    path: &Path,
    title: &str,
    categories: &[String],
    series: &[(String, Vec<f64>)],
    size: (u32, u32),
) -> Result<(), PlotError> {
    register_font();
    write_png(path, size, |root| draw_rate_bars(root, title, categories, series))
}

/// [`rate_bars`] as SVG text.
pub fn rate_bars_svg(
    title: &str,
    categories: &[String],
    series: &[(String, Vec<f64>)],
    size: (u32, u32),
) -> Result<String, PlotError> {
    register_font();
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        draw_rate_bars(&root, title, categories, series).map_err(|e| err(Path::new("<svg>"), e))?;
    }
    Ok(text)
}

fn draw_rate_bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    categories: &[String],
    series: &[(String, Vec<f64>)],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let ncat = categories.len().max(1);
    let nser = series.len().max(1);
    let mut ctx = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(110)
        .y_label_area_size(50)
        .build_cartesian_2d(0f64..ncat as f64, 0f64..1.05)
        .map_err(|e| e.to_string())?;
    let cats = categories.to_vec();
    ctx.configure_mesh()
        .disable_x_mesh()
        .x_labels(ncat * 2 + 1)
        .x_label_formatter(&|x| {
            let i = x.floor() as usize;
            if (x - i as f64 - 0.5).abs() < 1e-6 {
                cats.get(i).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .x_label_style(("sans-serif", 11).into_font().transform(FontTransform::Rotate90))
        .y_desc("rate")
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(|e| e.to_string())?;
    let w = 0.8 / nser as f64;
    for (k, (name, values)) in series.iter().enumerate() {
        let color = palette(k);
        ctx.draw_series(values.iter().enumerate().filter(|(_, v)| v.is_finite()).map(|(i, &v)| {
            let x0 = i as f64 + 0.1 + k as f64 * w;
            Rectangle::new([(x0, 0.0), (x0 + w * 0.95, v)], color.filled())
        }))
        .map_err(|e| e.to_string())?
        .label(name)
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    ctx.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .label_font(("sans-serif", 12))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_pngs() {
        let dir = std::env::temp_dir().join(format!("loomlab-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let x: Vec<f64> = (0..50).map(f64::from).collect();
        let chart = LineChart {
            title: "test".into(),
            x_label: "t".into(),
            y_label: "z".into(),
            series: vec![
                Series::new("a", x.clone(), x.iter().map(|v| v * v).collect()),
                Series::new(
                    "nan-holes",
                    x.clone(),
                    x.iter().map(|&v| if v > 10.0 { f64::NAN } else { v }).collect(),
                )
                .dashed(),
            ],
            ..Default::default()
        };
        let p = dir.join("line.png");
        line_chart(&p, &chart, (400, 300)).unwrap();
        let img = image::open(&p).unwrap();
        assert_eq!((img.width(), img.height()), (400, 300));
        line_chart_grid(&dir.join("grid.png"), &[chart.clone(), chart.clone()], 2, (300, 200)).unwrap();
        rate_bars(
            &dir.join("bars.png"),
            "rates",
            &["s1".into(), "s2".into()],
            &[("hit".into(), vec![0.5, 1.0]), ("fa".into(), vec![0.1, f64::NAN])],
            (500, 400),
        )
        .unwrap();
        assert!(dir.join("bars.png").metadata().unwrap().len() > 1000);
        let svg = line_chart_grid_svg(&[chart.clone(), chart.clone()], 2, (300, 200)).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains("polyline") && svg.contains(">\ntest\n</text>"),
            "{svg}"
        );
        let bars = rate_bars_svg("rates", &["s1".into()], &[("hit".into(), vec![0.5])], (300, 200)).unwrap();
        assert!(bars.contains("<rect") && bars.contains(">\ns1\n</text>"), "{bars}");
    }
}
