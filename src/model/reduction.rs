//! Cyclic Craig–Bampton reduction of a sector model (DESIGN §2.1–2.2; paper §2, "ten modes
//! per nodal diameter").
//!
//! For each nodal diameter `k = 0..=N/2` the sector matrices are turned into the complex
//! Hermitian harmonic matrices over the independent DOFs (`cyclic.rs`), which are split into
//! boundary DOFs `B` (the three DOFs of each contact node, in contact-node order) and interior
//! DOFs `I`. The Craig–Bampton basis is
//!
//! ```text
//! u_B = q_B,   u_I = Ψ q_B + Φ η,   Ψ = −K_II⁻¹ K_IB   (constraint modes),
//! K_II Φ = M_II Φ Λ,  Φᴴ M_II Φ = I                   (lowest n_m fixed-interface modes).
//! ```
//!
//! Cyclic superposition of the 360° constraint modes of the contact DOFs gives exactly `Ψ`
//! for each harmonic, so the harmonic route is equivalent and N times cheaper. The reduced
//! matrices are `Vᴴ A V` for `A = M, K0, K1`; `K2 = 0` (linear prestress).
//!
//! `K_II` is factorised by a sparse Cholesky (faer, [`crate::model::sparse_eigen`]); the
//! fixed-interface modes come from the sparse block Krylov solver on that factor, converged
//! to the relative residual `‖K φ − λ M φ‖ ≤ 1e-9 ‖K φ‖`. Real harmonics are solved in real
//! arithmetic. The nodal diameters are processed in parallel (rayon).

use crate::model::cyclic::{CyclicDofMap, CyclicError, SectorTopology, is_real_harmonic};
use crate::model::eigen::{EigenError, dense_gen_eigen};
use crate::model::fe::{ElementSetMatrices, SectorMatrices};
use crate::model::mesh::{NamedNode, SectorMesh};
use crate::model::mistuning::blade_modes_in_span;
use crate::model::recovery::{harmonic_recovery_rows, recovery_of};
use crate::model::rom::{
    BladeModes, ComplexRows, Component, ContactNode, CyclicRom, Damping, HarmonicBlock,
    HermitianMatrix, ModalData, RomError,
};
use crate::model::sparse_eigen::{
    CholeskyFactor, Eigenpairs, Pencil, Scalar, SparseEigenError, SparseEigenOptions,
    lowest_eigenpairs,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, MatRef, c64};
use nalgebra::DMatrix;
use rayon::prelude::*;
use std::f64::consts::PI;
use thiserror::Error;

/// Revision of the reduction's numerics, part of the key of the on-disk ROM cache
/// ([`crate::io::model_cache`]): bump it with every change that alters the numbers of a built
/// ROM, or a machine's cache keeps serving ROMs of the old code (the crate version does not
/// change with such commits). 2: fixed-interface modes from [`crate::model::sparse_eigen`];
/// 3: the consistent prestress became the impeller's default (an unchanged spec, new numbers).
pub const NUMERICS_REVISION: u32 = 3;

/// Options of the cyclic Craig–Bampton reduction.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ReductionOptions {
    /// Fixed-interface modes kept per nodal diameter `n_m` (paper: 10). Capped by the number of
    /// interior DOFs.
    pub modes_per_diameter: usize,
    /// Rotation speeds (rad/s) at which the modal data of the reduced model are computed;
    /// empty means `[0]`.
    pub omega_grid: Vec<f64>,
    /// Impeller (rotating frame) or casing (fixed frame).
    pub component: Component,
    /// Human-readable model name stored in the ROM.
    pub name: String,
    /// Damping model stored in the ROM.
    pub damping: Damping,
    /// Sector nodes whose recovery rows the ROM keeps (the built-in models' named nodes).
    pub recovery_points: Vec<NamedNode>,
    /// A speed (rad/s) at which the fixed-interface modes of K(Ω) are computed too and merged
    /// into the basis ([`merge_speed_modes`]): a basis of modes at rest alone does not
    /// represent the initial-displacement stiffness of the consistent prestress.
    pub speed_basis: Option<f64>,
    /// Blade modes kept for structural mistuning ([`crate::model::rom::BladeModes`]; 0: none).
    /// Needs the sector's blade ([`SectorModel::blade`]).
    pub blade_modes: usize,
}

impl Default for ReductionOptions {
    fn default() -> Self {
        Self {
            modes_per_diameter: 10,
            omega_grid: vec![0.0],
            component: Component::Casing,
            name: "sector".into(),
            damping: Damping::default(),
            recovery_points: Vec::new(),
            speed_basis: None,
            blade_modes: 0,
        }
    }
}

/// A reduction that could not be carried out; every variant names the cause.
#[derive(Debug, Error)]
pub enum ReductionError {
    /// The sector's cyclic topology is inconsistent.
    #[error("cyclic sector: {0}")]
    Cyclic(#[from] CyclicError),
    /// No contact nodes: the Craig–Bampton boundary would be empty.
    #[error("the sector has no contact nodes: the Craig–Bampton boundary would be empty")]
    NoContactNodes,
    /// `modes_per_diameter` is zero.
    #[error("modes_per_diameter must be at least 1")]
    NoModes,
    /// A speed of the Ω grid is negative or not finite.
    #[error("omega_grid entry {value} is not a finite non-negative speed (rad/s)")]
    BadOmega {
        /// The rejected speed (rad/s).
        value: f64,
    },
    /// The node list and the matrices disagree on the number of DOFs.
    #[error("nodes has {found} entries but the matrices have {dofs} DOFs (3 per node)")]
    NodeCount {
        /// Number of nodes given.
        found: usize,
        /// Order of the matrices.
        dofs: usize,
    },
    /// A sector matrix is not square of the model's order.
    #[error("{what} matrix is {rows}×{cols}, expected {n}×{n}")]
    MatrixShape {
        /// `"stiffness"`, `"mass"` or `"centrifugal"`.
        what: &'static str,
        /// Rows of the matrix.
        rows: usize,
        /// Columns of the matrix.
        cols: usize,
        /// Expected order, 3 per node.
        n: usize,
    },
    /// The interior stiffness `K_II` cannot be Cholesky-factorised: the contact nodes and
    /// clamps leave a rigid-body motion of the interior free.
    #[error(
        "nodal diameter {k}: interior stiffness K_II is not positive definite (the contact nodes and clamps do not suppress every rigid-body motion of the interior?): {detail}"
    )]
    InteriorNotDefinite {
        /// Nodal diameter.
        k: usize,
        /// The factorisation's message.
        detail: String,
    },
    /// A reduced matrix is not positive definite (not constructed by the current reduction;
    /// kept for callers that match on it).
    #[error("nodal diameter {k}: {what} is not positive definite: {detail}")]
    NotDefinite {
        /// Nodal diameter.
        k: usize,
        /// Which matrix.
        what: &'static str,
        /// The factorisation's message.
        detail: String,
    },
    /// The dense generalized eigensolver of the fixed-interface problem failed.
    #[error("nodal diameter {k}: eigensolver failed: {source}")]
    Eigen {
        /// Nodal diameter.
        k: usize,
        /// The eigensolver's error.
        source: EigenError,
    },
    /// The sparse eigensolver of the fixed-interface modes failed (e.g. did not converge).
    #[error("nodal diameter {k}: fixed-interface modes: {source}")]
    SparseEigen {
        /// Nodal diameter.
        k: usize,
        /// The sparse eigensolver's error.
        source: SparseEigenError,
    },
    /// The blade's modes for mistuning could not be computed.
    #[error("blade modes: {source}")]
    BladeModes {
        /// The eigensolver's error.
        source: EigenError,
    },
    /// The reduced model fails the ROM's own validation.
    #[error("reduced model is invalid: {0}")]
    Rom(#[from] RomError),
}

/// Borrowed view of a sector FE model: the input of the reduction, independent of the mesher.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SectorModel<'a> {
    /// Cyclic topology (N, faces, clamps).
    pub topology: SectorTopology<'a>,
    /// Node coordinates (m), global frame of sector 0.
    pub nodes: &'a [[f64; 3]],
    /// Contact nodes, ordered leading edge → trailing edge.
    pub contact_nodes: &'a [usize],
    /// Sector stiffness K0 (N/m), full symmetric storage, DOF `3·node + dir`.
    pub stiffness: &'a SparseColMat<usize, f64>,
    /// Sector consistent mass (kg).
    pub mass: &'a SparseColMat<usize, f64>,
    /// Centrifugal stiffness K1 (N/m per (rad/s)²), if the component rotates.
    pub centrifugal: Option<&'a SparseColMat<usize, f64>>,
    /// Quartic centrifugal stiffness K2 (N/m per (rad/s)⁴): `K(Ω) = K0 + Ω² K1 + Ω⁴ K2`.
    pub centrifugal_quartic: Option<&'a SparseColMat<usize, f64>>,
    /// The blade's elements' matrices, for its modes ([`ReductionOptions::blade_modes`]).
    pub blade: Option<&'a ElementSetMatrices>,
}

/// Result of the reduction of one nodal diameter.
#[derive(Clone, Debug)]
pub(crate) struct HarmonicReduction {
    /// Reduced matrices.
    pub block: HarmonicBlock,
    /// Free-vibration data of the reduced model over the Ω grid.
    pub modal: ModalData,
    /// Frequencies (Hz) of the kept fixed-interface modes, ascending.
    pub fixed_interface_hz: Vec<f64>,
    /// Recovery rows of `opts.recovery_points` for this nodal diameter (no rows when none).
    pub recovery: ComplexRows,
    /// The basis rows at the blade's nodes, when blade modes are asked for.
    pub blade_rows: Option<ComplexRows>,
}

/// Reduces a built-in sector mesh and its assembled matrices to a [`CyclicRom`]
/// (cyclic Craig–Bampton, DESIGN §2.2); see [`reduce_sector_model`].
pub(crate) fn reduce_cyclic(
    mesh: &SectorMesh,
    mats: &SectorMatrices,
    blade: Option<&ElementSetMatrices>,
    opts: &ReductionOptions,
) -> Result<CyclicRom, ReductionError> {
    let model = SectorModel {
        topology: SectorTopology::of(mesh),
        nodes: &mesh.nodes,
        contact_nodes: &mesh.contact_nodes,
        stiffness: &mats.stiffness,
        mass: &mats.mass,
        centrifugal: mats.centrifugal.as_ref(),
        centrifugal_quartic: mats.centrifugal_quartic.as_ref(),
        blade,
    };
    reduce_sector_model(&model, opts)
}

/// Reduces a cyclic sector FE model to a [`CyclicRom`] by cyclic Craig–Bampton (DESIGN §2.2).
pub(crate) fn reduce_sector_model(
    model: &SectorModel<'_>,
    opts: &ReductionOptions,
) -> Result<CyclicRom, ReductionError> {
    let map = check_model(model, opts)?;
    let kmax = model.topology.n_sectors / 2;
    let mut results: Vec<HarmonicReduction> = (0..=kmax)
        .into_par_iter()
        .map(|k| reduce_harmonic(model, &map, k, opts))
        .collect::<Result<_, _>>()?;
    let contact_nodes = model
        .contact_nodes
        .iter()
        .enumerate()
        .map(|(row, &n)| ContactNode {
            position: model.nodes[n],
            row,
            id: None,
        })
        .collect();
    let provenance = serde_json::json!({
        "method": "cyclic Craig-Bampton",
        "n_sector_nodes": model.topology.n_nodes,
        "n_independent_dofs": map.n_independent(),
        "modes_per_diameter": opts.modes_per_diameter,
        "fixed_interface_hz": results.iter().map(|r| r.fixed_interface_hz.clone()).collect::<Vec<_>>(),
        "accuracy_cutoff_hz": results.iter().map(|r| accuracy_cutoff_hz(&r.fixed_interface_hz)).collect::<Vec<_>>(),
    });
    let blade_modes = match model.blade {
        Some(blade) if opts.blade_modes > 0 => {
            let n = model.topology.n_sectors;
            let tuned = results
                .iter()
                .map(|r| {
                    let real = is_real_harmonic(r.block.nodal_diameter, n);
                    tuned_modes_below(&r.block, real, accuracy_cutoff_hz(&r.fixed_interface_hz))
                })
                .collect::<Result<Vec<_>, _>>();
            let rows: Vec<ComplexRows> = results
                .iter_mut()
                .filter_map(|r| r.blade_rows.take())
                .collect();
            tuned
                .and_then(|tuned| blade_modes_in_span(blade, &rows, &tuned, n, opts.blade_modes))
                .map_err(|source| ReductionError::BladeModes { source })?
        }
        _ => BladeModes::default(),
    };
    let mut rows = Vec::with_capacity(results.len());
    let (harmonics, modal_data): (Vec<_>, Vec<_>) = results
        .into_iter()
        .map(|r| {
            rows.push(r.recovery);
            (r.block, r.modal)
        })
        .unzip();
    let rom = CyclicRom {
        name: opts.name.clone(),
        component: opts.component,
        n_sectors: model.topology.n_sectors,
        contact_nodes,
        harmonics,
        modal_data,
        damping: opts.damping,
        provenance,
        recovery: recovery_of(&opts.recovery_points, model.nodes, rows),
        blade_modes: Box::new(blade_modes),
    };
    rom.validate()?;
    Ok(rom)
}

/// Frequency (Hz) below which the reduced model of one nodal diameter is trusted to 0.5 %:
/// 0.25 × the highest kept fixed-interface frequency. The Craig–Bampton error of a mode at `f`
/// grows like `(f / f_trunc)²` times the participation of the truncated fixed-interface modes.
/// The customary "half the highest kept" rule left 5 % errors on a hostile lattice sector, and
/// on the built-in casing (10 modes per nodal diameter) a mode at 0.27 × f_top is off by 0.9 %
/// while every mode below 0.25 × f_top is within 0.5 % (see the tests).
pub(crate) fn accuracy_cutoff_hz(fixed_interface_hz: &[f64]) -> f64 {
    fixed_interface_hz.last().copied().unwrap_or(0.0) * 0.25
}

fn check_model(
    model: &SectorModel<'_>,
    opts: &ReductionOptions,
) -> Result<CyclicDofMap, ReductionError> {
    if model.contact_nodes.is_empty() {
        return Err(ReductionError::NoContactNodes);
    }
    if opts.modes_per_diameter == 0 {
        return Err(ReductionError::NoModes);
    }
    if let Some(&value) = opts
        .omega_grid
        .iter()
        .find(|w| !(w.is_finite() && **w >= 0.0))
    {
        return Err(ReductionError::BadOmega { value });
    }
    let n = 3 * model.topology.n_nodes;
    if model.nodes.len() != model.topology.n_nodes {
        return Err(ReductionError::NodeCount {
            found: model.nodes.len(),
            dofs: n,
        });
    }
    let mats = [
        ("stiffness", Some(model.stiffness)),
        ("mass", Some(model.mass)),
        ("centrifugal", model.centrifugal),
        ("centrifugal quartic", model.centrifugal_quartic),
    ];
    for (what, m) in mats {
        if let Some(m) = m
            && (m.nrows() != n || m.ncols() != n)
        {
            return Err(ReductionError::MatrixShape {
                what,
                rows: m.nrows(),
                cols: m.ncols(),
                n,
            });
        }
    }
    Ok(CyclicDofMap::new(&model.topology, model.contact_nodes)?)
}

/// Builds the DOF map with the contact nodes first, for [`reduce_harmonic`].
#[cfg(test)]
pub(crate) fn boundary_first_map(
    model: &SectorModel<'_>,
    opts: &ReductionOptions,
) -> Result<CyclicDofMap, ReductionError> {
    check_model(model, opts)
}

/// Cyclic Craig–Bampton reduction of nodal diameter `k` (`map` from [`boundary_first_map`]).
pub(crate) fn reduce_harmonic(
    model: &SectorModel<'_>,
    map: &CyclicDofMap,
    k: usize,
    opts: &ReductionOptions,
) -> Result<HarmonicReduction, ReductionError> {
    let real = is_real_harmonic(k, map.n_sectors());
    let nb = map.n_first();
    let n = map.n_independent();
    let ni = n - nb;
    let k_trip = map.harmonic_triplets(model.stiffness, k)?;
    let m_trip = map.harmonic_triplets(model.mass, k)?;
    let sparse = |t: &[Triplet<usize, usize, c64>], rows, cols| {
        SparseColMat::try_new_from_triplets(rows, cols, t)
            .map_err(|e| CyclicError::Sparse(format!("{e:?}")))
    };
    let interior = |t: &[Triplet<usize, usize, c64>]| {
        let ii: Vec<_> = t
            .iter()
            .filter(|e| e.row >= nb && e.col >= nb)
            .map(|e| Triplet::new(e.row - nb, e.col - nb, e.val))
            .collect();
        sparse(&ii, ni, ni)
    };
    let k_ii = interior(&k_trip)?;
    let m_ii = interior(&m_trip)?;

    let coupling = |t: &[Triplet<usize, usize, c64>]| {
        let mut k_ib = Mat::<c64>::zeros(ni, nb);
        for e in t.iter().filter(|e| e.row >= nb && e.col < nb) {
            k_ib[(e.row - nb, e.col)] += e.val;
        }
        k_ib
    };
    let k_ib = coupling(&k_trip);
    // K(Ω)'s interior and interior–boundary blocks at the enrichment speed, if any.
    let k_speed = match opts.speed_basis {
        Some(w) if model.centrifugal.is_some() => {
            let t = triplets_at_speed(model, map, k, &k_trip, w)?;
            Some((interior(&t)?, coupling(&t)))
        }
        _ => None,
    };

    // Constraint modes Ψ = −K_II⁻¹ K_IB and the lowest fixed-interface modes, M_II-normalized;
    // in real arithmetic for the real harmonics (real Ψ and Φ keep their reduced blocks real).
    let n_m = opts.modes_per_diameter.min(ni);
    let real_dense = |a: &Mat<c64>| Mat::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)].re);
    let InteriorBasis {
        psi,
        ritz: lam,
        modes: phi,
    } = if real {
        let k_speed = match &k_speed {
            Some((kk, kb)) => Some((real_part(kk)?, real_dense(kb))),
            None => None,
        };
        let b = fixed_interface_basis(
            &real_part(&k_ii)?,
            &real_part(&m_ii)?,
            real_dense(&k_ib),
            k_speed,
            n_m,
            k,
        )?;
        InteriorBasis {
            psi: to_complex(b.psi.as_ref()),
            ritz: b.ritz,
            modes: to_complex(b.modes.as_ref()),
        }
    } else {
        fixed_interface_basis(&k_ii, &m_ii, k_ib, k_speed, n_m, k)?
    };
    let n_m = phi.ncols();

    // Basis V = [[I, 0], [Ψ, Φ]] over (B, I) → (q_B, η).
    let nr = nb + n_m;
    let mut v = Mat::<c64>::zeros(n, nr);
    for j in 0..nb {
        v[(j, j)] = c64::new(1.0, 0.0);
    }
    v.as_mut().submatrix_mut(nb, 0, ni, nb).copy_from(&psi);
    v.as_mut().submatrix_mut(nb, nb, ni, n_m).copy_from(&phi);

    let project = |t: &[Triplet<usize, usize, c64>]| -> Result<HermitianMatrix, ReductionError> {
        let a = sparse(t, n, n)?;
        let av = &a * &v;
        let r = v.adjoint() * &av;
        Ok(to_hermitian(r.as_ref(), real))
    };
    let mass = project(&m_trip)?;
    let k0 = project(&k_trip)?;
    let k1 = match model.centrifugal {
        Some(c) => project(&map.harmonic_triplets(c, k)?)?,
        None => HermitianMatrix::real(DMatrix::zeros(nr, nr)),
    };
    let k2 = match model.centrifugal_quartic {
        Some(c) => project(&map.harmonic_triplets(c, k)?)?,
        None => HermitianMatrix::real(DMatrix::zeros(nr, nr)),
    };
    let block = HarmonicBlock {
        nodal_diameter: k,
        n_modes: n_m,
        mass,
        stiffness: [k0, k1, k2],
    };
    let modal = modal_data(&block, nb, real, &opts.omega_grid)
        .map_err(|source| ReductionError::Eigen { k, source })?;
    let points: Vec<usize> = opts.recovery_points.iter().map(|p| p.node).collect();
    let recovery = harmonic_recovery_rows(map, v.as_ref(), &points, k);
    let blade_rows = match model.blade {
        Some(blade) if opts.blade_modes > 0 => {
            Some(harmonic_recovery_rows(map, v.as_ref(), &blade.nodes, k))
        }
        _ => None,
    };
    Ok(HarmonicReduction {
        block,
        modal,
        fixed_interface_hz: lam.iter().map(|&l| signed_hz(l)).collect(),
        recovery,
        blade_rows,
    })
}

/// Natural frequency (Hz) of an eigenvalue λ = ω² ((rad/s)²); negative for λ < 0, which flags
/// a statically unstable (divergent) mode.
pub(crate) fn signed_hz(lambda: f64) -> f64 {
    lambda.signum() * lambda.abs().sqrt() / (2.0 * PI)
}

/// Free vibrations of a reduced harmonic block at each Ω: all frequencies (Hz, ascending) and
/// the boundary part of the reduced-mass-normalized eigenvectors (`ũ` at the contact nodes;
/// phase fixed so that the largest boundary component is real and positive).
pub fn modal_data(
    block: &HarmonicBlock,
    nb: usize,
    real: bool,
    omega_grid: &[f64],
) -> Result<ModalData, EigenError> {
    let grid: Vec<f64> = if omega_grid.is_empty() {
        vec![0.0]
    } else {
        omega_grid.to_vec()
    };
    let m = to_faer(&block.mass);
    let mut data = ModalData {
        nodal_diameter: block.nodal_diameter,
        omega: grid.clone(),
        frequencies: vec![],
        shapes_re: vec![],
        shapes_im: vec![],
    };
    for &w in &grid {
        let k = to_faer(&block.stiffness_at(w));
        let (lam, x) = dense_gen_eigen(k.as_ref(), m.as_ref(), real)?;
        data.frequencies
            .push(lam.iter().map(|&l| signed_hz(l)).collect());
        let (mut re, mut im) = (vec![], vec![]);
        for p in 0..lam.len() {
            let col = x.col(p);
            let (mut best, mut phase) = (0.0, c64::new(1.0, 0.0));
            for i in 0..nb {
                let a = col[i].norm();
                if a > best {
                    best = a;
                    phase = col[i].conj() / a;
                }
            }
            re.push((0..nb).map(|i| (col[i] * phase).re).collect());
            im.push((0..nb).map(|i| (col[i] * phase).im).collect());
        }
        data.shapes_re.push(re);
        data.shapes_im.push(im);
    }
    Ok(data)
}

/// The tuned modes of a harmonic block at rest below `cutoff_hz` (at least the first), as
/// columns in ROM coordinates, each mass-normalized and divided by its circular frequency
/// (its strain energy is then ½): the snapshots of
/// [`crate::model::mistuning`]'s blade shapes.
pub(crate) fn tuned_modes_below(
    block: &HarmonicBlock,
    real: bool,
    cutoff_hz: f64,
) -> Result<ComplexRows, EigenError> {
    let (k, m) = (to_faer(&block.stiffness[0]), to_faer(&block.mass));
    let (lam, x) = dense_gen_eigen(k.as_ref(), m.as_ref(), real)?;
    let limit = (std::f64::consts::TAU * cutoff_hz).powi(2);
    let kept = lam.iter().take_while(|&&l| l <= limit).count().max(1);
    if lam[..kept].iter().any(|&l| l <= 0.0) {
        return Err(EigenError::MassNotDefinite);
    }
    let n = x.nrows();
    let scale = |j: usize| 1.0 / lam[j].sqrt();
    Ok(ComplexRows {
        re: DMatrix::from_fn(n, kept, |i, j| x[(i, j)].re * scale(j)),
        im: DMatrix::from_fn(n, kept, |i, j| x[(i, j)].im * scale(j)),
    })
}

/// Hermitian part of a reduced matrix, as the ROM's (re, im) pair; exactly real for the real harmonics.
fn to_hermitian(a: MatRef<'_, c64>, real: bool) -> HermitianMatrix {
    let n = a.nrows();
    let h = |i: usize, j: usize| (a[(i, j)] + a[(j, i)].conj()) * 0.5;
    let re = DMatrix::from_fn(n, n, |i, j| h(i, j).re);
    let im = if real {
        DMatrix::zeros(n, n)
    } else {
        DMatrix::from_fn(n, n, |i, j| h(i, j).im)
    };
    HermitianMatrix { re, im }
}

/// A ROM Hermitian matrix as a faer complex matrix.
pub fn to_faer(h: &HermitianMatrix) -> Mat<c64> {
    Mat::from_fn(h.size(), h.size(), |i, j| {
        c64::new(h.re[(i, j)], h.im[(i, j)])
    })
}

/// Relative residual `‖K φ − λ M φ‖ / ‖K φ‖` to which each fixed-interface mode is converged:
/// the Craig–Bampton basis is then exact to far below the reduction's own truncation error.
const FIXED_INTERFACE_TOLERANCE: f64 = 1e-9;

/// Constraint modes `Ψ = −K_II⁻¹ K_IB` and the lowest `n_m` fixed-interface eigenpairs
/// (`M_II`-normalized) of nodal diameter `kd`, from one sparse Cholesky factor of `K_II`
/// ([`crate::model::sparse_eigen`]). The static responses to the boundary loads seed the
/// Krylov space.
fn interior_modes<T: Scalar>(
    k_ii: &SparseColMat<usize, T>,
    m_ii: &SparseColMat<usize, T>,
    mut k_ib: Mat<T>,
    n_m: usize,
    kd: usize,
) -> Result<(Mat<T>, Eigenpairs<T>), ReductionError> {
    let par = faer::get_global_parallelism();
    let to_error = |source| match source {
        SparseEigenError::StiffnessNotDefinite(detail) => {
            ReductionError::InteriorNotDefinite { k: kd, detail }
        }
        source => ReductionError::SparseEigen { k: kd, source },
    };
    let factor = CholeskyFactor::new(k_ii, par).map_err(to_error)?;
    let start = factor.solve_in_place(k_ib.as_mut());
    let psi = -k_ib;
    if n_m == 0 {
        let none = Eigenpairs {
            values: vec![],
            vectors: Mat::zeros(k_ii.nrows(), 0),
            stats: Default::default(),
        };
        return Ok((psi, none));
    }
    let pencil = Pencil {
        stiffness: k_ii,
        mass: m_ii,
        factor: &factor,
    };
    let eig_opts = SparseEigenOptions {
        tolerance: FIXED_INTERFACE_TOLERANCE,
        par,
    };
    let pairs = lowest_eigenpairs(&pencil, n_m, start.as_ref(), &eig_opts).map_err(to_error)?;
    Ok((psi, pairs))
}

/// The triplets of nodal diameter `k`'s harmonic stiffness at speed `w` (rad/s):
/// `K0 + w² K1 + w⁴ K2`, from those of K0 (`k_trip`).
fn triplets_at_speed(
    model: &SectorModel<'_>,
    map: &CyclicDofMap,
    k: usize,
    k_trip: &[Triplet<usize, usize, c64>],
    w: f64,
) -> Result<Vec<Triplet<usize, usize, c64>>, ReductionError> {
    let mut t = k_trip.to_vec();
    for (a, factor) in [
        (model.centrifugal, w * w),
        (model.centrifugal_quartic, w.powi(4)),
    ] {
        if let Some(a) = a {
            let scale = c64::new(factor, 0.0);
            let extra = map.harmonic_triplets(a, k)?;
            t.extend(
                extra
                    .into_iter()
                    .map(|e| Triplet::new(e.row, e.col, e.val * scale)),
            );
        }
    }
    Ok(t)
}

/// Constraint modes and the interior part of a Craig–Bampton basis.
struct InteriorBasis<T> {
    /// Constraint modes `Ψ = −K_II⁻¹ K_IB` (interior × boundary).
    psi: Mat<T>,
    /// Ritz values of `(K_II, M_II)` on `modes`, ascending, (rad/s)².
    ritz: Vec<f64>,
    /// `M_II`-orthonormal, `K_II`-diagonal interior modes.
    modes: Mat<T>,
}

/// Constraint modes `Ψ = −K_II⁻¹ K_IB`, and the interior basis with its Ritz values: the lowest
/// `n_m` fixed-interface modes of `(K_II, M_II)`, merged, when `at_speed` gives `K_II(Ω)` and
/// `K_IB(Ω)`, with those of `(K_II(Ω), M_II)` and with the change of the constraint modes
/// `Ψ(Ω) − Ψ` ([`merge_speed_modes`]): the initial-displacement stiffness changes the static
/// shapes near the boundary too, which no number of fixed-interface modes at rest represents.
fn fixed_interface_basis<T: Scalar>(
    k_ii: &SparseColMat<usize, T>,
    m_ii: &SparseColMat<usize, T>,
    k_ib: Mat<T>,
    at_speed: Option<(SparseColMat<usize, T>, Mat<T>)>,
    n_m: usize,
    kd: usize,
) -> Result<InteriorBasis<T>, ReductionError> {
    let (psi, pairs) = interior_modes(k_ii, m_ii, k_ib, n_m, kd)?;
    let Some((k_speed, k_ib_speed)) = at_speed.filter(|_| n_m > 0) else {
        return Ok(InteriorBasis {
            psi,
            ritz: pairs.values,
            modes: pairs.vectors,
        });
    };
    let (psi_speed, modes) = interior_modes(&k_speed, m_ii, k_ib_speed, n_m, kd)?;
    let shift = &psi_speed - &psi;
    let (ni, nm, nb) = (psi.nrows(), modes.vectors.ncols(), psi.ncols());
    let mut speed = Mat::<T>::zeros(ni, nm + nb);
    speed
        .as_mut()
        .submatrix_mut(0, 0, ni, nm)
        .copy_from(&modes.vectors);
    speed
        .as_mut()
        .submatrix_mut(0, nm, ni, nb)
        .copy_from(&shift);
    let (ritz, modes) = merge_speed_modes(k_ii, m_ii, pairs.vectors, speed)
        .map_err(|source| ReductionError::Eigen { k: kd, source })?;
    Ok(InteriorBasis { psi, ritz, modes })
}

/// Relative `M`-norm² below which a mode at speed adds nothing to the modes at rest.
const NEW_DIRECTION: f64 = 1e-8;

/// The union of an `M`-orthonormal interior basis `rest` and vectors `speed` as one basis:
/// the `speed` vectors are `M`-normalised and `M`-orthogonalised against `rest`, directions with less
/// than [`NEW_DIRECTION`] of new content are dropped, and a Rayleigh–Ritz step on `(K_II,
/// M_II)` makes the merged basis `M`-orthonormal and `K_II`-diagonal (its Ritz values
/// returned, ascending) as the fixed-interface modes it replaces.
fn merge_speed_modes<T: Scalar>(
    k_ii: &SparseColMat<usize, T>,
    m_ii: &SparseColMat<usize, T>,
    rest: Mat<T>,
    speed: Mat<T>,
) -> Result<(Vec<f64>, Mat<T>), EigenError> {
    let m_speed = m_ii * &speed;
    let norms: Vec<f64> = (0..speed.ncols())
        .map(|j| {
            let v: T = (0..speed.nrows())
                .map(|i| faer::traits::math_utils::conj(&speed[(i, j)]) * m_speed[(i, j)])
                .fold(T::zero_impl(), |a, b| a + b);
            faer::traits::math_utils::real(&v)
                .max(f64::MIN_POSITIVE)
                .sqrt()
        })
        .collect();
    let speed = Mat::<T>::from_fn(speed.nrows(), speed.ncols(), |i, j| {
        faer::traits::math_utils::mul_real(&speed[(i, j)], &(1.0 / norms[j]))
    });
    let coupling = rest.adjoint() * (m_ii * &speed);
    let residual = &speed - &rest * &coupling;
    let gram = residual.adjoint() * (m_ii * &residual);
    let evd = gram
        .self_adjoint_eigen(faer::Side::Lower)
        .map_err(|_| EigenError::NoConvergence)?;
    let s = evd.S().column_vector();
    let keep: Vec<usize> = (0..s.nrows())
        .filter(|&i| faer::traits::math_utils::real(&s[i]) > NEW_DIRECTION)
        .collect();
    let u = evd.U();
    let scaled = Mat::<T>::from_fn(u.nrows(), keep.len(), |i, j| {
        let sj = faer::traits::math_utils::real(&s[keep[j]]);
        faer::traits::math_utils::mul_real(&u[(i, keep[j])], &(1.0 / sj.sqrt()))
    });
    let extra = &residual * &scaled;
    let (ni, n0, n1) = (rest.nrows(), rest.ncols(), extra.ncols());
    let mut basis = Mat::<T>::zeros(ni, n0 + n1);
    basis.as_mut().submatrix_mut(0, 0, ni, n0).copy_from(&rest);
    basis
        .as_mut()
        .submatrix_mut(0, n0, ni, n1)
        .copy_from(&extra);
    let kb = basis.adjoint() * (k_ii * &basis);
    let mb = basis.adjoint() * (m_ii * &basis);
    let (lam, y) = crate::model::eigen::cholesky_route(kb.as_ref(), mb.as_ref(), true)?;
    Ok((lam, &basis * &y))
}

/// The real part of a sparse complex matrix (a real harmonic's matrices, whose imaginary
/// parts are zero).
fn real_part(a: &SparseColMat<usize, c64>) -> Result<SparseColMat<usize, f64>, ReductionError> {
    let symbolic = a
        .symbolic()
        .to_owned()
        .map_err(|e| CyclicError::Sparse(format!("{e:?}")))?;
    Ok(SparseColMat::new(
        symbolic,
        a.val().iter().map(|v| v.re).collect(),
    ))
}

/// A real matrix as a complex one.
fn to_complex(a: MatRef<'_, f64>) -> Mat<c64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| c64::new(a[(i, j)], 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::cyclic::test_support::{TrussSector, truss_sector};
    use nalgebra::DMatrix;

    fn model(s: &TrussSector) -> SectorModel<'_> {
        SectorModel {
            topology: s.topology(),
            nodes: &s.nodes,
            contact_nodes: &s.contact,
            stiffness: &s.k,
            mass: &s.m,
            centrifugal: Some(&s.k1),
            centrifugal_quartic: None,
            blade: None,
        }
    }

    fn opts(n_m: usize) -> ReductionOptions {
        ReductionOptions {
            modes_per_diameter: n_m,
            ..Default::default()
        }
    }

    /// Lowest eigenvalues of the unreduced harmonic-k sector problem with K0 + Ω² K1: dense for
    /// small sectors; the sparse solver (block Krylov on the Cholesky factor of K) for large
    /// ones, because the dense route (Cholesky of M, then a symmetric eigensolver on
    /// L⁻¹KL⁻ᴴ) loses the lowest eigenvalues of the built-in impeller (‖L⁻¹KL⁻ᴴ‖ ≈ 6e14 from
    /// nodes of 0.45 mg): it returned −7.4e7 rad²/s² for a positive definite pencil.
    fn unreduced(s: &TrussSector, k: usize, omega: f64) -> Vec<f64> {
        let map = CyclicDofMap::new(&s.topology(), &s.contact).unwrap();
        let k0 = map.harmonic_matrix(&s.k, k).unwrap();
        let k1 = map.harmonic_matrix(&s.k1, k).unwrap();
        let m = map.harmonic_matrix(&s.m, k).unwrap();
        let real = is_real_harmonic(k, s.n_sectors);
        if k0.nrows() <= 600 {
            let kw = k0.to_dense() + faer::Scale(c64::new(omega * omega, 0.0)) * k1.to_dense();
            return dense_gen_eigen(kw.as_ref(), m.to_dense().as_ref(), real)
                .unwrap()
                .0;
        }
        let w2 = omega * omega;
        let mut t: Vec<Triplet<usize, usize, c64>> = Vec::new();
        for (a, f) in [(&k0, 1.0), (&k1, w2)] {
            for j in 0..a.ncols() {
                for (i, &v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                    t.push(Triplet::new(i, j, v * f));
                }
            }
        }
        let kw = SparseColMat::try_new_from_triplets(k0.nrows(), k0.ncols(), &t).unwrap();
        let factor = CholeskyFactor::new(&kw, faer::Par::Seq).unwrap();
        let pencil = Pencil {
            stiffness: &kw,
            mass: &m,
            factor: &factor,
        };
        let start = Mat::<c64>::zeros(kw.nrows(), 0);
        lowest_eigenpairs(&pencil, 20, start.as_ref(), &SparseEigenOptions::new(1e-9))
            .unwrap()
            .values
    }

    fn reduced(block: &HarmonicBlock, omega: f64, real: bool) -> Vec<f64> {
        let k = to_faer(&block.stiffness_at(omega));
        let m = to_faer(&block.mass);
        dense_gen_eigen(k.as_ref(), m.as_ref(), real).unwrap().0
    }

    /// Compares reduced and unreduced frequencies below the cutoff; returns (worst relative
    /// error, number of compared modes). Rigid-body modes (|f| below 1e-4 of the top kept
    /// fixed-interface frequency) are compared absolutely on that scale.
    fn compare(rom: &CyclicRom, s: &TrussSector, omega: f64) -> (f64, usize) {
        let fi: Vec<Vec<f64>> =
            serde_json::from_value(rom.provenance["fixed_interface_hz"].clone()).unwrap();
        let (mut worst, mut count): (f64, usize) = (0.0, 0);
        for (k, block) in rom.harmonics.iter().enumerate() {
            let cutoff = accuracy_cutoff_hz(&fi[k]);
            let real = rom.is_real_harmonic(k);
            let exact: Vec<f64> = unreduced(s, k, omega).into_iter().map(signed_hz).collect();
            let red: Vec<f64> = reduced(block, omega, real)
                .into_iter()
                .map(signed_hz)
                .collect();
            for (p, (&fe, &fr)) in exact.iter().zip(&red).enumerate() {
                if fe > cutoff {
                    break;
                }
                // Craig–Bampton is a Rayleigh–Ritz method: the reduced frequencies bound the
                // exact ones from above (for the Ω = 0 pencil).
                if omega == 0.0 {
                    assert!(fr >= fe - 1e-9 * cutoff, "k = {k} mode {p}: {fr} < {fe}");
                }
                let err = (fr - fe).abs() / fe.abs().max(1e-4 * 2.0 * cutoff);
                worst = worst.max(err);
                count += 1;
            }
        }
        (worst, count)
    }

    #[test]
    fn craig_bampton_matches_unreduced_sector_below_cutoff() {
        for (casing_like, n_m) in [(true, 6), (false, 6), (true, 10), (false, 10)] {
            let s = truss_sector(8, casing_like);
            let rom = reduce_sector_model(&model(&s), &opts(n_m)).unwrap();
            let (worst, count) = compare(&rom, &s, 0.0);
            println!(
                "CB casing_like = {casing_like}, n_m = {n_m}: {count} modes below cutoff, worst relative error {worst:.2e}"
            );
            assert!(count >= rom.harmonics.len(), "too few modes compared");
            assert!(worst < 5e-3, "worst relative error {worst}");
        }
    }

    /// The built-in Hex20 sector of `mesh` in the shape the comparison helpers take.
    fn built_in(mesh: &SectorMesh, mats: &SectorMatrices) -> TrussSector {
        let n = mats.stiffness.nrows();
        TrussSector {
            n_sectors: mesh.n_sectors,
            nodes: mesh.nodes.clone(),
            left: mesh.left_nodes.clone(),
            right: mesh.right_nodes.clone(),
            clamped: mesh.clamped_nodes.clone(),
            contact: mesh.contact_nodes.clone(),
            k: mats.stiffness.clone(),
            m: mats.mass.clone(),
            k1: mats
                .centrifugal
                .clone()
                .unwrap_or_else(|| SparseColMat::try_new_from_triplets(n, n, &[]).unwrap()),
        }
    }

    #[test]
    fn built_in_models_match_their_unreduced_sectors() {
        use crate::model::fe::assemble_sector;
        use crate::model::mesh::{CasingGeometry, ImpellerGeometry};
        let casing = CasingGeometry {
            n_sectors: 8,
            ..CasingGeometry::default()
        }
        .build()
        .unwrap();
        let s = built_in(&casing, &assemble_sector(&casing, false).unwrap());
        let rom = reduce_sector_model(&model(&s), &opts(10)).unwrap();
        let (worst, count) = compare(&rom, &s, 0.0);
        println!(
            "built-in casing (N = 8): {count} modes below cutoff, worst relative error {worst:.2e}"
        );
        assert!(
            count >= rom.harmonics.len() && worst < 5e-3,
            "casing: {worst} over {count} modes"
        );

        let impeller = ImpellerGeometry {
            n_blades: 4,
            ..ImpellerGeometry::default()
        }
        .build()
        .unwrap();
        let s = built_in(&impeller, &assemble_sector(&impeller, true).unwrap());
        let rom = reduce_sector_model(&model(&s), &opts(10)).unwrap();
        for (omega, tol) in [(0.0, 5e-3), (3000.0, 1e-2)] {
            let (worst, count) = compare(&rom, &s, omega);
            println!(
                "built-in impeller (N_b = 4), Ω = {omega} rad/s: {count} modes below cutoff, worst relative error {worst:.2e}"
            );
            assert!(
                count >= rom.harmonics.len() && worst < tol,
                "impeller at {omega}: {worst} over {count} modes"
            );
        }
    }

    #[test]
    fn casing_mesh_convergence_of_the_first_frequencies() {
        use crate::model::fe::assemble_sector;
        use crate::model::mesh::CasingGeometry;
        // Nodal diameters 2–4 hold the casing's lowest frequencies; refine along the meridian
        // and around the sector together.
        let mut rows = vec![];
        for (meridian, around) in [(4, 1), (8, 1), (16, 2)] {
            let g = CasingGeometry {
                n_sectors: 100,
                elements_meridian: meridian,
                elements_circumferential: around,
                ..CasingGeometry::default()
            };
            let mesh = g.build().unwrap();
            let s = built_in(&mesh, &assemble_sector(&mesh, false).unwrap());
            let f: Vec<f64> = (2..=4)
                .map(|k| signed_hz(unreduced(&s, k, 0.0)[0]))
                .collect();
            println!(
                "casing mesh {meridian} × {around}: {} DOFs per sector, first frequency at k = 2, 3, 4: {f:.1?} Hz",
                mesh.n_dofs()
            );
            rows.push(f);
        }
        for (k, ((a, b), c)) in rows[0].iter().zip(&rows[1]).zip(&rows[2]).enumerate() {
            let (d1, d2) = ((b - a).abs(), (c - b).abs());
            assert!(
                d2 < d1,
                "nodal diameter {}: differences {d1} then {d2} Hz do not shrink",
                k + 2
            );
        }
    }

    #[test]
    fn centrifugal_rom_matches_prestressed_sector() {
        let s = truss_sector(8, true);
        let rom = reduce_sector_model(&model(&s), &opts(10)).unwrap();
        // Ω such that Ω²K1 shifts the lowest elastic frequencies by several percent.
        let omega = 300.0;
        let f0 = signed_hz(unreduced(&s, 2, 0.0)[0]);
        let fw = signed_hz(unreduced(&s, 2, omega)[0]);
        println!("k = 2 first frequency: {f0:.3} Hz at rest, {fw:.3} Hz at Ω = {omega} rad/s");
        assert!(
            (fw - f0).abs() > 0.01 * f0,
            "prestress must matter for the test to bite"
        );
        let (worst, count) = compare(&rom, &s, omega);
        println!("centrifugal: {count} modes below cutoff, worst relative error {worst:.2e}");
        assert!(count > 0);
        assert!(worst < 1e-2, "worst relative error {worst}");
    }

    type Trig = fn(f64) -> f64;

    /// Orthonormal real DFT over sectors (ARCH convention): harmonic coordinates = T u, u the
    /// stacked sector vectors of `nb` DOFs each.
    fn dft(n_sectors: usize, nb: usize) -> DMatrix<f64> {
        let mut t = DMatrix::zeros(n_sectors * nb, n_sectors * nb);
        let mut row = 0;
        for k in 0..=n_sectors / 2 {
            let real = k == 0 || 2 * k == n_sectors;
            let comps: Vec<(f64, Trig)> = if real {
                vec![((1.0 / n_sectors as f64).sqrt(), f64::cos as fn(f64) -> f64)]
            } else {
                let c = (2.0 / n_sectors as f64).sqrt();
                vec![
                    (c, f64::cos as fn(f64) -> f64),
                    (c, f64::sin as fn(f64) -> f64),
                ]
            };
            for (c, f) in comps {
                for d in 0..nb {
                    for s in 0..n_sectors {
                        let th = 2.0 * PI * (k * s) as f64 / n_sectors as f64;
                        t[(row + d, s * nb + d)] = c * f(th);
                    }
                }
                row += nb;
            }
        }
        t
    }

    /// Physical boundary block of the assembled ROM: Tᵀ blockdiag(real_form(C_k,bb)) T.
    fn physical_boundary(
        rom: &CyclicRom,
        pick: impl Fn(&HarmonicBlock) -> &HermitianMatrix,
    ) -> DMatrix<f64> {
        let nb = rom.n_boundary();
        let n = rom.n_sectors * nb;
        let mut d = DMatrix::zeros(n, n);
        let mut at = 0;
        for (k, h) in rom.harmonics.iter().enumerate() {
            let c = pick(h);
            let bb = HermitianMatrix {
                re: c.re.view((0, 0), (nb, nb)).into_owned(),
                im: c.im.view((0, 0), (nb, nb)).into_owned(),
            };
            let r = bb.real_form(rom.is_real_harmonic(k));
            let m = r.nrows();
            d.view_mut((at, at), (m, m)).copy_from(&r);
            at += m;
        }
        let t = dft(rom.n_sectors, nb);
        t.transpose() * d * t
    }

    #[test]
    fn rom_is_valid_hermitian_and_its_boundary_equals_full_360_condensation() {
        let s = truss_sector(6, true);
        let rom = reduce_sector_model(&model(&s), &opts(6)).unwrap();
        rom.validate().unwrap();
        assert_eq!(rom.harmonics.len(), 4);
        assert_eq!(rom.modal_data.len(), 4);
        for k in [0, 3] {
            assert_eq!(rom.harmonics[k].stiffness[0].im.amax(), 0.0);
        }
        assert!(rom.harmonics[1].stiffness[0].im.amax() > 0.0);

        // Independent reference: the full 360° model statically condensed onto the contact
        // DOFs of every sector (Guyan stiffness), and its Guyan mass.
        let map = CyclicDofMap::new(&s.topology(), &s.contact).unwrap();
        let to_na = |a: &SparseColMat<usize, f64>| {
            let d = map.assemble_full(a).unwrap().to_dense();
            DMatrix::from_fn(d.nrows(), d.ncols(), |i, j| d[(i, j)])
        };
        let (kf, mf) = (to_na(&s.k), to_na(&s.m));
        let (ni, nb, n_sec) = (map.n_independent(), map.n_first(), s.n_sectors);
        let bset: Vec<usize> = (0..n_sec)
            .flat_map(|sec| (0..nb).map(move |j| sec * ni + j))
            .collect();
        let iset: Vec<usize> = (0..kf.nrows()).filter(|i| !bset.contains(i)).collect();
        let sub = |a: &DMatrix<f64>, r: &[usize], c: &[usize]| {
            DMatrix::from_fn(r.len(), c.len(), |i, j| a[(r[i], c[j])])
        };
        let kii = sub(&kf, &iset, &iset).cholesky().unwrap();
        let psi = -kii.solve(&sub(&kf, &iset, &bset));
        let guyan_k = sub(&kf, &bset, &bset) + sub(&kf, &bset, &iset) * &psi;
        let mut basis = DMatrix::zeros(kf.nrows(), bset.len());
        for (j, &b) in bset.iter().enumerate() {
            basis[(b, j)] = 1.0;
        }
        for (r, &i) in iset.iter().enumerate() {
            for j in 0..bset.len() {
                basis[(i, j)] = psi[(r, j)];
            }
        }
        let guyan_m = basis.transpose() * &mf * &basis;

        let kp = physical_boundary(&rom, |h| &h.stiffness[0]);
        let mp = physical_boundary(&rom, |h| &h.mass);
        let rel = |a: &DMatrix<f64>, b: &DMatrix<f64>| (a - b).amax() / b.amax();
        println!(
            "physical boundary vs full-360 condensation: K {:.2e}, M {:.2e}",
            rel(&kp, &guyan_k),
            rel(&mp, &guyan_m)
        );
        assert!(rel(&kp, &guyan_k) < 1e-9);
        assert!(rel(&mp, &guyan_m) < 1e-9);
        // Block-circulant: block (s, s') depends on s' − s only.
        let n = kp.nrows();
        for i in 0..n {
            for j in 0..n {
                let (ip, jp) = ((i + nb) % n, (j + nb) % n);
                assert!((kp[(i, j)] - kp[(ip, jp)]).abs() <= 1e-9 * kp.amax());
            }
        }
    }

    /// The fixed-interface modes of every harmonic (real and complex) from the sparse solver
    /// against the dense solver of `model::eigen` on the same interior pencil.
    #[test]
    fn sparse_eigensolver_agrees_with_dense_eigensolver() {
        let s = truss_sector(8, false);
        let m = model(&s);
        let o = opts(6);
        let rom = reduce_sector_model(&m, &o).unwrap();
        let map = boundary_first_map(&m, &o).unwrap();
        let fi: Vec<Vec<f64>> =
            serde_json::from_value(rom.provenance["fixed_interface_hz"].clone()).unwrap();
        let nb = map.n_first();
        for (k, sparse_hz) in fi.iter().enumerate() {
            let interior = |a: &SparseColMat<usize, f64>| {
                let d = map.harmonic_matrix(a, k).unwrap().to_dense();
                d.submatrix(nb, nb, d.nrows() - nb, d.ncols() - nb)
                    .to_owned()
            };
            let (kk, mm) = (interior(&s.k), interior(&s.m));
            assert!(
                kk.nrows() > 4 * 6,
                "the interior must not be trivially small"
            );
            let real = is_real_harmonic(k, s.n_sectors);
            let dense = dense_gen_eigen(kk.as_ref(), mm.as_ref(), real).unwrap().0;
            assert_eq!(sparse_hz.len(), 6);
            for (x, &l) in sparse_hz.iter().zip(&dense) {
                let y = signed_hz(l);
                assert!((x - y).abs() <= 1e-9 * y, "k = {k}: {x} vs {y}");
            }
        }
    }

    #[test]
    fn modal_data_is_mass_normalized_and_ascending() {
        let s = truss_sector(6, false);
        let o = ReductionOptions {
            omega_grid: vec![0.0, 200.0],
            component: Component::Impeller,
            ..opts(6)
        };
        let rom = reduce_sector_model(&model(&s), &o).unwrap();
        let nb = rom.n_boundary();
        for (k, md) in rom.modal_data.iter().enumerate() {
            assert_eq!(md.omega, vec![0.0, 200.0]);
            for (i, &w) in md.omega.iter().enumerate() {
                let f = &md.frequencies[i];
                assert!(f.windows(2).all(|p| p[0] <= p[1]));
                let exact: Vec<f64> = reduced(&rom.harmonics[k], w, rom.is_real_harmonic(k))
                    .into_iter()
                    .map(signed_hz)
                    .collect();
                for (a, b) in f.iter().zip(&exact) {
                    assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0));
                }
                assert_eq!(md.shapes_re[i].len(), f.len());
                assert_eq!(md.shapes_re[i][0].len(), nb);
                if rom.is_real_harmonic(k) {
                    assert!(md.shapes_im[i].iter().flatten().all(|&x| x == 0.0));
                }
            }
        }
        // Mass normalization: a boundary-only shape φ_B cannot be checked alone, so check the
        // full reduced eigenvector norm through the solver it came from.
        let h = &rom.harmonics[1];
        let (_, x) = dense_gen_eigen(
            to_faer(&h.stiffness[0]).as_ref(),
            to_faer(&h.mass).as_ref(),
            false,
        )
        .unwrap();
        let g = x.adjoint() * to_faer(&h.mass) * &x;
        for i in 0..g.nrows() {
            for j in 0..g.ncols() {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((g[(i, j)] - c64::new(e, 0.0)).norm() < 1e-8);
            }
        }
    }

    #[test]
    fn rejects_bad_input() {
        let s = truss_sector(6, true);
        let mut m = model(&s);
        let none: [usize; 0] = [];
        m.contact_nodes = &none;
        assert!(matches!(
            reduce_sector_model(&m, &opts(4)),
            Err(ReductionError::NoContactNodes)
        ));
        let m = model(&s);
        assert!(matches!(
            reduce_sector_model(&m, &opts(0)),
            Err(ReductionError::NoModes)
        ));
        let o = ReductionOptions {
            omega_grid: vec![f64::NAN],
            ..opts(4)
        };
        assert!(matches!(
            reduce_sector_model(&m, &o),
            Err(ReductionError::BadOmega { .. })
        ));
        let clamped = [0];
        let mut m = model(&s);
        m.contact_nodes = &clamped;
        assert!(matches!(
            reduce_sector_model(&m, &opts(4)),
            Err(ReductionError::Cyclic(
                CyclicError::DependentFirstNode { .. }
            ))
        ));
    }
}

#[cfg(test)]
mod exactness_tests {
    use super::*;
    use crate::model::cyclic::test_support::truss_sector;

    /// Keeping every fixed-interface mode makes the Craig–Bampton basis complete: the reduced
    /// spectrum must then equal the unreduced harmonic spectrum.
    #[test]
    fn complete_basis_reproduces_the_harmonic_spectrum() {
        let s = truss_sector(6, true);
        let model = SectorModel {
            topology: s.topology(),
            nodes: &s.nodes,
            contact_nodes: &s.contact,
            stiffness: &s.k,
            mass: &s.m,
            centrifugal: None,
            centrifugal_quartic: None,
            blade: None,
        };
        let o = ReductionOptions {
            modes_per_diameter: 10_000,
            ..Default::default()
        };
        let map = boundary_first_map(&model, &o).unwrap();
        for k in 0..=3 {
            let real = is_real_harmonic(k, 6);
            let r = reduce_harmonic(&model, &map, k, &o).unwrap();
            let kk = map.harmonic_matrix(&s.k, k).unwrap().to_dense();
            let mm = map.harmonic_matrix(&s.m, k).unwrap().to_dense();
            let exact = dense_gen_eigen(kk.as_ref(), mm.as_ref(), real).unwrap().0;
            let red = dense_gen_eigen(
                to_faer(&r.block.stiffness[0]).as_ref(),
                to_faer(&r.block.mass).as_ref(),
                real,
            )
            .unwrap()
            .0;
            assert_eq!(exact.len(), red.len());
            for (a, b) in exact.iter().zip(&red) {
                assert!((a - b).abs() <= 1e-8 * a.abs(), "k = {k}: {a} vs {b}");
            }
        }
    }
}
