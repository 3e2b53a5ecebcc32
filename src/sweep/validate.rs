//! Whole-spec validation before anything runs or is written: [`resolve`] turns a sweep spec
//! into a [`ResolvedSweep`] (models built, loaded or taken from the cache) or returns every
//! issue with its JSON pointer and reason.
//!
//! Checks that need no model run first, in [`crate::sweep::spec`] (schema with did-you-mean
//! suggestions for unknown fields, physical bounds, options that do not apply to the chosen
//! models), so that typos fail in well under a second. The model-dependent checks follow:
//! - every grid speed lies in the impeller ROM's valid speed range ([`valid_speed_range`]) and
//!   K(Ω) = K0 + Ω² K1 + Ω⁴ K2 is positive semi-definite there ([`Structure::new`]);
//! - the time step is below the explicit stability limit 2/ω_max
//!   ([`Structure::stability_limit`]) of both structures at every grid speed;
//! - casing probes name contact nodes of the flexible casing, and every probe of
//!   `scenario.probes` a node of the models with the quantity it asks for.

use crate::contact::{GapDirection, ImposedGap};
use crate::dynamics::probes::resolve_probes;
use crate::dynamics::scenario::Rotation;
use crate::dynamics::structure::{Structure, StructureError};
use crate::io::{model_cache, rom_file};
use crate::model::rom::{Component, CyclicRom};
use crate::sweep::spec::{CasingSource, ModelSource, RigidCasing, SpecError, SpecIssue, SweepSpec};
use std::path::Path;

/// Fraction of the largest tabulated speed by which a speed-dependent impeller ROM may be
/// extrapolated. The reduction basis and the Campbell data cover the tabulated speeds; a
/// 10 % margin admits the usual ±10 % bracket around a critical speed near the top of the
/// table, while a speed far above it (a unit mistake, rpm given as rad/s) is refused.
pub const SPEED_EXTRAPOLATION: f64 = 0.1;

/// The casing of a resolved sweep.
#[derive(Clone, Debug)]
pub enum ResolvedCasing {
    /// A flexible casing ROM (built-in or from a file).
    Flexible(CyclicRom),
    /// A rigid casing as given in the spec (its surface is built per job, on the clearance).
    Rigid(RigidCasing),
    /// A rigid casing of gaps imposed per blade-tip node.
    ImposedGap(ImposedGap),
}

/// A sweep spec checked as a whole, with its models: what the simulator consumes.
#[derive(Clone, Debug)]
pub struct ResolvedSweep {
    /// The validated spec.
    pub spec: SweepSpec,
    /// Impeller ROM.
    pub impeller: CyclicRom,
    /// Tip clearance (m) built into the impeller geometry, when known (built-in models).
    pub nominal_clearance: Option<f64>,
    /// Casing.
    pub casing: ResolvedCasing,
}

/// Speeds (rad/s) over which an impeller ROM's stiffness K(Ω) may be used: the span of its
/// tabulated modal data, extended by [`SPEED_EXTRAPOLATION`] above; `None` (any speed) when
/// K does not depend on Ω (K1 = K2 = 0, e.g. an imported model at rest) or nothing is tabulated.
pub fn valid_speed_range(rom: &CyclicRom) -> Option<(f64, f64)> {
    let depends = rom.harmonics.iter().any(|h| {
        h.stiffness[1..]
            .iter()
            .any(|k| k.re.iter().chain(k.im.iter()).any(|&x| x != 0.0))
    });
    let speeds = rom.modal_data.iter().flat_map(|m| m.omega.iter().copied());
    let (lo, hi) = speeds.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), w| {
        (a.min(w), b.max(w))
    });
    (depends && lo <= hi).then_some((lo, hi * (1.0 + SPEED_EXTRAPOLATION)))
}

fn issue(path: impl Into<String>, reason: impl Into<String>) -> SpecIssue {
    SpecIssue {
        path: path.into(),
        reason: reason.into(),
    }
}

/// An error and its causes, each said once: many errors (the model errors, I/O errors with
/// their file) name their source in their own message, so the chain would repeat it.
pub(crate) fn causes(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = String::new();
    for message in std::iter::successors(Some(e), |e| e.source()).map(ToString::to_string) {
        if !text.contains(&message) {
            if !text.is_empty() {
                text.push_str(": ");
            }
            text.push_str(&message);
        }
    }
    text
}

/// `rom` when it models `kind` (an impeller turns in the rotating frame, a casing stands in
/// the fixed one: one cannot stand for the other); else why not, naming its file `path`.
fn of_kind(rom: CyclicRom, kind: Component, path: &Path) -> Result<CyclicRom, String> {
    if rom.component == kind {
        Ok(rom)
    } else {
        let name = |c: Component| match c {
            Component::Impeller => "an impeller",
            Component::Casing => "a casing",
        };
        Err(format!(
            "{} holds {} ROM, not {} one (`rubscan model info` says which a file holds)",
            path.display(),
            name(rom.component),
            name(kind)
        ))
    }
}

/// Validates `spec` as a whole and resolves its models; every problem is returned at once
/// with its JSON pointer. Static checks ([`SweepSpec::validate`]) run first and stop before
/// any model is built or loaded.
pub fn resolve(spec: &SweepSpec) -> Result<ResolvedSweep, SpecError> {
    spec.validate()?;
    let mut issues = Vec::new();
    // The built-in machine turning clockwise is the mirror image of the counter-clockwise one
    // (its blades lean the same way against the rotation); an imported model turns as given.
    let turned = |rom: CyclicRom| match spec.models.rotation {
        Rotation::Counterclockwise => rom,
        Rotation::Clockwise => rom.mirrored(),
    };
    let impeller = match &spec.models.impeller {
        ModelSource::Builtin(b) => model_cache::impeller_rom(b)
            .map(|rom| (turned(rom), Some(b.geometry.tip_clearance)))
            .map_err(|e| issue("/models/impeller/builtin", causes(e.as_ref()))),
        ModelSource::Rom(p) => rom_file::load(p)
            .map_err(|e| causes(&e))
            .and_then(|rom| of_kind(rom, Component::Impeller, p))
            .map(|rom| (rom, None))
            .map_err(|e| issue("/models/impeller/rom", e)),
    };
    let casing = match &spec.models.casing {
        CasingSource::Builtin(b) => model_cache::casing_rom(b)
            .map(|rom| ResolvedCasing::Flexible(turned(rom)))
            .map_err(|e| issue("/models/casing/builtin", causes(e.as_ref()))),
        CasingSource::Rom(p) => rom_file::load(p)
            .map_err(|e| causes(&e))
            .and_then(|rom| of_kind(rom, Component::Casing, p))
            .map(ResolvedCasing::Flexible)
            .map_err(|e| issue("/models/casing/rom", e)),
        CasingSource::Rigid(r) => Ok(ResolvedCasing::Rigid(r.clone())),
        CasingSource::ImposedGap(g) => Ok(ResolvedCasing::ImposedGap(g.clone())),
    };
    let ((impeller, nominal_clearance), casing) = match (impeller, casing) {
        (Ok(i), Ok(c)) => (i, c),
        (i, c) => {
            issues.extend(i.err());
            issues.extend(c.err());
            return Err(SpecError::Invalid(issues));
        }
    };
    check_displacement_scale(spec, &impeller, &mut issues);
    check_speeds_and_step(spec, &impeller, &casing, &mut issues);
    check_probes(spec, &casing, &mut issues);
    check_lobes(spec, &casing, &mut issues);
    check_gap_directions(&impeller, &casing, &mut issues);
    check_node_probes(spec, &impeller, &casing, &mut issues);
    if issues.is_empty() {
        Ok(ResolvedSweep {
            spec: spec.clone(),
            impeller,
            nominal_clearance,
            casing,
        })
    } else {
        Err(SpecError::Invalid(issues))
    }
}

/// Largest casing load, clearance or rigid-profile amplitude (m), relative to the blade-tip
/// radius: the models are linear, so their displacements must stay small against their size;
/// 5 % (10 mm at a 0.2 m tip) is 10× the paper's loads and clearances, and a value above it is
/// a unit mistake (mm given as m) that would fail only once its job runs.
pub const MAX_DISPLACEMENT_OF_RADIUS: f64 = 0.05;

/// The displacements the spec imposes, against [`MAX_DISPLACEMENT_OF_RADIUS`] of the
/// impeller's largest tip radius.
fn check_displacement_scale(spec: &SweepSpec, impeller: &CyclicRom, issues: &mut Vec<SpecIssue>) {
    let radius = impeller
        .contact_nodes
        .iter()
        .map(|n| n.position[0].hypot(n.position[1]))
        .fold(0.0, f64::max);
    let limit = MAX_DISPLACEMENT_OF_RADIUS * radius;
    let mut imposed: Vec<(String, f64)> = Vec::new();
    if let Some(a) = spec.scenario.load_amplitude_m {
        imposed.push(("/scenario/load_amplitude_m".into(), a));
    }
    for (i, c) in spec.grid.clearance_m.iter().flatten().enumerate() {
        imposed.push((format!("/grid/clearance_m/{i}"), *c));
    }
    if let CasingSource::Rigid(r) = &spec.models.casing {
        imposed.push(("/models/casing/rigid/amplitude_m".into(), r.amplitude_m));
        for (i, o) in r.gap_offsets_m.iter().flatten().enumerate() {
            imposed.push((format!("/models/casing/rigid/gap_offsets_m/{i}"), *o));
        }
    }
    for (path, value) in imposed {
        if value.abs() > limit {
            issues.push(issue(
                path,
                format!(
                    "{value} m is over {:.0} % of the blade-tip radius {radius:.4} m ({limit:.3e} m): \
                     the models are linear and their displacements small (a unit mistake?)",
                    100.0 * MAX_DISPLACEMENT_OF_RADIUS
                ),
            ));
        }
    }
}

/// JSON pointer of grid speed `i`.
fn speed_pointer(spec: &SweepSpec, i: usize) -> String {
    if spec.grid.speed.values.is_some() {
        format!("/grid/speed/values/{i}")
    } else {
        "/grid/speed/range".into()
    }
}

/// Speed range, definiteness of K(Ω) and the explicit stability limit at every grid speed.
fn check_speeds_and_step(
    spec: &SweepSpec,
    impeller: &CyclicRom,
    casing: &ResolvedCasing,
    issues: &mut Vec<SpecIssue>,
) {
    let casing_structure = match casing {
        ResolvedCasing::Flexible(rom) => match Structure::new(rom, 0.0) {
            Ok(s) => Some(s.with_numerics(&spec.numerics)),
            Err(e) => {
                issues.push(issue("/models/casing", e.to_string()));
                return;
            }
        },
        ResolvedCasing::Rigid(_) | ResolvedCasing::ImposedGap(_) => None,
    };
    let range = valid_speed_range(impeller);
    let h = spec.numerics.time_step;
    // Smallest stability limit over the grid: (limit s, Ω rad/s, which structure).
    let mut worst: Option<(f64, f64, String)> = None;
    for (i, omega) in spec.grid.speed.values_rad_s().into_iter().enumerate() {
        if let Some((lo, hi)) = range
            && !(lo..=hi).contains(&omega)
        {
            issues.push(issue(
                speed_pointer(spec, i),
                format!(
                    "Ω = {omega} rad/s is outside the impeller ROM's valid speed range \
                     [{lo}, {hi:.1}] rad/s (its modal data are tabulated up to {:.1} rad/s, \
                     +{:.0} % extrapolation allowed)",
                    hi / (1.0 + SPEED_EXTRAPOLATION),
                    100.0 * SPEED_EXTRAPOLATION
                ),
            ));
            continue;
        }
        let st = match Structure::new(impeller, omega) {
            Ok(st) => st.with_numerics(&spec.numerics),
            Err(e @ StructureError::Indefinite { .. }) => {
                issues.push(issue(
                    speed_pointer(spec, i),
                    format!(
                        "the impeller's stiffness loses definiteness at Ω = {omega} rad/s: {e}"
                    ),
                ));
                continue;
            }
            Err(e) => {
                issues.push(issue("/models/impeller", e.to_string()));
                return;
            }
        };
        let mut candidates = vec![(st.stability_limit(), format!("impeller `{}`", st.name))];
        if let Some(c) = &casing_structure {
            candidates.push((c.stability_limit(), format!("casing `{}`", c.name)));
        }
        for (limit, which) in candidates {
            if worst.as_ref().is_none_or(|w| limit < w.0) {
                worst = Some((limit, omega, which));
            }
        }
    }
    // The default step is below every limit by construction, so a job takes more steps
    // than the duration over the smallest limit.
    if let (None, Some((limit, _, _))) = (h, &worst) {
        spec.check_step_count(issues, *limit, "/scenario/duration_s");
    }
    if let Some((limit, omega, which)) = worst
        && let Some(h) = h
        && h >= limit
    {
        issues.push(issue(
            "/numerics/time_step_s",
            format!(
                "h = {h:.4e} s is at or above the explicit stability limit 2/ω_max = {limit:.4e} s \
                 of the {which} at Ω = {omega} rad/s; use time_step_s < {limit:.4e}"
            ),
        ));
    }
}

/// The probes must name nodes of the models and quantities those nodes have
/// ([`resolve_probes`]): the first wrong one is reported at `/scenario/probes/{i}[/field]`.
fn check_node_probes(
    spec: &SweepSpec,
    impeller: &CyclicRom,
    casing: &ResolvedCasing,
    issues: &mut Vec<SpecIssue>,
) {
    let casing_rom = match casing {
        ResolvedCasing::Flexible(rom) => Some(rom),
        ResolvedCasing::Rigid(_) | ResolvedCasing::ImposedGap(_) => None,
    };
    if let Err(e) = resolve_probes(&spec.scenario.probes, impeller, casing_rom) {
        let field = if e.field.is_empty() {
            String::new()
        } else {
            format!("/{}", e.field)
        };
        issues.push(issue(
            format!("/scenario/probes/{}{field}", e.index),
            e.reason,
        ));
    }
}

/// Casing probes must be contact nodes `[sector < N, node < M]` of the flexible casing.
fn check_probes(spec: &SweepSpec, casing: &ResolvedCasing, issues: &mut Vec<SpecIssue>) {
    let ResolvedCasing::Flexible(rom) = casing else {
        return; // Rejected by the static checks.
    };
    let (n, m) = (rom.n_sectors, rom.n_contact());
    for (i, &[sector, node]) in spec.scenario.casing_probes.iter().enumerate() {
        if sector >= n || node >= m {
            issues.push(issue(
                format!("/scenario/casing_probes/{i}"),
                format!(
                    "casing probe [{sector}, {node}] does not exist: the casing has {n} sectors \
                     (0..{n}) of {m} contact nodes (0..{m})"
                ),
            ));
        }
    }
}

/// An n-lobe casing load on N sectors is sampled once per sector: above N/2 lobes it aliases
/// to N − n lobes (Nyquist), so the casing would be loaded on a shape the spec does not say.
fn check_lobes(spec: &SweepSpec, casing: &ResolvedCasing, issues: &mut Vec<SpecIssue>) {
    let (ResolvedCasing::Flexible(rom), Some(lobes)) = (casing, spec.scenario.lobes) else {
        return;
    };
    let sectors = rom.n_sectors;
    if 2 * lobes as usize > sectors {
        issues.push(issue(
            "/scenario/lobes",
            format!(
                "{lobes} lobes on a casing of {sectors} sectors: at most {} (more alias to fewer \
                 lobes on the sectors)",
                sectors / 2
            ),
        ));
    }
}

/// An imposed-gap casing's per-node directions: one non-zero vector per impeller contact node.
fn check_gap_directions(
    impeller: &CyclicRom,
    casing: &ResolvedCasing,
    issues: &mut Vec<SpecIssue>,
) {
    let ResolvedCasing::ImposedGap(ImposedGap {
        direction: GapDirection::PerNode(d),
        ..
    }) = casing
    else {
        return;
    };
    let path = "/models/casing/imposed_gap/direction/per_node";
    if d.len() != impeller.n_contact() {
        issues.push(issue(
            path,
            format!(
                "{} directions for the impeller's {} contact nodes",
                d.len(),
                impeller.n_contact()
            ),
        ));
    }
    for (j, v) in d.iter().enumerate() {
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(n.is_finite() && n > 0.0) {
            issues.push(issue(format!("{path}/{j}"), "not a finite non-zero vector"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model that cannot be built is refused at its pointer, its reason said once (each
    /// layer of a model error names its source, and the chain must not repeat it).
    #[test]
    fn a_bad_built_in_geometry_is_named_once() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/sweeps/quickstart.json");
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        v["models"]["impeller"]["builtin"] =
            serde_json::json!({"geometry": {"blade_thickness": 0.5}});
        let spec = crate::sweep::parse_spec(&v.to_string()).unwrap();
        let Err(err) = resolve(&spec) else {
            panic!("a 0.5 m blade was accepted")
        };
        let err = err.to_string();
        assert!(err.contains("/models/impeller/builtin"), "{err}");
        assert_eq!(err.matches("blade_thickness").count(), 1, "{err}");
    }

    /// A casing ROM given as the impeller is refused at its pointer, naming the file and what
    /// it holds (it used to run, its sectors taken for blades).
    #[test]
    fn a_casing_rom_given_as_the_impeller_is_refused() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        let dir = std::env::temp_dir().join(format!("rubscan-kind-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("casing.rom");
        let casing = synthetic_rom(&SyntheticSpec::small(Component::Casing, 4, 2, 2));
        rom_file::save(&casing, &path).unwrap();
        let mut spec = rigid_spec(&[500.0], 1e-7);
        spec.models.impeller = ModelSource::Rom(path.clone());
        let Err(err) = resolve(&spec) else {
            panic!("a casing ROM was accepted as the impeller")
        };
        let err = err.to_string();
        assert!(
            err.contains("/models/impeller/rom")
                && err.contains(&path.display().to_string())
                && err.contains("holds a casing ROM, not an impeller one"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn speed_range_is_the_tabulated_span_when_k_depends_on_omega() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::{Component, ModalData};
        let mut rom = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 4, 2, 2));
        rom.modal_data = vec![ModalData {
            nodal_diameter: 0,
            omega: vec![0.0, 100.0],
            frequencies: vec![vec![1.0]; 2],
            shapes_re: vec![vec![]; 2],
            shapes_im: vec![vec![]; 2],
        }];
        for h in &mut rom.harmonics {
            for k in &mut h.stiffness[1..] {
                k.re.fill(0.0);
                k.im.fill(0.0);
            }
        }
        // No K1, K2: the model does not depend on Ω, any speed goes.
        assert_eq!(valid_speed_range(&rom), None);
        rom.harmonics[0].stiffness[1].re[(0, 0)] = 1.0;
        let (lo, hi) = valid_speed_range(&rom).unwrap();
        assert_eq!(lo, 0.0);
        assert!(
            (hi - 100.0 * (1.0 + SPEED_EXTRAPOLATION)).abs() < 1e-9,
            "{hi}"
        );
    }

    /// A synthetic impeller whose K(Ω) = K0 + Ω² K1 loses definiteness at Ω = 1000 rad/s,
    /// tabulated up to 2000 rad/s (so the range check passes and the eigenvalue check acts).
    fn softening_impeller() -> CyclicRom {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::{Component, ModalData};
        let mut rom = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 4, 2, 2));
        for h in &mut rom.harmonics {
            h.stiffness[1].re = &h.stiffness[0].re * (-1.0 / (1000.0f64 * 1000.0));
            h.stiffness[1].im = &h.stiffness[0].im * (-1.0 / (1000.0f64 * 1000.0));
            h.stiffness[2].re.fill(0.0);
            h.stiffness[2].im.fill(0.0);
        }
        rom.modal_data = vec![ModalData {
            nodal_diameter: 0,
            omega: vec![0.0, 2000.0],
            frequencies: vec![vec![1.0]; 2],
            shapes_re: vec![vec![]; 2],
            shapes_im: vec![vec![]; 2],
        }];
        rom
    }

    fn rigid_spec(speeds: &[f64], h: f64) -> SweepSpec {
        crate::sweep::spec::spec_from_value(serde_json::json!({
            "name": "t",
            "models": {"impeller": {"rom": "x.rom"}, "casing": {"rigid": {"lobes": 2, "amplitude_m": 1e-4}}},
            "scenario": {"duration_s": 0.01},
            "numerics": {"time_step_s": h},
            "grid": {"speed": {"unit": "rad_s", "values": speeds}, "friction": [0.1]}
        }))
        .unwrap()
    }

    #[test]
    fn indefinite_stiffness_and_unstable_step_name_the_speed_and_the_limit() {
        let imp = softening_impeller();
        let casing = ResolvedCasing::Rigid(RigidCasing {
            lobes: 2,
            amplitude_m: 1e-4,
            gap_offsets_m: None,
        });
        let limit = Structure::new(&imp, 500.0).unwrap().stability_limit();
        // Below 1000 rad/s and below the stability limit: nothing to say.
        let mut issues = vec![];
        check_speeds_and_step(
            &rigid_spec(&[500.0], 0.5 * limit),
            &imp,
            &casing,
            &mut issues,
        );
        assert!(issues.is_empty(), "{issues:?}");
        // Above 1000 rad/s the stiffness is indefinite; h above the limit at 500 rad/s.
        check_speeds_and_step(
            &rigid_spec(&[500.0, 1500.0], 2.0 * limit),
            &imp,
            &casing,
            &mut issues,
        );
        let text: Vec<String> = issues.iter().map(ToString::to_string).collect();
        assert_eq!(text.len(), 2, "{text:?}");
        assert!(
            text[0].starts_with("/grid/speed/values/1: ")
                && text[0].contains("1500 rad/s")
                && text[0].contains("definiteness"),
            "{text:?}"
        );
        assert!(
            text[1].starts_with("/numerics/time_step_s: ")
                && text[1].contains("stability limit")
                && text[1].contains("Ω = 500 rad/s"),
            "{text:?}"
        );
    }
}
