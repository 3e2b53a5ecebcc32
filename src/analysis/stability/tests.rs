//! Checks of the prediction against independent references: the free frequencies of the
//! structures, the Hamiltonian symmetry of the conservative case, a fixed-frame time
//! integration (Floquet), and the built-in models' simulated runaway speeds.

use super::time_domain::FixedFrame;
use super::*;
use crate::dynamics::structure::Structure;
use crate::fixtures::{SyntheticSpec, synthetic_rom};
use crate::model::rom::Damping;
use faer::c64;

/// A small pair: 3 blades with one tip node, a 7-sector casing (odd: no Nyquist harmonic) with
/// one node per sector, 2 modes per nodal diameter, modal damping `zeta`.
fn small_pair(zeta: f64) -> (CyclicRom, CyclicRom) {
    let spec = |c, n| SyntheticSpec {
        damping: Damping::Modal { ratio: zeta },
        boundary_stiffness: 2e7,
        ..SyntheticSpec::small(c, n, 1, 2)
    };
    (
        synthetic_rom(&spec(Component::Impeller, 3)),
        synthetic_rom(&spec(Component::Casing, 7)),
    )
}

/// Every eigenvalue of every class (residues 0..N_b, conjugate classes included) at `omega`.
fn all_eigenvalues(p: &Predictor<'_>, omega: f64) -> Vec<c64> {
    (0..p.impeller.n_sectors)
        .flat_map(|class| p.class_solution(omega, class).unwrap().waves)
        .map(|w| w.lambda)
        .collect()
}

fn critical_wave_speed(cas: &CyclicRom) -> (f64, usize) {
    Structure::new(cas, 0.0)
        .unwrap()
        .critical_wave_speed()
        .unwrap()
}

/// Both cases grow: above the critical wave speed (the moving-load wave, ND 3), and below it
/// at light damping (friction-induced mode coupling), so the comparison covers the sign of σ.
#[test]
fn growth_rates_equal_the_floquet_exponents_of_the_fixed_frame_time_integration() {
    let stiffness = 5e7;
    for (factor, mu, zeta) in [(3.0, 0.3, 0.01), (0.5, 0.3, 0.002)] {
        let (imp, cas) = small_pair(zeta);
        let (omega_c, k) = critical_wave_speed(&cas);
        let omega = factor * omega_c;
        let opts = StabilityOptions {
            friction: mu,
            contact: ContactModel::Spring {
                stiffness_n_per_m: stiffness,
            },
            mode_cutoff_hz: None,
            ..Default::default()
        };
        let p = Predictor::new(&imp, &cas, &opts).unwrap();
        let mut predicted: Vec<f64> = all_eigenvalues(&p, omega).iter().map(|l| l.re).collect();
        predicted.sort_by(|a, b| b.total_cmp(a));
        let fixed = FixedFrame::new(&imp, &cas, omega, stiffness, &opts);
        // ω_max h = 1/4: RK4's amplitude error (ωh)⁶/144 per step stays far below the tolerance.
        let steps = (4.0 * fixed.max_frequency() * TAU / omega).ceil() as usize;
        let floquet = fixed.floquet_growth_rates(steps);
        assert_eq!(predicted.len(), floquet.len());
        let worst = (predicted.iter().zip(&floquet))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!(
            "Ω = {factor} Ω_c = {omega:.1} rad/s (casing ND {k}), μ = {mu}, ζ = {zeta}, {steps} RK4 \
             steps: largest growth rates predicted {:.4?}, Floquet {:.4?}; worst difference over \
             all {} exponents {worst:.3e} 1/s",
            &predicted[..3],
            &floquet[..3],
            predicted.len()
        );
        assert!(predicted[0] > 10.0, "the case must grow: {}", predicted[0]);
        assert!((predicted[0] - floquet[0]).abs() < 1e-4 * predicted[0]);
        // RK4 damps or amplifies a mode of ωh = 1/4 by (ωh)⁶/144 per step: over one revolution
        // T the fastest modes' exponents can be off by `steps (1/4)⁶/144 / T`.
        let period = TAU / omega;
        let rk4_bound = steps as f64 * 0.25f64.powi(6) / 144.0 / period;
        assert!(worst < 2.0 * rk4_bound, "{worst} vs RK4 bound {rk4_bound}");
    }
}

/// Distinct natural frequencies (rad/s) of block `k` of `rom` at `omega` from the time
/// integrator's structure (real form: a complex harmonic's frequencies come in equal pairs).
fn free_frequencies(rom: &CyclicRom, omega: f64, k: usize) -> Vec<f64> {
    let st = Structure::new(rom, omega).unwrap();
    let b = &st.blocks[k];
    b.omega
        .iter()
        .step_by(if b.real { 1 } else { 2 })
        .copied()
        .collect()
}

/// Pairs each of `got` with the nearest unused of `want`; the largest mismatch.
fn worst_match(got: &[f64], want: &[f64]) -> f64 {
    assert_eq!(got.len(), want.len());
    let (mut a, mut b) = (got.to_vec(), want.to_vec());
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn without_contact_the_waves_are_the_free_modes_shifted_to_the_rotating_frame() {
    let (imp, cas) = small_pair(0.0);
    let omega = 1500.0;
    for opts in [
        StabilityOptions {
            held_rows: Some(vec![]),
            ..StabilityOptions::with_friction(0.3)
        },
        StabilityOptions {
            contact: ContactModel::Spring {
                stiffness_n_per_m: 1e-6,
            },
            mode_cutoff_hz: None,
            ..StabilityOptions::with_friction(0.3)
        },
    ] {
        let p = Predictor::new(&imp, &cas, &opts).unwrap();
        for class in 0..imp.n_sectors {
            let lambdas: Vec<c64> = (p.class_solution(omega, class).unwrap().waves)
                .iter()
                .map(|w| w.lambda)
                .collect();
            // Impeller: ±ω_b(Ω); casing harmonic k (signed, k ≡ class): kΩ ± ω_c,|k|.
            let nd = class.min(imp.n_sectors - class);
            let mut want: Vec<f64> = free_frequencies(&imp, omega, nd)
                .iter()
                .flat_map(|&w| [w, -w])
                .collect();
            for k in coupled::class_harmonics(class, imp.n_sectors, cas.n_sectors) {
                let shift = k as f64 * omega;
                for w in free_frequencies(&cas, 0.0, k.unsigned_abs() as usize) {
                    want.extend([shift + w, shift - w]);
                }
            }
            let got: Vec<f64> = lambdas.iter().map(|l| l.im).collect();
            let scale = want.iter().map(|w| w.abs()).fold(0.0, f64::max);
            let worst = worst_match(&got, &want);
            assert!(
                worst < 1e-7 * scale,
                "{:?} class {class}: {worst} of {scale}",
                opts.contact
            );
            assert!(lambdas.iter().all(|l| l.re.abs() < 1e-7 * scale));
        }
    }
}

/// Without friction or damping the rub is conservative and gyroscopic: each class's spectrum is
/// symmetric about the imaginary axis (λ ↦ −λ̄), and below the casing's critical wave speed,
/// where the rotating-frame energy is positive definite, it lies on the axis.
#[test]
fn frictionless_undamped_rub_is_hamiltonian_and_neutral_below_the_critical_wave_speed() {
    let (imp, cas) = small_pair(0.0);
    let (omega_c, _) = critical_wave_speed(&cas);
    for cutoff in [None, Some(1.5e3)] {
        let opts = StabilityOptions {
            mode_cutoff_hz: cutoff,
            ..StabilityOptions::with_friction(0.0)
        };
        let p = Predictor::new(&imp, &cas, &opts).unwrap();
        for factor in [0.5, 0.95, 2.0, 3.0] {
            for class in 0..imp.n_sectors {
                let l: Vec<c64> = (p.class_solution(factor * omega_c, class).unwrap().waves)
                    .iter()
                    .map(|w| w.lambda)
                    .collect();
                let scale = l.iter().map(|z| z.norm()).fold(0.0, f64::max);
                let tol = 1e-8 * scale;
                for z in &l {
                    let partner = l
                        .iter()
                        .map(|y| (y + z.conj()).norm())
                        .fold(f64::MAX, f64::min);
                    assert!(partner < tol, "{cutoff:?} {factor} class {class}: {z}");
                    if factor < 1.0 {
                        assert!(z.re.abs() < tol, "{cutoff:?} {factor} class {class}: {z}");
                    }
                }
            }
        }
    }
}

#[test]
fn a_stiffening_contact_spring_converges_to_the_bilateral_constraint() {
    let (imp, cas) = small_pair(0.01);
    let (omega_c, _) = critical_wave_speed(&cas);
    let omega = 2.0 * omega_c;
    let top = |contact| {
        let opts = StabilityOptions {
            contact,
            mode_cutoff_hz: None,
            ..StabilityOptions::with_friction(0.2)
        };
        let p = Predictor::new(&imp, &cas, &opts).unwrap();
        let mut l = all_eigenvalues(&p, omega);
        l.sort_by(|a, b| b.re.total_cmp(&a.re).then(a.im.total_cmp(&b.im)));
        l
    };
    let exact = top(ContactModel::Bilateral);
    let mut errors = Vec::new();
    for k in [1e8, 1e9, 1e10] {
        let spring = top(ContactModel::Spring {
            stiffness_n_per_m: k,
        });
        // The spring keeps one stiff contact mode per held tip that the constraint removes;
        // compare the least-damped waves.
        let err = (exact.iter().take(6))
            .map(|z| {
                spring
                    .iter()
                    .map(|y| (y - z).norm())
                    .fold(f64::MAX, f64::min)
            })
            .fold(0.0, f64::max);
        errors.push(err);
    }
    println!("distance of the spring's least-damped waves to the constraint's: {errors:?}");
    assert!(
        errors[1] < 0.2 * errors[0] && errors[2] < 0.2 * errors[1],
        "{errors:?}"
    );
}
