//! `loomlab.run_suite` and `python -m loomlab run`: a [`RunSession`] of the `loomlab` crate (the
//! CLI's `loomlab run`), in this process, with Python detectors added to the suite's rows.
//! `run_suite` passes a typed [`RunRequest`] (this module's `loomlab._native.RunRequest`: keyword
//! arguments, not argv); `python -m loomlab run` passes the user's `loomlab run` flags, parsed by
//! the CLI's own parser. Either writes the same run folder (episodes.csv, report.json, plots,
//! report.html, manifest.json) and resumes the same way, and is refused for the same reasons
//! ([`loomlab::run::RunRequest::check`]).
//!
//! Ctrl-C: the run works on another thread while this one, holding the GIL only for a moment every
//! 50 ms, lets Python handle its signals; the first KeyboardInterrupt stops the run as the CLI's
//! first Ctrl-C does (no new episode starts, those in flight give up, every finished one is saved,
//! the folder says `interrupted` and `--resume` continues it). A second KeyboardInterrupt stops at
//! once as the CLI's second Ctrl-C does: the run in progress is marked `interrupted` (its finished
//! episodes are saved), the resume command is printed and the process exits with 130.

use std::path::PathBuf;
use std::time::Duration;

use clap::Parser;
use pyo3::exceptions::{PyKeyboardInterrupt, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use loomlab::cli::run::{RunArgs, run_session};
use loomlab::run::{EntryTable, EntryValue, Interrupt, RequestError, RunContext, RunEnd, RunFailure, RunSession};
use loomlab_scenarios::{RunError, ScenarioError};

use crate::detectors::{PythonEntry, registry_with};
use crate::errors::{self, Seed};

/// `loomlab run`'s arguments, parsed as the CLI parses them.
#[derive(Parser)]
#[command(
    name = "loomlab run",
    about = "Run a scenario suite closed-loop (see `loomlab run --help`)"
)]
struct RunCommand {
    #[command(flatten)]
    args: RunArgs,
}

/// Runs `f` on another thread while this one handles Python's signals; the first
/// KeyboardInterrupt (or other exception a signal handler raises) stops `interrupt` and is
/// returned with `f`'s result once `f` is done; a second one ends the process at once
/// ([`Interrupt::second`]).
pub(crate) fn interruptible<R: Send>(
    py: Python<'_>,
    interrupt: &Interrupt,
    f: impl FnOnce() -> R + Send,
) -> (R, Option<PyErr>) {
    let mut caught: Option<PyErr> = None;
    let result = py.detach(|| {
        std::thread::scope(|s| {
            let worker = s.spawn(f);
            while !worker.is_finished() {
                std::thread::sleep(Duration::from_millis(50));
                if let Err(e) = Python::attach(|py| py.check_signals()) {
                    if caught.is_some() {
                        interrupt.second();
                    }
                    interrupt.stop();
                    caught = Some(e);
                }
            }
            worker.join()
        })
    });
    match result {
        Ok(r) => (r, caught),
        Err(panic) => std::panic::resume_unwind(panic),
    }
}

/// Runs `loomlab run ARGS…` in this process with the Python detectors `detectors`
/// (`loomlab.PythonDetector`s) added to every scenario's rows; returns the CLI's exit code (0 done,
/// 1 regressions, 2 bad input, 3 an output not written, 130 interrupted), printing what the CLI
/// prints, errors included. `command` is the command line a resume message shows.
#[pyfunction]
#[pyo3(signature = (args, detectors, command = None))]
pub fn run_cli(
    py: Python<'_>,
    args: Vec<String>,
    detectors: Vec<Bound<'_, PyAny>>,
    command: Option<Vec<String>>,
) -> PyResult<i32> {
    let parsed = match RunCommand::try_parse_from(std::iter::once("loomlab run".to_string()).chain(args)) {
        Ok(p) => p,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return Ok(code);
        }
    };
    let entries = detectors.iter().map(PythonEntry::read).collect::<PyResult<Vec<_>>>()?;
    let (registry, added_detectors) = registry_with(entries)?;
    let interrupt = Interrupt::new();
    let context = RunContext {
        registry,
        added_detectors,
        interrupt: interrupt.clone(),
    };
    let request = parsed.args.into_request(command);
    let (result, caught) = interruptible(py, &interrupt, move || run_session(request, context));
    Ok(match result {
        _ if caught.is_some() => 130,
        Ok(code) => code,
        // as the CLI reports it
        Err(e) => loomlab::cli::report_error(&e),
    })
}

/// What `loomlab.run_suite` asks for: its keyword arguments, typed (the fields of
/// `loomlab::run::RunRequest` a Python caller sets). Checked when run, as the CLI's flags are.
#[pyclass(frozen, module = "loomlab._native")]
pub struct RunRequest {
    request: loomlab::run::RunRequest,
}

#[pymethods]
impl RunRequest {
    /// `suite`: a folder, list file or scenario file; `out`: the run folder (`None`: nothing is
    /// written); `detectors`: ids; `entries`: `[[detectors]]` entries as dicts (after
    /// `detectors_file`'s); `limit`, `jobs`, `size`: ints (a float or bool is a TypeError).
    #[new]
    #[pyo3(signature = (suite, *, out = None, seed = Seed(0), size = None, limit = None, detectors = None, detectors_file = None, entries = Vec::new(), jobs = None, resume = false))]
    #[pyo3(
        text_signature = "(suite, *, out=None, seed=0, size=None, limit=None, detectors=None, detectors_file=None, entries=[], jobs=None, resume=False)"
    )]
    #[allow(clippy::too_many_arguments)] // the Python keyword arguments
    fn new(
        suite: PathBuf,
        out: Option<PathBuf>,
        seed: Seed,
        size: Option<Bound<'_, PyAny>>,
        limit: Option<Bound<'_, PyAny>>,
        detectors: Option<Vec<String>>,
        detectors_file: Option<PathBuf>,
        entries: Vec<Bound<'_, PyDict>>,
        jobs: Option<Bound<'_, PyAny>>,
        resume: bool,
    ) -> PyResult<Self> {
        let request = loomlab::run::RunRequest {
            suite: Some(suite),
            out,
            seed: seed.0,
            size: size.map(|v| int("size", &v, "the frame size in pixels")).transpose()?,
            limit: limit
                .map(|v| int("limit", &v, "the number of episodes to run; None: all of them"))
                .transpose()?,
            detectors,
            detectors_file,
            detector_entries: entries.iter().map(entry_table).collect::<PyResult<_>>()?,
            jobs: jobs
                .map(|v| int("jobs", &v, "episodes run in parallel; None: one per CPU"))
                .transpose()?,
            resume,
            quiet: true,
            ..Default::default()
        };
        Ok(Self { request })
    }

    /// The run folder (`None`: nothing is written).
    #[getter]
    fn out(&self) -> Option<PathBuf> {
        self.request.out.clone()
    }

    fn __repr__(&self) -> String {
        format!("RunRequest({:?})", self.request)
    }
}

/// `value` as an integer: an int (or an object with `__index__`), not a bool or a float.
fn int(name: &str, value: &Bound<'_, PyAny>, meaning: &str) -> PyResult<i64> {
    let wrong = || {
        let shown = value.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
        PyTypeError::new_err(format!("run_suite: {name}={shown} must be an int >= 1 ({meaning})"))
    };
    if value.is_instance_of::<PyBool>() {
        return Err(wrong());
    }
    let index = value.py().import("operator")?.getattr("index")?;
    let index = index.call1((value,)).map_err(|_| wrong())?;
    index.extract::<i64>().map_err(|_| wrong())
}

/// A `[[detectors]]` entry given as a dict, as a table (keys as written; numbers as given, a NaN
/// included: the request's check names it).
fn entry_table(dict: &Bound<'_, PyDict>) -> PyResult<EntryTable> {
    let mut table = EntryTable::new();
    for (k, v) in dict.iter() {
        let key = k.str()?.to_string();
        let value = entry_value(&key, &v)?;
        table.insert(key, value);
    }
    Ok(table)
}

/// A value of a detector entry: a bool, int, float, str, list/tuple or dict.
fn entry_value(key: &str, v: &Bound<'_, PyAny>) -> PyResult<EntryValue> {
    Ok(if v.is_instance_of::<PyBool>() {
        EntryValue::Boolean(v.extract()?)
    } else if v.is_instance_of::<PyInt>() {
        EntryValue::Integer(v.extract()?)
    } else if v.is_instance_of::<PyFloat>() {
        EntryValue::Float(v.extract()?)
    } else if v.is_instance_of::<PyString>() {
        EntryValue::String(v.extract()?)
    } else if let Ok(d) = v.cast::<PyDict>() {
        EntryValue::Table(entry_table(d)?)
    } else if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v.try_iter()?.map(|x| entry_value(key, &x?)).collect::<PyResult<_>>()?;
        EntryValue::Array(items)
    } else {
        let shown = v.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
        return Err(PyTypeError::new_err(format!(
            "run_suite: a detectors entry's `{key}` = {shown}; give a bool, int, float, str, list or dict"
        )));
    })
}

/// Runs `request` in this process with the Python detectors `python` added to every scenario's
/// rows and returns its report as JSON text (what report.json holds). Bad input raises what it
/// is (ValueError, TypeError, ScenarioError, DetectorError, ...). Ctrl-C: without a run folder the
/// episodes in flight finish, then KeyboardInterrupt; with one it stops as the CLI's Ctrl-C does
/// (every finished episode saved, KeyboardInterrupt raised; `resume=True` continues).
#[pyfunction]
pub fn run_suite(py: Python<'_>, request: &Bound<'_, RunRequest>, python: Vec<Bound<'_, PyAny>>) -> PyResult<String> {
    let python = python.iter().map(PythonEntry::read).collect::<PyResult<Vec<_>>>()?;
    let (registry, added_detectors) = registry_with(python)?;
    let request = request.get().request.clone();
    let out = request.out.clone();
    let interrupt = Interrupt::new();
    let context = RunContext {
        registry,
        added_detectors,
        interrupt: interrupt.clone(),
    };
    let failed = |error| RunFailure { error, resume: None };
    let work = move || -> Result<RunEnd, RunFailure> {
        let mut session = RunSession::new(request, context).map_err(failed)?;
        if session.plan().request.out.is_none() {
            let runner = crate::sweep::runner(session.plan().request.workers()).map_err(|e| failed(e.into()))?;
            session = session.with_runner(runner);
        }
        session.run()
    };
    let (result, caught) = interruptible(py, &interrupt, work);
    match (result, out) {
        (Ok(RunEnd::Complete { report, .. }), _) if caught.is_none() => Ok(report.to_json()),
        (Err(failure), _) if caught.is_none() => Err(to_py(&failure)),
        (_, None) => Err(caught.unwrap_or_else(|| PyKeyboardInterrupt::new_err("run_suite: interrupted"))),
        (_, Some(out)) => Err(PyKeyboardInterrupt::new_err(format!(
            "run_suite: interrupted; the finished episodes are saved in {} (resume=True)",
            out.display()
        ))),
    }
}

/// The Python exception of an error a session stopped on (when its folder holds finished
/// episodes, the message says that `resume=True` continues them).
fn to_py(failure: &RunFailure) -> PyErr {
    let e = &failure.error;
    let mut msg = loomlab::cli::error_text(e);
    if failure.resume.is_some() {
        msg += "; the finished episodes are saved: resume=True continues the run";
    }
    if let Some(r) = e.downcast_ref::<RequestError>() {
        return match r {
            RequestError::AtLeastOne { field, value } => PyValueError::new_err(format!(
                "run_suite: {}={value} must be at least 1 ({}; `loomlab run {}` refuses it too)",
                field.keyword(),
                field.meaning(),
                field.flag()
            )),
            RequestError::ResumeWithoutOut => PyValueError::new_err(
                "run_suite: resume=True continues the run folder given as out=...; give out= (the folder of the \
                 interrupted run)",
            ),
            RequestError::UnknownDetector { .. } | RequestError::NotFinite { .. } => {
                errors::ScenarioError::new_err(format!("run_suite: {msg}"))
            }
            _ => PyValueError::new_err(format!("run_suite: {msg}")),
        };
    }
    for cause in e.chain() {
        if let Some(r) = cause.downcast_ref::<RunError>() {
            return match r {
                RunError::Gpu(_) | RunError::Sim { .. } => errors::RenderError::new_err(msg),
                RunError::Detector { .. } => errors::DetectorError::new_err(msg),
                _ => errors::LoomlabError::new_err(msg),
            };
        }
        if cause.downcast_ref::<ScenarioError>().is_some() {
            return errors::ScenarioError::new_err(msg);
        }
        if cause.downcast_ref::<loomlab_detector::DetectorError>().is_some() {
            return errors::DetectorError::new_err(msg);
        }
    }
    errors::LoomlabError::new_err(msg)
}
