//! Craig–Bampton reduction of a single, non-cyclic component given by sparse FE matrices
//! (typically imported from CalculiX or Matrix Market files, see [`crate::io::calculix`]).
//!
//! The result is a [`CyclicRom`] with `n_sectors = 1`: one harmonic block (k = 0) with real
//! matrices over `[3 n_c contact-node DOFs (node-major x, y, z); n_m fixed-interface modes]`
//! (DESIGN §2.4, Craig–Bampton as in §2.1 of Batailly & Legrand 2015).
//!
//! # Method
//! With the DOFs split into boundary `b` (the contact nodes' DOFs, kept physically) and
//! interior `i`, the reduction basis is
//! `T = [[I, 0], [Ψ, Φ]]`, `Ψ = −K_ii⁻¹ K_ib` (static constraint modes) and `Φ` the lowest
//! `n_m` eigenvectors of `K_ii φ = λ M_ii φ` (fixed-interface modes, mass-normalized).
//! `K_ii` is factored once, `P K_ii Pᵀ = L Lᵀ` (sparse supernodal Cholesky,
//! [`crate::model::sparse_eigen::CholeskyFactor`]); the constraint modes are solves with that
//! factor, and the fixed-interface modes come from the sparse generalized eigensolver on the
//! same factor ([`crate::model::sparse_eigen::lowest_eigenpairs`]: block Krylov–Rayleigh–Ritz
//! on the shift-invert operator, started from the static responses `L⁻¹ P K_ib`, each mode
//! converged to the relative residual [`ComponentReductionOptions::eigen_tolerance`]).
//! Finally `K_r = Tᵀ K T`, `M_r = Tᵀ M T` (dense, symmetrized).
//!
//! # Rotation speed
//! The imported matrices describe the component at rest: the ROM gets `K1 = K2 = 0`.
//! Centrifugal stiffening and spin softening need the FE code's matrices at three speeds
//! `Ω_a, Ω_b, Ω_c` (e.g. CalculiX `*STATIC` prestress + `*FREQUENCY, SOLVER=MATRIXSTORAGE`
//! with `PERTURBATION` at each speed). The hook for that is
//! [`speed_polynomial_from_samples`]: project each speed's stiffness with the same basis
//! (e.g. [`project`] with the `T` of the reference speed) and fit `K0, K1, K2` exactly.

use crate::model::eigen::symmetric_gen_eigen;
use crate::model::rom::{
    ComplexRows, Component, ContactNode, CyclicRom, Damping, HarmonicBlock, HermitianMatrix,
    ModalData, Recovery, RecoveryNode,
};
use crate::model::sparse_eigen::{
    CholeskyFactor, Pencil, SparseEigenError, SparseEigenOptions, hermitian_spmm_t,
    lowest_eigenpairs,
};
use faer::Mat;
use faer::prelude::*;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use nalgebra::DMatrix;
use std::collections::HashMap;
use thiserror::Error;

/// One row (= column) of an FE matrix: a node id (as numbered in the FE model) and a
/// direction 0, 1, 2 = x, y, z of the global frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct NodeDof {
    /// Node id of the FE model (any numbering, not necessarily contiguous).
    pub node: usize,
    /// Direction 0 = x, 1 = y, 2 = z.
    pub dir: usize,
}

/// Sparse FE matrices of a component, full (both triangles) storage, SI units.
/// DOFs that the FE model clamps are simply absent.
#[derive(Clone, Debug)]
pub struct ComponentMatrices {
    /// Stiffness K (N/m), symmetric positive definite.
    pub stiffness: SparseColMat<usize, f64>,
    /// Consistent mass M (kg), symmetric positive definite.
    pub mass: SparseColMat<usize, f64>,
    /// Meaning of each row/column.
    pub dofs: Vec<NodeDof>,
}

/// A contact node to keep as boundary DOFs: FE node id and reference position (m).
#[derive(Clone, Debug, PartialEq)]
pub struct ContactPoint {
    /// Node id of the FE model.
    pub node: usize,
    /// Position in the global frame (m).
    pub position: [f64; 3],
}

/// Options of [`reduce_component`].
#[derive(Clone, Debug)]
pub struct ComponentReductionOptions {
    /// Name stored in the ROM.
    pub name: String,
    /// Impeller (rotating frame) or casing (fixed frame).
    pub component: Component,
    /// Number n_m of fixed-interface modes to keep (≥ 1).
    pub n_modes: usize,
    /// Damping model stored in the ROM.
    pub damping: Damping,
    /// Convergence tolerance of the fixed-interface modes: largest relative residual
    /// `‖K_ii φ − λ M_ii φ‖ / ‖K_ii φ‖` of each mode ([`crate::model::sparse_eigen`]). The
    /// modes only span the reduction basis (the reduced matrices are the exact projections)
    /// and Ritz values are accurate to the square of the residual, so 1e-5 is ample.
    pub eigen_tolerance: f64,
    /// FE nodes whose rows of the reduction basis `T` are kept in the ROM (its
    /// [`Recovery`]), so that their displacement can be recovered from the ROM coordinates.
    pub recovery_nodes: Vec<ContactPoint>,
}

impl Default for ComponentReductionOptions {
    fn default() -> Self {
        Self {
            name: "component".into(),
            component: Component::Impeller,
            n_modes: 20,
            damping: Damping::default(),
            eigen_tolerance: 1e-5,
            recovery_nodes: Vec::new(),
        }
    }
}

/// Why a component cannot be reduced.
#[derive(Debug, Error, PartialEq)]
pub enum ComponentError {
    /// An FE matrix is not square with one row per DOF of the DOF map.
    #[error("{what} is {rows}×{cols}, expected {n}×{n} (one row per DOF of the DOF map)")]
    Size {
        /// Which matrix: `"stiffness"` or `"mass"`.
        what: &'static str,
        /// Its number of rows.
        rows: usize,
        /// Its number of columns.
        cols: usize,
        /// The expected size: the number of DOFs in the DOF map.
        n: usize,
    },
    /// A contact node lacks one of its x, y, z DOFs in the DOF map.
    #[error(
        "contact node {node} has no {axis} DOF in the model (clamped or absent from the DOF map)"
    )]
    ContactDofMissing {
        /// FE node id of the contact node.
        node: usize,
        /// The missing direction: `'x'`, `'y'` or `'z'`.
        axis: char,
    },
    /// The same contact node is given twice.
    #[error("contact node {node} is listed twice")]
    DuplicateContactNode {
        /// FE node id of the repeated node.
        node: usize,
    },
    /// A recovery node has no DOF in the DOF map.
    #[error("recovery node {node} has no DOF in the model (clamped or absent from the DOF map)")]
    RecoveryNodeMissing {
        /// FE node id of the recovery node.
        node: usize,
    },
    /// The same recovery node is given twice.
    #[error("recovery node {node} is listed twice")]
    DuplicateRecoveryNode {
        /// FE node id of the repeated node.
        node: usize,
    },
    /// The list of contact nodes is empty.
    #[error("no contact nodes given")]
    NoContactNodes,
    /// The requested number of fixed-interface modes is 0 or exceeds the interior DOFs.
    #[error("n_modes = {n_modes}: must be between 1 and the {n_interior} interior DOFs")]
    ModeCount {
        /// The requested number of fixed-interface modes.
        n_modes: usize,
        /// The number of interior (non-contact) DOFs.
        n_interior: usize,
    },
    /// The Cholesky factorization of the interior stiffness `K_ii` failed (holds its message).
    #[error(
        "the interior stiffness K_ii is not positive definite (is the component clamped?): {0}"
    )]
    NotPositiveDefinite(String),
    /// The sparse eigensolver of the fixed-interface modes failed (e.g. did not converge, or
    /// the mass matrix is not positive definite on the modes).
    #[error("fixed-interface modes: {0}")]
    Eigen(SparseEigenError),
    /// The dense generalized eigenproblem of the reduced model failed (holds its message).
    #[error("dense eigen-solution of the reduced model failed: {0}")]
    ReducedEigen(String),
    /// A sparse-matrix operation (e.g. symbolic Cholesky) failed (holds its message).
    #[error("sparse matrix: {0}")]
    Sparse(String),
    /// Two entries at the same matrix position.
    #[error("duplicate entry ({row}, {col}) (1-based; mirrored entries count as the same)")]
    DuplicateEntry {
        /// Row of the entry (1-based; the smaller of the two indices).
        row: usize,
        /// Column of the entry (1-based; the larger of the two indices).
        col: usize,
    },
    /// Invalid speed samples for [`speed_polynomial_from_samples`] (holds the reason).
    #[error("speed samples: {0}")]
    SpeedSamples(String),
}

/// Builds a full-storage `n × n` sparse matrix from entries `(row, col, value)` (0-based).
/// With `mirror`, each off-diagonal entry is also stored at `(col, row)` (input = one
/// triangle of a symmetric matrix). Duplicate positions are an error.
pub fn sparse_from_entries(
    n: usize,
    entries: &[(u32, u32, f64)],
    mirror: bool,
) -> Result<SparseColMat<usize, f64>, ComponentError> {
    let mut count = vec![0usize; n + 1];
    for &(r, c, _) in entries {
        count[c as usize + 1] += 1;
        if mirror && r != c {
            count[r as usize + 1] += 1;
        }
    }
    for j in 0..n {
        count[j + 1] += count[j];
    }
    let col_ptr = count.clone();
    let nnz = col_ptr[n];
    let mut next = count;
    let mut row_idx = vec![0usize; nnz];
    let mut val = vec![0.0f64; nnz];
    let mut push = |r: usize, c: usize, v: f64| {
        let p = next[c];
        row_idx[p] = r;
        val[p] = v;
        next[c] += 1;
    };
    for &(r, c, v) in entries {
        push(r as usize, c as usize, v);
        if mirror && r != c {
            push(c as usize, r as usize, v);
        }
    }
    let mut buf: Vec<(usize, f64)> = Vec::new();
    for j in 0..n {
        let range = col_ptr[j]..col_ptr[j + 1];
        if row_idx[range.clone()].windows(2).all(|w| w[0] < w[1]) {
            continue;
        }
        buf.clear();
        buf.extend(range.clone().map(|p| (row_idx[p], val[p])));
        buf.sort_unstable_by_key(|e| e.0);
        for (k, p) in range.enumerate() {
            if k > 0 && buf[k].0 == buf[k - 1].0 {
                return Err(ComponentError::DuplicateEntry {
                    row: buf[k].0.min(j) + 1,
                    col: buf[k].0.max(j) + 1,
                });
            }
            row_idx[p] = buf[k].0;
            val[p] = buf[k].1;
        }
    }
    let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    Ok(SparseColMat::new(symbolic, val))
}

/// Copies `a` scaled by `factor` (unit conversion).
pub fn scaled(a: &SparseColMat<usize, f64>, factor: f64) -> SparseColMat<usize, f64> {
    let val: Vec<f64> = a.val().iter().map(|v| v * factor).collect();
    SparseColMat::new(a.symbolic().to_owned().expect("allocation"), val)
}

/// The sub-matrix `a[rows, cols]` where `row_map[g] = Some(local row)` and `cols` lists the
/// global columns in local order; with `lower_only`, only entries with local row ≥ local
/// column are kept. `row_map` must be increasing on its `Some` entries (keeps rows sorted).
fn extract(
    a: &SparseColMat<usize, f64>,
    row_map: &[Option<usize>],
    n_rows: usize,
    cols: &[usize],
    lower_only: bool,
) -> SparseColMat<usize, f64> {
    let mut col_ptr = Vec::with_capacity(cols.len() + 1);
    col_ptr.push(0usize);
    let (mut row_idx, mut val) = (Vec::new(), Vec::new());
    for (lc, &gc) in cols.iter().enumerate() {
        for (gr, &v) in a.row_idx_of_col(gc).zip(a.val_of_col(gc)) {
            if let Some(lr) = row_map[gr]
                && (!lower_only || lr >= lc)
            {
                row_idx.push(lr);
                val.push(v);
            }
        }
        col_ptr.push(row_idx.len());
    }
    let symbolic = SymbolicSparseColMat::new_checked(n_rows, cols.len(), col_ptr, None, row_idx);
    SparseColMat::new(symbolic, val)
}

/// `Tᵀ A T` for a sparse symmetric `A` (full storage) and a dense basis `T` (n × r), symmetrized.
pub fn project(a: &SparseColMat<usize, f64>, t: MatRef<'_, f64>) -> DMatrix<f64> {
    let tt = t.transpose().to_owned();
    let mut yt = Mat::<f64>::zeros(t.ncols(), t.nrows());
    hermitian_spmm_t(a, tt.as_ref(), yt.as_mut());
    let r = &yt * t;
    let k = r.ncols();
    DMatrix::from_fn(k, k, |i, j| 0.5 * (r[(i, j)] + r[(j, i)]))
}

/// Lowest `count` eigenpairs of the dense symmetric-definite pencil `(k, m)`:
/// frequencies (Hz) ascending and `m`-normalized eigenvectors (columns).
pub fn dense_modes(
    k: &DMatrix<f64>,
    m: &DMatrix<f64>,
    count: usize,
) -> Result<(Vec<f64>, DMatrix<f64>), ComponentError> {
    let (lambdas, x) = dense_eigen(k, m, count)?;
    let freqs = lambdas
        .iter()
        .map(|l| l.max(0.0).sqrt() / (2.0 * std::f64::consts::PI))
        .collect();
    Ok((freqs, x))
}

/// Lowest `count` eigenvalues λ (ascending) and `m`-normalized eigenvectors of `k x = λ m x`.
fn dense_eigen(
    k: &DMatrix<f64>,
    m: &DMatrix<f64>,
    count: usize,
) -> Result<(Vec<f64>, DMatrix<f64>), ComponentError> {
    let (mut lambdas, x) =
        symmetric_gen_eigen(k, m).map_err(|e| ComponentError::ReducedEigen(e.to_string()))?;
    let count = count.min(lambdas.len());
    lambdas.truncate(count);
    Ok((lambdas, x.columns(0, count).into_owned()))
}

/// Exact fit of `K(Ω) = K0 + Ω² K1 + Ω⁴ K2` through reduced stiffness matrices at three
/// distinct speeds (rad/s): the hook for centrifugal effects of imported models (see module
/// doc). Returns `[K0, K1, K2]` in N/m, N/m/(rad/s)², N/m/(rad/s)⁴.
pub fn speed_polynomial_from_samples(
    samples: &[(f64, DMatrix<f64>); 3],
) -> Result<[DMatrix<f64>; 3], ComponentError> {
    let x: Vec<f64> = samples.iter().map(|s| s.0 * s.0).collect();
    let shape = samples[0].1.shape();
    if samples.iter().any(|s| s.1.shape() != shape) {
        return Err(ComponentError::SpeedSamples(
            "matrices of different sizes".into(),
        ));
    }
    if (x[0] - x[1]).abs() * (x[1] - x[2]).abs() * (x[0] - x[2]).abs() == 0.0
        || x.iter().any(|v| !v.is_finite())
    {
        return Err(ComponentError::SpeedSamples(
            "the three speeds must be finite with distinct Ω²".into(),
        ));
    }
    // Lagrange interpolation in Ω²: K(x) = Σ_a K_a Π_{b≠a} (x − x_b)/(x_a − x_b).
    let mut out = [
        DMatrix::zeros(shape.0, shape.1),
        DMatrix::zeros(shape.0, shape.1),
        DMatrix::zeros(shape.0, shape.1),
    ];
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let d = (x[a] - x[b]) * (x[a] - x[c]);
        // (x − x_b)(x − x_c) = x_b x_c − (x_b + x_c) x + x².
        let coef = [x[b] * x[c] / d, -(x[b] + x[c]) / d, 1.0 / d];
        for (o, cf) in out.iter_mut().zip(coef) {
            *o += &samples[a].1 * cf;
        }
    }
    Ok(out)
}

/// Craig–Bampton reduction of a clamped component with the contact nodes' DOFs kept
/// (see the module documentation): a one-sector, k = 0 [`CyclicRom`] at rest (K1 = K2 = 0),
/// with the modal data (lowest `n_modes` frequencies of the reduced model, Hz, and their
/// mass-normalized shapes at the contact DOFs) at Ω = 0. `contacts` is in row order
/// (leading → trailing edge). `provenance` is left `null` for the caller to fill.
pub fn reduce_component(
    mats: &ComponentMatrices,
    contacts: &[ContactPoint],
    opts: &ComponentReductionOptions,
) -> Result<CyclicRom, ComponentError> {
    let n = mats.dofs.len();
    for (what, a) in [("stiffness", &mats.stiffness), ("mass", &mats.mass)] {
        if a.nrows() != n || a.ncols() != n {
            return Err(ComponentError::Size {
                what,
                rows: a.nrows(),
                cols: a.ncols(),
                n,
            });
        }
    }
    if contacts.is_empty() {
        return Err(ComponentError::NoContactNodes);
    }
    let index: HashMap<NodeDof, usize> =
        mats.dofs.iter().enumerate().map(|(i, d)| (*d, i)).collect();
    let mut boundary = Vec::with_capacity(3 * contacts.len());
    let mut is_boundary = vec![false; n];
    for c in contacts {
        for dir in 0..3 {
            let &g = index.get(&NodeDof { node: c.node, dir }).ok_or(
                ComponentError::ContactDofMissing {
                    node: c.node,
                    axis: ['x', 'y', 'z'][dir],
                },
            )?;
            if is_boundary[g] {
                return Err(ComponentError::DuplicateContactNode { node: c.node });
            }
            is_boundary[g] = true;
            boundary.push(g);
        }
    }
    let interior: Vec<usize> = (0..n).filter(|&g| !is_boundary[g]).collect();
    let (nb, ni) = (boundary.len(), interior.len());
    if opts.n_modes == 0 || opts.n_modes > ni {
        return Err(ComponentError::ModeCount {
            n_modes: opts.n_modes,
            n_interior: ni,
        });
    }
    let mut imap = vec![None; n];
    for (l, &g) in interior.iter().enumerate() {
        imap[g] = Some(l);
    }
    let k_ii = extract(&mats.stiffness, &imap, ni, &interior, false);
    let m_ii = extract(&mats.mass, &imap, ni, &interior, false);
    let to_error = |e| match e {
        SparseEigenError::StiffnessNotDefinite(detail) => {
            ComponentError::NotPositiveDefinite(detail)
        }
        e => ComponentError::Eigen(e),
    };
    let factor = CholeskyFactor::new(&k_ii, faer::get_global_parallelism()).map_err(to_error)?;

    // Constraint modes Ψ = −K_ii⁻¹ K_ib.
    let k_ib = extract(&mats.stiffness, &imap, ni, &boundary, false);
    let mut psi = k_ib.to_dense();
    drop(k_ib);
    // `L⁻¹ P K_ib = Lᵀ P K_ii⁻¹ K_ib`: the static responses to boundary loads in the space of
    // the shift-invert operator, dominated by low modes: a good start for the Krylov space.
    let start = factor.solve_in_place(psi.as_mut());
    let pencil = Pencil {
        stiffness: &k_ii,
        mass: &m_ii,
        factor: &factor,
    };
    let phi = lowest_eigenpairs(
        &pencil,
        opts.n_modes,
        start.as_ref(),
        &SparseEigenOptions::new(opts.eigen_tolerance),
    )
    .map_err(to_error)?
    .vectors;
    drop((k_ii, m_ii, factor, start));

    // T over the original DOF ordering; columns [boundary (3 n_c); modes (n_m)].
    let nr = nb + opts.n_modes;
    let mut t = Mat::<f64>::zeros(n, nr);
    for (c, &g) in boundary.iter().enumerate() {
        t[(g, c)] = 1.0;
    }
    for (l, &g) in interior.iter().enumerate() {
        for c in 0..nb {
            t[(g, c)] = -psi[(l, c)];
        }
        for c in 0..opts.n_modes {
            t[(g, nb + c)] = phi[(l, c)];
        }
    }
    drop(psi);
    drop(phi);
    let k_r = project(&mats.stiffness, t.as_ref());
    let m_r = project(&mats.mass, t.as_ref());
    let recovery = recovery_rows(&index, t.as_ref(), &opts.recovery_nodes)?;
    drop(t);

    let (freqs, shapes) = dense_modes(&k_r, &m_r, opts.n_modes)?;
    let shapes_re: Vec<Vec<f64>> = (0..freqs.len())
        .map(|p| (0..nb).map(|r| shapes[(r, p)]).collect())
        .collect();
    let shapes_im = vec![vec![0.0; nb]; freqs.len()];
    let zeros = DMatrix::zeros(nr, nr);
    Ok(CyclicRom {
        name: opts.name.clone(),
        component: opts.component,
        n_sectors: 1,
        contact_nodes: contacts
            .iter()
            .enumerate()
            .map(|(row, c)| ContactNode {
                position: c.position,
                row,
                id: Some(c.node),
            })
            .collect(),
        harmonics: vec![HarmonicBlock {
            nodal_diameter: 0,
            n_modes: opts.n_modes,
            mass: HermitianMatrix::real(m_r),
            stiffness: [
                HermitianMatrix::real(k_r),
                HermitianMatrix::real(zeros.clone()),
                HermitianMatrix::real(zeros),
            ],
        }],
        modal_data: vec![ModalData {
            nodal_diameter: 0,
            omega: vec![0.0],
            frequencies: vec![freqs],
            shapes_re: vec![shapes_re],
            shapes_im: vec![shapes_im],
        }],
        damping: opts.damping,
        provenance: serde_json::Value::Null,
        recovery,
        blade_modes: Default::default(),
    })
}

/// The rows `T(node dofs, :)` of the reduction basis for each of `nodes` (x, y, z of the model
/// frame, node-major); a DOF absent from the DOF map is clamped, its row zero. A node none of
/// whose DOFs is in the model is refused (most likely a wrong id).
fn recovery_rows(
    index: &HashMap<NodeDof, usize>,
    t: MatRef<'_, f64>,
    nodes: &[ContactPoint],
) -> Result<Recovery, ComponentError> {
    if nodes.is_empty() {
        return Ok(Recovery::default());
    }
    let nr = 3 * nodes.len();
    let mut re = DMatrix::zeros(nr, t.ncols());
    let mut seen = std::collections::HashSet::new();
    for (i, p) in nodes.iter().enumerate() {
        if !seen.insert(p.node) {
            return Err(ComponentError::DuplicateRecoveryNode { node: p.node });
        }
        let mut any = false;
        for dir in 0..3 {
            if let Some(&g) = index.get(&NodeDof { node: p.node, dir }) {
                any = true;
                for c in 0..t.ncols() {
                    re[(3 * i + dir, c)] = t[(g, c)];
                }
            }
        }
        if !any {
            return Err(ComponentError::RecoveryNodeMissing { node: p.node });
        }
    }
    Ok(Recovery {
        nodes: nodes
            .iter()
            .map(|p| RecoveryNode {
                id: p.node,
                position: p.position,
                name: None,
            })
            .collect(),
        rows: vec![ComplexRows {
            im: DMatrix::zeros(nr, t.ncols()),
            re,
        }],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A 3-D lattice of point masses on axial springs along x, y, z (a cubic grid
    /// nx × ny × nz of nodes, each with 3 DOFs), clamped at x = 0, with a consistent-like
    /// (banded, non-diagonal) mass: mass m on each node plus coupling m/10 along springs.
    pub(crate) fn lattice(nx: usize, ny: usize, nz: usize) -> ComponentMatrices {
        let id = |i: usize, j: usize, k: usize| 1 + i + nx * (j + ny * k);
        let mut dofs = Vec::new();
        let mut pos = HashMap::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 1..nx {
                    for dir in 0..3 {
                        pos.insert((id(i, j, k), dir), dofs.len());
                        dofs.push(NodeDof {
                            node: id(i, j, k),
                            dir,
                        });
                    }
                }
            }
        }
        let n = dofs.len();
        let mut ke = Vec::new();
        let mut me = Vec::new();
        let add = |es: &mut Vec<(u32, u32, f64)>, a: Option<usize>, b: Option<usize>, v: f64| {
            // element matrix v [[1, −1], [−1, 1]] (or [[2,1],[1,2]]/… for mass handled by caller)
            if let Some(a) = a {
                es.push((a as u32, a as u32, v));
            }
            if let Some(b) = b {
                es.push((b as u32, b as u32, v));
            }
            if let (Some(a), Some(b)) = (a, b) {
                es.push((a.min(b) as u32, a.max(b) as u32, -v));
            }
        };
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let here = |dir| pos.get(&(id(i, j, k), dir)).copied();
                    for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (i2, j2, k2) = (i + di, j + dj, k + dk);
                        if i2 >= nx || j2 >= ny || k2 >= nz {
                            continue;
                        }
                        for dir in 0..3 {
                            let there = pos.get(&(id(i2, j2, k2), dir)).copied();
                            let stiff =
                                if dir == 0 { 3.0e6 } else { 1.0e6 } * (1.0 + 0.1 * dir as f64);
                            add(&mut ke, here(dir), there, stiff);
                            // consistent-like mass: +m/6 diagonal, +m/12 off-diagonal (positive).
                            if let (Some(a), Some(b)) = (here(dir), there) {
                                me.push((a.min(b) as u32, a.max(b) as u32, 0.1));
                            }
                            for d in [here(dir), there].into_iter().flatten() {
                                me.push((d as u32, d as u32, 0.2));
                            }
                        }
                    }
                    for dir in 0..3 {
                        if let Some(a) = here(dir) {
                            me.push((a as u32, a as u32, 1.0));
                        }
                    }
                }
            }
        }
        // Sum duplicates through a dense detour (test sizes are small).
        let dense = |es: &[(u32, u32, f64)]| {
            let mut d = DMatrix::<f64>::zeros(n, n);
            for &(r, c, v) in es {
                d[(r as usize, c as usize)] += v;
            }
            let tri: Vec<(u32, u32, f64)> = (0..n)
                .flat_map(|c| (0..=c).map(move |r| (r, c)))
                .filter(|&(r, c)| d[(r, c)] != 0.0)
                .map(|(r, c)| (r as u32, c as u32, d[(r, c)]))
                .collect();
            sparse_from_entries(n, &tri, true).unwrap()
        };
        ComponentMatrices {
            stiffness: dense(&ke),
            mass: dense(&me),
            dofs,
        }
    }

    fn to_dmatrix(a: &SparseColMat<usize, f64>) -> DMatrix<f64> {
        let d = a.to_dense();
        DMatrix::from_fn(d.nrows(), d.ncols(), |i, j| d[(i, j)])
    }

    #[test]
    fn sparse_builder_mirrors_and_rejects_duplicates() {
        let a = sparse_from_entries(
            3,
            &[(0, 0, 2.0), (0, 2, -1.0), (1, 1, 3.0), (2, 2, 4.0)],
            true,
        )
        .unwrap();
        let d = to_dmatrix(&a);
        assert_eq!(
            d,
            DMatrix::from_row_slice(3, 3, &[2., 0., -1., 0., 3., 0., -1., 0., 4.])
        );
        assert_eq!(
            sparse_from_entries(2, &[(0, 1, 1.0), (1, 1, 1.0), (0, 1, 2.0)], true).unwrap_err(),
            ComponentError::DuplicateEntry { row: 1, col: 2 }
        );
    }

    #[test]
    fn fixed_interface_modes_match_dense_solution() {
        // Large enough that the block Krylov subspace stays well below the problem size.
        let mats = lattice(10, 6, 5);
        let n = mats.dofs.len();
        let factor = CholeskyFactor::new(&mats.stiffness, Par::Seq).unwrap();
        // Solve check against the dense matrix.
        let kd = to_dmatrix(&mats.stiffness);
        let md = to_dmatrix(&mats.mass);
        let mut x = Mat::<f64>::from_fn(n, 2, |i, j| (i + 3 * j) as f64 / n as f64);
        let b = x.clone();
        factor.solve_in_place(x.as_mut());
        let xd = DMatrix::from_fn(n, 2, |i, j| x[(i, j)]);
        let bd = DMatrix::from_fn(n, 2, |i, j| b[(i, j)]);
        assert!((&kd * &xd - &bd).amax() < 1e-12 * bd.amax());

        let pencil = Pencil {
            stiffness: &mats.stiffness,
            mass: &mats.mass,
            factor: &factor,
        };
        let pairs = lowest_eigenpairs(
            &pencil,
            8,
            Mat::<f64>::zeros(n, 0).as_ref(),
            &SparseEigenOptions::new(1e-10),
        )
        .unwrap();
        assert!(pairs.stats.solves > 0, "the Krylov route must be taken");
        let (lam, phi) = (pairs.values, pairs.vectors);
        let (f_ref, _) = dense_modes(&kd, &md, 8).unwrap();
        for (l, f) in lam.iter().zip(&f_ref) {
            let f_sparse = l.sqrt() / (2.0 * std::f64::consts::PI);
            assert_relative_eq!(f_sparse, *f, max_relative = 1e-9);
        }
        let ph = DMatrix::from_fn(n, 8, |i, j| phi[(i, j)]);
        let gram = ph.transpose() * &md * &ph;
        assert!((gram - DMatrix::identity(8, 8)).amax() < 1e-8);
        let kk = ph.transpose() * &kd * &ph;
        for p in 0..8 {
            assert_relative_eq!(kk[(p, p)], lam[p], max_relative = 1e-8);
        }
    }

    #[test]
    fn craig_bampton_converges_to_full_model() {
        let mats = lattice(8, 3, 2);
        let contacts: Vec<ContactPoint> = [8usize, 16, 24]
            .iter()
            .map(|&node| ContactPoint {
                node,
                position: [node as f64 * 1e-3, 0.0, 0.0],
            })
            .collect();
        let opts = ComponentReductionOptions {
            n_modes: 30,
            ..Default::default()
        };
        let rom = reduce_component(&mats, &contacts, &opts).unwrap();
        assert_eq!(rom.validate(), Ok(()));
        assert_eq!(rom.n_sectors, 1);
        assert_eq!(rom.n_boundary(), 9);
        let kd = to_dmatrix(&mats.stiffness);
        let md = to_dmatrix(&mats.mass);
        let (f_full, _) = dense_modes(&kd, &md, 5).unwrap();
        let f_rom = &rom.modal_data[0].frequencies[0];
        // Fewer modes: a nested Rayleigh–Ritz subspace, so frequencies are upper bounds
        // that decrease as modes are added.
        let few = ComponentReductionOptions {
            n_modes: 10,
            ..Default::default()
        };
        let f_few =
            reduce_component(&mats, &contacts, &few).unwrap().modal_data[0].frequencies[0].clone();
        for p in 0..5 {
            assert!(f_rom[p] >= f_full[p] * (1.0 - 1e-12));
            assert!(f_few[p] >= f_rom[p] * (1.0 - 1e-12));
        }
        // All interior modes kept: the basis spans the whole space, the reduction is exact.
        let all = ComponentReductionOptions {
            n_modes: mats.dofs.len() - 9,
            ..Default::default()
        };
        let f_all =
            reduce_component(&mats, &contacts, &all).unwrap().modal_data[0].frequencies[0].clone();
        for p in 0..5 {
            assert_relative_eq!(f_all[p], f_full[p], max_relative = 1e-9);
        }
        // Modal block of K_r is diag(λ), decoupled from the boundary; modal mass block is I.
        let h = &rom.harmonics[0];
        let k = &h.stiffness[0].re;
        let m = &h.mass.re;
        for a in 9..9 + 30 {
            assert_relative_eq!(m[(a, a)], 1.0, max_relative = 1e-8);
            for b in 0..9 {
                assert!(k[(a, b)].abs() < 1e-6 * k[(a, a)]);
            }
        }
        // The boundary block of K_r is the static condensation (Guyan) of K.
        let dofs = &mats.dofs;
        let bset: Vec<usize> = contacts
            .iter()
            .flat_map(|c| {
                (0..3).map(move |d| {
                    dofs.iter()
                        .position(|x| {
                            *x == NodeDof {
                                node: c.node,
                                dir: d,
                            }
                        })
                        .unwrap()
                })
            })
            .collect();
        let iset: Vec<usize> = (0..kd.nrows()).filter(|g| !bset.contains(g)).collect();
        let sub =
            |r: &[usize], c: &[usize]| DMatrix::from_fn(r.len(), c.len(), |i, j| kd[(r[i], c[j])]);
        let guyan = sub(&bset, &bset)
            - sub(&bset, &iset) * sub(&iset, &iset).lu().solve(&sub(&iset, &bset)).unwrap();
        let kbb = k.view((0, 0), (9, 9)).into_owned();
        assert!((kbb - &guyan).amax() < 1e-8 * guyan.amax());
    }

    #[test]
    fn reduction_errors_are_reported() {
        let mats = lattice(4, 2, 2);
        let ok = ContactPoint {
            node: 4,
            position: [0.0; 3],
        };
        let clamped = ContactPoint {
            node: 1,
            position: [0.0; 3],
        };
        let opts = ComponentReductionOptions {
            n_modes: 4,
            ..Default::default()
        };
        assert_eq!(
            reduce_component(&mats, &[ok.clone(), clamped], &opts).unwrap_err(),
            ComponentError::ContactDofMissing { node: 1, axis: 'x' }
        );
        assert_eq!(
            reduce_component(&mats, &[ok.clone(), ok.clone()], &opts).unwrap_err(),
            ComponentError::DuplicateContactNode { node: 4 }
        );
        let bad = ComponentReductionOptions {
            n_modes: 0,
            ..Default::default()
        };
        assert!(matches!(
            reduce_component(&mats, std::slice::from_ref(&ok), &bad),
            Err(ComponentError::ModeCount { .. })
        ));
        // An unclamped (singular) stiffness is caught by the Cholesky.
        let mut free = mats.clone();
        free.stiffness = sparse_from_entries(free.dofs.len(), &[], true).unwrap();
        assert!(matches!(
            reduce_component(&free, &[ok], &opts),
            Err(ComponentError::NotPositiveDefinite(_))
        ));
    }

    #[test]
    fn speed_polynomial_recovers_coefficients() {
        let k0 = DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 3.0]);
        let k1 = DMatrix::from_row_slice(2, 2, &[0.5, -0.2, -0.2, 0.1]);
        let k2 = DMatrix::from_row_slice(2, 2, &[1e-3, 0.0, 0.0, 2e-3]);
        let at = |w: f64| &k0 + &k1 * w.powi(2) + &k2 * w.powi(4);
        let fit =
            speed_polynomial_from_samples(&[(0.0, at(0.0)), (10.0, at(10.0)), (25.0, at(25.0))])
                .unwrap();
        for (f, e) in fit.iter().zip([&k0, &k1, &k2]) {
            assert!((f - e).amax() < 1e-9 * e.amax().max(1.0));
        }
        assert!(
            speed_polynomial_from_samples(&[(1.0, at(1.0)), (-1.0, at(1.0)), (2.0, at(2.0))])
                .is_err()
        );
    }
}
