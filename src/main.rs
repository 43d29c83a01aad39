//! `loomlab`: closed-loop testbed for looming detectors. The binary parses arguments, dispatches to
//! one module per subcommand (`cli/`, in this package's library so that the Python package runs the
//! same `loomlab run`) and maps errors to exit codes; every capability lives in the library crates
//! (`loomlab-detector`, `loomlab-sim`, `loomlab-agents`, `loomlab-scenarios`).

use loomlab::cli;

use clap::{Parser, Subcommand};
use loomlab_sim::render::{LLVMPIPE_THREADS_ENV, llvmpipe_threads};

/// loomlab: a closed-loop testbed for vision-based looming (collision) detectors.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    // Subcommands are added here, one variant each, dispatching to cli::<name>::run.
    /// Calibrate detector thresholds to a false-alarm rate over the non-threat episodes of several
    /// runs pooled (held-out draws: the suite run with other --seed values).
    Calibrate(cli::calibrate::CalibrateArgs),
    /// Run looming detectors on a stimulus file or a video; writes responses.csv and a plot.
    Detect(cli::detect::DetectArgs),
    /// Regenerate the paper's artificial-video experiments (Figs. 3-8) as PNG + CSV.
    Figures(cli::figures::FiguresArgs),
    /// Render the robot's egocentric view of a simulated world: PNG frames, a GIF and truth.csv.
    Render(cli::render::RenderArgs),
    /// Run a scenario suite closed-loop (default: the default suite), print the results table and
    /// write report.json, episodes.csv and plots; with --baseline, exit 1 on regressions.
    Run(cli::run::RunArgs),
    /// Print a report.json's results as a Markdown table, or rewrite (--update) / check (--check)
    /// the generated tables of Markdown files, such as the README's (`make readme-table`).
    Table(cli::table::TableArgs),
}

fn main() {
    let cli = Cli::parse();
    if let Command::Run(args) = &cli.command {
        let cpus = loomlab_scenarios::runner::cpus();
        let user_set = std::env::var_os(LLVMPIPE_THREADS_ENV).is_some();
        if let Some(value) = llvmpipe_threads(cpus, args.jobs != Some(1), user_set) {
            // SAFETY: no other thread exists yet (clap parsed on this one, nothing was started),
            // so nothing reads the environment concurrently.
            unsafe { std::env::set_var(LLVMPIPE_THREADS_ENV, value) };
        }
    }
    let result: anyhow::Result<i32> = match cli.command {
        Command::Calibrate(a) => cli::calibrate::run(a),
        Command::Detect(a) => cli::detect::run(a),
        Command::Figures(a) => cli::figures::run(a),
        Command::Render(a) => cli::render::run(a),
        Command::Run(a) => cli::run::run(a),
        Command::Table(a) => cli::table::run(a),
    };
    match result {
        Ok(code) => std::process::exit(code),
        Err(e) => std::process::exit(cli::report_error(&e)),
    }
}
