//! Closest-point projection on the casing spline (paper §3.2, DESIGN.md §3): a warm-started
//! projection (the previous step's parameters, moved by ~1e-3 of a patch), a cold one, a patch
//! evaluation and the control points of the whole casing (N = 100 sectors, M = 5 nodes per
//! meridian, a cone).
//!
//! `cargo bench --bench projection`

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use rubscan::contact::projection::{DEFAULT_EPS_NR, closest_point};
use rubscan::contact::spline::{CasingSpline, SurfaceParam};

const N: usize = 100;
const M: usize = 5;

/// Nodes of a cone, sector-major, meridian index fastest: radius 0.3 + 0.05 s, axial 0.1 s.
fn cone_nodes() -> Vec<Vector3<f64>> {
    let mut nodes = Vec::with_capacity(N * M);
    for i in 0..N {
        let th = std::f64::consts::TAU * i as f64 / N as f64;
        for j in 0..M {
            let s = j as f64 / (M - 1) as f64;
            let r = 0.3 + 0.05 * s;
            nodes.push(Vector3::new(r * th.cos(), r * th.sin(), 0.1 * s));
        }
    }
    nodes
}

fn projection(c: &mut Criterion) {
    let nodes = cone_nodes();
    let mut sp = CasingSpline::new(N, M).expect("spline");
    sp.orient_toward_axis(&nodes).expect("orientation");
    let mut q = vec![Vector3::zeros(); sp.n_control()];
    sp.control_points(&nodes, &mut q).expect("control points");
    let param = |l: usize| SurfaceParam {
        i: l % N,
        j: l % (M - 1),
        u: (l as f64 * 0.618).fract(),
        v: (l as f64 * 0.414).fract(),
    };
    let targets: Vec<SurfaceParam> = (0..2000).map(param).collect();
    // Points 1 mm inside the surface, off the patch corners.
    let points: Vec<Vector3<f64>> = targets
        .iter()
        .map(|t| {
            let e = sp.evaluate(&q, t).expect("evaluation");
            e.s - 1e-3 * e.su.cross(&e.sv).normalize() * sp.normal_sign()
        })
        .collect();
    let warm: Vec<SurfaceParam> = targets
        .iter()
        .map(|t| SurfaceParam {
            u: (t.u + 1e-3).min(1.0),
            v: (t.v - 1e-3).max(0.0),
            ..*t
        })
        .collect();
    let mut g = c.benchmark_group("projection");
    g.bench_function("warm_2000_points", |b| {
        b.iter(|| {
            points.iter().zip(&warm).fold(0usize, |n, (x, w)| {
                n + closest_point(&sp, &q, *x, Some(*w), DEFAULT_EPS_NR)
                    .expect("projection")
                    .iterations
            })
        })
    });
    g.bench_function("cold_2000_points", |b| {
        b.iter(|| {
            points.iter().fold(0usize, |n, x| {
                n + closest_point(&sp, &q, *x, None, DEFAULT_EPS_NR)
                    .expect("projection")
                    .iterations
            })
        })
    });
    g.bench_function("control_points_N100_M5", |b| {
        let mut out = vec![Vector3::zeros(); sp.n_control()];
        b.iter(|| sp.control_points(&nodes, &mut out).expect("control points"))
    });
    g.finish();
}

criterion_group!(benches, projection);
criterion_main!(benches);
