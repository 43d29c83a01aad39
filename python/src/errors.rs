//! The Python exception tree and the mapping from Rust errors.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

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
        ErrorKind::Other => LoomlabError::new_err(msg),
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
