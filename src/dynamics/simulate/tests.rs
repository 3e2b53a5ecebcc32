//! Tests of the time loop: analytic solutions, energy, symmetry, convergence, kernels.
use super::casing_side::{add_casing_force_global, rotate_to_sector_frames};
use super::*;
use crate::dynamics::abradable::CoatingMaterial;
use crate::dynamics::numerics::Numerics;
use crate::dynamics::scenario::{InitialVelocity, LobeLoad, RigidShape, RigidSurface};
use crate::fixtures::{SyntheticSpec, synthetic_rom};
use crate::model::rom::{Component, ContactNode, Damping, HarmonicBlock, HermitianMatrix};
use nalgebra::DMatrix;

/// Virtual work: for any channel displacement δ, the load of a point force f satisfies
/// Σ F·δ = f·δS(param), in both channel modes, patches touching the ghost rows and the
/// closing line included. δS comes from CasingFrames::control_points (the forward map).
#[test]
fn casing_loads_are_the_transpose_of_the_surface_map() {
    let (n, m) = (7, 4);
    let sp = CasingSpline::new(n, m).unwrap();
    let rot: Vec<Matrix3<f64>> = (0..n)
        .map(|i| rot_z(i as f64 * 2.0 * PI / n as f64))
        .collect();
    let f = Vector3::new(0.7, -1.3, 2.1);
    let delta: Vec<f64> = (0..n * 3 * m)
        .map(|i| ((i * 7919 % 113) as f64 / 113.0 - 0.5) * 1e-3)
        .collect();
    for surface in [false, true] {
        let frames = CasingFrames {
            surface,
            rot: rot.clone(),
            rest_rows: vec![Vector3::zeros(); m],
            q_rest: vec![Vector3::zeros(); sp.n_control()],
        };
        let mut q = vec![Vector3::zeros(); sp.n_control()];
        let mut pnodes = vec![Vector3::zeros(); n * m];
        frames
            .control_points(&sp, &delta, &mut pnodes, &mut q)
            .unwrap();
        for (i, j, u, v) in [(0, 0, 0.2, 0.1), (n - 1, m - 2, 0.9, 0.8), (3, 1, 0.5, 0.4)] {
            let param = SurfaceParam { i, j, u, v };
            let (mut wu, mut wv) = (vec![0.0; n], vec![0.0; m]);
            let mut fc = vec![0.0; n * 3 * m];
            frames
                .add_force(&sp, &param, &f, (&mut wu, &mut wv), &mut fc)
                .unwrap();
            frames.finish_forces(&mut fc);
            let work: f64 = fc.iter().zip(&delta).map(|(a, b)| a * b).sum();
            let ds = sp.evaluate(&q, &param).unwrap().s;
            assert!(
                (work - f.dot(&ds)).abs() <= 1e-13 * f.norm() * 1e-3,
                "surface = {surface}, patch ({i}, {j}): {work:e} vs {:e}",
                f.dot(&ds)
            );
        }
    }
}

/// The casing share of a contact force is a partition of `f` over the data points: rotated
/// back to the global frame the node forces sum to `f` (the spline weights sum to 1).
#[test]
fn casing_force_distribution_sums_to_the_contact_force() {
    let (n, m) = (8, 3);
    let sp = CasingSpline::new(n, m).unwrap();
    let rot: Vec<Matrix3<f64>> = (0..n)
        .map(|i| rot_z(i as f64 * 2.0 * PI / n as f64))
        .collect();
    let (mut wu, mut wv) = (vec![0.0; n], vec![0.0; m]);
    let mut fc = vec![0.0; n * 3 * m];
    let f = Vector3::new(1.0, -2.0, 3.0);
    let param = SurfaceParam {
        i: 2,
        j: 1,
        u: 0.3,
        v: 0.6,
    };
    add_casing_force_global(&sp, &param, &f, &mut wu, &mut wv, &mut fc).unwrap();
    rotate_to_sector_frames(&rot, m, &mut fc);
    let mut total = Vector3::zeros();
    for (i, r) in rot.iter().enumerate() {
        for j in 0..m {
            let k = i * 3 * m + 3 * j;
            total += r * Vector3::new(fc[k], fc[k + 1], fc[k + 2]);
        }
    }
    assert!((total - f).norm() <= 1e-12 * f.norm(), "{total:?}");
}

fn small_pair(nb: usize) -> (CyclicRom, CyclicRom) {
    let imp = synthetic_rom(&SyntheticSpec::small(Component::Impeller, nb, 2, 2));
    let cas = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 3, 2));
    (imp, cas)
}

fn stable_h(imp: &CyclicRom, cas: &CyclicRom, omega: f64) -> f64 {
    let a = Structure::new(imp, omega).unwrap().stability_limit();
    let b = Structure::new(cas, 0.0).unwrap().stability_limit();
    0.5 * a.min(b)
}

fn lobe_case(h: f64, mu: f64, kernel: KernelChoice, eps: f64) -> Case {
    Case {
        omega: 1500.0,
        rotation: Default::default(),
        duration: 6e-3,
        friction: mu,
        load: Some(LobeLoad {
            lobes: 2,
            static_displacement: 2.5e-4,
            ramp_time: 3e-3,
            hold_time: 0.0,
        }),
        clearance_offset: vec![],
        casing_probes: vec![[0, 2], [2, 2]],
        probes: vec![],
        initial_velocity: InitialVelocity::default(),
        numerics: Numerics {
            time_step: Some(h),
            newton_tolerance: eps,
            kernel,
            decimation: 5,
            boundary: Boundary::Mass,
            mode_cutoff_hz: None,
            stop_on_runaway: true,
        },
        coating: None,
    }
}

fn max_abs(v: &[Vec<f64>]) -> f64 {
    v.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn max_diff(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn fast_and_dense_agree_on_a_contact_run_with_friction() {
    let (imp, cas) = small_pair(4);
    let h = stable_h(&imp, &cas, 1500.0);
    let casing = CasingModel::Flexible(cas);
    // Tight ε_NR so that both runs take the same Newton path (the kernels differ by round-off).
    let f = simulate(
        &lobe_case(h, 0.1, KernelChoice::Fast, 1e-12),
        &imp,
        &casing,
        None,
    )
    .unwrap();
    let d = simulate(
        &lobe_case(h, 0.1, KernelChoice::DenseReference, 1e-12),
        &imp,
        &casing,
        None,
    )
    .unwrap();
    assert!(
        f.summary.contact_steps > 20,
        "the scenario must rub: {} contact steps",
        f.summary.contact_steps
    );
    assert_eq!(f.summary.contact_steps, d.summary.contact_steps);
    for (a, b) in [
        (&f.blade_le_radial, &d.blade_le_radial),
        (&f.blade_te_radial, &d.blade_te_radial),
        (&f.casing_radial, &d.casing_radial),
        (&f.blade_normal_force, &d.blade_normal_force),
        (&f.blade_tangential_force, &d.blade_tangential_force),
    ] {
        let s = max_abs(b);
        assert!(s > 0.0);
        assert!(
            max_diff(a, b) <= 1e-9 * s,
            "fast vs dense: {:e} vs {:e}",
            max_diff(a, b),
            s
        );
    }
    // Residual penetrations (sample steps): the fast kernel re-projects on refreshed channels.
    let worst = f
        .residual_penetration
        .iter()
        .zip(&d.residual_penetration)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(d.summary.max_residual_penetration > 0.0);
    assert!(
        worst <= 1e-9 * max_abs(&d.blade_le_radial),
        "residual: {worst:e}"
    );
}

/// One radial oscillator (1-sector ROM, one node, no modes) released outward with speed v0
/// toward a rigid cylinder at clearance g0. Exact solution with the explicit Lagrange method
/// (perfectly plastic impact): u = (v0/ω) sin ωt until u = g0 at t_c, then u = g0 cos ω(t − t_c).
/// One blade of one contact node at radius `r0` (m): mass `m` (kg) and stiffness `k`
/// (N/m) in each of its three directions, undamped.
fn oscillator_rom(m: f64, k: f64, r0: f64) -> CyclicRom {
    let n = 3;
    CyclicRom {
        name: "oscillator".into(),
        component: Component::Impeller,
        n_sectors: 1,
        contact_nodes: vec![ContactNode {
            position: [r0, 0.0, 0.0],
            row: 0,
            id: None,
        }],
        harmonics: vec![HarmonicBlock {
            nodal_diameter: 0,
            n_modes: 0,
            mass: HermitianMatrix::real(DMatrix::identity(n, n) * m),
            stiffness: [
                HermitianMatrix::real(DMatrix::identity(n, n) * k),
                HermitianMatrix::real(DMatrix::zeros(n, n)),
                HermitianMatrix::real(DMatrix::zeros(n, n)),
            ],
        }],
        modal_data: vec![],
        damping: Damping::Modal { ratio: 0.0 },
        provenance: serde_json::Value::Null,
        recovery: Default::default(),
        blade_modes: Default::default(),
    }
}

/// A rigid cylinder of radius `r` (m) about the z axis, 64 sectors.
fn rigid_cylinder(r: f64) -> CasingModel {
    CasingModel::Rigid(RigidSurface {
        n_sectors: 64,
        meridian: vec![[r, -0.01], [r, 0.01]],
        shape: RigidShape::Lobes {
            lobes: 0,
            amplitude: 0.0,
        },
    })
}

/// A case without rotation, load or friction, at rest but for the impeller's boundary
/// velocity `v` (m/s, sector-major): `duration` (s) with `numerics` and `coating`.
fn thrown_case(
    v: Vec<f64>,
    duration: f64,
    numerics: Numerics,
    coating: Option<CoatingCase>,
) -> Case {
    Case {
        omega: 0.0,
        rotation: Default::default(),
        duration,
        friction: 0.0,
        load: None,
        clearance_offset: vec![],
        casing_probes: vec![],
        probes: vec![],
        initial_velocity: InitialVelocity {
            impeller: Some(v),
            casing: None,
        },
        numerics,
        coating,
    }
}

/// The tip of [`spring_mass_rom`] on a massless boundary, thrown outward at `v0` (m/s) from
/// rest position, at rest otherwise: `duration` (s) at step `h` (s), with `coating`.
fn thrown_tip_case(v0: f64, duration: f64, h: f64, coating: Option<CoatingCase>) -> Case {
    let numerics = Numerics {
        time_step: Some(h),
        decimation: 1,
        newton_tolerance: 1e-12,
        boundary: Boundary::Massless,
        ..Default::default()
    };
    thrown_case(
        vec![v0, 0.0, 0.0, v0, 0.0, 0.0],
        duration,
        numerics,
        coating,
    )
}

#[test]
fn single_oscillator_impacting_a_rigid_cylinder_matches_the_analytic_solution() {
    let (m, k) = (0.1, 4e6);
    let r0 = 0.2;
    let g0 = 1e-4;
    let rom = oscillator_rom(m, k, r0);
    let casing = rigid_cylinder(r0 + g0);
    let w = (k / m).sqrt();
    let h = 1e-3 / w;
    let v0 = 2.0 * g0 * w;
    let numerics = Numerics {
        time_step: Some(h),
        decimation: 1,
        newton_tolerance: 1e-12,
        boundary: Boundary::Mass,
        ..Default::default()
    };
    let case = thrown_case(vec![v0, 0.0, 0.0], 3.0 * 2.0 * PI / w, numerics, None);
    let out = simulate(&case, &rom, &casing, None).unwrap();
    let tc = (g0 * w / v0).asin() / w;
    // The discrete impact spreads over ≤ 2 steps: a timing error ≤ 2h, i.e. ≤ 2 ωh g0 in u.
    let tol = 5.0 * w * h * g0;
    let mut worst = 0.0f64;
    for (t, u) in out.time.iter().zip(&out.blade_le_radial[0]) {
        let exact = if *t < tc {
            v0 / w * (w * t).sin()
        } else {
            g0 * (w * (t - tc)).cos()
        };
        worst = worst.max((u - exact).abs());
        assert!(*u <= g0 * (1.0 + 1e-9), "penetration at t = {t}: u = {u}");
    }
    assert!(worst <= tol, "max error {worst:e} > {tol:e}");
    assert!(
        out.summary.contact_steps >= 1 && out.summary.contact_steps <= 4,
        "{} contact steps",
        out.summary.contact_steps
    );
    // Energy after the impact: only the strain energy at the wall remains, ½ k g0².
    let e_end =
        out.impeller_energy.kinetic.last().unwrap() + out.impeller_energy.strain.last().unwrap();
    assert!((e_end - 0.5 * k * g0 * g0).abs() < 1e-2 * 0.5 * k * g0 * g0);
}

/// A massless contact node tied by a spring `k_c` to a mass `m` on a spring `k₀` (each
/// direction), as a two-node ROM whose boundary node carries `m_b = 10⁻⁸ m`: boundary
/// first, the mass as its "modal" part.
fn spring_mass_rom(m: f64, k0: f64, kc: f64, r0: f64) -> CyclicRom {
    let mb = 1e-8 * m;
    let mut rom = oscillator_rom(m, k0, r0);
    let (mut mass, mut stiffness) = (DMatrix::zeros(6, 6), DMatrix::zeros(6, 6));
    for d in 0..3 {
        mass[(d, d)] = mb;
        mass[(3 + d, 3 + d)] = m;
        stiffness[(d, d)] = kc;
        stiffness[(3 + d, 3 + d)] = kc + k0;
        stiffness[(d, 3 + d)] = -kc;
        stiffness[(3 + d, d)] = -kc;
    }
    let h = &mut rom.harmonics[0];
    h.n_modes = 3;
    h.mass = HermitianMatrix::real(mass);
    h.stiffness[0] = HermitianMatrix::real(stiffness);
    for k in &mut h.stiffness[1..] {
        *k = HermitianMatrix::real(DMatrix::zeros(6, 6));
    }
    rom
}

/// [`spring_mass_rom`] thrown outward at `v₀` against a rigid cylinder `g₀` away, with a
/// massless boundary, at a step 20 times its mass formulation's limit. Exact motion: free
/// flight at `ω₀ = √(k₀/m)` (the unloaded spring carries the node with the mass) until the
/// node reaches `g₀`; contact, the node held at `g₀` and the mass at `ω₁ = √((k₀ + k_c)/m)`
/// about `x_e = k_c g₀/(k₀ + k_c)`, while `k_c (x − g₀) ≥ 0`; free flight again. Without
/// damping or friction the energy (the mass's, and the spring's at the held node) never
/// grows.
#[test]
fn massless_boundary_oscillator_against_a_rigid_wall_matches_the_analytic_solution() {
    let (m, k0, kc, r0, g0) = (0.1, 4e6, 1.2e7, 0.2, 1e-4);
    let rom = spring_mass_rom(m, k0, kc, r0);
    let casing = rigid_cylinder(r0 + g0);
    let (w0, w1) = ((k0 / m).sqrt(), ((k0 + kc) / m).sqrt());
    let v0 = 2.0 * g0 * w0;
    let st = Structure::new(&rom, 0.0).unwrap();
    let massless = st.clone().with_boundary(Boundary::Massless);
    let h = 0.02 / w1;
    assert!(h > 20.0 * st.stability_limit() && h < 0.01 * massless.stability_limit());
    let case = thrown_tip_case(v0, 2.0 * 2.0 * PI / w0, h, None);
    let out = simulate(&case, &rom, &casing, None).unwrap();
    // Phase times: reach the wall at t₁, leave it 2 atan2(b, a)/ω₁ later; then free flight
    // from phase π − ω₀t₁ to 2π (back at 0 with +v₀): the period.
    let t1 = (g0 * w0 / v0).asin() / w0;
    let v1 = v0 * (w0 * t1).cos();
    let xe = kc * g0 / (k0 + kc);
    let (a, b) = (g0 - xe, v1 / w1);
    let t2 = t1 + 2.0 * b.atan2(a) / w1;
    let period = t2 + (PI + w0 * t1) / w0;
    let exact = |t: f64| {
        let t = t % period;
        if t < t1 {
            v0 / w0 * (w0 * t).sin()
        } else if t < t2 {
            g0
        } else {
            v0 / w0 * (PI - w0 * t1 + w0 * (t - t2)).sin()
        }
    };
    // Timing errors of a step at the switches: a few ω₁ h g₀ (ω₁ h = 0.02).
    let tol = 5.0 * w1 * h * g0;
    let mut worst = 0.0f64;
    for (t, u) in out.time.iter().zip(&out.blade_le_radial[0]) {
        worst = worst.max((u - exact(*t)).abs());
        assert!(*u <= g0 * (1.0 + 1e-9), "penetration at t = {t}: u = {u}");
    }
    assert!(worst <= tol, "max error {worst:e} > {tol:e}");
    assert!(out.summary.contact_steps > 10);
    assert!(out.summary.max_residual_penetration <= 1e-12 * g0);
    let e = &out.impeller_energy;
    let total: Vec<f64> = e
        .kinetic
        .iter()
        .zip(&e.strain)
        .map(|(k, s)| k + s)
        .collect();
    for w in total.windows(2) {
        assert!(
            w[1] <= w[0] * (1.0 + 1e-12),
            "energy grew: {} -> {}",
            w[0],
            w[1]
        );
    }
}

/// [`spring_mass_rom`] with a massless boundary thrown outward at `v₀` into an abradable
/// coating (nominal material, tip area 1e-6 m²) on a rigid cylinder, the tip `g₀` below
/// the unworn surface at rest. The element is stiffer than the boundary is flexible
/// (`k w = 1.17` with `w = 1/k_c + 1/k₀`: the explicit coating force would not be stable), so
/// its force is solved with the boundary's static response. At the end of every step the
/// recorded force λ, the tip's depth below the unworn surface `p = u − g₀` and the wear
/// `Δ` meet the element's law: `λ = k (p − Δ)` when it pushes, never above the hardened
/// yield force `λ_Y + K' Δ` and on it whenever the wear grew; no force off the worn
/// surface.
#[test]
fn massless_boundary_tip_thrown_into_a_coating_meets_the_element_law_every_step() {
    let mat = CoatingMaterial::nominal();
    let (out, [g0, area, k0, kc]) = thrown_into_coating(mat);
    let e = mat.thickness;
    let (k, kh) = (mat.young * area / e, mat.plastic_modulus * area / e);
    let yield0 = mat.yield_stress * area;
    assert!(k * (1.0 / kc + 1.0 / k0) > 1.0);
    let (force, wear) = (&out.coating_blade_force[0], &out.coating_max_wear[0]);
    // The solve closes the element's law to the gap tolerance (2e-13 m at r₀).
    let tol = k * 1e-12 + 1e-9 * yield0;
    let (mut plastic_steps, mut elastic_steps) = (0, 0);
    for n in 1..out.time.len() {
        let (l, p, wn) = (force[n], out.blade_le_radial[0][n] - g0, wear[n]);
        let limit = yield0 + kh * wn;
        assert!(
            l <= limit + tol,
            "step {n}: λ {l} above the yield force {limit}"
        );
        if l > 0.0 {
            let elastic = k * (p - wn);
            assert!(
                (l - elastic).abs() <= tol,
                "step {n}: λ {l} vs k (p − Δ) {elastic}"
            );
            if wn > wear[n - 1] {
                assert!(
                    (l - limit).abs() <= tol,
                    "step {n}: wear grew off the yield force"
                );
                plastic_steps += 1;
            } else {
                elastic_steps += 1;
            }
        } else {
            assert!(
                p <= wn + 1e-12,
                "step {n}: tip {p:e} below the worn surface {wn:e}"
            );
        }
    }
    eprintln!(
        "{plastic_steps} plastic and {elastic_steps} elastic coating steps, final wear {:.4e} m",
        wear.last().unwrap()
    );
    assert!(plastic_steps > 10 && elastic_steps > 10);
    assert!(*wear.last().unwrap() > 10.0 * yield0 / k);
    assert_eq!(
        out.summary.contact_steps, 0,
        "the tip never reaches the casing"
    );
}

/// The run of [`massless_boundary_tip_thrown_into_a_coating_meets_the_element_law_every_step`]
/// with coating `mat`, and its `[g₀, tip area, k₀, k_c]`.
fn thrown_into_coating(mat: CoatingMaterial) -> (SimulationOutput, [f64; 4]) {
    let (m, k0, kc, r0, g0, area) = (0.1, 4e6, 1.2e7, 0.2, 1e-4, 1e-6);
    let e = mat.thickness;
    let rom = spring_mass_rom(m, k0, kc, r0);
    let casing = rigid_cylinder(r0 + g0 + e);
    let (w0, w1) = ((k0 / m).sqrt(), ((k0 + kc) / m).sqrt());
    let v0 = 3.0 * g0 * w0;
    let coating = CoatingCase {
        eta: 600,
        tip_area: vec![area],
        ..CoatingCase::new(mat)
    };
    let case = thrown_tip_case(v0, 2.0 * 2.0 * PI / w0, 0.02 / w1, Some(coating));
    let out = simulate(&case, &rom, &casing, None).unwrap();
    (out, [g0, area, k0, kc])
}

/// The same tip into a coating too thin to stop it (50 µm): the element is worn through,
/// removed, and the tip is then a Lagrange contact with the casing, which it never
/// penetrates.
#[test]
fn massless_boundary_tip_wearing_through_a_coating_switches_to_lagrange_contact() {
    let mat = CoatingMaterial {
        thickness: 5e-5,
        ..CoatingMaterial::nominal()
    };
    let (out, [g0, ..]) = thrown_into_coating(mat);
    let casing_at = g0 + mat.thickness;
    let co = out.summary.coating.as_ref().unwrap();
    eprintln!(
        "contact steps {}, coating steps {}, removed {:?}, residual {:.2e} m",
        out.summary.contact_steps,
        co.coating_steps,
        co.removed_elements,
        out.summary.max_residual_penetration
    );
    assert!(co.coating_steps > 0 && out.summary.contact_steps > 0);
    assert_eq!(co.removed_elements, vec![1]);
    assert_eq!(co.max_wear_final, mat.thickness);
    for (t, u) in out.time.iter().zip(&out.blade_le_radial[0]) {
        assert!(
            *u <= casing_at + 1e-12,
            "t = {t}: tip {u:e} beyond the casing"
        );
    }
    assert!(
        out.blade_le_radial[0]
            .iter()
            .any(|u| (u - casing_at).abs() < 1e-12)
    );
    assert!(out.summary.max_residual_penetration <= 1e-12 * casing_at);
}

/// A one-node blade (mass m, stiffness k in every direction) at rest, sweeping past one
/// Gaussian lobe of an imposed-gap casing without friction. The exact motion alternates
/// free flight `u = u₀ cos ω(t−t₀) + v₀/ω sin ω(t−t₀)` and contact `u = g(t)` while the
/// contact force `λ = −m g̈ − k g` stays ≥ 0 (u outward, gap g along e_r); the switches are
/// found by bisection on those closed forms, independently of the time stepper.
#[test]
fn single_oscillator_against_an_imposed_gap_matches_the_analytic_solution() {
    use crate::contact::{GapDirection, GapProfile, ImposedGap};
    let (m, k, r0, gm): (f64, f64, f64, f64) = (0.1, 4e6, 0.2, 1e-4);
    let w = (k / m).sqrt();
    let omega = w / 4.0;
    let profile = GapProfile::GaussianLobes {
        mean_gap: gm,
        width: 0.15,
        lobes: 1,
    };
    let rom = oscillator_rom(m, k, r0);
    let casing = CasingModel::ImposedGap(ImposedGap {
        profile: profile.clone(),
        direction: GapDirection::Radial,
    });
    let h = 2e-3 / w;
    let case = Case {
        omega,
        rotation: Default::default(),
        duration: 2.0 * PI / omega,
        friction: 0.0,
        load: None,
        clearance_offset: vec![],
        casing_probes: vec![],
        probes: vec![],
        initial_velocity: InitialVelocity::default(),
        numerics: Numerics {
            time_step: Some(h),
            decimation: 1,
            boundary: Boundary::Mass,
            ..Default::default()
        },
        coating: None,
    };
    let out = simulate(&case, &rom, &casing, None).unwrap();
    // The exact motion.
    let g = |t: f64| profile.at(omega * t).0;
    let gdot = |t: f64| omega * profile.at(omega * t).1;
    let force = |t: f64| {
        let d = 1e-4 / w;
        -m * (gdot(t + d) - gdot(t - d)) / (2.0 * d) - k * g(t)
    };
    let bisect = |f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64| {
        for _ in 0..100 {
            let c = 0.5 * (a + b);
            if (f(a) > 0.0) == (f(c) > 0.0) {
                a = c
            } else {
                b = c
            }
        }
        0.5 * (a + b)
    };
    // Pieces: (start time, Some((u0, v0)) for free flight, None for contact).
    let mut pieces: Vec<(f64, Option<(f64, f64)>)> = vec![(0.0, Some((0.0, 0.0)))];
    let free = |t0: f64, (u0, v0): (f64, f64), t: f64| {
        u0 * (w * (t - t0)).cos() + v0 / w * (w * (t - t0)).sin()
    };
    let dt = h / 20.0;
    let mut t = 0.0;
    while t < case.duration {
        let (t0, state) = *pieces.last().unwrap();
        let t1 = t + dt;
        match state {
            Some(s0) if free(t0, s0, t1) > g(t1) => {
                let tc = bisect(&|x| free(t0, s0, x) - g(x), t, t1);
                pieces.push((tc, None));
            }
            None if force(t1) < 0.0 => {
                let tr = bisect(&force, t, t1);
                pieces.push((tr, Some((g(tr), gdot(tr)))));
            }
            _ => {}
        }
        t = t1;
    }
    let exact = |t: f64| {
        let (t0, state) = *pieces.iter().rev().find(|p| p.0 <= t).unwrap();
        state.map_or_else(|| g(t), |s0| free(t0, s0, t))
    };
    let contacts = pieces.iter().filter(|p| p.1.is_none()).count();
    assert!(contacts >= 1, "the lobe must push the node: {pieces:?}");
    // The position is continuous at both switches (the node meets the lobe from rest and
    // leaves it where λ falls to 0) and the constraint is linear, enforced exactly at each
    // step: central differences keep their second order, an error O((ω h)²) of the motion.
    let tol = 5.0 * (w * h).powi(2) * gm;
    let mut worst = 0.0f64;
    for (t, u) in out.time.iter().zip(&out.blade_le_radial[0]) {
        worst = worst.max((u - exact(*t)).abs());
        assert!(
            *u <= g(*t) + 1e-12 * gm,
            "penetration at t = {t}: u = {u}, g = {}",
            g(*t)
        );
    }
    println!(
        "{} exact pieces, max error {worst:.3e} m (tolerance {tol:.3e} m)",
        pieces.len()
    );
    assert!(
        worst <= tol,
        "max error {worst:e} > {tol:e}; pieces {pieces:?}"
    );
    assert!(out.summary.max_residual_penetration <= 1e-12 * gm);
    // The node was pushed in by about g_m (the lobe's centre is at −g_m).
    let deepest = out.blade_le_radial[0].iter().copied().fold(0.0, f64::min);
    assert!(deepest < -0.9 * gm, "{deepest}");
}

#[test]
fn time_step_above_the_stability_limit_is_refused() {
    let (imp, cas) = small_pair(4);
    let h = 2.0 * stable_h(&imp, &cas, 1500.0) * 1.001;
    let err = simulate(
        &lobe_case(h, 0.0, KernelChoice::Fast, 1e-5),
        &imp,
        &CasingModel::Flexible(cas),
        None,
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, SimError::Unstable { .. }));
    assert!(
        msg.contains("stability limit") && msg.contains("steps"),
        "{msg}"
    );
    assert!(msg.contains(&format!("{h:.4e}")), "{msg}");
}

#[test]
fn energy_never_grows_with_contacts_and_no_damping_or_friction() {
    energy_never_grows(Boundary::Mass);
}

/// The same with a massless boundary on both structures (flexible casing), at a tenth of
/// its own, larger, stability limit (#24).
#[test]
fn energy_never_grows_with_a_massless_boundary() {
    energy_never_grows(Boundary::Massless);
}

fn energy_never_grows(boundary: Boundary) {
    let (imp, cas) = small_pair(4);
    // Per-step penetrations d* ∝ h: with h = limit/20 the O(κ d*²) error of linearizing the
    // curved constraint each step is below round-off (at h = limit/2 it reaches ~1e-7 of E).
    let limit = |rom, omega| {
        (Structure::new(rom, omega).unwrap().with_boundary(boundary)).stability_limit()
    };
    let h = 0.05 * limit(&imp, 0.0).min(limit(&cas, 0.0));
    let st = Structure::new(&imp, 0.0).unwrap();
    // Every tip node of every blade thrown outward. A massless boundary keeps only the
    // part of that velocity the dynamic modes carry: thrown harder to reach the casing.
    let scale = if boundary.is_mass() { 1.0 } else { 100.0 };
    let mut v = vec![0.0; st.n_modal];
    for s in 0..4 {
        for j in 0..2 {
            v[s * 6 + 3 * j] = scale * (30.0 + 10.0 * s as f64);
        }
    }
    let numerics = Numerics {
        time_step: Some(h),
        decimation: 1,
        boundary,
        ..Default::default()
    };
    let case = thrown_case(v, 3e-3, numerics, None);
    let out = simulate(&case, &imp, &CasingModel::Flexible(cas), None).unwrap();
    assert!(
        out.summary.contact_steps > 5,
        "{boundary:?}: {} contact steps",
        out.summary.contact_steps
    );
    let e: Vec<f64> = (0..out.time.len())
        .map(|i| {
            out.impeller_energy.kinetic[i]
                + out.impeller_energy.strain[i]
                + out.casing_energy.kinetic[i]
                + out.casing_energy.strain[i]
        })
        .collect();
    for w in e.windows(2) {
        assert!(
            w[1] <= w[0] * (1.0 + 1e-13),
            "{boundary:?}: energy grew: {} -> {}",
            w[0],
            w[1]
        );
    }
    assert!(
        e.last().unwrap() < &(0.999 * e[0]),
        "impacts must dissipate"
    );
}

#[test]
fn two_lobe_scenario_stays_symmetric_under_rotation_by_pi() {
    let (imp, cas) = small_pair(4);
    let h = stable_h(&imp, &cas, 1500.0);
    let out = simulate(
        &lobe_case(h, 0.1, KernelChoice::Fast, 1e-5),
        &imp,
        &CasingModel::Flexible(cas),
        None,
    )
    .unwrap();
    assert!(out.summary.contact_steps > 0);
    let s = max_abs(&out.blade_le_radial);
    for b in 0..2 {
        let d = max_diff(
            &out.blade_le_radial[b..b + 1],
            &out.blade_le_radial[b + 2..b + 3],
        );
        assert!(d <= 1e-9 * s, "blade {b} vs {}: {d:e} (scale {s:e})", b + 2);
        let f = max_diff(
            &out.blade_normal_force[b..b + 1],
            &out.blade_normal_force[b + 2..b + 3],
        );
        assert!(f <= 1e-9 * max_abs(&out.blade_normal_force));
    }
}

#[test]
fn convergence_in_h_eps_nr_and_friction() {
    let (imp, cas) = small_pair(4);
    let h = stable_h(&imp, &cas, 1500.0) / 10.0;
    let casing = CasingModel::Flexible(cas);
    let run = |h: f64, mu: f64, eps: f64| {
        simulate(
            &lobe_case(h, mu, KernelChoice::Fast, eps),
            &imp,
            &casing,
            None,
        )
        .unwrap()
    };
    let base = run(h, 0.0, 1e-5);
    assert!(base.summary.contact_steps > 0);
    // ε_NR = 1e-5 and 1e-10 superimposed.
    let tight = run(h, 0.0, 1e-10);
    let s = max_abs(&base.blade_le_radial);
    let d = max_diff(&base.blade_le_radial, &tight.blade_le_radial);
    assert!(d <= 1e-6 * s, "eps_NR: {d:e} vs {s:e}");
    // Halving h: peak blade amplitude within 1 %.
    let half = run(0.5 * h, 0.0, 1e-5);
    let (p1, p2) = (
        max_abs(&base.blade_le_radial),
        max_abs(&half.blade_le_radial),
    );
    assert!((p1 - p2).abs() <= 0.01 * p1, "peak {p1:e} vs {p2:e}");
    // μ = 0.01 nearly identical, no instability.
    let fr = run(h, 0.01, 1e-5);
    assert!(fr.summary.peaks.blade_radial().is_finite());
    let d = max_diff(&base.blade_le_radial, &fr.blade_le_radial);
    assert!(d <= 0.05 * s, "mu: {d:e} vs {s:e}");
    assert!(max_abs(&fr.blade_tangential_force) > 0.0);
}

/// Each step's residual reaches the summary: a step above the gap tolerance is counted,
/// and one above 1e-4 of the casing radius stops the run as diverged.
#[test]
fn residuals_above_the_tolerance_are_counted_and_a_runaway_stops_the_run() {
    let (imp, cas) = small_pair(4);
    let casing = CasingModel::Flexible(cas);
    let case = lobe_case(1e-7, 0.0, KernelChoice::Fast, 1e-5);
    let mut sim = Simulation::new(&case, &imp, &casing).unwrap();
    let tol = sim.casing.gap_tolerance();
    for residual in [0.5 * tol, 2.0 * tol, 0.0, 1.5 * tol] {
        sim.residual = residual;
        sim.check_residual().unwrap();
    }
    assert_eq!(sim.summary.steps_over_gap_tolerance, 2);
    assert_eq!(sim.summary.max_residual_penetration, 2.0 * tol);
    sim.residual = 2e-4 * sim.casing.radius_scale();
    let err = sim.check_residual().unwrap_err();
    assert!(matches!(err, SimError::Diverged { .. }), "{err}");
}

/// At the paper's resolution (h = 1e-7 s) the residual penetration after correction is
/// ≤ 1e-8 of the vibration level (paper §3.3.3). It is the O(κ d*²) error of the linearized
/// constraint, so it shrinks like h²; at coarse steps (a few hundred per revolution) it is larger.
#[test]
fn residual_penetration_is_negligible_at_paper_resolution() {
    let (imp, cas) = small_pair(4);
    let casing = CasingModel::Flexible(cas);
    for mu in [0.0, 0.01] {
        let mut case = lobe_case(1e-7, mu, KernelChoice::Fast, 1e-5);
        case.duration = 4e-3;
        case.numerics.decimation = 100;
        let out = simulate(&case, &imp, &casing, None).unwrap();
        assert!(out.summary.contact_steps > 100);
        assert!(
            out.summary.max_residual_penetration <= 1e-8 * out.summary.peaks.blade_radial(),
            "μ = {mu}: residual {:e} vs level {:e}",
            out.summary.max_residual_penetration,
            out.summary.peaks.blade_radial()
        );
    }
}
