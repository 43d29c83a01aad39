//! loomlab-report: every plot loomlab draws and the `report.html` pages of runs and sweeps.
//!
//! - [`plot`]: line charts, grids and rate bars, drawn as PNG files or as SVG text by the same code;
//! - [`run_plots`]: the plots of a run ([`run_plots::run_figures`]) and the trace CSVs of `--traces`;
//! - [`exemplar`]: the few episodes per scenario the page shows as evidence (first miss, first
//!   false alarm, first hit), their frames re-rendered and written as GIFs with the alarms marked;
//! - [`page`]: the run page (`report.html`): summary and per-scenario tables, plots, exemplars, the
//!   comparison with a baseline report;
//! - [`markdown`]: the Markdown tables the README and `docs/results.md` quote from the committed
//!   baseline report, between marker comments (`loomlab table`, `make readme-table`);
//! - [`sweep_page`]: the sweep page: ranking table and hit-rate-vs-false-alarm-rate scatter,
//!   each point linking to its own run page.
//!
//! Pages are self-contained: inline CSS, a little inline JavaScript (sortable tables), inline SVG;
//! the GIFs lie beside the page. Nothing is fetched from the network.

pub mod exemplar;
pub mod html;
pub mod markdown;
pub mod page;
pub mod plot;
pub mod run_plots;
pub mod sweep_page;

/// Errors while writing a report page.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] plot::PlotError),
    /// A file could not be written or read.
    #[error("{path}: {reason}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// Re-simulating an exemplar episode failed.
    #[error("exemplar {scenario} episode {episode}: {reason}")]
    Exemplar {
        /// Scenario name.
        scenario: String,
        /// Episode index in the scenario.
        episode: usize,
        /// What went wrong.
        reason: String,
    },
    /// A sweep folder is not what the sweep writes.
    #[error("{path}: {reason}")]
    Sweep {
        /// The file.
        path: String,
        /// What is wrong and how to fix it.
        reason: String,
    },
}

impl ReportError {
    pub(crate) fn io(path: &std::path::Path, e: impl std::fmt::Display) -> Self {
        Self::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        }
    }
}

/// The page's file name in a run or sweep folder.
pub const REPORT_HTML: &str = "report.html";
/// The folder beside the page holding the exemplar GIFs.
pub const EXEMPLARS_DIR: &str = "exemplars";
