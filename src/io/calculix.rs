//! Import of CalculiX models (DESIGN §2.4): the matrix storage output of
//! `*FREQUENCY, SOLVER=MATRIXSTORAGE` (`job.sti`, `job.mas`, `job.dof`) and node coordinates
//! and node sets from the input deck (`*NODE`, `*NSET`, `*INCLUDE`), then Craig–Bampton
//! reduction with [`crate::model::component::reduce_component`].
//!
//! # File formats (as written by CalculiX 2.x, checked on the Rotor 37 deck)
//! - `.sti` / `.mas`: one stored entry per line, `row col value`, 1-based, one triangle only
//!   (CalculiX writes `row ≤ col`, column by column), diagonal included, no header. The
//!   reader accepts either triangle but not a mixture, mirrors it to full storage, and
//!   requires every diagonal entry (a missing one means a truncated or corrupt file).
//!   Clamped DOFs (`*BOUNDARY`) are not in the stored matrices.
//! - `.dof`: one line per matrix row, `node.direction` (direction 1, 2, 3 = x, y, z).
//! - input deck: `*NODE[, NSET=name]` blocks `id, x, y, z`; `*NSET, NSET=name[, GENERATE]`
//!   blocks (ids or names of earlier sets, or `first, last[, step]`);
//!   `*INCLUDE, INPUT=file` (resolved relative to the including file's folder). Keywords and
//!   set names are case-insensitive; `**` starts a comment line.
//!
//! Every reader streams its file line by line and every error names the file and, where it
//! applies, the 1-based line. A last line with text but no end of line is refused as a cut
//! (truncated) file, in every text format.

use crate::model::component::{
    ComponentMatrices, ComponentReductionOptions, ContactPoint, NodeDof, reduce_component,
    sparse_from_entries,
};
use crate::model::rom::{Component, CyclicRom, Damping};
use faer::sparse::SparseColMat;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Unit system of the imported files; everything is converted to SI on reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Units {
    /// N, mm, tonne, s (CalculiX/Abaqus "mm" system): K in N/mm, M in t, lengths in mm.
    #[serde(rename = "mm-t-s")]
    MmTonneSecond,
    /// N, m, kg, s.
    #[serde(rename = "si")]
    Si,
}

impl Units {
    /// Factor from file stiffness units to N/m (N/mm → N/m: 1e3).
    pub fn stiffness_factor(self) -> f64 {
        match self {
            Units::MmTonneSecond => 1e3,
            Units::Si => 1.0,
        }
    }
    /// Factor from file mass units to kg (t → kg: 1e3).
    pub fn mass_factor(self) -> f64 {
        match self {
            Units::MmTonneSecond => 1e3,
            Units::Si => 1.0,
        }
    }
    /// Factor from file lengths to m (mm → m: 1e-3).
    pub fn length_factor(self) -> f64 {
        match self {
            Units::MmTonneSecond => 1e-3,
            Units::Si => 1.0,
        }
    }
}

/// Accumulates entries of one triangle of a symmetric matrix, checking that they all lie
/// in the same triangle, then builds the full matrix and checks its diagonal.
pub(crate) struct TriangleBuilder {
    n: usize,
    entries: Vec<(u32, u32, f64)>,
    /// `Some(true)`: upper (row ≤ col); decided by the first off-diagonal entry.
    upper: Option<bool>,
}

impl TriangleBuilder {
    pub fn new(n: usize, capacity: usize) -> Self {
        Self {
            n,
            entries: Vec::with_capacity(capacity),
            upper: None,
        }
    }

    /// Adds entry (r, c) (0-based); `Err` if it lies in the other triangle than the previous ones.
    pub fn push(&mut self, r: usize, c: usize, v: f64) -> Result<(), String> {
        if r != c {
            let up = r < c;
            match self.upper {
                None => self.upper = Some(up),
                Some(u) if u != up => {
                    return Err(format!(
                        "entry ({}, {}) is in the {} triangle but earlier entries are in the {} one \
                         (store one triangle of a symmetric matrix)",
                        r + 1,
                        c + 1,
                        if up { "upper" } else { "lower" },
                        if u { "upper" } else { "lower" }
                    ));
                }
                _ => {}
            }
        }
        self.entries.push((r as u32, c as u32, v));
        Ok(())
    }

    /// Full-storage matrix scaled by `factor`; every diagonal entry must be present and
    /// positive, every scaled value finite.
    pub fn finish(
        mut self,
        path: &Path,
        factor: f64,
    ) -> Result<SparseColMat<usize, f64>, ImportError> {
        let mut diag = vec![false; self.n];
        for e in self.entries.iter_mut() {
            e.2 *= factor;
            if !e.2.is_finite() {
                return Err(ImportError::file(
                    path,
                    format!(
                        "entry ({}, {}) = {} overflows in SI units (× {factor})",
                        e.0 + 1,
                        e.1 + 1,
                        e.2 / factor
                    ),
                ));
            }
            if e.0 == e.1 {
                if e.2 <= 0.0 {
                    return Err(ImportError::file(
                        path,
                        format!(
                            "diagonal entry {} is {} ≤ 0: the matrix is not positive definite",
                            e.0 + 1,
                            e.2 / factor
                        ),
                    ));
                }
                diag[e.0 as usize] = true;
            }
        }
        if let Some(i) = diag.iter().position(|d| !d) {
            return Err(ImportError::file(
                path,
                format!(
                    "no diagonal entry for row {} of {}: truncated or corrupt file",
                    i + 1,
                    self.n
                ),
            ));
        }
        sparse_from_entries(self.n, &self.entries, true)
            .map_err(|e| ImportError::file(path, e.to_string()))
    }
}

/// Reads a CalculiX `.dof` file (`node.direction` per line, direction 1..=3).
pub fn read_dof_map(path: &Path) -> Result<Vec<NodeDof>, ImportError> {
    read_dof_lines(
        path,
        "node.direction",
        |_| false,
        |t| {
            let (a, b) = t.split_once('.')?;
            Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
        },
    )
}

/// Reads a DOF list of one `(node, direction)` per line (direction 1..=3 for x, y, z), as
/// `parse` reads a trimmed line (`None`: not of the `form` the error message names); blank
/// lines and the lines `comment` accepts are skipped. Refuses other directions, repeated
/// DOFs and an empty list.
pub(crate) fn read_dof_lines(
    path: &Path,
    form: &str,
    comment: fn(&str) -> bool,
    parse: fn(&str) -> Option<(usize, usize)>,
) -> Result<Vec<NodeDof>, ImportError> {
    let mut rd = LineReader::open(path)?;
    let mut dofs = Vec::new();
    let mut seen = std::collections::HashSet::new();
    while let Some(l) = rd.next_line()? {
        let t = l.text.trim();
        if t.is_empty() || comment(t) {
            continue;
        }
        let Some((node, dir)) = parse(t) else {
            return Err(l.err(format!("expected '{form}', found '{t}'")));
        };
        if !(1..=3).contains(&dir) {
            return Err(l.err(format!(
                "direction {dir} of node {node}: only displacements 1, 2, 3 (x, y, z) are supported"
            )));
        }
        let d = NodeDof { node, dir: dir - 1 };
        if !seen.insert(d) {
            return Err(l.err(format!("DOF {dir} of node {node} is listed twice")));
        }
        dofs.push(d);
    }
    if dofs.is_empty() {
        return Err(ImportError::file(path, "no DOFs"));
    }
    Ok(dofs)
}

/// Reads a CalculiX matrix storage file (`.sti` or `.mas`) of order `n` (the length of the
/// DOF map) and returns it in full storage, multiplied by `factor` (unit conversion).
pub fn read_matrix_storage(
    path: &Path,
    n: usize,
    factor: f64,
) -> Result<SparseColMat<usize, f64>, ImportError> {
    let mut rd = LineReader::open(path)?;
    let size_hint = std::fs::metadata(path)
        .map(|m| m.len() as usize / 34)
        .unwrap_or(0);
    let mut tri = TriangleBuilder::new(n, size_hint);
    while let Some(l) = rd.next_line()? {
        let line = l.text;
        let mut it = line.split_ascii_whitespace();
        let Some(first) = it.next() else {
            continue;
        };
        let (r, c, v) = parse_entry(std::iter::once(first).chain(it), n).map_err(|e| l.err(e))?;
        tri.push(r, c, v).map_err(|e| l.err(e))?;
    }
    tri.finish(path, factor)
}

pub use crate::io::calculix_deck::{CalculixMesh, read_calculix_mesh};
pub use crate::io::text_lines::ImportError;
use crate::io::text_lines::{LineReader, parse_entry};

/// How the contact nodes are chosen; their order is the row order (leading → trailing edge).
/// In JSON, an object with exactly one of its fields: `{"nodes": […]}` or `{"node_set": "…"}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", try_from = "ContactFields")]
pub enum ContactSelection {
    /// Node ids of the FE model, in row order.
    Nodes(Vec<usize>),
    /// A CalculiX `*NSET` of the deck, in file order.
    NodeSet(String),
}

/// The JSON of a [`ContactSelection`], read field by field so that a misspelt field is
/// named and two fields are refused by name (serde's enum reading says only "expected value").
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ContactFields {
    nodes: Option<Vec<usize>>,
    node_set: Option<String>,
}

impl TryFrom<ContactFields> for ContactSelection {
    type Error = String;
    fn try_from(f: ContactFields) -> Result<Self, String> {
        match (f.nodes, f.node_set) {
            (Some(ids), None) => Ok(Self::Nodes(ids)),
            (None, Some(set)) => Ok(Self::NodeSet(set)),
            _ => Err(
                "contact: give exactly one of `nodes` (node ids) or `node_set` (an *NSET)".into(),
            ),
        }
    }
}

/// What `rubscan model import` needs to import a CalculiX model (JSON-deserializable).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalculixImportSpec {
    /// Name stored in the ROM.
    pub name: String,
    /// Impeller or casing.
    pub component: Component,
    /// Stiffness matrix storage file (`job.sti`).
    pub stiffness: PathBuf,
    /// Mass matrix storage file (`job.mas`).
    pub mass: PathBuf,
    /// DOF map (`job.dof`).
    pub dof_map: PathBuf,
    /// Input deck (or mesh file) with the `*NODE` (and `*NSET`) blocks.
    pub mesh: PathBuf,
    /// Contact nodes, leading → trailing edge.
    pub contact: ContactSelection,
    /// Number of fixed-interface modes kept.
    pub n_modes: usize,
    /// Unit system of the files (`"mm-t-s"` or `"si"`).
    pub units: Units,
    /// Damping stored in the ROM.
    #[serde(default)]
    pub damping: Damping,
    /// FE node ids whose displacement the ROM can recover (rows of the reduction basis kept
    /// in the ROM, see [`crate::model::rom::Recovery`]); probes may then name them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub recovery_nodes: Vec<usize>,
}

impl CalculixImportSpec {
    /// A spec for the files `dir/job.{sti,mas,dof,inp}` written by `ccx job`.
    pub fn from_job(
        dir: &Path,
        job: &str,
        contact: ContactSelection,
        n_modes: usize,
        units: Units,
    ) -> Self {
        let f = |ext: &str| dir.join(format!("{job}.{ext}"));
        Self {
            name: job.to_string(),
            component: Component::Impeller,
            stiffness: f("sti"),
            mass: f("mas"),
            dof_map: f("dof"),
            mesh: f("inp"),
            contact,
            n_modes,
            units,
            damping: Damping::default(),
            recovery_nodes: Vec::new(),
        }
    }
}

/// The contact node ids of `selection`, checked against the node list of `mesh`.
pub(crate) fn contact_points(
    selection: &ContactSelection,
    nodes: &HashMap<usize, [f64; 3]>,
    node_sets: &HashMap<String, Vec<usize>>,
    mesh_path: &Path,
    length_factor: f64,
) -> Result<Vec<ContactPoint>, ImportError> {
    let ids: Vec<usize> = match selection {
        ContactSelection::Nodes(ids) => ids.clone(),
        ContactSelection::NodeSet(name) => node_sets
            .get(&name.to_uppercase())
            .cloned()
            .ok_or_else(|| ImportError::file(mesh_path, format!("no node set '{name}'")))?,
    };
    if ids.is_empty() {
        return Err(ImportError::Spec("the contact selection is empty".into()));
    }
    ids.iter()
        .map(|&node| {
            let x = nodes.get(&node).ok_or_else(|| {
                ImportError::file(mesh_path, format!("contact node {node} is not defined"))
            })?;
            Ok(ContactPoint {
                node,
                position: x.map(|c| c * length_factor),
            })
        })
        .collect()
}

/// Checks that every contact node has its 3 DOFs in the DOF map (error naming that file).
pub(crate) fn check_contact_dofs(
    contacts: &[ContactPoint],
    dofs: &[NodeDof],
    dof_path: &Path,
) -> Result<(), ImportError> {
    let set: std::collections::HashSet<NodeDof> = dofs.iter().copied().collect();
    for c in contacts {
        for dir in 0..3 {
            if !set.contains(&NodeDof { node: c.node, dir }) {
                return Err(ImportError::file(
                    dof_path,
                    format!(
                        "contact node {} has no DOF {}.{} (clamped or not in the model)",
                        c.node,
                        c.node,
                        dir + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Imports a CalculiX model and reduces it (Craig–Bampton, contact nodes kept, `n_modes`
/// fixed-interface modes) to a one-sector [`CyclicRom`] in SI units, at rest (K1 = K2 = 0,
/// see [`crate::model::component`] for the centrifugal hook).
pub fn import_calculix(spec: &CalculixImportSpec) -> Result<CyclicRom, ImportError> {
    let dofs = read_dof_map(&spec.dof_map)?;
    let mesh = read_calculix_mesh(&spec.mesh)?;
    reduce_imported(
        "calculix",
        serde_json::json!(spec),
        &import_common!(spec),
        dofs,
        (&mesh, &spec.mesh),
        read_matrix_storage,
    )
}

/// Reads an `n × n` matrix file, multiplying every value by the unit factor.
pub(crate) type MatrixReader =
    fn(&Path, usize, f64) -> Result<SparseColMat<usize, f64>, ImportError>;

/// The fields both import specs (CalculiX, Matrix Market) share.
pub(crate) struct ImportCommon<'a> {
    pub name: &'a str,
    pub component: Component,
    pub stiffness: &'a Path,
    pub mass: &'a Path,
    pub dof_map: &'a Path,
    pub contact: &'a ContactSelection,
    pub n_modes: usize,
    pub units: Units,
    pub damping: Damping,
    pub recovery_nodes: &'a [usize],
}

/// The [`ImportCommon`] of an import spec (the fields of that name).
macro_rules! import_common {
    ($spec:expr) => {
        $crate::io::calculix::ImportCommon {
            name: &$spec.name,
            component: $spec.component,
            stiffness: &$spec.stiffness,
            mass: &$spec.mass,
            dof_map: &$spec.dof_map,
            contact: &$spec.contact,
            n_modes: $spec.n_modes,
            units: $spec.units,
            damping: $spec.damping,
            recovery_nodes: &$spec.recovery_nodes,
        }
    };
}
pub(crate) use import_common;

/// Picks the contact nodes in `mesh` (its nodes and node sets, read from `mesh_path`),
/// checks that the DOF map `dofs` holds their three translations, reads the stiffness and
/// mass with `read` (SI conversion from `common.units`), reduces them (Craig–Bampton, fixed
/// interface at the contact nodes) and records the import in the ROM's provenance; shared by
/// the CalculiX and Matrix Market importers.
pub(crate) fn reduce_imported(
    format: &str,
    spec: serde_json::Value,
    common: &ImportCommon<'_>,
    dofs: Vec<NodeDof>,
    (mesh, mesh_path): (&CalculixMesh, &Path),
    read: MatrixReader,
) -> Result<CyclicRom, ImportError> {
    let length = common.units.length_factor();
    let (nodes, sets) = (&mesh.nodes, &mesh.node_sets);
    let contacts = &contact_points(common.contact, nodes, sets, mesh_path, length)?;
    check_contact_dofs(contacts, &dofs, common.dof_map)?;
    let recovery_nodes = common
        .recovery_nodes
        .iter()
        .enumerate()
        .map(|(i, &node)| {
            let x = nodes.get(&node).ok_or_else(|| {
                ImportError::Spec(format!(
                    "recovery_nodes[{i}] = {node}: no such node in {}",
                    mesh_path.display()
                ))
            })?;
            Ok(ContactPoint {
                node,
                position: x.map(|c| c * length),
            })
        })
        .collect::<Result<Vec<_>, ImportError>>()?;
    let n = dofs.len();
    let stiffness = read(common.stiffness, n, common.units.stiffness_factor())?;
    let mass = read(common.mass, n, common.units.mass_factor())?;
    let mats = ComponentMatrices {
        stiffness,
        mass,
        dofs,
    };
    let opts = ComponentReductionOptions {
        name: common.name.to_string(),
        component: common.component,
        n_modes: common.n_modes,
        damping: common.damping,
        recovery_nodes,
        ..Default::default()
    };
    let (mats, opts) = (&mats, &opts);
    let mut rom = reduce_component(mats, contacts, opts)?;
    rom.provenance = serde_json::json!({
        "import": format,
        "spec": spec,
        "n_fe_dofs": mats.dofs.len(),
        "contact_node_ids": contacts.iter().map(|c| c.node).collect::<Vec<_>>(),
        "recovery_node_ids": common.recovery_nodes,
        "reduction": "Craig-Bampton, fixed interface at the contact nodes",
    });
    rom.validate()?;
    Ok(rom)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::io::calculix_deck::{MAX_INCLUDES, MAX_SET_IDS};
    use std::fs::File;
    use std::io::Write;

    pub(crate) fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        let mut f = File::create(&p).unwrap();
        f.write_all(text.as_bytes()).unwrap();
        p
    }

    pub(crate) fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rubscan-imp-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    pub(crate) fn line_err(e: ImportError) -> (String, usize, String) {
        match e {
            ImportError::Line { file, line, reason } => (
                file.file_name().unwrap().to_string_lossy().into_owned(),
                line,
                reason,
            ),
            other => panic!("expected a line error, got {other}"),
        }
    }

    #[test]
    fn reads_matrix_storage_and_mirrors() {
        let d = scratch("sti");
        let p = write(
            &d,
            "a.sti",
            "1 1  4.0e+00\n1 2 -1.0e+00\n2 2  5.0e+00\n2 3  2.0\n3 3 6\n",
        );
        let a = read_matrix_storage(&p, 3, 1e3).unwrap();
        let dense = a.to_dense();
        let expect = [[4.0, -1.0, 0.0], [-1.0, 5.0, 2.0], [0.0, 2.0, 6.0]];
        for i in 0..3 {
            for j in 0..3 {
                assert_eq!(dense[(i, j)], 1e3 * expect[i][j]);
            }
        }
    }

    #[test]
    fn rejects_bad_matrix_storage() {
        let d = scratch("stibad");
        let p = write(&d, "t.sti", "1 1 4.0\n1 2 -1.0\n2 2 5.0\n2 3 1.0\n3 3 6.");
        let (f, line, why) = line_err(read_matrix_storage(&p, 3, 1.0).unwrap_err());
        assert_eq!((f.as_str(), line), ("t.sti", 5));
        assert!(why.contains("truncated"), "{why}");

        let p = write(&d, "c.sti", "1 1 4.0\n1 2 -1.0x\n2 2 5.0\n");
        let (_, line, why) = line_err(read_matrix_storage(&p, 2, 1.0).unwrap_err());
        assert_eq!(line, 2);
        assert!(why.contains("not a number"), "{why}");

        let p = write(&d, "r.sti", "1 1 4.0\n1 4 -1.0\n2 2 5.0\n");
        let (_, line, why) = line_err(read_matrix_storage(&p, 3, 1.0).unwrap_err());
        assert_eq!(line, 2);
        assert!(why.contains("column 4 out of range 1..=3"), "{why}");

        let p = write(&d, "m.sti", "1 1 4.0\n1 2 -1.0\n2 1 -1.0\n2 2 5.0\n");
        let (_, line, why) = line_err(read_matrix_storage(&p, 2, 1.0).unwrap_err());
        assert_eq!(line, 3);
        assert!(why.contains("triangle"), "{why}");

        // Cut at a line boundary: the last diagonal entries are missing.
        let p = write(&d, "s.sti", "1 1 4.0\n1 2 -1.0\n2 2 5.0\n");
        let e = read_matrix_storage(&p, 3, 1.0).unwrap_err().to_string();
        assert!(
            e.contains("s.sti") && e.contains("no diagonal entry for row 3"),
            "{e}"
        );

        let p = write(&d, "d.sti", "1 1 4.0\n1 2 -1.0\n2 2 5.0\n1 2 3.0\n");
        let e = read_matrix_storage(&p, 2, 1.0).unwrap_err().to_string();
        assert!(
            e.contains("d.sti") && e.contains("duplicate entry (1, 2)"),
            "{e}"
        );
    }

    #[test]
    fn reads_dof_map_and_rejects_bad_lines() {
        let d = scratch("dof");
        let p = write(&d, "a.dof", "3.1\n3.2\n3.3\n10.2\n");
        let dofs = read_dof_map(&p).unwrap();
        assert_eq!(dofs[3], NodeDof { node: 10, dir: 1 });
        let p = write(&d, "b.dof", "3.1\n3.4\n");
        let (_, line, why) = line_err(read_dof_map(&p).unwrap_err());
        assert_eq!(line, 2);
        assert!(why.contains("direction 4"), "{why}");
        let p = write(&d, "c.dof", "3.1\nabc\n");
        assert_eq!(line_err(read_dof_map(&p).unwrap_err()).1, 2);
        let p = write(&d, "e.dof", "3.1\n3.2\n3.1\n");
        assert!(line_err(read_dof_map(&p).unwrap_err()).2.contains("twice"));
    }

    #[test]
    fn reads_nodes_sets_and_includes() {
        let d = scratch("deck");
        write(
            &d,
            "mesh.msh",
            "*NODE, NSET=Nall\n 1, 0.0, 0.0, 0.0\n 2, 1.0, 0.5, -2.0e+01\n 3, 2.0\n*ELEMENT, TYPE=C3D8\n 1, 1, 2, 3\n",
        );
        let deck = write(
            &d,
            "job.inp",
            "*HEADING\nx\n*include, input=./mesh.msh\n** comment\n*NSET, NSET=tip\n3, 1\n*nset,nset=TWO, generate\n1, 3, 2\n*NSET,NSET=both\ntip, 2\n",
        );
        let mesh = read_calculix_mesh(&deck).unwrap();
        assert_eq!(mesh.nodes[&2], [1.0, 0.5, -20.0]);
        assert_eq!(mesh.nodes[&3], [2.0, 0.0, 0.0]);
        assert_eq!(mesh.node_sets["NALL"], vec![1, 2, 3]);
        assert_eq!(mesh.node_sets["TIP"], vec![3, 1]);
        assert_eq!(mesh.node_sets["TWO"], vec![1, 3]);
        assert_eq!(mesh.node_sets["BOTH"], vec![3, 1, 2]);

        let bad = write(&d, "bad.inp", "*NODE\n1, 0, 0, 0\n2, 0, zz, 0\n");
        let (f, line, why) = line_err(read_calculix_mesh(&bad).unwrap_err());
        assert_eq!((f.as_str(), line), ("bad.inp", 3));
        assert!(why.contains("zz"), "{why}");
        let missing = write(&d, "inc.inp", "*INCLUDE, INPUT=nothere.msh\n");
        let e = read_calculix_mesh(&missing).unwrap_err().to_string();
        assert!(e.contains("nothere.msh"), "{e}");
    }

    #[test]
    fn contact_selection_errors_name_the_file() {
        let nodes: HashMap<usize, [f64; 3]> = [(1, [1.0, 2.0, 3.0])].into_iter().collect();
        let sets = HashMap::new();
        let mesh = Path::new("deck.inp");
        let pts =
            contact_points(&ContactSelection::Nodes(vec![1]), &nodes, &sets, mesh, 1e-3).unwrap();
        assert_eq!(pts[0].position, [1e-3, 2e-3, 3e-3]);
        let e = contact_points(
            &ContactSelection::Nodes(vec![1, 7]),
            &nodes,
            &sets,
            mesh,
            1.0,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("deck.inp") && e.contains("contact node 7"),
            "{e}"
        );
        let e = contact_points(
            &ContactSelection::NodeSet("tip".into()),
            &nodes,
            &sets,
            mesh,
            1.0,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("no node set 'tip'"), "{e}");
        let dofs = vec![NodeDof { node: 1, dir: 0 }, NodeDof { node: 1, dir: 1 }];
        let e = check_contact_dofs(&pts, &dofs, Path::new("job.dof"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("job.dof") && e.contains("1.3"), "{e}");
    }

    // Regressions found by tests/readers_never_panic.rs.

    #[test]
    fn cut_last_line_is_rejected_by_every_reader() {
        // A file cut inside its last line was read as if complete ("-20.0" read as "-2").
        let d = scratch("cut");
        let deck = write(&d, "cut.inp", "*NODE\n1, 0.0, 0.0, -2");
        let (f, line, why) = line_err(read_calculix_mesh(&deck).unwrap_err());
        assert_eq!((f.as_str(), line), ("cut.inp", 2));
        assert!(why.contains("truncated"), "{why}");
        let dof = write(&d, "cut.dof", "3.1\n3.2\n13.3");
        let (f, line, why) = line_err(read_dof_map(&dof).unwrap_err());
        assert_eq!((f.as_str(), line), ("cut.dof", 3));
        assert!(why.contains("truncated"), "{why}");
        // Trailing blanks without a newline are not a cut.
        let dof = write(&d, "blank.dof", "3.1\n3.2\n  ");
        assert_eq!(read_dof_map(&dof).unwrap().len(), 2);
    }

    #[test]
    fn scaled_value_overflow_is_rejected() {
        // 1e306 t became inf kg (× 1e3) and was accepted.
        let d = scratch("ovf");
        let p = write(&d, "o.mas", "1 1 1e306\n");
        let e = read_matrix_storage(&p, 1, 1e3).unwrap_err().to_string();
        assert!(e.contains("o.mas") && e.contains("overflows"), "{e}");
    }

    #[test]
    fn generate_range_beyond_the_set_budget_is_rejected() {
        // `1, 18446744073709551615` with GENERATE filled memory (10¹⁹ ids): the range is
        // now counted first. Just above the budget, so the test stays small without the fix.
        let d = scratch("gen");
        let text = format!("*NSET, NSET=G, GENERATE\n1, {}\n", MAX_SET_IDS + 1);
        let p = write(&d, "gen.inp", &text);
        let (f, line, why) = line_err(read_calculix_mesh(&p).unwrap_err());
        assert_eq!((f.as_str(), line), ("gen.inp", 2));
        assert!(why.contains("more than"), "{why}");
        let p = write(&d, "ok.inp", "*NSET, NSET=G, GENERATE\n1, 9, 4\n");
        assert_eq!(read_calculix_mesh(&p).unwrap().node_sets["G"], [1, 5, 9]);
    }

    #[test]
    fn self_doubling_node_set_is_rejected() {
        // A set naming itself doubles on every line: 64 lines claimed 2⁶⁴ ids.
        let d = scratch("dbl");
        let text = format!("*NSET, NSET=A\n1\n{}", "A\n".repeat(64));
        let p = write(&d, "dbl.inp", &text);
        let (f, line, why) = line_err(read_calculix_mesh(&p).unwrap_err());
        assert_eq!((f.as_str(), line), ("dbl.inp", 27));
        assert!(why.contains("more than"), "{why}");
    }

    #[test]
    fn include_cycle_is_rejected() {
        // A file including itself was read 16 levels deep, k¹⁶ times with k such lines.
        let d = scratch("cyc");
        let p = write(&d, "self.inp", "*INCLUDE, INPUT=self.inp\n");
        let e = read_calculix_mesh(&p).unwrap_err().to_string();
        assert!(e.contains("self.inp") && e.contains("cycle"), "{e}");
        write(&d, "b.inp", "*INCLUDE, INPUT=a.inp\n");
        let a = write(&d, "a.inp", "*INCLUDE, INPUT=b.inp\n");
        let e = read_calculix_mesh(&a).unwrap_err().to_string();
        assert!(e.contains("a.inp") && e.contains("cycle"), "{e}");
    }

    #[test]
    fn include_fan_out_is_bounded() {
        // Distinct files each including the next ten times: 1 + 10 + 100 + 1000 reads.
        let d = scratch("fan");
        write(&d, "d.inp", "** leaf\n");
        for (f, next) in [("c.inp", "d.inp"), ("b.inp", "c.inp"), ("a.inp", "b.inp")] {
            write(&d, f, &format!("*INCLUDE, INPUT={next}\n").repeat(10));
        }
        let e = read_calculix_mesh(&d.join("a.inp"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("more than {MAX_INCLUDES} files")),
            "{e}"
        );
        // One level less is fine.
        assert!(read_calculix_mesh(&d.join("b.inp")).is_ok());
    }

    #[test]
    fn spec_json_round_trip() {
        let spec = CalculixImportSpec::from_job(
            Path::new("/tmp/r37"),
            "blade",
            ContactSelection::Nodes(vec![188, 190]),
            50,
            Units::MmTonneSecond,
        );
        let json = serde_json::to_string(&spec).unwrap();
        assert!(
            json.contains("\"mm-t-s\"") && json.contains("\"nodes\":[188,190]"),
            "{json}"
        );
        let back: CalculixImportSpec = serde_json::from_str(&json).unwrap();
        assert_eq!(back, spec);
        // A misspelt contact field is named; two, or none, are refused by name.
        let with_contact = |contact: &str| {
            let v = json.replace("{\"nodes\":[188,190]}", contact);
            serde_json::from_str::<CalculixImportSpec>(&v)
                .unwrap_err()
                .to_string()
        };
        let e = with_contact("{\"nodez\":[188]}");
        assert!(e.contains("unknown field `nodez`"), "{e}");
        for contact in ["{\"nodes\":[188],\"node_set\":\"TIP\"}", "{}"] {
            let e = with_contact(contact);
            assert!(e.contains("exactly one of `nodes`"), "{contact}: {e}");
        }
    }
}
