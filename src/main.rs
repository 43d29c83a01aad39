//! `loomlab`: closed-loop testbed for looming detectors. Thin binary over `loomlab::cli`.

use clap::{Parser, Subcommand};

/// loomlab: a closed-loop testbed for vision-based looming (collision) detectors.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    // Subcommands are added here, one variant each, dispatching to loomlab::cli::<name>::run.
    /// Run looming detectors on a stimulus file or a video; writes responses.csv and a plot.
    Detect(loomlab::cli::detect::DetectArgs),
    /// Regenerate the paper's artificial-video experiments (Figs. 3-8) as PNG + CSV.
    Figures(loomlab::cli::figures::FiguresArgs),
    /// Render the robot's egocentric view of a simulated world: PNG frames, a GIF and truth.csv.
    Render(loomlab::cli::render::RenderArgs),
    /// Run a scenario suite closed-loop (default: the default suite), print the results table and
    /// write report.json, episodes.csv and plots; with --baseline, exit 1 on regressions.
    Run(loomlab::cli::run::RunArgs),
}

fn main() {
    let cli = Cli::parse();
    let result: anyhow::Result<i32> = match cli.command {
        Command::Detect(a) => loomlab::cli::detect::run(a),
        Command::Figures(a) => loomlab::cli::figures::run(a),
        Command::Render(a) => loomlab::cli::render::run(a),
        Command::Run(a) => loomlab::cli::run::run(a),
    };
    match result {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(2);
        }
    }
}
