//! Why the built-in flexible casing's response runs away above ≈ 4400 rad/s (the case study 2
//! scans, `docs/validation.md`): the moving-load instability of the casing's backward waves.
//!
//! A load rotating at Ω around a stationary elastic ring travels with the ring's wave of
//! nodal diameter k when Ω = ω_k / k (ω_k its lowest natural frequency). Above the lowest of
//! these speeds, the casing's critical wave speed, the backward wave stands still in the
//! rotating frame and has negative energy there: a rotating contact that dissipates (friction,
//! impacts, damping in the rotating structure) feeds it with the work of the imposed rotation
//! (Iwan & Moeller 1976, for the spinning disk under a stationary load system; here rotor and
//! stator are exchanged). The prediction comes from the casing's frequencies alone; the
//! simulation knows nothing of it. The shipped case study 2 scenario (five-lobe load
//! ramped to t_f = 4 ms, then released, μ = 0.15, 0.5 % modal damping) is run just below and
//! above it, and the energy the structures hold is compared with the work the rotation did
//! through the contact forces.

use rubscan::dynamics::recorder::SeriesRecorder;
use rubscan::dynamics::structure::Structure;
use rubscan::sweep::{parse_spec, plan};
use rubscan::{ModelSimulator, SimError, Simulation, SimulationOutput};
use serde_json::Value;

/// The shipped `sweeps/case_study_2.json` at one speed (rad/s), `duration` (s) long.
fn case_study_2_at(omega: f64, duration: f64) -> Value {
    let path = format!("{}/sweeps/case_study_2.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["scenario"]["duration_s"] = duration.into();
    v["grid"]["speed"] = serde_json::json!({ "unit": "rad_s", "values": [omega] });
    v
}

/// The casing's critical wave speed (rad/s) and its nodal diameter, from its ROM alone.
fn casing_critical_speed() -> (f64, usize) {
    let spec = parse_spec(&case_study_2_at(1000.0, 1e-2).to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let rom = sim
        .casing_rom()
        .expect("case study 2 has a flexible casing");
    Structure::new(rom, 0.0)
        .unwrap()
        .critical_wave_speed()
        .unwrap()
}

/// Runs the scenario at `omega` for `duration`, keeping the samples recorded before an error.
fn run(omega: f64, duration: f64) -> (SimulationOutput, Option<SimError>) {
    let spec = parse_spec(&case_study_2_at(omega, duration).to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let (case, casing, _) = sim.case_for_job(&plan(&spec).unwrap().jobs[0]).unwrap();
    let mut rec = SeriesRecorder::default();
    let result = Simulation::new(&case, sim.impeller(), &casing)
        .unwrap()
        .run(&mut rec, None);
    let out = rec.out;
    (out, result.err())
}

/// Total vibration energy (J) of both structures at sample `i`.
fn energy(out: &SimulationOutput, i: usize) -> f64 {
    out.impeller_energy.kinetic[i]
        + out.impeller_energy.strain[i]
        + out.casing_energy.kinetic[i]
        + out.casing_energy.strain[i]
}

/// After the release at `t_f` no load acts: the energy gained since then cannot exceed the
/// work the rotation did through the contact forces (friction, damping and the impacts of
/// the Lagrange correction only take energy out). Returns the first sample after `t_f`.
fn check_energy_balance(out: &SimulationOutput, t_f: f64) -> usize {
    let r = out.time.iter().position(|&t| t > t_f).unwrap();
    for i in r..out.time.len() {
        let gained = energy(out, i) - energy(out, r);
        let fed = out.drive_work[i] - out.drive_work[r];
        assert!(
            gained <= fed + 1e-9 * energy(out, i),
            "t = {:.4e} s: the structures gained {gained:.6e} J, the rotation fed {fed:.6e} J",
            out.time[i]
        );
    }
    r
}

#[test]
fn the_casing_response_grows_above_its_critical_wave_speed_and_decays_below() {
    let t_f = 4e-3;
    let (omega_c, k) = casing_critical_speed();
    println!("casing critical wave speed {omega_c:.1} rad/s (nodal diameter {k})");

    // Below: the contact opens after the release and the response rings down.
    let (below, err) = run(0.95 * omega_c, 12e-3);
    assert!(err.is_none(), "0.95 Ω_c: {err:?}");
    let r = check_energy_balance(&below, t_f);
    let last = below.time.len() - 1;
    let (at_release, at_end) = (energy(&below, r), energy(&below, last));
    println!("0.95 Ω_c: energy {at_release:.4e} J at release, {at_end:.4e} J at 12 ms");
    assert!(at_end < 0.25 * at_release, "{at_release:e} -> {at_end:e}");

    // Above: the contact stays closed and the rotation's work piles up in the casing, until the
    // contact solve gives up; the error says why.
    let (above, err) = run(1.10 * omega_c, 10e-3);
    let r = check_energy_balance(&above, t_f);
    let last = above.time.len() - 1;
    let (at_release, at_end) = (energy(&above, r), energy(&above, last));
    let fed = above.drive_work[last] - above.drive_work[r];
    println!(
        "1.10 Ω_c: energy {at_release:.4e} J at release, {at_end:.4e} J at {:.2} ms, the rotation \
         fed {fed:.4e} J since; {err:?}",
        above.time[last] * 1e3
    );
    assert!(at_end > 10.0 * at_release, "{at_release:e} -> {at_end:e}");
    if let Some(e) = err {
        let msg = e.to_string();
        assert!(
            msg.contains("critical wave speed") && msg.contains(&format!("nodal diameter {k}")),
            "{msg}"
        );
    }
}
