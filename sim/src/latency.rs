//! Latency of the robot's pipeline, applied by the simulator so that every consumer (the runner's
//! open loop, its closed-loop tails, the deadline replays, the env, `loomlab render` and `detect`)
//! honours it the same:
//! - **perception latency** (`world.camera.perception_latency_s`): a step's frame is the view of
//!   `round(latency · camera_hz)` frames earlier (the frame a detector receives now was exposed
//!   then; ground truth and contacts stay those of now);
//! - **actuation latency** (`world.robot.actuation_latency_s`): the command given to a step takes
//!   effect `round(latency · camera_hz)` frames later (until then the earlier commands act).
//!
//! Both are quantised to whole camera frames (at 120 Hz: 8.3 ms). At the start of an episode the
//! line is full of its first item: the first frame is seen, and the first command applied, during
//! the latency too (an episode starts in steady state).

use std::collections::VecDeque;

use crate::SimError;

/// A delay of whole frames: what goes in comes out `delay` pushes later.
#[derive(Clone, Debug)]
pub struct DelayLine<T> {
    delay: usize,
    items: VecDeque<T>,
}

impl<T: Clone> DelayLine<T> {
    /// A line that delays by `delay` pushes (0: what goes in comes out at once).
    pub fn new(delay: usize) -> Self {
        DelayLine {
            delay,
            items: VecDeque::with_capacity(delay + 1),
        }
    }

    /// The delay in pushes.
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// Pushes `item` and returns the one pushed `delay` pushes earlier (the first item while the
    /// line fills).
    pub fn push(&mut self, item: T) -> &T {
        if self.items.is_empty() {
            self.items.extend(std::iter::repeat_n(item.clone(), self.delay));
        }
        self.items.push_back(item);
        while self.items.len() > self.delay + 1 {
            self.items.pop_front();
        }
        self.front()
    }

    /// The item that comes out now (`None` before the first push).
    pub fn front_opt(&self) -> Option<&T> {
        self.items.front()
    }

    fn front(&self) -> &T {
        self.items.front().expect("a pushed line is never empty")
    }

    /// The item `i` places behind the front (0: the front).
    pub fn get(&self, i: usize) -> Option<&T> {
        self.items.get(i)
    }

    /// The item pushed last.
    pub fn back(&self) -> Option<&T> {
        self.items.back()
    }
}

/// The largest latency accepted (s).
pub const MAX_LATENCY_S: f64 = 1.0;

/// A latency in whole frames of `period_s`: `round(latency_s / period_s)`; `key` names it in errors.
pub fn latency_frames(key: &str, latency_s: f32, period_s: f64) -> Result<usize, SimError> {
    let l = f64::from(latency_s);
    if !(l.is_finite() && (0.0..=MAX_LATENCY_S).contains(&l)) {
        return Err(SimError::invalid(
            key,
            latency_s,
            format!("must be in [0, {MAX_LATENCY_S}] seconds (quantised to camera frames)"),
        ));
    }
    Ok((l / period_s).round() as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_delays_by_its_length_and_starts_full_of_its_first_item() {
        let mut line = DelayLine::new(2);
        let out: Vec<i32> = (1..=5).map(|i| *line.push(i)).collect();
        assert_eq!(out, vec![1, 1, 1, 2, 3]);
        let mut none = DelayLine::new(0);
        assert_eq!(*none.push(7), 7);
        assert_eq!(*none.push(8), 8);
    }

    #[test]
    fn latencies_are_quantised_to_frames_and_checked() {
        assert_eq!(latency_frames("k", 0.025, 1.0 / 120.0).unwrap(), 3);
        assert_eq!(latency_frames("k", 0.010, 1.0 / 120.0).unwrap(), 1);
        assert_eq!(latency_frames("k", 0.0, 1.0 / 120.0).unwrap(), 0);
        let e = latency_frames("world.robot.actuation_latency_s", -1.0, 0.01).unwrap_err();
        assert!(e.to_string().contains("world.robot.actuation_latency_s"));
        assert!(latency_frames("k", f32::NAN, 0.01).is_err());
    }
}
