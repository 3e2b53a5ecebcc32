//! The report's per-job figures (paper Figs. 16–18): time histories of selected jobs
//! overlaid with their wear profiles, and the strain energy per nodal diameter as bars.
//! A figure only draws panels that have data ([`history_panels`]): a sweep without stored
//! series gives no empty time-history panels.
//! Like [`crate::sweep::plots`], every function only writes its `path` (PNG or SVG by
//! extension), atomically. Axes in SI-derived units stated on each axis.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::sweep::plots::{PlotError, render, tab10, text_size, tick_decimals, tick_label};

/// The time series of one job drawn in [`time_histories`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JobHistory {
    /// Legend text (e.g. "job 3: Ω = 2500 rad/s, μ = 0.15").
    pub label: String,
    /// Sample times (s); empty when the job stored no series.
    pub time_s: Vec<f64>,
    /// Radial displacement of blade 0's trailing edge (m) at each sample.
    pub blade_te_radial_m: Vec<f64>,
    /// Radial displacement of the first casing probe (m) at each sample; empty if none.
    pub casing_radial_m: Vec<f64>,
    /// Normal contact force on blade 0 (N) at each sample.
    pub normal_force_n: Vec<f64>,
    /// Final wear depth (m) at θ_k = 360° k / n, the deepest over the meridian stations;
    /// empty without a coating.
    pub wear_m: Vec<f64>,
}

/// Input of [`time_histories`]: the jobs to overlay and the panel titles' probe names.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TimeHistoryData {
    /// One entry per job, in legend order.
    pub jobs: Vec<JobHistory>,
    /// Name of the casing probe (e.g. "casing sector 0, contact node 4").
    pub casing_probe: String,
}

/// Min/max envelope of `(t, y)` over `bins` equal time bins, as a polyline (each bin's
/// extreme values in time order): keeps every peak of a series far longer than the plot is
/// wide, which plain decimation would lose. Series no longer than `2·bins` come back whole.
pub fn envelope(t: &[f64], y: &[f64], bins: usize) -> Vec<(f64, f64)> {
    let n = t.len().min(y.len());
    if n <= 2 * bins || bins == 0 {
        return t.iter().zip(y).map(|(&a, &b)| (a, b)).collect();
    }
    let mut out = Vec::with_capacity(2 * bins);
    for b in 0..bins {
        let (lo, hi) = (b * n / bins, ((b + 1) * n / bins).max(b * n / bins + 1));
        let (mut imin, mut imax) = (lo, lo);
        for i in lo..hi {
            if y[i] < y[imin] {
                imin = i;
            }
            if y[i] > y[imax] {
                imax = i;
            }
        }
        let (a, c) = (imin.min(imax), imin.max(imax));
        out.push((t[a], y[a]));
        if c != a {
            out.push((t[c], y[c]));
        }
    }
    out
}

/// (min, max) of the finite values, padded by 5 % (a flat or empty series gets ±1).
fn padded_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    // Empty (or all non-finite): lo = +∞ > hi = −∞.
    if lo > hi {
        return (-1.0, 1.0);
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        lo.abs().max(1.0) * 0.05
    };
    (lo - pad, hi + pad)
}

/// One time-history panel: `get(job)` in `unit_scale` units against time.
fn history_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &TimeHistoryData,
    title: &str,
    y_desc: &str,
    unit_scale: f64,
    get: fn(&JobHistory) -> &[f64],
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let with: Vec<(usize, &JobHistory)> = d
        .jobs
        .iter()
        .enumerate()
        .filter(|(_, j)| !get(j).is_empty() && !j.time_s.is_empty())
        .collect();
    let t_max = with
        .iter()
        .filter_map(|(_, j)| j.time_s.last().copied())
        .fold(0.0, f64::max)
        .max(1e-12);
    let (y0, y1) = padded_range(
        with.iter()
            .flat_map(|(_, j)| get(j).iter().map(|v| v * unit_scale)),
    );
    // Enough decimals to tell five ticks apart, trailing zeros trimmed.
    let prec = tick_decimals(t_max);
    let y_prec = tick_decimals(y1 - y0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 15))
        .margin(8)
        // Room for the last time tick's label, centred on the right edge.
        .margin_right(20)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, y0..y1)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .bold_line_style(BLACK.mix(0.1))
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 13))
        .x_desc("time t (s)")
        .y_desc(y_desc)
        // Few enough ticks for a third of the figure's width.
        .x_labels(6)
        .x_label_formatter(&|v| tick_label(*v, prec))
        .y_label_formatter(&|v| tick_label(*v, y_prec))
        .draw()?;
    let width = area.dim_in_pixel().0 as usize;
    for (i, j) in with {
        let y: Vec<f64> = get(j).iter().map(|v| v * unit_scale).collect();
        chart.draw_series(LineSeries::new(
            envelope(&j.time_s, &y, width),
            // Width 1: plotters draws wider polylines as polygons, which break up on the
            // near-vertical segments of an envelope.
            tab10(i).stroke_width(1),
        ))?;
    }
    Ok(())
}

/// The wear panel: final wear depth (µm) against the angle (deg), one line per job.
fn wear_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &TimeHistoryData,
    title: &str,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let top = d
        .jobs
        .iter()
        .flat_map(|j| j.wear_m.iter().copied())
        .fold(0.0, f64::max)
        * 1e6;
    let top = if top > 0.0 { 1.1 * top } else { 1.0 };
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..360.0, 0.0..top)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .bold_line_style(BLACK.mix(0.1))
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 13))
        .x_desc("angle θ (deg)")
        .y_desc("wear depth (µm)")
        .draw()?;
    for (i, j) in d.jobs.iter().enumerate() {
        let n = j.wear_m.len() as f64;
        // Closed profile: θ = 360° repeats θ = 0.
        let pts = j
            .wear_m
            .iter()
            .chain(j.wear_m.first())
            .enumerate()
            .map(|(k, w)| (360.0 * k as f64 / n, w * 1e6));
        chart.draw_series(LineSeries::new(pts, tab10(i).stroke_width(2)))?;
    }
    Ok(())
}

/// The legend strip under the panels: one coloured line and label per job, in columns.
fn legend_strip<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    labels: &[String],
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let (w, _) = area.dim_in_pixel();
    let col_w = labels
        .iter()
        .map(|l| text_size(l, 13.0).0 + 40)
        .max()
        .unwrap_or(100)
        .max(100);
    let per_row = (w / col_w).max(1) as usize;
    for (i, l) in labels.iter().enumerate() {
        let x = 20 + (i % per_row) as i32 * col_w as i32;
        let y = 8 + (i / per_row) as i32 * 20;
        area.draw(&PathElement::new(
            [(x, y + 8), (x + 24, y + 8)],
            tab10(i).stroke_width(3),
        ))?;
        area.draw(&Text::new(
            l.clone(),
            (x + 30, y),
            ("sans-serif", 13).into_font(),
        ))?;
    }
    Ok(())
}

/// Rows of the legend strip for `n` labels, the widest `widest` pixels, in `width` pixels.
fn legend_rows(n: usize, widest: u32, width: u32) -> u32 {
    let per_row = (width / (widest + 40).max(100)).max(1) as usize;
    n.div_ceil(per_row) as u32
}

/// Height (pixels) of the legend strip of `labels` in a figure `width` pixels wide.
fn legend_height<'a>(labels: impl ExactSizeIterator<Item = &'a str>, width: u32) -> u32 {
    let n = labels.len();
    let widest = labels.map(|l| text_size(l, 13.0).0).max().unwrap_or(0);
    16 + 20 * legend_rows(n, widest, width)
}

/// A panel of the time-history figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HistoryPanel {
    /// Radial displacement of blade 0's trailing edge (mm) against time (s).
    BladeTrailingEdge,
    /// Radial displacement of the first casing probe (mm) against time (s).
    CasingProbe,
    /// Normal contact force on blade 0 (N) against time (s).
    NormalForce,
    /// Final wear depth (µm) against the angle (deg).
    Wear,
}

impl HistoryPanel {
    /// The panel's title (without its letter); `probe` names the casing probe.
    pub fn title(self, probe: &str) -> String {
        match self {
            Self::BladeTrailingEdge => "radial displacement, blade 0 trailing edge".into(),
            Self::CasingProbe => format!("radial displacement, {probe}"),
            Self::NormalForce => "normal contact force, blade 0".into(),
            Self::Wear => "final wear profile (deepest along the chord)".into(),
        }
    }

    /// What the panel shows, with its units (for a caption).
    pub fn description(self, probe: &str) -> String {
        match self {
            Self::BladeTrailingEdge => {
                "radial displacement of blade 0's trailing edge (mm) against time t (s)".into()
            }
            Self::CasingProbe => format!("radial displacement at {probe} (mm) against time t (s)"),
            Self::NormalForce => "normal contact force on blade 0 (N) against time t (s)".into(),
            Self::Wear => "final wear depth of the coating (µm, deepest along the chord) against \
                           the angle θ (deg)"
                .into(),
        }
    }
}

/// The panels of `d` that have data, in figure order: each series panel when some job has
/// that series stored, the wear panel when some job has a wear profile. Empty: nothing to
/// draw (a sweep run without `--timeseries` and without a coating).
pub fn history_panels(d: &TimeHistoryData) -> Vec<HistoryPanel> {
    let stored = |get: fn(&JobHistory) -> &[f64]| {
        d.jobs
            .iter()
            .any(|j| !j.time_s.is_empty() && !get(j).is_empty())
    };
    let mut out = Vec::new();
    for (panel, get) in [
        (
            HistoryPanel::BladeTrailingEdge,
            (|j| &j.blade_te_radial_m) as fn(&JobHistory) -> &[f64],
        ),
        (HistoryPanel::CasingProbe, |j| &j.casing_radial_m),
        (HistoryPanel::NormalForce, |j| &j.normal_force_n),
    ] {
        if stored(get) {
            out.push(panel);
        }
    }
    if d.jobs.iter().any(|j| !j.wear_m.is_empty()) {
        out.push(HistoryPanel::Wear);
    }
    out
}

/// Rows and columns of the panel grid for `n` panels: one row up to three, two rows of two
/// for four.
fn panel_grid(n: usize) -> (usize, usize) {
    if n <= 3 { (1, n.max(1)) } else { (2, 2) }
}

fn draw_histories<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    d: &TimeHistoryData,
    legend_h: u32,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let panels = history_panels(d);
    let title = if panels == [HistoryPanel::Wear] {
        "Final wear profiles of selected jobs (paper Fig. 17)"
    } else {
        "Time histories of selected jobs (paper Figs. 16–17)"
    };
    let root = root.titled(title, ("sans-serif", 20))?;
    let h = root.dim_in_pixel().1;
    let (grid, legend) = root.split_vertically(h.saturating_sub(legend_h));
    let cells = grid.split_evenly(panel_grid(panels.len()));
    for (k, (panel, cell)) in panels.iter().zip(&cells).enumerate() {
        let title = match panels.len() {
            1 => panel.title(&d.casing_probe),
            _ => format!(
                "({}) {}",
                (b'a' + k as u8) as char,
                panel.title(&d.casing_probe)
            ),
        };
        match panel {
            HistoryPanel::BladeTrailingEdge => {
                history_panel(cell, d, &title, "displacement (mm)", 1e3, |j| {
                    &j.blade_te_radial_m
                })?
            }
            HistoryPanel::CasingProbe => {
                history_panel(cell, d, &title, "displacement (mm)", 1e3, |j| {
                    &j.casing_radial_m
                })?
            }
            HistoryPanel::NormalForce => {
                history_panel(cell, d, &title, "force (N)", 1.0, |j| &j.normal_force_n)?
            }
            HistoryPanel::Wear => wear_panel(cell, d, &title)?,
        }
    }
    let labels: Vec<String> = d.jobs.iter().map(|j| j.label.clone()).collect();
    legend_strip(&legend, &labels)?;
    root.present()?;
    Ok(())
}

/// Up to four panels in the style of the paper's Figs. 16–17, one colour per job, each drawn
/// only when some job has its data ([`history_panels`]): blade 0 trailing-edge radial
/// displacement (mm), casing probe radial displacement (mm), normal contact force on blade 0
/// (N), all against time (s), and the final wear profile (µm) against the angle (deg). Long
/// series are drawn as their min/max envelope ([`envelope`]), so no peak is lost.
/// [`PlotError::Empty`] when no panel has data.
pub fn time_histories(data: &TimeHistoryData, path: &Path) -> Result<(), PlotError> {
    let panels = history_panels(data);
    if panels.is_empty() {
        return Err(PlotError::Empty(
            "no stored time series and no wear profile for the jobs shown",
        ));
    }
    let width = 1300;
    let legend_h = legend_height(data.jobs.iter().map(|j| j.label.as_str()), width);
    let rows = panel_grid(panels.len()).0 as u32;
    render(
        path,
        (width, 40 + 410 * rows + legend_h),
        |a| draw_histories(a, data, legend_h),
        |a| draw_histories(a, data, legend_h),
    )
}

/// The bar of job `j` (of `k` jobs) at nodal diameter `nd` for the energy `e` (J) on a log10
/// axis whose floor is `bottom`: corners `[(x0, bottom), (x1, max(log10 e, bottom))]` in
/// (nodal diameter, log10 J), so a bar rises from the axis floor to its value and the largest
/// energy draws the tallest bar. `None` for `e ≤ 0` (no logarithm).
pub fn nd_bar(nd: usize, j: usize, k: usize, e: f64, bottom: f64) -> Option<[(f64, f64); 2]> {
    if e.is_nan() || e <= 0.0 {
        return None;
    }
    let bar = 0.8 / k.max(1) as f64;
    let x0 = nd as f64 - 0.4 + j as f64 * bar;
    Some([(x0, bottom), (x0 + 0.9 * bar, e.log10().max(bottom))])
}

/// Input of [`nd_energy_bars`]: per job, the strain energy per nodal diameter.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NdEnergyData {
    /// Legend text and energies (J) for nodal diameters 0, 1, … of each job.
    pub jobs: Vec<(String, Vec<f64>)>,
}

fn draw_nd_energy<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    d: &NdEnergyData,
    legend_h: u32,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let n_nd = d.jobs.iter().map(|(_, e)| e.len()).max().unwrap_or(1);
    let e_max = d
        .jobs
        .iter()
        .flat_map(|(_, e)| e.iter().copied())
        .fold(0.0, f64::max);
    // Twelve decades below the largest energy: enough to show a 10× dominance and the
    // round-off floor of the odd diameters without flattening the bars that matter.
    let top = if e_max > 0.0 {
        e_max.log10().ceil()
    } else {
        0.0
    };
    let bottom = top - 12.0;
    root.fill(&WHITE)?;
    let (h, _) = (root.dim_in_pixel().1, 0);
    let (main, legend) = root.split_vertically(h.saturating_sub(legend_h));
    let mut chart = ChartBuilder::on(&main)
        .caption(
            "Impeller strain energy per nodal diameter, mean over the steady window (paper Fig. 18)",
            ("sans-serif", 18),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..(n_nd as f64 - 0.5), bottom..top)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .light_line_style(WHITE)
        .bold_line_style(BLACK.mix(0.12))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .x_desc("nodal diameter n_d")
        .y_desc("log10 strain energy (J)")
        .x_labels(n_nd)
        .x_label_formatter(&|v| {
            let r = v.round();
            if (v - r).abs() < 1e-6 && r >= 0.0 {
                format!("{r:.0}")
            } else {
                String::new()
            }
        })
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()?;
    let k = d.jobs.len();
    for (j, (_, e)) in d.jobs.iter().enumerate() {
        let color = tab10(j);
        chart.draw_series(
            e.iter()
                .enumerate()
                .filter_map(|(nd, &v)| nd_bar(nd, j, k, v, bottom))
                .map(|corners| Rectangle::new(corners, color.filled())),
        )?;
    }
    let labels: Vec<String> = d.jobs.iter().map(|(l, _)| l.clone()).collect();
    legend_strip(&legend, &labels)?;
    root.present()?;
    Ok(())
}

/// Bars of the impeller strain energy per nodal diameter (J, log scale), one bar group per
/// diameter and one colour per job (paper Fig. 18).
pub fn nd_energy_bars(data: &NdEnergyData, path: &Path) -> Result<(), PlotError> {
    if data.jobs.iter().all(|(_, e)| e.is_empty()) {
        return Err(PlotError::Empty("no strain energy per nodal diameter"));
    }
    let width = 1100;
    let legend_h = legend_height(data.jobs.iter().map(|(l, _)| l.as_str()), width);
    render(
        path,
        (width, 620 + legend_h),
        |a| draw_nd_energy(a, data, legend_h),
        |a| draw_nd_energy(a, data, legend_h),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_keeps_every_extreme() {
        let n = 100_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut y: Vec<f64> = t.iter().map(|x| (x * 0.01).sin()).collect();
        y[54_321] = 5.0; // a single-sample spike
        y[7] = -3.0;
        let e = envelope(&t, &y, 500);
        assert!(e.len() <= 1000);
        assert!(e.contains(&(54_321.0, 5.0)) && e.contains(&(7.0, -3.0)));
        // In time order.
        assert!(e.windows(2).all(|w| w[0].0 < w[1].0));
        // Short series come back whole.
        assert_eq!(envelope(&t[..10], &y[..10], 500).len(), 10);
    }

    /// Issue 41: on the log axis a bar starts at the floor and ends at its value, so a
    /// larger energy draws a taller bar.
    #[test]
    fn log_bars_rise_from_the_floor() {
        let bottom = -14.0;
        let big = nd_bar(2, 0, 2, 1e-3, bottom).unwrap();
        let small = nd_bar(2, 1, 2, 1e-9, bottom).unwrap();
        for b in [big, small] {
            assert_eq!(b[0].1, bottom, "starts on the axis floor");
            assert!(b[1].1 > b[0].1, "rises");
        }
        assert!((big[1].1 - -3.0).abs() < 1e-12 && (small[1].1 - -9.0).abs() < 1e-12);
        // Side by side within the diameter's slot.
        assert!(big[1].0 <= small[0].0 && small[1].0 <= 2.4);
        // Below the floor: a bar of zero height at the floor; no logarithm of 0.
        let tiny = nd_bar(0, 0, 1, 1e-20, bottom).unwrap();
        assert_eq!(tiny[1].1, bottom);
        assert_eq!(nd_bar(0, 0, 1, 0.0, bottom), None);
    }

    fn job(label: &str, series: bool, wear: bool) -> JobHistory {
        let n = if series { 50 } else { 0 };
        JobHistory {
            label: label.into(),
            time_s: (0..n).map(|i| 1e-4 * i as f64).collect(),
            blade_te_radial_m: (0..n).map(|i| 1e-5 * (i as f64).sin()).collect(),
            casing_radial_m: vec![],
            normal_force_n: (0..n).map(|i| i as f64).collect(),
            wear_m: if wear { vec![1e-6; 36] } else { vec![] },
        }
    }

    /// Issue 41: panels without data are left out, and a figure with none is not drawn.
    #[test]
    fn only_panels_with_data_are_drawn() {
        use HistoryPanel::*;
        let d = |jobs| TimeHistoryData {
            jobs,
            casing_probe: "casing probe 0".into(),
        };
        let none = d(vec![job("a", false, false), job("b", false, false)]);
        assert!(history_panels(&none).is_empty());
        let path = std::env::temp_dir().join(format!("rubscan-th-{}.png", std::process::id()));
        assert!(matches!(
            time_histories(&none, &path),
            Err(PlotError::Empty(_))
        ));
        assert!(!path.exists(), "nothing written");
        let wear_only = d(vec![job("a", false, true)]);
        assert_eq!(history_panels(&wear_only), [Wear]);
        // No casing probe series: three panels; one job's series suffice.
        let mixed = d(vec![job("a", true, false), job("b", false, true)]);
        assert_eq!(
            history_panels(&mixed),
            [BladeTrailingEdge, NormalForce, Wear]
        );
        time_histories(&mixed, &path).unwrap();
        std::fs::remove_file(&path).unwrap();
    }
}
