//! Every field of `numerics` acts on the run: a tiny synthetic contact case run through the
//! library API with one field changed at a time.

use rubscan::dynamics::structure::Structure;
use rubscan::dynamics::{
    Boundary, Case, CasingModel, InitialVelocity, KernelChoice, LobeLoad, Numerics,
    SimulationOutput, simulate,
};
use rubscan::fixtures::{SyntheticSpec, synthetic_rom};
use rubscan::model::rom::{Component, CyclicRom};

const OMEGA: f64 = 1500.0;

fn models() -> (CyclicRom, CasingModel, f64) {
    let imp = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 4, 2, 2));
    let cas = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 3, 2));
    let limit = Structure::new(&imp, OMEGA)
        .unwrap()
        .stability_limit()
        .min(Structure::new(&cas, 0.0).unwrap().stability_limit());
    (imp, CasingModel::Flexible(cas), limit)
}

/// A two-lobe casing load pushing the casing onto the blades (contact, friction).
fn run(numerics: Numerics) -> SimulationOutput {
    let (imp, casing, _) = models();
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
        probes: vec![],
        initial_velocity: InitialVelocity::default(),
        numerics,
        coating: None,
    };
    simulate(&case, &imp, &casing, None).unwrap()
}

fn base() -> Numerics {
    let (_, _, limit) = models();
    Numerics {
        time_step: Some(0.5 * limit),
        newton_tolerance: 1e-10,
        kernel: KernelChoice::Fast,
        decimation: 1,
        boundary: Boundary::Mass,
        mode_cutoff_hz: None,
        stop_on_runaway: true,
    }
}

/// Largest difference between the blade leading-edge displacements of two runs (m), over
/// their common samples.
fn max_diff(a: &SimulationOutput, b: &SimulationOutput) -> f64 {
    a.blade_le_radial
        .iter()
        .zip(&b.blade_le_radial)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f64::max)
}

fn level(a: &SimulationOutput) -> f64 {
    a.blade_le_radial
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()))
}

#[test]
fn the_reference_run_has_contact() {
    let out = run(base());
    assert!(out.summary.contact_steps > 0 && level(&out) > 0.0);
}

#[test]
fn time_step_sets_the_step_count_and_changes_the_response() {
    let a = run(base());
    let b = run(Numerics {
        time_step: base().time_step.map(|h| 0.5 * h),
        ..base()
    });
    assert_eq!(b.summary.time_step, 0.5 * a.summary.time_step);
    assert!(
        b.summary.n_steps >= 2 * a.summary.n_steps - 1,
        "{} vs {}",
        b.summary.n_steps,
        a.summary.n_steps
    );
    // Same instants every second sample of b: the responses differ by the time error.
    let at_same_times: f64 = a.blade_le_radial[0]
        .iter()
        .zip(b.blade_le_radial[0].iter().skip(1).step_by(2))
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    assert!(at_same_times > 0.0);
}

#[test]
fn newton_tolerance_changes_the_contact_solution() {
    let tight = run(base());
    let loose = run(Numerics {
        newton_tolerance: 1e-1,
        ..base()
    });
    let d = max_diff(&tight, &loose);
    assert!(d > 0.0, "a loose ε_NR left the run unchanged");
}

#[test]
fn kernels_differ_only_at_round_off() {
    let fast = run(base());
    let dense = run(Numerics {
        kernel: KernelChoice::DenseReference,
        ..base()
    });
    let d = max_diff(&fast, &dense);
    assert!(d > 0.0, "the kernel choice did not reach the run");
    assert!(d < 1e-6 * level(&fast), "{d} against {}", level(&fast));
}

#[test]
fn decimation_sets_the_number_of_samples() {
    let every = run(base());
    let fifth = run(Numerics {
        decimation: 5,
        ..base()
    });
    assert_eq!(every.time.len(), every.summary.n_steps);
    assert_eq!(fifth.time.len(), every.summary.n_steps / 5);
    // The kept samples are the same instants with the same values.
    assert_eq!(fifth.time[0], every.time[4]);
    assert_eq!(fifth.blade_le_radial[0][0], every.blade_le_radial[0][4]);
}

/// The massless boundary changes the run; its two kernels agree to round-off with contact and
/// friction, at a step beyond the paper formulation's limit.
#[test]
fn boundary_model_changes_the_run_and_its_kernels_agree() {
    let mass = run(base());
    let massless = run(Numerics {
        boundary: Boundary::Massless,
        ..base()
    });
    assert!(
        max_diff(&mass, &massless) > 0.0,
        "the boundary model did not reach the run"
    );
    let (_, _, limit) = models();
    let wide = Numerics {
        time_step: Some(1.2 * limit),
        boundary: Boundary::Massless,
        ..base()
    };
    let fast = run(wide.clone());
    assert!(fast.summary.contact_steps > 0);
    let dense = run(Numerics {
        kernel: KernelChoice::DenseReference,
        ..wide
    });
    let d = max_diff(&fast, &dense);
    assert!(d < 1e-6 * level(&fast), "{d} against {}", level(&fast));
}
