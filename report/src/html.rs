//! Pieces shared by the pages: escaping, number formats, sortable tables, the inline style and
//! script.

use std::fmt::Write as _;

use loomlab_scenarios::metrics::DetectorSummary;
use loomlab_scenarios::reference::is_reference;
use loomlab_scenarios::stats::Interval;

/// Escapes text for HTML element content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Percent-encodes one path segment for an `href` (letters, digits and `-_.~` stay).
pub fn url_segment(text: &str) -> String {
    let mut out = String::new();
    for b in text.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

/// An `id` attribute value for a name (letters, digits, `-`, `_`; others become `_`).
pub fn anchor(prefix: &str, name: &str) -> String {
    let body: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!("{prefix}-{body}")
}

/// A rate as a percentage with one decimal, `n/a` when undefined.
pub fn pct(v: Option<f64>) -> String {
    v.filter(|v| v.is_finite())
        .map_or("n/a".into(), |v| format!("{:.1}%", 100.0 * v))
}

/// A rate with its 95 % interval.
pub fn rate_ci(v: Option<f64>, ci: Option<Interval>) -> String {
    match (v.filter(|v| v.is_finite()), ci) {
        (Some(v), Some(ci)) => format!(
            "{:.1}% <small>[{:.0}–{:.0}]</small>",
            100.0 * v,
            100.0 * ci.lower,
            100.0 * ci.upper
        ),
        (v, _) => pct(v),
    }
}

/// A number with `digits` decimals, `n/a` when undefined.
pub fn num(v: Option<f64>, digits: usize) -> String {
    v.filter(|v| v.is_finite())
        .map_or("n/a".into(), |v| format!("{v:.digits$}"))
}

/// A table cell with a sort key (`data-v`: numbers sort numerically, the rest as text).
pub fn cell(html: &str, key: Option<f64>) -> String {
    match key.filter(|v| v.is_finite()) {
        Some(k) => format!("<td data-v=\"{k}\">{html}</td>"),
        None => format!("<td data-v=\"\">{html}</td>"),
    }
}

/// A text cell.
pub fn text_cell(text: &str) -> String {
    format!("<td>{}</td>", escape(text))
}

/// A sortable table: click a header to sort by that column.
pub fn table(class: &str, headers: &[&str], rows: &[(String, Vec<String>)]) -> String {
    let mut out = format!("<table class=\"sortable {class}\"><thead><tr>");
    for h in headers {
        let _ = write!(out, "<th title=\"click to sort\">{h}</th>");
    }
    out.push_str("</tr></thead><tbody>\n");
    for (row_class, cells) in rows {
        let _ = writeln!(out, "<tr class=\"{row_class}\">{}</tr>", cells.concat());
    }
    out.push_str("</tbody></table>\n");
    out
}

/// The headers of [`summary_rows`].
pub const SUMMARY_HEADERS: [&str; 14] = [
    "detector",
    "episodes",
    "hits",
    "misses",
    "false alarms",
    "hit rate [95% CI]",
    "false-alarm rate [95% CI]",
    "collision rate [95% CI]",
    "evasion rate [95% CI]",
    "AUC",
    "mean lead (s)",
    "θ at alarm (deg)",
    "collision reduction",
    "collisions caused (false alarms + hits)",
];

/// One row per detector of a summary table; reference rows (class `ref`) after the detectors.
pub fn summary_rows<'a>(
    detectors: impl Iterator<Item = (&'a String, &'a DetectorSummary)>,
) -> Vec<(String, Vec<String>)> {
    let (mut dets, mut refs) = (Vec::new(), Vec::new());
    for (label, s) in detectors {
        let cells = vec![
            if is_reference(label) {
                format!("<td>{} <small>(reference)</small></td>", escape(label))
            } else {
                text_cell(label)
            },
            cell(&s.episodes.to_string(), Some(s.episodes as f64)),
            cell(&s.hits.to_string(), Some(s.hits as f64)),
            cell(&s.misses.to_string(), Some(s.misses as f64)),
            cell(&s.false_alarms.to_string(), Some(s.false_alarms as f64)),
            cell(&rate_ci(s.hit_rate, s.hit_rate_ci), s.hit_rate),
            cell(&rate_ci(s.false_alarm_rate, s.false_alarm_rate_ci), s.false_alarm_rate),
            cell(&rate_ci(s.collision_rate, s.collision_rate_ci), s.collision_rate),
            cell(&rate_ci(s.evasion_rate, s.evasion_rate_ci), s.evasion_rate),
            cell(&num(s.auc, 3), s.auc),
            cell(&num(s.mean_lead_s, 3), s.mean_lead_s),
            cell(
                &num(s.mean_angular_size_at_alarm_deg, 1),
                s.mean_angular_size_at_alarm_deg,
            ),
            cell(&pct(s.collision_reduction), s.collision_reduction),
            cell(
                &format!(
                    "{} ({} + {})",
                    s.collisions_caused, s.false_alarm_collisions, s.hit_collisions
                ),
                Some(s.collisions_caused as f64),
            ),
        ];
        if is_reference(label) {
            refs.push(("ref".to_string(), cells));
        } else {
            dets.push((String::new(), cells));
        }
    }
    dets.extend(refs);
    dets
}

/// The inline style sheet.
pub const STYLE: &str = r#"
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto; max-width: 1360px; padding: 0 16px 48px; color: #1d232a; }
h1 { font-size: 1.6em; margin: 18px 0 4px; } h2 { margin-top: 32px; border-bottom: 1px solid #d0d7de; padding-bottom: 4px; }
h3 { margin: 22px 0 6px; } .meta { color: #57606a; font-size: 0.92em; }
nav a { margin-right: 12px; } code { background: #f3f4f6; padding: 1px 4px; border-radius: 3px; }
table { border-collapse: collapse; font-size: 0.88em; margin: 8px 0 12px; }
th, td { border: 1px solid #d0d7de; padding: 3px 8px; text-align: right; white-space: nowrap; }
th { background: #f6f8fa; cursor: pointer; user-select: none; }
th.asc::after { content: " ▲"; } th.desc::after { content: " ▼"; }
td:first-child, th:first-child { text-align: left; }
tr.ref td { color: #57606a; background: #fafbfc; font-style: italic; }
tr.worse td { background: #ffebe9; } tr.better td { background: #dafbe1; }
.figures { display: flex; flex-wrap: wrap; gap: 16px; } figure { margin: 0; }
figcaption { font-size: 0.85em; color: #57606a; max-width: 760px; }
svg { max-width: 100%; height: auto; }
.exemplars { display: flex; flex-wrap: wrap; gap: 18px; }
.exemplar { border: 1px solid #d0d7de; border-radius: 6px; padding: 8px; display: flex; gap: 10px; align-items: flex-start; }
.exemplar img.view { width: 192px; image-rendering: pixelated; border: 1px solid #d0d7de; }
.exemplar .facts { font-size: 0.82em; max-width: 280px; } .exemplar .facts table { font-size: 0.95em; }
.exemplar .facts td, .exemplar .facts th { padding: 1px 4px; }
.tag { display: inline-block; padding: 0 6px; border-radius: 10px; background: #ddf4ff; margin: 1px 2px; font-size: 0.9em; }
.tag.miss { background: #ffebe9; } .tag.false_alarm { background: #fff8c5; } .tag.hit { background: #dafbe1; }
.note { background: #f6f8fa; border-left: 3px solid #8c959f; padding: 6px 10px; font-size: 0.9em; }
"#;

/// The inline script: sortable tables (no network, no library).
pub const SCRIPT: &str = r#"
var sortable = document.querySelectorAll('table.sortable');
sortable.forEach(function (table) {
  var heads = table.querySelectorAll('th');
  heads.forEach(function (th, col) {
    th.addEventListener('click', function () {
      var asc = !th.classList.contains('asc');
      heads.forEach(function (h) { h.classList.remove('asc', 'desc'); });
      th.classList.add(asc ? 'asc' : 'desc');
      var body = table.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      rows.sort(function (a, b) {
        var x = a.cells[col], y = b.cells[col];
        var xv = x.getAttribute('data-v'), yv = y.getAttribute('data-v');
        var r;
        if (xv !== null && yv !== null) {
          if (xv === '' && yv === '') r = 0; else if (xv === '') r = 1; else if (yv === '') r = -1;
          else r = parseFloat(xv) - parseFloat(yv);
        } else r = x.textContent.localeCompare(y.textContent);
        return asc ? r : -r;
      });
      rows.forEach(function (row) { body.appendChild(row); });
    });
  });
});
document.body.setAttribute('data-sortable-tables', String(sortable.length));
"#;

/// A whole page around `body`.
pub fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{}</title><style>{STYLE}</style></head>\n<body>\n{body}\n<script>{SCRIPT}</script>\n</body></html>\n",
        escape(title)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_and_encodes() {
        assert_eq!(escape("<a href=\"x\">&'"), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;");
        assert_eq!(url_segment("hop field/α"), "hop%20field%2F%CE%B1");
        assert_eq!(anchor("s", "a b"), "s-a_b");
        assert_eq!(pct(None), "n/a");
        assert_eq!(pct(Some(0.125)), "12.5%");
    }
}
