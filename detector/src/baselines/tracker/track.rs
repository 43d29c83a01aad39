//! The track: which region is the object, the validation gate, and confirmation by appearance.

use std::collections::VecDeque;

use super::fit::{BoxSample, Lines};
use super::region::Blob;
use super::{
    APPEARANCE_CONFIRM_FRAMES, DIFFERENCE_MEMORY_DIVISOR, GATE_MIN_SAMPLES, GATE_SLACK_PX, TAKE_OVER_BESIDE_WIDTHS,
    TAKE_OVER_COURSE_WIDTHS, Tracker,
};

impl Tracker {
    /// How far around the tracked box `bbox` its object may be found next, and the model is
    /// frozen: a quarter of the box's size, at least `link_px` (pixels).
    pub(super) fn track_margin(&self, [i0, i1, j0, j1]: [usize; 4]) -> usize {
        ((i1 - i0).max(j1 - j0) / 4).max(self.config.link_px)
    }

    /// Chooses the tracked object among this frame's blobs (see the module docs, step 3): with a
    /// track, the heaviest region overlapping its grown box (None when none does), joined by the
    /// regions touching it and, for a moving camera, by every region overlapping that box; without
    /// one, the heaviest region.
    pub(super) fn choose(&self) -> Option<Blob> {
        let by_mass = |a: &&Blob, b: &&Blob| a.mass.total_cmp(&b.mass);
        let grown = self.track.as_ref().map(|t| (t.bbox, self.track_margin(t.bbox)));
        let mut chosen = *match grown {
            Some((bbox, margin)) => self.blobs.iter().filter(|b| b.overlaps(bbox, margin)).max_by(by_mass)?,
            None => self.blobs.iter().max_by(by_mass)?,
        };
        let first = chosen;
        let joins_track = |b: &Blob| self.moving && grown.is_some_and(|(bbox, margin)| b.overlaps(bbox, margin));
        for b in &self.blobs {
            if b.bbox != first.bbox && (b.overlaps(chosen.bbox, self.config.link_px) || joins_track(b)) {
                chosen.merge(b);
            }
        }
        Some(chosen)
    }

    /// The region that takes the track over (module docs, step 3), if any: while the tracked
    /// object's box lies more than [`TAKE_OVER_BESIDE_WIDTHS`] of its widths beside the image
    /// centre — on a straight course its lateral offset in widths stays the same as it nears, so it
    /// will pass beside the camera — the heaviest region that does not overlap the track's grown
    /// box and lies within [`TAKE_OVER_COURSE_WIDTHS`] of its own widths of the centre (on a
    /// collision course). A moving camera's residual of a pole beside the path held the single
    /// track while a ball thrown at the robot grew in the centre, never taken up.
    pub(super) fn take_over(&self, n: usize) -> Option<Blob> {
        let track = self.track.as_ref()?;
        // the box's lateral offset from the image centre in units of its width
        let beside = |[_, _, j0, j1]: [usize; 4]| {
            let centre = (j0 + j1 + 1) as f64 / 2.0 - n as f64 / 2.0;
            centre.abs() / (j1 - j0 + 1) as f64
        };
        if beside(track.bbox) <= TAKE_OVER_BESIDE_WIDTHS {
            return None;
        }
        let margin = self.track_margin(track.bbox);
        self.blobs
            .iter()
            .filter(|b| !b.overlaps(track.bbox, margin) && beside(b.bbox) <= TAKE_OVER_COURSE_WIDTHS)
            .max_by(|a, b| a.mass.total_cmp(&b.mass))
            .copied()
    }

    /// Whether region `b` passes the track's validation gate (module docs, step 3): its box's size
    /// (the square root of its area) within `size_gate_ratio` of the size predicted for this frame,
    /// give or take [`GATE_SLACK_PX`], once the track holds [`GATE_MIN_SAMPLES`] measurements
    /// (always, without a track). The prediction is the least-squares line through the measured
    /// boxes' sizes with the short memory of difference boxes (`fit_frames` /
    /// [`DIFFERENCE_MEMORY_DIVISOR`]): what the regions have been, not the fitted object box (a
    /// difference box's is cut to where the object is now).
    pub(super) fn passes_gate(&self, b: &Blob) -> bool {
        self.track.is_none() || self.size_gate(&self.samples, self.clock, b.bbox)
    }

    /// The validation gate of a track holding `samples` at frame `clock` of its fit, for a region
    /// of box `bbox` ([`Self::passes_gate`]; the tracks beside the primary one use it too): true
    /// while the track holds fewer than [`GATE_MIN_SAMPLES`] measurements.
    pub(super) fn size_gate(&self, samples: &VecDeque<BoxSample>, clock: usize, [i0, i1, j0, j1]: [usize; 4]) -> bool {
        if samples.len() < GATE_MIN_SAMPLES {
            return true;
        }
        let memory = self.config.fit_frames as f64 / DIFFERENCE_MEMORY_DIVISOR;
        let lines = Lines::fit(samples, clock as f64, memory, |s| {
            [(s.width * s.height).sqrt() / s.inverse_size, 0.0, 0.0, 0.0, 0.0]
        });
        let predicted = lines.at(0).max(1.0);
        let measured = (((i1 - i0 + 1) * (j1 - j0 + 1)) as f64).sqrt();
        let g = self.config.size_gate_ratio;
        measured <= g * predicted + GATE_SLACK_PX && measured >= predicted / g - GATE_SLACK_PX
    }

    /// Whether the track is reported before `confirm_frames`: a moving camera's track whose last
    /// [`APPEARANCE_CONFIRM_FRAMES`] measurements or more were all of the object's appearance (its
    /// fit starts afresh whenever the kind of measurement changes, so its samples are of one kind).
    pub(super) fn confirmed_by_appearance(&self) -> bool {
        self.moving
            && self.samples.len() >= APPEARANCE_CONFIRM_FRAMES
            && self.samples.back().is_some_and(|s| s.current)
    }
}
