//! The `loomlab` command line as a library: `src/main.rs` parses arguments and dispatches here, and
//! the Python package (`python -m loomlab run`, `loomlab.run_suite(out=...)`) runs the same
//! `loomlab run` in-process with its Python detectors ([`run::RunSession`]).

/// `println!` that never panics: a closed stdout (`loomlab run … | head -1`) stops the printing,
/// not the program (its files and run state are what matter; see docs/reference.md, "loomlab run").
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// `eprintln!` that never panics (a closed stderr is ignored).
#[macro_export]
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

pub mod cli;
pub mod run;
