//! Stage 2's memory of one object's motion in the world (a decider bound to one object,
//! [`super::Decider::for_one_object`]).
//!
//! The image cannot tell an object that stands in the world from one that flies straight at the
//! robot along its heading: both expand radially about the heading, and the second is only larger,
//! farther and faster. The gate takes the first reading when the edges expand so (the closing speed
//! is then the robot's own and its metres exact), which makes a ball thrown along the robot's
//! heading look small and close and predicts it to arrive on the robot's path: a false alarm for
//! a ball that passes beside.
//!
//! An object seen before it moved tells them apart: while it stood, the robot's own speed gave its
//! distance; a standing object can come no nearer afterwards than the robot drove. When it arrives
//! at less than [`MOVED_DISTANCE_FRACTION`] of that distance it has moved in the world (a ball
//! leaving the thrower's hand), and from then on the gate never reads it as standing again. At that
//! moment the decider also forgets its window: the frames before show another course and predict
//! nothing of this one (fitted across the launch, they put the ball's arrival anywhere for a few
//! frames, and a ball thrown at τ below the threshold alarmed on them at once).
//!
//! While it stood, its distance also gave its size: its height in metres (the distance times its
//! vertical extent in the image, `tan top − tan bottom`, which no turn of the object changes). Once
//! it moves, that height gives its distance in every frame, and the rate at which that distance
//! falls its closing speed: the gate scales the image with the measured speed instead of the assumed one
//! ([`CourseForecast::closing_measured`](super::CourseForecast::closing_measured)), and the planner
//! needs no other hypothesis. An object that moves from the first frame it is seen keeps the
//! ambiguity: the assumed closing speed scales it.

/// The fraction of the distance a standing object would now be at (the distance it stood at, less
/// the robot's travel since) below which the object has approached on its own: it moves in the world.
/// A half leaves room for the robot's own speed changing during the window.
pub const MOVED_DISTANCE_FRACTION: f64 = 0.5;

/// Relative tolerance within which a standing reading agrees with where the object stood before
/// (its distance then less the robot's travel since): only such a reading corrects the remembered
/// distance, by [`STANDING_CORRECTION`] of the difference. One in between, as the gate's window
/// slides over the moment the object starts to move, neither corrects it nor marks the object as
/// moving; nor can a drift of readings within the tolerance, frame after frame, carry it along.
pub const STANDING_AGREEMENT: f64 = 0.2;

/// The fraction of an agreeing reading's difference from the remembered distance that corrects it.
pub const STANDING_CORRECTION: f64 = 0.1;

/// What a decider bound to one object remembers of its motion in the world.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct WorldMotionMemory {
    /// The time (s) and distance (m) at which the object was last seen standing.
    standing_at: Option<(f64, f64)>,
    /// Whether it has been seen to approach faster than the robot drove.
    moved: bool,
    /// Its height (m), measured while it stood.
    height_m: Option<f64>,
}

impl WorldMotionMemory {
    /// The least time to contact a standing object can have at `t_s`, for a robot now driving
    /// forwards at `forward_mps` (infinite once the object was seen to move; `None` when it was
    /// never seen standing or the robot does not drive forwards).
    pub(super) fn min_standing_tau_s(&self, t_s: f64, forward_mps: f64) -> Option<f64> {
        if self.moved {
            return Some(f64::INFINITY);
        }
        let (t0, d0) = self.standing_at?;
        (forward_mps > 0.0)
            .then(|| MOVED_DISTANCE_FRACTION * (d0 - forward_mps * (t_s - t0).max(0.0)).max(0.0) / forward_mps)
    }

    /// Whether the object was seen to move in the world.
    pub(super) fn moved(&self) -> bool {
        self.moved
    }

    /// The object's height (m), when it was measured while it stood.
    pub(super) fn height_m(&self) -> Option<f64> {
        self.height_m
    }

    /// Record the gate's reading at `t_s` for a robot driving forwards at `forward_mps`: the object
    /// stood (`Some`: its distance in metres and its vertical extent `tan top − tan bottom` then),
    /// or `moved` (it came nearer than a standing object could).
    pub(super) fn record(&mut self, t_s: f64, forward_mps: f64, standing: Option<(f64, f64)>, moved: bool) {
        if moved {
            self.moved = true;
            self.standing_at = None;
            return;
        }
        let Some((d, extent_tan)) = standing.filter(|_| !self.moved) else {
            return;
        };
        let distance = match self.standing_at {
            Some((t0, d0)) => {
                let expected = d0 - forward_mps * (t_s - t0).max(0.0);
                if (d - expected).abs() > STANDING_AGREEMENT * expected.abs() {
                    return;
                }
                expected + STANDING_CORRECTION * (d - expected)
            }
            None => d,
        };
        self.standing_at = Some((t_s, distance));
        self.height_m = Some(distance * extent_tan).filter(|h| h.is_finite() && *h > 0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_standing_object_may_come_as_near_as_the_robot_drove() {
        let mut m = WorldMotionMemory::default();
        assert_eq!(m.min_standing_tau_s(0.0, 1.0), None, "never seen standing");
        m.record(0.0, 1.0, Some((12.0, 0.05)), false);
        assert!((m.height_m().unwrap() - 0.6).abs() < 1e-12, "12 m × 0.05");
        // 0.5 s later at 1 m/s it stands 11.5 m away: τ 11.5 s; anything above half of it passes
        let least = m.min_standing_tau_s(0.5, 1.0).unwrap();
        assert!((least - 5.75).abs() < 1e-12, "{least}");
        assert_eq!(
            m.min_standing_tau_s(0.5, 0.0),
            None,
            "a robot standing still measures nothing"
        );
        // a reading between agreement and half (the window sliding over a launch) keeps the anchor
        m.record(0.5, 1.0, Some((8.0, 0.075)), false);
        assert!((m.min_standing_tau_s(0.5, 1.0).unwrap() - 5.75).abs() < 1e-12);
        // one that agrees corrects it by a tenth: 11.0 expected, 11.2 read
        m.record(1.0, 1.0, Some((11.2, 0.05)), false);
        assert!((m.min_standing_tau_s(1.0, 1.0).unwrap() - 0.5 * 11.02).abs() < 1e-12);
        m.record(1.1, 1.0, None, true);
        assert_eq!(
            m.min_standing_tau_s(1.1, 1.0),
            Some(f64::INFINITY),
            "once moved, always moving"
        );
        m.record(1.2, 1.0, Some((3.0, 0.2)), false);
        assert_eq!(m.min_standing_tau_s(1.3, 1.0), Some(f64::INFINITY));
        assert!(
            (m.height_m().unwrap() - 11.02 * 0.05).abs() < 1e-12,
            "the height measured while it stood stays"
        );
    }
}
