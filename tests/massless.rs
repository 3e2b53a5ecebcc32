//! The massless boundary gives the paper formulation's answer on the built-in paper-scale
//! models (#24), and the contact correction leaves no penetration there (#23): the quickstart's two-lobe case at Ω = 3000 rad/s, μ = 0.15, the paper's
//! h = 1e-7 s against the massless boundary at half its own stability limit (about 7× the
//! step). Shortened to 8 ms (the load ramps over 4 ms, then is released).

use rubscan::analysis::spectra::SpectrumAnalyzer;
use rubscan::dynamics::numerics::Boundary;
use rubscan::dynamics::scenario::{InitialVelocity, LobeLoad};
use rubscan::dynamics::structure::Structure;
use rubscan::model::build::{CasingSpec, ImpellerSpec};
use rubscan::{Case, CasingModel, Numerics, SimulationOutput, casing_rom, impeller_rom, simulate};

const OMEGA: f64 = 3000.0;

fn run(boundary: Boundary, h: f64) -> SimulationOutput {
    let imp = impeller_rom(&ImpellerSpec::default()).unwrap();
    let cas = casing_rom(&CasingSpec::default()).unwrap();
    let case = Case {
        omega: OMEGA,
        duration: 8e-3,
        friction: 0.15,
        load: Some(LobeLoad {
            lobes: 2,
            static_displacement: 8e-4,
            ramp_time: 4e-3,
            hold_time: 0.0,
        }),
        clearance_offset: vec![],
        casing_probes: vec![[0, 4], [25, 4]],
        probes: vec![],
        initial_velocity: InitialVelocity::default(),
        numerics: Numerics {
            time_step: h,
            // About one sample per 2e-6 s in both runs.
            decimation: (2e-6 / h).round().max(1.0) as usize,
            boundary,
            ..Default::default()
        },
        coating: None,
    };
    simulate(&case, &imp, &CasingModel::Flexible(cas), None).unwrap()
}

fn peak(series: &[Vec<f64>]) -> f64 {
    series.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Frequency (Hz) of the largest spectral line of blade 0's trailing edge over the last 4 ms
/// (after the release), and the bin width.
fn dominant_frequency(out: &SimulationOutput) -> (f64, f64) {
    let dt = out.time[1] - out.time[0];
    let n = (4e-3 / dt) as usize;
    let signal = &out.blade_te_radial[0][out.time.len() - n..];
    let mut analyzer = SpectrumAnalyzer::new(n).unwrap();
    let amplitude = analyzer.amplitude_spectrum(signal, dt, true).unwrap();
    let k = (1..amplitude.len())
        .max_by(|&a, &b| amplitude[a].total_cmp(&amplitude[b]))
        .unwrap();
    let df = analyzer.bin_width(dt);
    (k as f64 * df, df)
}

#[test]
fn massless_boundary_gives_the_paper_formulations_answer_on_the_built_in_models() {
    let imp = impeller_rom(&ImpellerSpec::default()).unwrap();
    let cas = casing_rom(&CasingSpec::default()).unwrap();
    let limit = |rom, omega| {
        Structure::new(rom, omega)
            .unwrap()
            .with_boundary(Boundary::Massless)
            .stability_limit()
    };
    let h = 0.5 * limit(&imp, OMEGA).min(limit(&cas, 0.0));
    let mass = run(Boundary::Mass, 1e-7);
    let massless = run(Boundary::Massless, h);
    assert!(mass.summary.contact_steps > 0 && massless.summary.contact_steps > 0);
    let rel = |a: f64, b: f64| (a - b).abs() / b;
    let (te, te_ml) = (peak(&mass.blade_te_radial), peak(&massless.blade_te_radial));
    let (cas_m, cas_ml) = (peak(&mass.casing_radial), peak(&massless.casing_radial));
    let ((f, df), (f_ml, _)) = (dominant_frequency(&mass), dominant_frequency(&massless));
    eprintln!(
        "mass h = 1e-7 s / massless h = {h:.3e} s: blade TE peak {te:.4e} / {te_ml:.4e} m, \
         casing peak {cas_m:.4e} / {cas_ml:.4e} m, dominant {f:.0} / {f_ml:.0} Hz (bin {df:.0} Hz), \
         residual {:.2e} / {:.2e} m, loop {:.2} / {:.2} s",
        mass.summary.max_residual_penetration,
        massless.summary.max_residual_penetration,
        mass.summary.loop_seconds,
        massless.summary.loop_seconds
    );
    assert!(rel(te_ml, te) <= 0.05, "blade peak {te_ml:e} vs {te:e}");
    assert!(
        rel(cas_ml, cas_m) <= 0.05,
        "casing peak {cas_ml:e} vs {cas_m:e}"
    );
    assert!((f_ml - f).abs() <= 1.5 * df, "dominant {f_ml} Hz vs {f} Hz");
    for (out, level) in [(&mass, te), (&massless, te_ml)] {
        let residual = out.summary.max_residual_penetration;
        assert!(
            residual <= 1e-8 * level,
            "residual {residual:e} m, level {level:e} m"
        );
    }
}

/// The quickstart case at h = 2e-7 s (#23): the largest penetration left after the contact
/// correction, over every step, is below 1e-8 of the vibration level.
#[test]
fn contact_correction_leaves_no_penetration_on_the_quickstart_case() {
    let out = run(Boundary::Mass, 2e-7);
    let level = peak(&out.blade_te_radial);
    let residual = out.summary.max_residual_penetration;
    eprintln!("h = 2e-7 s: residual {residual:.3e} m, level {level:.3e} m");
    assert!(out.summary.contact_steps > 1000);
    assert!(
        residual <= 1e-8 * level,
        "residual {residual:e} m, level {level:e} m"
    );
}
