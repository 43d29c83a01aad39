//! Glue of `loomlab.sweep`: planning, running and merging sweep shards
//! ([`loomlab_scenarios::sweep`]), and the runner kept per process (`loomlab.run_suite` without a
//! run folder uses it too, see `run.rs`). Scheduling (Ray, resume, progress) lives in the
//! pure-Python `loomlab/sweep.py`.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use pyo3::prelude::*;

use loomlab_scenarios::sweep::{SweepDir, SweepError, format_ranking};
use loomlab_scenarios::{RunError, Runner};

use crate::errors;

/// Maps a sweep error to its Python exception.
fn to_py(e: SweepError) -> PyErr {
    let msg = e.to_string();
    match e {
        SweepError::Scenario(_) => errors::ScenarioError::new_err(msg),
        SweepError::Run(r) => run_to_py(r),
        _ => errors::SweepError::new_err(msg),
    }
}

pub(crate) fn run_to_py(e: RunError) -> PyErr {
    let msg = e.to_string();
    match e {
        RunError::Gpu(_) | RunError::Sim { .. } => errors::RenderError::new_err(msg),
        RunError::Detector { .. } => errors::DetectorError::new_err(msg),
        _ => errors::LoomlabError::new_err(msg),
    }
}

/// One runner (GPU context, renderer pool, worker threads) per process, made on first use and
/// kept for later shards: Ray reuses worker processes, so each pays the GPU start-up once.
pub(crate) fn runner(jobs: Option<usize>) -> Result<Arc<Runner>, RunError> {
    static RUNNER: Mutex<Option<Arc<Runner>>> = Mutex::new(None);
    let mut slot = RUNNER.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(r) = slot.as_ref()
        && jobs.is_none_or(|j| j.max(1) == r.jobs())
    {
        return Ok(Arc::clone(r));
    }
    let r = Arc::new(Runner::new(jobs)?);
    *slot = Some(Arc::clone(&r));
    Ok(r)
}

/// A planned sweep: the sweep file parsed, its suite expanded, its shards cut.
#[pyclass(frozen, module = "loomlab._native")]
pub struct SweepPlan {
    plan: loomlab_scenarios::sweep::SweepPlan,
}

#[pymethods]
impl SweepPlan {
    /// Parses the sweep file at `path` and plans it (`limit` overrides the file's `limit`).
    #[new]
    #[pyo3(signature = (path, limit = None))]
    fn new(py: Python<'_>, path: PathBuf, limit: Option<usize>) -> PyResult<Self> {
        if limit == Some(0) {
            return Err(errors::ScenarioError::new_err("limit must be at least 1"));
        }
        let plan = py
            .detach(|| loomlab_scenarios::sweep::SweepPlan::load(&path, limit))
            .map_err(to_py)?;
        Ok(Self { plan })
    }

    /// The sweep's name (default output folder `out/sweep/<name>`).
    #[getter]
    fn name(&self) -> String {
        self.plan.file.name.clone()
    }

    /// The sweep file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.plan.file.path.clone()
    }

    /// The suite, as written into the reports.
    #[getter]
    fn suite(&self) -> String {
        self.plan.file.suite.display().to_string()
    }

    /// Fingerprint of everything that determines the results.
    #[getter]
    fn fingerprint(&self) -> String {
        self.plan.fingerprint.clone()
    }

    /// Number of episodes.
    #[getter]
    fn episode_count(&self) -> usize {
        self.plan.episodes.len()
    }

    /// Number of shards.
    #[getter]
    fn shard_count(&self) -> usize {
        self.plan.shards.len()
    }

    /// Every point: `(label, detector id, {key: value})`.
    fn points(&self) -> Vec<(String, String, BTreeMap<String, String>)> {
        self.plan
            .file
            .points
            .iter()
            .map(|p| (p.label.clone(), p.detector.id.clone(), p.values.clone()))
            .collect()
    }

    /// Shard `i` as `(first episode, end episode, first point, end point)`.
    fn shard(&self, i: usize) -> PyResult<(usize, usize, usize, usize)> {
        let s = self.plan.shards.get(i).ok_or_else(|| {
            errors::SweepError::new_err(format!("no shard {i}; the sweep has {}", self.plan.shards.len()))
        })?;
        Ok((s.episodes.start, s.episodes.end, s.points.start, s.points.end))
    }

    /// Runs shard `i` on `jobs` threads (default: every CPU) and returns its rows (episodes.csv
    /// text). The GIL is released while it runs.
    #[pyo3(signature = (i, jobs = None))]
    fn run_shard(&self, py: Python<'_>, i: usize, jobs: Option<usize>) -> PyResult<String> {
        let outcomes = py
            .detach(|| -> Result<_, SweepError> { self.plan.run_shard(&*runner(jobs)?, i) })
            .map_err(to_py)?;
        Ok(loomlab_scenarios::sweep::SweepPlan::shard_csv(&outcomes))
    }

    /// Opens the output folder (see `loomlab_scenarios::sweep`); returns which shards are done.
    #[pyo3(signature = (out, restart = false))]
    fn open_out(&self, out: PathBuf, restart: bool) -> PyResult<Vec<bool>> {
        let dir = SweepDir::open(&out, &self.plan, restart).map_err(to_py)?;
        Ok(dir.done(&self.plan))
    }

    /// Checks shard `i`'s rows and writes them to the output folder atomically.
    fn write_shard(&self, out: PathBuf, i: usize, csv: &str) -> PyResult<()> {
        SweepDir { root: out }.write_shard(&self.plan, i, csv).map_err(to_py)
    }

    /// Merges every shard of the output folder into per-point reports, the ranking and the
    /// summary, and writes the sweep's `report.html` (ranking and scatter, each point linking to
    /// its own `points/<label>/report.html`, written too); returns the ranking as a text table of
    /// its first `top` rows.
    #[pyo3(signature = (out, wall_time_s, top = 10))]
    fn finish(&self, py: Python<'_>, out: PathBuf, wall_time_s: f64, top: usize) -> PyResult<String> {
        let table = py
            .detach(|| -> Result<String, SweepError> {
                let dir = SweepDir { root: out.clone() };
                let shards = dir.read_shards(&self.plan)?;
                let results = self.plan.merge(&shards, wall_time_s)?;
                let order = dir.write_results(&self.plan, &results)?;
                Ok(format_ranking(&self.plan, &results, &order, top))
            })
            .map_err(to_py)?;
        py.detach(|| loomlab_report::sweep_page::write_sweep_pages(&out))
            .map_err(|e| errors::SweepError::new_err(e.to_string()))?;
        Ok(table)
    }
}
