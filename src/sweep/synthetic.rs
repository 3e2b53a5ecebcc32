//! Deterministic analytic stand-in for the rubbing simulation (test fixture).
//!
//! Every output is a smooth closed-form function of the job parameters, built on the
//! steady-state amplification of a damped oscillator,
//! A(Ω) = a₀ / √((1 − r²)² + (2 ζ r)²), r = Ω / Ω*,
//! so that sweeps show a resonance at the configured critical speed Ω*. It has no
//! physical meaning beyond that; it exists so the sweep engine (planning, resume,
//! sharding, Parquet, plots) can be exercised without the real simulator.
//!
//! With [`SyntheticSimulator::unstable_above_speed_rad_s`] set, jobs above that speed end
//! `unstable`: their result carries a [`Runaway`] whose growth rate rises linearly with the
//! speed's excess over the limit (so the report's outcome shading and growth-rate captions
//! can be exercised end to end).

use std::f64::consts::TAU;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::planner::{CoatingValue, Job};
use super::{CriticalSpeed, FourierPeak, JobResult, JobSimulator, Maxima, Spectrum};
use crate::dynamics::runaway::Runaway;

/// Analytic test simulator. See the module docs for the formulas.
#[derive(Debug, Clone)]
pub struct SyntheticSimulator {
    /// Resonance (critical) speed Ω* (rad/s).
    pub critical_speed_rad_s: f64,
    /// Damping ratio ζ of the resonance.
    pub damping_ratio: f64,
    /// Static amplitude a₀ (m).
    pub base_amplitude_m: f64,
    /// Number of sectors N (strain energy is reported for nodal diameters 0..=N/2).
    pub n_sectors: usize,
    /// Lobes used when the scenario gives none.
    pub default_lobes: u32,
    /// Wear profile stations along the meridian.
    pub n_stations: usize,
    /// Wear profile angles per station.
    pub n_angles: usize,
    /// Spectrum bins (df = max_frequency_hz / bins).
    pub spectrum_bins: usize,
    /// Upper end of the spectrum (Hz).
    pub max_frequency_hz: f64,
    /// Wall-clock time each job takes (slept in slices, polling the cancel flag).
    pub sleep: Duration,
    /// Failure rule: jobs with Ω above this speed fail with a "diverged" reason.
    pub fail_above_speed_rad_s: Option<f64>,
    /// Runaway rule: jobs with Ω above this speed end `unstable` (see the module doc).
    pub unstable_above_speed_rad_s: Option<f64>,
}

impl Default for SyntheticSimulator {
    fn default() -> Self {
        SyntheticSimulator {
            critical_speed_rad_s: 1000.0,
            damping_ratio: 0.05,
            base_amplitude_m: 1e-4,
            n_sectors: 12,
            default_lobes: 2,
            n_stations: 4,
            n_angles: 36,
            spectrum_bins: 128,
            max_frequency_hz: 2000.0,
            sleep: Duration::ZERO,
            fail_above_speed_rad_s: None,
            unstable_above_speed_rad_s: None,
        }
    }
}

fn factor(v: Option<CoatingValue>, nominal: f64) -> f64 {
    match v {
        None => 1.0,
        Some(CoatingValue::Scale(s)) => s,
        Some(CoatingValue::Absolute(x)) => x / nominal,
    }
}

impl SyntheticSimulator {
    /// Amplification A(Ω) (m) at speed `omega` (rad/s).
    pub fn amplitude(&self, omega: f64) -> f64 {
        let r = omega / self.critical_speed_rad_s;
        self.base_amplitude_m
            / ((1.0 - r * r).powi(2) + (2.0 * self.damping_ratio * r).powi(2)).sqrt()
    }

    /// The closed-form result of a job (no sleeping, no failure rule).
    pub fn evaluate(&self, job: &Job) -> JobResult {
        let p = &job.params;
        let omega = p.speed_rad_s;
        let mu = p.friction;
        let a = self.amplitude(omega);
        let lobes = job
            .context
            .scenario
            .lobes
            .unwrap_or(self.default_lobes)
            .max(1);
        let clearance = p.clearance_m.unwrap_or(1e-4);
        let e_factor = factor(p.coating.young, 1e9);
        let t_factor = factor(p.coating.thickness, 1e-3);
        let contact = 1e6 * a * (1.0 + mu) * e_factor * (-clearance / 1e-4).exp();
        let maxima = Maxima {
            blade_le_radial_m: a * (1.0 + mu),
            blade_te_radial_m: 0.5 * a * (1.0 + mu),
            blade_le_radial_lowpass_m: Some(0.9 * a * (1.0 + mu)),
            blade_te_radial_lowpass_m: Some(0.45 * a * (1.0 + mu)),
            casing_radial_m: 0.8 * a / (1.0 + mu),
            contact_normal_force_n: contact,
            coating_force_n: 0.5 * contact * t_factor,
        };
        let wear_profile_m = (0..self.n_stations)
            .map(|j| {
                (0..self.n_angles)
                    .map(|k| {
                        let theta = TAU * k as f64 / self.n_angles as f64;
                        1e-5 * (a / self.base_amplitude_m)
                            * (1.0 + (f64::from(lobes) * theta).cos())
                            * (j + 1) as f64
                            / self.n_stations as f64
                    })
                    .collect()
            })
            .collect();
        let rev_hz = omega / TAU;
        let fourier_peaks: Vec<FourierPeak> = (1..=3u32)
            .map(|m| {
                let eo = f64::from(lobes * m);
                FourierPeak {
                    frequency_hz: eo * rev_hz,
                    engine_order: eo,
                    amplitude_m: a / f64::from(m),
                }
            })
            .collect();
        let n = self.n_sectors.max(1);
        let mut strain_energy_per_nd_j = vec![1e-12; n / 2 + 1];
        for pk in &fourier_peaks {
            // Engine order E excites nodal diameter min(E mod N, N − E mod N).
            let e = pk.engine_order.round() as usize % n;
            let nd = e.min(n - e);
            strain_energy_per_nd_j[nd] += 1e3 * pk.amplitude_m * pk.amplitude_m;
        }
        let df = self.max_frequency_hz / self.spectrum_bins as f64;
        let amplitude_m = (0..self.spectrum_bins)
            .map(|k| {
                let f = k as f64 * df;
                fourier_peaks
                    .iter()
                    .map(|pk| {
                        pk.amplitude_m * (-((f - pk.frequency_hz) / (2.0 * df)).powi(2)).exp()
                    })
                    .sum()
            })
            .collect();
        JobResult {
            maxima,
            wear_profile_m,
            fourier_peaks,
            strain_energy_per_nd_j,
            residual_penetration_m: 0.0,
            steps_over_gap_tolerance: Some(0),
            critical_speed: Some(CriticalSpeed {
                speed_rad_s: self.critical_speed_rad_s,
                nodal_diameter: lobes,
                compatibility: 0.9,
            }),
            spectrum: Some(Spectrum {
                df_hz: df,
                amplitude_m,
            }),
            drive_work_j: None,
            predicted: None,
            runaway: self.runaway(omega, lobes),
        }
    }

    /// The runaway of a job at `omega` (rad/s) under the runaway rule: growth rate
    /// σ = 10⁴ (Ω / limit − 1) (1/s), onset at 4 ms, confirmed 2 ms later; the
    /// growing wave has `lobes` nodal diameters and travels forward at 1.1 × the lobes'
    /// engine order. `None` at or below the limit, or without the rule.
    pub fn runaway(&self, omega: f64, lobes: u32) -> Option<Runaway> {
        let limit = self.unstable_above_speed_rad_s?;
        if omega <= limit {
            return None;
        }
        let f = 1.1 * f64::from(lobes) * omega / TAU;
        Some(Runaway {
            onset_time_s: 4e-3,
            detected_time_s: 6e-3,
            growth_rate_per_s: 1e4 * (omega / limit - 1.0),
            growth_fit_r2: 0.99,
            energy_growth: 12.0,
            drive_work_j: 1.0,
            nodal_diameter: Some(lobes),
            frequency_hz: Some(f),
            forward: Some(true),
            rotating_frame_frequency_hz: Some(f - f64::from(lobes) * omega / TAU),
            at_solve_breakdown: false,
        })
    }
}

impl JobSimulator for SyntheticSimulator {
    fn run(&self, job: &Job, cancel: &AtomicBool) -> Result<JobResult, String> {
        let start = Instant::now();
        while start.elapsed() < self.sleep {
            if cancel.load(Ordering::Relaxed) {
                return Err("cancelled".into());
            }
            std::thread::sleep(
                (self.sleep - start.elapsed().min(self.sleep)).min(Duration::from_millis(5)),
            );
        }
        if let Some(limit) = self.fail_above_speed_rad_s
            && job.params.speed_rad_s > limit
        {
            return Err(format!(
                "diverged: synthetic failure rule (speed {} rad/s above {limit} rad/s)",
                job.params.speed_rad_s
            ));
        }
        Ok(self.evaluate(job))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::plan;
    use crate::sweep::spec::spec_from_value;

    #[test]
    fn resonance_peak_and_aliasing() {
        let sim = SyntheticSimulator::default();
        // The amplification peaks at r = √(1 − 2ζ²) (damped oscillator), value a₀/(2ζ√(1−ζ²)).
        let z: f64 = sim.damping_ratio;
        let r_peak = (1.0 - 2.0 * z * z).sqrt();
        let a_peak = sim.amplitude(r_peak * sim.critical_speed_rad_s);
        assert!(
            (a_peak - sim.base_amplitude_m / (2.0 * z * (1.0 - z * z).sqrt())).abs()
                < 1e-12 * a_peak.abs().max(1.0)
        );
        assert!(sim.amplitude(0.9 * r_peak * sim.critical_speed_rad_s) < a_peak);
        assert!(sim.amplitude(1.1 * r_peak * sim.critical_speed_rad_s) < a_peak);

        let spec = spec_from_value(serde_json::json!({
            "name": "t", "models": {"impeller": {"builtin": {}}, "casing": {"builtin": {}}},
            "scenario": {"duration_s": 0.1, "lobes": 2, "load_amplitude_m": 1e-4},
            "grid": {"speed": {"unit": "rad_s", "values": [500.0]}, "friction": [0.0], "clearance_m": [0.0]}
        }))
        .unwrap();
        let job = &plan(&spec).unwrap().jobs[0];
        let r = sim.evaluate(job);
        // Two lobes, N = 12: engine orders 2, 4, 6 → nodal diameters 2, 4, 6; odd ones stay at the floor.
        for (k, e) in r.strain_energy_per_nd_j.iter().enumerate() {
            assert_eq!(*e > 1e-11, k == 2 || k == 4 || k == 6, "nd {k}: {e}");
        }
        assert!(r.check_finite().is_ok());
    }
}
