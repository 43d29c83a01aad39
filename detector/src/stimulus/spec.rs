//! The stimulus file schema ([`StimulusSpec`]): TOML parsing, defaults, validation and the
//! approach geometry (distance, true angular size and image size per frame).
//!
//! Every section and key is optional; missing keys take the defaults below (summarised in
//! docs/design.md §4), which are the paper's values (a 0.5 m object approaching at 50 km/h
//! from 10 m to 0.1 m, filmed at 120 frames/s by a 256×256 camera with a 60° field of view).
//! Unknown keys are errors. `stimuli/README.md` documents every key with its unit.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::DetectorError;

/// Largest accepted frame side (pixels); larger values are almost certainly typos.
pub const MAX_SIZE: usize = 8192;
/// Largest accepted number of frames of one stimulus.
pub const MAX_FRAMES: usize = 1_000_000;
/// Largest accepted video of one stimulus, `size² × frames` pixels: 2³⁰ (4 GiB of `f32` frames, as
/// `loomlab detect` holds them), e.g. 2000 frames of 724×724 or 16 384 frames of 256×256.
pub const MAX_TOTAL_PIXELS: usize = 1 << 30;

/// One artificial approach video, as described by a stimulus TOML file (docs/design.md §4).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StimulusSpec {
    /// Camera and timing: frame size, frame rate, field of view, random seed.
    pub stimulus: StimulusSection,
    /// The approaching object: shape, size, motion and texture.
    pub object: ObjectSection,
    /// What is behind the object.
    pub background: BackgroundSection,
    /// Optional occluding grating drawn over the whole scene (paper Fig. 5a).
    pub foreground: Option<ForegroundSection>,
    /// Optional pixel corruption (paper Fig. 5b).
    pub corruption: Option<CorruptionSection>,
}

/// `[stimulus]`: camera and timing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StimulusSection {
    /// Frame side n in pixels (frames are n×n), [`crate::MIN_FRAME_SIZE`]`..=`[`MAX_SIZE`] (20..=8192). Default 256.
    pub size: usize,
    /// Frame rate in frames per second. Default 120.
    pub fps: f64,
    /// Horizontal (= vertical) field of view in degrees, in (0, 180). Default 60.
    pub fov_deg: f64,
    /// Seed of every random element (noise textures, noise backgrounds, dropout). Default 1.
    pub seed: u64,
}

impl Default for StimulusSection {
    fn default() -> Self {
        Self {
            size: 256,
            fps: 120.0,
            fov_deg: 60.0,
            seed: 1,
        }
    }
}

/// Outline of the approaching object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// A disk of diameter `diameter_m`, facing the camera.
    #[default]
    Disk,
    /// An axis-aligned square of side `diameter_m`, facing the camera.
    Square,
}

/// Luminance pattern painted on the object, in object-centred coordinates, so it grows
/// with the object (paper Fig. 6b).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Texture {
    /// Constant `luminance`.
    #[default]
    Uniform,
    /// Checkerboard with `cycles` dark/bright pairs per object diameter.
    Checker,
    /// Static noise patch of `noise_cells`² cells fixed to the object (see `noise`).
    Noise,
    /// Square-wave grating, `cycles` per diameter, orientation 0 = horizontal stripes.
    Grating,
    /// Concentric square-wave rings, `cycles` per diameter.
    Circular,
    /// Radial sectors, `cycles` bright/dark pairs around the centre.
    Starburst,
}

/// Distribution of noise values (object noise patch, noise background).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseDistribution {
    /// Independent, uniformly distributed between the dark and the bright value.
    #[default]
    Uniform,
    /// Independent, the dark or the bright value with probability ½ each.
    Binary,
}

/// `[object]`: the approaching object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObjectSection {
    /// Disk or square. Default disk.
    pub shape: Shape,
    /// Diameter (disk) or side (square) in metres. Default 0.5.
    pub diameter_m: f64,
    /// Constant approach speed in km/h. Default 50.
    pub speed_kmh: f64,
    /// Distance at the first frame in metres. Default 10.
    pub start_distance_m: f64,
    /// The video ends at the last frame whose distance is ≥ this (metres). Default 0.1.
    pub end_distance_m: f64,
    /// Texture. Default uniform.
    pub texture: Texture,
    /// Luminance of a uniform object, and the bright value of textured objects, in [0, 1]. Default 1.
    pub luminance: f64,
    /// The dark value of textured objects, in [0, 1]. Default 0 (full contrast with `luminance = 1`).
    pub dark_luminance: f64,
    /// Spatial frequency of the texture: cycles per object diameter (starburst: around the centre).
    /// Default 2.
    pub cycles: f64,
    /// Texture orientation in degrees, counter-clockwise; 0 = horizontal stripes. Default 0.
    pub orientation_deg: f64,
    /// Texture phase in cycles. Default 0.25: the object's centre lies in the middle of a bright
    /// stripe/ring/cell (see the module docs of `stimulus` for why).
    pub phase: f64,
    /// Distribution of the `noise` texture. Default uniform.
    pub noise: NoiseDistribution,
    /// Number of noise cells across the object's diameter (noise texture). Default 32.
    pub noise_cells: usize,
    /// Alpha of the object over the background, in [0, 1]. Default 1 (opaque).
    pub opacity: f64,
    /// Horizontal focus of expansion, in [-1, 1] of the half-frame; +1 = right edge. Default 0.
    pub focus_x: f64,
    /// Vertical focus of expansion, in [-1, 1] of the half-frame; +1 = top edge. Default 0.
    pub focus_y: f64,
}

impl Default for ObjectSection {
    fn default() -> Self {
        Self {
            shape: Shape::Disk,
            diameter_m: 0.5,
            speed_kmh: 50.0,
            start_distance_m: 10.0,
            end_distance_m: 0.1,
            texture: Texture::Uniform,
            luminance: 1.0,
            dark_luminance: 0.0,
            cycles: 2.0,
            orientation_deg: 0.0,
            phase: 0.25,
            noise: NoiseDistribution::Uniform,
            noise_cells: 32,
            opacity: 1.0,
            focus_x: 0.0,
            focus_y: 0.0,
        }
    }
}

/// Kind of background.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BackgroundKind {
    /// Constant `luminance`.
    #[default]
    Uniform,
    /// Drifting sine-wave grating.
    Grating,
    /// Sine-wave grating whose orientation turns by `rotation_deg_per_frame` each frame.
    RotatingGrating,
    /// White noise, new every frame if `dynamic`.
    Noise,
}

/// `[background]`: the scene behind the object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BackgroundSection {
    /// Kind. Default uniform.
    pub kind: BackgroundKind,
    /// Uniform luminance, and the mean luminance of gratings, in [0, 1]. Default 0.5.
    pub luminance: f64,
    /// Michelson contrast of gratings, in [0, 1]. Default 1 (with luminance 0.5: 0…1).
    pub contrast: f64,
    /// Grating spatial frequency in cycles per image (frame side). Default 16.
    pub cycles: f64,
    /// Grating orientation in degrees, counter-clockwise; 0 = horizontal stripes. Default 0.
    pub orientation_deg: f64,
    /// Grating drift frequency k_t in Hz (phase 2π·t·k_t/fps); for orientation 0 the waves move
    /// from the bottom to the top. Applies to `rotating_grating` too (the paper's is 0). Default 8.
    pub drift_hz: f64,
    /// Rotation speed of `rotating_grating` in degrees per frame. Default 8.
    pub rotation_deg_per_frame: f64,
    /// Noise background: a new noise image every frame (true) or one static image. Default true.
    pub dynamic: bool,
    /// Noise background: value distribution (between 0 and 1). Default uniform.
    pub noise: NoiseDistribution,
}

impl Default for BackgroundSection {
    fn default() -> Self {
        Self {
            kind: BackgroundKind::Uniform,
            luminance: 0.5,
            contrast: 1.0,
            cycles: 16.0,
            orientation_deg: 0.0,
            drift_hz: 8.0,
            rotation_deg_per_frame: 8.0,
            dynamic: true,
            noise: NoiseDistribution::Uniform,
        }
    }
}

/// `[foreground]`: an occluding square-wave grating over the whole scene (paper Fig. 5a).
/// Where a bar is "on" the pixel is replaced by `luminance`; elsewhere the scene shows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ForegroundSection {
    /// Bars per image (frame side). Default 16.
    pub cycles: f64,
    /// Orientation in degrees, counter-clockwise; 0 = horizontal bars. Default 0.
    pub orientation_deg: f64,
    /// Drift frequency in Hz, same direction convention as the background. Default 8.
    pub drift_hz: f64,
    /// Luminance of the bars, in [0, 1]. Default 1 (bright bars).
    pub luminance: f64,
    /// Fraction of each cycle covered by a bar, in [0, 1]. Default 0.5.
    pub duty: f64,
}

impl Default for ForegroundSection {
    fn default() -> Self {
        Self {
            cycles: 16.0,
            orientation_deg: 0.0,
            drift_hz: 8.0,
            luminance: 1.0,
            duty: 0.5,
        }
    }
}

/// `[corruption]`: random pixel dropout applied last.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CorruptionSection {
    /// Probability that a pixel is set to 0, independently per pixel and frame. Default 0.01.
    pub dropout: f64,
}

impl Default for CorruptionSection {
    fn default() -> Self {
        Self { dropout: 0.01 }
    }
}

/// Path used in errors for stimuli that do not come from a file.
pub const INLINE_ORIGIN: &str = "<inline>";

impl StimulusSpec {
    /// Parses and validates a stimulus from TOML text. `origin` is the file name used in
    /// error messages (pass `Path::new("<inline>")` for text that has no file).
    pub fn from_toml_str(text: &str, origin: &Path) -> Result<Self, DetectorError> {
        let spec: StimulusSpec = toml::from_str(text).map_err(|e| toml_error(text, origin, &e))?;
        spec.validate_for(origin)?;
        Ok(spec)
    }

    /// Reads, parses and validates a stimulus TOML file.
    pub fn load(path: &Path) -> Result<Self, DetectorError> {
        let text = std::fs::read_to_string(path).map_err(|e| DetectorError::Io {
            path: path.to_path_buf(),
            reason: format!("cannot read stimulus file: {e}"),
        })?;
        Self::from_toml_str(&text, path)
    }

    /// Checks every value's range; errors name the key (e.g. `object.speed_kmh`) and the fix.
    /// Errors carry the path `<inline>`; [`StimulusSpec::from_toml_str`] and
    /// [`StimulusSpec::load`] name the file instead.
    pub fn validate(&self) -> Result<(), DetectorError> {
        self.validate_for(Path::new(INLINE_ORIGIN))
    }

    fn validate_for(&self, origin: &Path) -> Result<(), DetectorError> {
        let err = |key: &str, value: String, fix: &str| DetectorError::Stimulus {
            path: origin.to_path_buf(),
            reason: format!("`{key}` = {value}: {fix}"),
        };
        let s = &self.stimulus;
        if !(crate::MIN_FRAME_SIZE..=MAX_SIZE).contains(&s.size) {
            return Err(err(
                "stimulus.size",
                s.size.to_string(),
                &format!(
                    "must be {}..={MAX_SIZE} pixels (the detectors need frames of at least {0}×{0}, \
                     loomlab_detector::MIN_FRAME_SIZE)",
                    crate::MIN_FRAME_SIZE
                ),
            ));
        }
        positive(s.fps, "stimulus.fps", "frames per second", &err)?;
        if !(s.fov_deg.is_finite() && s.fov_deg > 0.0 && s.fov_deg < 180.0) {
            return Err(err(
                "stimulus.fov_deg",
                s.fov_deg.to_string(),
                "must be in (0, 180) degrees, e.g. 60",
            ));
        }

        let o = &self.object;
        positive(o.diameter_m, "object.diameter_m", "metres", &err)?;
        positive(o.speed_kmh, "object.speed_kmh", "km/h; the object must approach", &err)?;
        positive(o.start_distance_m, "object.start_distance_m", "metres", &err)?;
        positive(
            o.end_distance_m,
            "object.end_distance_m",
            "metres; the object must stay in front of the camera",
            &err,
        )?;
        if o.end_distance_m >= o.start_distance_m {
            return Err(err(
                "object.end_distance_m",
                o.end_distance_m.to_string(),
                &format!(
                    "must be smaller than `object.start_distance_m` = {}; the object approaches from start to end",
                    o.start_distance_m
                ),
            ));
        }
        unit(o.luminance, "object.luminance", &err)?;
        unit(o.dark_luminance, "object.dark_luminance", &err)?;
        positive(o.cycles, "object.cycles", "cycles per object diameter", &err)?;
        finite(o.orientation_deg, "object.orientation_deg", &err)?;
        finite(o.phase, "object.phase", &err)?;
        if o.noise_cells == 0 || o.noise_cells > 4096 {
            return Err(err(
                "object.noise_cells",
                o.noise_cells.to_string(),
                "must be 1..=4096 cells per diameter",
            ));
        }
        unit(o.opacity, "object.opacity", &err)?;
        for (v, key) in [(o.focus_x, "object.focus_x"), (o.focus_y, "object.focus_y")] {
            if !(v.is_finite() && (-1.0..=1.0).contains(&v)) {
                return Err(err(
                    key,
                    v.to_string(),
                    "must be in [-1, 1] (fraction of the half-frame; 0 = centre)",
                ));
            }
        }

        let b = &self.background;
        unit(b.luminance, "background.luminance", &err)?;
        unit(b.contrast, "background.contrast", &err)?;
        nonnegative(b.cycles, "background.cycles", "cycles per image", &err)?;
        finite(b.orientation_deg, "background.orientation_deg", &err)?;
        finite(b.drift_hz, "background.drift_hz", &err)?;
        finite(b.rotation_deg_per_frame, "background.rotation_deg_per_frame", &err)?;

        if let Some(f) = &self.foreground {
            positive(f.cycles, "foreground.cycles", "bars per image", &err)?;
            finite(f.orientation_deg, "foreground.orientation_deg", &err)?;
            finite(f.drift_hz, "foreground.drift_hz", &err)?;
            unit(f.luminance, "foreground.luminance", &err)?;
            unit(f.duty, "foreground.duty", &err)?;
        }
        if let Some(c) = &self.corruption {
            unit(c.dropout, "corruption.dropout", &err)?;
        }

        let frames = self.frame_count_f64();
        if frames > MAX_FRAMES as f64 {
            return Err(err(
                "object.speed_kmh",
                o.speed_kmh.to_string(),
                &format!(
                    "must give at most {MAX_FRAMES} frames, but the approach would take {frames:.0}; raise the \
                     speed, lower `stimulus.fps` or shorten the distance"
                ),
            ));
        }
        let pixels = (s.size as f64).powi(2) * frames;
        if pixels > MAX_TOTAL_PIXELS as f64 {
            return Err(err(
                "stimulus.size",
                s.size.to_string(),
                &format!(
                    "{frames:.0} frames of {0}×{0} pixels are {pixels:.0} pixels, more than the {MAX_TOTAL_PIXELS} \
                     of one stimulus (MAX_TOTAL_PIXELS, 4 GiB of frames); lower `stimulus.size` or `stimulus.fps`, \
                     raise `object.speed_kmh` or shorten the distance",
                    s.size
                ),
            ));
        }
        Ok(())
    }

    /// Approach speed in m/s.
    pub fn speed_mps(&self) -> f64 {
        self.object.speed_kmh / 3.6
    }

    fn frame_count_f64(&self) -> f64 {
        let o = &self.object;
        let steps = (o.start_distance_m - o.end_distance_m) * self.stimulus.fps / self.speed_mps();
        // A tiny tolerance so that an end distance hit exactly (up to rounding) counts as reached.
        (steps + 1e-9).floor() + 1.0
    }

    /// Number of frames: frame k is at t = k/fps and is included while its distance
    /// d(t) = start − v·t is ≥ `end_distance_m`, so `⌊(start − end)·fps / v⌋ + 1`.
    /// The paper's approach (10 m → 0.1 m at 50 km/h, 120 fps) gives ⌊85.54⌋ + 1 = 86 frames.
    pub fn frame_count(&self) -> usize {
        let f = self.frame_count_f64();
        if f.is_finite() && f >= 1.0 {
            (f as usize).min(MAX_FRAMES)
        } else {
            0
        }
    }

    /// Time of frame `t` in seconds (t / fps).
    pub fn time_s(&self, t: usize) -> f64 {
        t as f64 / self.stimulus.fps
    }

    /// Object distance at frame `t` in metres: start − v·t/fps (may fall below the end
    /// distance, or below zero, for `t ≥ frame_count()`).
    pub fn distance_m(&self, t: usize) -> f64 {
        self.object.start_distance_m - self.speed_mps() * self.time_s(t)
    }

    /// True angular size at frame `t` in degrees: θ = 2·atan((diameter/2)/d). For a square,
    /// `diameter_m` is the side, so θ is the angle its side subtends through its centre.
    /// Once the object has reached the camera (d ≤ 0) θ is 180°.
    pub fn theta_true_deg(&self, t: usize) -> f64 {
        let d = self.distance_m(t);
        if d <= 0.0 {
            180.0
        } else {
            2.0 * (0.5 * self.object.diameter_m / d).atan().to_degrees()
        }
    }

    /// Focal length in pixels: f = (n/2) / tan(fov/2).
    pub fn focal_length_px(&self) -> f64 {
        0.5 * self.stimulus.size as f64 / (0.5 * self.stimulus.fov_deg.to_radians()).tan()
    }

    /// Image radius (disk) or half-side (square) of the object at frame `t` in pixels:
    /// r = f·tan(θ/2) = f·(diameter/2)/d, so the pixel size matches the true angle.
    pub fn object_radius_px(&self, t: usize) -> f64 {
        let d = self.distance_m(t);
        if d <= 0.0 {
            f64::INFINITY
        } else {
            self.focal_length_px() * 0.5 * self.object.diameter_m / d
        }
    }

    /// Image position (x right, y down, pixels; the frame spans 0..n) of the object's centre:
    /// the frame centre shifted by `focus · n/2` (focus_y > 0 moves the object up).
    pub fn object_center_px(&self) -> (f64, f64) {
        let half = 0.5 * self.stimulus.size as f64;
        (half + self.object.focus_x * half, half - self.object.focus_y * half)
    }
}

type ErrFn<'a> = dyn Fn(&str, String, &str) -> DetectorError + 'a;

fn finite(v: f64, key: &str, err: &ErrFn) -> Result<(), DetectorError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(err(key, v.to_string(), "must be a finite number"))
    }
}

fn positive(v: f64, key: &str, unit: &str, err: &ErrFn) -> Result<(), DetectorError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(err(
            key,
            v.to_string(),
            &format!("must be a finite number > 0 ({unit})"),
        ))
    }
}

fn nonnegative(v: f64, key: &str, unit: &str, err: &ErrFn) -> Result<(), DetectorError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(err(
            key,
            v.to_string(),
            &format!("must be a finite number ≥ 0 ({unit})"),
        ))
    }
}

fn unit(v: f64, key: &str, err: &ErrFn) -> Result<(), DetectorError> {
    if v.is_finite() && (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(err(key, v.to_string(), "must be in [0, 1]"))
    }
}

/// Turns a toml/serde error into a [`DetectorError::Stimulus`] naming the line, column and
/// key path (e.g. `object.speed_kmh`).
fn toml_error(text: &str, origin: &Path, e: &toml::de::Error) -> DetectorError {
    let message = e.message().trim().to_string();
    let mut reason = String::new();
    if let Some(span) = e.span() {
        let (line, col) = line_col(text, span.start);
        reason.push_str(&format!("line {line}, column {col}"));
        if let Some(key) = key_path_at(text, span.start, &message) {
            reason.push_str(&format!(", key `{key}`"));
        }
        reason.push_str(": ");
    }
    reason.push_str(&message);
    if message.contains("unknown field") {
        reason.push_str(" (remove or rename the key; stimuli/README.md lists every key)");
    } else if message.contains("unknown variant") {
        reason.push_str(" (use one of the listed values)");
    } else if message.contains("invalid type") {
        reason.push_str(" (check the value's type: numbers without quotes, names in quotes)");
    }
    DetectorError::Stimulus {
        path: PathBuf::from(origin),
        reason,
    }
}

/// 1-based line and column of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..floor_char_boundary(text, offset)];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

fn floor_char_boundary(text: &str, mut i: usize) -> usize {
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// Best-effort dotted key path of the entry at byte `offset`: the enclosing `[table]` header
/// plus the key written at the start of that line (or the key an "unknown field" message names).
fn key_path_at(text: &str, offset: usize, message: &str) -> Option<String> {
    let offset = floor_char_boundary(text, offset.min(text.len()));
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = text[line_start..line_end].trim();
    let header = |l: &str| -> Option<String> {
        let l = l.trim();
        let inner = l.strip_prefix('[')?.split(']').next()?.trim_matches(['[', ' ']);
        Some(inner.trim().to_string())
    };
    let unknown = message
        .strip_prefix("unknown field `")
        .or_else(|| message.find("unknown field `").map(|i| &message[i + 15..]))
        .and_then(|m| m.split('`').next())
        .map(str::to_string);
    if let Some(h) = header(line) {
        // The error is about a table header itself (e.g. an unknown section).
        return Some(h);
    }
    let table = text[..line_start].lines().rev().find_map(|l| {
        if l.trim_start().starts_with('[') {
            header(l)
        } else {
            None
        }
    });
    let key = line
        .split_once('=')
        .map(|(k, _)| k.trim().trim_matches('"').to_string())
        .filter(|k| !k.is_empty())
        .or(unknown)?;
    Some(match table {
        Some(t) if !t.is_empty() => format!("{t}.{key}"),
        _ => key,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_path_from_span() {
        let text = "[stimulus]\nsize = 64\n\n[object]\nspeed_kmh = \"fast\"\n";
        let off = text.find("\"fast\"").unwrap();
        assert_eq!(
            key_path_at(text, off, "invalid type").as_deref(),
            Some("object.speed_kmh")
        );
        assert_eq!(line_col(text, off), (5, 13));
        let off = text.find("[object]").unwrap();
        assert_eq!(key_path_at(text, off, "").as_deref(), Some("object"));
    }
}
