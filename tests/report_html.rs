//! `report.html` of `loomlab run`, opened in headless Chromium: it renders without console errors
//! and shows the summary table, the plots, the per-scenario tables, at least one GIF per scenario
//! with its alarm frame marked, and (with `--baseline`) what got worse and what improved.
//!
//! Needs a GPU adapter (lavapipe) and Chromium (`apt-get install chromium`, which `make test`
//! does); without Chromium the browser checks are skipped with a message saying so (the page's
//! files are still checked). `LOOMLAB_CHROMIUM` names another browser binary.

use crate::common;

use std::path::Path;
use std::process::Command;

use common::{loomlab, s, text, tiny_suite};

/// The Chromium binary, if one is installed.
fn chromium() -> Option<String> {
    let candidates = std::env::var("LOOMLAB_CHROMIUM")
        .into_iter()
        .chain(["chromium", "chromium-browser", "google-chrome"].map(String::from));
    candidates.into_iter().find(|c| {
        Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// Opens `page` in headless Chromium: the DOM after the scripts ran, and the console messages
/// that are errors (uncaught exceptions, failed loads, `console.error`).
fn open(chromium: &str, page: &Path, scratch: &Path) -> (String, Vec<String>) {
    let o = Command::new(chromium)
        .args([
            "--headless",
            "--disable-gpu",
            "--no-sandbox",
            "--no-first-run",
            "--disable-extensions",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=5000",
        ])
        .arg(format!(
            "--user-data-dir={}",
            scratch.join("chromium-profile").display()
        ))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.canonicalize().unwrap().display()))
        .env("HOME", scratch)
        .output()
        .expect("run chromium");
    assert!(o.status.success(), "chromium failed: {}", text(&o.stderr));
    let errors = text(&o.stderr)
        .lines()
        .filter(|l| {
            (l.contains("CONSOLE") && (l.contains("Uncaught") || l.contains("Error") || l.contains(":ERROR:")))
                || l.contains("net::ERR_")
                || l.contains("Failed to load resource")
        })
        .map(String::from)
        .collect();
    (text(&o.stdout), errors)
}

/// The frames of a GIF.
fn gif_frames(gif: &Path) -> Vec<image::Frame> {
    use image::AnimationDecoder;
    let file = std::io::BufReader::new(std::fs::File::open(gif).unwrap());
    image::codecs::gif::GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap()
}

/// The GIF's frames whose delay marks them as alarm frames (1 s on screen), and whether each has
/// a coloured (non-grey) border: the alarm mark.
fn alarm_frames_marked(gif: &Path) -> Vec<bool> {
    let frames = gif_frames(gif);
    assert!(
        !frames.is_empty() && frames.len() <= 80,
        "{}: {} frames",
        gif.display(),
        frames.len()
    );
    frames
        .iter()
        .filter(|f| {
            let (n, d) = f.delay().numer_denom_ms();
            n / d.max(1) >= 1000
        })
        .map(|f| {
            let img = f.buffer();
            // the top-left corner of the image is inside the 4-pixel border
            let p = img.get_pixel(1, 1).0;
            !(p[0] == p[1] && p[1] == p[2])
        })
        .collect()
}

/// `loomlab run SUITE --out OUT --quiet --no-plots EXTRA...`, which must succeed.
fn run_without_plots(suite: &std::path::Path, out: &std::path::Path, extra: &[&str]) {
    let mut args = vec!["run", s(suite), "--out", s(out), "--quiet", "--no-plots"];
    args.extend_from_slice(extra);
    let o = loomlab(&args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
}

/// The `src` of every `<img class="CLASS">` of a page, in order.
fn img_srcs<'a>(html: &'a str, class: &str) -> Vec<&'a str> {
    html.split(&format!("<img class=\"{class}\" src=\""))
        .skip(1)
        .map(|r| &r[..r.find('"').unwrap()])
        .collect()
}

#[test]
fn run_report_html_renders_in_headless_chromium() {
    let dir = common::tmp("report-html", "run");
    let suite = tiny_suite(&dir);
    let out = dir.join("out");
    let baseline = dir.join("baseline.json");
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--baseline",
        s(&baseline),
        "--bless",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}{}", text(&o.stdout), text(&o.stderr));
    assert!(text(&o.stdout).contains("report.html in"), "{}", text(&o.stdout));

    // A baseline that was better in one respect and worse in another: hopfield's collision rate
    // was 0 (now 0.5: worse), soc's hit rate was 0 (now above: better).
    let mut base: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&baseline).unwrap()).unwrap();
    let soc_hit_rate = base["detectors"]["soc"]["hit_rate"].as_f64().unwrap();
    assert!(soc_hit_rate > 0.1, "the tiny suite's soc hits (threshold 0.01)");
    let zero = serde_json::json!({"lower": 0.0, "upper": 0.0});
    assert!(base["detectors"]["hopfield"]["collision_rate"].as_f64().unwrap() > 0.1);
    base["detectors"]["hopfield"]["collision_rate"] = 0.0.into();
    base["detectors"]["hopfield"]["collision_rate_ci"] = zero.clone();
    base["detectors"]["soc"]["hit_rate"] = 0.0.into();
    base["detectors"]["soc"]["hit_rate_ci"] = zero;
    std::fs::write(&baseline, base.to_string()).unwrap();
    let o = loomlab(&[
        "run",
        s(&suite),
        "--out",
        s(&out),
        "--overwrite",
        "--quiet",
        "--baseline",
        s(&baseline),
    ]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "a regression: {}{}",
        text(&o.stdout),
        text(&o.stderr)
    );

    let page = out.join("report.html");
    let html = std::fs::read_to_string(&page).unwrap();
    // self-contained: nothing is fetched from the network
    for attr in ["src=\"http", "href=\"http", "url(http", "@import"] {
        assert!(!html.contains(attr), "the page loads {attr}…");
    }
    // the comparison with the baseline
    assert!(html.contains("id=\"worse\"") && html.contains("id=\"better\""));
    let worse = &html[html.find("id=\"worse\"").unwrap()..html.find("id=\"better\"").unwrap()];
    assert!(worse.contains("<td>hopfield</td><td>collision_rate</td>"), "{worse}");
    let better = &html[html.find("id=\"better\"").unwrap()..];
    assert!(better.contains("<td>soc</td><td>hit_rate</td>"));

    // one exemplar GIF at least per scenario, each existing, bounded, with its alarm frames marked
    for scenario in ["ball", "fast_ball"] {
        let start = html.find(&format!("id=\"scenario-{scenario}\"")).unwrap();
        let section = &html[start..start + html[start..].find("</section>").unwrap()];
        assert!(section.contains("<table class=\"sortable per-scenario\">"));
        let gifs = img_srcs(section, "view");
        assert!(!gifs.is_empty(), "no GIF for {scenario}");
        let mut marked = 0;
        for g in &gifs {
            let flags = alarm_frames_marked(&out.join(g));
            assert!(flags.iter().all(|&m| m), "{g}: an alarm frame without its border");
            marked += flags.len();
        }
        assert!(
            marked > 0,
            "{scenario}: no GIF shows an alarm frame (soc alarms early in every episode)"
        );
    }

    let Some(chromium) = chromium() else {
        eprintln!(
            "SKIPPED the headless-browser part of run_report_html_renders_in_headless_chromium: no chromium \
             found (install it with `apt-get install chromium`, or name a binary in LOOMLAB_CHROMIUM)"
        );
        return;
    };
    // the checker sees console errors (a page with a script error is caught)
    let bad = dir.join("bad.html");
    std::fs::write(
        &bad,
        "<!DOCTYPE html><html><body><script>no_such_function();</script></body></html>",
    )
    .unwrap();
    let (_, errors) = open(&chromium, &bad, &dir);
    assert!(!errors.is_empty(), "a script error must show up in chromium's log");

    let (dom, errors) = open(&chromium, &page, &dir);
    assert!(errors.is_empty(), "console errors:\n{}", errors.join("\n"));
    // the script ran: every table is sortable (summary, two per-scenario, the three comparison ones)
    assert!(
        dom.contains("data-sortable-tables=\"6\""),
        "{}",
        &dom[..dom.len().min(2000)]
    );
    assert!(dom.contains("<table class=\"sortable summary\">"));
    for plot in ["roc", "rates", "collisions", "lv", "theta_hat", "trace"] {
        let at = dom
            .find(&format!("id=\"plot-{plot}\""))
            .unwrap_or_else(|| panic!("plot {plot} missing"));
        assert!(
            dom[at..].starts_with(&format!("id=\"plot-{plot}\" class=\"plot\"><svg")),
            "{plot}"
        );
    }
    assert!(dom.matches("<img class=\"view\"").count() >= 2);
    assert!(dom.matches("<figure class=\"trace\"><svg").count() >= 2);
}

#[test]
fn no_html_writes_no_page_and_overwrite_removes_an_old_one() {
    let dir = common::tmp("report-html", "no-html");
    let suite = tiny_suite(&dir);
    let out = dir.join("out");
    run_without_plots(&suite, &out, &["--limit", "2"]);
    assert!(out.join("report.html").is_file() && out.join("exemplars").is_dir());
    run_without_plots(&suite, &out, &["--limit", "2", "--overwrite", "--no-html"]);
    assert!(out.join("report.json").is_file());
    assert!(!out.join("report.html").exists() && !out.join("exemplars").exists());
}

#[test]
fn an_event_camera_run_shows_each_exemplars_events() {
    let dir = common::tmp("report-html", "events");
    let suite = tiny_suite(&dir);
    let out = dir.join("out");
    run_without_plots(&suite, &out, &["--sensor", "events", "--detectors", "soc,event_soc"]);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let (views, events) = (img_srcs(&html, "view"), img_srcs(&html, "view events"));
    assert!(!views.is_empty());
    assert_eq!(views.len(), events.len(), "one events GIF per exemplar: {events:?}");
    for (v, e) in views.iter().zip(&events) {
        assert_eq!(*e, v.replace(".gif", "_events.gif"));
        let (view_frames, event_frames) = (gif_frames(&out.join(v)), gif_frames(&out.join(e)));
        let event_frames: Vec<&image::RgbaImage> = event_frames.iter().map(|f| f.buffer()).collect();
        assert_eq!(view_frames.len(), event_frames.len(), "{e}: the view's frames");
        // the approaching ball makes events: some frame has pixels off the mid-grey of "none"
        let image_rows = event_frames[0].height() - 24;
        let eventful = event_frames
            .iter()
            .any(|f| (0..image_rows).any(|y| (0..f.width()).any(|x| f.get_pixel(x, y).0[0].abs_diff(128) > 40)));
        assert!(eventful, "{e}: no events shown");
    }
    // --overwrite removes the events GIFs with the rest of the run
    run_without_plots(&suite, &out, &["--overwrite", "--limit", "1", "--no-html"]);
    assert!(!out.join(events[0]).exists(), "{} left behind", events[0]);
}
