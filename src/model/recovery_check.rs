//! Checks of the recovery rows of the built-in models' named nodes ([`super::recovery`])
//! against the full 360° assembled FE model (test only; kept apart from `recovery.rs`, which
//! the reduction imports, so that the checks may call the reduction).

use nalgebra::DMatrix;

use crate::model::cyclic::SectorTopology;
use crate::model::cyclic::{CyclicDofMap, is_real_harmonic};
use crate::model::fe::assemble_sector;
use crate::model::mesh::{CasingGeometry, ImpellerGeometry, SectorMesh};
use crate::model::reduction::{ReductionOptions, reduce_cyclic};
use crate::model::rom::CyclicRom;
use faer::Side;
use faer::prelude::Solve;
use nalgebra::Complex;
use std::f64::consts::TAU;

/// Static load of a single nodal diameter `k` on the contact DOFs of every sector,
/// `f_s = Re(f̃ e^{ikθ_s})`, solved (a) on the full 360° assembled FE model and (b) on the
/// ROM, whose named nodes are recovered as `u_s = Re(R_k x̃ e^{ikθ_s})`. Craig–Bampton is
/// exact for loads on its boundary, so the two agree to round-off. Returns the worst
/// relative difference over the named nodes, sectors, directions and nodal diameters.
fn worst_static_recovery_error(mesh: &SectorMesh, rotating: bool, modes: usize) -> f64 {
    let mats = assemble_sector(mesh, rotating).unwrap();
    let opts = ReductionOptions {
        modes_per_diameter: modes,
        recovery_points: mesh.named_nodes.clone(),
        ..ReductionOptions::default()
    };
    let rom: CyclicRom = reduce_cyclic(mesh, &mats, None, &opts).unwrap();
    assert_eq!(rom.recovery.nodes.len(), mesh.named_nodes.len());
    let topo = SectorTopology::of(mesh);
    let map = CyclicDofMap::new(&topo, &mesh.contact_nodes).unwrap();
    let (n_sec, ni, nb) = (mesh.n_sectors, map.n_independent(), map.n_first());
    let full = map
        .assemble_full(&mats.stiffness)
        .unwrap()
        .sp_cholesky(Side::Lower)
        .unwrap();
    let mut worst: f64 = 0.0;
    for k in 0..=n_sec / 2 {
        let real = is_real_harmonic(k, n_sec);
        // A deterministic, non-symmetric load pattern (real for the real harmonics).
        let f: Vec<Complex<f64>> = (0..nb)
            .map(|j| {
                let a = ((j * 7 + 3 * k + 1) % 11) as f64 - 5.0;
                let b = if real {
                    0.0
                } else {
                    ((j * 5 + k) % 13) as f64 - 6.0
                };
                Complex::new(a, b)
            })
            .collect();
        let theta = |s: usize| TAU * ((k * s) % n_sec) as f64 / n_sec as f64;
        let phase = |s: usize| Complex::from_polar(1.0, theta(s));
        let mut rhs = faer::Mat::<f64>::zeros(n_sec * ni, 1);
        for s in 0..n_sec {
            for (j, fj) in f.iter().enumerate() {
                rhs[(s * ni + j, 0)] = (fj * phase(s)).re;
            }
        }
        let u_full = full.solve(&rhs);

        let h = &rom.harmonics[k];
        let n = h.mass.size();
        let c = DMatrix::from_fn(n, n, |i, j| {
            Complex::new(h.stiffness[0].re[(i, j)], h.stiffness[0].im[(i, j)])
        });
        let mut load = nalgebra::DVector::zeros(n);
        for (j, fj) in f.iter().enumerate() {
            load[j] = *fj;
        }
        let x = c.lu().solve(&load).unwrap();
        let rows = &rom.recovery.rows[k];
        let r = DMatrix::from_fn(rows.re.nrows(), n, |i, j| {
            Complex::new(rows.re[(i, j)], rows.im[(i, j)])
        });
        let u_node = r * x;
        for (i, p) in mesh.named_nodes.iter().enumerate() {
            let reference: Vec<f64> = (0..n_sec)
                .flat_map(|s| {
                    let map = &map;
                    let u_full = &u_full;
                    (0..3).map(move |d| {
                        // Named nodes are independent: one term of coefficient 1.
                        let t = map.dof_terms(3 * p.node + d, k);
                        assert_eq!(t.len(), 1);
                        u_full[(s * ni + t[0].0, 0)]
                    })
                })
                .collect();
            let scale = reference.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(scale > 0.0, "{} does not move under the load", p.name);
            for s in 0..n_sec {
                for d in 0..3 {
                    let rec = (u_node[3 * i + d] * phase(s)).re;
                    let e = (rec - reference[3 * s + d]).abs() / scale;
                    worst = worst.max(e);
                }
            }
        }
    }
    worst
}

#[test]
fn built_in_named_nodes_recover_the_full_360_static_solution() {
    let impeller = ImpellerGeometry {
        n_blades: 4,
        ..ImpellerGeometry::default()
    }
    .build()
    .unwrap();
    let names: Vec<&str> = impeller
        .named_nodes
        .iter()
        .map(|p| p.name.as_str())
        .collect();
    assert_eq!(names, ["leading_edge_mid_span", "trailing_edge_mid_span"]);
    let e = worst_static_recovery_error(&impeller, true, 6);
    println!("impeller (4 blades): worst relative recovery error {e:.2e}");
    assert!(e < 1e-6, "impeller: {e}");

    let casing = CasingGeometry {
        n_sectors: 8,
        ..CasingGeometry::default()
    }
    .build()
    .unwrap();
    let e = worst_static_recovery_error(&casing, false, 4);
    println!("casing (8 sectors): worst relative recovery error {e:.2e}");
    assert!(e < 1e-6, "casing: {e}");
}

#[test]
fn named_nodes_sit_where_documented() {
    let g = ImpellerGeometry::default();
    let mesh = g.build().unwrap();
    let alpha = TAU / g.n_blades as f64;
    let (hub, tip) = (g.hub.point(0.0), g.tip(0.0));
    let le = mesh.nodes[mesh.named_nodes[0].node];
    let r = (le[0] * le[0] + le[1] * le[1]).sqrt();
    // Mid-span of the inlet edge, on the blade's mid-plane θ = α/2.
    assert!((r - 0.5 * (hub[0] + tip[0])).abs() < 1e-12);
    assert!((le[2] - 0.5 * (hub[1] + tip[1])).abs() < 1e-12);
    assert!((le[1].atan2(le[0]) - 0.5 * alpha).abs() < 1e-12);
    let te = mesh.nodes[mesh.named_nodes[1].node];
    let (hub, tip) = (
        g.hub.point(std::f64::consts::FRAC_PI_2),
        g.tip(std::f64::consts::FRAC_PI_2),
    );
    assert!((te[2] - 0.5 * (hub[1] + tip[1])).abs() < 1e-12);

    let c = CasingGeometry::default();
    let mesh = c.build().unwrap();
    let p = mesh.nodes[mesh.named_nodes[0].node];
    let phi = std::f64::consts::FRAC_PI_4;
    let (s, nf) = (c.shroud.point(phi), c.shroud.flow_normal(phi));
    // Outer skin: the shroud point moved by the thickness against the flow normal.
    assert!((p[0] - (s[0] - c.thickness * nf[0])).abs() < 1e-12);
    assert!((p[2] - (s[1] - c.thickness * nf[1])).abs() < 1e-12);
    assert_eq!(p[1], 0.0);
}
