//! A small process-wide cache for what a detector computes from its configuration alone when it is
//! built (the Hopfield model's region-of-interest mask and template bank). The scenario runner
//! builds a fresh detector for every episode and every closed-loop tail; these values are the same
//! each time, so they are computed once and shared (bit for bit the values a fresh computation
//! gives). Bounded: at most [`Memo::CAPACITY`] entries per cache, the oldest dropped first.

use std::sync::{Arc, Mutex};

/// A bounded cache from keys to shared values.
pub(crate) struct Memo<K, V> {
    entries: Mutex<Vec<(K, Arc<V>)>>,
}

impl<K: PartialEq, V> Memo<K, V> {
    /// Entries kept per cache (distinct configurations in use at once; a sweep over more simply
    /// recomputes).
    pub(crate) const CAPACITY: usize = 16;

    pub(crate) const fn new() -> Self {
        Self {
            entries: Mutex::new(Vec::new()),
        }
    }

    /// The value for `key`, computed by `make` (outside the lock) when it is not cached.
    pub(crate) fn get_or_try_insert<E>(&self, key: K, make: impl FnOnce() -> Result<V, E>) -> Result<Arc<V>, E> {
        if let Some(v) = self.lock().iter().find(|(k, _)| *k == key).map(|(_, v)| v.clone()) {
            return Ok(v);
        }
        let value = Arc::new(make()?);
        let mut entries = self.lock();
        if !entries.iter().any(|(k, _)| *k == key) {
            if entries.len() >= Self::CAPACITY {
                entries.remove(0);
            }
            entries.push((key, value.clone()));
        }
        Ok(value)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<(K, Arc<V>)>> {
        // a panic while holding the lock cannot leave the list inconsistent (push/remove only)
        self.entries.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_is_computed_once_per_key_and_the_cache_stays_bounded() {
        let memo: Memo<usize, usize> = Memo::new();
        let mut calls = 0;
        for round in 0..2 {
            for key in 0..3 {
                let v = memo
                    .get_or_try_insert(key, || {
                        calls += 1;
                        Ok::<_, ()>(key * 10)
                    })
                    .unwrap();
                assert_eq!(*v, key * 10, "round {round}");
            }
        }
        assert_eq!(calls, 3, "the second round is served from the cache");
        for key in 0..100 {
            memo.get_or_try_insert(key, || Ok::<_, ()>(key)).unwrap();
        }
        assert_eq!(memo.lock().len(), Memo::<usize, usize>::CAPACITY);
        assert!(
            memo.get_or_try_insert(7, || Err("boom")).is_err(),
            "evicted keys are computed again"
        );
    }
}
