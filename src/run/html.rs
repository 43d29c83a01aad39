//! `report.html`: the page a person reads, with every table and plot and, per scenario, a few
//! exemplary episodes (GIFs of the robot's view, traces); see `loomlab_report`.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context as _;
use loomlab_report::exemplar::{self, ExemplarRuns};
use loomlab_report::page::RunPage;
use loomlab_report::run_plots::{PlotSamples, run_figures};
use loomlab_report::{EXEMPLARS_DIR, REPORT_HTML};
use loomlab_scenarios::metrics::EpisodeOutcome;
use loomlab_scenarios::report::Report;
use loomlab_scenarios::{EpisodeRun, EpisodeSpec};
use loomlab_sim::GpuContext;
use rayon::prelude::*;

use super::episodes::Ran;
use super::folder::Writers;
use super::run_dir::RunDir;
use super::{Engine, RunSession};

/// The page as written: its path, the seconds it took, the exemplary episodes simulated again
/// (they ran in an earlier invocation) and the number of exemplars.
pub(super) struct HtmlWritten {
    /// `report.html`.
    pub path: PathBuf,
    /// Seconds spent on the page.
    pub secs: f64,
    /// Exemplary episodes simulated again.
    pub rerun: usize,
    /// Exemplary episodes on the page.
    pub exemplars: usize,
}

/// What `report.html` needs.
struct Html<'a> {
    run_dir: &'a RunDir,
    out: &'a Path,
    report: &'a Report,
    outcomes: &'a [EpisodeOutcome],
    samples: &'a PlotSamples,
    exemplar_runs: &'a ExemplarRuns,
    baseline: Option<(String, &'a Report)>,
}

impl RunSession {
    /// Writes the page; `None`: interrupted while writing it (the message printed).
    pub(super) fn write_html(
        &self,
        engine: &Engine,
        w: &mut Writers,
        report: &Report,
        ran: &Ran,
        samples: &PlotSamples,
    ) -> anyhow::Result<Option<HtmlWritten>> {
        let started = Instant::now();
        let out = w.dir.dir.clone();
        let page = Html {
            run_dir: &w.dir,
            out: &out,
            report,
            outcomes: &ran.outcomes,
            samples,
            exemplar_runs: &ran.exemplar_runs,
            baseline: match (&self.plan.request.baseline, &self.plan.baseline) {
                (Some(p), Some(b)) => Some((p.display().to_string(), b)),
                _ => None,
            },
        };
        let rerun = |scenario: &str, episode: usize| -> anyhow::Result<EpisodeRun> {
            Ok(engine.runner.run_episode(&self.plan.spec(scenario, episode)?)?)
        };
        let spec = |scenario: &str, episode: usize| self.plan.spec(scenario, episode);
        let gpu = engine.gpu.as_ref().context("report.html needs the run's GPU context")?;
        let written = page.write(gpu, &rerun, &spec);
        if written.is_err() && self.stopped(w)? {
            return Ok(None);
        }
        let (path, rerun, exemplars) = written?;
        Ok(Some(HtmlWritten {
            path,
            secs: started.elapsed().as_secs_f64(),
            rerun,
            exemplars,
        }))
    }
}

impl Html<'_> {
    /// Chooses the exemplary episodes from every episode, renders their GIFs (in parallel) and
    /// writes the page. `rerun` runs an episode that this invocation did not (a resumed run), `spec`
    /// gives an episode's specification. Returns the page's path, the episodes run again and the
    /// number of exemplars.
    fn write(
        &self,
        gpu: &Arc<GpuContext>,
        rerun: &(dyn Fn(&str, usize) -> anyhow::Result<EpisodeRun> + Sync),
        spec: &(dyn Fn(&str, usize) -> anyhow::Result<EpisodeSpec> + Sync),
    ) -> anyhow::Result<(PathBuf, usize, usize)> {
        let choices = exemplar::choose(self.outcomes);
        // the GIFs an earlier invocation of this run wrote go (never another file in the folder)
        for rel in self.run_dir.written() {
            if rel.starts_with(&format!("{EXEMPLARS_DIR}/")) && !rel.ends_with('/') {
                self.run_dir.remove_written(&rel)?;
            }
        }
        let gif_dir = if choices.is_empty() {
            self.out.join(EXEMPLARS_DIR)
        } else {
            self.run_dir.create_dir(EXEMPLARS_DIR)?
        };
        for c in &choices {
            self.run_dir.record(&format!("{EXEMPLARS_DIR}/{}", c.gif_name()))?;
            if !spec(&c.scenario, c.episode)?.world.camera.kind.is_frames() {
                self.run_dir
                    .record(&format!("{EXEMPLARS_DIR}/{}", c.events_gif_name()))?;
            }
        }
        self.run_dir.record(REPORT_HTML)?;
        let rerun_count = choices
            .iter()
            .filter(|c| self.exemplar_runs.get(&c.scenario, c.episode).is_none())
            .count();
        let exemplars = choices
            .par_iter()
            .map(|c| -> anyhow::Result<exemplar::Exemplar> {
                let again;
                let run = match self.exemplar_runs.get(&c.scenario, c.episode) {
                    Some(r) => r,
                    None => {
                        again = rerun(&c.scenario, c.episode)?;
                        &again
                    }
                };
                let spec = spec(&c.scenario, c.episode)?;
                Ok(exemplar::build(gpu, &spec, run, c, &gif_dir, EXEMPLARS_DIR)?)
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let count = exemplars.len();
        let page = RunPage {
            report: self.report,
            title: format!("loomlab run: {}", self.report.suite),
            facts: vec![("command".into(), std::env::args().collect::<Vec<_>>().join(" "))],
            figures: run_figures(self.report, self.outcomes, Some(self.samples)),
            exemplars,
            baseline: self.baseline.clone(),
            notes: Vec::new(),
        };
        let path = page.write(self.out)?;
        debug_assert!(path.ends_with(REPORT_HTML));
        Ok((path, rerun_count, count))
    }
}
