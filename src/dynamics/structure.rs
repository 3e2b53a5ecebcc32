//! A cyclic ROM frozen at one rotation speed Ω: per-nodal-diameter real-form matrices,
//! mass-normalized eigenpairs, damping, the explicit stability limit, and the assembled
//! physical ROM used by the dense reference kernel.
//!
//! # Harmonic coordinates
//! For nodal diameter `k` the real-form vector is `x_k = [a (n); b (n)]` (only `a` for
//! `k = 0` and `k = N/2`), `n = 3 n_c + n_m`, in the convention of `model::rom`: each part
//! is `[boundary DOFs (3 n_c); modal coordinates (n_m)]`. The boundary parts are the
//! orthonormal real DFT over sectors of the physical boundary DOFs (ARCH brief):
//! `a_k = w_k Σ_s cos(kθ_s) u_s`, `b_k = w_k Σ_s sin(kθ_s) u_s`, `w_k = N^{-1/2}` for the real
//! harmonics and `(2/N)^{1/2}` otherwise. The map physical → harmonic is therefore orthogonal,
//! and `M_phys = Pᵀ blockdiag(M_k) P` (same for K, D).
//!
//! # Damping
//! Both kernels use the same damping matrix, chosen so that the eigenvectors of `(K(Ω), M)`
//! diagonalise it (the fast kernel relies on it): modal damping `c_p = 2 ζ ω_p`;
//! Rayleigh `c_p = α + β ω_p²`, i.e. `D = α M + β K(Ω)`. For the impeller at Ω ≠ 0 this
//! differs from the ROM's literal `α M + β K0` by `β Ω² K1 (+ β Ω⁴ K2)` — a deliberate,
//! documented choice that keeps the damping modal.
//!
//! # Stability
//! Central differences with the centred damping term `D/2h` have the characteristic
//! polynomial `(1 + c h/2) z² − (2 − ω² h²) z + (1 − c h/2)` per mode; its roots lie in the
//! unit disc iff `ω h < 2`, whatever `c ≥ 0`. Hence `h_crit = 2/ω_max` exactly, with or without
//! damping; `h ≥ h_crit` is refused.
//!
//! # Massless boundary
//! [`Structure::with_boundary`]`(`[`Boundary::Massless`]`)` applies MacNeal's residual-flexibility
//! idea to the Craig–Bampton ROM itself (Monjaraz-Tec, Gross & Krack 2022, arXiv 2111.07693):
//! per nodal diameter and per part the `n_m` lowest eigenmodes of `(K(Ω), M)` stay dynamic and
//! the `3 n_c` highest — the boundary-dominated ones that set the stability limit — become
//! quasi-static, `η_p = φ_pᵀ f / ω_p²`. The boundary then carries no inertia: its
//! displacement is `u_b = Φ_b,d η_d + R f` with the residual flexibility
//! `R = Σ_static φ_b φ_bᵀ/ω² = [K⁻¹ − Φ_d Λ_d⁻¹ Φ_dᵀ]_bb`, exact in statics, and the
//! stability limit is `2/ω_max` of the dynamic modes only.
//!
//! Central differences reach that formulation without a second code path
//! ([`Structure::discretized`]): a static mode scaled by `α = √2/(ω h)` with frequency
//! `ω̃ = √2/h` and damping `c̃ = 2/h` has `c₁ = c₂ = 0` in the three-term recurrence, so
//! `η_{n+1} = φ_pᵀ f/ω_p²` every step with no memory, and `A⁻¹` holds `R` exactly. In physical
//! terms the static modes' mass becomes `ω²h²/2` of theirs and their damping `ω² h`; the
//! stiffness is unchanged. Both kernels take that structure as it is.

use crate::dynamics::numerics::{Boundary, Numerics};
use crate::model::eigen::{EigenError, symmetric_gen_eigen};
use crate::model::rom::{CyclicRom, Damping, RomError};
use nalgebra::DMatrix;
use std::borrow::Cow;
use thiserror::Error;

/// Errors when freezing a ROM at a rotation speed.
#[derive(Debug, Error, PartialEq)]
pub enum StructureError {
    /// The ROM fails its own validation.
    #[error("ROM `{name}` is invalid: {source}")]
    Rom {
        /// Name of the ROM.
        name: String,
        /// What is wrong with it.
        source: RomError,
    },
    /// The generalized eigenproblem of one nodal diameter could not be solved.
    #[error("ROM `{name}`, nodal diameter {k}: eigen-decomposition failed ({source})")]
    Eigen {
        /// Name of the ROM.
        name: String,
        /// Nodal diameter.
        k: usize,
        /// The eigensolver's error.
        source: EigenError,
    },
    /// `K(Ω) = K0 + Ω² K1 + Ω⁴ K2` has a negative eigenvalue: Ω is outside the range where
    /// the linearised prestress model is valid.
    #[error(
        "ROM `{name}`, nodal diameter {k}: K(Ω = {omega} rad/s) is not positive semi-definite (eigenvalue {lambda:.4e} (rad/s)²)"
    )]
    Indefinite {
        /// Name of the ROM.
        name: String,
        /// Nodal diameter.
        k: usize,
        /// Rotation speed Ω (rad/s).
        omega: f64,
        /// The most negative eigenvalue ω² ((rad/s)²).
        lambda: f64,
    },
    /// The rotation speed (rad/s) is NaN or infinite.
    #[error("rotation speed Ω = {0} rad/s must be finite")]
    BadOmega(f64),
}

/// One nodal diameter of a [`Structure`].
#[derive(Clone, Debug)]
pub struct NdBlock {
    /// Nodal diameter k.
    pub k: usize,
    /// True for k = 0 and k = N/2 (only the `a` part exists).
    pub real: bool,
    /// Size of one part, `3 n_c + n_m`.
    pub n: usize,
    /// Number of fixed-interface modal coordinates `n_m`.
    pub n_modes: usize,
    /// Real-form order, `n` or `2n`.
    pub dim: usize,
    /// Real-form mass matrix (kg), `dim × dim`.
    pub mass: DMatrix<f64>,
    /// Real-form stiffness matrix K(Ω) = K0 + Ω² K1 + Ω⁴ K2 (N/m), `dim × dim`.
    pub stiffness: DMatrix<f64>,
    /// Real-form damping matrix (N·s/m), `dim × dim`, diagonalised by [`NdBlock::modes`]
    /// (see the module doc, "Damping").
    pub damping: DMatrix<f64>,

    /// Mass-normalized eigenvectors (columns, `Φᵀ M Φ = I`), sorted by ascending frequency.
    pub modes: DMatrix<f64>,
    /// Natural circular frequencies ω_p (rad/s), ascending (in [`Structure::discretized`]
    /// the static modes come last with `ω̃ = √2/h`).
    pub omega: Vec<f64>,
    /// Modal damping coefficients `c_p` (1/s): the mode obeys `η̈ + c_p η̇ + ω_p² η = φ_pᵀ f`.
    pub damping_coef: Vec<f64>,
    /// Offset of this block in the flat modal-coordinate vector of the structure.
    pub offset: usize,
    /// Quasi-static modes per part (the highest ones; see "Massless boundary" in the module
    /// doc): 0 in the paper's formulation, `3 n_c` with a massless boundary.
    pub n_static: usize,
}

impl NdBlock {
    /// Number of parts of the real form: 1 (real harmonic) or 2.
    fn parts(&self) -> usize {
        if self.real { 1 } else { 2 }
    }

    /// Real-form index of the first static mode (the dynamic modes come first).
    pub fn first_static(&self) -> usize {
        self.dim - self.parts() * self.n_static
    }
}

/// A cyclic ROM at one rotation speed, ready for time integration.
#[derive(Clone, Debug)]
pub struct Structure {
    /// Name of the ROM.
    pub name: String,
    /// Number of sectors N.
    pub n_sectors: usize,
    /// Boundary DOFs per sector, `3 n_c`.
    pub n_boundary: usize,
    /// Rotation speed Ω (rad/s) at which K(Ω) was evaluated (0 for a casing).
    pub omega_rot: f64,
    /// Per nodal diameter, k = 0..=N/2.
    pub blocks: Vec<NdBlock>,
    /// Total number of modal coordinates (= number of DOFs of the assembled physical ROM).
    pub n_modal: usize,
    /// Largest natural circular frequency (rad/s).
    pub omega_max: f64,
}

impl Structure {
    /// Freezes `rom` at rotation speed `omega` (rad/s): K(Ω), damping, per-ND eigenpairs.
    pub fn new(rom: &CyclicRom, omega: f64) -> Result<Self, StructureError> {
        if !omega.is_finite() {
            return Err(StructureError::BadOmega(omega));
        }
        rom.validate().map_err(|source| StructureError::Rom {
            name: rom.name.clone(),
            source,
        })?;
        let nb = rom.n_boundary();
        let mut blocks = Vec::with_capacity(rom.harmonics.len());
        let mut offset = 0;
        let mut omega_max: f64 = 0.0;
        for h in &rom.harmonics {
            let k = h.nodal_diameter;
            let real = rom.is_real_harmonic(k);
            let n = nb + h.n_modes;
            let dim = if real { n } else { 2 * n };
            let mass = h.mass.real_form(real);
            let stiffness = h.stiffness_at(omega).real_form(real);
            let (lambdas, modes) =
                symmetric_gen_eigen(&stiffness, &mass).map_err(|source| StructureError::Eigen {
                    name: rom.name.clone(),
                    k,
                    source,
                })?;
            let lmax = lambdas.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
            let mut om = Vec::with_capacity(dim);
            for &l in &lambdas {
                if l < -1e-9 * lmax.max(1.0) {
                    return Err(StructureError::Indefinite {
                        name: rom.name.clone(),
                        k,
                        omega,
                        lambda: l,
                    });
                }
                om.push(l.max(0.0).sqrt());
            }
            let damping_coef: Vec<f64> = om
                .iter()
                .map(|&w| match rom.damping {
                    Damping::Modal { ratio } => 2.0 * ratio * w,
                    Damping::Rayleigh { alpha, beta } => alpha + beta * w * w,
                })
                .collect();
            // D = M Φ diag(c) Φᵀ M, so that Φᵀ D Φ = diag(c).
            let mphi = &mass * &modes;
            let mut scaled = mphi.clone();
            for (j, c) in damping_coef.iter().enumerate() {
                scaled.column_mut(j).scale_mut(*c);
            }
            let damping = &scaled * mphi.transpose();
            omega_max = omega_max.max(om.iter().cloned().fold(0.0, f64::max));
            blocks.push(NdBlock {
                k,
                real,
                n,
                n_modes: h.n_modes,
                dim,
                mass,
                stiffness,
                damping,
                modes,
                omega: om,
                damping_coef,
                offset,
                n_static: 0,
            });
            offset += dim;
        }
        Ok(Self {
            name: rom.name.clone(),
            n_sectors: rom.n_sectors,
            n_boundary: nb,
            omega_rot: omega,
            blocks,
            n_modal: offset,
            omega_max,
        })
    }

    /// The structure with the boundary model `boundary`: unchanged for [`Boundary::Mass`]; for
    /// [`Boundary::Massless`] the `3 n_c` highest modes per part of each nodal diameter become
    /// static and `ω_max` (hence the stability limit) is that of the dynamic modes.
    pub fn with_boundary(mut self, boundary: Boundary) -> Self {
        if boundary == Boundary::Massless {
            for b in &mut self.blocks {
                b.n_static = b.n - b.n_modes;
            }
            self.omega_max = self.dynamic_omega_max();
        }
        self
    }

    /// The structure the numerics `n` integrate: its boundary model, then its mode cutoff.
    pub fn with_numerics(self, n: &Numerics) -> Self {
        self.with_boundary(n.boundary)
            .with_mode_cutoff(n.mode_cutoff_hz)
    }

    /// With a massless boundary, also the modes above `cutoff_hz` (Hz) static in every nodal
    /// diameter (both parts of a pair alike), and `ω_max` that of the modes left dynamic.
    /// `None`, or the paper's formulation, leaves the structure as it is.
    pub fn with_mode_cutoff(mut self, cutoff_hz: Option<f64>) -> Self {
        let Some(cut) = cutoff_hz.map(|f| 2.0 * std::f64::consts::PI * f) else {
            return self;
        };
        if !self.has_static_modes() {
            return self;
        }
        for b in &mut self.blocks {
            let above = b.omega[..b.first_static()].iter().filter(|&&w| w > cut);
            let pairs = above.count().div_ceil(b.parts());
            b.n_static = (b.n_static + pairs).min(b.n);
        }
        self.omega_max = self.dynamic_omega_max();
        self
    }

    /// Highest circular frequency of the dynamic modes (rad/s).
    fn dynamic_omega_max(&self) -> f64 {
        (self.blocks.iter())
            .flat_map(|b| b.omega[..b.first_static()].iter().copied())
            .fold(0.0, f64::max)
    }

    /// Whether some modes are static (a massless boundary).
    pub fn has_static_modes(&self) -> bool {
        self.blocks.iter().any(|b| b.n_static > 0)
    }

    /// The structure central differences with step `h` (s) integrate: itself in the paper's
    /// formulation; with a massless boundary, each static mode `p` scaled by
    /// `α = √2/(ω_p h)` with `ω̃ = √2/h`, `c̃ = 2/h`, the mass and damping changed to match
    /// (`M' = M − Σ_s (1 − ω²h²/2) M φ φᵀ M`, `D' = D + Σ_s (ω² h − c) M φ φᵀ M`), so that
    /// the modes stay `M'`-orthonormal and diagonalise `K` and `D'` (module doc).
    pub fn discretized(&self, h: f64) -> Cow<'_, Structure> {
        if !self.has_static_modes() {
            return Cow::Borrowed(self);
        }
        let mut st = self.clone();
        for b in &mut st.blocks {
            for p in b.first_static()..b.dim {
                let (w, c) = (b.omega[p], b.damping_coef[p]);
                let mphi = &b.mass * b.modes.column(p);
                let outer = &mphi * mphi.transpose();
                b.mass -= &outer * (1.0 - 0.5 * w * w * h * h);
                b.damping += &outer * (w * w * h - c);
                b.modes.column_mut(p).scale_mut(2f64.sqrt() / (w * h));
                b.omega[p] = 2f64.sqrt() / h;
                b.damping_coef[p] = 2.0 / h;
            }
        }
        Cow::Owned(st)
    }

    /// The critical speed of this structure as a stator: the lowest rotation speed (rad/s) at
    /// which a load rotating around it travels with one of its waves, `min_k ω_k / k` over the
    /// nodal diameters k ≥ 1 (`ω_k` the lowest natural frequency of diameter k), with the
    /// minimising k. Above it the backward wave of that diameter stands still in the rotating
    /// frame, and a rotating contact that dissipates (friction, impacts, coating) can feed it
    /// with the rotation's energy: the moving-load instability of a stationary elastic ring
    /// or disk (Iwan & Moeller 1976, with rotor and stator exchanged). `None` without a
    /// nodal diameter k ≥ 1.
    pub fn critical_wave_speed(&self) -> Option<(f64, usize)> {
        (self.blocks.iter())
            .filter(|b| b.k >= 1)
            .filter_map(|b| {
                let lowest = b.omega.iter().copied().fold(f64::INFINITY, f64::min);
                lowest.is_finite().then(|| (lowest / b.k as f64, b.k))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Explicit stability limit `h_crit = 2/ω_max` (s); infinite for a structure without stiffness.
    pub fn stability_limit(&self) -> f64 {
        if self.omega_max > 0.0 {
            2.0 / self.omega_max
        } else {
            f64::INFINITY
        }
    }

    /// Weight `w_k` of the orthonormal real DFT (ARCH brief).
    pub(crate) fn dft_weight(&self, k: usize) -> f64 {
        let n = self.n_sectors as f64;
        if self.blocks[k].real {
            n.powf(-0.5)
        } else {
            (2.0 / n).sqrt()
        }
    }

    /// Offset of nodal diameter `k`'s modal coordinates in the assembled physical DOF vector.
    pub(crate) fn physical_modal_offset(&self, k: usize) -> usize {
        self.n_sectors * self.n_boundary
            + self.blocks[..k]
                .iter()
                .map(|b| b.n_modes * if b.real { 1 } else { 2 })
                .sum::<usize>()
    }

    /// Orthogonal map `P` from the assembled physical DOF vector (ARCH ordering) to the
    /// concatenated harmonic real-form vectors `[x_0; x_1; …]` (offsets `NdBlock::offset`).
    pub(crate) fn physical_to_harmonic(&self) -> DMatrix<f64> {
        let n = self.n_modal;
        let nb = self.n_boundary;
        let ns = self.n_sectors;
        let mut p = DMatrix::zeros(n, n);
        let alpha = 2.0 * std::f64::consts::PI / ns as f64;
        for b in &self.blocks {
            let w = self.dft_weight(b.k);
            let moff = self.physical_modal_offset(b.k);
            let parts = if b.real { 1 } else { 2 };
            for part in 0..parts {
                let row0 = b.offset + part * b.n;
                for s in 0..ns {
                    let th = (b.k * s) as f64 * alpha;
                    let f = if part == 0 { th.cos() } else { th.sin() };
                    for r in 0..nb {
                        p[(row0 + r, s * nb + r)] = w * f;
                    }
                }
                for m in 0..b.n_modes {
                    p[(row0 + nb + m, moff + part * b.n_modes + m)] = 1.0;
                }
            }
        }
        p
    }

    /// Assembled physical mass, stiffness K(Ω) and damping matrices (ARCH ordering),
    /// `Pᵀ blockdiag(·_k) P`.
    pub(crate) fn assemble_physical(&self) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        // P is sparse (a boundary harmonic row has N entries, a modal row one): form
        // Pᵀ X P row by row instead of with dense products (O(N² n_b n) instead of O(n³)).
        let p = self.physical_to_harmonic();
        let n = self.n_modal;
        let rows: Vec<Vec<(usize, f64)>> = (0..n)
            .map(|r| {
                (0..n)
                    .filter(|&c| p[(r, c)] != 0.0)
                    .map(|c| (c, p[(r, c)]))
                    .collect()
            })
            .collect();
        let assemble = |pick: usize| {
            // Y = X P (row-major rows of length n), then Pᵀ Y.
            let mut y = vec![0.0; n * n];
            for b in &self.blocks {
                let x = match pick {
                    0 => &b.mass,
                    1 => &b.stiffness,
                    _ => &b.damping,
                };
                for r in 0..b.dim {
                    let yr = &mut y[(b.offset + r) * n..(b.offset + r + 1) * n];
                    for c in 0..b.dim {
                        let v = x[(r, c)];
                        if v != 0.0 {
                            for &(j, pv) in &rows[b.offset + c] {
                                yr[j] += v * pv;
                            }
                        }
                    }
                }
            }
            let mut out = DMatrix::zeros(n, n);
            for (r, row) in rows.iter().enumerate() {
                let yr = &y[r * n..(r + 1) * n];
                for &(i, pv) in row {
                    for (j, yv) in yr.iter().enumerate() {
                        out[(i, j)] += pv * yv;
                    }
                }
            }
            out
        };
        (assemble(0), assemble(1), assemble(2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{SyntheticSpec, synthetic_rom};
    use crate::model::rom::Component;

    #[test]
    fn eigenpairs_are_mass_normalized_and_solve_the_problem() {
        let rom = synthetic_rom(&SyntheticSpec {
            damping: crate::model::rom::Damping::Modal { ratio: 0.01 },
            ..SyntheticSpec::small(Component::Impeller, 5, 2, 3)
        });
        let st = Structure::new(&rom, 300.0).unwrap();
        for b in &st.blocks {
            let id = b.modes.transpose() * &b.mass * &b.modes;
            assert!((id - DMatrix::identity(b.dim, b.dim)).amax() < 1e-10);
            let kk = b.modes.transpose() * &b.stiffness * &b.modes;
            for p in 0..b.dim {
                let w2 = b.omega[p] * b.omega[p];
                assert!((kk[(p, p)] - w2).abs() < 1e-9 * st.omega_max.powi(2));
            }
            let dd = b.modes.transpose() * &b.damping * &b.modes;
            for p in 0..b.dim {
                assert!((dd[(p, p)] - b.damping_coef[p]).abs() < 1e-9 * b.damping_coef[b.dim - 1]);
            }
            assert!(b.omega.windows(2).all(|w| w[0] <= w[1]));
        }
        assert!((st.stability_limit() - 2.0 / st.omega_max).abs() < 1e-20);
    }

    #[test]
    fn a_mode_cutoff_makes_every_mode_above_it_static_and_no_other() {
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 6, 2, 4));
        let mass = Structure::new(&rom, 0.0).unwrap();
        let all: Vec<f64> = mass.blocks.iter().flat_map(|b| b.omega.clone()).collect();
        let mut sorted = all.clone();
        sorted.sort_by(f64::total_cmp);
        // A cutoff between two distinct frequencies of the dynamic range.
        let massless = mass.clone().with_boundary(Boundary::Massless);
        let below = massless.omega_max;
        let lower = sorted
            .iter()
            .rev()
            .find(|&&w| w < 0.9 * below)
            .copied()
            .unwrap();
        let cut_hz = 0.5 * (lower + below) / (2.0 * std::f64::consts::PI);
        let cut = massless.clone().with_mode_cutoff(Some(cut_hz));
        assert!(cut.omega_max <= 2.0 * std::f64::consts::PI * cut_hz);
        assert!(cut.omega_max < massless.omega_max);
        assert!((cut.stability_limit() - 2.0 / cut.omega_max).abs() < 1e-20);
        for (b, m) in cut.blocks.iter().zip(&massless.blocks) {
            assert!(b.n_static >= m.n_static);
            let (dynamic, stat) = b.omega.split_at(b.first_static());
            assert!(
                dynamic
                    .iter()
                    .all(|&w| w <= 2.0 * std::f64::consts::PI * cut_hz)
            );
            // Only modes above the cutoff joined the static ones (both parts of a pair).
            let joined = &stat[..stat.len() - b.parts() * m.n_static];
            assert!(
                joined
                    .iter()
                    .all(|&w| w > 2.0 * std::f64::consts::PI * cut_hz)
            );
        }
        // The paper's formulation has no static modes to join: a cutoff leaves it as it is.
        let unchanged = mass.clone().with_mode_cutoff(Some(cut_hz));
        assert_eq!(unchanged.omega_max, mass.omega_max);
        assert!(!unchanged.has_static_modes());
        // A cutoff above every mode changes nothing.
        let high = massless
            .clone()
            .with_mode_cutoff(Some(2.0 * all[0].max(below) * 1e3));
        assert_eq!(high.omega_max, massless.omega_max);
    }

    #[test]
    fn harmonic_map_is_orthogonal_and_physical_matrices_are_block_circulant() {
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 6, 2, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let p = st.physical_to_harmonic();
        let n = st.n_modal;
        assert!((p.transpose() * &p - DMatrix::identity(n, n)).amax() < 1e-12);
        let (m, k, _) = st.assemble_physical();
        let nb = st.n_boundary;
        // Boundary blocks depend only on the sector offset (local frames).
        for s1 in 0..6 {
            for s2 in 0..6 {
                let (t1, t2) = ((s1 + 1) % 6, (s2 + 1) % 6);
                for i in 0..nb {
                    for j in 0..nb {
                        let a = k[(s1 * nb + i, s2 * nb + j)];
                        let b = k[(t1 * nb + i, t2 * nb + j)];
                        assert!((a - b).abs() < 1e-9 * k.amax());
                        let a = m[(s1 * nb + i, s2 * nb + j)];
                        let b = m[(t1 * nb + i, t2 * nb + j)];
                        assert!((a - b).abs() < 1e-9 * m.amax());
                    }
                }
            }
        }
        assert!((&k - k.transpose()).amax() < 1e-9 * k.amax());
    }
}
