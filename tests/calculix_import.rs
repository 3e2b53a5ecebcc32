//! Cyclic sectors imported from CalculiX decks (issue 40, items 2 and 4): the example pair
//! `tests/data/imported/` holds the built-in impeller and casing sectors as `rubscan model
//! export calculix` writes them; imported back (`rubscan model import calculix-cyclic`), they
//! must give the built-in ROMs' frequencies within 1e-6 on every nodal diameter and speed, and
//! the quickstart job on the imported pair must match the built-in one within 1 % on every
//! reported number. Bad sector decks are refused before any reduction, naming the file and the
//! cause, with a non-zero status and no ROM written.

mod common;
use common::{Scratch, rubscan, stderr, table_without_timing};

use arrow_array::{Array, Float64Array, ListArray, RecordBatch};
use rubscan::io::calculix_export::model_deck;
use rubscan::io::calculix_sector::{CalculixSectorSpec, import_calculix_sector};
use rubscan::model::build::{CasingSpec, ImpellerSpec, build_casing, build_impeller};
use rubscan::model::mesh::{CasingGeometry, ImpellerGeometry};
use rubscan::model::rom::CyclicRom;
use std::path::{Path, PathBuf};

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

fn import(spec_file: &str) -> CyclicRom {
    let path = data().join(spec_file);
    let mut spec: CalculixSectorSpec =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    spec.deck = data().join(&spec.deck);
    import_calculix_sector(&spec).unwrap()
}

/// Largest relative difference between the two ROMs' frequencies over every nodal
/// diameter, speed and mode.
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

#[test]
fn imported_sectors_reduce_to_the_built_in_roms() {
    let pairs = [
        (
            import("impeller_import.json"),
            build_impeller(&ImpellerSpec::default()).unwrap(),
        ),
        (
            import("casing_import.json"),
            build_casing(&CasingSpec::default()).unwrap(),
        ),
    ];
    for (imported, built_in) in &pairs {
        let worst = frequency_difference(imported, built_in);
        eprintln!(
            "{}: largest relative frequency difference {worst:.2e}",
            imported.name
        );
        assert!(worst < 1e-6, "{}: {worst:e}", imported.name);
        assert_eq!(imported.n_sectors, built_in.n_sectors);
        // The deck keeps 15 significant digits of each coordinate.
        for (p, q) in imported.contact_nodes.iter().zip(&built_in.contact_nodes) {
            let d = (0..3)
                .map(|k| (p.position[k] - q.position[k]).abs())
                .fold(0.0, f64::max);
            assert!(d < 1e-15, "contact node moved by {d:e} m");
        }
        assert_eq!(imported.contact_nodes.len(), built_in.contact_nodes.len());
        let names = |r: &CyclicRom| {
            r.recovery
                .nodes
                .iter()
                .map(|n| n.name.clone())
                .collect::<Vec<_>>()
        };
        assert_eq!(names(imported), names(built_in));
    }
    // The impeller's modal data span the built-in speed grid: K(Ω) is imported too.
    assert!(pairs[0].0.modal_data[0].omega.len() > 1);
}

/// Every value of column `i` of both tables, flattened (lists element by element).
fn values(batches: &[RecordBatch], i: usize) -> Option<Vec<f64>> {
    let mut out = Vec::new();
    for b in batches {
        let col = b.column(i);
        if let Some(f) = col.as_any().downcast_ref::<Float64Array>() {
            out.extend(f.iter().map(|v| v.unwrap_or(f64::NAN)));
        } else if let Some(list) = col.as_any().downcast_ref::<ListArray>() {
            let inner = list.values().as_any().downcast_ref::<Float64Array>()?;
            out.extend(inner.iter().map(|v| v.unwrap_or(f64::NAN)));
        } else {
            return None;
        }
    }
    Some(out)
}

#[test]
fn the_quickstart_on_the_imported_pair_matches_the_built_in_one() {
    let work = scratch("quickstart");
    let dir = &work.0;
    std::fs::create_dir_all(dir.join("sweeps")).unwrap();
    std::fs::create_dir_all(dir.join("results/imported")).unwrap();
    for c in ["impeller", "casing"] {
        let o = rubscan()
            .args(["model", "import", "calculix-cyclic"])
            .arg(data().join(format!("{c}_import.json")))
            .arg("-o")
            .arg(dir.join(format!("results/imported/{c}.rom")))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    // The sweep names its ROMs relative to itself: run a copy beside the imported ROMs.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let spec = std::fs::read_to_string(root.join("sweeps/imported_quickstart.json")).unwrap();
    std::fs::write(dir.join("sweeps/imported_quickstart.json"), spec).unwrap();
    let run = |spec: &Path, out: &Path| {
        let o = rubscan()
            .arg("run")
            .arg(spec)
            .args(["--threads", "2", "-o"])
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };
    run(
        &dir.join("sweeps/imported_quickstart.json"),
        &dir.join("imported"),
    );
    run(&root.join("sweeps/quickstart.json"), &dir.join("built_in"));
    let (a, b) = (
        table_without_timing(&dir.join("imported")),
        table_without_timing(&dir.join("built_in")),
    );
    let schema = a[0].schema();
    assert_eq!(schema.fields().len(), b[0].schema().fields().len());
    let mut compared = 0;
    for (i, field) in schema.fields().iter().enumerate() {
        let (Some(x), Some(y)) = (values(&a, i), values(&b, i)) else {
            continue;
        };
        assert_eq!(x.len(), y.len(), "column {}", field.name());
        // Relative to the column's largest magnitude: a spectrum's or a profile's small
        // entries are judged against its peak.
        let scale = y
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        for (p, q) in x.iter().zip(&y) {
            assert_eq!(p.is_finite(), q.is_finite(), "column {}", field.name());
            if p.is_finite() && field.name() != "residual_penetration_m" {
                assert!(
                    (p - q).abs() <= 1e-2 * scale,
                    "column {}: imported {p:e}, built-in {q:e}",
                    field.name()
                );
            }
        }
        compared += 1;
    }
    assert!(compared > 10, "only {compared} numeric columns compared");
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
