//! The linear stability prediction on the built-in models (`docs/stability.md` §6): stable
//! where the quickstart's and case study 1's jobs ring down, a growing wave from just above the
//! casing's critical wave speed. Beside the sweeps, so it builds the models as a sweep does.

use rubscan::analysis::stability::{Predictor, StabilityOptions, Verdict, predict};
use rubscan::dynamics::structure::Structure;
use rubscan::model::rom::CyclicRom;
use rubscan::sweep::parse_spec;
use rubscan::sweep::simulator::ModelSimulator;

/// The casing's critical wave speed (rad/s) and its nodal diameter.
fn critical_wave_speed(cas: &CyclicRom) -> (f64, usize) {
    Structure::new(cas, 0.0)
        .unwrap()
        .critical_wave_speed()
        .unwrap()
}

/// A shipped sweep spec as JSON.
fn sweep_json(name: &str) -> serde_json::Value {
    let path = format!("{}/sweeps/{name}.json", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Case study 2's models (the impeller's grid extended to 8000 rad/s), μ = 0.15 of its grid and
/// 0.5 % modal damping of the ROMs: stable at every speed of the quickstart and of case study 1
/// (whose jobs ring down) for each of case study 1's frictions, and a growing wave from just
/// above the casing's critical wave speed, of its nodal diameter, standing in the rotating
/// frame (the moving-load divergence).
#[test]
fn built_in_models_are_stable_where_the_jobs_ring_down_and_diverge_above_the_critical_wave_speed() {
    let cs2 = sweep_json("case_study_2");
    let spec = parse_spec(&cs2.to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let (imp, cas) = (sim.impeller(), sim.casing_rom().unwrap());
    let mu = numbers(&cs2["grid"]["friction"])[0];
    let cs1 = sweep_json("case_study_1");
    let mut speeds = numbers(&sweep_json("quickstart")["grid"]["speed"]["values"]);
    speeds.extend(numbers(&cs1["grid"]["speed"]["values"]));
    for friction in numbers(&cs1["grid"]["friction"]) {
        let p = Predictor::new(imp, cas, &StabilityOptions::with_friction(friction)).unwrap();
        for &w in &speeds {
            let s = p.at(w).unwrap();
            let top = s.most_unstable().unwrap();
            println!(
                "μ = {friction}, Ω = {w} rad/s: stable, least-damped σ = {:.2} 1/s",
                top.growth_rate_per_s
            );
            assert!(s.is_stable(), "μ = {friction}, Ω = {w}: {top:?}");
        }
    }
    let (omega_c, nd) = critical_wave_speed(cas);
    let opts = StabilityOptions::with_friction(mu);
    let p = Predictor::new(imp, cas, &opts).unwrap();
    let onset = p
        .onset_speed(0.8 * omega_c, 1.3 * omega_c, 0.1)
        .unwrap()
        .unwrap();
    println!(
        "μ = {mu}: casing critical wave speed {omega_c:.1} rad/s (ND {nd}); predicted onset \
         {onset:.1} rad/s ({:+.3} % of it)",
        100.0 * (onset / omega_c - 1.0)
    );
    assert!(
        onset > omega_c && onset < 1.01 * omega_c,
        "{onset} vs {omega_c}"
    );
    for factor in [1.02, 1.1] {
        let s = p.at(factor * onset).unwrap();
        let w = s.most_unstable().unwrap();
        println!(
            "{factor} × onset = {:.1} rad/s: σ = {:.1} 1/s, casing ND {}, impeller ND {}, \
             {:.1} Hz fixed frame ({}), {:.2} Hz rotating frame",
            factor * onset,
            w.growth_rate_per_s,
            w.nodal_diameter,
            w.impeller_nodal_diameter,
            w.frequency_hz,
            if w.backward { "backward" } else { "forward" },
            w.rotating_frequency_hz,
        );
        assert!(!s.is_stable() && w.quasi_static);
        assert_eq!(w.nodal_diameter, nd);
        // The mode cutoff is converged: twice the band moves σ by < 0.1 %.
        let wider = StabilityOptions {
            mode_cutoff_hz: Some(2.0 * opts.mode_cutoff_hz.unwrap()),
            ..opts.clone()
        };
        let s2 = predict(imp, cas, factor * onset, &wider).unwrap();
        let w2 = s2.most_unstable().unwrap();
        assert!((w2.growth_rate_per_s / w.growth_rate_per_s - 1.0).abs() < 1e-3);
    }
    // Every wave counted: the bilateral sliding contact's friction-induced mode coupling grows
    // at 3000 rad/s already (oscillating waves, which a unilateral contact does not keep).
    let every = StabilityOptions {
        verdict: Verdict::EveryWave,
        ..opts.clone()
    };
    let s = predict(imp, cas, 3000.0, &every).unwrap();
    let w = s.most_unstable().unwrap();
    println!("every wave, 3000 rad/s: {w:?}");
    assert!(!s.is_stable() && !w.quasi_static);
}
