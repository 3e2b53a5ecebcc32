//! The cyclic Craig–Bampton reduced-order model (ROM) shared by every stage.
//!
//! # Conventions
//! - Axis of rotation: global `z`. Sector `s` (0-based) spans angles
//!   `[θ_s, θ_s + α]` with `α = 2π/N`, `θ_s = s α`, counter-clockwise about `+z`.
//! - Each sector carries the same `n_c` contact nodes. DOFs of sector `s` are
//!   expressed in its *sector-local frame*: the global Cartesian frame rotated by
//!   `θ_s` about `z`. Sector 0's local frame is the global frame.
//! - Nodal diameter `k` (0..=N/2): a physical field `u_s` is described by a
//!   complex amplitude `ũ` with `u_s = Re(ũ e^{i k θ_s})`; the right interface
//!   of sector 0 equals `e^{i k α}` times its left interface (both in local frames).
//!   With `ũ = a − i b` this is `u_s = a cos kθ_s + b sin kθ_s`.
//! - The reduced matrices of nodal diameter `k` are Hermitian `C = C_re + i C_im`
//!   over `[boundary DOFs (3 n_c, node-major, x y z); fixed-interface modal
//!   coordinates (n_m)]`. In the real basis `(a, b)` they act as
//!   `[[C_re, C_im], [−C_im, C_re]]` (symmetric since `C_im` is antisymmetric).
//!   For `k = 0` and `k = N/2` the imaginary part vanishes and only `a` exists.
//! - `K(Ω) = K0 + Ω² K1 + Ω⁴ K2` (impeller, rotating frame); a casing has `K1 = K2 = 0`.
//!
//! Units: SI (m, kg, s, N, rad/s); frequencies in the modal data are in Hz.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Version of the ROM data layout; bumped on any incompatible change.
pub const ROM_FORMAT_VERSION: u32 = 2;

/// Oldest ROM format version still read: version 1 files (no recovery matrix, no FE node ids of
/// the contact nodes) load with an empty [`Recovery`].
pub const ROM_FORMAT_OLDEST_READ: u32 = 1;

/// Which structure a ROM describes: it decides the frame (rotating or fixed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Component {
    /// Bladed wheel, modelled in the frame rotating at Ω.
    Impeller,
    /// Casing, modelled in the fixed frame.
    Casing,
}

/// Damping model of a ROM.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Damping {
    /// The same modal damping ratio ζ (dimensionless) on every free-vibration mode of the ROM.
    Modal {
        /// Modal damping ratio ζ (dimensionless, in [0, 1)).
        ratio: f64,
    },
    /// Rayleigh damping `D = α M + β K0`, α in 1/s and β in s.
    Rayleigh {
        /// Mass-proportional coefficient α (1/s).
        alpha: f64,
        /// Stiffness-proportional coefficient β (s).
        beta: f64,
    },
}

impl Default for Damping {
    fn default() -> Self {
        Damping::Modal { ratio: 0.005 }
    }
}

impl Damping {
    /// Checks the coefficients: a modal ratio in [0, 1) (1 is critical damping, beyond which
    /// no mode vibrates), Rayleigh α and β finite and ≥ 0.
    pub fn check(&self) -> Result<(), RomError> {
        match *self {
            Damping::Modal { ratio } if !(ratio.is_finite() && (0.0..1.0).contains(&ratio)) => Err(
                RomError::Damping(format!("modal ratio {ratio} must be in [0, 1)")),
            ),
            Damping::Rayleigh { alpha, beta }
                if !(alpha.is_finite() && beta.is_finite() && alpha >= 0.0 && beta >= 0.0) =>
            {
                Err(RomError::Damping(format!(
                    "Rayleigh coefficients ({alpha}, {beta}) must be finite and non-negative"
                )))
            }
            _ => Ok(()),
        }
    }
}

/// A Hermitian matrix stored as its real (symmetric) and imaginary (antisymmetric) parts.
#[derive(Clone, Debug, PartialEq)]
pub struct HermitianMatrix {
    /// Real part `C_re` (symmetric).
    pub re: DMatrix<f64>,
    /// Imaginary part `C_im` (antisymmetric; zero for k = 0 and k = N/2).
    pub im: DMatrix<f64>,
}

impl HermitianMatrix {
    /// A real symmetric matrix (imaginary part zero).
    pub fn real(re: DMatrix<f64>) -> Self {
        let n = re.nrows();
        Self {
            re,
            im: DMatrix::zeros(n, n),
        }
    }

    /// Order of the matrix.
    pub fn size(&self) -> usize {
        self.re.nrows()
    }

    /// Real representation `[[re, im], [−im, re]]` acting on `(a, b)`, or `re` alone when `real_only`.
    pub fn real_form(&self, real_only: bool) -> DMatrix<f64> {
        if real_only {
            return self.re.clone();
        }
        let n = self.size();
        let mut out = DMatrix::zeros(2 * n, 2 * n);
        out.view_mut((0, 0), (n, n)).copy_from(&self.re);
        out.view_mut((n, n), (n, n)).copy_from(&self.re);
        out.view_mut((0, n), (n, n)).copy_from(&self.im);
        out.view_mut((n, 0), (n, n)).copy_from(&(-&self.im));
        out
    }
}

/// Reduced matrices of one nodal diameter.
#[derive(Clone, Debug, PartialEq)]
pub struct HarmonicBlock {
    /// Nodal diameter k.
    pub nodal_diameter: usize,
    /// Number of fixed-interface modes `n_m` kept for this nodal diameter.
    pub n_modes: usize,
    /// Reduced mass (kg), order `3 n_c + n_m`.
    pub mass: HermitianMatrix,
    /// Reduced stiffness coefficients `[K0 (N/m), K1 (N/m per (rad/s)²), K2 (N/m per (rad/s)⁴)]`.
    pub stiffness: [HermitianMatrix; 3],
}

impl HarmonicBlock {
    /// Stiffness `K(Ω) = K0 + Ω² K1 + Ω⁴ K2` at rotation speed `omega` (rad/s).
    pub fn stiffness_at(&self, omega: f64) -> HermitianMatrix {
        let (w2, w4) = (omega * omega, omega.powi(4));
        let [k0, k1, k2] = &self.stiffness;
        HermitianMatrix {
            re: &k0.re + &k1.re * w2 + &k2.re * w4,
            im: &k0.im + &k1.im * w2 + &k2.im * w4,
        }
    }
}

/// A contact node of the reference sector.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactNode {
    /// Reference position in the global frame (m).
    pub position: [f64; 3],
    /// Index of the node along the meridian / blade tip, 0 = leading edge.
    pub row: usize,
    /// Node id in the FE model the ROM was imported from (`None` for built-in models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<usize>,
}

/// An FE node whose displacement can be recovered from the ROM coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecoveryNode {
    /// Node id (FE model id for imported models; documented numbering for built-ins).
    pub id: usize,
    /// Reference position in the global frame of sector 0 (m).
    pub position: [f64; 3],
    /// Documented name of a built-in model's node (`leading_edge_mid_span`, …; see
    /// [`crate::model::mesh::NamedNode`]); `None` for imported nodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

/// Rows of the reduction basis at chosen FE nodes: the recovery matrix (DESIGN §2.1, the
/// Craig–Bampton basis `T` of Batailly & Legrand 2015 eq. 2 restricted to those nodes).
///
/// For nodal diameter `k`, `rows[k]` is a complex `3 n_r × (3 n_c + n_m(k))` matrix `R_k`
/// (3 rows per node, x, y, z of the sector-local frame, node-major) with
/// `ũ_node = R_k x̃_k`, `x̃_k = a_k − i b_k` the complex harmonic amplitude of the ROM
/// coordinates. For a single component (N = 1) `R_0` is real and `u_node = R_0 x` exactly.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recovery {
    /// The recovered nodes (empty: no recovery).
    pub nodes: Vec<RecoveryNode>,
    /// One block per nodal diameter (empty when `nodes` is).
    pub rows: Vec<ComplexRows>,
}

/// A complex rectangular matrix as its real and imaginary parts (same shape).
#[derive(Clone, Debug, PartialEq)]
pub struct ComplexRows {
    /// Real part.
    pub re: DMatrix<f64>,
    /// Imaginary part, same shape as `re`.
    pub im: DMatrix<f64>,
}

impl Recovery {
    /// Index of the recovery node with FE id `id`.
    pub fn position_of(&self, id: usize) -> Option<usize> {
        self.nodes.iter().position(|n| n.id == id)
    }

    /// Index of the recovery node named `name` (built-in models).
    pub fn named(&self, name: &str) -> Option<usize> {
        self.nodes
            .iter()
            .position(|n| n.name.as_deref() == Some(name))
    }
}

/// The blade's shapes expressed in the ROM coordinates: what a structural mistuning acts
/// through (DESIGN §11, [`crate::model::mistuning`]).
///
/// Shape `j` is a motion ψ_j of the sector's blade elements, `M_b`-normalized, with
/// `ω_j² = ψ_jᵀ K_b ψ_j` (its Rayleigh quotient on the blade's elastic stiffness `K_b` and
/// mass `M_b`); the shapes are `K_b`-orthogonal, in the order of the blade strain energy of
/// the tuned modes they capture. For nodal diameter `k`, `rows[k]` is the complex
/// `n_bm × (3 n_c + n_m(k))` matrix `P_k` with `p_s = Σ_k Re(P_k x̃_k e^{i k θ_s})` the
/// coordinates `ψ_jᵀ K_b u_s / ω_j²` (√kg·m) of sector `s`'s blade. The strain energy of that
/// blade is `½ Σ_j ω_j² p_{s,j}²`, exactly for motions in the shapes' span.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BladeModes {
    /// `ω_j²` of each kept shape, (rad/s)², most energetic first (empty: no blade shapes).
    pub omega2: Vec<f64>,
    /// One block `P_k` per nodal diameter (empty when `omega2` is).
    pub rows: Vec<ComplexRows>,
}

/// Free-vibration data of one nodal diameter, for the Campbell diagram and the interaction criterion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModalData {
    /// Nodal diameter k.
    pub nodal_diameter: usize,
    /// Rotation speeds of the grid (rad/s); a single 0 for a casing.
    pub omega: Vec<f64>,
    /// Natural frequencies (Hz), `frequencies[i][p]` at `omega[i]`, ascending in `p`.
    pub frequencies: Vec<Vec<f64>>,
    /// Mode shapes at the contact nodes of sector 0 (complex amplitude `ũ`, real and
    /// imaginary parts, 3 n_c entries each), mass-normalized, at `omega[i]`: `shapes[i][p]`.
    /// This field holds the real parts (1/√kg).
    pub shapes_re: Vec<Vec<Vec<f64>>>,
    /// Imaginary parts of the mode shapes, indexed as `shapes_re` (1/√kg).
    pub shapes_im: Vec<Vec<Vec<f64>>>,
}

/// A cyclic Craig–Bampton ROM (DESIGN §2.1–2.2); a single non-cyclic component has `n_sectors = 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct CyclicRom {
    /// Human-readable name of the model.
    pub name: String,
    /// Impeller or casing.
    pub component: Component,
    /// Number of sectors N.
    pub n_sectors: usize,
    /// Contact nodes of sector 0 (the others follow by rotation).
    pub contact_nodes: Vec<ContactNode>,
    /// Reduced matrices for k = 0..=N/2, in order.
    pub harmonics: Vec<HarmonicBlock>,
    /// Free-vibration data per nodal diameter.
    pub modal_data: Vec<ModalData>,
    /// Damping model.
    pub damping: Damping,
    /// How the model was made (build spec or import description), free-form JSON.
    pub provenance: serde_json::Value,
    /// Recovery matrix of chosen interior FE nodes (empty when none were asked for).
    pub recovery: Recovery,
    /// The blade's modes in the span of the reduction basis, which a structural mistuning
    /// acts through (empty when none were asked for; see [`BladeModes`]). Boxed: the casing
    /// enums that hold a ROM stay small.
    pub blade_modes: Box<BladeModes>,
}

/// A ROM that fails validation; every variant names what is wrong.
#[derive(Debug, Error, PartialEq)]
pub enum RomError {
    /// `n_sectors` is 0.
    #[error("the ROM has no sectors (n_sectors = 0)")]
    NoSectors,
    /// The list of contact nodes is empty.
    #[error("the ROM has no contact nodes")]
    NoContactNodes,
    /// The number of harmonic blocks is not N/2 + 1.
    #[error("expected {expected} harmonic blocks (k = 0..={kmax}), found {found}")]
    HarmonicCount {
        /// Expected number of blocks, N/2 + 1.
        expected: usize,
        /// Largest nodal diameter, N/2.
        kmax: usize,
        /// Number of blocks found.
        found: usize,
    },
    /// A harmonic block is out of order (block `index` must have nodal diameter `index`).
    #[error("harmonic block {index} has nodal diameter {found}, expected {index}")]
    HarmonicOrder {
        /// Position of the block in `harmonics`.
        index: usize,
        /// Nodal diameter the block declares.
        found: usize,
    },
    /// A reduced matrix (or one of its parts) has the wrong size.
    #[error("{what} of nodal diameter {k} is {rows}×{cols}, expected {n}×{n}")]
    Shape {
        /// Which matrix: `"mass"`, `"K0"`, `"K1"` or `"K2"`.
        what: &'static str,
        /// Nodal diameter of the block.
        k: usize,
        /// Its number of rows.
        rows: usize,
        /// Its number of columns.
        cols: usize,
        /// Expected size, 3 n_c + n_m.
        n: usize,
    },
    /// A reduced matrix has a NaN or infinite entry.
    #[error("{what} of nodal diameter {k} has a non-finite entry at ({row}, {col})")]
    NotFinite {
        /// Which matrix: `"mass"`, `"K0"`, `"K1"` or `"K2"`.
        what: &'static str,
        /// Nodal diameter of the block.
        k: usize,
        /// Row of the entry (0-based).
        row: usize,
        /// Column of the entry (0-based).
        col: usize,
    },
    /// A reduced matrix is not Hermitian within the tolerance.
    #[error("{what} of nodal diameter {k} is not Hermitian (relative asymmetry {asym:.3e})")]
    NotHermitian {
        /// Which matrix: `"mass"`, `"K0"`, `"K1"` or `"K2"`.
        what: &'static str,
        /// Nodal diameter of the block.
        k: usize,
        /// Largest asymmetry relative to the largest entry (dimensionless).
        asym: f64,
    },
    /// A reduced matrix of nodal diameter 0 or N/2 has a non-zero imaginary part.
    #[error("{what} of nodal diameter {k} must be real for k = 0 and k = N/2")]
    NotReal {
        /// Which matrix: `"mass"`, `"K0"`, `"K1"` or `"K2"`.
        what: &'static str,
        /// Nodal diameter of the block.
        k: usize,
    },
    /// The reduced mass matrix of a block is not positive definite.
    #[error("mass of nodal diameter {k} is not positive definite")]
    MassNotPositiveDefinite {
        /// Nodal diameter of the block.
        k: usize,
    },
    /// A [`ModalData`] entry is inconsistent.
    #[error("modal data entry {index}: {reason}")]
    ModalData {
        /// Position of the entry in `modal_data`.
        index: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// The damping parameters are out of range (holds the reason).
    #[error("damping: {0}")]
    Damping(String),
    /// A contact node's reference position is NaN or infinite.
    #[error("contact node {index} has a non-finite coordinate")]
    ContactNodeNotFinite {
        /// Position of the node in `contact_nodes`.
        index: usize,
    },
    /// The recovery matrix is inconsistent with the ROM (holds the reason).
    #[error("recovery: {0}")]
    Recovery(String),
    /// The blade modes are inconsistent with the ROM (holds the reason).
    #[error("blade modes: {0}")]
    BladeModes(String),
}

/// Relative tolerance on the symmetry of stored matrices.
const HERMITIAN_TOL: f64 = 1e-9;

impl CyclicRom {
    /// Number of contact nodes per sector.
    pub fn n_contact(&self) -> usize {
        self.contact_nodes.len()
    }

    /// Number of boundary DOFs per sector (3 per contact node).
    pub fn n_boundary(&self) -> usize {
        3 * self.contact_nodes.len()
    }

    /// Largest nodal diameter N/2 (integer division).
    pub fn max_nodal_diameter(&self) -> usize {
        self.n_sectors / 2
    }

    /// Whether nodal diameter `k` is described by a real amplitude only (k = 0, or k = N/2 with N even).
    pub fn is_real_harmonic(&self, k: usize) -> bool {
        k == 0 || 2 * k == self.n_sectors
    }

    /// Total number of DOFs of the assembled physical ROM: every boundary DOF of every
    /// sector plus every modal coordinate (a complex mode counts twice).
    pub fn n_dofs(&self) -> usize {
        self.n_sectors * self.n_boundary()
            + self
                .harmonics
                .iter()
                .map(|h| {
                    h.n_modes
                        * if self.is_real_harmonic(h.nodal_diameter) {
                            1
                        } else {
                            2
                        }
                })
                .sum::<usize>()
    }

    /// Checks shapes, finiteness, Hermitian symmetry and positive definiteness of the mass.
    pub fn validate(&self) -> Result<(), RomError> {
        if self.n_sectors == 0 {
            return Err(RomError::NoSectors);
        }
        if self.contact_nodes.is_empty() {
            return Err(RomError::NoContactNodes);
        }
        for (index, node) in self.contact_nodes.iter().enumerate() {
            if node.position.iter().any(|x| !x.is_finite()) {
                return Err(RomError::ContactNodeNotFinite { index });
            }
        }
        let kmax = self.max_nodal_diameter();
        if self.harmonics.len() != kmax + 1 {
            return Err(RomError::HarmonicCount {
                expected: kmax + 1,
                kmax,
                found: self.harmonics.len(),
            });
        }
        for (index, h) in self.harmonics.iter().enumerate() {
            if h.nodal_diameter != index {
                return Err(RomError::HarmonicOrder {
                    index,
                    found: h.nodal_diameter,
                });
            }
            let n = self.n_boundary() + h.n_modes;
            let real = self.is_real_harmonic(index);
            let named = [
                ("mass", &h.mass),
                ("K0", &h.stiffness[0]),
                ("K1", &h.stiffness[1]),
                ("K2", &h.stiffness[2]),
            ];
            for (what, m) in named {
                check_hermitian(what, index, m, n, real)?;
            }
            if h.mass.real_form(real).cholesky().is_none() {
                return Err(RomError::MassNotPositiveDefinite { k: index });
            }
        }
        for (index, md) in self.modal_data.iter().enumerate() {
            let bad = |reason: String| Err(RomError::ModalData { index, reason });
            if md.nodal_diameter != index {
                return bad(format!("nodal diameter {} out of order", md.nodal_diameter));
            }
            if md.frequencies.len() != md.omega.len()
                || md.shapes_re.len() != md.omega.len()
                || md.shapes_im.len() != md.omega.len()
            {
                return bad("frequencies and shapes must have one entry per rotation speed".into());
            }
            if md
                .omega
                .iter()
                .chain(md.frequencies.iter().flatten())
                .any(|x| !x.is_finite())
            {
                return bad("non-finite rotation speed or frequency".into());
            }
        }
        self.validate_recovery()?;
        self.validate_blade_modes()?;
        self.damping.check()
    }
}

impl CyclicRom {
    /// Checks the blade modes: positive finite `ω²` and one finite block of
    /// `n_bm` rows per harmonic, real for the real harmonics.
    fn validate_blade_modes(&self) -> Result<(), RomError> {
        let b = &self.blade_modes;
        let bad = |m: String| Err(RomError::BladeModes(m));
        if b.omega2.is_empty() {
            return if b.rows.is_empty() {
                Ok(())
            } else {
                bad("rows without modes".into())
            };
        }
        if let Some(j) = b.omega2.iter().position(|w| !(w.is_finite() && *w > 0.0)) {
            return bad(format!("ω² of mode {j} is {} (rad/s)²", b.omega2[j]));
        }
        self.check_harmonic_rows(&b.rows, b.omega2.len())
            .map_err(RomError::BladeModes)
    }

    /// Checks the recovery matrix: one block per harmonic of `3 n_r` rows and the harmonic's
    /// order of columns, finite, real for the real harmonics; node ids unique and positions finite.
    fn validate_recovery(&self) -> Result<(), RomError> {
        let r = &self.recovery;
        let bad = |m: String| Err(RomError::Recovery(m));
        if r.nodes.is_empty() {
            return if r.rows.is_empty() {
                Ok(())
            } else {
                bad("recovery rows without recovery nodes".into())
            };
        }
        let mut ids = std::collections::HashSet::new();
        let mut names = std::collections::HashSet::new();
        for (i, n) in r.nodes.iter().enumerate() {
            if !ids.insert(n.id) {
                return bad(format!("node {} is listed twice", n.id));
            }
            if let Some(name) = &n.name
                && !names.insert(name)
            {
                return bad(format!("name `{name}` is given to two nodes"));
            }
            if n.position.iter().any(|x| !x.is_finite()) {
                return bad(format!(
                    "node {i} (id {}) has a non-finite coordinate",
                    n.id
                ));
            }
        }
        self.check_harmonic_rows(&r.rows, 3 * r.nodes.len())
            .map_err(RomError::Recovery)
    }

    /// Checks rows read against the ROM coordinates ([`Recovery`], [`BladeModes`]): one block
    /// per harmonic of `n_rows` rows and the harmonic's order of columns, finite, real for the
    /// real harmonics; the error says what is wrong.
    fn check_harmonic_rows(&self, rows: &[ComplexRows], n_rows: usize) -> Result<(), String> {
        if rows.len() != self.harmonics.len() {
            return Err(format!(
                "{} blocks of rows, expected one per nodal diameter ({})",
                rows.len(),
                self.harmonics.len()
            ));
        }
        for (k, (b, h)) in rows.iter().zip(&self.harmonics).enumerate() {
            let n = self.n_boundary() + h.n_modes;
            for (part, m) in [("re", &b.re), ("im", &b.im)] {
                if m.shape() != (n_rows, n) {
                    return Err(format!(
                        "rows of nodal diameter {k} ({part}) are {}×{}, expected {n_rows}×{n}",
                        m.nrows(),
                        m.ncols()
                    ));
                }
                if m.iter().any(|x| !x.is_finite()) {
                    return Err(format!(
                        "rows of nodal diameter {k} ({part}) are not finite"
                    ));
                }
            }
            if self.is_real_harmonic(k) && b.im.iter().any(|&x| x != 0.0) {
                return Err(format!("rows of nodal diameter {k} must be real"));
            }
        }
        Ok(())
    }
}

fn check_hermitian(
    what: &'static str,
    k: usize,
    m: &HermitianMatrix,
    n: usize,
    real: bool,
) -> Result<(), RomError> {
    for part in [&m.re, &m.im] {
        if part.nrows() != n || part.ncols() != n {
            return Err(RomError::Shape {
                what,
                k,
                rows: part.nrows(),
                cols: part.ncols(),
                n,
            });
        }
        if let Some(pos) = part.iter().position(|x| !x.is_finite()) {
            return Err(RomError::NotFinite {
                what,
                k,
                row: pos % n,
                col: pos / n,
            });
        }
    }
    let scale = m.re.amax().max(m.im.amax());
    if scale == 0.0 {
        return Ok(());
    }
    if real && m.im.amax() > HERMITIAN_TOL * scale {
        return Err(RomError::NotReal { what, k });
    }
    let asym = (&m.re - m.re.transpose())
        .amax()
        .max((&m.im + m.im.transpose()).amax())
        / scale;
    if asym > HERMITIAN_TOL {
        return Err(RomError::NotHermitian { what, k, asym });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-sector ROM with one contact node and one mode per harmonic: the smallest valid model.
    pub(crate) fn tiny_rom() -> CyclicRom {
        let n = 4;
        let harmonics = (0..=1)
            .map(|k| HarmonicBlock {
                nodal_diameter: k,
                n_modes: 1,
                mass: HermitianMatrix::real(DMatrix::identity(n, n)),
                stiffness: [
                    HermitianMatrix::real(DMatrix::identity(n, n) * 1e6),
                    HermitianMatrix::real(DMatrix::zeros(n, n)),
                    HermitianMatrix::real(DMatrix::zeros(n, n)),
                ],
            })
            .collect();
        CyclicRom {
            name: "tiny".into(),
            component: Component::Casing,
            n_sectors: 2,
            contact_nodes: vec![ContactNode {
                position: [0.1, 0.0, 0.0],
                row: 0,
                id: None,
            }],
            harmonics,
            modal_data: vec![],
            damping: Damping::default(),
            provenance: serde_json::Value::Null,
            recovery: Recovery::default(),
            blade_modes: Box::default(),
        }
    }

    #[test]
    fn tiny_rom_is_valid_and_counts_dofs() {
        let rom = tiny_rom();
        assert_eq!(rom.validate(), Ok(()));
        assert_eq!(rom.n_dofs(), 2 * 3 + 2);
    }

    #[test]
    fn rejects_non_symmetric_mass() {
        let mut rom = tiny_rom();
        rom.harmonics[1].mass.re[(0, 1)] = 0.5;
        assert!(matches!(
            rom.validate(),
            Err(RomError::NotHermitian {
                what: "mass",
                k: 1,
                ..
            })
        ));
    }

    #[test]
    fn rejects_indefinite_mass_nan_and_wrong_shape() {
        let mut rom = tiny_rom();
        rom.harmonics[0].mass.re[(2, 2)] = -1.0;
        assert_eq!(
            rom.validate(),
            Err(RomError::MassNotPositiveDefinite { k: 0 })
        );
        let mut rom = tiny_rom();
        rom.harmonics[0].stiffness[0].re[(1, 3)] = f64::NAN;
        assert!(matches!(
            rom.validate(),
            Err(RomError::NotFinite {
                what: "K0",
                k: 0,
                row: 1,
                col: 3
            })
        ));
        let mut rom = tiny_rom();
        rom.harmonics[1].stiffness[1] = HermitianMatrix::real(DMatrix::zeros(3, 3));
        assert!(matches!(
            rom.validate(),
            Err(RomError::Shape {
                what: "K1",
                k: 1,
                ..
            })
        ));
    }

    #[test]
    fn real_form_is_symmetric_for_hermitian_input() {
        let re = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 3.0]);
        let im = DMatrix::from_row_slice(2, 2, &[0.0, 0.7, -0.7, 0.0]);
        let r = HermitianMatrix { re, im }.real_form(false);
        assert_eq!(r, r.transpose());
    }
}
