//! The built-in sector meshes assembled into their finite-element matrices: sizes, mass,
//! rigid-body modes, convergence and centrifugal stiffening. Beside neither `mesh` nor `fe`,
//! since each checks the two together.

use crate::model::fe::tests::{free_dofs, gen_eigenvalues};
use crate::model::fe::{SectorMatrices, assemble_sector};
use crate::model::mesh::{CasingGeometry, ImpellerGeometry};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use std::f64::consts::FRAC_PI_2;

/// Lowest eigenvalue of (K, M) on the DOFs `keep` by inverse iteration with a sparse Cholesky.
fn lowest_eigenvalue(
    k: &SparseColMat<usize, f64>,
    m: &SparseColMat<usize, f64>,
    keep: &[usize],
) -> f64 {
    let mut pos = vec![usize::MAX; k.nrows()];
    for (i, &d) in keep.iter().enumerate() {
        pos[d] = i;
    }
    let restrict = |a: &SparseColMat<usize, f64>| {
        let mut t = Vec::new();
        for j in 0..a.ncols() {
            for (i, &v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                if pos[i] != usize::MAX && pos[j] != usize::MAX {
                    t.push(Triplet::new(pos[i], pos[j], v));
                }
            }
        }
        SparseColMat::<usize, f64>::try_new_from_triplets(keep.len(), keep.len(), &t).unwrap()
    };
    let (kr, mr) = (restrict(k), restrict(m));
    let llt = kr.sp_cholesky(Side::Lower).unwrap();
    use faer::linalg::solvers::Solve;
    let n = keep.len();
    let mut x = Mat::<f64>::from_fn(n, 1, |i, _| 1.0 + ((i * 7919) % 13) as f64 / 13.0);
    let mut lam = f64::INFINITY;
    for _ in 0..500 {
        let y = llt.solve(&(&mr * &x));
        let (ky, my) = (&kr * &y, &mr * &y);
        let num: f64 = (0..n).map(|i| y[(i, 0)] * ky[(i, 0)]).sum();
        let den: f64 = (0..n).map(|i| y[(i, 0)] * my[(i, 0)]).sum();
        let new = num / den;
        x = y * faer::Scale(1.0 / den.sqrt());
        if (new - lam).abs() < 1e-14 * new {
            return new;
        }
        lam = new;
    }
    lam
}

#[test]
fn default_meshes_sizes_and_validity() {
    let casing = CasingGeometry::default().build().unwrap();
    let imp = ImpellerGeometry::default().build().unwrap();
    println!(
        "casing sector: {} elements, {} nodes, {} DOFs; impeller sector: {} elements, {} nodes, {} DOFs",
        casing.elements.len(),
        casing.nodes.len(),
        casing.n_dofs(),
        imp.elements.len(),
        imp.nodes.len(),
        imp.n_dofs()
    );
    assert_eq!(casing.n_dofs(), 384);
    assert!(imp.n_dofs() <= 3000);
    assert_eq!(casing.contact_nodes.len(), 5);
    assert_eq!(imp.contact_nodes.len(), 5);
    // every element has a positive Jacobian at every Gauss point, K1 is computable and symmetric
    assemble_sector(&casing, false).unwrap();
    let t = std::time::Instant::now();
    let m = assemble_sector(&imp, true).unwrap();
    println!("impeller assembly with K1: {:?}", t.elapsed());
    let k1 = m.centrifugal.unwrap().to_dense();
    let scale = (0..k1.nrows())
        .map(|i| k1[(i, i)].abs())
        .fold(0.0, f64::max);
    for i in 0..k1.nrows() {
        for j in 0..i {
            assert!((k1[(i, j)] - k1[(j, i)]).abs() < 1e-10 * scale);
        }
    }
}

#[test]
fn casing_sector_mass_matches_analytic_volume() {
    let g = CasingGeometry {
        elements_meridian: 32,
        elements_circumferential: 2,
        ..Default::default()
    };
    let mesh = g.build().unwrap();
    let SectorMatrices { mass, .. } = assemble_sector(&mesh, false).unwrap();
    let md = mass.to_dense();
    let nn = mesh.nodes.len();
    let mut fe_mass = 0.0;
    for i in 0..nn {
        for j in 0..nn {
            fe_mass += md[(3 * i + 2, 3 * j + 2)];
        }
    }
    // V = α ∫∫ r |∂P/∂φ × ∂P/∂s| ds dφ over P(φ, s) = C(φ) − s n(φ), composite Simpson in φ,
    // exact Simpson in s (the integrand is quadratic in s).
    let s = g.shroud;
    let (big_r, l, t) = (s.r_out - s.r_in, s.length, g.thickness);
    let nrm = |phi: f64| {
        let (dr, dz) = (big_r * phi.sin(), l * phi.cos());
        let h = dr.hypot(dz);
        [-dz / h, dr / h]
    };
    let integrand = |phi: f64, sd: f64| {
        let c = s.point(phi);
        let n = nrm(phi);
        let h = 1e-6;
        let (np, nm) = (nrm(phi + h), nrm(phi - h));
        let dn = [(np[0] - nm[0]) / (2.0 * h), (np[1] - nm[1]) / (2.0 * h)];
        let dp = [big_r * phi.sin() - sd * dn[0], l * phi.cos() - sd * dn[1]];
        let ds = [-n[0], -n[1]];
        (c[0] - sd * n[0]) * (dp[0] * ds[1] - dp[1] * ds[0]).abs()
    };
    let inner = |phi: f64| {
        t / 6.0 * (integrand(phi, 0.0) + 4.0 * integrand(phi, 0.5 * t) + integrand(phi, t))
    };
    let m = 4000;
    let hph = FRAC_PI_2 / m as f64;
    let mut v = inner(0.0) + inner(FRAC_PI_2);
    for i in 1..m {
        v += if i % 2 == 1 { 4.0 } else { 2.0 } * inner(i as f64 * hph);
    }
    v *= hph / 3.0 * mesh.sector_angle();
    // Inlet duct: an annular sector of radii r_in, r_in + t and length inlet_length.
    v += 0.5 * mesh.sector_angle() * ((s.r_in + t).powi(2) - s.r_in.powi(2)) * g.inlet_length;
    let expect = g.material.density * v;
    println!(
        "casing sector mass: FE {fe_mass:.9e} kg, analytic {expect:.9e} kg, rel. error {:.2e}",
        (fe_mass - expect) / expect
    );
    assert!(((fe_mass - expect) / expect).abs() < 1e-6);
}

#[test]
fn free_sectors_have_six_rigid_body_modes() {
    let casing = CasingGeometry::default().build().unwrap();
    let imp = ImpellerGeometry {
        elements_meridian: 4,
        elements_span: 1,
        elements_disk_depth: 1,
        elements_disk_side: 1,
        ..Default::default()
    }
    .build()
    .unwrap();
    for mesh in [casing, imp] {
        let mats = assemble_sector(&mesh, false).unwrap();
        let all: Vec<usize> = (0..mesh.n_dofs()).collect();
        let lam = gen_eigenvalues(&mats.stiffness, &mats.mass, &all);
        println!(
            "free sector, {} DOFs: λ1..7 = {:?}",
            mesh.n_dofs(),
            &lam[..7]
        );
        for l in &lam[..6] {
            assert!(l.abs() < 1e-6 * lam[6], "{l} vs 7th {}", lam[6]);
        }
        assert!(lam[6] > 1e-9 * lam[lam.len() - 1]);
    }
}

#[test]
fn blade_first_frequency_converges_under_refinement() {
    let mut rows = Vec::new();
    for f in [1usize, 2, 4] {
        let g = ImpellerGeometry {
            elements_meridian: 4 * f,
            elements_span: 2 * f,
            ..Default::default()
        };
        let mesh = g.build_blade_only().unwrap();
        let mats = assemble_sector(&mesh, false).unwrap();
        let lam = lowest_eigenvalue(&mats.stiffness, &mats.mass, &free_dofs(&mesh));
        rows.push((
            g.elements_meridian,
            g.elements_span,
            mesh.n_dofs(),
            lam.sqrt() / (2.0 * std::f64::consts::PI),
        ));
    }
    println!("blade clamped at the root: first frequency vs mesh");
    println!("  meridian x span   DOFs    f1 (Hz)");
    for (a, b, n, f) in &rows {
        println!("  {a:>4} x {b:<4}   {n:>6}   {f:.3}");
    }
    let d1 = (rows[1].3 - rows[0].3).abs();
    let d2 = (rows[2].3 - rows[1].3).abs();
    println!("  successive differences: {d1:.4} Hz, {d2:.4} Hz");
    assert!(d2 < d1, "differences must shrink");
}

#[test]
fn centrifugal_stiffening_raises_blade_frequency() {
    let g = ImpellerGeometry::default();
    let mesh = g.build_blade_only().unwrap();
    let mats = assemble_sector(&mesh, true).unwrap();
    let free = free_dofs(&mesh);
    let l0 = lowest_eigenvalue(&mats.stiffness, &mats.mass, &free);
    let omega = 3000.0; // rad/s (≈ 28 650 rpm)
    let k = &mats.stiffness + &(mats.centrifugal.as_ref().unwrap() * faer::Scale(omega * omega));
    let l1 = lowest_eigenvalue(&k, &mats.mass, &free);
    println!(
        "blade f1: {:.2} Hz at rest, {:.2} Hz at Ω = {omega} rad/s",
        l0.sqrt() / std::f64::consts::TAU,
        l1.sqrt() / std::f64::consts::TAU
    );
    assert!(l1 > l0);
}
