//! Geometry of a cyclic sector given by a user's mesh (issue 40): the angle between its two
//! cyclic faces, the pairing of each left-face node with the right-face node it turns into
//! (rotation by 2π/N about `+z`), and the mesh's free surface (where contact nodes must lie).
//!
//! The built-in meshes are made paired; an imported one is paired here, before any assembly,
//! so that a wrong face, a wrong sector count or a mislabelled node is named up front.

use std::collections::{HashMap, HashSet};
use std::f64::consts::TAU;

use crate::model::hex20::HEX20_NATURAL;

/// Why two cyclic faces do not pair.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FaceError {
    /// A face node set is empty.
    #[error("the {0} cyclic face has no nodes")]
    Empty(&'static str),
    /// No right-face node has the radius and axial position of a left-face node.
    #[error(
        "left-face node {node} (r = {r:e}, z = {z:e}) has no right-face node at the same radius \
         and axial position: the faces cannot be one sector apart"
    )]
    NoPartner {
        /// The node's id.
        node: usize,
        /// Its radius.
        r: f64,
        /// Its axial position.
        z: f64,
    },
    /// The faces are an angle apart that is not 2π/N for an integer N.
    #[error(
        "the cyclic faces are {degrees:.6}° apart, which does not divide 360° \
         (360° / {degrees:.6}° = {ratio:.6})"
    )]
    AngleDoesNotDivide {
        /// The measured angle, degrees.
        degrees: f64,
        /// 360° divided by it.
        ratio: f64,
    },
    /// The faces are 2π/M apart but the model says N sectors.
    #[error(
        "the cyclic faces are 360°/{measured} apart but the model declares N = {declared} sectors"
    )]
    SectorCount {
        /// The declared N.
        declared: usize,
        /// The count the faces' angle gives.
        measured: usize,
    },
    /// Some nodes of one face have no partner on the other after rotation by 2π/N.
    #[error(
        "{} node(s) do not match a node of the other face after rotation by 360°/{n_sectors} \
         about +z (within {tolerance:e} in the mesh's length unit): {}",
        nodes.len(),
        list(nodes)
    )]
    Unmatched {
        /// The unmatched node ids (left face first, then right face).
        nodes: Vec<usize>,
        /// The sector count used.
        n_sectors: usize,
        /// The distance tolerance.
        tolerance: f64,
    },
}

fn list(ids: &[usize]) -> String {
    let shown: Vec<String> = ids.iter().take(12).map(usize::to_string).collect();
    let more = if ids.len() > 12 { ", …" } else { "" };
    format!("{}{more}", shown.join(", "))
}

/// Relative tolerance of the face pairing, times the mesh's largest coordinate: mesh
/// generators print 7 to 16 significant digits.
pub const PAIRING_TOLERANCE: f64 = 1e-6;

/// A spatial hash of points with cells of the pairing tolerance.
struct PointGrid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<usize>>,
}

impl PointGrid {
    fn new(points: impl Iterator<Item = (usize, [f64; 3])>, cell: f64) -> Self {
        let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (i, p) in points {
            cells.entry(Self::key(p, cell)).or_default().push(i);
        }
        Self { cell, cells }
    }

    fn key(p: [f64; 3], cell: f64) -> [i64; 3] {
        p.map(|c| (c / cell).floor() as i64)
    }

    /// The stored points within `tol` of `p`, nearest first.
    fn near(&self, p: [f64; 3], tol: f64, coords: &dyn Fn(usize) -> [f64; 3]) -> Option<usize> {
        let k = Self::key(p, self.cell);
        let mut best: Option<(f64, usize)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(ids) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                        continue;
                    };
                    for &i in ids {
                        let d = crate::model::mesh::dist(p, coords(i));
                        if d <= tol && best.is_none_or(|(bd, _)| d < bd) {
                            best = Some((d, i));
                        }
                    }
                }
            }
        }
        best.map(|(_, i)| i)
    }
}

fn rotate(p: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]]
}

/// The pairing distance tolerance of a mesh: [`PAIRING_TOLERANCE`] times its largest
/// coordinate magnitude.
pub fn pairing_tolerance(nodes: &[[f64; 3]]) -> f64 {
    let scale = nodes
        .iter()
        .flat_map(|p| p.iter().map(|c| c.abs()))
        .fold(0.0f64, f64::max);
    PAIRING_TOLERANCE * scale.max(f64::MIN_POSITIVE)
}

/// The number of sectors the two faces imply: the angle from the left face's outermost node to
/// the nearest right-face node at its radius and axial position, which must be 2π/M.
/// `ids` gives each node's id for messages.
pub fn measured_sector_count(
    nodes: &[[f64; 3]],
    left: &[usize],
    right: &[usize],
    ids: &dyn Fn(usize) -> usize,
) -> Result<usize, FaceError> {
    let tol = pairing_tolerance(nodes);
    let radius = |p: [f64; 3]| p[0].hypot(p[1]);
    let &probe = left
        .iter()
        .max_by(|&&a, &&b| radius(nodes[a]).total_cmp(&radius(nodes[b])))
        .ok_or(FaceError::Empty("left"))?;
    if right.is_empty() {
        return Err(FaceError::Empty("right"));
    }
    let p = nodes[probe];
    let theta = |q: [f64; 3]| q[1].atan2(q[0]);
    let angle = right
        .iter()
        .map(|&j| nodes[j])
        .filter(|q| (radius(*q) - radius(p)).abs() <= tol && (q[2] - p[2]).abs() <= tol)
        .map(|q| (theta(q) - theta(p)).rem_euclid(TAU))
        .filter(|&a| a * radius(p) > tol)
        .min_by(f64::total_cmp)
        .ok_or(FaceError::NoPartner {
            node: ids(probe),
            r: radius(p),
            z: p[2],
        })?;
    let ratio = TAU / angle;
    let m = ratio.round();
    // An angle error of one tolerance at the probe's radius.
    let angle_tol = tol / radius(p);
    if m < 1.0 || (TAU / m - angle).abs() > angle_tol {
        return Err(FaceError::AngleDoesNotDivide {
            degrees: angle.to_degrees(),
            ratio,
        });
    }
    Ok(m as usize)
}

/// `right` reordered so that `right[i]` is `left[i]` turned by 2π/N about `+z`, within
/// [`pairing_tolerance`]; every unmatched node is named (by `ids`).
pub fn pair_faces(
    nodes: &[[f64; 3]],
    left: &[usize],
    right: &[usize],
    n_sectors: usize,
    ids: &dyn Fn(usize) -> usize,
) -> Result<Vec<usize>, FaceError> {
    let tol = pairing_tolerance(nodes);
    let grid = PointGrid::new(right.iter().map(|&j| (j, nodes[j])), 2.0 * tol);
    let angle = TAU / n_sectors as f64;
    let mut used = HashSet::new();
    let mut paired = Vec::with_capacity(left.len());
    let mut unmatched = Vec::new();
    for &l in left {
        match grid.near(rotate(nodes[l], angle), tol, &|j| nodes[j]) {
            Some(r) if used.insert(r) => paired.push(r),
            _ => unmatched.push(ids(l)),
        }
    }
    unmatched.extend(right.iter().filter(|r| !used.contains(r)).map(|&r| ids(r)));
    if !unmatched.is_empty() {
        return Err(FaceError::Unmatched {
            nodes: unmatched,
            n_sectors,
            tolerance: tol,
        });
    }
    Ok(paired)
}

/// The six faces of a Hex20 element as (natural axis, side): ξ, η or ζ = ±1.
const HEX20_FACES: [(usize, f64); 6] = [
    (0, -1.0),
    (0, 1.0),
    (1, -1.0),
    (1, 1.0),
    (2, -1.0),
    (2, 1.0),
];

/// Nodes on the free surface of a Hex20 mesh: the 8 nodes of every element face that no
/// other element shares, less the faces lying wholly on a cyclic face (`cyclic` holds both
/// faces' nodes), which another sector covers.
pub fn free_surface_nodes(elements: &[[usize; 20]], cyclic: &HashSet<usize>) -> HashSet<usize> {
    let face_nodes = |conn: &[usize; 20], (axis, side): (usize, f64)| -> Vec<usize> {
        (0..20)
            .filter(|&a| HEX20_NATURAL[a][axis] == side)
            .map(|a| conn[a])
            .collect()
    };
    let mut count: HashMap<Vec<usize>, (usize, Vec<usize>)> = HashMap::new();
    for conn in elements {
        for face in HEX20_FACES {
            let nodes = face_nodes(conn, face);
            let mut key = nodes.clone();
            key.sort_unstable();
            count.entry(key).or_insert((0, nodes)).0 += 1;
        }
    }
    count
        .into_values()
        .filter(|(n, nodes)| *n == 1 && !nodes.iter().all(|v| cyclic.contains(v)))
        .flat_map(|(_, nodes)| nodes)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::mesh::ImpellerGeometry;

    fn id(i: usize) -> usize {
        i + 1
    }

    #[test]
    fn the_built_in_impeller_faces_pair_as_the_mesher_made_them() {
        let mesh = ImpellerGeometry::default().build().unwrap();
        let n =
            measured_sector_count(&mesh.nodes, &mesh.left_nodes, &mesh.right_nodes, &id).unwrap();
        assert_eq!(n, mesh.n_sectors);
        let mut shuffled = mesh.right_nodes.clone();
        shuffled.reverse();
        let paired = pair_faces(&mesh.nodes, &mesh.left_nodes, &shuffled, n, &id).unwrap();
        assert_eq!(paired, mesh.right_nodes);
    }

    #[test]
    fn a_wrong_count_or_a_moved_node_is_named() {
        let mut mesh = ImpellerGeometry::default().build().unwrap();
        let n = mesh.n_sectors;
        let e = pair_faces(&mesh.nodes, &mesh.left_nodes, &mesh.right_nodes, n + 1, &id);
        assert!(
            matches!(e, Err(FaceError::Unmatched { ref nodes, .. }) if nodes.len() == 2 * mesh.left_nodes.len())
        );
        let moved = mesh.right_nodes[3];
        mesh.nodes[moved][2] += 1e-4;
        let e = pair_faces(&mesh.nodes, &mesh.left_nodes, &mesh.right_nodes, n, &id).unwrap_err();
        let FaceError::Unmatched { nodes, .. } = &e else {
            panic!("{e}");
        };
        assert_eq!(nodes, &[id(mesh.left_nodes[3]), id(moved)]);
        assert!(e.to_string().contains(&id(moved).to_string()), "{e}");
    }

    #[test]
    fn faces_turned_by_an_angle_that_does_not_divide_a_turn_are_refused() {
        let mut mesh = ImpellerGeometry::default().build().unwrap();
        let alpha = TAU / mesh.n_sectors as f64;
        for &r in &mesh.right_nodes {
            mesh.nodes[r] = rotate(mesh.nodes[r], 0.1 * alpha);
        }
        let e = measured_sector_count(&mesh.nodes, &mesh.left_nodes, &mesh.right_nodes, &id)
            .unwrap_err();
        let FaceError::AngleDoesNotDivide { degrees, .. } = e else {
            panic!("{e}");
        };
        assert!(
            (degrees - 1.1 * alpha.to_degrees()).abs() < 1e-6,
            "{degrees}"
        );
    }

    /// On a 3 × 3 × 3 block of the unit cube the free surface is the cube's faces; with the
    /// x = 0 face declared cyclic, its nodes that lie on no other face drop out.
    #[test]
    fn free_surface_of_a_block_is_its_outer_faces_less_the_cyclic_ones() {
        let (mesh, _) = crate::model::fe::tests::block_mesh(
            [3, 3, 3],
            crate::model::mesh::Material::default(),
            |p| p,
        );
        let on = |i: usize, axis: usize, v: f64| (mesh.nodes[i][axis] - v).abs() < 1e-12;
        let on_plane = |i: usize, skip: Option<(usize, f64)>| {
            (0..3).any(|a| {
                [0.0, 1.0]
                    .into_iter()
                    .any(|v| Some((a, v)) != skip && on(i, a, v))
            })
        };
        let n = mesh.nodes.len();
        let outer: HashSet<usize> = (0..n).filter(|&i| on_plane(i, None)).collect();
        assert!(outer.len() < n, "the block has interior nodes");
        assert_eq!(free_surface_nodes(&mesh.elements, &HashSet::new()), outer);
        let x0: HashSet<usize> = (0..n).filter(|&i| on(i, 0, 0.0)).collect();
        let expect: HashSet<usize> = (0..n).filter(|&i| on_plane(i, Some((0, 0.0)))).collect();
        assert!(expect.len() < outer.len());
        assert_eq!(free_surface_nodes(&mesh.elements, &x0), expect);
    }
}
