//! Structural mistuning of a bladed wheel (DESIGN §11): blade `s`'s Young's modulus scaled by
//! `1 + δ_s`, the disk's left as it is.
//!
//! # Reduction
//! The mistuned wheel is projected on the tuned cyclic Craig–Bampton basis of every nodal
//! diameter (the subset-of-nominal-modes idea of Yang & Griffin, J. Eng. Gas Turbines Power
//! 123(4), 2001, with the whole reduction basis as the subset). A mistuning `δ_s` adds the
//! strain energy `½ δ_s u_sᵀ K_b u_s` of blade `s`, with `u_s = Σ_k Re(B_k x̃_k e^{ikθ_s})` its
//! displacement (`B_k` the basis rows at the blade's nodes). That term couples the nodal
//! diameters through the discrete Fourier transform of the pattern. To keep it cheap, `K_b` is
//! written on a few blade shapes ψ_j (`u_sᵀ K_b u_s ≈ Σ_j ω_j² p_{s,j}²`): the proper
//! orthogonal decomposition, in the blade's strain energy, of the blade fields of the tuned
//! modes the ROM is trusted for ([`blade_modes_in_span`]). Once every shape is kept, the
//! mistuning of any combination of those modes is exact; on the built-in impeller 5 shapes
//! already reach the reduction's own error against the full mistuned wheel.
//! The coupling has rank `n_bm` per blade: `N_b n_bm` products per application, whatever the
//! number of modes per nodal diameter.
//!
//! # Definitions
//! - `δ_s` scales the elastic stiffness `K0` of blade `s`'s elements: its Young's modulus.
//!   The centrifugal terms `K1`, `K2` (stress stiffening, spin softening) stay tuned: to first
//!   order the prestress depends on the density and the geometry, not on `E`.
//! - Blade `s` is the blade of sector `s`, at angle `θ_s = 2π s / N_b` from blade 0, counted
//!   in the sense of `+z`.

use faer::Mat;
use faer::sparse::SparseColMat;
use nalgebra::{DMatrix, SymmetricEigen};
use thiserror::Error;

use crate::model::cyclic::is_real_harmonic;
use crate::model::eigen::EigenError;
use crate::model::fe::ElementSetMatrices;
use crate::model::rom::{BladeModes, ComplexRows, CyclicRom};

mod pattern;
pub use pattern::{MAX_SIGMA, Scatter, StiffnessPattern};

/// Blade shapes kept for a structural mistuning when a model asks for it without a count
/// (`impeller.blade_modes`): on the built-in impeller 5 already reach the tuned ROM's own
/// error against the full mistuned wheel (`analysis::mistuned_modes` checks), 10 leave a
/// margin.
pub const DEFAULT_BLADE_MODES: usize = 10;

/// A mistuning pattern that cannot be applied; the message names the field and the reason.
#[derive(Debug, Error, PartialEq)]
pub enum MistuningError {
    /// The pattern does not have one value per blade.
    #[error("{field}: {found} values for {blades} blades")]
    Length {
        /// The pattern's field.
        field: String,
        /// Its number of values.
        found: usize,
        /// The wheel's number of blades.
        blades: usize,
    },
    /// A value is out of range.
    #[error("{field}[{blade}] = {value}: {reason}")]
    Value {
        /// The pattern's field.
        field: String,
        /// The blade.
        blade: usize,
        /// The value.
        value: f64,
        /// Why it is refused.
        reason: &'static str,
    },
    /// A parameter of a pattern is out of range.
    #[error("{field} = {value}: {reason}")]
    Parameter {
        /// The parameter.
        field: String,
        /// Its value.
        value: f64,
        /// Why it is refused.
        reason: String,
    },
    /// The ROM carries no blade modes.
    #[error(
        "the impeller model has no blade modes: build it with `impeller.blade_modes` > 0 \
         (a built-in impeller) to apply a structural mistuning"
    )]
    NoBladeModes,
}

/// Checks a structural pattern (`field` names it): one `δ_s` per blade of an `n_blades`
/// wheel, each finite and above −1 (a blade's modulus stays positive).
pub fn check_stiffness_pattern(
    field: &str,
    delta: &[f64],
    n_blades: usize,
) -> Result<(), MistuningError> {
    if delta.len() != n_blades {
        return Err(MistuningError::Length {
            field: field.into(),
            found: delta.len(),
            blades: n_blades,
        });
    }
    if let Some((blade, &value)) = delta
        .iter()
        .enumerate()
        .find(|(_, d)| !(d.is_finite() && **d > -1.0))
    {
        return Err(MistuningError::Value {
            field: field.into(),
            blade,
            value,
            reason: "must be finite and > -1 (the blade's Young's modulus is E (1 + δ))",
        });
    }
    Ok(())
}

/// The blade's `count` leading shapes ([`BladeModes`]) from the basis rows `rows[k]` at the
/// blade's nodes (`blade.nodes`, x y z of the sector frame) of every nodal diameter of an
/// `n_sectors` wheel, and the tuned modes `tuned[k]` (columns, ROM coordinates) they are
/// drawn from.
///
/// The snapshots are the blade fields of the tuned modes at sector 0, a complex harmonic's at
/// the two phases `x̃` and `i x̃`, each divided by its circular frequency so that its blade
/// strain energy is its share of the mode's strain energy. Their proper orthogonal
/// decomposition in the energy product of `K_b` (eigenvectors of the snapshots' Gram matrix
/// `Zᵀ K_b Z`, largest first) orders the shapes by the blade strain energy they capture. Every
/// sector field of a combination of the tuned modes lies in the snapshots' span, so once
/// every shape is kept the mistuning of such motions is exact: the subset of nominal modes of
/// Yang & Griffin with the modes the ROM is trusted for as the subset. Ordered by frequency
/// instead, the free blade's own modes start with motions of a free root that no wheel mode
/// makes (190 Hz on the built-in impeller, whose first mode is at 2100 Hz) and 40 of them
/// left 0.9 % errors.
pub(crate) fn blade_modes_in_span(
    blade: &ElementSetMatrices,
    rows: &[ComplexRows],
    tuned: &[ComplexRows],
    n_sectors: usize,
    count: usize,
) -> Result<BladeModes, EigenError> {
    // Real columns [Re B_k, −Im B_k] (Re B_k alone for a real harmonic): u = T z with
    // z = [Re(x̃ e^{ikθ}); Im(x̃ e^{ikθ})].
    let real: Vec<bool> = (0..rows.len())
        .map(|k| is_real_harmonic(k, n_sectors))
        .collect();
    let widths: Vec<usize> = rows
        .iter()
        .zip(&real)
        .map(|(b, &r)| if r { b.re.ncols() } else { 2 * b.re.ncols() })
        .collect();
    let r: usize = widths.iter().sum();
    let n_dof = 3 * blade.nodes.len();
    let mut t = Mat::<f64>::zeros(n_dof, r);
    let mut off = 0;
    for ((b, &re_only), &w) in rows.iter().zip(&real).zip(&widths) {
        let n = b.re.ncols();
        for i in 0..n_dof {
            for j in 0..n {
                t[(i, off + j)] = b.re[(i, j)];
                if !re_only {
                    t[(i, off + n + j)] = -b.im[(i, j)];
                }
            }
        }
        off += w;
    }
    let project = |a: &SparseColMat<usize, f64>| {
        let at = a * &t;
        let p = t.transpose() * &at;
        DMatrix::from_fn(r, r, |i, j| 0.5 * (p[(i, j)] + p[(j, i)]))
    };
    let (k_r, m_r) = (project(&blade.stiffness), project(&blade.mass));
    let z = snapshots(tuned, &real, &widths, r);
    let gram = z.transpose() * &k_r * &z;
    let eig = SymmetricEigen::new((&gram + gram.transpose()) * 0.5);
    let mut order: Vec<usize> = (0..gram.nrows()).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let top = order.first().map_or(0.0, |&i| eig.eigenvalues[i]);
    if !(top.is_finite() && top > 0.0) {
        return Err(EigenError::MassNotDefinite);
    }
    // φ_i = Z v_i / √σ_i, K_b-orthonormal; ψ_i = ω_i φ_i is M_b-normalized with
    // ω_i² = 1 / φ_iᵀ M_b φ_i, and p_i = ψ_iᵀ K_b z / ω_i² = φ_iᵀ K_b z / ω_i.
    let kept: Vec<usize> = order
        .into_iter()
        .filter(|&i| eig.eigenvalues[i] > 1e-12 * top)
        .take(count)
        .collect();
    let phi = DMatrix::from_fn(z.ncols(), kept.len(), |i, j| {
        eig.eigenvectors[(i, kept[j])] / eig.eigenvalues[kept[j]].sqrt()
    });
    let phi = &z * phi;
    let omega2: Vec<f64> = (0..kept.len())
        .map(|j| 1.0 / (phi.column(j).transpose() * &m_r * phi.column(j))[(0, 0)])
        .collect();
    let mut q = &k_r * &phi;
    for (j, w2) in omega2.iter().enumerate() {
        q.column_mut(j).scale_mut(1.0 / w2.sqrt());
    }
    // Per nodal diameter P_k = q_reᵀ − i q_imᵀ.
    let mut out = Vec::with_capacity(rows.len());
    let mut off = 0;
    for ((b, &re_only), &w) in rows.iter().zip(&real).zip(&widths) {
        let n = b.re.ncols();
        let re = DMatrix::from_fn(kept.len(), n, |j, c| q[(off + c, j)]);
        let im = if re_only {
            DMatrix::zeros(kept.len(), n)
        } else {
            DMatrix::from_fn(kept.len(), n, |j, c| -q[(off + n + c, j)])
        };
        out.push(ComplexRows { re, im });
        off += w;
    }
    Ok(BladeModes { omega2, rows: out })
}

/// The snapshot matrix of [`blade_modes_in_span`]: per tuned mode `x̃` of harmonic `k`, the
/// `z` of `x̃` (and of `i x̃` for a complex harmonic) at sector 0, `[Re; Im]` in that harmonic's
/// columns.
fn snapshots(tuned: &[ComplexRows], real: &[bool], widths: &[usize], r: usize) -> DMatrix<f64> {
    let n_snap: usize = tuned
        .iter()
        .zip(real)
        .map(|(m, &re_only)| if re_only { 1 } else { 2 } * m.re.ncols())
        .sum();
    let mut z = DMatrix::zeros(r, n_snap);
    let (mut off, mut col) = (0, 0);
    for ((modes, &re_only), &w) in tuned.iter().zip(real).zip(widths) {
        let n = modes.re.nrows();
        for p in 0..modes.re.ncols() {
            let phases: &[(f64, f64)] = if re_only {
                &[(1.0, 0.0)]
            } else {
                &[(1.0, 0.0), (0.0, 1.0)]
            };
            for &(c, s) in phases {
                for i in 0..n {
                    let (a, b) = (modes.re[(i, p)], modes.im[(i, p)]);
                    z[(off + i, col)] = c * a - s * b;
                    if !re_only {
                        z[(off + n + i, col)] = s * a + c * b;
                    }
                }
                col += 1;
            }
        }
        off += w;
    }
    z
}

/// Layout of the wheel coordinates: every nodal diameter's ROM coordinates in real form
/// (`a`, then `b` for a complex harmonic), `k = 0..=N/2` in order.
#[derive(Clone, Debug)]
pub(crate) struct WheelCoordinates {
    /// First wheel coordinate of each harmonic.
    pub offset: Vec<usize>,
    /// ROM coordinates of each harmonic (`3 n_c + n_m(k)`).
    pub size: Vec<usize>,
    /// Whether each harmonic is real (no `b` part).
    pub real: Vec<bool>,
    /// Energy weight of each harmonic: `N` for a real one, `N/2` for a complex one (the
    /// wheel's kinetic energy is `Σ_k c_k ½ ẋ_kᵀ M_k ẋ_k`).
    pub weight: Vec<f64>,
    /// Total number of wheel coordinates.
    pub total: usize,
}

impl WheelCoordinates {
    /// The layout of `rom`.
    pub(crate) fn of(rom: &CyclicRom) -> Self {
        let n = rom.n_sectors;
        let (mut offset, mut size, mut real, mut weight) = (vec![], vec![], vec![], vec![]);
        let mut total = 0;
        for h in &rom.harmonics {
            let r = is_real_harmonic(h.nodal_diameter, n);
            let m = h.mass.size();
            offset.push(total);
            size.push(m);
            real.push(r);
            weight.push(if r { n as f64 } else { n as f64 / 2.0 });
            total += if r { m } else { 2 * m };
        }
        Self {
            offset,
            size,
            real,
            weight,
            total,
        }
    }

    /// Gradient of `Re(Σ_k c_k x̃_k e^{ikθ_s})` with respect to the wheel coordinates, for one
    /// row `c_k` (re, im) per harmonic: `Re(c e^{ikθ})` on `a`, `Im(c e^{ikθ})` on `b`
    /// (`x̃ = a − i b`). Written into `out` (length `total`).
    pub(crate) fn sector_gradient(
        &self,
        n_sectors: usize,
        sector: usize,
        row: impl Fn(usize, usize) -> (f64, f64),
        out: &mut [f64],
    ) {
        for k in 0..self.offset.len() {
            let (sin, cos) = sector_angle(k, sector, n_sectors).sin_cos();
            let (o, m) = (self.offset[k], self.size[k]);
            for c in 0..m {
                let (re, im) = row(k, c);
                out[o + c] = re * cos - im * sin;
                if !self.real[k] {
                    out[o + m + c] = re * sin + im * cos;
                }
            }
        }
    }

    /// `Re(Σ_k x̃_k[i] e^{ikθ_s})` of ROM coordinate `i` (a contact DOF for `i < 3 n_c`) in
    /// sector `s`, from wheel coordinates `x`.
    pub(crate) fn sector_value(&self, n_sectors: usize, sector: usize, i: usize, x: &[f64]) -> f64 {
        (0..self.offset.len())
            .map(|k| {
                let theta = sector_angle(k, sector, n_sectors);
                let a = x[self.offset[k] + i];
                if self.real[k] {
                    a * theta.cos()
                } else {
                    a * theta.cos() + x[self.offset[k] + self.size[k] + i] * theta.sin()
                }
            })
            .sum()
    }
}

/// `k θ_s` (rad) of harmonic `k` at sector `s`, reduced modulo a turn.
fn sector_angle(k: usize, sector: usize, n_sectors: usize) -> f64 {
    std::f64::consts::TAU * ((k * sector) % n_sectors) as f64 / n_sectors as f64
}

/// The mistuning stiffness in wheel coordinates ([`WheelCoordinates`]):
/// `Σ_s δ_s Σ_j ω_j² g_{s,j} g_{s,j}ᵀ`, `g_{s,j}` the gradient of blade `s`'s modal
/// coordinate `p_{s,j}` (N/m in the ROM's units). Checks the pattern first.
pub(crate) fn wheel_mistuning_stiffness(
    rom: &CyclicRom,
    layout: &WheelCoordinates,
    delta: &[f64],
) -> Result<DMatrix<f64>, MistuningError> {
    let modes = &rom.blade_modes;
    if modes.omega2.is_empty() {
        return Err(MistuningError::NoBladeModes);
    }
    check_stiffness_pattern("stiffness", delta, rom.n_sectors)?;
    let mut out = DMatrix::zeros(layout.total, layout.total);
    let mut g = vec![0.0; layout.total];
    for (s, &d) in delta.iter().enumerate() {
        if d == 0.0 {
            continue;
        }
        for (j, &w2) in modes.omega2.iter().enumerate() {
            layout.sector_gradient(
                rom.n_sectors,
                s,
                |k, c| (modes.rows[k].re[(j, c)], modes.rows[k].im[(j, c)]),
                &mut g,
            );
            let gv = nalgebra::DVector::from_column_slice(&g);
            out.ger(d * w2, &gv, &gv, 1.0);
        }
    }
    Ok(out)
}
