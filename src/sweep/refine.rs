//! Ω refined where the answer changes (issue 37 item 3, DESIGN.md §10): after the coarse
//! grid, speeds are added to each speed line (one combination of the other axes) where its
//! answer changes, round after round, until each answer is located to the tolerance of
//! [`RefineSpec`] or the line's job budget is spent.
//!
//! - **Boundary** (`refine.boundary`): between neighbouring speeds whose outcomes differ
//!   (`ok` / `unstable`), the midpoint is added while the bracket is wider than the
//!   tolerance: plain bisection, ⌈log₂(spacing / tolerance)⌉ rounds of one job per boundary.
//!   A `failed` point is neither side: it is skipped as unknown, the boundary is bracketed
//!   by the nearest known neighbours, and the widest gap between the bracket's points
//!   (failed ones included, so a failed speed is never run again) is bisected.
//! - **Peak** (`refine.peak_of`): each local maximum of the chosen quantity among the `ok`
//!   points that carry it (`failed` ones skipped as unknown; an `unstable` point separates
//!   two stretches) is bracketed by its two neighbours; a job is added at the vertex
//!   of the parabola through the three (clamped into the bracket, kept at least tolerance/2
//!   away from every existing speed), or, when the vertex is degenerate or has no room,
//!   at the midpoint of the widest gap of the bracket (the larger half-bracket: a
//!   golden-section-style step). A peak is located when half the distance between its best
//!   point's neighbours is within the tolerance. A maximum at either end of a stretch
//!   (an end of the grid, or next to an `unstable` point) is reported but not refined:
//!   the response still rises towards the end, so the peak lies outside what was scanned.
//!
//! Everything here is pure and deterministic: the same points in any order give the same
//! speeds, bit for bit, so a resumed or sharded round plans exactly the jobs it planned
//! before (their ids are those of coarse jobs at the same speeds).

use std::cmp::Ordering;

use serde::{Deserialize, Serialize};

use crate::sweep::JobResult;

/// The numeric scalar columns of the results table (`schemas/results.md`) whose local
/// maxima along Ω refinement can locate (`refine.peak_of`): the job's deterministic result
/// scalars. Not offered: the grid parameters (constant along a speed line, or Ω itself),
/// `wall_time_s` (differs between runs, so a refined round would not be reproducible) and
/// the list, struct and text columns.
pub const PEAK_QUANTITIES: &[&str] = &[
    "max_blade_le_radial_m",
    "max_blade_te_radial_m",
    "max_blade_le_radial_lowpass_m",
    "max_blade_te_radial_lowpass_m",
    "max_casing_radial_m",
    "max_contact_normal_force_n",
    "max_coating_force_n",
    "residual_penetration_m",
    "steps_over_gap_tolerance",
    "critical_speed_rad_s",
    "critical_nodal_diameter",
    "critical_compatibility",
    "spectrum_df_hz",
];

/// The other columns of the results table, refused as `refine.peak_of` with a reason of
/// their own; with [`PEAK_QUANTITIES`] they are every column (a test in `table` holds
/// that, so that a new column is put on one side or the other).
pub const OTHER_COLUMNS: &[&str] = &[
    "job_index",
    "job_id",
    "speed_rad_s",
    "friction",
    "clearance_m",
    "coating_young_pa",
    "coating_young_scale",
    "coating_hardening_pa",
    "coating_hardening_scale",
    "coating_yield_stress_pa",
    "coating_yield_stress_scale",
    "coating_thickness_m",
    "coating_thickness_scale",
    "refinement_round",
    "status",
    "reason",
    "drive_work_j",
    "runaway_onset_s",
    "runaway_detected_s",
    "growth_rate_per_s",
    "growth_fit_r2",
    "runaway_energy_growth",
    "runaway_drive_work_j",
    "growing_wave_frequency_hz",
    "growing_wave_rotating_frequency_hz",
    "growing_nodal_diameter",
    "growing_wave_forward",
    "runaway_at_solve_breakdown",
    "predicted_stable",
    "predicted_growth_rate_per_s",
    "predicted_nodal_diameter",
    "predicted_frequency_hz",
    "wear_profile_m",
    "fourier_peaks",
    "strain_energy_per_nd_j",
    "spectrum_amplitude_m",
    "wall_time_s",
];

/// Smallest refinement tolerance, relative to the fastest grid speed. A speed is held to
/// 2.2e-16 of itself in f64, and a job id tells apart any two different f64 speeds, but two
/// simulations 1e-9 Ω apart answer the same: a finer tolerance only spends the budget on
/// speeds no result can tell apart (and on round-off in the brackets' midpoints).
pub const MIN_REFINE_TOLERANCE: f64 = 1e-9;

/// Refinement of the speed axis: after the grid, speeds are added to each speed line (one
/// combination of the other axes) where its answer changes, round after round, by
/// [`next_round`]. Checked by `SweepSpec::validate`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefineSpec {
    /// Tolerance (rad/s, whatever the axis' unit): a boundary is located when its bracket is
    /// at most this wide, a peak when the distance between its best speed's neighbours is at
    /// most twice this. > 0, at least [`MIN_REFINE_TOLERANCE`] × the largest grid speed and
    /// below the largest spacing of the grid's speeds.
    pub tolerance_rad_s: f64,
    /// Refined jobs allowed per speed line (≥ 1), over all rounds.
    pub max_jobs: usize,
    /// Bisect between neighbouring speeds whose outcomes differ (`ok` / `unstable`).
    #[serde(default = "yes")]
    pub boundary: bool,
    /// A numeric scalar column of the results table (one of [`PEAK_QUANTITIES`]) whose local
    /// maxima along Ω are located.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peak_of: Option<String>,
}

fn yes() -> bool {
    true
}

/// The value of the results-table column `column` (one of [`PEAK_QUANTITIES`]) for a
/// job's result, in the column's unit; `None` when the column is null for this result or
/// is not one of [`PEAK_QUANTITIES`].
pub fn quantity_of(column: &str, result: &JobResult) -> Option<f64> {
    let m = &result.maxima;
    let critical = result.critical_speed.as_ref();
    match column {
        "max_blade_le_radial_m" => Some(m.blade_le_radial_m),
        "max_blade_te_radial_m" => Some(m.blade_te_radial_m),
        "max_blade_le_radial_lowpass_m" => m.blade_le_radial_lowpass_m,
        "max_blade_te_radial_lowpass_m" => m.blade_te_radial_lowpass_m,
        "max_casing_radial_m" => Some(m.casing_radial_m),
        "max_contact_normal_force_n" => Some(m.contact_normal_force_n),
        "max_coating_force_n" => Some(m.coating_force_n),
        "residual_penetration_m" => Some(result.residual_penetration_m),
        "steps_over_gap_tolerance" => result.steps_over_gap_tolerance.map(|n| n as f64),
        "critical_speed_rad_s" => critical.map(|c| c.speed_rad_s),
        "critical_nodal_diameter" => critical.map(|c| f64::from(c.nodal_diameter)),
        "critical_compatibility" => critical.map(|c| c.compatibility),
        "spectrum_df_hz" => result.spectrum.as_ref().map(|s| s.df_hz),
        _ => None,
    }
}

/// Outcome of a finished job, as refinement reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PointOutcome {
    /// Bounded response.
    Ok,
    /// Runaway detected.
    Unstable,
    /// Numerics, I/O or limits: neither side of a boundary, and no value.
    Failed,
}

/// One finished job of a speed line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedPoint {
    /// Rotation speed Ω (rad/s).
    pub omega_rad_s: f64,
    /// How the job ended.
    pub outcome: PointOutcome,
    /// The `peak_of` quantity (its column's unit); `None` when missing (no `peak_of`, a
    /// null column, a job that did not end `ok`). Only `ok` points' values are used.
    pub value: Option<f64>,
}

/// Why a speed is added.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refinement {
    /// Bisects the bracket `[lo, hi]` (rad/s) of an `ok`/`unstable` boundary.
    Boundary {
        /// Lower end of the bracket (rad/s): the nearest known speed below.
        lo_rad_s: f64,
        /// Upper end of the bracket (rad/s).
        hi_rad_s: f64,
    },
    /// The vertex of the parabola through a peak's best point and its two neighbours.
    Peak {
        /// Speed of the highest point so far (rad/s).
        best_rad_s: f64,
        /// Its lower neighbour (rad/s).
        lo_rad_s: f64,
        /// Its upper neighbour (rad/s).
        hi_rad_s: f64,
    },
    /// A peak's bracket halved where the parabola cannot say (degenerate vertex, or no room
    /// at tolerance/2 from the existing speeds): the midpoint of its widest gap.
    PeakCheck {
        /// Speed of the highest point so far (rad/s).
        best_rad_s: f64,
        /// Its lower neighbour (rad/s).
        lo_rad_s: f64,
        /// Its upper neighbour (rad/s).
        hi_rad_s: f64,
    },
}

/// A speed to add to a speed line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewSpeed {
    /// Rotation speed Ω (rad/s).
    pub omega_rad_s: f64,
    /// What it refines.
    pub reason: Refinement,
}

/// An `ok`/`unstable` boundary of a speed line and how well it is located.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocatedBoundary {
    /// Nearest known (`ok` or `unstable`) speed below the boundary (rad/s).
    pub lo_rad_s: f64,
    /// Nearest known speed above it (rad/s).
    pub hi_rad_s: f64,
    /// True when the upper side is the `unstable` one (the runaway starts above).
    pub unstable_above: bool,
    /// `failed` points inside the bracket.
    pub failed_inside: usize,
    /// The bracket is at most the tolerance wide.
    pub within_tolerance: bool,
}

/// A local maximum of the `peak_of` quantity along a speed line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocatedPeak {
    /// Speed of the highest point (rad/s).
    pub best_rad_s: f64,
    /// Its value (the column's unit).
    pub value: f64,
    /// Lower neighbour among the points with a value (rad/s; the best speed itself at the
    /// lower end).
    pub lo_rad_s: f64,
    /// Upper neighbour (rad/s; the best speed itself at the upper end).
    pub hi_rad_s: f64,
    /// Vertex of the parabola through the three points (rad/s), an estimate of the peak's
    /// speed; `None` at an end or when degenerate.
    pub vertex_rad_s: Option<f64>,
    /// The maximum is at an end of a stretch of `ok` points (an end of the grid, or next to
    /// an `unstable` point): not a located peak (the response still rises towards the end of
    /// what was scanned, or into the runaway), never refined.
    pub at_end: bool,
    /// Interior, and half the distance between its neighbours is within the tolerance.
    pub within_tolerance: bool,
}

/// What a speed line's points locate (empty lists for what the spec does not ask).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Located {
    /// Boundaries in increasing Ω (when `refine.boundary`).
    pub boundaries: Vec<LocatedBoundary>,
    /// Local maxima in increasing Ω (when `refine.peak_of` is given).
    pub peaks: Vec<LocatedPeak>,
}

impl Located {
    /// Every boundary and every interior peak is located within the tolerance.
    pub fn all_within_tolerance(&self) -> bool {
        self.boundaries.iter().all(|b| b.within_tolerance)
            && self.peaks.iter().all(|p| p.at_end || p.within_tolerance)
    }
}

/// Relative slack on the tolerance/2 spacing of speeds: a speed pushed exactly tolerance/2
/// away from another must pass the check despite the rounding of the sum.
const SPACING_SLACK: f64 = 1e-9;

/// The points in a canonical order (Ω, then outcome, then value), non-finite speeds dropped,
/// non-finite values as missing, one point per speed: the order of the input never matters.
fn canonical(points: &[SpeedPoint]) -> Vec<SpeedPoint> {
    let mut p: Vec<SpeedPoint> = points
        .iter()
        .filter(|p| p.omega_rad_s.is_finite())
        .map(|p| SpeedPoint {
            value: p.value.filter(|v| v.is_finite()),
            ..*p
        })
        .collect();
    let value_order = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(x), Some(y)) => x.total_cmp(&y),
        (a, b) => a.is_some().cmp(&b.is_some()),
    };
    p.sort_by(|a, b| {
        a.omega_rad_s
            .total_cmp(&b.omega_rad_s)
            .then(a.outcome.cmp(&b.outcome))
            .then(value_order(a.value, b.value))
    });
    p.dedup_by(|later, first| later.omega_rad_s == first.omega_rad_s);
    p
}

/// The widest gap between consecutive speeds of `speeds` (sorted), when wider than `tol`:
/// its midpoint lies more than tol/2 from every speed.
fn widest_gap_midpoint(speeds: &[f64], tol: f64) -> Option<f64> {
    let (a, b) = speeds
        .windows(2)
        .map(|w| (w[0], w[1]))
        // First of equally wide gaps: `max_by` keeps the last, so compare reversed on ties.
        .max_by(|x, y| (x.1 - x.0).total_cmp(&(y.1 - y.0)).then(Ordering::Greater))?;
    (b - a > tol).then_some(a + 0.5 * (b - a))
}

/// Boundaries of the canonical points `pts`, with the speeds inside each bracket.
fn boundaries(pts: &[SpeedPoint], tol: f64) -> Vec<(LocatedBoundary, Vec<f64>)> {
    let known: Vec<usize> = (0..pts.len())
        .filter(|&i| pts[i].outcome != PointOutcome::Failed)
        .collect();
    known
        .windows(2)
        .filter(|w| pts[w[0]].outcome != pts[w[1]].outcome)
        .map(|w| {
            let (lo, hi) = (pts[w[0]].omega_rad_s, pts[w[1]].omega_rad_s);
            let b = LocatedBoundary {
                lo_rad_s: lo,
                hi_rad_s: hi,
                unstable_above: pts[w[1]].outcome == PointOutcome::Unstable,
                failed_inside: w[1] - w[0] - 1,
                within_tolerance: hi - lo <= tol,
            };
            let inside = pts[w[0]..=w[1]].iter().map(|p| p.omega_rad_s).collect();
            (b, inside)
        })
        .collect()
}

/// Vertex of the parabola through (x0, y0), (x1, y1), (x2, y2) with x0 < x1 < x2 and y1
/// above y0 (a local maximum); `None` when not concave or not finite. Written about x1,
/// so that the fit does not lose the small differences of close speeds to cancellation.
fn parabola_vertex([(x0, y0), (x1, y1), (x2, y2)]: [(f64, f64); 3]) -> Option<f64> {
    let (a, b) = (x0 - x1, x2 - x1);
    let (fa, fb) = (y0 - y1, y2 - y1);
    // f(t) = c1 t + c2 t² through (a, fa), (0, 0), (b, fb).
    let c2 = (a * fb - b * fa) / (a * b * (b - a));
    let c1 = fa / a - c2 * a;
    let t = -c1 / (2.0 * c2);
    (c2 < 0.0 && t.is_finite()).then_some(x1 + t)
}

/// Local maxima of the `ok` points' values, with the three points of each fit. An
/// `unstable` point ends a stretch (the response is another regime beyond it); `failed`
/// points and `ok` points without a value are skipped as unknown, as for boundaries.
fn peaks(pts: &[SpeedPoint], tol: f64) -> Vec<(LocatedPeak, [(f64, f64); 3])> {
    pts.split(|p| p.outcome == PointOutcome::Unstable)
        .flat_map(|stretch| {
            let valued: Vec<(f64, f64)> = stretch
                .iter()
                .filter(|p| p.outcome == PointOutcome::Ok)
                .filter_map(|p| p.value.map(|v| (p.omega_rad_s, v)))
                .collect();
            stretch_peaks(&valued, tol)
        })
        .collect()
}

/// Local maxima of one stretch of (Ω, value) in increasing Ω; none from fewer than two.
fn stretch_peaks(valued: &[(f64, f64)], tol: f64) -> Vec<(LocatedPeak, [(f64, f64); 3])> {
    let n = valued.len();
    if n < 2 {
        return Vec::new();
    }
    let mut out = Vec::new();
    for k in 0..n {
        let (x, y) = valued[k];
        let left = k.checked_sub(1).map(|i| valued[i]);
        let right = valued.get(k + 1).copied();
        // Strictly above the left neighbour, at least the right one: one maximum per plateau.
        if !(left.is_none_or(|l| y > l.1) && right.is_none_or(|r| y >= r.1)) {
            continue;
        }
        let (lo, hi) = (left.unwrap_or((x, y)), right.unwrap_or((x, y)));
        let at_end = left.is_none() || right.is_none();
        let fit = [lo, (x, y), hi];
        out.push((
            LocatedPeak {
                best_rad_s: x,
                value: y,
                lo_rad_s: lo.0,
                hi_rad_s: hi.0,
                vertex_rad_s: if at_end { None } else { parabola_vertex(fit) },
                at_end,
                within_tolerance: !at_end && 0.5 * (hi.0 - lo.0) <= tol,
            },
            fit,
        ));
    }
    out
}

/// What the points of one speed line locate: boundaries with their brackets, peaks with
/// their speed and bracket, and whether each meets the tolerance (see [`Located`]).
/// `refine` is a validated refinement request.
pub fn located(points: &[SpeedPoint], refine: &RefineSpec) -> Located {
    let pts = canonical(points);
    let tol = refine.tolerance_rad_s;
    Located {
        boundaries: if refine.boundary {
            boundaries(&pts, tol).into_iter().map(|(b, _)| b).collect()
        } else {
            Vec::new()
        },
        peaks: if refine.peak_of.is_some() {
            peaks(&pts, tol).into_iter().map(|(p, _)| p).collect()
        } else {
            Vec::new()
        },
    }
}

/// The next job of an unlocated interior peak: the parabola's vertex kept tol/2 from every
/// existing speed (pushed away from the nearest one when closer), else the midpoint of the
/// bracket's widest gap; `None` when the bracket has no room left.
fn peak_speed(peak: &LocatedPeak, fit: [(f64, f64); 3], all: &[f64], tol: f64) -> Option<NewSpeed> {
    let (x0, x1, x2) = (fit[0].0, fit[1].0, fit[2].0);
    let half = 0.5 * tol;
    let inside: Vec<f64> = all
        .iter()
        .copied()
        .filter(|&w| (x0..=x2).contains(&w))
        .collect();
    let free = |x: f64| {
        x > x0
            && x < x2
            && inside
                .iter()
                .all(|&w| (x - w).abs() >= half * (1.0 - SPACING_SLACK))
    };
    let (best_rad_s, lo_rad_s, hi_rad_s) = (peak.best_rad_s, peak.lo_rad_s, peak.hi_rad_s);
    if let Some(v) = parabola_vertex(fit).map(|v| v.clamp(x0, x2)) {
        let near = inside
            .iter()
            .copied()
            .min_by(|a, b| (a - v).abs().total_cmp(&(b - v).abs()))
            .unwrap_or(x1);
        // Away from the nearest speed on the vertex's side (the larger half when on it).
        let side = match v.total_cmp(&near) {
            Ordering::Greater => 1.0,
            Ordering::Less => -1.0,
            Ordering::Equal if x2 - x1 >= x1 - x0 => 1.0,
            Ordering::Equal => -1.0,
        };
        let reason = Refinement::Peak {
            best_rad_s,
            lo_rad_s,
            hi_rad_s,
        };
        if let Some(omega_rad_s) = [v, near + side * half, near - side * half]
            .into_iter()
            .find(|&x| free(x))
        {
            return Some(NewSpeed {
                omega_rad_s,
                reason,
            });
        }
    }
    widest_gap_midpoint(&inside, tol).map(|omega_rad_s| NewSpeed {
        omega_rad_s,
        reason: Refinement::PeakCheck {
            best_rad_s,
            lo_rad_s,
            hi_rad_s,
        },
    })
}

/// Speeds to add to one speed line, given its finished points of all rounds so far (in any
/// order) and the refined jobs already spent on this line; empty when everything asked is
/// located within the tolerance, blocked, or the budget `refine.max_jobs` is spent.
///
/// One speed per unlocated boundary or interior peak, at most `max_jobs − spent` of them:
/// when the budget is short, the answers furthest from their tolerance (bracket width over
/// the width that locates it) go first, boundaries before peaks on ties, then lower Ω.
/// Every new speed lies at least tolerance/2 from every existing point and from the others
/// (a duplicate would be the same job). Output in increasing Ω; deterministic bit for bit.
pub fn next_round(points: &[SpeedPoint], refine: &RefineSpec, spent: usize) -> Vec<NewSpeed> {
    let budget = refine.max_jobs.saturating_sub(spent);
    let tol = refine.tolerance_rad_s;
    if budget == 0 || !(tol.is_finite() && tol > 0.0) {
        return Vec::new();
    }
    let pts = canonical(points);
    let all: Vec<f64> = pts.iter().map(|p| p.omega_rad_s).collect();
    // (how far from located, kind: 0 boundary / 1 peak, speed)
    let mut candidates: Vec<(f64, u8, NewSpeed)> = Vec::new();
    if refine.boundary {
        for (b, inside) in boundaries(&pts, tol) {
            if b.within_tolerance {
                continue;
            }
            if let Some(omega_rad_s) = widest_gap_midpoint(&inside, tol) {
                let reason = Refinement::Boundary {
                    lo_rad_s: b.lo_rad_s,
                    hi_rad_s: b.hi_rad_s,
                };
                let distance = (b.hi_rad_s - b.lo_rad_s) / tol;
                candidates.push((
                    distance,
                    0,
                    NewSpeed {
                        omega_rad_s,
                        reason,
                    },
                ));
            }
        }
    }
    if refine.peak_of.is_some() {
        for (p, fit) in peaks(&pts, tol) {
            if p.at_end || p.within_tolerance {
                continue;
            }
            if let Some(s) = peak_speed(&p, fit, &all, tol) {
                candidates.push((0.5 * (p.hi_rad_s - p.lo_rad_s) / tol, 1, s));
            }
        }
    }
    candidates.sort_by(|a, b| {
        b.0.total_cmp(&a.0)
            .then(a.1.cmp(&b.1))
            .then(a.2.omega_rad_s.total_cmp(&b.2.omega_rad_s))
    });
    let mut out: Vec<NewSpeed> = Vec::with_capacity(budget.min(candidates.len()));
    for (_, _, s) in candidates {
        if out.len() == budget {
            break;
        }
        // A boundary and a peak can ask for nearly the same speed: the first one asked does.
        let clash = out
            .iter()
            .any(|o| (o.omega_rad_s - s.omega_rad_s).abs() < 0.5 * tol * (1.0 - SPACING_SLACK));
        if !clash {
            out.push(s);
        }
    }
    out.sort_by(|a, b| a.omega_rad_s.total_cmp(&b.omega_rad_s));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(tol: f64, max_jobs: usize, boundary: bool, peak: bool) -> RefineSpec {
        RefineSpec {
            tolerance_rad_s: tol,
            max_jobs,
            boundary,
            peak_of: peak.then(|| "max_blade_te_radial_m".to_string()),
        }
    }

    /// `count` speeds evenly spaced over [start, stop] (rad/s).
    fn grid(start: f64, stop: f64, count: usize) -> Vec<f64> {
        (0..count)
            .map(|i| start + (stop - start) * i as f64 / (count - 1) as f64)
            .collect()
    }

    /// What a finished refinement did on one line.
    struct Run {
        points: Vec<SpeedPoint>,
        rounds: usize,
        jobs: usize,
    }

    /// Runs the grid, then rounds of [`next_round`] until it asks for nothing, evaluating
    /// each speed with `job`; checks on the way that every round is sorted, within the
    /// budget left and at least tolerance/2 from every point so far.
    fn refine_line(speeds: &[f64], job: impl Fn(f64) -> SpeedPoint, r: &RefineSpec) -> Run {
        let mut points: Vec<SpeedPoint> = speeds.iter().map(|&w| job(w)).collect();
        let (mut rounds, mut jobs) = (0, 0);
        loop {
            let new = next_round(&points, r, jobs);
            if new.is_empty() {
                break;
            }
            assert!(new.len() <= r.max_jobs - jobs, "over budget");
            assert!(new.windows(2).all(|w| w[0].omega_rad_s < w[1].omega_rad_s));
            for s in &new {
                let gap = points
                    .iter()
                    .map(|p| (p.omega_rad_s - s.omega_rad_s).abs())
                    .fold(f64::INFINITY, f64::min);
                assert!(gap >= 0.5 * r.tolerance_rad_s * (1.0 - 1e-6), "{s:?} {gap}");
            }
            rounds += 1;
            jobs += new.len();
            points.extend(new.iter().map(|s| job(s.omega_rad_s)));
            assert!(rounds < 100, "refinement does not end");
        }
        Run {
            points,
            rounds,
            jobs,
        }
    }

    /// Unstable above `omega_b` (rad/s); the value is the Lorentzian resonance curve
    /// 1 / ((Ω − Ω_p)² + γ²) of a peak at `omega_p` of half-width `gamma`.
    fn system(omega_b: f64, omega_p: f64, gamma: f64) -> impl Fn(f64) -> SpeedPoint {
        move |w| SpeedPoint {
            omega_rad_s: w,
            outcome: if w > omega_b {
                PointOutcome::Unstable
            } else {
                PointOutcome::Ok
            },
            value: Some(1.0 / ((w - omega_p).powi(2) + gamma * gamma)),
        }
    }

    #[test]
    fn a_boundary_is_bisected_to_the_tolerance_in_log2_rounds() {
        let speeds = grid(3500.0, 5300.0, 9);
        let spacing = speeds[1] - speeds[0];
        for (omega_b, tol) in [(4321.7, 20.0), (3600.1, 3.0), (5299.0, 50.0)] {
            let r = spec(tol, 100, true, false);
            let run = refine_line(&speeds, system(omega_b, 0.0, 1.0), &r);
            let want = (spacing / tol).log2().ceil() as usize;
            assert_eq!(run.rounds, want, "Ω_b = {omega_b}, tol = {tol}");
            // One boundary: one job per round.
            assert_eq!(run.jobs, want);
            let found = located(&run.points, &r);
            assert_eq!(found.boundaries.len(), 1);
            let b = found.boundaries[0];
            assert!(b.within_tolerance && b.unstable_above && found.all_within_tolerance());
            assert!(b.lo_rad_s <= omega_b && omega_b < b.hi_rad_s, "{b:?}");
            assert!(b.hi_rad_s - b.lo_rad_s <= tol);
        }
    }

    #[test]
    fn each_boundary_of_an_unstable_band_is_located() {
        let speeds = grid(1000.0, 2000.0, 11);
        let job = |w: f64| SpeedPoint {
            omega_rad_s: w,
            outcome: if (1234.0..1678.0).contains(&w) {
                PointOutcome::Unstable
            } else {
                PointOutcome::Ok
            },
            value: None,
        };
        let r = spec(5.0, 100, true, false);
        let run = refine_line(&speeds, job, &r);
        let found = located(&run.points, &r);
        assert_eq!(found.boundaries.len(), 2);
        let [up, down] = [found.boundaries[0], found.boundaries[1]];
        assert!(up.unstable_above && !down.unstable_above);
        assert!(up.lo_rad_s < 1234.0 && 1234.0 <= up.hi_rad_s && up.within_tolerance);
        assert!(down.lo_rad_s < 1678.0 && 1678.0 <= down.hi_rad_s && down.within_tolerance);
        // Both are bisected in the same rounds: ⌈log₂(100/5)⌉ = 5 rounds of 2 jobs.
        assert_eq!((run.rounds, run.jobs), (5, 10));
    }

    #[test]
    fn a_lorentzian_peak_off_the_grid_is_located_within_the_tolerance() {
        let speeds = grid(3500.0, 5300.0, 9);
        let mut worst_rounds = 0;
        for (omega_p, gamma, tol) in [
            (4447.3, 150.0, 5.0),
            (4447.3, 40.0, 5.0),
            (3777.7, 300.0, 2.0),
            (4950.0, 90.0, 10.0),
            (4049.9, 400.0, 1.0),
        ] {
            let r = spec(tol, 50, false, true);
            let run = refine_line(&speeds, system(f64::INFINITY, omega_p, gamma), &r);
            let found = located(&run.points, &r);
            assert_eq!(found.peaks.len(), 1, "{:?}", found.peaks);
            let p = found.peaks[0];
            assert!(!p.at_end && p.within_tolerance && found.all_within_tolerance());
            assert!(
                p.lo_rad_s <= omega_p && omega_p <= p.hi_rad_s,
                "{p:?} Ω_p = {omega_p}"
            );
            assert!((p.best_rad_s - omega_p).abs() <= 2.0 * tol, "{p:?}");
            let vertex = p.vertex_rad_s.unwrap();
            assert!((vertex - omega_p).abs() <= tol, "{p:?}, Ω_p = {omega_p}");
            // A few rounds of one job, far fewer than bisection's ⌈log₂(225 / tol)⌉ + 1.
            assert_eq!(run.jobs, run.rounds);
            assert!(run.rounds <= 8, "{} rounds for Ω_p = {omega_p}", run.rounds);
            worst_rounds = worst_rounds.max(run.rounds);
            eprintln!(
                "Ω_p = {omega_p}, γ = {gamma}, tol = {tol}: {} jobs in {} rounds",
                run.jobs, run.rounds
            );
        }
        eprintln!("peak located in at most {worst_rounds} rounds");
    }

    #[test]
    fn the_budget_stops_refinement() {
        let speeds = grid(3500.0, 5300.0, 9);
        // 225 rad/s down to 1 rad/s takes 8 rounds; the budget allows 3.
        let r = spec(1.0, 3, true, false);
        let run = refine_line(&speeds, system(4321.7, 0.0, 1.0), &r);
        assert_eq!((run.rounds, run.jobs), (3, 3));
        assert!(!located(&run.points, &r).all_within_tolerance());
        assert!(next_round(&run.points, &r, 3).is_empty());
        assert!(next_round(&run.points, &r, 7).is_empty());
        // Two answers for one job left: the one furthest from its tolerance goes first.
        let band = |w: f64| SpeedPoint {
            omega_rad_s: w,
            outcome: if (3700.0..4500.0).contains(&w) {
                PointOutcome::Unstable
            } else {
                PointOutcome::Ok
            },
            value: None,
        };
        let mut points: Vec<SpeedPoint> = speeds.iter().map(|&w| band(w)).collect();
        points.push(band(3612.5)); // halves the first bracket
        let new = next_round(&points, &spec(1.0, 5, true, false), 4);
        assert_eq!(new.len(), 1);
        assert!(
            matches!(new[0].reason, Refinement::Boundary { lo_rad_s, .. } if lo_rad_s == 4400.0)
        );
    }

    #[test]
    fn the_order_of_the_points_does_not_matter() {
        let speeds = grid(3500.0, 5300.0, 9);
        let r = spec(3.0, 40, true, true);
        let run = refine_line(&speeds, system(4800.0, 4100.3, 120.0), &r);
        let bits =
            |v: &[NewSpeed]| -> Vec<u64> { v.iter().map(|s| s.omega_rad_s.to_bits()).collect() };
        // Every state the run went through (the grid, then one more point at a time), each
        // also with a duplicated point, in many orders.
        let mut widest = 0;
        for n in speeds.len()..=run.points.len() {
            let state = &run.points[..n];
            let reference = next_round(state, &r, 0);
            widest = widest.max(reference.len());
            let mut shuffled = state.to_vec();
            shuffled.push(state[n / 2]);
            for k in 0..shuffled.len() {
                shuffled.rotate_left(k % 3 + 1);
                if k % 2 == 1 {
                    shuffled.reverse();
                }
                let again = next_round(&shuffled, &r, 0);
                assert_eq!(bits(&again), bits(&reference));
                assert_eq!(again, reference);
                assert_eq!(located(&shuffled, &r), located(state, &r));
            }
        }
        // The boundary and the peak were refined side by side.
        assert!(widest >= 2);
    }

    #[test]
    fn failed_points_are_unknown_and_never_run_again() {
        let speeds = grid(3500.0, 5300.0, 9);
        // The job fails on [4210, 4260], inside the bracket of the boundary at 4321.7.
        let flaky = |w: f64| {
            let mut p = system(4321.7, 0.0, 1.0)(w);
            if (4210.0..=4260.0).contains(&w) {
                p.outcome = PointOutcome::Failed;
                p.value = None;
            }
            p
        };
        let r = spec(10.0, 100, true, false);
        let mut points: Vec<SpeedPoint> = speeds.iter().map(|&w| flaky(w)).collect();
        points.push(flaky(4225.0));
        let found = located(&points, &r);
        // [4175, 4400] with the failed 4225 inside: its widest gap [4225, 4400] is halved.
        assert_eq!(found.boundaries.len(), 1);
        let b = found.boundaries[0];
        assert_eq!(
            (b.lo_rad_s, b.hi_rad_s, b.failed_inside),
            (4175.0, 4400.0, 1)
        );
        let new = next_round(&points, &r, 1);
        assert_eq!(new.len(), 1);
        assert_eq!(new[0].omega_rad_s, 4312.5);
        let run = refine_line(&speeds, flaky, &r);
        let b = located(&run.points, &r).boundaries[0];
        assert!(
            b.within_tolerance && b.lo_rad_s <= 4321.7 && 4321.7 < b.hi_rad_s,
            "{b:?}"
        );
        // A failure band over the boundary leaves it bracketed but blocked: nothing to add.
        let blocked = |w: f64| {
            let mut p = system(4321.7, 0.0, 1.0)(w);
            if (4315.0..=4330.0).contains(&w) {
                p.outcome = PointOutcome::Failed;
            }
            p
        };
        let run = refine_line(&speeds, blocked, &r);
        let b = located(&run.points, &r).boundaries[0];
        assert!(!b.within_tolerance && b.failed_inside > 0, "{b:?}");
        assert!(
            b.hi_rad_s - b.lo_rad_s <= 2.0 * r.tolerance_rad_s + 15.0,
            "{b:?}"
        );
    }

    #[test]
    fn a_line_without_change_asks_for_nothing_but_its_peak() {
        let speeds = grid(3500.0, 5300.0, 9);
        let calm: Vec<SpeedPoint> = speeds
            .iter()
            .map(|&w| system(f64::INFINITY, 4447.3, 150.0)(w))
            .collect();
        assert!(next_round(&calm, &spec(5.0, 10, true, false), 0).is_empty());
        let found = located(&calm, &spec(5.0, 10, true, false));
        assert!(found.boundaries.is_empty() && found.peaks.is_empty());
        // The same line asked for its peak refines it.
        let new = next_round(&calm, &spec(5.0, 10, true, true), 0);
        assert_eq!(new.len(), 1);
        assert!(matches!(new[0].reason, Refinement::Peak { .. }));
        // A response that still rises at the end of the grid has no peak to locate.
        let rising: Vec<SpeedPoint> = speeds
            .iter()
            .map(|&w| system(f64::INFINITY, 6000.0, 150.0)(w))
            .collect();
        let r = spec(5.0, 10, true, true);
        assert!(next_round(&rising, &r, 0).is_empty());
        let p = located(&rising, &r).peaks;
        assert!(
            p.len() == 1 && p[0].at_end && p[0].best_rad_s == 5300.0,
            "{p:?}"
        );
        // Nor does a response rising into the runaway: the last ok point is an end.
        let into_runaway: Vec<SpeedPoint> = speeds
            .iter()
            .map(|&w| system(4800.0, 6000.0, 150.0)(w))
            .collect();
        assert!(next_round(&into_runaway, &spec(5.0, 10, false, true), 0).is_empty());
    }

    #[test]
    fn a_peak_is_found_across_failed_points_but_not_across_a_runaway() {
        let speeds = grid(3500.0, 5300.0, 9);
        let r = spec(5.0, 50, false, true);
        // The job at the grid speed next to the peak fails: the peak is still bracketed by
        // the nearest values, and the failed speed is never asked again.
        let flaky = |w: f64| {
            let mut p = system(f64::INFINITY, 4447.3, 150.0)(w);
            if w == 4400.0 {
                (p.outcome, p.value) = (PointOutcome::Failed, None);
            }
            p
        };
        let run = refine_line(&speeds, flaky, &r);
        let p = located(&run.points, &r).peaks;
        assert!(p.len() == 1 && p[0].within_tolerance, "{p:?}");
        assert!((p[0].vertex_rad_s.unwrap() - 4447.3).abs() <= 5.0, "{p:?}");
        // A response that is highest next to an unstable band is not a peak, on either side,
        // while a real peak on the far side of the band is refined.
        let banded = |w: f64| {
            let mut p = system(f64::INFINITY, 3950.0, 300.0)(w);
            if (4200.0..4700.0).contains(&w) {
                p.outcome = PointOutcome::Unstable;
            }
            p
        };
        let points: Vec<SpeedPoint> = speeds.iter().map(|&w| banded(w)).collect();
        let found = located(&points, &r).peaks;
        let (interior, ends): (Vec<LocatedPeak>, Vec<LocatedPeak>) =
            found.iter().partition(|p| !p.at_end);
        assert_eq!(interior.len(), 1, "{found:?}");
        assert_eq!(interior[0].best_rad_s, 3950.0);
        // The stretch above the band falls away from it: its maximum is at its lower end.
        assert!(ends.iter().any(|p| p.best_rad_s == 4850.0), "{found:?}");
        let new = next_round(&points, &r, 0);
        assert_eq!(new.len(), 1);
        assert!(
            new[0].omega_rad_s > 3725.0 && new[0].omega_rad_s < 4175.0,
            "{new:?}"
        );
    }

    #[test]
    fn a_degenerate_fit_falls_back_to_halving_the_larger_half() {
        // A plateau's best point and its right neighbour are equal: the fit's vertex is
        // the middle of the pair, a point is added there; with a flat top of three points the
        // vertex sits on the best point and is pushed tolerance/2 away.
        let pts = |v: [f64; 4]| -> Vec<SpeedPoint> {
            [100.0, 200.0, 300.0, 400.0]
                .iter()
                .zip(v)
                .map(|(&w, y)| SpeedPoint {
                    omega_rad_s: w,
                    outcome: PointOutcome::Ok,
                    value: Some(y),
                })
                .collect()
        };
        let r = spec(10.0, 10, false, true);
        let new = next_round(&pts([0.0, 1.0, 1.0, 0.0]), &r, 0);
        assert_eq!(new.len(), 1);
        assert!((new[0].omega_rad_s - 250.0).abs() < 1e-9, "{new:?}");
        let v = parabola_vertex([(100.0, 0.0), (200.0, 1.0), (300.0, 0.0)]).unwrap();
        assert!((v - 200.0).abs() < 1e-12);
        let new = next_round(&pts([0.0, 1.0, 0.0, -1.0]), &r, 0);
        assert_eq!(new[0].omega_rad_s, 205.0, "{new:?}");
        // An underflowing fit (values 1e-320 apart) has no vertex: the larger half is halved.
        assert_eq!(
            parabola_vertex([(100.0, 0.0), (200.0, 1e-320), (400.0, 0.0)]),
            None
        );
        let new = next_round(&pts([0.0, 1e-320, 0.0, -1.0]), &r, 0);
        assert!(
            matches!(new[0].reason, Refinement::PeakCheck { .. }),
            "{new:?}"
        );
        assert_eq!(new[0].omega_rad_s, 150.0);
    }

    /// Issue 37's figure: on a scan of 0.8–1.2 × the predicted onset, the boundary to 0.5 %
    /// of Ω for at most a quarter of the jobs of a uniform grid of that resolution.
    #[test]
    fn refinement_needs_a_quarter_of_the_jobs_of_a_uniform_grid() {
        let onset: f64 = 4000.0;
        let (start, stop) = (0.8 * onset, 1.2 * onset);
        for omega_b in [1.037 * onset, 0.83 * onset, 1.19 * onset] {
            let tol = 0.005 * omega_b;
            let uniform = ((stop - start) / tol).ceil() as usize + 1;
            let coarse = grid(start, stop, 9);
            let r = spec(tol, 20, true, false);
            let run = refine_line(&coarse, system(omega_b, 0.0, 1.0), &r);
            let b = located(&run.points, &r).boundaries[0];
            assert!(b.within_tolerance && b.lo_rad_s <= omega_b && omega_b < b.hi_rad_s);
            let refined = coarse.len() + run.jobs;
            eprintln!("Ω_b = {omega_b}: {refined} jobs refined against {uniform} uniform");
            assert!(4 * refined <= uniform, "{refined} jobs against {uniform}");
        }
    }

    /// The schema offers `peak_of` the same names.
    #[test]
    fn the_schema_offers_the_peak_quantities() {
        let schema: serde_json::Value =
            serde_json::from_str(crate::sweep::schema::SWEEP_SCHEMA).unwrap();
        let offered: Vec<&str> = schema["$defs"]["refine"]["properties"]["peak_of"]["enum"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        assert_eq!(offered, PEAK_QUANTITIES);
    }
}
