//! A probe's steady response over its last revolutions, the figures a rubbing benchmark
//! reports (Piollet, Nyssen & Batailly 2019): the peak-to-peak over the last few revolutions,
//! the mean over a longer tail, and the dominant frequency with its engine order.

use crate::analysis::spectra::{MIN_SAMPLES, PeakOptions, SpectrumAnalyzer, SpectrumError};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// What to measure over the last revolutions of a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RevolutionWindows {
    /// Revolutions at the end of the run over which the peak-to-peak is taken.
    #[serde(rename = "peak_to_peak_revolutions")]
    pub peak_to_peak: f64,
    /// Revolutions at the end of the run over which the mean and the spectrum are taken.
    #[serde(rename = "mean_revolutions")]
    pub mean_and_spectrum: f64,
}

/// A probe's steady response (signal units, e.g. m).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RevolutionStats {
    /// `max − min` over the last [`RevolutionWindows::peak_to_peak`] revolutions.
    pub peak_to_peak: f64,
    /// Mean over the last [`RevolutionWindows::mean_and_spectrum`] revolutions.
    pub mean: f64,
    /// Frequency (Hz) of the largest spectral peak of the same window, mean removed.
    pub dominant_frequency_hz: f64,
    /// That frequency over the rotation frequency Ω/2π (dimensionless).
    pub dominant_engine_order: f64,
    /// Amplitude of that peak (signal units).
    pub dominant_amplitude: f64,
}

/// Index of the first sample of the last `revolutions` of `time` (s, uniform, ascending) at
/// rotation speed `omega` (rad/s); errors when the run is shorter than the window.
fn window_start(time: &[f64], omega: f64, revolutions: f64) -> Result<usize, SpectrumError> {
    let bad = |name, reason, value| SpectrumError::BadParameter {
        name,
        reason,
        value,
    };
    if !(omega.is_finite() && omega > 0.0) {
        return Err(bad("omega", "rotation speed must be positive", omega));
    }
    if !(revolutions.is_finite() && revolutions > 0.0) {
        return Err(bad("revolutions", "must be positive", revolutions));
    }
    let (Some(&first), Some(&last)) = (time.first(), time.last()) else {
        return Err(bad("time", "no samples", 0.0));
    };
    let start = last - revolutions * TAU / omega;
    if start < first {
        return Err(bad(
            "revolutions",
            "the run is shorter than the window",
            revolutions,
        ));
    }
    Ok(time.partition_point(|&t| t <= start))
}

/// The steady response of `signal` sampled at `time` (s, uniform) at rotation speed `omega`
/// (rad/s) over the windows `w`.
pub fn revolution_stats(
    time: &[f64],
    signal: &[f64],
    omega: f64,
    w: &RevolutionWindows,
) -> Result<RevolutionStats, SpectrumError> {
    if time.len() != signal.len() {
        return Err(SpectrumError::LengthMismatch {
            got: signal.len(),
            expected: time.len(),
        });
    }
    let tail_p2p = &signal[window_start(time, omega, w.peak_to_peak)?..];
    let from = window_start(time, omega, w.mean_and_spectrum)?;
    let tail = &signal[from..];
    if tail.len() < MIN_SAMPLES || tail_p2p.is_empty() {
        return Err(SpectrumError::BadParameter {
            name: "revolutions",
            reason: "too few samples in the window",
            value: w.mean_and_spectrum,
        });
    }
    let (lo, hi) = tail_p2p
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    let mean = tail.iter().sum::<f64>() / tail.len() as f64;
    let dt = (time[time.len() - 1] - time[from]) / (tail.len() - 1) as f64;
    let opts = PeakOptions {
        max_peaks: 1,
        ..PeakOptions::default()
    };
    let peak = SpectrumAnalyzer::new(tail.len())?
        .peaks(tail, dt, omega, &opts)?
        .first()
        .copied();
    Ok(RevolutionStats {
        peak_to_peak: hi - lo,
        mean,
        dominant_frequency_hz: peak.map_or(0.0, |p| p.frequency_hz),
        dominant_engine_order: peak.map_or(0.0, |p| p.engine_order),
        dominant_amplitude: peak.map_or(0.0, |p| p.amplitude),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_steady_tone_over_a_decaying_transient_reads_its_own_figures() {
        // Ω = 1344 rad/s, 50 revolutions sampled 200 times each; the response: a transient
        // that dies in the first revolutions, a mean offset, and a tone at engine order 2.
        let omega: f64 = 1344.0;
        let f_rot = omega / TAU;
        let n = 50 * 200;
        let dt = TAU / omega / 200.0;
        let time: Vec<f64> = (0..=n).map(|i| i as f64 * dt).collect();
        let (a, offset, f) = (2e-4, -5e-5, 2.0 * f_rot);
        let signal: Vec<f64> = time
            .iter()
            .map(|&t| offset + a * (TAU * f * t).sin() + 1e-3 * (-t / 2e-3).exp())
            .collect();
        let w = RevolutionWindows {
            peak_to_peak: 5.0,
            mean_and_spectrum: 20.0,
        };
        let s = revolution_stats(&time, &signal, omega, &w).unwrap();
        assert!((s.peak_to_peak - 2.0 * a).abs() < 1e-3 * a, "{s:?}");
        assert!((s.mean - offset).abs() < 1e-3 * a, "{s:?}");
        assert!((s.dominant_engine_order - 2.0).abs() < 1e-3, "{s:?}");
        assert!((s.dominant_frequency_hz - f).abs() < 1e-3 * f, "{s:?}");
        assert!((s.dominant_amplitude - a).abs() < 1e-2 * a, "{s:?}");
        // A window longer than the run is an error that names it.
        let long = RevolutionWindows {
            peak_to_peak: 5.0,
            mean_and_spectrum: 60.0,
        };
        let e = revolution_stats(&time, &signal, omega, &long).unwrap_err();
        assert!(e.to_string().contains("revolutions"), "{e}");
    }
}
