//! Import of a cyclic sector from a CalculiX input deck (issue 40): an impeller or casing
//! sector meshed with C3D20 elements, its two cyclic faces, its clamps and its contact nodes,
//! reduced exactly as the built-in models are (all nodal diameters, the impeller's
//! K(Ω) = K0 + Ω² K1 + Ω⁴ K2 from its centrifugal prestress).
//!
//! # Why the mesh, not `*MATRIXSTORAGE`
//! rubscan assembles the sector's K, M and K1 itself from the deck's mesh and material with
//! its own C3D20 element (full 3×3×3 integration, consistent mass, the element CalculiX uses;
//! `tests/calculix_export.rs` checks it against `ccx`'s cyclic solve). That gives the
//! centrifugal stiffening from the same linear prestress as the built-in impeller (stress
//! stiffening and initial-displacement stiffness from the nodal-diameter-0 static solution
//! under `ρΩ²r`, spin softening from the mass matrix) at any speed, where CalculiX's matrix storage holds one speed's matrices per
//! run and no record of which DOFs the cyclic tie made dependent. The price: C3D20 elements
//! and one isotropic material only; other decks are refused with the element or material
//! named.
//!
//! # What is read from the deck ([`crate::io::calculix_deck`])
//! - nodes and C3D20 elements (nodes no element uses are dropped);
//! - the one `*MATERIAL` (`*ELASTIC` isotropic E, ν; `*DENSITY`);
//! - the number of sectors N from `*CYCLIC SYMMETRY MODEL, N=`, whose axis must be `+z`
//!   through the origin;
//! - the cyclic faces: node sets named by the spec, else the slave (θ = 0, rubscan's left)
//!   and master (θ = 2π/N, right) node surfaces of the card's `*TIE, CYCLIC SYMMETRY`;
//! - the clamped nodes: a node set named by the spec, else every node `*BOUNDARY` fixes in
//!   its three translations.
//!
//! Before any assembly the faces are paired by rotation through 2π/N (unmatched nodes named,
//! an angle that does not divide 2π refused), the contact nodes are checked to lie on the
//! mesh's free surface, and every set is resolved.

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::io::calculix::{ContactSelection, Units};
use crate::io::calculix_deck::{CalculixMesh, read_calculix_mesh};
use crate::io::text_lines::ImportError;
use crate::model::build::{
    BuildError, DEFAULT_MODES_PER_DIAMETER, Prestress, check_omega_grid, reduce_sector,
};
use crate::model::mesh::{Material, NamedNode, SectorMesh};
use crate::model::rom::{Component, CyclicRom, Damping};
use crate::model::sector_faces::{free_surface_nodes, measured_sector_count, pair_faces};

/// What `rubscan model import calculix-cyclic` needs (JSON; unknown fields are errors).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalculixSectorSpec {
    /// Name stored in the ROM.
    pub name: String,
    /// Impeller (rotating, K(Ω)) or casing.
    pub component: Component,
    /// The sector's input deck (`*INCLUDE`s followed).
    pub deck: PathBuf,
    /// Contact nodes, leading → trailing edge (blade tip; casing inner surface row).
    pub contact: ContactSelection,
    /// Node set of the θ = 0 face; default: the slave surface of the deck's cyclic tie.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub left_nodes: Option<String>,
    /// Node set of the θ = 2π/N face; default: the master surface of the deck's cyclic tie.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub right_nodes: Option<String>,
    /// Node set of the clamped nodes; default: the nodes `*BOUNDARY` fixes in x, y and z.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clamped_nodes: Option<String>,
    /// Fixed-interface modes per nodal diameter.
    #[serde(default = "default_modes")]
    pub modes_per_diameter: usize,
    /// Impeller only: speeds (rad/s) of the stored modal data; default: the built-in
    /// impeller's grid (0 to 7000 rad/s every 500).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega_grid_rad_s: Option<Vec<f64>>,
    /// Impeller only: how K(Ω) follows the speed (default `"consistent"`, as CalculiX's
    /// prestressed perturbation step; `"stress_stiffening"` leaves out the
    /// initial-displacement stiffness).
    #[serde(default, skip_serializing_if = "Prestress::is_default")]
    pub prestress: Prestress,
    /// Unit system of the deck (`"si"` or `"mm-t-s"`).
    pub units: Units,
    /// Damping stored in the ROM.
    #[serde(default)]
    pub damping: Damping,
    /// Probe point names → one-node `*NSET`s of the deck: nodes the ROM can recover.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub named_nodes: BTreeMap<String, String>,
}

fn default_modes() -> usize {
    DEFAULT_MODES_PER_DIAMETER
}

/// A sector mesh read from a deck, with the deck's node id of each mesh node.
#[derive(Clone, Debug)]
pub struct ImportedSector {
    /// The mesh in SI units, nodes numbered 0.. in increasing deck id.
    pub mesh: SectorMesh,
    /// Deck node id of each mesh node.
    pub node_ids: Vec<usize>,
    /// Largest distance (m) a right-face node was moved to lie exactly on its left partner
    /// turned by 2π/N.
    pub face_snap_m: f64,
}

/// Reads, checks and reduces a cyclic sector deck (see the module notes).
pub fn import_calculix_sector(spec: &CalculixSectorSpec) -> Result<CyclicRom, ImportError> {
    let grid = match (spec.component, &spec.omega_grid_rad_s) {
        (Component::Casing, Some(_)) => {
            return Err(ImportError::Spec(
                "omega_grid_rad_s: the casing does not rotate; give it for an impeller only".into(),
            ));
        }
        (Component::Casing, None) if !spec.prestress.is_default() => {
            return Err(ImportError::Spec(
                "prestress: the casing does not rotate; give it for an impeller only".into(),
            ));
        }
        (Component::Casing, None) => vec![0.0],
        (Component::Impeller, Some(g)) => g.clone(),
        (Component::Impeller, None) => {
            crate::model::build::ImpellerSpec::default().omega_grid_rad_s
        }
    };
    check_omega_grid("omega_grid_rad_s", &grid).map_err(|e| ImportError::Spec(e.to_string()))?;
    if spec.modes_per_diameter == 0 {
        return Err(ImportError::Spec(
            "modes_per_diameter must be at least 1".into(),
        ));
    }
    let sector = read_sector(spec)?;
    let mut rom = reduce_sector(
        spec.component,
        &sector.mesh,
        crate::model::build::SectorReduction {
            modes_per_diameter: spec.modes_per_diameter,
            omega_grid: grid,
            blade_modes: 0,
        },
        spec.prestress,
        spec.damping,
        spec.name.clone(),
    )
    .map_err(|e: BuildError| ImportError::File {
        file: spec.deck.clone(),
        reason: e.to_string(),
    })?;
    for node in &mut rom.recovery.nodes {
        node.id = sector.node_ids[node.id];
    }
    rom.provenance = serde_json::json!({
        "import": "calculix-cyclic",
        "spec": spec,
        "rubscan": env!("CARGO_PKG_VERSION"),
        "n_nodes": sector.mesh.nodes.len(),
        "n_elements": sector.mesh.elements.len(),
        "n_sectors": sector.mesh.n_sectors,
        "contact_node_ids": sector.mesh.contact_nodes.iter().map(|&i| sector.node_ids[i]).collect::<Vec<_>>(),
        "right_face_snap_m": sector.face_snap_m,
    });
    rom.validate()?;
    Ok(rom)
}

/// Reads the deck of `spec` into a checked, paired [`SectorMesh`] in SI units.
pub fn read_sector(spec: &CalculixSectorSpec) -> Result<ImportedSector, ImportError> {
    let deck_path = spec.deck.as_path();
    let deck = read_calculix_mesh(deck_path)?;
    let bad = |reason: String| ImportError::File {
        file: deck_path.to_path_buf(),
        reason,
    };
    let (node_ids, elements) = c3d20_elements(&deck).map_err(bad)?;
    let index: HashMap<usize, usize> = node_ids
        .iter()
        .enumerate()
        .map(|(i, &id)| (id, i))
        .collect();
    let length = spec.units.length_factor();
    let nodes: Vec<[f64; 3]> = node_ids
        .iter()
        .map(|id| deck.nodes[id].map(|c| c * length))
        .collect();
    let material = material(&deck, spec.units).map_err(bad)?;
    let n_sectors = cyclic_card(&deck).map_err(bad)?;
    let resolve = |what: &str, set: &str| -> Result<Vec<usize>, ImportError> {
        set_nodes(&deck, set)
            .ok_or_else(|| bad(format!("{what}: no node set or node surface '{set}'")))?
            .iter()
            .map(|id| {
                index.get(id).copied().ok_or_else(|| {
                    bad(format!(
                        "{what} ('{set}'): node {id} is not a node of a C3D20 element"
                    ))
                })
            })
            .collect()
    };
    let (left_set, right_set) = face_sets(spec, &deck).map_err(bad)?;
    let left = dedup(resolve("left_nodes", &left_set)?);
    let right = dedup(resolve("right_nodes", &right_set)?);
    let id_of = |i: usize| node_ids[i];
    let measured =
        measured_sector_count(&nodes, &left, &right, &id_of).map_err(|e| bad(e.to_string()))?;
    if measured != n_sectors {
        return Err(bad(crate::model::sector_faces::FaceError::SectorCount {
            declared: n_sectors,
            measured,
        }
        .to_string()));
    }
    let right =
        pair_faces(&nodes, &left, &right, n_sectors, &id_of).map_err(|e| bad(e.to_string()))?;
    let mut nodes = nodes;
    let face_snap_m = snap_right_face(&mut nodes, &left, &right, n_sectors);
    let clamped = match &spec.clamped_nodes {
        Some(set) => dedup(resolve("clamped_nodes", set)?),
        None => boundary_clamps(&deck, deck_path, &index)?,
    };
    let cyclic: HashSet<usize> = left.iter().chain(&right).copied().collect();
    let contact_nodes =
        contact_nodes(spec, &deck, &index, &elements, &cyclic, &clamped).map_err(bad)?;
    let named_nodes = spec
        .named_nodes
        .iter()
        .map(|(name, set)| {
            let nodes = resolve(&format!("named_nodes.{name}"), set)?;
            match nodes[..] {
                [node] => Ok(NamedNode {
                    name: name.clone(),
                    node,
                }),
                _ => Err(bad(format!(
                    "named_nodes.{name}: set '{set}' holds {} nodes, not one",
                    nodes.len()
                ))),
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mesh = SectorMesh {
        n_sectors,
        nodes,
        elements,
        left_nodes: left,
        right_nodes: right,
        contact_nodes,
        clamped_nodes: clamped,
        material,
        named_nodes,
        blade_elements: vec![],
    };
    mesh.validate().map_err(|e| bad(e.to_string()))?;
    Ok(ImportedSector {
        mesh,
        node_ids,
        face_snap_m,
    })
}

fn dedup(mut v: Vec<usize>) -> Vec<usize> {
    let mut seen = HashSet::new();
    v.retain(|x| seen.insert(*x));
    v
}

/// The deck's nodes used by its elements (sorted ids) and the elements as 0-based Hex20
/// connectivity; every element must be a C3D20 with 20 defined nodes.
fn c3d20_elements(deck: &CalculixMesh) -> Result<(Vec<usize>, Vec<[usize; 20]>), String> {
    if deck.elements.is_empty() {
        return Err("no *ELEMENT data: a sector deck needs its C3D20 elements".into());
    }
    let mut used = BTreeSet::new();
    for e in &deck.elements {
        if e.kind != "C3D20" {
            return Err(format!(
                "element {} is a {}: rubscan assembles a sector itself and supports C3D20 \
                 elements only (full integration; not C3D20R)",
                e.id, e.kind
            ));
        }
        if e.nodes.len() != 20 {
            return Err(format!(
                "element {} has {} nodes, a C3D20 has 20 (a truncated deck?)",
                e.id,
                e.nodes.len()
            ));
        }
        if let Some(n) = e.nodes.iter().find(|n| !deck.nodes.contains_key(n)) {
            return Err(format!(
                "element {} uses node {n}, which no *NODE defines",
                e.id
            ));
        }
        used.extend(e.nodes.iter().copied());
    }
    let ids: Vec<usize> = used.into_iter().collect();
    let index: HashMap<usize, usize> = ids.iter().enumerate().map(|(i, &id)| (id, i)).collect();
    let elements = deck
        .elements
        .iter()
        .map(|e| std::array::from_fn(|a| index[&e.nodes[a]]))
        .collect();
    Ok((ids, elements))
}

/// The deck's one isotropic material in SI units.
fn material(deck: &CalculixMesh, units: Units) -> Result<Material, String> {
    let [m] = &deck.materials[..] else {
        return Err(format!(
            "{} *MATERIAL cards: a sector needs exactly one (rubscan's sectors are homogeneous)",
            deck.materials.len()
        ));
    };
    let name = &m.name;
    let (kind, data) = m
        .elastic
        .as_ref()
        .ok_or_else(|| format!("material {name} has no *ELASTIC"))?;
    let [young, poisson, ..] = data[..] else {
        return Err(format!("material {name}: *ELASTIC needs 'E, ν'"));
    };
    if kind != "ISO" {
        return Err(format!(
            "material {name}: *ELASTIC, TYPE={kind} is not supported (isotropic only)"
        ));
    }
    let density = m
        .density
        .ok_or_else(|| format!("material {name} has no *DENSITY"))?;
    let l = units.length_factor();
    let material = Material {
        young: young * units.stiffness_factor() / l,
        poisson,
        density: density * units.mass_factor() / (l * l * l),
    };
    material
        .validate()
        .map_err(|e| format!("material {name}: {e}"))?;
    Ok(material)
}

/// N of the deck's one `*CYCLIC SYMMETRY MODEL`, whose axis must be `+z` through the origin.
fn cyclic_card(deck: &CalculixMesh) -> Result<usize, String> {
    let [card] = &deck.cyclic_models[..] else {
        return Err(format!(
            "{} *CYCLIC SYMMETRY MODEL cards: a sector deck needs exactly one (N = sectors)",
            deck.cyclic_models.len()
        ));
    };
    let [a, b] = card
        .axis
        .ok_or("*CYCLIC SYMMETRY MODEL has no axis line 'ax, ay, az, bx, by, bz'")?;
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let scale = d[2].abs().max(f64::MIN_POSITIVE);
    let off_axis = [a[0], a[1], d[0], d[1]]
        .iter()
        .any(|c| c.abs() > 1e-12 * scale.max(1.0));
    if off_axis || d[2] <= 0.0 {
        return Err(format!(
            "*CYCLIC SYMMETRY MODEL: the axis {a:?} → {b:?} is not +z through the origin, \
             about which rubscan's sectors turn"
        ));
    }
    Ok(card.n_sectors)
}

/// Node ids of a node set, or of a node surface's sets and ids (upper-cased names).
fn set_nodes(deck: &CalculixMesh, name: &str) -> Option<Vec<usize>> {
    let key = name.to_uppercase();
    if let Some(ids) = deck.node_sets.get(&key) {
        return Some(ids.clone());
    }
    let entries = deck.node_surfaces.get(&key)?;
    let mut ids = Vec::new();
    for entry in entries {
        match entry.parse::<usize>() {
            Ok(id) => ids.push(id),
            Err(_) => ids.extend(deck.node_sets.get(entry)?),
        }
    }
    Some(ids)
}

/// The left and right face set names: the spec's, else the cyclic tie's slave and master.
fn face_sets(spec: &CalculixSectorSpec, deck: &CalculixMesh) -> Result<(String, String), String> {
    if let (Some(l), Some(r)) = (&spec.left_nodes, &spec.right_nodes) {
        return Ok((l.clone(), r.clone()));
    }
    let tie = deck
        .cyclic_models
        .first()
        .map(|c| c.tie.clone())
        .unwrap_or_default();
    let (slave, master) = deck.cyclic_ties.get(&tie).cloned().ok_or_else(|| {
        format!(
            "no *TIE, NAME={tie}, CYCLIC SYMMETRY: name the faces with left_nodes and right_nodes"
        )
    })?;
    Ok((
        spec.left_nodes.clone().unwrap_or(slave),
        spec.right_nodes.clone().unwrap_or(master),
    ))
}

/// Nodes `*BOUNDARY` fixes in all three translations, as mesh indices; a node fixed in only
/// some, or to a non-zero value, is refused (rubscan clamps whole nodes at rest).
fn boundary_clamps(
    deck: &CalculixMesh,
    deck_path: &Path,
    index: &HashMap<usize, usize>,
) -> Result<Vec<usize>, ImportError> {
    // Keyed by deck id: mesh indices follow increasing deck ids, so the order is the same.
    let mut fixed: BTreeMap<usize, BTreeSet<usize>> = BTreeMap::new();
    for b in &deck.boundaries {
        let at = |reason: String| ImportError::line(&b.at.0, b.at.1, reason);
        if b.value != 0.0 {
            return Err(at(format!(
                "*BOUNDARY imposes {} on {}: rubscan clamps nodes at zero only",
                b.value, b.target
            )));
        }
        let ids = match b.target.parse::<usize>() {
            Ok(id) => vec![id],
            Err(_) => deck
                .node_sets
                .get(&b.target)
                .cloned()
                .ok_or_else(|| at(format!("*BOUNDARY: no node set '{}'", b.target)))?,
        };
        for id in ids {
            if !index.contains_key(&id) {
                return Err(at(format!(
                    "*BOUNDARY: node {id} is not a node of a C3D20 element"
                )));
            }
            fixed.entry(id).or_default().extend(b.dofs.0..=b.dofs.1);
        }
    }
    fixed
        .into_iter()
        .map(|(id, dofs)| {
            if dofs == BTreeSet::from([1, 2, 3]) {
                Ok(index[&id])
            } else {
                Err(ImportError::file(
                    deck_path,
                    format!(
                        "*BOUNDARY fixes DOFs {dofs:?} of node {id}: rubscan clamps all three \
                         translations of a node or none"
                    ),
                ))
            }
        })
        .collect()
}

/// The contact nodes (mesh indices, in the selection's order), each on the free surface of
/// the mesh and not clamped.
fn contact_nodes(
    spec: &CalculixSectorSpec,
    deck: &CalculixMesh,
    index: &HashMap<usize, usize>,
    elements: &[[usize; 20]],
    cyclic: &HashSet<usize>,
    clamped: &[usize],
) -> Result<Vec<usize>, String> {
    let ids = match &spec.contact {
        ContactSelection::Nodes(ids) => ids.clone(),
        ContactSelection::NodeSet(name) => {
            set_nodes(deck, name).ok_or_else(|| format!("contact: no node set '{name}'"))?
        }
    };
    if ids.is_empty() {
        return Err("contact: the selection is empty".into());
    }
    let free = free_surface_nodes(elements, cyclic);
    ids.iter()
        .map(|id| {
            let node = *index
                .get(id)
                .ok_or_else(|| format!("contact node {id} is not a node of a C3D20 element"))?;
            if !free.contains(&node) {
                return Err(format!(
                    "contact node {id} is not on the free surface of the sector (an interior \
                     node, or one only on a cyclic face): contact nodes lie on the blade tip or \
                     the casing's inner surface"
                ));
            }
            if clamped.contains(&node) {
                return Err(format!("contact node {id} is clamped"));
            }
            Ok(node)
        })
        .collect()
}

/// Moves each right-face node onto its left partner turned by 2π/N (exact cyclic pairing, as
/// the built-in meshes have it); returns the largest move, m.
fn snap_right_face(nodes: &mut [[f64; 3]], left: &[usize], right: &[usize], n: usize) -> f64 {
    let (s, c) = (std::f64::consts::TAU / n as f64).sin_cos();
    let mut largest = 0.0f64;
    for (&l, &r) in left.iter().zip(right) {
        let p = nodes[l];
        let q = [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]];
        largest = largest.max(crate::model::mesh::dist(q, nodes[r]));
        nodes[r] = q;
    }
    largest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calculix_export::model_deck;
    use crate::model::mesh::ImpellerGeometry;

    fn exported_impeller(dir: &Path, edit: impl Fn(String) -> String) -> CalculixSectorSpec {
        let mesh = ImpellerGeometry::default().build().unwrap();
        let deck = edit(model_deck(&mesh, "impeller").unwrap());
        std::fs::create_dir_all(dir).unwrap();
        let path = dir.join("impeller_sector.inp");
        std::fs::write(&path, deck).unwrap();
        CalculixSectorSpec {
            name: "impeller".into(),
            component: Component::Impeller,
            deck: path,
            contact: ContactSelection::NodeSet("CONTACT".into()),
            left_nodes: None,
            right_nodes: None,
            clamped_nodes: Some("CLAMPED".into()),
            modes_per_diameter: 4,
            omega_grid_rad_s: None,
            prestress: Prestress::default(),
            units: Units::Si,
            damping: Damping::default(),
            named_nodes: BTreeMap::from([(
                "leading_edge_mid_span".into(),
                "LEADING_EDGE_MID_SPAN".into(),
            )]),
        }
    }

    fn scratch(tag: &str) -> PathBuf {
        crate::io::calculix::tests::scratch(&format!("sector_{tag}"))
    }

    /// The exported built-in impeller reads back as the mesh it was written from (the right
    /// face paired in the mesher's order, every coordinate to the bit: the deck writes each
    /// exactly, and the right face snapped onto the turned left face does not move).
    #[test]
    fn an_exported_sector_reads_back_as_its_mesh() {
        let mesh = ImpellerGeometry::default().build().unwrap();
        let spec = exported_impeller(&scratch("roundtrip"), |d| d);
        let back = read_sector(&spec).unwrap();
        let m = &back.mesh;
        assert_eq!(m.n_sectors, mesh.n_sectors);
        assert_eq!(m.elements, mesh.elements);
        assert_eq!(m.left_nodes, mesh.left_nodes);
        assert_eq!(m.right_nodes, mesh.right_nodes);
        assert_eq!(m.contact_nodes, mesh.contact_nodes);
        assert_eq!(m.clamped_nodes, mesh.clamped_nodes);
        assert_eq!(m.material, mesh.material);
        assert_eq!(m.named_nodes[0].node, mesh.named_nodes[0].node);
        assert!(m.nodes == mesh.nodes, "coordinates differ");
        assert_eq!(back.face_snap_m, 0.0);
        assert_eq!(back.node_ids, (1..=mesh.nodes.len()).collect::<Vec<_>>());
    }

    /// Without a clamp set the clamps come from `*BOUNDARY` (the deck fixes the master
    /// partners of clamped slave nodes: the same constrained space).
    #[test]
    fn clamps_default_to_the_boundary_card() {
        let mut spec = exported_impeller(&scratch("boundary"), |d| d);
        spec.clamped_nodes = None;
        let back = read_sector(&spec).unwrap();
        let mesh = ImpellerGeometry::default().build().unwrap();
        assert_eq!(
            back.mesh.clamped_nodes,
            crate::io::calculix_export::fixed_nodes(&mesh)
        );
    }

    /// A clamp of only some translations, or to a non-zero value, is refused by name.
    #[test]
    fn partial_or_moving_clamps_are_refused() {
        for (card, why) in [
            ("FIXED, 1, 2", "all three"),
            ("FIXED, 1, 3, 1e-3", "at zero only"),
        ] {
            let mut spec = exported_impeller(&scratch("partial"), |d| {
                d.replace("*BOUNDARY\nFIXED, 1, 3", &format!("*BOUNDARY\n{card}"))
            });
            spec.clamped_nodes = None;
            let e = file_error(&spec);
            assert!(e.contains(why), "{card}: {e}");
        }
    }

    fn file_error(spec: &CalculixSectorSpec) -> String {
        let e = read_sector(spec).unwrap_err();
        let text = e.to_string();
        assert!(text.contains(&spec.deck.display().to_string()), "{text}");
        text
    }

    #[test]
    fn a_wrong_sector_count_is_refused() {
        let n = ImpellerGeometry::default().build().unwrap().n_sectors;
        let spec = exported_impeller(&scratch("count"), |d| {
            d.replace(&format!("MODEL, N={n},"), &format!("MODEL, N={},", n + 1))
        });
        let e = file_error(&spec);
        assert!(
            e.contains(&format!(
                "360°/{n} apart but the model declares N = {}",
                n + 1
            )),
            "{e}"
        );
    }

    #[test]
    fn an_interior_contact_node_is_refused() {
        let mesh = ImpellerGeometry::default().build().unwrap();
        let all: HashSet<usize> = (0..mesh.nodes.len()).collect();
        let cyclic: HashSet<usize> = mesh
            .left_nodes
            .iter()
            .chain(&mesh.right_nodes)
            .copied()
            .collect();
        let free = free_surface_nodes(&mesh.elements, &cyclic);
        let interior = *all
            .difference(&free)
            .min()
            .expect("the sector has interior nodes");
        let mut spec = exported_impeller(&scratch("interior"), |d| d);
        let mut ids: Vec<usize> = mesh.contact_nodes.iter().map(|n| n + 1).collect();
        ids[2] = interior + 1;
        spec.contact = ContactSelection::Nodes(ids);
        let e = file_error(&spec);
        assert!(
            e.contains(&format!(
                "contact node {} is not on the free surface",
                interior + 1
            )),
            "{e}"
        );
    }

    #[test]
    fn a_deck_cut_at_a_line_boundary_in_the_elements_is_refused() {
        let spec = exported_impeller(&scratch("cut"), |d| {
            let lines: Vec<&str> = d.lines().collect();
            let first = lines
                .iter()
                .position(|l| l.starts_with("*ELEMENT"))
                .unwrap();
            // Keep the first element's first line only: its node list stops at 15.
            lines[..first + 2].join("\n") + "\n"
        });
        let e = file_error(&spec);
        assert!(e.contains("element 1 has 15 nodes"), "{e}");
    }

    #[test]
    fn a_non_c3d20_element_or_a_second_material_is_named() {
        let spec = exported_impeller(&scratch("c3d20r"), |d| {
            d.replace("TYPE=C3D20", "TYPE=C3D20R")
        });
        let e = file_error(&spec);
        assert!(e.contains("element 1 is a C3D20R"), "{e}");
        let spec = exported_impeller(&scratch("materials"), |d| {
            d.replace("*SOLID SECTION", "*MATERIAL, NAME=OTHER\n*SOLID SECTION")
        });
        let e = file_error(&spec);
        assert!(e.contains("2 *MATERIAL cards"), "{e}");
    }
}
