//! `rubscan report` end to end: the report of a small sweep, looked at in a real browser (a
//! headless Chromium screenshot of `index.html` must show every figure: each image's bordered
//! box found in the screenshot and filled with plot colours; the same check fails on the page
//! with its images broken), also when the sweep stored no time series (the main job's way:
//! no figure without data); a synthetic sweep with ok, unstable and failed jobs (the response
//! against Ω with its outcomes); bad results directories refused naming the file; the
//! Campbell diagram's and interaction map's labels checked box by box.
//!
//! Needs `chromium` (Debian `chromium`, installed by `.ci/setup`) on the PATH for the browser
//! test; without it the test fails under the README's test command (`RUBSCAN_REQUIRE_TOOLS`) or
//! in CI and prints a skip note otherwise (as the CalculiX tests do).

use crate::common;
use common::{find_on_path, quickstart_output, skip_or_fail};
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use rubscan::sweep::labels::{LabelBox, disjoint};
use rubscan::sweep::plots::{
    CampbellData, CasingMode, ImpellerBranch, InteractionMapData, PlotLabels, SpectrumColumn,
    campbell_diagram, interaction_map,
};
use rubscan::sweep::report::{ReportOptions, write_report};
use rubscan::sweep::synthetic::SyntheticSimulator;
use rubscan::sweep::{CriticalSpeed, RunOptions, parse_spec, run_sweep};

const SMALL: &str = "tests/data/small_sweep.json";

fn rubscan() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rubscan"));
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rubscan-report-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn ok(out: Output) -> String {
    assert!(
        out.status.success(),
        "exit {:?}\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Removes a test's folder, unless `RUBSCAN_KEEP_PLOTS` is set (to look at the figures).
fn cleanup(dir: &Path) {
    if std::env::var_os("RUBSCAN_KEEP_PLOTS").is_none() {
        std::fs::remove_dir_all(dir).unwrap();
    }
}

/// Runs the small sweep with its time series into `dir`.
fn small_sweep(dir: &Path) {
    ok(rubscan()
        .args(["run", SMALL, "--timeseries", "--threads", "1", "-o"])
        .arg(dir)
        .output()
        .unwrap());
}

/// The figures of a report page, in page order.
fn page_figures(html: &str) -> Vec<String> {
    html.split("<img src=\"")
        .skip(1)
        .map(|s| s[..s.find('"').unwrap()].to_string())
        .collect()
}

/// An 8-bit screenshot.
struct Image {
    width: usize,
    height: usize,
    /// Bytes per pixel (3 RGB or 4 RGBA).
    bpp: usize,
    data: Vec<u8>,
}

impl Image {
    fn read(path: &Path) -> Image {
        let dec = png::Decoder::new(std::fs::File::open(path).unwrap());
        let mut reader = dec.read_info().unwrap();
        let mut data = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut data).unwrap();
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        let width = info.width as usize;
        Image {
            width,
            height: info.height as usize,
            bpp: info.line_size / width,
            data,
        }
    }

    fn rgb(&self, x: usize, y: usize) -> [u8; 3] {
        let i = (y * self.width + x) * self.bpp;
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Fraction of the pixels of the box `[x0, x1) × [y0, y1)` that `pred` accepts.
    fn fraction(&self, b: (usize, usize, usize, usize), pred: impl Fn([u8; 3]) -> bool) -> f64 {
        let (x0, x1, y0, y1) = b;
        let n = (x1 - x0) * (y1 - y0);
        let hits = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| pred(self.rgb(x, y)))
            .count();
        hits as f64 / n.max(1) as f64
    }
}

/// Not white: anything drawn.
fn inked(p: [u8; 3]) -> bool {
    p.iter().any(|&c| c < 245)
}

/// A saturated colour (plot lines, bars, colour maps), unlike text, borders and a broken
/// image's icon.
fn colourful(p: [u8; 3]) -> bool {
    let (lo, hi) = (p.iter().min().unwrap(), p.iter().max().unwrap());
    hi - lo > 60
}

/// The boxes `(x0, x1, y0, y1)` of the page's images in a screenshot: the page draws each
/// `<img>` with a 1 px #ccc border, so an image of its natural size shows as two long
/// horizontal #ccc runs at the same columns (top and bottom border). A broken image has
/// only a small box around its alternative text.
fn image_boxes(img: &Image) -> Vec<(usize, usize, usize, usize)> {
    const MIN_WIDTH: usize = 300;
    let mut runs: Vec<(usize, usize, usize)> = Vec::new(); // (y, x0, x1)
    for y in 0..img.height {
        let mut start = None;
        for x in 0..=img.width {
            let border = x < img.width && img.rgb(x, y) == [204, 204, 204];
            match (border, start) {
                (true, None) => start = Some(x),
                (false, Some(s)) => {
                    if x - s >= MIN_WIDTH {
                        runs.push((y, s, x));
                    }
                    start = None;
                }
                _ => {}
            }
        }
    }
    let mut boxes = Vec::new();
    let mut used = vec![false; runs.len()];
    for i in 0..runs.len() {
        if used[i] {
            continue;
        }
        let (y0, a, b) = runs[i];
        if let Some(j) = (i + 1..runs.len())
            .find(|&j| !used[j] && runs[j].1 == a && runs[j].2 == b && runs[j].0 > y0 + 50)
        {
            used[j] = true;
            boxes.push((a + 1, b - 1, y0 + 1, runs[j].0));
        }
    }
    boxes
}

/// Screenshot of `page` in headless Chromium (device scale 1, a window tall enough for the
/// whole page).
fn screenshot(chromium: &Path, page: &Path, out: &Path) -> Image {
    let profile = out.with_extension("profile");
    let status = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--hide-scrollbars",
            "--force-device-scale-factor=1",
            "--window-size=1400,6000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", out.display()))
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    assert!(
        out.is_file(),
        "chromium wrote no screenshot: {}",
        String::from_utf8_lossy(&status.stderr)
    );
    let _ = std::fs::remove_dir_all(&profile);
    Image::read(out)
}

/// The images of a screenshot that show data: image boxes with plot colours on more than
/// 0.2 % of their pixels. Axes, grid and text are grey; a legend's swatches alone colour
/// 0.013 % of the quickstart's response figure, while its one line with four markers colours
/// 0.72 % and the other figures 2.8–68 %.
fn loaded_images(img: &Image) -> usize {
    image_boxes(img)
        .into_iter()
        .filter(|&b| img.fraction(b, colourful) > 0.002)
        .count()
}

/// The page `out/index.html` in a headless browser: every one of its `figures` shows in its
/// own box with plot colours (a figure without data, all axes and text, fails); with
/// `broken`, the same page with its images broken is checked to fail the same test.
fn check_in_browser(dir: &Path, out: &Path, figures: &[String], broken: bool) {
    let Some(chromium) = find_on_path(&["chromium", "chromium-browser", "google-chrome"]) else {
        skip_or_fail(
            "report browser check",
            "chromium (Debian chromium) is not on the PATH",
        );
        return;
    };
    let shot = screenshot(&chromium, &out.join("index.html"), &dir.join("shot.png"));
    let whole = (0, shot.width, 0, shot.height);
    assert!(shot.fraction(whole, inked) > 0.02, "the page is blank");
    assert_eq!(
        loaded_images(&shot),
        figures.len(),
        "every figure shows, with plot colours, in its own box"
    );
    if !broken {
        return;
    }
    // The same page with its images broken: the check fails.
    let broken = dir.join("broken");
    std::fs::create_dir_all(&broken).unwrap();
    std::fs::copy(out.join("index.html"), broken.join("index.html")).unwrap();
    for f in figures {
        std::fs::write(broken.join(f), b"not a PNG").unwrap();
    }
    let shot = screenshot(
        &chromium,
        &broken.join("index.html"),
        &dir.join("broken.png"),
    );
    assert!(shot.fraction(whole, inked) > 0.002, "text still shows");
    assert_eq!(
        loaded_images(&shot),
        0,
        "broken images are not taken as loaded"
    );
}

#[test]
fn report_of_a_small_sweep_shows_every_figure_in_a_browser() {
    let dir = tmp("browser");
    small_sweep(&dir);
    let text = ok(rubscan().arg("report").arg(&dir).output().unwrap());
    let out = dir.join("report");
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let figures = page_figures(&html);
    // The response against Ω, time histories, ND strain energy and one interaction map per
    // friction value (the small models have no critical speed, so no Campbell diagram: said
    // on the page).
    assert_eq!(
        figures,
        [
            "response_vs_speed.png",
            "time_histories.png",
            "nd_strain_energy.png",
            "interaction_map_0.png",
            "interaction_map_1.png"
        ],
        "{text}"
    );
    for f in &figures {
        assert!(out.join(f).is_file(), "{f}");
        assert!(text.contains(f.as_str()), "{text}");
    }
    assert!(html.contains("no Campbell diagram"));
    for unit in ["(mm)", "(N)", "(µm)", "(J", "(rad/s)", "(Hz"] {
        assert!(html.contains(unit), "captions state {unit}");
    }
    assert!(html.contains("6 jobs: 6 ok, 0 unstable"), "{html}");
    // Every job's series was stored: no note about missing ones.
    assert!(!html.contains("no time series"), "{html}");
    check_in_browser(&dir, &out, &figures, true);
    cleanup(&dir);
}

/// The main job itself (`rubscan run sweeps/quickstart.json`, no `--timeseries`; the run shared
/// with `tests/quickstart_reference.rs`, which holds its table to the reference): no figure
/// of its report is without data, in a browser's screenshot. With no series and no coating
/// the time histories are left out, with one note saying how to get them, instead of empty
/// panels.
#[test]
fn the_main_jobs_report_has_no_figure_without_data() {
    let dir = tmp("noseries");
    let out = dir.join("report");
    ok(rubscan()
        .arg("report")
        .arg(quickstart_output())
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap());
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let figures = page_figures(&html);
    assert_eq!(
        figures,
        [
            "response_vs_speed.png",
            "nd_strain_energy.png",
            "campbell.png",
            "interaction_map.png"
        ]
    );
    assert!(!out.join("time_histories.png").exists());
    let notes: Vec<&str> = html.lines().filter(|l| l.contains("time series")).collect();
    assert_eq!(notes.len(), 1, "one line: {notes:?}");
    assert!(
        notes[0].contains("--timeseries") && notes[0].contains("rubscan simulate"),
        "{}",
        notes[0]
    );
    check_in_browser(&dir, &out, &figures, false);
    cleanup(&dir);
}

/// A synthetic scan of the small models with runaways above 2200 rad/s and failures above
/// 2400 rad/s: the response against Ω counts the outcomes, gives the unstable jobs' growth
/// rates and onsets, and shades them; the page shows every figure.
#[test]
fn report_of_a_scan_with_unstable_and_failed_jobs() {
    let mut spec: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(SMALL)).unwrap(),
    )
    .unwrap();
    spec["name"] = "unstable_scan".into();
    spec["grid"]["speed"] = serde_json::json!({"unit": "rad_s", "range": {"start": 1500.0, "stop": 2500.0, "count": 11}});
    let spec = parse_spec(&spec.to_string()).unwrap();
    let sim = SyntheticSimulator {
        critical_speed_rad_s: 2000.0,
        unstable_above_speed_rad_s: Some(2200.0),
        fail_above_speed_rad_s: Some(2400.0),
        ..Default::default()
    };
    let dir = tmp("unstable");
    run_sweep(&spec, &RunOptions::new(&dir), &sim).unwrap();
    let report = write_report(&dir, &ReportOptions::default()).unwrap();
    let out = dir.join("report");
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let figures = page_figures(&html);
    // No series stored: the time-history figure keeps the synthetic wear profiles alone.
    assert_eq!(
        figures,
        [
            "response_vs_speed.png",
            "time_histories.png",
            "nd_strain_energy.png",
            "interaction_map_0.png",
            "interaction_map_1.png"
        ]
    );
    assert!(html.contains("Final wear profiles (Fig. 17)"), "{html}");
    // Two speed lines of 11 speeds: 2300 and 2400 rad/s unstable, 2500 rad/s failed.
    assert!(html.contains("22 jobs: 16 ok, 4 unstable"), "{html}");
    for needle in [
        "16 ok (filled circles), 4 unstable",
        "2 failed (crosses on the axis floor)",
        "maxima run only to the stop",
        // σ = 10⁴ (Ω/2200 − 1): 454.545 /s at 2300 rad/s, 909.091 /s at 2400 rad/s.
        "growth rate σ 454.545–909.091 1/s",
        "onset at t = 0.0040 s",
        "Shaded red",
        "no linear stability prediction",
    ] {
        assert!(html.contains(needle), "{needle} not on the page: {html}");
    }
    let labels = report.scan_labels.expect("the response against Ω is drawn");
    let boxes: Vec<LabelBox> = labels.placed.iter().map(|l| l.bbox).collect();
    assert!(disjoint(&boxes), "{labels:?}");
    check_in_browser(&dir, &out, &figures, false);
    cleanup(&dir);
}

#[test]
fn bad_results_dirs_are_refused_naming_the_file() {
    let refused = |dir: &Path, extra: &[&str], needle: &str| {
        let out = rubscan()
            .arg("report")
            .arg(dir)
            .args(extra)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains(needle), "{needle} not named in: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!dir.join("report").exists(), "nothing written");
    };
    let dir = tmp("bad");
    refused(&dir, &[], &dir.display().to_string());
    std::fs::create_dir_all(&dir).unwrap();
    refused(&dir, &[], "manifest.json");
    small_sweep(&dir);
    refused(&dir, &["--job", "99"], "job 99");
    let table = dir.join("results.parquet");
    let good = std::fs::read(&table).unwrap();
    std::fs::write(&table, &good[..good.len() / 2]).unwrap();
    refused(&dir, &[], "results.parquet");
    std::fs::remove_file(&table).unwrap();
    refused(&dir, &[], "results.parquet");
    std::fs::write(&table, &good).unwrap();
    std::fs::write(dir.join("manifest.json"), b"{ \"sweep\": ").unwrap();
    refused(&dir, &[], "manifest.json");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Checks a figure's labels: pairwise disjoint, inside the figure, and drawn where the
/// boxes say (the SVG's `<text>` elements carry the top-left corners).
fn check_labels(labels: &PlotLabels, svg: &str, size: (i32, i32), expected: usize) {
    assert_eq!(labels.placed.len() + labels.dropped.len(), expected);
    let boxes: Vec<LabelBox> = labels.placed.iter().map(|l| l.bbox).collect();
    assert!(disjoint(&boxes), "overlapping labels: {:?}", labels.placed);
    let figure = LabelBox {
        x0: 0,
        y0: 0,
        x1: size.0,
        y1: size.1,
    };
    for l in &labels.placed {
        assert!(l.bbox.inside(&figure), "{l:?}");
        let tag = format!("x=\"{}\" y=\"{}\"", l.bbox.x0, l.bbox.y0);
        let drawn = svg.split("<text ").any(|t| {
            let content = t.split_once('>').map_or("", |(_, c)| c);
            let content = content.split("</text>").next().unwrap_or("");
            t.starts_with(&tag) && content.trim() == l.text
        });
        assert!(drawn, "{} not drawn at {tag}", l.text);
    }
}

/// Twelve critical speeds within 7 % of the speed range, as the built-in models have them
/// (6494–6919 rad/s on a 0–7000 rad/s diagram): the old diagram printed their labels on top
/// of each other at the top of the plot.
#[test]
fn crowded_campbell_labels_do_not_overlap() {
    let speeds: Vec<f64> = (0..=14).map(|i| 500.0 * i as f64).collect();
    let crit: Vec<CriticalSpeed> = (0..12)
        .map(|i| CriticalSpeed {
            speed_rad_s: 6494.0 + 38.0 * i as f64,
            nodal_diameter: 5 + (i % 4),
            compatibility: 0.1 + 0.07 * i as f64,
        })
        .collect();
    let data = CampbellData {
        casing: (5..9)
            .map(|n| CasingMode {
                nodal_diameter: n,
                omega_rad_s: TAU * 700.0 * f64::from(n),
            })
            .collect(),
        impeller: (5..9)
            .map(|n| ImpellerBranch {
                nodal_diameter: n,
                omega_rad_s: speeds.iter().map(|w| 0.4 * f64::from(n) * w).collect(),
            })
            .collect(),
        speeds_rad_s: speeds,
        critical_speeds: crit,
        speed_band_rad_s: Some((6000.0, 7000.0)),
    };
    let dir = tmp("campbell");
    let path = dir.join("campbell.svg");
    let labels = campbell_diagram(&data, &path).unwrap();
    check_labels(
        &labels,
        &std::fs::read_to_string(&path).unwrap(),
        (1100, 750),
        12,
    );
    // Room was found by moving labels, not by dropping most of them.
    assert!(labels.placed.len() >= 10, "{labels:?}");
    cleanup(&dir);
}

/// Twenty engine orders and three critical speeds in a narrow band: labels move along their
/// line or are left out, never overlap.
#[test]
fn crowded_interaction_map_labels_do_not_overlap() {
    let columns = (0..21)
        .map(|i| SpectrumColumn {
            speed_rad_s: 6700.0 + 20.0 * i as f64,
            df_hz: 50.0,
            amplitude_m: (0..400).map(|k| 1e-6 / (1.0 + k as f64)).collect(),
        })
        .collect();
    let data = InteractionMapData {
        columns,
        engine_orders: (1..=20).collect(),
        critical_speeds_rad_s: vec![6891.0, 6900.0, 6918.0],
        max_frequency_hz: Some(15_000.0),
        dynamic_range_decades: 3.0,
        subtitle: "μ = 0.15".into(),
        mode_lines: vec![],
    };
    let dir = tmp("map");
    let path = dir.join("map.svg");
    let labels = interaction_map(&data, &path).unwrap();
    // The engine orders whose line enters the band at the lowest speed (the map's left edge
    // is half a column below the first speed), and the three critical speeds.
    let x_lo = 6700.0 - 10.0;
    let orders = (1..=20)
        .filter(|&e| f64::from(e) * x_lo / TAU < 15_000.0)
        .count();
    assert_eq!(orders, 14);
    let expected = orders + 3;
    check_labels(
        &labels,
        &std::fs::read_to_string(&path).unwrap(),
        (1100, 700),
        expected,
    );
    assert!(labels.placed.iter().any(|l| l.text == "Ω* = 6891"));
    cleanup(&dir);
}
