//! The per-job row of a sweep, computed online while the job runs: maxima over every step of
//! the run (the simulation's [`Peaks`](crate::dynamics::probes::Peaks)), Fourier peaks of blade 0's leading-edge radial displacement over the steady window, mean
//! strain energy per nodal diameter over that window, final wear. Memory is bounded whatever
//! the run's length: the steady window keeps at most [`JobAggregator::DEFAULT_WINDOW_SAMPLES`]
//! samples (its last ones), everything else is a running value.

use std::collections::VecDeque;

use crate::analysis::spectra::{PeakOptions, SpectrumAnalyzer};
use crate::dynamics::probes::RunSummary;
use crate::dynamics::recorder::{RecordError, Recorder, Sample};
use crate::sweep::{FourierPeak, JobResult, Maxima, Spectrum};

/// A [`Recorder`] that keeps only what the sweep's table needs.
#[derive(Clone, Debug)]
pub struct JobAggregator {
    /// Rotation speed Ω (rad/s), for the engine orders of the peaks.
    omega: f64,
    /// Start (s) of the steady window.
    window_start: f64,
    /// The first two sample times (s): their difference is the sampling interval.
    first_times: [Option<f64>; 2],
    /// Blade 0's leading-edge radial displacement (m) over the steady window, its last
    /// `capacity` samples.
    window: VecDeque<f64>,
    capacity: usize,
    /// Running sums of the strain energy per nodal diameter over the window (J), and the
    /// number of window samples.
    nd_sum: Vec<f64>,
    window_samples: usize,
    /// Drive work (J) at the last sample.
    drive_work: f64,
}

impl JobAggregator {
    /// Samples kept for the steady window's spectrum: 2¹⁷ (1 MiB), 0.13 s at the default
    /// 1 MHz sampling (h = 1e-7 s, decimation 10), a resolution of 7.6 Hz.
    pub const DEFAULT_WINDOW_SAMPLES: usize = 1 << 17;

    /// An aggregator for a job at Ω = `omega` (rad/s) whose steady window starts at
    /// `window_start` (s); the window's spectrum uses at most its last `capacity` samples.
    pub fn new(omega: f64, window_start: f64, capacity: usize) -> Self {
        Self {
            omega,
            window_start,
            first_times: [None; 2],
            window: VecDeque::new(),
            capacity: capacity.max(1),
            nd_sum: Vec::new(),
            window_samples: 0,
            drive_work: 0.0,
        }
    }

    /// The job's row from the samples seen and the run's `summary`.
    pub fn finish(self, summary: &RunSummary) -> Result<JobResult, String> {
        let dt = match self.first_times {
            [Some(t0), Some(t1)] => t1 - t0,
            _ => 0.0,
        };
        let n = self.window.len();
        let (mut fourier_peaks, mut spectrum) = (vec![], None);
        if n >= 16 && dt > 0.0 {
            let signal: Vec<f64> = self.window.into_iter().collect();
            let mut analyzer = SpectrumAnalyzer::new(n).map_err(|e| e.to_string())?;
            let opts = PeakOptions {
                max_peaks: 5,
                ..PeakOptions::default()
            };
            fourier_peaks = analyzer
                .peaks(&signal, dt, self.omega, &opts)
                .map_err(|e| e.to_string())?
                .into_iter()
                .map(|p| FourierPeak {
                    frequency_hz: p.frequency_hz,
                    engine_order: p.engine_order,
                    amplitude_m: p.amplitude,
                })
                .collect();
            let amplitude = analyzer
                .amplitude_spectrum(&signal, dt, true)
                .map_err(|e| e.to_string())?
                .to_vec();
            spectrum = Some(Spectrum {
                df_hz: analyzer.bin_width(dt),
                amplitude_m: amplitude,
            });
        }
        let count = self.window_samples;
        let strain_energy_per_nd_j = self
            .nd_sum
            .iter()
            .map(|s| if count > 0 { s / count as f64 } else { 0.0 })
            .collect();
        let peaks = &summary.peaks;
        Ok(JobResult {
            maxima: Maxima {
                blade_le_radial_m: peaks.blade_le_radial,
                blade_te_radial_m: peaks.blade_te_radial,
                blade_le_radial_lowpass_m: peaks.blade_le_radial_lowpass,
                blade_te_radial_lowpass_m: peaks.blade_te_radial_lowpass,
                casing_radial_m: peaks.casing_radial,
                contact_normal_force_n: peaks.contact_normal_force,
                coating_force_n: peaks.coating_force,
            },
            wear_profile_m: summary
                .coating
                .as_ref()
                .map_or(vec![], |c| c.final_wear.clone()),
            fourier_peaks,
            strain_energy_per_nd_j,
            residual_penetration_m: summary.max_residual_penetration,
            steps_over_gap_tolerance: Some(summary.steps_over_gap_tolerance as u64),
            critical_speed: None,
            spectrum,
            drive_work_j: Some(self.drive_work),
            predicted: None,
            runaway: summary.runaway,
        })
    }
}

impl Recorder for JobAggregator {
    fn record(&mut self, s: &Sample<'_>) -> Result<(), RecordError> {
        self.drive_work = s.drive_work;
        match self.first_times {
            [None, _] => self.first_times[0] = Some(s.time),
            [Some(_), None] => self.first_times[1] = Some(s.time),
            _ => {}
        }
        if s.time < self.window_start {
            return Ok(());
        }
        if let Some(&x) = s.blade_le_radial.first() {
            if self.window.len() == self.capacity {
                self.window.pop_front();
            }
            self.window.push_back(x);
        }
        if self.nd_sum.is_empty() {
            // The value of an empty `Iterator::sum`, so that the running sums equal the sums
            // of the stored series.
            let zero: f64 = std::iter::empty::<f64>().sum();
            self.nd_sum = vec![zero; s.impeller_nd_strain_energy.len()];
        }
        for (acc, e) in self.nd_sum.iter_mut().zip(s.impeller_nd_strain_energy) {
            *acc += e;
        }
        self.window_samples += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::kernel::Energies;

    fn sample<'a>(t: f64, le: &'a [f64], nd: &'a [f64]) -> Sample<'a> {
        Sample {
            time: t,
            blade_le_radial: le,
            blade_te_radial: le,
            casing_radial: &[],
            blade_normal_force: &[],
            blade_tangential_force: &[],
            min_gap: 0.0,
            residual_penetration: 0.0,
            drive_work: 0.0,
            impeller_energy: Energies::default(),
            casing_energy: None,
            impeller_nd_strain_energy: nd,
            coating: None,
            probe_columns: &[],
            probes: &[],
        }
    }

    /// A sine of 1 kHz sampled at 64 kHz: the window's peak is at 1 kHz whether the window
    /// holds every sample or only its last 256; window means are exact, and the maxima are the
    /// run's.
    #[test]
    fn online_aggregates_match_the_series_and_the_window_is_bounded() {
        let dt = 1.0 / 64_000.0;
        let n = 1024;
        let signal: Vec<f64> = (0..n)
            .map(|i| 1e-4 * (2.0 * std::f64::consts::PI * 1000.0 * i as f64 * dt).sin())
            .collect();
        let omega = 2.0 * std::f64::consts::PI * 100.0;
        let run = |capacity: usize| {
            let mut agg = JobAggregator::new(omega, 0.5 * n as f64 * dt, capacity);
            for (i, x) in signal.iter().enumerate() {
                let nd = [i as f64, 1.0];
                agg.record(&sample(i as f64 * dt, &[*x, -2.0 * x], &nd))
                    .unwrap();
            }
            assert!(agg.window.len() <= capacity);
            let mut summary = RunSummary::default();
            summary.peaks.blade_te_radial = 3e-4;
            agg.finish(&summary).unwrap()
        };
        let full = run(usize::MAX);
        let bounded = run(256);
        for r in [&full, &bounded] {
            let p = r.fourier_peaks[0];
            assert!((p.frequency_hz - 1000.0).abs() < 1.0, "{p:?}");
            assert!((p.engine_order - 10.0).abs() < 0.01, "{p:?}");
        }
        assert_eq!(bounded.spectrum.as_ref().unwrap().amplitude_m.len(), 129);
        // Window i = 512..1024: mean of i is 767.5.
        assert_eq!(full.strain_energy_per_nd_j, vec![767.5, 1.0]);
        assert_eq!(full.maxima.blade_te_radial_m, 3e-4);
        assert_eq!(full.maxima.blade_le_radial_m, 0.0);
    }
}
