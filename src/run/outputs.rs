//! The session's outputs step: the report of every finished episode, written to `report.json`
//! (or `report.partial.json` when interrupted), then the plots and the page. An interrupt while
//! they are written stops after the file being written; the run stays resumable.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Context as _;
use loomlab_report::run_plots::{EpisodeSamples, PlotSamples, run_figures};
use loomlab_scenarios::report::{Report, ReportMeta};

use super::episodes::Ran;
use super::folder::Writers;
use super::html::HtmlWritten;
use super::run_dir::{CannotWrite, EPISODES_CSV, PARTIAL_REPORT, REPORT, RunState, write_atomic};
use super::{Engine, RunSession};

/// What the outputs step wrote.
pub(super) struct Written {
    /// The report of the whole run.
    pub report: Report,
    /// `report.json` (none without a run folder).
    pub report_path: Option<PathBuf>,
    /// The page, when written.
    pub html: Option<HtmlWritten>,
}

impl RunSession {
    /// The report's facts: the suite, the seed, the wall time of every invocation of the run so
    /// far (recorded in the manifest) and the lead margin.
    pub(super) fn meta(&self, writers: Option<&mut Writers>, ran: &Ran) -> ReportMeta {
        let mut wall_time_s = ran.started.elapsed().as_secs_f64();
        if let Some(w) = writers {
            wall_time_s += w.dir.manifest.wall_time_s;
            w.dir.manifest.wall_time_s = wall_time_s;
        }
        ReportMeta {
            suite: self.plan.suite_path.display().to_string(),
            seed: self.plan.request.seed,
            wall_time_s,
            lead_margin_s: self.plan.lead_margin_s,
        }
    }

    /// An interrupted run keeps what is done (`report.partial.json`) and says how to go on.
    pub(super) fn save_interrupted(
        &self,
        writers: Option<&mut Writers>,
        ran: &Ran,
        meta: &ReportMeta,
    ) -> anyhow::Result<()> {
        let Some(w) = writers else { return Ok(()) };
        let out = w.dir.dir.clone();
        if !ran.outcomes.is_empty() {
            let mut partial = Report::from_tiered_episodes(meta, &ran.outcomes, &self.plan.tiers);
            partial.sensor_profile = self.plan.suite.sensor.map(String::from);
            w.dir.record(PARTIAL_REPORT)?;
            write_atomic(&out.join(PARTIAL_REPORT), (partial.to_json() + "\n").as_bytes())?;
        }
        w.dir.set_state(RunState::Interrupted)?;
        errln!(
            "interrupted: {} of {} episodes done ({} this time), saved in {}; {} holds their scores. Resume with:\n  {}",
            ran.outcomes.len(),
            self.plan.total,
            ran.work.episodes,
            out.join(EPISODES_CSV).display(),
            if ran.outcomes.is_empty() {
                "nothing yet"
            } else {
                PARTIAL_REPORT
            },
            w.dir.manifest.resume_command()
        );
        Ok(())
    }

    /// The outputs step of a run whose every episode is done: report.json, the plots, the page,
    /// then the state `complete`. `None`: interrupted while writing them (the message printed).
    pub(super) fn write_outputs(
        &self,
        engine: &Engine,
        writers: Option<&mut Writers>,
        ran: &Ran,
        meta: &ReportMeta,
    ) -> anyhow::Result<Option<Written>> {
        let mut report = Report::from_tiered_episodes(meta, &ran.outcomes, &self.plan.tiers);
        report.sensor_profile = self.plan.suite.sensor.map(String::from);
        let Some(w) = writers else {
            return Ok(Some(Written {
                report,
                report_path: None,
                html: None,
            }));
        };
        let r = &self.plan.request;
        let out = w.dir.dir.clone();
        let report_path = out.join(REPORT);
        w.dir.record(REPORT)?;
        write_atomic(&report_path, (report.to_json() + "\n").as_bytes())?;
        let _ = std::fs::remove_file(out.join(PARTIAL_REPORT));
        // every episode is done: an interrupt now stops the report writing (the run stays resumable)
        self.interrupt.writing_report();
        if self.stopped(w)? {
            return Ok(None);
        }
        let Some(samples) = self.plot_samples(engine, w, ran)? else {
            return Ok(None);
        };
        if !r.no_plots && !self.write_plots(w, &report, ran, &samples)? {
            return Ok(None);
        }
        let html = if r.no_html {
            None
        } else {
            match self.write_html(engine, w, &report, ran, &samples)? {
                Some(h) => Some(h),
                None => return Ok(None),
            }
        };
        if self.stopped(w)? {
            return Ok(None);
        }
        w.dir.set_state(RunState::Complete)?;
        Ok(Some(Written {
            report,
            report_path: Some(report_path),
            html,
        }))
    }

    /// Whether the run was interrupted while its report is written: if so the state says
    /// `interrupted` and the message says how to write the rest.
    pub(super) fn stopped(&self, w: &mut Writers) -> anyhow::Result<bool> {
        if !self.interrupt.stopped() {
            return Ok(false);
        }
        w.dir.set_state(RunState::Interrupted)?;
        errln!(
            "interrupted while writing the report: all {} episodes are saved in {}. Write the rest with:\n  {}",
            self.plan.total,
            w.dir.dir.join(EPISODES_CSV).display(),
            w.dir.manifest.resume_command()
        );
        Ok(true)
    }

    /// The plots' samples from every episode, this invocation's and earlier ones' (in suite
    /// order), with the sample episode (trace.png, the page's trace plot) unless nothing is drawn.
    /// `None`: interrupted while the sample episode was simulated again.
    fn plot_samples(&self, engine: &Engine, w: &mut Writers, ran: &Ran) -> anyhow::Result<Option<PlotSamples>> {
        let r = &self.plan.request;
        let text = std::fs::read_to_string(&w.samples_path)
            .with_context(|| CannotWrite(format!("cannot read {}", w.samples_path.display())))?;
        let mut by_pos: BTreeMap<usize, EpisodeSamples> = BTreeMap::new();
        for line in text.lines() {
            if let Some(es) = EpisodeSamples::from_line(line)
                && let Some(p) = self.plan.position(&es.scenario, es.episode)
            {
                by_pos.insert(p, es); // a later line (an episode run again) replaces an earlier one
            }
        }
        let mut all = PlotSamples::default();
        for es in by_pos.values() {
            all.add_points(es);
        }
        if let Some(best) = by_pos.values().min_by_key(|es| es.rank)
            && !(r.no_plots && r.no_html)
        {
            let live = ran
                .samples
                .sample()
                .filter(|s| s.outcome.scenario == best.scenario && s.outcome.episode == best.episode);
            let run = match live {
                Some(s) => s.clone(),
                // the sample episode ran in an earlier invocation: simulate it again (deterministic)
                None => match engine
                    .runner
                    .run_episode(&self.plan.spec(&best.scenario, best.episode)?)
                {
                    Ok(s) => s,
                    Err(e) => {
                        if self.stopped(w)? {
                            return Ok(None);
                        }
                        return Err(e.into());
                    }
                },
            };
            all.set_sample(run);
        }
        Ok(Some(all))
    }

    /// The PNG plots, each through a temporary file; `false`: interrupted after one of them.
    fn write_plots(&self, w: &mut Writers, report: &Report, ran: &Ran, samples: &PlotSamples) -> anyhow::Result<bool> {
        let out = w.dir.dir.clone();
        for f in run_figures(report, &ran.outcomes, Some(samples)) {
            // through a temporary file (same extension: the encoder goes by it), listed first
            let name = format!("{}.png", f.name);
            let tmp = format!(".{}.tmp.png", f.name);
            w.dir.record(&name)?;
            w.dir.record(&tmp)?;
            f.write_png(&out.join(&tmp))
                .with_context(|| CannotWrite(format!("cannot write {}", out.join(&name).display())))?;
            std::fs::rename(out.join(&tmp), out.join(&name))
                .with_context(|| CannotWrite(format!("cannot write {}", out.join(&name).display())))?;
            if self.stopped(w)? {
                return Ok(false);
            }
        }
        Ok(true)
    }
}
