//! The GIF of the robot's view: which frames it shows, and their encoding with alarm marks and captions.

use std::collections::BTreeSet;

use plotters::prelude::*;

use super::gif_palette::{gif_palette, palette_index};
use crate::plot::{palette, register_font};

/// Frames per GIF at most.
pub const MAX_GIF_FRAMES: usize = 80;
/// Width and height of a GIF's image at most (larger frames are box-downscaled).
pub const MAX_GIF_SIZE: u32 = 96;
/// Height of the caption strip under the image (time, true angular size, alarms).
const CAPTION_PX: u32 = 24;
/// Playback slow-down against real time (a 2.6 s episode plays in about 5 s).
const SLOW_DOWN: f64 = 2.0;
/// How long an alarm frame stays on screen (centiseconds).
const ALARM_DELAY_CS: u16 = 100;

/// The frames a GIF of an episode of `len` frames shows: every `stride`-th and every alarm frame,
/// at most [`MAX_GIF_FRAMES`] in all.
pub fn gif_frames(len: usize, alarms: &[usize]) -> Vec<usize> {
    let alarms: BTreeSet<usize> = alarms
        .iter()
        .copied()
        .filter(|&k| k < len)
        .take(MAX_GIF_FRAMES / 2)
        .collect();
    let room = MAX_GIF_FRAMES - alarms.len();
    let stride = len.div_ceil(room.max(1)).max(1);
    let mut frames: BTreeSet<usize> = (0..len).step_by(stride).collect();
    if len > 0 {
        frames.insert(len - 1);
    }
    while frames.len() + alarms.len() > MAX_GIF_FRAMES {
        // the last frame pushed it over: drop the frame before it
        let Some(&k) = frames.iter().rev().nth(1) else { break };
        frames.remove(&k);
    }
    frames.extend(alarms);
    frames.into_iter().collect()
}

/// What a GIF shows.
pub(super) struct GifEpisode<'a> {
    pub(super) n: u32,
    pub(super) hz: f64,
    pub(super) frames: &'a [(usize, Vec<f32>)],
    pub(super) t_s: &'a [f64],
    pub(super) theta_deg: &'a [f64],
    pub(super) labels: &'a [String],
    pub(super) alarms: &'a [(String, usize)],
    pub(super) featured: Option<usize>,
}

impl GifEpisode<'_> {
    pub(super) fn encode(&self) -> Result<Vec<u8>, String> {
        register_font();
        let factor = self.n.div_ceil(MAX_GIF_SIZE).max(1);
        // small frames (tests, --size 32) are enlarged, pixel for pixel, so the caption fits
        let up = (f64::from(MAX_GIF_SIZE) / f64::from(self.n / factor)).round().max(1.0) as u32;
        let side = self.n / factor * up;
        let (w, h) = (side, side + CAPTION_PX);
        let mut bytes = Vec::new();
        {
            let mut enc =
                gif::Encoder::new(&mut bytes, w as u16, h as u16, &gif_palette()).map_err(|e| e.to_string())?;
            enc.set_repeat(gif::Repeat::Infinite).map_err(|e| e.to_string())?;
            let featured_alarm = self
                .featured
                .and_then(|i| self.alarms.iter().find(|(l, _)| *l == self.labels[i]).map(|(_, k)| *k));
            for (i, (k, frame)) in self.frames.iter().enumerate() {
                let rgb = self.draw_frame(*k, frame, (factor, up), side, featured_alarm)?;
                let indices: Vec<u8> = rgb.chunks_exact(3).map(|p| palette_index([p[0], p[1], p[2]])).collect();
                let here: Vec<&str> = self.alarm_labels(*k);
                let next = self.frames.get(i + 1).map_or(*k + 1, |(n, _)| *n);
                let delay = if here.is_empty() {
                    (100.0 * SLOW_DOWN * (next - k) as f64 / self.hz)
                        .round()
                        .clamp(2.0, 50.0) as u16
                } else {
                    ALARM_DELAY_CS
                };
                let f = gif::Frame {
                    width: w as u16,
                    height: h as u16,
                    delay,
                    buffer: std::borrow::Cow::Owned(indices),
                    ..gif::Frame::default()
                };
                enc.write_frame(&f).map_err(|e| e.to_string())?;
            }
        }
        Ok(bytes)
    }

    fn alarm_labels(&self, k: usize) -> Vec<&str> {
        self.alarms
            .iter()
            .filter(|(_, a)| *a == k)
            .map(|(l, _)| l.as_str())
            .collect()
    }

    fn colour_of(&self, label: &str) -> RGBColor {
        palette(self.labels.iter().position(|l| l == label).unwrap_or(0))
    }

    /// One GIF frame as RGB: the camera frame box-downscaled by `factor`, enlarged by `up` to
    /// `side` pixels, the alarm marks and the caption strip.
    fn draw_frame(
        &self,
        k: usize,
        frame: &[f32],
        (factor, up): (u32, u32),
        side: u32,
        featured_alarm: Option<usize>,
    ) -> Result<Vec<u8>, String> {
        let (w, h) = (side, side + CAPTION_PX);
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        let n = self.n as usize;
        let f = factor as usize;
        let up = up as usize;
        for y in 0..side as usize {
            for x in 0..side as usize {
                let (sy, sx) = (y / up, x / up);
                let mut sum = 0.0f32;
                for dy in 0..f {
                    for dx in 0..f {
                        sum += frame.get((sy * f + dy) * n + sx * f + dx).copied().unwrap_or(0.0);
                    }
                }
                let v = (sum / (f * f) as f32).clamp(0.0, 1.0);
                let g = (v * 255.0).round() as u8;
                let o = (y * side as usize + x) * 3;
                rgb[o..o + 3].copy_from_slice(&[g, g, g]);
            }
        }
        let here = self.alarm_labels(k);
        {
            let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
            let e = |e: DrawingAreaErrorKind<_>| e.to_string();
            let (iw, ih) = (side as i32, side as i32);
            let border = |width: i32, c: RGBColor| {
                (0..width)
                    .map(|i| Rectangle::new([(i, i), (iw - 1 - i, ih - 1 - i)], c.stroke_width(1)))
                    .collect::<Vec<_>>()
            };
            if let Some(first) = here.first() {
                for r in border(4, self.colour_of(first)) {
                    root.draw(&r).map_err(e)?;
                }
            } else if let (Some(a), Some(i)) = (featured_alarm, self.featured)
                && k > a
            {
                for r in border(1, palette(i)) {
                    root.draw(&r).map_err(e)?;
                }
            }
            let t = self.t_s.get(k).copied().unwrap_or(k as f64 / self.hz);
            let theta = self.theta_deg.get(k).copied().filter(|v| v.is_finite());
            let line1 = match theta {
                Some(th) => format!("t {t:.2}s θ {th:.1}°"),
                None => format!("t {t:.2}s"),
            };
            let font = ("sans-serif", 10).into_font();
            root.draw(&Text::new(line1, (2, ih + 1), font.clone().color(&WHITE)))
                .map_err(e)?;
            if let Some(first) = here.first() {
                let more = if here.len() > 1 {
                    format!(" +{}", here.len() - 1)
                } else {
                    String::new()
                };
                let c = self.colour_of(first);
                root.draw(&Text::new(format!("ALARM {first}{more}"), (2, ih + 12), font.color(&c)))
                    .map_err(e)?;
            } else if let (Some(a), Some(i)) = (featured_alarm, self.featured)
                && k > a
            {
                root.draw(&Text::new(
                    format!("{} alarmed", self.labels[i]),
                    (2, ih + 12),
                    font.color(&palette(i)),
                ))
                .map_err(e)?;
            }
            root.present().map_err(e)?;
        }
        Ok(rgb)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gif_frames_are_bounded_and_keep_the_alarms() {
        for len in [1usize, 5, 79, 80, 81, 312, 10_000] {
            let all: Vec<usize> = (0..200).collect();
            for alarms in [vec![], vec![len / 2, len.saturating_sub(1), 3], all] {
                let f = gif_frames(len, &alarms);
                assert!(f.len() <= MAX_GIF_FRAMES && !f.is_empty(), "len {len}: {}", f.len());
                assert!(f.windows(2).all(|w| w[0] < w[1]) && f.iter().all(|&k| k < len));
                if alarms.len() < 3 {
                    assert!(
                        alarms.iter().filter(|&&a| a < len).all(|a| f.contains(a)),
                        "{len} {alarms:?}"
                    );
                }
            }
        }
    }
}
