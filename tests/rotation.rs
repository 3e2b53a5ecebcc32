//! The sense of rotation is part of the model (`models.rotation`): the built-in machine turned
//! clockwise is the mirror image (y → −y) of the counter-clockwise one, so it must give the
//! mirrored response: blade s of one is blade −s of the other, casing sector s is sector −s,
//! radial and axial displacements and the contact and coating forces are equal, tangential
//! displacements opposite. The clockwise run shares no sign with the counter-clockwise one
//! except through `Case::angular_velocity`: a sign left out anywhere (the rotating frame, the
//! drive's work, an imposed gap's angle, the slip) breaks the equality.

use rubscan::dynamics::recorder::SeriesRecorder;
use rubscan::sweep::{parse_spec, plan};
use rubscan::{ModelSimulator, Simulation, SimulationOutput};
use serde_json::{Value, json};

/// A short rub of the built-in impeller: the quickstart's two-lobe casing load ramped in 1 ms
/// (contact from 0.6 ms), 2.5 ms at 3000 rad/s, μ = 0.15, turning `rotation`; with `coated`
/// the nominal abradable coating. Casing probes at sectors `probe_sectors`, tip-node probes on
/// blade `blade`.
fn spec(rotation: &str, coated: bool, blade: usize, probe_sectors: [usize; 2]) -> Value {
    let path = format!("{}/sweeps/quickstart.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["models"]["rotation"] = rotation.into();
    v["scenario"]["duration_s"] = 2.5e-3.into();
    v["scenario"]["load_ramp_s"] = 1e-3.into();
    v["scenario"]["casing_probes"] = json!([[probe_sectors[0], 4], [probe_sectors[1], 2]]);
    let mut probes = ["radial", "tangential", "axial"]
        .map(|c| {
            json!({
                "blade": blade, "row": 4, "quantity": "displacement", "component": c
            })
        })
        .to_vec();
    // A recovered interior node (the ROM's recovery rows).
    probes.push(json!({ "point": "leading_edge_mid_span", "blade": blade,
        "quantity": "displacement", "component": "tangential" }));
    v["scenario"]["probes"] = json!(probes);
    if coated {
        v["scenario"]["coating"] = json!({});
    }
    v["grid"]["speed"] = json!({ "unit": "rad_s", "values": [3000.0] });
    v
}

/// Runs the single job of `v`: its series and summary.
fn run(v: &Value) -> SimulationOutput {
    let spec = parse_spec(&v.to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let (case, casing, _) = sim.case_for_job(&plan(&spec).unwrap().jobs[0]).unwrap();
    let mut rec = SeriesRecorder::default();
    rec.out.summary = Simulation::new(&case, sim.impeller(), &casing)
        .unwrap()
        .run(&mut rec, None)
        .unwrap();
    rec.out
}

/// Largest |a − sign·b| over two series, relative to the largest |a|.
fn mismatch(a: &[f64], b: &[f64], sign: f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = (a.iter().zip(b)).fold(0.0f64, |m, (x, y)| m.max((x - sign * y).abs()));
    if scale > 0.0 { diff / scale } else { diff }
}

/// Checks that `cw` mirrors `ccw` (module doc), with `n` blades and `nc` casing sectors.
fn assert_mirrored(ccw: &SimulationOutput, cw: &SimulationOutput, n: usize, label: &str) {
    const ROUND_OFF: f64 = 1e-8;
    let mut worst = Vec::new();
    for s in 0..n {
        let m = (n - s) % n;
        for (name, a, b) in [
            ("LE radial", &ccw.blade_le_radial, &cw.blade_le_radial),
            ("TE radial", &ccw.blade_te_radial, &cw.blade_te_radial),
            (
                "normal force",
                &ccw.blade_normal_force,
                &cw.blade_normal_force,
            ),
            (
                "friction force",
                &ccw.blade_tangential_force,
                &cw.blade_tangential_force,
            ),
        ] {
            worst.push((format!("blade {s} {name}"), mismatch(&a[s], &b[m], 1.0)));
        }
        if !ccw.coating_blade_force.is_empty() {
            let (a, b) = (&ccw.coating_blade_force[s], &cw.coating_blade_force[m]);
            worst.push((format!("blade {s} coating force"), mismatch(a, b, 1.0)));
        }
    }
    for (p, (a, b)) in ccw.casing_radial.iter().zip(&cw.casing_radial).enumerate() {
        worst.push((format!("casing probe {p} radial"), mismatch(a, b, 1.0)));
    }
    for (p, sign) in [(0, 1.0), (1, -1.0), (2, 1.0), (3, -1.0)] {
        let name = [
            "tip radial",
            "tip tangential",
            "tip axial",
            "mid-span LE tangential",
        ][p];
        worst.push((name.into(), mismatch(&ccw.probes[p], &cw.probes[p], sign)));
    }
    worst.push((
        "drive work".into(),
        mismatch(&ccw.drive_work, &cw.drive_work, 1.0),
    ));
    let contact = (ccw
        .blade_normal_force
        .iter()
        .chain(&ccw.coating_blade_force))
    .flatten()
    .any(|f| *f > 0.0);
    assert!(contact, "{label}: no contact, nothing tested");
    let tangential = ccw.probes[1].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(
        tangential > 0.0,
        "{label}: no tangential motion, nothing tested"
    );
    let (name, err) = worst.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    println!("{label}: largest relative mismatch {err:.2e} ({name})");
    for (name, err) in &worst {
        assert!(
            *err < ROUND_OFF,
            "{label}: {name} differs by {err:e} (relative)"
        );
    }
}

/// The same impeller against a rigid imposed-gap casing (the Rotor 37 benchmark's form: two
/// Gaussian lobes, 0.1 mm mean gap, met radially at θ = φ ± Ωt).
fn imposed_gap(rotation: &str, blade: usize) -> Value {
    let mut v = spec(rotation, false, blade, [0, 0]);
    v["models"]["casing"] = json!({ "imposed_gap": { "profile": { "gaussian_lobes": {
        "mean_gap_m": 1e-4, "width": 0.15, "lobes": 2
    } } } });
    let scenario = v["scenario"].as_object_mut().unwrap();
    for flexible_only in ["lobes", "load_amplitude_m", "load_ramp_s", "casing_probes"] {
        scenario.remove(flexible_only);
    }
    v
}

/// `v` with the contact boundary `boundary` (`"mass"`, the paper's formulation with the
/// explicit coating force, or `"massless"`, the default, with the coating solved with the
/// contact), named rather than left to the default.
fn with_boundary(mut v: Value, boundary: &str) -> Value {
    v["numerics"]["boundary"] = boundary.into();
    v
}

/// Both contact boundaries on the flexible casing, bare and coated, then the imposed-gap
/// casing. The massless runs come first: a sign dropped in a path of the paper's formulation
/// alone (its explicit coating force's work on the drive) passes them and fails the mass
/// runs.
#[test]
fn the_built_in_machine_turned_clockwise_gives_the_mirrored_response() {
    let v = spec("counterclockwise", false, 1, [0, 10]);
    let sim = ModelSimulator::new(&parse_spec(&v.to_string()).unwrap()).unwrap();
    let n = sim.impeller().n_sectors;
    let nc = sim.casing_rom().unwrap().n_sectors;
    let mut steps = vec![];
    for boundary in ["massless", "mass"] {
        for coated in [false, true] {
            let ccw = spec("counterclockwise", coated, 1, [0, 10]);
            let cw = spec("clockwise", coated, n - 1, [0, nc - 10]);
            let (ccw, cw) = (with_boundary(ccw, boundary), with_boundary(cw, boundary));
            let label = format!("{boundary} boundary, coated {coated}");
            let (ccw, cw) = (run(&ccw), run(&cw));
            steps.push((label.clone(), ccw.summary.time_step));
            assert_mirrored(&ccw, &cw, n, &label);
        }
    }
    // Each run is the formulation it names: the paper's stability limit is set by the
    // boundary-dominated modes, so its default step is several times shorter.
    println!("time steps (s): {steps:?}");
    assert!(steps[2].1 < 0.5 * steps[0].1, "{steps:?}");
    let ccw = run(&imposed_gap("counterclockwise", 1));
    let cw = run(&imposed_gap("clockwise", n - 1));
    assert_mirrored(&ccw, &cw, n, "built-in impeller, imposed gap");
}
