//! Amplitude spectra and peak picking of uniformly sampled signals (DESIGN §5, paper
//! Fig. 20): Hann-windowed real FFT over a steady window, peaks in Hz and in engine
//! orders `E = f / (Ω / 2π)`.
//!
//! # Method
//! - The mean is removed (optional), the signal is multiplied by the periodic
//!   ("DFT-even") Hann window `w_j = ½ (1 − cos 2πj/n)`, and transformed by a real FFT
//!   planned once per length ([`SpectrumAnalyzer`] keeps the plan and all buffers, so
//!   repeated calls do not allocate except for the returned peak list).
//! - Amplitude spectrum: `A_k = 2 |X_k| / Σ w` (coherent-gain correction, `Σ w = n/2`):
//!   a sinusoid `a cos(2π f_k t)` centred on bin `k` reads `a`.
//! - Peaks: interior local maxima of `A_k` above `relative_threshold × max A`. The peak
//!   frequency is refined with the Hann-specific two-bin interpolation (Grandke 1983):
//!   with `α` the ratio of the larger neighbour to the peak bin, the offset is
//!   `δ = ±(2α − 1)/(α + 1)` bins. It is exact for a pure tone in the large-`n` limit,
//!   where a parabola through three log-magnitudes (the usual parabolic interpolation)
//!   leaves a bias of several hundredths of a bin. The amplitude is then corrected for
//!   scalloping with the Hann kernel `W(δ) = sinc(δ) / (1 − δ²)`.
//! - Resolution: two tones closer than ~4 bins (`4 / (n dt)` Hz) are not separated.

use rubscan_fft::{Complex, RealFftPlanner64, RealToComplex};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};
use std::sync::Arc;
use thiserror::Error;

/// Invalid spectrum input; every variant names the parameter.
#[derive(Debug, Error, PartialEq)]
pub enum SpectrumError {
    /// Too few samples for a meaningful spectrum.
    #[error("signal window must have at least {min} samples (got {got})")]
    TooShort {
        /// Number of samples given.
        got: usize,
        /// Smallest number accepted.
        min: usize,
    },
    /// The signal length differs from the analyser's planned length.
    #[error("signal has {got} samples but the analyser was planned for {expected}")]
    LengthMismatch {
        /// Number of samples given.
        got: usize,
        /// Number of samples the analyser was planned for.
        expected: usize,
    },
    /// A parameter is not finite or out of range.
    #[error("`{name}` is invalid: {reason} (got {value})")]
    BadParameter {
        /// Name of the parameter.
        name: &'static str,
        /// Why the value is rejected.
        reason: &'static str,
        /// The rejected value (in the parameter's unit).
        value: f64,
    },
    /// The signal contains NaN or infinity.
    #[error("signal sample {index} is not finite")]
    NonFiniteSample {
        /// Index of the first non-finite sample.
        index: usize,
    },

    /// The FFT backend failed (buffer sizes; should not happen).
    #[error("FFT failed: {0}")]
    Fft(String),
}

/// A spectral peak.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// Frequency (Hz), interpolated between bins.
    pub frequency_hz: f64,
    /// Engine order `f / (Ω / 2π)` (dimensionless); NaN when Ω = 0.
    pub engine_order: f64,
    /// Amplitude of the sinusoid (signal units, e.g. m), window- and scalloping-corrected.
    pub amplitude: f64,
}

/// Options of [`SpectrumAnalyzer::peaks`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PeakOptions {
    /// Maximum number of peaks returned (strongest first).
    pub max_peaks: usize,
    /// Peaks below this fraction of the largest amplitude are ignored.
    pub relative_threshold: f64,
    /// Subtract the mean before windowing (a static offset would otherwise leak into the
    /// lowest bins).
    pub remove_mean: bool,
}

impl Default for PeakOptions {
    fn default() -> Self {
        Self {
            max_peaks: 10,
            relative_threshold: 1e-3,
            remove_mean: true,
        }
    }
}

/// Minimum window length accepted.
pub const MIN_SAMPLES: usize = 16;

/// A reusable Hann-windowed real-FFT analyser for signals of a fixed length `n`.
pub struct SpectrumAnalyzer {
    fft: Arc<dyn RealToComplex<f64>>,
    window: Vec<f64>,
    window_sum: f64,
    input: Vec<f64>,
    output: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
    amplitude: Vec<f64>,
}

impl SpectrumAnalyzer {
    /// Plans a forward real FFT of length `n` (≥ [`MIN_SAMPLES`]).
    pub fn new(n: usize) -> Result<Self, SpectrumError> {
        if n < MIN_SAMPLES {
            return Err(SpectrumError::TooShort {
                got: n,
                min: MIN_SAMPLES,
            });
        }
        let plan = RealFftPlanner64::new().plan_fft_forward(n);
        Self::with_plan(plan)
    }

    /// Builds an analyser around an existing plan, so that parallel jobs share one plan
    /// (plans are `Send + Sync`).
    pub(crate) fn with_plan(fft: Arc<dyn RealToComplex<f64>>) -> Result<Self, SpectrumError> {
        let n = fft.len();
        if n < MIN_SAMPLES {
            return Err(SpectrumError::TooShort {
                got: n,
                min: MIN_SAMPLES,
            });
        }
        let window: Vec<f64> = (0..n)
            .map(|j| 0.5 * (1.0 - (TAU * j as f64 / n as f64).cos()))
            .collect();
        let window_sum = window.iter().sum();
        Ok(Self {
            input: fft.make_input_vec(),
            output: fft.make_output_vec(),
            scratch: fft.make_scratch_vec(),
            amplitude: vec![0.0; n / 2 + 1],
            fft,
            window,
            window_sum,
        })
    }

    /// Planned signal length n.
    pub fn len(&self) -> usize {
        self.window.len()
    }

    /// Always false (n ≥ [`MIN_SAMPLES`]); provided for API symmetry with `len`.
    pub fn is_empty(&self) -> bool {
        self.window.is_empty()
    }

    /// Frequency resolution `1 / (n dt)` (Hz) for a time step `dt` (s).
    pub fn bin_width(&self, dt: f64) -> f64 {
        1.0 / (self.len() as f64 * dt)
    }

    /// Single-sided amplitude spectrum `A_k`, `k = 0..=n/2`, at frequencies `k / (n dt)`
    /// (Hz), of `signal` (n samples, time step `dt` in s), in signal units.
    pub fn amplitude_spectrum(
        &mut self,
        signal: &[f64],
        dt: f64,
        remove_mean: bool,
    ) -> Result<&[f64], SpectrumError> {
        let n = self.len();
        if signal.len() != n {
            return Err(SpectrumError::LengthMismatch {
                got: signal.len(),
                expected: n,
            });
        }
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SpectrumError::BadParameter {
                name: "dt",
                reason: "time step must be positive and finite",
                value: dt,
            });
        }
        if let Some(index) = signal.iter().position(|x| !x.is_finite()) {
            return Err(SpectrumError::NonFiniteSample { index });
        }
        let mean = if remove_mean {
            signal.iter().sum::<f64>() / n as f64
        } else {
            0.0
        };
        for ((x, &s), &w) in self.input.iter_mut().zip(signal).zip(&self.window) {
            *x = (s - mean) * w;
        }
        self.fft
            .process_with_scratch(&mut self.input, &mut self.output, &mut self.scratch)
            .map_err(|e| SpectrumError::Fft(e.to_string()))?;
        let scale = 2.0 / self.window_sum;
        for (a, c) in self.amplitude.iter_mut().zip(&self.output) {
            *a = c.norm() * scale;
        }
        // DC and Nyquist bins have no negative-frequency twin.
        self.amplitude[0] *= 0.5;
        if n.is_multiple_of(2) {
            self.amplitude[n / 2] *= 0.5;
        }
        Ok(&self.amplitude)
    }

    /// Peaks of the spectrum of `signal` (n samples, step `dt` in s), strongest first;
    /// engine orders refer to the rotation speed `omega` (rad/s, ≥ 0).
    pub fn peaks(
        &mut self,
        signal: &[f64],
        dt: f64,
        omega: f64,
        opts: &PeakOptions,
    ) -> Result<Vec<Peak>, SpectrumError> {
        if !(omega.is_finite() && omega >= 0.0) {
            return Err(SpectrumError::BadParameter {
                name: "omega",
                reason: "rotation speed must be finite and non-negative",
                value: omega,
            });
        }
        if !(opts.relative_threshold.is_finite() && (0.0..=1.0).contains(&opts.relative_threshold))
        {
            return Err(SpectrumError::BadParameter {
                name: "relative_threshold",
                reason: "must lie in [0, 1]",
                value: opts.relative_threshold,
            });
        }
        let df = self.bin_width(dt);
        let amp = self.amplitude_spectrum(signal, dt, opts.remove_mean)?;
        let max = amp[1..].iter().fold(0.0_f64, |m, &a| m.max(a));
        if max == 0.0 {
            return Ok(Vec::new());
        }
        let floor = opts.relative_threshold * max;
        let mut peaks = Vec::new();
        for k in 1..amp.len() - 1 {
            let (l, c, r) = (amp[k - 1], amp[k], amp[k + 1]);
            if !(c > l && c >= r && c >= floor) {
                continue;
            }
            let delta = hann_offset(l, c, r);
            let amplitude = c / hann_kernel(delta);
            let frequency_hz = (k as f64 + delta) * df;
            let engine_order = if omega > 0.0 {
                frequency_hz / (omega / TAU)
            } else {
                f64::NAN
            };
            peaks.push(Peak {
                frequency_hz,
                engine_order,
                amplitude,
            });
        }
        peaks.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        peaks.truncate(opts.max_peaks);
        Ok(peaks)
    }
}

/// Bin offset `δ ∈ [−½, ½]` of a tone whose peak bin has magnitude `c` and neighbours
/// `l`, `r` (Hann window, Grandke 1983): for a tone at `k + δ`, `δ ≥ 0`, the ratio
/// `α = A_{k+1}/A_k = W(1 − δ)/W(δ) = (1 + δ)/(2 − δ)`, hence `δ = (2α − 1)/(α + 1)`.
fn hann_offset(l: f64, c: f64, r: f64) -> f64 {
    let (alpha, sign) = if r >= l { (r / c, 1.0) } else { (l / c, -1.0) };
    sign * ((2.0 * alpha - 1.0) / (alpha + 1.0)).clamp(-0.5, 0.5)
}

/// Normalised magnitude of the Hann window's spectral kernel at an offset of `x` bins
/// (large-n limit): `sinc(x) / (1 − x²)`, equal to 1 at `x = 0`.
fn hann_kernel(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        return 1.0;
    }
    let px = PI * x;
    (px.sin() / px) / (1.0 - x * x)
}

/// The last `n` samples of `signal` (the steady part of a run), or an error naming the
/// shortfall.
pub fn tail(signal: &[f64], n: usize) -> Result<&[f64], SpectrumError> {
    if signal.len() < n {
        return Err(SpectrumError::TooShort {
            got: signal.len(),
            min: n,
        });
    }
    Ok(&signal[signal.len() - n..])
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn synth(n: usize, dt: f64, tones: &[(f64, f64, f64)], offset: f64) -> Vec<f64> {
        (0..n)
            .map(|j| {
                let t = j as f64 * dt;
                offset
                    + tones
                        .iter()
                        .map(|&(a, f, ph)| a * (TAU * f * t + ph).cos())
                        .sum::<f64>()
            })
            .collect()
    }

    #[test]
    fn recovers_harmonics_and_engine_orders() {
        // Ω such that the rotation frequency is 37.3 Hz; tones at engine orders 2, 4.5
        // and 7.25 with amplitudes 1e-3, 2e-4, 5e-5 m, off bin centres, plus a DC offset.
        let n = 8192;
        let dt = 1.0 / 5000.0;
        let f_rot = 37.3;
        let omega = TAU * f_rot;
        let tones = [
            (1e-3, 2.0 * f_rot, 0.3),
            (2e-4, 4.5 * f_rot, 1.1),
            (5e-5, 7.25 * f_rot, -2.0),
        ];
        let x = synth(n, dt, &tones, 3e-3);
        let mut an = SpectrumAnalyzer::new(n).unwrap();
        let df = an.bin_width(dt);
        let peaks = an.peaks(&x, dt, omega, &PeakOptions::default()).unwrap();
        assert_eq!(peaks.len(), 3, "{peaks:?}");
        for (p, &(a, f, _)) in peaks.iter().zip(&tones) {
            assert!((p.frequency_hz - f).abs() < 1e-3 * df, "{p:?} vs {f}");
            assert_relative_eq!(p.amplitude, a, max_relative = 1e-4);
            assert_relative_eq!(p.engine_order, f / f_rot, max_relative = 1e-6);
        }
        // Reuse of the same analyser gives the same answer (buffers reset properly).
        let again = an.peaks(&x, dt, omega, &PeakOptions::default()).unwrap();
        assert_eq!(peaks, again);
    }

    #[test]
    fn tone_offset_sweep_within_one_bin() {
        // The interpolation is accurate for any position of the tone between bins.
        let n = 4096;
        let dt = 1e-3;
        let mut an = SpectrumAnalyzer::new(n).unwrap();
        let df = an.bin_width(dt);
        for i in 0..=10 {
            let f = (300.0 + i as f64 / 10.0) * df;
            let x = synth(n, dt, &[(2.0, f, 0.7)], 0.0);
            let p = an.peaks(&x, dt, 0.0, &PeakOptions::default()).unwrap();
            assert_eq!(p.len(), 1);
            assert!((p[0].frequency_hz - f).abs() < 1e-3 * df);
            assert_relative_eq!(p[0].amplitude, 2.0, max_relative = 1e-4);
            assert!(p[0].engine_order.is_nan());
        }
    }

    #[test]
    fn bin_centred_tone_amplitude_spectrum() {
        let n = 1024;
        let dt = 0.01;
        let mut an = SpectrumAnalyzer::new(n).unwrap();
        let f = 50.0 * an.bin_width(dt);
        let x = synth(n, dt, &[(3.0, f, 0.0)], 0.0);
        let a = an.amplitude_spectrum(&x, dt, false).unwrap();
        assert_relative_eq!(a[50], 3.0, max_relative = 1e-12);
        // Hann main lobe: the adjacent bins read half the amplitude; further bins vanish.
        assert_relative_eq!(a[49], 1.5, max_relative = 1e-12);
        assert!(a[47] < 1e-12 && a[53] < 1e-12);
    }

    #[test]
    fn threshold_and_top_n() {
        let n = 4096;
        let dt = 1e-3;
        let x = synth(
            n,
            dt,
            &[(1.0, 100.3, 0.0), (0.1, 200.7, 0.0), (0.001, 310.1, 0.0)],
            0.0,
        );
        let mut an = SpectrumAnalyzer::new(n).unwrap();
        let opts = PeakOptions {
            relative_threshold: 0.01,
            ..Default::default()
        };
        let p = an.peaks(&x, dt, 10.0, &opts).unwrap();
        assert_eq!(p.len(), 2);
        let opts = PeakOptions {
            max_peaks: 1,
            ..Default::default()
        };
        let p = an.peaks(&x, dt, 10.0, &opts).unwrap();
        assert_eq!(p.len(), 1);
        assert!((p[0].frequency_hz - 100.3).abs() < 1e-3);
    }

    #[test]
    fn errors() {
        assert!(SpectrumAnalyzer::new(4).is_err());
        let mut an = SpectrumAnalyzer::new(64).unwrap();
        let x = vec![0.0; 63];
        assert!(matches!(
            an.peaks(&x, 1e-3, 1.0, &PeakOptions::default()),
            Err(SpectrumError::LengthMismatch { .. })
        ));
        let mut x = vec![0.0; 64];
        assert!(an.peaks(&x, 0.0, 1.0, &PeakOptions::default()).is_err());
        assert!(an.peaks(&x, 1e-3, -1.0, &PeakOptions::default()).is_err());
        assert!(
            an.peaks(&x, 1e-3, 1.0, &PeakOptions::default())
                .unwrap()
                .is_empty()
        );
        x[3] = f64::NAN;
        assert_eq!(
            an.peaks(&x, 1e-3, 1.0, &PeakOptions::default()),
            Err(SpectrumError::NonFiniteSample { index: 3 })
        );
        assert_eq!(tail(&[1.0, 2.0, 3.0], 2).unwrap(), &[2.0, 3.0]);
        assert!(tail(&[1.0], 2).is_err());
    }
}
