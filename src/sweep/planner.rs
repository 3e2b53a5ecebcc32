//! Planner: expands a validated [`SweepSpec`] into [`Job`]s with fully resolved
//! parameters and stable ids.
//!
//! Order: full factorial over the axes in [`AxisName::ALL`] order, with speed
//! varying fastest (so consecutive jobs form a speed scan, the natural layout of
//! an interaction map). Zipped axes form one combined axis placed at the slot of
//! the first zipped axis. The order depends only on the spec.
//!
//! Job id: FNV-1a 64-bit hash of the canonical JSON (keys sorted, no whitespace,
//! floats in serde_json's shortest round-trip form) of
//! `{"identity": JOB_IDENTITY, "params": …, "models": …, "scenario": …, "numerics": …}`,
//! printed as 16 hex digits. Everything that decides the numbers is in it: the formulation
//! (`numerics.boundary`, always written), the time step (given, or the default rule, whose
//! revision is [`JOB_IDENTITY`]) and, for built-in models, the modes per nodal diameter (the
//! whole build spec is written, defaults filled in). A change of a default bumps
//! [`JOB_IDENTITY`], and a run refuses an output directory written under another one.
//! The sweep name, description and the job's position are *not* hashed, so
//! renaming a sweep, reordering axes or extending a grid keeps the ids (and the
//! finished results) of the jobs that did not change. ROM paths enter the hash by
//! file name only (so a sweep directory can move between machines); changing a
//! ROM file's content keeps the id — delete the job files to force a re-run.

use std::sync::Arc;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::dynamics::scenario::Rotation;
use crate::io::content_hash::content_hash;

use super::spec::{
    AxisName, CasingSource, CoatingAxis, ModelSource, Numerics, Scenario, SpecError, SweepSpec,
};

/// A coating property setting of one job.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CoatingValue {
    /// Absolute value (Pa for moduli and stress, m for thickness).
    Absolute(f64),
    /// Factor on the model's nominal value (resolved by the simulator).
    Scale(f64),
}

/// Coating settings of one job; `None` = the model's nominal value.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct CoatingParams {
    /// Young's modulus E.
    pub young: Option<CoatingValue>,
    /// Plastic (hardening) modulus K.
    pub hardening: Option<CoatingValue>,
    /// Yield stress σ_Y.
    pub yield_stress: Option<CoatingValue>,
    /// Thickness e_abr.
    pub thickness: Option<CoatingValue>,
}

/// Fully resolved grid parameters of one job.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JobParams {
    /// Rotation speed Ω (rad/s).
    pub speed_rad_s: f64,
    /// Coulomb friction coefficient μ.
    pub friction: f64,
    /// Clearance (m); `None` = the model's own.
    pub clearance_m: Option<f64>,
    /// Coating settings.
    pub coating: CoatingParams,
}

/// Human-readable description of a job's non-speed parameters (the slice key of an
/// interaction map), e.g. `μ = 0.15, E ×0.1, e_abr = 0.00015 m`.
pub(crate) fn slice_label(p: &JobParams) -> String {
    let mut parts = vec![format!("μ = {}", p.friction)];
    if let Some(c) = p.clearance_m {
        parts.push(format!("clearance = {c} m"));
    }
    let c = &p.coating;
    for (name, unit, v) in [
        ("E", "Pa", c.young),
        ("K", "Pa", c.hardening),
        ("σ_Y", "Pa", c.yield_stress),
        ("e_abr", "m", c.thickness),
    ] {
        match v {
            Some(CoatingValue::Absolute(x)) => parts.push(format!("{name} = {x} {unit}")),
            Some(CoatingValue::Scale(f)) => parts.push(format!("{name} ×{f}")),
            None => {}
        }
    }
    parts.join(", ")
}

/// What is common to every job of a sweep: models, scenario and numerics as given
/// in the spec (ROM paths resolved by [`SweepSpec::resolve_paths`] if the spec was loaded from a file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobContext {
    /// Impeller model.
    pub impeller: ModelSource,
    /// Casing model.
    pub casing: CasingSource,
    /// The sense of rotation (not written when counter-clockwise: job ids unchanged).
    #[serde(default, skip_serializing_if = "Rotation::is_default")]
    pub rotation: Rotation,
    /// Scenario.
    pub scenario: Scenario,
    /// Numerics.
    pub numerics: Numerics,
}

/// One simulation of a sweep.
#[derive(Debug, Clone)]
pub struct Job {
    /// Position in the plan (0-based; the row order of the results table).
    pub index: usize,
    /// Stable id: 16 hex digits of the FNV-1a 64 hash (see module docs).
    pub id: String,
    /// Grid parameters.
    pub params: JobParams,
    /// Models, scenario and numerics shared by all jobs.
    pub context: Arc<JobContext>,
}

/// The expanded sweep.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Jobs in deterministic order; `jobs[i].index == i`: the grid's jobs, then the refined
    /// ones ([`plan_with_speeds`]) by round, speed line and Ω.
    pub jobs: Vec<Job>,
    /// Refinement round of each job, by index: 0 for the grid's jobs, r for the jobs added by
    /// round r (the results table's `refinement_round`). Kept beside the jobs rather than in
    /// [`Job`]: the round is not a parameter of the simulation, and `Job` is built field by
    /// field elsewhere.
    pub refinement_rounds: Vec<u32>,
    /// Time steps per job, ⌈duration_s / time_step_s⌉ (always known: the time step has a default).
    pub steps_per_job: Option<u64>,
    /// Work estimate: jobs × steps per job.
    pub total_steps: Option<u64>,
}

/// Revision of what a job id stands for (module docs). 4: with a massless boundary the
/// inertial modes carry the coating force's history (second order in the step); 3: the
/// maxima are taken on every step, not on the sample steps only (so they no longer depend
/// on `numerics.decimation`), and the built-in impeller's K(Ω) is the consistent prestress
/// by default; 2: the massless boundary became the default and the formulation is always
/// written (1: the paper's formulation was the unwritten default).
pub const JOB_IDENTITY: u32 = 4;

/// Stable id of a job from its parameters and the shared context (see module docs).
pub fn job_id(params: &JobParams, context_json: &Value) -> String {
    let mut doc = context_json.clone();
    if let Value::Object(m) = &mut doc {
        m.insert("identity".into(), JOB_IDENTITY.into());
        // Serialization of plain structs/f64 into Value cannot fail.
        m.insert(
            "params".into(),
            serde_json::to_value(params).unwrap_or(Value::Null),
        );
    }
    content_hash(&doc)
}

/// One value of one axis.
#[derive(Clone, Copy)]
enum AxisValue {
    Speed(f64),
    Friction(f64),
    Clearance(f64),
    Coating(AxisName, CoatingValue),
}

fn axis_values(spec: &SweepSpec, axis: AxisName) -> Option<Vec<AxisValue>> {
    let coating = |a: &Option<CoatingAxis>| -> Option<Vec<AxisValue>> {
        a.as_ref().map(|a| match a {
            CoatingAxis::Values(v) => v
                .iter()
                .map(|&x| AxisValue::Coating(axis, CoatingValue::Absolute(x)))
                .collect(),
            CoatingAxis::Scale(v) => v
                .iter()
                .map(|&x| AxisValue::Coating(axis, CoatingValue::Scale(x)))
                .collect(),
        })
    };
    let g = &spec.grid;
    match axis {
        AxisName::Speed => Some(
            g.speed
                .values_rad_s()
                .into_iter()
                .map(AxisValue::Speed)
                .collect(),
        ),
        AxisName::Friction => Some(g.friction.iter().map(|&x| AxisValue::Friction(x)).collect()),
        AxisName::Clearance => g
            .clearance_m
            .as_ref()
            .map(|v| v.iter().map(|&x| AxisValue::Clearance(x)).collect()),
        AxisName::CoatingYoung => g.coating.as_ref().and_then(|c| coating(&c.young)),
        AxisName::CoatingHardening => g.coating.as_ref().and_then(|c| coating(&c.hardening)),
        AxisName::CoatingYieldStress => g.coating.as_ref().and_then(|c| coating(&c.yield_stress)),
        AxisName::CoatingThickness => g.coating.as_ref().and_then(|c| coating(&c.thickness)),
    }
}

fn apply(p: &mut JobParams, v: AxisValue) {
    match v {
        AxisValue::Speed(x) => p.speed_rad_s = x,
        AxisValue::Friction(x) => p.friction = x,
        AxisValue::Clearance(x) => p.clearance_m = Some(x),
        AxisValue::Coating(AxisName::CoatingYoung, c) => p.coating.young = Some(c),
        AxisValue::Coating(AxisName::CoatingHardening, c) => p.coating.hardening = Some(c),
        AxisValue::Coating(AxisName::CoatingYieldStress, c) => p.coating.yield_stress = Some(c),
        AxisValue::Coating(_, c) => p.coating.thickness = Some(c),
    }
}

/// Expands a spec into its jobs (validates the spec first).
///
/// Errors: the spec's validation issues; a duplicate job (two grid points that
/// resolve to identical parameters, e.g. a repeated list value), which would make
/// ids ambiguous, is reported against the grid.
pub fn plan(spec: &SweepSpec) -> Result<Plan, SpecError> {
    spec.validate()?;
    // Combined axes: each is a list of "points", a point being one value per member axis.
    let mut combined: Vec<Vec<Vec<AxisValue>>> = Vec::new();
    let mut zipped_done = false;
    for axis in AxisName::ALL {
        let Some(values) = axis_values(spec, axis) else {
            continue;
        };
        if spec.grid.zip.contains(&axis) {
            if zipped_done {
                continue;
            }
            zipped_done = true;
            // All zipped axes have equal lengths (validated).
            let members: Vec<Vec<AxisValue>> = AxisName::ALL
                .iter()
                .filter(|a| spec.grid.zip.contains(a))
                .filter_map(|&a| axis_values(spec, a))
                .collect();
            let n = members[0].len();
            combined.push(
                (0..n)
                    .map(|i| members.iter().map(|m| m[i]).collect())
                    .collect(),
            );
        } else {
            combined.push(values.into_iter().map(|v| vec![v]).collect());
        }
    }
    let n_jobs: usize = combined.iter().map(Vec::len).product();

    let context = Arc::new(JobContext {
        impeller: spec.models.impeller.clone(),
        casing: spec.models.casing.clone(),
        rotation: spec.models.rotation,
        scenario: spec.scenario.clone(),
        numerics: spec.numerics.clone(),
    });
    // ROM paths enter the id by file name only, so moving the sweep directory keeps ids.
    let context_json = context_hash_json(&context);

    let mut jobs = Vec::with_capacity(n_jobs);
    let mut seen = std::collections::HashMap::with_capacity(n_jobs);
    for index in 0..n_jobs {
        let mut params = JobParams {
            speed_rad_s: 0.0,
            friction: 0.0,
            clearance_m: None,
            coating: CoatingParams::default(),
        };
        // Mixed radix, first combined axis (speed) fastest.
        let mut rest = index;
        for axis in &combined {
            let k = rest % axis.len();
            rest /= axis.len();
            for &v in &axis[k] {
                apply(&mut params, v);
            }
        }
        let id = job_id(&params, &context_json);
        if let Some(prev) = seen.insert(id.clone(), index) {
            return Err(SpecError::Invalid(vec![super::spec::SpecIssue {
                path: "/grid".into(),
                reason: format!(
                    "jobs {prev} and {index} have identical parameters (repeated grid value?)"
                ),
            }]));
        }
        jobs.push(Job {
            index,
            id,
            params,
            context: Arc::clone(&context),
        });
    }
    // Rounded as the simulation counts its steps (`Simulation::new`): 2e-4 s / 2e-7 s is
    // 1000.0000000000001, 1000 steps, not 1001. A default step is known per job only.
    let steps_per_job =
        (spec.numerics.time_step).map(|h| (spec.scenario.duration_s / h).round() as u64);
    Ok(Plan {
        total_steps: steps_per_job.map(|s| s.saturating_mul(n_jobs as u64)),
        steps_per_job,
        refinement_rounds: vec![0; jobs.len()],
        jobs,
    })
}

/// A speed added to one speed line by refinement (see [`crate::sweep::refine`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefinedSpeed {
    /// The speed line: index over the other axes, as numbered by [`speed_lines`] (line `l`
    /// holds the grid's jobs `l·n .. (l+1)·n` of an axis of `n` speeds).
    pub line: usize,
    /// Rotation speed Ω (rad/s).
    pub omega_rad_s: f64,
    /// Refinement round that added it (≥ 1).
    pub round: u32,
}

impl Plan {
    /// Refinement round of job `index` (0 for a grid job; 0 when out of range).
    pub fn refinement_round(&self, index: usize) -> u32 {
        self.refinement_rounds.get(index).copied().unwrap_or(0)
    }
}

/// Expands a spec into its grid's jobs followed by the refined speeds `extra` as ordinary
/// jobs: each takes the parameters of its line's grid jobs with its own Ω, so its id is the
/// one a grid job at that Ω would have. The refined jobs follow the grid's in the order
/// (round, line, Ω), whatever the order of `extra`, so indices of earlier rounds never move.
///
/// Errors: the spec's issues; refined speeds on a spec without `grid.speed.refine`; a
/// line that does not exist; a round of 0; an Ω outside the grid's speeds (the models were
/// checked over those); more refined speeds on a line than `max_jobs`; a speed that is
/// already a job of its line.
pub fn plan_with_speeds(spec: &SweepSpec, extra: &[RefinedSpeed]) -> Result<Plan, SpecError> {
    let mut plan = plan(spec)?;
    if extra.is_empty() {
        return Ok(plan);
    }
    let pointer = "/grid/speed/refine";
    let Some(refine) = &spec.grid.speed.refine else {
        return Err(SpecError::one(pointer, "the spec asks for no refinement"));
    };
    let speeds = spec.grid.speed.values_rad_s();
    let (slowest, fastest) = speeds
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &w| {
            (a.min(w), b.max(w))
        });
    // Refinement is refused on a zipped speed axis, so the grid's jobs form whole lines.
    let lines = plan.jobs.len() / speeds.len();
    let mut extra = extra.to_vec();
    extra.sort_by(|a, b| {
        (a.round, a.line)
            .cmp(&(b.round, b.line))
            .then(a.omega_rad_s.total_cmp(&b.omega_rad_s))
    });
    let mut per_line = vec![0usize; lines];
    for e in &extra {
        let bad = |reason: String| Err(SpecError::one(pointer, reason));
        if e.line >= lines {
            return bad(format!(
                "refined speed on line {}: the grid has {lines} speed lines",
                e.line
            ));
        }
        if e.round == 0 {
            return bad(format!(
                "refined speed {} rad/s in round 0 (the grid's round)",
                e.omega_rad_s
            ));
        }
        if !(slowest..=fastest).contains(&e.omega_rad_s) {
            return bad(format!(
                "refined speed {} rad/s lies outside the grid's speeds [{slowest}, {fastest}] rad/s",
                e.omega_rad_s
            ));
        }
        per_line[e.line] += 1;
        if per_line[e.line] > refine.max_jobs {
            return bad(format!(
                "line {} has more refined speeds than max_jobs = {}",
                e.line, refine.max_jobs
            ));
        }
    }
    let context = Arc::clone(&plan.jobs[0].context);
    let context_json = context_hash_json(&context);
    let mut seen: std::collections::HashMap<String, usize> =
        plan.jobs.iter().map(|j| (j.id.clone(), j.index)).collect();
    for e in extra {
        let index = plan.jobs.len();
        let params = JobParams {
            speed_rad_s: e.omega_rad_s,
            ..plan.jobs[e.line * speeds.len()].params
        };
        let id = job_id(&params, &context_json);
        if let Some(prev) = seen.insert(id.clone(), index) {
            return Err(SpecError::one(
                pointer,
                format!(
                    "refined speed {} rad/s on line {} is already job {prev}",
                    e.omega_rad_s, e.line
                ),
            ));
        }
        plan.jobs.push(Job {
            index,
            id,
            params,
            context: Arc::clone(&context),
        });
        plan.refinement_rounds.push(e.round);
    }
    plan.total_steps = plan
        .steps_per_job
        .map(|s| s.saturating_mul(plan.jobs.len() as u64));
    Ok(plan)
}

/// The plan's jobs grouped into speed lines (one per combination of the axes other than
/// speed): each line's job indices in increasing Ω. Lines are numbered in the order of
/// their first job, so that line `l` holds the grid's jobs `l·n .. (l+1)·n` (speed varies
/// fastest) and any refined jobs with the same other parameters.
pub fn speed_lines(plan: &Plan) -> Vec<Vec<usize>> {
    let mut lines: Vec<Vec<usize>> = Vec::new();
    let mut line_of: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for job in &plan.jobs {
        // The line is what is left of the parameters without Ω; their JSON is an exact key
        // (shortest round-trip floats), unlike a float comparison with a tolerance.
        let key = serde_json::to_string(&JobParams {
            speed_rad_s: 0.0,
            ..job.params
        })
        .unwrap_or_default();
        let next = lines.len();
        let l = *line_of.entry(key).or_insert(next);
        if l == next {
            lines.push(Vec::new());
        }
        lines[l].push(job.index);
    }
    for line in &mut lines {
        line.sort_by(|&a, &b| {
            plan.jobs[a]
                .params
                .speed_rad_s
                .total_cmp(&plan.jobs[b].params.speed_rad_s)
                .then(a.cmp(&b))
        });
    }
    lines
}

/// The JSON of the context that enters the job id: ROM paths reduced to their file
/// names so that the id does not depend on where the sweep directory lives.
fn context_hash_json(ctx: &JobContext) -> Value {
    let mut v = serde_json::to_value(ctx).unwrap_or(Value::Null);
    for comp in ["impeller", "casing"] {
        if let Some(Value::String(p)) = v.get_mut(comp).and_then(|c| c.get_mut("rom")) {
            let name = std::path::Path::new(p.as_str())
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            *p = name;
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::spec::spec_from_value;

    fn spec(grid: Value) -> SweepSpec {
        spec_from_value(serde_json::json!({
            "name": "t",
            "models": {"impeller": {"builtin": {}}, "casing": {"builtin": {}}},
            "scenario": {"duration_s": 0.01},
            "numerics": {"time_step_s": 1e-4},
            "grid": grid
        }))
        .unwrap()
    }

    #[test]
    fn full_factorial_count_order_and_estimate() {
        let s = spec(serde_json::json!({
            "speed": {"unit": "rad_s", "values": [10.0, 20.0, 30.0]},
            "friction": [0.0, 0.1],
            "clearance_m": [1e-4, 2e-4]
        }));
        let p = plan(&s).unwrap();
        assert_eq!(p.jobs.len(), 12);
        assert_eq!(p.steps_per_job, Some(100));
        assert_eq!(p.total_steps, Some(1200));
        // Speed fastest, then friction, then clearance.
        let got: Vec<(f64, f64, f64)> = p
            .jobs
            .iter()
            .map(|j| {
                (
                    j.params.speed_rad_s,
                    j.params.friction,
                    j.params.clearance_m.unwrap(),
                )
            })
            .collect();
        let mut want = Vec::new();
        for c in [1e-4, 2e-4] {
            for f in [0.0, 0.1] {
                for w in [10.0, 20.0, 30.0] {
                    want.push((w, f, c));
                }
            }
        }
        assert_eq!(got, want);
        assert!(p.jobs.iter().enumerate().all(|(i, j)| j.index == i));
    }

    #[test]
    fn zipped_axes_vary_together() {
        let s = spec(serde_json::json!({
            "speed": {"unit": "rad_s", "values": [10.0, 20.0]},
            "friction": [0.1],
            "coating": {"young": {"scale": [0.1, 10.0]}, "hardening": {"scale": [0.1, 10.0]}},
            "zip": ["coating.young", "coating.hardening"]
        }));
        let p = plan(&s).unwrap();
        assert_eq!(p.jobs.len(), 4);
        for j in &p.jobs {
            assert_eq!(j.params.coating.young, j.params.coating.hardening);
        }
    }

    #[test]
    fn ids_stable_unique_and_sensitive() {
        let g = serde_json::json!({"speed": {"unit": "rad_s", "values": [10.0, 20.0]}, "friction": [0.0, 0.1]});
        let p1 = plan(&spec(g.clone())).unwrap();
        let p2 = plan(&spec(g)).unwrap();
        let ids1: Vec<&str> = p1.jobs.iter().map(|j| j.id.as_str()).collect();
        let ids2: Vec<&str> = p2.jobs.iter().map(|j| j.id.as_str()).collect();
        assert_eq!(ids1, ids2);
        let set: std::collections::HashSet<_> = ids1.iter().collect();
        assert_eq!(set.len(), ids1.len());
        // Extending the grid keeps ids of existing points; changing the scenario changes all.
        let p3 = plan(&spec(serde_json::json!({"speed": {"unit": "rad_s", "values": [10.0, 20.0, 40.0]}, "friction": [0.0, 0.1]}))).unwrap();
        for j in &p1.jobs {
            assert!(p3.jobs.iter().any(|k| k.id == j.id));
        }
        let mut s4 = spec(
            serde_json::json!({"speed": {"unit": "rad_s", "values": [10.0, 20.0]}, "friction": [0.0, 0.1]}),
        );
        s4.scenario.duration_s = 0.02;
        let p4 = plan(&s4).unwrap();
        assert!(p4.jobs.iter().all(|j| !ids1.contains(&j.id.as_str())));
    }

    /// The formulation, the step and the modes per nodal diameter are part of a job's identity,
    /// the default formulation too: a spec that says `"massless"` and one that says nothing
    /// give the same ids, `"mass"` other ones, and so do another step or mode count.
    #[test]
    fn formulation_step_and_modes_are_part_of_the_id() {
        use crate::dynamics::numerics::Boundary;
        use crate::sweep::spec::ModelSource;
        let g =
            serde_json::json!({"speed": {"unit": "rad_s", "values": [10.0]}, "friction": [0.1]});
        let id = |s: &SweepSpec| plan(s).unwrap().jobs[0].id.clone();
        let base = spec(g.clone());
        assert_eq!(base.numerics.boundary, Boundary::Massless);
        let context = serde_json::to_value(&base.numerics).unwrap();
        assert_eq!(context["boundary"], "massless", "the default is written");
        let mut explicit = spec(g.clone());
        explicit.numerics.boundary = Boundary::Massless;
        assert_eq!(id(&explicit), id(&base));
        let mut mass = spec(g.clone());
        mass.numerics.boundary = Boundary::Mass;
        let mut step = spec(g.clone());
        step.numerics.time_step = Some(5e-5);
        let mut modes = spec(g);
        let ModelSource::Builtin(imp) = &mut modes.models.impeller else {
            panic!("built-in impeller")
        };
        imp.modes_per_diameter += 1;
        let ids = [id(&base), id(&mass), id(&step), id(&modes)];
        let distinct: std::collections::HashSet<_> = ids.iter().collect();
        assert_eq!(distinct.len(), 4, "{ids:?}");
    }

    fn refined_grid(speeds: &[f64], refine: bool) -> SweepSpec {
        let mut g = serde_json::json!({
            "speed": {"unit": "rad_s", "values": speeds},
            "friction": [0.0, 0.1],
            "clearance_m": [1e-4]
        });
        if refine {
            g["speed"]["refine"] = serde_json::json!({"tolerance_rad_s": 5.0, "max_jobs": 3,
                "peak_of": "max_blade_te_radial_m"});
        }
        spec(g)
    }

    #[test]
    fn a_refinement_request_keeps_the_grids_ids() {
        let plain = plan(&refined_grid(&[100.0, 200.0, 300.0], false)).unwrap();
        let refined = plan(&refined_grid(&[100.0, 200.0, 300.0], true)).unwrap();
        let ids = |p: &Plan| p.jobs.iter().map(|j| j.id.clone()).collect::<Vec<_>>();
        assert_eq!(ids(&plain), ids(&refined));
        assert_eq!(refined.refinement_rounds, vec![0; 6]);
    }

    #[test]
    fn a_refined_job_is_the_grid_job_at_its_speed() {
        let s = refined_grid(&[100.0, 200.0, 300.0], true);
        let extra = [
            RefinedSpeed {
                line: 1,
                omega_rad_s: 250.0,
                round: 2,
            },
            RefinedSpeed {
                line: 1,
                omega_rad_s: 150.0,
                round: 1,
            },
            RefinedSpeed {
                line: 0,
                omega_rad_s: 150.0,
                round: 1,
            },
        ];
        let p = plan_with_speeds(&s, &extra).unwrap();
        assert_eq!(p.jobs.len(), 9);
        assert_eq!(p.total_steps, Some(900));
        assert!(p.jobs.iter().enumerate().all(|(i, j)| j.index == i));
        // Grid first, then (round, line, Ω), whatever the order given.
        let added: Vec<(f64, f64, u32)> = p.jobs[6..]
            .iter()
            .map(|j| {
                (
                    j.params.speed_rad_s,
                    j.params.friction,
                    p.refinement_round(j.index),
                )
            })
            .collect();
        assert_eq!(added, [(150.0, 0.0, 1), (150.0, 0.1, 1), (250.0, 0.1, 2)]);
        let mut reversed = extra;
        reversed.reverse();
        let q = plan_with_speeds(&s, &reversed).unwrap();
        assert!(p.jobs.iter().zip(&q.jobs).all(|(a, b)| a.id == b.id));
        // Each refined job is the job a grid holding its speed would plan, id and all.
        let dense = plan(&refined_grid(&[100.0, 150.0, 200.0, 250.0, 300.0], false)).unwrap();
        for j in &p.jobs {
            let twin = dense
                .jobs
                .iter()
                .find(|k| k.id == j.id)
                .unwrap_or_else(|| panic!("{:?}", j.params));
            assert_eq!(twin.params, j.params);
            assert_eq!(*twin.context, *j.context);
        }
        // Speed lines: each line's jobs in increasing Ω, grid and refined together.
        let lines = speed_lines(&p);
        let speeds = |l: &[usize]| {
            l.iter()
                .map(|&i| p.jobs[i].params.speed_rad_s)
                .collect::<Vec<_>>()
        };
        assert_eq!(lines.len(), 2);
        assert_eq!(speeds(&lines[0]), [100.0, 150.0, 200.0, 300.0]);
        assert_eq!(speeds(&lines[1]), [100.0, 150.0, 200.0, 250.0, 300.0]);
        assert!(lines[1].iter().all(|&i| p.jobs[i].params.friction == 0.1));
    }

    #[test]
    fn refined_speeds_that_cannot_be_jobs_are_refused() {
        let s = refined_grid(&[100.0, 200.0, 300.0], true);
        let at = |line, omega_rad_s, round| RefinedSpeed {
            line,
            omega_rad_s,
            round,
        };
        for (extra, needle) in [
            (vec![at(2, 150.0, 1)], "2 speed lines"),
            (vec![at(0, 150.0, 0)], "round 0"),
            (vec![at(0, 350.0, 1)], "outside the grid's speeds"),
            (vec![at(0, f64::NAN, 1)], "outside the grid's speeds"),
            (vec![at(0, 200.0, 1)], "already job 1"),
            (vec![at(0, 150.0, 1), at(0, 150.0, 2)], "already job"),
            (
                vec![
                    at(0, 110.0, 1),
                    at(0, 120.0, 1),
                    at(0, 130.0, 2),
                    at(0, 140.0, 3),
                ],
                "max_jobs = 3",
            ),
        ] {
            let e = plan_with_speeds(&s, &extra).unwrap_err().to_string();
            assert!(
                e.contains("/grid/speed/refine: ") && e.contains(needle),
                "{needle}: {e}"
            );
        }
        let plain = refined_grid(&[100.0, 200.0, 300.0], false);
        let e = plan_with_speeds(&plain, &[at(0, 150.0, 1)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("asks for no refinement"), "{e}");
        assert_eq!(plan_with_speeds(&plain, &[]).unwrap().jobs.len(), 6);
    }

    #[test]
    fn duplicate_grid_values_rejected() {
        let s = spec(
            serde_json::json!({"speed": {"unit": "rad_s", "values": [10.0, 10.0]}, "friction": [0.0]}),
        );
        assert!(plan(&s).is_err());
    }
}
