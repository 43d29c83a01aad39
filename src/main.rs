//! `loomlab`: closed-loop testbed for looming detectors. The binary parses arguments, dispatches to
//! one module per subcommand (`cli/`, in this package's library so that the Python package runs the
//! same `loomlab run`) and maps errors to exit codes; every capability lives in the library crates
//! (`loomlab-detector`, `loomlab-sim`, `loomlab-agents`, `loomlab-scenarios`).

use loomlab::{cli, errln};

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
    // Subcommands are added here, one variant each, dispatching to cli::<name>::run.
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

/// Exit code of a failure to write an output (disk full, permissions): not the user's input.
const EXIT_IO: i32 = 3;

fn main() {
    let cli = Cli::parse();
    let result: anyhow::Result<i32> = match cli.command {
        Command::Detect(a) => cli::detect::run(a),
        Command::Figures(a) => cli::figures::run(a),
        Command::Render(a) => cli::render::run(a),
        Command::Run(a) => cli::run::run(a),
        Command::Table(a) => cli::table::run(a),
    };
    match result {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            // the chain of causes, each once (a message that already quotes its cause, like
            // "cannot read F: No such file", is not followed by the cause again)
            let mut text = String::new();
            for cause in e.chain() {
                let c = cause.to_string();
                if !text.contains(&c) {
                    if !text.is_empty() {
                        text += ": ";
                    }
                    text += &c;
                }
            }
            errln!("error: {text}");
            if let Some(cmd) = cli::run_dir::RESUME_HINT
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take()
            {
                errln!("the finished episodes are saved; resume with:\n  {cmd}");
            }
            // 3: an output could not be written (disk full, permissions), 2: bad input
            let io = e.downcast_ref::<cli::run_dir::CannotWrite>().is_some();
            std::process::exit(if io { EXIT_IO } else { 2 });
        }
    }
}
