//! Free vibration of a mistuned wheel: the tuned ROM of every nodal diameter coupled by a
//! structural mistuning pattern ([`crate::model::mistuning`]), solved as one real symmetric
//! eigenproblem over the wheel coordinates.
//!
//! Each mode's motion at the blade tips (the contact nodes of every sector) gives the
//! per-blade amplitude `A_s` (the norm of blade `s`'s tip displacement) and the localization
//! `IPR = N_b Σ A_s⁴ / (Σ A_s²)²`: 1 when every blade moves alike, `N_b` when one blade
//! carries the whole mode.

use nalgebra::DMatrix;

use crate::model::eigen::{EigenError, symmetric_gen_eigen};
use crate::model::mistuning::{MistuningError, WheelCoordinates, wheel_mistuning_stiffness};
use crate::model::rom::CyclicRom;

/// Why the mistuned modes could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum MistunedModesError {
    /// The pattern or the ROM cannot be used.
    #[error(transparent)]
    Mistuning(#[from] MistuningError),
    /// The rotation speed is not finite and ≥ 0.
    #[error("omega = {0} rad/s must be finite and >= 0")]
    Omega(f64),
    /// The eigensolver failed.
    #[error("mistuned wheel eigenproblem: {0}")]
    Eigen(#[from] EigenError),
}

/// The lowest free-vibration modes of a mistuned wheel at one rotation speed.
#[derive(Clone, Debug)]
pub struct MistunedModes {
    /// Rotation speed Ω (rad/s).
    pub omega: f64,
    /// Natural frequencies (Hz), ascending.
    pub frequencies_hz: Vec<f64>,
    /// Per mode, the tip displacement of every blade: `tips[p][s·3n_c + i]` is contact DOF `i`
    /// (x y z of the sector frame, node-major) of blade `s`, for the mass-normalized mode
    /// (m/√kg).
    pub tips: Vec<Vec<f64>>,
    /// Per mode, each blade's tip amplitude relative to the largest (dimensionless, max 1).
    pub blade_amplitude: Vec<Vec<f64>>,
    /// Per mode, the inverse participation ratio of the blade amplitudes (1 to N_b).
    pub localization: Vec<f64>,
}

/// The lowest `count` modes (all if fewer) of the wheel of `rom` with blade `s`'s Young's
/// modulus scaled by `1 + delta[s]`, at rotation speed `omega` (rad/s; `K(Ω)` of the ROM).
/// `delta` all zero gives the tuned ROM's frequencies of every nodal diameter, each complex
/// harmonic's twice.
pub fn mistuned_modes(
    rom: &CyclicRom,
    delta: &[f64],
    omega: f64,
    count: usize,
) -> Result<MistunedModes, MistunedModesError> {
    if !(omega.is_finite() && omega >= 0.0) {
        return Err(MistunedModesError::Omega(omega));
    }
    let layout = WheelCoordinates::of(rom);
    let mistuning = wheel_mistuning_stiffness(rom, &layout, delta)?;
    let (mut mass, mut stiffness) = (DMatrix::zeros(layout.total, layout.total), mistuning);
    for (k, h) in rom.harmonics.iter().enumerate() {
        let (o, c, real) = (layout.offset[k], layout.weight[k], layout.real[k]);
        let m = h.mass.real_form(real) * c;
        let kk = h.stiffness_at(omega).real_form(real) * c;
        let n = m.nrows();
        let mut view = mass.view_mut((o, o), (n, n));
        view += &m;
        let mut view = stiffness.view_mut((o, o), (n, n));
        view += &kk;
    }
    let (lam, x) = symmetric_gen_eigen(&stiffness, &mass)?;
    let count = count.min(lam.len());
    let (n_sec, nb) = (rom.n_sectors, rom.n_boundary());
    let mut out = MistunedModes {
        omega,
        frequencies_hz: Vec::with_capacity(count),
        tips: Vec::with_capacity(count),
        blade_amplitude: Vec::with_capacity(count),
        localization: Vec::with_capacity(count),
    };
    for (p, &lam) in lam.iter().enumerate().take(count) {
        let col: Vec<f64> = x.column(p).iter().copied().collect();
        let tips: Vec<f64> = (0..n_sec)
            .flat_map(|s| (0..nb).map(move |i| (s, i)))
            .map(|(s, i)| layout.sector_value(n_sec, s, i, &col))
            .collect();
        let amp: Vec<f64> = tips
            .chunks(nb)
            .map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt())
            .collect();
        out.frequencies_hz
            .push(crate::model::reduction::signed_hz(lam));
        out.localization.push(inverse_participation_ratio(&amp));
        let top = amp
            .iter()
            .copied()
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        out.blade_amplitude
            .push(amp.iter().map(|a| a / top).collect());
        out.tips.push(tips);
    }
    Ok(out)
}

/// `N Σ a⁴ / (Σ a²)²` of per-blade amplitudes `a` (1 when equal, N when one is nonzero; 1 for
/// all zero).
pub fn inverse_participation_ratio(a: &[f64]) -> f64 {
    let s2: f64 = a.iter().map(|x| x * x).sum();
    if s2 == 0.0 {
        return 1.0;
    }
    a.len() as f64 * a.iter().map(|x| x.powi(4)).sum::<f64>() / (s2 * s2)
}

#[cfg(test)]
mod check;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_participation_ratio_runs_from_one_to_the_blade_count() {
        assert_eq!(inverse_participation_ratio(&[2.0; 6]), 1.0);
        assert_eq!(inverse_participation_ratio(&[0.0, 0.0, 3.0, 0.0]), 4.0);
        let half = inverse_participation_ratio(&[1.0, 1.0, 0.0, 0.0]);
        assert!((half - 2.0).abs() < 1e-15, "{half}");
    }
}
