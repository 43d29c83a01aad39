//! `loomlab._native`: the Rust engine of the `loomlab` Python package.
//!
//! Thin glue over [`loomlab_env`], one name per type on both sides: the Python class
//! `_native.EscapeEnv` (`PyEscapeEnv`) wraps a [`loomlab_env::EscapeEnv`] and
//! `_native.EscapeVectorEnv` (`PyEscapeVectorEnv`) a [`loomlab_env::EscapeVectorEnv`], whose results
//! come back as batched numpy arrays; the Gymnasium classes `loomlab.EscapeEnv` and
//! `loomlab.EscapeVectorEnv` wrap them. Defaults and action names are exported
//! (`REWARD_DEFAULTS`, `ACTION_DEFAULTS`, `DISCRETE_ACTIONS`, `CONTINUOUS_ACTION_NAMES`) so that the
//! Python side restates none of them.
//! The GIL is released while Rust steps. Errors map to the exception tree `loomlab.LoomlabError` ⊃
//! `ScenarioError`, `RenderError`, `DetectorError`, `ActionError`; a seed outside [0, 2^64) is a
//! `ValueError` (seeds never wrap around) and a call on a closed environment Gymnasium's
//! `ClosedEnvironmentError`. The Gymnasium classes live in the pure-Python part of the package
//! (`python/loomlab`).

mod convert;
mod detectors;
mod errors;
mod evaluation;
mod run;
mod scenarios;
mod sweep;

use std::sync::{Mutex, MutexGuard};

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

use loomlab_agents::{ActionConfig, ContinuousAction, DiscreteAction};
use loomlab_env::{
    Action, ActionKind, EnvError, EnvOptions, EscapeEnv, EscapeVectorEnv, ObsMode, ROBOT_FIELDS, RewardConfig,
    StepResult, VectorSnapshot,
};

use crate::errors::{Seed, to_py};

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// An environment that `close()` drops (releasing its renderer, frames and episode).
type Slot<T> = Mutex<Option<T>>;

/// Runs `f` on the environment in `slot` with the GIL released; `what` (e.g. `step()`) names the
/// call in the error of a closed environment.
fn with_open<T, R: Send>(
    py: Python<'_>,
    slot: &Slot<T>,
    what: &str,
    f: impl FnOnce(&mut T) -> Result<R, EnvError> + Send,
) -> PyResult<R>
where
    T: Send,
{
    let r = py.detach(|| lock(slot).as_mut().map(f));
    match r {
        Some(r) => r.map_err(to_py),
        None => Err(errors::closed(py, what)),
    }
}

fn parse_options(options_json: &str) -> PyResult<EnvOptions> {
    EnvOptions::from_json(options_json).map_err(to_py)
}

/// Static facts about an environment, copied out so that Python can read them without the lock.
#[derive(Clone)]
struct Meta {
    scenario_name: String,
    detector_labels: Vec<String>,
    detector_ids: Vec<String>,
    signal_names: Vec<Vec<String>>,
    thresholds: Vec<f64>,
    frame_size: u32,
    dt: f64,
    duration_steps: u64,
    action_kind: ActionKind,
    observe_frames: bool,
    event_camera: bool,
    obs_mode: ObsMode,
    feature_names: Vec<String>,
    feature_low: Vec<f32>,
    feature_high: Vec<f32>,
    adapter: String,
}

impl Meta {
    fn of(env: &EscapeEnv) -> Self {
        Self {
            scenario_name: env.scenario_name().to_string(),
            detector_labels: env.detector_labels().iter().map(|s| s.to_string()).collect(),
            detector_ids: env.detector_ids().iter().map(|s| s.to_string()).collect(),
            signal_names: env.signal_names().to_vec(),
            thresholds: env.thresholds(),
            frame_size: env.frame_size(),
            dt: env.dt(),
            duration_steps: env.duration_steps(),
            action_kind: env.options().action_kind,
            observe_frames: env.options().observe_frames,
            event_camera: env.event_camera(),
            obs_mode: env.options().obs_mode,
            feature_names: env.feature_specs().into_iter().map(|f| f.name).collect(),
            feature_low: env.feature_specs().iter().map(|f| f.low).collect(),
            feature_high: env.feature_specs().iter().map(|f| f.high).collect(),
            adapter: env.adapter(),
        }
    }
}

macro_rules! meta_getters {
    ($ty:ty) => {
        #[pymethods]
        impl $ty {
            /// Scenario name.
            #[getter]
            fn scenario_name(&self) -> String {
                self.meta.scenario_name.clone()
            }
            /// Chosen detectors' labels (their ids unless the scenario labels them), in observation
            /// order: the per-detector observation keys.
            #[getter]
            fn detector_labels(&self) -> Vec<String> {
                self.meta.detector_labels.clone()
            }
            /// Chosen detectors' ids (`hopfield`, `soc`, …), in observation order.
            #[getter]
            fn detector_ids(&self) -> Vec<String> {
                self.meta.detector_ids.clone()
            }
            /// Names of each detector's signal vector (`output`, then auxiliary signals).
            #[getter]
            fn signal_names(&self) -> Vec<Vec<String>> {
                self.meta.signal_names.clone()
            }
            /// Alarm thresholds, in detector order.
            #[getter]
            fn thresholds(&self) -> Vec<f64> {
                self.meta.thresholds.clone()
            }
            /// Frame size n.
            #[getter]
            fn frame_size(&self) -> u32 {
                self.meta.frame_size
            }
            /// Camera period (s).
            #[getter]
            fn dt(&self) -> f64 {
                self.meta.dt
            }
            /// Steps of a full-length episode.
            #[getter]
            fn duration_steps(&self) -> u64 {
                self.meta.duration_steps
            }
            /// `"continuous"` or `"discrete"`.
            #[getter]
            fn action_kind(&self) -> &'static str {
                self.meta.action_kind.as_str()
            }
            /// Whether observations include the frame.
            #[getter]
            fn observe_frames(&self) -> bool {
                self.meta.observe_frames
            }
            /// Whether the episodes have an event camera (observed frames then come with the
            /// period's event counts, `obs["events"]`).
            #[getter]
            fn event_camera(&self) -> bool {
                self.meta.event_camera
            }
            /// The GPU adapter that renders.
            #[getter]
            fn adapter(&self) -> String {
                self.meta.adapter.clone()
            }
            /// `"raw"` or `"normalized"`.
            #[getter]
            fn obs_mode(&self) -> &'static str {
                self.meta.obs_mode.as_str()
            }
            /// Names of the features of the observation mode (the normalized ones for `raw`), in order.
            #[getter]
            fn feature_names(&self) -> Vec<String> {
                self.meta.feature_names.clone()
            }
            /// Declared lower bounds of those features.
            #[getter]
            fn feature_low(&self) -> Vec<f32> {
                self.meta.feature_low.clone()
            }
            /// Declared upper bounds of those features.
            #[getter]
            fn feature_high(&self) -> Vec<f32> {
                self.meta.feature_high.clone()
            }
            /// Names of the robot observation entries.
            #[getter]
            fn robot_fields(&self) -> Vec<&'static str> {
                ROBOT_FIELDS.to_vec()
            }
        }
    };
}

/// One environment (the engine of the Gymnasium class `loomlab.EscapeEnv`).
#[pyclass(name = "EscapeEnv", module = "loomlab._native")]
struct PyEscapeEnv {
    inner: Slot<EscapeEnv>,
    meta: Meta,
}

meta_getters!(PyEscapeEnv);

#[pymethods]
impl PyEscapeEnv {
    /// Builds an environment from a scenario (a shipped name or a TOML file path; `None`: the default)
    /// or TOML text, and options as JSON.
    #[new]
    #[pyo3(signature = (scenario=None, scenario_toml=None, options_json="{}"))]
    fn new(
        py: Python<'_>,
        scenario: Option<scenarios::ScenarioArg>,
        scenario_toml: Option<String>,
        options_json: &str,
    ) -> PyResult<Self> {
        let options = parse_options(options_json)?;
        let env = py
            .detach(|| {
                let sc = scenarios::load_arg(scenario.as_ref(), scenario_toml.as_deref())?;
                EscapeEnv::new(sc, options)
            })
            .map_err(to_py)?;
        Ok(Self {
            meta: Meta::of(&env),
            inner: Mutex::new(Some(env)),
        })
    }

    /// An environment over the episodes of a suite (a folder, list file or scenario file, or a
    /// shipped scenario name; `None`: the default scenario) expanded with `seed` as `loomlab run
    /// SUITE --seed SEED --limit LIMIT` expands them, for `reset_to_episode` (`loomlab.evaluate`).
    #[staticmethod]
    #[pyo3(signature = (suite, seed, limit=None, options_json="{}"))]
    fn from_suite(
        py: Python<'_>,
        suite: Option<String>,
        seed: Seed,
        limit: Option<usize>,
        options_json: &str,
    ) -> PyResult<Self> {
        let options = parse_options(options_json)?;
        let env = py.detach(|| {
            let (source, episodes) = evaluation::suite_episodes(suite.as_deref(), seed.0, limit, &options)?;
            let ctx = loomlab_env::shared_gpu_context()?;
            EscapeEnv::for_episodes(&source, episodes, options, ctx)
        });
        let env = env.map_err(to_py)?;
        Ok(Self {
            meta: Meta::of(&env),
            inner: Mutex::new(Some(env)),
        })
    }

    /// The simulator seed of the current episode (`None` before the first reset).
    #[getter]
    fn episode_seed(&self, py: Python<'_>) -> PyResult<Option<u64>> {
        with_open(py, &self.inner, "episode_seed", |env| Ok(env.episode_seed()))
    }

    /// The scenario of the current episode (`None` before the first reset).
    #[getter]
    fn episode_scenario(&self, py: Python<'_>) -> PyResult<Option<String>> {
        with_open(py, &self.inner, "episode_scenario", |env| {
            Ok(env.episode_spec().map(|s| s.scenario.clone()))
        })
    }

    /// Number of expanded episodes (`reset_to_episode` indices).
    #[getter]
    fn num_episodes(&self, py: Python<'_>) -> PyResult<usize> {
        with_open(py, &self.inner, "num_episodes", |env| Ok(env.episodes().len()))
    }

    /// Starts an episode: `(obs, info)`. The seed is an integer in [0, 2**64) (else `ValueError`).
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(&self, py: Python<'py>, seed: Option<Seed>) -> PyResult<Bound<'py, PyTuple>> {
        let (obs, info) = with_open(py, &self.inner, "reset()", |env| env.reset(seed.map(|s| s.0)))?;
        let o = convert::obs_dict(py, &self.meta, &obs)?;
        let i = convert::info_dict(py, &info, self.meta.action_kind)?;
        PyTuple::new(py, [o.into_any(), i.into_any()])
    }

    /// Starts expanded episode `index` with its own simulator seed, as `loomlab run` runs it:
    /// `(obs, info)`. The seed stream is untouched.
    fn reset_to_episode<'py>(&self, py: Python<'py>, index: usize) -> PyResult<Bound<'py, PyTuple>> {
        let (obs, info) = with_open(py, &self.inner, "reset_to_episode()", |env| {
            env.reset_to_episode(index, None)
        })?;
        let o = convert::obs_dict(py, &self.meta, &obs)?;
        let i = convert::info_dict(py, &info, self.meta.action_kind)?;
        PyTuple::new(py, [o.into_any(), i.into_any()])
    }

    /// Steps with a continuous action `[forward, yaw_rate, lateral]`.
    fn step_continuous<'py>(&self, py: Python<'py>, a0: f32, a1: f32, a2: f32) -> PyResult<Bound<'py, PyTuple>> {
        self.step(py, Action::Continuous([a0, a1, a2]))
    }

    /// Steps with a discrete action index.
    fn step_discrete<'py>(&self, py: Python<'py>, index: i64) -> PyResult<Bound<'py, PyTuple>> {
        self.step(py, Action::Discrete(index))
    }

    /// The latest frame, `(n, n)` uint8.
    fn frame<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let data = with_open(py, &self.inner, "render()", |env| Ok(env.frame_u8()))?;
        let n = self.meta.frame_size as usize;
        if data.is_empty() {
            return Ok(PyArray1::<u8>::zeros(py, [n * n], false).reshape([n, n])?.into_any());
        }
        Ok(PyArray1::from_vec(py, data).reshape([n, n])?.into_any())
    }

    /// The state that reproduces the current episode, as JSON (for pickling).
    fn snapshot(&self, py: Python<'_>) -> PyResult<String> {
        let snap = with_open(py, &self.inner, "snapshot()", |env| Ok(env.snapshot()))?;
        serde_json::to_string(&snap).map_err(|e| errors::LoomlabError::new_err(e.to_string()))
    }

    /// Restores a snapshot by replaying it; returns `(obs, info)` when an episode was running.
    fn restore<'py>(&self, py: Python<'py>, snapshot_json: &str) -> PyResult<Option<Bound<'py, PyTuple>>> {
        let snap = serde_json::from_str(snapshot_json)
            .map_err(|e| errors::LoomlabError::new_err(format!("invalid snapshot: {e}")))?;
        let last = with_open(py, &self.inner, "restore()", |env| env.restore(&snap))?;
        match last {
            None => Ok(None),
            Some((obs, info)) => {
                let o = convert::obs_dict(py, &self.meta, &obs)?;
                let i = convert::info_dict(py, &info, self.meta.action_kind)?;
                Ok(Some(PyTuple::new(py, [o.into_any(), i.into_any()])?))
            }
        }
    }

    /// Drops the environment (its renderer, frames and episode); later calls raise Gymnasium's
    /// `ClosedEnvironmentError`. Closing twice is allowed.
    fn close(&self, py: Python<'_>) {
        py.detach(|| drop(lock(&self.inner).take()));
    }

    /// Whether `close()` was called.
    #[getter]
    fn closed(&self) -> bool {
        lock(&self.inner).is_none()
    }
}

impl PyEscapeEnv {
    fn step<'py>(&self, py: Python<'py>, action: Action) -> PyResult<Bound<'py, PyTuple>> {
        let r: StepResult = with_open(py, &self.inner, "step()", |env| env.step(action))?;
        let o = convert::obs_dict(py, &self.meta, &r.obs)?;
        let i = convert::info_dict(py, &r.info, self.meta.action_kind)?;
        PyTuple::new(
            py,
            [
                o.into_any(),
                r.reward.into_pyobject(py)?.into_any(),
                pyo3::types::PyBool::new(py, r.terminated).to_owned().into_any(),
                pyo3::types::PyBool::new(py, r.truncated).to_owned().into_any(),
                i.into_any(),
            ],
        )
    }
}

/// N environments stepped on Rust threads (the engine of the Gymnasium class
/// `loomlab.EscapeVectorEnv`).
#[pyclass(name = "EscapeVectorEnv", module = "loomlab._native")]
struct PyEscapeVectorEnv {
    inner: Slot<EscapeVectorEnv>,
    meta: Meta,
    num_envs: usize,
}

meta_getters!(PyEscapeVectorEnv);

#[pymethods]
impl PyEscapeVectorEnv {
    /// Builds `num_envs` environments (see `EscapeEnv`).
    #[new]
    #[pyo3(signature = (num_envs, scenario=None, scenario_toml=None, options_json="{}"))]
    fn new(
        py: Python<'_>,
        num_envs: usize,
        scenario: Option<scenarios::ScenarioArg>,
        scenario_toml: Option<String>,
        options_json: &str,
    ) -> PyResult<Self> {
        let options = parse_options(options_json)?;
        let vec = py
            .detach(|| {
                let sc = scenarios::load_arg(scenario.as_ref(), scenario_toml.as_deref())?;
                EscapeVectorEnv::new(sc, options, num_envs)
            })
            .map_err(to_py)?;
        Ok(Self {
            meta: Meta::of(&vec.envs()[0]),
            num_envs: vec.num_envs(),
            inner: Mutex::new(Some(vec)),
        })
    }

    /// Number of environments.
    #[getter]
    fn num_envs(&self) -> usize {
        self.num_envs
    }

    /// Resets every environment (env i gets `seed + i`, which must stay below 2**64, else
    /// `ValueError`): `(obs, info)` batched.
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(&self, py: Python<'py>, seed: Option<Seed>) -> PyResult<Bound<'py, PyTuple>> {
        let out = with_open(py, &self.inner, "reset()", |vec| vec.reset(seed.map(|s| s.0)))?;
        self.reset_batch(py, out.into_iter().map(Some).collect())
    }

    /// The state that reproduces every environment, as JSON (for pickling).
    fn snapshot(&self, py: Python<'_>) -> PyResult<String> {
        let snap = with_open(py, &self.inner, "snapshot()", |vec| Ok(vec.snapshot()))?;
        serde_json::to_string(&snap).map_err(|e| errors::LoomlabError::new_err(e.to_string()))
    }

    /// Restores a snapshot by replaying every environment's episode; returns the batched last
    /// `(obs, info)` when every environment had an episode running, else `None`.
    fn restore<'py>(&self, py: Python<'py>, snapshot_json: &str) -> PyResult<Option<Bound<'py, PyTuple>>> {
        let snap: VectorSnapshot = serde_json::from_str(snapshot_json)
            .map_err(|e| errors::LoomlabError::new_err(format!("invalid snapshot: {e}")))?;
        let last = with_open(py, &self.inner, "restore()", |vec| vec.restore(&snap))?;
        if last.iter().any(Option::is_none) {
            return Ok(None);
        }
        self.reset_batch(py, last).map(Some)
    }

    /// Drops the environments (their renderers, frames and episodes); later calls raise
    /// Gymnasium's `ClosedEnvironmentError`. Closing twice is allowed.
    fn close(&self, py: Python<'_>) {
        py.detach(|| drop(lock(&self.inner).take()));
    }

    /// Whether `close()` was called.
    #[getter]
    fn closed(&self) -> bool {
        lock(&self.inner).is_none()
    }

    /// Steps with continuous actions, `(num_envs, 3)` float32.
    fn step_continuous<'py>(
        &self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let view = actions.as_array();
        if view.shape() != [self.num_envs, 3] {
            return Err(errors::ActionError::new_err(format!(
                "continuous actions must have shape ({}, 3), got {:?}",
                self.num_envs,
                view.shape()
            )));
        }
        let acts: Vec<Action> = view
            .rows()
            .into_iter()
            .map(|r| Action::Continuous([r[0], r[1], r[2]]))
            .collect();
        self.step(py, acts)
    }

    /// Steps with discrete actions, `(num_envs,)` int64.
    fn step_discrete<'py>(
        &self,
        py: Python<'py>,
        actions: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let view = actions.as_array();
        if view.len() != self.num_envs {
            return Err(errors::ActionError::new_err(format!(
                "discrete actions must have shape ({},), got {:?}",
                self.num_envs,
                view.shape()
            )));
        }
        let acts: Vec<Action> = view.iter().map(|&i| Action::Discrete(i)).collect();
        self.step(py, acts)
    }

    /// The training step (`loomlab.EscapeVectorEnv.step_train`): steps with `actions` (`(num_envs,)`
    /// int64 for discrete and manoeuvre actions, `(num_envs, 3)` float32 for continuous ones) with
    /// same-step auto-reset, for feature observations without frames. Returns `(features, reward,
    /// terminated, truncated, last_features, outcomes)`: the next observations (the new episode's
    /// first one where an episode ended) `(num_envs, F)` float32, the rewards float32, the flags,
    /// the observations the step ended on (an ended episode's last one), and `[(index, outcome)]`
    /// for the episodes that ended. No info dicts, no per-environment Python objects otherwise.
    fn step_train<'py>(&self, py: Python<'py>, actions: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyTuple>> {
        if !self.meta.obs_mode.is_vector() || self.meta.observe_frames {
            return Err(errors::ActionError::new_err(
                "step_train needs one feature vector per observation: obs_mode 'normalized', 'privileged' or \
                 'decision' and observe_frames=False (use step otherwise)",
            ));
        }
        let acts: Vec<Action> = if self.meta.action_kind == ActionKind::Continuous {
            let a: PyReadonlyArray2<'py, f32> = actions.extract()?;
            let view = a.as_array();
            if view.shape() != [self.num_envs, 3] {
                return Err(errors::ActionError::new_err(format!(
                    "continuous actions must have shape ({}, 3), got {:?}",
                    self.num_envs,
                    view.shape()
                )));
            }
            view.rows()
                .into_iter()
                .map(|r| Action::Continuous([r[0], r[1], r[2]]))
                .collect()
        } else {
            let a: PyReadonlyArray1<'py, i64> = actions.extract()?;
            let view = a.as_array();
            if view.len() != self.num_envs {
                return Err(errors::ActionError::new_err(format!(
                    "discrete actions must have shape ({},), got {:?}",
                    self.num_envs,
                    view.shape()
                )));
            }
            view.iter().map(|&i| Action::Discrete(i)).collect()
        };
        let (results, fresh) = with_open(py, &self.inner, "step_train()", |vec| vec.step_resetting(&acts))?;
        let width = self.meta.feature_names.len();
        let (m, mut next, mut last) = (
            results.len(),
            Vec::with_capacity(results.len() * width),
            Vec::with_capacity(results.len() * width),
        );
        let row = |o: &loomlab_env::Observation, out: &mut Vec<f32>| match &o.features {
            Some(f) => out.extend_from_slice(f),
            None => out.resize(out.len() + width, 0.0),
        };
        for (r, f) in results.iter().zip(&fresh) {
            row(&r.obs, &mut last);
            row(f.as_ref().unwrap_or(&r.obs), &mut next);
        }
        let outcomes = PyList::empty(py);
        for (i, r) in results.iter().enumerate() {
            if let Some(o) = &r.info.outcome {
                outcomes.append((i, convert::outcome_dict(py, o)?))?;
            }
        }
        let reward: Vec<f32> = results.iter().map(|r| r.reward as f32).collect();
        let terminated: Vec<bool> = results.iter().map(|r| r.terminated).collect();
        let truncated: Vec<bool> = results.iter().map(|r| r.truncated).collect();
        PyTuple::new(
            py,
            [
                PyArray1::from_vec(py, next).reshape([m, width])?.into_any(),
                PyArray1::from_vec(py, reward).into_any(),
                PyArray1::from_vec(py, terminated).into_any(),
                PyArray1::from_vec(py, truncated).into_any(),
                PyArray1::from_vec(py, last).reshape([m, width])?.into_any(),
                outcomes.into_any(),
            ],
        )
    }

    /// Resets the environments `indices` now (their seed streams continue) and clears their pending
    /// next-step auto-reset: `(obs, info)` batched over `indices`, in that order.
    fn reset_envs<'py>(&self, py: Python<'py>, indices: Vec<usize>) -> PyResult<Bound<'py, PyTuple>> {
        let out = with_open(py, &self.inner, "reset_envs()", |vec| vec.reset_envs(&indices))?;
        self.reset_batch(py, out.into_iter().map(Some).collect())
    }

    /// The latest frames, `(num_envs, n, n)` uint8.
    fn frames<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.meta.frame_size as usize;
        let data = with_open(py, &self.inner, "render()", |vec| {
            let mut data = Vec::with_capacity(vec.num_envs() * n * n);
            for env in vec.envs() {
                let f = env.frame_u8();
                if f.len() == n * n {
                    data.extend_from_slice(&f);
                } else {
                    data.resize(data.len() + n * n, 0);
                }
            }
            Ok(data)
        })?;
        Ok(PyArray1::from_vec(py, data).reshape([self.num_envs, n, n])?.into_any())
    }
}

impl PyEscapeVectorEnv {
    /// Batched `(obs, info)` of a reset (every entry `Some`).
    fn reset_batch<'py>(
        &self,
        py: Python<'py>,
        out: Vec<Option<(loomlab_env::Observation, loomlab_env::StepInfo)>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let results: Vec<StepResult> = out
            .into_iter()
            .flatten()
            .map(|(obs, info)| StepResult {
                obs,
                reward: 0.0,
                terminated: false,
                truncated: false,
                info,
            })
            .collect();
        let batch = convert::Batch::new(py, &self.meta, &results)?;
        PyTuple::new(py, [batch.obs.into_any(), batch.info.into_any()])
    }

    fn step<'py>(&self, py: Python<'py>, actions: Vec<Action>) -> PyResult<Bound<'py, PyTuple>> {
        let results = with_open(py, &self.inner, "step()", |vec| vec.step(&actions))?;
        let batch = convert::Batch::new(py, &self.meta, &results)?;
        PyTuple::new(
            py,
            [
                batch.obs.into_any(),
                batch.reward.into_any(),
                batch.terminated.into_any(),
                batch.truncated.into_any(),
                batch.info.into_any(),
            ],
        )
    }
}

/// Names of the scenarios shipped inside the package.
#[pyfunction]
fn scenario_names() -> Vec<&'static str> {
    scenarios::BUILTIN.iter().map(|(name, _)| *name).collect()
}

/// The TOML text of a shipped scenario.
#[pyfunction]
fn scenario_toml(name: &str) -> PyResult<&'static str> {
    scenarios::builtin(name).map_err(to_py)
}

/// The ids of every built-in detector, in display order (the registry's: `hopfield`, `soc`,
/// `keil2004`, `cizek2019`, `fu2020`, …).
#[pyfunction]
fn detector_ids() -> Vec<&'static str> {
    loomlab_detector::detector_ids()
}

/// Raises the exception an environment error of this kind maps to (tests of the mapping).
#[pyfunction]
fn _raise(kind: &str) -> PyResult<()> {
    let e = match kind {
        "scenario" => EnvError::Scenario("test".into()),
        "render" => EnvError::Sim(loomlab_sim::SimError::NoRenderer),
        "detector" => EnvError::Detector(loomlab_detector::DetectorError::UnknownDetector("test".into())),
        "action" => EnvError::ActionCount { expected: 1, got: 2 },
        "seed" => EnvError::Seed {
            seed: "test".into(),
            reason: "test".into(),
        },
        _ => EnvError::State("test"),
    };
    Err(to_py(e))
}

/// A default config as a `{field: float}` dict (its serde form, so the keys are the option keys).
fn defaults_dict<'py, T: serde::Serialize>(py: Python<'py>, config: &T) -> PyResult<Bound<'py, PyDict>> {
    let value = serde_json::to_value(config).map_err(|e| errors::LoomlabError::new_err(e.to_string()))?;
    let d = PyDict::new(py);
    for (k, v) in value.as_object().into_iter().flatten() {
        let v = v
            .as_f64()
            .ok_or_else(|| errors::LoomlabError::new_err(format!("default {k} = {v} is not a number")))?;
        d.set_item(k, v)?;
    }
    Ok(d)
}

/// The serde (snake_case) name of a discrete action: `none`, `dodge_left`, …
fn snake_name(a: &DiscreteAction) -> PyResult<String> {
    match serde_json::to_value(a) {
        Ok(serde_json::Value::String(s)) => Ok(s),
        other => Err(errors::LoomlabError::new_err(format!("{a:?} has no name: {other:?}"))),
    }
}

/// On a machine of a few CPUs, has Mesa's llvmpipe rasterise on its queue thread unless the user
/// set `LP_NUM_THREADS` (`loomlab_sim::render::llvmpipe_threads`, the rule of `loomlab run`): the
/// vector env and `run_suite` keep every CPU busy. Set through `os.environ` at import, before any
/// environment creates the GPU context (Mesa reads it then), so Python sees the value too.
fn set_llvmpipe_threads(py: Python<'_>) -> PyResult<()> {
    use loomlab_sim::render::{LLVMPIPE_THREADS_ENV, llvmpipe_threads};
    let environ = py.import("os")?.getattr("environ")?;
    let user_set = environ.contains(LLVMPIPE_THREADS_ENV)?;
    if let Some(value) = llvmpipe_threads(loomlab_scenarios::runner::cpus(), true, user_set) {
        environ.set_item(LLVMPIPE_THREADS_ENV, value)?;
    }
    Ok(())
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    set_llvmpipe_threads(py)?;
    m.add_class::<PyEscapeEnv>()?;
    m.add_class::<PyEscapeVectorEnv>()?;
    m.add_class::<sweep::SweepPlan>()?;
    m.add_class::<run::RunRequest>()?;
    m.add_function(wrap_pyfunction!(run::run_suite, m)?)?;
    m.add_function(wrap_pyfunction!(run::run_cli, m)?)?;
    m.add_function(wrap_pyfunction!(detectors::_time_python_detector, m)?)?;
    m.add_function(wrap_pyfunction!(evaluation::evaluation_report, m)?)?;
    m.add_function(wrap_pyfunction!(evaluation::calibrate_thresholds, m)?)?;
    m.add_function(wrap_pyfunction!(scenario_names, m)?)?;
    m.add_function(wrap_pyfunction!(scenario_toml, m)?)?;
    m.add_function(wrap_pyfunction!(detector_ids, m)?)?;
    m.add_function(wrap_pyfunction!(_raise, m)?)?;
    errors::register(py, m)?;
    m.add("ROBOT_FIELDS", PyList::new(py, ROBOT_FIELDS)?)?;
    m.add("SIGNAL_LIMIT", loomlab_env::SIGNAL_LIMIT)?;
    m.add("ROBOT_LIMIT", loomlab_env::ROBOT_LIMIT)?;
    let scales = PyDict::new(py);
    for (k, v) in loomlab_env::features::FEATURE_SCALES {
        scales.set_item(k, v)?;
    }
    m.add("FEATURE_SCALES", scales)?;
    m.add("SENSOR_PROFILES", PyTuple::new(py, loomlab_sim::SENSOR_PROFILES)?)?;
    m.add(
        "OBS_MODES",
        PyTuple::new(
            py,
            [
                ObsMode::Raw.as_str(),
                ObsMode::Normalized.as_str(),
                ObsMode::Privileged.as_str(),
                ObsMode::Decision.as_str(),
            ],
        )?,
    )?;
    m.add("AGENT_LABEL", loomlab_env::AGENT_LABEL)?;
    m.add("REWARD_DEFAULTS", defaults_dict(py, &RewardConfig::default())?)?;
    m.add("ACTION_DEFAULTS", defaults_dict(py, &ActionConfig::default())?)?;
    let discrete: Vec<String> = DiscreteAction::ALL.iter().map(snake_name).collect::<PyResult<_>>()?;
    m.add("DISCRETE_ACTIONS", PyTuple::new(py, discrete)?)?;
    m.add("CONTINUOUS_ACTION_NAMES", PyTuple::new(py, ContinuousAction::NAMES)?)?;
    m.add("MANOEUVRE_ACTIONS", PyTuple::new(py, loomlab_env::MANOEUVRE_ACTIONS)?)?;
    m.add("DEFAULT_SUITE", loomlab_scenarios::DEFAULT_SUITE)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
