//! The report's scan figure: a response maximum against the rotation speed Ω, one curve per
//! speed line (jobs sharing every parameter but Ω), a marker per job by outcome (`ok`,
//! `unstable`, `failed`), the Ω intervals found unstable shaded, and the predictions as
//! vertical lines: the interaction criterion's critical speeds Ω*, the flexible casing's
//! critical wave speed and the linear stability prediction's boundary (where its growth rate
//! changes sign), with the predicted growth rate on a secondary axis.
//!
//! The figure's data ([`scan_rows`], [`scan_data`]) are built apart from the drawing
//! ([`response_against_speed`]), so that tests check what is drawn without reading pixels.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::sweep::CriticalSpeed;
use crate::sweep::PredictedStability;
use crate::sweep::checkpoint::{JobRecord, JobStatus, Outcomes};
use crate::sweep::labels::LabelBox;
use crate::sweep::planner::slice_label;
use crate::sweep::plots::{
    DrawResult, Pending, PlotError, PlotLabels, draw_labels, draw_speed_mesh, plot_box, render,
    subscript, tab10, text_size, tick_decimals, tick_label,
};
use crate::sweep::refine::{PEAK_QUANTITIES, PointOutcome, quantity_of};

/// Column drawn against Ω unless the report is told otherwise (the spec's `refine.peak_of`).
pub const DEFAULT_SCAN_QUANTITY: &str = "max_blade_te_radial_m";

/// Speed lines drawn in job order; the line holding the strongest response is added when it
/// is not among them. More curves than this on one axis cannot be told apart.
pub const FIRST_SCAN_LINES: usize = 4;

/// The stability prediction stored with a job's result, if any.
pub fn predicted_of(record: &JobRecord) -> Option<PredictedStability> {
    record.result.as_ref()?.predicted
}

/// Refinement round that added a job (0: the coarse grid).
pub fn refinement_round_of(record: &JobRecord) -> u32 {
    record.refinement_round
}

/// A results-table column drawn against Ω, and the unit it is drawn in.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanQuantity {
    /// The column's name (one of [`PEAK_QUANTITIES`]).
    pub column: String,
    /// Unit on the axis (e.g. "mm").
    pub unit: &'static str,
    /// Factor from the column's unit to the axis unit (1000 for m → mm).
    pub scale: f64,
}

impl ScanQuantity {
    /// The quantity of `column`: lengths in mm, forces in N; `None` unless `column` is a
    /// numeric scalar column ([`PEAK_QUANTITIES`]).
    pub fn of(column: &str) -> Option<Self> {
        if !PEAK_QUANTITIES.contains(&column) {
            return None;
        }
        let (unit, scale) = [
            ("_m", "mm", 1e3),
            ("_n", "N", 1.0),
            ("_rad_s", "rad/s", 1.0),
            ("_hz", "Hz", 1.0),
        ]
        .into_iter()
        .find(|(suffix, _, _)| column.ends_with(suffix))
        .map_or(("1", 1.0), |(_, u, s)| (u, s));
        Some(ScanQuantity {
            column: column.to_string(),
            unit,
            scale,
        })
    }

    /// The axis title: the column's name and the axis unit.
    pub fn axis_label(&self) -> String {
        format!("{} ({})", self.column, self.unit)
    }
}

/// What the figure needs of one job.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanRow {
    /// Position of the job in the plan.
    pub job_index: usize,
    /// Its speed line: the parameters other than Ω (e.g. "μ = 0.15").
    pub line: String,
    /// Rotation speed Ω (rad/s).
    pub speed_rad_s: f64,
    /// How the job ended.
    pub outcome: PointOutcome,
    /// The quantity in its column's unit; `None` for a failed job or a null column.
    pub value: Option<f64>,
    /// An unstable job's measured growth rate σ (1/s) and onset time (s).
    pub runaway: Option<(f64, f64)>,
    /// The stability prediction at the job's Ω, when the table has it.
    pub predicted: Option<PredictedStability>,
    /// Refinement round that added the job (0: the coarse grid).
    pub refinement_round: u32,
    /// The nearest critical speed of the interaction criterion stored with the job.
    pub critical_speed: Option<CriticalSpeed>,
}

/// The figure's rows of `records` (`(job index, record)`), in job order.
pub fn scan_rows(records: &[(usize, JobRecord)], quantity: &ScanQuantity) -> Vec<ScanRow> {
    let mut rows: Vec<ScanRow> = records
        .iter()
        .map(|(i, r)| {
            let outcome = match r.status {
                JobStatus::Ok => PointOutcome::Ok,
                JobStatus::Unstable => PointOutcome::Unstable,
                JobStatus::Failed { .. } => PointOutcome::Failed,
            };
            let result = r.result.as_ref().filter(|_| r.succeeded());
            ScanRow {
                job_index: *i,
                line: slice_label(&r.params),
                speed_rad_s: r.params.speed_rad_s,
                outcome,
                value: result.and_then(|x| quantity_of(&quantity.column, x)),
                runaway: result
                    .and_then(|x| x.runaway.as_ref())
                    .map(|w| (w.growth_rate_per_s, w.onset_time_s)),
                predicted: predicted_of(r),
                refinement_round: refinement_round_of(r),
                critical_speed: result.and_then(|x| x.critical_speed),
            }
        })
        .collect();
    rows.sort_by_key(|r| r.job_index);
    rows
}

/// One job on the figure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanPoint {
    /// Rotation speed Ω (rad/s).
    pub speed_rad_s: f64,
    /// The quantity in the axis unit; `None` for a failed job (drawn on the axis floor).
    pub value: Option<f64>,
    /// How the job ended.
    pub outcome: PointOutcome,
    /// Added by a refinement round (drawn smaller).
    pub refined: bool,
}

/// Where the predicted growth rate changes sign between two neighbouring speeds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedBoundary {
    /// Speed (rad/s) at which the linear interpolation of the growth rate is zero.
    pub speed_rad_s: f64,
    /// True when the prediction is stable below and unstable above (an onset), false for a
    /// return to stability.
    pub onset: bool,
    /// Nodal diameter of the wave predicted to grow on the unstable side.
    pub nodal_diameter: u32,
}

/// One speed line of the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanLine {
    /// The line's parameters other than Ω.
    pub label: String,
    /// Its jobs in increasing Ω.
    pub points: Vec<ScanPoint>,
    /// Ω intervals (rad/s) shaded as unstable ([`unstable_spans`]).
    pub unstable_spans_rad_s: Vec<(f64, f64)>,
    /// The predicted growth rate: `(Ω in rad/s, σ in 1/s)` in increasing Ω.
    pub predicted_growth: Vec<(f64, f64)>,
    /// Where the prediction changes sign ([`predicted_boundaries`]).
    pub predicted_boundaries: Vec<PredictedBoundary>,
}

/// Overlays known from the models rather than from the rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScanOverlays {
    /// Critical speeds of the interaction criterion from the models; `None` (models not
    /// loaded): the distinct ones stored with the rows.
    pub critical_speeds: Option<Vec<CriticalSpeed>>,
    /// The flexible casing's critical wave speed (rad/s) and its nodal diameter.
    pub critical_wave_speed: Option<(f64, u32)>,
}

/// Input of [`response_against_speed`].
#[derive(Debug, Clone, PartialEq)]
pub struct ScanFigureData {
    /// The quantity drawn.
    pub quantity: ScanQuantity,
    /// The speed lines drawn, in job order.
    pub lines: Vec<ScanLine>,
    /// Speed lines of the whole table.
    pub lines_total: usize,
    /// Index in `lines` of the line holding the strongest response, when lines were left out.
    pub strongest_line: Option<usize>,
    /// Lowest and highest speed drawn (rad/s).
    pub speed_range_rad_s: (f64, f64),
    /// Critical speeds Ω* within that range, in increasing Ω.
    pub critical_speeds: Vec<CriticalSpeed>,
    /// The flexible casing's critical wave speed (rad/s) and nodal diameter, when known
    /// (drawn when within the range).
    pub critical_wave_speed: Option<(f64, u32)>,
    /// Outcomes of the whole table.
    pub outcomes: Outcomes,
    /// Smallest and largest measured growth rate (1/s) of the unstable jobs.
    pub growth_rate_range_per_s: Option<(f64, f64)>,
    /// Earliest and latest onset time (s) of the unstable jobs.
    pub onset_range_s: Option<(f64, f64)>,
    /// Whether any drawn job was added by refinement.
    pub has_refined: bool,
}

/// The Ω intervals (rad/s) of one speed line found unstable. Each run of consecutive
/// `unstable` points spans from half-way between the last `ok` speed below it and its first
/// speed to half-way between its last speed and the next `ok` speed above it; at an end of
/// the line (no `ok` neighbour) it stops at the unstable speed itself. Half-way is the best
/// estimate of a boundary known only to lie between two jobs (refined jobs, which bisect it,
/// narrow the shading). Failed points are skipped: a failure says nothing of stability.
/// `points` must be in increasing Ω.
pub fn unstable_spans(points: &[ScanPoint]) -> Vec<(f64, f64)> {
    let known: Vec<&ScanPoint> = points
        .iter()
        .filter(|p| p.outcome != PointOutcome::Failed)
        .collect();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < known.len() {
        if known[i].outcome != PointOutcome::Unstable {
            i += 1;
            continue;
        }
        let first = i;
        while i < known.len() && known[i].outcome == PointOutcome::Unstable {
            i += 1;
        }
        let lo = match first.checked_sub(1) {
            Some(b) => 0.5 * (known[b].speed_rad_s + known[first].speed_rad_s),
            None => known[first].speed_rad_s,
        };
        let hi = match known.get(i) {
            Some(a) => 0.5 * (known[i - 1].speed_rad_s + a.speed_rad_s),
            None => known[i - 1].speed_rad_s,
        };
        spans.push((lo, hi));
    }
    spans
}

/// Where a predicted growth rate changes sign between neighbouring speeds: the zero of its
/// linear interpolation. `samples` are `(Ω in rad/s, prediction)` in increasing Ω; σ > 0
/// counts as unstable, σ ≤ 0 as stable; non-finite rates are skipped.
pub fn predicted_boundaries(samples: &[(f64, PredictedStability)]) -> Vec<PredictedBoundary> {
    let finite: Vec<&(f64, PredictedStability)> = samples
        .iter()
        .filter(|(w, p)| w.is_finite() && p.growth_rate_per_s.is_finite())
        .collect();
    finite
        .windows(2)
        .filter_map(|pair| {
            let ((w0, p0), (w1, p1)) = (pair[0], pair[1]);
            let (g0, g1) = (p0.growth_rate_per_s, p1.growth_rate_per_s);
            if (g0 > 0.0) == (g1 > 0.0) {
                return None;
            }
            // Signs differ, so g1 − g0 ≠ 0 and the zero lies in [w0, w1].
            let speed_rad_s = w0 + (w1 - w0) * (-g0) / (g1 - g0);
            let onset = g1 > 0.0;
            Some(PredictedBoundary {
                speed_rad_s,
                onset,
                nodal_diameter: if onset {
                    p1.nodal_diameter
                } else {
                    p0.nodal_diameter
                },
            })
        })
        .collect()
}

/// One drawn speed line from its rows (in any order).
fn scan_line(label: &str, rows: &[&ScanRow], quantity: &ScanQuantity) -> ScanLine {
    let mut rows = rows.to_vec();
    rows.sort_by(|a, b| {
        a.speed_rad_s
            .total_cmp(&b.speed_rad_s)
            .then(a.job_index.cmp(&b.job_index))
    });
    let points: Vec<ScanPoint> = rows
        .iter()
        .map(|r| ScanPoint {
            speed_rad_s: r.speed_rad_s,
            value: r
                .value
                .filter(|_| r.outcome != PointOutcome::Failed)
                .map(|v| v * quantity.scale),
            outcome: r.outcome,
            refined: r.refinement_round > 0,
        })
        .collect();
    let mut predicted: Vec<(f64, PredictedStability)> = rows
        .iter()
        .filter_map(|r| Some((r.speed_rad_s, r.predicted?)))
        .collect();
    // The prediction depends on Ω and the line's parameters only: one sample per speed.
    predicted.dedup_by(|a, b| a.0 == b.0);
    ScanLine {
        label: label.to_string(),
        unstable_spans_rad_s: unstable_spans(&points),
        predicted_growth: predicted
            .iter()
            .map(|(w, p)| (*w, p.growth_rate_per_s))
            .collect(),
        predicted_boundaries: predicted_boundaries(&predicted),
        points,
    }
}

/// (min, max) of the values, `None` when there are none.
fn range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// The figure's data from the table's `rows` (as from [`scan_rows`]): the first
/// `first_lines` speed lines in job order and, when it is not among them, the one holding the
/// strongest response (the largest value of an `ok` or `unstable` job); the critical speeds
/// (the models', else the rows' own) within the drawn speed range; outcome counts, growth rates
/// and onsets over the whole table.
pub fn scan_data(
    rows: &[ScanRow],
    quantity: &ScanQuantity,
    overlays: &ScanOverlays,
    first_lines: usize,
) -> ScanFigureData {
    let mut groups: Vec<(&str, Vec<&ScanRow>)> = Vec::new();
    for r in rows {
        match groups.iter_mut().find(|(k, _)| *k == r.line) {
            Some((_, v)) => v.push(r),
            None => groups.push((&r.line, vec![r])),
        }
    }
    let strongest = groups
        .iter()
        .enumerate()
        .flat_map(|(g, (_, v))| v.iter().filter_map(move |r| Some((g, r.value?))))
        .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
        .map(|(g, _)| g);
    let mut chosen: Vec<usize> = (0..groups.len().min(first_lines.max(1))).collect();
    let mut strongest_line = None;
    if let Some(g) = strongest
        && !chosen.contains(&g)
    {
        chosen.push(g);
        strongest_line = Some(chosen.len() - 1);
    }
    let lines: Vec<ScanLine> = chosen
        .iter()
        .map(|&g| scan_line(groups[g].0, &groups[g].1, quantity))
        .collect();
    let speed_range_rad_s = range(
        lines
            .iter()
            .flat_map(|l| l.points.iter().map(|p| p.speed_rad_s)),
    )
    .unwrap_or((0.0, 0.0));
    let inside = |w: f64| w >= speed_range_rad_s.0 && w <= speed_range_rad_s.1;
    let mut critical_speeds: Vec<CriticalSpeed> = match &overlays.critical_speeds {
        Some(c) => c.clone(),
        None => rows.iter().filter_map(|r| r.critical_speed).collect(),
    };
    critical_speeds.retain(|c| inside(c.speed_rad_s));
    critical_speeds.sort_by(|a, b| {
        a.speed_rad_s
            .total_cmp(&b.speed_rad_s)
            .then(a.nodal_diameter.cmp(&b.nodal_diameter))
    });
    critical_speeds.dedup_by(|a, b| {
        a.nodal_diameter == b.nodal_diameter
            && (a.speed_rad_s - b.speed_rad_s).abs() <= 1e-9 * b.speed_rad_s.abs()
    });
    let outcomes = Outcomes {
        ok: count(rows, PointOutcome::Ok),
        unstable: count(rows, PointOutcome::Unstable),
        failed: count(rows, PointOutcome::Failed),
    };
    ScanFigureData {
        quantity: quantity.clone(),
        has_refined: lines.iter().flat_map(|l| &l.points).any(|p| p.refined),
        lines,
        lines_total: groups.len(),
        strongest_line,
        speed_range_rad_s,
        critical_speeds,
        critical_wave_speed: overlays.critical_wave_speed,
        outcomes,
        growth_rate_range_per_s: range(rows.iter().filter_map(|r| Some(r.runaway?.0))),
        onset_range_s: range(rows.iter().filter_map(|r| Some(r.runaway?.1))),
    }
}

fn count(rows: &[ScanRow], o: PointOutcome) -> usize {
    rows.iter().filter(|r| r.outcome == o).count()
}

/// `lo–hi unit`, or one value when they agree to the shown precision.
fn span_text(r: (f64, f64), unit: &str, fmt: fn(f64) -> String) -> String {
    let (a, b) = (fmt(r.0), fmt(r.1));
    if a == b {
        format!("{a} {unit}")
    } else {
        format!("{a}–{b} {unit}")
    }
}

/// The figure's caption on the page: what is drawn, the outcomes of the table (counts, the
/// unstable jobs' growth rates and onsets), the lines overlaid, and the labels left out.
pub fn scan_caption(d: &ScanFigureData, labels: &PlotLabels) -> String {
    let o = &d.outcomes;
    let mut c = format!(
        "{} ({}) against the rotation speed Ω (rad/s), one colour per speed line. Outcomes of \
         the {} jobs: {} ok (filled circles), {} unstable (triangles with a red rim; a runaway stops the job, \
         so their maxima run only to the stop), {} failed (crosses on the axis floor). ",
        d.quantity.column,
        d.quantity.unit,
        o.ok + o.unstable + o.failed,
        o.ok,
        o.unstable,
        o.failed
    );
    if let (Some(g), Some(t)) = (d.growth_rate_range_per_s, d.onset_range_s) {
        c += &format!(
            "Unstable jobs: growth rate σ {}, onset at t = {}. ",
            span_text(g, "1/s", |v| format!("{v:.3}")),
            span_text(t, "s", |v| format!("{v:.4}")),
        );
    }
    c += "Shaded red: Ω found unstable, from half-way between the last ok and the first \
          unstable speed to half-way between the last unstable and the next ok speed (failed \
          jobs skipped). ";
    if d.lines.len() < d.lines_total {
        c += &format!(
            "Speed lines drawn: {} of {} (the first {} in job order{}). ",
            d.lines.len(),
            d.lines_total,
            d.lines.len() - usize::from(d.strongest_line.is_some()),
            d.strongest_line.map_or(String::new(), |i| format!(
                " and {}, which holds the strongest response",
                d.lines[i].label
            ))
        );
    }
    c += &overlay_caption(d);
    if d.has_refined {
        c += "Smaller markers: jobs added by refinement. ";
    }
    if !labels.dropped.is_empty() {
        c += &format!(
            "Not labelled for lack of room: {}.",
            labels.dropped.join("; ")
        );
    }
    c.trim_end().to_string()
}

/// The caption's sentences on the vertical lines and the secondary axis.
fn overlay_caption(d: &ScanFigureData) -> String {
    let mut c = String::new();
    if d.critical_speeds.is_empty() {
        c += "No critical speed Ω* of the interaction criterion lies in the scanned range. ";
    } else {
        let list: Vec<String> = d
            .critical_speeds
            .iter()
            .map(|s| format!("{:.0} rad/s (n = {})", s.speed_rad_s, s.nodal_diameter))
            .collect();
        c += &format!(
            "Dark red dashed: critical speeds Ω* of the interaction criterion, {}. ",
            list.join(", ")
        );
    }
    match d.critical_wave_speed {
        Some((w, n)) => {
            let (lo, hi) = d.speed_range_rad_s;
            c += &format!(
                "The flexible casing's critical wave speed is {w:.0} rad/s (n = {n}){}. ",
                if w >= lo && w <= hi {
                    ": purple dash-dotted line"
                } else {
                    ", outside the scanned range"
                }
            );
        }
        None => c += "No critical wave speed (rigid casing or models not loaded). ",
    }
    let boundaries: Vec<String> = d
        .lines
        .iter()
        .flat_map(|l| {
            l.predicted_boundaries.iter().map(move |b| {
                format!(
                    "{} {:.0} rad/s (n = {}, {})",
                    if b.onset { "onset" } else { "restabilisation" },
                    b.speed_rad_s,
                    b.nodal_diameter,
                    l.label
                )
            })
        })
        .collect();
    if d.lines.iter().all(|l| l.predicted_growth.is_empty()) {
        c += "The table holds no linear stability prediction: no predicted boundary drawn. ";
    } else {
        c += "Thin dashed, right axis: the linear stability prediction's largest growth rate σ \
              (1/s, > 0 unstable). ";
        if boundaries.is_empty() {
            c += "Its sign does not change over the scanned range. ";
        } else {
            c += &format!(
                "Black: predicted stability boundary where σ changes sign (linear \
                 interpolation between neighbouring speeds): {}. ",
                boundaries.join("; ")
            );
        }
    }
    c
}

/// Colour of the unstable shading and of the unstable markers' rim.
const UNSTABLE_RED: RGBColor = RGBColor(214, 39, 40);
/// Colour of the critical speeds Ω*.
const CRITICAL_RED: RGBColor = RGBColor(150, 20, 20);
/// Colour of the critical wave speed.
const WAVE_PURPLE: RGBColor = RGBColor(120, 50, 170);

/// A legend entry's glyph.
#[derive(Clone, Copy)]
enum Glyph {
    Line(RGBColor),
    Dashed(RGBColor),
    Dot(u32),
    Triangle,
    Cross,
    Shade,
}

/// The legend's entries: the lines drawn, the outcome markers and the overlays present.
fn legend_entries(d: &ScanFigureData) -> Vec<(Glyph, String)> {
    let mut e: Vec<(Glyph, String)> = d
        .lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let strongest = if d.strongest_line == Some(i) {
                " (strongest response)"
            } else {
                ""
            };
            (Glyph::Line(tab10(i)), format!("{}{strongest}", l.label))
        })
        .collect();
    // Only what is drawn.
    let drawn = |o: PointOutcome| {
        d.lines
            .iter()
            .flat_map(|l| &l.points)
            .any(|p| p.outcome == o)
    };
    for (o, glyph, text) in [
        (PointOutcome::Ok, Glyph::Dot(5), "ok"),
        (
            PointOutcome::Unstable,
            Glyph::Triangle,
            "unstable (maxima to the stop)",
        ),
        (
            PointOutcome::Failed,
            Glyph::Cross,
            "failed (on the axis floor)",
        ),
    ] {
        if drawn(o) {
            e.push((glyph, text.into()));
        }
    }
    if d.has_refined {
        e.push((Glyph::Dot(3), "refined job".into()));
    }
    if d.lines.iter().any(|l| !l.unstable_spans_rad_s.is_empty()) {
        e.push((Glyph::Shade, "Ω found unstable".into()));
    }
    if !d.critical_speeds.is_empty() {
        e.push((
            Glyph::Dashed(CRITICAL_RED),
            "Ω*ₙ, interaction criterion".into(),
        ));
    }
    let (lo, hi) = d.speed_range_rad_s;
    if d.critical_wave_speed
        .is_some_and(|(w, _)| w >= lo && w <= hi)
    {
        e.push((Glyph::Dashed(WAVE_PURPLE), "critical wave speed".into()));
    }
    if d.lines.iter().any(|l| !l.predicted_growth.is_empty()) {
        e.push((Glyph::Line(BLACK), "predicted boundary (σ = 0)".into()));
        e.push((Glyph::Dashed(BLACK), "predicted σ (right axis)".into()));
    }
    e
}

/// Width (pixels) of a legend column for `entries`.
fn legend_column_width(entries: &[(Glyph, String)]) -> u32 {
    entries
        .iter()
        .map(|(_, t)| text_size(t, 13.0).0 + 44)
        .max()
        .unwrap_or(100)
        .max(100)
}

/// Height (pixels) of the legend strip of `d` in a figure `width` pixels wide.
fn legend_height(d: &ScanFigureData, width: u32) -> u32 {
    let entries = legend_entries(d);
    let per_row = ((width - 20) / legend_column_width(&entries)).max(1) as usize;
    16 + 20 * entries.len().div_ceil(per_row) as u32
}

/// The legend strip under the plot, in columns.
fn draw_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, d: &ScanFigureData) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let entries = legend_entries(d);
    let col_w = legend_column_width(&entries);
    let per_row = ((area.dim_in_pixel().0 - 20) / col_w).max(1) as usize;
    for (i, (glyph, text)) in entries.iter().enumerate() {
        let x = 20 + (i % per_row) as i32 * col_w as i32;
        let y = 8 + (i / per_row) as i32 * 20;
        let c = (x + 12, y + 8);
        match *glyph {
            Glyph::Line(col) => area.draw(&PathElement::new(
                [(x, c.1), (x + 24, c.1)],
                col.stroke_width(3),
            ))?,
            Glyph::Dashed(col) => {
                for k in 0..3 {
                    let x0 = x + 9 * k;
                    area.draw(&PathElement::new(
                        [(x0, c.1), (x0 + 5, c.1)],
                        col.stroke_width(2),
                    ))?;
                }
            }
            Glyph::Dot(r) => area.draw(&Circle::new(c, r, BLACK.filled()))?,
            Glyph::Triangle => {
                area.draw(&TriangleMarker::new(c, 9, UNSTABLE_RED.filled()))?;
                area.draw(&TriangleMarker::new(c, 6, BLACK.filled()))?;
            }
            Glyph::Cross => area.draw(&Cross::new(c, 5, BLACK.stroke_width(2)))?,
            Glyph::Shade => area.draw(&Rectangle::new(
                [(x, y), (x + 24, y + 16)],
                UNSTABLE_RED.mix(0.15).filled(),
            ))?,
        }
        area.draw(&Text::new(
            text.clone(),
            (x + 32, y),
            ("sans-serif", 13).into_font(),
        ))?;
    }
    Ok(())
}

/// A vertical line of the figure with its label.
struct Marker {
    speed_rad_s: f64,
    text: String,
    color: RGBColor,
    dashed: bool,
}

/// The vertical lines in drawing priority: predicted boundaries (the answer the scan checks),
/// the critical wave speed, then the critical speeds, most compatible first.
fn vertical_lines(d: &ScanFigureData) -> Vec<Marker> {
    let (lo, hi) = d.speed_range_rad_s;
    let mut out: Vec<Marker> = d
        .lines
        .iter()
        .flat_map(|l| &l.predicted_boundaries)
        .map(|b| Marker {
            speed_rad_s: b.speed_rad_s,
            text: format!(
                "predicted {} {:.0} (n = {})",
                if b.onset { "onset" } else { "stable above" },
                b.speed_rad_s,
                b.nodal_diameter
            ),
            color: BLACK,
            dashed: false,
        })
        .collect();
    if let Some((w, n)) = d.critical_wave_speed
        && w >= lo
        && w <= hi
    {
        out.push(Marker {
            speed_rad_s: w,
            text: format!("critical wave speed {w:.0} (n = {n})"),
            color: WAVE_PURPLE,
            dashed: true,
        });
    }
    let mut crit: Vec<&CriticalSpeed> = d.critical_speeds.iter().collect();
    crit.sort_by(|a, b| b.compatibility.total_cmp(&a.compatibility));
    out.extend(crit.into_iter().map(|c| Marker {
        speed_rad_s: c.speed_rad_s,
        text: format!("Ω*{} = {:.0}", subscript(c.nodal_diameter), c.speed_rad_s),
        color: CRITICAL_RED,
        dashed: true,
    }));
    out
}

type ScanChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// Draws the curves and the outcome markers; returns the markers' pixel boxes (obstacles to
/// the labels).
fn draw_points<DB: DrawingBackend>(
    chart: &mut ScanChart<'_, DB>,
    d: &ScanFigureData,
) -> DrawResult<Vec<LabelBox>>
where
    DB::ErrorType: 'static,
{
    let mut boxes = Vec::new();
    for (i, l) in d.lines.iter().enumerate() {
        let color = tab10(i);
        chart.draw_series(LineSeries::new(
            l.points
                .iter()
                .filter_map(|p| Some((p.speed_rad_s, p.value?))),
            color.stroke_width(4),
        ))?;
        for p in &l.points {
            let r = if p.refined { 5 } else { 7 };
            let at = (p.speed_rad_s, p.value.unwrap_or(0.0));
            match (p.outcome, p.value) {
                (PointOutcome::Failed, _) | (_, None) => {
                    chart.draw_series(std::iter::once(Cross::new(
                        at,
                        r + 1,
                        color.stroke_width(2),
                    )))?;
                }
                (PointOutcome::Unstable, Some(_)) => {
                    // plotters fills every triangle: a red one under the line's colour
                    // draws a red rim, so the outcome and the line both show.
                    chart.draw_series(std::iter::once(TriangleMarker::new(
                        at,
                        r + 4,
                        UNSTABLE_RED.filled(),
                    )))?;
                    chart.draw_series(std::iter::once(TriangleMarker::new(
                        at,
                        r + 1,
                        color.filled(),
                    )))?;
                }
                (PointOutcome::Ok, Some(_)) => {
                    chart.draw_series(std::iter::once(Circle::new(at, r, color.filled())))?;
                }
            }
            let px = chart.backend_coord(&at);
            let m = r + 3;
            boxes.push(LabelBox::at(
                (px.0 - m, px.1 - m),
                (2 * m as u32, 2 * m as u32),
            ));
        }
    }
    Ok(boxes)
}

/// The drawn x range: the speed range padded by 4 % (a single speed by ±5 %).
fn x_range(d: &ScanFigureData) -> (f64, f64) {
    let (lo, hi) = d.speed_range_rad_s;
    if hi > lo {
        let pad = 0.04 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let half = (0.05 * lo.abs()).max(1.0);
        (lo - half, hi + half)
    }
}

fn draw_scan<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    d: &ScanFigureData,
    legend_h: u32,
) -> DrawResult<PlotLabels>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let h = root.dim_in_pixel().1;
    let (main, legend) = root.split_vertically(h.saturating_sub(legend_h));
    let (x_lo, x_hi) = x_range(d);
    let v_max = d
        .lines
        .iter()
        .flat_map(|l| l.points.iter().filter_map(|p| p.value))
        .fold(0.0, f64::max);
    // A third above the largest value holds the lines' labels clear of the curves.
    let y_max = if v_max > 0.0 { 1.35 * v_max } else { 1.0 };
    let sigma: Vec<f64> = d
        .lines
        .iter()
        .flat_map(|l| l.predicted_growth.iter().map(|p| p.1))
        .filter(|s| s.is_finite())
        .collect();
    let has_prediction = !sigma.is_empty();
    let s_lo = sigma.iter().copied().fold(0.0, f64::min);
    let s_hi = sigma.iter().copied().fold(0.0, f64::max);
    let s_pad = if s_hi > s_lo {
        0.1 * (s_hi - s_lo)
    } else {
        1.0
    };
    let mut chart = ChartBuilder::on(&main)
        .caption(
            "Response against rotation speed: outcomes, critical speeds, predicted stability",
            ("sans-serif", 19),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .right_y_label_area_size(if has_prediction { 75 } else { 10 })
        .build_cartesian_2d(x_lo..x_hi, 0.0..y_max)?
        .set_secondary_coord(x_lo..x_hi, (s_lo - s_pad)..(s_hi + s_pad));
    let y_prec = tick_decimals(y_max);
    draw_speed_mesh(&mut chart, &d.quantity.axis_label(), &|v| {
        tick_label(*v, y_prec)
    })?;
    if has_prediction {
        chart
            .configure_secondary_axes()
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .y_desc("predicted growth rate σ (1/s)")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()?;
    }
    // Shading first, so that curves, markers and lines are drawn over it.
    let min_w = 0.004 * (x_hi - x_lo);
    for l in &d.lines {
        for &(a, b) in &l.unstable_spans_rad_s {
            let (a, b) = if b - a < min_w {
                (0.5 * (a + b) - 0.5 * min_w, 0.5 * (a + b) + 0.5 * min_w)
            } else {
                (a, b)
            };
            chart.draw_series(std::iter::once(Rectangle::new(
                [(a.max(x_lo), 0.0), (b.min(x_hi), y_max)],
                UNSTABLE_RED.mix(0.13).filled(),
            )))?;
        }
    }
    for (i, l) in d.lines.iter().enumerate() {
        if l.predicted_growth.len() > 1 {
            chart.draw_secondary_series(DashedLineSeries::new(
                l.predicted_growth.clone(),
                5,
                4,
                tab10(i).mix(0.7).stroke_width(1),
            ))?;
        }
    }
    let lines = vertical_lines(d);
    for m in &lines {
        let pts = [(m.speed_rad_s, 0.0), (m.speed_rad_s, y_max)];
        if m.dashed {
            chart.draw_series(DashedLineSeries::new(pts, 8, 5, m.color.stroke_width(2)))?;
        } else {
            chart.draw_series(LineSeries::new(pts, m.color.stroke_width(2)))?;
        }
    }
    let obstacles = draw_points(&mut chart, d)?;
    let area = plot_box(&chart);
    let pending = lines
        .into_iter()
        .map(|m| {
            let (tw, th) = text_size(&m.text, 13.0);
            let (px, _) = chart.backend_coord(&(m.speed_rad_s, y_max));
            let candidates = (0..10)
                .flat_map(|k| {
                    let y = area.y0 + 4 + k * (th as i32 + 4);
                    [(px + 4, y), (px - 4 - tw as i32, y)]
                })
                .collect();
            Pending {
                text: m.text,
                size: 13.0,
                color: m.color,
                candidates,
                background: Some(WHITE.mix(0.85)),
            }
        })
        .collect();
    let (labels, _) = draw_labels(&main, pending, area, &obstacles)?;
    draw_legend(&legend, d)?;
    root.present()?;
    Ok(labels)
}

/// The response against Ω (see the module doc): the quantity (its unit on the axis) against
/// Ω (rad/s), markers by outcome (`ok` filled circles, `unstable` triangles with a red rim,
/// `failed` crosses on the axis floor; refined jobs smaller), the unstable spans shaded, the
/// critical speeds Ω*, the critical wave speed and the predicted boundary as vertical lines
/// with labels that never overlap each other or a marker (crowded ones are left out:
/// [`PlotLabels::dropped`]), and the predicted growth rate (1/s) on the right axis.
pub fn response_against_speed(data: &ScanFigureData, path: &Path) -> Result<PlotLabels, PlotError> {
    if data.lines.iter().all(|l| l.points.is_empty()) {
        return Err(PlotError::Empty("no job to draw against the speed"));
    }
    let width = 1100;
    let legend_h = legend_height(data, width);
    render(
        path,
        (width, 660 + legend_h),
        |a| draw_scan(a, data, legend_h),
        |a| draw_scan(a, data, legend_h),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::runaway::Runaway;
    use crate::sweep::labels::disjoint;
    use crate::sweep::{CoatingParams, JobParams, JobResult, Maxima};

    /// A job record at `speed` on the line of friction `mu`: `ok` with a trailing-edge peak of
    /// `peak_m`, `unstable` (a runaway of growth rate `sigma` and onset `onset`) or `failed`.
    /// Built through JSON so that fields added to the record with a default keep it valid.
    fn rec(speed: f64, mu: f64, state: &str, peak_m: f64, sigma: f64, onset: f64) -> JobRecord {
        let params = JobParams {
            speed_rad_s: speed,
            friction: mu,
            clearance_m: None,
            coating: CoatingParams::default(),
        };
        let result = (state != "failed").then(|| JobResult {
            maxima: Maxima {
                blade_te_radial_m: peak_m,
                ..Default::default()
            },
            critical_speed: Some(CriticalSpeed {
                speed_rad_s: 1450.0,
                nodal_diameter: 2,
                compatibility: 0.8,
            }),
            runaway: (state == "unstable").then_some(Runaway {
                onset_time_s: onset,
                detected_time_s: onset + 1e-3,
                growth_rate_per_s: sigma,
                growth_fit_r2: 0.99,
                energy_growth: 12.0,
                drive_work_j: 1.0,
                nodal_diameter: Some(2),
                frequency_hz: None,
                forward: None,
                rotating_frame_frequency_hz: None,
                at_solve_breakdown: false,
            }),
            ..Default::default()
        });
        let status = match state {
            "failed" => serde_json::json!({"state": "failed", "reason": "diverged"}),
            s => serde_json::json!({ "state": s }),
        };
        serde_json::from_value(serde_json::json!({
            "format_version": crate::sweep::checkpoint::JOB_RECORD_VERSION,
            "id": format!("{speed}-{mu}"),
            "params": params,
            "status": status,
            "result": result,
            "wall_time_s": 0.0,
        }))
        .unwrap()
    }

    /// Line μ = 0.1 over 1000–1800 rad/s: ok up to 1300, unstable at 1400 and 1500, ok at
    /// 1600, failed at 1700, unstable at 1800; line μ = 0.2: three ok speeds.
    fn records() -> Vec<(usize, JobRecord)> {
        let outcomes = [
            "ok", "ok", "ok", "ok", "unstable", "unstable", "ok", "failed", "unstable",
        ];
        let mut out: Vec<(usize, JobRecord)> = outcomes
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let w = 1000.0 + 100.0 * k as f64;
                (
                    k,
                    rec(
                        w,
                        0.1,
                        s,
                        1e-4 * (1.0 + k as f64),
                        40.0 * k as f64,
                        1e-3 * k as f64,
                    ),
                )
            })
            .collect();
        for k in 0..3 {
            let w = 1000.0 + 400.0 * k as f64;
            out.push((9 + k, rec(w, 0.2, "ok", 5e-5, 0.0, 0.0)));
        }
        out
    }

    fn quantity() -> ScanQuantity {
        ScanQuantity::of(DEFAULT_SCAN_QUANTITY).unwrap()
    }

    /// The predicted growth rate of line μ = 0.1: unstable from 1370 rad/s, stable again
    /// between 1500 and 1600 rad/s (σ = 13 → −5: zero at 1500 + 100 · 13/18).
    fn predict(rows: &mut [ScanRow]) {
        let sigma = [-37.0, -27.0, -17.0, -7.0, 3.0, 13.0, -5.0, -6.0, -7.0];
        for (r, s) in rows.iter_mut().zip(sigma) {
            r.predicted = Some(PredictedStability {
                stable: s <= 0.0,
                growth_rate_per_s: s,
                nodal_diameter: if s > 0.0 { 5 } else { 2 },
                frequency_hz: 3500.0,
            });
        }
    }

    #[test]
    fn figure_data_by_outcome_with_spans_and_predicted_boundaries() {
        let mut rows = scan_rows(&records(), &quantity());
        assert_eq!(rows.len(), 12);
        predict(&mut rows);
        let overlays = ScanOverlays {
            critical_speeds: None,
            critical_wave_speed: Some((1650.0, 5)),
        };
        let d = scan_data(&rows, &quantity(), &overlays, FIRST_SCAN_LINES);
        assert_eq!(d.lines.len(), 2);
        assert_eq!((d.lines_total, d.strongest_line), (2, None));
        let l = &d.lines[0];
        assert_eq!(l.label, "μ = 0.1");
        let by = |o: PointOutcome| l.points.iter().filter(|p| p.outcome == o).count();
        assert_eq!(
            (
                by(PointOutcome::Ok),
                by(PointOutcome::Unstable),
                by(PointOutcome::Failed)
            ),
            (5, 3, 1)
        );
        // Values in mm; the failed job has none (drawn on the floor); unstable ones keep theirs.
        assert!((l.points[0].value.unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(l.points[7].value, None);
        assert!((l.points[8].value.unwrap() - 0.9).abs() < 1e-12);
        // Shaded: half-way 1300–1400 to half-way 1500–1600; then from half-way between the ok
        // 1600 and the unstable 1800 (the failed 1700 says nothing) to the line's end.
        assert_eq!(
            l.unstable_spans_rad_s,
            vec![(1350.0, 1550.0), (1700.0, 1800.0)]
        );
        assert!(d.lines[1].unstable_spans_rad_s.is_empty());
        // Predicted boundaries: linear interpolation of σ between neighbouring speeds.
        let b = &l.predicted_boundaries;
        assert_eq!(b.len(), 2, "{b:?}");
        assert!((b[0].speed_rad_s - 1370.0).abs() < 1e-9 && b[0].onset);
        assert!((b[1].speed_rad_s - (1500.0 + 1300.0 / 18.0)).abs() < 1e-9 && !b[1].onset);
        assert_eq!((b[0].nodal_diameter, b[1].nodal_diameter), (5, 5));
        assert_eq!(l.predicted_growth.len(), 9);
        assert!(d.lines[1].predicted_growth.is_empty());
        // Over the whole table; growth rates and onsets of the unstable jobs (k = 4, 5, 8).
        assert_eq!(
            (d.outcomes.ok, d.outcomes.unstable, d.outcomes.failed),
            (8, 3, 1)
        );
        assert_eq!(d.growth_rate_range_per_s, Some((160.0, 320.0)));
        assert_eq!(d.onset_range_s, Some((4e-3, 8e-3)));
        // The rows' critical speed, once; the wave speed kept.
        assert_eq!(d.speed_range_rad_s, (1000.0, 1800.0));
        assert_eq!(d.critical_speeds.len(), 1);
        assert_eq!(d.critical_wave_speed, Some((1650.0, 5)));
        assert!(!d.has_refined);
    }

    #[test]
    fn caption_states_outcomes_rates_and_lines() {
        let mut rows = scan_rows(&records(), &quantity());
        predict(&mut rows);
        let d = scan_data(&rows, &quantity(), &ScanOverlays::default(), 4);
        let c = scan_caption(&d, &PlotLabels::default());
        for needle in [
            "max_blade_te_radial_m (mm)",
            "8 ok",
            "3 unstable",
            "1 failed",
            "maxima run only to the stop",
            "growth rate σ 160.000–320.000 1/s",
            "onset at t = 0.0040–0.0080 s",
            "1450 rad/s (n = 2)",
            "onset 1370 rad/s (n = 5, μ = 0.1)",
            "restabilisation 1572 rad/s",
            "No critical wave speed",
        ] {
            assert!(c.contains(needle), "{needle} not in: {c}");
        }
        // Without a prediction, the caption says so.
        let bare = scan_data(&rows[9..], &quantity(), &ScanOverlays::default(), 4);
        let c = scan_caption(&bare, &PlotLabels::default());
        assert!(c.contains("no linear stability prediction"), "{c}");
        assert!(c.contains("0 unstable"), "{c}");
    }

    /// Seven lines: the first four and the one holding the strongest response.
    #[test]
    fn many_lines_draw_the_first_few_and_the_strongest() {
        let mu = [0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3];
        let records: Vec<(usize, JobRecord)> = (0..7)
            .flat_map(|l| {
                (0..3).map(move |k| {
                    let peak = if l == 6 && k == 1 { 1e-3 } else { 1e-4 };
                    let w = 1000.0 + 100.0 * k as f64;
                    (3 * l + k, rec(w, mu[l], "ok", peak, 0.0, 0.0))
                })
            })
            .collect();
        let d = scan_data(
            &scan_rows(&records, &quantity()),
            &quantity(),
            &ScanOverlays::default(),
            FIRST_SCAN_LINES,
        );
        let labels: Vec<&str> = d.lines.iter().map(|l| l.label.as_str()).collect();
        assert_eq!(
            labels,
            ["μ = 0", "μ = 0.05", "μ = 0.1", "μ = 0.15", "μ = 0.3"]
        );
        assert_eq!((d.lines_total, d.strongest_line), (7, Some(4)));
        let c = scan_caption(&d, &PlotLabels::default());
        assert!(
            c.contains("5 of 7 (the first 4 in job order and μ = 0.3, which holds the strongest"),
            "{c}"
        );
    }

    #[test]
    fn predicted_boundary_interpolates_and_counts_zero_as_stable() {
        let p = |g: f64| PredictedStability {
            stable: g <= 0.0,
            growth_rate_per_s: g,
            nodal_diameter: 3,
            frequency_hz: 3500.0,
        };
        let b = predicted_boundaries(&[
            (100.0, p(-1.0)),
            (200.0, p(0.0)),
            (300.0, p(2.0)),
            (400.0, p(f64::NAN)),
            (500.0, p(-2.0)),
        ]);
        // σ = 0 is stable: the onset is at 200; the NaN is skipped, so 300 → 500 returns
        // to stability half-way.
        assert_eq!(b.len(), 2);
        assert_eq!((b[0].speed_rad_s, b[0].onset), (200.0, true));
        assert_eq!((b[1].speed_rad_s, b[1].onset), (400.0, false));
        assert!(predicted_boundaries(&[(1.0, p(1.0))]).is_empty());
    }

    #[test]
    fn unstable_spans_at_the_ends_of_a_line() {
        let pt = |w: f64, o: PointOutcome| ScanPoint {
            speed_rad_s: w,
            value: Some(1.0),
            outcome: o,
            refined: false,
        };
        use PointOutcome::{Failed, Ok, Unstable};
        // Unstable from the first speed, then a lone unstable point at the end.
        let pts = [
            pt(1.0, Unstable),
            pt(2.0, Unstable),
            pt(3.0, Ok),
            pt(4.0, Failed),
            pt(5.0, Unstable),
        ];
        assert_eq!(unstable_spans(&pts), vec![(1.0, 2.5), (4.0, 5.0)]);
        assert!(unstable_spans(&[pt(1.0, Ok), pt(2.0, Failed)]).is_empty());
    }

    #[test]
    fn quantities_and_ticks() {
        let q = ScanQuantity::of("max_contact_normal_force_n").unwrap();
        assert_eq!((q.unit, q.scale), ("N", 1.0));
        assert_eq!(quantity().axis_label(), "max_blade_te_radial_m (mm)");
        assert_eq!(ScanQuantity::of("status"), None);
        // Issue 41: no long strings of zeros on the axes.
        use crate::sweep::plots::{tick_decimals, tick_label};
        assert_eq!(tick_label(0.0, tick_decimals(1e-12)), "0");
        assert_eq!(tick_label(0.004, tick_decimals(0.012)), "0.004");
        assert_eq!(tick_label(0.010, tick_decimals(0.012)), "0.01");
        assert_eq!(tick_label(-0.0, 3), "0");
        assert_eq!(tick_label(2500.0, 0), "2500");
    }

    /// Drawn as SVG: labels disjoint and inside the figure, each line's label present.
    #[test]
    fn figure_draws_with_disjoint_labels() {
        let mut rows = scan_rows(&records(), &quantity());
        predict(&mut rows);
        let crit = (0..6)
            .map(|k| CriticalSpeed {
                speed_rad_s: 1360.0 + 10.0 * k as f64,
                nodal_diameter: 2 + k,
                compatibility: 0.1 * k as f64,
            })
            .collect();
        let overlays = ScanOverlays {
            critical_speeds: Some(crit),
            critical_wave_speed: Some((1380.0, 5)),
        };
        let d = scan_data(&rows, &quantity(), &overlays, FIRST_SCAN_LINES);
        let dir = std::env::temp_dir().join(format!("rubscan-scan-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for ext in ["svg", "png"] {
            let path = dir.join(format!("scan.{ext}"));
            let labels = response_against_speed(&d, &path).unwrap();
            // 2 predicted boundaries, the wave speed and 6 critical speeds.
            assert_eq!(labels.placed.len() + labels.dropped.len(), 9);
            let boxes: Vec<LabelBox> = labels.placed.iter().map(|l| l.bbox).collect();
            assert!(disjoint(&boxes), "{labels:?}");
            assert!(
                labels
                    .placed
                    .iter()
                    .any(|l| l.text == "predicted onset 1370 (n = 5)")
            );
            if ext == "svg" {
                let svg = std::fs::read_to_string(&path).unwrap();
                for l in &labels.placed {
                    assert!(svg.contains(&l.text), "{} not drawn", l.text);
                }
                assert!(svg.contains("predicted growth rate σ (1/s)"));
                assert!(svg.contains("rotation speed Ω (rad/s)"));
            }
        }
        if std::env::var_os("RUBSCAN_KEEP_PLOTS").is_none() {
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }
}
