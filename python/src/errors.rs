//! The Python exception tree and the mapping from Rust errors.

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyType};

use loomlab_env::{EnvError, ErrorKind};

create_exception!(
    loomlab,
    LoomlabError,
    PyException,
    "Base class of every error raised by loomlab."
);
create_exception!(
    loomlab,
    ScenarioError,
    LoomlabError,
    "A scenario could not be found, read, parsed or expanded, or an environment option is invalid."
);
create_exception!(
    loomlab,
    RenderError,
    LoomlabError,
    "No GPU adapter (install mesa-vulkan-drivers for a CPU one), or rendering failed."
);
create_exception!(
    loomlab,
    DetectorError,
    LoomlabError,
    "A detector id is unknown, a detector parameter is invalid or a detector failed."
);
create_exception!(
    loomlab,
    ActionError,
    LoomlabError,
    "An action has the wrong shape or type, is out of range or not finite."
);

create_exception!(
    loomlab,
    SweepError,
    LoomlabError,
    "A sweep's output folder holds another sweep, or a shard's results do not match the plan."
);

/// Maps an environment error to its Python exception (the message is the Rust error's).
pub fn to_py(e: EnvError) -> PyErr {
    let msg = e.to_string();
    match e.kind() {
        ErrorKind::Scenario => ScenarioError::new_err(msg),
        ErrorKind::Render => RenderError::new_err(msg),
        ErrorKind::Detector => DetectorError::new_err(msg),
        ErrorKind::Action => ActionError::new_err(msg),
        ErrorKind::Seed => PyValueError::new_err(msg),
        ErrorKind::Other => LoomlabError::new_err(msg),
    }
}

/// The error of using a closed environment: Gymnasium's `gymnasium.error.ClosedEnvironmentError`
/// (a `RuntimeError` where Gymnasium cannot be imported). `what` is the call, e.g. `step()`.
pub fn closed(py: Python<'_>, what: &str) -> PyErr {
    let msg = format!("{what} called on a closed environment; close() released it, so make a new environment");
    let cls = py
        .import("gymnasium.error")
        .and_then(|m| m.getattr("ClosedEnvironmentError"))
        .ok()
        .and_then(|c| c.cast_into::<PyType>().ok());
    match cls {
        Some(cls) => PyErr::from_type(cls, msg),
        None => PyRuntimeError::new_err(msg),
    }
}

/// A seed: a Python `int` in [0, 2^64) (never wrapped around; a `bool` is no seed). Anything else
/// raises `ValueError` naming the seed.
#[derive(Debug, Clone, Copy)]
pub struct Seed(pub u64);

impl<'a, 'py> FromPyObject<'a, 'py> for Seed {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let bad = |why: &str| {
            let shown = obj.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
            PyValueError::new_err(format!("seed must be an integer in [0, 2**64), got {shown}{why}"))
        };
        if obj.is_instance_of::<PyBool>() {
            return Err(bad(" (a bool)"));
        }
        // `__index__`: Python and numpy integers, not floats or strings
        let Ok(index) = obj.call_method0("__index__") else {
            return Err(bad(""));
        };
        index
            .extract::<u64>()
            .map(Seed)
            .map_err(|_| bad(": seeds never wrap around"))
    }
}

/// Adds the exception classes to the module.
pub fn register(py: Python<'_>, m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LoomlabError", py.get_type::<LoomlabError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("RenderError", py.get_type::<RenderError>())?;
    m.add("DetectorError", py.get_type::<DetectorError>())?;
    m.add("ActionError", py.get_type::<ActionError>())?;
    m.add("SweepError", py.get_type::<SweepError>())?;
    Ok(())
}
