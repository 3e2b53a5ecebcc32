//! The source tree follows the pipeline (README, "Layout"): each stage folder of `src/` imports
//! only the stages before it, and no two files import each other, directly or in a circle.
//! Imports are read from the code (`crate::` and `super::` paths, `use` groups included; comment
//! lines are skipped, so doc links do not count), test modules included.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The stages in pipeline order; a stage may import the ones before it.
const STAGES: [&str; 8] = [
    "simd", "model", "contact", "dynamics", "analysis", "io", "sweep", "app",
];

/// The dev-only fixtures (synthetic models, seeded generator): any stage's tests may use them,
/// and they import only [`FIXTURES_USE`].
const FIXTURES: &str = "fixtures";
const FIXTURES_USE: [&str; 1] = ["model"];

/// Module path (`dynamics::modal`) → source text, for every file under `src/` but the crate
/// roots.
fn modules(src: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap().with_extension("");
                let mut name = rel.to_string_lossy().replace('/', "::");
                if let Some(parent) = name.strip_suffix("::mod") {
                    name = parent.to_string();
                }
                if name != "lib" && name != "main" {
                    out.insert(name, std::fs::read_to_string(&path).unwrap());
                }
            }
        }
    }
    out
}

/// The paths named after `prefix` in `text`, with `use` groups (`a::{b, c::{d}}`) expanded.
fn paths_after(text: &str, prefix: &str) -> Vec<String> {
    fn expand(head: &str, rest: &str, out: &mut Vec<String>) {
        // `rest` starts right after "head::{".
        let mut depth = 0;
        let mut item = String::new();
        for ch in rest.chars() {
            match ch {
                '{' => depth += 1,
                '}' if depth == 0 => break,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    push_item(head, &item, out);
                    item.clear();
                    continue;
                }
                _ => {}
            }
            item.push(ch);
        }
        push_item(head, &item, out);
    }
    fn push_item(head: &str, item: &str, out: &mut Vec<String>) {
        let item = item.trim();
        let join = |tail: &str| match head {
            "" => tail.to_string(),
            _ => format!("{head}::{tail}"),
        };
        match item.find("::{") {
            Some(i) => expand(&join(&item[..i]), &item[i + 3..], out),
            None => out.push(join(item)),
        }
    }
    let mut out = Vec::new();
    for (at, _) in text.match_indices(prefix) {
        let rest = &text[at + prefix.len()..];
        let end = rest
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
            .unwrap_or(rest.len());
        let path = rest[..end].trim_end_matches(':');
        if rest[end..].starts_with('{') {
            expand(path, &rest[end + 1..], &mut out);
        } else {
            out.push(path.to_string());
        }
    }
    out
}

/// The modules of `known` that `name`'s source imports (the longest known prefix of each path).
fn imports(name: &str, text: &str, known: &BTreeMap<String, String>) -> BTreeSet<String> {
    let code: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let parent = name.rsplit_once("::").map_or("", |(p, _)| p);
    let mut paths = paths_after(&code, "crate::");
    for p in paths_after(&code, "super::") {
        paths.push(if parent.is_empty() {
            p
        } else {
            format!("{parent}::{p}")
        });
    }
    let mut out = BTreeSet::new();
    for p in paths {
        let segs: Vec<&str> = p.split("::").filter(|s| !s.is_empty()).collect();
        if let Some(m) = (1..=segs.len())
            .rev()
            .map(|k| segs[..k].join("::"))
            .find(|m| known.contains_key(m))
        {
            // A module and its own ancestors (re-exports, `super::*` in tests) are one unit.
            let related = |a: &str, b: &str| a.starts_with(&format!("{b}::"));
            if m != name && !related(name, &m) && !related(&m, name) {
                out.insert(m);
            }
        }
    }
    out
}

/// A cycle of the graph, if any (depth-first search).
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        v: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(v.to_string(), 1);
        stack.push(v.to_string());
        for w in graph.get(v).into_iter().flatten() {
            match state.get(w.as_str()) {
                Some(1) => {
                    let start = stack.iter().position(|s| s == w).unwrap();
                    return Some(stack[start..].to_vec());
                }
                Some(_) => {}
                None => {
                    if let Some(c) = visit(w, graph, state, stack) {
                        return Some(c);
                    }
                }
            }
        }
        stack.pop();
        state.insert(v.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in graph.keys() {
        if !state.contains_key(v.as_str())
            && let Some(c) = visit(v, graph, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

fn import_graph() -> BTreeMap<String, BTreeSet<String>> {
    let known = modules(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    known
        .iter()
        .map(|(name, text)| (name.clone(), imports(name, text, &known)))
        .collect()
}

#[test]
fn no_two_files_import_each_other_even_in_a_circle() {
    let graph = import_graph();
    assert!(graph.len() > 40, "only {} modules found", graph.len());
    assert_eq!(find_cycle(&graph), None);
}

#[test]
fn each_stage_imports_only_the_stages_before_it() {
    let stage = |m: &str| m.split("::").next().unwrap().to_string();
    let rank = |s: &str| STAGES.iter().position(|&t| t == s);
    let mut wrong = Vec::new();
    for (from, tos) in import_graph() {
        for to in tos {
            let (sf, st) = (stage(&from), stage(&to));
            let allowed = if sf == FIXTURES {
                FIXTURES_USE.contains(&st.as_str())
            } else {
                let r = rank(&sf).unwrap_or_else(|| panic!("{from}: stage not in STAGES"));
                st == sf || st == FIXTURES || rank(&st).is_some_and(|t| t < r)
            };
            if !allowed {
                wrong.push(format!("{from} imports {to}"));
            }
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

#[test]
fn the_import_reader_expands_groups_and_skips_comments() {
    let text = "use crate::{a::b, c::{d, e::f}};\n// crate::z\nlet x = super::g::h();";
    assert_eq!(
        paths_after(text, "crate::"),
        ["a::b", "c::d", "c::e::f", "z"]
    );
    let known: BTreeMap<String, String> = ["a", "c::e", "c", "m::g", "z"]
        .iter()
        .map(|k| (k.to_string(), String::new()))
        .collect();
    let got = imports("m::n", text, &known);
    let want: BTreeSet<String> = ["a", "c", "c::e", "m::g"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(got, want);
}
