//! The session's report and bless steps: the results table and what the run did, then the
//! baseline written (`--bless`) or compared with (regressions listed, exit code 1).

use anyhow::Context as _;
use loomlab_scenarios::regression::{Tolerances, compare};
use loomlab_scenarios::report::Report;

use super::episodes::Ran;
use super::outputs::Written;
use super::{Engine, RunEnd, RunSession};

impl RunSession {
    /// The report step: prints the results table and what this invocation did (unless quiet),
    /// and the calibrated thresholds (`--calibrate`).
    pub(super) fn print_summary(&self, engine: &Engine, ran: &Ran, written: &Written) {
        let r = &self.plan.request;
        if !r.quiet {
            let work = &ran.work;
            let elapsed = ran.started.elapsed().as_secs_f64();
            outln!("{}", written.report.format_table(!r.brief).trim_end());
            outln!(
                "\nescape deadlines: {} physics-only replays for {} threats, {:.1} s of worker time",
                work.replays,
                work.deadlines,
                work.deadline_s
            );
            let earlier = if ran.resumed.is_empty() {
                String::new()
            } else {
                format!(" (plus {} episodes from the earlier run)", ran.resumed.len())
            };
            outln!(
                "\n{} episodes{earlier}, {} frames rendered in {elapsed:.1} s on {} ({} workers)",
                work.episodes,
                work.frames,
                engine.runner.adapter(),
                engine.runner.jobs()
            );
            if let Some(report_path) = &written.report_path {
                match &self.plan.request.out {
                    Some(out) if !r.no_plots => outln!(
                        "wrote {} and episodes.csv, plots in {}",
                        report_path.display(),
                        out.display()
                    ),
                    _ => outln!(
                        "wrote {} and episodes.csv (no plots: --no-plots)",
                        report_path.display()
                    ),
                }
            }
            if let Some(h) = &written.html {
                let again = if h.rerun > 0 {
                    format!(", {} of them from the earlier run simulated again", h.rerun)
                } else {
                    String::new()
                };
                outln!(
                    "wrote {} in {:.1} s ({:.1} % of this run's {elapsed:.1} s; {} exemplary episodes{again})",
                    h.path.display(),
                    h.secs,
                    100.0 * h.secs / elapsed,
                    h.exemplars
                );
            }
        }
        if let Some(target) = r.calibrate {
            outln!();
            crate::cli::calibrate::print_calibrations(&ran.outcomes, target, "this run's non-threat episodes");
        }
    }

    /// The bless step: writes the report to `--baseline` (`--bless`) or compares it with the
    /// baseline, listing every regression.
    pub(super) fn bless(&self, report: Report) -> anyhow::Result<RunEnd> {
        let r = &self.plan.request;
        let Some(path) = &r.baseline else {
            return Ok(RunEnd::Complete { report, regressions: 0 });
        };
        if r.bless {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
            }
            report.write_json(path)?;
            if !r.quiet {
                outln!("baseline written to {}", path.display());
            }
        } else if let Some(base) = &self.plan.baseline {
            let regressions = compare(&report, base, &Tolerances::default());
            if !regressions.is_empty() {
                errln!("{} regression(s) against {}:", regressions.len(), path.display());
                for reg in &regressions {
                    errln!("  {reg}");
                }
                let regressions = regressions.len();
                return Ok(RunEnd::Complete { report, regressions });
            }
            if !r.quiet {
                outln!("no regression against {}", path.display());
            }
        }
        Ok(RunEnd::Complete { report, regressions: 0 })
    }
}
