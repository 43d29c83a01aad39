//! Event LGMD — an event-driven LGMD network (detector id `event_lgmd`) after Salt, Indiveri &
//! Sandamirskaya 2017, "Obstacle avoidance with LGMD neuron: towards a neuromorphic UAV
//! implementation" (ISCAS), whose network Salt et al. 2019 (IEEE TNNLS, "Parameter optimization and
//! learning in a spiking neural network for UAV obstacle avoidance targeting neuromorphic
//! processors") tuned: events drive a photoreceptor layer P; each P spike excites the summing
//! neuron S below it (E) and, one delay later, inhibits its eight neighbours (I, lateral
//! inhibition that an expanding edge outruns and a translating one does not); S neurons are leaky
//! integrate-and-fire and their spikes excite the LGMD neuron, also leaky integrate-and-fire;
//! feed-forward inhibition (F) suppresses the LGMD when the whole field fires at once (a turn).
//!
//! Here (docs/detectors.md, `event_lgmd`): time runs in bins of `bin_s` within each camera period;
//! every event of a bin is one P spike (both polarities); S: `v ← v·e^(−Δt/τ_S) + w_E·E − w_I·I`,
//! clamped at 0, spike and reset to 0 at `v ≥ θ_S`; LGMD: `u ← u·e^(−Δt/τ_L) + g·(S spikes −
//! F)`, with `g = 4096 / n²` (input per S spike at 64², independent of the image size) and
//! `F = w_F · max(0, P spikes − ff_fraction · n²)`, spike and reset at `u ≥ θ_L`. The output is
//! the LGMD's firing rate (Hz), low-passed with `rate_tau_s`. **The parameter values are ours**
//! (chosen for this simulator's images and event rates), not the papers': their network ran on a
//! DVS at 240×180 on a UAV, and the 2019 work optimised them for those recordings.
//!
//! It reads events ([`crate::Detector::step_events`]); on frames alone, [`FrameEvents`].

use serde::Deserialize;

use super::common::{Range, check};
use crate::events::{EventInput, FrameEvents};
use crate::registry::{DetectorConfig, Registration, Signal};
use crate::{Detector, DetectorError, EfferenceCopy, Frame, Signals};

/// Parameters of [`EventLgmd`] (every time in seconds).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EventLgmdConfig {
    /// Time bin of the network (s). Default 0.001.
    pub bin_s: f64,
    /// Membrane time constant of the S neurons (s). Default 0.005.
    pub tau_s_s: f64,
    /// Excitation of an S neuron per P spike below it (E). Default 1.
    pub w_excitation: f64,
    /// Inhibition of an S neuron per P spike of each of its eight neighbours, one `inhibition_delay_bins` later (I). Default 0.2.
    pub w_inhibition: f64,
    /// Delay of the lateral inhibition (bins). Default 2.
    pub inhibition_delay_bins: u32,
    /// Firing threshold of the S neurons. Default 1.5.
    pub s_threshold: f64,
    /// Membrane time constant of the LGMD neuron (s). Default 0.02.
    pub tau_lgmd_s: f64,
    /// Firing threshold of the LGMD neuron (in S spikes at 64², see the module docs). Default 8.
    pub lgmd_threshold: f64,
    /// Feed-forward inhibition per P spike beyond `ff_fraction · n²` in a bin (F). Default 1.
    pub w_feedforward: f64,
    /// P spikes in one bin, as a fraction of the pixels, above which the feed-forward inhibition
    /// acts. Default 0.1.
    pub ff_fraction: f64,
    /// Time constant of the output's firing-rate estimate (s). Default 0.02.
    pub rate_tau_s: f64,
    /// Contrast threshold of the events made from frames without an event camera (log units). Default 0.2.
    pub frame_contrast: f64,
    /// Camera frame rate (Hz): from `world.camera_hz`, never a param. Default 120.
    pub frame_rate_hz: f64,
}

impl Default for EventLgmdConfig {
    fn default() -> Self {
        Self {
            bin_s: 0.001,
            tau_s_s: 0.005,
            w_excitation: 1.0,
            w_inhibition: 0.2,
            inhibition_delay_bins: 2,
            s_threshold: 1.5,
            tau_lgmd_s: 0.02,
            lgmd_threshold: 8.0,
            w_feedforward: 1.0,
            ff_fraction: 0.1,
            rate_tau_s: 0.02,
            frame_contrast: 0.2,
            frame_rate_hz: 120.0,
        }
    }
}

impl EventLgmdConfig {
    /// Checks every value (errors name the parameter, its range and its default).
    pub fn validate(&self) -> Result<(), DetectorError> {
        let d = Self::default();
        check("event_lgmd.bin_s", self.bin_s, Range::Closed(1e-5, 0.1), d.bin_s, "time bin (s)")?;
        check("event_lgmd.tau_s_s", self.tau_s_s, Range::Positive, d.tau_s_s, "S time constant (s)")?;
        check("event_lgmd.w_excitation", self.w_excitation, Range::NonNegative, d.w_excitation, "E weight")?;
        check("event_lgmd.w_inhibition", self.w_inhibition, Range::NonNegative, d.w_inhibition, "I weight")?;
        check(
            "event_lgmd.inhibition_delay_bins",
            f64::from(self.inhibition_delay_bins),
            Range::Closed(0.0, 100.0),
            f64::from(d.inhibition_delay_bins),
            "bins",
        )?;
        check("event_lgmd.s_threshold", self.s_threshold, Range::Positive, d.s_threshold, "S threshold")?;
        check("event_lgmd.tau_lgmd_s", self.tau_lgmd_s, Range::Positive, d.tau_lgmd_s, "LGMD time constant (s)")?;
        check("event_lgmd.lgmd_threshold", self.lgmd_threshold, Range::Positive, d.lgmd_threshold, "LGMD threshold")?;
        check("event_lgmd.w_feedforward", self.w_feedforward, Range::NonNegative, d.w_feedforward, "F weight")?;
        check("event_lgmd.ff_fraction", self.ff_fraction, Range::Closed(0.0, 1.0), d.ff_fraction, "fraction of pixels")?;
        check("event_lgmd.rate_tau_s", self.rate_tau_s, Range::Positive, d.rate_tau_s, "rate time constant (s)")?;
        check("event_lgmd.frame_contrast", self.frame_contrast, Range::Closed(0.01, 5.0), d.frame_contrast, "log units")?;
        check("event_lgmd.frame_rate_hz", self.frame_rate_hz, Range::Positive, d.frame_rate_hz, "frame rate (Hz)")?;
        Ok(())
    }
}

/// The network's state (allocated on the first period, reused after).
#[derive(Debug, Clone, Default)]
struct Network {
    n: usize,
    /// S membrane potentials.
    s: Vec<f64>,
    /// P spikes per pixel of the last `delay + 1` bins (a ring; slot `bin % len`).
    p: Vec<Vec<f32>>,
    /// Total P spikes of each ring slot.
    p_total: Vec<usize>,
    bin: u64,
    lgmd: f64,
    rate_hz: f64,
}

/// The event-driven LGMD (see the module docs). `output`: the LGMD's firing rate (Hz); `aux`:
/// `s_spikes`, `lgmd_spikes` (this period), `lgmd_v` (the membrane at the period's end),
/// `feedforward` (the period's F).
#[derive(Debug, Clone)]
pub struct EventLgmd {
    config: EventLgmdConfig,
    frames: FrameEvents,
    net: Network,
}

impl EventLgmd {
    /// Builds the model after validating `config`.
    pub fn new(config: EventLgmdConfig) -> Result<Self, DetectorError> {
        config.validate()?;
        Ok(Self {
            config,
            frames: FrameEvents::new(config.frame_contrast, 1e-3, 1.0 / config.frame_rate_hz),
            net: Network::default(),
        })
    }

    fn zero() -> Signals {
        Signals {
            output: 0.0,
            angular_size_deg: None,
            aux: vec![("s_spikes", 0.0), ("lgmd_spikes", 0.0), ("lgmd_v", 0.0), ("feedforward", 0.0)],
            region: None,
            objects: Vec::new(),
        }
    }
}

impl Network {
    fn start(&mut self, n: usize, delay: usize) {
        self.n = n;
        self.s.clear();
        self.s.resize(n * n, 0.0);
        self.p.resize_with(delay + 1, Vec::new);
        for slot in &mut self.p {
            slot.clear();
            slot.resize(n * n, 0.0);
        }
        self.p_total.clear();
        self.p_total.resize(delay + 1, 0);
        self.bin = 0;
        self.lgmd = 0.0;
        self.rate_hz = 0.0;
    }

    /// Runs the network over one period's events.
    fn period(&mut self, c: &EventLgmdConfig, events: &EventInput<'_>) -> Result<Signals, DetectorError> {
        events.check()?;
        let n = events.n;
        if self.n == 0 {
            self.start(n, c.inhibition_delay_bins as usize);
        } else if self.n != n {
            return Err(DetectorError::FrameSize { expected: self.n, got: n });
        }
        let period = events.t_end_s - events.t_start_s;
        let bins = ((period / c.bin_s).round() as usize).max(1);
        let dt = if period > 0.0 { period / bins as f64 } else { c.bin_s };
        let (decay_s, decay_l, decay_r) = ((-dt / c.tau_s_s).exp(), (-dt / c.tau_lgmd_s).exp(), (-dt / c.rate_tau_s).exp());
        let gain = 4096.0 / (n * n) as f64;
        let (mut s_total, mut l_spikes, mut ff_total) = (0.0, 0.0, 0.0);
        let mut next = 0;
        for b in 0..bins {
            let end = events.t_start_s + (b + 1) as f64 * dt;
            let slot = (self.bin % self.p.len() as u64) as usize;
            let delayed = ((self.bin + 1) % self.p.len() as u64) as usize;
            // this bin's P spikes
            self.p[slot].iter_mut().for_each(|v| *v = 0.0);
            let first = next;
            while next < events.events.len() && (events.events[next].t_s <= end || b + 1 == bins) {
                let e = events.events[next];
                self.p[slot][usize::from(e.y) * n + usize::from(e.x)] += 1.0;
                next += 1;
            }
            self.p_total[slot] = next - first;
            let s_spikes = self.s_layer(c, slot, delayed, decay_s);
            let ff = c.w_feedforward * (self.p_total[slot] as f64 - c.ff_fraction * (n * n) as f64).max(0.0);
            self.lgmd = self.lgmd * decay_l + gain * (s_spikes - ff);
            self.lgmd = self.lgmd.max(0.0);
            let mut spiked = 0.0;
            if self.lgmd >= c.lgmd_threshold {
                spiked = 1.0;
                self.lgmd = 0.0;
            }
            self.rate_hz = self.rate_hz * decay_r + spiked / c.rate_tau_s;
            s_total += s_spikes;
            l_spikes += spiked;
            ff_total += ff;
            self.bin += 1;
        }
        Ok(Signals {
            output: self.rate_hz,
            angular_size_deg: None,
            aux: vec![
                ("s_spikes", s_total),
                ("lgmd_spikes", l_spikes),
                ("lgmd_v", self.lgmd),
                ("feedforward", ff_total),
            ],
            region: None,
            objects: Vec::new(),
        })
    }

    /// One bin of the S layer: excitation from this bin's P spikes (`slot`), lateral inhibition
    /// from the eight neighbours' P spikes of the delayed bin (`delayed`, the oldest of the ring);
    /// returns the S spikes.
    fn s_layer(&mut self, c: &EventLgmdConfig, slot: usize, delayed: usize, decay: f64) -> f64 {
        let n = self.n;
        let inhibit = self.p_total[delayed] > 0 && c.w_inhibition > 0.0;
        let mut spikes = 0.0;
        for y in 0..n {
            for x in 0..n {
                let i = y * n + x;
                let mut input = c.w_excitation * f64::from(self.p[slot][i]);
                if inhibit {
                    let mut around = 0.0f32;
                    for yy in y.saturating_sub(1)..(y + 2).min(n) {
                        for xx in x.saturating_sub(1)..(x + 2).min(n) {
                            if yy != y || xx != x {
                                around += self.p[delayed][yy * n + xx];
                            }
                        }
                    }
                    input -= c.w_inhibition * f64::from(around);
                }
                let v = (self.s[i] * decay + input).max(0.0);
                if v >= c.s_threshold {
                    spikes += 1.0;
                    self.s[i] = 0.0;
                } else {
                    self.s[i] = v;
                }
            }
        }
        spikes
    }
}

impl Detector for EventLgmd {
    fn id(&self) -> &'static str {
        "event_lgmd"
    }

    fn reads_events(&self) -> bool {
        true
    }

    fn snapshot(&self) -> Option<Box<dyn Detector>> {
        Some(Box::new(self.clone()))
    }

    fn reset(&mut self) {
        self.frames.reset();
        self.net = Network::default();
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        match self.frames.convert(frame)? {
            None => {
                if self.net.n == 0 {
                    self.net.start(frame.n(), self.config.inhibition_delay_bins as usize);
                }
                Ok(Self::zero())
            }
            Some(events) => self.net.period(&self.config, &events),
        }
    }

    fn step_events(&mut self, _frame: &Frame, events: &EventInput<'_>, _ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        self.net.period(&self.config, events)
    }
}

impl DetectorConfig for EventLgmdConfig {
    const CAMERA_KEYS: &'static [&'static str] = &["frame_rate_hz"];

    fn for_camera(self, camera: &crate::registry::CameraFacts) -> Self {
        Self {
            frame_rate_hz: camera.frame_rate_hz,
            ..self
        }
    }

    fn validate(&self) -> Result<(), DetectorError> {
        EventLgmdConfig::validate(self)
    }

    fn build(&self, _n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Ok(Box::new(EventLgmd::new(*self)?))
    }
}

/// `event_lgmd` in the registry; the default threshold is the LGMD's firing rate (Hz), calibrated
/// on held-out draws of the default suite on the event camera (`EVENT_LGMD_THRESHOLD`).
pub(crate) fn registration() -> Registration {
    Registration::of::<EventLgmdConfig>(
        "event_lgmd",
        "Event-driven LGMD network (Salt, Indiveri & Sandamirskaya 2017)",
        &[Signal::Output],
        Signal::Output,
        EVENT_LGMD_THRESHOLD,
    )
}

/// The default threshold of `event_lgmd` (LGMD spikes per second): calibrated on the default
/// suite on the event camera at `--seed 7` alone (`loomlab run --sensor events --seed 7
/// --calibrate 0.1`: at most 10 % false alarms over its 200 non-threats; near the network's
/// saturation of one spike per bin, 1000 Hz); not yet pooled with seeds 8 and 9.
const EVENT_LGMD_THRESHOLD: f64 = 940.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::Event;

    fn input<'a>(n: usize, t0: f64, events: &'a [Event], counts: &'a [u16]) -> EventInput<'a> {
        EventInput {
            n,
            t_start_s: t0,
            t_end_s: t0 + 1.0 / 120.0,
            events,
            on_counts: counts,
            off_counts: counts,
        }
    }

    /// An expanding ring of events makes the LGMD fire; the same number of events spread as
    /// whole-field flicker (every pixel at once) is held back by the feed-forward inhibition.
    #[test]
    fn an_expanding_edge_excites_and_whole_field_flicker_does_not() {
        let n = 64;
        let counts = vec![0u16; n * n];
        let mut ring = EventLgmd::new(EventLgmdConfig::default()).unwrap();
        let mut flicker = EventLgmd::new(EventLgmdConfig::default()).unwrap();
        let (mut ring_rate, mut flicker_rate) = (0.0, 0.0);
        for k in 0..12 {
            let t0 = k as f64 / 120.0;
            let mut ev = Vec::new();
            for sub in 0..8 {
                let t = t0 + (sub as f64 + 0.5) / 8.0 / 120.0;
                let (r0, r1) = (4.0 + (k * 8 + sub) as f64 * 0.25, 4.0 + (k * 8 + sub + 1) as f64 * 0.25);
                for p in 0..n * n {
                    let d = ((p % n) as f64 + 0.5 - 32.0).hypot((p / n) as f64 + 0.5 - 32.0);
                    if r0 < d && d <= r1 {
                        // a dark edge crosses several thresholds: three events per pixel
                        for j in 0..3 {
                            ev.push(Event { t_s: t + j as f64 * 1e-5, x: (p % n) as u16, y: (p / n) as u16, polarity: -1 });
                        }
                    }
                }
            }
            ev.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
            let mut whole: Vec<Event> = (0..ev.len())
                .map(|i| {
                    let p = i / 3;
                    Event { t_s: t0 + 0.004 + (i % 3) as f64 * 1e-5, x: (p % n) as u16, y: ((p / n) % n) as u16, polarity: 1 }
                })
                .collect();
            whole.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
            ring_rate = ring.step_events(&Frame::uniform(n, 0.5), &input(n, t0, &ev, &counts), &EfferenceCopy::default()).unwrap().output;
            flicker_rate = flicker
                .step_events(&Frame::uniform(n, 0.5), &input(n, t0, &whole, &counts), &EfferenceCopy::default())
                .unwrap()
                .output;
        }
        assert!(ring_rate > 100.0, "expanding edge: {ring_rate} Hz");
        assert!(flicker_rate < ring_rate / 4.0, "flicker {flicker_rate} Hz against the edge's {ring_rate} Hz");
    }
}
