//! Keil's lowpass operator `LP[x, α]` (paper Eq. `EqLowpass`; docs/detectors.md, common §3).

/// Scalar leaky integrator `out(t+1) = α·out(t) + (1−α)·in(t)` (paper Eq. `EqLowpass`).
///
/// Convention of docs/detectors.md, common §3: the state starts at 0 and each call of
/// [`LowPass::update`] first updates, then returns the updated value, so Keil's
/// `out(t+1)` is reported at frame `t` (no extra frame of latency).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LowPass {
    alpha: f64,
    state: f64,
}

impl LowPass {
    /// A lowpass with memory coefficient `alpha` (0 ≤ α < 1; α = 0 passes the input through).
    pub fn new(alpha: f64) -> Self {
        Self { alpha, state: 0.0 }
    }

    /// Feeds `input` and returns the updated output `α·out + (1−α)·input`.
    pub fn update(&mut self, input: f64) -> f64 {
        self.state = self.alpha * self.state + (1.0 - self.alpha) * input;
        self.state
    }

    /// The current output (0 before the first update).
    pub fn value(&self) -> f64 {
        self.state
    }

    /// The memory coefficient α.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// Sets the output back to 0.
    pub fn reset(&mut self) {
        self.state = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn update_then_read() {
        let mut lp = LowPass::new(0.75);
        assert_eq!(lp.value(), 0.0);
        assert_eq!(lp.update(1.0), 0.25);
        assert_eq!(lp.update(1.0), 0.4375);
        assert_eq!(lp.value(), 0.4375);
        lp.reset();
        assert_eq!(lp.value(), 0.0);
        assert_eq!(LowPass::new(0.0).update(3.0), 3.0);
    }
}
