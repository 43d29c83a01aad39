//! Event input: what an event camera delivers each camera period (the simulator's
//! `[world.camera] kind = "events"`, `loomlab_sim::events`), as detectors receive it
//! ([`EventInput`], [`crate::Detector::step_events`]), and [`FrameEvents`], the same model's
//! events made from consecutive frames when there is no event camera.
//!
//! Which rows read what (docs/detectors.md, "Event input"): the event rows (`event_soc`,
//! `event_lgmd`; [`crate::Detector::reads_events`]) read events; every other row reads frames, with
//! or without an event camera (the default [`crate::Detector::step_events`] ignores the events).

use crate::{DetectorError, Frame};

/// One event: a pixel's log intensity crossed a contrast threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// Time (s), within the period `(t_start_s, t_end_s]`.
    pub t_s: f64,
    /// Column (0 = left).
    pub x: u16,
    /// Row (0 = top).
    pub y: u16,
    /// +1 (ON: brighter) or −1 (OFF: darker).
    pub polarity: i8,
}

/// The events of one camera period, borrowed: the event list and the ON / OFF count images.
#[derive(Clone, Copy, Debug)]
pub struct EventInput<'a> {
    /// Image side n (pixels).
    pub n: usize,
    /// Start of the period (s): the previous frame's time.
    pub t_start_s: f64,
    /// End of the period (s): this frame's time.
    pub t_end_s: f64,
    /// The events, sorted by time.
    pub events: &'a [Event],
    /// ON events per pixel (n·n, row-major).
    pub on_counts: &'a [u16],
    /// OFF events per pixel (n·n, row-major).
    pub off_counts: &'a [u16],
}

impl EventInput<'_> {
    /// Checks the sizes (count images n·n, events inside the image): an
    /// [`DetectorError::InvalidImage`] naming what is wrong.
    pub fn check(&self) -> Result<(), DetectorError> {
        let px = self.n * self.n;
        if self.on_counts.len() != px || self.off_counts.len() != px {
            return Err(DetectorError::InvalidImage(format!(
                "event count images must be n·n = {px} pixels (n = {}); got {} ON and {} OFF",
                self.n,
                self.on_counts.len(),
                self.off_counts.len()
            )));
        }
        if let Some(e) = self
            .events
            .iter()
            .find(|e| usize::from(e.x) >= self.n || usize::from(e.y) >= self.n)
        {
            return Err(DetectorError::InvalidImage(format!(
                "event at ({}, {}) outside the {}×{} image",
                e.x, e.y, self.n, self.n
            )));
        }
        if self.t_end_s.is_nan() || self.t_start_s.is_nan() || self.t_end_s < self.t_start_s {
            return Err(DetectorError::InvalidImage(format!(
                "event period ends ({} s) before it starts ({} s)",
                self.t_end_s, self.t_start_s
            )));
        }
        Ok(())
    }

    /// Events in the period (ON and OFF).
    pub fn len(&self) -> usize {
        self.events.len()
    }

    /// Whether the period has no event.
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }
}

/// Events made from consecutive frames: the event camera's model with one render per period (log
/// intensity linear in time between two frames), no threshold mismatch, refractory period or noise.
/// What an event row reads when it is stepped on frames alone (a video, the paper's stimuli, a
/// world without an event camera); with an event camera it reads the camera's events instead.
#[derive(Clone, Debug)]
pub struct FrameEvents {
    contrast: f64,
    log_offset: f64,
    period_s: f64,
    n: Option<usize>,
    previous: Vec<f64>,
    reference: Vec<f64>,
    t_s: f64,
    events: Vec<Event>,
    on: Vec<u16>,
    off: Vec<u16>,
}

impl FrameEvents {
    /// Crossings of `contrast` (log units) in `ln(L + log_offset)`, frames `period_s` apart.
    pub fn new(contrast: f64, log_offset: f64, period_s: f64) -> Self {
        Self {
            contrast,
            log_offset,
            period_s,
            n: None,
            previous: Vec::new(),
            reference: Vec::new(),
            t_s: 0.0,
            events: Vec::new(),
            on: Vec::new(),
            off: Vec::new(),
        }
    }

    /// Forgets every frame.
    pub fn reset(&mut self) {
        self.n = None;
        self.t_s = 0.0;
    }

    /// The events of the period that ended with `frame`; `None` for the first frame (nothing
    /// before it). A frame of another size than the first is [`DetectorError::FrameSize`].
    pub fn convert(&mut self, frame: &Frame) -> Result<Option<EventInput<'_>>, DetectorError> {
        let n = frame.n();
        let log = |l: f32| (f64::from(l.clamp(0.0, 1.0)) + self.log_offset).ln();
        match self.n {
            None => {
                self.n = Some(n);
                self.previous.clear();
                self.previous.extend(frame.data().iter().map(|&l| log(l)));
                self.reference.clone_from(&self.previous);
                self.t_s = 0.0;
                return Ok(None);
            }
            Some(expected) if expected != n => return Err(DetectorError::FrameSize { expected, got: n }),
            Some(_) => {}
        }
        let (t0, t1) = (self.t_s, self.t_s + self.period_s);
        self.events.clear();
        self.on.clear();
        self.on.resize(n * n, 0);
        self.off.clear();
        self.off.resize(n * n, 0);
        let c = self.contrast;
        for (p, &l) in frame.data().iter().enumerate() {
            let (la, lb) = (self.previous[p], log(l));
            let mut r = self.reference[p];
            while (lb - r).abs() >= c {
                let (level, polarity) = if lb > r { (r + c, 1) } else { (r - c, -1) };
                let f = if lb == la {
                    1.0
                } else {
                    ((level - la) / (lb - la)).clamp(0.0, 1.0)
                };
                r = level;
                self.events.push(Event {
                    t_s: t0 + f * (t1 - t0),
                    x: (p % n) as u16,
                    y: (p / n) as u16,
                    polarity,
                });
                let count = if polarity > 0 {
                    &mut self.on[p]
                } else {
                    &mut self.off[p]
                };
                *count = count.saturating_add(1);
            }
            self.reference[p] = r;
            self.previous[p] = lb;
        }
        self.events
            .sort_unstable_by(|a, b| a.t_s.total_cmp(&b.t_s).then(a.y.cmp(&b.y)).then(a.x.cmp(&b.x)));
        self.t_s = t1;
        Ok(Some(EventInput {
            n,
            t_start_s: t0,
            t_end_s: t1,
            events: &self.events,
            on_counts: &self.on,
            off_counts: &self.off,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_events_count_the_log_crossings() {
        let mut fe = FrameEvents::new(0.2, 1e-9, 0.01);
        assert!(fe.convert(&Frame::uniform(20, 0.1)).unwrap().is_none());
        let ev = fe.convert(&Frame::uniform(20, 0.5)).unwrap().unwrap();
        // ln 5 / 0.2 = 8.05: 8 ON events per pixel
        assert!(ev.on_counts.iter().all(|&c| c == 8) && ev.off_counts.iter().all(|&c| c == 0));
        assert_eq!(ev.len(), 8 * 400);
        assert!(ev.events.iter().all(|e| e.t_s > 0.0 && e.t_s <= 0.01));
        ev.check().unwrap();
        let e = fe.convert(&Frame::uniform(24, 0.5)).unwrap_err();
        assert!(matches!(e, DetectorError::FrameSize { expected: 20, got: 24 }));
    }
}
