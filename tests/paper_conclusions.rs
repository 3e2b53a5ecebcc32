//! The paper's conclusions (Batailly & Legrand 2015, §5–6) on the built-in paper-scale models,
//! at reduced length: the shipped `sweeps/case_study_*.json` specs, shortened, run job by job
//! through the sweep simulator (the jobs `rubscan run` would run), and each conclusion checked
//! on their time series. `docs/validation.md` gives the full-length figures and commands.
//!
//! Case study 1 is cut from 70 ms to 20 ms: the load is released at t_f = 4 ms and the coating
//! contact has ended well before 20 ms (no coating force after ≈ 15 ms in the full run), so the
//! wear, the maxima and the post-release window are those of the full run's contact phase.
//!
//! The runs use the massless boundary with the 50 kHz mode cutoff at its default step
//! ([`cheapest_formulation`]), not the shipped specs' paper formulation at h = 1e-7 s: the
//! conclusions are the physics', and `tests/massless.rs` checks on the same 10-mode ROMs that
//! this configuration gives the paper formulation's answer (both blade-tip edges and the
//! casing, uncoated) and that, coated, its default step is converged (peaks, coating force,
//! wear profile). About five times fewer core-seconds; `docs/validation.md` gives the paper
//! formulation's full-length figures.

use rayon::prelude::*;
use rubscan::SimulationOutput;
use rubscan::model::mesh::ImpellerGeometry;
use rubscan::sweep::simulator::tip_rows;
use rubscan::sweep::{CoatingValue, JobParams, parse_spec, plan};
use rubscan::{ModelSimulator, simulate};
use serde_json::Value;
use std::f64::consts::TAU;
use std::sync::OnceLock;

/// The spec `sweeps/<name>.json` as JSON, to be shortened by the tests.
fn shipped_spec(name: &str) -> Value {
    let path = format!("{}/sweeps/{name}.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap()
}

/// One finished job: its parameters, its output and the tip rows `[r, z]` (m) of its impeller.
struct Run {
    params: JobParams,
    out: SimulationOutput,
    rows: Vec<[f64; 2]>,
}

/// `v` in the cheapest formulation that keeps the conclusions: the massless boundary with the
/// modes above 50 kHz quasi-static, at its default step (2e-6 s; the coating force solved with
/// the contact, so that the stiffest coating, 10 E, needs no shorter step), a sample every
/// two steps (about 4 µs, the shipped specs' 5 µs).
fn cheapest_formulation(mut v: Value) -> Value {
    v["numerics"] = serde_json::json!({
        "boundary": "massless", "mode_cutoff_hz": 5e4, "decimation": 2
    });
    v
}

/// Runs every job of `spec` (in plan order, on the rayon pool) through the sweep simulator.
fn run_all(spec: &Value) -> Vec<Run> {
    let spec = parse_spec(&spec.to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let rows = tip_rows(sim.impeller());
    plan(&spec)
        .unwrap()
        .jobs
        .par_iter()
        .map(|job| {
            let (case, casing, _) = sim.case_for_job(job).unwrap();
            let out = simulate(&case, sim.impeller(), &casing, None)
                .unwrap_or_else(|e| panic!("job {:?}: {e}", job.params));
            Run {
                params: job.params,
                out,
                rows: rows.clone(),
            }
        })
        .collect()
}

/// The spec of case study 1 shortened to 20 ms, with the grid replaced by `friction` ×
/// `scale` (E and K scaled together, as in the shipped spec).
fn case_study_1_spec(friction: &[f64], scale: &[f64]) -> Value {
    let mut v = cheapest_formulation(shipped_spec("case_study_1"));
    v["scenario"]["duration_s"] = 0.02.into();
    v["grid"]["friction"] = friction.into();
    v["grid"]["coating"]["young"]["scale"] = scale.into();
    v["grid"]["coating"]["hardening"]["scale"] = scale.into();
    v
}

/// The jobs of [`case_study_1_spec`], run.
fn case_study_1(friction: &[f64], scale: &[f64]) -> Vec<Run> {
    run_all(&case_study_1_spec(friction, scale))
}

/// The nominal coating at μ = 0, 0.15, 0.3 (shared by the friction and strain-energy tests).
fn friction_runs() -> &'static [Run] {
    static RUNS: OnceLock<Vec<Run>> = OnceLock::new();
    RUNS.get_or_init(|| case_study_1(&[0.0, 0.15, 0.3], &[1.0]))
}

/// Release time t_f (s) of the shipped case study 1.
fn release_time() -> f64 {
    shipped_spec("case_study_1")["scenario"]["load_ramp_s"]
        .as_f64()
        .unwrap()
}

/// Worn volume (m³): per row, the wear depth integrated around the circumference at the
/// row's radius, times the row's tributary length along the blade tip (half the distance to
/// each neighbouring row, in the meridian plane) — the same strip that gives the row its tip
/// area in the coating model.
fn worn_volume(run: &Run) -> f64 {
    let wear = &run.out.summary.coating.as_ref().unwrap().final_wear;
    let rows = &run.rows;
    assert_eq!(wear.len(), rows.len());
    let seg: Vec<f64> = rows
        .windows(2)
        .map(|w| (w[0][0] - w[1][0]).hypot(w[0][1] - w[1][1]))
        .collect();
    (0..rows.len())
        .map(|r| {
            let left = if r > 0 { seg[r - 1] } else { 0.0 };
            let right = seg.get(r).copied().unwrap_or(0.0);
            let arc = TAU * rows[r][0] / wear[r].len() as f64;
            0.5 * (left + right) * arc * wear[r].iter().sum::<f64>()
        })
        .sum()
}

/// Largest |value| of `series` over the samples with time in `[from, to)`.
fn max_abs_between(time: &[f64], series: &[Vec<f64>], from: f64, to: f64) -> f64 {
    series
        .iter()
        .flat_map(|s| {
            s.iter()
                .zip(time)
                .filter(move |(_, t)| **t >= from && **t < to)
        })
        .fold(0.0f64, |m, (v, _)| m.max(v.abs()))
}

/// Largest radial displacement (m) of the blade-tip edge nodes (leading and trailing edge,
/// every blade) over the whole run.
fn max_blade(out: &SimulationOutput) -> f64 {
    let all = |s: &[Vec<f64>]| max_abs_between(&out.time, s, f64::NEG_INFINITY, f64::INFINITY);
    all(&out.blade_le_radial).max(all(&out.blade_te_radial))
}

/// The coated jobs keep the built-in tip clearance to the unworn coating on every row: each
/// tip starts `tip_clearance + e_abr` from the casing, the gap measured along the casing normal
/// (radial at the leading edge, axial at the radial outlet). A radial shift by e_abr left the
/// trailing-edge tips 0.99 mm from the casing, 1 mm deep inside the 2 mm coating.
#[test]
fn coated_tips_start_at_the_clearance_from_the_unworn_coating() {
    let mut v = shipped_spec("case_study_1");
    // Ten steps: the load (ramped over them) moves the casing by ~1e-7 m at most.
    v["scenario"]["duration_s"] = 1e-6.into();
    v["scenario"]["load_ramp_s"] = 1e-6.into();
    v["numerics"]["decimation"] = 1.into();
    v["grid"]["friction"] = [0.15].as_slice().into();
    v["grid"]["coating"]["young"]["scale"] = [1.0].as_slice().into();
    v["grid"]["coating"]["hardening"]["scale"] = [1.0].as_slice().into();
    let rows = 5;
    v["scenario"]["probes"] = (0..rows)
        .map(|r| serde_json::json!({"blade": 0, "row": r, "quantity": "gap"}))
        .collect::<Vec<_>>()
        .into();
    let run = &run_all(&v)[0];
    assert_eq!(run.rows.len(), rows);
    let coating = run.out.summary.coating.as_ref().unwrap();
    let expected = ImpellerGeometry::default().tip_clearance + coating.thickness;
    let gaps: Vec<f64> = run.out.probes.iter().map(|p| p[0]).collect();
    eprintln!("initial gaps (m): {gaps:?}, expected {expected:e} m");
    for (r, g) in gaps.iter().enumerate() {
        assert!((g - expected).abs() < 1e-5, "row {r}: gap {g:e} m");
    }
    assert_eq!(coating.coating_steps, 0, "a tip starts inside the coating");
}

/// §5.1: "the lower μ, the higher the wear level" — the worn volume of the nominal coating
/// at μ = 0, 0.15, 0.3.
///
/// Ignored: it does not hold in rubscan at this speed on the built-in radial blades (see
/// `docs/validation.md`, §5.1). The worn volume *grows* with μ by about 1 % (full run: Σ wear
/// 0.9678, 0.9721, 0.9781 m over the 5 × 6000 elements); with (E/10, K/10) it falls with μ,
/// by 0.1 %. It holds for blades leaned against the rotation
/// (`the_friction_trend_of_the_wear_follows_the_blade_lean`). Run it with
/// `cargo test --test integration paper_conclusions:: -- --ignored` to see the current numbers.
#[test]
#[ignore = "paper §5.1 does not hold in rubscan on the built-in models (docs/validation.md)"]
fn lower_friction_wears_more() {
    let runs = friction_runs();
    let v: Vec<(f64, f64)> = runs
        .iter()
        .map(|r| (r.params.friction, worn_volume(r)))
        .collect();
    eprintln!("μ, worn volume (m³): {v:?}");
    assert!(v.iter().all(|&(_, w)| w > 0.0), "no wear at all: {v:?}");
    for w in v.windows(2) {
        assert!(w[0].0 < w[1].0);
        assert!(
            w[0].1 > w[1].1,
            "μ = {} wears less than μ = {}: {v:?}",
            w[0].0,
            w[1].0
        );
    }
}

/// Why §5.1 depends on the blade: friction acts on the tip along the circumference, across
/// the plane of a radial blade, so it bends the blade without moving its tip across the
/// clearance (−/+1 % on the worn volume above). A blade leaned by γ out of its meridian plane
/// bends along its normal `n = cos γ e_θ − sin γ e_s` (e_s the meridian direction of its span,
/// toward the casing), so the friction force `−μλ e_θ` moves the tip by `−μλ cos γ / k` along
/// `n`, that is by `+μλ sin γ cos γ / k` toward the casing: friction deepens the rub of a blade
/// leaned with the rotation (γ > 0) and relieves one leaned against it (γ < 0). Case study 1
/// (20 ms) with the built-in impeller leaned by ∓20°: the worn volume falls with μ at −20°
/// (the paper's statement) and grows with it at +20°.
#[test]
fn the_friction_trend_of_the_wear_follows_the_blade_lean() {
    for lean in [-20.0, 20.0] {
        let mut v = case_study_1_spec(&[0.0, 0.15, 0.3], &[1.0]);
        v["models"]["impeller"]["builtin"] =
            serde_json::json!({"geometry": {"blade_lean_deg": lean}});
        let worn: Vec<f64> = run_all(&v).iter().map(worn_volume).collect();
        eprintln!("lean {lean}°: worn volume at μ = 0, 0.15, 0.3: {worn:?} m³");
        for w in worn.windows(2) {
            let falls = w[1] < w[0];
            assert_eq!(falls, lean < 0.0, "lean {lean}°: {worn:?}");
        }
    }
}

/// The coating of case study 1 wears as the paper's Fig. 16(d): a partial-depth profile,
/// deepest under the two lobes of the load (θ = 0 and π) and two-fold symmetric, only near the
/// trailing edge where the load acts.
#[test]
fn case_study_1_wears_a_lobed_partial_depth_profile() {
    let run = &friction_runs()[1];
    let coating = run.out.summary.coating.as_ref().unwrap();
    let e_abr = coating.thickness;
    let te = coating.final_wear.last().unwrap();
    let eta = te.len();
    let deepest = te.iter().copied().fold(0.0f64, f64::max);
    eprintln!(
        "max wear per row (m): {:?}",
        coating
            .final_wear
            .iter()
            .map(|w| w.iter().copied().fold(0.0f64, f64::max))
            .collect::<Vec<_>>()
    );
    // Partial depth: worn, but nowhere through the coating.
    assert!(
        deepest > 0.05 * e_abr && deepest < e_abr,
        "trailing-edge wear {deepest:e} m of {e_abr:e} m"
    );
    assert_eq!(coating.removed_elements.iter().sum::<usize>(), 0);
    // Leading-edge row: the load acts at the trailing edge, far from it.
    assert!(coating.final_wear[0].iter().all(|&w| w == 0.0));
    // Deepest within ±15° of a lobe of the load, and the profile two-fold symmetric.
    let k = te.iter().position(|&w| w == deepest).unwrap();
    let theta = TAU * (k as f64 + 0.5) / eta as f64;
    let from_lobe = (theta.rem_euclid(TAU / 2.0)).min(TAU / 2.0 - theta.rem_euclid(TAU / 2.0));
    assert!(from_lobe < 15f64.to_radians(), "deepest at θ = {theta} rad");
    let asym = (0..eta / 2)
        .map(|i| (te[i] - te[i + eta / 2]).abs())
        .fold(0.0f64, f64::max);
    assert!(asym < 0.05 * deepest, "θ ↔ θ + π differ by {asym:e} m");
}

/// §5.2: (E/10, K/10) gives a lower maximum impeller amplitude than (10E, 10K), and a higher
/// maximum casing amplitude after the release (t > t_f, where the paper places the effect:
/// "the casing is less constrained in its vibration for t > t_f").
///
/// Over the whole run the casing maximum is the other way round (full run: 8.33e-4 m against
/// 9.43e-4 m): while the load is applied, the stiff coating pushes the casing out further.
#[test]
fn softer_coating_lowers_the_impeller_and_raises_the_casing_amplitude() {
    let runs = case_study_1(&[0.15], &[0.1, 10.0]);
    let scale = |r: &Run| match r.params.coating.young {
        Some(CoatingValue::Scale(s)) => s,
        other => panic!("{other:?}"),
    };
    let (soft, stiff) = (&runs[0], &runs[1]);
    assert_eq!((scale(soft), scale(stiff)), (0.1, 10.0));
    let t_f = release_time();
    let casing_after =
        |r: &Run| max_abs_between(&r.out.time, &r.out.casing_radial, t_f, f64::INFINITY);
    let (b_soft, b_stiff) = (max_blade(&soft.out), max_blade(&stiff.out));
    let (c_soft, c_stiff) = (casing_after(soft), casing_after(stiff));
    eprintln!(
        "max blade: E/10 {b_soft:.4e} m, 10E {b_stiff:.4e} m; max casing after t_f: \
         E/10 {c_soft:.4e} m, 10E {c_stiff:.4e} m"
    );
    assert!(b_soft < b_stiff, "blade {b_soft:e} vs {b_stiff:e}");
    assert!(c_soft > c_stiff, "casing {c_soft:e} vs {c_stiff:e}");
}

/// Mean strain energy per nodal diameter (J) of the impeller over the last half of the run
/// (the sweep's steady window, after the release), paper eqs. (20)–(22).
fn nd_energy(out: &SimulationOutput) -> Vec<f64> {
    let start = out.time.last().unwrap() / 2.0;
    let keep: Vec<usize> = (0..out.time.len())
        .filter(|&i| out.time[i] >= start)
        .collect();
    out.impeller_nd_strain_energy
        .iter()
        .map(|e| keep.iter().map(|&i| e[i]).sum::<f64>() / keep.len() as f64)
        .collect()
}

/// Whether ND 0, 2 and 4 each exceed every odd ND by at least 10× (paper §5.3, Fig. 18).
fn even_dominates(e: &[f64]) -> bool {
    let odd = e.iter().skip(1).step_by(2).copied().fold(0.0f64, f64::max);
    [0, 2, 4].iter().all(|&k| e[k] >= 10.0 * odd)
}

/// §5.3: under the two-lobe load the impeller's strain energy lives in the even nodal
/// diameters: ND 0, 2 and 4 each exceed every odd ND by at least 10×. The check can fail: the
/// same scenario with a three-lobe load (engine orders 3, 6, 9 → ND 3, 4, 1 on 10 blades) puts
/// odd nodal diameters above ND 0 and 2.
#[test]
fn even_nodal_diameters_dominate_the_impeller_strain_energy() {
    let nominal = &friction_runs()[1];
    let e = nd_energy(&nominal.out);
    eprintln!("two lobes, ND 0..=5 (J): {e:?}");
    assert_eq!(e.len(), 6);
    assert!(e[2] > 0.0 && e[0] > 0.0 && e[4] > 0.0);
    assert!(even_dominates(&e), "{e:?}");

    let mut v = cheapest_formulation(shipped_spec("case_study_1"));
    v["scenario"]["lobes"] = 3.into();
    v["scenario"]["duration_s"] = 0.01.into();
    v["grid"]["friction"] = [0.15].as_slice().into();
    v["grid"]["coating"]["young"]["scale"] = [1.0].as_slice().into();
    v["grid"]["coating"]["hardening"]["scale"] = [1.0].as_slice().into();
    let three = run_all(&v);
    let e3 = nd_energy(&three[0].out);
    eprintln!("three lobes, ND 0..=5 (J): {e3:?}");
    assert!(!even_dominates(&e3), "{e3:?}");
}

/// Sustained fraction of a job's blade response: the largest blade-tip edge displacement over
/// the window `t ≥ from` divided by the largest one while the load acts (`t ≤ t_f`).
///
/// Why this is the resonance criterion: after the release the casing is free. Away from an
/// interaction the contact opens and every mode rings down with its own decay time
/// τ = 1/(ζω) (≤ 21 ms here, ζ = 0.5 %), so a window starting ≥ 2τ after t_f holds at most
/// e⁻² ≈ 0.14 of the load-phase level. At a modal interaction the contact keeps feeding the
/// coinciding modes and the level does not decay (fraction ≈ 1 or above). The threshold e⁻¹
/// is the geometric middle of the two; it does not depend on the absolute amplitude, which the
/// load amplitude and the clearance set.
fn sustained_fraction(out: &SimulationOutput, t_f: f64, from: f64) -> f64 {
    let edges = |from: f64, to: f64| {
        max_abs_between(&out.time, &out.blade_le_radial, from, to).max(max_abs_between(
            &out.time,
            &out.blade_te_radial,
            from,
            to,
        ))
    };
    edges(from, f64::INFINITY) / edges(0.0, t_f + 1e-12)
}

/// Case study 2 scan `name`, shortened to 60 ms and to the speeds `factors` × its reference
/// speed; returns each speed's sustained fraction over the last 15 ms (from 41 ms after the
/// release: ≥ 2τ for τ ≤ 20.5 ms).
fn scan(name: &str, factors: &[f64]) -> Vec<(f64, f64)> {
    let mut v = shipped_spec(name);
    v["scenario"]["duration_s"] = 0.06.into();
    v["grid"]["speed"]["range"] = Value::Null;
    v["grid"]["speed"]
        .as_object_mut()
        .unwrap()
        .retain(|_, x| !x.is_null());
    v["grid"]["speed"]["values"] = factors.into();
    let t_f = v["scenario"]["load_ramp_s"].as_f64().unwrap();
    run_all(&v)
        .iter()
        .map(|r| (r.params.speed_rad_s, sustained_fraction(&r.out, t_f, 0.045)))
        .collect()
}

/// §6: no resonance near the incompatible critical speed Ω*_5, a resonance near the most
/// compatible one (Ω*_10), each scanned from 0.98 to 1.18 × Ω* with its own lobe count.
///
/// Ignored: the scans lie far above the built-in casing's critical wave speed (4377 rad/s),
/// where a closed contact feeds the casing's backward waves with the rotation's energy
/// (tests/supercritical.rs): every job of the Ω*_5 scan and the ends of the Ω*_10 one run
/// away until the contact correction fails (docs/validation.md, §6), so the incompatible scan
/// has no answer on these models.
#[test]
#[ignore = "case-study-2 jobs run away above the built-in casing's critical wave speed (docs/validation.md, §6)"]
fn only_the_compatible_critical_speed_resonates() {
    let factors = [0.98, 1.02, 1.06, 1.10, 1.14, 1.18];
    let limit = (-1.0f64).exp();
    let incompatible = scan("case_study_2", &factors);
    let compatible = scan("case_study_2_compatible", &factors);
    eprintln!("Ω (rad/s), sustained fraction: Ω*_5 scan {incompatible:.3?}");
    eprintln!("Ω (rad/s), sustained fraction: Ω*_10 scan {compatible:.3?}");
    assert!(
        incompatible.iter().all(|&(_, f)| f < limit),
        "a resonance near the incompatible Ω*_5: {incompatible:?}"
    );
    assert!(
        compatible.iter().any(|&(_, f)| f >= limit),
        "no resonance near the compatible Ω*_10: {compatible:?}"
    );
}
