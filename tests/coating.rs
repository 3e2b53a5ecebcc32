//! Abradable coating in the time loop (paper §4, Fig. 11): η convergence, localized full
//! removal (hybrid coating / Lagrange contact), sensitivity to the coating moduli, stability
//! guard.

use rubscan::dynamics::abradable::CoatingMaterial;
use rubscan::dynamics::numerics::{Boundary, KernelChoice, Numerics};
use rubscan::dynamics::probes::SimulationOutput;
use rubscan::dynamics::scenario::{Case, CasingModel, CoatingCase, InitialVelocity, LobeLoad};
use rubscan::dynamics::{SimError, simulate};
use rubscan::fixtures::{SyntheticSpec, synthetic_rom};
use rubscan::model::rom::{Component, CyclicRom, Damping};

/// The small synthetic pair with 1 % modal damping. (Undamped, the fixture's highest modes
/// ring for ever and engrave a short-wavelength wear pattern: the η error constant roughly
/// doubles; 6000 vs 12000 then differ by 2.1 % instead of 1.2 %.)
fn pair() -> (CyclicRom, CasingModel) {
    let damped = |mut s: SyntheticSpec| {
        s.damping = Damping::Modal { ratio: 0.01 };
        synthetic_rom(&s)
    };
    let imp = damped(SyntheticSpec::small(Component::Impeller, 4, 2, 2));
    let cas = damped(SyntheticSpec::small(Component::Casing, 8, 3, 2));
    (imp, CasingModel::Flexible(cas))
}

/// Two-lobe casing distortion at the trailing edge (static 0.25 mm, ramp 3 ms, then released),
/// Ω = 1500 rad/s, μ = 0.1, h = 1e-7 s (the paper's step: a tip advances Ω r h = 3e-5 m per
/// step, a third of an element at η = 12000). `clearance` (m) is the radial clearance of each
/// contact row (leading edge, trailing edge) to the unworn coating surface.
fn case(material: CoatingMaterial, eta: usize, clearance: [f64; 2], duration: f64) -> Case {
    let c0 = SyntheticSpec::small(Component::Impeller, 4, 2, 2).clearance;
    let e = material.thickness;
    Case {
        omega: 1500.0,
        rotation: Default::default(),
        duration,
        friction: 0.1,
        load: Some(LobeLoad {
            lobes: 2,
            static_displacement: 2.5e-4,
            ramp_time: 3e-3,
            hold_time: 0.0,
        }),
        // Tips at (casing radius − e_abr − clearance).
        clearance_offset: clearance.iter().map(|c| c0 - e - c).collect(),
        casing_probes: vec![],
        probes: vec![],
        initial_velocity: InitialVelocity::default(),
        numerics: Numerics {
            time_step: Some(1e-7),
            kernel: KernelChoice::Fast,
            decimation: 20,
            boundary: Boundary::Mass,
            ..Default::default()
        },
        coating: Some(CoatingCase {
            eta,
            ..CoatingCase::new(material)
        }),
    }
}

fn run(c: &Case) -> SimulationOutput {
    let (imp, cas) = pair();
    simulate(c, &imp, &cas, None).unwrap()
}

/// Nominal material with a 0.5 mm layer.
fn half_mm() -> CoatingMaterial {
    CoatingMaterial {
        thickness: 0.5e-3,
        ..CoatingMaterial::nominal()
    }
}

/// Wear of `profile` (η elements over 2π) at angle `theta` (piecewise constant).
fn wear_at(profile: &[f64], theta: f64) -> f64 {
    let eta = profile.len();
    let i = ((theta / std::f64::consts::TAU) * eta as f64).floor() as usize;
    profile[i.min(eta - 1)]
}

/// Relative L2 distance of two sets of wear profiles (all rows), both resampled at the element
/// centres of a common grid of `n` angles.
fn rel_l2(a: &[Vec<f64>], b: &[Vec<f64>], n: usize) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (pa, pb) in a.iter().zip(b) {
        for k in 0..n {
            let th = std::f64::consts::TAU * (k as f64 + 0.5) / n as f64;
            let (x, y) = (wear_at(pa, th), wear_at(pb, th));
            num += (x - y) * (x - y);
            den += y * y;
        }
    }
    (num / den).sqrt()
}

/// Paper §4.2.1: η = 600, 3000, 6000, 12000 on the same scenario. The final wear profiles,
/// resampled on the 12000-element grid, converge: 6000 vs 12000 within 2 % (relative L2),
/// the coarse ones visibly farther (monotone in η, 600 at least 3× the 6000 distance).
#[test]
fn wear_profile_converges_in_eta() {
    let etas = [600, 3000, 6000, 12000];
    let outs: Vec<SimulationOutput> = etas
        .iter()
        .map(|&eta| run(&case(half_mm(), eta, [1e-4, 1e-4], 4e-3)))
        .collect();
    let wear: Vec<&Vec<Vec<f64>>> = outs
        .iter()
        .map(|o| &o.summary.coating.as_ref().unwrap().final_wear)
        .collect();
    let fine = *wear.last().unwrap();
    let co = outs[3].summary.coating.as_ref().unwrap();
    assert!(co.steps_per_element > 2.0, "{}", co.steps_per_element);
    // The scenario wears the coating substantially but does not remove it.
    assert!(co.max_wear_final > 0.2 * half_mm().thickness);
    assert!(co.max_wear_final < half_mm().thickness);
    assert_eq!(
        outs[3].summary.contact_steps, 0,
        "no direct contact expected"
    );
    let d: Vec<f64> = wear[..3].iter().map(|w| rel_l2(w, fine, 12000)).collect();
    println!(
        "relative L2 distance to η = 12000: 600 {:.4}, 3000 {:.4}, 6000 {:.4}",
        d[0], d[1], d[2]
    );
    assert!(d[2] <= 0.02, "6000 vs 12000: {}", d[2]);
    assert!(d[0] > d[1] && d[1] > d[2], "{d:?}");
    assert!(d[0] >= 3.0 * d[2], "{d:?}");
}

/// Paper §4.2.2: a thin coating (0.15 mm) and zero initial clearance at the trailing edge. The
/// casing distortion pushes the trailing-edge tips through the coating: the wear reaches e_abr
/// locally (elements fully removed), the forces there switch from the coating law to the
/// Lagrange multipliers (a multiplier is active only where the coating is gone), and the
/// residual penetration into the casing stays at the contact method's tolerance (≤ 1e-8 of the
/// vibration level, paper §3.3.3). The leading-edge row (0.1 mm clearance) is worn, not removed.
#[test]
fn localized_full_removal_hands_over_to_lagrange_contact() {
    let thin = CoatingMaterial {
        thickness: 0.15e-3,
        ..CoatingMaterial::nominal()
    };
    let e = thin.thickness;
    let out = run(&case(thin, 6000, [1e-4, 0.0], 4e-3));
    let co = out.summary.coating.as_ref().unwrap();
    let (le, te) = (0, 1);
    // Local full removal at the trailing edge only.
    assert!(co.removed_elements[te] > 0, "{:?}", co.removed_elements);
    assert!(
        co.removed_elements[te] < co.eta / 2,
        "removal must be local"
    );
    assert_eq!(co.removed_elements[le], 0);
    let te_profile = &co.final_wear[te];
    assert_eq!(te_profile.iter().fold(0.0f64, |m, &w| m.max(w)), e);
    assert_eq!(
        te_profile.iter().filter(|&&w| w == e).count(),
        co.removed_elements[te]
    );
    assert!(co.final_wear[le].iter().all(|&w| w < e));
    // Coating forces first, multipliers only once the coating is removed.
    let n = out.time.len();
    let lag = |k: usize| out.blade_normal_force.iter().any(|f| f[k] > 0.0);
    let abr = |k: usize| out.coating_blade_force.iter().any(|f| f[k] > 0.0);
    let first_lag = (0..n).find(|&k| lag(k)).expect("direct contact must occur");
    let first_abr = (0..n).find(|&k| abr(k)).expect("coating must be loaded");
    assert!(
        first_abr < first_lag,
        "coating at {first_abr}, Lagrange at {first_lag}"
    );
    for k in (0..n).filter(|&k| lag(k)) {
        assert_eq!(
            out.coating_max_wear[te][k], e,
            "multiplier active before removal at sample {k}"
        );
    }
    // Both kinds of force coexist at some sample (hybrid scenario, paper Fig. 13c).
    assert!((0..n).any(|k| lag(k) && abr(k)));
    assert!(
        out.summary.contact_steps > 10,
        "{}",
        out.summary.contact_steps
    );
    assert!(
        out.summary.max_residual_penetration <= 1e-8 * out.summary.peaks.blade_radial(),
        "residual {:e} vs level {:e}",
        out.summary.max_residual_penetration,
        out.summary.peaks.blade_radial()
    );
}

/// Paper §5.2: the (10 E, 10 K) coating gives a larger peak coating force on the blades than the
/// nominal one, which gives more than (E/10, K/10); the stiffer coating also wears less.
#[test]
fn peak_coating_force_is_monotone_in_the_moduli() {
    let res: Vec<(f64, f64)> = [0.1, 1.0, 10.0]
        .iter()
        .map(|&s| {
            let out = run(&case(half_mm().scaled(s), 6000, [1e-4, 1e-4], 4e-3));
            let co = out.summary.coating.unwrap();
            (co.peak_force, co.max_wear_final)
        })
        .collect();
    println!("peak coating force (N), max wear (m): {res:?}");
    assert!(res[0].0 < res[1].0 && res[1].0 < res[2].0, "{res:?}");
    assert!(res[0].1 > res[1].1 && res[1].1 > res[2].1, "{res:?}");
}

/// A coating too stiff for the explicit step is refused with a message naming the fix; a
/// bad tip-area count and an unknown JSON field are refused too.
#[test]
fn invalid_coating_cases_are_refused() {
    let (imp, cas) = pair();
    let mut c = case(half_mm(), 600, [1e-4, 1e-4], 1e-5);
    c.coating.as_mut().unwrap().tip_area = vec![1.0, 1.0];
    let err = simulate(&c, &imp, &cas, None).unwrap_err();
    assert!(matches!(err, SimError::InvalidCase(_)));
    assert!(err.to_string().contains("time_step"), "{err}");
    c.coating.as_mut().unwrap().tip_area = vec![1e-5];
    let err = simulate(&c, &imp, &cas, None).unwrap_err().to_string();
    assert!(err.contains("tip_area"), "{err}");
    let json = serde_json::json!({"material": half_mm(), "eta": 600, "colour": 1});
    assert!(serde_json::from_value::<CoatingCase>(json).is_err());
    let json = serde_json::json!({"material": half_mm()});
    let cc: CoatingCase = serde_json::from_value(json).unwrap();
    assert_eq!(cc, CoatingCase::new(half_mm()));
    assert_eq!(cc.eta, 6000);
}

/// The coating stage on the fast kernel (its coating correction fused with the next predictor,
/// the casing's channels synthesised by the harmonic kernel) against the dense reference kernel
/// (plain correction, full matrices): on the hybrid scenario of
/// `localized_full_removal_hands_over_to_lagrange_contact` (coating forces, removal, Lagrange
/// multipliers), the wear profiles, the peak coating force and the blade-force series agree to
/// round-off accumulated over 40 000 steps.
#[test]
fn fast_and_dense_kernels_agree_on_a_coated_run() {
    kernels_agree_on_a_coated_run(Boundary::Mass);
}

/// The same with a massless boundary at its default step: the coating force solved with the
/// contact on each kernel's static boundary flexibility.
#[test]
fn fast_and_dense_kernels_agree_on_a_coated_run_with_a_massless_boundary() {
    kernels_agree_on_a_coated_run(Boundary::Massless);
}

fn kernels_agree_on_a_coated_run(boundary: Boundary) {
    let thin = CoatingMaterial {
        thickness: 0.15e-3,
        ..CoatingMaterial::nominal()
    };
    let mut fast_case = case(thin, 6000, [1e-4, 0.0], 4e-3);
    if boundary == Boundary::Massless {
        fast_case.numerics.boundary = boundary;
        fast_case.numerics.time_step = None;
    }
    let mut dense_case = fast_case.clone();
    dense_case.numerics.kernel = KernelChoice::DenseReference;
    let (fast, dense) = (run(&fast_case), run(&dense_case));
    let (cf, cd) = (
        fast.summary.coating.as_ref().unwrap(),
        dense.summary.coating.as_ref().unwrap(),
    );
    // 1000 of the 40 000 steps at h = 1e-7 s.
    assert!(fast.summary.contact_steps > 10 && cf.coating_steps > fast.summary.n_steps / 40);
    let wear_diff = cf
        .final_wear
        .iter()
        .flatten()
        .zip(cd.final_wear.iter().flatten())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let force_scale = cd.peak_force;
    let force_diff = (fast.coating_blade_force.iter().flatten())
        .zip(dense.coating_blade_force.iter().flatten())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!(
        "{boundary:?}: h = {:.3e} s, max wear difference {wear_diff:e} m (e_abr {:e} m), peak force {:e} vs {:e} N, \
         max coating force difference {force_diff:e} N, removed {:?} vs {:?}",
        fast.summary.time_step,
        thin.thickness,
        cf.peak_force,
        cd.peak_force,
        cf.removed_elements,
        cd.removed_elements
    );
    assert!(wear_diff <= 1e-9 * thin.thickness, "{wear_diff:e}");
    // Observed: 4e-10 of the peak force.
    assert!(force_diff <= 1e-8 * force_scale, "{force_diff:e}");
    assert_eq!(cf.removed_elements, cd.removed_elements);
}
