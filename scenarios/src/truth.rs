//! Open-loop ground truth of an episode: is it a threat, when is the contact, which object is the
//! reference object. Computed once here for the runner and the Gymnasium environment alike.
//!
//! The open-loop pass runs the episode's world with the robot following its cruise command (no
//! escape). It ends at the first contact of any object with the robot's body or after the
//! episode's duration:
//! - a contact (one that is not [`Contact::harmless`]: see `world.harmless_impact_speed_mps`)
//!   makes the episode a **threat**; the contact time `t_contact_s` is
//!   [`Contact::time_s`] (the exact time of impact) and the touching object is the **reference
//!   object**;
//! - without contact the reference object is the moving object (projectile or vehicle; any
//!   object if there is none) that came closest to the camera.
//!
//! Per frame the reference object's true time to contact and angular size are what the scoring
//! reads at the alarm.

use loomlab_agents::{EscapeController, LoomingSideEstimator};
use loomlab_detector::Frame;
use loomlab_sim::{CapturedView, Contact, ObjectKind, Renderer, Sim, SimError, StepOutput};

use crate::deadline::{EscapeDeadline, escape_deadline_with};

use crate::schema::EpisodeSpec;

/// A collision of the robot: when, how fast and how hard (from a [`Contact`] that is not
/// harmless).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// Contact time (s, [`Contact::time_s`]).
    pub t_s: f64,
    /// Relative speed of the bodies when they touched (m/s, [`Contact::impact_speed_mps`]).
    pub impact_speed_mps: f64,
    /// Contact impulse (N·s, [`Contact::impulse_ns`]; `None` with analytic physics).
    pub impulse_ns: Option<f64>,
}

impl From<&Contact> for Impact {
    fn from(c: &Contact) -> Self {
        Impact {
            t_s: c.time_s(),
            impact_speed_mps: c.impact_speed_mps,
            impulse_ns: c.impulse_ns,
        }
    }
}

/// The first collision of the open-loop pass (harmless contacts do not count).
#[derive(Debug, Clone, PartialEq)]
pub struct FirstContact {
    /// Open-loop frame index (0-based: the k-th step's output) during which it happened.
    pub frame: usize,
    /// Contact time (s, [`Contact::time_s`]).
    pub t_s: f64,
    /// The touching object's id.
    pub object_id: usize,
    /// How fast and how hard.
    pub impact: Impact,
}

/// Open-loop ground truth (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeTruth {
    /// The first contact, if the episode is a threat.
    pub contact: Option<FirstContact>,
    /// The reference object's id.
    pub reference: Option<usize>,
    /// A non-threat whose last frame still has an object on a collision course with the robot:
    /// that object's name and its predicted time to contact after the episode's end (s). Such an
    /// episode is a threat cut short by `episode.duration_s`, not a non-threat: an alarm on it is
    /// right. The default suite has none (tested); lengthen the episode when a scenario does.
    pub cut_short: Option<(String, f64)>,
    /// The reference object's smallest distance from the camera to its surface over the open-loop
    /// pass (m; `None` without a reference object). A non-threat with `closest_m` at most
    /// [`NEAR_MISS_M`] is a **near miss**.
    pub closest_m: Option<f64>,
}

/// A non-threat is a **near miss** when its reference object's surface comes within this distance
/// of the camera (m): close enough that its image expands like a threat's, so only the
/// collision-course gate (the looming's position and drift) tells it apart.
pub const NEAR_MISS_M: f64 = 1.5;

impl EpisodeTruth {
    /// Whether the episode is a threat.
    pub fn threat(&self) -> bool {
        self.contact.is_some()
    }

    /// Whether the episode is a near miss: a non-threat whose reference object comes within
    /// [`NEAR_MISS_M`] of the camera.
    pub fn near_miss(&self) -> bool {
        !self.threat() && self.closest_m.is_some_and(|d| d <= NEAR_MISS_M)
    }

    /// The contact time of a threat (s).
    pub fn t_contact_s(&self) -> Option<f64> {
        self.contact.as_ref().map(|c| c.t_s)
    }

    /// The open-loop collision of a threat.
    pub fn impact(&self) -> Option<Impact> {
        self.contact.as_ref().map(|c| c.impact)
    }
}

/// Collects ground truth step by step during an open-loop pass.
#[derive(Debug, Clone)]
pub struct TruthRecorder {
    objects: Vec<(usize, String, ObjectKind)>,
    min_distance_m: Vec<f64>,
    frames: usize,
    contact: Option<FirstContact>,
    last_collision_course: Option<(usize, f64)>,
}

impl TruthRecorder {
    /// A recorder for the objects of `sim` ([`Sim::objects`]).
    pub fn new(sim: &Sim) -> Self {
        let objects = sim.objects();
        Self {
            min_distance_m: vec![f64::INFINITY; objects.len()],
            objects,
            frames: 0,
            contact: None,
            last_collision_course: None,
        }
    }

    /// Records one open-loop step; returns the first contact when this step made one (the pass
    /// ends there).
    pub fn record(&mut self, out: &StepOutput) -> Option<&FirstContact> {
        for t in &out.truth {
            if let Some(d) = self.min_distance_m.get_mut(t.id) {
                *d = d.min(f64::from(t.distance_m));
            }
        }
        self.last_collision_course = out
            .truth
            .iter()
            .filter_map(|t| t.ttc_s.map(|ttc| (t.id, f64::from(ttc))))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let frame = self.frames;
        self.frames += 1;
        if self.contact.is_none()
            && let Some(c) = out.first_collision()
        {
            self.contact = Some(first_contact(frame, c));
            return self.contact.as_ref();
        }
        None
    }

    /// The episode's ground truth from the steps recorded.
    pub fn finish(self) -> EpisodeTruth {
        let reference = match &self.contact {
            Some(c) => Some(c.object_id),
            None => {
                let movers: Vec<usize> = self
                    .objects
                    .iter()
                    .filter(|(_, _, kind)| *kind != ObjectKind::Scenery)
                    .map(|(id, _, _)| *id)
                    .collect();
                let candidates = if movers.is_empty() {
                    self.objects.iter().map(|(id, _, _)| *id).collect()
                } else {
                    movers
                };
                candidates
                    .into_iter()
                    .min_by(|&a, &b| self.min_distance_m[a].total_cmp(&self.min_distance_m[b]))
            }
        };
        let cut_short = match (&self.contact, self.last_collision_course) {
            (None, Some((id, ttc))) => {
                let name = self
                    .objects
                    .iter()
                    .find(|o| o.0 == id)
                    .map_or_else(String::new, |o| o.1.clone());
                Some((name, ttc))
            }
            _ => None,
        };
        let closest_m = reference.and_then(|r| self.min_distance_m.get(r).copied().filter(|d| d.is_finite()));
        EpisodeTruth {
            contact: self.contact,
            reference,
            cut_short,
            closest_m,
        }
    }
}

fn first_contact(frame: usize, c: &Contact) -> FirstContact {
    FirstContact {
        frame,
        t_s: c.time_s(),
        object_id: c.object_id,
        impact: Impact::from(c),
    }
}

/// The open-loop ground truth of episode `spec` with simulator seed `seed`, physics only (no
/// rendering): what the runner's rendered open-loop pass finds, without the frames.
pub fn open_loop_truth(spec: &EpisodeSpec, seed: u64) -> Result<EpisodeTruth, SimError> {
    physics_only_pass(spec, seed, |_, _| {})
}

/// The physics-only open-loop pass of [`open_loop_truth`], calling `each(sim, out)` after every
/// step (the contact's included).
fn physics_only_pass(
    spec: &EpisodeSpec,
    seed: u64,
    mut each: impl FnMut(&mut Sim, &StepOutput),
) -> Result<EpisodeTruth, SimError> {
    let mut sim = Sim::new_physics_only(&spec.world, seed)?;
    let mut recorder = TruthRecorder::new(&sim);
    for _ in 0..spec.frames() {
        let cmd = spec.cruise.command_at(sim.time());
        let out = sim.step(&cmd.to_sim())?;
        each(&mut sim, &out);
        if recorder.record(&out).is_some() {
            break;
        }
    }
    Ok(recorder.finish())
}

/// The open-loop ground truth of episode `spec` (simulator seed `seed`, as [`open_loop_truth`]
/// gives it) and, for a threat, its escape deadline under `controller`, from **one** physics-only
/// pass that captures each step's view ([`Sim::capture_view`]). The deadline's backward search
/// ([`escape_deadline_with`]) asks for the looming sides of the frames it replays, from the contact
/// back to the deadline; those views (and the one before each) are rendered on `renderer` in
/// batches (32 views at 64²), each bit-identical to the frame a rendering pass draws, so the
/// deadline is what a rendered open-loop pass gives (test `env::tests`: the Gymnasium
/// environment's deadline equals the runner's) at a fraction of the rendering: before, the
/// environment's resets rendered the whole pass up to the contact one view per submission.
pub fn open_loop_truth_and_deadline(
    spec: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    renderer: &mut Renderer,
) -> Result<(EpisodeTruth, Option<EscapeDeadline>), SimError> {
    let (mut views, mut t_s) = (Vec::new(), Vec::new());
    let truth = physics_only_pass(spec, seed, |sim, out| {
        t_s.push(out.t_s);
        views.push(sim.capture_view());
    })?;
    let Some(contact) = &truth.contact else {
        return Ok((truth, None));
    };
    let mut sides = ViewSides {
        n: spec.world.camera.n as usize,
        views: &views,
        renderer,
        sides: vec![None; views.len()],
        pixels: Vec::new(),
    };
    let deadline = escape_deadline_with(spec, seed, controller, |k| sides.side(k), &t_s, contact.frame)?;
    Ok((truth, Some(deadline)))
}

/// Views rendered together by [`open_loop_truth_and_deadline`] (plus the one before them): 32 at
/// 64², fewer for larger frames (at most [`SIDE_BATCH_PIXELS`] pixels, at least 4 views).
fn side_batch(n: usize) -> usize {
    (SIDE_BATCH_PIXELS / (n * n).max(1)).clamp(4, 32)
}

/// Pixels of one batch of [`side_batch`] views (what the renderer's layers and readback hold).
const SIDE_BATCH_PIXELS: usize = 32 * 64 * 64;

/// The looming sides of captured open-loop views, rendered on demand: asking for frame `k` renders
/// frames `k − side_batch(n) .. k` in one batch (the side of a frame comes from it and the frame
/// before: [`LoomingSideEstimator`]), so a search going backwards renders each view about once.
struct ViewSides<'a> {
    n: usize,
    views: &'a [CapturedView],
    renderer: &'a mut Renderer,
    /// `Some(side)` once frame k's side is known.
    sides: Vec<Option<Option<f32>>>,
    pixels: Vec<Vec<f32>>,
}

impl ViewSides<'_> {
    fn side(&mut self, k: usize) -> Result<Option<f32>, SimError> {
        if let Some(side) = self.sides[k] {
            return Ok(side);
        }
        let lo = (k + 1).saturating_sub(side_batch(self.n));
        // frame lo - 1 too: frame lo's side needs its predecessor (frame 0 has none)
        let first = lo.saturating_sub(1);
        let descs: Vec<_> = self.views[first..=k].iter().map(CapturedView::desc).collect();
        self.pixels.resize_with(descs.len(), Vec::new);
        self.renderer.render_batch(&descs, &mut self.pixels[..descs.len()])?;
        let mut estimator = LoomingSideEstimator::default();
        for (j, px) in (first..=k).zip(&mut self.pixels) {
            let side = Frame::from_f32(self.n, std::mem::take(px))
                .ok()
                .and_then(|f| estimator.update(&f));
            if j >= lo {
                self.sides[j] = Some(side);
            }
        }
        Ok(self.sides[k].flatten())
    }
}
