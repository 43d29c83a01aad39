//! Python detectors (`loomlab.PythonDetector`) as detectors of the Rust registry, so that the one
//! closed loop (`loomlab_scenarios::Runner`: open-loop pass, scoring, escape tails, the escape
//! controller's percept and decision step) runs them exactly as it runs the built-in detectors.
//!
//! - **Frames**: every frame the runner hands its detectors (`loomlab_detector::Frame`, luminance
//!   in [0, 1]) is copied into a fresh float32 numpy array of shape (n, n), row-major, and passed
//!   to the object's `step(frame)`. It returns a float (the output) or a dict with `output` and
//!   optionally `angular_size_deg` (θ̂, degrees; `None`: no estimate this frame), `image_x` and
//!   `image_y` (the object's image position, recorded as auxiliary signals) and `objects`: every
//!   object the detector perceives, a list of dicts `{id, box, theta_deg, tau_s}` (`id` an int,
//!   `box` `[x0, x1, y0, y1]` in normalised image coordinates within [−1, 1], `theta_deg` θ̂ in
//!   degrees, `tau_s` optional: its own τ̂ in seconds, or `None`), which become
//!   `Signals::objects`; the first listed is the primary object, whose θ̂ and box stand for
//!   `output`, `angular_size_deg` and the region when the dict does not give them.
//! - **Instances**: the runner builds a fresh detector per episode and per closed-loop tail, on
//!   several worker threads. Each build is an independent instance: the class called with no
//!   arguments when the wrapped object is a class, else `copy.deepcopy` of the object; then
//!   `reset()`. So episodes never share state and results do not depend on `jobs`.
//! - **The GIL**: each `reset`/`step` acquires the GIL for the call; the runner's workers render and
//!   run the Rust detectors in parallel, and the Python calls take turns (one at a time).

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};

use numpy::ToPyArray;
use numpy::ndarray::ArrayView2;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTracebackMethods, PyType};

use loomlab_detector::registry::{CameraFacts, Configure, ConfiguredDetector, ParamError, Registration, Signal};
use loomlab_detector::{
    Detector, DetectorError, DetectorParams, EfferenceCopy, Frame, ImageRegion, PerceivedObject, Registry, Signals,
};
use loomlab_scenarios::schema::{DetectorDesc, trigger_of};

use crate::errors;

/// The keys a Python detector's `step` may return in a dict.
const STEP_KEYS: [&str; 5] = ["output", "angular_size_deg", "image_x", "image_y", "objects"];

/// The keys of one object in a step's `objects` list (`tau_s` optional).
const OBJECT_KEYS: [&str; 4] = ["id", "box", "theta_deg", "tau_s"];

/// One `loomlab.PythonDetector`, read from its attributes.
#[derive(Debug)]
pub(crate) struct PythonEntry {
    label: String,
    object: Arc<Py<PyAny>>,
    threshold: f64,
    trigger: Signal,
    description: String,
}

impl PythonEntry {
    /// Reads a `loomlab.PythonDetector` (`label`, `detector`, `threshold`, `trigger`).
    pub(crate) fn read(wrapper: &Bound<'_, PyAny>) -> PyResult<Self> {
        let label: String = wrapper.getattr("label")?.extract()?;
        let object = wrapper.getattr("detector")?;
        let threshold: f64 = wrapper.getattr("threshold")?.extract()?;
        let trigger: String = wrapper.getattr("trigger")?.extract()?;
        let trigger = match trigger.as_str() {
            "output" => Signal::Output,
            "angular_size" | "angular_size_deg" => Signal::AngularSize,
            other => {
                return Err(errors::DetectorError::new_err(format!(
                    "PythonDetector `{label}`: trigger = {other:?}; use \"output\" or \"angular_size\""
                )));
            }
        };
        let class = if object.is_instance_of::<PyType>() {
            object.clone()
        } else {
            object.get_type().into_any()
        };
        let description = format!(
            "Python detector {}.{}",
            class.getattr("__module__")?.str()?,
            class.getattr("__qualname__")?.str()?
        );
        Ok(Self {
            label,
            object: Arc::new(object.unbind()),
            threshold,
            trigger,
            description,
        })
    }
}

/// The built-in registry plus `entries` (each registered under its label), and the detector entry
/// that runs each at its threshold and trigger.
pub(crate) fn registry_with(entries: Vec<PythonEntry>) -> PyResult<(Registry, Vec<DetectorDesc>)> {
    let mut registry = Registry::builtin().clone();
    let mut descs = Vec::with_capacity(entries.len());
    for e in entries {
        if loomlab_scenarios::reference::is_reference(&e.label) {
            return Err(errors::DetectorError::new_err(format!(
                "PythonDetector `{label}` ({what}): label = \"{label}\" is the name of a reference row ({all}), \
                 which every report has; give it another label (PythonDetector(..., label=\"my_{label}\") or \
                 --label my_{label})",
                label = e.label,
                what = e.description,
                all = loomlab_scenarios::reference::REFERENCE_LABELS.join(", "),
            )));
        }
        let configured = PythonConfigured {
            id: intern(&e.label),
            object: Arc::clone(&e.object),
            description: format!("{} as `{}`", e.description, e.label),
            trigger: e.trigger,
        };
        let label = e.label.clone();
        let configure: Arc<Configure> = Arc::new(move |params, _camera: &CameraFacts| {
            if params.is_some_and(|p| !p.is_empty()) {
                return Err(ParamError {
                    key: "params".into(),
                    reason: format!("the Python detector `{label}` takes no params; configure its object in Python"),
                });
            }
            Ok(DetectorParams::new(configured.clone()))
        });
        let signals = [Signal::Output, e.trigger];
        let registration =
            Registration::with_configure(&e.label, &e.description, &signals, e.trigger, e.threshold, configure);
        registry = registry.with(registration).map_err(|err| {
            errors::DetectorError::new_err(format!(
                "PythonDetector `{}` ({}): {err}; give it another label (PythonDetector(..., label=...) or --label)",
                e.label, e.description
            ))
        })?;
        descs.push(DetectorDesc {
            threshold: Some(e.threshold),
            trigger: Some(trigger_of(e.trigger)),
            ..DetectorDesc::of_id(&e.label)
        });
    }
    Ok((registry, descs))
}

/// A detector id that lives for the whole process (the `Detector::id` of a Python detector):
/// each distinct label is stored once.
fn intern(label: &str) -> &'static str {
    static IDS: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut ids = IDS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(id) = ids.get(label) {
        return id;
    }
    let id: &'static str = Box::leak(label.to_string().into_boxed_str());
    ids.insert(id);
    id
}

/// A Python detector's object, ready to build instances from (see the module docs).
#[derive(Clone)]
struct PythonConfigured {
    id: &'static str,
    object: Arc<Py<PyAny>>,
    description: String,
    /// The signal its alarms trigger on: with [`Signal::AngularSize`] every step must return
    /// `angular_size_deg` (`None` allowed).
    trigger: Signal,
}

impl PythonConfigured {
    fn failed(&self, py: Python<'_>, what: &str, e: PyErr) -> DetectorError {
        DetectorError::Failed {
            detector: self.id.to_string(),
            reason: format!("{what}: {}", describe_exception(py, &e)),
        }
    }
}

impl ConfiguredDetector for PythonConfigured {
    fn build(&self, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        Python::attach(|py| {
            let object = self.object.bind(py);
            let instance = if object.is_instance_of::<PyType>() {
                object
                    .call0()
                    .map_err(|e| self.failed(py, "calling the class with no arguments", e))?
            } else {
                py.import("copy")
                    .and_then(|copy| copy.call_method1("deepcopy", (object,)))
                    .map_err(|e| {
                        self.failed(
                            py,
                            "copy.deepcopy of the object (each episode gets its own copy; pass the class \
                             instead if it cannot be copied)",
                            e,
                        )
                    })?
            };
            let accepts = |what: &str| {
                py.import("loomlab.detectors")
                    .and_then(|m| m.call_method1(what, (&instance,)))
                    .and_then(|v| v.extract::<bool>())
                    .map_err(|e| self.failed(py, "inspecting step()", e))
            };
            let (wants_ego, wants_events) = (accepts("_accepts_ego")?, accepts("_accepts_events")?);
            instance
                .call_method0("reset")
                .map_err(|e| self.failed(py, "reset()", e))?;
            Ok(Box::new(PythonInstance {
                id: self.id,
                instance: instance.unbind(),
                n,
                wants_ego,
                wants_events,
                reset_error: None,
                trigger: self.trigger,
                frame: 0,
            }) as Box<dyn Detector>)
        })
    }

    fn describe(&self) -> String {
        self.description.clone()
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// One instance of a Python detector, stepped by the runner.
struct PythonInstance {
    id: &'static str,
    instance: Py<PyAny>,
    n: usize,
    /// Whether `step` takes a second argument, the efference copy.
    wants_ego: bool,
    /// Whether `step` takes the keyword argument `events` (an event camera's events).
    wants_events: bool,
    /// An exception of `reset()` (the trait's `reset` cannot fail): reported by the next step.
    reset_error: Option<String>,
    /// The trigger signal (see [`PythonConfigured::trigger`]).
    trigger: Signal,
    /// Frames stepped since the last reset (the next one's index, 0-based, named in errors).
    frame: u64,
}

impl PythonInstance {
    fn failed(&self, reason: String) -> DetectorError {
        DetectorError::Failed {
            detector: self.id.to_string(),
            reason,
        }
    }
}

impl Detector for PythonInstance {
    fn id(&self) -> &'static str {
        self.id
    }

    fn reset(&mut self) {
        self.frame = 0;
        Python::attach(|py| {
            if let Err(e) = self.instance.bind(py).call_method0("reset") {
                self.reset_error = Some(format!("reset(): {}", describe_exception(py, &e)));
            }
        });
    }

    fn reads_events(&self) -> bool {
        self.wants_events
    }

    fn step(&mut self, frame: &Frame) -> Result<Signals, DetectorError> {
        self.call_step(frame, None, None)
    }

    fn step_moving(&mut self, frame: &Frame, ego: &EfferenceCopy) -> Result<Signals, DetectorError> {
        self.call_step(frame, Some(ego), None)
    }

    fn step_events(
        &mut self,
        frame: &Frame,
        events: &loomlab_detector::EventInput<'_>,
        ego: &EfferenceCopy,
    ) -> Result<Signals, DetectorError> {
        self.call_step(frame, Some(ego), Some(events))
    }
}

/// The events of a camera period as the dict a Python detector's `step(..., events=...)` gets:
/// `t_s` (float64), `x`, `y` (uint16), `polarity` (int8: +1 ON, −1 OFF) arrays of the events in
/// time order, `on` and `off` (uint16, n × n count images), `t_start_s` and `t_end_s`.
fn events_dict<'py>(py: Python<'py>, e: &loomlab_detector::EventInput<'_>) -> PyResult<Bound<'py, PyDict>> {
    use numpy::{PyArray1, PyArrayMethods};
    let d = PyDict::new(py);
    d.set_item("t_s", PyArray1::from_iter(py, e.events.iter().map(|v| v.t_s)))?;
    d.set_item("x", PyArray1::from_iter(py, e.events.iter().map(|v| v.x)))?;
    d.set_item("y", PyArray1::from_iter(py, e.events.iter().map(|v| v.y)))?;
    d.set_item("polarity", PyArray1::from_iter(py, e.events.iter().map(|v| v.polarity)))?;
    d.set_item("on", PyArray1::from_slice(py, e.on_counts).reshape([e.n, e.n])?)?;
    d.set_item("off", PyArray1::from_slice(py, e.off_counts).reshape([e.n, e.n])?)?;
    d.set_item("t_start_s", e.t_start_s)?;
    d.set_item("t_end_s", e.t_end_s)?;
    Ok(d)
}

impl PythonInstance {
    /// `step(frame)`, or `step(frame, ego)` when it takes the efference copy (a dict
    /// `{forward_mps, yaw_rate_rps, lateral_mps, dt_s, rotation_rad, translation_m, height_m,
    /// pitch_rad, roll_rad}`, the fields of [`EfferenceCopy`]; `None` where there is none).
    ///
    /// A `step` with the keyword argument `events` gets the event camera's events of the period
    /// ([`events_dict`]), or `None` without an event camera.
    fn call_step(
        &mut self,
        frame: &Frame,
        ego: Option<&EfferenceCopy>,
        events: Option<&loomlab_detector::EventInput<'_>>,
    ) -> Result<Signals, DetectorError> {
        if let Some(reason) = self.reset_error.take() {
            return Err(self.failed(reason));
        }
        let n = frame.n();
        if n != self.n {
            return Err(DetectorError::FrameSize {
                expected: self.n,
                got: n,
            });
        }
        let view =
            ArrayView2::from_shape((n, n), frame.data()).map_err(|e| DetectorError::InvalidImage(e.to_string()))?;
        let index = self.frame;
        self.frame += 1;
        Python::attach(|py| {
            let array = view.to_pyarray(py);
            let answer = if self.wants_ego {
                let ego = match ego {
                    Some(e) => {
                        let d = PyDict::new(py);
                        d.set_item("forward_mps", e.forward_mps)
                            .and_then(|()| d.set_item("yaw_rate_rps", e.yaw_rate_rps))
                            .and_then(|()| d.set_item("lateral_mps", e.lateral_mps))
                            .and_then(|()| d.set_item("dt_s", e.dt_s))
                            .and_then(|()| d.set_item("rotation_rad", e.rotation_rad.to_vec()))
                            .and_then(|()| d.set_item("translation_m", e.translation_m.to_vec()))
                            .and_then(|()| d.set_item("height_m", e.height_m))
                            .and_then(|()| d.set_item("pitch_rad", e.pitch_rad))
                            .and_then(|()| d.set_item("roll_rad", e.roll_rad))
                            .map_err(|e| self.failed(format!("building the efference copy: {e}")))?;
                        d.into_any()
                    }
                    None => py.None().into_bound(py),
                };
                self.call_with_events(py, (array, ego).into_pyobject(py), events)
            } else {
                self.call_with_events(py, (array,).into_pyobject(py), events)
            };
            let answer = answer
                .map_err(|e| self.failed(format!("step(frame) at frame {index}: {}", describe_exception(py, &e))))?;
            signals_of(&answer)
                .and_then(|(signals, gave_theta)| checked(signals, gave_theta, self.trigger))
                .map_err(|why| self.failed(format!("step(frame) at frame {index} of the episode returned {why}")))
        })
    }
}

impl PythonInstance {
    /// `step(*args)`, with `events=` when the detector takes it.
    fn call_with_events<'py>(
        &self,
        py: Python<'py>,
        args: PyResult<Bound<'py, pyo3::types::PyTuple>>,
        events: Option<&loomlab_detector::EventInput<'_>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let step = self.instance.bind(py);
        let args = args?;
        if !self.wants_events {
            return step.call_method1("step", args);
        }
        let kwargs = PyDict::new(py);
        match events {
            Some(e) => kwargs.set_item("events", events_dict(py, e)?)?,
            None => kwargs.set_item("events", py.None())?,
        }
        step.call_method("step", args, Some(&kwargs))
    }
}

/// Refuses signals the scoring cannot use: a non-finite output or image position (an infinite
/// output would alarm and be scored a hit), a θ̂ that is not an angle in [0°, 180°], and, for a
/// detector triggered on θ̂, an answer without `angular_size_deg` (it could never alarm).
fn checked(signals: Signals, gave_theta: bool, trigger: Signal) -> Result<Signals, String> {
    if !signals.output.is_finite() {
        return Err(format!(
            "output = {}; outputs must be finite numbers (return 0.0 or the last value when there is none)",
            signals.output
        ));
    }
    if let Some(theta) = signals.angular_size_deg
        && !(theta.is_finite() && (0.0..=180.0).contains(&theta))
    {
        return Err(format!(
            "angular_size_deg = {theta}; θ̂ is an angular size in degrees, 0 to 180 (None: no estimate this frame)"
        ));
    }
    if let Some((key, v)) = signals.aux.iter().find(|(_, v)| !v.is_finite()) {
        return Err(format!("{key} = {v}; image positions must be finite numbers"));
    }
    if trigger == Signal::AngularSize && !gave_theta {
        return Err(
            "no angular_size_deg, but its trigger is \"angular_size\" (it alarms on θ̂, so it would never alarm); \
             return a dict with angular_size_deg (None when there is no estimate) or use trigger=\"output\""
                .into(),
        );
    }
    Ok(signals)
}

/// The signals of what `step` returned: a number, or a dict of [`STEP_KEYS`]; and whether it gave
/// `angular_size_deg` (a value or `None`).
fn signals_of(answer: &Bound<'_, PyAny>) -> Result<(Signals, bool), String> {
    let number = |key: &str, v: &Bound<'_, PyAny>| -> Result<f64, String> {
        v.extract::<f64>().map_err(|_| {
            let shown = v.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
            format!("{key} = {shown}, which is not a number")
        })
    };
    let Ok(dict) = answer.cast::<PyDict>() else {
        let signals = Signals {
            output: number("a value", answer).map_err(|e| {
                format!(
                    "{e}; return a float (the output) or a dict with keys {}",
                    STEP_KEYS.join(", ")
                )
            })?,
            angular_size_deg: None,
            aux: Vec::new(),
            region: None,
            objects: Vec::new(),
        };
        return Ok((signals, false));
    };
    let mut signals = Signals::default();
    let mut has_output = false;
    let mut gave_theta = false;
    let mut objects: Option<Vec<PerceivedObject>> = None;
    for (k, v) in dict.iter() {
        let key: String = k.str().map_or_else(|_| "?".into(), |s| s.to_string());
        match key.as_str() {
            "output" => {
                signals.output = number("output", &v)?;
                has_output = true;
            }
            "angular_size_deg" if v.is_none() => gave_theta = true,
            "angular_size_deg" => {
                signals.angular_size_deg = Some(number("angular_size_deg", &v)?);
                gave_theta = true;
            }
            "image_x" => signals.aux.push(("image_x", number("image_x", &v)?)),
            "image_y" => signals.aux.push(("image_y", number("image_y", &v)?)),
            "objects" => objects = Some(objects_of(&v)?),
            other => {
                return Err(format!(
                    "a dict with the key {other:?}; the keys are {}",
                    STEP_KEYS.join(", ")
                ));
            }
        }
    }
    if let Some(objects) = objects {
        // the first object is the primary one: its θ̂ and box stand for what the dict leaves out
        let primary = objects.first();
        if !has_output {
            signals.output = primary.map_or(0.0, |o| o.angular_size_deg);
            has_output = true;
        }
        if !gave_theta {
            signals.angular_size_deg = primary.map(|o| o.angular_size_deg);
            gave_theta = true;
        }
        signals.region = primary.map(|o| o.region);
        signals.objects = objects;
    }
    if !has_output {
        return Err("a dict without \"output\" (the detector's primary output, a float) or \"objects\"".into());
    }
    signals.aux.sort_by(|a, b| a.0.cmp(b.0));
    Ok((signals, gave_theta))
}

/// The perceived objects of a step's `objects` value: a list of dicts of [`OBJECT_KEYS`], each
/// checked (an int id, not repeated; a box of four finite numbers in [−1, 1] with x0 ≤ x1 and
/// y0 ≤ y1; θ̂ finite in [0°, 180°]; τ̂ finite and positive, or `None`); errors name the object's
/// index and key.
fn objects_of(value: &Bound<'_, PyAny>) -> Result<Vec<PerceivedObject>, String> {
    let shown = |v: &Bound<'_, PyAny>| v.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
    let list = value.cast::<pyo3::types::PyList>().map_err(|_| {
        format!(
            "objects = {}, which is not a list (a list of dicts {{id, box, theta_deg, tau_s}})",
            shown(value)
        )
    })?;
    let mut objects = Vec::with_capacity(list.len());
    for (index, item) in list.iter().enumerate() {
        let at = |key: &str| format!("objects[{index}].{key}");
        let dict = item.cast::<PyDict>().map_err(|_| {
            format!(
                "objects[{index}] = {}, which is not a dict with keys {}",
                shown(&item),
                OBJECT_KEYS.join(", ")
            )
        })?;
        if let Some(other) = dict
            .keys()
            .iter()
            .map(|k| k.to_string())
            .find(|k| !OBJECT_KEYS.contains(&k.as_str()))
        {
            return Err(format!(
                "objects[{index}] with the key {other:?}; its keys are {}",
                OBJECT_KEYS.join(", ")
            ));
        }
        let get = |key: &str| -> Result<Bound<'_, PyAny>, String> {
            dict.get_item(key).ok().flatten().ok_or_else(|| {
                format!(
                    "objects[{index}] without {key:?}; its keys are {}",
                    OBJECT_KEYS.join(", ")
                )
            })
        };
        let id_value = get("id")?;
        let id = (!id_value.is_instance_of::<pyo3::types::PyBool>())
            .then(|| id_value.extract::<usize>().ok())
            .flatten()
            .ok_or_else(|| format!("{} = {}; ids are ints ≥ 0", at("id"), shown(&id_value)))?;
        if objects.iter().any(|o: &PerceivedObject| o.id == id) {
            return Err(format!(
                "{} = {id}, the id of an earlier object; each object's id is its own",
                at("id")
            ));
        }
        let box_value = get("box")?;
        let bad_box = || {
            format!(
                "{} = {}; a box is [x0, x1, y0, y1]: four finite numbers in [-1, 1] (normalised image coordinates, \
                 x to the right, y up) with x0 <= x1 and y0 <= y1",
                at("box"),
                shown(&box_value)
            )
        };
        let [x0, x1, y0, y1] = box_value.extract::<[f64; 4]>().map_err(|_| bad_box())?;
        let inside = [x0, x1, y0, y1]
            .iter()
            .all(|v| v.is_finite() && (-1.0..=1.0).contains(v));
        if !inside || x0 > x1 || y0 > y1 {
            return Err(bad_box());
        }
        let theta_value = get("theta_deg")?;
        let theta = theta_value
            .extract::<f64>()
            .ok()
            .filter(|t| t.is_finite() && (0.0..=180.0).contains(t))
            .ok_or_else(|| {
                format!(
                    "{} = {}; θ̂ is an angular size in degrees, 0 to 180",
                    at("theta_deg"),
                    shown(&theta_value)
                )
            })?;
        let tau_s = match dict.get_item("tau_s").ok().flatten() {
            None => None,
            Some(v) if v.is_none() => None,
            Some(v) => Some(
                v.extract::<f64>()
                    .ok()
                    .filter(|t| t.is_finite() && *t > 0.0)
                    .ok_or_else(|| {
                        format!(
                            "{} = {}; τ̂ is a finite time to contact in seconds, > 0 (None: no estimate)",
                            at("tau_s"),
                            shown(&v)
                        )
                    })?,
            ),
        };
        objects.push(PerceivedObject {
            id,
            region: ImageRegion {
                centroid: [(x0 + x1) / 2.0, (y0 + y1) / 2.0],
                x: [x0, x1],
                y: [y0, y1],
                track: Some(id),
            },
            angular_size_deg: theta,
            tau_s,
        });
    }
    Ok(objects)
}

/// `Type: message` of a Python exception and the last line of its traceback (where it was raised).
fn describe_exception(py: Python<'_>, e: &PyErr) -> String {
    let mut text = e.to_string();
    if let Some(where_) = e.traceback(py).and_then(|t| t.format().ok()).and_then(|t| {
        t.lines()
            .rev()
            .find(|l| l.trim_start().starts_with("File "))
            .map(str::to_string)
    }) {
        text = format!("{text} ({})", where_.trim());
    }
    text
}

/// Seconds that `frames` steps of a `loomlab.PythonDetector` take through the runner's glue (a
/// fresh instance, then `step` on an n×n frame of the runner's `Frame` type, called from a worker
/// thread with the GIL acquired per step, exactly as an episode calls it), for the overhead
/// benchmark (`make bench-python`).
#[pyfunction]
pub fn _time_python_detector(py: Python<'_>, detector: Bound<'_, PyAny>, n: usize, frames: usize) -> PyResult<f64> {
    if !(1..=4096).contains(&n) || frames > 10_000_000 {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "n must be in 1..=4096 and frames at most 10^7",
        ));
    }
    let (registry, descs) = registry_with(vec![PythonEntry::read(&detector)?])?;
    let id = &descs[0].id;
    let camera = CameraFacts {
        n,
        fov_deg: 60.0,
        frame_rate_hz: 120.0,
    };
    let params = registry
        .get(id)
        .and_then(|r| {
            r.configure(None, &camera)
                .map_err(|e| DetectorError::InvalidImage(e.to_string()))
        })
        .map_err(|e| errors::DetectorError::new_err(e.to_string()))?;
    let frame_data: Vec<Frame> = (0..2)
        .map(|k| Frame::from_f32(n, (0..n * n).map(|i| ((i * 7 + k * 13) % 101) as f32 / 100.0).collect()))
        .collect::<Result<_, _>>()
        .map_err(|e| errors::DetectorError::new_err(e.to_string()))?;
    py.detach(|| {
        std::thread::scope(|s| {
            s.spawn(|| -> Result<f64, DetectorError> {
                let mut d = params.build(n)?;
                let started = std::time::Instant::now();
                for k in 0..frames {
                    d.step(&frame_data[k % 2])?;
                }
                Ok(started.elapsed().as_secs_f64())
            })
            .join()
        })
    })
    .map_err(|_| errors::DetectorError::new_err("the benchmark thread panicked"))?
    .map_err(|e| errors::DetectorError::new_err(e.to_string()))
}
