//! Linear stability of the coupled impeller–casing system about a persistent rub, per rotation
//! speed Ω, independent of the time integration (issue 37, item 2; derivation and figures in
//! `docs/stability.md`).
//!
//! # The linearisation
//! The blade-tip nodes of the held rows ([`StabilityOptions::held_rows`]) stay on the casing
//! surface along its normal `n` and slide on it with Coulomb friction. The impeller turns
//! counter-clockwise about `+z`, so a tip slides along `+e_θ` over the casing: the contact force
//! on the casing is `N (n + μ e_θ)`, the one on the blade its opposite. The sliding speed `ΩR`
//! dominates the vibration velocities, so the friction direction is fixed at first order and the
//! force perturbation is `δN (n + μ e_θ)`. The preload `N₀` and every term it multiplies
//! (geometric stiffness, rotation of the normal, the velocity dependence of the friction
//! direction `μ N₀ δv/(ΩR)`) are neglected: the perturbation equations hold for any preload.
//!
//! # One frame, one eigenproblem per impeller nodal diameter
//! The casing (fixed frame, `N_c` sectors) is written as harmonics `X_k e^{ikφ}`, `k` signed,
//! interpolated around the circumference by the harmonic itself (the B-spline between nodes is
//! not modelled, the casing is "axisymmetric" in its harmonics; the Nyquist harmonic `N_c/2` of
//! an even casing, which cannot be written so, is left out). A tip of blade `s` sits at the
//! fixed-frame angle `Ωt + 2πs/N_b + φ_j`, so casing harmonic `k` reaches it as
//! `X_k e^{ikΩt} e^{ik(2πs/N_b + φ_j)}`. In the rotating frame, `Y_k = X_k e^{ikΩt}`, the
//! coupling is time-invariant, and the casing equations become
//! `ρ [(λ − ikΩ)² M_k + (λ − ikΩ) D_k + K_k] Y_k = B_kᴴ F` (Coriolis `−2ikΩ M`, centrifugal
//! `−k²Ω² M`, and the circulatory `−ikΩ D` of the stator's damping seen from the rotor), with
//! `ρ = N_c/N_b` the ratio of the two structures' sector counts. Summed over the blades, casing
//! harmonic `k` only meets impeller nodal diameter `ν ≡ k (mod N_b)` (aliasing): each impeller
//! class `ν` gives one time-invariant complex eigenproblem. This is the moving-load system of
//! Iwan & Moeller (1976) with rotor and stator exchanged, closed by the tip–casing contact of
//! Legrand et al. (2009).
//!
//! # Contact and size
//! Each class is solved on the free modes of its blocks (the impeller block `ν` at `K(Ω)`, the
//! casing harmonics `k ≡ ν`). Modes whose rotating-frame frequencies `|kΩ ± ω_p|` all exceed
//! [`StabilityOptions::mode_cutoff_hz`] are condensed quasi-statically in the rotating frame
//! (their response at `λ = 0`, `φφᴴ/(ω_p² − k²Ω² − ikΩc_p)`): a residual flexibility `R` of the
//! contact, which turns the bilateral constraint into `N = R⁻¹ G η` exactly (MacNeal's residual
//! flexibility; no penalty parameter). Without a cutoff every mode stays and the constraint is
//! imposed exactly by null-space projection (an index-reduced DAE). A finite contact stiffness
//! ([`ContactModel::Spring`]) adds `1/k_c` in series.
//!
//! # Units
//! SI inside: rad/s for Ω and eigenvalues, 1/s for growth rates; frequencies reported in Hz.

mod coupled;
mod interface;
mod modes;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod time_domain;

use crate::model::rom::{Component, CyclicRom, RomError};
use coupled::{ClassSolution, solve_class};
use interface::Interface;
use modes::{BlockModes, block_modes};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;
use thiserror::Error;

/// How the held tip nodes meet the casing along the normal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ContactModel {
    /// The tip stays on the surface exactly (bilateral constraint, zero penetration).
    Bilateral,
    /// A linear spring of stiffness `stiffness_n_per_m` (N/m) along the normal, in series with
    /// the structures; → [`ContactModel::Bilateral`] as the stiffness grows, no coupling as it
    /// vanishes.
    Spring {
        /// Contact stiffness (N/m), finite and > 0.
        stiffness_n_per_m: f64,
    },
}

/// Which growing waves make a speed unstable.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Only the waves that keep the rub persistent while they grow
    /// ([`CoupledWave::quasi_static`]): a growing wave that oscillates faster than it grows,
    /// seen from the blades, reverses its contact-force perturbation every half period and
    /// opens a unilateral contact as soon as that exceeds the preload, so the linearisation
    /// about a closed contact does not describe its growth (friction-induced mode coupling of
    /// a sliding bilateral contact, which the simulations show ringing down).
    #[default]
    PersistentRub,
    /// Every wave of the linearised (bilateral) system.
    EveryWave,
}

/// Options of [`predict`], [`scan`] and [`onset_speed`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StabilityOptions {
    /// Coulomb friction coefficient μ (dimensionless, ≥ 0) of the sliding contact.
    pub friction: f64,
    /// Contact law along the normal.
    pub contact: ContactModel,
    /// Tip rows held on the casing (the `row` of the impeller's contact nodes); `None`: every
    /// row.
    pub held_rows: Option<Vec<usize>>,
    /// Modes whose rotating-frame frequencies `|kΩ ± ω_p|` (impeller: `ω_p`) all exceed this
    /// (Hz) are condensed quasi-statically into the contact's residual flexibility; `None`
    /// keeps every mode (exact, slower: a few seconds per speed on the built-in models).
    pub mode_cutoff_hz: Option<f64>,
    /// A wave grows when its growth rate exceeds this (1/s, ≥ 0): eigenvalues of a conservative
    /// system sit on the imaginary axis only to round-off.
    pub growth_threshold_per_s: f64,
    /// Which growing waves count for [`StabilityAtSpeed::is_stable`].
    pub verdict: Verdict,
    /// Speeds of the uniform scan with which [`onset_speed`] looks for the first growing wave
    /// before it bisects (≥ 2); narrower unstable windows than its spacing can be missed.
    pub onset_scan_points: usize,
}

impl Default for StabilityOptions {
    /// μ = 0, bilateral contact on every row, modes above 20 kHz condensed (`docs/stability.md`
    /// for the convergence), threshold 0.1 s⁻¹, the persistent-rub verdict, 48 scan points.
    fn default() -> Self {
        Self {
            friction: 0.0,
            contact: ContactModel::Bilateral,
            held_rows: None,
            mode_cutoff_hz: Some(20e3),
            growth_threshold_per_s: 0.1,
            verdict: Verdict::PersistentRub,
            onset_scan_points: 48,
        }
    }
}

impl StabilityOptions {
    /// The default options with friction `mu`.
    pub fn with_friction(mu: f64) -> Self {
        Self {
            friction: mu,
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<(), StabilityError> {
        let bad = |name, reason| Err(StabilityError::BadOption { name, reason });
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return bad("friction", "must be finite and ≥ 0");
        }
        if let ContactModel::Spring { stiffness_n_per_m } = self.contact
            && !(stiffness_n_per_m.is_finite() && stiffness_n_per_m > 0.0)
        {
            return bad("contact.stiffness_n_per_m", "must be finite and > 0");
        }
        if let Some(f) = self.mode_cutoff_hz
            && !(f.is_finite() && f > 0.0)
        {
            return bad("mode_cutoff_hz", "must be finite and > 0");
        }
        if !(self.growth_threshold_per_s.is_finite() && self.growth_threshold_per_s >= 0.0) {
            return bad("growth_threshold_per_s", "must be finite and ≥ 0");
        }
        if self.onset_scan_points < 2 {
            return bad("onset_scan_points", "must be at least 2");
        }
        Ok(())
    }
}

/// One coupled wave: an eigenvalue of the linearised system with the casing harmonic that
/// carries most of its casing energy.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CoupledWave {
    /// Casing nodal diameter |k| of the dominant casing harmonic (for a wave with no casing
    /// part, the lowest |k| of its class).
    pub nodal_diameter: usize,
    /// Impeller nodal diameter of the class, `min(ν, N_b − ν)`.
    pub impeller_nodal_diameter: usize,
    /// Re λ: the amplitude grows as `e^{σt}` (1/s); > 0 grows, < 0 decays.
    pub growth_rate_per_s: f64,
    /// Frequency of the casing wave in the fixed frame, `|Im λ − kΩ|/2π` (Hz).
    pub frequency_hz: f64,
    /// Frequency seen from the rotating frame (by the blades), `|Im λ|/2π` (Hz).
    pub rotating_frequency_hz: f64,
    /// The casing wave travels against the rotation in the fixed frame. (The moving-load
    /// unstable wave is forward here and backward in the rotating frame.)
    pub backward: bool,
    /// Whether it travels against the rotation as seen from the rotating frame (blades).
    pub backward_in_rotating_frame: bool,
    /// Fraction of the wave's modal energy in the casing, in [0, 1].
    pub casing_share: f64,
    /// `|Im λ| ≤ |Re λ|`: seen from the blades the wave changes sign more slowly than it grows
    /// (or decays) e-fold, so while it grows the contact-force perturbation at each tip keeps
    /// its sign and the persistent rub it assumes holds for a unilateral contact. The
    /// moving-load divergence above the critical wave speed stands still in the rotating frame.
    pub quasi_static: bool,
}

impl CoupledWave {
    /// Whether the wave counts for `verdict` (a decaying wave always counts).
    pub fn counts_for(&self, verdict: Verdict, threshold_per_s: f64) -> bool {
        match verdict {
            Verdict::EveryWave => true,
            Verdict::PersistentRub => {
                self.quasi_static || self.growth_rate_per_s <= threshold_per_s
            }
        }
    }
}

/// The coupled waves at one speed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StabilityAtSpeed {
    /// Rotation speed Ω (rad/s).
    pub omega_rad_s: f64,
    /// Growth rate (1/s) above which a wave counts as growing (the options' threshold).
    pub growth_threshold_per_s: f64,
    /// Which growing waves count.
    pub verdict: Verdict,
    /// Every coupled wave (each real wave once), largest growth rate first.
    pub waves: Vec<CoupledWave>,
}

impl StabilityAtSpeed {
    /// The wave with the largest growth rate among those the verdict counts.
    pub fn most_unstable(&self) -> Option<&CoupledWave> {
        (self.waves.iter()).find(|w| w.counts_for(self.verdict, self.growth_threshold_per_s))
    }

    /// No counted wave grows faster than the threshold.
    pub fn is_stable(&self) -> bool {
        self.most_unstable()
            .is_none_or(|w| w.growth_rate_per_s <= self.growth_threshold_per_s)
    }

    /// The largest growth rate (1/s) among the counted waves whose dominant casing nodal
    /// diameter is `nd`.
    pub fn max_growth_of(&self, nd: usize) -> Option<f64> {
        (self.waves.iter())
            .filter(|w| w.counts_for(self.verdict, self.growth_threshold_per_s))
            .find(|w| w.nodal_diameter == nd)
            .map(|w| w.growth_rate_per_s)
    }
}

/// Why no prediction was made; every variant names what is wrong.
#[derive(Debug, Error, PartialEq)]
pub enum StabilityError {
    /// An option out of range.
    #[error("stability option `{name}`: {reason}")]
    BadOption {
        /// Name of the option.
        name: &'static str,
        /// Why its value is refused.
        reason: &'static str,
    },
    /// A rotation speed (rad/s) that is negative or not finite: the impeller turns
    /// counter-clockwise about +z, Ω ≥ 0.
    #[error("rotation speed Ω = {0} rad/s must be finite and ≥ 0")]
    BadSpeed(f64),
    /// A speed range that is empty or not finite.
    #[error("speed range [{lo}, {hi}] rad/s with tolerance {tol} rad/s is invalid")]
    BadRange {
        /// Lower end (rad/s).
        lo: f64,
        /// Upper end (rad/s).
        hi: f64,
        /// Tolerance (rad/s).
        tol: f64,
    },
    /// A ROM fails its validation or is the wrong component.
    #[error("{which} ROM: {reason}")]
    Rom {
        /// `"impeller"` or `"casing"`.
        which: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A held row that no impeller contact node has.
    #[error("held row {0} is not a row of the impeller's contact nodes")]
    UnknownRow(usize),
    /// `K(Ω)` of a block is not positive semi-definite (the impeller beyond its prestress range).
    #[error(
        "{which} nodal diameter {k}: K(Ω = {omega} rad/s) is indefinite (eigenvalue {lambda:.4e} (rad/s)²)"
    )]
    Indefinite {
        /// `"impeller"` or `"casing"`.
        which: &'static str,
        /// Nodal diameter of the block.
        k: usize,
        /// Rotation speed (rad/s).
        omega: f64,
        /// The most negative eigenvalue ((rad/s)²).
        lambda: f64,
    },
    /// A dense eigen- or linear solve failed.
    #[error("impeller class ν = {class} at Ω = {omega} rad/s: {reason}")]
    Solve {
        /// Impeller nodal-diameter class.
        class: usize,
        /// Rotation speed (rad/s).
        omega: f64,
        /// What failed.
        reason: String,
    },
}

fn rom_error(which: &'static str) -> impl Fn(RomError) -> StabilityError {
    move |e| StabilityError::Rom {
        which,
        reason: e.to_string(),
    }
}

/// The speed-independent part of the prediction, built once for a scan: the contact geometry
/// and the casing's free modes per harmonic.
pub struct Predictor<'a> {
    impeller: &'a CyclicRom,
    opts: StabilityOptions,
    iface: Interface,
    /// Free modes of casing harmonic k = 0..⌈N_c/2⌉ − 1 (the Nyquist harmonic is left out).
    casing_modes: Vec<BlockModes>,
    n_casing: usize,
}

impl<'a> Predictor<'a> {
    /// Checks the ROMs and options, builds the contact geometry and the casing modes.
    pub fn new(
        impeller: &'a CyclicRom,
        casing: &CyclicRom,
        opts: &StabilityOptions,
    ) -> Result<Self, StabilityError> {
        opts.validate()?;
        impeller.validate().map_err(rom_error("impeller"))?;
        casing.validate().map_err(rom_error("casing"))?;
        for (rom, which, want) in [
            (impeller, "impeller", Component::Impeller),
            (casing, "casing", Component::Casing),
        ] {
            if rom.component != want {
                return Err(StabilityError::Rom {
                    which,
                    reason: format!("is a {:?} model", rom.component),
                });
            }
        }
        let iface = Interface::new(impeller, casing, opts)?;
        let n_casing = casing.n_sectors;
        let casing_modes = (0..n_casing.div_ceil(2))
            .map(|k| {
                let h = &casing.harmonics[k];
                block_modes(h, 0.0, casing.is_real_harmonic(k), casing.damping)
                    .map_err(|e| e.named("casing", k, 0.0))
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            impeller,
            opts: opts.clone(),
            iface,
            casing_modes,
            n_casing,
        })
    }

    /// The coupled waves at speed `omega` (rad/s).
    pub fn at(&self, omega: f64) -> Result<StabilityAtSpeed, StabilityError> {
        let n_b = self.impeller.n_sectors;
        let mut waves = Vec::new();
        for class in 0..=n_b / 2 {
            let sol = self.class_solution(omega, class)?;
            let self_conjugate = class == 0 || 2 * class == n_b;
            for w in sol.waves {
                // A self-conjugate class holds each real wave twice (λ and λ̄), but a real λ
                // (a divergence in the rotating frame) once, with a round-off sign of Im λ.
                if self_conjugate && w.lambda.im < -1e-8 * w.lambda.norm() {
                    continue;
                }
                waves.push(w.describe(omega, class.min(n_b - class)));
            }
        }
        waves.sort_by(|a: &CoupledWave, b| b.growth_rate_per_s.total_cmp(&a.growth_rate_per_s));
        Ok(StabilityAtSpeed {
            omega_rad_s: omega,
            growth_threshold_per_s: self.opts.growth_threshold_per_s,
            verdict: self.opts.verdict,
            waves,
        })
    }

    /// The eigen-solution of impeller class `class` (a residue mod N_b: classes above N_b/2 are
    /// the complex conjugates of those below) at `omega` (rad/s).
    fn class_solution(&self, omega: f64, class: usize) -> Result<ClassSolution, StabilityError> {
        if !(omega.is_finite() && omega >= 0.0) {
            return Err(StabilityError::BadSpeed(omega));
        }
        let n_b = self.impeller.n_sectors;
        let nd = class.min(n_b - class);
        let imp = block_modes(
            &self.impeller.harmonics[nd],
            omega,
            self.impeller.is_real_harmonic(nd),
            self.impeller.damping,
        )
        .map_err(|e| e.named("impeller", nd, omega))?;
        solve_class(self, &imp, class > n_b / 2, omega, class)
    }
}

/// The coupled waves of `impeller` rubbing in `casing` at speed `omega` (rad/s).
pub fn predict(
    impeller: &CyclicRom,
    casing: &CyclicRom,
    omega: f64,
    opts: &StabilityOptions,
) -> Result<StabilityAtSpeed, StabilityError> {
    Predictor::new(impeller, casing, opts)?.at(omega)
}

/// [`predict`] at every speed of `omegas` (rad/s), in parallel (rayon), in the given order; the
/// casing modes are computed once.
pub fn scan(
    impeller: &CyclicRom,
    casing: &CyclicRom,
    omegas: &[f64],
    opts: &StabilityOptions,
) -> Result<Vec<StabilityAtSpeed>, StabilityError> {
    let p = Predictor::new(impeller, casing, opts)?;
    omegas.par_iter().map(|&w| p.at(w)).collect()
}

/// The lowest speed (rad/s) in `[lo, hi]` at which some wave grows, within `tol` (rad/s):
/// a uniform scan of [`StabilityOptions::onset_scan_points`] speeds finds the first growing
/// one, then bisection brackets the change; the smallest speed known to grow is returned.
/// `None` when no scanned speed grows.
pub fn onset_speed(
    impeller: &CyclicRom,
    casing: &CyclicRom,
    lo: f64,
    hi: f64,
    tol: f64,
    opts: &StabilityOptions,
) -> Result<Option<f64>, StabilityError> {
    Predictor::new(impeller, casing, opts)?.onset_speed(lo, hi, tol)
}

impl Predictor<'_> {
    /// See [`onset_speed`].
    pub fn onset_speed(&self, lo: f64, hi: f64, tol: f64) -> Result<Option<f64>, StabilityError> {
        let finite = lo.is_finite() && hi.is_finite() && tol.is_finite();
        if !(finite && lo >= 0.0 && hi > lo && tol > 0.0) {
            return Err(StabilityError::BadRange { lo, hi, tol });
        }
        let n = self.opts.onset_scan_points;
        let grid: Vec<f64> = (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect();
        let stable: Vec<bool> = (grid.par_iter())
            .map(|&w| self.at(w).map(|s| s.is_stable()))
            .collect::<Result<_, _>>()?;
        let Some(first) = stable.iter().position(|s| !s) else {
            return Ok(None);
        };
        if first == 0 {
            return Ok(Some(lo));
        }
        let (mut a, mut b) = (grid[first - 1], grid[first]);
        while b - a > tol {
            let mid = 0.5 * (a + b);
            if self.at(mid)?.is_stable() {
                a = mid;
            } else {
                b = mid;
            }
        }
        Ok(Some(b))
    }
}

/// Angular frequency (rad/s) → Hz.
fn hz(w: f64) -> f64 {
    w / TAU
}
