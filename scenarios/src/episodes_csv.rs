//! `episodes.csv`: one row per episode × detector, written as the run goes, read back to rebuild a
//! report from a partial run.
//!
//! Columns (see [`HEADER`]): `scenario,episode,seed,params,detector,threat,t_contact_s,t_alarm_s,
//! outcome,collision,ttc_at_alarm_s,angular_size_at_alarm_deg,max_signal,lead_s,t_deadline_s,
//! deadline_lead_s,evadable,l_over_v_s,eye_ttc_at_alarm_s,theta_rel_err_median,theta_rel_err_p90,
//! theta_at_first_estimate_deg,triggers,impact_speed_mps,impulse_ns,theta_required_deg,
//! collision_caused,t_in_view_s`
//! (`theta_required_deg`: the true angular size of an evadable threat at its escape deadline, the
//! same on every row of the episode; `collision_caused`: the row's own escape manoeuvre caused the
//! collision, a false alarm or a hit that collided, see [`crate::metrics`]; `t_in_view_s`: the
//! first time a threat is in the camera's view, the same on every row). `params` is a
//! compact JSON object of the episode's swept/sampled values (`{"speed_kmh":"50"}`), quoted as CSV
//! requires; booleans are `true`/`false`; absent values are empty cells; numbers are written in
//! Rust's shortest round-trip form, so a read gives back exactly what was written. `lead_s`
//! (`t_c − t_a` for hits), `deadline_lead_s` (`t_c − t_dl`), `evadable` (a threat with a
//! deadline) and `collision_caused` are derived and ignored on reading; files written before
//! `collision_caused` or `t_in_view_s` existed (the last columns) still read ([`OPTIONAL_ON_READ`]). Fields are quoted per RFC 4180 when they
//! hold a comma, quote or line break.
//!
//! Crash safety: [`EpisodesCsvWriter::write_episode`] writes all rows of an episode with one
//! `write_all` and flushes, so an interrupted run keeps every finished episode. Reading drops a
//! final line without its newline (a write cut short); [`EpisodesCsvWriter::append`] truncates
//! such a line before appending.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::metrics::{DetectorEpisode, EpisodeOutcome, Outcome, ScoringError};

/// The column names, in order (new columns are appended, so that tools reading columns by position
/// keep working).
pub const HEADER: [&str; 28] = [
    "scenario",
    "episode",
    "seed",
    "params",
    "detector",
    "threat",
    "t_contact_s",
    "t_alarm_s",
    "outcome",
    "collision",
    "ttc_at_alarm_s",
    "angular_size_at_alarm_deg",
    "max_signal",
    "lead_s",
    "t_deadline_s",
    "deadline_lead_s",
    "evadable",
    "l_over_v_s",
    "eye_ttc_at_alarm_s",
    "theta_rel_err_median",
    "theta_rel_err_p90",
    "theta_at_first_estimate_deg",
    "triggers",
    "impact_speed_mps",
    "impulse_ns",
    "theta_required_deg",
    "collision_caused",
    "t_in_view_s",
];

/// Columns added after the first release of the format: a file without them still reads (the
/// derived `collision_caused`; `t_in_view_s`, then unknown).
pub const OPTIONAL_ON_READ: [&str; 2] = ["collision_caused", "t_in_view_s"];

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ScoringError + '_ {
    move |source| ScoringError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Quote a field per RFC 4180 when it holds a comma, quote or line break.
pub(crate) fn quote(field: &str) -> String {
    if field.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.into()
    }
}

fn opt(v: Option<f64>) -> String {
    v.filter(|v| v.is_finite()).map_or_else(String::new, |v| v.to_string())
}

/// The header line, with its newline.
pub fn header_line() -> String {
    HEADER.join(",") + "\n"
}

/// Format the rows of one episode (one per detector), each ending in `\n`.
pub fn format_rows(episode: &EpisodeOutcome) -> String {
    let params = serde_json::to_string(&episode.params).expect("a string map always serialises");
    let mut out = String::new();
    for d in &episode.detectors {
        let cells = [
            quote(&episode.scenario),
            episode.episode.to_string(),
            episode.seed.to_string(),
            quote(&params),
            quote(&d.detector),
            d.threat.to_string(),
            opt(d.t_contact_s),
            opt(d.t_alarm_s),
            d.outcome.to_string(),
            d.collision.to_string(),
            opt(d.ttc_at_alarm_s),
            opt(d.angular_size_at_alarm_deg),
            opt(d.max_signal),
            opt(d.lead_s()),
            opt(d.t_deadline_s),
            opt(d.deadline_lead_s()),
            d.evadable().to_string(),
            opt(d.l_over_v_s),
            opt(d.eye_ttc_at_alarm_s),
            opt(d.theta_rel_err_median),
            opt(d.theta_rel_err_p90),
            opt(d.theta_at_first_estimate_deg),
            d.triggers.to_string(),
            opt(d.impact_speed_mps),
            opt(d.impulse_ns),
            opt(d.theta_required_deg),
            d.collision_caused().to_string(),
            opt(d.t_in_view_s),
        ];
        out += &cells.join(",");
        out.push('\n');
    }
    out
}

/// Appends episodes to an `episodes.csv` as they finish.
#[derive(Debug)]
pub struct EpisodesCsvWriter {
    file: File,
    path: PathBuf,
}

impl EpisodesCsvWriter {
    /// Create (or truncate) `path` and write the header.
    pub fn create(path: &Path) -> Result<Self, ScoringError> {
        let mut file = File::create(path).map_err(io_err(path))?;
        file.write_all(header_line().as_bytes()).map_err(io_err(path))?;
        file.flush().map_err(io_err(path))?;
        Ok(Self {
            file,
            path: path.into(),
        })
    }

    /// Open `path` for appending (resuming a run). A missing or empty file gets the header; an
    /// existing one must have the same header (else an error: it was written by another
    /// version), and a final line cut short by a crash is removed first.
    pub fn append(path: &Path) -> Result<Self, ScoringError> {
        let mut file = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(path)
            .map_err(io_err(path))?;
        let mut text = String::new();
        file.read_to_string(&mut text).map_err(io_err(path))?;
        if text.is_empty() {
            file.write_all(header_line().as_bytes()).map_err(io_err(path))?;
        } else {
            let first = text.lines().next().unwrap_or("");
            if first != HEADER.join(",") {
                return Err(ScoringError::Csv {
                    path: path.into(),
                    line: 1,
                    reason: format!(
                        "header `{first}` differs from this version's `{}`; write to a new output folder",
                        HEADER.join(",")
                    ),
                });
            }
            if !text.ends_with('\n') {
                let keep = text.rfind('\n').map_or(0, |i| i + 1) as u64;
                file.set_len(keep).map_err(io_err(path))?;
                file.seek(SeekFrom::End(0)).map_err(io_err(path))?;
            }
        }
        file.flush().map_err(io_err(path))?;
        Ok(Self {
            file,
            path: path.into(),
        })
    }

    /// Write all rows of one episode and flush.
    pub fn write_episode(&mut self, episode: &EpisodeOutcome) -> Result<(), ScoringError> {
        self.file
            .write_all(format_rows(episode).as_bytes())
            .map_err(io_err(&self.path))?;
        self.file.flush().map_err(io_err(&self.path))
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// One CSV record: 1-based line of its start, fields, and whether a newline terminated it.
struct Record {
    line: usize,
    fields: Vec<String>,
    terminated: bool,
}

fn split_records(text: &str) -> Vec<Record> {
    let mut records = Vec::new();
    let mut fields = Vec::new();
    let mut field = String::new();
    let mut in_quotes = false;
    let mut line = 1;
    let mut start_line = 1;
    let mut chars = text.chars().peekable();
    let mut any = false;
    while let Some(c) = chars.next() {
        any = true;
        if in_quotes {
            match c {
                '"' if chars.peek() == Some(&'"') => {
                    chars.next();
                    field.push('"');
                }
                '"' => in_quotes = false,
                '\n' => {
                    line += 1;
                    field.push(c);
                }
                _ => field.push(c),
            }
            continue;
        }
        match c {
            '"' => in_quotes = true,
            ',' => fields.push(std::mem::take(&mut field)),
            '\r' if chars.peek() == Some(&'\n') => {}
            '\n' => {
                fields.push(std::mem::take(&mut field));
                records.push(Record {
                    line: start_line,
                    fields: std::mem::take(&mut fields),
                    terminated: true,
                });
                line += 1;
                start_line = line;
                any = false;
            }
            _ => field.push(c),
        }
    }
    if any {
        fields.push(field);
        records.push(Record {
            line: start_line,
            fields,
            terminated: false,
        });
    }
    records
}

/// Parse `episodes.csv` text; `origin` names the source in errors. Rows are grouped into episodes
/// by (scenario, episode, seed) in order of first appearance. A final unterminated line is dropped.
pub fn parse_episodes_csv(text: &str, origin: &Path) -> Result<Vec<EpisodeOutcome>, ScoringError> {
    let err = |line: usize, reason: String| ScoringError::Csv {
        path: origin.to_path_buf(),
        line,
        reason,
    };
    let mut records = split_records(text);
    if records.last().is_some_and(|r| !r.terminated) {
        records.pop();
    }
    let mut records = records.into_iter();
    let Some(header) = records.next() else {
        return Err(err(1, "empty file: expected the episodes.csv header".into()));
    };
    let mut col = BTreeMap::new();
    for name in HEADER {
        let found = header.fields.iter().position(|h| h == name);
        if found.is_none() && OPTIONAL_ON_READ.contains(&name) {
            continue;
        }
        let i = found.ok_or_else(|| {
            err(
                1,
                format!("missing column `{name}` (expected columns: {})", HEADER.join(",")),
            )
        })?;
        col.insert(name, i);
    }
    let mut episodes: Vec<EpisodeOutcome> = Vec::new();
    let mut index: BTreeMap<(String, usize, u64), usize> = BTreeMap::new();
    for r in records {
        if r.fields.len() == 1 && r.fields[0].is_empty() {
            continue; // blank line
        }
        if r.fields.len() != header.fields.len() {
            return Err(err(
                r.line,
                format!("{} fields, the header has {}", r.fields.len(), header.fields.len()),
            ));
        }
        let get = |name: &str| col.get(name).map_or("", |&i| r.fields[i].as_str());
        let parse_f = |name: &str| -> Result<Option<f64>, ScoringError> {
            let s = get(name);
            if s.is_empty() {
                return Ok(None);
            }
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Some)
                .ok_or_else(|| err(r.line, format!("column `{name}`: `{s}` is not a finite number")))
        };
        let parse_b = |name: &str| match get(name) {
            "true" => Ok(true),
            "false" => Ok(false),
            s => Err(err(r.line, format!("column `{name}`: `{s}` is not true/false"))),
        };
        let episode: usize = get("episode").parse().map_err(|_| {
            err(
                r.line,
                format!("column `episode`: `{}` is not an index", get("episode")),
            )
        })?;
        let seed: u64 = get("seed")
            .parse()
            .map_err(|_| err(r.line, format!("column `seed`: `{}` is not a seed", get("seed"))))?;
        let params: BTreeMap<String, String> = serde_json::from_str(get("params"))
            .map_err(|e| err(r.line, format!("column `params`: not a JSON object of strings: {e}")))?;
        let outcome: Outcome = get("outcome")
            .parse()
            .map_err(|e| err(r.line, format!("column `outcome`: {e}")))?;
        let detector = DetectorEpisode {
            detector: get("detector").to_string(),
            threat: parse_b("threat")?,
            t_contact_s: parse_f("t_contact_s")?,
            t_deadline_s: parse_f("t_deadline_s")?,
            t_alarm_s: parse_f("t_alarm_s")?,
            outcome,
            collision: parse_b("collision")?,
            impact_speed_mps: parse_f("impact_speed_mps")?,
            impulse_ns: parse_f("impulse_ns")?,
            theta_required_deg: parse_f("theta_required_deg")?,
            t_in_view_s: parse_f("t_in_view_s")?,
            ttc_at_alarm_s: parse_f("ttc_at_alarm_s")?,
            angular_size_at_alarm_deg: parse_f("angular_size_at_alarm_deg")?,
            max_signal: parse_f("max_signal")?,
            l_over_v_s: parse_f("l_over_v_s")?,
            eye_ttc_at_alarm_s: parse_f("eye_ttc_at_alarm_s")?,
            theta_rel_err_median: parse_f("theta_rel_err_median")?,
            theta_rel_err_p90: parse_f("theta_rel_err_p90")?,
            theta_at_first_estimate_deg: parse_f("theta_at_first_estimate_deg")?,
            triggers: get("triggers").parse().map_err(|_| {
                err(
                    r.line,
                    format!("column `triggers`: `{}` is not a count", get("triggers")),
                )
            })?,
            trace: None,
        };
        let key = (get("scenario").to_string(), episode, seed);
        let slot = *index.entry(key).or_insert_with(|| {
            episodes.push(EpisodeOutcome {
                scenario: get("scenario").to_string(),
                episode,
                seed,
                params,
                detectors: Vec::new(),
            });
            episodes.len() - 1
        });
        episodes[slot].detectors.push(detector);
    }
    Ok(episodes)
}

/// Read an `episodes.csv` file (see [`parse_episodes_csv`]).
pub fn read_episodes_csv(path: &Path) -> Result<Vec<EpisodeOutcome>, ScoringError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    parse_episodes_csv(&text, path)
}
