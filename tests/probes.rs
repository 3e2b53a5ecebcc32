//! Probes of contact and recovery nodes against independent formulations on a small
//! synthetic rub (flexible casing under a two-lobe load, friction), with both kernels:
//! - a recovery node whose rows select a contact node's boundary DOFs in every harmonic
//!   (the harmonic state through the recovery rows) equals that contact node's displacement
//!   (the kernel's boundary synthesis);
//! - per-node normal and friction forces sum to the per-blade series;
//! - a casing probe equals the legacy `casing_probes` series;
//! - gaps: never below the residual penetration, zero at nodes in contact, and their minimum
//!   equals the exact minimum gap on samples without contact.

use nalgebra::DMatrix;
use rubscan::dynamics::probes::{ProbeComponent, ProbeQuantity, ProbeSpec};
use rubscan::dynamics::structure::Structure;
use rubscan::dynamics::{
    Boundary, Case, CasingModel, InitialVelocity, KernelChoice, LobeLoad, Numerics,
    SimulationOutput, simulate,
};
use rubscan::fixtures::{SyntheticSpec, synthetic_rom};
use rubscan::model::rom::{ComplexRows, Component, CyclicRom, Recovery, RecoveryNode};

const OMEGA: f64 = 1500.0;
const N_BLADES: usize = 4;
const N_ROWS: usize = 2;

/// The impeller with a recovery node (id 901) whose rows are the boundary DOFs of contact
/// node 1, in every harmonic.
fn impeller() -> CyclicRom {
    let mut imp = synthetic_rom(&SyntheticSpec::small(
        Component::Impeller,
        N_BLADES,
        N_ROWS,
        2,
    ));
    let rows = imp
        .harmonics
        .iter()
        .map(|h| {
            let n = h.mass.size();
            let re = DMatrix::from_fn(3, n, |i, j| if j == 3 + i { 1.0 } else { 0.0 });
            ComplexRows {
                re,
                im: DMatrix::zeros(3, n),
            }
        })
        .collect();
    imp.recovery = Recovery {
        nodes: vec![RecoveryNode {
            id: 901,
            position: imp.contact_nodes[1].position,
            name: None,
        }],
        rows,
    };
    imp.validate().unwrap();
    imp
}

fn probe(q: ProbeQuantity, c: Option<ProbeComponent>) -> ProbeSpec {
    ProbeSpec {
        node: None,
        point: None,
        contact_node: None,
        blade: None,
        sector: None,
        row: None,
        quantity: q,
        component: c,
    }
}

/// Probe list: per blade and row normal force, tangential force, gap; per blade the recovery
/// node and contact node 1 along x, y, z and tangential; casing node (0, 2) radial.
fn probes() -> Vec<ProbeSpec> {
    use ProbeComponent::*;
    use ProbeQuantity::*;
    let mut v = Vec::new();
    for b in 0..N_BLADES {
        for r in 0..N_ROWS {
            for q in [NormalForce, TangentialForce, Gap] {
                v.push(ProbeSpec {
                    blade: Some(b),
                    row: Some(r),
                    ..probe(q, None)
                });
            }
        }
        for c in [X, Y, Z, Tangential] {
            v.push(ProbeSpec {
                node: Some(901),
                blade: Some(b),
                ..probe(Displacement, Some(c))
            });
            v.push(ProbeSpec {
                blade: Some(b),
                row: Some(1),
                ..probe(Displacement, Some(c))
            });
        }
    }
    v.push(ProbeSpec {
        sector: Some(0),
        row: Some(2),
        ..probe(Displacement, Some(Radial))
    });
    v
}

fn run(kernel: KernelChoice) -> SimulationOutput {
    let imp = impeller();
    let cas = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 3, 2));
    let limit = Structure::new(&imp, OMEGA)
        .unwrap()
        .stability_limit()
        .min(Structure::new(&cas, 0.0).unwrap().stability_limit());
    let case = Case {
        omega: OMEGA,
        rotation: Default::default(),
        duration: 4e-3,
        friction: 0.1,
        load: Some(LobeLoad {
            lobes: 2,
            static_displacement: 2.5e-4,
            ramp_time: 2e-3,
            hold_time: 0.0,
        }),
        clearance_offset: vec![],
        casing_probes: vec![[0, 2]],
        probes: probes(),
        initial_velocity: InitialVelocity::default(),
        numerics: Numerics {
            time_step: Some(0.5 * limit),
            newton_tolerance: 1e-10,
            kernel,
            decimation: 1,
            boundary: Boundary::Mass,
            ..Default::default()
        },
        coating: None,
    };
    simulate(&case, &imp, &CasingModel::Flexible(cas), None).unwrap()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn check(kernel: KernelChoice) {
    let out = run(kernel);
    assert!(out.summary.contact_steps > 0, "the case must rub");
    let per_blade = 3 * N_ROWS + 8;
    let at = |b: usize, i: usize| &out.probes[b * per_blade + i];
    let level = out
        .blade_le_radial
        .iter()
        .map(|s| max_abs(s))
        .fold(0.0, f64::max);
    assert!(level > 0.0);
    for b in 0..N_BLADES {
        // Recovery through the harmonic state = the contact node's boundary displacement.
        for c in 0..4 {
            let (rec, node) = (at(b, 3 * N_ROWS + 2 * c), at(b, 3 * N_ROWS + 2 * c + 1));
            assert!(max_abs(node) > 0.0);
            for (x, y) in rec.iter().zip(node) {
                assert!(
                    (x - y).abs() <= 1e-10 * level,
                    "blade {b} comp {c}: {x} vs {y}"
                );
            }
        }
        // Node forces sum to the blade's.
        for (i, series) in [&out.blade_normal_force, &out.blade_tangential_force]
            .iter()
            .enumerate()
        {
            let peak = max_abs(&series[b]);
            assert!(peak > 0.0, "blade {b} carries force {i}");
            for (t, total) in series[b].iter().enumerate() {
                let sum: f64 = (0..N_ROWS).map(|r| at(b, 3 * r + i)[t]).sum();
                assert!(
                    (sum - total).abs() <= 1e-12 * peak,
                    "blade {b} force {i} at {t}"
                );
            }
        }
    }
    let casing = out.probes.last().unwrap();
    assert_eq!(casing, &out.casing_radial[0]);
    check_gaps(&out, per_blade, level);
}

/// Gaps after the correction: at nodes in contact (λ > 0) as small as the residual
/// penetration allows, nowhere below it, and on samples without contact their minimum is the
/// exact minimum predicted gap (nothing was corrected).
fn check_gaps(out: &SimulationOutput, per_blade: usize, level: f64) {
    let nodes: Vec<(usize, usize)> = (0..N_BLADES)
        .flat_map(|b| (0..N_ROWS).map(move |r| (b, r)))
        .collect();
    let (mut free_samples, mut contacts) = (0, 0);
    let (mut worst_contact, mut worst_free) = (0.0f64, f64::INFINITY);
    for t in 0..out.time.len() {
        // The paper's check of the correction: 1e-8 of the vibration level.
        let tol = 1e-8 * level;
        let mut min_gap = f64::INFINITY;
        let mut any = false;
        for &(b, r) in &nodes {
            let gap = out.probes[b * per_blade + 3 * r + 2][t];
            let lambda = out.probes[b * per_blade + 3 * r][t];
            if lambda == 0.0 {
                worst_free = worst_free.min(gap);
            }
            if lambda > 0.0 {
                any = true;
                contacts += 1;
                worst_contact = worst_contact.max(gap.abs());
            }
            min_gap = min_gap.min(gap);
        }
        if !any && out.min_gap[t] >= 0.0 {
            free_samples += 1;
            assert!(
                (min_gap - out.min_gap[t]).abs() <= tol,
                "sample {t}: {min_gap} vs {}",
                out.min_gap[t]
            );
        }
    }
    assert!(
        free_samples > 0 && contacts > 0,
        "{free_samples} {contacts}"
    );
    eprintln!(
        "largest |gap| at a node in contact: {worst_contact:.3e} m = {:.3e} of the level {level:.3e} m; \
         smallest gap of a node without force: {worst_free:.3e} m",
        worst_contact / level
    );
}

#[test]
fn probes_agree_with_independent_series_fast_kernel() {
    check(KernelChoice::Fast);
}

#[test]
fn probes_agree_with_independent_series_dense_kernel() {
    check(KernelChoice::DenseReference);
}
