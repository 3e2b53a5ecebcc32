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

use rubscan::dynamics::RunSummary;
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

/// The case study 2 scenario with `lobes` lobes, with or without the nominal coating, and
/// with the runaway watch on or off.
fn scenario(omega: f64, duration: f64, lobes: u32, coated: bool, watch: bool) -> Value {
    let mut v = case_study_2_at(omega, duration);
    v["scenario"]["lobes"] = lobes.into();
    if coated {
        v["scenario"]["coating"] = serde_json::json!({});
    }
    v["numerics"]["stop_on_runaway"] = watch.into();
    v
}

/// Runs the spec `v`'s single job, keeping the samples recorded before an error.
fn run_spec(v: &Value) -> (SimulationOutput, Result<RunSummary, SimError>) {
    let spec = parse_spec(&v.to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let (case, casing, _) = sim.case_for_job(&plan(&spec).unwrap().jobs[0]).unwrap();
    let mut rec = SeriesRecorder::default();
    let result = Simulation::new(&case, sim.impeller(), &casing)
        .unwrap()
        .run(&mut rec, None);
    (rec.out, result)
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

/// Runs the five-lobe scenario at `omega` for `duration` without the runaway watch, keeping
/// the samples recorded before an error.
fn run(omega: f64, duration: f64) -> (SimulationOutput, Option<SimError>) {
    let (out, result) = run_spec(&scenario(omega, duration, 5, false, false));
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

/// The energy at the first sample at or after `t` (J).
fn energy_at(out: &SimulationOutput, t: f64) -> f64 {
    energy(out, out.time.iter().position(|&x| x >= t).unwrap())
}

/// A runaway is called, and the job stopped, before its contact solve gives up; a job that
/// rings down is never called: on each side of the critical wave speed, with and without the
/// coating, for two and five lobes. Whether a case runs away is the simulation's own answer
/// (run again without the watch: it fails or keeps growing); the watch must agree with it.
#[test]
fn runaways_are_called_before_the_solve_gives_up_and_ring_downs_never() {
    let (omega_c, k) = casing_critical_speed();
    let t_f = 4e-3;
    let mut unstable = vec![];
    for (lobes, coated, side) in [2u32, 5]
        .into_iter()
        .flat_map(|l| [(l, false), (l, true)])
        .flat_map(|(l, c)| [(l, c, 0.95), (l, c, 1.10)])
    {
        let label = format!("{lobes} lobes, coated {coated}, {side} Ω_c");
        let omega = side * omega_c;
        let (out, watched) = run_spec(&scenario(omega, 16e-3, lobes, coated, true));
        let summary = watched.unwrap_or_else(|e| panic!("{label}: the solve gave up first: {e}"));
        match summary.runaway {
            None => {
                // Ran to the end unwatched in effect (the watch never feeds back): it rang down.
                assert_eq!(summary.steps_run, summary.n_steps, "{label}");
                let (release, end) = (energy_at(&out, t_f), energy(&out, out.time.len() - 1));
                println!("{label}: ok, energy {release:.3e} J at release, {end:.3e} J at the end");
                assert!(
                    end < 0.5 * release,
                    "{label}: not a ring-down but not called"
                );
            }
            Some(r) => {
                let stop = r.detected_time_s;
                println!(
                    "{label}: unstable at {:.2} ms (onset {:.2} ms), σ = {:.0} 1/s (R² {:.2}), \
                     nodal diameter {:?}, {:?} Hz, forward {:?}, {:?} Hz in the rotating \
                     frame, {} of {} steps run",
                    stop * 1e3,
                    r.onset_time_s * 1e3,
                    r.growth_rate_per_s,
                    r.growth_fit_r2,
                    r.nodal_diameter,
                    r.frequency_hz,
                    r.forward,
                    r.rotating_frame_frequency_hz,
                    summary.steps_run,
                    summary.n_steps
                );
                assert!(summary.steps_run < summary.n_steps, "{label}");
                assert!(
                    r.growth_rate_per_s > 0.0 && r.growth_fit_r2 >= 0.8,
                    "{label}"
                );
                // Unwatched, the same job grows on until its solve gives up, or by another
                // decade of energy by the end: the call was a true runaway, made in time.
                let (raw, result) = run_spec(&scenario(omega, 16e-3, lobes, coated, false));
                let last = raw.time.len() - 1;
                let grew = energy(&raw, last) > 10.0 * energy_at(&raw, stop);
                assert!(
                    result.is_err() || grew,
                    "{label}: unwatched it did not run away"
                );
                assert!(raw.time[last] > stop, "{label}");
                unstable.push((lobes, coated, side, r));
            }
        }
    }
    // The five-lobe load above the critical wave speed feeds the casing's wave of the
    // critical nodal diameter, coated or not: a forward wave in the fixed frame (backward, or
    // standing, as the blades see it), at the casing's own frequency of that diameter
    // stiffened by the closed contact (at most by 20 %).
    let f_free = k as f64 * omega_c / std::f64::consts::TAU;
    for coated in [false, true] {
        let (.., r) = unstable
            .iter()
            .find(|u| u.0 == 5 && u.1 == coated && u.2 > 1.0)
            .unwrap_or_else(|| panic!("5 lobes, coated {coated}, above Ω_c: not called"));
        assert_eq!(r.nodal_diameter, Some(k as u32));
        assert_eq!(r.forward, Some(true));
        let f = r.frequency_hz.unwrap();
        assert!(
            (f_free..1.2 * f_free).contains(&f),
            "{f} Hz vs {f_free} Hz free"
        );
    }
    assert!(unstable.iter().all(|u| u.2 > 1.0), "a runaway below Ω_c");
}

/// Far above the critical wave speed (case study 2's fastest job, 1.18 Ω*₅) the energy grows
/// three decades in four periods and the growth slows as it goes, so the watch's steady-rate
/// test does not confirm it before the contact forces reach hundreds of kN: the job used to
/// fail with its solve ("residual penetration 1.4e-5 m after correction"). It is a runaway,
/// called where the contact stops being exact, and every step it keeps had exact contact:
/// residual penetration ≤ 1e-8 of the blade-tip level, re-projected on every step.
#[test]
fn the_fastest_runaway_is_called_with_exact_contact_up_to_its_stop() {
    let mut v = case_study_2_at(8131.262, 6e-3);
    v["numerics"]["decimation"] = 1.into();
    let (_, result) = run_spec(&v);
    let summary = result.unwrap_or_else(|e| panic!("the solve gave up first: {e}"));
    let r = summary.runaway.expect("called unstable");
    let level = summary.peaks.blade_radial();
    println!(
        "unstable at {:.3} ms (onset {:.3} ms, at the solve's breakdown: {}), σ = {:.0} 1/s, \
         nodal diameter {:?}; residual {:.3e} m, level {level:.3e} m",
        r.detected_time_s * 1e3,
        r.onset_time_s * 1e3,
        r.at_solve_breakdown,
        r.growth_rate_per_s,
        r.nodal_diameter,
        summary.max_residual_penetration
    );
    assert!(
        r.growth_rate_per_s > 0.0 && r.energy_growth >= 100.0,
        "{r:?}"
    );
    assert_eq!(r.nodal_diameter, Some(5));
    assert!(summary.max_residual_penetration <= 1e-8 * level);
}
