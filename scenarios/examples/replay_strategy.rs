//! Replays a decision strategy on the open-loop traces of a run, in seconds instead of a new run
//! (`loomlab_scenarios::replay`): a quick way to try a τ window or a gate setting before running
//! the suite.
//!
//! ```sh
//! loomlab run --traces --out out/traced
//! cargo run --release -p loomlab-scenarios --example replay_strategy -- out/traced tracker_tau \
//!     'tau_window_s = 0.2' 'course_window_s = 0.35'
//! ```
//!
//! Arguments: the run folder, the label of a row with a τ trigger or course gate, then any number
//! of `escape.*` settings as TOML lines (`key = value`, over `trigger = "tau"`, `course = "image"`
//! and the controller's defaults, as in the default suite's τ rows). Prints the row's open-loop
//! hits (first alarm about the threat no later than its escape deadline) and false alarms, as
//! recorded and as replayed, and on how many frames the decision values differ (none with the
//! run's own parameters). The closed loop (evasion) needs a run. The robot's body and camera are
//! the defaults (`loomlab_agents::RobotFacts::default`: a 60° camera, a 0.2 m half-width body).

use std::path::Path;
use std::process::ExitCode;

use loomlab_agents::EscapeConfig;
use loomlab_scenarios::replay::replay_run;

fn run(args: &[String]) -> Result<(), String> {
    let [dir, label, settings @ ..] = args else {
        return Err("usage: replay_strategy RUN_DIR LABEL ['key = value' ...]   (see the file's docs)".into());
    };
    let toml = format!("trigger = \"tau\"\ncourse = \"image\"\n{}", settings.join("\n"));
    let config: EscapeConfig = toml::from_str(&toml).map_err(|e| {
        format!("the settings {settings:?} are not escape settings ({e}); write them as TOML lines, e.g. 'tau_window_s = 0.2'")
    })?;
    config
        .validate()
        .map_err(|e| format!("the settings {settings:?}: {e}"))?;
    let r = replay_run(Path::new(dir), label, &config, &loomlab_agents::RobotFacts::default())?;
    println!("{label}, {} episodes, open loop:", r.episodes);
    println!("  recorded: {}", r.recorded);
    println!("  replayed: {}", r.replayed);
    println!(
        "  decision values differing from the recorded ones on {} of {} frames",
        r.differing, r.frames
    );
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("replay_strategy: {e}");
            ExitCode::FAILURE
        }
    }
}
