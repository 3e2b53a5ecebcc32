//! Sweep plots (plotters with the vendored DejaVuSans font through ab_glyph, so no
//! system font stack is needed): interaction map, Campbell diagram, wear map.
//!
//! Every function is pure apart from writing `path`; the format follows the extension
//! (`.png` or `.svg`). Files are written to a temporary name and renamed, so a plot is
//! either complete or absent. Axes in SI: speed in rad/s, frequency in Hz.

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::sweep::checkpoint::JobRecord;

static FONT: &[u8] = include_bytes!("assets/DejaVuSans.ttf");

/// Why a plot could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The path has no `.png` / `.svg` extension.
    #[error("unsupported plot format for {0} (use .png or .svg)")]
    Format(PathBuf),
    /// Nothing to draw.
    #[error("no data to plot: {0}")]
    Empty(&'static str),
    /// The vendored font could not be registered.
    #[error("cannot register the plot font")]
    Font,
    /// plotters failed while drawing or writing.
    #[error("drawing {path}: {message}")]
    Draw {
        /// Target file.
        path: PathBuf,
        /// plotters' message.
        message: String,
    },
}

/// One column of an interaction map: the amplitude spectrum of one job.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrumColumn {
    /// Rotation speed Ω (rad/s).
    pub speed_rad_s: f64,
    /// Frequency resolution (Hz).
    pub df_hz: f64,
    /// Amplitudes (m) at f = k·df.
    pub amplitude_m: Vec<f64>,
}

/// Input of [`interaction_map`].
#[derive(Debug, Clone, PartialEq)]
pub struct InteractionMapData {
    /// One spectrum per speed (any order; one column per distinct speed).
    pub columns: Vec<SpectrumColumn>,
    /// Engine orders drawn as lines f = E·Ω/2π.
    pub engine_orders: Vec<u32>,
    /// Predicted critical speeds Ω* (rad/s), drawn as vertical lines.
    pub critical_speeds_rad_s: Vec<f64>,
    /// Upper frequency limit (Hz); `None` = the largest spectrum frequency.
    pub max_frequency_hz: Option<f64>,
    /// Colour scale span in decades below the largest amplitude.
    pub dynamic_range_decades: f64,
    /// Extra caption text (e.g. the fixed parameters of this slice of the sweep).
    pub subtitle: String,
}

/// A casing mode of the Campbell diagram (fixed frame, independent of Ω).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CasingMode {
    /// Nodal diameter n.
    pub nodal_diameter: u32,
    /// Angular frequency ω_c (rad/s).
    pub omega_rad_s: f64,
}

/// An impeller mode branch: rotating-frame angular frequency ω_b(Ω) at each speed.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpellerBranch {
    /// Nodal diameter n.
    pub nodal_diameter: u32,
    /// ω_b(Ω) (rad/s) at each of [`CampbellData::speeds_rad_s`].
    pub omega_rad_s: Vec<f64>,
}

/// Input of [`campbell_diagram`].
#[derive(Debug, Clone, PartialEq)]
pub struct CampbellData {
    /// Speeds Ω (rad/s), increasing.
    pub speeds_rad_s: Vec<f64>,
    /// Casing modes.
    pub casing: Vec<CasingMode>,
    /// Impeller branches.
    pub impeller: Vec<ImpellerBranch>,
    /// Critical speeds (Ω*, n) to mark.
    pub critical_speeds: Vec<(f64, u32)>,
}

/// One row of a wear map.
#[derive(Debug, Clone, PartialEq)]
pub struct WearRow {
    /// Row label (e.g. "Ω = 1047 rad/s, μ = 0.15").
    pub label: String,
    /// Wear depth (m) at θ_k = 2πk/n, k = 0..n.
    pub wear_m: Vec<f64>,
}

/// Input of [`wear_map`].
#[derive(Debug, Clone, PartialEq)]
pub struct WearMapData {
    /// One row per job, drawn bottom to top.
    pub rows: Vec<WearRow>,
}

fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// A perceptually ordered colour map (viridis anchors, linear in between), t ∈ [0, 1].
pub(crate) fn colormap(t: f64) -> RGBColor {
    const ANCHORS: [(u8, u8, u8); 5] = [
        (68, 1, 84),
        (59, 82, 139),
        (33, 145, 140),
        (94, 201, 98),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (ANCHORS.len() - 1) as f64;
    let i = (x.floor() as usize).min(ANCHORS.len() - 2);
    let f = x - i as f64;
    let lerp = |a: u8, b: u8| (f64::from(a) + f * (f64::from(b) - f64::from(a))).round() as u8;
    let (a, b) = (ANCHORS[i], ANCHORS[i + 1]);
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// Distinct colours per nodal diameter (Tableau 10, readable on white).
fn nd_color(n: u32) -> RGBColor {
    const TAB10: [(u8, u8, u8); 10] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ];
    let (r, g, b) = TAB10[n as usize % TAB10.len()];
    RGBColor(r, g, b)
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// Renders `draw` into `path` (PNG or SVG by extension) through a temporary file.
fn render(
    path: &Path,
    size: (u32, u32),
    draw_png: impl FnOnce(DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult,
    draw_svg: impl FnOnce(DrawingArea<SVGBackend<'_>, Shift>) -> DrawResult,
) -> Result<(), PlotError> {
    ensure_font()?;
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .ok_or_else(|| PlotError::Format(path.to_path_buf()))?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{stem}.{}.tmp.{ext}", std::process::id()));
    let err = |e: Box<dyn std::error::Error>| PlotError::Draw {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let result = match ext.as_str() {
        "png" => draw_png(BitMapBackend::new(&tmp, size).into_drawing_area()).map_err(err),
        "svg" => draw_svg(SVGBackend::new(&tmp, size).into_drawing_area()).map_err(err),
        _ => return Err(PlotError::Format(path.to_path_buf())),
    };
    match result {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| PlotError::Draw {
            path: path.to_path_buf(),
            message: e.to_string(),
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Cell edges along x for sorted column positions: midpoints between neighbours,
/// half a spacing beyond the ends (one column: ±5 %).
fn cell_edges(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    if n == 1 {
        return vec![x[0] * 0.95, x[0] * 1.05];
    }
    let mut e = Vec::with_capacity(n + 1);
    e.push(x[0] - 0.5 * (x[1] - x[0]));
    for w in x.windows(2) {
        e.push(0.5 * (w[0] + w[1]));
    }
    e.push(x[n - 1] + 0.5 * (x[n - 1] - x[n - 2]));
    e
}

fn draw_colorbar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    lo: f64,
    hi: f64,
    label: &str,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let hi = if hi > lo { hi } else { lo + 1.0 };
    let mut chart = ChartBuilder::on(area)
        .margin(20)
        .margin_left(5)
        .y_label_area_size(75)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .y_desc(label)
        .y_label_formatter(&|v| format!("{v:.1}"))
        .draw()?;
    let n = 64;
    chart.draw_series((0..n).map(|i| {
        let a = lo + (hi - lo) * i as f64 / n as f64;
        let b = lo + (hi - lo) * (i + 1) as f64 / n as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            colormap((i as f64 + 0.5) / n as f64).filled(),
        )
    }))?;
    Ok(())
}

fn draw_interaction<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    d: &InteractionMapData,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let mut cols: Vec<&SpectrumColumn> = d.columns.iter().collect();
    cols.sort_by(|a, b| a.speed_rad_s.total_cmp(&b.speed_rad_s));
    cols.dedup_by(|a, b| a.speed_rad_s == b.speed_rad_s);
    let speeds: Vec<f64> = cols.iter().map(|c| c.speed_rad_s).collect();
    let edges = cell_edges(&speeds);
    let f_max = d.max_frequency_hz.unwrap_or_else(|| {
        cols.iter()
            .map(|c| c.df_hz * c.amplitude_m.len() as f64)
            .fold(0.0, f64::max)
    });
    let f_max = if f_max > 0.0 { f_max } else { 1.0 };
    let a_max = cols
        .iter()
        .flat_map(|c| c.amplitude_m.iter().copied())
        .fold(0.0, f64::max);
    let top = if a_max > 0.0 { a_max.log10() } else { 0.0 };
    let bottom = top - d.dynamic_range_decades.max(0.1);

    root.fill(&WHITE)?;
    let (main, bar) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(140));
    let mut chart = ChartBuilder::on(&main)
        .caption(
            if d.subtitle.is_empty() {
                "Interaction map: blade-tip spectrum vs rotation speed".to_string()
            } else {
                format!("Interaction map ({})", d.subtitle)
            },
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(edges[0]..edges[edges.len() - 1], 0.0..f_max)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .x_desc("rotation speed Ω (rad/s)")
        .y_desc("frequency (Hz)")
        .draw()?;
    for (i, c) in cols.iter().enumerate() {
        let (x0, x1) = (edges[i], edges[i + 1]);
        chart.draw_series(c.amplitude_m.iter().enumerate().filter_map(|(k, &a)| {
            let f0 = k as f64 * c.df_hz;
            if f0 >= f_max {
                return None;
            }
            let level = if a > 0.0 {
                (a.log10() - bottom) / (top - bottom)
            } else {
                0.0
            };
            Some(Rectangle::new(
                [(x0, f0), (x1, f0 + c.df_hz)],
                colormap(level).filled(),
            ))
        }))?;
    }
    let (x_lo, x_hi) = (edges[0], edges[edges.len() - 1]);
    for &e in &d.engine_orders {
        let e = f64::from(e);
        // Clip the line f = e Ω / 2π to the plot box.
        let x_end = x_hi.min(f_max * TAU / e);
        if x_end <= x_lo {
            continue;
        }
        chart.draw_series(LineSeries::new(
            [(x_lo, e * x_lo / TAU), (x_end, e * x_end / TAU)],
            WHITE.stroke_width(1),
        ))?;
        // Label inside the box, a little before the line's end.
        let x_label = x_lo + 0.9 * (x_end - x_lo);
        chart.draw_series(std::iter::once(Text::new(
            format!("EO {e}"),
            (x_label, e * x_label / TAU + 0.02 * f_max),
            ("sans-serif", 14).into_font().color(&WHITE),
        )))?;
    }
    for &w in &d.critical_speeds_rad_s {
        if w < x_lo || w > x_hi {
            continue;
        }
        chart.draw_series(LineSeries::new([(w, 0.0), (w, f_max)], RED.stroke_width(2)))?;
        chart.draw_series(std::iter::once(Text::new(
            format!("Ω* = {w:.0}"),
            (w, f_max * 0.97),
            ("sans-serif", 14).into_font().color(&RED),
        )))?;
    }
    draw_colorbar(&bar, bottom, top, "log10 amplitude (m)")?;
    root.present()?;
    Ok(())
}

/// Interaction map: colour = log10 of the blade-tip spectrum amplitude over speed Ω
/// (x, rad/s) and frequency (y, Hz), with engine-order lines f = E Ω/2π and the
/// predicted critical speeds Ω* as vertical red lines.
pub fn interaction_map(data: &InteractionMapData, path: &Path) -> Result<(), PlotError> {
    if data.columns.iter().all(|c| c.amplitude_m.is_empty()) {
        return Err(PlotError::Empty(
            "interaction map needs at least one spectrum",
        ));
    }
    render(
        path,
        (1100, 700),
        |a| draw_interaction(a, data),
        |a| draw_interaction(a, data),
    )
}

fn draw_campbell<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, d: &CampbellData) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let x_lo = d.speeds_rad_s.first().copied().unwrap_or(0.0);
    let x_hi = d
        .speeds_rad_s
        .last()
        .copied()
        .unwrap_or(1.0)
        .max(x_lo + 1e-9);
    let hz = |w: f64| w / TAU;
    let mut f_max = d
        .casing
        .iter()
        .map(|c| hz(c.omega_rad_s))
        .fold(0.0, f64::max);
    for b in &d.impeller {
        for (&w, &wb) in d.speeds_rad_s.iter().zip(&b.omega_rad_s) {
            f_max = f_max.max(hz(f64::from(b.nodal_diameter) * w - wb));
        }
    }
    let f_max = if f_max > 0.0 { 1.1 * f_max } else { 1.0 };
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Campbell diagram (fixed frame)", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(x_lo..x_hi, 0.0..f_max)?;
    chart
        .configure_mesh()
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .x_desc("rotation speed Ω (rad/s)")
        .y_desc("frequency (Hz)")
        .draw()?;
    for c in &d.casing {
        let color = nd_color(c.nodal_diameter);
        let f = hz(c.omega_rad_s);
        chart
            .draw_series(DashedLineSeries::new(
                [(x_lo, f), (x_hi, f)],
                8,
                5,
                color.stroke_width(2),
            ))?
            .label(format!("casing ω_c, n = {}", c.nodal_diameter))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    for b in &d.impeller {
        let color = nd_color(b.nodal_diameter);
        let n = f64::from(b.nodal_diameter);
        chart
            // Only the part seen as a positive frequency in the fixed frame can meet ω_c > 0.
            .draw_series(LineSeries::new(
                d.speeds_rad_s
                    .iter()
                    .zip(&b.omega_rad_s)
                    .map(|(&w, &wb)| (w, hz(n * w - wb)))
                    .filter(|&(_, f)| f >= 0.0),
                color.stroke_width(2),
            ))?
            .label(format!("impeller nΩ − ω_b, n = {}", b.nodal_diameter))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    for &(w, n) in &d.critical_speeds {
        chart.draw_series(LineSeries::new(
            [(w, 0.0), (w, f_max)],
            BLACK.mix(0.5).stroke_width(1),
        ))?;
        chart.draw_series(std::iter::once(Text::new(
            format!("Ω* (n = {n}) = {w:.0}"),
            (w, f_max * 0.97),
            ("sans-serif", 13).into_font(),
        )))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Campbell diagram in the fixed frame: casing modes ω_c/2π (dashed, constant) and
/// impeller backward waves seen from the fixed frame (nΩ − ω_b(Ω))/2π (solid), one
/// colour per nodal diameter n; their crossings are the critical speeds Ω*ₙ
/// (DESIGN.md §5), marked by vertical lines.
pub fn campbell_diagram(data: &CampbellData, path: &Path) -> Result<(), PlotError> {
    if data.speeds_rad_s.len() < 2 || (data.casing.is_empty() && data.impeller.is_empty()) {
        return Err(PlotError::Empty(
            "Campbell diagram needs ≥ 2 speeds and at least one mode",
        ));
    }
    render(
        path,
        (1000, 700),
        |a| draw_campbell(a, data),
        |a| draw_campbell(a, data),
    )
}

fn draw_wear<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, d: &WearMapData) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let w_max_um = d
        .rows
        .iter()
        .flat_map(|r| r.wear_m.iter().copied())
        .fold(0.0, f64::max)
        * 1e6;
    let top = if w_max_um > 0.0 { w_max_um } else { 1.0 };
    let n_rows = d.rows.len();
    root.fill(&WHITE)?;
    let (main, bar) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(140));
    let labels: Vec<String> = d.rows.iter().map(|r| r.label.clone()).collect();
    let label_fmt = |y: &f64| {
        let i = y.floor();
        if i >= 0.0 && (y - i - 0.5).abs() < 1e-9 {
            labels.get(i as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    let mut chart = ChartBuilder::on(&main)
        .caption("Wear map: final wear depth vs angle", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(220)
        .build_cartesian_2d(0.0..360.0, 0.0..n_rows as f64)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .x_desc("angle θ (deg)")
        .y_labels(n_rows.min(40) * 2 + 1)
        .y_label_formatter(&label_fmt)
        .draw()?;
    for (i, r) in d.rows.iter().enumerate() {
        let n = r.wear_m.len().max(1) as f64;
        chart.draw_series(r.wear_m.iter().enumerate().map(|(k, &w)| {
            let t0 = 360.0 * k as f64 / n;
            Rectangle::new(
                [(t0, i as f64), (t0 + 360.0 / n, i as f64 + 1.0)],
                colormap(w * 1e6 / top).filled(),
            )
        }))?;
    }
    draw_colorbar(&bar, 0.0, top, "wear depth (µm)")?;
    root.present()?;
    Ok(())
}

/// Wear map: one row per job, colour = final wear depth (µm) over the angle θ ∈ [0°, 360°).
pub fn wear_map(data: &WearMapData, path: &Path) -> Result<(), PlotError> {
    if data.rows.is_empty() || data.rows.iter().all(|r| r.wear_m.is_empty()) {
        return Err(PlotError::Empty("wear map needs at least one wear profile"));
    }
    let height = (200 + 22 * data.rows.len()).clamp(400, 2000) as u32;
    render(
        path,
        (1000, height),
        |a| draw_wear(a, data),
        |a| draw_wear(a, data),
    )
}

/// Interaction-map data from job records (ok jobs with a spectrum). Pass one slice of a
/// sweep (e.g. fixed μ and coating): columns at the same speed replace each other.
/// Critical speeds are the distinct `critical_speed_rad_s` values of the records.
pub fn interaction_data_from_records<'a>(
    records: impl IntoIterator<Item = &'a JobRecord>,
    engine_orders: Vec<u32>,
) -> InteractionMapData {
    let mut columns = Vec::new();
    let mut crit: Vec<f64> = Vec::new();
    for rec in records {
        let Some(res) = &rec.result else { continue };
        if let Some(s) = &res.spectrum {
            columns.push(SpectrumColumn {
                speed_rad_s: rec.params.speed_rad_s,
                df_hz: s.df_hz,
                amplitude_m: s.amplitude_m.clone(),
            });
        }
        if let Some(c) = res.critical_speed
            && !crit
                .iter()
                .any(|&w| (w - c.speed_rad_s).abs() <= 1e-9 * c.speed_rad_s.abs())
        {
            crit.push(c.speed_rad_s);
        }
    }
    InteractionMapData {
        columns,
        engine_orders,
        critical_speeds_rad_s: crit,
        max_frequency_hz: None,
        dynamic_range_decades: 4.0,
        subtitle: String::new(),
    }
}

/// Wear-map data from job records: per ok job, the wear at each angle maximised over the
/// meridian stations; labelled with Ω and μ.
pub fn wear_data_from_records<'a>(records: impl IntoIterator<Item = &'a JobRecord>) -> WearMapData {
    let rows = records
        .into_iter()
        .filter_map(|rec| {
            let res = rec.result.as_ref()?;
            let n = res.wear_profile_m.iter().map(Vec::len).max()?;
            let wear_m = (0..n)
                .map(|k| {
                    res.wear_profile_m
                        .iter()
                        .filter_map(|s| s.get(k))
                        .copied()
                        .fold(0.0, f64::max)
                })
                .collect();
            Some(WearRow {
                label: format!(
                    "Ω = {:.0} rad/s, μ = {}",
                    rec.params.speed_rad_s, rec.params.friction
                ),
                wear_m,
            })
        })
        .collect();
    WearMapData { rows }
}

/// Human-readable description of a job's non-speed parameters (the slice key of an
/// interaction map), e.g. `μ = 0.15, E ×0.1, e_abr = 0.00015 m`.
pub(crate) fn slice_label(p: &crate::sweep::JobParams) -> String {
    use crate::sweep::CoatingValue;
    let mut parts = vec![format!("μ = {}", p.friction)];
    if let Some(c) = p.clearance_m {
        parts.push(format!("clearance = {c} m"));
    }
    let c = &p.coating;
    for (name, unit, v) in [
        ("E", "Pa", c.young),
        ("K", "Pa", c.hardening),
        ("σ_Y", "Pa", c.yield_stress),
        ("e_abr", "m", c.thickness),
    ] {
        match v {
            Some(CoatingValue::Absolute(x)) => parts.push(format!("{name} = {x} {unit}")),
            Some(CoatingValue::Scale(f)) => parts.push(format!("{name} ×{f}")),
            None => {}
        }
    }
    parts.join(", ")
}

/// Writes the standard plots of a sweep output into `dir`: one interaction map per slice
/// of the grid (jobs sharing every parameter but the speed; `interaction_map.png`, or
/// `interaction_map_<k>.png` for slice k = 0, 1, … in job order when there are several)
/// when the jobs kept spectra, and `wear_map.png` when they have wear profiles.
/// Returns the files written. `records` are `(job index, record)` as from
/// [`crate::sweep::load_records`].
pub fn write_sweep_plots(
    dir: &Path,
    records: &[(usize, JobRecord)],
    engine_orders: &[u32],
) -> Result<Vec<PathBuf>, PlotError> {
    let mut written = Vec::new();
    let mut slices: Vec<(String, Vec<&JobRecord>)> = Vec::new();
    let mut sorted: Vec<&(usize, JobRecord)> = records.iter().collect();
    sorted.sort_by_key(|(i, _)| *i);
    for (_, rec) in &sorted {
        let key = slice_label(&rec.params);
        match slices.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(rec),
            None => slices.push((key, vec![rec])),
        }
    }
    let n_slices = slices.len();
    for (k, (label, recs)) in slices.into_iter().enumerate() {
        let mut data = interaction_data_from_records(recs, engine_orders.to_vec());
        if data.columns.iter().all(|c| c.amplitude_m.is_empty()) {
            continue;
        }
        data.subtitle = label;
        let path = if n_slices == 1 {
            dir.join("interaction_map.png")
        } else {
            dir.join(format!("interaction_map_{k}.png"))
        };
        interaction_map(&data, &path)?;
        written.push(path);
    }
    let wear = wear_data_from_records(sorted.iter().map(|(_, r)| r));
    if wear.rows.iter().any(|r| !r.wear_m.is_empty()) {
        let path = dir.join("wear_map.png");
        wear_map(&wear, &path)?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rubscan-plots-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn colormap_endpoints_and_monotone_luminance() {
        assert_eq!(colormap(0.0), RGBColor(68, 1, 84));
        assert_eq!(colormap(1.0), RGBColor(253, 231, 37));
        assert_eq!(colormap(f64::NAN), colormap(0.0));
        let lum = |c: RGBColor| {
            0.2126 * f64::from(c.0) + 0.7152 * f64::from(c.1) + 0.0722 * f64::from(c.2)
        };
        let mut prev = -1.0;
        for i in 0..=100 {
            let l = lum(colormap(i as f64 / 100.0));
            assert!(l >= prev - 1.0, "luminance drops at {i}");
            prev = l;
        }
    }

    #[test]
    fn cell_edges_bracket_columns() {
        assert_eq!(cell_edges(&[1.0, 2.0, 4.0]), vec![0.5, 1.5, 3.0, 5.0]);
    }

    fn interaction() -> InteractionMapData {
        // Peaks on the EO 2 line f = 2Ω/2π at each speed.
        let df = 5.0;
        let columns = (0..11)
            .map(|i| {
                let w = 500.0 + 100.0 * i as f64;
                let f2 = 2.0 * w / TAU;
                SpectrumColumn {
                    speed_rad_s: w,
                    df_hz: df,
                    amplitude_m: (0..100)
                        .map(|k| 1e-6 + 1e-4 * (-((k as f64 * df - f2) / 10.0).powi(2)).exp())
                        .collect(),
                }
            })
            .collect();
        InteractionMapData {
            columns,
            engine_orders: vec![2, 4],
            critical_speeds_rad_s: vec![1000.0],
            max_frequency_hz: None,
            dynamic_range_decades: 3.0,
            subtitle: "μ = 0.1".into(),
        }
    }

    #[test]
    fn all_plots_render_png_and_svg() {
        let d = tmpdir("all");
        let camp = CampbellData {
            speeds_rad_s: (0..=20).map(|i| 100.0 * i as f64).collect(),
            casing: vec![CasingMode {
                nodal_diameter: 2,
                omega_rad_s: 1500.0,
            }],
            impeller: vec![ImpellerBranch {
                nodal_diameter: 2,
                omega_rad_s: (0..=20)
                    .map(|i| 800.0 + 1e-5 * (100.0 * i as f64).powi(2))
                    .collect(),
            }],
            critical_speeds: vec![(1150.0, 2)],
        };
        let wear = WearMapData {
            rows: (0..5)
                .map(|i| WearRow {
                    label: format!("job {i}"),
                    wear_m: (0..36)
                        .map(|k| 1e-5 * (1.0 + (2.0 * TAU * k as f64 / 36.0).cos()) * i as f64)
                        .collect(),
                })
                .collect(),
        };
        for ext in ["png", "svg"] {
            let p = d.join(format!("map.{ext}"));
            interaction_map(&interaction(), &p).unwrap();
            let c = d.join(format!("campbell.{ext}"));
            campbell_diagram(&camp, &c).unwrap();
            let w = d.join(format!("wear.{ext}"));
            wear_map(&wear, &w).unwrap();
            for f in [&p, &c, &w] {
                let bytes = std::fs::read(f).unwrap();
                if ext == "png" {
                    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", f.display());
                    assert!(bytes.len() > 5000, "{} suspiciously small", f.display());
                } else {
                    let s = String::from_utf8(bytes).unwrap();
                    assert!(s.contains("<svg"), "{}", f.display());
                }
            }
        }
        let svg = std::fs::read_to_string(d.join("map.svg")).unwrap();
        assert!(svg.contains("EO 2") && svg.contains("EO 4") && svg.contains("Ω* = 1000"));
        let svg = std::fs::read_to_string(d.join("campbell.svg")).unwrap();
        assert!(svg.contains("casing ω_c, n = 2") && svg.contains("Ω* (n = 2) = 1150"));
        // No temporary files left.
        let names: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 6, "{names:?}");
        assert!(matches!(
            interaction_map(&interaction(), &d.join("x.pdf")),
            Err(PlotError::Format(_))
        ));
        assert!(matches!(
            wear_map(&WearMapData { rows: vec![] }, &d.join("w.png")),
            Err(PlotError::Empty(_))
        ));
        if std::env::var_os("RUBSCAN_KEEP_PLOTS").is_none() {
            std::fs::remove_dir_all(&d).unwrap();
        }
    }
}
