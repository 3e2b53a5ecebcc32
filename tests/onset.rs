//! The simulated onset of the runaway against the linear prediction (issue 37): a refined
//! speed scan of case study 2's five-lobe scenario around the casing's critical wave speed,
//! bare and with the nominal abradable coating, brackets the lowest `ok`/`unstable` boundary,
//! and that boundary lies within 3 % of the onset that `rubscan stability` predicts from the
//! ROMs alone (`docs/stability.md`). The simulation knows nothing of the prediction. The
//! two-lobe scenario's onset lies further off; `docs/validation.md` §6 gives it and why.

use arrow_array::cast::AsArray;
use arrow_array::types::Float64Type;
use rubscan::analysis::stability::{Predictor, StabilityOptions};
use rubscan::dynamics::structure::Structure;
use rubscan::sweep::simulator::ModelSimulator;
use rubscan::sweep::table::read_results;
use rubscan::sweep::{RunOptions, parse_spec, run_sweep};
use serde_json::{Value, json};

/// The shipped case study 2 with `coated` or not, 30 ms long (the slowest runaway just above
/// the onset is confirmed by 15 ms), scanning 0.9–1.2 × `omega_c` (rad/s) and refining the
/// ok/unstable boundaries to 20 rad/s.
fn scan(omega_c: f64, coated: bool) -> Value {
    let path = format!("{}/sweeps/case_study_2.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["scenario"]["duration_s"] = 0.03.into();
    if coated {
        v["scenario"]["coating"] = json!({});
    }
    v["grid"]["speed"] = json!({
        "unit": "normalized",
        "reference_rad_s": omega_c,
        "range": { "start": 0.9, "stop": 1.2, "count": 7 },
        "refine": { "tolerance_rad_s": 20.0, "max_jobs": 12, "boundary": true }
    });
    v
}

/// The (Ω, status) rows of a results table, by increasing Ω.
fn outcomes(path: &std::path::Path) -> Vec<(f64, String)> {
    let mut rows: Vec<(f64, String)> = read_results(path)
        .unwrap()
        .iter()
        .flat_map(|b| {
            let w = b.column_by_name("speed_rad_s").unwrap();
            let w = w.as_primitive::<Float64Type>();
            let s = b.column_by_name("status").unwrap().as_string::<i32>();
            (0..b.num_rows()).map(move |i| (w.value(i), s.value(i).to_string()))
        })
        .collect();
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    rows
}

#[test]
fn the_simulated_onset_lies_within_3_percent_of_the_predicted_one_bare_and_coated() {
    let base = parse_spec(&scan(4000.0, false).to_string()).unwrap();
    let sim = ModelSimulator::new(&base).unwrap();
    let casing = sim.casing_rom().expect("a flexible casing");
    let (omega_c, _) = Structure::new(casing, 0.0)
        .unwrap()
        .critical_wave_speed()
        .unwrap();
    let friction = base.grid.friction[0];
    let predicted = Predictor::new(
        sim.impeller(),
        casing,
        &StabilityOptions::with_friction(friction),
    )
    .unwrap()
    .onset_speed(0.8 * omega_c, 1.3 * omega_c, 0.1)
    .unwrap()
    .expect("an onset in 0.8–1.3 Ω_c");
    for coated in [false, true] {
        let spec = parse_spec(&scan(omega_c, coated).to_string()).unwrap();
        let sim = ModelSimulator::new(&spec).unwrap();
        let dir =
            std::env::temp_dir().join(format!("rubscan-onset-{coated}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let summary = run_sweep(&spec, &RunOptions::new(&dir), &sim).unwrap();
        let rows = outcomes(&summary.results_path);
        assert!(
            rows.iter().all(|r| r.1 != "failed"),
            "coated {coated}: {rows:?}"
        );
        let first = rows.iter().position(|r| r.1 == "unstable");
        let first = first.unwrap_or_else(|| panic!("coated {coated}: no runaway: {rows:?}"));
        assert!(
            first > 0,
            "coated {coated}: unstable from the lowest speed: {rows:?}"
        );
        let (ok, unstable) = (rows[first - 1].0, rows[first].0);
        println!(
            "coated {coated}: {} jobs, onset bracketed in ({ok:.1}, {unstable:.1}] rad/s; \
             predicted {predicted:.1} rad/s ({:+.2} … {:+.2} %)",
            rows.len(),
            100.0 * (ok / predicted - 1.0),
            100.0 * (unstable / predicted - 1.0)
        );
        assert!(
            unstable - ok <= 20.0,
            "coated {coated}: bracket not refined: {rows:?}"
        );
        for w in [ok, unstable] {
            assert!(
                (w / predicted - 1.0).abs() < 0.03,
                "coated {coated}: {w} rad/s vs predicted {predicted} rad/s"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
