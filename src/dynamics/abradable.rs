//! Abradable coating: one-dimensional elastoplastic elements with linear isotropic
//! hardening (Legrand, Batailly & Pierre 2012; Batailly & Legrand 2015, §4).
//!
//! # Model
//! The coating is a layer of uniform initial thickness `e_abr` rigidly attached to the
//! casing contact surface. For each axial row `r` of blade-tip contact nodes (row = the
//! node's index along the blade tip, leading edge = 0) the circumference is cut into `η`
//! equal one-dimensional elements, element `i` covering the circumferential coordinate
//! `θ ∈ [2π i/η, 2π (i+1)/η)`. One element spans the whole thickness (paper §4).
//!
//! # Conventions
//! - **Incursion** `δ` (m): depth of the blade node below the *unworn* coating surface,
//!   `δ = e_abr − d` where `d` is the gap to the casing surface itself (DESIGN §3, `d < 0`
//!   is penetration of the casing). See [`CoatingMaterial::incursion_from_gap`].
//! - **Strain** `ε = δ / e_abr`, compression positive, in `[0, 1]` while the node is in
//!   the coating.
//! - **Plastic strain** `ε_p ∈ [0, 1]` (dimensionless) is the element's permanent
//!   shortening divided by `e_abr`. The **wear** (removed depth) is the *length*
//!   `ε_p · e_abr ∈ [0, e_abr]` (m). The paper writes `Δε_p` for this length (it is
//!   compared with `e_abr`); here the stored state is the strain and every wear output
//!   is the length.
//! - **No tension**: when the node's strain is below `ε_p` the tip has left the worn
//!   surface and the element carries no force; unloading inside the coating is elastic.
//!   Consequently the stress is never negative, reversed yielding never happens and the
//!   accumulated plastic strain of isotropic hardening equals `ε_p`.
//! - **Force**: `F = σ · A_r` (N), positive = pushing the blade node away from the
//!   casing (along the casing normal `n` of DESIGN §3) and the casing outwards. `A_r` is
//!   the blade-tip area attributed to the contact node of row `r` (m²): a property of the
//!   blade, independent of `η` (the element only decides *where* wear is stored).
//! - **Which element**: the single element containing the circumferential coordinate of
//!   the contact point. The caller passes the fixed-frame angle of the node's closest point
//!   on the casing surface; to attach elements to the deforming spline (paper Fig. 10) it
//!   may pass `2π u / N` with `u` the spline's circumferential parameter.
//! - Full removal (paper §4.1, hybrid scenario §4.2.2): when a node reaches the casing
//!   itself the caller sets the element fully worn with `CoatingLayer::remove` and
//!   quarantines the node for the step (quarantine bookkeeping is the caller's).

use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;
use thiserror::Error;

/// Invalid coating parameters or queries; every variant names the parameter.
#[derive(Debug, Error, PartialEq)]
pub enum AbradableError {
    /// A material parameter is not a positive finite number.
    #[error("coating parameter `{name}` must be positive and finite (got {value})")]
    NotPositive {
        /// Name of the parameter.
        name: &'static str,
        /// The rejected value (in the parameter's SI unit).
        value: f64,
    },
    /// A layer dimension is zero.
    #[error("coating layer `{name}` must be at least 1 (got {value})")]
    ZeroCount {
        /// Name of the dimension.
        name: &'static str,
        /// The rejected value.
        value: usize,
    },
    /// The number of per-row tip areas differs from the number of rows.
    #[error("`tip_area` has {got} entries but the layer has {rows} rows")]
    AreaCount {
        /// Number of tip areas given.
        got: usize,
        /// Number of rows of the layer.
        rows: usize,
    },
    /// A row index outside the layer.
    #[error("row {row} is out of range (layer has {rows} rows)")]
    RowOutOfRange {
        /// The row asked for.
        row: usize,
        /// Number of rows of the layer.
        rows: usize,
    },
    /// An element index outside the layer.
    #[error("element {element} is out of range (layer has {eta} elements per row)")]
    ElementOutOfRange {
        /// The element asked for.
        element: usize,
        /// Number of elements per row η.
        eta: usize,
    },
    /// A non-finite angle or incursion.
    #[error("`{name}` must be finite (got {value})")]
    NotFinite {
        /// Name of the quantity (`theta` in rad, `incursion` and `plastic shortening` in m).
        name: &'static str,
        /// The rejected value.
        value: f64,
    },
}

/// Mechanical properties of the abradable coating (1D elastoplastic law, linear
/// isotropic hardening).
///
/// Nominal values ([`CoatingMaterial::nominal`]) describe a plasma-sprayed
/// aluminium–silicon/polyester abradable (Metco 601 class) at room temperature; see that
/// function for the justification and its uncertainty.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoatingMaterial {
    /// Young's modulus E (Pa).
    pub young: f64,
    /// Plastic (hardening) modulus K (Pa): slope of yield stress vs plastic strain.
    pub plastic_modulus: f64,
    /// Initial yield stress σ_Y (Pa).
    pub yield_stress: f64,
    /// Initial coating thickness e_abr (m).
    pub thickness: f64,
}

impl Default for CoatingMaterial {
    fn default() -> Self {
        Self::nominal()
    }
}

impl CoatingMaterial {
    /// Nominal aluminium–silicon/polyester abradable (E_n, K_n of paper §5.2).
    ///
    /// The paper takes E_n and K_n from undisclosed empirical data, so these are
    /// engineering estimates of the right order of magnitude, not the paper's numbers:
    /// - `young = 7 GPa`: a porous plasma-sprayed Al–Si matrix with ~40 vol.% polyester
    ///   and porosity has a modulus an order of magnitude below bulk Al–Si (≈ 75 GPa);
    ///   published measurements on Al–Si/polyester and Al–Si/hBN abradables (indentation,
    ///   tensile tests on free-standing coatings) lie in the few-GPa to ~15 GPa range.
    /// - `yield_stress = 20 MPa`: compressive flow stress of soft compressor abradables
    ///   (HR15Y hardness ≈ 60–80) is of order tens of MPa.
    /// - `plastic_modulus = 0.7 GPa` (= E/10): compaction of the porous coating hardens it
    ///   mildly; the paper's sensitivity bounds (×/÷ 10, [`Self::scaled`]) cover the
    ///   uncertainty of both moduli.
    /// - `thickness = 2 mm`: paper §4.2.2 quotes typical thicknesses of 2 or 3 (mm).
    pub fn nominal() -> Self {
        Self {
            young: 7.0e9,
            plastic_modulus: 0.7e9,
            yield_stress: 20.0e6,
            thickness: 2.0e-3,
        }
    }

    /// The same coating with E and K multiplied by `factor` (σ_Y and e_abr unchanged):
    /// `factor = 0.1` and `10` are the lower and upper bounds of paper §5.2.
    pub fn scaled(&self, factor: f64) -> Self {
        Self {
            young: self.young * factor,
            plastic_modulus: self.plastic_modulus * factor,
            ..*self
        }
    }

    /// Checks that every parameter is positive and finite.
    pub fn validate(&self) -> Result<(), AbradableError> {
        for (name, value) in [
            ("young", self.young),
            ("plastic_modulus", self.plastic_modulus),
            ("yield_stress", self.yield_stress),
            ("thickness", self.thickness),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(AbradableError::NotPositive { name, value });
            }
        }
        Ok(())
    }

    /// Elastoplastic tangent modulus `E K / (E + K)` (Pa): slope of stress vs total strain
    /// during plastic loading.
    pub fn tangent_modulus(&self) -> f64 {
        self.young * self.plastic_modulus / (self.young + self.plastic_modulus)
    }

    /// Incursion `δ = e_abr − d` (m) below the unworn coating surface of a node whose gap
    /// to the casing surface is `gap` (m, negative = penetration of the casing).
    pub fn incursion_from_gap(&self, gap: f64) -> f64 {
        self.thickness - gap
    }

    /// Return mapping of one element (Simo & Hughes, 1D linear isotropic hardening).
    ///
    /// Given the committed plastic strain `eps_p` and the total strain `eps`
    /// (= incursion / e_abr, clamped to `[0, 1]` by the caller), returns
    /// `(stress in Pa, new plastic strain)`. Elastic predictor `σ* = E (ε − ε_p)`; no
    /// tension (`σ* ≤ 0` → no force, state unchanged); yield check
    /// `f = σ* − (σ_Y + K ε_p)`; plastic corrector `Δε_p = f / (E + K)`,
    /// `σ = σ* − E Δε_p`.
    pub(crate) fn return_map(&self, eps_p: f64, eps: f64) -> (f64, f64) {
        let sigma_trial = self.young * (eps - eps_p);
        if sigma_trial <= 0.0 {
            return (0.0, eps_p);
        }
        let f = sigma_trial - (self.yield_stress + self.plastic_modulus * eps_p);
        if f <= 0.0 {
            return (sigma_trial, eps_p);
        }
        let d_eps_p = f / (self.young + self.plastic_modulus);
        (sigma_trial - self.young * d_eps_p, eps_p + d_eps_p)
    }
}

/// Outcome of a trial evaluation: the element's state if the step is accepted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ElementUpdate {
    /// Row of blade-tip nodes.
    pub row: usize,
    /// Element index in `0..η`.
    pub element: usize,
    /// Plastic strain after the step (dimensionless, `[0, 1]`).
    pub plastic_strain: f64,
    /// The incursion reached or passed the casing surface (`δ ≥ e_abr`): the caller should
    /// [`CoatingLayer::remove`] the element, quarantine the node and let the Lagrange
    /// multipliers act (paper §4.1). The returned force is then that of a fully crushed
    /// element and should not be applied.
    pub reaches_casing: bool,
}

/// One element's law as the contact solve of a massless boundary reads it: the element is a
/// spring in series with the boundary's static flexibility, so its force is solved with the
/// tip displacement instead of being evaluated on the predicted one (see
/// `contact_solve::coated_solve`). With `p` the tip's depth below the worn surface (m) and `Δp`
/// the plastic shortening of the step (m), the element carries `λ = k (p − Δp) ≥ 0` and yields
/// when `λ = λ_Y + K' Δp` ([`CoatingMaterial::return_map`] in forces and lengths).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CoatingLaw {
    /// Gap to the casing (m) at which the tip meets the worn surface: `e_abr (1 − ε_p)`.
    pub remaining: f64,
    /// Elastic stiffness `k = E A / e_abr` (N/m).
    pub stiffness: f64,
    /// Force at which the element yields, `λ_Y = A (σ_Y + K ε_p)` (N).
    pub yield_force: f64,
    /// Hardening stiffness `K' = K A / e_abr` (N/m): the yield force per metre of plastic
    /// shortening.
    pub hardening: f64,
}

/// State of the whole coating: `n_rows × η` elements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct CoatingLayer {
    material: CoatingMaterial,
    eta: usize,
    n_rows: usize,
    /// Blade-tip area attributed to the contact node of each row (m²).
    tip_area: Vec<f64>,
    /// Committed plastic strain, row-major `[row * eta + element]`.
    plastic_strain: Vec<f64>,
}

impl CoatingLayer {
    /// Default number of elements per row (paper §4.2.1 convergence study).
    pub(crate) const DEFAULT_ETA: usize = 6000;

    /// A virgin coating with `eta` elements per row and the blade-tip area `tip_area[r]`
    /// (m²) attributed to the contact node of row `r` (`tip_area.len()` rows).
    pub fn new(
        material: CoatingMaterial,
        eta: usize,
        tip_area: Vec<f64>,
    ) -> Result<Self, AbradableError> {
        material.validate()?;
        if eta == 0 {
            return Err(AbradableError::ZeroCount {
                name: "eta",
                value: eta,
            });
        }
        if tip_area.is_empty() {
            return Err(AbradableError::ZeroCount {
                name: "tip_area (rows)",
                value: 0,
            });
        }
        for &a in &tip_area {
            if !(a.is_finite() && a > 0.0) {
                return Err(AbradableError::NotPositive {
                    name: "tip_area",
                    value: a,
                });
            }
        }
        let n_rows = tip_area.len();
        Ok(Self {
            material,
            eta,
            n_rows,
            tip_area,
            plastic_strain: vec![0.0; n_rows * eta],
        })
    }

    /// The coating material.
    pub fn material(&self) -> &CoatingMaterial {
        &self.material
    }

    /// Number of rows.
    pub fn n_rows(&self) -> usize {
        self.n_rows
    }

    /// Blade-tip area attributed to each row (m²).
    pub fn tip_area(&self) -> &[f64] {
        &self.tip_area
    }

    /// Index of the element containing the circumferential coordinate `theta` (rad, any
    /// real value; wrapped to `[0, 2π)`): `floor(θ η / 2π)`.
    pub(crate) fn element_index(&self, theta: f64) -> Result<usize, AbradableError> {
        if !theta.is_finite() {
            return Err(AbradableError::NotFinite {
                name: "theta",
                value: theta,
            });
        }
        let wrapped = theta.rem_euclid(TAU);
        // rem_euclid may round up to exactly 2π for tiny negative angles.
        let i = (wrapped / TAU * self.eta as f64).floor() as usize;
        Ok(if i >= self.eta { 0 } else { i })
    }

    fn check_row(&self, row: usize) -> Result<(), AbradableError> {
        if row >= self.n_rows {
            return Err(AbradableError::RowOutOfRange {
                row,
                rows: self.n_rows,
            });
        }
        Ok(())
    }

    /// The angles (rad) of the centres of the elements strictly between those under `from` and
    /// `to` (rad), the shorter way round, in the order a tip going from `from` to `to` passes
    /// them: the elements a tip jumps over in a step that moves it more than an element.
    pub(crate) fn centres_between(
        &self,
        from: f64,
        to: f64,
    ) -> Result<impl Iterator<Item = f64> + use<>, AbradableError> {
        let (i0, i1) = (self.element_index(from)?, self.element_index(to)?);
        let eta = self.eta as isize;
        // Signed element count from i0 to i1 in (−η/2, η/2].
        let mut diff = (i1 as isize - i0 as isize).rem_euclid(eta);
        if diff > eta / 2 {
            diff -= eta;
        }
        let width = TAU / self.eta as f64;
        Ok((1..diff.abs()).map(move |k| {
            let e = (i0 as isize + diff.signum() * k).rem_euclid(eta);
            (e as f64 + 0.5) * width
        }))
    }

    /// Committed plastic strain of element `element` of row `row`.
    pub(crate) fn plastic_strain(&self, row: usize, element: usize) -> Result<f64, AbradableError> {
        self.check_row(row)?;
        if element >= self.eta {
            return Err(AbradableError::ElementOutOfRange {
                element,
                eta: self.eta,
            });
        }
        Ok(self.plastic_strain[row * self.eta + element])
    }

    /// Remaining coating thickness `e_abr (1 − ε_p)` (m) under angle `theta` in row `row`.
    /// The gap of a node to the worn coating surface is `d − remaining_thickness` (paper
    /// §4.1, `d^{*,abr}`).
    pub(crate) fn remaining_thickness(
        &self,
        row: usize,
        theta: f64,
    ) -> Result<f64, AbradableError> {
        self.check_row(row)?;
        let e = self.element_index(theta)?;
        Ok(self.material.thickness * (1.0 - self.plastic_strain[row * self.eta + e]))
    }

    /// Trial evaluation for a blade node of row `row` whose contact point is at angle
    /// `theta` (rad) with incursion `incursion` (m, below the unworn surface): returns the
    /// force on the node (N, ≥ 0, along the casing normal) and the element's state if the
    /// step is accepted. Does not modify the layer; call [`Self::commit`] once the step is
    /// accepted. A node outside the coating (`incursion ≤ 0`) gives zero force and an
    /// unchanged state.
    pub fn trial(
        &self,
        row: usize,
        theta: f64,
        incursion: f64,
    ) -> Result<(f64, ElementUpdate), AbradableError> {
        self.check_row(row)?;
        if !incursion.is_finite() {
            return Err(AbradableError::NotFinite {
                name: "incursion",
                value: incursion,
            });
        }
        let element = self.element_index(theta)?;
        let eps_p = self.plastic_strain[row * self.eta + element];
        let eps = (incursion / self.material.thickness).clamp(0.0, 1.0);
        let (sigma, new_eps_p) = self.material.return_map(eps_p, eps);
        let update = ElementUpdate {
            row,
            element,
            plastic_strain: new_eps_p,
            reaches_casing: incursion >= self.material.thickness,
        };
        Ok((sigma * self.tip_area[row], update))
    }

    /// The element under angle `theta` (rad) in row `row` and its law for the implicit solve.
    pub(crate) fn law(
        &self,
        row: usize,
        theta: f64,
    ) -> Result<(usize, CoatingLaw), AbradableError> {
        self.check_row(row)?;
        let element = self.element_index(theta)?;
        let m = &self.material;
        let (area, eps_p) = (
            self.tip_area[row],
            self.plastic_strain[row * self.eta + element],
        );
        let law = CoatingLaw {
            remaining: m.thickness * (1.0 - eps_p),
            stiffness: m.young * area / m.thickness,
            yield_force: area * (m.yield_stress + m.plastic_modulus * eps_p),
            hardening: m.plastic_modulus * area / m.thickness,
        };
        Ok((element, law))
    }

    /// The update of element `element` of row `row` after a plastic shortening `plastic` (m,
    /// ≥ 0) found by the implicit solve; `reaches_casing` is false (a tip that reaches the
    /// casing is removed by the caller instead).
    pub(crate) fn plastic_update(
        &self,
        row: usize,
        element: usize,
        plastic: f64,
    ) -> Result<ElementUpdate, AbradableError> {
        let eps_p = self.plastic_strain(row, element)?;
        if !plastic.is_finite() {
            return Err(AbradableError::NotFinite {
                name: "plastic shortening",
                value: plastic,
            });
        }
        Ok(ElementUpdate {
            row,
            element,
            plastic_strain: (eps_p + plastic.max(0.0) / self.material.thickness).min(1.0),
            reaches_casing: false,
        })
    }

    /// Commits an accepted update. Plastic strain never decreases, so the element keeps
    /// the larger of its committed and updated values: committing several updates of the
    /// same element in one step gives the same result in any order.
    pub fn commit(&mut self, update: &ElementUpdate) -> Result<(), AbradableError> {
        self.check_row(update.row)?;
        if update.element >= self.eta {
            return Err(AbradableError::ElementOutOfRange {
                element: update.element,
                eta: self.eta,
            });
        }
        let slot = &mut self.plastic_strain[update.row * self.eta + update.element];
        *slot = slot.max(update.plastic_strain.clamp(0.0, 1.0));
        Ok(())
    }

    /// Full local removal (paper §4.1): sets the element's wear to `e_abr` (ε_p = 1).
    pub fn remove(&mut self, row: usize, element: usize) -> Result<(), AbradableError> {
        self.check_row(row)?;
        if element >= self.eta {
            return Err(AbradableError::ElementOutOfRange {
                element,
                eta: self.eta,
            });
        }
        self.plastic_strain[row * self.eta + element] = 1.0;
        Ok(())
    }

    /// Wear profile of row `row` (m, removed depth `ε_p e_abr ∈ [0, e_abr]`), element `i`
    /// centred at angle `2π (i + ½)/η`.
    pub(crate) fn wear_profile(&self, row: usize) -> Result<Vec<f64>, AbradableError> {
        self.check_row(row)?;
        let e = self.material.thickness;
        Ok(self.plastic_strain[row * self.eta..(row + 1) * self.eta]
            .iter()
            .map(|&p| p * e)
            .collect())
    }

    /// Largest wear over the whole layer (m).
    pub fn max_wear(&self) -> f64 {
        self.plastic_strain.iter().fold(0.0_f64, |m, &p| m.max(p)) * self.material.thickness
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn mat() -> CoatingMaterial {
        CoatingMaterial {
            young: 5.0e9,
            plastic_modulus: 1.0e9,
            yield_stress: 10.0e6,
            thickness: 2.0e-3,
        }
    }

    #[test]
    fn validate_names_field() {
        let mut m = mat();
        m.plastic_modulus = -1.0;
        assert_eq!(
            m.validate(),
            Err(AbradableError::NotPositive {
                name: "plastic_modulus",
                value: -1.0
            })
        );
        m = mat();
        m.thickness = f64::NAN;
        assert!(matches!(
            m.validate(),
            Err(AbradableError::NotPositive {
                name: "thickness",
                ..
            })
        ));
        assert!(CoatingMaterial::nominal().validate().is_ok());
        assert!(CoatingLayer::new(mat(), 0, vec![1e-6]).is_err());
        assert!(CoatingLayer::new(mat(), 10, vec![]).is_err());
        assert!(CoatingLayer::new(mat(), 10, vec![0.0]).is_err());
    }

    #[test]
    fn serde_roundtrip_and_unknown_field() {
        let m = CoatingMaterial::nominal();
        let s = serde_json::to_string(&m).unwrap();
        let back: CoatingMaterial = serde_json::from_str(&s).unwrap();
        assert_eq!(m, back);
        let bad = r#"{"young":1,"plastic_modulus":1,"yield_stress":1,"thickness":1,"x":2}"#;
        assert!(serde_json::from_str::<CoatingMaterial>(bad).is_err());
    }

    /// Load–unload–reload cycle against the closed-form 1D elastoplastic answer.
    #[test]
    fn single_element_cycle_matches_analytic() {
        let m = mat();
        let area = 3.0e-6;
        let mut layer = CoatingLayer::new(m, 100, vec![area]).unwrap();
        let (e, k, sy, t) = (m.young, m.plastic_modulus, m.yield_stress, m.thickness);
        let eps_y = sy / e;
        let theta = 0.123;
        // Monotonic loading in small committed increments up to eps_max.
        let eps_max = 10.0 * eps_y;
        let n = 400;
        for i in 1..=n {
            let eps = eps_max * i as f64 / n as f64;
            let (f, up) = layer.trial(0, theta, eps * t).unwrap();
            let sigma_exact = if eps <= eps_y {
                e * eps
            } else {
                sy + (eps - eps_y) * e * k / (e + k)
            };
            assert_relative_eq!(f, sigma_exact * area, max_relative = 1e-12);
            layer.commit(&up).unwrap();
        }
        // Plastic strain at eps_max: (σ − σ_Y)/K.
        let sigma_max = sy + (eps_max - eps_y) * m.tangent_modulus();
        let eps_p = (sigma_max - sy) / k;
        let el = layer.element_index(theta).unwrap();
        assert_relative_eq!(
            layer.plastic_strain(0, el).unwrap(),
            eps_p,
            max_relative = 1e-12
        );
        let eps_p_committed = layer.plastic_strain(0, el).unwrap();
        // Elastic unloading with slope E; zero force at the residual shortening.
        let eps_half = 0.5 * (eps_max + eps_p);
        let (f, up) = layer.trial(0, theta, eps_half * t).unwrap();
        assert_relative_eq!(f, e * (eps_half - eps_p) * area, max_relative = 1e-12);
        assert_eq!(up.plastic_strain, eps_p_committed, "unloading is elastic");
        let (f, _) = layer.trial(0, theta, 0.999 * eps_p * t).unwrap();
        assert_eq!(f, 0.0, "no tension below the worn surface");
        // Residual shortening (wear length) = ε_p e_abr.
        assert_relative_eq!(
            layer.wear_profile(0).unwrap()[el],
            eps_p * t,
            max_relative = 1e-12
        );
        // Reloading is elastic up to the hardened yield stress σ_Y + K ε_p = σ_max.
        let eps_re = eps_p + 0.99 * sigma_max / e;
        let (f, up) = layer.trial(0, theta, eps_re * t).unwrap();
        assert_relative_eq!(f, e * (eps_re - eps_p) * area, max_relative = 1e-12);
        assert_eq!(up.plastic_strain, eps_p_committed, "reloading is elastic");
        // ... and plastic with slope EK/(E+K) beyond.
        let eps_beyond = eps_max + 2.0 * eps_y;
        let (f, _) = layer.trial(0, theta, eps_beyond * t).unwrap();
        assert_relative_eq!(
            f,
            (sigma_max + 2.0 * eps_y * m.tangent_modulus()) * area,
            max_relative = 1e-12
        );
    }

    #[test]
    fn single_large_step_equals_incremental() {
        // Linear hardening with proportional loading: return mapping is path-independent.
        let m = mat();
        let eps = 0.05;
        let (s1, p1) = m.return_map(0.0, eps);
        let mut p = 0.0;
        let mut s = 0.0;
        for i in 1..=1000 {
            (s, p) = m.return_map(p, eps * i as f64 / 1000.0);
        }
        assert_relative_eq!(s1, s, max_relative = 1e-12);
        assert_relative_eq!(p1, p, max_relative = 1e-12);
    }

    #[test]
    fn no_tension_and_outside() {
        let layer = CoatingLayer::new(mat(), 10, vec![1e-6]).unwrap();
        let (f, up) = layer.trial(0, 1.0, -1e-4).unwrap();
        assert_eq!(f, 0.0);
        assert_eq!(up.plastic_strain, 0.0);
        assert!(!up.reaches_casing);
    }

    #[test]
    fn peak_force_monotone_in_scale() {
        // Same prescribed incursion history (load to 30% of the thickness): a stiffer
        // coating (E, K scaled up) gives a larger peak force.
        let base = mat();
        let mut peaks = Vec::new();
        for s in [0.1, 1.0, 10.0] {
            let mut layer = CoatingLayer::new(base.scaled(s), 50, vec![1e-6]).unwrap();
            let mut peak = 0.0_f64;
            for i in 0..=300 {
                let x = 0.3 * base.thickness * (i as f64 / 300.0);
                let (f, up) = layer.trial(0, 0.0, x).unwrap();
                layer.commit(&up).unwrap();
                peak = peak.max(f);
            }
            peaks.push(peak);
        }
        assert!(peaks[0] < peaks[1] && peaks[1] < peaks[2], "{peaks:?}");
        assert_eq!(base.scaled(10.0).yield_stress, base.yield_stress);
    }

    #[test]
    fn wear_bounded_and_removal() {
        let m = mat();
        let mut layer = CoatingLayer::new(m, 20, vec![1e-6, 2e-6]).unwrap();
        // Incursion beyond the casing: strain clamped, flagged, wear ≤ e_abr.
        let (_, up) = layer.trial(1, 0.5, 3.0 * m.thickness).unwrap();
        assert!(up.reaches_casing);
        layer.commit(&up).unwrap();
        assert!(layer.max_wear() <= m.thickness);
        for w in layer.wear_profile(1).unwrap() {
            assert!((0.0..=m.thickness).contains(&w));
        }
        layer.remove(1, up.element).unwrap();
        assert_eq!(layer.wear_profile(1).unwrap()[up.element], m.thickness);
        assert_eq!(layer.remaining_thickness(1, 0.5).unwrap(), 0.0);
        // A fully removed element carries no force for any incursion inside the layer.
        let (f, _) = layer.trial(1, 0.5, 0.9 * m.thickness).unwrap();
        assert_eq!(f, 0.0);
        // Other row untouched.
        assert_eq!(layer.wear_profile(0).unwrap().iter().sum::<f64>(), 0.0);
        assert!(layer.remove(2, 0).is_err());
        assert!(layer.remove(0, 20).is_err());
    }

    #[test]
    fn commit_order_independent() {
        let m = mat();
        let mut a = CoatingLayer::new(m, 8, vec![1e-6]).unwrap();
        let mut b = a.clone();
        let (_, u1) = a.trial(0, 0.1, 0.2 * m.thickness).unwrap();
        let (_, u2) = a.trial(0, 0.1, 0.4 * m.thickness).unwrap();
        a.commit(&u1).unwrap();
        a.commit(&u2).unwrap();
        b.commit(&u2).unwrap();
        b.commit(&u1).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn element_indexing_wraps() {
        let layer = CoatingLayer::new(mat(), 6000, vec![1e-6]).unwrap();
        let w = TAU / 6000.0;
        assert_eq!(layer.element_index(0.0).unwrap(), 0);
        assert_eq!(layer.element_index(0.5 * w).unwrap(), 0);
        assert_eq!(layer.element_index(1.5 * w).unwrap(), 1);
        assert_eq!(layer.element_index(TAU - 0.5 * w).unwrap(), 5999);
        assert_eq!(layer.element_index(TAU).unwrap(), 0);
        assert_eq!(layer.element_index(-0.5 * w).unwrap(), 5999);
        assert_eq!(layer.element_index(-1e-18).unwrap(), 0);
        assert_eq!(layer.element_index(3.0 * TAU + 2.5 * w).unwrap(), 2);
        assert!(layer.element_index(f64::INFINITY).is_err());
        // Every element centre maps to its own index.
        for i in 0..6000 {
            assert_eq!(layer.element_index((i as f64 + 0.5) * w).unwrap(), i);
        }
    }

    #[test]
    fn centres_between_are_the_jumped_elements_in_order() {
        let layer = CoatingLayer::new(mat(), 100, vec![1e-6]).unwrap();
        let w = TAU / 100.0;
        let between = |a: f64, b: f64| -> Vec<usize> {
            (layer.centres_between(a * w, b * w).unwrap())
                .map(|t| layer.element_index(t).unwrap())
                .collect()
        };
        assert_eq!(between(10.9, 12.1), vec![11]);
        assert_eq!(between(10.1, 11.3), Vec::<usize>::new());
        assert_eq!(between(10.5, 10.6), Vec::<usize>::new());
        assert_eq!(between(12.1, 9.9), vec![11, 10]);
        // Across the seam, both ways.
        assert_eq!(between(98.5, 101.5), vec![99, 0]);
        assert_eq!(between(1.5, -1.5), vec![0, 99]);
        // Every centre lies inside its own element.
        for t in layer.centres_between(0.2 * w, 5.7 * w).unwrap() {
            let e = layer.element_index(t).unwrap() as f64;
            assert!((t / w - e - 0.5).abs() < 1e-9);
        }
    }

    #[test]
    fn incursion_and_gap_convention() {
        let m = mat();
        let mut layer = CoatingLayer::new(m, 4, vec![1e-6]).unwrap();
        // Gap to the casing equal to the thickness: just touching the unworn surface.
        assert_eq!(m.incursion_from_gap(m.thickness), 0.0);
        let (_, up) = layer.trial(0, 0.0, m.incursion_from_gap(0.0)).unwrap();
        assert!(up.reaches_casing);
        layer.commit(&up).unwrap();
        // Remaining thickness = e_abr − wear.
        let wear = layer.wear_profile(0).unwrap()[0];
        assert_relative_eq!(
            layer.remaining_thickness(0, 0.0).unwrap(),
            m.thickness - wear,
            max_relative = 1e-12
        );
    }
}
