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
    InvalidParameter {
        /// Name of the parameter.
        field: &'static str,
        /// Why its value is rejected.
        reason: String,
    },

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
    /// Named interior nodes whose displacement the ROM can recover (built-in models, see
    /// [`NamedNode`]); empty for other meshes.
    pub named_nodes: Vec<NamedNode>,
    /// Indices (into `elements`) of the blade's elements: those whose Young's modulus a
    /// structural mistuning scales (the disk keeps its own). Empty when the sector has no
    /// blade (casing) or the model does not name it.
    pub blade_elements: Vec<usize>,
}

/// A documented node of a built-in sector mesh, kept by the reduction as a recovery node:
/// its name (probe `point`) and its index in [`SectorMesh::nodes`] (the node's id).
#[derive(Clone, Debug, PartialEq)]
pub struct NamedNode {
    /// Name a probe gives (`leading_edge_mid_span`, …).
    pub name: String,
    /// Index of the node in the sector mesh.
    pub node: usize,
}

/// Impeller blade, leading edge (inlet, φ = 0), mid-thickness, at mid-span (the element corner
/// nearest mid-span when `elements_span` is odd).
pub const LEADING_EDGE_MID_SPAN: &str = "leading_edge_mid_span";
/// Impeller blade, trailing edge (outlet, φ = π/2), mid-thickness, at mid-span (as
/// [`LEADING_EDGE_MID_SPAN`]).
pub const TRAILING_EDGE_MID_SPAN: &str = "trailing_edge_mid_span";
/// Casing outer surface (away from the flow), mid-meridian (φ = π/4), on the θ = 0 face of
/// its sector: where an accelerometer on the casing skin sits.
pub const OUTER_MID_MERIDIAN: &str = "outer_mid_meridian";

impl SectorMesh {
    /// Sector angle α = 2π/N, rad.
    pub(crate) fn sector_angle(&self) -> f64 {
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
        if let Some(&e) = self
            .blade_elements
            .iter()
            .find(|&&e| e >= self.elements.len())
        {
            return Err(MeshError::InvalidMesh(format!(
                "blade_elements references element {e} but there are {} elements",
                self.elements.len()
            )));
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
pub(crate) struct MeshBuilder {
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
pub(crate) struct BlockNodes {
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
    /// coordinates s ∈ \[0,1\]³ to space. Element orientation is flipped where needed so that
    /// every Jacobian is positive at the element centre.
    pub(crate) fn add_block(
        &mut self,
        n: [usize; 3],
        map: impl Fn([f64; 3]) -> [f64; 3],
    ) -> BlockNodes {
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
                        for (a, p) in super::hex20::HEX20_NATURAL.iter().enumerate() {
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
        let (_, dn) = super::hex20::hex20_shape([0.0; 3]);
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

/// Meridian curve of a surface of revolution in the (r, z) half-plane, parametrised by
/// φ ∈ [0, π/2]: `r(φ) = r_in + (r_out − r_in)(1 − cos φ)`, `z(φ) = length · sin φ`.
/// At φ = 0 the curve is axial (inlet at z = 0), at φ = π/2 it is radial (outlet at z = length).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Meridian {
    /// Radius at the inlet (φ = 0), m.
    pub r_in: f64,
    /// Radius at the outlet (φ = π/2), m.
    pub r_out: f64,
    /// Axial position of the outlet, m (the inlet is at z = 0).
    pub length: f64,
}

impl Meridian {
    /// Point (r, z), m, at parameter φ (rad).
    pub fn point(&self, phi: f64) -> [f64; 2] {
        [
            self.r_in + (self.r_out - self.r_in) * (1.0 - phi.cos()),
            self.length * phi.sin(),
        ]
    }

    /// Unit tangent (dr, dz) at φ, pointing from inlet to outlet.
    pub fn tangent(&self, phi: f64) -> [f64; 2] {
        let t = [
            (self.r_out - self.r_in) * phi.sin(),
            self.length * phi.cos(),
        ];
        let n = (t[0] * t[0] + t[1] * t[1]).sqrt();
        [t[0] / n, t[1] / n]
    }

    /// Unit normal (r, z components) at φ on the flow side of a shroud curve: the tangent
    /// rotated by +90° in the (r, z) plane, i.e. (−1, 0) at the inlet and (0, +1) at the outlet.
    pub(crate) fn flow_normal(&self, phi: f64) -> [f64; 2] {
        let t = self.tangent(phi);
        [-t[1], t[0]]
    }

    fn validate(&self, field: &'static str) -> Result<(), MeshError> {
        if ![self.r_in, self.r_out, self.length]
            .iter()
            .all(|v| v.is_finite() && *v > 0.0)
        {
            return Err(bad(
                field,
                format!("r_in, r_out and length must be finite and > 0 (got {self:?})"),
            ));
        }
        if self.r_out < self.r_in {
            return Err(bad(
                field,
                format!("r_out = {} m must be >= r_in = {} m", self.r_out, self.r_in),
            ));
        }
        Ok(())
    }
}

/// Parametric casing: a shell of revolution whose inner (shroud) surface follows the
/// [`Meridian`] `shroud`, thickened outward (away from the flow) by `thickness`.
///
/// Defaults (small helicopter-turboshaft centrifugal compressor, SI units): N = 100 sectors,
/// M = 5 contact nodes, shroud r_in = 0.075 m → r_out = 0.120 m over L = 0.055 m, wall
/// thickness 3 mm, steel (E = 200 GPa, ν = 0.3, ρ = 7850 kg/m³), 8 × 1 × 1 elements
/// (meridian × circumference × thickness), plus a straight axial inlet duct of 15 mm (2 elements)
/// upstream of the leading edge whose upstream end face (the flange) is clamped: the contact
/// nodes, leading edge included, are then free to move, as on a real shroud.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CasingGeometry {
    /// Number of sectors N.
    pub n_sectors: usize,
    /// Contact nodes per sector M (on the inner surface of the θ = 0 face, equally spaced in φ).
    pub contact_nodes: usize,
    /// Inner (shroud) meridian, m.
    pub shroud: Meridian,
    /// Wall thickness along the outward normal, m.
    pub thickness: f64,
    /// Elements along the meridian (a multiple of M − 1).
    pub elements_meridian: usize,
    /// Elements per sector along the circumference.
    pub elements_circumferential: usize,
    /// Elements through the wall thickness.
    pub elements_thickness: usize,
    /// Length of the axial inlet duct upstream of the leading edge (z < 0), m; its upstream end
    /// face is the clamped flange.
    pub inlet_length: f64,
    /// Elements along the inlet duct.
    pub elements_inlet: usize,
    /// Casing material.
    pub material: Material,
}

/// Default shroud meridian shared by casing and impeller: r 0.075 → 0.120 m over 0.055 m.
pub(crate) const DEFAULT_SHROUD: Meridian = Meridian {
    r_in: 0.075,
    r_out: 0.120,
    length: 0.055,
};

impl Default for CasingGeometry {
    fn default() -> Self {
        CasingGeometry {
            n_sectors: 100,
            contact_nodes: 5,
            shroud: DEFAULT_SHROUD,
            thickness: 3.0e-3,
            elements_meridian: 8,
            elements_circumferential: 1,
            elements_thickness: 1,
            inlet_length: 0.015,
            elements_inlet: 2,
            material: Material::STEEL,
        }
    }
}

fn check_count(field: &'static str, v: usize, min: usize) -> Result<(), MeshError> {
    if v < min {
        return Err(bad(field, format!("{v} must be >= {min}")));
    }
    Ok(())
}

/// Contact nodes must be element corners: `elements_meridian` a multiple of `contact_nodes − 1`.
fn check_contact_spacing(elements_meridian: usize, contact_nodes: usize) -> Result<(), MeshError> {
    if !elements_meridian.is_multiple_of(contact_nodes - 1) {
        return Err(bad(
            "elements_meridian",
            format!(
                "{elements_meridian} must be a multiple of contact_nodes − 1 = {} so that contact nodes are element corners",
                contact_nodes - 1
            ),
        ));
    }
    Ok(())
}

/// Whether a default-zero field is left out when written (the model's hash, and so the job
/// ids of existing specs, stay as they were).
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn check_len(field: &'static str, v: f64) -> Result<(), MeshError> {
    if !(v.is_finite() && v > 0.0) {
        return Err(bad(field, format!("{v} m must be finite and > 0")));
    }
    Ok(())
}

impl CasingGeometry {
    /// Checks every parameter; the error names the offending field and the reason.
    pub fn validate(&self) -> Result<(), MeshError> {
        check_count("n_sectors", self.n_sectors, 3)?;
        check_count("contact_nodes", self.contact_nodes, 2)?;
        self.shroud.validate("shroud")?;
        check_len("thickness", self.thickness)?;
        check_count("elements_meridian", self.elements_meridian, 1)?;
        check_contact_spacing(self.elements_meridian, self.contact_nodes)?;
        check_count("elements_circumferential", self.elements_circumferential, 1)?;
        check_count("elements_thickness", self.elements_thickness, 1)?;
        check_len("inlet_length", self.inlet_length)?;
        check_count("elements_inlet", self.elements_inlet, 1)?;
        // The wall must not fold over itself where the meridian curves towards the flow side.
        let kmin = min_radius_of_curvature(&self.shroud);
        if self.thickness >= 0.5 * kmin {
            return Err(bad(
                "thickness",
                format!(
                    "{} m must be below half the smallest meridian radius of curvature ({kmin} m)",
                    self.thickness
                ),
            ));
        }
        self.material.validate()
    }

    /// Builds the casing sector mesh (θ ∈ [0, 2π/N]).
    pub fn build(&self) -> Result<SectorMesh, MeshError> {
        self.validate()?;
        let alpha = 2.0 * std::f64::consts::PI / self.n_sectors as f64;
        let n = [
            self.elements_meridian,
            self.elements_circumferential,
            self.elements_thickness,
        ];
        let mut b = MeshBuilder::new(1e-9 * self.shroud.r_out);
        let (sh, t) = (self.shroud, self.thickness);
        let blk = b.add_block(n, |[s0, s1, s2]| {
            let phi = s0 * std::f64::consts::FRAC_PI_2;
            let p = sh.point(phi);
            let nf = sh.flow_normal(phi);
            let (r, z) = (p[0] - s2 * t * nf[0], p[1] - s2 * t * nf[1]);
            let th = s1 * alpha;
            [r * th.cos(), r * th.sin(), z]
        });
        let (r_in, len) = (sh.r_in, self.inlet_length);
        let inlet = b.add_block([self.elements_inlet, n[1], n[2]], |[s0, s1, s2]| {
            let (r, z) = (r_in + s2 * t, -len * (1.0 - s0));
            let th = s1 * alpha;
            [r * th.cos(), r * th.sin(), z]
        });
        let [_, d1, d2] = blk.dims;
        let mut left = Vec::new();
        let mut right = Vec::new();
        // The duct's downstream face is the main block's upstream face: skip it once.
        for (block, first) in [(&inlet, 0), (&blk, 1)] {
            for i in first..block.dims[0] {
                for k in 0..d2 {
                    if let (Some(l), Some(r)) = (block.get(i, 0, k), block.get(i, d1 - 1, k)) {
                        left.push(l);
                        right.push(r);
                    }
                }
            }
        }
        let mut clamped = Vec::new();
        for j in 0..d1 {
            for k in 0..d2 {
                clamped.extend(inlet.get(0, j, k));
            }
        }
        let step = 2 * self.elements_meridian / (self.contact_nodes - 1);
        let contact = (0..self.contact_nodes)
            .map(|c| {
                blk.get(c * step, 0, 0)
                    .expect("contact nodes are corner nodes")
            })
            .collect();
        let mesh = SectorMesh {
            n_sectors: self.n_sectors,
            nodes: b.nodes,
            elements: b.elements,
            left_nodes: left,
            right_nodes: right,
            contact_nodes: contact,
            clamped_nodes: clamped,
            material: self.material,
            named_nodes: vec![NamedNode {
                name: OUTER_MID_MERIDIAN.into(),
                node: blk
                    .get(self.elements_meridian, 0, d2 - 1)
                    .expect("corner-line nodes exist"),
            }],
            blade_elements: vec![],
        };
        mesh.validate()?;
        Ok(mesh)
    }
}

fn min_radius_of_curvature(m: &Meridian) -> f64 {
    // The meridian is an ellipse arc with semi-axes (r_out − r_in, length): its smallest radius
    // of curvature is b²/a for the larger semi-axis a.
    let (a, b) = (
        (m.r_out - m.r_in).max(m.length),
        (m.r_out - m.r_in).min(m.length),
    );
    if b <= 0.0 { f64::INFINITY } else { b * b / a }
}

/// Parametric centrifugal impeller: a disk (back plate) under the hub curve spanning the whole
/// sector, and one radial blade per sector at mid-sector θ = α/2 (no lean), whose tip follows
/// the casing shroud curve offset towards the flow by `tip_clearance`.
///
/// Meridian layout: the blade fills, at each φ, the straight segment from the hub point
/// `hub(φ)` to the tip point `shroud(φ) + tip_clearance · n(φ)` (n = flow normal); the disk
/// fills the segment from `hub(φ)` to `back(φ)`. The disk's inlet face (φ = 0: z = 0,
/// r ∈ [back.r_in, hub.r_in], where the wheel sits against the shaft shoulder, down to the
/// bore radius `back.r_in`) is clamped.
///
/// Defaults (small helicopter-turboshaft centrifugal compressor, SI units): 10 blades; shroud
/// r 0.075 → 0.120 m over 0.055 m (as the casing); tip clearance 0.5 mm; hub r 0.035 → 0.120 m
/// over 0.063 m (blade height ≈ 39.5 mm at the inlet, 7.5 mm at the outlet); back/bore curve
/// r 0.015 → 0.120 m over 0.069 m (bore radius 15 mm, 6 mm rim); blade thickness 2.5 mm;
/// Ti-6Al-4V; 8 elements along the meridian, 6 along the span, 1 through the blade thickness,
/// 2 through the disk depth, 1 + 1 + 1 around the disk: 723 nodes, 2169 DOFs per sector;
/// 5 tip contact nodes (LE → TE, mid-thickness). The span resolution matters most for the
/// blade modes: the first root-clamped blade frequency is ≈ 2590 Hz with this mesh against
/// ≈ 2550 Hz for a 24 × 12 mesh (≈ 1.5–2 % stiff).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImpellerGeometry {
    /// Number of blades N_b (= number of sectors).
    pub n_blades: usize,
    /// Tip contact nodes per blade, from leading to trailing edge.
    pub contact_nodes: usize,
    /// Casing inner (shroud) meridian, m.
    pub shroud: Meridian,
    /// Radial/normal gap between blade tip and shroud, m.
    pub tip_clearance: f64,
    /// Hub curve (blade root, top of the disk), m.
    pub hub: Meridian,
    /// Back curve of the disk (bore at φ = 0, back face of the rim at φ = π/2), m.
    pub back: Meridian,
    /// Blade thickness (circumferential), m.
    pub blade_thickness: f64,
    /// Lean of the blade (degrees): its span line, from root to tip, turns by this angle out
    /// of the meridian plane, toward +θ (the direction of rotation for Ω > 0) when positive.
    /// 0 (default): radial blades, whose mid-surface is a meridian plane. A leaned blade bends
    /// under a circumferential tip force (friction) along its normal, which has a component
    /// across the tip clearance.
    #[serde(skip_serializing_if = "is_zero")]
    pub blade_lean_deg: f64,
    /// Elements along the meridian (blade and disk; a multiple of contact_nodes − 1).
    pub elements_meridian: usize,
    /// Elements along the blade span (hub → tip).
    pub elements_span: usize,
    /// Elements through the disk depth (hub → back).
    pub elements_disk_depth: usize,
    /// Disk elements around the circumference on each side of the blade.
    pub elements_disk_side: usize,
    /// Impeller material.
    pub material: Material,
}

impl Default for ImpellerGeometry {
    fn default() -> Self {
        ImpellerGeometry {
            n_blades: 10,
            contact_nodes: 5,
            shroud: DEFAULT_SHROUD,
            tip_clearance: 0.5e-3,
            hub: Meridian {
                r_in: 0.035,
                r_out: 0.120,
                length: 0.063,
            },
            back: Meridian {
                r_in: 0.015,
                r_out: 0.120,
                length: 0.069,
            },
            blade_thickness: 2.5e-3,
            blade_lean_deg: 0.0,
            elements_meridian: 8,
            elements_span: 6,
            elements_disk_depth: 2,
            elements_disk_side: 1,
            material: Material::TI6AL4V,
        }
    }
}

impl ImpellerGeometry {
    /// Checks every parameter; the error names the offending field and the reason.
    pub fn validate(&self) -> Result<(), MeshError> {
        check_count("n_blades", self.n_blades, 3)?;
        check_count("contact_nodes", self.contact_nodes, 2)?;
        self.shroud.validate("shroud")?;
        self.hub.validate("hub")?;
        self.back.validate("back")?;
        check_len("tip_clearance", self.tip_clearance)?;
        check_len("blade_thickness", self.blade_thickness)?;
        for (f, v) in [
            ("elements_meridian", self.elements_meridian),
            ("elements_span", self.elements_span),
            ("elements_disk_depth", self.elements_disk_depth),
            ("elements_disk_side", self.elements_disk_side),
        ] {
            check_count(f, v, 1)?;
        }
        check_contact_spacing(self.elements_meridian, self.contact_nodes)?;
        let kmin = min_radius_of_curvature(&self.shroud);
        if self.tip_clearance >= 0.5 * kmin {
            return Err(bad(
                "tip_clearance",
                format!(
                    "{} m is not small against the shroud curvature",
                    self.tip_clearance
                ),
            ));
        }
        // The flow path must be open: hub below the blade tip at the inlet, beyond it at the outlet.
        let tip0 = self.tip(0.0);
        let tip1 = self.tip(std::f64::consts::FRAC_PI_2);
        if self.hub.r_in >= tip0[0] {
            return Err(bad(
                "hub",
                format!(
                    "hub.r_in = {} m must be below the blade tip radius {} m at the inlet",
                    self.hub.r_in, tip0[0]
                ),
            ));
        }
        if self.hub.length <= tip1[1] {
            return Err(bad(
                "hub",
                format!(
                    "hub.length = {} m must exceed the blade tip z = {} m at the outlet",
                    self.hub.length, tip1[1]
                ),
            ));
        }
        if self.back.r_in >= self.hub.r_in {
            return Err(bad(
                "back",
                format!(
                    "back.r_in (bore) = {} m must be below hub.r_in = {} m",
                    self.back.r_in, self.hub.r_in
                ),
            ));
        }
        if self.back.length <= self.hub.length {
            return Err(bad(
                "back",
                format!(
                    "back.length = {} m must exceed hub.length = {} m (disk rim)",
                    self.back.length, self.hub.length
                ),
            ));
        }
        let alpha = 2.0 * std::f64::consts::PI / self.n_blades as f64;
        if self.blade_thickness >= 0.5 * alpha * self.back.r_in {
            return Err(bad(
                "blade_thickness",
                format!(
                    "{} m must be below half the sector arc at the bore ({} m)",
                    self.blade_thickness,
                    0.5 * alpha * self.back.r_in
                ),
            ));
        }
        self.check_lean()?;
        self.material.validate()
    }

    /// A lean of at most 45° that keeps the blade inside its sector along the whole tip (the
    /// blade's thickness checked already).
    fn check_lean(&self) -> Result<(), MeshError> {
        let lean = self.blade_lean_deg;
        if !(lean.is_finite() && lean.abs() <= 45.0) {
            return Err(bad(
                "blade_lean_deg",
                format!("{lean}° must be finite and within ±45°"),
            ));
        }
        if lean == 0.0 {
            return Ok(());
        }
        let alpha = 2.0 * std::f64::consts::PI / self.n_blades as f64;
        for i in 0..=32 {
            let phi = i as f64 / 32.0 * std::f64::consts::FRAC_PI_2;
            let r = self.tip(phi)[0];
            let reach = self.lean_angle(phi, 1.0).abs() + 0.5 * self.blade_thickness / r;
            if reach >= 0.5 * alpha {
                return Err(bad(
                    "blade_lean_deg",
                    format!(
                        "{lean}° takes the blade tip out of its sector at r = {r:.4} m \
                         ({reach:.3} rad from the root's meridian plane, half-sector {:.3} rad)",
                        0.5 * alpha
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Angle (rad) about the axis between the blade's point at meridian position φ and span
    /// fraction `span` (0 root, 1 tip) and its root: the lean's circumferential offset,
    /// `tan(lean) × (distance from the root along the span)`, over the point's radius.
    fn lean_angle(&self, phi: f64, span: f64) -> f64 {
        let (h, t) = (self.hub.point(phi), self.tip(phi));
        let r = h[0] + span * (t[0] - h[0]);
        let along = span * (t[0] - h[0]).hypot(t[1] - h[1]);
        self.blade_lean_deg.to_radians().tan() * along / r
    }

    /// Blade tip point (r, z), m, at φ: the shroud offset by the clearance along its flow normal.
    pub fn tip(&self, phi: f64) -> [f64; 2] {
        let p = self.shroud.point(phi);
        let n = self.shroud.flow_normal(phi);
        [
            p[0] + self.tip_clearance * n[0],
            p[1] + self.tip_clearance * n[1],
        ]
    }

    fn blade_map(&self, [s0, s1, s2]: [f64; 3]) -> [f64; 3] {
        let alpha = 2.0 * std::f64::consts::PI / self.n_blades as f64;
        let phi = s0 * std::f64::consts::FRAC_PI_2;
        let (h, t) = (self.hub.point(phi), self.tip(phi));
        let (r, z) = (h[0] + s2 * (t[0] - h[0]), h[1] + s2 * (t[1] - h[1]));
        let th = 0.5 * alpha + self.lean_angle(phi, s2) + (s1 - 0.5) * self.blade_thickness / r;
        [r * th.cos(), r * th.sin(), z]
    }

    /// Disk block `side` (0: θ from 0 to the blade, 1: under the blade, 2: from the blade to α).
    fn disk_map(&self, side: usize, [s0, s1, s2]: [f64; 3]) -> [f64; 3] {
        let alpha = 2.0 * std::f64::consts::PI / self.n_blades as f64;
        let phi = s0 * std::f64::consts::FRAC_PI_2;
        let (h, b) = (self.hub.point(phi), self.back.point(phi));
        let (r, z) = (h[0] + s2 * (b[0] - h[0]), h[1] + s2 * (b[1] - h[1]));
        let half = 0.5 * self.blade_thickness / r;
        let (t0, t1) = match side {
            0 => (0.0, 0.5 * alpha - half),
            1 => (0.5 * alpha - half, 0.5 * alpha + half),
            _ => (0.5 * alpha + half, alpha),
        };
        let th = t0 + s1 * (t1 - t0);
        [r * th.cos(), r * th.sin(), z]
    }

    /// Builds the impeller sector mesh (θ ∈ [0, 2π/N_b], blade at θ = α/2).
    pub fn build(&self) -> Result<SectorMesh, MeshError> {
        self.validate()?;
        let mut b = MeshBuilder::new(1e-9 * self.shroud.r_out);
        let nm = self.elements_meridian;
        let disk: Vec<BlockNodes> = [self.elements_disk_side, 1, self.elements_disk_side]
            .iter()
            .enumerate()
            .map(|(side, &nc)| {
                b.add_block([nm, nc, self.elements_disk_depth], |s| {
                    self.disk_map(side, s)
                })
            })
            .collect();
        let first_blade_element = b.elements.len();
        let blade = b.add_block([nm, 1, self.elements_span], |s| self.blade_map(s));
        let blade_elements = (first_blade_element..b.elements.len()).collect();
        let mut left = Vec::new();
        let mut right = Vec::new();
        let (l, r) = (&disk[0], &disk[2]);
        for i in 0..l.dims[0] {
            for k in 0..l.dims[2] {
                if let (Some(a), Some(c)) = (l.get(i, 0, k), r.get(i, r.dims[1] - 1, k)) {
                    left.push(a);
                    right.push(c);
                }
            }
        }
        let mut clamped: Vec<usize> = Vec::new();
        for blk in &disk {
            for j in 0..blk.dims[1] {
                for k in 0..blk.dims[2] {
                    clamped.extend(blk.get(0, j, k));
                }
            }
        }
        clamped.sort_unstable();
        clamped.dedup();
        let step = 2 * nm / (self.contact_nodes - 1);
        let tip = blade.dims[2] - 1;
        // Fine-grid span index of the element corner at (or nearest below) mid-span: with the
        // meridian index even, a corner exists at mid-thickness (j = 1).
        let mid = 2 * (self.elements_span / 2);
        let on_edge = "mid-thickness edge nodes at element corners exist";
        let contact = (0..self.contact_nodes)
            .map(|c| {
                blade
                    .get(c * step, 1, tip)
                    .expect("mid-thickness tip nodes exist")
            })
            .collect();
        let mesh = SectorMesh {
            n_sectors: self.n_blades,
            nodes: b.nodes,
            elements: b.elements,
            left_nodes: left,
            right_nodes: right,
            contact_nodes: contact,
            clamped_nodes: clamped,
            material: self.material,
            named_nodes: vec![
                NamedNode {
                    name: LEADING_EDGE_MID_SPAN.into(),
                    node: blade.get(0, 1, mid).expect(on_edge),
                },
                NamedNode {
                    name: TRAILING_EDGE_MID_SPAN.into(),
                    node: blade.get(2 * nm, 1, mid).expect(on_edge),
                },
            ],
            blade_elements,
        };
        mesh.validate()?;
        Ok(mesh)
    }

    /// The blade alone (no disk, non-cyclic), clamped at its root: used to check mesh convergence.
    #[cfg(test)]
    pub(crate) fn build_blade_only(&self) -> Result<SectorMesh, MeshError> {
        self.validate()?;
        let mut b = MeshBuilder::new(1e-9 * self.shroud.r_out);
        let blade = b.add_block([self.elements_meridian, 1, self.elements_span], |s| {
            self.blade_map(s)
        });
        let mut clamped = Vec::new();
        for i in 0..blade.dims[0] {
            for j in 0..blade.dims[1] {
                clamped.extend(blade.get(i, j, 0));
            }
        }
        Ok(SectorMesh {
            n_sectors: 1,
            nodes: b.nodes,
            elements: b.elements,
            left_nodes: vec![],
            right_nodes: vec![],
            contact_nodes: vec![],
            clamped_nodes: clamped,
            material: self.material,
            named_nodes: vec![],
            blade_elements: vec![],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn theta(p: [f64; 3]) -> f64 {
        p[1].atan2(p[0])
    }

    /// A leaned blade keeps its root on the disk and its nodes' meridian positions; its tip nodes turn
    /// about the axis by `tan(lean) × span length / r` (toward +θ for a positive lean). A
    /// lean beyond ±45° or out of the sector is refused, naming the field; no lean leaves the
    /// mesh as it was and the field unwritten.
    #[test]
    fn a_leaned_blade_turns_its_tip_about_the_axis() {
        let radial = ImpellerGeometry::default();
        let leaned = ImpellerGeometry {
            blade_lean_deg: -20.0,
            ..radial.clone()
        };
        let (a, b) = (radial.build().unwrap(), leaned.build().unwrap());
        // The same node count: the blade's root still merges with the disk.
        assert_eq!(a.nodes.len(), b.nodes.len());
        // Nodes move about the axis only.
        let moved: Vec<usize> = (0..a.nodes.len())
            .filter(|&i| a.nodes[i] != b.nodes[i])
            .collect();
        for &i in &moved {
            let (p, q) = (a.nodes[i], b.nodes[i]);
            assert!((p[0].hypot(p[1]) - q[0].hypot(q[1])).abs() < 1e-12 && p[2] == q[2]);
        }
        assert!(!moved.is_empty());
        let last = (radial.contact_nodes - 1) as f64;
        for (c, (&na, &nb)) in a.contact_nodes.iter().zip(&b.contact_nodes).enumerate() {
            let (p, q) = (a.nodes[na], b.nodes[nb]);
            let phi = c as f64 / last * FRAC_PI_2;
            let (h, t) = (radial.hub.point(phi), radial.tip(phi));
            let span = (t[0] - h[0]).hypot(t[1] - h[1]);
            let turn = theta(q) - theta(p);
            let expected = -(20f64.to_radians().tan()) * span / t[0];
            assert!(
                (turn - expected).abs() < 1e-12,
                "tip {c}: {turn} vs {expected}"
            );
        }
        for lean in [50.0, f64::NAN, 44.0] {
            let bad = ImpellerGeometry {
                blade_lean_deg: lean,
                ..radial.clone()
            };
            let err = bad.build().unwrap_err().to_string();
            assert!(err.contains("blade_lean_deg"), "{lean}: {err}");
        }
        let json = serde_json::to_value(&radial).unwrap();
        assert!(json.get("blade_lean_deg").is_none());
        assert_eq!(
            serde_json::to_value(&leaned).unwrap()["blade_lean_deg"],
            -20.0
        );
    }

    #[test]
    fn cyclic_faces_are_complete_and_paired() {
        for mesh in [
            CasingGeometry::default().build().unwrap(),
            ImpellerGeometry::default().build().unwrap(),
        ] {
            let alpha = mesh.sector_angle();
            let on_left = mesh
                .nodes
                .iter()
                .filter(|p| theta(**p).abs() < 1e-9)
                .count();
            let on_right = mesh
                .nodes
                .iter()
                .filter(|p| (theta(**p) - alpha).abs() < 1e-9)
                .count();
            assert_eq!(on_left, mesh.left_nodes.len());
            assert_eq!(on_right, mesh.right_nodes.len());
            for (&l, &r) in mesh.left_nodes.iter().zip(&mesh.right_nodes) {
                let (p, q) = (mesh.nodes[l], mesh.nodes[r]);
                assert!(theta(p).abs() < 1e-12 && (theta(q) - alpha).abs() < 1e-12);
                assert!(
                    (p[0].hypot(p[1]) - q[0].hypot(q[1])).abs() < 1e-12
                        && (p[2] - q[2]).abs() < 1e-15
                );
            }
            assert!(mesh.validate().is_ok());
        }
    }

    #[test]
    fn casing_contact_nodes_lie_on_the_inner_surface() {
        let g = CasingGeometry::default();
        let mesh = g.build().unwrap();
        let s = g.shroud;
        for (j, &c) in mesh.contact_nodes.iter().enumerate() {
            let p = mesh.nodes[c];
            assert!(p[1].abs() < 1e-15 && p[0] > 0.0, "on the θ = 0 face");
            // invert z(φ) = L sin φ, then check r(φ) = r_in + (r_out − r_in)(1 − cos φ)
            let phi = (p[2] / s.length).clamp(-1.0, 1.0).asin();
            let r = s.r_in + (s.r_out - s.r_in) * (1.0 - phi.cos());
            assert!((p[0] - r).abs() < 1e-12, "node {j}: r = {} vs {}", p[0], r);
            let expect_phi = j as f64 / (mesh.contact_nodes.len() - 1) as f64 * FRAC_PI_2;
            assert!(
                (phi - expect_phi).abs() < 1e-6,
                "node {j}: φ = {phi} vs {expect_phi}"
            );
        }
    }

    #[test]
    fn blade_tip_contact_nodes_at_the_requested_clearance() {
        let g = ImpellerGeometry {
            tip_clearance: 0.8e-3,
            ..Default::default()
        };
        let mesh = g.build().unwrap();
        let alpha = mesh.sector_angle();
        for &c in &mesh.contact_nodes {
            let p = mesh.nodes[c];
            assert!((theta(p) - 0.5 * alpha).abs() < 1e-12, "mid-thickness node");
            let (r, z) = (p[0].hypot(p[1]), p[2]);
            // distance to the shroud meridian by dense sampling then golden-section refinement
            let d = |phi: f64| {
                let q = g.shroud.point(phi);
                (q[0] - r).hypot(q[1] - z)
            };
            let n = 4000;
            let i0 = (0..=n)
                .min_by(|&a, &b| {
                    d(a as f64 * FRAC_PI_2 / n as f64)
                        .total_cmp(&d(b as f64 * FRAC_PI_2 / n as f64))
                })
                .unwrap();
            let (mut lo, mut hi) = (
                (i0.max(1) - 1) as f64 * FRAC_PI_2 / n as f64,
                ((i0 + 1).min(n)) as f64 * FRAC_PI_2 / n as f64,
            );
            for _ in 0..200 {
                let (a, b) = (lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo));
                if d(a) < d(b) { hi = b } else { lo = a }
            }
            let dist = d(0.5 * (lo + hi));
            assert!(
                (dist - g.tip_clearance).abs() < 1e-10,
                "distance {dist} vs clearance {}",
                g.tip_clearance
            );
            // and on the flow side: inside the casing (r below the shroud radius at this z, or beyond z at the outlet)
        }
    }

    #[test]
    fn specs_deserialize_with_defaults_and_reject_bad_input() {
        let c: CasingGeometry = serde_json::from_str("{}").unwrap();
        assert_eq!(c, CasingGeometry::default());
        let i: ImpellerGeometry = serde_json::from_str(r#"{"tip_clearance": 0.001}"#).unwrap();
        assert_eq!(i.tip_clearance, 0.001);
        assert!(serde_json::from_str::<CasingGeometry>(r#"{"thicknes": 0.001}"#).is_err());
        let bad_c = CasingGeometry {
            elements_meridian: 6,
            ..Default::default()
        };
        match bad_c.validate() {
            Err(MeshError::InvalidParameter { field, .. }) => {
                assert_eq!(field, "elements_meridian")
            }
            other => panic!("unexpected {other:?}"),
        }
        let bad_i = ImpellerGeometry {
            blade_thickness: -1.0,
            ..Default::default()
        };
        match bad_i.build() {
            Err(MeshError::InvalidParameter { field, .. }) => assert_eq!(field, "blade_thickness"),
            other => panic!("unexpected {other:?}"),
        }
        let bad_hub = ImpellerGeometry {
            hub: Meridian {
                r_in: 0.08,
                ..ImpellerGeometry::default().hub
            },
            ..Default::default()
        };
        assert!(matches!(
            bad_hub.validate(),
            Err(MeshError::InvalidParameter { field: "hub", .. })
        ));
    }
}
