//! Export of a cyclic sector mesh (the built-in impeller and casing, issue 40) as CalculiX
//! input decks, so that an independent solver can check rubscan's finite elements and its
//! reduced models: `ccx` solves the same sector with its own C3D20 element and its own cyclic
//! symmetry.
//!
//! Two decks per component, both plain text built without I/O ([`model_deck`],
//! [`frequency_deck`]):
//! - the *model* deck (`<name>_sector.inp`): `*NODE` (m), `*ELEMENT, TYPE=C3D20`, the node
//!   sets (cyclic faces, clamps, contact nodes in leading → trailing edge order, the named
//!   recovery nodes), `*MATERIAL` (`*ELASTIC` Pa, `*DENSITY` kg/m³), `*SOLID SECTION`, the
//!   clamps (`*BOUNDARY`), the cyclic faces as node surfaces tied by
//!   `*TIE, CYCLIC SYMMETRY` and `*CYCLIC SYMMETRY MODEL` about `+z` through the origin;
//! - the *frequency* deck (`<name>_frequencies.inp`): `*INCLUDE`s the model and adds one
//!   `*FREQUENCY` step over every nodal diameter `0..=N/2` at rest (Ω = 0, no prestress);
//! - the *prestressed* deck (`impeller_prestressed_<Ω>.inp`, per speed asked for): a linear
//!   `*STATIC` step under `CENTRIF` about +z, then the same frequency step as its
//!   `PERTURBATION`.
//!
//! # Correspondence with rubscan's model
//! - Element: rubscan's Hex20 node order *is* CalculiX's C3D20 order (corners as C3D8, then
//!   the mid-edge nodes of edges 1-2, 2-3, 3-4, 4-1, 5-6, 6-7, 7-8, 8-5, 1-5, 2-6, 3-7, 4-8;
//!   [`C3D20_EDGES`], checked by a test). rubscan integrates K and M with 3×3×3 Gauss points
//!   and a consistent mass: the full-integration C3D20 (not C3D20R), whose frequency step uses
//!   the consistent mass too.
//! - Ids: CalculiX node `i + 1` is rubscan node `i`, element `e + 1` is element `e`.
//! - Cyclic faces: CalculiX repeats the datum sector from the slave (dependent) surface to the
//!   master surface by the right-hand rule about the axis a → b. rubscan's sector spans
//!   θ ∈ [0, 2π/N] about `+z` and its right face is its left face turned by +2π/N, so the
//!   left face (θ = 0) is the slave and the right face (θ = 2π/N) the master, axis
//!   (0, 0, 0) → (0, 0, 1).
//! - Clamps: CalculiX refuses a boundary condition on a slave node (it is an MPC's dependent
//!   DOF). rubscan carries a clamp on a face node over to its partner on the other face, so
//!   the deck clamps every clamped node and the master partner of every clamped slave node, and
//!   no slave node: the tie then holds the clamped slave nodes at zero, as in rubscan.

use std::fmt::Write as _;

use crate::model::mesh::SectorMesh;

/// Mid-edge nodes of the C3D20 element (0-based, local): node `8 + i` lies on the edge between
/// corners `C3D20_EDGES[i]` (CalculiX manual, "Three-dimensional solid element C3D20"). The
/// corners 0–7 are those of C3D8: (−,−,−) (+,−,−) (+,+,−) (−,+,−) then the same at ζ = +1.
pub const C3D20_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [1, 2],
    [2, 3],
    [3, 0],
    [4, 5],
    [5, 6],
    [6, 7],
    [7, 4],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];

/// Names of the node sets and surfaces the model deck defines (upper case, as CalculiX
/// stores them).
pub mod sets {
    /// Every node.
    pub const ALL_NODES: &str = "NALL";
    /// Every element.
    pub const ALL_ELEMENTS: &str = "EALL";
    /// Nodes of the θ = 0 face (the cyclic slave side).
    pub const LEFT: &str = "LEFT";
    /// Nodes of the θ = 2π/N face (the cyclic master side).
    pub const RIGHT: &str = "RIGHT";
    /// rubscan's clamped nodes (all three DOFs fixed), slave nodes included.
    pub const CLAMPED: &str = "CLAMPED";
    /// The nodes the deck's `*BOUNDARY` fixes: [`CLAMPED`] and the master partners of clamped
    /// slave nodes, less the slave nodes.
    pub const FIXED: &str = "FIXED";
    /// Contact nodes, leading → trailing edge; `CONTACT_1`, `CONTACT_2`, … hold one each in
    /// that order (a set's order is not kept by every reader).
    pub const CONTACT: &str = "CONTACT";
    /// The slave (θ = 0) node surface.
    pub const SLAVE_SURFACE: &str = "CYCLIC_SLAVE";
    /// The master (θ = 2π/N) node surface.
    pub const MASTER_SURFACE: &str = "CYCLIC_MASTER";
    /// The cyclic symmetry tie.
    pub const TIE: &str = "CYCLIC";
}

/// A mesh that cannot be written as a CalculiX deck.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The mesh fails its own validation (indices, cyclic pairing, material).
    #[error("{component}: {source}")]
    Mesh {
        /// Which component (`"impeller"`, `"casing"`).
        component: String,
        /// The validation error.
        source: crate::model::mesh::MeshError,
    },
    /// The mesh is valid but not a cyclic sector CalculiX can solve (reason given).
    #[error("{component}: {reason}")]
    NotCyclic {
        /// Which component.
        component: String,
        /// Why.
        reason: String,
    },
}

/// Options of the frequency deck.
#[derive(Clone, Debug, PartialEq)]
pub struct FrequencyDeck {
    /// File name of the model deck to `*INCLUDE` (relative to the frequency deck).
    pub model_file: String,
    /// Eigenvalues CalculiX computes per nodal diameter (the `*FREQUENCY` data line).
    pub modes_per_diameter: usize,
    /// Rotation speed of the prestress, rad/s about +z: 0 solves at rest; otherwise a linear
    /// `*STATIC` step under `CENTRIF` (Ω²) comes first and the frequency step is its
    /// perturbation (stress stiffening, spin softening and initial-displacement stiffness).
    pub omega_rad_s: f64,
}

/// Number of eigenvalues per nodal diameter the exported frequency deck asks CalculiX for:
/// CalculiX's cyclic solve doubles the sector (cosine and sine parts), so every frequency of
/// a nodal diameter 0 < k < N/2 comes twice; 20 leaves at least 10 distinct frequencies on
/// every nodal diameter.
pub const DEFAULT_CALCULIX_MODES: usize = 20;

/// Checks that `mesh` is a cyclic sector CalculiX can take: valid, N ≥ 2, non-empty and
/// disjoint cyclic faces, elements and nodes present.
fn check(mesh: &SectorMesh, component: &str) -> Result<(), ExportError> {
    mesh.validate().map_err(|source| ExportError::Mesh {
        component: component.to_string(),
        source,
    })?;
    let fail = |reason: &str| {
        Err(ExportError::NotCyclic {
            component: component.to_string(),
            reason: reason.to_string(),
        })
    };
    if mesh.n_sectors < 2 {
        return fail("a cyclic deck needs at least 2 sectors");
    }
    if mesh.left_nodes.is_empty() {
        return fail("the sector has no cyclic faces (left_nodes is empty)");
    }
    if mesh.elements.is_empty() {
        return fail("the sector has no elements");
    }
    Ok(())
}

/// Writes the node ids (1-based) of `nodes` as a `*NSET` block, 10 per line.
fn write_nset(out: &mut String, name: &str, nodes: impl IntoIterator<Item = usize>) {
    let _ = writeln!(out, "*NSET, NSET={name}");
    let ids: Vec<String> = nodes.into_iter().map(|n| (n + 1).to_string()).collect();
    for chunk in ids.chunks(10) {
        let _ = writeln!(out, "{},", chunk.join(", "));
    }
}

/// The nodes the `*BOUNDARY` card fixes (0-based, sorted): the clamped nodes and the master
/// partners of clamped slave nodes, less the slave nodes (see the module notes).
pub fn fixed_nodes(mesh: &SectorMesh) -> Vec<usize> {
    let clamped: std::collections::BTreeSet<usize> = mesh.clamped_nodes.iter().copied().collect();
    let slave: std::collections::BTreeSet<usize> = mesh.left_nodes.iter().copied().collect();
    let mut fixed: std::collections::BTreeSet<usize> = clamped.clone();
    for (l, r) in mesh.left_nodes.iter().zip(&mesh.right_nodes) {
        if clamped.contains(l) || clamped.contains(r) {
            fixed.insert(*r);
        }
    }
    fixed.difference(&slave).copied().collect()
}

/// Widest real number field CalculiX reads: it parses each field of a data line from its
/// first 20 characters (`read(textpart(i)(1:20), '(f20.0)')`), so a longer field fails
/// ("*ERROR reading *NODE").
pub const MAX_FIELD: usize = 20;

/// `x` in at most [`MAX_FIELD`] characters, exactly when it can be: the shortest round-trip
/// text, in exponent form (`3.5e-2`) or, when that is too long, in plain decimals with the
/// zero before the point dropped (`-.030000000000000002`, which CalculiX's `f20.0` and Rust
/// both read); only when neither fits, the most significant digits that fit (15 for a
/// negative 17-digit number below 0.001, relative rounding below 1e-14; 13 for a negative
/// number with a three-digit exponent). Every coordinate of the built-in sectors has an exact
/// form, so an exported sector imports back to the same bits (`tests/calculix_import.rs`).
pub fn real_field(x: f64) -> String {
    let shortest = format!("{x:e}");
    if shortest.len() <= MAX_FIELD {
        return shortest;
    }
    let plain = format!("{x}");
    let plain = match (plain.strip_prefix("0."), plain.strip_prefix("-0.")) {
        (Some(rest), _) => format!(".{rest}"),
        (_, Some(rest)) => format!("-.{rest}"),
        _ => plain,
    };
    if plain.len() <= MAX_FIELD {
        return plain;
    }
    (0..16)
        .rev()
        .map(|digits| format!("{x:.digits$e}"))
        .find(|s| s.len() <= MAX_FIELD)
        .unwrap_or_else(|| format!("{x:.0e}"))
}

/// Nodes and elements of the model deck.
fn write_mesh(out: &mut String, mesh: &SectorMesh) {
    let _ = writeln!(out, "*NODE, NSET={}", sets::ALL_NODES);
    for (i, p) in mesh.nodes.iter().enumerate() {
        let [x, y, z] = p.map(real_field);
        let _ = writeln!(out, "{}, {x}, {y}, {z}", i + 1);
    }
    let _ = writeln!(out, "*ELEMENT, TYPE=C3D20, ELSET={}", sets::ALL_ELEMENTS);
    for (e, conn) in mesh.elements.iter().enumerate() {
        // 16 entries per line at most: the id and 15 nodes, then the last 5 nodes.
        let ids: Vec<String> = conn.iter().map(|n| (n + 1).to_string()).collect();
        let _ = writeln!(out, "{}, {},", e + 1, ids[..15].join(", "));
        let _ = writeln!(out, "{}", ids[15..].join(", "));
    }
}

/// The model-definition deck of a cyclic sector (see the module notes): mesh, sets, material,
/// clamps and cyclic symmetry, no step. `component` names the model in the heading and in
/// errors.
pub fn model_deck(mesh: &SectorMesh, component: &str) -> Result<String, ExportError> {
    check(mesh, component)?;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "** rubscan {} export: {component} sector, {} sectors, {} nodes, {} C3D20 elements",
        env!("CARGO_PKG_VERSION"),
        mesh.n_sectors,
        mesh.nodes.len(),
        mesh.elements.len()
    );
    let _ = writeln!(
        out,
        "** units SI (m, kg, s, N, Pa); node i+1 = rubscan node i; sector theta in [0, 2pi/N] about +z"
    );
    write_mesh(&mut out, mesh);
    write_nset(&mut out, sets::LEFT, mesh.left_nodes.iter().copied());
    write_nset(&mut out, sets::RIGHT, mesh.right_nodes.iter().copied());
    write_nset(&mut out, sets::CLAMPED, mesh.clamped_nodes.iter().copied());
    let fixed = fixed_nodes(mesh);
    write_nset(&mut out, sets::FIXED, fixed.iter().copied());
    write_nset(&mut out, sets::CONTACT, mesh.contact_nodes.iter().copied());
    for (j, &n) in mesh.contact_nodes.iter().enumerate() {
        write_nset(&mut out, &format!("{}_{}", sets::CONTACT, j + 1), [n]);
    }
    for named in &mesh.named_nodes {
        write_nset(&mut out, &named.name.to_ascii_uppercase(), [named.node]);
    }
    let m = mesh.material;
    let _ = writeln!(out, "*MATERIAL, NAME=MATERIAL");
    let _ = writeln!(
        out,
        "*ELASTIC\n{}, {}",
        real_field(m.young),
        real_field(m.poisson)
    );
    let _ = writeln!(out, "*DENSITY\n{}", real_field(m.density));
    let _ = writeln!(
        out,
        "*SOLID SECTION, ELSET={}, MATERIAL=MATERIAL",
        sets::ALL_ELEMENTS
    );
    if !fixed.is_empty() {
        let _ = writeln!(out, "*BOUNDARY\n{}, 1, 3", sets::FIXED);
    }
    let _ = writeln!(
        out,
        "*SURFACE, NAME={}, TYPE=NODE\n{}",
        sets::SLAVE_SURFACE,
        sets::LEFT
    );
    let _ = writeln!(
        out,
        "*SURFACE, NAME={}, TYPE=NODE\n{}",
        sets::MASTER_SURFACE,
        sets::RIGHT
    );
    let _ = writeln!(
        out,
        "*TIE, NAME={}, CYCLIC SYMMETRY\n{}, {}",
        sets::TIE,
        sets::SLAVE_SURFACE,
        sets::MASTER_SURFACE
    );
    let _ = writeln!(
        out,
        "*CYCLIC SYMMETRY MODEL, N={}, NGRAPH=1, TIE={}\n0., 0., 0., 0., 0., 1.",
        mesh.n_sectors,
        sets::TIE
    );
    Ok(out)
}

/// The frequency deck: includes the model deck and asks for `modes_per_diameter` eigenvalues
/// of every nodal diameter 0..=N/2 (`*SELECT CYCLIC SYMMETRY MODES`), at rest or prestressed
/// at `opts.omega_rad_s`; CalculiX prints them per nodal diameter in the job's `.dat` file.
pub fn frequency_deck(mesh: &SectorMesh, opts: &FrequencyDeck) -> String {
    let mut out = String::new();
    let omega = opts.omega_rad_s;
    let _ = writeln!(
        out,
        "** rubscan {}: cyclic frequencies per nodal diameter at Omega = {omega} rad/s",
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(out, "*INCLUDE, INPUT={}", opts.model_file);
    if omega != 0.0 {
        // Linear statics (no NLGEOM): the prestate rubscan's K(Ω) linearises about.
        let _ = writeln!(
            out,
            "*STEP\n*STATIC\n*DLOAD\n{}, CENTRIF, {}, 0., 0., 0., 0., 0., 1.\n*END STEP",
            sets::ALL_ELEMENTS,
            real_field(omega * omega)
        );
        let _ = writeln!(out, "*STEP, PERTURBATION");
    } else {
        let _ = writeln!(out, "*STEP");
    }
    let _ = writeln!(out, "*FREQUENCY\n{}", opts.modes_per_diameter);
    let _ = writeln!(
        out,
        "*SELECT CYCLIC SYMMETRY MODES, NMIN=0, NMAX={}",
        mesh.n_sectors / 2
    );
    let _ = writeln!(out, "*END STEP");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::mesh::{CasingGeometry, ImpellerGeometry};

    /// Natural coordinates of the C3D20 nodes from the CalculiX convention (C3D8 corners,
    /// mid-edge nodes at the midpoints of [`C3D20_EDGES`]).
    fn c3d20_natural() -> [[f64; 3]; 20] {
        let corners = [
            [-1.0, -1.0, -1.0],
            [1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, 1.0],
            [-1.0, 1.0, 1.0],
        ];
        let mut out = [[0.0; 3]; 20];
        out[..8].copy_from_slice(&corners);
        for (i, [a, b]) in C3D20_EDGES.iter().enumerate() {
            for d in 0..3 {
                out[8 + i][d] = 0.5 * (corners[*a][d] + corners[*b][d]);
            }
        }
        out
    }

    /// rubscan's Hex20 local nodes (natural coordinates, which the mesher and the element
    /// matrices both use) are the C3D20 nodes in CalculiX's order: the export writes the
    /// connectivity unchanged.
    #[test]
    fn hex20_order_is_the_c3d20_order() {
        let calculix = c3d20_natural();
        assert_eq!(crate::model::hex20::HEX20_NATURAL, calculix);
    }

    #[test]
    fn decks_name_every_set_and_fix_no_slave_node() {
        let mesh = CasingGeometry {
            n_sectors: 8,
            ..CasingGeometry::default()
        }
        .build()
        .unwrap();
        let deck = model_deck(&mesh, "casing").unwrap();
        for card in [
            "*ELEMENT, TYPE=C3D20, ELSET=EALL",
            "*TIE, NAME=CYCLIC, CYCLIC SYMMETRY\nCYCLIC_SLAVE, CYCLIC_MASTER",
            "*CYCLIC SYMMETRY MODEL, N=8, NGRAPH=1, TIE=CYCLIC\n0., 0., 0., 0., 0., 1.",
            "*BOUNDARY\nFIXED, 1, 3",
            "*NSET, NSET=CONTACT_5\n",
            "*NSET, NSET=OUTER_MID_MERIDIAN\n",
        ] {
            assert!(deck.contains(card), "missing {card:?}");
        }
        assert!(
            deck.lines().all(|l| l.len() <= 132),
            "a line exceeds 132 characters"
        );
        let fixed = fixed_nodes(&mesh);
        assert!(fixed.iter().all(|n| !mesh.left_nodes.contains(n)));
        // Every clamped node is fixed, or is a slave whose master partner is.
        for c in &mesh.clamped_nodes {
            let partner = mesh.left_nodes.iter().position(|l| l == c);
            let held =
                fixed.contains(c) || partner.is_some_and(|i| fixed.contains(&mesh.right_nodes[i]));
            assert!(held, "clamped node {c} is free in the deck");
        }
        let freq = frequency_deck(
            &mesh,
            &FrequencyDeck {
                model_file: "casing_sector.inp".into(),
                modes_per_diameter: 20,
                omega_rad_s: 0.0,
            },
        );
        assert!(freq.contains("*INCLUDE, INPUT=casing_sector.inp\n*STEP\n*FREQUENCY\n20\n"));
        assert!(freq.contains("NMIN=0, NMAX=4"));
        let prestressed = frequency_deck(
            &mesh,
            &FrequencyDeck {
                model_file: "casing_sector.inp".into(),
                modes_per_diameter: 20,
                omega_rad_s: 3000.0,
            },
        );
        let steps = "*STEP\n*STATIC\n*DLOAD\nEALL, CENTRIF, 9e6, 0., 0., 0., 0., 0., 1.\n\
                     *END STEP\n*STEP, PERTURBATION\n*FREQUENCY\n20\n";
        assert!(prestressed.contains(steps), "{prestressed}");
    }

    /// The model deck read back by rubscan's own CalculiX reader (through the frequency
    /// deck's `*INCLUDE`): every node within 1e-14 relative of the mesh, the face, clamp and
    /// contact sets in the mesh's order.
    #[test]
    fn the_deck_reads_back_as_the_mesh() {
        use crate::io::calculix::read_calculix_mesh;
        let mesh = ImpellerGeometry {
            n_blades: 6,
            ..ImpellerGeometry::default()
        }
        .build()
        .unwrap();
        let dir = std::env::temp_dir().join(format!("rubscan-export-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let opts = FrequencyDeck {
            model_file: "impeller_sector.inp".into(),
            modes_per_diameter: 4,
            omega_rad_s: 0.0,
        };
        std::fs::write(
            dir.join(&opts.model_file),
            model_deck(&mesh, "impeller").unwrap(),
        )
        .unwrap();
        let job = dir.join("impeller_frequencies.inp");
        std::fs::write(&job, frequency_deck(&mesh, &opts)).unwrap();
        let back = read_calculix_mesh(&job).unwrap();
        assert_eq!(back.nodes.len(), mesh.nodes.len());
        for (i, p) in mesh.nodes.iter().enumerate() {
            let q = back.nodes[&(i + 1)];
            for d in 0..3 {
                assert!(
                    (p[d] - q[d]).abs() <= 1e-14 * 0.2,
                    "node {i}: {p:?} vs {q:?}"
                );
            }
        }
        let ids = |v: &[usize]| v.iter().map(|n| n + 1).collect::<Vec<_>>();
        assert_eq!(back.node_sets[sets::LEFT], ids(&mesh.left_nodes));
        assert_eq!(back.node_sets[sets::RIGHT], ids(&mesh.right_nodes));
        assert_eq!(back.node_sets[sets::CLAMPED], ids(&mesh.clamped_nodes));
        assert_eq!(back.node_sets[sets::CONTACT], ids(&mesh.contact_nodes));
        assert_eq!(back.node_sets["LEADING_EDGE_MID_SPAN"].len(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Every real field fits CalculiX's 20 characters and reads back exactly when an exact
    /// form fits (plain decimals for 17 digits between 0.01 and 1), else within 1e-14 (1e-12
    /// with a three-digit exponent).
    #[test]
    fn real_fields_fit_calculix_and_round_trip() {
        for (x, tol) in [
            (2.4500392080940066e-3, 1e-14),
            (-7.784608481740518e-2, 0.0),
            (3.0000000000000004e-2, 0.0),
            (-7.784608481740518e-3, 1e-14),
            (-1.234_567_890_123_456_7e-100, 1e-12),
            (1.138e11, 0.0),
            (0.0, 0.0),
            (-0.0, 0.0),
            (-1.234_567_890_123_456_7e200, 1e-12),
        ] {
            let s = real_field(x);
            assert!(s.len() <= MAX_FIELD, "{s}");
            let back: f64 = s.parse().unwrap();
            assert!((back - x).abs() <= tol * x.abs(), "{x} -> {s}");
        }
    }

    #[test]
    fn a_sector_without_cyclic_faces_is_refused_by_name() {
        let blade = ImpellerGeometry::default().build_blade_only().unwrap();
        let err = model_deck(&blade, "blade").unwrap_err().to_string();
        assert!(
            err.starts_with("blade: ") && err.contains("sectors"),
            "{err}"
        );
    }
}
