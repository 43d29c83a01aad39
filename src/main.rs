//! `loomlab`: closed-loop testbed for looming detectors. The binary parses arguments, dispatches to
//! one module per subcommand (`cli/`, in this package's library so that the Python package runs the
//! same `loomlab run`) and maps errors to exit codes; every capability lives in the library crates
//! (`loomlab-detector`, `loomlab-sim`, `loomlab-agents`, `loomlab-scenarios`).

use loomlab::cli;

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

/// Most CPUs on which `loomlab run` has llvmpipe rasterise on its queue thread (see
/// [`llvmpipe_threads`]): rendering is about a sixth of a run's CPU time, so one queue thread keeps
/// up with the workers of a few CPUs, not with those of many.
const MAX_CPUS_FOR_QUEUE_RASTERIZER: usize = 4;

/// The `LP_NUM_THREADS` that `loomlab run` sets on a machine of `cpus` CPUs when the user has not
/// set it and asked for more than one worker (`None`: leave it alone). On Mesa's llvmpipe
/// (lavapipe, the software Vulkan of a machine without a GPU) every render pass otherwise hands
/// its tiles to llvmpipe's own rasterizer threads, one per CPU, while the run already keeps every
/// CPU busy with its workers: the hand-offs and wake-ups cost more than they save (default suite,
/// 2 workers on 2 CPUs: 155 → 132 s wall, 244 → 216 s CPU, the same pixels and report). `0` has
/// llvmpipe rasterise on its queue thread; other drivers ignore the variable.
fn llvmpipe_threads(cpus: usize, jobs: Option<usize>, user_set: bool) -> Option<&'static str> {
    let several_workers = jobs != Some(1);
    (!user_set && several_workers && cpus <= MAX_CPUS_FOR_QUEUE_RASTERIZER).then_some("0")
}

fn main() {
    let cli = Cli::parse();
    if let Command::Run(args) = &cli.command {
        let cpus = loomlab_scenarios::runner::cpus();
        if let Some(value) = llvmpipe_threads(cpus, args.jobs, std::env::var_os("LP_NUM_THREADS").is_some()) {
            // SAFETY: no other thread exists yet (clap parsed on this one, nothing was started),
            // so nothing reads the environment concurrently.
            unsafe { std::env::set_var("LP_NUM_THREADS", value) };
        }
    }
    let result: anyhow::Result<i32> = match cli.command {
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

#[cfg(test)]
mod tests {
    use super::llvmpipe_threads;

    #[test]
    fn llvmpipe_rasterises_on_its_queue_thread_on_a_few_cpus_unless_the_user_chose() {
        assert_eq!(llvmpipe_threads(2, None, false), Some("0"));
        assert_eq!(llvmpipe_threads(4, Some(8), false), Some("0"));
        // one worker: llvmpipe's threads use the CPUs the run leaves idle
        assert_eq!(llvmpipe_threads(2, Some(1), false), None);
        // many CPUs: one queue thread would not keep up with their workers' renders
        assert_eq!(llvmpipe_threads(16, None, false), None);
        assert_eq!(llvmpipe_threads(2, None, true), None);
    }
}
