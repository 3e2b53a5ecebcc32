//! Free modes of one harmonic block and their rows at the held contacts.
//!
//! A block is the ROM's Hermitian harmonic matrix pair `(K, M)` of one nodal diameter: a field
//! `u_s = x e^{ikθ_s}` over the sectors obeys `(s² M + s D + K) x = f̂` with `f̂` the
//! harmonic of the sector loads (`model::rom` conventions). Its modes are mass-normalized and
//! carry the ROM's modal damping (`c_p = 2ζω_p`, or `α + βω_p²` for Rayleigh, as in
//! [`crate::dynamics::structure`]), so that each modal coordinate obeys
//! `η̈ + c_p η̇ + ω_p² η = φ_pᴴ f̂`. The negative harmonic `−k` is the complex conjugate of the
//! block `k`: same frequencies, conjugate shapes.

use super::StabilityError;
use super::interface::Interface;
use crate::model::eigen::{EigenError, dense_gen_eigen};
use crate::model::rom::{Damping, HarmonicBlock};
use faer::{Mat, c64};

/// Mass-normalized free modes of one block.
pub(super) struct BlockModes {
    /// Natural circular frequencies ω_p (rad/s), ascending.
    pub omega: Vec<f64>,
    /// Modal damping coefficients c_p (1/s).
    pub damping: Vec<f64>,
    /// Mode shapes (columns, `Φᴴ M Φ = I`) over `[boundary DOFs; modal coordinates]`.
    pub shapes: Mat<c64>,
}

/// Why a block has no modes; named by the caller ([`ModesError::named`]).
pub(super) enum ModesError {
    Eigen(EigenError),
    Indefinite(f64),
}

impl ModesError {
    /// The error of block `k` of `which` at `omega` (rad/s).
    pub fn named(self, which: &'static str, k: usize, omega: f64) -> StabilityError {
        match self {
            ModesError::Eigen(e) => StabilityError::Rom {
                which,
                reason: format!("nodal diameter {k}: {e}"),
            },
            ModesError::Indefinite(lambda) => StabilityError::Indefinite {
                which,
                k,
                omega,
                lambda,
            },
        }
    }
}

/// The free modes of `block` at speed `omega` (rad/s; `K(Ω) = K0 + Ω² K1 + Ω⁴ K2`).
pub(super) fn block_modes(
    block: &HarmonicBlock,
    omega: f64,
    real: bool,
    damping: Damping,
) -> Result<BlockModes, ModesError> {
    let to_faer = |re: &nalgebra::DMatrix<f64>, im: &nalgebra::DMatrix<f64>| {
        Mat::from_fn(re.nrows(), re.ncols(), |i, j| {
            c64::new(re[(i, j)], im[(i, j)])
        })
    };
    let k = block.stiffness_at(omega);
    let (lambdas, shapes) = dense_gen_eigen(
        to_faer(&k.re, &k.im).as_ref(),
        to_faer(&block.mass.re, &block.mass.im).as_ref(),
        real,
    )
    .map_err(ModesError::Eigen)?;
    let lmax = lambdas.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    if let Some(&l) = lambdas.first()
        && l < -1e-9 * lmax.max(1.0)
    {
        return Err(ModesError::Indefinite(l));
    }
    let omega_p: Vec<f64> = lambdas.iter().map(|l| l.max(0.0).sqrt()).collect();
    let c = (omega_p.iter())
        .map(|&w| match damping {
            Damping::Modal { ratio } => 2.0 * ratio * w,
            Damping::Rayleigh { alpha, beta } => alpha + beta * w * w,
        })
        .collect();
    Ok(BlockModes {
        omega: omega_p,
        damping: c,
        shapes,
    })
}

/// Rows of one block's modes at the held contacts: `gap[(j, p)]` is the normal displacement
/// (tip minus casing) that mode `p` gives at held row `j`, `force[(j, p)]` the same along the
/// force direction `n + μ e_θ`; the generalized force of a contact force `N_j` on the mode is
/// `−conj(force[(j, p)]) N_j`.
pub(super) struct ContactRows {
    pub gap: Mat<c64>,
    pub force: Mat<c64>,
}

/// The rows of the impeller block's modes (`conjugate`: the class is the negative harmonic).
pub(super) fn impeller_rows(iface: &Interface, modes: &BlockModes, conjugate: bool) -> ContactRows {
    let (m, n) = (iface.rows.len(), modes.omega.len());
    let phi = |i: usize, p: usize| {
        let v = modes.shapes[(i, p)];
        if conjugate { v.conj() } else { v }
    };
    let along = |dir: &[f64; 3], node: usize, p: usize| {
        (0..3).fold(c64::new(0.0, 0.0), |s, a| s + phi(3 * node + a, p) * dir[a])
    };
    ContactRows {
        gap: Mat::from_fn(m, n, |j, p| {
            along(&iface.rows[j].tip_normal, iface.rows[j].tip_node, p)
        }),
        force: Mat::from_fn(m, n, |j, p| {
            along(&iface.rows[j].tip_force, iface.rows[j].tip_node, p)
        }),
    }
}

/// The rows of casing harmonic `k` (signed; `modes` are those of `|k|`), each scaled by
/// `scale` (`1/√ρ`, see the module doc of [`super`]): the casing displacement enters the gap
/// with a minus sign.
pub(super) fn casing_rows(
    iface: &Interface,
    modes: &BlockModes,
    k: i64,
    scale: f64,
) -> ContactRows {
    let (m, n) = (iface.rows.len(), modes.omega.len());
    let phi = |i: usize, p: usize| {
        let v = modes.shapes[(i, p)];
        if k < 0 { v.conj() } else { v }
    };
    let row = |j: usize, p: usize, force: bool| {
        let mut s = c64::new(0.0, 0.0);
        for t in &iface.rows[j].casing {
            let dir = if force { &t.force } else { &t.normal };
            let along = (0..3).fold(c64::new(0.0, 0.0), |a, d| {
                a + phi(3 * t.node + d, p) * dir[d]
            });
            let (sin, cos) = (k as f64 * t.angle_offset).sin_cos();
            s += c64::new(cos, sin) * along * t.weight;
        }
        -s * scale
    };
    ContactRows {
        gap: Mat::from_fn(m, n, |j, p| row(j, p, false)),
        force: Mat::from_fn(m, n, |j, p| row(j, p, true)),
    }
}
