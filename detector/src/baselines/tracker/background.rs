//! The standing camera's background model: cleaning the object's region, and following the scene.

use super::region::{Blob, ring_of};
use super::{FROZEN_BACKGROUND_SLOWDOWN, Tracker};

impl Tracker {
    /// A standing camera's object region `blob` without the background it uncovered: the model
    /// may hold the object where it was (an object in view from the first frame, or one that stood
    /// still for a while). With `b` the median of the model just outside the region's box, a
    /// changed pixel shows the object now when the frame differs more from `b` than the model
    /// does; otherwise it shows background again: the model takes its current value and it leaves
    /// the region.
    pub(super) fn refine_standing(&mut self, frame: &[f32], n: usize, blob: Blob, starting: bool) -> Blob {
        let l = self.config.link_px;
        let [i0, i1, j0, j1] = blob.bbox;
        let (i0, i1, j0, j1) = (i0.saturating_sub(l), (i1 + l).min(n - 1), j0.saturating_sub(l), (j1 + l).min(n - 1));
        let mut ring = Vec::new();
        ring_of(&self.background, n, [i0, i1, j0, j1], &mut ring);
        if ring.is_empty() {
            return blob;
        }
        let mid = ring.len() / 2;
        let b = *ring.select_nth_unstable_by(mid, f32::total_cmp).1;
        let thr = self.config.threshold as f32;
        let (mut i0, mut i1, mut j0, mut j1) = (i0, i1, j0, j1);
        if starting {
            // a new track: the model may hold the object where it stood (an object in view from
            // the first frame). That imprint — the pixels of the model connected to the region
            // that differ from the median `b` around it — takes the value `b` when the model
            // around the imprint is uniform (at least three quarters of the ring around its box
            // within half the threshold of `b`): a uniform background hides nothing behind it.
            self.filled.fill(false);
            self.stack.clear();
            let mut imprint = Vec::new();
            for i in i0..=i1 {
                for j in j0..=j1 {
                    let p = i * n + j;
                    if (self.background[p] - b).abs() > thr {
                        self.filled[p] = true;
                        self.stack.push(p);
                    }
                }
            }
            let limit = n * n / 4;
            let mut bbox = [i0, i1, j0, j1];
            while let Some(p) = self.stack.pop() {
                if imprint.len() > limit {
                    break;
                }
                imprint.push(p);
                let (i, j) = (p / n, p % n);
                bbox = [bbox[0].min(i), bbox[1].max(i), bbox[2].min(j), bbox[3].max(j)];
                let neighbours = [
                    (i > 0).then(|| p - n),
                    (i + 1 < n).then(|| p + n),
                    (j > 0).then(|| p - 1),
                    (j + 1 < n).then(|| p + 1),
                ];
                for q in neighbours.into_iter().flatten() {
                    if !self.filled[q] && (self.background[q] - b).abs() > thr {
                        self.filled[q] = true;
                        self.stack.push(q);
                    }
                }
            }
            ring_of(&self.background, n, bbox, &mut ring);
            let uniform = imprint.len() <= limit
                && !ring.is_empty()
                && ring.iter().filter(|&&v| (v - b).abs() <= thr / 2.0).count() * 4 >= ring.len() * 3;
            if uniform {
                for &p in &imprint {
                    self.background[p] = b;
                    let r = frame[p] - b;
                    self.residual[p] = r;
                    self.mask[p] = if r.abs() > thr { r.abs() } else { 0.0 };
                }
                [i0, i1, j0, j1] = bbox;
            }
        }
        let mut kept: Option<Blob> = None;
        for i in i0..=i1 {
            for j in j0..=j1 {
                let p = i * n + j;
                let m = self.mask[p];
                if m == 0.0 {
                    continue;
                }
                // the object is where the frame, not the model, differs more from the background
                let model = frame[p] - self.residual[p];
                if (frame[p] - b).abs() <= (model - b).abs() {
                    self.background[p] = frame[p];
                    self.mask[p] = 0.0;
                    continue;
                }
                let one = Blob::pixel(i, j, f64::from(m));
                match kept.as_mut() {
                    Some(k) => k.merge(&one),
                    None => kept = Some(one),
                }
            }
        }
        kept.unwrap_or(blob)
    }

    /// Moves the standing camera's background model towards `frame`: by `1/background_frames` of
    /// the difference outside the tracked object's box grown by a quarter of its size (at least
    /// `link_px`), [`FROZEN_BACKGROUND_SLOWDOWN`] times less inside it.
    pub(super) fn update_background(&mut self, frame: &[f32], n: usize) {
        let rate = 1.0 / self.config.background_frames as f32;
        let slow = rate / FROZEN_BACKGROUND_SLOWDOWN;
        let frozen = self.track.as_ref().map(|t| {
            let [i0, i1, j0, j1] = t.bbox;
            let m = self.track_margin(t.bbox);
            [i0.saturating_sub(m), (i1 + m).min(n - 1), j0.saturating_sub(m), (j1 + m).min(n - 1)]
        });
        for (i, (brow, frow)) in self.background.chunks_exact_mut(n).zip(frame.chunks_exact(n)).enumerate() {
            match frozen {
                Some([i0, i1, j0, j1]) if (i0..=i1).contains(&i) => {
                    for (j, (b, &f)) in brow.iter_mut().zip(frow).enumerate() {
                        let k = if (j0..=j1).contains(&j) { slow } else { rate };
                        *b += (f - *b) * k;
                    }
                }
                _ => {
                    for (b, &f) in brow.iter_mut().zip(frow) {
                        *b += (f - *b) * rate;
                    }
                }
            }
        }
    }
}
