//! Per-step timing of the simulation at a given model size, shared by the benches
//! (`time_step`, `stage_breakdown`): wall-clock µs per time step, single thread.
#![allow(dead_code)] // each bench target uses part of this module

use rubscan::dynamics::abradable::CoatingMaterial;
use rubscan::dynamics::numerics::{KernelChoice, Numerics};
use rubscan::dynamics::probes::StageSeconds;
use rubscan::dynamics::scenario::{Case, CasingModel, CoatingCase, InitialVelocity, LobeLoad};
use rubscan::dynamics::simulate::{SimError, simulate};
use rubscan::dynamics::structure::Structure;
use rubscan::fixtures::{SyntheticSpec, synthetic_rom};
use rubscan::model::rom::CyclicRom;

/// Result of [`bench_time_step`].
/// Timing of one bench run.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchResult {
    /// Wall-clock time per step (µs), setup excluded.
    pub us_per_step: f64,
    /// Fraction of (step × blade-tip node) pairs with a positive Lagrange multiplier.
    pub contact_fraction: f64,
    /// Fraction of the steps with at least one contact candidate (they run the contact
    /// solve and the correction).
    pub contact_step_fraction: f64,
    /// Fraction of the steps in which the abradable coating pushes some tip (0 uncoated).
    pub coating_step_fraction: f64,
    /// Steps run.
    pub n_steps: usize,
    /// The loop time per step split by stage (µs per step).
    pub stage_us: StageSeconds,
    /// Time step h (s) and steps per revolution at the bench speed.
    pub time_step: f64,
    pub steps_per_revolution: f64,
}

/// Times `steps` steps of `impeller` in the flexible `casing` at Ω = `omega`, with the kernel
/// `kernel`; `contact_offset` (m) is added to the blade tips' radius on the trailing-edge row
/// (enough to overlap the casing puts that row in permanent contact). Only the stepping loop is
/// timed (`SimulationOutput::loop_seconds`); probes are sampled at the default decimation.
pub fn bench_time_step(
    impeller: &CyclicRom,
    casing: &CyclicRom,
    omega: f64,
    kernel: KernelChoice,
    contact_offset: f64,
    steps: usize,
) -> Result<BenchResult, SimError> {
    let rows = impeller
        .contact_nodes
        .iter()
        .map(|c| c.row)
        .max()
        .unwrap_or(0)
        + 1;
    let mut offs = vec![0.0; rows];
    offs[rows - 1] = contact_offset;
    bench_with_offsets(impeller, casing, omega, kernel, offs, None, steps)
}

/// Time step (s) of the benches: half the smaller stability limit, at most 1e-7 s.
fn bench_step(impeller: &CyclicRom, casing: &CyclicRom, omega: f64) -> Result<f64, SimError> {
    Ok(0.5
        * Structure::new(impeller, omega)?
            .stability_limit()
            .min(Structure::new(casing, 0.0)?.stability_limit())
            .min(2e-7))
}

/// [`bench_time_step`] with an explicit outward offset (m) per impeller contact row.
pub fn bench_with_offsets(
    impeller: &CyclicRom,
    casing: &CyclicRom,
    omega: f64,
    kernel: KernelChoice,
    offs: Vec<f64>,
    load: Option<LobeLoad>,
    steps: usize,
) -> Result<BenchResult, SimError> {
    let numerics = Numerics {
        time_step: Some(bench_step(impeller, casing, omega)?),
        kernel,
        ..Default::default()
    };
    bench_case(impeller, casing, omega, numerics, offs, load, steps)
}

/// [`bench_with_offsets`] with explicit numerics (time step, kernel, boundary model).
pub fn bench_case(
    impeller: &CyclicRom,
    casing: &CyclicRom,
    omega: f64,
    numerics: Numerics,
    offs: Vec<f64>,
    load: Option<LobeLoad>,
    steps: usize,
) -> Result<BenchResult, SimError> {
    let case = coated_case(omega, numerics, offs, load, None, steps);
    bench_run(impeller, casing, &case)
}

/// The case of [`bench_case`] with a coating: μ = 0.1, `steps` steps of `numerics.time_step`.
pub fn coated_case(
    omega: f64,
    numerics: Numerics,
    offs: Vec<f64>,
    load: Option<LobeLoad>,
    coating: Option<CoatingCase>,
    steps: usize,
) -> Case {
    Case {
        omega,
        rotation: Default::default(),
        duration: steps as f64 * numerics.time_step.expect("benches set their step"),
        friction: 0.1,
        load,
        clearance_offset: offs,
        casing_probes: vec![],
        probes: vec![],
        initial_velocity: InitialVelocity::default(),
        numerics,
        coating,
    }
}

/// Times `case` for `impeller` in the flexible `casing`.
pub fn bench_run(
    impeller: &CyclicRom,
    casing: &CyclicRom,
    case: &Case,
) -> Result<BenchResult, SimError> {
    let casing = CasingModel::Flexible(casing.clone());
    let out = simulate(case, impeller, &casing, None)?;
    let nodes = (impeller.n_sectors * impeller.n_contact()) as f64;
    let in_contact =
        out.summary.active_contacts as f64 / (out.summary.n_steps.max(1) as f64 * nodes);
    let per = 1e6 / out.summary.n_steps.max(1) as f64;
    let st = out.summary.stage_seconds;
    Ok(BenchResult {
        us_per_step: out.summary.loop_seconds * per,
        contact_fraction: in_contact,
        contact_step_fraction: out.summary.contact_steps as f64 / out.summary.n_steps.max(1) as f64,
        n_steps: out.summary.n_steps,
        stage_us: StageSeconds {
            predict: st.predict * per,
            spline: st.spline * per,
            projection: st.projection * per,
            contact_solve: st.contact_solve * per,
            correction: st.correction * per,
            other: st.other * per,
        },
        time_step: out.summary.time_step,
        steps_per_revolution: out.summary.steps_per_revolution,
        coating_step_fraction: out.summary.coating.as_ref().map_or(0.0, |c| {
            c.coating_steps as f64 / out.summary.n_steps.max(1) as f64
        }),
    })
}

/// [`bench_time_step`] on the paper-scale synthetic models (casing N = 100, M = 5, 10 modes/ND;
/// impeller N_b = 10, 5 tip nodes, 10 modes/ND) at Ω = 1000 rad/s.
pub fn bench_paper_scale(
    kernel: KernelChoice,
    contact: bool,
    steps: usize,
) -> Result<BenchResult, SimError> {
    let imp = synthetic_rom(&SyntheticSpec::paper_impeller());
    let cas = synthetic_rom(&SyntheticSpec::paper_casing());
    let off = if contact {
        1.5 * SyntheticSpec::paper_impeller().clearance
    } else {
        0.0
    };
    bench_time_step(&imp, &cas, 1000.0, kernel, off, steps)
}

/// Radial clearance (m) of the impeller's contact row `row` (its first node): the casing
/// meridian (contact nodes, `(r, z)` by row) interpolated linearly at the node's `z`, minus the
/// node's radius. Positive when the blade tip is inside. An estimate for benchmark setups.
pub fn radial_clearance(impeller: &CyclicRom, casing: &CyclicRom, row: usize) -> f64 {
    let r = |p: &[f64; 3]| (p[0] * p[0] + p[1] * p[1]).sqrt();
    let Some(node) = impeller.contact_nodes.iter().find(|c| c.row == row) else {
        return 0.0;
    };
    let (rb, zb) = (r(&node.position), node.position[2]);
    let mer: Vec<(f64, f64)> = casing
        .contact_nodes
        .iter()
        .map(|c| (r(&c.position), c.position[2]))
        .collect();
    let mut best = (f64::INFINITY, 0.0);
    for w in mer.windows(2) {
        let ((r0, z0), (r1, z1)) = (w[0], w[1]);
        let t = if z1 != z0 { (zb - z0) / (z1 - z0) } else { 0.0 };
        let tc = t.clamp(0.0, 1.0);
        // Distance outside the segment's z-range ranks the candidates.
        let miss = (t - tc).abs();
        if miss < best.0 {
            best = (miss, r0 + tc * (r1 - r0) - rb);
        }
    }
    best.1
}

/// Static inward displacement of the bench's casing load, in units of the middle contact
/// row's radial clearance (see [`bench_default_models`]).
pub const BENCH_LOBE_DEPTH: f64 = 2.0;

/// [`bench_time_step`] on the built-in paper-scale models
/// (`app::impeller_rom(&ImpellerSpec::default())`, `app::casing_rom(&CasingSpec::default())`,
/// built on first use and cached) at Ω = `omega` (rad/s). With `contact`, the casing is
/// ovalised as in the paper's case study 1 and kept so: a two-lobe load on its trailing-edge
/// nodes, ramped over 20 steps and then held, whose static inward displacement is
/// [`BENCH_LOBE_DEPTH`] × the middle row's radial clearance. The blades then rub near the two
/// lobes only, about 10 % of the tip nodes at a time.
pub fn bench_default_models(
    kernel: KernelChoice,
    contact: bool,
    omega: f64,
    steps: usize,
) -> anyhow::Result<BenchResult> {
    bench_default_models_coated(kernel, contact, omega, steps, None)
}

/// [`bench_default_models`] with the nominal coating ([`CoatingMaterial::nominal`], 2 mm
/// thick) of `eta` elements per row, or without coating (`None`). As in a sweep job, the
/// clearances are to the coating's unworn surface: the tips move in by its thickness, and the
/// load cuts the coating near the lobes as it makes the uncoated tips rub.
pub fn bench_default_models_coated(
    kernel: KernelChoice,
    contact: bool,
    omega: f64,
    steps: usize,
    eta: Option<usize>,
) -> anyhow::Result<BenchResult> {
    use rubscan::model::build::{CasingSpec, ImpellerSpec};
    let imp = rubscan::app::impeller_rom(&ImpellerSpec::default())?;
    let cas = rubscan::app::casing_rom(&CasingSpec::default())?;
    let case = default_models_case(&imp, &cas, kernel, contact, omega, steps, eta)?;
    Ok(bench_run(&imp, &cas, &case)?)
}

/// The case of [`bench_default_models_coated`] for the built-in models `imp`, `cas`.
pub fn default_models_case(
    imp: &CyclicRom,
    cas: &CyclicRom,
    kernel: KernelChoice,
    contact: bool,
    omega: f64,
    steps: usize,
    eta: Option<usize>,
) -> Result<Case, SimError> {
    let rows = imp.contact_nodes.iter().map(|c| c.row).max().unwrap_or(0) + 1;
    let h = bench_step(imp, cas, omega)?;
    let load = contact.then(|| LobeLoad {
        lobes: 2,
        static_displacement: BENCH_LOBE_DEPTH * radial_clearance(imp, cas, rows / 2).max(0.0),
        ramp_time: 20.0 * h,
        hold_time: f64::INFINITY,
    });
    let coating = eta.map(|eta| CoatingCase {
        eta,
        ..CoatingCase::new(CoatingMaterial::nominal())
    });
    let e_abr = coating.as_ref().map_or(0.0, |c| c.material.thickness);
    let numerics = Numerics {
        time_step: Some(h),
        kernel,
        ..Default::default()
    };
    Ok(coated_case(
        omega,
        numerics,
        vec![-e_abr; rows],
        load,
        coating,
        steps,
    ))
}
