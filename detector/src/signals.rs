//! The [`Detector`] trait shared by every looming model, and its output [`Signals`].

use crate::{DetectorError, Frame};

/// What a detector reports for one frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Signals {
    /// The model's primary output (z for Hopfield; the LGMD potential for baselines).
    pub output: f64,
    /// Estimated angular size of the looming object in degrees, for models that give one.
    pub angular_size_deg: Option<f64>,
    /// Named auxiliary signals (e.g. `("on", z_on)`), written as `<id>_<name>` CSV columns.
    pub aux: Vec<(&'static str, f64)>,
    /// Where the looming object is in the image, for models that localise it (`tracker`, and
    /// `hopfield` with `attention = "tracker"`); `None` for the others. The escape agent turns it into the object's azimuth, elevation and image
    /// extent for the collision-course gate (`agents/src/decision/`).
    pub region: Option<ImageRegion>,
    /// Every object the detector perceives in this frame, for detectors that perceive several at
    /// once (`tracker`: its confirmed tracks); empty for the others, whose one percept is
    /// [`Self::angular_size_deg`] and [`Self::region`] (or the looming side). [`Self::region`] and
    /// [`Self::angular_size_deg`] stay those of the detector's primary object (`tracker`: its
    /// primary track, listed first whenever they report it; docs/detectors.md, tracker §4).
    /// The escape agent runs one decider per object and plans its manoeuvre about all of them.
    pub objects: Vec<PerceivedObject>,
}

/// One object a detector perceives in a frame ([`Signals::objects`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PerceivedObject {
    /// The detector's number for it (stable while the detector follows it; a lost and re-found
    /// object gets a new number). Perception only, not the world's object id.
    pub id: usize,
    /// Its image region ([`ImageRegion::track`] is `Some(id)`).
    pub region: ImageRegion,
    /// Its angular size θ̂ (degrees).
    pub angular_size_deg: f64,
    /// Its time to contact τ̂ (s), when the detector estimates one itself (`None`: the escape
    /// agent's decider estimates it from θ̂).
    pub tau_s: Option<f64>,
}

/// The image region of a tracked object in normalised image coordinates: x ∈ [−1, 1] from the left
/// to the right border, y ∈ [−1, 1] from the bottom to the top border (a pixel column j of an n×n
/// frame spans `x ∈ [2j/n − 1, 2(j+1)/n − 1]`, row i spans `y ∈ [1 − 2(i+1)/n, 1 − 2i/n]`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ImageRegion {
    /// Centroid `[x, y]` of the object's pixels.
    pub centroid: [f64; 2],
    /// Horizontal extent `[left, right]` (x of the outer borders of its leftmost and rightmost pixels).
    pub x: [f64; 2],
    /// Vertical extent `[bottom, top]` (y of the outer borders of its lowest and highest pixels).
    pub y: [f64; 2],
    /// Which of the detector's tracks the region belongs to, for detectors that tell objects apart
    /// (`tracker`: its tracks are numbered from 1 after a reset; a new number whenever it starts
    /// following another blob). Perception only: which image region the detector follows, not
    /// which object of the world it is (a lost and re-found object gets a new number). `None`: the
    /// detector does not tell objects apart. The escape agent passes it to its controller, which
    /// dodges an alarm about another track afresh (`EscapeController::set_object`, `agents`).
    pub track: Option<usize>,
}

impl ImageRegion {
    /// Angular width and height (degrees) of this region for a camera of full field of view
    /// `fov_deg` across the image (pinhole: image x = tan(azimuth) / tan(fov/2)).
    pub fn angular_size_deg(&self, fov_deg: f64) -> [f64; 2] {
        let camera = crate::Pinhole::new(fov_deg);
        let span = |[a, b]: [f64; 2]| (camera.angle_rad(b) - camera.angle_rad(a)).to_degrees();
        [span(self.x), span(self.y)]
    }
}

/// What the robot knows about its own motion during the camera period that ended with a frame (an
/// efference copy, for detectors that discount their own motion): the velocity command it applied,
/// and the camera's own motion and pose as its odometry and inertial sensor measure them. Nothing in
/// it is about other objects.
///
/// Camera frame: x = optical axis (forward), y = left, z = up. The motion fields
/// ([`Self::dt_s`], [`Self::rotation_rad`], [`Self::translation_m`]) and the pose fields
/// ([`Self::height_m`], [`Self::pitch_rad`], [`Self::roll_rad`]) are known when `dt_s > 0` and
/// `height_m > 0` respectively; the `Default` (all zero) means "not known": a compensating
/// detector then predicts no image motion (its residual is the plain temporal difference).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EfferenceCopy {
    /// Forward speed commanded (m/s).
    pub forward_mps: f64,
    /// Yaw rate commanded (rad/s, positive = turning left).
    pub yaw_rate_rps: f64,
    /// Lateral speed commanded (m/s, positive = to the left).
    pub lateral_mps: f64,
    /// Length of the camera period that ended with this frame (s; 0 = no motion known, e.g. the
    /// first frame).
    pub dt_s: f64,
    /// The camera's rotation since the previous frame as a rotation vector (rad) in the previous
    /// frame's camera axes: the current camera's axes are the previous ones rotated by it
    /// (`[roll, -pitch, yaw]` increments for small angles: z component positive = turned left).
    /// Includes camera shake, as a gyroscope on the camera measures it.
    pub rotation_rad: [f64; 3],
    /// The camera's displacement since the previous frame (m), in the previous frame's camera axes
    /// (x forward, y left, z up). Includes the shake's translation.
    pub translation_m: [f64; 3],
    /// Height of the camera's centre above the (flat) ground in this frame (m; 0 = unknown).
    pub height_m: f64,
    /// Pitch of the optical axis above the horizontal in this frame (rad, positive = up).
    pub pitch_rad: f64,
    /// Roll of the camera about its optical axis in this frame (rad, positive = right side down,
    /// i.e. a rotation about +x).
    pub roll_rad: f64,
}

impl EfferenceCopy {
    /// Whether the camera's motion since the previous frame is known ([`Self::dt_s`] > 0).
    pub fn knows_motion(&self) -> bool {
        self.dt_s > 0.0 && self.dt_s.is_finite()
    }

    /// Whether the camera's pose above the ground is known ([`Self::height_m`] > 0).
    pub fn knows_ground(&self) -> bool {
        self.height_m > 0.0 && self.height_m.is_finite()
    }

    /// The camera's "up" direction (the opposite of gravity) in the current camera axes, from
    /// [`Self::pitch_rad`] and [`Self::roll_rad`].
    pub fn up_in_camera(&self) -> [f64; 3] {
        // world up = R · e_z with R = Ry(−pitch)·Rx(roll) (the simulator's camera construction);
        // in camera axes: Rᵀ · e_z.
        let (sp, cp) = self.pitch_rad.sin_cos();
        let (sr, cr) = self.roll_rad.sin_cos();
        [sp, cp * sr, cp * cr]
    }
}

/// A looming detector: a causal filter from frames to [`Signals`].
///
/// Implementations keep their own state between frames; [`Detector::reset`]
/// returns them to the state before the first frame.
pub trait Detector: Send {
    /// Stable id used in the CLI, CSV columns, reports and Python (e.g. `hopfield`).
    fn id(&self) -> &'static str;
    /// Forget all history (start a new video).
    fn reset(&mut self);
    /// Process the next frame. Errors only on frames of the wrong size.
    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError>;
    /// [`Self::step`] with the efference copy of the camera period that ended with `frame`: what
    /// the scenario runner and the escape agent call. The default ignores it.
    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        let _ = ego;
        self.step(frame)
    }
    /// Whether this detector reads an event camera's events ([`Self::step_events`]) rather than
    /// frames: the event rows (`event_soc`, `event_lgmd`). Default false.
    fn reads_events(&self) -> bool {
        false
    }
    /// [`Self::step_moving`] with the events of the camera period that ended with `frame`, when
    /// the camera is an event camera (`[world.camera] kind = "events"`). The default ignores the
    /// events, so every frame row reads frames exactly as without an event camera; the event rows
    /// read the events.
    fn step_events(
        &mut self,
        frame: &Frame,
        events: &crate::events::EventInput<'_>,
        ego: &EfferenceCopy,
    ) -> Result<Signals, DetectorError> {
        let _ = events;
        self.step_moving(frame, ego)
    }
    /// An independent copy of this detector in its current state (its history included), when it
    /// can make one: stepping the copy on the next frames gives exactly the signals this detector
    /// would give. The scenario runner starts a closed-loop tail from the copy taken at the alarm
    /// frame instead of stepping a fresh detector through the whole open-loop prefix again. The
    /// default, `None`, is always correct: callers then replay the frames.
    fn snapshot(&self) -> Option<Box<dyn Detector>> {
        None
    }
}
