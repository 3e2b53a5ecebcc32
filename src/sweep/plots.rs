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

use plotters::coord::ranged1d::Ranged;
use plotters::coord::types::RangedCoordf64;

use crate::io::atomic::write_atomic;
use crate::sweep::CriticalSpeed;
use crate::sweep::checkpoint::JobRecord;
use crate::sweep::labels::{LabelBox, LabelRequest, place_labels};
use crate::sweep::planner::slice_label;

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
    /// Natural-frequency curves drawn over the map (dashed), e.g. the blade modes of the
    /// nodal diameters of the critical speeds.
    pub mode_lines: Vec<ModeLine>,
}

/// A frequency curve over speed drawn on an interaction map.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeLine {
    /// Label, e.g. "impeller n = 5, mode 1".
    pub label: String,
    /// Speeds Ω (rad/s), increasing.
    pub speeds_rad_s: Vec<f64>,
    /// Frequency (Hz) at each speed.
    pub frequency_hz: Vec<f64>,
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
    /// Critical speeds to mark (speed, nodal diameter, compatibility).
    pub critical_speeds: Vec<CriticalSpeed>,
    /// Speed range (rad/s) shaded as the swept one, if any.
    pub speed_band_rad_s: Option<(f64, f64)>,
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

/// Distinct colours per nodal diameter.
fn nd_color(n: u32) -> RGBColor {
    tab10(n as usize)
}

/// The `i`-th of ten distinct colours, cycling (Tableau 10, readable on white).
pub(crate) fn tab10(i: usize) -> RGBColor {
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
    let (r, g, b) = TAB10[i % TAB10.len()];
    RGBColor(r, g, b)
}

pub(crate) type DrawResult<T = ()> = Result<T, Box<dyn std::error::Error>>;

/// Renders a figure of `size` pixels to `path`, PNG or SVG by extension: drawn in memory, then
/// written atomically ([`write_atomic`]), so a plot is either complete or absent. Returns what
/// the drawing returns (e.g. the placed labels).
pub(crate) fn render<R>(
    path: &Path,
    size: (u32, u32),
    draw_png: impl FnOnce(DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult<R>,
    draw_svg: impl FnOnce(DrawingArea<SVGBackend<'_>, Shift>) -> DrawResult<R>,
) -> Result<R, PlotError> {
    ensure_font()?;
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .ok_or_else(|| PlotError::Format(path.to_path_buf()))?;
    let err = |message: String| PlotError::Draw {
        path: path.to_path_buf(),
        message,
    };
    let (bytes, out) = match ext.as_str() {
        "png" => {
            let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
            let out = draw_png(BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area())
                .map_err(|e| err(e.to_string()))?;
            (encode_png(&rgb, size).map_err(|e| err(e.to_string()))?, out)
        }
        "svg" => {
            let mut svg = String::new();
            let out = draw_svg(SVGBackend::with_string(&mut svg, size).into_drawing_area())
                .map_err(|e| err(e.to_string()))?;
            (svg.into_bytes(), out)
        }
        _ => return Err(PlotError::Format(path.to_path_buf())),
    };
    write_atomic(path, &bytes).map_err(|e| err(e.to_string()))?;
    Ok(out)
}

/// An 8-bit RGB image as PNG bytes.
fn encode_png(rgb: &[u8], size: (u32, u32)) -> Result<Vec<u8>, png::EncodingError> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, size.0, size.1);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()?.write_image_data(rgb)?;
    Ok(bytes)
}

/// Width and height (pixels) of `text` in the plot font at `size` points.
pub fn text_size(text: &str, size: f64) -> (u32, u32) {
    ("sans-serif", size).into_font().box_size(text).unwrap_or((
        text.chars().count() as u32 * size as u32 * 6 / 10,
        size as u32,
    ))
}

/// A tick label with at most `prec` decimals and no trailing zeros ("0.25", never
/// "0.250000000").
pub(crate) fn tick_label(v: f64, prec: usize) -> String {
    let s = format!("{v:.prec$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" { "0".into() } else { s }
}

/// Decimals that tell ticks `span / 5` apart.
pub(crate) fn tick_decimals(span: f64) -> usize {
    if span > 0.0 && span.is_finite() {
        (-(span / 5.0).log10()).ceil().clamp(0.0, 6.0) as usize
    } else {
        0
    }
}

/// A label drawn on a figure: its text and its box in pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedLabel {
    /// The text.
    pub text: String,
    /// Its box (pixels, y down) in the figure.
    pub bbox: LabelBox,
}

/// The labels of a figure: those drawn (boxes disjoint by construction) and those left out
/// because no free place was found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlotLabels {
    /// Labels drawn, with their boxes.
    pub placed: Vec<PlacedLabel>,
    /// Texts of the labels left out.
    pub dropped: Vec<String>,
}

/// A label to place on a figure: text, size (points), colour and candidate corners.
pub(crate) struct Pending {
    /// The text.
    pub(crate) text: String,
    /// Font size (points).
    pub(crate) size: f64,
    /// Text colour.
    pub(crate) color: RGBColor,
    /// Candidate top-left corners (pixels), best first.
    pub(crate) candidates: Vec<(i32, i32)>,
    /// Box drawn behind the text (labels over a colour map), if any.
    pub(crate) background: Option<RGBAColor>,
}

/// Places `pending` labels (priority order) inside `area`, away from `obstacles`, draws the
/// placed ones on `root` and returns them, with each pending label's box (`None`: left out).
pub(crate) fn draw_labels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    pending: Vec<Pending>,
    area: LabelBox,
    obstacles: &[LabelBox],
) -> DrawResult<(PlotLabels, Vec<Option<LabelBox>>)>
where
    DB::ErrorType: 'static,
{
    let requests: Vec<LabelRequest> = pending
        .iter()
        .map(|p| LabelRequest {
            size: text_size(&p.text, p.size),
            candidates: p.candidates.clone(),
        })
        .collect();
    let mut labels = PlotLabels::default();
    let boxes = place_labels(&requests, area, obstacles, 2);
    for (p, b) in pending.into_iter().zip(boxes.iter().copied()) {
        match b {
            Some(bbox) => {
                if let Some(bg) = p.background {
                    root.draw(&Rectangle::new(
                        [(bbox.x0 - 1, bbox.y0 - 1), (bbox.x1 + 1, bbox.y1 + 1)],
                        bg.filled(),
                    ))?;
                }
                root.draw(&Text::new(
                    p.text.clone(),
                    (bbox.x0, bbox.y0),
                    ("sans-serif", p.size).into_font().color(&p.color),
                ))?;
                labels.placed.push(PlacedLabel { text: p.text, bbox });
            }
            None => labels.dropped.push(p.text),
        }
    }
    Ok((labels, boxes))
}

/// The pixel box of a chart's plotting area.
pub(crate) fn plot_box<DB: DrawingBackend, X: Ranged, Y: Ranged>(
    chart: &ChartContext<'_, DB, Cartesian2d<X, Y>>,
) -> LabelBox {
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    LabelBox {
        x0: xr.start,
        y0: yr.start,
        x1: xr.end,
        y1: yr.end,
    }
}

/// `n` in Unicode subscript digits (Ω*₅).
pub(crate) fn subscript(n: u32) -> String {
    n.to_string()
        .chars()
        .map(|c| char::from_u32(0x2080 + c.to_digit(10).unwrap_or(0)).unwrap_or(c))
        .collect()
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
) -> DrawResult<PlotLabels>
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
    // The colour scale spans the amplitudes shown (the band), not the whole spectrum.
    let a_max = cols
        .iter()
        .flat_map(|c| {
            c.amplitude_m
                .iter()
                .enumerate()
                .filter(|&(k, _)| k as f64 * c.df_hz < f_max)
                .map(|(_, &a)| a)
        })
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
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(edges[0]..edges[edges.len() - 1], 0.0..f_max)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .x_desc("rotation speed Ω (rad/s)")
        .y_desc("frequency (Hz)")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
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
                [(x0, f0), (x1, (f0 + c.df_hz).min(f_max))],
                colormap(level).filled(),
            ))
        }))?;
    }
    let mut pending = interaction_lines(&mut chart, d, f_max)?;
    let area = plot_box(&chart);
    // Ω* labels go in rows below the top edge, beside their line.
    for &w in &d.critical_speeds_rad_s {
        let (x_lo, x_hi) = (edges[0], edges[edges.len() - 1]);
        if w < x_lo || w > x_hi {
            continue;
        }
        let text = format!("Ω* = {w:.0}");
        let (tw, th) = text_size(&text, 14.0);
        let (px, _) = chart.backend_coord(&(w, f_max));
        let candidates = (0..8)
            .flat_map(|k| {
                let y = area.y0 + 4 + k * (th as i32 + 4);
                [(px + 4, y), (px - 4 - tw as i32, y)]
            })
            .collect();
        pending.push(Pending {
            text,
            size: 14.0,
            color: RGBColor(255, 120, 120),
            candidates,
            background: Some(BLACK.mix(0.45)),
        });
    }
    let (labels, _) = draw_labels(&root, pending, area, &[])?;
    draw_colorbar(&bar, bottom, top, "log10 amplitude (m)")?;
    root.present()?;
    Ok(labels)
}

type MapChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Candidate label corners along a visible line segment from `a` to `b` (pixels), near its
/// end first: above-left of the line, then below-right.
fn along_segment(a: (i32, i32), b: (i32, i32), size: (u32, u32)) -> Vec<(i32, i32)> {
    let (w, h) = (size.0 as i32, size.1 as i32);
    [0.97, 0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2]
        .iter()
        .flat_map(|&t| {
            let x = a.0 + (t * f64::from(b.0 - a.0)) as i32;
            let y = a.1 + (t * f64::from(b.1 - a.1)) as i32;
            [(x - w - 3, y - h - 3), (x + 3, y + 3)]
        })
        .collect()
}

/// Draws the engine-order lines, the mode curves and the critical-speed lines of an
/// interaction map; returns their labels to place.
fn interaction_lines<DB: DrawingBackend>(
    chart: &mut MapChart<'_, DB>,
    d: &InteractionMapData,
    f_max: f64,
) -> DrawResult<Vec<Pending>>
where
    DB::ErrorType: 'static,
{
    let (x_lo, x_hi) = (chart.x_range().start, chart.x_range().end);
    let mut pending = Vec::new();
    for &e in &d.engine_orders {
        let e = f64::from(e);
        // Clip the line f = e Ω / 2π to the plot box.
        let x_end = x_hi.min(f_max * TAU / e);
        if x_end <= x_lo {
            continue;
        }
        let (p0, p1) = ((x_lo, e * x_lo / TAU), (x_end, e * x_end / TAU));
        chart.draw_series(LineSeries::new([p0, p1], WHITE.stroke_width(1)))?;
        let text = format!("EO {e}");
        let size = text_size(&text, 14.0);
        pending.push(Pending {
            candidates: along_segment(chart.backend_coord(&p0), chart.backend_coord(&p1), size),
            text,
            size: 14.0,
            color: WHITE,
            background: Some(BLACK.mix(0.45)),
        });
    }
    let mode_color = RGBColor(255, 170, 200);
    for m in &d.mode_lines {
        let pts: Vec<(f64, f64)> = m
            .speeds_rad_s
            .iter()
            .zip(&m.frequency_hz)
            .map(|(&w, &f)| (w, f))
            .filter(|&(w, f)| w >= x_lo && w <= x_hi && f <= f_max && f >= 0.0)
            .collect();
        let (Some(&first), Some(&last)) = (pts.first(), pts.last()) else {
            continue;
        };
        chart.draw_series(DashedLineSeries::new(pts, 6, 4, mode_color.stroke_width(2)))?;
        let size = text_size(&m.label, 13.0);
        pending.push(Pending {
            candidates: along_segment(
                chart.backend_coord(&first),
                chart.backend_coord(&last),
                size,
            ),
            text: m.label.clone(),
            size: 13.0,
            color: mode_color,
            background: Some(BLACK.mix(0.45)),
        });
    }
    for &w in &d.critical_speeds_rad_s {
        if w >= x_lo && w <= x_hi {
            chart.draw_series(LineSeries::new(
                [(w, 0.0), (w, f_max)],
                RGBColor(255, 90, 90).stroke_width(2),
            ))?;
        }
    }
    Ok(pending)
}

/// Interaction map: colour = log10 of the blade-tip spectrum amplitude over speed Ω
/// (x, rad/s) and frequency (y, Hz, up to `max_frequency_hz`), with engine-order lines
/// f = E Ω/2π, mode curves (dashed) and the predicted critical speeds Ω* as vertical red
/// lines. Labels never overlap: crowded ones are moved along their line or left out
/// (returned in [`PlotLabels::dropped`]).
pub fn interaction_map(data: &InteractionMapData, path: &Path) -> Result<PlotLabels, PlotError> {
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

/// Frequency (Hz) of the crossing of a critical speed: its casing mode, or 0 (the
/// engine-order crossing of a casing without modes).
fn crossing_hz(d: &CampbellData, n: u32) -> f64 {
    d.casing
        .iter()
        .find(|c| c.nodal_diameter == n)
        .map_or(0.0, |c| c.omega_rad_s / TAU)
}

/// The Campbell diagram's legend (top left of the plot): one colour per nodal diameter, the
/// line styles, the marker. Returns its box, which labels then avoid.
fn campbell_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &CampbellData,
    at: (i32, i32),
) -> DrawResult<LabelBox>
where
    DB::ErrorType: 'static,
{
    let mut diameters: Vec<u32> = d
        .casing
        .iter()
        .map(|c| c.nodal_diameter)
        .chain(d.impeller.iter().map(|b| b.nodal_diameter))
        .collect();
    diameters.sort_unstable();
    diameters.dedup();
    let nd: Vec<String> = diameters.iter().map(|n| format!("n = {n}")).collect();
    let mut rows: Vec<(String, Option<RGBColor>)> = vec![(nd.join("   "), None)];
    rows.push(("solid: impeller (nΩ − ω_b)/2π".into(), None));
    rows.push(("dashed: casing ω_c/2π".into(), None));
    rows.push(("●  Ω*ₙ, C = mode compatibility (0–1)".into(), None));
    if d.speed_band_rad_s.is_some() {
        rows.push(("shaded: speeds of the sweep".into(), None));
    }
    let size = 13.0;
    let line_h = text_size("Hg", size).1 as i32 + 4;
    let width = rows
        .iter()
        .map(|(t, _)| text_size(t, size).0 as i32)
        .max()
        .unwrap_or(0)
        + 16;
    let bbox = LabelBox::at(at, (width as u32, (line_h * rows.len() as i32 + 8) as u32));
    root.draw(&Rectangle::new(
        [(bbox.x0, bbox.y0), (bbox.x1, bbox.y1)],
        WHITE.mix(0.9).filled(),
    ))?;
    root.draw(&Rectangle::new(
        [(bbox.x0, bbox.y0), (bbox.x1, bbox.y1)],
        BLACK.stroke_width(1),
    ))?;
    // First row: the nodal diameters, each in its colour.
    let mut x = bbox.x0 + 8;
    for (n, t) in diameters.iter().zip(&nd) {
        root.draw(&Text::new(
            t.clone(),
            (x, bbox.y0 + 4),
            ("sans-serif", size).into_font().color(&nd_color(*n)),
        ))?;
        x += text_size(&format!("{t}   "), size).0 as i32;
    }
    for (i, (t, _)) in rows.iter().enumerate().skip(1) {
        root.draw(&Text::new(
            t.clone(),
            (bbox.x0 + 8, bbox.y0 + 4 + line_h * i as i32),
            ("sans-serif", size).into_font(),
        ))?;
    }
    Ok(bbox)
}

/// Label candidates around a marker at `p`: right/left, above/below, then further away in
/// rows of the label's height.
pub(crate) fn around_marker(p: (i32, i32), size: (u32, u32)) -> Vec<(i32, i32)> {
    let (w, h) = (size.0 as i32, size.1 as i32);
    (0..14)
        .flat_map(|k| {
            let dy = k * (h + 3);
            [
                (p.0 + 7, p.1 - h - 5 - dy),
                (p.0 + 7, p.1 + 5 + dy),
                (p.0 - 7 - w, p.1 - h - 5 - dy),
                (p.0 - 7 - w, p.1 + 5 + dy),
            ]
        })
        .collect()
}

fn draw_campbell<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    d: &CampbellData,
) -> DrawResult<PlotLabels>
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
        .caption(
            "Campbell diagram (fixed frame): critical speeds Ω*ₙ and mode compatibility C",
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x_lo..x_hi, 0.0..f_max)?;
    draw_speed_mesh(&mut chart, "frequency (Hz)", &|v| format!("{v:.0}"))?;
    draw_campbell_curves(&mut chart, d, (x_lo, x_hi), f_max)?;
    let area = plot_box(&chart);
    let legend = campbell_legend(&root, d, (area.x0 + 8, area.y0 + 8))?;
    let labels = label_critical_speeds(&root, &mut chart, d, (x_lo, x_hi), legend)?;
    root.present()?;
    Ok(labels)
}

/// The swept speed band and the mode lines of the Campbell diagram: casing modes dashed,
/// impeller backward waves seen from the fixed frame solid (speeds `x` in rad/s, up to
/// `f_max` Hz).
/// Draws the mesh of a chart against rotation speed, as every speed-scan figure has it: a
/// light grid, Ω in rad/s on x without decimals, `y_desc` and the `y_label` ticks on y.
pub(crate) fn draw_speed_mesh<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    y_desc: &str,
    y_label: &dyn Fn(&f64) -> String,
) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .bold_line_style(BLACK.mix(0.12))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .x_desc("rotation speed Ω (rad/s)")
        .y_desc(y_desc)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(y_label)
        .draw()?;
    Ok(())
}

fn draw_campbell_curves<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    d: &CampbellData,
    (x_lo, x_hi): (f64, f64),
    f_max: f64,
) -> DrawResult<()>
where
    DB::ErrorType: 'static,
{
    let hz = |w: f64| w / TAU;
    if let Some((a, b)) = d.speed_band_rad_s {
        // A single-speed sweep still shows: at least 0.6 % of the axis wide.
        let half = (0.5 * (b - a)).max(0.003 * (x_hi - x_lo));
        let mid = 0.5 * (a + b);
        chart.draw_series(std::iter::once(Rectangle::new(
            [
                ((mid - half).max(x_lo), 0.0),
                ((mid + half).min(x_hi), f_max),
            ],
            RGBColor(255, 200, 120).mix(0.35).filled(),
        )))?;
    }
    for c in &d.casing {
        let color = nd_color(c.nodal_diameter);
        let f = hz(c.omega_rad_s);
        chart.draw_series(DashedLineSeries::new(
            [(x_lo, f), (x_hi, f)],
            8,
            5,
            color.stroke_width(2),
        ))?;
    }
    for b in &d.impeller {
        let color = nd_color(b.nodal_diameter);
        let n = f64::from(b.nodal_diameter);
        // Only the part seen as a positive frequency in the fixed frame can meet ω_c > 0.
        chart.draw_series(LineSeries::new(
            d.speeds_rad_s
                .iter()
                .zip(&b.omega_rad_s)
                .map(|(&w, &wb)| (w, hz(n * w - wb)))
                .filter(|&(_, f)| f >= 0.0),
            color.stroke_width(2),
        ))?;
    }
    Ok(())
}

/// Markers at the critical speeds' crossings and their labels, placed away from the
/// `legend` box, with leader lines to labels set apart and a note of those left out.
fn label_critical_speeds<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    d: &CampbellData,
    (x_lo, x_hi): (f64, f64),
    legend: LabelBox,
) -> DrawResult<PlotLabels>
where
    DB::ErrorType: 'static,
{
    let area = plot_box(chart);
    // Markers at the crossings, then labels: the most compatible first (the ones that
    // matter), so crowding drops the least compatible.
    let mut crit: Vec<&CriticalSpeed> = d
        .critical_speeds
        .iter()
        .filter(|c| c.speed_rad_s >= x_lo && c.speed_rad_s <= x_hi)
        .collect();
    crit.sort_by(|a, b| {
        b.compatibility
            .total_cmp(&a.compatibility)
            .then(a.speed_rad_s.total_cmp(&b.speed_rad_s))
    });
    let mut obstacles = vec![legend];
    let mut pending = Vec::new();
    for c in &crit {
        let p = (c.speed_rad_s, crossing_hz(d, c.nodal_diameter));
        let px = chart.backend_coord(&p);
        chart.draw_series(std::iter::once(Circle::new(
            p,
            4,
            nd_color(c.nodal_diameter).filled(),
        )))?;
        chart.draw_series(std::iter::once(Circle::new(p, 4, BLACK.stroke_width(1))))?;
        obstacles.push(LabelBox::at((px.0 - 5, px.1 - 5), (11, 11)));
        let text = format!(
            "Ω*{} = {:.0} rad/s, C = {:.2}",
            subscript(c.nodal_diameter),
            c.speed_rad_s,
            c.compatibility
        );
        let size = text_size(&text, 13.0);
        pending.push((
            px,
            Pending {
                candidates: around_marker(px, size),
                text,
                size: 13.0,
                color: BLACK,
                background: Some(WHITE.mix(0.8)),
            },
        ));
    }
    let markers: Vec<(i32, i32)> = pending.iter().map(|(p, _)| *p).collect();
    let (labels, boxes) = draw_labels(
        root,
        pending.into_iter().map(|(_, l)| l).collect(),
        area,
        &obstacles,
    )?;
    // Leader lines from each marker to a label set away from it.
    for (p, b) in markers.iter().zip(&boxes) {
        let Some(b) = b else { continue };
        let q = (p.0.clamp(b.x0, b.x1 - 1), p.1.clamp(b.y0, b.y1 - 1));
        if (q.0 - p.0).abs() + (q.1 - p.1).abs() > 12 {
            root.draw(&PathElement::new([*p, q], BLACK.mix(0.5).stroke_width(1)))?;
        }
    }
    if !labels.dropped.is_empty() {
        let note = format!(
            "{} more Ω* not labelled (listed with the figure)",
            labels.dropped.len()
        );
        let (w, h) = text_size(&note, 13.0);
        let at = (area.x1 - w as i32 - 6, area.y1 - h as i32 - 6);
        root.draw(&Text::new(note, at, ("sans-serif", 13).into_font()))?;
    }
    Ok(labels)
}

/// Campbell diagram in the fixed frame: casing modes ω_c/2π (dashed, constant) and
/// impeller backward waves seen from the fixed frame (nΩ − ω_b(Ω))/2π (solid), one
/// colour per nodal diameter n; their crossings are the critical speeds Ω*ₙ
/// (DESIGN.md §5), marked at the crossing and labelled with their speed and the
/// compatibility C of the two mode shapes. Labels never overlap each other, the legend or
/// the markers: crowded ones move away (with a leader line) or are left out, least
/// compatible first ([`PlotLabels::dropped`]).
pub fn campbell_diagram(data: &CampbellData, path: &Path) -> Result<PlotLabels, PlotError> {
    if data.speeds_rad_s.len() < 2 || (data.casing.is_empty() && data.impeller.is_empty()) {
        return Err(PlotError::Empty(
            "Campbell diagram needs ≥ 2 speeds and at least one mode",
        ));
    }
    render(
        path,
        (1100, 750),
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
        mode_lines: Vec::new(),
    }
}

/// The wear depth at each angle, the deepest over the meridian stations of a
/// `[station][angle]` profile (empty without wear data).
pub(crate) fn deepest_wear(profile: &[Vec<f64>]) -> Vec<f64> {
    let n = profile.iter().map(Vec::len).max().unwrap_or(0);
    (0..n)
        .map(|k| {
            profile
                .iter()
                .filter_map(|s| s.get(k))
                .copied()
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Wear-map data from job records: per ok job, the wear at each angle maximised over the
/// meridian stations; labelled with Ω and μ.
pub fn wear_data_from_records<'a>(records: impl IntoIterator<Item = &'a JobRecord>) -> WearMapData {
    let rows = records
        .into_iter()
        .filter_map(|rec| {
            let res = rec.result.as_ref()?;
            let wear_m = deepest_wear(&res.wear_profile_m);
            if wear_m.is_empty() {
                return None;
            }
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
            mode_lines: vec![ModeLine {
                label: "blade mode 1, n = 2".into(),
                speeds_rad_s: vec![500.0, 1500.0],
                frequency_hz: vec![300.0, 320.0],
            }],
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
            critical_speeds: vec![CriticalSpeed {
                speed_rad_s: 1150.0,
                nodal_diameter: 2,
                compatibility: 0.9,
            }],
            speed_band_rad_s: Some((1000.0, 1500.0)),
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
        assert!(svg.contains("blade mode 1, n = 2"));
        let svg = std::fs::read_to_string(d.join("campbell.svg")).unwrap();
        assert!(svg.contains("casing ω_c/2π") && svg.contains("Ω*₂ = 1150 rad/s, C = 0.90"));
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
