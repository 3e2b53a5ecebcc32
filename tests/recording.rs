//! Recording does not change the physics: the same job sampled every step, every 10th and
//! every 100th step (and recorded into memory or only aggregated) gives bit-identical probes
//! at the common sample times and the same run counters, on the built-in paper-scale models
//! (flexible casing under its two-lobe load, friction, abradable coating) and on a rigid
//! casing.

use rubscan::app::{casing_rom, impeller_rom};
use rubscan::dynamics::abradable::CoatingMaterial;
use rubscan::dynamics::probes::{ProbeComponent, ProbeQuantity, ProbeSpec};
use rubscan::dynamics::recorder::SeriesRecorder;
use rubscan::dynamics::simulate::{CASING_PEAK_INTERVAL, Simulation};
use rubscan::dynamics::{Case, CasingModel, CoatingCase, LobeLoad, Numerics, SimulationOutput};
use rubscan::model::build::{CasingSpec, ImpellerSpec};
use rubscan::model::rom::CyclicRom;
use rubscan::sweep::aggregate::JobAggregator;
use rubscan::sweep::simulator::{rigid_casing, rigid_meridian, tip_rows};

/// Per-blade (or per-probe, per-nodal-diameter) series `[index][sample]`.
type Series = Vec<Vec<f64>>;

fn run(case: &Case, imp: &CyclicRom, casing: &CasingModel) -> SimulationOutput {
    let mut rec = SeriesRecorder::default();
    let summary = Simulation::new(case, imp, casing)
        .unwrap()
        .run(&mut rec, None)
        .unwrap();
    rec.into_output(summary)
}

/// Every probe of `a` at sample `i·stride` equals (bitwise) that of `b` at sample `i`.
fn assert_common_samples_equal(a: &SimulationOutput, b: &SimulationOutput, stride: usize) {
    assert!(!b.time.is_empty());
    let pick = |s: &[f64]| -> Vec<u64> {
        s.iter()
            .skip(stride - 1)
            .step_by(stride)
            .map(|x| x.to_bits())
            .collect()
    };
    let bits = |s: &[f64]| -> Vec<u64> { s.iter().map(|x| x.to_bits()).collect() };
    let same = |name: &str, x: &[f64], y: &[f64]| {
        assert_eq!(pick(x), bits(y), "{name} differs (stride {stride})");
    };
    same("time", &a.time, &b.time);
    let groups: [(&str, &Series, &Series); 7] = [
        ("probes", &a.probes, &b.probes),
        ("blade_le_radial", &a.blade_le_radial, &b.blade_le_radial),
        ("blade_te_radial", &a.blade_te_radial, &b.blade_te_radial),
        ("casing_radial", &a.casing_radial, &b.casing_radial),
        ("normal_force", &a.blade_normal_force, &b.blade_normal_force),
        (
            "tangential_force",
            &a.blade_tangential_force,
            &b.blade_tangential_force,
        ),
        (
            "nd_strain_energy",
            &a.impeller_nd_strain_energy,
            &b.impeller_nd_strain_energy,
        ),
    ];
    for (name, x, y) in groups {
        assert_eq!(x.len(), y.len(), "{name}");
        for (xs, ys) in x.iter().zip(y) {
            same(name, xs, ys);
        }
    }
    same("min_gap", &a.min_gap, &b.min_gap);
    same(
        "impeller kinetic energy",
        &a.impeller_energy.kinetic,
        &b.impeller_energy.kinetic,
    );
    same(
        "casing strain energy",
        &a.casing_energy.strain,
        &b.casing_energy.strain,
    );
    if let (Some(ca), Some(cb)) = (&a.summary.coating, &b.summary.coating) {
        for (x, y) in a.coating_max_wear.iter().zip(&b.coating_max_wear) {
            same("coating max wear", x, y);
        }
        assert_eq!(ca.final_wear, cb.final_wear);
    }
    assert_eq!(
        (a.summary.contact_steps, a.summary.active_contacts),
        (b.summary.contact_steps, b.summary.active_contacts)
    );
    assert_eq!(
        a.summary.peaks.blade_radial().to_bits(),
        b.summary.peaks.blade_radial().to_bits()
    );
}

/// Checks the decimations and the aggregator on `case`; returns the run sampled every step.
fn check_decimations(case: &Case, imp: &CyclicRom, casing: &CasingModel) -> SimulationOutput {
    let with = |d: usize| {
        let mut c = case.clone();
        c.numerics.decimation = d;
        run(&c, imp, casing)
    };
    let every = with(1);
    let coating_steps = every
        .summary
        .coating
        .as_ref()
        .map_or(0, |c| c.coating_steps);
    assert!(
        every.summary.contact_steps + coating_steps > every.summary.n_steps / 2,
        "the case must rub: {} contact and {coating_steps} coating steps of {}",
        every.summary.contact_steps,
        every.summary.n_steps
    );
    for d in [10, 100] {
        assert_common_samples_equal(&every, &with(d), d);
    }
    // Aggregating sparse samples instead of keeping the series: the maxima of every step.
    let mut agg = JobAggregator::new(case.omega, 0.0, usize::MAX);
    let mut c = case.clone();
    c.numerics.decimation = 10;
    let summary = Simulation::new(&c, imp, casing)
        .unwrap()
        .run(&mut agg, None)
        .unwrap();
    let row = agg.finish(&summary).unwrap();
    let peak = |series: &[Vec<f64>], stride: usize| {
        let every_step = series
            .iter()
            .flat_map(|s| s.iter().step_by(stride))
            .fold(0.0f64, |m, x| m.max(x.abs()));
        let sampled = series
            .iter()
            .flat_map(|s| s.iter().skip(9).step_by(10))
            .fold(0.0f64, |m, x| m.max(x.abs()));
        (every_step, sampled)
    };
    let m = &row.maxima;
    let coating = &every.coating_blade_force;
    // The casing probes are read every CASING_PEAK_INTERVAL (a pass over the casing's modal
    // state), on the modal state by a functional, not from the synthesised nodes.
    let casing_stride = ((CASING_PEAK_INTERVAL / summary.time_step).floor() as usize).max(1);
    assert!(casing_stride > 1, "the case must exercise the stride");
    for (name, value, series, stride) in [
        ("blade LE", m.blade_le_radial_m, &every.blade_le_radial, 1),
        ("blade TE", m.blade_te_radial_m, &every.blade_te_radial, 1),
        (
            "contact force",
            m.contact_normal_force_n,
            &every.blade_normal_force,
            1,
        ),
        ("coating force", m.coating_force_n, coating, 1),
        (
            "casing",
            m.casing_radial_m,
            &every.casing_radial,
            casing_stride,
        ),
    ] {
        let (every_step, sampled) = peak(series, stride);
        let recorded = series.iter().any(|s| !s.is_empty());
        assert!(
            every_step > 0.0 || !recorded,
            "{name}: the case must move it"
        );
        if stride == 1 {
            assert_eq!(value.to_bits(), every_step.to_bits(), "{name}");
            assert!(value >= sampled, "{name}");
        } else {
            assert!(
                (value - every_step).abs() <= 1e-12 * every_step,
                "{name}: {value} against {every_step}"
            );
        }
    }
    assert_eq!(summary.contact_steps, every.summary.contact_steps);
    every
}

/// Gap, forces and displacements of the trailing-edge tip node of blades 0 and 3, and a
/// casing contact node `[sector, row]`: probes that read the state (the gap re-projects a
/// node) must leave it unchanged.
fn tip_probes(rows: usize, casing: Option<[usize; 2]>) -> Vec<ProbeSpec> {
    let mut v = Vec::new();
    for blade in [0, 3] {
        for (quantity, component) in [
            (ProbeQuantity::Gap, None),
            (ProbeQuantity::NormalForce, None),
            (ProbeQuantity::TangentialForce, None),
            (ProbeQuantity::Displacement, Some(ProbeComponent::Radial)),
            (
                ProbeQuantity::Displacement,
                Some(ProbeComponent::Tangential),
            ),
        ] {
            v.push(ProbeSpec {
                node: None,
                point: None,
                contact_node: None,
                blade: Some(blade),
                sector: None,
                row: Some(rows - 1),
                quantity,
                component,
            });
        }
    }
    if let Some([sector, row]) = casing {
        v.push(ProbeSpec {
            node: None,
            point: None,
            contact_node: None,
            blade: None,
            sector: Some(sector),
            row: Some(row),
            quantity: ProbeQuantity::Displacement,
            component: Some(ProbeComponent::Axial),
        });
    }
    v
}

fn paper_models() -> (CyclicRom, CyclicRom) {
    (
        impeller_rom(&ImpellerSpec::default()).unwrap(),
        casing_rom(&CasingSpec::default()).unwrap(),
    )
}

#[test]
fn decimation_does_not_change_a_coated_flexible_casing_run() {
    let (imp, cas) = paper_models();
    let rows = imp.contact_nodes.iter().map(|c| c.row).max().unwrap() + 1;
    let h = 1e-7;
    let coating = CoatingCase::new(CoatingMaterial::nominal());
    let case = Case {
        omega: 3000.0,
        rotation: Default::default(),
        duration: 3000.0 * h,
        friction: 0.15,
        // A two-lobe load held from the start, deep enough to cut through the 2 mm coating:
        // the trailing edge loads the coating from about step 300 on, then the casing.
        load: Some(LobeLoad {
            lobes: 2,
            static_displacement: 3e-3,
            ramp_time: h,
            hold_time: 1.0,
        }),
        clearance_offset: vec![-coating.material.thickness; rows],
        casing_probes: vec![[0, 4], [25, 4]],
        probes: tip_probes(rows, Some([25, 4])),
        initial_velocity: Default::default(),
        numerics: Numerics {
            time_step: Some(h),
            ..Default::default()
        },
        coating: Some(coating),
    };
    let every = check_decimations(&case, &imp, &CasingModel::Flexible(cas));
    assert!(every.summary.contact_steps > 0 && every.summary.coating.unwrap().coating_steps > 0);
}

#[test]
fn decimation_does_not_change_a_rigid_casing_run() {
    let (imp, _) = paper_models();
    let tips = tip_rows(&imp);
    // A casing 0.1 mm off the tips, distorted in 3 lobes of 0.2 mm: the blades rub at every
    // lobe passage.
    let h = 1e-7;
    let casing = CasingModel::Rigid(rigid_casing(
        3,
        2e-4,
        None,
        Some(120),
        rigid_meridian(&tips, 1e-4),
    ));
    let case = Case {
        omega: 3000.0,
        rotation: Default::default(),
        duration: 3000.0 * h,
        friction: 0.15,
        load: None,
        clearance_offset: vec![],
        casing_probes: vec![],
        probes: tip_probes(tips.len(), None),
        initial_velocity: Default::default(),
        numerics: Numerics {
            time_step: Some(h),
            ..Default::default()
        },
        coating: None,
    };
    check_decimations(&case, &imp, &casing);
}
