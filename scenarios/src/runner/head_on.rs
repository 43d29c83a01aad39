//! The l/|v| of a threat approaching head-on at constant speed, measured from ground truth.

use loomlab_sim::ObjectTruth;

/// A threat approaching head-on at constant speed (see [`crate::lv`]), measured from ground truth
/// before contact.
#[derive(Debug, Clone)]
pub(super) struct HeadOnApproach {
    /// Half-size over closing speed (s), averaged over the window.
    pub(super) l_over_v_s: f64,
    /// The first open-loop frame from which the approach stays head-on at constant speed until
    /// the window's end: alarms before it are not on a constant approach and stay out of the fit.
    pub(super) constant_from: usize,
    /// Per open-loop frame: distance to the object's centre over its closing speed (s).
    eye_ttc_s: Vec<Option<f64>>,
}

impl HeadOnApproach {
    /// The window before contact over which the approach must be head-on at constant speed (s):
    /// short enough for fast projectiles (launched only ~1 s before contact) to qualify. An
    /// earlier alarm counts only if the approach is constant from the alarm on.
    const WINDOW_S: f64 = 0.5;
    /// The end of the window before contact (s): in the last frames the object's centre passes
    /// the camera off-axis (it is aimed at the body) and the distance stops shrinking at the
    /// closing speed.
    const WINDOW_END_S: f64 = 0.05;
    /// Largest relative spread of the half-size and closing speed over the window.
    const MAX_SPREAD: f64 = 0.05;
    /// Largest |bearing| over the window (degrees).
    const MAX_BEARING_DEG: f64 = 15.0;

    pub(super) fn measure(truth: &[Vec<ObjectTruth>], id: usize, contact_frame: usize, dt: f64) -> Option<Self> {
        let get = |k: usize| truth.get(k).and_then(|row| row.get(id));
        let distance = |k: usize| get(k).map(|o| f64::from(o.center_distance_m));
        let last = contact_frame.min(truth.len().checked_sub(1)?);
        let closing = |k: usize| -> Option<f64> {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(last));
            if b <= a {
                return None;
            }
            Some((distance(a)? - distance(b)?) / ((b - a) as f64 * dt))
        };
        // the window before contact, ending WINDOW_END_S before it
        let frames = |s: f64| (s / dt).round() as usize;
        let end = last.saturating_sub(frames(Self::WINDOW_END_S).max(1));
        let first = last.saturating_sub(frames(Self::WINDOW_S).max(2));
        if end < first + 2 {
            return None;
        }
        // grow the constant stretch backwards from the window's end while the half-size and
        // closing speed stay within MAX_SPREAD of their running means and the bearing on axis
        let (mut half, mut speed) = (Spread::default(), Spread::default());
        let mut constant_from = end;
        for k in (0..end).rev() {
            let Some(o) = get(k) else { break };
            let Some(v) = closing(k) else { break };
            if f64::from(o.bearing_deg).abs() > Self::MAX_BEARING_DEG {
                break;
            }
            let l = f64::from(o.center_distance_m) * (f64::from(o.angular_size_deg).to_radians() / 2.0).sin();
            let (h, s) = (half.with(l), speed.with(v));
            let within = |x: &Spread| x.relative().is_some_and(|r| r <= Self::MAX_SPREAD);
            if !within(&h) || !within(&s) {
                break;
            }
            (half, speed) = (h, s);
            constant_from = k;
        }
        if constant_from > first {
            return None;
        }
        // l/|v| from the fixed window, so that it does not depend on how far back the stretch goes
        let mean = |f: &dyn Fn(usize) -> Option<f64>| -> Option<f64> {
            let v: Vec<f64> = (first..end).map(f).collect::<Option<_>>()?;
            Some(v.iter().sum::<f64>() / v.len() as f64)
        };
        let l = mean(&|k| {
            get(k).map(|o| f64::from(o.center_distance_m) * (f64::from(o.angular_size_deg).to_radians() / 2.0).sin())
        })?;
        let v = mean(&closing)?;
        let eye_ttc_s = (0..truth.len())
            .map(|k| {
                let v = closing(k)?;
                (v > 0.0).then(|| distance(k).map(|d| d / v)).flatten()
            })
            .collect();
        Some(Self {
            l_over_v_s: l / v,
            constant_from,
            eye_ttc_s,
        })
    }

    /// The eye TTC at an alarm in frame `k`; `None` before the constant stretch.
    pub(super) fn eye_ttc_s(&self, k: usize) -> Option<f64> {
        (k >= self.constant_from)
            .then(|| self.eye_ttc_s.get(k).copied().flatten())
            .flatten()
    }
}

/// Running minimum, maximum and sum of a series (for its relative spread).
#[derive(Debug, Clone, Copy)]
struct Spread {
    lo: f64,
    hi: f64,
    sum: f64,
    n: usize,
}

impl Default for Spread {
    fn default() -> Self {
        Self {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            sum: 0.0,
            n: 0,
        }
    }
}

impl Spread {
    fn with(self, x: f64) -> Self {
        Self {
            lo: self.lo.min(x),
            hi: self.hi.max(x),
            sum: self.sum + x,
            n: self.n + 1,
        }
    }

    /// (max − min) / mean; `None` when the mean is not positive or a value is not finite.
    fn relative(&self) -> Option<f64> {
        let mean = self.sum / self.n as f64;
        (mean > 0.0 && self.lo.is_finite() && self.hi.is_finite()).then(|| (self.hi - self.lo) / mean)
    }
}
