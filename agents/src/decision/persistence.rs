//! Stage 3, persistence (module docs, "Persistence"): K-of-M confirmation of the decision value.

use std::collections::VecDeque;

/// The last M values and the rule's K.
#[derive(Debug, Clone)]
pub(super) struct Persistence {
    /// K: how many of the last M values must reach a threshold.
    k: usize,
    /// M: the window (frames, at least K).
    m: usize,
    /// The last M values before this step.
    recent: VecDeque<f64>,
    /// Scratch space (the window's values that are numbers).
    ranked: Vec<f64>,
}

impl Persistence {
    /// K-of-M persistence (`k` < 1 counts as 1; M = `m`, at least K).
    pub(super) fn new(k: usize, m: usize) -> Self {
        Self {
            k: k.max(1),
            m,
            recent: VecDeque::with_capacity(m.clamp(1, 64)),
            ranked: Vec::new(),
        }
    }

    /// Forget the values (new episode).
    pub(super) fn clear(&mut self) {
        self.recent.clear();
    }

    /// K, and how many of the last M values (before this rule; M ≥ 2) are at or above `threshold`:
    /// the K-of-M count the rule confirms an alarm with (read-only; `None` with M ≤ 1, where the
    /// value is its own confirmation).
    pub(super) fn confirmations(&self, threshold: f64) -> Option<(usize, usize)> {
        (self.m > 1).then(|| (self.recent.iter().filter(|&&v| v >= threshold).count(), self.k))
    }

    /// The K-th largest of the last M values that are numbers (`idle` while fewer than K are);
    /// with M = K the smallest of the last K values (`idle` while fewer have been seen, or when
    /// one is NaN). With M ≤ 1, `value` itself.
    pub(super) fn apply(&mut self, value: f64, idle: f64) -> f64 {
        let (k, m) = (self.k, self.m);
        if m <= 1 {
            return value;
        }
        if self.recent.len() == m {
            self.recent.pop_front();
        }
        self.recent.push_back(value);
        self.ranked.clear();
        self.ranked.extend(self.recent.iter().copied().filter(|v| !v.is_nan()));
        if self.ranked.len() < k {
            return idle;
        }
        // the K-th largest: index K − 1 in descending order
        let (_, kth, _) = self.ranked.select_nth_unstable_by(k - 1, |a, b| b.total_cmp(a));
        *kth
    }
}
