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
//! through the contact forces. What the runaway watch reports (growth rate, nodal diameter,
//! frequency, direction of the wave) is compared with the linear prediction of a persistent
//! rub (`rubscan::analysis::stability`, `docs/stability.md`), computed from the same ROMs
//! without time integration.
//!
//! **Setting: the cheapest that shows it** (see [`case_study_2_at`]). The instability lives in
//! the casing's lowest nodal-diameter-5 mode (3.5 kHz) and the contact that feeds it, so the
//! models keep 4 fixed-interface modes per nodal diameter instead of the spec's 10 (the
//! critical wave speed moves from 4376.79 to 4376.90 rad/s, the predicted onset from 4377.3 to
//! 4377.4 rad/s), and the default massless boundary with a 50 kHz mode cutoff replaces the
//! paper's mass-carrying boundary at h = 2e-7 s: the step is then the default (1000 per
//! revolution, 1.3e-6 s at 1.1 Ω_c), the contact is solved exactly all the same (Lagrange
//! multipliers on the boundary's static flexibility). The paper's formulation of the same
//! scenario runs in `docs/validation.md` §6 (`rubscan run sweeps/case_study_2.json`).

use rubscan::analysis::stability::{CoupledWave, Predictor, StabilityAtSpeed, StabilityOptions};
use rubscan::dynamics::RunSummary;
use rubscan::dynamics::recorder::SeriesRecorder;
use rubscan::dynamics::runaway::Runaway;
use rubscan::dynamics::structure::Structure;
use rubscan::sweep::{parse_spec, plan};
use rubscan::{ModelSimulator, SimError, Simulation, SimulationOutput};
use serde_json::{Value, json};

/// The shipped `sweeps/case_study_2.json` at one speed (rad/s), `duration` (s) long, on the
/// cheap setting of the module doc: 4 fixed-interface modes per nodal diameter on both models
/// (the impeller's modal grid to 8000 rad/s kept, for the fastest job), the default massless
/// boundary with a 50 kHz mode cutoff and the default time step.
fn case_study_2_at(omega: f64, duration: f64) -> Value {
    let mut v = shipped_case_study_2_at(omega, duration);
    v["models"]["impeller"]["builtin"]["modes_per_diameter"] = 4.into();
    v["models"]["casing"]["builtin"]["modes_per_diameter"] = 4.into();
    v["numerics"] = json!({ "boundary": "massless", "mode_cutoff_hz": 5e4, "decimation": 10 });
    v
}

/// The shipped `sweeps/case_study_2.json` as it is (the paper's formulation at h = 2e-7 s, 10
/// modes per nodal diameter) at one speed (rad/s), `duration` (s) long.
fn shipped_case_study_2_at(omega: f64, duration: f64) -> Value {
    let path = format!("{}/sweeps/case_study_2.json", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v["scenario"]["duration_s"] = duration.into();
    v["grid"]["speed"] = json!({ "unit": "rad_s", "values": [omega] });
    v
}

/// The case study 2 scenario with `lobes` lobes, with or without the nominal coating, and
/// with the runaway watch on or off.
fn scenario(omega: f64, duration: f64, lobes: u32, coated: bool, watch: bool) -> Value {
    let mut v = case_study_2_at(omega, duration);
    v["scenario"]["lobes"] = lobes.into();
    if coated {
        v["scenario"]["coating"] = json!({});
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

/// The models of the setting: the casing's critical wave speed Ω_c (rad/s) and nodal
/// diameter, from its ROM alone, and the linear prediction of a persistent rub at the spec's
/// μ = 0.15 at each speed (rad/s) that `speeds` gives for Ω_c.
fn casing_and_prediction(
    speeds: impl Fn(f64) -> Vec<f64>,
) -> ((f64, usize), Vec<StabilityAtSpeed>) {
    models_and_prediction(&case_study_2_at(1000.0, 1e-2), speeds)
}

/// [`casing_and_prediction`] for the models of the spec `v`.
fn models_and_prediction(
    v: &Value,
    speeds: impl Fn(f64) -> Vec<f64>,
) -> ((f64, usize), Vec<StabilityAtSpeed>) {
    let spec = parse_spec(&v.to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let rom = sim
        .casing_rom()
        .expect("case study 2 has a flexible casing");
    let (omega_c, k) = Structure::new(rom, 0.0)
        .unwrap()
        .critical_wave_speed()
        .unwrap();
    let predictor = Predictor::new(
        sim.impeller(),
        rom,
        &StabilityOptions::with_friction(spec.grid.friction[0]),
    )
    .unwrap();
    let predictions = (speeds(omega_c).into_iter())
        .map(|w| predictor.at(w).unwrap())
        .collect();
    ((omega_c, k), predictions)
}

/// How much faster the linear prediction grows than the simulation: the documented gap.
/// The bilateral linearisation holds every blade on the casing; in the simulation the
/// unstable wave's contact-force perturbation alternates from blade to blade and every other
/// blade lifts off, so the rub feeds the wave through about half the blades, intermittently,
/// and it grows slower (`docs/stability.md` §6: 5–14×; README, "Outcomes": σ = 370–1460 1/s at
/// 1.1 Ω_c for two and five lobes, bare and coated, against the predicted 5828 1/s: 4.0–15.8×).
/// Measured on this setting: 4.8 (five lobes, bare), 15.0 (coated), 6.6 (two lobes, bare,
/// against the predicted ND 6 wave) at 1.1 Ω_c; 6.0 at case study 2's fastest job.
const PREDICTED_OVER_SIMULATED_GROWTH: std::ops::RangeInclusive<f64> = 4.0..=15.8;

/// Largest distance of the critical diameter's runaway wave's fixed-frame frequency from the
/// predicted one, as a fraction of it, close above the critical wave speed. The predicted
/// wave stands still in the rotating frame (its fixed-frame frequency kΩ/2π); the
/// alternative, the casing's free wave of that diameter (ω_k/2π, at which a released casing
/// would ring), lies 9 % lower at 1.1 Ω_c: the tolerance is a third of that gap. Measured:
/// +0.8 % (five lobes, bare), −0.03 % (coated). (The two-lobe load grows the ND 6 wave,
/// predicted 0.34 kHz off standing, which the simulation is not: its frequency is not
/// compared.)
const STANDING_WAVE_TOLERANCE: f64 = 0.03;

/// Asserts a runaway's figures against the prediction `p` at its speed (module doc): a
/// forward wave in the fixed frame of a diameter that the prediction makes grow
/// (quasi-statically: seen from the blades it changes sign more slowly than it grows
/// e-fold, so the rub it assumes persists), whose growth is slower than the
/// predicted one of that diameter by the documented gap. Returns the predicted wave.
fn check_against_prediction(label: &str, r: &Runaway, p: &StabilityAtSpeed) -> CoupledWave {
    let nd = r.nodal_diameter.expect("the growing wave's nodal diameter") as usize;
    let w = *(p.waves.iter())
        .find(|w| w.nodal_diameter == nd && w.quasi_static && w.growth_rate_per_s > 0.0)
        .unwrap_or_else(|| panic!("{label}: nodal diameter {nd} does not grow in the prediction"));
    let ratio = w.growth_rate_per_s / r.growth_rate_per_s;
    println!(
        "{label}: σ = {:.0} 1/s simulated, {:.0} 1/s predicted (ND {nd}): ratio {ratio:.2}",
        r.growth_rate_per_s, w.growth_rate_per_s
    );
    assert!(
        PREDICTED_OVER_SIMULATED_GROWTH.contains(&ratio),
        "{label}: the predicted growth rate {:.1} 1/s (ND {nd}) is {ratio:.2} × the simulated \
         {:.1} 1/s, outside the documented gap {PREDICTED_OVER_SIMULATED_GROWTH:?}",
        w.growth_rate_per_s,
        r.growth_rate_per_s
    );
    assert_eq!(
        r.forward,
        Some(!w.backward),
        "{label}: the simulated wave's direction (forward in the fixed frame: {:?}) is not the \
         predicted one (backward: {})",
        r.forward,
        w.backward
    );
    w
}

/// Total vibration energy (J) of both structures at sample `i`.
fn energy(out: &SimulationOutput, i: usize) -> f64 {
    out.impeller_energy.kinetic[i]
        + out.impeller_energy.strain[i]
        + out.casing_energy.kinetic[i]
        + out.casing_energy.strain[i]
}

/// The energy at the first sample at or after `t` (J).
fn energy_at(out: &SimulationOutput, t: f64) -> f64 {
    energy(out, out.time.iter().position(|&x| x >= t).unwrap())
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

/// The unwatched run's error, when it has one, must be the contact solve's breakdown under
/// the growing wave, named as such: what the time loop itself counts as the solve breaking
/// (`Simulation::run`: a divergence of the contact correction or of its solve, or a failed
/// closest-point projection), explained by the speed above the casing's critical wave speed
/// of nodal diameter `k`. Any other failure (a non-finite state, an invalid case, the
/// coating, the recorder…) is no evidence of a runaway.
fn assert_named_breakdown(label: &str, e: &SimError, k: usize) {
    let solve_broke = match e {
        SimError::Diverged { reason, .. } => !reason.starts_with("non-finite"),
        SimError::Projection { reason, .. } => reason.starts_with("closest point"),
        _ => false,
    };
    let named = matches!(e, SimError::Diverged { reason, .. } | SimError::Projection { reason, .. }
        if reason.contains("above the flexible casing's critical wave speed")
            && reason.contains(&format!("nodal diameter {k},")));
    assert!(
        solve_broke && named,
        "{label}: the unwatched run failed, but not by the contact solve's breakdown under the \
         critical wave: {e}"
    );
}

/// A runaway called by the watch in the watched run `(out, summary)` of the scenario `v` at
/// speed `p.omega_rad_s`, checked as a finding: before the contact solve's breakdown (close
/// above Ω_c the growth is slow and steady: the watch's steady-rate test confirms it), with
/// exact contact on every kept sample step (residual penetration ≤ 1e-8 of the blade-tip
/// level, paper §3.3), against the prediction `p` (`check_against_prediction`; on the critical
/// diameter `k`, a wave standing still in the rotating frame as predicted), and as a true
/// runaway: run again without the watch past the stop, it grows on by a decade of energy (run
/// to the decade, at most 1.25 times the ln 10 / 2σ that its own rate σ needs for it), or its
/// solve gives up under the growing wave first, with the named breakdown. Returns the
/// runaway.
fn check_called(
    label: &str,
    v: &Value,
    (out, summary): (&SimulationOutput, &RunSummary),
    p: &StabilityAtSpeed,
    k: usize,
) -> Runaway {
    let r = summary
        .runaway
        .unwrap_or_else(|| panic!("{label}: not called unstable"));
    let stop = r.detected_time_s;
    let level = summary.peaks.blade_radial();
    println!(
        "{label}: unstable at {:.2} ms (onset {:.2} ms), σ = {:.0} 1/s (R² {:.2}), nodal \
         diameter {:?}, {:?} Hz, forward {:?}, {:?} Hz in the rotating frame, {} of {} steps \
         run; residual {:.3e} m, level {level:.3e} m",
        stop * 1e3,
        r.onset_time_s * 1e3,
        r.growth_rate_per_s,
        r.growth_fit_r2,
        r.nodal_diameter,
        r.frequency_hz,
        r.forward,
        r.rotating_frame_frequency_hz,
        summary.steps_run,
        summary.n_steps,
        summary.max_residual_penetration
    );
    assert!(summary.steps_run < summary.n_steps, "{label}");
    assert!(
        !r.at_solve_breakdown,
        "{label}: called only at the solve's breakdown: {r:?}"
    );
    assert!(
        summary.max_residual_penetration <= 1e-8 * level,
        "{label}: residual penetration {:.3e} m, level {level:.3e} m",
        summary.max_residual_penetration
    );
    check_energy_balance(out, T_F);
    let w = check_against_prediction(label, &r, p);
    if w.nodal_diameter == k {
        let f = r.frequency_hz.unwrap();
        assert!(
            (f / w.frequency_hz - 1.0).abs() <= STANDING_WAVE_TOLERANCE,
            "{label}: {f:.1} Hz against the predicted {:.1} Hz (ND {k})",
            w.frequency_hz
        );
    }
    let decade = 10f64.ln() / (2.0 * r.growth_rate_per_s);
    let mut unwatched = v.clone();
    unwatched["numerics"]["stop_on_runaway"] = false.into();
    unwatched["scenario"]["duration_s"] = (stop + 1.25 * decade).into();
    let (raw, result) = run_until_tenfold(&unwatched, stop);
    let last = raw.time.len() - 1;
    assert!(raw.time[last] > stop, "{label}");
    check_energy_balance(&raw, T_F);
    let (at_stop, at_end) = (energy_at(&raw, stop), energy(&raw, last));
    println!(
        "{label}: unwatched, {at_stop:.3e} J at the stop, {at_end:.3e} J at {:.2} ms: {:?}",
        raw.time[last] * 1e3,
        result.as_ref().err()
    );
    match result {
        Err(e) => assert_named_breakdown(label, &e, k),
        Ok(()) => assert!(
            at_end > 10.0 * at_stop,
            "{label}: unwatched it did not run away: {at_stop:.3e} J at the stop, {at_end:.3e} \
             J at {:.2} ms",
            raw.time[last] * 1e3
        ),
    }
    r
}

/// Runs the spec `v`'s single job (unwatched) step by step, until its energy exceeds ten
/// times its energy at `stop` (s), its duration ends, or a step fails; keeps the samples
/// recorded before an error. Stopping at the decade spares the growth's costliest steps,
/// where the contact forces reach hundreds of kN and box 4b iterates ten times.
fn run_until_tenfold(v: &Value, stop: f64) -> (SimulationOutput, Result<(), SimError>) {
    let spec = parse_spec(&v.to_string()).unwrap();
    let sim = ModelSimulator::new(&spec).unwrap();
    let (case, casing, _) = sim.case_for_job(&plan(&spec).unwrap().jobs[0]).unwrap();
    let duration = case.duration;
    let mut rec = SeriesRecorder::default();
    let mut run = Simulation::new(&case, sim.impeller(), &casing).unwrap();
    let mut seen = 0;
    loop {
        if let Err(e) = run.step(&mut rec) {
            return (rec.out, Err(e));
        }
        let out = &rec.out;
        if out.time.len() == seen {
            continue;
        }
        seen = out.time.len();
        let t = out.time[seen - 1];
        if t >= duration - 0.5 * run.time_step()
            || (t > stop && energy(out, seen - 1) > 10.0 * energy_at(out, stop))
        {
            return (rec.out, Ok(()));
        }
    }
}

/// The load's release (s): the scenario's ramp.
const T_F: f64 = 4e-3;

/// Just below the critical wave speed (0.95 Ω_c) the five-lobe response rings down after the
/// release, and is never called; just above (1.10 Ω_c) the contact stays closed and the
/// rotation's work piles up in the casing: the watch calls it `unstable` (`check_called`:
/// before the solve's breakdown, exact contact on every step, the critical diameter's forward
/// wave standing still in the rotating frame, growing slower than the prediction by the
/// documented gap), and unwatched it grows on by a decade. At every sample after the release
/// the energy gained never exceeds the rotation's work. Cheap: 12 ms below; above, the stop
/// at 6.6 ms, re-run to the decade at 7.25 ms (unwatched, the solve breaks down at 8.5 ms,
/// after the costliest steps of the growth; a breakdown and its named error: the ignored
/// `the_fastest_runaway_on_the_papers_formulation_keeps_exact_contact_up_to_its_stop`).
#[test]
fn the_casing_response_grows_above_its_critical_wave_speed_and_decays_below() {
    let ((omega_c, k), p) = casing_and_prediction(|w| vec![1.10 * w]);
    println!("casing critical wave speed {omega_c:.1} rad/s (nodal diameter {k})");

    // Below: the contact opens after the release and the response rings down; watched, it is
    // never called (the watch does not feed back: the run is the unwatched one).
    let (below, result) = run_spec(&scenario(0.95 * omega_c, 12e-3, 5, false, true));
    let summary = result.unwrap_or_else(|e| panic!("0.95 Ω_c: {e}"));
    assert_eq!(
        summary.runaway, None,
        "0.95 Ω_c: a ring-down called unstable"
    );
    assert_eq!(summary.steps_run, summary.n_steps);
    let r = check_energy_balance(&below, T_F);
    let last = below.time.len() - 1;
    let (at_release, at_end) = (energy(&below, r), energy(&below, last));
    println!("0.95 Ω_c: energy {at_release:.4e} J at release, {at_end:.4e} J at 12 ms");
    assert!(at_end < 0.25 * at_release, "{at_release:e} -> {at_end:e}");

    // Above: every step re-projected, so that the exact contact holds on each.
    let mut v = scenario(p[0].omega_rad_s, 12e-3, 5, false, true);
    v["numerics"]["decimation"] = 1.into();
    let (above, result) = run_spec(&v);
    let summary = result.unwrap_or_else(|e| panic!("1.10 Ω_c: the solve gave up first: {e}"));
    let r = check_called("1.10 Ω_c", &v, (&above, &summary), &p[0], k);
    assert_eq!(r.nodal_diameter, Some(k as u32), "{r:?}");
    let r0 = check_energy_balance(&above, T_F);
    let last = above.time.len() - 1;
    let (at_release, at_stop) = (energy(&above, r0), energy(&above, last));
    println!("1.10 Ω_c: energy {at_release:.4e} J at release, {at_stop:.4e} J at the stop");
    assert!(at_stop > 10.0 * at_release, "{at_release:e} -> {at_stop:e}");
}

/// A runaway is called, and the job stopped, before its contact solve gives up; a job that
/// rings down is never called: on each side of the critical wave speed, with and without the
/// coating, for two and five lobes (five lobes bare: the test above). Whether a case runs
/// away is the simulation's own answer (run again without the watch past the stop: it keeps
/// growing by a decade, or fails with the contact solve's breakdown, named); the watch must
/// agree with it. Each called runaway is checked as in `check_called`: against the linear
/// prediction at its speed (growth rate within the documented gap, direction, a diameter
/// that the prediction makes grow; on the critical diameter, standing still in the rotating
/// frame as predicted). The five-lobe load feeds the critical diameter itself. Cheap: 12 ms
/// per run (a ring-down's energy has fallen below half of its release value by then; the
/// runaways at 1.1 Ω_c are called by 8 ms).
#[test]
fn runaways_are_called_before_the_solve_gives_up_and_ring_downs_never() {
    let ((_, k), p) = casing_and_prediction(|w| vec![0.95 * w, 1.10 * w]);
    let mut called = vec![];
    for (lobes, coated, side) in [(2u32, false), (2, true), (5, true)]
        .into_iter()
        .flat_map(|(l, c)| [(l, c, 0), (l, c, 1)])
    {
        let factor = [0.95, 1.10][side];
        let label = format!("{lobes} lobes, coated {coated}, {factor} Ω_c");
        let v = scenario(p[side].omega_rad_s, 12e-3, lobes, coated, true);
        let (out, watched) = run_spec(&v);
        let summary = watched.unwrap_or_else(|e| panic!("{label}: the solve gave up first: {e}"));
        if summary.runaway.is_none() {
            // Ran to the end unwatched in effect (the watch never feeds back): it rang down.
            assert_eq!(summary.steps_run, summary.n_steps, "{label}");
            let (release, end) = (energy_at(&out, T_F), energy(&out, out.time.len() - 1));
            println!("{label}: ok, energy {release:.3e} J at release, {end:.3e} J at the end");
            assert!(
                end < 0.5 * release,
                "{label}: not a ring-down but not called"
            );
            continue;
        }
        let r = check_called(&label, &v, (&out, &summary), &p[side], k);
        called.push((lobes, coated, factor, r));
    }
    // Above the critical wave speed the five-lobe load feeds the casing's wave of the
    // critical nodal diameter, coated or not (bare: the test above).
    let (.., r) = called
        .iter()
        .find(|u| u.0 == 5 && u.1 && u.2 > 1.0)
        .expect("5 lobes, coated, above Ω_c: not called");
    assert_eq!(r.nodal_diameter, Some(k as u32));
    assert!(called.iter().all(|u| u.2 > 1.0), "a runaway below Ω_c");
}

/// Far above the critical wave speed (case study 2's fastest job, 1.18 Ω*₅ = 1.86 Ω_c) the
/// energy grows three decades in four periods of the critical wave and the contact forces
/// reach hundreds of kN per tip: the growth takes the contact past exactness (a residual
/// penetration above 1e-8 of the blade-tip level) before the watch can confirm it at the
/// close of an envelope block (one period of the critical wave, 0.29 ms), and it is called
/// there, at the step before (`at_solve_breakdown`). On this setting the massless boundary's
/// contact, solved on its static flexibility, loses exactness at 3.25 ms, at every step and
/// mode count tried (2.5e-7–7.7e-7 s, 4 and 10 modes), and still does with the steady-rate
/// test relaxed from 0.7 to 0.3 (a scratch mutation): the growth outruns the solve, not only
/// the steady-rate test. The paper's formulation on the spec's 10 modes is called so too, at
/// 3.47 ms (`docs/validation.md` §6; on 4 modes, whose contact stays exact longer, the watch
/// confirms it first, at 3.44 ms). The wave is the critical diameter's, forward, growing
/// slower than the prediction by the documented gap (far above Ω_c it no longer stands still
/// in the rotating frame: its frequency is not compared). Cheap: the job stops at 3.3 ms.
/// (Exact contact on every kept step of this job, ≤ 1e-8 of the level, and the unwatched
/// job's named breakdown a few periods later: the ignored
/// `the_fastest_runaway_on_the_papers_formulation_keeps_exact_contact_up_to_its_stop`; the
/// massless boundary keeps 3e-8 of the level on this job.)
#[test]
fn the_fastest_runaway_is_called_at_the_solve_breakdown() {
    let omega = 8131.262;
    let ((omega_c, k), p) = casing_and_prediction(|_| vec![omega]);
    let (_, result) = run_spec(&case_study_2_at(omega, 6e-3));
    let summary = result.unwrap_or_else(|e| panic!("the solve gave up first: {e}"));
    let r = summary.runaway.expect("called unstable");
    println!(
        "{:.2} Ω_c: unstable at {:.3} ms (onset {:.3} ms, at the solve's breakdown: {}), \
         σ = {:.0} 1/s, energy ×{:.0}, nodal diameter {:?}, {:?} Hz, forward {:?}",
        omega / omega_c,
        r.detected_time_s * 1e3,
        r.onset_time_s * 1e3,
        r.at_solve_breakdown,
        r.growth_rate_per_s,
        r.energy_growth,
        r.nodal_diameter,
        r.frequency_hz,
        r.forward,
    );
    assert!(
        r.at_solve_breakdown,
        "called by the steady-rate test, not at the solve's breakdown: {r:?}"
    );
    assert_eq!(r.nodal_diameter, Some(k as u32));
    check_against_prediction("1.18 Ω*₅", &r, &p[0]);
}

/// The fastest job of `the_fastest_runaway_is_called_at_the_solve_breakdown` on the shipped
/// spec's own formulation (the paper's mass-carrying boundary at h = 2e-7 s, 10 modes per
/// nodal diameter), every step re-projected: every step it keeps had exact contact (residual
/// penetration ≤ 1e-8 of the blade-tip level, paper §3.3; the massless boundary keeps 3e-8 on
/// this job), it is called at the solve's breakdown, on the critical diameter, forward,
/// within the documented gap of the prediction; unwatched, the same job runs on until its
/// contact solve gives up, with the error that names the critical wave (it used to fail so,
/// "residual penetration 1.4e-5 m after correction"). The full-fidelity tier:
/// `cargo test --release --test integration supercritical:: -- --ignored`.
#[test]
#[ignore = "full fidelity: cargo test --release --test integration supercritical:: -- --ignored"]
fn the_fastest_runaway_on_the_papers_formulation_keeps_exact_contact_up_to_its_stop() {
    let omega = 8131.262;
    let mut v = shipped_case_study_2_at(omega, 6e-3);
    v["numerics"]["decimation"] = 1.into();
    let ((_, k), p) = models_and_prediction(&v, |_| vec![omega]);
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
    assert!(r.at_solve_breakdown, "{r:?}");
    assert_eq!(r.nodal_diameter, Some(k as u32));
    check_against_prediction("1.18 Ω*₅, paper's formulation", &r, &p[0]);
    assert!(
        summary.max_residual_penetration <= 1e-8 * level,
        "residual penetration {:.3e} m, level {level:.3e} m",
        summary.max_residual_penetration
    );
    v["numerics"]["stop_on_runaway"] = false.into();
    v["numerics"]["decimation"] = 20.into();
    let (raw, result) = run_spec(&v);
    let last = raw.time.len() - 1;
    println!("unwatched: {result:?} at {:.3} ms", raw.time[last] * 1e3);
    let e = result.expect_err("unwatched, the contact solve never gave up");
    assert_named_breakdown("1.18 Ω*₅, unwatched", &e, k);
    assert!(raw.time[last] >= r.detected_time_s);
}
