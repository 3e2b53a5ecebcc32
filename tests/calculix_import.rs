//! Cyclic sectors imported from CalculiX decks (issue 40, items 2 and 4): the example pair
//! `tests/data/imported/` holds the built-in impeller and casing sectors as `rubscan model
//! export calculix` writes them; imported back (`rubscan model import calculix-cyclic`), they
//! must give the built-in ROMs to the bit (matrices, modal data, recovery rows, contact
//! nodes), and the quickstart job on the imported pair must give the built-in one's table
//! within 1e-9 on every value of every column. The bit-for-bit ROM is what makes the second
//! claim possible: the quickstart's rubbing amplifies round-off about 1e9-fold (its stiffness
//! scaled by 1 + 1e-12 moves the blade's leading-edge peak by 1.5e-3), so ROMs equal to 1e-11
//! gave tables 0.36 % apart. Bad sector decks are refused before any reduction, naming the
//! file and the cause, with a non-zero status and no ROM written.

use crate::common;
use common::{Scratch, quickstart_output, rubscan, stderr, table_without_timing};

use arrow_array::Array;
use rubscan::io::calculix_export::model_deck;
use rubscan::io::rom_file;
use rubscan::model::build::{CasingSpec, ImpellerSpec, build_casing, build_impeller};
use rubscan::model::mesh::{CasingGeometry, ImpellerGeometry};
use rubscan::model::rom::CyclicRom;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/imported")
}

fn scratch(tag: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("rubscan-import-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    Scratch(dir)
}

/// The deck's data lines (comments dropped: they carry the writing version).
fn data_lines(text: &str) -> Vec<&str> {
    text.lines().filter(|l| !l.starts_with("**")).collect()
}

/// The shipped decks are what the export writes for today's built-in sectors, so the
/// comparisons below compare the same mesh.
#[test]
fn the_example_decks_are_the_built_in_sectors() {
    for (file, mesh, name) in [
        (
            "impeller_sector.inp",
            ImpellerGeometry::default().build(),
            "impeller",
        ),
        (
            "casing_sector.inp",
            CasingGeometry::default().build(),
            "casing",
        ),
    ] {
        let shipped = std::fs::read_to_string(data().join(file)).unwrap();
        let now = model_deck(&mesh.unwrap(), name).unwrap();
        assert!(
            data_lines(&shipped) == data_lines(&now),
            "{file} is stale: rewrite it with `rubscan model export calculix -o tests/data/imported`"
        );
    }
}

/// The example pair imported once per test binary with the README's commands (`rubscan model
/// import calculix-cyclic tests/data/imported/{impeller,casing}_import.json -o
/// results/imported/<c>.rom`, under a scratch folder) and read back: `[impeller, casing]`,
/// and the folder.
fn imported_pair() -> &'static ([CyclicRom; 2], PathBuf) {
    static PAIR: OnceLock<([CyclicRom; 2], PathBuf)> = OnceLock::new();
    PAIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("calculix_import");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("results/imported")).unwrap();
        let roms = ["impeller", "casing"].map(|c| {
            let rom = dir.join(format!("results/imported/{c}.rom"));
            let o = rubscan()
                .args(["model", "import", "calculix-cyclic"])
                .arg(data().join(format!("{c}_import.json")))
                .arg("-o")
                .arg(&rom)
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", stderr(&o));
            rom_file::load(&rom).unwrap()
        });
        (roms, dir)
    })
}

/// Largest relative difference between the two ROMs' frequencies over every nodal
/// diameter, speed and mode (printed: 0 when the ROMs are equal to the bit).
fn frequency_difference(a: &CyclicRom, b: &CyclicRom) -> f64 {
    assert_eq!(a.modal_data.len(), b.modal_data.len());
    let mut worst = 0.0f64;
    for (da, db) in a.modal_data.iter().zip(&b.modal_data) {
        assert_eq!(da.omega, db.omega);
        for (fa, fb) in da.frequencies.iter().zip(&db.frequencies) {
            assert_eq!(fa.len(), fb.len());
            for (x, y) in fa.iter().zip(fb) {
                worst = worst.max((x - y).abs() / y.abs());
            }
        }
    }
    worst
}

/// Largest difference between the two ROMs' stored mode shapes, relative to the largest entry.
fn shape_difference(a: &CyclicRom, b: &CyclicRom) -> f64 {
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for (da, db) in a.modal_data.iter().zip(&b.modal_data) {
        for (sa, sb) in [
            (&da.shapes_re, &db.shapes_re),
            (&da.shapes_im, &db.shapes_im),
        ] {
            let (x, y): (Vec<f64>, Vec<f64>) = (
                sa.iter().flatten().flatten().copied().collect(),
                sb.iter().flatten().flatten().copied().collect(),
            );
            assert_eq!(x.len(), y.len(), "ND {}: shapes", da.nodal_diameter);
            for (p, q) in x.iter().zip(&y) {
                worst = worst.max((p - q).abs());
                scale = scale.max(q.abs());
            }
        }
    }
    worst / scale
}

/// The example pair imported back is the built-in pair: every matrix, recovery row, contact
/// node and frequency to the bit, the stored mode shapes to round-off.
#[test]
fn imported_sectors_reduce_to_the_built_in_roms() {
    let [impeller, casing] = &imported_pair().0;
    let pairs = [
        (impeller, build_impeller(&ImpellerSpec::default()).unwrap()),
        (casing, build_casing(&CasingSpec::default()).unwrap()),
    ];
    for (imported, built_in) in &pairs {
        let worst = frequency_difference(imported, built_in);
        eprintln!(
            "{}: largest relative frequency difference {worst:.2e}",
            imported.name
        );
        // The same ROM but for its name, its provenance and the recovery nodes' ids (deck ids,
        // 1-based, against the built-in mesh's 0-based indices): the deck holds every coordinate
        // exactly (`calculix_export::real_field`), so the same mesh goes through the same reduction
        // (the deck clamps a clamped slave node through its master partner; the reduction clamps
        // both nodes of a cyclic pair either way). The mode shapes stored for the interaction
        // criterion come from an eigensolver whose vectors may differ by round-off (7.5e-14
        // measured once between two processes, 0 here); they are held to 1e-9 of their largest
        // entry.
        assert!(
            worst == 0.0,
            "{}: frequencies differ by {worst:e}",
            imported.name
        );
        let mut same = built_in.clone();
        same.name.clone_from(&imported.name);
        same.provenance = imported.provenance.clone();
        for (n, m) in same.recovery.nodes.iter_mut().zip(&imported.recovery.nodes) {
            assert_eq!(m.id, n.id + 1, "recovery node {:?}", n.name);
            n.id = m.id;
        }
        let shape_gap = shape_difference(imported, &same);
        eprintln!("{}: mode shapes within {shape_gap:.2e}", imported.name);
        assert!(
            shape_gap <= 1e-9,
            "{}: mode shapes {shape_gap:e}",
            imported.name
        );
        for (m, n) in same.modal_data.iter_mut().zip(&imported.modal_data) {
            m.shapes_re.clone_from(&n.shapes_re);
            m.shapes_im.clone_from(&n.shapes_im);
        }
        assert!(
            **imported == same,
            "{}: the imported ROM differs from the built-in one",
            imported.name
        );
    }
    // The impeller's modal data span the built-in speed grid: K(Ω) is imported too.
    assert!(pairs[0].0.modal_data[0].omega.len() > 1);
}

/// One value of a results table: a number (floats, integers and booleans as f64), a text, a
/// list's length or a null.
#[derive(Clone, Debug, PartialEq)]
enum Cell {
    Num(f64),
    Text(String),
    Len(usize),
    Null,
}

/// The values of column `col` named `name`, in row order, each with its leaf's name: a list
/// gives its length, then its items; a struct gives its fields as `name.field`.
fn cells(name: &str, col: &dyn Array, out: &mut Vec<(String, Cell)>) {
    use arrow_array::{
        BooleanArray, Float64Array, ListArray, StringArray, StructArray, UInt32Array, UInt64Array,
    };
    let any = col.as_any();
    for i in 0..col.len() {
        let cell = if col.is_null(i) {
            Cell::Null
        } else if let Some(a) = any.downcast_ref::<Float64Array>() {
            Cell::Num(a.value(i))
        } else if let Some(a) = any.downcast_ref::<UInt32Array>() {
            Cell::Num(f64::from(a.value(i)))
        } else if let Some(a) = any.downcast_ref::<UInt64Array>() {
            Cell::Num(a.value(i) as f64)
        } else if let Some(a) = any.downcast_ref::<BooleanArray>() {
            Cell::Num(f64::from(u8::from(a.value(i))))
        } else if let Some(a) = any.downcast_ref::<StringArray>() {
            Cell::Text(a.value(i).to_string())
        } else if let Some(a) = any.downcast_ref::<ListArray>() {
            let items = a.value(i);
            out.push((format!("{name}[]"), Cell::Len(items.len())));
            cells(name, items.as_ref(), out);
            continue;
        } else if let Some(a) = any.downcast_ref::<StructArray>() {
            for (field, c) in a.fields().iter().zip(a.columns()) {
                cells(&format!("{name}.{}", field.name()), &c.slice(i, 1), out);
            }
            continue;
        } else {
            panic!("{name}: column type {:?} not compared", col.data_type());
        };
        out.push((name.to_string(), cell));
    }
}

/// Columns that name a job rather than report on it: the job id hashes the job's context,
/// which names the models by source (built-in spec or ROM file name), so it differs between
/// the two runs by construction.
const IDENTITY_COLUMNS: [&str; 1] = ["job_id"];

/// Largest relative difference accepted between the two quickstart tables. The imported ROMs
/// equal the built-in ones to the bit (test above), so the runs are the same computation and
/// agree exactly; 1e-9 is the bound, well above the round-off of one step and far
/// below the 1.5e-3 that a 1e-12 change of the impeller's stiffness makes.
const TABLE_TOLERANCE: f64 = 1e-9;

/// The quickstart (`sweeps/imported_quickstart.json`) on the imported pair, run as the README
/// runs it, gives the built-in quickstart's table within [`TABLE_TOLERANCE`] on every value
/// of every column: floats relative to the largest magnitude of their column (or list or
/// struct field: a spectrum's small bins are judged against its peak), integers, booleans,
/// list lengths and texts exactly; left out are the wall time (timing) and the job id (it
/// names the models' source).
#[test]
fn the_quickstart_on_the_imported_pair_matches_the_built_in_one() {
    let dir = &imported_pair().1;
    std::fs::create_dir_all(dir.join("sweeps")).unwrap();
    // The sweep names its ROMs relative to itself: run a copy beside the imported ROMs.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let spec = std::fs::read_to_string(root.join("sweeps/imported_quickstart.json")).unwrap();
    std::fs::write(dir.join("sweeps/imported_quickstart.json"), spec).unwrap();
    let o = rubscan()
        .arg("run")
        .arg(dir.join("sweeps/imported_quickstart.json"))
        .args(["--threads", "2", "-o"])
        .arg(dir.join("imported"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // The built-in quickstart of this build, run once for the test binaries that need it.
    let (a, b) = (
        table_without_timing(&dir.join("imported")),
        table_without_timing(quickstart_output()),
    );
    let schema = b[0].schema();
    assert_eq!(a[0].schema(), schema, "the two tables' columns");
    let mut compared = 0;
    let mut worst: (f64, String) = (0.0, String::new());
    for (i, field) in schema.fields().iter().enumerate() {
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for batch in &a {
            cells(field.name(), batch.column(i).as_ref(), &mut x);
        }
        for batch in &b {
            cells(field.name(), batch.column(i).as_ref(), &mut y);
        }
        assert_eq!(x.len(), y.len(), "column {}: values", field.name());
        if IDENTITY_COLUMNS.contains(&field.name().as_str()) {
            continue;
        }
        // Scale of each leaf (column, list items, struct field): its largest finite magnitude.
        let mut scale: BTreeMap<&str, f64> = BTreeMap::new();
        for (leaf, c) in &y {
            if let Cell::Num(v) = c
                && v.is_finite()
            {
                let s = scale.entry(leaf.as_str()).or_insert(0.0);
                *s = s.max(v.abs());
            }
        }
        for ((leaf, p), (_, q)) in x.iter().zip(&y) {
            match (p, q) {
                (Cell::Num(p), Cell::Num(q)) if p.is_finite() && q.is_finite() => {
                    let d = if p == q {
                        0.0
                    } else {
                        (p - q).abs() / scale[leaf.as_str()]
                    };
                    if d > worst.0 {
                        worst = (d, leaf.clone());
                    }
                    assert!(
                        d <= TABLE_TOLERANCE,
                        "{leaf}: imported {p:e}, built-in {q:e} ({d:.2e} of the column's \
                         largest value {:e})",
                        scale[leaf.as_str()]
                    );
                }
                (Cell::Num(p), Cell::Num(q)) => assert!(
                    p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()),
                    "{leaf}: imported {p:e}, built-in {q:e}"
                ),
                _ => assert_eq!(p, q, "{leaf}"),
            }
        }
        compared += 1;
    }
    eprintln!(
        "{compared} columns compared; largest relative difference {:.2e} ({})",
        worst.0, worst.1
    );
    assert_eq!(compared + IDENTITY_COLUMNS.len(), schema.fields().len());
    assert!(compared > 20, "only {compared} columns compared");
}

/// A bad sector deck or spec given to the CLI: non-zero status, the message names `names`
/// and says `why`, and no ROM is written.
fn refused(dir: &Path, deck: &str, spec: serde_json::Value, names: &Path, why: &str) {
    std::fs::write(dir.join("sector.inp"), deck).unwrap();
    let spec_path = dir.join("import.json");
    std::fs::write(&spec_path, spec.to_string()).unwrap();
    let rom = dir.join("out.rom");
    let o = rubscan()
        .args(["model", "import", "calculix-cyclic"])
        .arg(&spec_path)
        .arg("-o")
        .arg(&rom)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(!o.status.success(), "accepted; {err}");
    assert!(err.contains(&names.display().to_string()), "{err}");
    assert!(err.contains(why), "expected '{why}' in: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!rom.exists());
}

/// The deck with the `*NODE` lines of `ids` rewritten by `f`.
fn move_nodes(deck: &str, ids: &[usize], f: impl Fn([f64; 3]) -> [f64; 3]) -> String {
    let ids: std::collections::HashSet<usize> = ids.iter().copied().collect();
    let mut in_nodes = false;
    let mut out = String::new();
    for line in deck.lines() {
        if line.starts_with('*') {
            in_nodes = line.starts_with("*NODE");
        } else if in_nodes {
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            let id: usize = fields[0].parse().unwrap();
            if ids.contains(&id) {
                let p = [1, 2, 3].map(|k| fields[k].parse::<f64>().unwrap());
                let [x, y, z] = f(p);
                out.push_str(&format!("{id}, {x:e}, {y:e}, {z:e}\n"));
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

#[test]
fn bad_sector_decks_are_refused_before_any_reduction() {
    let work = scratch("bad");
    let dir = &work.0;
    let mesh = ImpellerGeometry::default().build().unwrap();
    let deck = std::fs::read_to_string(data().join("impeller_sector.inp")).unwrap();
    let spec = serde_json::json!({
        "name": "bad", "component": "impeller", "deck": "sector.inp",
        "contact": { "node_set": "CONTACT" }, "units": "si"
    });
    let deck_path = dir.join("sector.inp");
    let right_ids: Vec<usize> = mesh.right_nodes.iter().map(|n| n + 1).collect();

    // One right-face node off its place: named.
    let moved = right_ids[7];
    let bad = move_nodes(&deck, &[moved], |[x, y, z]| [x, y, z + 1e-4]);
    refused(
        dir,
        &bad,
        spec.clone(),
        &deck_path,
        "do not match a node of the other face",
    );
    refused(dir, &bad, spec.clone(), &deck_path, &moved.to_string());

    // The right face turned by 1.1 × 2π/N: 360°/(1.1 × 36°) is not a whole number.
    let alpha = std::f64::consts::TAU / mesh.n_sectors as f64;
    let (s, c) = (0.1 * alpha).sin_cos();
    let turned = move_nodes(&deck, &right_ids, |[x, y, z]| {
        [c * x - s * y, s * x + c * y, z]
    });
    refused(
        dir,
        &turned,
        spec.clone(),
        &deck_path,
        "which does not divide 360°",
    );

    // A contact node inside the blade.
    let mut interior_spec = spec.clone();
    let free = {
        let cyclic = mesh
            .left_nodes
            .iter()
            .chain(&mesh.right_nodes)
            .copied()
            .collect();
        rubscan::model::sector_faces::free_surface_nodes(&mesh.elements, &cyclic)
    };
    let inside = (0..mesh.nodes.len()).find(|n| !free.contains(n)).unwrap() + 1;
    interior_spec["contact"] = serde_json::json!({ "nodes": [inside] });
    refused(
        dir,
        &deck,
        interior_spec,
        &deck_path,
        "is not on the free surface",
    );

    // Cut in the middle of a line, and at a line boundary inside the elements.
    let cut = deck.len() / 2;
    refused(dir, &deck[..cut], spec.clone(), &deck_path, "truncated");
    // Element 21's first line (an element takes two lines): its node list stops at 15.
    let lines: Vec<&str> = deck.lines().collect();
    let first = lines
        .iter()
        .position(|l| l.starts_with("*ELEMENT"))
        .unwrap();
    let at_boundary = lines[..=first + 41].join("\n") + "\n";
    refused(
        dir,
        &at_boundary,
        spec,
        &deck_path,
        "element 21 has 15 nodes",
    );
}
