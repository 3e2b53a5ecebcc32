//! 20-node serendipity hexahedron (Hex20), linear isotropic elasticity, and the
//! sparse sector matrices K0, M and the centrifugal stiffness K1 (DESIGN.md §2.1, §2.3).
//!
//! All element quantities use 3×3×3 Gauss quadrature. Element matrices are
//! 60×60, row-major, DOF `3*a + dir` for local node `a` (0..20) and direction
//! `dir` (0, 1, 2 = x, y, z). Units: SI.
//!
//! The speed dependence of the impeller stiffness is the linear-prestress form
//! `K(Ω) = K0 + Ω² K1` (K2 = 0, DESIGN.md §2.1), with
//! `K1 = K_σ(σ₁) − M_s`: `σ₁` is the stress of the static centrifugal solution
//! per unit Ω² (`K0 u₁ = f₁`, nodal diameter 0), `K_σ` the geometric
//! (initial-stress) stiffness and `M_s` the spin-softening matrix.

#![allow(clippy::needless_range_loop)] // index loops mirror the tensor notation

use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use thiserror::Error;

use super::hex20::hex20_shape;
use super::mesh::{Material, MeshError, SectorMesh};

/// Errors of element computations and sector assembly.
#[derive(Debug, Error)]
pub enum FeError {
    /// The mesh failed its validation.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// An element is inverted or degenerate at a Gauss point.
    #[error("element {element}: Jacobian determinant {det:e} <= 0 at Gauss point {point}")]
    BadJacobian {
        /// Element index in the mesh.
        element: usize,
        /// Gauss point index, `0..27`.
        point: usize,
        /// Jacobian determinant there (m³ per unit natural volume).
        det: f64,
    },

    /// The centrifugal static problem cannot be solved.
    #[error("centrifugal prestress: {0}")]
    Prestress(String),
    /// Sparse matrix creation failed (should not happen for a valid mesh).
    #[error("sparse assembly: {0}")]
    Sparse(String),
}

/// Shape data at one Gauss point in physical coordinates.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GaussPoint {
    /// Shape function values N_a.
    pub n: [f64; 20],
    /// Physical gradients ∂N_a/∂(x, y, z), 1/m.
    pub grad: [[f64; 3]; 20],
    /// Quadrature weight × Jacobian determinant, m³.
    pub weight: f64,
    /// Physical position of the Gauss point, m.
    pub x: [f64; 3],
}

/// The 27 Gauss points (3×3×3 Gauss–Legendre) of an element with node coordinates `coords`.
///
/// Fails with [`FeError::BadJacobian`] (element index `element`) if det J ≤ 0 anywhere.
pub(crate) fn gauss_points(
    coords: &[[f64; 3]; 20],
    element: usize,
) -> Result<[GaussPoint; 27], FeError> {
    const G: [f64; 3] = [-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4];
    const W: [f64; 3] = [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0];
    let mut out = [GaussPoint {
        n: [0.0; 20],
        grad: [[0.0; 3]; 20],
        weight: 0.0,
        x: [0.0; 3],
    }; 27];
    let mut q = 0;
    for (i, &gi) in G.iter().enumerate() {
        for (j, &gj) in G.iter().enumerate() {
            for (k, &gk) in G.iter().enumerate() {
                let (n, dn) = hex20_shape([gi, gj, gk]);
                // J[r][c] = ∂x_c/∂ξ_r
                let mut jac = [[0.0; 3]; 3];
                let mut x = [0.0; 3];
                for a in 0..20 {
                    for r in 0..3 {
                        x[r] += n[a] * coords[a][r];
                        for c in 0..3 {
                            jac[r][c] += dn[a][r] * coords[a][c];
                        }
                    }
                }
                let det = det3(&jac);
                if det.is_nan() || det <= 0.0 {
                    return Err(FeError::BadJacobian {
                        element,
                        point: q,
                        det,
                    });
                }
                let inv = inv3(&jac, det);
                let mut grad = [[0.0; 3]; 20];
                for a in 0..20 {
                    for c in 0..3 {
                        // ∂N/∂x_c = Σ_r (J⁻¹)[c][r] ∂N/∂ξ_r
                        grad[a][c] =
                            inv[c][0] * dn[a][0] + inv[c][1] * dn[a][1] + inv[c][2] * dn[a][2];
                    }
                }
                out[q] = GaussPoint {
                    n,
                    grad,
                    weight: W[i] * W[j] * W[k] * det,
                    x,
                };
                q += 1;
            }
        }
    }
    Ok(out)
}

fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

fn inv3(m: &[[f64; 3]; 3], det: f64) -> [[f64; 3]; 3] {
    let d = 1.0 / det;
    [
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * d,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * d,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * d,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * d,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * d,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * d,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * d,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * d,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * d,
        ],
    ]
}

/// Isotropic elasticity matrix D (6×6, Pa) in Voigt order xx, yy, zz, xy, yz, zx with engineering shear strains.
pub(crate) fn elasticity_matrix(mat: &Material) -> [[f64; 6]; 6] {
    let (e, nu) = (mat.young, mat.poisson);
    let lam = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let mut d = [[0.0; 6]; 6];
    for i in 0..3 {
        for j in 0..3 {
            d[i][j] = lam;
        }
        d[i][i] = lam + 2.0 * mu;
        d[i + 3][i + 3] = mu;
    }
    d
}

/// Strain–displacement matrix block of node `a`: ε (Voigt) = Σ_a B_a u_a, B_a is 6×3.
fn b_block(g: &[f64; 3]) -> [[f64; 3]; 6] {
    [
        [g[0], 0.0, 0.0],
        [0.0, g[1], 0.0],
        [0.0, 0.0, g[2]],
        [g[1], g[0], 0.0],
        [0.0, g[2], g[1]],
        [g[2], 0.0, g[0]],
    ]
}

/// Element stiffness K_e = ∫ Bᵀ D B dV (60×60 row-major, N/m).
pub(crate) fn element_stiffness(gps: &[GaussPoint; 27], mat: &Material) -> Vec<f64> {
    let d = elasticity_matrix(mat);
    let mut k = vec![0.0; 3600];
    for gp in gps {
        let bs: Vec<[[f64; 3]; 6]> = gp.grad.iter().map(b_block).collect();
        // DB_b = D B_b (6×3), then K_ab += B_aᵀ DB_b w
        let db: Vec<[[f64; 3]; 6]> = bs
            .iter()
            .map(|b| {
                let mut o = [[0.0; 3]; 6];
                for r in 0..6 {
                    for c in 0..3 {
                        o[r][c] = (0..6).map(|s| d[r][s] * b[s][c]).sum();
                    }
                }
                o
            })
            .collect();
        for a in 0..20 {
            for bnode in 0..20 {
                for i in 0..3 {
                    for j in 0..3 {
                        let mut s = 0.0;
                        for r in 0..6 {
                            s += bs[a][r][i] * db[bnode][r][j];
                        }
                        k[(3 * a + i) * 60 + 3 * bnode + j] += s * gp.weight;
                    }
                }
            }
        }
    }
    k
}

/// Element mass matrix `∫ ρ Nᵀ diag(w) N dV` (60×60 row-major, kg): `dirs = [1,1,1]` gives the
/// consistent mass, `dirs = [1,1,0]` the spin-softening matrix M_s of a rotation about z.
pub(crate) fn element_mass(gps: &[GaussPoint; 27], density: f64, dirs: [f64; 3]) -> Vec<f64> {
    let mut m = vec![0.0; 3600];
    for gp in gps {
        for a in 0..20 {
            for b in 0..20 {
                let v = density * gp.n[a] * gp.n[b] * gp.weight;
                for (i, &w) in dirs.iter().enumerate() {
                    m[(3 * a + i) * 60 + 3 * b + i] += v * w;
                }
            }
        }
    }
    m
}

/// Centrifugal load per unit Ω², `f = ∫ ρ Nᵀ (x, y, 0) dV` (N·s², 60 entries), rotation about z.
pub(crate) fn element_centrifugal_load(gps: &[GaussPoint; 27], density: f64) -> [f64; 60] {
    let mut f = [0.0; 60];
    for gp in gps {
        for a in 0..20 {
            let v = density * gp.n[a] * gp.weight;
            f[3 * a] += v * gp.x[0];
            f[3 * a + 1] += v * gp.x[1];
        }
    }
    f
}

/// Cauchy stresses (Voigt xx, yy, zz, xy, yz, zx; Pa) at the 27 Gauss points for element
/// displacements `u` (60 entries, m), `σ = D B u`.
pub(crate) fn element_stresses(
    gps: &[GaussPoint; 27],
    mat: &Material,
    u: &[f64; 60],
) -> [[f64; 6]; 27] {
    let d = elasticity_matrix(mat);
    let mut out = [[0.0; 6]; 27];
    for (q, gp) in gps.iter().enumerate() {
        let mut eps = [0.0; 6];
        for a in 0..20 {
            let b = b_block(&gp.grad[a]);
            for (r, e) in eps.iter_mut().enumerate() {
                *e += b[r][0] * u[3 * a] + b[r][1] * u[3 * a + 1] + b[r][2] * u[3 * a + 2];
            }
        }
        for r in 0..6 {
            out[q][r] = (0..6).map(|s| d[r][s] * eps[s]).sum();
        }
    }
    out
}

/// Geometric (initial-stress) stiffness `K_σ = ∫ Gᵀ Σ G dV` (60×60 row-major, N/m), Σ =
/// blockdiag(σ, σ, σ) with σ the 3×3 Cauchy stress at each Gauss point (`stresses` in Voigt order).
pub(crate) fn element_geometric_stiffness(
    gps: &[GaussPoint; 27],
    stresses: &[[f64; 6]; 27],
) -> Vec<f64> {
    let mut k = vec![0.0; 3600];
    for (gp, s) in gps.iter().zip(stresses) {
        let sig = [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]];
        for a in 0..20 {
            let ga = gp.grad[a];
            let sg = [
                sig[0][0] * ga[0] + sig[0][1] * ga[1] + sig[0][2] * ga[2],
                sig[1][0] * ga[0] + sig[1][1] * ga[1] + sig[1][2] * ga[2],
                sig[2][0] * ga[0] + sig[2][1] * ga[1] + sig[2][2] * ga[2],
            ];
            for b in 0..20 {
                let gb = gp.grad[b];
                let v = (sg[0] * gb[0] + sg[1] * gb[1] + sg[2] * gb[2]) * gp.weight;
                for i in 0..3 {
                    k[(3 * a + i) * 60 + 3 * b + i] += v;
                }
            }
        }
    }
    k
}

/// Derivative of the Green–Lagrange strain's quadratic part at displacement gradient `h`
/// (`h[k][j] = ∂u_k/∂x_j`) with respect to the displacement of a node with shape gradient `g`:
/// the 6×3 block `B_H` (Voigt xx, yy, zz, xy, yz, zx, engineering shears) with
/// `δE = (B_L + B_H) δu` to first order in `δu`.
fn b_displacement_block(g: &[f64; 3], h: &[[f64; 3]; 3]) -> [[f64; 3]; 6] {
    let mut b = [[0.0; 3]; 6];
    for k in 0..3 {
        b[0][k] = h[k][0] * g[0];
        b[1][k] = h[k][1] * g[1];
        b[2][k] = h[k][2] * g[2];
        b[3][k] = h[k][0] * g[1] + h[k][1] * g[0];
        b[4][k] = h[k][1] * g[2] + h[k][2] * g[1];
        b[5][k] = h[k][2] * g[0] + h[k][0] * g[2];
    }
    b
}

/// Initial-displacement (large-displacement) stiffness of a prestressed element whose static
/// displacement is `u` (60 entries, m): the tangent `∫ (B_L + B_H)ᵀ D (B_L + B_H) dV` less
/// `K0`, split by order in `u`: `(∫ B_Lᵀ D B_H + B_Hᵀ D B_L dV, ∫ B_Hᵀ D B_H dV)` (60×60
/// row-major each, N/m). With `u = Ω² u₁` they enter `K(Ω)` at Ω² and Ω⁴.
pub(crate) fn element_displacement_stiffness(
    gps: &[GaussPoint; 27],
    mat: &Material,
    u: &[f64; 60],
) -> (Vec<f64>, Vec<f64>) {
    let d = elasticity_matrix(mat);
    let (mut k1, mut k2) = (vec![0.0; 3600], vec![0.0; 3600]);
    for gp in gps {
        let mut h = [[0.0; 3]; 3];
        for a in 0..20 {
            for k in 0..3 {
                for j in 0..3 {
                    h[k][j] += u[3 * a + k] * gp.grad[a][j];
                }
            }
        }
        let bl: Vec<[[f64; 3]; 6]> = gp.grad.iter().map(b_block).collect();
        let bh: Vec<[[f64; 3]; 6]> = gp
            .grad
            .iter()
            .map(|g| b_displacement_block(g, &h))
            .collect();
        let times_d = |b: &[[f64; 3]; 6]| {
            let mut o = [[0.0; 3]; 6];
            for r in 0..6 {
                for c in 0..3 {
                    o[r][c] = (0..6).map(|s| d[r][s] * b[s][c]).sum();
                }
            }
            o
        };
        let dbl: Vec<[[f64; 3]; 6]> = bl.iter().map(times_d).collect();
        let dbh: Vec<[[f64; 3]; 6]> = bh.iter().map(times_d).collect();
        for a in 0..20 {
            for b in 0..20 {
                for i in 0..3 {
                    for j in 0..3 {
                        let (mut first, mut second) = (0.0, 0.0);
                        for r in 0..6 {
                            first += bl[a][r][i] * dbh[b][r][j] + bh[a][r][i] * dbl[b][r][j];
                            second += bh[a][r][i] * dbh[b][r][j];
                        }
                        k1[(3 * a + i) * 60 + 3 * b + j] += first * gp.weight;
                        k2[(3 * a + i) * 60 + 3 * b + j] += second * gp.weight;
                    }
                }
            }
        }
    }
    (k1, k2)
}

/// Sparse matrices of one sector (DOF `3*node + dir`, full storage of both triangles).
#[derive(Clone, Debug)]
pub(crate) struct SectorMatrices {
    /// Elastic stiffness K0, N/m.
    pub stiffness: SparseColMat<usize, f64>,
    /// Consistent mass M, kg.
    pub mass: SparseColMat<usize, f64>,
    /// Centrifugal stiffness K1 per unit Ω² (kg): geometric stiffness of the linear
    /// centrifugal prestress minus spin softening, so that K(Ω) = K0 + Ω² K1.
    pub centrifugal: Option<SparseColMat<usize, f64>>,
    /// Quartic centrifugal stiffness K2 per unit Ω⁴ (kg·s²); `None` here, set by
    /// [`crate::model::build::reduce_sector`] for the consistent prestress.
    pub centrifugal_quartic: Option<SparseColMat<usize, f64>>,
    /// The prestate u₁: the nodal-diameter-0 static displacement per unit Ω² (m·s², DOF
    /// `3·node + dir`), with K1.
    pub prestate: Option<Vec<f64>>,
}

fn element_coords(mesh: &SectorMesh, conn: &[usize; 20]) -> [[f64; 3]; 20] {
    let mut c = [[0.0; 3]; 20];
    for (a, &n) in conn.iter().enumerate() {
        c[a] = mesh.nodes[n];
    }
    c
}

fn scatter(trip: &mut Vec<Triplet<usize, usize, f64>>, conn: &[usize; 20], ke: &[f64]) {
    for a in 0..20 {
        for i in 0..3 {
            let row = 3 * conn[a] + i;
            for b in 0..20 {
                for j in 0..3 {
                    let v = ke[(3 * a + i) * 60 + 3 * b + j];
                    if v != 0.0 {
                        trip.push(Triplet::new(row, 3 * conn[b] + j, v));
                    }
                }
            }
        }
    }
}

fn sparse(
    n: usize,
    trip: &[Triplet<usize, usize, f64>],
) -> Result<SparseColMat<usize, f64>, FeError> {
    SparseColMat::try_new_from_triplets(n, n, trip).map_err(|e| FeError::Sparse(format!("{e:?}")))
}

/// Assembles K0 and M of a sector and, if `with_centrifugal`, K1 = K_σ(σ₁) − M_s where σ₁ is the
/// stress of the nodal-diameter-0 static solution per unit Ω² (see [`centrifugal_displacement`]).
/// K1 leaves out the initial-displacement stiffness ([`initial_displacement_stiffness`]): a
/// Craig–Bampton basis of modes at rest does not represent it (`docs/validation.md`,
/// "Prestressed frequencies").
///
/// Fails if the mesh is invalid, an element is inverted, or (with K1) the constrained static
/// problem is singular (e.g. no clamped nodes).
pub(crate) fn assemble_sector(
    mesh: &SectorMesh,
    with_centrifugal: bool,
) -> Result<SectorMatrices, FeError> {
    mesh.validate()?;
    let n = mesh.n_dofs();
    let rho = mesh.material.density;
    let mut tk = Vec::new();
    let mut tm = Vec::new();
    let mut f = vec![0.0; n];
    let mut gauss = Vec::with_capacity(mesh.elements.len());
    for (e, conn) in mesh.elements.iter().enumerate() {
        let gps = gauss_points(&element_coords(mesh, conn), e)?;
        scatter(&mut tk, conn, &element_stiffness(&gps, &mesh.material));
        scatter(&mut tm, conn, &element_mass(&gps, rho, [1.0; 3]));
        if with_centrifugal {
            let fe = element_centrifugal_load(&gps, rho);
            for a in 0..20 {
                for i in 0..3 {
                    f[3 * conn[a] + i] += fe[3 * a + i];
                }
            }
            gauss.push(gps);
        }
    }
    let stiffness = sparse(n, &tk)?;
    let mass = sparse(n, &tm)?;
    let (centrifugal, prestate) = if with_centrifugal {
        let u = centrifugal_displacement(mesh, &stiffness, &f)?;
        let mut t1 = Vec::new();
        for (conn, gps) in mesh.elements.iter().zip(&gauss) {
            let mut ue = [0.0; 60];
            for a in 0..20 {
                for i in 0..3 {
                    ue[3 * a + i] = u[3 * conn[a] + i];
                }
            }
            let sig = element_stresses(gps, &mesh.material, &ue);
            let mut ke = element_geometric_stiffness(gps, &sig);
            let ms = element_mass(gps, rho, [1.0, 1.0, 0.0]);
            for (k, m) in ke.iter_mut().zip(&ms) {
                *k -= m;
            }
            scatter(&mut t1, conn, &ke);
        }
        (Some(sparse(n, &t1)?), Some(u))
    } else {
        (None, None)
    };
    Ok(SectorMatrices {
        stiffness,
        mass,
        centrifugal,
        centrifugal_quartic: None,
        prestate,
    })
}

/// Elastic stiffness and consistent mass of a set of elements (a sector's blade), over the
/// DOFs of the nodes those elements touch: local DOF `3·i + dir` is DOF `dir` of sector node
/// `nodes[i]`. What a structural mistuning scales (Young's modulus of the set, [`Material`]).
#[derive(Clone, Debug)]
pub(crate) struct ElementSetMatrices {
    /// Sector nodes of the set, ascending.
    pub nodes: Vec<usize>,
    /// Elastic stiffness of the set's elements, N/m.
    pub stiffness: SparseColMat<usize, f64>,
    /// Consistent mass of the set's elements, kg.
    pub mass: SparseColMat<usize, f64>,
}

/// Assembles [`ElementSetMatrices`] of `elements` (indices into `mesh.elements`).
pub(crate) fn assemble_element_set(
    mesh: &SectorMesh,
    elements: &[usize],
) -> Result<ElementSetMatrices, FeError> {
    let mut nodes: Vec<usize> = elements.iter().flat_map(|&e| mesh.elements[e]).collect();
    nodes.sort_unstable();
    nodes.dedup();
    let local = |n: usize| nodes.binary_search(&n).expect("a node of the set");
    let (mut tk, mut tm) = (Vec::new(), Vec::new());
    for &e in elements {
        let conn = &mesh.elements[e];
        let gps = gauss_points(&element_coords(mesh, conn), e)?;
        let local_conn = conn.map(local);
        scatter(
            &mut tk,
            &local_conn,
            &element_stiffness(&gps, &mesh.material),
        );
        scatter(
            &mut tm,
            &local_conn,
            &element_mass(&gps, mesh.material.density, [1.0; 3]),
        );
    }
    let n = 3 * nodes.len();
    Ok(ElementSetMatrices {
        stiffness: sparse(n, &tk)?,
        mass: sparse(n, &tm)?,
        nodes,
    })
}

/// The initial-displacement stiffness of a sector about its centrifugal prestate `u₁` (per
/// unit Ω², [`SectorMatrices::prestate`]): `[K_u1, K_u2]` with the tangent stiffness of the
/// spinning sector `K0 + Ω² (K1 + K_u1) + Ω⁴ K_u2` ([`element_displacement_stiffness`]), the
/// consistent linearisation that CalculiX's perturbation step forms after a linear `*STATIC`
/// step under `CENTRIF`. rubscan's ROMs leave it out (see [`assemble_sector`]); the unreduced
/// reference can include it to compare with CalculiX.
pub(crate) fn initial_displacement_stiffness(
    mesh: &SectorMesh,
    u1: &[f64],
) -> Result<[SparseColMat<usize, f64>; 2], FeError> {
    let (mut t1, mut t2) = (Vec::new(), Vec::new());
    for (e, conn) in mesh.elements.iter().enumerate() {
        let gps = gauss_points(&element_coords(mesh, conn), e)?;
        let ue: [f64; 60] = std::array::from_fn(|i| u1[3 * conn[i / 3] + i % 3]);
        let (k1, k2) = element_displacement_stiffness(&gps, &mesh.material, &ue);
        scatter(&mut t1, conn, &k1);
        scatter(&mut t2, conn, &k2);
    }
    Ok([sparse(mesh.n_dofs(), &t1)?, sparse(mesh.n_dofs(), &t2)?])
}

/// Linear map from the full sector DOFs to the independent DOFs of the nodal-diameter-0 cyclic
/// problem: `u[dof] = Σ coef · q[idx]` over `map[dof]`. Clamped DOFs map to nothing; right-face
/// DOFs map to their left partner rotated by α (u_right = R(α) u_left). Returns (map, n_free).
fn cyclic_nd0_map(mesh: &SectorMesh) -> (Vec<Vec<(usize, f64)>>, usize) {
    let nn = mesh.nodes.len();
    #[derive(Clone, Copy, PartialEq)]
    enum Kind {
        Free,
        Clamped,
        Right(usize),
    }
    let mut kind = vec![Kind::Free; nn];
    for (&l, &r) in mesh.left_nodes.iter().zip(&mesh.right_nodes) {
        kind[r] = Kind::Right(l);
    }
    for &c in &mesh.clamped_nodes {
        kind[c] = Kind::Clamped;
    }
    // A clamp on either node of a cyclic pair fixes both, as in the reduction's
    // [`crate::model::cyclic::CyclicDofMap`]: u_right = R(α) u_left = 0.
    for (&l, &r) in mesh.left_nodes.iter().zip(&mesh.right_nodes) {
        if kind[l] == Kind::Clamped || kind[r] == Kind::Clamped {
            kind[l] = Kind::Clamped;
            kind[r] = Kind::Clamped;
        }
    }
    let mut idx = vec![usize::MAX; nn];
    let mut nf = 0;
    for i in 0..nn {
        if kind[i] == Kind::Free {
            idx[i] = nf;
            nf += 3;
        }
    }
    let (s, c) = mesh.sector_angle().sin_cos();
    let rot = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
    let mut map = vec![Vec::new(); 3 * nn];
    for i in 0..nn {
        match kind[i] {
            Kind::Free => {
                for d in 0..3 {
                    map[3 * i + d].push((idx[i] + d, 1.0));
                }
            }
            Kind::Clamped => {}
            Kind::Right(l) => {
                for d in 0..3 {
                    for (e, &r) in rot[d].iter().enumerate() {
                        if r != 0.0 {
                            map[3 * i + d].push((idx[l] + e, r));
                        }
                    }
                }
            }
        }
    }
    (map, nf)
}

/// Static centrifugal displacement per unit Ω² (m·s²): solves `K0 u = f` with the
/// nodal-diameter-0 cyclic condition `u_right = R(α) u_left` and the clamped nodes fixed, by
/// sparse Cholesky of the constrained stiffness. `f` is the centrifugal load per unit Ω².
pub(crate) fn centrifugal_displacement(
    mesh: &SectorMesh,
    k0: &SparseColMat<usize, f64>,
    f: &[f64],
) -> Result<Vec<f64>, FeError> {
    let (map, nf) = cyclic_nd0_map(mesh);
    if nf == 0 {
        return Err(FeError::Prestress("every DOF is constrained".into()));
    }
    let mut trip = Vec::new();
    for j in 0..k0.ncols() {
        let rows = k0.row_idx_of_col(j);
        let vals = k0.val_of_col(j);
        for (i, &v) in rows.zip(vals) {
            for &(p, cp) in &map[i] {
                for &(q, cq) in &map[j] {
                    trip.push(Triplet::new(p, q, cp * cq * v));
                }
            }
        }
    }
    let kr = sparse(nf, &trip)?;
    let mut fr = Mat::<f64>::zeros(nf, 1);
    for (i, m) in map.iter().enumerate() {
        for &(p, c) in m {
            fr[(p, 0)] += c * f[i];
        }
    }
    let llt = kr.sp_cholesky(Side::Lower).map_err(|e| {
        FeError::Prestress(format!(
            "constrained stiffness is not positive definite ({e:?}); the structure needs clamped nodes"
        ))
    })?;
    use faer::linalg::solvers::Solve;
    let q = llt.solve(&fr);
    let mut u = vec![0.0; map.len()];
    for (i, m) in map.iter().enumerate() {
        u[i] = m.iter().map(|&(p, c)| c * q[(p, 0)]).sum();
    }
    if u.iter().any(|v| !v.is_finite()) {
        return Err(FeError::Prestress("non-finite static solution".into()));
    }
    Ok(u)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::model::mesh::{BlockNodes, MeshBuilder};

    /// A free (unclamped, non-cyclic) mesh of one structured block.
    pub(crate) fn block_mesh(
        n: [usize; 3],
        mat: Material,
        map: impl Fn([f64; 3]) -> [f64; 3],
    ) -> (SectorMesh, BlockNodes) {
        let mut b = MeshBuilder::new(1e-10);
        let blk = b.add_block(n, map);
        let mesh = SectorMesh {
            n_sectors: 1,
            nodes: b.nodes,
            elements: b.elements,
            left_nodes: vec![],
            right_nodes: vec![],
            contact_nodes: vec![],
            clamped_nodes: vec![],
            material: mat,
            named_nodes: vec![],
            blade_elements: vec![],
        };
        (mesh, blk)
    }

    fn dense(a: &SparseColMat<usize, f64>, keep: &[usize]) -> Mat<f64> {
        let d = a.to_dense();
        Mat::from_fn(keep.len(), keep.len(), |i, j| d[(keep[i], keep[j])])
    }

    /// Ascending generalized eigenvalues of (K, M) restricted to the DOFs `keep` (dense, Cholesky of M).
    pub(crate) fn gen_eigenvalues(
        k: &SparseColMat<usize, f64>,
        m: &SparseColMat<usize, f64>,
        keep: &[usize],
    ) -> Vec<f64> {
        let (kd, md) = (dense(k, keep), dense(m, keep));
        let lm = md.llt(Side::Lower).expect("M SPD");
        let l = lm.L();
        let mut c = kd.clone();
        l.solve_lower_triangular_in_place(c.as_mut());
        let mut c2 = c.transpose().to_owned();
        l.solve_lower_triangular_in_place(c2.as_mut());
        c2.self_adjoint_eigenvalues(Side::Lower)
            .expect("eigenvalues")
    }

    pub(crate) fn free_dofs(mesh: &SectorMesh) -> Vec<usize> {
        let mut fixed = vec![false; mesh.nodes.len()];
        for &c in &mesh.clamped_nodes {
            fixed[c] = true;
        }
        (0..mesh.n_dofs()).filter(|d| !fixed[d / 3]).collect()
    }

    fn distorted_cube(s: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = s;
        let w = (std::f64::consts::PI * x).sin()
            * (std::f64::consts::PI * y).sin()
            * (std::f64::consts::PI * z).sin();
        [
            x + 0.3 * y + 0.08 * y * z + 0.06 * w,
            0.9 * y + 0.1 * x * x - 0.04 * w,
            1.1 * z + 0.05 * x * y + 0.07 * w,
        ]
    }

    #[test]
    fn patch_test_constant_strain_and_interior_recovery() {
        let mat = Material::TI6AL4V;
        let (mesh, blk) = block_mesh([2, 2, 2], mat, distorted_cube);
        let grad_u = [
            [1.0e-3, 2.0e-4, -3.0e-4],
            [5.0e-4, -7.0e-4, 1.0e-4],
            [-2.0e-4, 6.0e-4, 9.0e-4],
        ];
        let lin = |p: [f64; 3]| -> [f64; 3] {
            let mut u = [1e-4, -2e-4, 3e-4];
            for i in 0..3 {
                for j in 0..3 {
                    u[i] += grad_u[i][j] * p[j];
                }
            }
            u
        };
        let eps = [
            grad_u[0][0],
            grad_u[1][1],
            grad_u[2][2],
            grad_u[0][1] + grad_u[1][0],
            grad_u[1][2] + grad_u[2][1],
            grad_u[2][0] + grad_u[0][2],
        ];
        let d = elasticity_matrix(&mat);
        let sig: Vec<f64> = (0..6)
            .map(|r| (0..6).map(|s| d[r][s] * eps[s]).sum())
            .collect();
        // (a) every element reproduces the constant stress at every Gauss point
        for (e, conn) in mesh.elements.iter().enumerate() {
            let gps = gauss_points(&element_coords(&mesh, conn), e).unwrap();
            let mut ue = [0.0; 60];
            for a in 0..20 {
                ue[3 * a..3 * a + 3].copy_from_slice(&lin(mesh.nodes[conn[a]]));
            }
            for s in element_stresses(&gps, &mat, &ue) {
                for r in 0..6 {
                    assert!(
                        (s[r] - sig[r]).abs() < 1e-9 * mat.young * 1e-3,
                        "{r}: {} vs {}",
                        s[r],
                        sig[r]
                    );
                }
            }
        }
        // (b) prescribe the linear field on the patch boundary, solve for the interior nodes
        let mut interior = vec![false; mesh.nodes.len()];
        for i in 1..4 {
            for j in 1..4 {
                for k in 1..4 {
                    if let Some(nd) = blk.get(i, j, k) {
                        interior[nd] = true;
                    }
                }
            }
        }
        let ni: Vec<usize> = (0..mesh.n_dofs()).filter(|d| interior[d / 3]).collect();
        let nb: Vec<usize> = (0..mesh.n_dofs()).filter(|d| !interior[d / 3]).collect();
        assert_eq!(
            ni.len(),
            3 * 7,
            "centre corner node + 6 mid-edge nodes are interior"
        );
        let mats = assemble_sector(&mesh, false).unwrap();
        let k = mats.stiffness.to_dense();
        let u_exact: Vec<f64> = mesh.nodes.iter().flat_map(|&p| lin(p)).collect();
        let kii = Mat::from_fn(ni.len(), ni.len(), |i, j| k[(ni[i], ni[j])]);
        let rhs = Mat::from_fn(ni.len(), 1, |i, _| {
            -nb.iter().map(|&b| k[(ni[i], b)] * u_exact[b]).sum::<f64>()
        });
        use faer::linalg::solvers::Solve;
        let ui = kii.llt(Side::Lower).unwrap().solve(&rhs);
        for (i, &dof) in ni.iter().enumerate() {
            assert!(
                (ui[(i, 0)] - u_exact[dof]).abs() < 1e-12,
                "dof {dof}: {} vs {}",
                ui[(i, 0)],
                u_exact[dof]
            );
        }
    }

    fn check_rigid_body_modes(mesh: &SectorMesh) {
        let mats = assemble_sector(mesh, false).unwrap();
        let kd = mats.stiffness.to_dense();
        let md = mats.mass.to_dense();
        let n = mesh.n_dofs();
        for i in 0..n {
            for j in 0..n {
                assert!(
                    (kd[(i, j)] - kd[(j, i)]).abs()
                        <= 1e-12 * kd[(i, i)].abs().max(kd[(j, j)].abs())
                );
                assert!(
                    (md[(i, j)] - md[(j, i)]).abs()
                        <= 1e-14 * md[(i, i)].abs().max(md[(j, j)].abs())
                );
            }
        }
        let all: Vec<usize> = (0..n).collect();
        let lam = gen_eigenvalues(&mats.stiffness, &mats.mass, &all);
        let top = lam[n - 1];
        for l in &lam[..6] {
            assert!(
                l.abs() < 1e-10 * top,
                "rigid-body eigenvalue {l} vs max {top}"
            );
        }
        assert!(
            lam[6] > 1e-6 * top,
            "7th eigenvalue {} must be clearly nonzero",
            lam[6]
        );
        let mev = md.self_adjoint_eigenvalues(Side::Lower).unwrap();
        assert!(
            mev[0] > 0.0,
            "M must be positive definite, min eigenvalue {}",
            mev[0]
        );
    }

    #[test]
    fn free_element_and_patch_have_six_rigid_body_modes() {
        let (one, _) = block_mesh([1, 1, 1], Material::STEEL, distorted_cube);
        check_rigid_body_modes(&one);
        let (stack, _) = block_mesh([3, 2, 2], Material::STEEL, distorted_cube);
        check_rigid_body_modes(&stack);
    }

    #[test]
    fn total_mass_of_a_prism_is_density_times_volume() {
        // A hexahedron with planar faces whose top face is tilted: volume = base area × mean height.
        let (a, b, h0, hx, hy) = (0.3, 0.2, 0.1, 0.04, -0.03);
        let (mesh, _) = block_mesh([2, 3, 2], Material::TI6AL4V, |[s, t, u]| {
            let (x, y) = (a * s, b * t);
            [x, y, u * (h0 + hx * x / a + hy * y / b)]
        });
        let vol = a * b * (h0 + 0.5 * hx + 0.5 * hy);
        let mats = assemble_sector(&mesh, false).unwrap();
        // Σ_ij M[3i, 3j] = total mass (rigid x-translation kinetic energy)
        let m = mats.mass.to_dense();
        let mut total = 0.0;
        for i in 0..mesh.nodes.len() {
            for j in 0..mesh.nodes.len() {
                total += m[(3 * i, 3 * j)];
            }
        }
        let expect = Material::TI6AL4V.density * vol;
        assert!(
            (total - expect).abs() < 1e-12 * expect,
            "{total} vs {expect}"
        );
    }

    /// Cantilever beam along x from x = 0 (clamped) to L, cross-section b (y) × h (z).
    fn cantilever(ne: usize, l: f64, b: f64, h: f64) -> SectorMesh {
        let (mut mesh, blk) = block_mesh([ne, 1, 1], Material::STEEL, |[s, t, u]| {
            [l * s, b * (t - 0.5), h * (u - 0.5)]
        });
        for j in 0..3 {
            for k in 0..3 {
                if let Some(nd) = blk.get(0, j, k) {
                    mesh.clamped_nodes.push(nd);
                }
            }
        }
        mesh
    }

    #[test]
    fn cantilever_first_bending_frequency_matches_euler_bernoulli() {
        let (l, b, h) = (1.0, 0.02, 0.02);
        let mesh = cantilever(20, l, b, h);
        let mats = assemble_sector(&mesh, false).unwrap();
        let lam = gen_eigenvalues(&mats.stiffness, &mats.mass, &free_dofs(&mesh));
        let mat = mesh.material;
        let (area, inertia) = (b * h, b * h.powi(3) / 12.0);
        let beta1: f64 = 1.875_104_068_711_961;
        let w_eb = beta1 * beta1 * (mat.young * inertia / (mat.density * area * l.powi(4))).sqrt();
        let w_fe = lam[0].sqrt();
        let err = (w_fe - w_eb) / w_eb;
        println!(
            "cantilever: f_FE = {:.4} Hz, f_EB = {:.4} Hz, error {:.3e}",
            w_fe / (2.0 * std::f64::consts::PI),
            w_eb / (2.0 * std::f64::consts::PI),
            err
        );
        assert!(err.abs() < 0.01);
        // square section: the two bending directions are degenerate
        assert!((lam[1] - lam[0]).abs() < 1e-6 * lam[0]);
    }

    /// The prestress holds a clamped cyclic pair at zero whichever of its two nodes carries
    /// the clamp (a CalculiX deck cannot clamp a tie's slave node, so it clamps the master).
    #[test]
    fn a_clamp_on_either_node_of_a_cyclic_pair_gives_the_same_prestress() {
        let mesh = crate::model::mesh::ImpellerGeometry::default()
            .build()
            .unwrap();
        let partner: std::collections::HashMap<usize, usize> = mesh
            .left_nodes
            .iter()
            .copied()
            .zip(mesh.right_nodes.iter().copied())
            .collect();
        let mut moved = mesh.clone();
        let clamps: std::collections::BTreeSet<usize> = mesh
            .clamped_nodes
            .iter()
            .map(|c| partner.get(c).copied().unwrap_or(*c))
            .collect();
        moved.clamped_nodes = clamps.into_iter().collect();
        assert_ne!(
            moved.clamped_nodes, mesh.clamped_nodes,
            "the bore has left-face nodes"
        );
        // The built-in bore clamps both nodes of each pair, so its ROM is the same either way.
        let right_clamped = mesh
            .clamped_nodes
            .iter()
            .filter(|c| mesh.right_nodes.contains(c));
        assert_eq!(
            right_clamped.count(),
            mesh.clamped_nodes
                .iter()
                .filter(|c| partner.contains_key(c))
                .count()
        );
        let k1 = |m: &SectorMesh| {
            assemble_sector(m, true)
                .unwrap()
                .centrifugal
                .unwrap()
                .to_dense()
        };
        let (a, b) = (k1(&mesh), k1(&moved));
        let rel = (&a - &b).norm_l2() / a.norm_l2();
        assert!(rel < 1e-12, "relative difference of K1: {rel:e}");
    }

    #[test]
    fn rotating_cantilever_southwell_coefficient() {
        // Radial beam along x from the axis (r_hub = 0), flapwise = z (out of the rotation plane).
        let (l, b, h) = (1.0, 0.04, 0.02);
        let mesh = cantilever(20, l, b, h);
        let mats = assemble_sector(&mesh, true).unwrap();
        let k1 = mats.centrifugal.as_ref().unwrap();
        let free = free_dofs(&mesh);
        let lam0 = gen_eigenvalues(&mats.stiffness, &mats.mass, &free)[0];
        let omega = lam0.sqrt(); // Ω = ω₀: a strong stiffening
        let kw = &mats.stiffness + &(k1 * faer::Scale(omega * omega));
        let lam = gen_eigenvalues(&kw, &mats.mass, &free)[0];
        let s = (lam - lam0) / (omega * omega);
        println!("Southwell coefficient: FE {s:.5}, beam theory 1.1933");
        assert!((s - 1.1933).abs() < 0.01 * 1.1933, "S = {s}");
    }

    #[test]
    fn nd0_prestress_of_a_rotating_annular_disk_matches_lame_solution() {
        // Thin annular disk (plane stress) clamped at the inner radius a, free at b, spinning about
        // z: u(r) = A r + B/r − (1−ν²) ρ Ω² r³ / (8E) with u(a) = 0 and σ_r(b) = 0 (per unit Ω²).
        let (a, b, h, n_sec) = (0.02, 0.10, 0.002, 12usize);
        let mat = Material::STEEL;
        let alpha = 2.0 * std::f64::consts::PI / n_sec as f64;
        let mut builder = MeshBuilder::new(1e-12);
        let blk = builder.add_block([10, 2, 1], |[s, t, u]| {
            let (r, th) = (a + (b - a) * s, alpha * t);
            [r * th.cos(), r * th.sin(), h * (u - 0.5)]
        });
        let [d0, d1, d2] = blk.dims;
        let mut mesh = SectorMesh {
            n_sectors: n_sec,
            nodes: builder.nodes,
            elements: builder.elements,
            left_nodes: vec![],
            right_nodes: vec![],
            contact_nodes: vec![],
            clamped_nodes: vec![],
            material: mat,
            named_nodes: vec![],
            blade_elements: vec![],
        };
        for i in 0..d0 {
            for k in 0..d2 {
                if let (Some(l), Some(r)) = (blk.get(i, 0, k), blk.get(i, d1 - 1, k)) {
                    mesh.left_nodes.push(l);
                    mesh.right_nodes.push(r);
                }
            }
        }
        for j in 0..d1 {
            for k in 0..d2 {
                mesh.clamped_nodes.extend(blk.get(0, j, k));
            }
        }
        let mats = assemble_sector(&mesh, false).unwrap();
        let mut f = vec![0.0; mesh.n_dofs()];
        for (e, conn) in mesh.elements.iter().enumerate() {
            let gps = gauss_points(&element_coords(&mesh, conn), e).unwrap();
            let fe = element_centrifugal_load(&gps, mat.density);
            for a in 0..20 {
                for i in 0..3 {
                    f[3 * conn[a] + i] += fe[3 * a + i];
                }
            }
        }
        let u = centrifugal_displacement(&mesh, &mats.stiffness, &f).unwrap();
        let (e, nu, rho) = (mat.young, mat.poisson, mat.density);
        let c = (1.0 - nu * nu) * rho / (8.0 * e);
        let (up, dup) = (|r: f64| -c * r.powi(3), |r: f64| -3.0 * c * r * r);
        // [a, 1/a; (1+ν), −(1−ν)/b²] [A; B] = [−u_p(a); −u_p'(b) − ν u_p(b)/b]
        let (m11, m12, m21, m22) = (a, 1.0 / a, 1.0 + nu, -(1.0 - nu) / (b * b));
        let (r1, r2) = (-up(a), -dup(b) - nu * up(b) / b);
        let det = m11 * m22 - m12 * m21;
        let (ca, cb) = ((r1 * m22 - m12 * r2) / det, (m11 * r2 - m21 * r1) / det);
        let exact = |r: f64| ca * r + cb / r + up(r);
        let mut worst = 0.0f64;
        for i in (2..d0).step_by(2) {
            for j in [0, d1 - 1] {
                let nd = blk.get(i, j, 0).unwrap();
                let p = mesh.nodes[nd];
                let r = p[0].hypot(p[1]);
                let ur = (u[3 * nd] * p[0] + u[3 * nd + 1] * p[1]) / r;
                let ut = (-u[3 * nd] * p[1] + u[3 * nd + 1] * p[0]) / r;
                worst = worst.max((ur - exact(r)).abs() / exact(b));
                assert!(
                    (ur - exact(r)).abs() < 5e-3 * exact(b),
                    "r = {r}: u_r {ur:e} vs {:e}",
                    exact(r)
                );
                assert!(ut.abs() < 1e-9 * exact(b), "no hoop displacement at ND 0");
            }
        }
        println!(
            "rotating disk: u_r(b) = {:.6e} m per (rad/s)², max |error| / u_r(b) = {worst:.2e}",
            exact(b)
        );
    }
}
