//! Several objects at once (module docs, step 6): the tracks beside the primary one — assignment
//! of this frame's regions to them with gating, their births, confirmation and ends — and the list
//! of every confirmed track ([`Signals::objects`](crate::Signals::objects)).

use std::collections::VecDeque;

use super::fit::{BoxSample, fit_box};
use super::region::{Blob, ring_of};
use super::{FIT_SPAN, Tracker};
use crate::PerceivedObject;
use crate::compensation::{IDENTITY, Mat3, mul};

/// The most tracks the tracker holds at once, the primary one included: a region that finds no
/// free place starts no track (the heaviest regions come first), so the work per frame and the
/// list of objects stay bounded whatever the scene.
pub const MAX_TRACKS: usize = 8;

/// A confirmed track beside the primary one whose predicted box overlaps another track's box (the
/// two objects' images touch or one hides the other, and their regions merged) survives this many
/// times `hold_frames` frames without a region of its own, on its fitted motion: two objects
/// crossing in the image stay merged for longer than a gap in one object's region lasts.
pub const MERGED_HOLD_FACTOR: usize = 4;

/// What the other tracks' step reads of this frame.
struct Scene<'a> {
    frame: &'a [f32],
    n: usize,
    standing: bool,
    /// The other tracks' background model (`Others::background`; empty for a moving camera).
    background: &'a [f32],
}

/// One track beside the primary one: its region, its fit (the primary track's kind, with its own
/// samples and frame count) and its life.
#[derive(Debug, Clone)]
pub(super) struct Track {
    /// Its number ([`ImageRegion::track`](crate::ImageRegion::track)).
    pub(super) id: usize,
    /// Its last region (the last measured one while it holds).
    blob: Blob,
    /// Its measurements ([`BoxSample`]), at most `FIT_SPAN · fit_frames`.
    samples: VecDeque<BoxSample>,
    /// Frames since its fit started.
    clock: usize,
    /// Its fitted box `[top, bottom, left, right]` (pixels, sub-pixel) in the current frame.
    edges: [f64; 4],
    /// How the fitted box's edges moved in the last frame (pixels per frame): its predicted box in
    /// the next frame is `edges + motion`.
    motion: [f64; 4],
    /// Frames it has lasted.
    age: usize,
    /// Frames since its last region.
    missed: usize,
    /// The camera's rotation since its fit started (the primary track's `turn`).
    turn: Mat3,
    /// Whether it has lasted `confirm_frames` (then it is listed; a tentative track ends at its
    /// first frame without a region).
    pub(super) confirmed: bool,
}

/// The tracks beside the primary one and the working memory of their assignment, kept between
/// frames (no allocation per frame once the buffers have grown).
#[derive(Debug, Clone, Default)]
pub(super) struct Others {
    tracks: Vec<Track>,
    /// Candidate (cost, track, region) pairs of the assignment.
    pairs: Vec<(f64, usize, usize)>,
    /// Per region of this frame: whether no track has taken it yet.
    free: Vec<bool>,
    /// Per track: the region assigned to it this frame.
    assigned: Vec<Option<Blob>>,
    /// The background model's values around a region ([`Tracker::measure_standing`]).
    ring: Vec<f32>,
    /// A standing camera's background model for these tracks (n·n; empty for a moving camera):
    /// the primary track's model while there are no other tracks, then followed like it but
    /// frozen in every track's box ([`Tracker::update_others_background`]), so that an object
    /// tracked here does not fade into it (the primary track's model is frozen in its box only).
    background: Vec<f32>,
    /// Per pixel: whether it lies in a track's grown box (the model's update, scratch).
    frozen: Vec<bool>,
    /// The sample buffers of ended tracks, reused by new ones (at most [`MAX_TRACKS`]).
    spare: Vec<VecDeque<BoxSample>>,
}

impl Others {
    /// Forgets every track (a reset).
    pub(super) fn clear(&mut self) {
        self.tracks.clear();
        self.background.clear();
    }

    /// Composes each track's camera rotation with the camera's `rotation` in this frame.
    pub(super) fn turn(&mut self, rotation: &Mat3) {
        for t in &mut self.tracks {
            t.turn = mul(&t.turn, rotation);
        }
    }
}

/// The inclusive pixel box `[i0, i1, j0, j1]` covering the sub-pixel box `[top, bottom, left,
/// right]` inside an n × n image (at least one pixel).
fn pixel_box([top, bottom, left, right]: [f64; 4], n: usize) -> [usize; 4] {
    let last = (n - 1) as f64;
    let lo = |v: f64| v.floor().clamp(0.0, last) as usize;
    let hi = |v: f64, low: usize| ((v.ceil() - 1.0).clamp(0.0, last) as usize).max(low);
    let (i0, j0) = (lo(top), lo(left));
    [i0, hi(bottom, i0), j0, hi(right, j0)]
}

/// Whether pixel boxes `a` and `b` (inclusive) overlap once `a` is grown by `margin` pixels.
fn boxes_overlap(a: [usize; 4], b: [usize; 4], margin: usize) -> bool {
    a[0] <= b[1] + margin && b[0] <= a[1] + margin && a[2] <= b[3] + margin && b[2] <= a[3] + margin
}

impl Tracker {
    /// The primary track's number for a region `b` it starts on: that of the other track whose
    /// last region or predicted box `b` overlaps (the oldest such; that track ends, the primary one continues it and
    /// is listed at once when it was confirmed), else a new number.
    pub(super) fn adopt(&mut self, b: &Blob) {
        let continued = (0..self.others.tracks.len())
            .filter(|&k| {
                let t = &self.others.tracks[k];
                let predicted = pixel_box(std::array::from_fn(|q| t.edges[q] + t.motion[q]), self.n.unwrap_or(1));
                b.overlaps(t.blob.bbox, 0) || b.overlaps(predicted, 0)
            })
            .max_by_key(|&k| (self.others.tracks[k].age, std::cmp::Reverse(k)));
        match continued {
            Some(k) => {
                let mut t = self.others.tracks.remove(k);
                t.samples.clear();
                self.others.spare.push(t.samples);
                self.primary_id = t.id;
                self.primary_inherited = t.confirmed;
            }
            None => {
                self.tracks += 1;
                self.primary_id = self.tracks;
                self.primary_inherited = false;
            }
        }
    }

    /// The primary track, ending because another region takes it over (`take_over`), lives on as
    /// one of the other tracks with its number, fit and age, when there is room.
    pub(super) fn hand_over_primary(&mut self) {
        let Some(blob) = self.track else { return };
        if self.others.tracks.len() + 1 >= MAX_TRACKS {
            return;
        }
        // the primary track's buffer goes with it; the primary track takes a spare one
        let mut samples = self.others.spare.pop().unwrap_or_default();
        std::mem::swap(&mut samples, &mut self.samples);
        let motion = std::array::from_fn(|q| self.edges[q] - self.previous_edges[q]);
        let confirmed = self.age >= self.config.confirm_frames || self.primary_inherited;
        self.others.tracks.push(Track {
            id: self.primary_id,
            blob,
            samples,
            clock: self.clock,
            edges: self.edges,
            motion,
            age: self.age,
            missed: self.missed,
            turn: self.turn,
            confirmed,
        });
    }

    /// The other tracks' step (module docs, step 6), after the primary track's: the regions not
    /// part of the primary track's region (`claimed`: its box) are assigned to the other tracks,
    /// cheapest first (greedy), each track's candidates gated by its predicted box grown by a
    /// quarter of its size (at least `link_px`) and by its validation gate, the cost being the
    /// distance of the region's box centre from the predicted one in units of its size. Each track
    /// is then measured and fitted, held or ended, and the regions left over start new tracks.
    pub(super) fn follow_others(&mut self, frame: &[f32], n: usize, standing: bool, claimed: Option<[usize; 4]>) {
        let mut others = std::mem::take(&mut self.others);
        let Others { tracks, pairs, free, assigned, ring, background, spare, .. } = &mut others;
        if !standing {
            background.clear();
        } else if background.len() != n * n {
            background.clear();
            background.extend_from_slice(&self.background);
        }
        let scene = Scene { frame, n, standing, background };
        free.clear();
        free.extend(self.blobs.iter().map(|b| !claimed.is_some_and(|c| b.overlaps(c, 0))));
        pairs.clear();
        for (k, t) in tracks.iter().enumerate() {
            let predicted = std::array::from_fn(|q| t.edges[q] + t.motion[q]);
            let bbox = pixel_box(predicted, n);
            let margin = self.track_margin(bbox);
            let (pi, pj) = ((predicted[0] + predicted[1]) / 2.0, (predicted[2] + predicted[3]) / 2.0);
            let size = ((predicted[1] - predicted[0]) * (predicted[3] - predicted[2])).abs().sqrt().max(1.0);
            for (r, b) in self.blobs.iter().enumerate() {
                if !free[r] || !b.overlaps(bbox, margin) || !self.size_gate(&t.samples, t.clock, b.bbox) {
                    continue;
                }
                let [i0, i1, j0, j1] = b.bbox;
                let (bi, bj) = ((i0 + i1 + 1) as f64 / 2.0, (j0 + j1 + 1) as f64 / 2.0);
                pairs.push((((bi - pi).powi(2) + (bj - pj).powi(2)).sqrt() / size, k, r));
            }
        }
        pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        assigned.clear();
        assigned.resize(tracks.len(), None);
        for &(_, k, r) in pairs.iter() {
            if assigned[k].is_none() && free[r] {
                free[r] = false;
                assigned[k] = Some(self.blobs[r]);
            }
        }
        // each region joined by the free regions touching it and, for a moving camera (whose
        // difference falls apart into where the object is and where it was), those overlapping
        // the track's predicted box
        for (k, t) in tracks.iter().enumerate() {
            let Some(region) = assigned[k].as_mut() else { continue };
            let bbox = pixel_box(std::array::from_fn(|q| t.edges[q] + t.motion[q]), n);
            let margin = self.track_margin(bbox);
            for (r, b) in self.blobs.iter().enumerate() {
                if free[r] && (b.overlaps(region.bbox, self.config.link_px) || (!standing && b.overlaps(bbox, margin))) {
                    free[r] = false;
                    region.merge(b);
                }
            }
        }
        for k in 0..tracks.len() {
            let region = assigned[k].take();
            self.step_other(&mut tracks[k], region, &scene, ring);
        }
        self.end_others(tracks, spare);
        let mut next_id = self.tracks;
        self.start_others(&mut next_id, tracks, free, &scene, ring, spare);
        self.tracks = next_id;
        self.others = others;
    }

    /// Track `t`'s measurement of `region` (None: it holds on its fit) and its fit in this frame.
    fn step_other(&self, t: &mut Track, region: Option<Blob>, scene: &Scene, ring: &mut Vec<f32>) {
        let n = scene.n;
        // a standing camera's object is measured in the window of its region and its predicted box
        let window = region.map(|b| {
            let predicted = pixel_box(std::array::from_fn(|q| t.edges[q] + t.motion[q]), n);
            if scene.standing { super::region::box_union(b.bbox, predicted) } else { b.bbox }
        });
        // a standing camera's region that is all uncovered background is no measurement
        match region.zip(window).and_then(|(b, w)| self.measure_other(b, w, t.clock, scene, ring)) {
            Some((b, sample)) => {
                // a track switching between the object's image and the difference's boxes starts
                // its fit afresh (the primary track's rule)
                if t.samples.back().is_some_and(|s| s.current != sample.current) {
                    t.samples.clear();
                    t.clock = 0;
                    t.turn = IDENTITY;
                }
                if t.samples.len() >= FIT_SPAN * self.config.fit_frames {
                    t.samples.pop_front();
                }
                t.samples.push_back(self.stabilise_by(&t.turn, sample, n));
                t.blob = b;
                t.missed = 0;
            }
            None => t.missed += 1,
        }
        t.age += 1;
        t.confirmed |= t.age >= self.config.confirm_frames;
        let baseline = if self.moving { self.config.baseline_frames as f64 } else { 0.0 };
        let fitted = fit_box(&t.samples, t.clock, self.config.fit_frames as f64, n, baseline);
        let edges = self.destabilise_by(&t.turn, fitted, n);
        t.motion = std::array::from_fn(|q| edges[q] - t.edges[q]);
        t.edges = edges;
        t.clock += 1;
    }

    /// A region `b` of another track measured at frame `clock` of its fit: a moving camera's as
    /// it is, a standing camera's object found in `window` ([`Self::measure_standing`]; None when
    /// nothing of it is left: where an object was, or stood when the model started).
    fn measure_other(
        &self,
        b: Blob,
        window: [usize; 4],
        clock: usize,
        scene: &Scene,
        ring: &mut Vec<f32>,
    ) -> Option<(Blob, BoxSample)> {
        if !scene.standing {
            return Some((b, self.measure_at(&b, scene.n, clock, |p| self.mask[p] != 0.0)));
        }
        self.measure_standing(window, clock, scene, ring)
    }

    /// A standing camera's object of another track in `window` (grown by `link_px`), against the
    /// other tracks' background model `bg` (`Others::background`) and cleaned of the background it
    /// uncovered (the primary track's rule, `Tracker::refine_standing`, without changing a model):
    /// with `b` the median of the model just outside the window, a pixel is the object's when it
    /// differs from the model by more than the threshold and the frame differs more than the
    /// model from `b`. None when fewer than `standing_min_pixels` pixels are.
    fn measure_standing(&self, window: [usize; 4], clock: usize, scene: &Scene, ring: &mut Vec<f32>) -> Option<(Blob, BoxSample)> {
        let (n, frame, bg) = (scene.n, scene.frame, scene.background);
        let l = self.config.link_px;
        let [i0, i1, j0, j1] = window;
        let (i0, i1, j0, j1) = (i0.saturating_sub(l), (i1 + l).min(n - 1), j0.saturating_sub(l), (j1 + l).min(n - 1));
        ring_of(bg, n, [i0, i1, j0, j1], ring);
        if ring.is_empty() {
            return None;
        }
        let mid = ring.len() / 2;
        let b = *ring.select_nth_unstable_by(mid, f32::total_cmp).1;
        let thr = self.config.threshold as f32;
        let object = |p: usize| (frame[p] - bg[p]).abs() > thr && (frame[p] - b).abs() > (bg[p] - b).abs();
        let mut kept: Option<Blob> = None;
        for i in i0..=i1 {
            for j in j0..=j1 {
                let p = i * n + j;
                if !object(p) {
                    continue;
                }
                let one = Blob::pixel(i, j, f64::from((frame[p] - bg[p]).abs()));
                match kept.as_mut() {
                    Some(k) => k.merge(&one),
                    None => kept = Some(one),
                }
            }
        }
        let kept = kept.filter(|k| k.pixels >= self.config.standing_min_pixels)?;
        Some((kept, self.measure_at(&kept, n, clock, object)))
    }

    /// Moves the other tracks' background model (`Others::background`) towards a standing
    /// camera's `frame`: a copy of the primary track's model while there are no other tracks,
    /// else as the primary track's model moves (`Tracker::update_background`) but
    /// [`super::FROZEN_BACKGROUND_SLOWDOWN`] times more slowly inside every track's box grown by
    /// its margin.
    pub(super) fn update_others_background(&mut self, frame: &[f32], n: usize) {
        let mut others = std::mem::take(&mut self.others);
        self.freeze_and_follow(&mut others, frame, n);
        self.others = others;
    }

    /// [`Self::update_others_background`] on the other tracks taken out of the tracker.
    fn freeze_and_follow(&self, others: &mut Others, frame: &[f32], n: usize) {
        let Others { tracks, background, frozen, .. } = others;
        if tracks.is_empty() || background.len() != n * n {
            background.clear();
            background.extend_from_slice(&self.background);
            return;
        }
        let rate = 1.0 / self.config.background_frames as f32;
        let slow = rate / super::FROZEN_BACKGROUND_SLOWDOWN;
        frozen.clear();
        frozen.resize(n * n, false);
        for bbox in self.track.iter().map(|t| t.bbox).chain(tracks.iter().map(|t| t.blob.bbox)) {
            let m = self.track_margin(bbox);
            let (i0, i1, j0, j1) = (bbox[0].saturating_sub(m), (bbox[1] + m).min(n - 1), bbox[2].saturating_sub(m), (bbox[3] + m).min(n - 1));
            for i in i0..=i1 {
                frozen[i * n + j0..=i * n + j1].fill(true);
            }
        }
        for ((b, &f), &still) in background.iter_mut().zip(frame).zip(frozen.iter()) {
            *b += (f - *b) * if still { slow } else { rate };
        }
    }

    /// Ends the other tracks that have held too long: a tentative one at its first frame without a
    /// region, a confirmed one after `hold_frames` frames without one ([`MERGED_HOLD_FACTOR`] times
    /// that while its box overlaps the primary track's or another track's box).
    fn end_others(&self, tracks: &mut Vec<Track>, spare: &mut Vec<VecDeque<BoxSample>>) {
        let primary = self.track.map(|t| t.bbox);
        let hold = self.config.hold_frames;
        let mut k = 0;
        while k < tracks.len() {
            let t = &tracks[k];
            let keep = if t.missed == 0 {
                true
            } else if !t.confirmed {
                false
            } else {
                let bbox = t.blob.bbox;
                let merged = primary.is_some_and(|p| boxes_overlap(p, bbox, self.config.link_px))
                    || tracks
                        .iter()
                        .enumerate()
                        .any(|(q, o)| q != k && boxes_overlap(o.blob.bbox, bbox, self.config.link_px));
                t.missed <= if merged { MERGED_HOLD_FACTOR * hold } else { hold }
            };
            if keep {
                k += 1;
            } else {
                let mut ended = tracks.remove(k);
                ended.samples.clear();
                spare.push(ended.samples);
            }
        }
    }

    /// New tracks on the regions left free (heaviest first) while there is room ([`MAX_TRACKS`]),
    /// except regions overlapping the primary track's or another track's box grown by a quarter of
    /// its size (at least `link_px`) — parts of a tracked object's region — and a standing
    /// camera's regions that are all uncovered background ([`Self::measure_other`]).
    fn start_others(
        &self,
        next_id: &mut usize,
        tracks: &mut Vec<Track>,
        free: &mut [bool],
        scene: &Scene,
        ring: &mut Vec<f32>,
        spare: &mut Vec<VecDeque<BoxSample>>,
    ) {
        let n = scene.n;
        let near = |b: &Blob, tracks: &[Track]| {
            self.track.is_some_and(|t| b.overlaps(t.bbox, self.track_margin(t.bbox)))
                || tracks.iter().any(|t| b.overlaps(t.blob.bbox, self.track_margin(t.blob.bbox)))
        };
        while tracks.len() + 1 < MAX_TRACKS {
            let heaviest = (0..self.blobs.len())
                .filter(|&r| free[r] && !near(&self.blobs[r], tracks))
                .max_by(|&a, &b| self.blobs[a].mass.total_cmp(&self.blobs[b].mass).then(b.cmp(&a)));
            let Some(r) = heaviest else { break };
            free[r] = false;
            let b = self.blobs[r];
            let Some((blob, sample)) = self.measure_other(b, b.bbox, 0, scene, ring) else {
                continue;
            };
            let mut samples = spare
                .pop()
                .unwrap_or_else(|| VecDeque::with_capacity(FIT_SPAN * self.config.fit_frames));
            samples.push_back(sample);
            let baseline = if self.moving { self.config.baseline_frames as f64 } else { 0.0 };
            let edges = fit_box(&samples, 0, self.config.fit_frames as f64, n, baseline);
            *next_id += 1;
            tracks.push(Track {
                id: *next_id,
                blob,
                samples,
                clock: 1,
                edges,
                motion: [0.0; 4],
                age: 1,
                missed: 0,
                turn: IDENTITY,
                confirmed: self.config.confirm_frames <= 1,
            });
        }
    }

    /// Every confirmed track as a [`PerceivedObject`] (θ̂ from its fitted box, module docs step 5;
    /// no τ̂ of its own): `primary` (the primary track's region and θ̂, when it is reported) first,
    /// then the other tracks in the order they started.
    pub(super) fn objects(&self, n: usize, primary: Option<(crate::ImageRegion, f64)>) -> Vec<PerceivedObject> {
        let others = self.others.tracks.iter().filter(|t| t.confirmed);
        if primary.is_none() && others.clone().next().is_none() {
            return Vec::new();
        }
        let mut objects = Vec::with_capacity(MAX_TRACKS);
        let listed = primary.into_iter().chain(others.filter_map(|t| self.percept(&t.blob, t.edges, t.id, n)));
        objects.extend(listed.map(|(region, theta)| PerceivedObject {
            id: region.track.unwrap_or_default(),
            region,
            angular_size_deg: theta,
            tau_s: None,
        }));
        objects
    }
}
