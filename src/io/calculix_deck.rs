//! The CalculiX input deck reader (DESIGN §2.4): nodes, node sets, elements, the material, the
//! clamps (`*BOUNDARY`) and the cyclic symmetry cards, following `*INCLUDE`s.
//!
//! Read: `*NODE[, NSET=name]` blocks `id, x, y, z`; `*NSET, NSET=name[, GENERATE]` blocks (ids
//! or names of earlier sets, or `first, last[, step]`); `*INCLUDE, INPUT=file` (resolved
//! relative to the including file's folder); `*ELEMENT, TYPE=t` blocks (an id and node ids, a
//! line ending with a comma continued on the next); `*MATERIAL, NAME=`, `*ELASTIC` and
//! `*DENSITY`; `*BOUNDARY` data lines; `*SURFACE, NAME=, TYPE=NODE`; `*TIE, NAME=, CYCLIC
//! SYMMETRY` and `*CYCLIC SYMMETRY MODEL, N=, TIE=` with its axis line. Other keywords and
//! their data are skipped. Keywords and set names are case-insensitive; `**` starts a comment
//! line. Every error names the file and the 1-based line.

use crate::io::text_lines::{ImportError, Line, LineReader, parse_value};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The model data of a CalculiX input deck, in the file's units.
#[derive(Clone, Debug, Default)]
pub struct CalculixMesh {
    /// Node id → coordinates in the file's length unit.
    pub nodes: HashMap<usize, [f64; 3]>,
    /// Upper-cased set name → node ids in file order.
    pub node_sets: HashMap<String, Vec<usize>>,
    /// Elements in file order.
    pub elements: Vec<DeckElement>,
    /// Materials in file order.
    pub materials: Vec<DeckMaterial>,
    /// `*BOUNDARY` data lines in file order.
    pub boundaries: Vec<DeckBoundary>,
    /// Upper-cased name → node set names and node ids of each `*SURFACE, TYPE=NODE`.
    pub node_surfaces: HashMap<String, Vec<String>>,
    /// Upper-cased name → (slave, master) surface of each `*TIE, CYCLIC SYMMETRY`.
    pub cyclic_ties: HashMap<String, (String, String)>,
    /// The `*CYCLIC SYMMETRY MODEL` cards.
    pub cyclic_models: Vec<DeckCyclicModel>,
}

/// One element of a deck: its id, its upper-cased `TYPE` and its node ids in the order given.
#[derive(Clone, Debug, PartialEq)]
pub struct DeckElement {
    /// Element id.
    pub id: usize,
    /// Element type (`C3D20`, …), upper case.
    pub kind: String,
    /// Node ids.
    pub nodes: Vec<usize>,
}

/// A `*MATERIAL` with the data rubscan uses: the first line of `*ELASTIC` and `*DENSITY`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeckMaterial {
    /// Name, upper case.
    pub name: String,
    /// `*ELASTIC`'s `TYPE` (upper case, `ISO` when absent) and its first data line.
    pub elastic: Option<(String, Vec<f64>)>,
    /// `*DENSITY`'s first value (file units).
    pub density: Option<f64>,
}

/// One `*BOUNDARY` data line `node or set, first DOF[, last DOF[, value]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct DeckBoundary {
    /// A node id or an (upper-cased) node set name.
    pub target: String,
    /// First and last DOF fixed (1-based; `last = first` when not given).
    pub dofs: (usize, usize),
    /// Imposed value (0 when not given).
    pub value: f64,
    /// The file (the deck or one it includes) and the line of the data line, for messages.
    pub at: (PathBuf, usize),
}

/// A `*CYCLIC SYMMETRY MODEL` card: the number of sectors, its tie and the axis a → b.
#[derive(Clone, Debug, PartialEq)]
pub struct DeckCyclicModel {
    /// `N=`, the number of sectors of 360°.
    pub n_sectors: usize,
    /// `TIE=`, upper case.
    pub tie: String,
    /// Two points of the symmetry axis (file length units), a then b.
    pub axis: Option<[[f64; 3]; 2]>,
}

/// Which block the deck reader is in.
enum Block {
    Node(Option<String>),
    Nset {
        name: String,
        generate: bool,
    },
    /// `*ELEMENT` data; `open` is the element whose node list continues on the next line.
    Element {
        kind: String,
        open: bool,
    },
    Elastic,
    Density,
    Boundary,
    NodeSurface(String),
    Tie(String),
    CyclicModel,
    Other,
}

/// Most node ids all the node sets of a deck may hold together (repeats included), a bound
/// on the memory a deck can claim: a set naming itself doubles on every line and a
/// `GENERATE` range may announce 10¹⁹ ids. 2²⁴ ≈ 16.8 M is far above real models.
pub const MAX_SET_IDS: usize = 1 << 24;

/// Most files one deck may read through `*INCLUDE`s (the same file included repeatedly
/// counts each time), a bound on the work of includes fanning out.
pub const MAX_INCLUDES: usize = 1000;

/// State of a deck read, across its `*INCLUDE`s.
struct Deck<'m> {
    mesh: &'m mut CalculixMesh,
    /// The files being read, outermost first (canonical paths when they resolve).
    stack: Vec<PathBuf>,
    /// Files read so far.
    files: usize,
    /// Node ids held by all node sets.
    set_ids: usize,
}

/// Reads `*NODE` and `*NSET` data from a CalculiX deck, following `*INCLUDE`s (at most 16
/// deep and [`MAX_INCLUDES`] files, no file including itself; node sets hold at most
/// [`MAX_SET_IDS`] ids in all).
pub fn read_calculix_mesh(path: &Path) -> Result<CalculixMesh, ImportError> {
    let mut mesh = CalculixMesh::default();
    let mut deck = Deck {
        mesh: &mut mesh,
        stack: Vec::new(),
        files: 0,
        set_ids: 0,
    };
    read_deck(path, &mut deck)?;
    Ok(mesh)
}

/// `KEY=VALUE` parameter of a keyword line (key compared case-insensitively).
fn keyword_param(parts: &[&str], key: &str) -> Option<String> {
    parts.iter().find_map(|p| {
        let (k, v) = p.split_once('=')?;
        k.trim()
            .eq_ignore_ascii_case(key)
            .then(|| v.trim().to_string())
    })
}

fn read_deck(path: &Path, deck: &mut Deck<'_>) -> Result<(), ImportError> {
    if deck.stack.len() > 16 {
        return Err(ImportError::file(path, "*INCLUDE nested more than 16 deep"));
    }
    deck.files += 1;
    if deck.files > MAX_INCLUDES {
        return Err(ImportError::file(
            path,
            format!("the deck reads more than {MAX_INCLUDES} files through *INCLUDE"),
        ));
    }
    let mut rd = LineReader::open(path)?;
    let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if deck.stack.contains(&key) {
        return Err(ImportError::file(
            path,
            "*INCLUDE cycle: this file includes itself (directly or through other files)",
        ));
    }
    deck.stack.push(key);
    let mut block = Block::Other;
    while let Some(l) = rd.next_line()? {
        let t = l.text.trim();
        if t.is_empty() || t.starts_with("**") {
            continue;
        }
        if let Some(kw) = t.strip_prefix('*') {
            block = keyword(path, &l, kw, deck)?;
            continue;
        }
        let fields: Vec<&str> = t
            .split(',')
            .map(str::trim)
            .filter(|f| !f.is_empty())
            .collect();
        match &block {
            Block::Node(set) => node_line(&l, t, &fields, set.as_deref(), deck.mesh)?,
            Block::Nset { name, generate } => {
                let budget = MAX_SET_IDS - deck.set_ids;
                let add = nset_line(&l, t, &fields, *generate, &deck.mesh.node_sets, budget)?;
                deck.set_ids += add.len();
                deck.mesh
                    .node_sets
                    .entry(name.clone())
                    .or_default()
                    .extend(add);
            }
            Block::Element { kind, open } => {
                let open = element_line(&l, &fields, kind, *open, deck.mesh)?;
                block = Block::Element {
                    kind: kind.clone(),
                    open,
                };
            }
            Block::Elastic | Block::Density | Block::Boundary | Block::CyclicModel => {
                data_line(&l, &fields, &block, deck.mesh)?;
                // Only the first data line counts (temperature tables are not supported).
                if !matches!(block, Block::Boundary) {
                    block = Block::Other;
                }
            }
            Block::NodeSurface(name) => deck
                .mesh
                .node_surfaces
                .entry(name.clone())
                .or_default()
                .extend(fields.iter().map(|f| f.to_uppercase())),
            Block::Tie(name) => {
                let [slave, master] = fields[..] else {
                    return Err(l.err(format!(
                        "expected 'slave surface, master surface', found '{t}'"
                    )));
                };
                deck.mesh
                    .cyclic_ties
                    .insert(name.clone(), (slave.to_uppercase(), master.to_uppercase()));
                block = Block::Other;
            }
            Block::Other => {}
        }
    }
    deck.stack.pop();
    Ok(())
}

/// The block a keyword line `*kw` (without its star) opens; reads an `*INCLUDE`d file.
fn keyword(path: &Path, l: &Line<'_>, kw: &str, deck: &mut Deck<'_>) -> Result<Block, ImportError> {
    let parts: Vec<&str> = kw.split(',').collect();
    let name = parts[0].trim().to_ascii_uppercase();
    Ok(match name.as_str() {
        "NODE" => Block::Node(keyword_param(&parts, "NSET").map(|s| s.to_uppercase())),
        "NSET" => {
            let Some(set) = keyword_param(&parts, "NSET") else {
                return Err(l.err("*NSET without NSET=name"));
            };
            let generate = parts[1..]
                .iter()
                .any(|p| p.trim().eq_ignore_ascii_case("GENERATE"));
            let set = set.to_uppercase();
            deck.mesh.node_sets.entry(set.clone()).or_default();
            Block::Nset {
                name: set,
                generate,
            }
        }
        "INCLUDE" => {
            let Some(file) = keyword_param(&parts, "INPUT") else {
                return Err(l.err("*INCLUDE without INPUT=file"));
            };
            let file = file.trim_matches('"');
            let inc = path.parent().unwrap_or(Path::new(".")).join(file);
            read_deck(&inc, deck)?;
            Block::Other
        }
        "ELEMENT" => Block::Element {
            kind: keyword_param(&parts, "TYPE")
                .ok_or_else(|| l.err("*ELEMENT without TYPE=type"))?
                .to_uppercase(),
            open: false,
        },
        "MATERIAL" => {
            let name = keyword_param(&parts, "NAME")
                .ok_or_else(|| l.err("*MATERIAL without NAME=name"))?;
            deck.mesh.materials.push(DeckMaterial {
                name: name.to_uppercase(),
                ..Default::default()
            });
            Block::Other
        }
        "ELASTIC" | "DENSITY" => {
            let Some(material) = deck.mesh.materials.last_mut() else {
                return Err(l.err(format!("*{name} outside a *MATERIAL")));
            };
            if name == "DENSITY" {
                Block::Density
            } else {
                let kind = keyword_param(&parts, "TYPE").map_or("ISO".into(), |t| t.to_uppercase());
                material.elastic = Some((kind, Vec::new()));
                Block::Elastic
            }
        }
        "BOUNDARY" => Block::Boundary,
        "SURFACE" => match keyword_param(&parts, "TYPE").map(|t| t.to_uppercase()) {
            Some(t) if t == "NODE" => Block::NodeSurface(
                keyword_param(&parts, "NAME")
                    .ok_or_else(|| l.err("*SURFACE without NAME=name"))?
                    .to_uppercase(),
            ),
            _ => Block::Other,
        },
        "TIE"
            if parts[1..]
                .iter()
                .any(|p| p.trim().eq_ignore_ascii_case("CYCLIC SYMMETRY")) =>
        {
            Block::Tie(
                keyword_param(&parts, "NAME")
                    .ok_or_else(|| l.err("*TIE without NAME=name"))?
                    .to_uppercase(),
            )
        }
        "CYCLIC SYMMETRY MODEL" => {
            let n = keyword_param(&parts, "N")
                .and_then(|n| n.parse::<usize>().ok())
                .filter(|&n| n >= 1)
                .ok_or_else(|| l.err("*CYCLIC SYMMETRY MODEL needs N=<number of sectors ≥ 1>"))?;
            let tie = keyword_param(&parts, "TIE")
                .ok_or_else(|| l.err("*CYCLIC SYMMETRY MODEL without TIE=name"))?;
            deck.mesh.cyclic_models.push(DeckCyclicModel {
                n_sectors: n,
                tie: tie.to_uppercase(),
                axis: None,
            });
            Block::CyclicModel
        }
        _ => Block::Other,
    })
}

/// One data line of an `*ELEMENT` block; returns whether the element's node list goes on
/// (the line ends with a comma).
fn element_line(
    l: &Line<'_>,
    fields: &[&str],
    kind: &str,
    open: bool,
    mesh: &mut CalculixMesh,
) -> Result<bool, ImportError> {
    let ids = fields
        .iter()
        .map(|f| f.parse::<usize>().ok().filter(|&id| id > 0))
        .collect::<Option<Vec<usize>>>()
        .ok_or_else(|| {
            l.err(format!(
                "*ELEMENT, TYPE={kind}: expected positive integer ids, found '{}'",
                l.text.trim()
            ))
        })?;
    if open {
        let element = mesh.elements.last_mut().expect("an open element exists");
        element.nodes.extend(ids);
    } else {
        let Some((&id, nodes)) = ids.split_first() else {
            return Err(l.err("empty element line"));
        };
        mesh.elements.push(DeckElement {
            id,
            kind: kind.to_string(),
            nodes: nodes.to_vec(),
        });
    }
    Ok(l.text.trim_end().ends_with(','))
}

/// The first data line of `*ELASTIC`, `*DENSITY`, `*CYCLIC SYMMETRY MODEL` or a `*BOUNDARY`
/// data line, stored in `mesh`.
fn data_line(
    l: &Line<'_>,
    fields: &[&str],
    block: &Block,
    mesh: &mut CalculixMesh,
) -> Result<(), ImportError> {
    let numbers = |from: usize| -> Result<Vec<f64>, ImportError> {
        fields[from..]
            .iter()
            .map(|f| parse_value(Some(f), "value").map_err(|e| l.err(e)))
            .collect()
    };
    match block {
        Block::Elastic => {
            let material = mesh
                .materials
                .last_mut()
                .expect("*ELASTIC is in a material");
            if let Some((_, data)) = &mut material.elastic {
                *data = numbers(0)?;
            }
        }
        Block::Density => {
            let material = mesh
                .materials
                .last_mut()
                .expect("*DENSITY is in a material");
            material.density = numbers(0)?.first().copied();
        }
        Block::CyclicModel => {
            let v = numbers(0)?;
            let [ax, ay, az, bx, by, bz] = v[..] else {
                return Err(
                    l.err("*CYCLIC SYMMETRY MODEL: expected the axis 'ax, ay, az, bx, by, bz'")
                );
            };
            let card = mesh.cyclic_models.last_mut().expect("the card was pushed");
            card.axis = Some([[ax, ay, az], [bx, by, bz]]);
        }
        Block::Boundary => {
            let bad = || {
                l.err(format!(
                    "*BOUNDARY: expected 'node or set, first DOF[, last DOF[, value]]', found '{}'",
                    l.text.trim()
                ))
            };
            let (target, rest) = fields.split_first().ok_or_else(bad)?;
            let dof = |i: usize| {
                rest.get(i)
                    .map(|f| f.parse::<usize>().map_err(|_| bad()))
                    .transpose()
            };
            let first = dof(0)?.ok_or_else(bad)?;
            let last = dof(1)?.unwrap_or(first);
            let value = match rest.get(2) {
                Some(f) => parse_value(Some(f), "value").map_err(|e| l.err(e))?,
                None => 0.0,
            };
            mesh.boundaries.push(DeckBoundary {
                target: target.to_uppercase(),
                dofs: (first, last),
                value,
                at: (l.path.to_path_buf(), l.no),
            });
        }
        _ => unreachable!("data_line is called for data blocks only"),
    }
    Ok(())
}

/// One `id, x[, y[, z]]` line of a `*NODE` block (missing coordinates are 0), added to
/// `mesh` and to the node set `set`.
fn node_line(
    l: &Line<'_>,
    t: &str,
    fields: &[&str],
    set: Option<&str>,
    mesh: &mut CalculixMesh,
) -> Result<(), ImportError> {
    let id: usize = fields
        .first()
        .and_then(|f| f.parse().ok())
        .filter(|&id| id > 0)
        .ok_or_else(|| l.err(format!("expected 'id, x, y, z', found '{t}'")))?;
    let mut x = [0.0; 3];
    if fields.len() > 4 {
        return Err(l.err(format!("node {id}: more than 3 coordinates")));
    }
    for (k, f) in fields[1..].iter().enumerate() {
        x[k] = parse_value(Some(f), "coordinate").map_err(|e| l.err(e))?;
    }
    if mesh.nodes.insert(id, x).is_some() {
        return Err(l.err(format!("node {id} defined twice")));
    }
    if let Some(s) = set {
        mesh.node_sets.entry(s.to_string()).or_default().push(id);
    }
    Ok(())
}

/// The node ids of one data line of a `*NSET` block: ids and names of earlier sets, or
/// `first, last[, step]` with `GENERATE`; more than `budget` ids is an error.
fn nset_line(
    l: &Line<'_>,
    t: &str,
    fields: &[&str],
    generate: bool,
    sets: &HashMap<String, Vec<usize>>,
    budget: usize,
) -> Result<Vec<usize>, ImportError> {
    let too_many = || {
        l.err(format!(
            "the node sets would hold more than {MAX_SET_IDS} node ids \
             (a set including itself, or a huge GENERATE range?)"
        ))
    };
    let mut add = Vec::new();
    if generate {
        let bad = || l.err(format!("expected 'first, last[, step]', found '{t}'"));
        let nums: Vec<usize> = fields
            .iter()
            .map(|f| f.parse::<usize>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad())?;
        let (a, b, s) = match nums[..] {
            [a, b] => (a, b, 1),
            [a, b, s] => (a, b, s),
            _ => return Err(bad()),
        };
        if s == 0 || b < a {
            return Err(l.err(format!("invalid GENERATE range '{t}'")));
        }
        if (b - a) / s >= budget {
            return Err(too_many());
        }
        add.extend((a..=b).step_by(s));
        return Ok(add);
    }
    for f in fields {
        match f.parse::<usize>() {
            Ok(id) => add.push(id),
            Err(_) => {
                let other = sets.get(&f.to_uppercase()).ok_or_else(|| {
                    l.err(format!("'{f}' is neither a node id nor a known node set"))
                })?;
                if add.len() + other.len() > budget {
                    return Err(too_many());
                }
                add.extend_from_slice(other);
            }
        }
    }
    if add.len() > budget {
        return Err(too_many());
    }
    Ok(add)
}
