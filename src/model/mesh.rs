//! Sector meshes of 20-node hexahedra and the built-in parametric geometries
//! (casing shell of revolution, bladed centrifugal impeller), DESIGN.md §2.3.
//!
//! A [`SectorMesh`] describes one of the N identical sectors of a cyclic
//! structure in the global frame of sector 0 (θ ∈ [0, 2π/N] about `+z`).
//! Units: SI (m, Pa, kg/m³).

#![allow(clippy::needless_range_loop)] // index loops mirror the tensor notation

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of mesh validation and of the parametric geometry builders.
#[derive(Debug, Error, PartialEq)]
pub enum MeshError {
    /// A geometric or material parameter is out of its admissible range.
    #[error("invalid parameter `{field}`: {reason}")]
    InvalidParameter { field: &'static str, reason: String },
    /// The mesh topology or the cyclic face pairing is inconsistent.
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
}

fn bad(field: &'static str, reason: impl Into<String>) -> MeshError {
    MeshError::InvalidParameter {
        field,
        reason: reason.into(),
    }
}

/// Linear isotropic elastic material.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus E, Pa.
    pub young: f64,
    /// Poisson's ratio ν (dimensionless), in (−1, 0.5).
    pub poisson: f64,
    /// Mass density ρ, kg/m³.
    pub density: f64,
}

impl Material {
    /// Titanium alloy Ti-6Al-4V (annealed): E = 113.8 GPa, ν = 0.342, ρ = 4430 kg/m³.
    pub const TI6AL4V: Material = Material {
        young: 113.8e9,
        poisson: 0.342,
        density: 4430.0,
    };
    /// Structural steel: E = 200 GPa, ν = 0.30, ρ = 7850 kg/m³.
    pub const STEEL: Material = Material {
        young: 200.0e9,
        poisson: 0.30,
        density: 7850.0,
    };

    /// Checks E > 0, −1 < ν < 0.5, ρ > 0 (all finite).
    pub fn validate(&self) -> Result<(), MeshError> {
        if !(self.young.is_finite() && self.young > 0.0) {
            return Err(bad(
                "material.young",
                format!("{} Pa must be finite and > 0", self.young),
            ));
        }
        if !(self.poisson.is_finite() && self.poisson > -1.0 && self.poisson < 0.5) {
            return Err(bad(
                "material.poisson",
                format!("{} must lie in (-1, 0.5)", self.poisson),
            ));
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(bad(
                "material.density",
                format!("{} kg/m³ must be finite and > 0", self.density),
            ));
        }
        Ok(())
    }
}

impl Default for Material {
    /// Ti-6Al-4V, see [`Material::TI6AL4V`].
    fn default() -> Self {
        Material::TI6AL4V
    }
}

/// One sector of a cyclic structure meshed with 20-node serendipity hexahedra.
///
/// Hex20 local node order (natural coordinates ξ, η, ζ): corners 0–7 at
/// (−,−,−) (+,−,−) (+,+,−) (−,+,−) (−,−,+) (+,−,+) (+,+,+) (−,+,+); mid-edge
/// nodes 8–11 on the edges 0-1, 1-2, 2-3, 3-0; 12–15 on 4-5, 5-6, 6-7, 7-4;
/// 16–19 on 0-4, 1-5, 2-6, 3-7 (the CalculiX/Abaqus C3D20 order). Elements
/// have a positive Jacobian.
#[derive(Clone, Debug, PartialEq)]
pub struct SectorMesh {
    /// Number of sectors N; the sector spans θ ∈ [0, 2π/N] about `+z`.
    pub n_sectors: usize,
    /// Node coordinates, m, in the global frame of sector 0.
    pub nodes: Vec<[f64; 3]>,
    /// Hex20 connectivity (indices into `nodes`).
    pub elements: Vec<[usize; 20]>,
    /// Nodes on the θ = 0 face.
    pub left_nodes: Vec<usize>,
    /// Nodes on the θ = 2π/N face: `right_nodes[i]` = `left_nodes[i]` rotated by +2π/N about z.
    pub right_nodes: Vec<usize>,
    /// Contact nodes, ordered from leading edge (inlet) to trailing edge (outlet).
    pub contact_nodes: Vec<usize>,
    /// Nodes with all three DOFs fixed (casing flange, impeller bore face).
    pub clamped_nodes: Vec<usize>,
    /// Material of every element.
    pub material: Material,
}

impl SectorMesh {
    /// Sector angle α = 2π/N, rad.
    pub fn sector_angle(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.n_sectors as f64
    }

    /// Number of DOFs (3 per node, numbered `3*node + dir`).
    pub fn n_dofs(&self) -> usize {
        3 * self.nodes.len()
    }

    /// Checks indices, finiteness, the material and the cyclic pairing
    /// (`right_nodes[i]` = R(α) `left_nodes[i]` within 1e-9 of the mesh size).
    pub fn validate(&self) -> Result<(), MeshError> {
        if self.n_sectors == 0 {
            return Err(bad("n_sectors", "must be >= 1"));
        }
        self.material.validate()?;
        let nn = self.nodes.len();
        if let Some(i) = self
            .nodes
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(MeshError::InvalidMesh(format!(
                "node {i} has a non-finite coordinate"
            )));
        }
        for (e, conn) in self.elements.iter().enumerate() {
            if let Some(&n) = conn.iter().find(|&&n| n >= nn) {
                return Err(MeshError::InvalidMesh(format!(
                    "element {e} references node {n} but there are {nn} nodes"
                )));
            }
        }
        for (name, list) in [
            ("left_nodes", &self.left_nodes),
            ("right_nodes", &self.right_nodes),
            ("contact_nodes", &self.contact_nodes),
            ("clamped_nodes", &self.clamped_nodes),
        ] {
            if let Some(&n) = list.iter().find(|&&n| n >= nn) {
                return Err(MeshError::InvalidMesh(format!(
                    "{name} references node {n} but there are {nn} nodes"
                )));
            }
        }
        if self.left_nodes.len() != self.right_nodes.len() {
            return Err(MeshError::InvalidMesh(format!(
                "{} left-face nodes but {} right-face nodes",
                self.left_nodes.len(),
                self.right_nodes.len()
            )));
        }
        let scale = self
            .nodes
            .iter()
            .map(|p| p.iter().fold(0.0f64, |m, c| m.max(c.abs())))
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let (s, c) = self.sector_angle().sin_cos();
        for (i, (&l, &r)) in self.left_nodes.iter().zip(&self.right_nodes).enumerate() {
            if l == r {
                return Err(MeshError::InvalidMesh(format!(
                    "node {l} is on both cyclic faces (nodes on the axis are not supported)"
                )));
            }
            let p = self.nodes[l];
            let q = [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]];
            let d = dist(q, self.nodes[r]);
            if d > 1e-9 * scale {
                return Err(MeshError::InvalidMesh(format!(
                    "cyclic pair {i}: right node {r} is {d:e} m away from left node {l} rotated by 2π/N"
                )));
            }
        }
        Ok(())
    }
}

pub(crate) fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Incremental builder of a Hex20 mesh from structured blocks; nodes closer than `tol`
/// (m) are merged so that blocks sharing a face share its nodes.
#[derive(Debug)]
pub struct MeshBuilder {
    /// Node coordinates, m.
    pub nodes: Vec<[f64; 3]>,
    /// Hex20 connectivity.
    pub elements: Vec<[usize; 20]>,
    cells: std::collections::HashMap<[i64; 3], Vec<usize>>,
    cell: f64,
    tol: f64,
}

/// Node indices of a structured block on its fine grid (2n+1 points per direction; points with
/// two or more odd indices do not exist in a Hex20 mesh).
#[derive(Debug)]
pub struct BlockNodes {
    /// Fine-grid size per direction (2n+1).
    pub dims: [usize; 3],
    ids: Vec<usize>,
}

impl BlockNodes {
    /// Node at fine-grid index (i, j, k), if it exists.
    pub fn get(&self, i: usize, j: usize, k: usize) -> Option<usize> {
        let [a, b, c] = self.dims;
        if i >= a || j >= b || k >= c {
            return None;
        }
        let id = self.ids[(i * b + j) * c + k];
        (id != usize::MAX).then_some(id)
    }
}

impl MeshBuilder {
    /// Empty builder merging nodes closer than `tol` (m).
    pub fn new(tol: f64) -> Self {
        MeshBuilder {
            nodes: Vec::new(),
            elements: Vec::new(),
            cells: Default::default(),
            cell: 100.0 * tol,
            tol,
        }
    }

    fn key(&self, p: [f64; 3]) -> [i64; 3] {
        p.map(|c| (c / self.cell).floor() as i64)
    }

    /// Existing node within `tol` of `p`, if any.
    pub fn find(&self, p: [f64; 3]) -> Option<usize> {
        let k = self.key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        for &i in list {
                            if dist(self.nodes[i], p) <= self.tol {
                                return Some(i);
                            }
                        }
                    }
                }
            }
        }
        None
    }

    /// Index of the node at `p`, created if no node lies within `tol`.
    pub fn node(&mut self, p: [f64; 3]) -> usize {
        if let Some(i) = self.find(p) {
            return i;
        }
        let i = self.nodes.len();
        self.nodes.push(p);
        let k = self.key(p);
        self.cells.entry(k).or_default().push(i);
        i
    }

    /// Adds a structured block of `n[0]×n[1]×n[2]` Hex20 elements: `map` sends logical
    /// coordinates s ∈ [0,1]³ to space. Element orientation is flipped where needed so that
    /// every Jacobian is positive at the element centre.
    pub fn add_block(&mut self, n: [usize; 3], map: impl Fn([f64; 3]) -> [f64; 3]) -> BlockNodes {
        let dims = n.map(|k| 2 * k + 1);
        let mut ids = vec![usize::MAX; dims[0] * dims[1] * dims[2]];
        for i in 0..dims[0] {
            for j in 0..dims[1] {
                for k in 0..dims[2] {
                    if (i % 2) + (j % 2) + (k % 2) >= 2 {
                        continue;
                    }
                    let s = [
                        i as f64 / (dims[0] - 1) as f64,
                        j as f64 / (dims[1] - 1) as f64,
                        k as f64 / (dims[2] - 1) as f64,
                    ];
                    ids[(i * dims[1] + j) * dims[2] + k] = self.node(map(s));
                }
            }
        }
        let block = BlockNodes { dims, ids };
        for ei in 0..n[0] {
            for ej in 0..n[1] {
                for ek in 0..n[2] {
                    let conn = |flip: f64| -> [usize; 20] {
                        let mut c = [0; 20];
                        for (a, p) in super::fe::HEX20_NATURAL.iter().enumerate() {
                            let gi = (2 * ei + 1) as i64 + (flip * p[0]) as i64;
                            let gj = (2 * ej + 1) as i64 + p[1] as i64;
                            let gk = (2 * ek + 1) as i64 + p[2] as i64;
                            c[a] = block
                                .get(gi as usize, gj as usize, gk as usize)
                                .expect("Hex20 nodes exist on the fine grid");
                        }
                        c
                    };
                    let c = conn(1.0);
                    let c = if self.centre_jacobian(&c) < 0.0 {
                        conn(-1.0)
                    } else {
                        c
                    };
                    self.elements.push(c);
                }
            }
        }
        block
    }

    fn centre_jacobian(&self, conn: &[usize; 20]) -> f64 {
        let (_, dn) = super::fe::hex20_shape([0.0; 3]);
        let mut j = [[0.0; 3]; 3];
        for a in 0..20 {
            for r in 0..3 {
                for c in 0..3 {
                    j[r][c] += dn[a][r] * self.nodes[conn[a]][c];
                }
            }
        }
        j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
            - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
            + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0])
    }
}
