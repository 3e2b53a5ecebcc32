//! Each probe's extremes over the run and its steady response over the run's last revolutions
//! ([`analysis::revolutions`](crate::analysis::revolutions)), the figures a rubbing benchmark
//! reports. Kept online in bounded memory: only the samples of the last window are stored.

use serde::Serialize;

use crate::analysis::revolutions::{RevolutionStats, RevolutionWindows, revolution_stats};
use crate::dynamics::recorder::{RecordError, Recorder, Sample};
use std::f64::consts::TAU;

/// The figures of one probe (its unit, m or N).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProbeFigures {
    /// Time-series column of the probe, e.g. `node1353_y_m`.
    pub column: String,
    /// Unit of the values.
    pub unit: &'static str,
    /// Smallest and largest value over the whole run.
    pub min: f64,
    /// Largest value over the whole run.
    pub max: f64,
    /// Steady response over the last revolutions.
    pub steady: RevolutionStats,
}

/// A [`Recorder`] of the probes' extremes and of their samples over the last revolutions.
#[derive(Clone, Debug)]
pub struct ProbeReport {
    omega: f64,
    windows: RevolutionWindows,
    /// Samples before this time (s) are not kept: the longest window's start, less a margin.
    keep_from: f64,
    columns: Vec<(String, &'static str)>,
    extremes: Vec<(f64, f64)>,
    time: Vec<f64>,
    /// `[probe][sample]` over the kept window.
    values: Vec<Vec<f64>>,
}

impl ProbeReport {
    /// A report for a run of `duration` (s) at `omega` (rad/s) over the `windows`.
    pub fn new(omega: f64, duration: f64, windows: RevolutionWindows) -> Self {
        let longest = windows.peak_to_peak.max(windows.mean_and_spectrum);
        let revolution = TAU / omega;
        Self {
            omega,
            windows,
            keep_from: duration - (longest + 0.01) * revolution,
            columns: vec![],
            extremes: vec![],
            time: vec![],
            values: vec![],
        }
    }

    /// The figures of every probe, in the case's order.
    pub fn finish(self) -> Result<Vec<ProbeFigures>, String> {
        self.columns
            .into_iter()
            .zip(self.extremes)
            .zip(&self.values)
            .map(|(((column, unit), (min, max)), v)| {
                let steady = revolution_stats(&self.time, v, self.omega, &self.windows)
                    .map_err(|e| format!("probe {column}: {e}"))?;
                Ok(ProbeFigures {
                    column,
                    unit,
                    min,
                    max,
                    steady,
                })
            })
            .collect()
    }
}

impl Recorder for ProbeReport {
    fn record(&mut self, s: &Sample<'_>) -> Result<(), RecordError> {
        if self.columns.is_empty() {
            self.columns = (s.probe_columns.iter())
                .map(|p| (p.column.clone(), p.unit))
                .collect();
            self.extremes = vec![(f64::INFINITY, f64::NEG_INFINITY); s.probes.len()];
            self.values = vec![vec![]; s.probes.len()];
        }
        for (e, &x) in self.extremes.iter_mut().zip(s.probes) {
            *e = (e.0.min(x), e.1.max(x));
        }
        if s.time >= self.keep_from {
            self.time.push(s.time);
            for (v, &x) in self.values.iter_mut().zip(s.probes) {
                v.push(x);
            }
        }
        Ok(())
    }
}
