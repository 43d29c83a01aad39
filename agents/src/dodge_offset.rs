//! How far the robot's dodges have taken it off its cruising path, as the robot knows it: the
//! lateral speeds it commanded beyond the cruise's, through its drive's acceleration limit.
//!
//! A corridor or a lane (`max_dodge_offset_m`) bounds where the **body** may go, and a body that
//! sidesteps at 1.5 m/s runs on about 0.45 m after its sidestep command ends (braking at
//! 2.5 m/s²). So a sidestep is held once the body, braking from now, would come to rest at the
//! limit ([`DodgeOffset::stopping_offset_m`]), not once the commands alone add up to it.

/// The body's lateral offset from its cruising path and its lateral speed beyond the cruise's
/// (left positive), modelled from the commands (what the robot knows of itself).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DodgeOffset {
    /// Offset from the cruising path (m, + left).
    pub offset_m: f64,
    /// Lateral speed beyond the cruise's (m/s, + left).
    pub velocity_mps: f64,
}

impl DodgeOffset {
    /// Advance by `dt_s` under a commanded lateral speed beyond the cruise's `commanded_mps`,
    /// the body's speed following it at most `accel_mps2` (the drive's limit, as
    /// [`crate::planner::Odometry::advance`] models it).
    pub fn advance(&mut self, commanded_mps: f64, dt_s: f64, accel_mps2: f64) {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return;
        }
        let step = accel_mps2 * dt_s;
        let before = self.velocity_mps;
        let change = commanded_mps - before;
        self.velocity_mps = if change.abs() <= step {
            commanded_mps
        } else {
            before + step * change.signum()
        };
        self.offset_m += (before + self.velocity_mps) / 2.0 * dt_s;
    }

    /// Where the body comes to rest if it brakes from now at `accel_mps2` (m, + left).
    pub fn stopping_offset_m(&self, accel_mps2: f64) -> f64 {
        let v = self.velocity_mps;
        if accel_mps2 > 0.0 {
            self.offset_m + v * v.abs() / (2.0 * accel_mps2)
        } else {
            self.offset_m
        }
    }

    /// Whether a sidestep at `lateral_mps` beyond the cruise's is to be held within `limit_m` of
    /// the cruising path: it leads further out, and the body braking from now would come to rest
    /// at the limit or beyond it. A sidestep back towards the path is never held.
    pub fn holds(&self, lateral_mps: f64, limit_m: f64, accel_mps2: f64) -> bool {
        lateral_mps != 0.0 && lateral_mps.signum() * self.stopping_offset_m(accel_mps2) >= limit_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_body_follows_the_command_through_the_acceleration_limit_and_its_stopping_point_is_exact() {
        let mut d = DodgeOffset::default();
        let dt = 0.001;
        for _ in 0..600 {
            d.advance(1.5, dt, 2.5);
        }
        // 0.6 s at 2.5 m/s²: 1.5 m/s, 0.45 m
        assert!(
            (d.velocity_mps - 1.5).abs() < 1e-9 && (d.offset_m - 0.45).abs() < 1e-6,
            "{d:?}"
        );
        let predicted = d.stopping_offset_m(2.5);
        assert!((predicted - 0.9).abs() < 1e-6, "{predicted}");
        while d.velocity_mps > 0.0 {
            d.advance(0.0, dt, 2.5);
        }
        assert!((d.offset_m - predicted).abs() < 1e-6, "{d:?} {predicted}");
        // held further out, never back
        assert!(d.holds(1.5, 0.85, 2.5) && !d.holds(-1.5, 0.85, 2.5) && !d.holds(1.5, 0.95, 2.5));
    }
}
