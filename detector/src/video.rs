//! Video input: grayscale [`Frame`]s from a directory of images, an animated GIF or a still.
//!
//! Accepted inputs ([`load_video`]):
//! - a **directory** of PNG/JPEG frames (extensions `.png`, `.jpg`, `.jpeg`, any case). Other
//!   files and subdirectories are ignored. Frames are ordered by *natural* filename order:
//!   runs of digits compare by their numeric value, everything else character by character, so
//!   `f2.png` comes before `f10.png` and zero-padded names (`0001.png`) sort as expected.
//!   Directories carry no frame rate (`fps = None`);
//! - an **animated GIF** (`.gif`): every frame, composited onto the full canvas as the GIF's
//!   disposal rules say. `fps` is 1000 / mean frame delay in ms when every delay is positive,
//!   else `None` (GIF delays are in 1/100 s, so e.g. 120 frames/s cannot be represented);
//! - a **single PNG/JPEG** image: a one-frame video with `fps = None`.
//!
//! Colour is converted to luminance with the `image` crate's Rec. 709 weights applied to the
//! encoded (gamma) values; alpha is ignored; 16-bit images keep their precision. Non-square
//! frames become square per [`NonSquare`] (embed in mid-grey or crop, paper §2.2.1). All frames
//! must have the same size.
//!
//! Bounds, checked from the files' headers before any frame is decoded: a square frame's side is
//! at most [`MAX_VIDEO_FRAME_SIDE`] pixels and a whole video holds at most [`MAX_VIDEO_PIXELS`].

use std::cmp::Ordering;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use image::{AnimationDecoder, DynamicImage, ImageReader};

use crate::{DetectorError, Frame, NonSquare};

/// Largest side of a video's square frames (pixels; the stimulus files' bound): an 8192² frame
/// holds 256 MiB of `f32` luminance.
pub const MAX_VIDEO_FRAME_SIDE: usize = crate::stimulus::spec::MAX_SIZE;

/// Most pixels (frames × n²) a whole video may hold: 2³⁰, 4 GiB of `f32` luminance.
pub const MAX_VIDEO_PIXELS: u64 = 1 << 30;

/// The side of the square frame an image of `w`×`h` pixels becomes.
fn square_side((w, h): (u32, u32), mode: NonSquare) -> u64 {
    match mode {
        NonSquare::Embed => u64::from(w.max(h)),
        NonSquare::Crop => u64::from(w.min(h)),
    }
}

/// Refuses frames too large to hold: `frames` of them, each `dims` before squaring.
fn check_size(path: &Path, dims: (u32, u32), mode: NonSquare, frames: u64) -> Result<(), DetectorError> {
    let side = square_side(dims, mode);
    let (w, h) = dims;
    if side > MAX_VIDEO_FRAME_SIDE as u64 {
        let how = match mode {
            NonSquare::Embed => "embedded in a square",
            NonSquare::Crop => "cropped to a square",
        };
        return Err(io_err(
            path,
            format!(
                "a {w}×{h} frame {how} is {side}×{side} pixels; the most is {MAX_VIDEO_FRAME_SIDE}×{MAX_VIDEO_FRAME_SIDE} \
                 (scale the video down first, e.g. `ffmpeg -i in.mp4 -vf scale=512:-1 frames/%05d.png`)"
            ),
        ));
    }
    let pixels = frames.saturating_mul(side * side);
    if pixels > MAX_VIDEO_PIXELS {
        return Err(io_err(
            path,
            format!(
                "{frames} frames of {side}×{side} pixels are {pixels} pixels; a video holds at most {MAX_VIDEO_PIXELS} \
                 (4 GiB): use fewer or smaller frames"
            ),
        ));
    }
    Ok(())
}

/// The (width, height) of an image file, read from its header only.
fn image_dims(path: &Path) -> Result<(u32, u32), DetectorError> {
    ImageReader::open(path)
        .map_err(|e| io_err(path, format!("cannot open image: {e}")))?
        .with_guessed_format()
        .map_err(|e| io_err(path, format!("cannot read image: {e}")))?
        .into_dimensions()
        .map_err(|e| io_err(path, format!("cannot decode image: {e}")))
}

/// A loaded video: square grayscale frames, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Video {
    /// The frames, all n×n with the same n.
    pub frames: Vec<Frame>,
    /// Frame rate, when the file states one (animated GIFs), else `None`.
    pub fps: Option<f64>,
    /// The directory or file the video was read from.
    pub source: PathBuf,
}

impl Video {
    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether there are no frames (never true for a video from [`load_video`]).
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Side length n of the (square) frames, 0 for an empty video.
    pub fn frame_size(&self) -> usize {
        self.frames.first().map_or(0, Frame::n)
    }
}

fn io_err(path: &Path, reason: impl Into<String>) -> DetectorError {
    DetectorError::Io {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

fn is_frame_image(path: &Path) -> bool {
    matches!(extension(path).as_deref(), Some("png" | "jpg" | "jpeg"))
}

/// Reads a video from a directory of PNG/JPEG frames, an animated GIF or a single image
/// (see the module docs for ordering, frame rate and colour conversion).
///
/// Errors ([`DetectorError::Io`], naming the offending file): the path does not exist, a
/// directory holds no PNG/JPEG frames, a file cannot be decoded, a GIF has no frames, frames
/// differ in size, or the file type is not supported.
pub fn load_video(path: &Path, mode: NonSquare) -> Result<Video, DetectorError> {
    let meta = std::fs::metadata(path).map_err(|e| {
        io_err(
            path,
            format!("cannot open video: {e}; pass a directory of PNG/JPEG frames or a GIF"),
        )
    })?;
    if meta.is_dir() {
        return load_dir(path, mode);
    }
    match extension(path).as_deref() {
        Some("gif") => load_gif(path, mode),
        Some("png" | "jpg" | "jpeg") => {
            check_size(path, image_dims(path)?, mode, 1)?;
            let frame = load_image(path, mode)?.1;
            Ok(Video {
                frames: vec![frame],
                fps: None,
                source: path.to_path_buf(),
            })
        }
        _ => Err(io_err(
            path,
            "unsupported video file; pass a directory of PNG/JPEG frames, an animated .gif or a .png/.jpg image \
             (convert other formats first, e.g. `ffmpeg -i in.mp4 frames/%05d.png`)",
        )),
    }
}

/// Frame files of a directory in natural order.
pub fn frame_files(dir: &Path) -> Result<Vec<PathBuf>, DetectorError> {
    let entries = std::fs::read_dir(dir).map_err(|e| io_err(dir, format!("cannot list directory: {e}")))?;
    let mut files = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| io_err(dir, format!("cannot list directory: {e}")))?;
        let p = entry.path();
        if p.is_file() && is_frame_image(&p) {
            files.push(p);
        }
    }
    files.sort_by(|a, b| {
        natural_cmp(
            &a.file_name().unwrap_or_default().to_string_lossy(),
            &b.file_name().unwrap_or_default().to_string_lossy(),
        )
    });
    Ok(files)
}

fn load_dir(dir: &Path, mode: NonSquare) -> Result<Video, DetectorError> {
    let files = frame_files(dir)?;
    if files.is_empty() {
        return Err(io_err(dir, "directory contains no PNG/JPEG frames (.png, .jpg, .jpeg)"));
    }
    // bounded before any frame is decoded: every file's header is read first
    let first_dims = image_dims(&files[0])?;
    check_size(&files[0], first_dims, mode, files.len() as u64)?;
    for file in &files[1..] {
        check_size(file, image_dims(file)?, mode, files.len() as u64)?;
    }
    let mut frames = Vec::with_capacity(files.len());
    let mut first: Option<(PathBuf, (u32, u32))> = None;
    for file in &files {
        let (dims, frame) = load_image(file, mode)?;
        match &first {
            None => first = Some((file.clone(), dims)),
            Some((first_file, first_dims)) if *first_dims != dims => {
                return Err(io_err(
                    file,
                    format!(
                        "frame is {}×{} pixels but {} is {}×{}; all frames of a video must have the same size",
                        dims.0,
                        dims.1,
                        first_file.display(),
                        first_dims.0,
                        first_dims.1
                    ),
                ));
            }
            Some(_) => {}
        }
        frames.push(frame);
    }
    Ok(Video {
        frames,
        fps: None,
        source: dir.to_path_buf(),
    })
}

/// Converts a decoded image to a frame; returns its (width, height) too.
fn to_frame(img: &DynamicImage, path: &Path, mode: NonSquare) -> Result<((u32, u32), Frame), DetectorError> {
    let luma = img.to_luma32f();
    let (w, h) = luma.dimensions();
    let frame =
        Frame::from_rect_f32(h as usize, w as usize, luma.as_raw(), mode).map_err(|e| io_err(path, e.to_string()))?;
    Ok(((w, h), frame))
}

fn load_image(path: &Path, mode: NonSquare) -> Result<((u32, u32), Frame), DetectorError> {
    let img = ImageReader::open(path)
        .map_err(|e| io_err(path, format!("cannot open image: {e}")))?
        .with_guessed_format()
        .map_err(|e| io_err(path, format!("cannot read image: {e}")))?
        .decode()
        .map_err(|e| io_err(path, format!("cannot decode image: {e}")))?;
    to_frame(&img, path, mode)
}

fn load_gif(path: &Path, mode: NonSquare) -> Result<Video, DetectorError> {
    let file = File::open(path).map_err(|e| io_err(path, format!("cannot open GIF: {e}")))?;
    let decoder = image::codecs::gif::GifDecoder::new(BufReader::new(file))
        .map_err(|e| io_err(path, format!("cannot decode GIF: {e}")))?;
    let dims = image::ImageDecoder::dimensions(&decoder);
    check_size(path, dims, mode, 1)?;
    let mut frames = Vec::new();
    let mut delays_ms = Vec::new();
    for (k, f) in decoder.into_frames().enumerate() {
        check_size(path, dims, mode, k as u64 + 1)?;
        let f = f.map_err(|e| io_err(path, format!("cannot decode GIF frame {k}: {e}")))?;
        let (num, den) = f.delay().numer_denom_ms();
        delays_ms.push(if den == 0 { 0.0 } else { num as f64 / den as f64 });
        let img = DynamicImage::ImageRgba8(f.into_buffer());
        frames.push(to_frame(&img, path, mode)?.1);
    }
    if frames.is_empty() {
        return Err(io_err(path, "GIF contains no frames"));
    }
    let fps = if delays_ms.iter().all(|&d| d > 0.0) {
        Some(1000.0 * delays_ms.len() as f64 / delays_ms.iter().sum::<f64>())
    } else {
        None
    };
    Ok(Video {
        frames,
        fps,
        source: path.to_path_buf(),
    })
}

/// Natural order of file names: digit runs compare numerically, the rest by character;
/// ties (e.g. `01` vs `1`) are broken by plain string order.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (a, b);
    loop {
        match (x.chars().next(), y.chars().next()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(cx), Some(cy)) if cx.is_ascii_digit() && cy.is_ascii_digit() => {
                let dx = x.find(|c: char| !c.is_ascii_digit()).unwrap_or(x.len());
                let dy = y.find(|c: char| !c.is_ascii_digit()).unwrap_or(y.len());
                let nx = x[..dx].trim_start_matches('0');
                let ny = y[..dy].trim_start_matches('0');
                let ord = nx.len().cmp(&ny.len()).then_with(|| nx.cmp(ny));
                if ord != Ordering::Equal {
                    return ord;
                }
                x = &x[dx..];
                y = &y[dy..];
            }
            (Some(cx), Some(cy)) => {
                if cx != cy {
                    return cx.cmp(&cy);
                }
                x = &x[cx.len_utf8()..];
                y = &y[cy.len_utf8()..];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order() {
        let mut v = vec!["f10.png", "f2.png", "f1.png", "g0.png", "f02.png", "f0010.png"];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(v, ["f1.png", "f02.png", "f2.png", "f0010.png", "f10.png", "g0.png"]);
    }
}
