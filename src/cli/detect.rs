//! `loomlab detect`: run detectors on a stimulus file or a video, write `responses.csv` and a plot.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};
use clap::{Args, ValueEnum};
use loomlab_detector::hopfield::config::CAMERA_KEYS;
use loomlab_detector::hopfield::{HopfieldConfig, Implementation};
use loomlab_detector::stimulus::StimulusSpec;
use loomlab_detector::video::{frame_files, load_video};
use loomlab_detector::{DetectorSet, Frame, MIN_FRAME_SIZE, NonSquare, parse_detector_list};

use super::efference::{CameraMount, efference_copies, read_poses};
use loomlab_sim::{SensorDesc, SensorProfile};

use loomlab_report::plot::{LineChart, Series, line_chart};

/// Implementation of the Hopfield detector (both give the same numbers to 1e-6).
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ImplArg {
    /// Literal dense equations of the paper (slow; for checking).
    Reference,
    /// Exact fast path: shared product, pattern-space iteration, sparse templates.
    Fast,
}

/// How to make non-square video frames square (paper §2.2.1).
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum NonSquareArg {
    /// Embed in an n = max(rows, cols) square of luminance 0.5.
    Embed,
    /// Crop to an n = min(rows, cols) square.
    Crop,
}

/// Arguments of `loomlab detect`.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["stimulus", "video"])))]
pub struct DetectArgs {
    /// Stimulus file (TOML, see stimuli/README.md): an analytic approach video with its true angular size.
    #[arg(long, value_name = "FILE.toml")]
    pub stimulus: Option<PathBuf>,
    /// Video: a folder of PNG/JPEG frames (natural filename order) or an animated GIF, read as grayscale.
    #[arg(long, value_name = "DIR|FILE.gif")]
    pub video: Option<PathBuf>,
    /// Detector ids, comma-separated, or `all` (every registered detector: hopfield, soc, keil2004,
    /// cizek2019, fu2020, …).
    #[arg(long, short, default_value = "hopfield", value_name = "ID[,ID...]|all")]
    pub detector: String,
    /// Hopfield implementation.
    #[arg(long = "impl", value_enum, default_value = "fast")]
    pub implementation: ImplArg,
    /// Hopfield parameters as a TOML file (keys of HopfieldConfig; unknown keys are errors).
    /// `n`, `fov_deg` and `frame_rate_hz` come from the input (stimulus file or video and
    /// `--fov-deg`/`--fps`) and are rejected here.
    #[arg(long, value_name = "FILE.toml")]
    pub hopfield_config: Option<PathBuf>,
    /// Camera field of view in degrees for the angular-size readout of videos (stimuli carry their own).
    #[arg(long, default_value_t = 60.0)]
    pub fov_deg: f64,
    /// Frame rate of a folder of frames (GIFs carry their own).
    #[arg(long, default_value_t = 120.0)]
    pub fps: f64,
    /// Non-square video frames: embed in gray or crop.
    #[arg(long, value_enum, default_value = "embed")]
    pub non_square: NonSquareArg,
    /// The robot's own motion for a --video: a CSV with one pose per frame (the truth.csv that
    /// `loomlab render` writes, or columns t_s, x, y and yaw_deg or yaw_rad). Each frame's detector
    /// then gets the efference copy of the camera period that ended with it (what the scenario
    /// runner gives; docs/detectors.md): the ego-motion-compensated detectors need it.
    #[arg(long, value_name = "FILE.csv", requires = "video")]
    pub efference: Option<PathBuf>,
    /// How far ahead of the robot's origin (the pose in the --efference CSV) the camera sits (m;
    /// `loomlab render`'s default camera: 0.25).
    #[arg(long, value_name = "M", default_value_t = 0.0, requires = "efference")]
    pub camera_forward_m: f64,
    /// Height of the camera above the ground for --efference (m; without it only the camera's
    /// rotation is compensated; `loomlab render`'s default camera: 0.3).
    #[arg(long, value_name = "M", requires = "efference")]
    pub camera_height_m: Option<f64>,
    /// Pitch of the camera's optical axis above the horizontal for --efference (degrees).
    #[arg(long, value_name = "DEG", default_value_t = 0.0, requires = "efference")]
    pub camera_pitch_deg: f64,
    /// Sensor profile applied to every input frame (`ideal`: the frames as read; `robot`: shot and
    /// read noise, gain and 8-bit quantisation, docs/reference.md "Sensor profiles"). Only the
    /// per-frame part applies: the profile's exposure blur needs the world between two frames and
    /// its perception and actuation latencies a robot in a world, so neither is modelled here (use
    /// `loomlab run --sensor` for the whole profile).
    #[arg(long, value_name = "PROFILE", default_value = "ideal")]
    pub sensor: String,
    /// Seed of the --sensor noise: the same seed gives the same noisy frames (frame k draws from
    /// stream k of this seed, as the simulator's frame k does).
    #[arg(long, value_name = "SEED", default_value_t = 0)]
    pub seed: u64,
    /// Output folder for responses.csv and responses.png (created if missing).
    #[arg(long, short, default_value = "out/detect")]
    pub out: PathBuf,
}

/// Frames to process plus their timing and ground truth.
struct Input {
    frames: Vec<Frame>,
    t_s: Vec<f64>,
    theta_true_deg: Option<Vec<f64>>,
    fov_deg: f64,
    /// Frame rate (frames per second).
    fps: f64,
    /// Where `fov_deg`, `fps` and the frame size come from, for error messages.
    camera_source: CameraSource,
    label: String,
}

/// Where the camera facts (frame size, field of view, frame rate) of the input come from.
enum CameraSource {
    Stimulus,
    Video { gif_fps: bool },
}

impl CameraSource {
    /// Where the value of the Hopfield key `key` (one of [`CAMERA_KEYS`]) comes from.
    fn origin_of(&self, key: &str) -> &'static str {
        match (self, key) {
            (CameraSource::Stimulus, "n") => "the stimulus file's `stimulus.size`",
            (CameraSource::Stimulus, "fov_deg") => "the stimulus file's `stimulus.fov_deg`",
            (CameraSource::Stimulus, _) => "the stimulus file's `stimulus.fps`",
            (CameraSource::Video { .. }, "n") => "the video's frame size (see --non-square)",
            (CameraSource::Video { .. }, "fov_deg") => "the --fov-deg flag",
            (CameraSource::Video { gif_fps: true }, _) => "the GIF's frame delays",
            (CameraSource::Video { gif_fps: false }, _) => "the --fps flag",
        }
    }
}

fn load_input(args: &DetectArgs) -> anyhow::Result<Input> {
    if let Some(path) = &args.stimulus {
        let spec = StimulusSpec::load(path)?;
        let rendered = spec.render();
        return Ok(Input {
            t_s: rendered.iter().map(|f| f.t_s).collect(),
            theta_true_deg: Some(rendered.iter().map(|f| f.theta_true_deg).collect()),
            frames: rendered.into_iter().map(|f| f.frame).collect(),
            fov_deg: spec.stimulus.fov_deg,
            fps: spec.stimulus.fps,
            camera_source: CameraSource::Stimulus,
            label: path.display().to_string(),
        });
    }
    let path = args.video.as_ref().expect("clap requires --stimulus or --video");
    let mode = match args.non_square {
        NonSquareArg::Embed => NonSquare::Embed,
        NonSquareArg::Crop => NonSquare::Crop,
    };
    if !(args.fov_deg.is_finite() && args.fov_deg > 0.0 && args.fov_deg < 180.0) {
        bail!(
            "--fov-deg = {}: the field of view must be in (0, 180) degrees, e.g. 60",
            args.fov_deg
        );
    }
    if path.is_dir() {
        check_frame_numbers(&frame_files(path)?)?;
    }
    let video = load_video(path, mode)?;
    if video.frame_size() < MIN_FRAME_SIZE {
        bail!(
            "{}: the frames are {n}×{n} pixels once made square (--non-square {}); the detectors need at least \
             {MIN_FRAME_SIZE}×{MIN_FRAME_SIZE}{}",
            path.display(),
            if mode == NonSquare::Crop { "crop" } else { "embed" },
            if mode == NonSquare::Crop {
                " (cropping keeps the shorter side: try --non-square embed)"
            } else {
                ""
            },
            n = video.frame_size()
        );
    }
    let fps = video.fps.unwrap_or(args.fps);
    if !(fps.is_finite() && fps > 0.0) {
        bail!("--fps = {fps}: must be a positive number of frames per second, e.g. 120");
    }
    let invalid: usize = video.frames.iter().map(Frame::invalid_pixels).sum();
    if invalid > 0 {
        errln!(
            "warning: {invalid} non-finite pixel values in {} were read as black",
            path.display()
        );
    }
    Ok(Input {
        t_s: (0..video.len()).map(|k| k as f64 / fps).collect(),
        theta_true_deg: None,
        frames: video.frames,
        fov_deg: args.fov_deg,
        fps,
        camera_source: CameraSource::Video {
            gif_fps: video.fps.is_some(),
        },
        label: path.display().to_string(),
    })
}

/// Applies the per-frame part of the `--sensor` profile (noise, gain, gamma, quantisation; not the
/// exposure blur nor the latencies) to every input frame, frame k with noise stream k of `--seed`.
fn apply_sensor(args: &DetectArgs, input: &mut Input) -> anyhow::Result<()> {
    let profile = SensorProfile::named(&args.sensor).map_err(|reason| anyhow!("--sensor {}: {reason}", args.sensor))?;
    let per_frame = SensorDesc {
        exposure_s: 0.0,
        ..profile.sensor
    };
    let Some(sensor) = per_frame
        .build(1.0 / input.fps)
        .with_context(|| format!("--sensor {}", args.sensor))?
    else {
        return Ok(());
    };
    for (k, frame) in input.frames.iter_mut().enumerate() {
        let mut pixels = frame.data().to_vec();
        sensor.apply(&mut pixels, args.seed, k as u64);
        *frame = Frame::from_f32(frame.n(), pixels)?;
    }
    Ok(())
}

/// Refuses numbered frame files with a gap (`frame_8`, `frame_10`): frame k is shown at k / fps,
/// so a missing file would shift every later frame's time. Files are numbered when every name
/// ends in digits after the same prefix; the numbers must then step evenly.
fn check_frame_numbers(files: &[PathBuf]) -> anyhow::Result<()> {
    let numbered: Option<Vec<(&str, u64)>> = files
        .iter()
        .map(|f| {
            let stem = f.file_stem()?.to_str()?;
            let digits = stem.len() - stem.trim_end_matches(|c: char| c.is_ascii_digit()).len();
            let (prefix, number) = stem.split_at(stem.len() - digits);
            Some((prefix, number.parse().ok()?))
        })
        .collect();
    let Some(numbered) = numbered else {
        return Ok(());
    };
    if numbered.len() < 3 || numbered.iter().any(|(prefix, _)| *prefix != numbered[0].0) {
        return Ok(());
    }
    // sorted in natural order, so the numbers ascend; the smallest step is the video's
    let steps: Vec<u64> = numbered.windows(2).map(|p| p[1].1 - p[0].1).collect();
    let step = steps.iter().copied().min().unwrap_or(1);
    for (k, &d) in steps.iter().enumerate() {
        if d == 0 || d != step {
            let why = if d == 0 {
                "both have the same frame number".to_string()
            } else {
                format!("frame numbers step by {step} elsewhere but by {d} here, so frames are missing")
            };
            bail!(
                "{} is followed by {}: {why}, and every later frame would be shown at the wrong time; add the \
                 missing frames or renumber the files",
                files[k].display(),
                files[k + 1].display()
            );
        }
    }
    Ok(())
}

/// One output column of responses.csv.
struct Column {
    name: String,
    values: Vec<f64>,
}

/// Runs `loomlab detect`.
pub fn run(args: DetectArgs) -> anyhow::Result<i32> {
    let ids = parse_detector_list(&args.detector)?;
    let mut input = load_input(&args)?;
    apply_sensor(&args, &mut input)?;
    let n = input.frames.first().map(Frame::n).context("the input has no frames")?;

    let hopfield = match &args.hopfield_config {
        Some(p) => load_hopfield_config(p, &input)?,
        None => HopfieldConfig::default(),
    };
    let hopfield = HopfieldConfig {
        fov_deg: input.fov_deg,
        frame_rate_hz: input.fps,
        implementation: match args.implementation {
            ImplArg::Reference => Implementation::Reference,
            ImplArg::Fast => Implementation::Fast,
        },
        ..hopfield
    };
    let set = DetectorSet {
        hopfield,
        ..DetectorSet::default()
    };
    let mut detectors = ids.iter().map(|id| set.build(id, n)).collect::<Result<Vec<_>, _>>()?;
    let efference = match &args.efference {
        Some(path) => {
            if let Some(h) = args.camera_height_m.filter(|h| !(h.is_finite() && *h > 0.0)) {
                bail!("--camera-height-m {h}: the camera's height above the ground must be a number of metres > 0");
            }
            if !(args.camera_pitch_deg.is_finite() && args.camera_pitch_deg.abs() < 90.0) {
                bail!(
                    "--camera-pitch-deg {}: the pitch must lie strictly between -90 and 90 degrees",
                    args.camera_pitch_deg
                );
            }
            if !args.camera_forward_m.is_finite() {
                bail!(
                    "--camera-forward-m {}: must be a number of metres",
                    args.camera_forward_m
                );
            }
            let mount = CameraMount {
                forward_m: args.camera_forward_m,
                height_m: args.camera_height_m,
                pitch_rad: args.camera_pitch_deg.to_radians(),
            };
            Some(efference_copies(&read_poses(path, input.frames.len())?, mount))
        }
        None => None,
    };

    // Everything is computed before anything is written: an error leaves no partial output.
    let has_hopfield = ids.contains(&"hopfield");
    let mut header = vec!["frame".to_string(), "t_s".into(), "theta_true_deg".into()];
    header.extend(ids.iter().map(|s| s.to_string()));
    if has_hopfield {
        header.extend(["hopfield_on".into(), "hopfield_off".into(), "hopfield_theta_deg".into()]);
    }
    let mut lines = vec![header.join(",")];
    let mut columns: Vec<Column> = ids
        .iter()
        .map(|id| Column {
            name: id.to_string(),
            values: vec![],
        })
        .collect();
    let mut hopfield_theta = Vec::new();
    let bar = super::progress(input.frames.len() as u64, "detect");
    for (k, frame) in input.frames.iter().enumerate() {
        let theta = input
            .theta_true_deg
            .as_ref()
            .map_or(String::new(), |t| format!("{:.6}", t[k]));
        let mut row = vec![k.to_string(), format!("{:.6}", input.t_s[k]), theta];
        let mut extra = Vec::new();
        for (det, col) in detectors.iter_mut().zip(&mut columns) {
            let s = match &efference {
                Some(copies) => det.step_moving(frame, &copies[k])?,
                None => det.step(frame)?,
            };
            row.push(format!("{:.9}", s.output));
            col.values.push(s.output);
            if det.id() == "hopfield" {
                let aux = |name| s.aux.iter().find(|(k, _)| *k == name).map_or(f64::NAN, |(_, v)| *v);
                let theta_hat = s.angular_size_deg.unwrap_or(f64::NAN);
                extra = vec![
                    format!("{:.9}", aux("on")),
                    format!("{:.9}", aux("off")),
                    format!("{theta_hat:.6}"),
                ];
                hopfield_theta.push(theta_hat);
            }
        }
        row.extend(extra);
        lines.push(row.join(","));
        bar.inc(1);
    }
    bar.finish_and_clear();

    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let csv_path = args.out.join("responses.csv");
    let mut csv =
        BufWriter::new(File::create(&csv_path).with_context(|| format!("cannot create {}", csv_path.display()))?);
    for line in &lines {
        writeln!(csv, "{line}")?;
    }
    csv.flush()?;

    let plot_path = args.out.join("responses.png");
    let memory_columns = set.hopfield.template.template_count(n) + 1;
    plot_responses(&plot_path, &input, &columns, memory_columns)?;
    if has_hopfield && input.theta_true_deg.is_some() {
        let chart = LineChart {
            title: "Hopfield angular-size estimate".into(),
            x_label: "t [s]".into(),
            y_label: "angle [deg]".into(),
            series: vec![
                Series::new("θ̂ (hopfield)", input.t_s.clone(), hopfield_theta),
                Series::new(
                    "θ true",
                    input.t_s.clone(),
                    input.theta_true_deg.clone().unwrap_or_default(),
                )
                .dashed(),
            ],
            ..Default::default()
        };
        line_chart(&args.out.join("angular_size.png"), &chart, (800, 450))?;
    }
    outln!(
        "{} frames of {} ({n}×{n}) through {}",
        input.frames.len(),
        input.label,
        ids.join(", ")
    );
    outln!("wrote {} and {}", csv_path.display(), plot_path.display());
    Ok(0)
}

/// Reads `--hopfield-config`: the keys of [`HopfieldConfig`] except the camera's ([`CAMERA_KEYS`]),
/// which come from the input. Errors name the file and the key.
fn load_hopfield_config(path: &Path, input: &Input) -> anyhow::Result<HopfieldConfig> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let table: toml::Table = toml::from_str(&text).with_context(|| format!("in {}", path.display()))?;
    if let Some(key) = CAMERA_KEYS.iter().find(|k| table.contains_key(**k)) {
        bail!(
            "{}: `{key}` = {} is not a detector parameter: it comes from {} (as in scenario files, where it \
             comes from world.camera); remove it here",
            path.display(),
            table[*key],
            input.camera_source.origin_of(key)
        );
    }
    HopfieldConfig::from_toml_str(&text).with_context(|| format!("in {}", path.display()))
}

fn plot_responses(path: &Path, input: &Input, columns: &[Column], memory_columns: usize) -> anyhow::Result<()> {
    let named: Vec<(&str, &[f64])> = columns.iter().map(|c| (c.name.as_str(), c.values.as_slice())).collect();
    let (scaled, theta) = display_normalise(&named, input.theta_true_deg.as_deref(), memory_columns);
    let mut series: Vec<Series> = scaled
        .into_iter()
        .map(|(name, y)| Series::new(name, input.t_s.clone(), y))
        .collect();
    if let Some(theta) = theta {
        series.push(Series::new("θ (normalised)", input.t_s.clone(), theta).dashed());
    }
    let chart = LineChart {
        title: format!("Detector responses — {}", input.label),
        x_label: "t [s]".into(),
        y_label: "response (normalised, paper §3.2)".into(),
        series,
        ..Default::default()
    };
    line_chart(path, &chart, (900, 500))?;
    Ok(())
}

/// Curves with their names (detector ids).
pub type NamedCurves = Vec<(String, Vec<f64>)>;

/// Normalises detector outputs for joint display as in the paper's §3.2: Hopfield z is divided by
/// its maximum possible value (memory columns)², FuHuPe20's filtered spikes by 2; every other
/// curve (and the true angular size θ) is divided by its own maximum and multiplied by the largest
/// value of the scaled Hopfield/FuHuPe20 curves (or 1 when neither is shown).
pub fn display_normalise(
    columns: &[(&str, &[f64])],
    theta: Option<&[f64]>,
    memory_columns: usize,
) -> (NamedCurves, Option<Vec<f64>>) {
    let max_of = |v: &[f64]| v.iter().copied().filter(|x| x.is_finite()).fold(0.0f64, f64::max);
    let fixed = |id: &str| match id {
        "hopfield" => Some(1.0 / (memory_columns * memory_columns) as f64),
        "fu2020" => Some(0.5),
        _ => None,
    };
    let reference = columns
        .iter()
        .filter_map(|(id, v)| fixed(id).map(|k| k * max_of(v)))
        .fold(0.0f64, f64::max);
    let reference = if reference > 0.0 { reference } else { 1.0 };
    let by_max = |v: &[f64]| {
        let m = max_of(v);
        v.iter()
            .map(|x| if m > 0.0 { x / m * reference } else { 0.0 })
            .collect::<Vec<_>>()
    };
    let scaled = columns
        .iter()
        .map(|(id, v)| {
            let y = match fixed(id) {
                Some(k) => v.iter().map(|x| x * k).collect(),
                None => by_max(v),
            };
            (id.to_string(), y)
        })
        .collect();
    (scaled, theta.map(by_max))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalisation_follows_paper() {
        let h = [1.0, 4.0, 16.0];
        let soc = [0.0, 5.0, 10.0];
        let (s, theta) = display_normalise(&[("hopfield", &h), ("soc", &soc)], Some(&[1.0, 2.0, 4.0]), 4);
        assert_eq!(s[0].1, vec![1.0 / 16.0, 0.25, 1.0]);
        assert_eq!(s[1].1, vec![0.0, 0.5, 1.0]);
        assert_eq!(theta.unwrap(), vec![0.25, 0.5, 1.0]);
        let (s, _) = display_normalise(&[("soc", &soc)], None, 4);
        assert_eq!(s[0].1, vec![0.0, 0.5, 1.0]);
    }
}
