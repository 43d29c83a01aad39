//! `loomlab table`: a report's results as Markdown tables; rewrites (`--update`) or checks
//! (`--check`) the generated tables of documents, the README's among them (`make readme-table`).
//!
//! The tables live between marker comments (`<!-- results-table:begin -->` …
//! `<!-- results-table:end -->`); the block names and their contents are
//! `loomlab_report::markdown::BLOCKS`. Exit codes: 0 done (or up to date), 1 `--check` found a
//! stale block (each named on stderr with the command that regenerates it), 2 bad input.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use loomlab_report::markdown::{
    REGENERATE, render_block, stale_compare_blocks, stale_tagged_blocks, update_compare_blocks, update_tagged_blocks,
    valid_tag,
};
use loomlab_scenarios::report::Report;

/// Arguments of `loomlab table`.
#[derive(Debug, Args)]
pub struct TableArgs {
    /// The report.json to read (e.g. out/run/report.json, or the committed baseline
    /// scenarios/baseline/default-report.json).
    #[arg(value_name = "REPORT.json")]
    pub report: PathBuf,
    /// Rewrite the generated blocks of this Markdown file from the report (repeatable). Without
    /// it the README's table is printed.
    #[arg(long, value_name = "FILE.md")]
    pub update: Vec<PathBuf>,
    /// With --update: write nothing, exit 1 if a file's blocks differ from the report's numbers.
    #[arg(long, requires = "update")]
    pub check: bool,
    /// With --update: rewrite (or check) the blocks tagged with this suite tag
    /// (`<!-- results-table@TAG:begin -->`, e.g. `heldout`) instead of the untagged ones, which are
    /// the default suite's.
    #[arg(long, requires = "update", value_name = "TAG")]
    pub tag: Option<String>,
    /// With --update: rewrite (or check) only the comparison blocks (`results-robot`: per row, the
    /// evasion and false-alarm rates under REPORT.json's sensor and this report's, e.g. the
    /// `robot` profile's scenarios/baseline/default-robot-report.json, and the change) instead of
    /// REPORT.json's own blocks.
    #[arg(long, requires = "update", conflicts_with = "tag", value_name = "OTHER.json")]
    pub compare: Option<PathBuf>,
}

/// Runs `loomlab table`.
pub fn run(args: TableArgs) -> anyhow::Result<i32> {
    if let Some(tag) = args.tag.as_deref().filter(|t| !valid_tag(t)) {
        bail!("--tag `{tag}`: a suite tag is made of lower-case letters, digits, `_` and `-` (e.g. `--tag heldout`)");
    }
    let tag = args.tag.as_deref();
    let report = Report::read_json(&args.report)?;
    let other = args.compare.as_deref().map(Report::read_json).transpose()?;
    if args.update.is_empty() {
        outln!(
            "{}",
            render_block("results-table", &report).unwrap_or_default().trim_end()
        );
        return Ok(0);
    }
    let mut stale = 0;
    for file in &args.update {
        let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
        if args.check {
            let names = match &other {
                Some(other) => stale_compare_blocks(&text, &report, other),
                None => stale_tagged_blocks(&text, &report, tag),
            }
            .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
            for name in &names {
                errln!(
                    "{}: the generated block `{name}` disagrees with {}{}; regenerate it with `{REGENERATE}`",
                    file.display(),
                    args.report.display(),
                    args.compare
                        .as_ref()
                        .map_or(String::new(), |o| format!(" and {}", o.display()))
                );
            }
            stale += names.len();
            continue;
        }
        let (new, blocks) = match &other {
            Some(other) => update_compare_blocks(&text, &report, other),
            None => update_tagged_blocks(&text, &report, tag),
        }
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
        if blocks == 0 && other.is_some() {
            bail!(
                "{}: no comparison block (`<!-- results-robot:begin -->` … `:end -->`) for --compare",
                file.display()
            );
        }
        if blocks == 0 {
            bail!(
                "{}: no generated block (`<!-- results-table:begin -->` … `:end -->`)",
                file.display()
            );
        }
        if new != text {
            std::fs::write(file, new).with_context(|| format!("cannot write {}", file.display()))?;
            outln!("{}: {blocks} generated block(s) rewritten", file.display());
        } else {
            outln!("{}: {blocks} generated block(s) up to date", file.display());
        }
    }
    Ok(if stale > 0 { 1 } else { 0 })
}
