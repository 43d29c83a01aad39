//! The event camera (`[world.camera] kind = "events"`, parameters in `[world.camera.events]`): a
//! dynamic vision sensor (DVS) model in the manner of ESIM (Rebecq, Gehrig & Scaramuzza 2018,
//! "ESIM: an open event camera simulator", CoRL), delivered once per camera period as an event
//! list `(t, x, y, polarity)` and as ON / OFF count images ([`EventPacket`]).
//!
//! **The model**, per pixel i with log intensity `I(t) = ln(L(t) + log_offset)` of its luminance
//! L ∈ [0, 1]:
//! 1. *Renders*: each camera period `[t₀, t₁]` starts from the view rendered at t₀ (the previous
//!    frame) and ends with the view at t₁ (this frame). Between two neighbouring renders at times
//!    a < b the camera subdivides **adaptively**: while the largest per-pixel change
//!    `max_i |I_i(b) − I_i(a)|` of some interval exceeds `adaptive_fraction · min(C+, C−)` and
//!    fewer than `max_renders` views were rendered in the period, the widest such interval (the
//!    earliest of equals) is split at its midpoint by one more render (the bodies' and the camera's poses interpolated as
//!    for the exposure blur, [`crate::sensor`]). A still scene costs one render per period (the
//!    frame); fast motion up to `max_renders`.
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
//! arithmetic; after the first period the conversion allocates nothing (its buffers are reused).
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
    /// 1 interpolates linearly from the previous frame to this one. Default 8.
    pub max_renders: u32,
    /// Adaptive sub-frames: an interval between two renders is split while its largest per-pixel
    /// log-intensity change exceeds this fraction of min(C+, C−), in (0, 10]. Default 0.5.
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
            max_renders: 8,
            adaptive_fraction: 0.5,
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

/// Salt of the event noise generator's seed.
const NOISE_SALT: u64 = 0x4556_454e_5453_4e5a;
/// Salt of the threshold mismatch's generator.
const MISMATCH_SALT: u64 = 0x4d49_534d_4154_4348;

/// One render of a period: its time as a fraction of the period and its log intensity.
#[derive(Clone, Debug, Default)]
struct Key {
    alpha: f64,
    log: Vec<f32>,
}

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
    t_previous_s: f64,
    started: bool,
    /// The renders of the period being converted (a pool: buffers reused), and their order in time.
    keys: Vec<Key>,
    order: Vec<usize>,
    /// Per neighbouring pair of `order`: its largest per-pixel change.
    gaps: Vec<f32>,
    /// The luminance buffer renders are written into.
    scratch: Vec<f32>,
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
            t_previous_s: 0.0,
            started: false,
            keys: Vec::new(),
            order: Vec::new(),
            gaps: Vec::new(),
            scratch: Vec::new(),
        })
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
        out.extend(luminance.iter().map(|&l| (l.clamp(0.0, 1.0) + eps).ln()));
    }

    /// Converts one camera period ending with `frame` (n·n luminances at time `t_s`, frame index
    /// `frame_index`) into `out`. `render(alpha, buf)` renders the view at the fraction `alpha` ∈
    /// (0, 1) of the period (0 = the previous frame, 1 = this one) into `buf`, for the adaptive
    /// sub-frames. The episode's first call only stores the frame (no events, no renders asked).
    pub fn period<E>(
        &mut self,
        frame: &[f32],
        t_s: f64,
        frame_index: u64,
        render: &mut dyn FnMut(f64, &mut Vec<f32>) -> Result<(), E>,
        out: &mut EventPacket,
    ) -> Result<(), E> {
        let n = self.n as u32;
        assert_eq!(frame.len(), self.n * self.n, "event camera: the frame must be n·n");
        if !self.started {
            out.clear(n, t_s, t_s);
            out.renders = 1;
            let mut prev = std::mem::take(&mut self.previous);
            self.log_into(frame, &mut prev);
            self.reference.copy_from_slice(&prev);
            self.previous = prev;
            self.t_previous_s = t_s;
            self.started = true;
            return Ok(());
        }
        out.clear(n, self.t_previous_s, t_s);
        out.renders = self.subdivide(frame, render)?;
        self.crossings(out);
        self.noise(frame_index, out);
        out.events.sort_unstable_by(|a, b| {
            a.t_s
                .total_cmp(&b.t_s)
                .then(a.y.cmp(&b.y))
                .then(a.x.cmp(&b.x))
                .then(a.polarity.cmp(&b.polarity))
        });
        // this frame's log intensity is the next period's start
        let last = self.order[self.order.len() - 1];
        std::mem::swap(&mut self.previous, &mut self.keys[last].log);
        self.t_previous_s = t_s;
        Ok(())
    }

    /// Step 1: the renders of the period (keys at alpha 0 and 1, then the adaptive midpoints);
    /// returns the number of views rendered (the frame included).
    fn subdivide<E>(
        &mut self,
        frame: &[f32],
        render: &mut dyn FnMut(f64, &mut Vec<f32>) -> Result<(), E>,
    ) -> Result<u32, E> {
        self.keys.resize_with(self.keys.len().max(2), Key::default);
        self.keys[0].alpha = 0.0;
        self.keys[0].log.clone_from(&self.previous);
        let mut end = std::mem::take(&mut self.keys[1].log);
        self.log_into(frame, &mut end);
        self.keys[1] = Key { alpha: 1.0, log: end };
        self.order.clear();
        self.order.extend([0, 1]);
        self.gaps.clear();
        self.gaps.push(max_change(&self.keys[0].log, &self.keys[1].log));
        let limit = (self.desc.adaptive_fraction * self.desc.contrast_on.min(self.desc.contrast_off)) as f32;
        let mut renders = 1u32;
        while renders < self.desc.max_renders {
            // the widest interval whose change exceeds the limit (the earliest of equals): halves,
            // then quarters, … of the changing parts of the period
            let mut split: Option<(usize, f64)> = None;
            for (i, &gap) in self.gaps.iter().enumerate() {
                let width = self.keys[self.order[i + 1]].alpha - self.keys[self.order[i]].alpha;
                if gap > limit && split.is_none_or(|(_, w)| width > w) {
                    split = Some((i, width));
                }
            }
            let Some((i, _)) = split else { break };
            let (a, b) = (self.order[i], self.order[i + 1]);
            let alpha = 0.5 * (self.keys[a].alpha + self.keys[b].alpha);
            let mut lum = std::mem::take(&mut self.scratch);
            let rendered = render(alpha, &mut lum);
            let slot = renders as usize + 1;
            if self.keys.len() <= slot {
                self.keys.push(Key::default());
            }
            let mut log = std::mem::take(&mut self.keys[slot].log);
            if rendered.is_ok() {
                self.log_into(&lum, &mut log);
            }
            self.scratch = lum;
            rendered?;
            self.keys[slot] = Key { alpha, log };
            self.order.insert(i + 1, slot);
            let left = max_change(&self.keys[a].log, &self.keys[slot].log);
            let right = max_change(&self.keys[slot].log, &self.keys[b].log);
            self.gaps[i] = left;
            self.gaps.insert(i + 1, right);
            renders += 1;
        }
        Ok(renders)
    }

    /// Step 2–4: the threshold crossings of every pixel over the period's renders.
    fn crossings(&mut self, out: &mut EventPacket) {
        let (t0, t1) = (out.t_start_s, out.t_end_s);
        let period = t1 - t0;
        let refractory = self.desc.refractory_s;
        for p in 0..self.n * self.n {
            let (c_on, c_off) = (f64::from(self.c_on[p]), f64::from(self.c_off[p]));
            let mut r = f64::from(self.reference[p]);
            let mut last = self.last_event_s[p];
            for w in self.order.windows(2) {
                let (ka, kb) = (&self.keys[w[0]], &self.keys[w[1]]);
                let (la, lb) = (f64::from(ka.log[p]), f64::from(kb.log[p]));
                if (lb - r).abs() < c_on.min(c_off) {
                    continue;
                }
                let (ta, tb) = (t0 + ka.alpha * period, t0 + kb.alpha * period);
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

/// The largest per-pixel absolute difference of two log images.
fn max_change(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()))
}

#[cfg(test)]
mod tests {
    use super::*;

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
