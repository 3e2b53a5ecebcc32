//! The rules of a sweep spec that serde's types do not enforce ([`SweepSpec::validate`]): every
//! constraint of the JSON Schema again (so that specs built in code are held to them) and the
//! cross-field ones a schema cannot express, each reported with its JSON path.

use super::{
    AxisName, CasingSource, CoatingAxis, MAX_COATING_ELEMENTS, MAX_FRICTION, MAX_JOBS,
    MAX_STEPS_PER_JOB, MIN_REFINE_TOLERANCE, ModelSource, RefineSpec, SpecError, SpecIssue,
    SpeedUnit, SweepSpec,
};
use crate::analysis::revolutions::RevolutionWindows;
use crate::dynamics::numerics::Boundary;

/// Pushes an issue when `v` is not finite and > 0.
fn check_positive(issues: &mut Vec<SpecIssue>, pointer: &str, v: f64, unit: &str) {
    if !(v.is_finite() && v > 0.0) {
        issues.push(SpecIssue {
            path: pointer.into(),
            reason: format!("{v}{unit} must be finite and > 0"),
        });
    }
}

fn check_list(
    issues: &mut Vec<SpecIssue>,
    pointer: &str,
    values: &[f64],
    allow_zero: bool,
    what: &str,
) {
    if values.is_empty() {
        issues.push(SpecIssue {
            path: pointer.to_string(),
            reason: format!("{what} list is empty"),
        });
    }
    for (i, &v) in values.iter().enumerate() {
        let ok = v.is_finite() && if allow_zero { v >= 0.0 } else { v > 0.0 };
        if !ok {
            let bound = if allow_zero {
                "must be finite and ≥ 0"
            } else {
                "must be finite and > 0"
            };
            issues.push(SpecIssue {
                path: format!("{pointer}/{i}"),
                reason: format!("{v} is not a valid {what}: {bound}"),
            });
        }
    }
}

impl SweepSpec {
    /// Checks every rule of the schema that the type system does not enforce, plus the
    /// cross-field rules (equal lengths of zipped axes, range ordering, reference speed).
    /// Returns all problems at once, each with its JSON path.
    pub fn validate(&self) -> Result<(), SpecError> {
        let mut issues = Vec::new();
        let name_ok =
            !self.name.is_empty()
                && self.name.len() <= 128
                && self.name.chars().enumerate().all(|(i, c)| {
                    c.is_ascii_alphanumeric() || (i > 0 && matches!(c, '_' | '.' | '-'))
                });
        if !name_ok {
            issues.push(SpecIssue {
                path: "/name".into(),
                reason: format!(
                    "{:?} is not a valid sweep name ([A-Za-z0-9][A-Za-z0-9_.-]*, ≤ 128 chars)",
                    self.name
                ),
            });
        }
        if let ModelSource::Rom(p) = &self.models.impeller
            && p.as_os_str().is_empty()
        {
            issues.push(SpecIssue {
                path: "/models/impeller/rom".into(),
                reason: "empty path".into(),
            });
        }
        match &self.models.casing {
            CasingSource::Rom(p) if p.as_os_str().is_empty() => issues.push(SpecIssue {
                path: "/models/casing/rom".into(),
                reason: "empty path".into(),
            }),
            CasingSource::Rigid(r) => {
                if r.lobes == 0 {
                    issues.push(SpecIssue {
                        path: "/models/casing/rigid/lobes".into(),
                        reason: "0 is less than the minimum of 1".into(),
                    });
                }
                if !(r.amplitude_m.is_finite() && r.amplitude_m >= 0.0) {
                    issues.push(SpecIssue {
                        path: "/models/casing/rigid/amplitude_m".into(),
                        reason: format!("{} must be finite and ≥ 0", r.amplitude_m),
                    });
                }
                if let Some(o) = &r.gap_offsets_m
                    && (o.len() < 3 || o.iter().any(|v| !v.is_finite()))
                {
                    issues.push(SpecIssue {
                        path: "/models/casing/rigid/gap_offsets_m".into(),
                        reason: format!("needs at least 3 finite values, got {}", o.len()),
                    });
                }
            }
            CasingSource::ImposedGap(g) => {
                if let Err(reason) = g.profile.validate() {
                    issues.push(SpecIssue {
                        path: "/models/casing/imposed_gap/profile".into(),
                        reason,
                    });
                }
            }
            _ => {}
        }
        self.validate_scenario(&mut issues);
        self.validate_numerics(&mut issues);
        self.validate_applicability(&mut issues);
        self.validate_speed(&mut issues);
        self.validate_grid(&mut issues);
        self.validate_refine(&mut issues);
        if let Some(limit) = self.job_time_limit_s {
            check_positive(&mut issues, "/job_time_limit_s", limit, " s");
        }
        if issues.is_empty() {
            Ok(())
        } else {
            Err(SpecError::Invalid(issues))
        }
    }

    /// A job of `duration_s` at step `h` (s) takes at most [`MAX_STEPS_PER_JOB`] steps; `field`
    /// is the pointer blamed.
    pub fn check_step_count(&self, issues: &mut Vec<SpecIssue>, h: f64, field: &str) {
        let steps = self.scenario.duration_s / h;
        if h > 0.0 && steps > MAX_STEPS_PER_JOB {
            issues.push(SpecIssue {
                path: field.into(),
                reason: format!(
                    "duration_s = {:.3e} s at a step of {h:.3e} s is {steps:.3e} steps per job, \
                     more than the {MAX_STEPS_PER_JOB:.0e} allowed (a unit mistake?)",
                    self.scenario.duration_s
                ),
            });
        }
    }

    /// Each window lies within the run at every grid speed and needs probes to report on.
    fn validate_revolution_report(&self, w: &RevolutionWindows, issues: &mut Vec<SpecIssue>) {
        let path = "/scenario/revolution_report";
        if self.scenario.probes.is_empty() {
            issues.push(SpecIssue {
                path: path.into(),
                reason: "reports on the probes: give /scenario/probes".into(),
            });
        }
        let slowest = self
            .grid
            .speed
            .values_rad_s()
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        let run = self.scenario.duration_s * slowest / std::f64::consts::TAU;
        for (field, revs) in [
            ("peak_to_peak_revolutions", w.peak_to_peak),
            ("mean_revolutions", w.mean_and_spectrum),
        ] {
            if !(revs.is_finite() && revs > 0.0 && revs <= run) {
                issues.push(SpecIssue {
                    path: format!("{path}/{field}"),
                    reason: format!(
                        "{revs} revolutions must be > 0 and within the run ({run:.2} revolutions \
                         at the slowest grid speed)"
                    ),
                });
            }
        }
    }

    fn validate_scenario(&self, issues: &mut Vec<SpecIssue>) {
        let sc = &self.scenario;
        check_positive(issues, "/scenario/duration_s", sc.duration_s, " s");
        if sc.lobes == Some(0) {
            issues.push(SpecIssue {
                path: "/scenario/lobes".into(),
                reason: "0 is less than the minimum of 1".into(),
            });
        }
        if let Some(a) = sc.load_amplitude_m {
            check_positive(issues, "/scenario/load_amplitude_m", a, " m");
        }
        if let Some(t) = sc.load_ramp_s {
            check_positive(issues, "/scenario/load_ramp_s", t, " s");
            if t > sc.duration_s {
                issues.push(SpecIssue {
                    path: "/scenario/load_ramp_s".into(),
                    reason: format!(
                        "the load ramp ends at {t} s, after the end of the run ({} s)",
                        sc.duration_s
                    ),
                });
            }
        }
        if let Some(w) = &sc.revolution_report {
            self.validate_revolution_report(w, issues);
        }
        if let Some(f) = sc.steady_fraction
            && !(f.is_finite() && f > 0.0 && f <= 1.0)
        {
            issues.push(SpecIssue {
                path: "/scenario/steady_fraction".into(),
                reason: format!("{f} must lie in (0, 1]"),
            });
        }
        if let Some(n) = sc.rigid_stations
            && n < 3
        {
            issues.push(SpecIssue {
                path: "/scenario/rigid_stations".into(),
                reason: format!("{n} is less than the minimum of 3"),
            });
        }
        if let Some(c) = &sc.coating {
            for (field, v, unit) in [
                ("young_pa", c.young_pa, " Pa"),
                ("hardening_pa", c.hardening_pa, " Pa"),
                ("yield_stress_pa", c.yield_stress_pa, " Pa"),
                ("thickness_m", c.thickness_m, " m"),
            ] {
                check_positive(issues, &format!("/scenario/coating/{field}"), v, unit);
            }
            if !(1..=MAX_COATING_ELEMENTS).contains(&c.eta) {
                issues.push(SpecIssue {
                    path: "/scenario/coating/eta".into(),
                    reason: format!(
                        "{} elements per row: η must lie in 1..={MAX_COATING_ELEMENTS}",
                        c.eta
                    ),
                });
            }
        }
    }

    /// The grid's axes (lists of physical values, a coating grid naming a property), its
    /// zipped axes and the number of jobs it expands into ([`MAX_JOBS`]).
    fn validate_grid(&self, issues: &mut Vec<SpecIssue>) {
        check_list(
            issues,
            "/grid/friction",
            &self.grid.friction,
            true,
            "friction coefficient",
        );
        for (i, &mu) in self.grid.friction.iter().enumerate() {
            if mu > MAX_FRICTION {
                issues.push(SpecIssue {
                    path: format!("/grid/friction/{i}"),
                    reason: format!(
                        "μ = {mu} is not a physical Coulomb coefficient: the bound is {MAX_FRICTION} \
                         (measured blade/casing and blade/abradable pairs lie in 0.05–0.8)"
                    ),
                });
            }
        }
        if let Some(c) = &self.grid.clearance_m {
            check_list(issues, "/grid/clearance_m", c, true, "clearance");
        }
        if let Some(c) = &self.grid.coating {
            let axes = [
                ("young", &c.young),
                ("hardening", &c.hardening),
                ("yield_stress", &c.yield_stress),
                ("thickness", &c.thickness),
            ];
            if axes.iter().all(|(_, a)| a.is_none()) {
                issues.push(SpecIssue {
                    path: "/grid/coating".into(),
                    reason: "coating grid names no property".into(),
                });
            }
            for (name, axis) in axes {
                match axis {
                    Some(CoatingAxis::Values(v)) => check_list(
                        issues,
                        &format!("/grid/coating/{name}/values"),
                        v,
                        false,
                        "coating value",
                    ),
                    Some(CoatingAxis::Scale(v)) => check_list(
                        issues,
                        &format!("/grid/coating/{name}/scale"),
                        v,
                        false,
                        "scale factor",
                    ),
                    None => {}
                }
            }
        }
        self.validate_zip(issues);
        let jobs = self.grid.job_count();
        if jobs > MAX_JOBS {
            issues.push(SpecIssue {
                path: "/grid".into(),
                reason: format!(
                    "the grid expands into {} jobs, more than the {MAX_JOBS} a sweep may hold \
                     (the product of its axis lengths, zipped axes counted once)",
                    if jobs == u64::MAX {
                        "over 1.8e19".into()
                    } else {
                        jobs.to_string()
                    }
                ),
            });
        }
    }

    fn validate_numerics(&self, issues: &mut Vec<SpecIssue>) {
        let n = &self.numerics;
        if let Some(h) = n.time_step {
            check_positive(issues, "/numerics/time_step_s", h, " s");
            // A step under 1 ns would resolve modes above 100 MHz, no structure's: the step is
            // the mistake then, else the duration.
            let field = if h < 1e-9 {
                "/numerics/time_step_s"
            } else {
                "/scenario/duration_s"
            };
            self.check_step_count(issues, h, field);
        }
        if let Some(f) = n.mode_cutoff_hz {
            check_positive(issues, "/numerics/mode_cutoff_hz", f, " Hz");
        }
        check_positive(issues, "/numerics/newton_tolerance", n.newton_tolerance, "");
        if n.decimation == 0 {
            issues.push(SpecIssue {
                path: "/numerics/decimation".into(),
                reason: "0 is less than the minimum of 1 (one sample every `decimation` steps)"
                    .into(),
            });
        }
    }

    /// Options that do not apply to the chosen models are rejected, not ignored.
    fn validate_applicability(&self, issues: &mut Vec<SpecIssue>) {
        let sc = &self.scenario;
        let mut reject = |path: &str, reason: &str| {
            issues.push(SpecIssue {
                path: path.into(),
                reason: reason.into(),
            })
        };
        if self.numerics.boundary == Boundary::Mass && self.numerics.mode_cutoff_hz.is_some() {
            reject(
                "/numerics/mode_cutoff_hz",
                "a mode cutoff needs \"boundary\": \"massless\": in the paper's formulation \
                 every retained mode carries its mass",
            );
        }
        if self.models.casing.is_rigid() {
            let flexible_only = "applies to a flexible casing only; a rigid casing";
            if sc.lobes.is_some() {
                reject(
                    "/scenario/lobes",
                    &format!("{flexible_only} takes its lobes from its own profile"),
                );
            }
            if sc.load_amplitude_m.is_some() {
                reject(
                    "/scenario/load_amplitude_m",
                    &format!("{flexible_only} is not loaded"),
                );
            }
            if sc.load_ramp_s.is_some() {
                reject(
                    "/scenario/load_ramp_s",
                    &format!("{flexible_only} is not loaded"),
                );
            }
            if !sc.casing_probes.is_empty() {
                reject(
                    "/scenario/casing_probes",
                    &format!("{flexible_only} does not move"),
                );
            }
            match (sc.rigid_stations, &self.models.casing) {
                (Some(_), CasingSource::Rigid(r)) if r.gap_offsets_m.is_some() => reject(
                    "/scenario/rigid_stations",
                    "the length of /models/casing/rigid/gap_offsets_m sets the stations",
                ),
                (Some(_), CasingSource::ImposedGap(_)) => reject(
                    "/scenario/rigid_stations",
                    "applies to a rigid casing surface only (an imposed-gap casing has no stations)",
                ),
                _ => {}
            }
            if let CasingSource::ImposedGap(_) = &self.models.casing {
                let no_surface = "needs a casing surface; an imposed-gap casing has none";
                if sc.coating.is_some() {
                    reject(
                        "/scenario/coating",
                        &format!("the abradable coating {no_surface}"),
                    );
                }
                if self.grid.coating.is_some() {
                    reject(
                        "/grid/coating",
                        &format!("the abradable coating {no_surface}"),
                    );
                }
                if self.grid.clearance_m.is_some() {
                    reject(
                        "/grid/clearance_m",
                        "an imposed-gap casing takes its clearance from its profile",
                    );
                }
            }
        } else {
            if sc.rigid_stations.is_some() {
                reject(
                    "/scenario/rigid_stations",
                    "applies to a rigid casing only (a flexible casing's stations are its sectors)",
                );
            }
            match (sc.lobes, sc.load_amplitude_m) {
                (Some(_), None) => reject(
                    "/scenario",
                    "`lobes` needs `load_amplitude_m` (they define the n-lobe casing load together)",
                ),
                (None, Some(_)) => reject(
                    "/scenario",
                    "`load_amplitude_m` needs `lobes` (they define the n-lobe casing load together)",
                ),
                (None, None) if sc.load_ramp_s.is_some() => reject(
                    "/scenario/load_ramp_s",
                    "there is no casing load to ramp (give `lobes` and `load_amplitude_m`)",
                ),
                _ => {}
            }
        }
        if matches!(self.models.impeller, ModelSource::Rom(_))
            && !self.models.casing.is_rigid()
            && self.grid.clearance_m.is_some()
        {
            reject(
                "/grid/clearance_m",
                "with a flexible casing, needs a built-in impeller (a ROM file does not state \
                 its clearance, so it cannot be changed)",
            );
        }
    }

    fn validate_speed(&self, issues: &mut Vec<SpecIssue>) {
        let s = &self.grid.speed;
        match (&s.values, &s.range) {
            (Some(v), None) => check_list(issues, "/grid/speed/values", v, false, "speed"),
            (None, Some(r)) => {
                for (field, v) in [("start", r.start), ("stop", r.stop)] {
                    if !(v.is_finite() && v > 0.0) {
                        issues.push(SpecIssue {
                            path: format!("/grid/speed/range/{field}"),
                            reason: format!("{v} is not a valid speed: must be finite and > 0"),
                        });
                    }
                }
                if r.count == 0 {
                    issues.push(SpecIssue {
                        path: "/grid/speed/range/count".into(),
                        reason: "0 is less than the minimum of 1".into(),
                    });
                }
                if r.stop < r.start {
                    issues.push(SpecIssue {
                        path: "/grid/speed/range".into(),
                        reason: format!("stop {} is below start {}", r.stop, r.start),
                    });
                }
                if r.count == 1 && r.stop != r.start {
                    issues.push(SpecIssue {
                        path: "/grid/speed/range".into(),
                        reason: "count 1 requires start == stop".into(),
                    });
                }
            }
            _ => issues.push(SpecIssue {
                path: "/grid/speed".into(),
                reason: "give exactly one of `values` or `range`".into(),
            }),
        }
        match (s.unit, s.reference_rad_s) {
            (SpeedUnit::Normalized, None) => issues.push(SpecIssue {
                path: "/grid/speed".into(),
                reason: "\"reference_rad_s\" is a required property for unit \"normalized\"".into(),
            }),
            (_, Some(r)) if !(r.is_finite() && r > 0.0) => issues.push(SpecIssue {
                path: "/grid/speed/reference_rad_s".into(),
                reason: format!("{r} must be finite and > 0"),
            }),
            _ => {}
        }
    }

    /// A refinement request that cannot work is refused before anything runs: too few
    /// speeds, a zipped speed axis, nothing asked, a tolerance that is not positive, below the
    /// float resolution of the speeds or unable to shrink any bracket, a budget of 0 or one
    /// that takes the sweep past [`MAX_JOBS`], and a `peak_of` that is not a numeric scalar
    /// column of the results table.
    fn validate_refine(&self, issues: &mut Vec<SpecIssue>) {
        let Some(r) = &self.grid.speed.refine else {
            return;
        };
        let mut push = |field: &str, reason: String| {
            issues.push(SpecIssue {
                path: format!("/grid/speed/refine{field}"),
                reason,
            })
        };
        let mut speeds = self.grid.speed.values_rad_s();
        if speeds.len() < 2 {
            push(
                "",
                format!(
                    "refinement needs at least 2 speeds on the axis to bracket anything, it has {}",
                    speeds.len()
                ),
            );
        }
        if self.grid.zip.contains(&AxisName::Speed) {
            push(
                "",
                "a speed axis zipped with other axes has no speed lines to refine (each \
                 combination of the other axes has a single speed)"
                    .into(),
            );
        }
        if !r.boundary && r.peak_of.is_none() {
            push(
                "",
                "asks for nothing: set `boundary` to true, give `peak_of`, or both".into(),
            );
        }
        let tol = r.tolerance_rad_s;
        if !(tol.is_finite() && tol > 0.0) {
            push(
                "/tolerance_rad_s",
                format!("{tol} rad/s must be finite and > 0"),
            );
        } else if speeds.len() >= 2 && speeds.iter().all(|w| w.is_finite() && *w > 0.0) {
            speeds.sort_by(f64::total_cmp);
            let fastest = speeds[speeds.len() - 1];
            let floor = MIN_REFINE_TOLERANCE * fastest;
            let widest = speeds.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
            if tol < floor {
                push(
                    "/tolerance_rad_s",
                    format!(
                        "{tol:e} rad/s is below the float resolution of the grid's speeds: at \
                         least {MIN_REFINE_TOLERANCE:e} × the fastest ({fastest} rad/s), \
                         {floor:.3e} rad/s"
                    ),
                );
            } else if tol >= widest {
                push(
                    "/tolerance_rad_s",
                    format!(
                        "{tol} rad/s cannot shrink any bracket: the grid's widest spacing is \
                         {widest} rad/s (the tolerance is in rad/s whatever the axis' unit)"
                    ),
                );
            }
        }
        self.validate_refine_budget(r, &mut push);
        if let Some(q) = &r.peak_of
            && !crate::sweep::refine::PEAK_QUANTITIES.contains(&q.as_str())
        {
            push("/peak_of", not_a_peak_quantity(q));
        }
    }

    /// `max_jobs` ≥ 1, and the coarse grid plus every line's refined jobs stay within
    /// [`MAX_JOBS`].
    fn validate_refine_budget(&self, r: &RefineSpec, push: &mut impl FnMut(&str, String)) {
        if r.max_jobs == 0 {
            push("/max_jobs", "0 is less than the minimum of 1".into());
            return;
        }
        let coarse = self.grid.job_count();
        let lines = coarse / (self.grid.speed.len().max(1) as u64);
        let total = coarse.saturating_add(lines.saturating_mul(r.max_jobs as u64));
        if total > MAX_JOBS {
            push(
                "/max_jobs",
                format!(
                    "{} refined jobs on each of the {lines} speed lines take the sweep to {total} \
                     jobs, more than the {MAX_JOBS} a sweep may hold",
                    r.max_jobs
                ),
            );
        }
    }

    fn validate_zip(&self, issues: &mut Vec<SpecIssue>) {
        let zip = &self.grid.zip;
        if zip.is_empty() {
            return;
        }
        if zip.len() < 2 {
            issues.push(SpecIssue {
                path: "/grid/zip".into(),
                reason: "zip needs at least 2 axes".into(),
            });
        }
        let mut first_len: Option<(AxisName, usize)> = None;
        for (i, &axis) in zip.iter().enumerate() {
            if zip[..i].contains(&axis) {
                issues.push(SpecIssue {
                    path: format!("/grid/zip/{i}"),
                    reason: format!("axis {axis} is listed twice"),
                });
                continue;
            }
            match self.grid.axis_len(axis) {
                None => issues.push(SpecIssue {
                    path: format!("/grid/zip/{i}"),
                    reason: format!("axis {axis} is not present in the grid"),
                }),
                Some(n) => match first_len {
                    None => first_len = Some((axis, n)),
                    Some((a0, n0)) if n0 != n => issues.push(SpecIssue {
                        path: format!("/grid/zip/{i}"),
                        reason: format!(
                            "zipped axes need equal lengths: {a0} has {n0} values, {axis} has {n}"
                        ),
                    }),
                    _ => {}
                },
            }
        }
    }
}

/// Why `name` is refused as `refine.peak_of`, with the closest valid name when one is close.
fn not_a_peak_quantity(name: &str) -> String {
    use crate::sweep::refine::{OTHER_COLUMNS, PEAK_QUANTITIES};
    let hint = match crate::sweep::schema::did_you_mean(name, PEAK_QUANTITIES.iter().copied()) {
        Some(best) => format!(", did you mean `{best}`?"),
        None => format!("; one of {}", PEAK_QUANTITIES.join(", ")),
    };
    if OTHER_COLUMNS.contains(&name) {
        format!(
            "`{name}` is a column of the results table but not a result quantity with a \
             maximum along Ω (a grid parameter, the wall time, a list or a text){hint}"
        )
    } else {
        format!("`{name}` is not a numeric scalar column of the results table{hint}")
    }
}
