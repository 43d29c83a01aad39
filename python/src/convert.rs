//! Rust results → Python objects (dicts of numpy arrays), single and batched.
//!
//! Batched `info` dicts follow Gymnasium's vector convention (`VectorEnv._add_info`): every key holds
//! an array over environments plus a boolean mask `_key`; nested dicts are batched recursively. The
//! episode outcomes (only for environments whose episode just ended) are returned under the private
//! key `_outcomes` as `[(env_index, outcome_dict), …]` and merged by the Python wrapper.

use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use loomlab_env::{ActionKind, EpisodeSummary, Observation, ROBOT_DIM, StepInfo, StepResult};

use crate::Meta;

/// A time that may never come: `inf` for `None` (so that infos compare equal, unlike NaN).
fn inf_if_none(v: Option<f64>) -> f64 {
    v.unwrap_or(f64::INFINITY)
}

/// The observation of one environment: raw, a dict (per-detector signals under the detector
/// labels); normalized, the feature vector (a dict `{features, frame}` when frames are observed);
/// with an event camera the observed frame comes with `events` (ON and OFF counts, 2×n×n).
pub fn obs_dict<'py>(py: Python<'py>, meta: &Meta, obs: &Observation) -> PyResult<Bound<'py, PyAny>> {
    let n = meta.frame_size as usize;
    if meta.obs_mode.is_vector() {
        let f = obs.features.as_deref().unwrap_or_default();
        let features = PyArray1::from_slice(py, f).into_any();
        return match &obs.frame {
            None => Ok(features),
            Some(frame) => {
                let d = PyDict::new(py);
                d.set_item("features", features)?;
                d.set_item("frame", PyArray1::from_slice(py, frame).reshape([n, n])?)?;
                if let Some(e) = &obs.events {
                    d.set_item("events", PyArray1::from_slice(py, e).reshape([2, n, n])?)?;
                }
                Ok(d.into_any())
            }
        };
    }
    let d = PyDict::new(py);
    for (label, s) in meta.detector_labels.iter().zip(&obs.signals) {
        d.set_item(label, PyArray1::from_slice(py, s))?;
    }
    d.set_item("theta_hat", PyArray1::from_slice(py, &[obs.theta_hat_deg]))?;
    let alarm: Vec<i8> = obs.alarm.iter().map(|&a| i8::from(a)).collect();
    d.set_item("alarm", PyArray1::from_vec(py, alarm))?;
    d.set_item("robot", PyArray1::from_slice(py, &obs.robot))?;
    if let Some(f) = &obs.frame {
        d.set_item("frame", PyArray1::from_slice(py, f).reshape([n, n])?)?;
    }
    if let Some(e) = &obs.events {
        d.set_item("events", PyArray1::from_slice(py, e).reshape([2, n, n])?)?;
    }
    Ok(d.into_any())
}

fn reward_terms_dict<'py>(py: Python<'py>, info: &StepInfo) -> PyResult<Bound<'py, PyDict>> {
    let t = &info.reward_terms;
    let d = PyDict::new(py);
    d.set_item("collision", t.collision)?;
    d.set_item("survival", t.survival)?;
    d.set_item("progress", t.progress)?;
    d.set_item("effort", t.effort)?;
    d.set_item("unnecessary_dodge", t.unnecessary_dodge)?;
    d.set_item("timely_dodge", t.timely_dodge)?;
    Ok(d)
}

/// The scored outcome of an episode as a dict.
pub fn outcome_dict<'py>(py: Python<'py>, o: &EpisodeSummary) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("threat", o.threat)?;
    d.set_item("t_contact_s", o.t_contact_s)?;
    d.set_item("collision", o.collision)?;
    d.set_item("evaded", o.evaded)?;
    d.set_item("steps", o.steps)?;
    d.set_item("episode_return", o.episode_return)?;
    let dets = PyDict::new(py);
    for e in &o.detectors {
        let x = PyDict::new(py);
        x.set_item("outcome", e.outcome.as_str())?;
        x.set_item("t_alarm_s", e.t_alarm_s)?;
        x.set_item("lead_s", e.lead_s())?;
        x.set_item("ttc_at_alarm_s", e.ttc_at_alarm_s)?;
        x.set_item("angular_size_at_alarm_deg", e.angular_size_at_alarm_deg)?;
        x.set_item("max_signal", e.max_signal)?;
        dets.set_item(&e.detector, x)?;
    }
    d.set_item("detectors", dets)?;
    d.set_item("agent", json_value(py, &o.agent)?)?;
    Ok(d)
}

/// A serialisable value as Python data (through its JSON form: dicts, lists, numbers, None).
pub fn json_value<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| crate::errors::LoomlabError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// The info dict of one environment.
pub fn info_dict<'py>(py: Python<'py>, info: &StepInfo, kind: ActionKind) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("t_s", info.t_s)?;
    d.set_item("step", info.step)?;
    d.set_item("episode", info.episode)?;
    d.set_item("threat", info.threat)?;
    d.set_item("t_contact_s", inf_if_none(info.t_contact_s))?;
    d.set_item("ttc_s", inf_if_none(info.ttc_s))?;
    d.set_item("angular_size_deg", info.angular_size_deg.unwrap_or(0.0))?;
    d.set_item("collision", info.collision)?;
    d.set_item("dodging", info.dodging)?;
    match kind {
        ActionKind::Continuous => d.set_item(
            "controller_action",
            PyArray1::from_slice(py, &info.controller_continuous),
        )?,
        ActionKind::Discrete => d.set_item("controller_action", info.controller_discrete.index() as i64)?,
        ActionKind::Manoeuvre => d.set_item("controller_action", info.controller_manoeuvre as i64)?,
    }
    d.set_item("reward_terms", reward_terms_dict(py, info)?)?;
    if let Some(o) = &info.outcome {
        d.set_item("outcome", outcome_dict(py, o)?)?;
    }
    Ok(d)
}

/// Batched results of a vector step or reset.
pub struct Batch<'py> {
    /// Observation dict of `(num_envs, …)` arrays.
    pub obs: Bound<'py, PyDict>,
    /// `(num_envs,)` float64.
    pub reward: Bound<'py, PyAny>,
    /// `(num_envs,)` bool.
    pub terminated: Bound<'py, PyAny>,
    /// `(num_envs,)` bool.
    pub truncated: Bound<'py, PyAny>,
    /// Info dict (vector convention) with `_outcomes`.
    pub info: Bound<'py, PyDict>,
}

fn set_masked<'py>(
    py: Python<'py>,
    d: &Bound<'py, PyDict>,
    key: &str,
    value: Bound<'py, PyAny>,
    m: usize,
) -> PyResult<()> {
    d.set_item(key, value)?;
    d.set_item(format!("_{key}"), PyArray1::from_vec(py, vec![true; m]))?;
    Ok(())
}

impl<'py> Batch<'py> {
    /// Packs per-environment results into arrays (all in Rust; no per-environment Python objects
    /// except the outcomes of episodes that just ended).
    pub fn new(py: Python<'py>, meta: &Meta, results: &[StepResult]) -> PyResult<Self> {
        let m = results.len();
        let n = meta.frame_size as usize;
        let obs = PyDict::new(py);
        let features = meta.obs_mode.is_vector().then(|| {
            let width = meta.feature_names.len();
            let mut v = Vec::with_capacity(m * width);
            for r in results {
                match &r.obs.features {
                    Some(f) => v.extend_from_slice(f),
                    None => v.resize(v.len() + width, 0.0),
                }
            }
            (v, width)
        });
        let raw = features.is_none();
        for (k, id) in meta.detector_labels.iter().enumerate().filter(|_| raw) {
            let width = meta.signal_names[k].len();
            let mut v = Vec::with_capacity(m * width);
            for r in results {
                v.extend_from_slice(&r.obs.signals[k]);
            }
            obs.set_item(id, PyArray1::from_vec(py, v).reshape([m, width])?)?;
        }
        if let Some((v, width)) = features {
            obs.set_item("features", PyArray1::from_vec(py, v).reshape([m, width])?)?;
        } else {
            let theta: Vec<f32> = results.iter().map(|r| r.obs.theta_hat_deg).collect();
            obs.set_item("theta_hat", PyArray1::from_vec(py, theta).reshape([m, 1])?)?;
            let d = meta.detector_labels.len();
            let alarm: Vec<i8> = results
                .iter()
                .flat_map(|r| r.obs.alarm.iter().map(|&a| i8::from(a)))
                .collect();
            obs.set_item("alarm", PyArray1::from_vec(py, alarm).reshape([m, d])?)?;
            let robot: Vec<f32> = results.iter().flat_map(|r| r.obs.robot).collect();
            obs.set_item("robot", PyArray1::from_vec(py, robot).reshape([m, ROBOT_DIM])?)?;
        }
        if meta.observe_frames {
            let mut frames = Vec::with_capacity(m * n * n);
            for r in results {
                match &r.obs.frame {
                    Some(f) => frames.extend_from_slice(f),
                    None => frames.resize(frames.len() + n * n, 0),
                }
            }
            obs.set_item("frame", PyArray1::from_vec(py, frames).reshape([m, n, n])?)?;
            if meta.event_camera {
                let mut counts = Vec::with_capacity(m * 2 * n * n);
                for r in results {
                    match &r.obs.events {
                        Some(e) => counts.extend_from_slice(e),
                        None => counts.resize(counts.len() + 2 * n * n, 0),
                    }
                }
                obs.set_item("events", PyArray1::from_vec(py, counts).reshape([m, 2, n, n])?)?;
            }
        }

        let reward = PyArray1::from_vec(py, results.iter().map(|r| r.reward).collect()).into_any();
        let terminated = PyArray1::from_vec(py, results.iter().map(|r| r.terminated).collect()).into_any();
        let truncated = PyArray1::from_vec(py, results.iter().map(|r| r.truncated).collect()).into_any();

        let info = PyDict::new(py);
        let f64s = |f: &dyn Fn(&StepInfo) -> f64| PyArray1::from_vec(py, results.iter().map(|r| f(&r.info)).collect());
        let bools =
            |f: &dyn Fn(&StepInfo) -> bool| PyArray1::from_vec(py, results.iter().map(|r| f(&r.info)).collect());
        set_masked(py, &info, "t_s", f64s(&|i| i.t_s).into_any(), m)?;
        let steps: Vec<i64> = results.iter().map(|r| r.info.step as i64).collect();
        set_masked(py, &info, "step", PyArray1::from_vec(py, steps).into_any(), m)?;
        let episodes: Vec<i64> = results.iter().map(|r| r.info.episode as i64).collect();
        set_masked(py, &info, "episode", PyArray1::from_vec(py, episodes).into_any(), m)?;
        set_masked(py, &info, "threat", bools(&|i| i.threat).into_any(), m)?;
        set_masked(
            py,
            &info,
            "t_contact_s",
            f64s(&|i| inf_if_none(i.t_contact_s)).into_any(),
            m,
        )?;
        set_masked(py, &info, "ttc_s", f64s(&|i| inf_if_none(i.ttc_s)).into_any(), m)?;
        set_masked(
            py,
            &info,
            "angular_size_deg",
            f64s(&|i| i.angular_size_deg.unwrap_or(0.0)).into_any(),
            m,
        )?;
        set_masked(py, &info, "collision", bools(&|i| i.collision).into_any(), m)?;
        set_masked(py, &info, "dodging", bools(&|i| i.dodging).into_any(), m)?;
        let ctrl = match meta.action_kind {
            ActionKind::Continuous => {
                let v: Vec<f32> = results.iter().flat_map(|r| r.info.controller_continuous).collect();
                PyArray1::from_vec(py, v).reshape([m, 3])?.into_any()
            }
            ActionKind::Discrete => {
                let v: Vec<i64> = results
                    .iter()
                    .map(|r| r.info.controller_discrete.index() as i64)
                    .collect();
                PyArray1::from_vec(py, v).into_any()
            }
            ActionKind::Manoeuvre => {
                let v: Vec<i64> = results.iter().map(|r| r.info.controller_manoeuvre as i64).collect();
                PyArray1::from_vec(py, v).into_any()
            }
        };
        set_masked(py, &info, "controller_action", ctrl, m)?;
        let terms = PyDict::new(py);
        set_masked(
            py,
            &terms,
            "collision",
            f64s(&|i| i.reward_terms.collision).into_any(),
            m,
        )?;
        set_masked(py, &terms, "survival", f64s(&|i| i.reward_terms.survival).into_any(), m)?;
        set_masked(py, &terms, "progress", f64s(&|i| i.reward_terms.progress).into_any(), m)?;
        set_masked(py, &terms, "effort", f64s(&|i| i.reward_terms.effort).into_any(), m)?;
        set_masked(
            py,
            &terms,
            "unnecessary_dodge",
            f64s(&|i| i.reward_terms.unnecessary_dodge).into_any(),
            m,
        )?;
        set_masked(
            py,
            &terms,
            "timely_dodge",
            f64s(&|i| i.reward_terms.timely_dodge).into_any(),
            m,
        )?;
        set_masked(py, &info, "reward_terms", terms.into_any(), m)?;
        let outcomes = PyList::empty(py);
        for (k, r) in results.iter().enumerate() {
            if let Some(o) = &r.info.outcome {
                outcomes.append((k, outcome_dict(py, o)?))?;
            }
        }
        info.set_item("_outcomes", outcomes)?;
        Ok(Self {
            obs,
            reward,
            terminated,
            truncated,
            info,
        })
    }
}
