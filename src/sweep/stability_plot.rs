//! The stability diagram of `rubscan stability`: the largest growth rate σ (1/s) of the coupled
//! waves of each casing nodal diameter against the rotation speed Ω, with the predicted onset,
//! the casing's critical wave speed and the interaction criterion's critical speeds marked.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::analysis::stability::StabilityAtSpeed;
use crate::sweep::plots::{PlotError, draw_speed_mesh, render, tab10};

/// Input of [`stability_diagram`].
#[derive(Debug, Clone)]
pub struct StabilityPlotData<'a> {
    /// Friction coefficient μ of the prediction (title).
    pub friction: f64,
    /// The prediction at each speed, speeds increasing.
    pub speeds: &'a [StabilityAtSpeed],
    /// Predicted onset speed (rad/s), if any in the range.
    pub onset_rad_s: Option<f64>,
    /// The casing's critical wave speed (rad/s) and its nodal diameter.
    pub critical_wave_speed: Option<(f64, usize)>,
    /// Critical speeds Ω* (rad/s) of the interaction criterion with their nodal diameter.
    pub interaction_speeds: Vec<(f64, u32)>,
}

/// At most this many nodal diameters are drawn: those of largest peak growth rate.
const MAX_CURVES: usize = 8;

/// The nodal diameters to draw: largest peak σ first.
fn curves(d: &StabilityPlotData<'_>) -> Vec<(usize, Vec<(f64, f64)>)> {
    let mut nds: Vec<usize> = (d.speeds.iter())
        .filter_map(|s| s.most_unstable().map(|w| w.nodal_diameter))
        .collect();
    if let Some((_, nd)) = d.critical_wave_speed {
        nds.push(nd);
    }
    nds.sort_unstable();
    nds.dedup();
    let mut out: Vec<(usize, Vec<(f64, f64)>)> = nds
        .into_iter()
        .map(|nd| {
            let pts = (d.speeds.iter())
                .filter_map(|s| s.max_growth_of(nd).map(|g| (s.omega_rad_s, g)))
                .collect();
            (nd, pts)
        })
        .collect();
    let peak = |p: &[(f64, f64)]| p.iter().map(|q| q.1).fold(f64::MIN, f64::max);
    out.sort_by(|a, b| peak(&b.1).total_cmp(&peak(&a.1)));
    out.truncate(MAX_CURVES);
    out
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    d: &StabilityPlotData<'_>,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let lines = curves(d);
    let (x_lo, x_hi) = (
        d.speeds[0].omega_rad_s,
        d.speeds[d.speeds.len() - 1].omega_rad_s,
    );
    let ys = lines.iter().flat_map(|l| l.1.iter().map(|p| p.1));
    let (y_lo, y_hi) = ys.fold((0.0f64, 0.0f64), |(a, b), y| (a.min(y), b.max(y)));
    let pad = 0.05 * (y_hi - y_lo).max(1.0);
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "Linearised persistent rub, μ = {}: largest growth rate per casing nodal diameter",
                d.friction
            ),
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x_lo..x_hi.max(x_lo + 1e-9), (y_lo - pad)..(y_hi + pad))?;
    draw_speed_mesh(&mut chart, "growth rate σ (1/s)", &|v| format!("{v:.0}"))?;
    chart.draw_series(LineSeries::new([(x_lo, 0.0), (x_hi, 0.0)], BLACK.mix(0.5)))?;
    for (i, (nd, pts)) in lines.iter().enumerate() {
        let color = tab10(i);
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))?
            .label(format!("casing ND {nd}"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color.stroke_width(2)));
    }
    let mut marks: Vec<(f64, String, RGBColor)> = Vec::new();
    if let Some(w) = d.onset_rad_s {
        marks.push((w, format!("onset {w:.0}"), RGBColor(200, 0, 0)));
    }
    if let Some((w, nd)) = d.critical_wave_speed {
        marks.push((
            w,
            format!("critical wave speed {w:.0} (ND {nd})"),
            RGBColor(60, 60, 60),
        ));
    }
    // Many critical speeds crowd each other: past a few, their lines go unlabelled.
    let labelled = d.interaction_speeds.len() <= 6;
    for &(w, nd) in &d.interaction_speeds {
        let label = if labelled {
            format!("Ω*{nd}")
        } else {
            String::new()
        };
        marks.push((w, label, RGBColor(160, 160, 220)));
    }
    for (i, (w, label, color)) in marks.into_iter().enumerate() {
        if !(x_lo..=x_hi).contains(&w) {
            continue;
        }
        let y_text = y_hi + pad - (y_hi - y_lo + 2.0 * pad) * (0.04 + 0.05 * (i % 6) as f64);
        chart.draw_series(LineSeries::new(
            [(w, y_lo - pad), (w, y_hi + pad)],
            color.stroke_width(1),
        ))?;
        chart.draw_series([Text::new(
            label,
            (w, y_text),
            ("sans-serif", 13).into_font().color(&color),
        )])?;
    }
    if !labelled {
        let color = RGBColor(160, 160, 220);
        chart
            .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
            .label("Ω* of the interaction criterion")
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color.stroke_width(1)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 13))
        .draw()?;
    root.present()?;
    Ok(())
}

/// Draws the stability diagram to `path` (PNG or SVG by extension, written atomically).
pub fn stability_diagram(data: &StabilityPlotData<'_>, path: &Path) -> Result<(), PlotError> {
    if data.speeds.len() < 2 {
        return Err(PlotError::Empty("stability diagram needs ≥ 2 speeds"));
    }
    render(path, (1100, 700), |a| draw(a, data), |a| draw(a, data))
}
