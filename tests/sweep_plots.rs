//! Plots from a synthetic sweep's records. Set RUBSCAN_KEEP_PLOTS=1 to keep the files
//! (their directory is printed).

use rubscan::sweep::plots::{
    interaction_data_from_records, interaction_map, wear_data_from_records, wear_map,
};
use rubscan::sweep::synthetic::SyntheticSimulator;
use rubscan::sweep::{RunOptions, load_records, parse_spec, plan, run_sweep};

#[test]
fn interaction_and_wear_maps_from_a_synthetic_sweep() {
    let spec = parse_spec(
        &serde_json::json!({
            "name": "plots",
            "models": {"impeller": {"builtin": {}}, "casing": {"builtin": {}}},
            "scenario": {"duration_s": 0.01, "lobes": 2, "load_amplitude_m": 1e-4},
            "grid": {"speed": {"unit": "rad_s", "range": {"start": 400.0, "stop": 1600.0, "count": 25}}, "friction": [0.1]}
        })
        .to_string(),
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("rubscan-sweep-plots-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let sim = SyntheticSimulator::default();
    run_sweep(&spec, &RunOptions::new(&dir), &sim).unwrap();
    let records = load_records(&dir, plan(&spec).unwrap().jobs.iter());
    assert_eq!(records.len(), 25);
    let data = interaction_data_from_records(records.iter().map(|(_, r)| r), vec![2, 4, 6]);
    assert_eq!(data.columns.len(), 25);
    assert_eq!(data.critical_speeds_rad_s, vec![sim.critical_speed_rad_s]);
    interaction_map(&data, &dir.join("interaction_map.png")).unwrap();
    let wear = wear_data_from_records(records.iter().map(|(_, r)| r));
    // Max over stations = last station: 1e-5 (A/a0)(1 + cos 2θ) → 2e-5 A/a0 at θ = 0.
    let a = sim.amplitude(400.0);
    assert!((wear.rows[0].wear_m[0] - 2e-5 * a / sim.base_amplitude_m).abs() < 1e-18);
    wear_map(&wear, &dir.join("wear_map.png")).unwrap();
    if std::env::var_os("RUBSCAN_KEEP_PLOTS").is_some() {
        eprintln!("plots kept in {}", dir.display());
    } else {
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn standard_plots_one_interaction_map_per_slice() {
    use rubscan::sweep::plots::write_sweep_plots;
    let spec = parse_spec(
        &serde_json::json!({
            "name": "plots2",
            "models": {"impeller": {"builtin": {}}, "casing": {"builtin": {}}},
            "scenario": {"duration_s": 0.01, "lobes": 2, "load_amplitude_m": 1e-4},
            "grid": {"speed": {"unit": "rad_s", "values": [800.0, 1000.0, 1200.0]}, "friction": [0.0, 0.2]}
        })
        .to_string(),
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("rubscan-sweep-plots2-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    run_sweep(
        &spec,
        &RunOptions::new(&dir),
        &SyntheticSimulator::default(),
    )
    .unwrap();
    let records = load_records(&dir, plan(&spec).unwrap().jobs.iter());
    let files = write_sweep_plots(&dir, &records, &[2, 4, 6]).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    // Two friction values → two slices of three speeds each.
    assert_eq!(
        names,
        [
            "interaction_map_0.png",
            "interaction_map_1.png",
            "wear_map.png"
        ]
    );
    assert!(files.iter().all(|f| f.exists()));
    std::fs::remove_dir_all(&dir).unwrap();
}
