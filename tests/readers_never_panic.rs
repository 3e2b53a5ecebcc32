//! Property tests of every input reader (issue #22): mutated sweep specs, ROM files,
//! CalculiX files (`.sti`/`.mas`, `.dof`, `.inp`/`.msh`) and Matrix Market files (`.mtx`,
//! DOF list, node table), truncated, corrupted or random, give an error, never a panic, a
//! hang or a huge allocation; and an input that is invalid by construction (a truncated
//! file, an unknown key, a non-number where a number belongs…) gives `Err`.
//!
//! The readers are exercised through their public API: `parse_spec(&str)`,
//! `rom_file::from_bytes(&[u8])`, and the path-based text readers on files written to a
//! folder of this test binary (`CARGO_TARGET_TMPDIR`, one per property and process).
//!
//! Every allocation above [`MAX_ALLOC`] fails (see [`CappedAlloc`]): a reader that sizes a
//! buffer from a corrupted length aborts the test binary with "memory allocation of N bytes
//! failed" instead of silently over-committing memory.
//!
//! Cases per property are set by `cases(n)`; see [`CASES`] for the total.

use std::alloc::{GlobalAlloc, Layout, System};
use std::fmt::Debug;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use proptest::prelude::*;
use proptest::test_runner::{RngSeed, TestCaseError};
use rubscan::io::{calculix, matrix_market, rom_file};
use rubscan::sweep::parse_spec;
use serde_json::{Value, json};

/// Largest single allocation the readers may make in this test binary (256 MiB).
const MAX_ALLOC: usize = 256 << 20;

/// The system allocator, refusing any single allocation above [`MAX_ALLOC`] (the process
/// then aborts with "memory allocation of N bytes failed", naming the size).
struct CappedAlloc;

// SAFETY: forwards to `System`, only refusing (null) requests that are too large.
unsafe impl GlobalAlloc for CappedAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > MAX_ALLOC {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > MAX_ALLOC {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > MAX_ALLOC {
            return std::ptr::null_mut();
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOC: CappedAlloc = CappedAlloc;

/// Cases per property, in the order of the properties below (name, cases); the total is
/// printed by `case_counts_are_documented`.
const CASES: &[(&str, u32)] = &[
    ("spec_structured_mutations", 600),
    ("spec_truncated", 300),
    ("spec_byte_flips", 300),
    ("spec_random_text", 300),
    ("rom_truncated", 200),
    ("rom_byte_flips", 300),
    ("rom_header_corrupted", 600),
    ("sti_corrupted", 400),
    ("dof_corrupted", 300),
    ("deck_corrupted", 400),
    ("mtx_corrupted", 500),
    ("mm_dof_and_nodes_corrupted", 300),
    ("text_readers_random_bytes", 300),
];

/// The proptest configuration of property `name` (its count from [`CASES`]; no
/// persistence file: found inputs become unit tests in the readers' modules). Under CI the
/// seed is fixed so that a run is reproducible; elsewhere each run explores new inputs.
fn cases(name: &str) -> ProptestConfig {
    let n = CASES
        .iter()
        .find(|(p, _)| *p == name)
        .unwrap_or_else(|| panic!("no case count for {name}"))
        .1;
    ProptestConfig {
        cases: n,
        failure_persistence: None,
        rng_seed: match std::env::var_os("CI") {
            Some(_) => RngSeed::Fixed(0x5275_6273_6361_6e00),
            None => RngSeed::Random,
        },
        ..ProptestConfig::default()
    }
}

#[test]
fn case_counts_are_documented() {
    let total: u32 = CASES.iter().map(|c| c.1).sum();
    println!("{} properties, {total} cases in total", CASES.len());
    assert_eq!(CASES.len(), 13);
}

/// Runs `f`, turning a panic into a test failure that shows `input`.
fn no_panic<T>(what: &str, input: &dyn Debug, f: impl FnOnce() -> T) -> Result<T, TestCaseError> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|p| {
        let msg = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        TestCaseError::fail(format!("{what} panicked ({msg}) on input {input:?}"))
    })
}

/// A fresh folder for property `name` of this process.
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("readers_never_panic-{}", std::process::id()))
        .join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// `text` cut to at most `cut` bytes, on a character boundary.
fn cut_str(text: &str, cut: usize) -> &str {
    let mut c = cut.min(text.len());
    while !text.is_char_boundary(c) {
        c -= 1;
    }
    &text[..c]
}

/// `bytes` with each `(position, value)` written (positions modulo the length).
fn flip(bytes: &[u8], flips: &[(usize, u8)]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    if !b.is_empty() {
        for &(i, v) in flips {
            let n = b.len();
            b[i % n] = v;
        }
    }
    b
}

// ---------------------------------------------------------------------------------------
// Sweep specs
// ---------------------------------------------------------------------------------------

/// The real specs: every `sweeps/*.json` and `tests/data/small_sweep.json`.
fn real_specs() -> Vec<(String, Value)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(root.join("sweeps"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    files.push(root.join("tests/data/small_sweep.json"));
    files
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (
                p.display().to_string(),
                serde_json::from_str(&text).unwrap(),
            )
        })
        .collect()
}

/// Every object key of the schema and of the real specs: a key renamed to none of these is unknown.
fn known_keys(specs: &[(String, Value)]) -> std::collections::HashSet<String> {
    fn walk(v: &Value, out: &mut std::collections::HashSet<String>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    out.insert(k.clone());
                    walk(x, out);
                }
            }
            Value::Array(a) => a.iter().for_each(|x| walk(x, out)),
            _ => {}
        }
    }
    let schema = Path::new(env!("CARGO_MANIFEST_DIR")).join("schemas/sweep.schema.json");
    let schema: Value = serde_json::from_str(&std::fs::read_to_string(schema).unwrap()).unwrap();
    let mut out = std::collections::HashSet::new();
    walk(&schema, &mut out);
    specs.iter().for_each(|(_, v)| walk(v, &mut out));
    out
}

#[derive(Clone, Debug, PartialEq)]
enum Seg {
    Key(String),
    Idx(usize),
}

/// Paths of every node of `v` (root first, pre-order).
fn paths(v: &Value) -> Vec<Vec<Seg>> {
    fn walk(v: &Value, here: &mut Vec<Seg>, out: &mut Vec<Vec<Seg>>) {
        out.push(here.clone());
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    here.push(Seg::Key(k.clone()));
                    walk(x, here, out);
                    here.pop();
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    here.push(Seg::Idx(i));
                    walk(x, here, out);
                    here.pop();
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(v, &mut Vec::new(), &mut out);
    out
}

fn node_mut<'a>(v: &'a mut Value, path: &[Seg]) -> &'a mut Value {
    path.iter().fold(v, |v, s| match s {
        Seg::Key(k) => &mut v[k.as_str()],
        Seg::Idx(i) => &mut v[*i],
    })
}

/// The node at `path`, if `v` has one.
fn node_at<'a>(v: &'a Value, path: &[Seg]) -> Option<&'a Value> {
    path.iter().try_fold(v, |v, s| match s {
        Seg::Key(k) => v.get(k.as_str()),
        Seg::Idx(i) => v.get(*i),
    })
}

/// Whether the schema lets anything through at `path` (typed check elsewhere, or not at
/// parse time): inside `scenario`, `numerics` (pass-through objects) or a `builtin` model.
fn pass_through(path: &[Seg]) -> bool {
    let first_free =
        matches!(path.first(), Some(Seg::Key(k)) if k == "scenario" || k == "numerics");
    let builtin = path.iter().any(|s| *s == Seg::Key("builtin".into()));
    (first_free && path.len() >= 2) || builtin
}

/// A JSON value substituted into a spec.
#[derive(Clone, Debug)]
enum Repl {
    Null,
    Bool(bool),
    Num(f64),
    BigInt(u64),
    NegInt(i64),
    Str(String),
    EmptyArray,
    EmptyObject,
    Deep(usize),
}

impl Repl {
    fn value(&self) -> Value {
        match self {
            Repl::Null => Value::Null,
            Repl::Bool(b) => json!(b),
            Repl::Num(x) => json!(x),
            Repl::BigInt(x) => json!(x),
            Repl::NegInt(x) => json!(x),
            Repl::Str(s) => json!(s),
            Repl::EmptyArray => json!([]),
            Repl::EmptyObject => json!({}),
            Repl::Deep(d) => (0..*d).fold(json!(1), |v, _| json!([v])),
        }
    }
}

fn repl() -> impl Strategy<Value = Repl> {
    prop_oneof![
        Just(Repl::Null),
        any::<bool>().prop_map(Repl::Bool),
        prop::sample::select(vec![
            0.0, -0.0, -1.0, -1e-300, 1e-320, 0.5, 1e308, -1e308, 1e20, 4e9
        ])
        .prop_map(Repl::Num),
        prop::sample::select(vec![u64::MAX, 1 << 53, 1 << 32, 1_000_000_001])
            .prop_map(Repl::BigInt),
        prop::sample::select(vec![i64::MIN, -1, 0]).prop_map(Repl::NegInt),
        prop::sample::select(vec!["NaN", "inf", "-Infinity", "", "1e999", "é\u{0}"])
            .prop_map(|s| Repl::Str(s.into())),
        Just(Repl::EmptyArray),
        Just(Repl::EmptyObject),
        (1usize..200).prop_map(Repl::Deep),
    ]
}

/// One structured mutation of a spec; `at` picks a node (modulo the candidates).
#[derive(Clone, Debug)]
enum SpecMut {
    /// Removes the node from its object or array.
    Delete { at: usize },
    /// Renames an object key by one edit (insert, delete or replace `ch` at `pos`).
    Rename {
        at: usize,
        pos: usize,
        op: u8,
        ch: char,
    },
    /// Replaces the node's value.
    Replace { at: usize, with: Repl },
    /// Adds the key `zz_not_a_field` to an object.
    AddUnknown { at: usize },
}

fn spec_mut() -> impl Strategy<Value = SpecMut> {
    let ch = prop::sample::select("az_09X".chars().collect::<Vec<_>>());
    prop_oneof![
        any::<usize>().prop_map(|at| SpecMut::Delete { at }),
        (any::<usize>(), any::<usize>(), 0u8..3, ch)
            .prop_map(|(at, pos, op, ch)| { SpecMut::Rename { at, pos, op, ch } }),
        (any::<usize>(), repl()).prop_map(|(at, with)| SpecMut::Replace { at, with }),
        any::<usize>().prop_map(|at| SpecMut::AddUnknown { at }),
    ]
}

fn json_type(v: &Value) -> u8 {
    match v {
        Value::Null => 0,
        Value::Bool(_) => 1,
        Value::Number(_) => 2,
        Value::String(_) => 3,
        Value::Array(_) => 4,
        Value::Object(_) => 5,
    }
}

/// Applies `m` to `v`; returns whether it made the spec invalid by construction (an
/// unknown key or a value of another JSON type where the schema types the field). The
/// field's type is the one it has in `original`, the real spec, when it is there: an earlier
/// mutation may have changed it, and writing the original type back is not an error.
fn apply(
    v: &mut Value,
    m: &SpecMut,
    original: &Value,
    known: &std::collections::HashSet<String>,
) -> bool {
    let all = paths(v);
    match m {
        SpecMut::Delete { at } => {
            let p = &all[at % all.len()];
            if let Some((last, parent)) = p.split_last() {
                match (node_mut(v, parent), last) {
                    (Value::Object(o), Seg::Key(k)) => {
                        o.remove(k);
                    }
                    (Value::Array(a), Seg::Idx(i)) => {
                        a.remove(*i);
                    }
                    _ => unreachable!(),
                }
            }
            false
        }
        SpecMut::Rename { at, pos, op, ch } => {
            let keyed: Vec<&Vec<Seg>> = all
                .iter()
                .filter(|p| matches!(p.last(), Some(Seg::Key(_))))
                .collect();
            if keyed.is_empty() {
                return false;
            }
            let p = keyed[at % keyed.len()];
            let (Some(Seg::Key(old)), parent) = (p.last(), &p[..p.len() - 1]) else {
                unreachable!()
            };
            let mut chars: Vec<char> = old.chars().collect();
            let i = pos % (chars.len() + 1);
            match op {
                0 => chars.insert(i, *ch),
                1 if i < chars.len() => {
                    chars.remove(i);
                }
                _ if i < chars.len() => chars[i] = *ch,
                _ => chars.push(*ch),
            }
            let new: String = chars.into_iter().collect();
            let Value::Object(o) = node_mut(v, parent) else {
                unreachable!()
            };
            if new == *old || o.contains_key(&new) {
                return false;
            }
            let x = o.remove(old).unwrap();
            o.insert(new.clone(), x);
            !known.contains(&new) && !pass_through(p)
        }
        SpecMut::Replace { at, with } => {
            let p = &all[at % all.len()];
            let node = node_mut(v, p);
            let new = with.value();
            let typed = node_at(original, p).unwrap_or(&*node);
            let changed_type = json_type(typed) != json_type(&new)
                && json_type(node) != json_type(&new)
                && !new.is_null();
            *node = new;
            changed_type && !pass_through(p)
        }
        SpecMut::AddUnknown { at } => {
            let objects: Vec<&Vec<Seg>> = all
                .iter()
                .filter(|p| matches!(node_mut(&mut v.clone(), p), Value::Object(_)))
                .collect();
            if objects.is_empty() {
                return false;
            }
            let p = objects[at % objects.len()];
            let free = pass_through(p)
                || matches!(p.as_slice(), [Seg::Key(k)] if k == "scenario" || k == "numerics");
            if let Value::Object(o) = node_mut(v, p) {
                o.insert("zz_not_a_field".into(), json!(1));
            }
            !free
        }
    }
}

proptest! {
    #![proptest_config(cases("spec_structured_mutations"))]
    /// Structured mutations of the real specs: never a panic; `Err` when the last mutation
    /// made the spec invalid by construction.
    #[test]
    fn spec_structured_mutations(
        which in any::<usize>(),
        muts in prop::collection::vec(spec_mut(), 0..3),
        last in spec_mut(),
    ) {
        let specs = real_specs();
        let known = known_keys(&specs);
        let (name, original) = &specs[which % specs.len()];
        let mut v = original.clone();
        for m in &muts {
            apply(&mut v, m, original, &known);
        }
        let invalid = apply(&mut v, &last, original, &known);
        let text = serde_json::to_string_pretty(&v).unwrap();
        let r = no_panic("parse_spec", &text, || parse_spec(&text))?;
        if invalid {
            prop_assert!(r.is_err(), "{name}: {last:?} must be rejected, accepted:\n{text}");
        }
        if let Err(e) = r {
            prop_assert!(!e.to_string().is_empty());
        }
    }
}

proptest! {
    #![proptest_config(cases("spec_truncated"))]
    /// A spec cut anywhere before its last non-blank byte is rejected.
    #[test]
    fn spec_truncated(which in any::<usize>(), cut in any::<usize>()) {
        let specs = real_specs();
        let (name, v) = &specs[which % specs.len()];
        let text = serde_json::to_string_pretty(v).unwrap();
        let cut = cut_str(&text, cut % text.len());
        let r = no_panic("parse_spec", &cut, || parse_spec(cut))?;
        prop_assert!(r.is_err(), "{name} cut at {} bytes was accepted", cut.len());
    }
}

proptest! {
    #![proptest_config(cases("spec_byte_flips"))]
    /// Random bytes written over a spec: never a panic.
    #[test]
    fn spec_byte_flips(which in any::<usize>(), flips in prop::collection::vec(any::<(usize, u8)>(), 1..8)) {
        let specs = real_specs();
        let text = serde_json::to_string_pretty(&specs[which % specs.len()].1).unwrap();
        let bytes = flip(text.as_bytes(), &flips);
        let text = String::from_utf8_lossy(&bytes);
        let _ = no_panic("parse_spec", &text, || parse_spec(&text))?;
    }
}

proptest! {
    #![proptest_config(cases("spec_random_text"))]
    /// Random bytes, and random JSON-like text, are rejected.
    #[test]
    fn spec_random_text(
        bytes in prop::collection::vec(any::<u8>(), 0..300),
        jsonish in prop::collection::vec(
            prop::sample::select("{}[]\":, 0123456789.eE-+truefalsenul\n\\".chars().collect::<Vec<_>>()),
            0..300,
        ),
    ) {
        let text = String::from_utf8_lossy(&bytes);
        let r = no_panic("parse_spec", &text, || parse_spec(&text))?;
        prop_assert!(r.is_err(), "random bytes accepted: {text:?}");
        let text: String = jsonish.into_iter().collect();
        let r = no_panic("parse_spec", &text, || parse_spec(&text))?;
        prop_assert!(r.is_err(), "random text accepted: {text:?}");
    }
}

// ---------------------------------------------------------------------------------------
// ROM files
// ---------------------------------------------------------------------------------------

/// A small valid ROM: 4 sectors (harmonics 0, 1, 2 of order 7), 2 contact nodes, modal data.
fn small_rom() -> rubscan::model::rom::CyclicRom {
    use nalgebra::DMatrix;
    use rubscan::model::rom::*;
    let n = 7;
    let harmonics = (0..=2)
        .map(|k| {
            let mut re = DMatrix::identity(n, n) * (2.0 + k as f64);
            re[(0, 1)] = 0.3;
            re[(1, 0)] = 0.3;
            let mut im = DMatrix::zeros(n, n);
            if k == 1 {
                im[(0, 2)] = 0.1;
                im[(2, 0)] = -0.1;
            }
            let h = HermitianMatrix { re, im };
            HarmonicBlock {
                nodal_diameter: k,
                n_modes: 1,
                mass: h.clone(),
                stiffness: [
                    h,
                    HermitianMatrix::real(DMatrix::identity(n, n) * 0.5),
                    HermitianMatrix::real(DMatrix::zeros(n, n)),
                ],
            }
        })
        .collect();
    let node = |x: f64, row| ContactNode {
        position: [x, 0.0, 0.01],
        row,
        id: None,
    };
    CyclicRom {
        name: "fuzz".into(),
        component: Component::Impeller,
        n_sectors: 4,
        contact_nodes: vec![node(0.1, 0), node(0.11, 1)],
        harmonics,
        modal_data: vec![ModalData {
            nodal_diameter: 0,
            omega: vec![0.0, 100.0],
            frequencies: vec![vec![10.0, 20.0], vec![11.0, 21.0]],
            shapes_re: vec![vec![vec![1.0; 6], vec![2.0; 6]]; 2],
            shapes_im: vec![vec![vec![0.0; 6]; 2]; 2],
        }],
        damping: Damping::Rayleigh {
            alpha: 1.0,
            beta: 1e-6,
        },
        provenance: json!({"test": "readers_never_panic"}),
        recovery: Default::default(),
        blade_modes: Default::default(),
    }
}

/// The bytes of [`small_rom`] (`variant` 0), of it without modal speeds (1), or with speeds
/// but no frequency (2).
fn rom_bytes(variant: usize) -> Vec<u8> {
    let mut rom = small_rom();
    let md = &mut rom.modal_data[0];
    match variant % 3 {
        1 => {
            (md.omega, md.frequencies, md.shapes_re, md.shapes_im) =
                (vec![], vec![], vec![], vec![])
        }
        2 => {
            md.frequencies = vec![vec![]; 2];
            md.shapes_re = vec![vec![]; 2];
            md.shapes_im = vec![vec![]; 2];
        }
        _ => {}
    }
    rom_file::to_bytes(&rom).unwrap()
}

/// Loads `bytes` as a ROM without panicking; an accepted ROM must round-trip.
fn load_rom(bytes: &[u8]) -> Result<Result<(), String>, TestCaseError> {
    let path = Path::new("fuzz.rom");
    let r = no_panic("rom_file::from_bytes", &bytes.len(), || {
        rom_file::from_bytes(bytes, path)
    })?;
    match r {
        Ok(rom) => {
            let n_c = rom.contact_nodes.len();
            prop_assert!(
                rom.contact_nodes.iter().all(|c| c.row < n_c),
                "row out of range"
            );
            let again = rom_file::to_bytes(&rom).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let back = rom_file::from_bytes(&again, path).map_err(|e| {
                TestCaseError::fail(format!("accepted ROM does not round-trip: {e}"))
            })?;
            prop_assert_eq!(back, rom);
            Ok(Ok(()))
        }
        Err(e) => {
            let msg = e.to_string();
            prop_assert!(
                msg.starts_with("fuzz.rom:"),
                "error does not name the file: {msg}"
            );
            Ok(Err(msg))
        }
    }
}

proptest! {
    #![proptest_config(cases("rom_truncated"))]
    /// A ROM file cut anywhere is rejected.
    #[test]
    fn rom_truncated(variant in 0usize..3, cut in any::<usize>()) {
        let bytes = rom_bytes(variant);
        let cut = cut % bytes.len();
        prop_assert!(load_rom(&bytes[..cut])?.is_err(), "cut at {cut} accepted");
    }
}

proptest! {
    #![proptest_config(cases("rom_byte_flips"))]
    /// Random bytes written over a ROM file: never a panic; accepted only if it round-trips.
    #[test]
    fn rom_byte_flips(variant in 0usize..3, flips in prop::collection::vec(any::<(usize, u8)>(), 1..6)) {
        let _ = load_rom(&flip(&rom_bytes(variant), &flips))?;
    }
}

/// A JSON number as the header may hold it.
fn header_num() -> impl Strategy<Value = Value> {
    prop::sample::select(vec![
        json!(0),
        json!(1),
        json!(2),
        json!(3),
        json!(7),
        json!(49),
        json!(1u64 << 40),
        json!(u64::MAX / 8),
        json!(u64::MAX),
        json!(-1),
        json!(1.5),
    ])
}

/// One corruption of the safetensors header of a ROM file.
#[derive(Clone, Debug)]
enum HeaderMut {
    Dtype {
        at: usize,
        to: String,
    },
    Shape {
        at: usize,
        to: Vec<Value>,
    },
    Offsets {
        at: usize,
        to: [Value; 2],
    },
    Delete {
        at: usize,
    },
    /// Replaces a node of the `rom` metadata JSON.
    Meta {
        at: usize,
        with: Value,
    },
    /// Replaces a `__metadata__` entry (`format`, `format_version`, `rom`).
    Info {
        key: String,
        with: String,
    },
    /// Writes another header length.
    Length(u64),
}

fn header_mut() -> impl Strategy<Value = HeaderMut> {
    let dtype = prop::sample::select(vec!["F32", "F16", "BF16", "I64", "U8", "BOOL", "F8", "X"]);
    let meta_value = prop_oneof![
        3 => header_num(),
        1 => Just(json!([])),
        1 => Just(json!(null)),
        1 => Just(json!("x")),
        1 => Just(json!({})),
        1 => prop::collection::vec(header_num(), 0..4).prop_map(Value::Array),
    ];
    prop_oneof![
        1 => (any::<usize>(), dtype).prop_map(|(at, to)| HeaderMut::Dtype { at, to: to.into() }),
        1 => (any::<usize>(), prop::collection::vec(header_num(), 0..4))
            .prop_map(|(at, to)| HeaderMut::Shape { at, to }),
        1 => (any::<usize>(), header_num(), header_num())
            .prop_map(|(at, a, b)| HeaderMut::Offsets { at, to: [a, b] }),
        1 => any::<usize>().prop_map(|at| HeaderMut::Delete { at }),
        6 => (any::<usize>(), meta_value).prop_map(|(at, with)| HeaderMut::Meta { at, with }),
        1 => (
            prop::sample::select(vec!["format", "format_version", "rom"]),
            prop::sample::select(vec!["", "2", "rubscan-rom", "{}", "{\"name\":1}"])
        )
            .prop_map(|(k, w)| HeaderMut::Info { key: k.into(), with: w.into() }),
        1 => prop_oneof![Just(0u64), Just(1), Just(u64::MAX), Just(1 << 40), 0u64..20_000]
            .prop_map(HeaderMut::Length),
    ]
}

/// Applies `m` to the header of `bytes`; returns the new file, the header slot it wrote and
/// whether that slot now makes the file invalid by construction (dtype, shape, offsets, a
/// missing tensor, the length). A later change of the same slot supersedes the verdict: a
/// `format` blanked and then restored leaves a valid file.
fn corrupt_header(bytes: &[u8], m: &HeaderMut) -> (Vec<u8>, String, bool) {
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let mut header: Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    let data = &bytes[8 + n..];
    let mut names: Vec<String> = header
        .as_object()
        .unwrap()
        .keys()
        .filter(|k| *k != "__metadata__")
        .cloned()
        .collect();
    names.sort();
    let pick = |at: usize| names[at % names.len()].clone();
    let mut invalid = true;
    let mut length = None;
    let slot = match m {
        HeaderMut::Dtype { at, to } => {
            header[pick(*at)]["dtype"] = json!(to);
            format!("dtype {}", pick(*at))
        }
        HeaderMut::Shape { at, to } => {
            let t = &mut header[pick(*at)]["shape"];
            invalid = *t != json!(to);
            *t = json!(to);
            format!("shape {}", pick(*at))
        }
        HeaderMut::Offsets { at, to } => {
            let t = &mut header[pick(*at)]["data_offsets"];
            // An empty tensor may sit at any boundary: [a, a] for [b, b] can stay valid.
            let moved_empty = t[0] == t[1] && to[0] == to[1];
            invalid = *t != json!(to) && !moved_empty;
            *t = json!(to);
            format!("offsets {}", pick(*at))
        }
        HeaderMut::Delete { at } => {
            header.as_object_mut().unwrap().remove(&pick(*at));
            format!("tensor {}", pick(*at))
        }
        HeaderMut::Meta { at, with } => {
            let info = &mut header["__metadata__"]["rom"];
            let Some(Ok(mut meta)) = info.as_str().map(serde_json::from_str::<Value>) else {
                return (bytes.to_vec(), "rom".into(), false);
            };
            let all = paths(&meta);
            *node_mut(&mut meta, &all[at % all.len()]) = with.clone();
            *info = json!(meta.to_string());
            invalid = false;
            "rom".into()
        }
        HeaderMut::Info { key, with } => {
            header["__metadata__"][key.as_str()] = json!(with);
            // The format's own name and the current version leave the file as it was.
            let current = rubscan::model::rom::ROM_FORMAT_VERSION.to_string();
            invalid = !((key == "format" && with == "rubscan-rom")
                || (key == "format_version" && *with == current));
            key.clone()
        }
        HeaderMut::Length(l) => {
            length = Some(*l);
            invalid = *l != n as u64;
            "length".into()
        }
    };
    let text = header.to_string();
    let mut out = length.unwrap_or(text.len() as u64).to_le_bytes().to_vec();
    out.extend_from_slice(text.as_bytes());
    out.extend_from_slice(data);
    (out, slot, invalid)
}

proptest! {
    #![proptest_config(cases("rom_header_corrupted"))]
    /// Corrupted safetensors headers (dtypes, shapes, offsets, lengths, metadata): never a
    /// panic nor a huge allocation; `Err` for every structural corruption.
    #[test]
    fn rom_header_corrupted(variant in 0usize..3, muts in prop::collection::vec(header_mut(), 1..4)) {
        let mut bytes = rom_bytes(variant);
        let mut verdicts = std::collections::BTreeMap::new();
        for m in &muts {
            if bytes.len() < 8
                || u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize > bytes.len() - 8
                || serde_json::from_slice::<Value>(&bytes[8..8 + u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize]).is_err()
            {
                break;
            }
            let (b, slot, bad) = corrupt_header(&bytes, m);
            bytes = b;
            verdicts.insert(slot, bad);
        }
        let invalid = verdicts.values().any(|&bad| bad);
        let r = load_rom(&bytes)?;
        // A metadata change may leave a tensor unused, so that removing it is harmless.
        let meta_changed = muts.iter().any(|m| matches!(m, HeaderMut::Meta { .. }));
        if invalid && !meta_changed {
            prop_assert!(r.is_err(), "{muts:?} accepted");
        }
    }
}

// ---------------------------------------------------------------------------------------
// CalculiX and Matrix Market text files
// ---------------------------------------------------------------------------------------

/// Tokens written into a field of a text line.
fn token() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![
        "x",
        "-1",
        "0",
        "1",
        "2",
        "5",
        "1.5",
        "-2.5e3",
        "18446744073709551615",
        "18446744073709551616",
        "1000000000000",
        "99999999999999999999999",
        "NaN",
        "inf",
        "-inf",
        "1e400",
        "0x10",
        "",
        "1,2",
        "3.1",
        "TIP",
        "NALL",
        "GENERATE",
        "NSET=G",
        "*NSET",
        "\u{0}",
        "é",
    ])
}

/// One corruption of a text file: a field replaced, a line replaced or deleted, or a cut.
#[derive(Clone, Debug)]
enum TextMut {
    Field {
        line: usize,
        field: usize,
        tok: &'static str,
    },
    Line {
        line: usize,
        text: &'static str,
    },
    DeleteLine {
        line: usize,
    },
    Cut(usize),
}

fn text_mut(lines: Vec<&'static str>) -> impl Strategy<Value = TextMut> {
    prop_oneof![
        4 => (any::<usize>(), any::<usize>(), token())
            .prop_map(|(line, field, tok)| TextMut::Field { line, field, tok }),
        2 => (any::<usize>(), prop::sample::select(lines))
            .prop_map(|(line, text)| TextMut::Line { line, text }),
        1 => any::<usize>().prop_map(|line| TextMut::DeleteLine { line }),
        1 => any::<usize>().prop_map(TextMut::Cut),
    ]
}

/// Applies `m` to `text` (fields split at whitespace and commas, rejoined with `sep`).
fn apply_text(text: &str, m: &TextMut, sep: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let n = lines.len().max(1);
    match m {
        TextMut::Field { line, field, tok } => {
            if let Some(l) = lines.get_mut(line % n) {
                let mut f: Vec<String> = l
                    .split(|c: char| c == ',' || c.is_ascii_whitespace())
                    .filter(|s| !s.is_empty())
                    .map(String::from)
                    .collect();
                let i = field % (f.len() + 1);
                if i == f.len() {
                    f.push(tok.to_string());
                } else {
                    f[i] = tok.to_string();
                }
                *l = f.join(sep);
            }
        }
        TextMut::Line { line, text } => {
            if let Some(l) = lines.get_mut(line % n) {
                *l = text.to_string();
            }
        }
        TextMut::DeleteLine { line } => {
            if !lines.is_empty() {
                lines.remove(line % n);
            }
        }
        TextMut::Cut(c) => return cut_str(text, c % (text.len() + 1)).to_string(),
    }
    let mut out = lines.join("\n");
    out.push('\n');
    out
}

/// Whether the file `text` (after mutation) is the fixture cut short, mid-line: its last
/// line has text but no newline. A blank fragment carries no data, so the lines before it
/// are whole and the readers may accept them.
fn cut_mid_line(text: &str) -> bool {
    text.rsplit('\n')
        .next()
        .is_some_and(|last| !last.trim().is_empty())
}

const STI: &str = "1 1 4.0\n1 2 -1.0\n2 2 5.0\n2 3 2.0\n3 3 6.0\n3 4 0.5\n4 4 3.0\n";

/// Whether a mutated `.sti`/`.mtx` entry line must be rejected: an index not in 1..=n, a
/// value that is not a finite number, a missing or extra field.
fn bad_entry(line: &str, n: usize) -> bool {
    let f: Vec<&str> = line.split_ascii_whitespace().collect();
    if f.is_empty() {
        return false;
    }
    let idx = |s: &str| s.parse::<usize>().is_ok_and(|i| (1..=n).contains(&i));
    let val = |s: &str| s.parse::<f64>().is_ok_and(f64::is_finite);
    f.len() != 3 || !idx(f[0]) || !idx(f[1]) || !val(f[2])
}

proptest! {
    #![proptest_config(cases("sti_corrupted"))]
    /// CalculiX matrix storage with corrupted or cut lines: never a panic; `Err` for a
    /// malformed entry or a cut; an accepted matrix is n × n with at most 2 entries a line.
    #[test]
    fn sti_corrupted(muts in prop::collection::vec(text_mut(vec!["", "1 1", "1 1 1 1", "4 4 -3.0", "% c", "\u{feff}1 1 4.0"]), 1..4)) {
        let dir = scratch("sti");
        let mut text = STI.to_string();
        for m in &muts {
            text = apply_text(&text, m, " ");
        }
        let invalid = text.lines().any(|l| bad_entry(l, 4)) || cut_mid_line(&text);
        let p = write(&dir, "k.sti", text.as_bytes());
        let r = no_panic("read_matrix_storage", &text, || calculix::read_matrix_storage(&p, 4, 1e3))?;
        match r {
            Ok(a) => {
                prop_assert!(!invalid, "accepted:\n{text}");
                prop_assert_eq!((a.nrows(), a.ncols()), (4, 4));
                prop_assert!(a.compute_nnz() <= 2 * text.lines().count());
                prop_assert!(a.val().iter().all(|v| v.is_finite()));
            }
            Err(e) => prop_assert!(e.to_string().contains("k.sti"), "{e}"),
        }
    }
}

const DOF: &str = "3.1\n3.2\n3.3\n4.1\n4.2\n4.3\n10.2\n";

proptest! {
    #![proptest_config(cases("dof_corrupted"))]
    /// CalculiX `.dof` files with corrupted or cut lines: never a panic; an accepted map
    /// has at most one DOF a line, directions 0..3 and no repeats.
    #[test]
    fn dof_corrupted(muts in prop::collection::vec(text_mut(vec!["", "3.4", "3.0", ".1", "3.", "18446744073709551616.1", "5.1.1", "3 1"]), 1..4)) {
        let dir = scratch("dof");
        let mut text = DOF.to_string();
        for m in &muts {
            text = apply_text(&text, m, ".");
        }
        let p = write(&dir, "job.dof", text.as_bytes());
        let r = no_panic("read_dof_map", &text, || calculix::read_dof_map(&p))?;
        match r {
            Ok(d) => {
                prop_assert!(!cut_mid_line(&text), "cut file accepted:\n{text}");
                prop_assert!(!d.is_empty() && d.len() <= text.lines().count());
                prop_assert!(d.iter().all(|x| x.dir < 3));
                let set: std::collections::HashSet<_> = d.iter().collect();
                prop_assert_eq!(set.len(), d.len());
            }
            Err(e) => prop_assert!(e.to_string().contains("job.dof"), "{e}"),
        }
    }
}

const DECK: &str = "*HEADING\nfuzz deck\n*INCLUDE, INPUT=inc.msh\n** comment\n*NSET, NSET=TIP\n3, 1\n*NSET, NSET=GEN, GENERATE\n1, 4, 1\n*NSET, NSET=BOTH\nTIP, 2\n*BOUNDARY\n1, 1, ,\n";
const MESH: &str = "*NODE, NSET=NALL\n1, 0.0, 0.0, 0.0\n2, 1.0, 0.5, -20.0\n3, 2.0, 0.0, 0.0\n4, 3.0, 1.0, 1.0\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n";

fn deck_lines() -> Vec<&'static str> {
    vec![
        "*INCLUDE, INPUT=main.inp",
        "*INCLUDE, INPUT=inc.msh",
        "*INCLUDE, INPUT=missing.msh",
        "*INCLUDE",
        "*NSET, NSET=TIP",
        "*NSET, NSET=G, GENERATE",
        "*NSET",
        "*NODE",
        "*NODE, NSET=TIP",
        "TIP, TIP, TIP, TIP",
        "1, 18446744073709551615",
        "1, 1000000000000, 1",
        "5, 1, 1",
        "*",
        "**",
        ",,,",
        "1, 2, 3, 4, 5",
        "",
    ]
}

proptest! {
    #![proptest_config(cases("deck_corrupted"))]
    /// CalculiX decks (`.inp` including a `.msh`) with corrupted or cut lines: never a
    /// panic, a hang or a huge allocation; an accepted mesh has at most one node a line,
    /// finite coordinates, and no cut file.
    #[test]
    fn deck_corrupted(
        main_muts in prop::collection::vec(text_mut(deck_lines()), 0..3),
        mesh_muts in prop::collection::vec(text_mut(deck_lines()), 0..3),
    ) {
        let dir = scratch("deck");
        let (mut main, mut mesh) = (DECK.to_string(), MESH.to_string());
        for m in &main_muts {
            main = apply_text(&main, m, ", ");
        }
        for m in &mesh_muts {
            mesh = apply_text(&mesh, m, ", ");
        }
        write(&dir, "inc.msh", mesh.as_bytes());
        let p = write(&dir, "main.inp", main.as_bytes());
        let input = (&main, &mesh);
        let r = no_panic("read_calculix_mesh", &input, || calculix::read_calculix_mesh(&p))?;
        match r {
            Ok(m) => {
                // The mesh file is read only while the main deck still includes it.
                let mesh_read = main.lines().any(|l| {
                    let u = l.trim().to_ascii_uppercase();
                    u.starts_with("*INCLUDE") && u.contains("INPUT=INC.MSH")
                });
                prop_assert!(
                    !(cut_mid_line(&main) || (mesh_read && cut_mid_line(&mesh))),
                    "cut deck accepted: {input:?}"
                );
                prop_assert!(m.nodes.len() <= mesh.lines().count() + main.lines().count());
                prop_assert!(m.nodes.values().flatten().all(|x| x.is_finite()));
            }
            Err(e) => {
                let e = e.to_string();
                // Names a file of the deck's folder (`*INCLUDE, INPUT=` names the folder).
                prop_assert!(e.contains(dir.to_str().unwrap()), "{e}");
            }
        }
    }
}

const MTX_SYM: &str = "%%MatrixMarket matrix coordinate real symmetric\n% fuzz\n4 4 7\n1 1 4.0\n2 1 -1.0\n2 2 5.0\n3 2 2.0\n3 3 6.0\n4 3 0.5\n4 4 3.0\n";
const MTX_GEN: &str = "%%MatrixMarket matrix coordinate real general\n4 4 6\n1 1 4.0\n2 1 -1.0\n1 2 -1.0\n2 2 5.0\n3 3 6.0\n4 4 3.0\n";

fn mtx_lines() -> Vec<&'static str> {
    vec![
        "%%MatrixMarket matrix coordinate real symmetric",
        "%%MatrixMarket matrix coordinate real general",
        "%%MatrixMarket matrix coordinate complex symmetric",
        "%%MatrixMarket matrix array real general",
        "%%MatrixMarket matrix coordinate pattern symmetric",
        "%%MatrixMarket matrix coordinate integer skew-symmetric",
        "4 4 1000000000000",
        "4 4 18446744073709551615",
        "4 4 0",
        "1000000000000 1000000000000 7",
        "4 4",
        "% comment",
        "",
        "4 4 1.0",
        "1 1 1 1",
    ]
}

proptest! {
    #![proptest_config(cases("mtx_corrupted"))]
    /// Matrix Market files (symmetric and general) with corrupted or cut lines: never a
    /// panic nor a huge allocation (size line claiming 10¹² entries); `Err` for a cut file
    /// or a malformed entry; an accepted matrix is n × n, finite, at most 2 entries a line.
    #[test]
    fn mtx_corrupted(general in any::<bool>(), muts in prop::collection::vec(text_mut(mtx_lines()), 1..4)) {
        let dir = scratch("mtx");
        let mut text = if general { MTX_GEN } else { MTX_SYM }.to_string();
        for m in &muts {
            text = apply_text(&text, m, " ");
        }
        let entries = text
            .lines()
            .filter(|l| !l.trim().is_empty() && !l.trim().starts_with('%'))
            .skip(1);
        let invalid = entries.clone().any(|l| bad_entry(l, 4)) || cut_mid_line(&text);
        let p = write(&dir, "K.mtx", text.as_bytes());
        let r = no_panic("read_matrix_market", &text, || matrix_market::read_matrix_market(&p, 4, 1e3))?;
        match r {
            Ok(a) => {
                prop_assert!(!invalid, "accepted:\n{text}");
                prop_assert_eq!((a.nrows(), a.ncols()), (4, 4));
                prop_assert!(a.compute_nnz() <= 2 * entries.count());
                prop_assert!(a.val().iter().all(|v| v.is_finite()));
            }
            Err(e) => prop_assert!(e.to_string().contains("K.mtx"), "{e}"),
        }
    }
}

const MM_DOFS: &str = "# node direction\n3 1\n% x\n\n3 2\n10   3\n";
const NODES: &str = "# id x y z\n1 0 0 0\n2, 1.5, 0, -2e1\n10 3 1 1\n";

proptest! {
    #![proptest_config(cases("mm_dof_and_nodes_corrupted"))]
    /// Matrix Market DOF lists and node tables with corrupted or cut lines: never a panic;
    /// an accepted list or table is consistent with the line count, finite, and not cut.
    #[test]
    fn mm_dof_and_nodes_corrupted(
        dof_muts in prop::collection::vec(text_mut(vec!["3 4", "0 1", "3 1 2", "# c", ""]), 1..4),
        node_muts in prop::collection::vec(text_mut(vec!["1 0 0", "0 1 2 3", "1 0 0 0", "% c", ""]), 1..4),
    ) {
        let dir = scratch("mm-aux");
        let mut dofs = MM_DOFS.to_string();
        for m in &dof_muts {
            dofs = apply_text(&dofs, m, " ");
        }
        let p = write(&dir, "dofs.txt", dofs.as_bytes());
        match no_panic("read_dof_list", &dofs, || matrix_market::read_dof_list(&p))? {
            Ok(d) => {
                prop_assert!(!cut_mid_line(&dofs), "cut file accepted:\n{dofs}");
                prop_assert!(!d.is_empty() && d.len() <= dofs.lines().count());
                prop_assert!(d.iter().all(|x| x.dir < 3 && x.node > 0));
            }
            Err(e) => prop_assert!(e.to_string().contains("dofs.txt"), "{e}"),
        }
        let mut nodes = NODES.to_string();
        for m in &node_muts {
            nodes = apply_text(&nodes, m, " ");
        }
        let p = write(&dir, "nodes.txt", nodes.as_bytes());
        match no_panic("read_node_table", &nodes, || matrix_market::read_node_table(&p))? {
            Ok(t) => {
                prop_assert!(!cut_mid_line(&nodes), "cut file accepted:\n{nodes}");
                prop_assert!(t.len() <= nodes.lines().count());
                prop_assert!(t.values().flatten().all(|x| x.is_finite()));
            }
            Err(e) => prop_assert!(e.to_string().contains("nodes.txt"), "{e}"),
        }
    }
}

proptest! {
    #![proptest_config(cases("text_readers_random_bytes"))]
    /// Random bytes (and random number-like text) given to every text reader: never a
    /// panic; the matrix readers, which need every diagonal entry, reject it.
    #[test]
    fn text_readers_random_bytes(
        bytes in prop::collection::vec(any::<u8>(), 0..400),
        numeric in prop::collection::vec(
            prop::sample::select("0123456789 .,-e\n*%#NODESTGA=".chars().collect::<Vec<_>>()),
            0..400,
        ),
    ) {
        let dir = scratch("random");
        let numeric: String = numeric.into_iter().collect();
        for input in [&bytes[..], numeric.as_bytes()] {
            let p = write(&dir, "f.txt", input);
            let show = String::from_utf8_lossy(input);
            let r = no_panic("read_matrix_storage", &show, || calculix::read_matrix_storage(&p, 4, 1.0))?;
            prop_assert!(r.is_err(), "accepted:\n{show}");
            let r = no_panic("read_matrix_market", &show, || matrix_market::read_matrix_market(&p, 4, 1.0))?;
            prop_assert!(r.is_err(), "accepted:\n{show}");
            let _ = no_panic("read_dof_map", &show, || calculix::read_dof_map(&p))?;
            let _ = no_panic("read_dof_list", &show, || matrix_market::read_dof_list(&p))?;
            let _ = no_panic("read_node_table", &show, || matrix_market::read_node_table(&p))?;
            let deck = write(&dir, "f.inp", input);
            let _ = no_panic("read_calculix_mesh", &show, || calculix::read_calculix_mesh(&deck))?;
            let _ = no_panic("rom_file::from_bytes", &show, || rom_file::from_bytes(input, &p))?;
        }
    }
}

/// The ROM fixtures load and round-trip (modal data without speeds, or without frequencies,
/// included), and a header announcing a 2⁴⁰-value tensor in a small file is refused from
/// its size, before anything is allocated for it (see [`CappedAlloc`]).
#[test]
fn rom_fixtures_load_and_giant_tensors_are_refused() {
    for v in 0..3 {
        let r = rom_file::from_bytes(&rom_bytes(v), Path::new("x.rom"));
        assert!(r.is_ok(), "fixture {v}: {:?}", r.err());
    }
    let bytes = rom_bytes(0);
    for shape in [
        vec![json!(1u64 << 40)],
        vec![json!(1u64 << 40), json!(1u64 << 40)],
    ] {
        let m = HeaderMut::Shape { at: 0, to: shape };
        let (b, _, invalid) = corrupt_header(&bytes, &m);
        assert!(invalid);
        let e = rom_file::from_bytes(&b, Path::new("giant.rom"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("giant.rom:"), "{e}");
    }
}
