//! Cyclic symmetry of a sector model: the harmonic (nodal-diameter) sector problem and the
//! full 360° reference assembly (DESIGN §2.2).
//!
//! Conventions (see `rom.rs`): sector `s` spans `[θ_s, θ_s + α]`, `α = 2π/N`, DOFs of every
//! sector in its own local frame (global frame rotated by `θ_s` about `z`), DOF `3·node + dir`.
//! For nodal diameter `k` the right-face nodes of sector 0 satisfy
//! `u_right = e^{ikα} R(α) u_left` (both in sector-0 coordinates).
//!
//! The *independent* DOFs of the harmonic problem are every sector DOF except those of the
//! right-face nodes (slaved to the left face) and of the clamped nodes (zero). A clamp on a
//! face node propagates to its partner on the other face, since the cyclic condition ties
//! the two. The sector matrices become the complex Hermitian matrices `Tᴴ A T` over the
//! independent DOFs, where `u_sector = T u_independent`.

use faer::c64;
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::Matrix3;
use std::f64::consts::PI;
use thiserror::Error;

/// Borrowed topology of one cyclic sector: what cyclic symmetry needs from a sector mesh.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SectorTopology<'a> {
    /// Number of sectors N of the full structure (1 for a non-cyclic component).
    pub n_sectors: usize,
    /// Number of nodes of the sector model (the sector has `3·n_nodes` DOFs).
    pub n_nodes: usize,
    /// Nodes on the `θ = 0` face.
    pub left_nodes: &'a [usize],
    /// `right_nodes[i]` is `left_nodes[i]` rotated by `+α`.
    pub right_nodes: &'a [usize],
    /// Nodes with all three DOFs fixed.
    pub clamped_nodes: &'a [usize],
}

impl<'a> SectorTopology<'a> {
    /// The cyclic topology of a built-in sector mesh.
    pub(crate) fn of(mesh: &'a super::mesh::SectorMesh) -> Self {
        SectorTopology {
            n_sectors: mesh.n_sectors,
            n_nodes: mesh.nodes.len(),
            left_nodes: &mesh.left_nodes,
            right_nodes: &mesh.right_nodes,
            clamped_nodes: &mesh.clamped_nodes,
        }
    }
}

/// Inconsistent sector topology; every variant names the offending data.
#[derive(Debug, Error, PartialEq)]
pub enum CyclicError {
    /// The sector count N is zero.
    #[error("n_sectors must be at least 1")]
    NoSectors,
    /// The two cyclic faces have different node counts.
    #[error("left_nodes has {left} entries but right_nodes has {right}")]
    FaceLengthMismatch {
        /// Number of left-face nodes.
        left: usize,
        /// Number of right-face nodes.
        right: usize,
    },
    /// A face, clamped or first-ordered node index is not a node of the sector.
    #[error("{what} node index {node} is out of range (the sector has {n_nodes} nodes)")]
    NodeOutOfRange {
        /// Which list holds the index.
        what: &'static str,
        /// The index.
        node: usize,
        /// Number of nodes of the sector.
        n_nodes: usize,
    },
    /// A node appears twice on the cyclic faces (e.g. a node on the axis).
    #[error(
        "node {node} is listed more than once on the cyclic faces (axis nodes and repeated face nodes are not supported)"
    )]
    RepeatedFaceNode {
        /// The repeated node.
        node: usize,
    },
    /// A one-sector model was given cyclic faces.
    #[error("a one-sector (non-cyclic) model must have empty left/right faces")]
    FacesOnSingleSector,
    /// The node that must carry the first independent DOFs is slaved or clamped.
    #[error("first-ordered node {node} is {reason}; it cannot be an independent DOF")]
    DependentFirstNode {
        /// The node.
        node: usize,
        /// Why it is not independent (right-face or clamped).
        reason: &'static str,
    },
    /// A nodal diameter above N/2.
    #[error("nodal diameter {k} exceeds N/2 = {max}")]
    NodalDiameter {
        /// The nodal diameter asked for.
        k: usize,
        /// The largest one, ⌊N/2⌋.
        max: usize,
    },
    /// A sector matrix whose size is not `3 n_nodes` square.
    #[error("matrix is {rows}×{cols}, expected {n}×{n} (3 DOFs per node)")]
    MatrixShape {
        /// Rows of the matrix.
        rows: usize,
        /// Columns of the matrix.
        cols: usize,
        /// Expected order, `3 n_nodes`.
        n: usize,
    },
    /// The sparse backend refused to build a harmonic matrix (message from faer).
    #[error("could not build sparse matrix: {0}")]
    Sparse(String),
}

/// What the cyclic condition makes of a sector node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NodeRole {
    /// Independent node whose x, y, z DOFs are independent DOFs `first..first+3`.
    Independent { first: usize },
    /// Right-face node slaved to the independent left-face node whose DOFs start at `first`.
    Right { first: usize },
    /// All three DOFs zero.
    Clamped,
}

/// Map from the sector DOFs to the independent DOFs of the cyclic problem.
#[derive(Clone, Debug)]
pub(crate) struct CyclicDofMap {
    n_sectors: usize,
    roles: Vec<NodeRole>,
    n_independent: usize,
    n_first: usize,
}

/// Rotation matrix about `+z` by `angle` (rad): sector frames, the rotating frame `R(Ω t)`.
#[inline]
pub fn rot_z(angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// The inter-sector phase `e^{ikα}` with `α = 2π/N`, exactly ±1 for the real harmonics.
pub(crate) fn cyclic_phase(k: usize, n_sectors: usize) -> c64 {
    if k == 0 {
        c64::new(1.0, 0.0)
    } else if 2 * k == n_sectors {
        c64::new(-1.0, 0.0)
    } else {
        let (s, c) = (2.0 * PI * k as f64 / n_sectors as f64).sin_cos();
        c64::new(c, s)
    }
}

/// Whether nodal diameter `k` of an `n`-sector structure is a real (standing-wave-only) harmonic.
pub fn is_real_harmonic(k: usize, n_sectors: usize) -> bool {
    k == 0 || 2 * k == n_sectors
}

impl CyclicDofMap {
    /// Builds the map. The nodes of `first` (e.g. contact nodes, in order) get the independent
    /// DOFs `0..3·first.len()` (node-major x, y, z); the other independent nodes follow in
    /// increasing node order. Errors if a `first` node is clamped or on the right face.
    pub fn new(topo: &SectorTopology<'_>, first: &[usize]) -> Result<Self, CyclicError> {
        let n_nodes = topo.n_nodes;
        if topo.n_sectors == 0 {
            return Err(CyclicError::NoSectors);
        }
        if topo.left_nodes.len() != topo.right_nodes.len() {
            return Err(CyclicError::FaceLengthMismatch {
                left: topo.left_nodes.len(),
                right: topo.right_nodes.len(),
            });
        }
        if topo.n_sectors == 1 && !topo.left_nodes.is_empty() {
            return Err(CyclicError::FacesOnSingleSector);
        }
        let check = |what: &'static str, list: &[usize]| {
            list.iter().try_for_each(|&node| {
                if node < n_nodes {
                    Ok(())
                } else {
                    Err(CyclicError::NodeOutOfRange {
                        what,
                        node,
                        n_nodes,
                    })
                }
            })
        };
        check("left-face", topo.left_nodes)?;
        check("right-face", topo.right_nodes)?;
        check("clamped", topo.clamped_nodes)?;
        check("first-ordered", first)?;

        let mut clamped = vec![false; n_nodes];
        for &c in topo.clamped_nodes {
            clamped[c] = true;
        }
        let mut on_face = vec![false; n_nodes];
        // partner[right] = left
        let mut partner: Vec<Option<usize>> = vec![None; n_nodes];
        for (&l, &r) in topo.left_nodes.iter().zip(topo.right_nodes) {
            for node in [l, r] {
                if on_face[node] {
                    return Err(CyclicError::RepeatedFaceNode { node });
                }
                on_face[node] = true;
            }
            partner[r] = Some(l);
            // The cyclic condition ties the two faces: a clamp on either fixes both.
            if clamped[l] || clamped[r] {
                clamped[l] = true;
                clamped[r] = true;
            }
        }
        let mut roles = vec![NodeRole::Clamped; n_nodes];
        let mut assigned = vec![false; n_nodes];
        let mut next = 0;
        let mut assign = |node: usize, roles: &mut Vec<NodeRole>| {
            roles[node] = NodeRole::Independent { first: next };
            next += 3;
        };
        for &node in first {
            if clamped[node] {
                return Err(CyclicError::DependentFirstNode {
                    node,
                    reason: "clamped",
                });
            }
            if partner[node].is_some() {
                return Err(CyclicError::DependentFirstNode {
                    node,
                    reason: "on the right face (use its left-face partner)",
                });
            }
            if assigned[node] {
                return Err(CyclicError::RepeatedFaceNode { node });
            }
            assigned[node] = true;
            assign(node, &mut roles);
        }
        for node in 0..n_nodes {
            if !assigned[node] && !clamped[node] && partner[node].is_none() {
                assign(node, &mut roles);
            }
        }
        for node in 0..n_nodes {
            if let (Some(l), false) = (partner[node], clamped[node])
                && let NodeRole::Independent { first } = roles[l]
            {
                roles[node] = NodeRole::Right { first };
            }
        }
        Ok(Self {
            n_sectors: topo.n_sectors,
            roles,
            n_independent: next,
            n_first: 3 * first.len(),
        })
    }

    /// Number of independent DOFs of the harmonic problem.
    pub(crate) fn n_independent(&self) -> usize {
        self.n_independent
    }

    /// Number of DOFs of the whole sector (`3·n_nodes`).
    pub(crate) fn n_sector_dofs(&self) -> usize {
        3 * self.roles.len()
    }

    /// Number of independent DOFs of the `first` nodes given at construction.
    pub(crate) fn n_first(&self) -> usize {
        self.n_first
    }

    /// Number of sectors N.
    pub fn n_sectors(&self) -> usize {
        self.n_sectors
    }

    /// Expresses sector DOF `dof` as `Σ c_j u_j` over independent DOFs `j`, for a given
    /// inter-sector `phase`. Returns up to three `(j, c, on_next_sector)` terms; the flag marks
    /// terms that belong to the left face of the *next* sector (used by the 360° assembly).
    fn terms(
        &self,
        dof: usize,
        phase: c64,
        rot: &Matrix3<f64>,
    ) -> ([(usize, c64); 3], usize, bool) {
        let (node, dir) = (dof / 3, dof % 3);
        let mut out = [(0, c64::new(0.0, 0.0)); 3];
        match self.roles[node] {
            NodeRole::Clamped => (out, 0, false),
            NodeRole::Independent { first } => {
                out[0] = (first + dir, c64::new(1.0, 0.0));
                (out, 1, false)
            }
            NodeRole::Right { first } => {
                let mut n = 0;
                for (b, &r) in rot.row(dir).iter().enumerate() {
                    if r != 0.0 {
                        out[n] = (first + b, phase * r);
                        n += 1;
                    }
                }
                (out, n, true)
            }
        }
    }

    /// Sector DOF `dof` of nodal diameter `k` as `Σ c_j ũ_j` over the independent DOFs `j`
    /// (empty for a clamped DOF; a right-face DOF is `e^{ikα} R(α)` times its left partner's).
    /// What a recovery row of an interior sector node is made of.
    pub(crate) fn dof_terms(&self, dof: usize, k: usize) -> Vec<(usize, c64)> {
        let phase = cyclic_phase(k, self.n_sectors);
        let rot = rot_z(2.0 * PI / self.n_sectors as f64);
        let (t, n, _) = self.terms(dof, phase, &rot);
        t[..n].to_vec()
    }

    fn check_shape(&self, rows: usize, cols: usize) -> Result<(), CyclicError> {
        let n = self.n_sector_dofs();
        if rows != n || cols != n {
            return Err(CyclicError::MatrixShape { rows, cols, n });
        }
        Ok(())
    }

    /// Triplets of the harmonic-`k` matrix `Tᴴ A T` (duplicates to be summed) over the
    /// independent DOFs, for a real symmetric sector matrix `a` in full storage.
    pub(crate) fn harmonic_triplets(
        &self,
        a: &SparseColMat<usize, f64>,
        k: usize,
    ) -> Result<Vec<Triplet<usize, usize, c64>>, CyclicError> {
        self.check_shape(a.nrows(), a.ncols())?;
        let max = self.n_sectors / 2;
        if k > max {
            return Err(CyclicError::NodalDiameter { k, max });
        }
        let phase = cyclic_phase(k, self.n_sectors);
        let rot = rot_z(2.0 * PI / self.n_sectors as f64);
        let mut out = Vec::with_capacity(a.compute_nnz() * 2);
        for col in 0..a.ncols() {
            let (tc, nc, _) = self.terms(col, phase, &rot);
            if nc == 0 {
                continue;
            }
            for (row, &v) in a.row_idx_of_col(col).zip(a.val_of_col(col)) {
                let (tr, nr, _) = self.terms(row, phase, &rot);
                for &(i, ci) in &tr[..nr] {
                    for &(j, cj) in &tc[..nc] {
                        out.push(Triplet::new(i, j, ci.conj() * v * cj));
                    }
                }
            }
        }
        Ok(out)
    }

    /// The complex Hermitian harmonic-`k` matrix `Tᴴ A T` over the independent DOFs.
    #[cfg(test)]
    pub(crate) fn harmonic_matrix(
        &self,
        a: &SparseColMat<usize, f64>,
        k: usize,
    ) -> Result<SparseColMat<usize, c64>, CyclicError> {
        let t = self.harmonic_triplets(a, k)?;
        let n = self.n_independent;
        SparseColMat::try_new_from_triplets(n, n, &t)
            .map_err(|e| CyclicError::Sparse(format!("{e:?}")))
    }

    /// Full 360° assembly of a real symmetric sector matrix (reference model for tests and
    /// checks): the sector is replicated N times, the right face of sector `s` merged with the
    /// left face of sector `s+1`. Global DOF `s·n_independent + j` is independent DOF `j` of
    /// sector `s`, in sector `s`'s local frame. Clamped DOFs are eliminated.
    #[cfg(test)]
    pub(crate) fn assemble_full(
        &self,
        a: &SparseColMat<usize, f64>,
    ) -> Result<SparseColMat<usize, f64>, CyclicError> {
        self.assemble_full_weighted(a, &vec![1.0; self.n_sectors])
    }

    /// [`Self::assemble_full`] with sector `s`'s copy of `a` scaled by `weights[s]` (a
    /// mistuned wheel's reference: the blade's stiffness of each sector scaled by its own factor).
    #[cfg(test)]
    pub(crate) fn assemble_full_weighted(
        &self,
        a: &SparseColMat<usize, f64>,
        weights: &[f64],
    ) -> Result<SparseColMat<usize, f64>, CyclicError> {
        self.check_shape(a.nrows(), a.ncols())?;
        let n_sec = self.n_sectors;
        assert_eq!(weights.len(), n_sec, "one weight per sector");
        let ni = self.n_independent;
        let rot = rot_z(2.0 * PI / n_sec as f64);
        let one = c64::new(1.0, 0.0);
        let mut out = Vec::with_capacity(a.compute_nnz() * 2 * n_sec);
        for col in 0..a.ncols() {
            let (tc, nc, next_c) = self.terms(col, one, &rot);
            for (row, &v) in a.row_idx_of_col(col).zip(a.val_of_col(col)) {
                let (tr, nr, next_r) = self.terms(row, one, &rot);
                for (s, &weight) in weights.iter().enumerate() {
                    let off_r = ((s + next_r as usize) % n_sec) * ni;
                    let off_c = ((s + next_c as usize) % n_sec) * ni;
                    for &(i, ci) in &tr[..nr] {
                        for &(j, cj) in &tc[..nc] {
                            out.push(Triplet::new(
                                off_r + i,
                                off_c + j,
                                weight * ci.re * v * cj.re,
                            ));
                        }
                    }
                }
            }
        }
        SparseColMat::try_new_from_triplets(n_sec * ni, n_sec * ni, &out)
            .map_err(|e| CyclicError::Sparse(format!("{e:?}")))
    }
}

/// A hand-made cyclic sector for tests: a rigid truss of 3-D bars with consistent bar masses
/// and lumped masses, plus a centrifugal-like `K1` (bar tension stiffening minus spin
/// softening). Independent of the FE mesher.
#[cfg(test)]
pub(crate) mod test_support {
    use super::*;

    pub(crate) struct TrussSector {
        pub n_sectors: usize,
        pub nodes: Vec<[f64; 3]>,
        pub left: Vec<usize>,
        pub right: Vec<usize>,
        pub clamped: Vec<usize>,
        pub contact: Vec<usize>,
        pub k: SparseColMat<usize, f64>,
        pub m: SparseColMat<usize, f64>,
        pub k1: SparseColMat<usize, f64>,
    }

    impl TrussSector {
        pub(crate) fn topology(&self) -> SectorTopology<'_> {
            SectorTopology {
                n_sectors: self.n_sectors,
                n_nodes: self.nodes.len(),
                left_nodes: &self.left,
                right_nodes: &self.right,
                clamped_nodes: &self.clamped,
            }
        }
    }

    fn cyl(r: f64, theta: f64, z: f64) -> [f64; 3] {
        [r * theta.cos(), r * theta.sin(), z]
    }

    /// A lattice truss shaped like a thin shell sector: nodes on a (radius × angle × axial)
    /// grid of 2 × 4 × 6 points, bars between all grid neighbours (diagonals included, so each
    /// cell is rigid), consistent bar masses plus lumped masses. Its spectrum spreads like a
    /// continuum's. `casing_like`: the first axial ring is clamped and the contact nodes are
    /// the inner-radius left-face nodes of the other rings (leading → trailing); otherwise the
    /// structure is free and the contact nodes are outer-radius nodes inside the sector.
    pub(crate) fn truss_sector(n_sectors: usize, casing_like: bool) -> TrussSector {
        truss_sector_dims(n_sectors, casing_like, [2, 4, 6])
    }

    /// [`truss_sector`] with a `[radial, angular, axial]` node grid; 5 contact nodes.
    pub(crate) fn truss_sector_dims(
        n_sectors: usize,
        casing_like: bool,
        dims: [usize; 3],
    ) -> TrussSector {
        let alpha = 2.0 * PI / n_sectors as f64;
        let [nr, nt, nz] = dims;
        // Face nodes first (left then right, same order) so that right[i] images left[i].
        let mut index = vec![usize::MAX; nr * nt * nz];
        let id = |ir: usize, it: usize, iz: usize| (ir * nt + it) * nz + iz;
        let mut order = vec![];
        for it in [0, nt - 1].into_iter().chain(1..nt - 1) {
            for ir in 0..nr {
                for iz in 0..nz {
                    order.push((ir, it, iz));
                }
            }
        }
        let mut nodes = vec![];
        for (n, &(ir, it, iz)) in order.iter().enumerate() {
            index[id(ir, it, iz)] = n;
            let zf = iz as f64 / (nz - 1) as f64;
            // A gently flaring meridian, like a centrifugal casing.
            let r = 0.3 + 0.05 * zf * zf + 0.02 * ir as f64;
            nodes.push(cyl(r, alpha * it as f64 / (nt - 1) as f64, 0.1 * zf));
        }
        let n = nodes.len();
        let node = |ir, it, iz| index[id(ir, it, iz)];
        let is_right = |p: usize| (nr * nz..2 * nr * nz).contains(&p);
        let (mut k, mut m, mut k1) = (vec![], vec![], vec![]);
        let mut h = 0x9e37_79b9_u64;
        let mut rnd = || {
            h = h
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (h >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut bars = vec![];
        for a in 0..nr * nt * nz {
            for b in (a + 1)..nr * nt * nz {
                let (ra, ta, za) = (a / (nt * nz), (a / nz) % nt, a % nz);
                let (rb, tb, zb) = (b / (nt * nz), (b / nz) % nt, b % nz);
                if ra.abs_diff(rb) <= 1 && ta.abs_diff(tb) <= 1 && za.abs_diff(zb) <= 1 {
                    let (i, j) = (node(ra, ta, za), node(rb, tb, zb));
                    // Right-face bars belong to the next sector (its left face).
                    if !(is_right(i) && is_right(j)) {
                        bars.push((i, j));
                    }
                }
            }
        }
        for (i, j) in bars {
            let d: Vec<f64> = (0..3).map(|a| nodes[j][a] - nodes[i][a]).collect();
            let len = d.iter().map(|x| x * x).sum::<f64>().sqrt();
            let e: Vec<f64> = d.iter().map(|x| x / len).collect();
            let ea = 1e6 * (1.0 + 0.3 * rnd());
            let rho_a = 1.0 + 0.3 * rnd();
            let rad = |p: &[f64; 3]| p[0].hypot(p[1]);
            let tension = 0.5 * (rad(&nodes[i]) + rad(&nodes[j]));
            for a in 0..3 {
                for b in 0..3 {
                    let kab = ea / len * e[a] * e[b];
                    let gab = tension / len * (f64::from(a == b) - e[a] * e[b]);
                    for (p, q, s) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
                        k.push(Triplet::new(3 * p + a, 3 * q + b, s * kab));
                        k1.push(Triplet::new(3 * p + a, 3 * q + b, s * gab));
                    }
                }
                let mm = rho_a * len / 6.0;
                for (p, q, s) in [(i, i, 2.0), (j, j, 2.0), (i, j, 1.0), (j, i, 1.0)] {
                    m.push(Triplet::new(3 * p + a, 3 * q + a, s * mm));
                    if a < 2 {
                        // Spin softening: −Ω² M on the in-plane components.
                        k1.push(Triplet::new(3 * p + a, 3 * q + a, -s * mm));
                    }
                }
            }
        }
        let n_face = 2 * nr * nz;
        for i in 0..n {
            // Face nodes are shared by two sectors: half the point mass on each side.
            let lumped = if i < n_face { 0.005 } else { 0.01 };
            for a in 0..3 {
                m.push(Triplet::new(3 * i + a, 3 * i + a, lumped));
                if a < 2 {
                    k1.push(Triplet::new(3 * i + a, 3 * i + a, -lumped));
                }
            }
        }
        let sp = |t: &[Triplet<usize, usize, f64>]| {
            SparseColMat::try_new_from_triplets(3 * n, 3 * n, t).unwrap()
        };
        let face = |it: usize| -> Vec<usize> {
            (0..nr)
                .flat_map(|ir| (0..nz).map(move |iz| (ir, iz)))
                .map(|(ir, iz)| node(ir, it, iz))
                .collect()
        };
        let clamped = if casing_like {
            (0..nr)
                .flat_map(|ir| (0..nt).map(move |it| (ir, it)))
                .map(|(ir, it)| node(ir, it, 0))
                .collect()
        } else {
            vec![]
        };
        let rows: Vec<usize> = (1..=5).map(|j| 1 + (j - 1) * (nz - 2) / 4).collect();
        let contact = if casing_like {
            rows.iter().map(|&iz| node(0, 0, iz)).collect()
        } else {
            rows.iter().map(|&iz| node(nr - 1, 1, iz)).collect()
        };
        TrussSector {
            n_sectors,
            nodes,
            left: face(0),
            right: face(nt - 1),
            clamped,
            contact,
            k: sp(&k),
            m: sp(&m),
            k1: sp(&k1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::truss_sector;
    use super::*;
    use crate::model::eigen::dense_gen_eigen;
    use faer::Mat;

    fn real_dense(a: &SparseColMat<usize, f64>) -> Mat<c64> {
        let d = a.to_dense();
        Mat::from_fn(d.nrows(), d.ncols(), |i, j| c64::new(d[(i, j)], 0.0))
    }

    /// Union over k of the harmonic eigenvalues, each with its multiplicity in the full model.
    fn cyclic_union(n_sectors: usize, casing_like: bool) -> Vec<f64> {
        let s = truss_sector(n_sectors, casing_like);
        let map = CyclicDofMap::new(&s.topology(), &s.contact).unwrap();
        let mut all = vec![];
        for k in 0..=n_sectors / 2 {
            let kk = map.harmonic_matrix(&s.k, k).unwrap().to_dense();
            let mm = map.harmonic_matrix(&s.m, k).unwrap().to_dense();
            let real = is_real_harmonic(k, n_sectors);
            let (lam, _) = dense_gen_eigen(kk.as_ref(), mm.as_ref(), real).unwrap();
            for l in lam {
                all.push(l);
                if !real {
                    all.push(l);
                }
            }
        }
        all.sort_by(f64::total_cmp);
        all
    }

    fn full_eigenvalues(n_sectors: usize, casing_like: bool) -> Vec<f64> {
        let s = truss_sector(n_sectors, casing_like);
        let map = CyclicDofMap::new(&s.topology(), &s.contact).unwrap();
        let kf = map.assemble_full(&s.k).unwrap();
        let mf = map.assemble_full(&s.m).unwrap();
        let (lam, _) =
            dense_gen_eigen(real_dense(&kf).as_ref(), real_dense(&mf).as_ref(), true).unwrap();
        lam
    }

    #[test]
    fn cyclic_union_equals_full_360_spectrum() {
        for (n, casing_like) in [(6, true), (8, true), (5, true), (6, false)] {
            let full = full_eigenvalues(n, casing_like);
            let cyc = cyclic_union(n, casing_like);
            assert_eq!(full.len(), cyc.len(), "N = {n}");
            // Compare natural frequencies (the quantity of interest), f ∝ √λ.
            let freq =
                |v: &[f64]| -> Vec<f64> { v.iter().map(|l| l.signum() * l.abs().sqrt()).collect() };
            let (full, cyc) = (freq(&full), freq(&cyc));
            let scale = full.last().unwrap().abs();
            // Rigid-body frequencies are zero up to round-off (~√ε·f_max): their counts must
            // agree; every elastic frequency is compared relatively.
            let rigid = |v: &[f64]| v.iter().filter(|f| f.abs() < 1e-6 * scale).count();
            assert_eq!(rigid(&full), rigid(&cyc));
            assert_eq!(rigid(&full), if casing_like { 0 } else { 6 });
            let mut worst: f64 = 0.0;
            for (a, b) in full.iter().zip(&cyc).skip(rigid(&full)) {
                worst = worst.max((a - b).abs() / a.abs());
            }
            println!(
                "N = {n} casing_like = {casing_like}: {} eigenvalues, worst relative frequency difference {worst:.2e}",
                full.len()
            );
            assert!(worst < 1e-6, "N = {n}: worst relative error {worst}");
        }
    }

    #[test]
    fn harmonic_matrices_are_hermitian_and_real_for_standing_harmonics() {
        let s = truss_sector(6, true);
        let map = CyclicDofMap::new(&s.topology(), &s.contact).unwrap();
        for k in 0..=3 {
            for a in [&s.k, &s.m, &s.k1] {
                let h = map.harmonic_matrix(a, k).unwrap().to_dense();
                let n = h.nrows();
                let scale = (0..n).map(|i| h[(i, i)].norm()).fold(0.0, f64::max);
                let (mut asym, mut imag): (f64, f64) = (0.0, 0.0);
                for i in 0..n {
                    for j in 0..n {
                        asym = asym.max((h[(i, j)] - h[(j, i)].conj()).norm());
                        imag = imag.max(h[(i, j)].im.abs());
                    }
                }
                assert!(asym <= 1e-12 * scale, "k = {k}: asymmetry {asym}");
                if k == 0 || k == 3 {
                    assert_eq!(imag, 0.0, "k = {k} must be real");
                } else {
                    assert!(imag > 1e-6 * scale, "k = {k} should be complex");
                }
            }
        }
    }

    #[test]
    fn full_assembly_is_symmetric_and_block_circulant() {
        let s = truss_sector(6, true);
        let map = CyclicDofMap::new(&s.topology(), &s.contact).unwrap();
        let kf = map.assemble_full(&s.k).unwrap().to_dense();
        let ni = map.n_independent();
        let n = kf.nrows();
        let tol = 1e-12 * (0..n).map(|i| kf[(i, i)]).fold(0.0, f64::max);
        assert_eq!(n, 6 * ni);
        for i in 0..n {
            for j in 0..n {
                assert!((kf[(i, j)] - kf[(j, i)]).abs() <= tol);
                let (ip, jp) = ((i + ni) % n, (j + ni) % n);
                assert!((kf[(i, j)] - kf[(ip, jp)]).abs() <= tol);
            }
        }
    }

    #[test]
    fn rejects_inconsistent_topology() {
        let s = truss_sector(6, true);
        let mut topo = s.topology();
        let r = s.right[1];
        assert_eq!(
            CyclicDofMap::new(&topo, &[r]).unwrap_err(),
            CyclicError::DependentFirstNode {
                node: r,
                reason: "on the right face (use its left-face partner)"
            }
        );
        assert!(matches!(
            CyclicDofMap::new(&topo, &[0]),
            Err(CyclicError::DependentFirstNode { node: 0, .. })
        ));
        let short = [4, 5];
        topo.right_nodes = &short;
        assert_eq!(
            CyclicDofMap::new(&topo, &[]).unwrap_err(),
            CyclicError::FaceLengthMismatch { left: 12, right: 2 }
        );
        let map = CyclicDofMap::new(&s.topology(), &[]).unwrap();
        assert!(matches!(
            map.harmonic_matrix(&s.k, 4),
            Err(CyclicError::NodalDiameter { k: 4, max: 3 })
        ));
    }
}
