//! The event camera (`[world.camera] kind = "events"`, parameters in `[world.camera.events]`): a
//! dynamic vision sensor (DVS) model in the manner of ESIM (Rebecq, Gehrig & Scaramuzza 2018,
//! "ESIM: an open event camera simulator", CoRL), delivered once per camera period as an event
//! list `(t, x, y, polarity)` and as ON / OFF count images ([`EventPacket`]).
//!
//! **The model**, per pixel i with log intensity `I(t) = ln(L(t) + log_offset)` of its luminance
//! L ∈ [0, 1]:
//! 1. *Renders* (adaptive sub-frames, ESIM's rule): each camera period `[t₀, t₁]` starts from the
//!    view at t₀ (the previous frame) and ends with the view at t₁ (this frame). ESIM samples the
//!    scene with a time step `λ · C / max_i |dI_i/dt|`; here the rate is the period's own largest
//!    per-pixel change `Δ = max_i |I_i(t₁) − I_i(t₀)|`, so the period is sampled at
//!    `k = clamp(⌈Δ / (adaptive_fraction · min(C+, C−))⌉, 1, max_renders)` evenly spaced times
//!    `t₀ + j·(t₁ − t₀)/k`, j = 1..k: `k − 1` extra views (the bodies' and the camera's poses
//!    interpolated as for the exposure blur, [`crate::sensor`]) and the frame. A still scene costs
//!    no extra render; fast motion up to `max_renders − 1`. Because k depends only on the two
//!    frames, the sub-frames of many periods can be rendered in one batch (the scenario runner
//!    does: [`EventCamera::renders_for`], [`EventCamera::period_with`]).
//! 2. *Crossings*: between two renders I is linear in time. Each pixel holds a reference level r
//!    (its log intensity at its last crossing; at the episode's first frame, that frame's). When I
//!    reaches `r + C+ᵢ` the pixel emits an ON event (+1) at the interpolated time and r moves up by
//!    `C+ᵢ`; at `r − C−ᵢ` an OFF event (−1) and r moves down by `C−ᵢ`; repeatedly, so a change by
//!    Δ gives ⌊Δ / C⌋ events. A uniform brightening by a factor k gives ⌊ln k / C+⌋ ON events.
//! 3. *Mismatch*: the thresholds `C±ᵢ = C± · (1 + mismatch_sigma · zᵢ)` (z standard normal, one
//!    per pixel and polarity, clamped to at least `C± / 10`) are drawn once per episode from the
//!    simulator's seed.
//! 4. *Refractory period*: a crossing less than `refractory_s` after the pixel's last emitted event
//!    is not emitted (its reference still moves: the level is consumed).
//! 5. *Noise*: leak events (ON, `leak_rate_hz` per pixel) and shot-noise events (either polarity
//!    with probability ½, `shot_rate_hz` per pixel), independent Poisson processes at uniformly
//!    random times in the period; they do not move the reference and ignore the refractory period.
//!    They are drawn from a generator seeded by the simulator's seed on stream k (frame index k),
//!    so events depend on the seed and the frame index only.
//!
//! Events of a period are sorted by time, then row, column and polarity, and time-stamped in
//! `(t₀, t₁]`. The episode's first frame gives no events (nothing before it). **Cost**: the renders
//! (1 to `max_renders` per period: [`EventPacket::renders`] counts them) plus O(n² · renders) of
//! arithmetic; after the first periods the conversion allocates nothing (its buffers are reused).
//! The frame the camera delivers beside the events is the ordinary frame at t₁ (frame rows read it).

use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::SimError;

/// What the camera delivers (`[world.camera] kind`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CameraKind {
    /// Frames only (the default).
    #[default]
    Frames,
    /// Frames and, each period, the events of an event camera on the same view
    /// ([`EventCameraDesc`], `[world.camera.events]`).
    Events,
}

impl CameraKind {
    /// True for [`CameraKind::Frames`] (left out when a world is written).
    pub fn is_frames(&self) -> bool {
        *self == CameraKind::Frames
    }
}

/// The event camera's parameters (`[world.camera.events]`); read when `[world.camera] kind =
/// "events"`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EventCameraDesc {
    /// ON contrast threshold C+ (change of natural-log intensity per ON event). Default 0.2 (the
    /// order of DVS pixels' 15–30 % thresholds).
    pub contrast_on: f64,
    /// OFF contrast threshold C− (log-intensity decrease per OFF event). Default 0.2.
    pub contrast_off: f64,
    /// Per-pixel threshold mismatch: the standard deviation of each pixel's thresholds relative to
    /// C± (drawn once per episode from the seed). Default 0.03.
    pub mismatch_sigma: f64,
    /// Refractory period (s): crossings closer than this to the pixel's last event are not
    /// emitted. Default 0.0001 (0.1 ms).
    pub refractory_s: f64,
    /// Leak events (ON) per pixel per second. Default 0.1 Hz.
    pub leak_rate_hz: f64,
    /// Shot-noise events (random polarity) per pixel per second. Default 0.1 Hz.
    pub shot_rate_hz: f64,
    /// The most views rendered per camera period (the frame included), 1..=[`MAX_EVENT_RENDERS`];
    /// 1 interpolates linearly from the previous frame to this one. Default 3 (the default suite
    /// on events within 2× the suite on frames: docs/events.md).
    pub max_renders: u32,
    /// Adaptive sub-frames: the period is sampled so that the largest per-pixel log-intensity
    /// change per sample is at most this fraction of min(C+, C−) (up to `max_renders`), in
    /// (0, 10]. Default 1.
    pub adaptive_fraction: f64,
    /// Offset ε of the log intensity `ln(L + ε)` (luminance units; keeps black finite). Default
    /// 0.001.
    pub log_offset: f64,
}

/// The most views [`EventCameraDesc::max_renders`] allows per period.
pub const MAX_EVENT_RENDERS: u32 = 64;

impl Default for EventCameraDesc {
    fn default() -> Self {
        EventCameraDesc {
            contrast_on: 0.2,
            contrast_off: 0.2,
            mismatch_sigma: 0.03,
            refractory_s: 0.0001,
            leak_rate_hz: 0.1,
            shot_rate_hz: 0.1,
            max_renders: 3,
            adaptive_fraction: 1.0,
            log_offset: 0.001,
        }
    }
}

impl EventCameraDesc {
    /// True for the defaults (left out when a world is written).
    pub fn is_default(&self) -> bool {
        *self == EventCameraDesc::default()
    }

    /// Validates the parameters (errors name `world.camera.events.KEY`, the value and the range).
    pub fn validate(&self) -> Result<(), SimError> {
        let key = |k: &str| format!("world.camera.events.{k}");
        let range = |k: &str, v: f64, lo: f64, hi: f64, what: &str| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err(SimError::invalid(
                    key(k),
                    v,
                    format!("must be in [{lo}, {hi}] ({what})"),
                ))
            }
        };
        range(
            "contrast_on",
            self.contrast_on,
            0.01,
            5.0,
            "log-intensity change per ON event",
        )?;
        range(
            "contrast_off",
            self.contrast_off,
            0.01,
            5.0,
            "log-intensity change per OFF event",
        )?;
        range(
            "mismatch_sigma",
            self.mismatch_sigma,
            0.0,
            1.0,
            "relative σ of the thresholds; 0 = none",
        )?;
        range("refractory_s", self.refractory_s, 0.0, 1.0, "seconds; 0 = none")?;
        range(
            "leak_rate_hz",
            self.leak_rate_hz,
            0.0,
            1e4,
            "events per pixel per second",
        )?;
        range(
            "shot_rate_hz",
            self.shot_rate_hz,
            0.0,
            1e4,
            "events per pixel per second",
        )?;
        if !(1..=MAX_EVENT_RENDERS).contains(&self.max_renders) {
            return Err(SimError::invalid(
                key("max_renders"),
                self.max_renders,
                format!("must be in 1..={MAX_EVENT_RENDERS} (views rendered per camera period, the frame included)"),
            ));
        }
        if !(self.adaptive_fraction.is_finite() && self.adaptive_fraction > 0.0 && self.adaptive_fraction <= 10.0) {
            return Err(SimError::invalid(
                key("adaptive_fraction"),
                self.adaptive_fraction,
                "must be in (0, 10] (fraction of min(contrast_on, contrast_off))",
            ));
        }
        range(
            "log_offset",
            self.log_offset,
            1e-9,
            1.0,
            "luminance added before the log",
        )?;
        Ok(())
    }
}

/// One event: a pixel's log intensity crossed a threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// Time (s, simulation time), within the camera period `(t₀, t₁]`.
    pub t_s: f64,
    /// Column (0 = left).
    pub x: u16,
    /// Row (0 = top).
    pub y: u16,
    /// +1 (ON: brighter) or −1 (OFF: darker).
    pub polarity: i8,
}

/// The events of one camera period.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EventPacket {
    /// Image size (n × n).
    pub n: u32,
    /// Start of the period (s): the previous frame's time.
    pub t_start_s: f64,
    /// End of the period (s): this frame's time.
    pub t_end_s: f64,
    /// The events, sorted by time (then row, column, polarity).
    pub events: Vec<Event>,
    /// ON events per pixel (n·n, row-major), noise included.
    pub on_counts: Vec<u16>,
    /// OFF events per pixel (n·n, row-major), noise included.
    pub off_counts: Vec<u16>,
    /// Views rendered for this period, the frame included (the adaptive sub-frames).
    pub renders: u32,
}

impl EventPacket {
    /// Empties the packet for an `n × n` image and the period `[t_start_s, t_end_s]`, keeping its
    /// buffers.
    pub fn clear(&mut self, n: u32, t_start_s: f64, t_end_s: f64) {
        let px = (n as usize) * (n as usize);
        self.n = n;
        self.t_start_s = t_start_s;
        self.t_end_s = t_end_s;
        self.events.clear();
        self.on_counts.clear();
        self.on_counts.resize(px, 0);
        self.off_counts.clear();
        self.off_counts.resize(px, 0);
        self.renders = 0;
    }

    fn push(&mut self, e: Event) {
        let i = e.y as usize * self.n as usize + e.x as usize;
        let c = if e.polarity > 0 {
            &mut self.on_counts[i]
        } else {
            &mut self.off_counts[i]
        };
        *c = c.saturating_add(1);
        self.events.push(e);
    }
}

/// `ln(x)` for finite `x > 0`, to within 1e-6 (absolute) of `f32::ln`: a polynomial on the
/// mantissa (the camera takes n² logs per view; this is ~5× faster and vectorises).
#[inline]
fn fast_ln(x: f32) -> f32 {
    let bits = x.to_bits();
    let exponent = ((bits >> 23) & 0xff) as i32 - 127;
    // mantissa m in [1, 2), folded to [√½, √2) so that the series argument is small
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let mut e = exponent as f32;
    if m > std::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1.0;
    }
    // ln m = 2 atanh(u), u = (m − 1)/(m + 1) ∈ (−0.172, 0.172)
    let u = (m - 1.0) / (m + 1.0);
    let u2 = u * u;
    let series = 2.0 * u * (1.0 + u2 * (1.0 / 3.0 + u2 * (1.0 / 5.0 + u2 * (1.0 / 7.0 + u2 * (1.0 / 9.0)))));
    series + e * std::f32::consts::LN_2
}

/// A renderer of sub-frames for [`EventCamera::period`]: `(alpha, buf)` renders the view at the
/// fraction `alpha` of the period into `buf`.
pub type RenderSubframe<'a, E> = dyn FnMut(f64, &mut Vec<f32>) -> Result<(), E> + 'a;

/// Salt of the event noise generator's seed.
const NOISE_SALT: u64 = 0x4556_454e_5453_4e5a;
/// Salt of the threshold mismatch's generator.
const MISMATCH_SALT: u64 = 0x4d49_534d_4154_4348;

/// A running event camera (one per episode; [`EventCamera::period`] once per camera period).
#[derive(Clone, Debug)]
pub struct EventCamera {
    desc: EventCameraDesc,
    seed: u64,
    n: usize,
    /// Per-pixel thresholds (log units).
    c_on: Vec<f32>,
    c_off: Vec<f32>,
    /// Per-pixel reference level (log intensity at the last crossing).
    reference: Vec<f32>,
    /// Per-pixel time of the last emitted event (s; −∞ before any).
    last_event_s: Vec<f64>,
    /// The log intensity at the end of the last period and its time.
    previous: Vec<f32>,
    /// The luminance at the end of the last period (for [`Self::renders_after`]).
    previous_luminance: Vec<f32>,
    t_previous_s: f64,
    started: bool,
    /// The log intensities of the period's views in time order, from the previous frame to this
    /// one (a pool: buffers reused).
    logs: Vec<Vec<f32>>,
    /// The period's sub-frames (luminance) when rendered one by one ([`Self::period`]).
    subframes: Vec<Vec<f32>>,
}

impl EventCamera {
    /// An event camera with validated parameters for an `n × n` image, seeded with the simulator's
    /// seed (thresholds and noise).
    pub fn new(desc: &EventCameraDesc, n: u32, seed: u64) -> Result<EventCamera, SimError> {
        desc.validate()?;
        let n = n as usize;
        let px = n * n;
        let table = crate::sensor::normal_table();
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ MISMATCH_SALT);
        let mut draw = |c: f64| {
            let z = table[(rng.next_u32() & 0xffff) as usize];
            (c * (1.0 + desc.mismatch_sigma * z)).max(c / 10.0) as f32
        };
        let c_on = (0..px).map(|_| draw(desc.contrast_on)).collect();
        let c_off = (0..px).map(|_| draw(desc.contrast_off)).collect();
        Ok(EventCamera {
            desc: *desc,
            seed,
            n,
            c_on,
            c_off,
            reference: vec![0.0; px],
            last_event_s: vec![f64::NEG_INFINITY; px],
            previous: vec![0.0; px],
            previous_luminance: vec![0.0; px],
            t_previous_s: 0.0,
            started: false,
            logs: Vec::new(),
            subframes: Vec::new(),
        })
    }

    /// Image side n (pixels).
    pub fn n(&self) -> u32 {
        self.n as u32
    }

    /// The parameters.
    pub fn desc(&self) -> &EventCameraDesc {
        &self.desc
    }

    /// The per-pixel ON and OFF thresholds (log units), row-major.
    pub fn thresholds(&self) -> (&[f32], &[f32]) {
        (&self.c_on, &self.c_off)
    }

    /// Whether a first frame was seen (later frames give events).
    pub fn started(&self) -> bool {
        self.started
    }

    fn log_into(&self, luminance: &[f32], out: &mut Vec<f32>) {
        let eps = self.desc.log_offset as f32;
        out.clear();
        out.extend(luminance.iter().map(|&l| fast_ln(l.clamp(0.0, 1.0) + eps)));
    }

    /// Views to render for the period from `previous` to `current` (luminances, n·n each), the
    /// frame included: step 1's `k` (1 ..= `max_renders`).
    pub fn renders_for(&self, previous: &[f32], current: &[f32]) -> u32 {
        let eps = self.desc.log_offset as f32;
        // the largest |ln(b + ε) − ln(a + ε)| is the log of the largest ratio either way
        let ratio = previous.iter().zip(current).fold(1.0f32, |m, (&a, &b)| {
            let (a, b) = (a.clamp(0.0, 1.0) + eps, b.clamp(0.0, 1.0) + eps);
            m.max(a / b).max(b / a)
        });
        self.renders_of_change(fast_ln(ratio))
    }

    /// Step 1's `k` for a largest log-intensity change `change`.
    fn renders_of_change(&self, change: f32) -> u32 {
        let step = self.desc.adaptive_fraction * self.desc.contrast_on.min(self.desc.contrast_off);
        (f64::from(change) / step)
            .ceil()
            .clamp(1.0, f64::from(self.desc.max_renders)) as u32
    }

    /// Converts one camera period ending with `frame` (n·n luminances at time `t_s`, frame index
    /// `frame_index`) into `out`, rendering its sub-frames one by one: `render(alpha, buf)`
    /// renders the view at the fraction `alpha` ∈ (0, 1) of the period (0 = the previous frame,
    /// 1 = this one) into `buf`. The episode's first call only stores the frame (no events, no
    /// renders asked). [`Self::period_with`] is the same with the sub-frames rendered beforehand.
    pub fn period<E>(
        &mut self,
        frame: &[f32],
        t_s: f64,
        frame_index: u64,
        render: &mut RenderSubframe<'_, E>,
        out: &mut EventPacket,
    ) -> Result<(), E> {
        let mut subframes = std::mem::take(&mut self.subframes);
        let k = if self.started {
            self.renders_after(frame) as usize
        } else {
            1
        };
        subframes.resize_with(subframes.len().max(k - 1), Vec::new);
        for (j, buf) in subframes[..k - 1].iter_mut().enumerate() {
            if let Err(e) = render((j + 1) as f64 / k as f64, buf) {
                self.subframes = subframes;
                return Err(e);
            }
        }
        let views: Vec<&[f32]> = subframes[..k - 1].iter().map(Vec::as_slice).collect();
        self.period_with(frame, t_s, frame_index, &views, out);
        drop(views);
        self.subframes = subframes;
        Ok(())
    }

    /// [`Self::renders_for`] from the last frame this camera converted to `frame` (1 before the
    /// first frame).
    pub fn renders_after(&self, frame: &[f32]) -> u32 {
        if !self.started {
            return 1;
        }
        self.renders_for(&self.previous_luminance, frame)
    }

    /// [`Self::period`] with the period's sub-frames given: `subframes[j]` is the view at the
    /// fraction `(j + 1) / (subframes.len() + 1)` of the period (luminances, n·n each), as many as
    /// [`Self::renders_for`] asks minus one (the frame). The episode's first call only stores the
    /// frame.
    pub fn period_with(
        &mut self,
        frame: &[f32],
        t_s: f64,
        frame_index: u64,
        subframes: &[&[f32]],
        out: &mut EventPacket,
    ) {
        let n = self.n as u32;
        assert_eq!(frame.len(), self.n * self.n, "event camera: the frame must be n·n");
        if !self.started {
            out.clear(n, t_s, t_s);
            out.renders = 1;
            let mut prev = std::mem::take(&mut self.previous);
            self.log_into(frame, &mut prev);
            self.reference.copy_from_slice(&prev);
            self.previous = prev;
            self.previous_luminance.copy_from_slice(frame);
            self.t_previous_s = t_s;
            self.started = true;
            return;
        }
        out.clear(n, self.t_previous_s, t_s);
        let views = subframes.len() + 2;
        self.logs.resize_with(self.logs.len().max(views), Vec::new);
        let mut logs = std::mem::take(&mut self.logs);
        logs[0].clone_from(&self.previous);
        for (log, lum) in logs[1..views].iter_mut().zip(subframes.iter().copied().chain([frame])) {
            self.log_into(lum, log);
        }
        self.logs = logs;
        out.renders = subframes.len() as u32 + 1;
        self.crossings(views, out);
        self.noise(frame_index, out);
        out.events.sort_unstable_by(|a, b| {
            a.t_s
                .total_cmp(&b.t_s)
                .then(a.y.cmp(&b.y))
                .then(a.x.cmp(&b.x))
                .then(a.polarity.cmp(&b.polarity))
        });
        // this frame's log intensity is the next period's start
        std::mem::swap(&mut self.previous, &mut self.logs[views - 1]);
        self.previous_luminance.copy_from_slice(frame);
        self.t_previous_s = t_s;
    }

    /// Step 2–4: the threshold crossings of every pixel over the period's `views` log images
    /// (`self.logs`, evenly spaced in time).
    fn crossings(&mut self, views: usize, out: &mut EventPacket) {
        let (t0, t1) = (out.t_start_s, out.t_end_s);
        let step = (t1 - t0) / (views - 1) as f64;
        let refractory = self.desc.refractory_s;
        let logs = &self.logs[..views];
        for p in 0..self.n * self.n {
            let (c_on, c_off) = (f64::from(self.c_on[p]), f64::from(self.c_off[p]));
            let mut r = f64::from(self.reference[p]);
            let mut last = self.last_event_s[p];
            for (j, w) in logs.windows(2).enumerate() {
                let (la, lb) = (f64::from(w[0][p]), f64::from(w[1][p]));
                if (lb - r).abs() < c_on.min(c_off) {
                    continue;
                }
                let ta = t0 + j as f64 * step;
                let tb = if j + 2 == views { t1 } else { ta + step };
                loop {
                    let (level, polarity) = if lb >= r + c_on {
                        (r + c_on, 1)
                    } else if lb <= r - c_off {
                        (r - c_off, -1)
                    } else {
                        break;
                    };
                    // the linear segment la → lb crosses `level` once (|la − r| was below a threshold)
                    let f = if lb == la {
                        1.0
                    } else {
                        ((level - la) / (lb - la)).clamp(0.0, 1.0)
                    };
                    let t = (ta + f * (tb - ta)).max(t0 + f64::EPSILON * t0.abs().max(1.0));
                    r = level;
                    if t - last >= refractory {
                        last = t;
                        out.push(Event {
                            t_s: t,
                            x: (p % self.n) as u16,
                            y: (p / self.n) as u16,
                            polarity,
                        });
                    }
                }
            }
            self.reference[p] = r as f32;
            self.last_event_s[p] = last;
        }
    }

    /// Step 5: leak and shot-noise events of the period, from the seed and the frame index.
    fn noise(&self, frame_index: u64, out: &mut EventPacket) {
        let rate = self.desc.leak_rate_hz + self.desc.shot_rate_hz;
        let period = out.t_end_s - out.t_start_s;
        if rate <= 0.0 || period <= 0.0 {
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ NOISE_SALT);
        rng.set_stream(frame_index);
        let mut unit = || (((rng.next_u64() >> 11) as f64) + 0.5) * (1.0 / (1u64 << 53) as f64);
        // one Poisson process of rate `rate` on the pixels' periods laid end to end
        let total = (self.n * self.n) as f64 * period;
        let mut u = 0.0;
        loop {
            u += -unit().ln() / rate;
            if u >= total {
                break;
            }
            let p = ((u / period) as usize).min(self.n * self.n - 1);
            let t = out.t_start_s + (u - p as f64 * period).clamp(0.0, period);
            let kind = unit() * rate;
            // leak events are ON; shot-noise events ON or OFF with probability ½ each
            let polarity = if kind < self.desc.leak_rate_hz + self.desc.shot_rate_hz / 2.0 {
                1
            } else {
                -1
            };
            out.push(Event {
                t_s: t.max(out.t_start_s + f64::EPSILON * out.t_start_s.abs().max(1.0)),
                x: (p % self.n) as u16,
                y: (p / self.n) as u16,
                polarity,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_ln_is_ln() {
        let mut worst = 0.0f32;
        for i in 0..200_000 {
            let x = 1e-4 + i as f32 * (1.001 / 200_000.0);
            worst = worst.max((fast_ln(x) - x.ln()).abs());
        }
        assert!(worst < 2e-6, "{worst}");
    }

    #[test]
    fn defaults_validate_and_bad_values_name_the_key() {
        EventCameraDesc::default().validate().unwrap();
        let e = EventCameraDesc {
            contrast_on: 0.0,
            ..EventCameraDesc::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("world.camera.events.contrast_on") && e.contains("0.01"),
            "{e}"
        );
        let e = EventCameraDesc {
            max_renders: 0,
            ..EventCameraDesc::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("max_renders") && e.contains("1..=64"), "{e}");
        for bad in [
            EventCameraDesc {
                leak_rate_hz: -1.0,
                ..EventCameraDesc::default()
            },
            EventCameraDesc {
                adaptive_fraction: f64::NAN,
                ..EventCameraDesc::default()
            },
            EventCameraDesc {
                log_offset: 0.0,
                ..EventCameraDesc::default()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }
}
