//! Writing frames (PNG, animated GIF), ground truth (CSV) and comparing frames with golden images.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use crate::render::frame_to_u8;
use crate::truth::ObjectTruth;
use crate::{RobotState, SimError};

fn out_err(path: &Path, e: impl std::fmt::Display) -> SimError {
    SimError::Output {
        path: path.display().to_string(),
        reason: e.to_string(),
    }
}

/// Writes an n × n frame as an 8-bit greyscale PNG.
pub fn write_png(path: &Path, frame: &[f32], n: u32) -> Result<(), SimError> {
    let img = image::GrayImage::from_raw(n, n, frame_to_u8(frame))
        .ok_or_else(|| out_err(path, format!("frame has {} values, expected {}", frame.len(), n * n)))?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| out_err(path, e))
}

/// Reads a greyscale (or colour: the first channel is used) PNG as a frame in [0, 1]; returns it and n.
pub fn read_png(path: &Path) -> Result<(Vec<f32>, u32), SimError> {
    let img = image::open(path).map_err(|e| out_err(path, e))?.to_luma8();
    if img.width() != img.height() {
        return Err(out_err(
            path,
            format!("image is {}x{}, expected a square frame", img.width(), img.height()),
        ));
    }
    Ok((img.pixels().map(|p| f32::from(p.0[0]) / 255.0).collect(), img.width()))
}

/// An animated greyscale GIF being written frame by frame (256-level grey palette, loops forever).
pub struct GifWriter {
    encoder: gif::Encoder<BufWriter<File>>,
    n: u16,
    delay_cs: u16,
    path: String,
}

impl GifWriter {
    /// Creates `path` for n × n frames shown `delay_cs` hundredths of a second each.
    pub fn create(path: &Path, n: u32, delay_cs: u16) -> Result<GifWriter, SimError> {
        let n16 = u16::try_from(n).map_err(|_| out_err(path, "frame too large for GIF"))?;
        let file = File::create(path).map_err(|e| out_err(path, e))?;
        let palette: Vec<u8> = (0..=255u8).flat_map(|v| [v, v, v]).collect();
        let mut encoder = gif::Encoder::new(BufWriter::new(file), n16, n16, &palette).map_err(|e| out_err(path, e))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| out_err(path, e))?;
        Ok(GifWriter {
            encoder,
            n: n16,
            delay_cs,
            path: path.display().to_string(),
        })
    }

    /// Appends a frame.
    pub fn add(&mut self, frame: &[f32]) -> Result<(), SimError> {
        let pixels = frame_to_u8(frame);
        if pixels.len() != usize::from(self.n) * usize::from(self.n) {
            return Err(SimError::Output {
                path: self.path.clone(),
                reason: "frame size changed".into(),
            });
        }
        let mut f = gif::Frame::from_indexed_pixels(self.n, self.n, pixels, None);
        f.delay = self.delay_cs;
        self.encoder.write_frame(&f).map_err(|e| SimError::Output {
            path: self.path.clone(),
            reason: e.to_string(),
        })
    }
}

/// Header of [`TruthCsv`] files.
pub const TRUTH_CSV_HEADER: &str = "frame,t_s,robot_x_m,robot_y_m,robot_yaw_deg,object,kind,distance_m,center_distance_m,\
angular_size_deg,angular_rate_deg_s,tau_s,ttc_s,on_collision_course,bearing,bearing_deg,elevation_deg,in_view,in_contact,contact";

/// Per-frame ground truth as CSV: one row per object per frame (columns: [`TRUTH_CSV_HEADER`]; empty
/// cells for absent `tau_s`/`ttc_s`; booleans as 0/1; `contact` = 1 in the frame a contact started).
pub struct TruthCsv {
    out: BufWriter<File>,
    path: String,
}

fn opt(v: Option<f32>) -> String {
    v.map(|x| format!("{x:.6}")).unwrap_or_default()
}

impl TruthCsv {
    /// Creates the file and writes the header.
    pub fn create(path: &Path) -> Result<TruthCsv, SimError> {
        let file = File::create(path).map_err(|e| out_err(path, e))?;
        let mut out = BufWriter::new(file);
        writeln!(out, "{TRUTH_CSV_HEADER}").map_err(|e| out_err(path, e))?;
        Ok(TruthCsv {
            out,
            path: path.display().to_string(),
        })
    }

    /// Writes the rows of one frame; `contact_ids` are the objects whose contact started in it.
    pub fn write_frame(
        &mut self,
        frame: u64,
        robot: &RobotState,
        truth: &[ObjectTruth],
        contact_ids: &[usize],
    ) -> Result<(), SimError> {
        for o in truth {
            let row = format!(
                "{frame},{:.6},{:.6},{:.6},{:.4},{},{},{:.6},{:.6},{:.6},{:.6},{},{},{},{:.6},{:.4},{:.4},{},{},{}",
                robot.t_s,
                robot.x_m,
                robot.y_m,
                robot.yaw_rad.to_degrees(),
                o.name,
                o.kind,
                o.distance_m,
                o.center_distance_m,
                o.angular_size_deg,
                o.angular_rate_deg_s,
                opt(o.tau_s),
                opt(o.ttc_s),
                u8::from(o.on_collision_course),
                o.bearing,
                o.bearing_deg,
                o.elevation_deg,
                u8::from(o.in_view),
                u8::from(o.in_contact),
                u8::from(contact_ids.contains(&o.id)),
            );
            writeln!(self.out, "{row}").map_err(|e| SimError::Output {
                path: self.path.clone(),
                reason: e.to_string(),
            })?;
        }
        Ok(())
    }

    /// Flushes the file.
    pub fn finish(mut self) -> Result<(), SimError> {
        self.out.flush().map_err(|e| SimError::Output {
            path: self.path.clone(),
            reason: e.to_string(),
        })
    }
}

/// How two frames differ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameDiff {
    /// Largest absolute difference.
    pub max_abs: f32,
    /// Mean absolute difference.
    pub mean_abs: f32,
    /// Fraction of pixels differing by more than the per-pixel threshold.
    pub fraction_over: f32,
}

/// Compares two frames of equal size: per-pixel differences above `pixel_threshold` count as "over"
/// (wgpu-examples style: goldens are compared with a tolerance, never byte for byte).
pub fn compare_frames(a: &[f32], b: &[f32], pixel_threshold: f32) -> Option<FrameDiff> {
    if a.len() != b.len() || a.is_empty() {
        return None;
    }
    let mut max_abs = 0.0f32;
    let mut sum = 0.0f64;
    let mut over = 0usize;
    for (x, y) in a.iter().zip(b) {
        let d = (x - y).abs();
        max_abs = max_abs.max(d);
        sum += f64::from(d);
        if d > pixel_threshold {
            over += 1;
        }
    }
    Some(FrameDiff {
        max_abs,
        mean_abs: (sum / a.len() as f64) as f32,
        fraction_over: over as f32 / a.len() as f32,
    })
}
