//! The two kernels checked against each other: the fast modal kernel and the dense reference
//! advance the same structure through the same loads to the same states (free flight, loads,
//! corrections, inertial loads, energies), in the paper's formulation and with a massless
//! boundary. Beside both, since it needs both.

use crate::dynamics::dense::DenseKernel;
use crate::dynamics::kernel::StructureKernel;
use crate::dynamics::modal::ModalKernel;
use crate::dynamics::numerics::Boundary;
use crate::dynamics::structure::Structure;
use crate::fixtures::{SyntheticSpec, synthetic_rom};
use crate::model::rom::{Component, Damping};

fn check_free_flight(spec: SyntheticSpec, omega: f64) {
    let rom = synthetic_rom(&spec);
    for boundary in [Boundary::Mass, Boundary::Massless] {
        let st = Structure::new(&rom, omega).unwrap().with_boundary(boundary);
        check_structure(&st);
    }
}

fn check_structure(st: &Structure) {
    let h = 0.3 * st.stability_limit();
    let mut fast = ModalKernel::new(st, h).unwrap();
    let mut dense = DenseKernel::new(st, h);
    let n = st.n_modal;
    let v0: Vec<f64> = (0..n).map(|i| ((i * 7 % 13) as f64 - 6.0) * 0.01).collect();
    let pat: Vec<f64> = (0..st.n_sectors * st.n_boundary)
        .map(|i| ((i * 5 % 11) as f64 - 5.0) * 10.0)
        .collect();
    for k in [&mut fast as &mut dyn StructureKernel, &mut dense] {
        k.set_initial_velocity(&v0);
        k.set_load_pattern(&pat);
    }
    let nb = st.n_sectors * st.n_boundary;
    let mut scale = 0.0f64;
    let mut worst = 0.0f64;
    for step in 0..400 {
        let amp = (step as f64 * 0.05).sin();
        fast.predict(amp);
        dense.predict(amp);
        let force = |shift: usize| -> Vec<f64> {
            (0..nb).map(|i| ((i + shift) % 3) as f64 - 1.0).collect()
        };
        if step % 50 == 7 {
            // Same correction force on both (exercises A⁻¹ f), and an inertial load that the
            // fast kernel puts in the predictor it forms with the correction.
            let (f, g) = (force(step), force(step + 1));
            fast.add_inertial_load(&g);
            dense.add_inertial_load(&g);
            fast.correct_then_predict(&f, ((step + 1) as f64 * 0.05).sin());
            dense.correct(&f);
        } else if step % 50 == 21 {
            // An inertial load for the next predictor alone.
            let g = force(step);
            fast.add_inertial_load(&g);
            dense.add_inertial_load(&g);
        }
        for (a, b) in fast.boundary().iter().zip(dense.boundary()) {
            scale = scale.max(b.abs());
            worst = worst.max((a - b).abs());
        }
        fast.advance();
        dense.advance();
    }
    assert!(scale > 0.0);
    // The dense kernel inverts A = M/h² + D/2h; a massless boundary's static modes enter it at
    // ω_s² (mass ω²h²/2 over h², damping ω²h over 2h) beside the dynamic modes' 1/h², which
    // adds a factor (ω_s,max h)² ≈ 10²–10³ to its condition number, and to its round-off.
    let rel = if st.has_static_modes() { 1e-11 } else { 1e-12 };
    assert!(
        worst <= rel * scale,
        "fast vs dense: {worst:e} vs scale {scale:e}"
    );
    let (ef, ed) = (fast.energies(), dense.energies());
    // Round-off of quadratic forms scales with the energy of the state, not with one part
    // (with a massless boundary the last case keeps 6e-4 of its energy as kinetic).
    let energy = ed.kinetic + ed.strain.abs();
    assert!((ef.kinetic - ed.kinetic).abs() <= 1e-10 * energy);
    assert!((ef.strain - ed.strain).abs() <= 1e-10 * energy);
    let kmax = st.blocks.len();
    let (mut a, mut b) = (vec![0.0; kmax], vec![0.0; kmax]);
    fast.nd_strain_energy(&mut a);
    dense.nd_strain_energy(&mut b);
    let tot: f64 = b.iter().sum();
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 1e-9 * tot);
    }
    // Boundary flexibility: response of a unit force equals a column of A⁻¹_bb.
    let mut f = vec![0.0; nb];
    f[nb - 2] = 1.0;
    let (mut ra, mut rb) = (vec![0.0; nb], vec![0.0; nb]);
    fast.response(&f, &mut ra);
    dense.response(&f, &mut rb);
    let s = rb.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for (x, y) in ra.iter().zip(&rb) {
        assert!((x - y).abs() <= 1e-12 * s);
    }
}

/// In the paper's formulation every mode is inertial: an inertial load `f` given before the
/// predictor moves the predicted boundary as the correction `A⁻¹ f` of that predictor does,
/// in both kernels.
#[test]
fn an_inertial_load_without_static_modes_is_a_correction_of_the_predictor() {
    let rom = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 5, 2, 3));
    let st = Structure::new(&rom, 800.0).unwrap();
    let h = 0.3 * st.stability_limit();
    let nb = st.n_sectors * st.n_boundary;
    let v0: Vec<f64> = (0..st.n_modal).map(|i| (i % 5) as f64 * 0.01).collect();
    let f: Vec<f64> = (0..nb).map(|i| ((i * 7) % 5) as f64 - 2.0).collect();
    for dense in [false, true] {
        let make = |st: &Structure| -> Box<dyn StructureKernel> {
            if dense {
                Box::new(DenseKernel::new(st, h))
            } else {
                Box::new(ModalKernel::new(st, h).unwrap())
            }
        };
        let (mut loaded, mut corrected) = (make(&st), make(&st));
        for k in [&mut loaded, &mut corrected] {
            k.set_initial_velocity(&v0);
            k.predict(0.0);
            k.advance();
        }
        loaded.add_inertial_load(&f);
        loaded.predict(0.0);
        corrected.predict(0.0);
        corrected.correct(&f);
        let scale = corrected
            .boundary()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        for (a, b) in loaded.boundary().iter().zip(corrected.boundary()) {
            assert!((a - b).abs() <= 1e-12 * scale, "{a:e} vs {b:e}");
        }
        // Used up by its predictor.
        for k in [&mut loaded, &mut corrected] {
            k.advance();
            k.predict(0.0);
        }
        for (a, b) in loaded.boundary().iter().zip(corrected.boundary()) {
            assert!((a - b).abs() <= 1e-12 * scale, "{a:e} vs {b:e}");
        }
    }
}

#[test]
fn fast_and_dense_agree_in_free_flight() {
    let damped = |mut s: SyntheticSpec| {
        s.damping = Damping::Modal { ratio: 0.02 };
        s
    };
    check_free_flight(
        damped(SyntheticSpec::small(Component::Casing, 8, 3, 2)),
        0.0,
    );
    check_free_flight(
        damped(SyntheticSpec::small(Component::Impeller, 5, 2, 3)),
        800.0,
    );
    let mut s = SyntheticSpec::small(Component::Impeller, 4, 2, 2);
    s.damping = Damping::Rayleigh {
        alpha: 5.0,
        beta: 1e-7,
    };
    check_free_flight(s, 500.0);
    check_free_flight(SyntheticSpec::small(Component::Impeller, 1, 1, 1), 0.0);
}
