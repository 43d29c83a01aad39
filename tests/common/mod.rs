//! Helpers shared by the CLI's integration tests: scratch folders and running the binary.
#![allow(dead_code)] // each test binary uses a part

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh scratch folder `<tmp>/loomlab-<test>-<pid>-<name>`.
pub fn tmp(test: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("loomlab-{test}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The `loomlab` binary, run from the repository root.
pub fn loomlab_command() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_loomlab"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

/// Runs `loomlab ARGS` to completion.
pub fn loomlab(args: &[&str]) -> Output {
    loomlab_command().args(args).output().expect("run the loomlab binary")
}

/// Process output as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A path as `&str`.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
