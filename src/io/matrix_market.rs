//! Import of a component given as Matrix Market files (DESIGN §2.4): stiffness and mass
//! in `coordinate real|integer symmetric|general` format, a DOF map and node coordinates,
//! then Craig–Bampton reduction ([`crate::model::component::reduce_component`]).
//!
//! # Files
//! - `K.mtx`, `M.mtx`: Matrix Market coordinate format. `symmetric` files store one triangle
//!   (the standard says the lower one; either is accepted, not a mixture); `general` files
//!   store both and must be symmetric (relative tolerance 1e-12 of the largest entry).
//! - DOF map (rubscan text format): one line per matrix row, `node direction`, whitespace
//!   separated, `node` a positive integer id, `direction` 1, 2, 3 = x, y, z. Empty lines and
//!   lines starting with `#` or `%` are ignored (they do not count as rows).
//! - Nodes: either a CalculiX deck / mesh (extension `.inp` or `.msh`, read with
//!   [`crate::io::calculix::read_calculix_mesh`], which also gives `*NSET`s), or a text
//!   table `id x y z` per line (whitespace or comma separated, `#`/`%` comments).

use crate::io::calculix::{
    ContactSelection, TriangleBuilder, Units, import_common, read_dof_lines, reduce_imported,
};
use crate::io::calculix_deck::{CalculixMesh, read_calculix_mesh};
use crate::io::text_lines::{ImportError, LineReader, parse_entry, parse_value};
use crate::model::component::{NodeDof, sparse_from_entries};
use crate::model::rom::{Component, CyclicRom, Damping};
use faer::sparse::SparseColMat;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Relative tolerance on the symmetry of a `general` Matrix Market matrix.
const SYMMETRY_TOL: f64 = 1e-12;

/// Reads a square, symmetric Matrix Market coordinate matrix of order `n` (the length of
/// the DOF map) into full storage, multiplied by `factor` (unit conversion).
pub fn read_matrix_market(
    path: &Path,
    n: usize,
    factor: f64,
) -> Result<SparseColMat<usize, f64>, ImportError> {
    let mut rd = LineReader::open(path)?;
    let header = rd
        .next_line()?
        .ok_or_else(|| ImportError::file(path, "empty file"))?
        .text
        .to_ascii_lowercase();
    let h: Vec<&str> = header.split_ascii_whitespace().collect();
    if h.len() != 5 || h[0] != "%%matrixmarket" || h[1] != "matrix" {
        return Err(rd.err("expected the header '%%MatrixMarket matrix coordinate real symmetric'"));
    }
    if h[2] != "coordinate" {
        return Err(rd.err(format!(
            "format '{}' not supported (only 'coordinate')",
            h[2]
        )));
    }
    if h[3] != "real" && h[3] != "integer" {
        return Err(rd.err(format!(
            "field '{}' not supported (only 'real' or 'integer')",
            h[3]
        )));
    }
    let symmetric = match h[4] {
        "symmetric" => true,
        "general" => false,
        other => {
            return Err(rd.err(format!(
                "symmetry '{other}' not supported (only 'symmetric' or 'general')"
            )));
        }
    };
    // Size line after the comments.
    let (rows, cols, nnz) = loop {
        let Some(l) = rd.next_line()? else {
            return Err(ImportError::file(path, "no size line: truncated file"));
        };
        let t = l.text.trim();
        if t.is_empty() || t.starts_with('%') {
            continue;
        }
        let nums: Result<Vec<usize>, _> = t.split_ascii_whitespace().map(str::parse).collect();
        match nums.as_deref() {
            Ok([r, c, z]) => break (*r, *c, *z),
            _ => {
                return Err(l.err(format!(
                    "expected the size line 'rows cols entries', found '{t}'"
                )));
            }
        }
    };
    if rows != cols {
        return Err(rd.err(format!("the matrix is {rows}×{cols}, not square")));
    }
    if rows != n {
        return Err(rd.err(format!(
            "the matrix has order {rows} but the DOF map has {n} rows"
        )));
    }
    // Reserve for the announced entries, but no more than the file can hold (an entry line
    // takes at least 6 bytes): a corrupt size line must not claim memory.
    let fits = std::fs::metadata(path).map_or(0, |m| m.len() / 6) as usize;
    let mut tri = TriangleBuilder::new(n, if symmetric { nnz.min(fits) } else { 0 });
    let mut general: Vec<(u32, u32, f64)> = Vec::new();
    let mut lines: Vec<usize> = Vec::new();
    let mut count = 0usize;
    while let Some(l) = rd.next_line()? {
        let line = l.text;
        let t = line.trim();
        if t.is_empty() || t.starts_with('%') {
            continue;
        }
        if count == nnz {
            return Err(l.err(format!("more entries than the {nnz} announced")));
        }
        let (r, c, v) = parse_entry(t.split_ascii_whitespace(), n).map_err(|e| l.err(e))?;
        if symmetric {
            tri.push(r, c, v).map_err(|e| l.err(e))?;
        } else {
            if !(v * factor).is_finite() {
                return Err(l.err(format!("value {v} overflows in SI units (× {factor})")));
            }
            general.push((r as u32, c as u32, v * factor));
            lines.push(l.no);
        }
        count += 1;
    }
    if count < nnz {
        return Err(ImportError::line(
            path,
            rd.line,
            format!("truncated file: {count} of the {nnz} announced entries"),
        ));
    }
    if symmetric {
        return tri.finish(path, factor);
    }
    let a = sparse_from_entries(n, &general, false)
        .map_err(|e| ImportError::file(path, e.to_string()))?;
    let scale = a.val().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (&(r, c, v), &line) in general.iter().zip(&lines) {
        let w = a.get(c as usize, r as usize).copied().unwrap_or(0.0);
        if (v - w).abs() > SYMMETRY_TOL * scale {
            return Err(ImportError::line(
                path,
                line,
                format!(
                    "non-symmetric general input: entry ({}, {}) = {} but ({}, {}) = {}",
                    r + 1,
                    c + 1,
                    v / factor,
                    c + 1,
                    r + 1,
                    w / factor
                ),
            ));
        }
    }
    for i in 0..n {
        match a.get(i, i) {
            Some(&d) if d > 0.0 => {}
            _ => {
                return Err(ImportError::file(
                    path,
                    format!(
                        "diagonal entry {} is missing or ≤ 0: not positive definite",
                        i + 1
                    ),
                ));
            }
        }
    }
    Ok(a)
}

/// Reads a DOF map in the rubscan text format (`node direction` per row, see module doc).
pub fn read_dof_list(path: &Path) -> Result<Vec<NodeDof>, ImportError> {
    let comment = |t: &str| t.starts_with('#') || t.starts_with('%');
    read_dof_lines(path, "node direction", comment, |t| {
        let mut f = t.split_ascii_whitespace();
        let (a, b) = (f.next()?, f.next()?);
        let node = a.parse().ok().filter(|&node| node > 0)?;
        f.next().is_none().then_some((node, b.parse().ok()?))
    })
}

/// Reads a node table `id x y z` per line (see module doc), coordinates in file units.
pub fn read_node_table(path: &Path) -> Result<HashMap<usize, [f64; 3]>, ImportError> {
    let mut rd = LineReader::open(path)?;
    let mut nodes = HashMap::new();
    while let Some(l) = rd.next_line()? {
        let line = l.text;
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') || t.starts_with('%') {
            continue;
        }
        let f: Vec<&str> = t
            .split(|c: char| c == ',' || c.is_ascii_whitespace())
            .filter(|s| !s.is_empty())
            .collect();
        if f.len() != 4 {
            return Err(l.err(format!("expected 'id x y z', found '{t}'")));
        }
        let id: usize = f[0]
            .parse()
            .ok()
            .filter(|&i| i > 0)
            .ok_or_else(|| l.err(format!("node id '{}' is not a positive integer", f[0])))?;
        let mut x = [0.0; 3];
        for k in 0..3 {
            x[k] = parse_value(Some(f[k + 1]), "coordinate").map_err(|e| l.err(e))?;
        }
        if nodes.insert(id, x).is_some() {
            return Err(l.err(format!("node {id} defined twice")));
        }
    }
    Ok(nodes)
}

/// What `rubscan model import` needs to import a Matrix Market model (JSON-deserializable).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MatrixMarketImportSpec {
    /// Name stored in the ROM.
    pub name: String,
    /// Impeller or casing.
    pub component: Component,
    /// Stiffness matrix (`.mtx`).
    pub stiffness: PathBuf,
    /// Mass matrix (`.mtx`).
    pub mass: PathBuf,
    /// DOF map (`node direction` per row).
    pub dof_map: PathBuf,
    /// Node coordinates: CalculiX deck (`.inp`/`.msh`) or `id x y z` table.
    pub nodes: PathBuf,
    /// Contact nodes, leading → trailing edge (`node_set` needs a CalculiX deck).
    pub contact: ContactSelection,
    /// Number of fixed-interface modes kept.
    pub n_modes: usize,
    /// Unit system of the files (`"mm-t-s"` or `"si"`).
    pub units: Units,
    /// Damping stored in the ROM.
    #[serde(default)]
    pub damping: Damping,
    /// Node ids whose displacement the ROM can recover (see
    /// [`crate::io::calculix::CalculixImportSpec::recovery_nodes`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub recovery_nodes: Vec<usize>,
}

/// Imports a Matrix Market model and reduces it to a one-sector [`CyclicRom`] (SI units, at
/// rest; see [`crate::io::calculix::import_calculix`] for the same on CalculiX files).
pub fn import_matrix_market(spec: &MatrixMarketImportSpec) -> Result<CyclicRom, ImportError> {
    let dofs = read_dof_list(&spec.dof_map)?;
    let is_deck = matches!(
        spec.nodes
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("inp" | "msh")
    );
    let mesh = if is_deck {
        read_calculix_mesh(&spec.nodes)?
    } else {
        CalculixMesh {
            nodes: read_node_table(&spec.nodes)?,
            ..Default::default()
        }
    };
    reduce_imported(
        "matrix_market",
        serde_json::json!(spec),
        &import_common!(spec),
        dofs,
        (&mesh, &spec.nodes),
        read_matrix_market,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calculix::tests::{line_err, scratch, write};
    use crate::model::component::dense_modes;
    use approx::assert_relative_eq;
    use nalgebra::DMatrix;
    use std::fmt::Write as _;

    /// A planar-in-3-D spring–mass chain of `n` nodes along x (ids 1..=n, spacing 10 mm),
    /// clamped at a wall before node 1, each node with 3 DOFs, in mm-t-s units:
    /// springs k_dir (N/mm) between neighbours and consistent rod-like masses
    /// (m/3 diagonal, m/6 coupling, t). Returns dense K, M (file units) and the DOF list.
    fn chain(n: usize) -> (DMatrix<f64>, DMatrix<f64>, Vec<(usize, usize)>) {
        let nd = 3 * n;
        let mut k = DMatrix::zeros(nd, nd);
        let mut m = DMatrix::zeros(nd, nd);
        let ks = [2.0e4, 5.0e3, 7.0e3];
        let ms = 1.0e-3;
        for e in 0..n {
            // element between node e-1 (wall when e = 0) and node e
            for (dir, kd) in ks.iter().enumerate() {
                let b = 3 * e + dir;
                let kk = kd * (1.0 + 0.05 * e as f64);
                k[(b, b)] += kk;
                m[(b, b)] += ms / 3.0;
                if e > 0 {
                    let a = 3 * (e - 1) + dir;
                    k[(a, a)] += kk;
                    k[(a, b)] -= kk;
                    k[(b, a)] -= kk;
                    m[(a, a)] += ms / 3.0;
                    m[(a, b)] += ms / 6.0;
                    m[(b, a)] += ms / 6.0;
                }
            }
        }
        let dofs = (0..nd).map(|i| (i / 3 + 1, i % 3 + 1)).collect();
        (k, m, dofs)
    }

    fn mtx(a: &DMatrix<f64>, symmetric: bool) -> String {
        let mut entries = Vec::new();
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                if a[(i, j)] != 0.0 && (!symmetric || i >= j) {
                    entries.push((i + 1, j + 1, a[(i, j)]));
                }
            }
        }
        let mut s = format!(
            "%%MatrixMarket matrix coordinate real {}\n% generated\n{} {} {}\n",
            if symmetric { "symmetric" } else { "general" },
            a.nrows(),
            a.ncols(),
            entries.len()
        );
        for (i, j, v) in entries {
            writeln!(s, "{i} {j} {v:.17e}").unwrap();
        }
        s
    }

    #[test]
    fn chain_round_trips_through_import_and_reduction() {
        let d = scratch("mm-chain");
        let n = 30;
        let (k, m, dofs) = chain(n);
        let kp = write(&d, "K.mtx", &mtx(&k, true));
        let mp = write(&d, "M.mtx", &mtx(&m, false));
        let dof_text: String = dofs.iter().map(|(a, b)| format!("{a} {b}\n")).collect();
        let dp = write(&d, "dofs.txt", &format!("# node direction\n{dof_text}"));
        let nodes: String = (1..=n)
            .map(|i| format!("{i} {} 0 0\n", 10.0 * i as f64))
            .collect();
        let np = write(&d, "nodes.txt", &nodes);
        let spec = MatrixMarketImportSpec {
            name: "chain".into(),
            component: Component::Casing,
            stiffness: kp,
            mass: mp,
            dof_map: dp,
            nodes: np,
            contact: ContactSelection::Nodes(vec![10, 20, 30]),
            n_modes: 40,
            units: Units::MmTonneSecond,
            damping: Damping::default(),
            recovery_nodes: vec![],
        };
        let rom = import_matrix_market(&spec).unwrap();
        assert_eq!(rom.contact_nodes[2].position, [0.3, 0.0, 0.0]);
        assert_eq!(rom.contact_nodes[1].row, 1);
        // Reference: dense eigen-solution of the full model in SI units.
        let (f_ref, _) = dense_modes(&(&k * 1e3), &(&m * 1e3), 6).unwrap();
        let f = &rom.modal_data[0].frequencies[0];
        for p in 0..6 {
            assert!(f[p] >= f_ref[p] * (1.0 - 1e-12));
            assert_relative_eq!(f[p], f_ref[p], max_relative = 1e-3);
        }
        // Units: the boundary blocks (physical DOFs) scale by 1e3 from the file units
        // (N/mm → N/m, t → kg); the frequencies do not change.
        let si = import_matrix_market(&MatrixMarketImportSpec {
            units: Units::Si,
            ..spec.clone()
        })
        .unwrap();
        let (h_mm, h_si) = (&rom.harmonics[0], &si.harmonics[0]);
        let bb = |x: &DMatrix<f64>| x.view((0, 0), (9, 9)).into_owned();
        let kb = bb(&h_si.stiffness[0].re) * 1e3;
        assert!((bb(&h_mm.stiffness[0].re) - &kb).amax() < 1e-9 * kb.amax());
        let mb = bb(&h_si.mass.re) * 1e3;
        assert!((bb(&h_mm.mass.re) - &mb).amax() < 1e-9 * mb.amax());
        for (a, b) in f.iter().zip(&si.modal_data[0].frequencies[0]) {
            assert_relative_eq!(*a, *b, max_relative = 1e-9);
        }
    }

    /// The chain of `n` nodes written as a Matrix Market model in SI units, contact nodes
    /// `contact`, `n_modes` modes and recovery nodes `recovery`; with its dense K, M.
    fn chain_spec(
        tag: &str,
        n: usize,
        contact: Vec<usize>,
        n_modes: usize,
        recovery: Vec<usize>,
    ) -> (MatrixMarketImportSpec, DMatrix<f64>, DMatrix<f64>) {
        let d = scratch(tag);
        let (k, m, dofs) = chain(n);
        let dof_text: String = dofs.iter().map(|(a, b)| format!("{a} {b}\n")).collect();
        let nodes: String = (1..=n)
            .map(|i| format!("{i} {} 0 0\n", 0.01 * i as f64))
            .collect();
        let spec = MatrixMarketImportSpec {
            name: "chain".into(),
            component: Component::Impeller,
            stiffness: write(&d, "K.mtx", &mtx(&k, true)),
            mass: write(&d, "M.mtx", &mtx(&m, true)),
            dof_map: write(&d, "dofs.txt", &dof_text),
            nodes: write(&d, "nodes.txt", &nodes),
            contact: ContactSelection::Nodes(contact),
            n_modes,
            units: Units::Si,
            damping: Damping::default(),
            recovery_nodes: recovery,
        };
        (spec, k, m)
    }

    /// Static load on the contact nodes: the recovered displacement of interior nodes equals
    /// the full FE solution `K u = f` (dense LU of the full matrix, independent of the ROM).
    /// Craig–Bampton spans this response exactly (constraint modes), so 1e-6 is a wide margin.
    #[test]
    fn recovered_static_response_equals_the_full_solution() {
        let n = 30;
        let recovery = vec![5, 15, 20, 27];
        let (spec, k, _) = chain_spec("mm-rec", n, vec![10, 20, 30], 12, recovery.clone());
        let rom = import_matrix_market(&spec).unwrap();
        assert_eq!(rom.contact_nodes[1].id, Some(20));
        assert_eq!(rom.recovery.nodes[2].position, [0.2, 0.0, 0.0]);
        // Forces (N) on the contact nodes: one per DOF.
        let fb = [3.0, -1.0, 2.0, 0.5, 4.0, -2.0, -1.5, 1.0, 6.0];
        let mut f = nalgebra::DVector::zeros(3 * n);
        for (j, node) in [10usize, 20, 30].iter().enumerate() {
            for dir in 0..3 {
                f[3 * (node - 1) + dir] = fb[3 * j + dir];
            }
        }
        let u_full = k.clone().lu().solve(&f).unwrap();
        let h = &rom.harmonics[0];
        let nr = h.mass.size();
        let mut g = nalgebra::DVector::zeros(nr);
        g.rows_mut(0, 9).copy_from_slice(&fb);
        let x = h.stiffness[0].re.clone().lu().solve(&g).unwrap();
        let u_rec = &rom.recovery.rows[0].re * &x;
        for (i, node) in recovery.iter().enumerate() {
            for dir in 0..3 {
                let (a, b) = (u_rec[3 * i + dir], u_full[3 * (node - 1) + dir]);
                assert!(b.abs() > 0.0);
                assert_relative_eq!(a, b, max_relative = 1e-6);
            }
        }
    }

    /// Every interior mode kept: the ROM's modes are the full model's, and their shapes
    /// recovered at interior nodes equal the full eigenvectors there (up to sign).
    #[test]
    fn recovered_mode_shapes_equal_the_full_eigenvectors() {
        let n = 8;
        let recovery = vec![2, 6, 4];
        let (spec, k, m) = chain_spec("mm-recmodes", n, vec![4, 8], 3 * n - 6, recovery.clone());
        let rom = import_matrix_market(&spec).unwrap();
        let (_, phi_full) = dense_modes(&k, &m, 4).unwrap();
        let h = &rom.harmonics[0];
        let (_, phi_rom) = dense_modes(&h.stiffness[0].re, &h.mass.re, 4).unwrap();
        let shapes = &rom.recovery.rows[0].re * &phi_rom;
        for p in 0..4 {
            let full = |i: usize, dir: usize| phi_full[(3 * (recovery[i] - 1) + dir, p)];
            // The sign from the largest recovered entry: a mode moves along one direction of
            // the chain, so the others are round-off whose sign means nothing.
            let at = (0..3 * recovery.len())
                .max_by(|&a, &b| {
                    full(a / 3, a % 3)
                        .abs()
                        .total_cmp(&full(b / 3, b % 3).abs())
                })
                .unwrap();
            let sign = if shapes[(at, p)] * full(at / 3, at % 3) < 0.0 {
                -1.0
            } else {
                1.0
            };
            let scale = phi_full.column(p).amax();
            for i in 0..recovery.len() {
                for dir in 0..3 {
                    let d = sign * shapes[(3 * i + dir, p)] - full(i, dir);
                    assert!(
                        d.abs() <= 1e-6 * scale,
                        "mode {p} node {i} dir {dir}: {d:e}"
                    );
                }
            }
        }
    }

    #[test]
    fn unknown_recovery_node_is_rejected_with_its_index() {
        let (spec, _, _) = chain_spec("mm-recbad", 6, vec![3, 6], 4, vec![2, 99]);
        let e = import_matrix_market(&spec).unwrap_err().to_string();
        assert!(e.contains("recovery_nodes[1] = 99"), "{e}");
    }

    #[test]
    fn all_modes_kept_reproduces_the_full_spectrum() {
        let d = scratch("mm-exact");
        let n = 8;
        let (k, m, dofs) = chain(n);
        let spec = MatrixMarketImportSpec {
            name: "c".into(),
            component: Component::Impeller,
            stiffness: write(&d, "K.mtx", &mtx(&k, false)),
            mass: write(&d, "M.mtx", &mtx(&m, true)),
            dof_map: write(
                &d,
                "d.txt",
                &dofs
                    .iter()
                    .map(|(a, b)| format!("{a} {b}\n"))
                    .collect::<String>(),
            ),
            nodes: write(
                &d,
                "n.txt",
                &(1..=n)
                    .map(|i| format!("{i},{i}.0,0,0\n"))
                    .collect::<String>(),
            ),
            contact: ContactSelection::Nodes(vec![4, 8]),
            n_modes: 3 * n - 6,
            units: Units::Si,
            damping: Damping::default(),
            recovery_nodes: vec![],
        };
        let rom = import_matrix_market(&spec).unwrap();
        let (f_ref, _) = dense_modes(&k, &m, 3 * n - 6).unwrap();
        for (a, b) in rom.modal_data[0].frequencies[0].iter().zip(&f_ref) {
            assert_relative_eq!(*a, *b, max_relative = 1e-9);
        }
    }

    #[test]
    fn reads_dof_list_and_rejects_bad_lines() {
        let d = scratch("mm-dof");
        let p = write(&d, "a.txt", "# node direction\n3 1\n% x\n\n3 2\n10   3\n");
        let dofs = read_dof_list(&p).unwrap();
        assert_eq!(
            dofs,
            [(3, 0), (3, 1), (10, 2)].map(|(node, dir)| NodeDof { node, dir })
        );
        for (text, line, why) in [
            ("3 1\n3 4\n", 2, "direction 4"),
            ("3 1\n3 1 2\n", 2, "expected 'node direction'"),
            ("0 1\n", 1, "expected 'node direction'"),
            ("3 1\n3 2\n3 1\n", 3, "twice"),
        ] {
            let p = write(&d, "b.txt", text);
            let (_, l, w) = line_err(read_dof_list(&p).unwrap_err());
            assert_eq!(l, line, "{text:?}");
            assert!(w.contains(why), "{text:?}: {w}");
        }
        let p = write(&d, "c.txt", "# nothing\n");
        assert!(
            read_dof_list(&p)
                .unwrap_err()
                .to_string()
                .contains("no DOFs")
        );
    }

    #[test]
    fn malformed_matrix_market_is_rejected() {
        let d = scratch("mm-bad");
        let hdr = "%%MatrixMarket matrix coordinate real symmetric\n";
        let p = write(&d, "t.mtx", &format!("{hdr}2 2 3\n1 1 2.0\n2 1 -1.0\n"));
        let (f, line, why) = line_err(read_matrix_market(&p, 2, 1.0).unwrap_err());
        assert_eq!((f.as_str(), line), ("t.mtx", 4));
        assert!(
            why.contains("truncated") && why.contains("2 of the 3"),
            "{why}"
        );

        let p = write(
            &d,
            "c.mtx",
            &format!("{hdr}2 2 3\n1 1 2.0\n2 1 -1.0 7\n2 2 3\n"),
        );
        let (_, line, why) = line_err(read_matrix_market(&p, 2, 1.0).unwrap_err());
        assert_eq!(line, 4);
        assert!(why.contains("extra field"), "{why}");

        let p = write(&d, "s.mtx", &format!("{hdr}3 3 1\n1 1 2.0\n"));
        let (_, line, why) = line_err(read_matrix_market(&p, 2, 1.0).unwrap_err());
        assert_eq!(line, 2);
        assert!(why.contains("order 3 but the DOF map has 2"), "{why}");

        let p = write(
            &d,
            "g.mtx",
            "%%MatrixMarket matrix coordinate real general\n2 2 4\n1 1 2.0\n2 1 -1.0\n1 2 -1.5\n2 2 3\n",
        );
        let (_, line, why) = line_err(read_matrix_market(&p, 2, 1.0).unwrap_err());
        assert_eq!(line, 4);
        assert!(why.contains("non-symmetric"), "{why}");

        let p = write(
            &d,
            "x.mtx",
            "%%MatrixMarket matrix array real general\n2 2\n",
        );
        assert!(
            line_err(read_matrix_market(&p, 2, 1.0).unwrap_err())
                .2
                .contains("array")
        );
        let p = write(&d, "o.mtx", &format!("{hdr}2 2 1\n1 3 2.0\n"));
        assert!(
            line_err(read_matrix_market(&p, 2, 1.0).unwrap_err())
                .2
                .contains("out of range")
        );
    }

    // Regressions found by tests/readers_never_panic.rs.

    #[test]
    fn size_line_claiming_huge_count_reserves_nothing() {
        // `4 4 1000000000000` reserved 16 TB for the entries (allocation failure, abort).
        let d = scratch("mm-huge");
        let p = write(
            &d,
            "h.mtx",
            "%%MatrixMarket matrix coordinate real symmetric\n1 1 1000000000000\n1 1 2.0\n",
        );
        let (f, line, why) = line_err(read_matrix_market(&p, 1, 1.0).unwrap_err());
        assert_eq!((f.as_str(), line), ("h.mtx", 3));
        assert!(why.contains("1 of the 1000000000000"), "{why}");
    }

    #[test]
    fn cut_files_are_rejected() {
        // Cut inside the last line: "3.25" read as "3.2", "-20" as "-2".
        let d = scratch("mm-cut");
        let hdr = "%%MatrixMarket matrix coordinate real general\n";
        let p = write(&d, "c.mtx", &format!("{hdr}1 1 1\n1 1 3.2"));
        let (f, line, why) = line_err(read_matrix_market(&p, 1, 1.0).unwrap_err());
        assert_eq!((f.as_str(), line), ("c.mtx", 3));
        assert!(why.contains("truncated"), "{why}");
        let p = write(&d, "n.txt", "1 0 0 0\n2 1 0 -2");
        let (_, line, why) = line_err(read_node_table(&p).unwrap_err());
        assert!(line == 2 && why.contains("truncated"), "{why}");
        let p = write(&d, "d.txt", "1 1\n1 2\n12 3");
        let (_, line, why) = line_err(read_dof_list(&p).unwrap_err());
        assert!(line == 3 && why.contains("truncated"), "{why}");
    }

    #[test]
    fn scaled_value_overflow_is_rejected() {
        // 1e306 N/mm became inf N/m (× 1e3) and was accepted.
        let d = scratch("mm-ovf");
        for sym in ["symmetric", "general"] {
            let text = format!("%%MatrixMarket matrix coordinate real {sym}\n1 1 1\n1 1 1e306\n");
            let p = write(&d, "o.mtx", &text);
            let e = read_matrix_market(&p, 1, 1e3).unwrap_err().to_string();
            assert!(e.contains("o.mtx") && e.contains("overflows"), "{sym}: {e}");
        }
    }

    #[test]
    fn import_errors_name_the_file() {
        let d = scratch("mm-imp");
        let (k, m, dofs) = chain(4);
        let mut spec = MatrixMarketImportSpec {
            name: "c".into(),
            component: Component::Impeller,
            stiffness: write(&d, "K.mtx", &mtx(&k, true)),
            mass: write(
                &d,
                "M.mtx",
                &mtx(&m.view((0, 0), (9, 9)).into_owned(), true),
            ),
            dof_map: write(
                &d,
                "d.txt",
                &dofs
                    .iter()
                    .map(|(a, b)| format!("{a} {b}\n"))
                    .collect::<String>(),
            ),
            nodes: write(&d, "n.txt", "1 0 0 0\n2 1 0 0\n3 2 0 0\n4 3 0 0\n"),
            contact: ContactSelection::Nodes(vec![4]),
            n_modes: 2,
            units: Units::Si,
            damping: Damping::default(),
            recovery_nodes: vec![],
        };
        // Mass of the wrong size.
        let e = import_matrix_market(&spec).unwrap_err().to_string();
        assert!(
            e.contains("M.mtx") && e.contains("order 9 but the DOF map has 12"),
            "{e}"
        );
        spec.mass = write(&d, "M2.mtx", &mtx(&m, true));
        assert!(import_matrix_market(&spec).is_ok());
        // Contact node missing from the node list, then from the DOF map.
        spec.contact = ContactSelection::Nodes(vec![5]);
        let e = import_matrix_market(&spec).unwrap_err().to_string();
        assert!(e.contains("n.txt") && e.contains("contact node 5"), "{e}");
        spec.nodes = write(
            &d,
            "n2.txt",
            "1 0 0 0\n2 1 0 0\n3 2 0 0\n4 3 0 0\n5 4 0 0\n",
        );
        let e = import_matrix_market(&spec).unwrap_err().to_string();
        assert!(e.contains("d.txt") && e.contains("contact node 5"), "{e}");
        // Corrupted DOF map line.
        spec.dof_map = write(&d, "d2.txt", "1 1\n1 2\n1 x\n");
        let (f, line, _) = line_err(import_matrix_market(&spec).unwrap_err());
        assert_eq!((f.as_str(), line), ("d2.txt", 3));
    }
}
