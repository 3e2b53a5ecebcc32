//! Building a [`Simulation`] from a case: the stability limit and the default step, both
//! kernels and their tables, the casing surface and its load, the initial velocities and
//! the coating stage; the loop that then steps it is in `mod.rs`.

use super::*;
use crate::dynamics::numerics::Numerics;
use std::sync::{Arc, Mutex};

/// The abradable coating's stage of a case (Fig. 11), checked against the casing kind and,
/// with the paper's formulation, the explicit stability of its force (a massless boundary
/// solves it implicitly, box 4); `None` without a coating.
fn coating_stage(
    case: &Case,
    impeller: &CyclicRom,
    blades: &mut Blades,
    casing: &mut Casing,
    steps_per_revolution: f64,
) -> Result<Option<CoatingStage>, SimError> {
    Ok(match (&case.coating, casing.surface_mut()) {
        (Some(cc), Some(side)) => {
            let mut cs = CoatingStage::new(cc, impeller, blades, case.friction, side)?;
            cs.out.steps_per_element = steps_per_revolution / cc.eta as f64;
            match case.numerics.boundary {
                Boundary::Mass => cs.check_stability(blades, side.flexible.as_mut())?,
                Boundary::Massless => {
                    let nn = blades.n_blades * blades.n_contact;
                    cs.node_law = vec![None; nn];
                    cs.path_now = vec![[f64::NAN; 2]; nn];
                    cs.path_prev = vec![[f64::NAN; 2]; nn];
                }
            }
            Some(cs)
        }
        (Some(_), None) => {
            return Err(SimError::InvalidCase(
                "an abradable coating needs a casing surface (not an imposed-gap casing)".into(),
            ));
        }
        (None, _) => None,
    })
}

/// The accuracy-driven default time step (s) of a case at `omega` (rad/s):
/// [`STEPS_PER_PERIOD`] steps per period of the highest dynamic mode of either structure,
/// and at least [`STEPS_PER_REVOLUTION`] steps per revolution. Always below the stability
/// limit `2/ω_max` (π/5 < 2).
pub fn default_time_step(st_i: &Structure, st_c: Option<&Structure>, omega: f64) -> f64 {
    let omega_max = st_c.map_or(st_i.omega_max, |c| c.omega_max.max(st_i.omega_max));
    let per_mode = 2.0 * PI / (omega_max * STEPS_PER_PERIOD);
    let per_revolution = 2.0 * PI / (omega.abs() * STEPS_PER_REVOLUTION);
    per_mode.min(per_revolution)
}

/// Checks the case's scalars and the explicit stability limit `h < 2/ω_max` of both
/// structures at the step `h` (s). Returns the limit (s) and the steps per revolution.
fn check_stability(
    case: &Case,
    h: f64,
    st_i: &Structure,
    st_c: Option<&Structure>,
) -> Result<(f64, f64), SimError> {
    let num = &case.numerics;
    num.validate().map_err(SimError::InvalidCase)?;
    let bad = |m: String| Err(SimError::InvalidCase(m));
    if !(case.omega.is_finite() && case.omega >= 0.0) {
        return bad(format!(
            "omega = {} rad/s must be finite and ≥ 0 (its sense is `rotation`)",
            case.omega
        ));
    }
    if !(case.duration.is_finite() && case.duration > 0.0) {
        return bad(format!("duration = {} s must be > 0", case.duration));
    }
    if !(case.friction.is_finite() && case.friction >= 0.0) {
        return bad(format!("friction = {} must be ≥ 0", case.friction));
    }
    if !(h.is_finite() && h > 0.0) {
        return bad(format!(
            "no time step: the default {h} s (neither structure has a dynamic mode and Ω = 0); \
             set numerics.time_step_s"
        ));
    }
    let (mut limit, mut omega_max, mut which) = (
        st_i.stability_limit(),
        st_i.omega_max,
        format!("impeller `{}`", st_i.name),
    );
    if let Some(c) = st_c
        && c.stability_limit() < limit
    {
        (limit, omega_max, which) = (
            c.stability_limit(),
            c.omega_max,
            format!("casing `{}`", c.name),
        );
    }
    let steps_per_rev = if case.omega != 0.0 {
        2.0 * PI / (case.omega.abs() * h)
    } else {
        f64::INFINITY
    };
    if h >= limit {
        let rev = if case.omega != 0.0 {
            format!(
                "; at Ω = {} rad/s one revolution needs at least {:.0} steps (h gives {:.0})",
                case.omega,
                (2.0 * PI / (case.omega.abs() * limit)).ceil(),
                steps_per_rev
            )
        } else {
            String::new()
        };
        return Err(SimError::Unstable {
            h,
            limit,
            omega_max,
            which,
            rev,
        });
    }
    Ok((limit, steps_per_rev))
}

/// A flexible casing's structure and time-loop side, built once per numerics and time step
/// and copied into every job that meets them again: neither depends on the rotation speed
/// (70 of the 95 ms that a headline job spends before its time loop). One cache serves one
/// casing ROM: a sweep's (`ModelSimulator`).
#[derive(Default)]
pub(crate) struct CasingCache {
    structures: Mutex<Vec<(Numerics, Arc<Structure>)>>,
    sides: Mutex<Vec<(SideKey, Arc<CasingSide>)>>,
}

impl std::fmt::Debug for CasingCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CasingCache")
            .field("structures", &self.structures.lock().map_or(0, |v| v.len()))
            .field("sides", &self.sides.lock().map_or(0, |v| v.len()))
            .finish()
    }
}

/// What a casing side is built from besides the casing ROM.
#[derive(PartialEq)]
struct SideKey {
    numerics: Numerics,
    casing_probes: Vec<[usize; 2]>,
    time_step_bits: u64,
}

impl CasingCache {
    /// The casing's structure under `num`: the cached one, or built by `build` and kept.
    fn structure(
        &self,
        num: &Numerics,
        build: impl FnOnce() -> Result<Structure, SimError>,
    ) -> Result<Arc<Structure>, SimError> {
        let mut kept = self.structures.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((_, st)) = kept.iter().find(|(n, _)| n == num) {
            return Ok(st.clone());
        }
        let st = Arc::new(build()?);
        kept.push((num.clone(), st.clone()));
        Ok(st)
    }

    /// How many casing sides are kept (one per time step and numerics met).
    #[cfg(test)]
    pub(crate) fn sides_kept(&self) -> usize {
        self.sides.lock().map_or(0, |v| v.len())
    }

    /// A copy of the casing side of `case` at step `h` (s): of the cached one, or built by
    /// `build` and kept.
    fn side(
        &self,
        case: &Case,
        h: f64,
        build: impl FnOnce() -> Result<CasingSide, SimError>,
    ) -> Result<CasingSide, SimError> {
        let key = SideKey {
            numerics: case.numerics.clone(),
            casing_probes: case.casing_probes.clone(),
            time_step_bits: h.to_bits(),
        };
        // Built outside the lock: two threads may both build the first one, never wait on it.
        let cached = (self.sides.lock().unwrap_or_else(|p| p.into_inner()).iter())
            .find(|(k, _)| *k == key)
            .map(|(_, side)| side.clone());
        if let Some(side) = cached {
            return Ok((*side).clone());
        }
        let side = build()?;
        let mut kept = self.sides.lock().unwrap_or_else(|p| p.into_inner());
        if !kept.iter().any(|(k, _)| *k == key) {
            kept.push((key, Arc::new(side.clone())));
        }
        Ok(side)
    }
}

impl<'a> Simulation<'a> {
    /// Builds the simulation of `case` for `impeller` rotating inside `casing`: checks the
    /// case and the stability limit, builds both kernels (and their flexibility tables), the
    /// casing spline, the casing load and the coating.
    pub fn new(
        case: &'a Case,
        impeller: &CyclicRom,
        casing: &CasingModel,
    ) -> Result<Self, SimError> {
        Self::with_cache(case, impeller, casing, None)
    }

    /// [`Simulation::new`], with the flexible casing's structure and side taken from `cache`
    /// (whose casing ROM `casing` must be) when it holds them, and kept there when not.
    pub(crate) fn with_cache(
        case: &'a Case,
        impeller: &CyclicRom,
        casing: &CasingModel,
        cache: Option<&CasingCache>,
    ) -> Result<Self, SimError> {
        let num = &case.numerics;
        let st_i = Structure::new(impeller, case.omega)?.with_numerics(num);
        let st_c = match casing {
            CasingModel::Flexible(rom) => {
                let build = || Ok(Structure::new(rom, 0.0)?.with_numerics(num));
                Some(match cache {
                    Some(cache) => cache.structure(num, build)?,
                    None => Arc::new(build()?),
                })
            }
            CasingModel::Rigid(_) | CasingModel::ImposedGap(_) => None,
        };
        let st_c = st_c.as_deref();
        let h = (num.time_step).unwrap_or_else(|| default_time_step(&st_i, st_c, case.omega));
        let (limit, steps_per_revolution) = check_stability(case, h, &st_i, st_c)?;
        let casing_rom = match casing {
            CasingModel::Flexible(rom) => Some(rom),
            CasingModel::Rigid(_) | CasingModel::ImposedGap(_) => None,
        };
        let probes = resolve_probes(&case.probes, impeller, casing_rom)
            .map_err(|e| SimError::InvalidCase(e.to_string()))?;
        let mut blades = Blades::new(case, h, impeller, &st_i)?;
        let mut casing = match casing {
            CasingModel::ImposedGap(g) => {
                // No surface: the offsets are radial (the profile holds the clearance).
                blades.shift_tips(&case.clearance_offset, &blades.radial.clone());
                let offsets: Vec<Vector3<f64>> = (blades.reference.iter())
                    .zip(&impeller.contact_nodes)
                    .map(|(x, c)| x - Vector3::from(c.position))
                    .collect();
                let imposed =
                    ImposedCasing::new(g, impeller, &offsets, &blades.rot, case.angular_velocity());
                Casing::Imposed(
                    imposed
                        .map_err(|e| SimError::InvalidCase(format!("imposed-gap casing: {e}")))?,
                )
            }
            model => {
                let build = || CasingSide::new(case, h, model, st_c);
                let side = match (model, cache) {
                    (CasingModel::Flexible(_), Some(cache)) => cache.side(case, h, build)?,
                    _ => build()?,
                };
                blades.shift_tips_toward(case, &side)?;
                Casing::Surface(side)
            }
        };
        set_casing_load(case, h, st_c, &mut casing)?;
        set_initial_velocities(case, &st_i, st_c, &mut blades, &mut casing)?;
        let nn = blades.n_blades * blades.n_contact;
        let coating = coating_stage(
            case,
            impeller,
            &mut blades,
            &mut casing,
            steps_per_revolution,
        )?;
        if let Some(side) = casing.surface_mut() {
            side.past.touched = vec![None; nn];
            side.fold_spline()?;
        }
        let rigid = casing.surface().is_some_and(|side| side.flexible.is_none());
        let projector = Projector {
            bounds: GapBounds::new(nn).with_fixed_surface(rigid),
            warm: vec![None; nn],
            proj: vec![Projection::default(); nn],
            eps: case.numerics.newton_tolerance,
            margin: case.coating.as_ref().map_or(0.0, |c| c.material.thickness),
            res_proj: vec![Projection::default(); 1],
            res_warm: vec![None; 1],
        };
        let contact = ContactProblem::new(&blades, &casing);
        let n_blades = blades.n_blades;
        let n_nd = st_i.blocks.len();
        let recovery = probes
            .iter()
            .any(|p| matches!(p.target, ProbeTarget::Recovery { .. }))
            .then(|| {
                let eval = RecoveryEval::new(&st_i);
                (impeller.recovery.clone(), eval, vec![0.0; st_i.n_modal])
            });
        let casing_recovery = match (casing_rom, &st_c) {
            (Some(rom), Some(st))
                if probes
                    .iter()
                    .any(|p| matches!(p.target, ProbeTarget::CasingRecovery { .. })) =>
            {
                let eval = RecoveryEval::new(st);
                Some((rom.recovery.clone(), eval, vec![0.0; st.n_modal]))
            }
            _ => None,
        };
        let casing_wave = st_c.and_then(Structure::critical_wave_speed);
        let watch = (num.stop_on_runaway)
            .then(|| RunawayWatch::new(casing_wave, &st_i))
            .flatten();
        Ok(Self {
            summary: RunSummary {
                time_step: h,
                stability_limit: limit,
                steps_per_revolution,
                n_steps: (case.duration / h).round() as usize,
                ..Default::default()
            },
            case,
            blades,
            casing,
            projector,
            contact,
            coating,
            clock: StageClock::new(),
            steps_done: 0,
            t1: 0.0,
            r_om: Matrix3::identity(),
            sample_step: false,
            min_gap: f64::INFINITY,
            rubs: false,
            residual: 0.0,
            drive_work: 0.0,
            casing_wave,
            watch,
            runaway: None,
            sample_energy: 0.0,
            blade_band_peaks: blade_band_peaks(h),
            le: vec![0.0; n_blades],
            te: vec![0.0; n_blades],
            casing_radial: vec![0.0; case.casing_probes.len()],
            nd_energy: vec![0.0; n_nd],
            probe_values: vec![0.0; probes.len()],
            probes,
            recovery,
            casing_recovery,
        })
    }
}

/// The low-passed blade-tip peaks' trackers (leading, trailing edge) for the step `h` (s);
/// `None` when the step is too long for the band: its Nyquist frequency `1/(2h)` below
/// twice [`BLADE_BAND_HZ`], where the bilinear filter is no longer the analog one.
fn blade_band_peaks(h: f64) -> Option<[LowPassPeak; 2]> {
    (4.0 * BLADE_BAND_HZ * h < 1.0).then(|| {
        let filter = BesselLowPass::new(BLADE_BAND_HZ, h);
        [LowPassPeak::new(filter), LowPassPeak::new(filter)]
    })
}

/// Sets the initial velocities of the case on both kernels (`u_{−1} = −h v_0`).
fn set_initial_velocities(
    case: &Case,
    st_i: &Structure,
    st_c: Option<&Structure>,
    blades: &mut Blades,
    casing: &mut Casing,
) -> Result<(), SimError> {
    if let Some(v) = &case.initial_velocity.impeller {
        if v.len() != st_i.n_modal {
            return Err(SimError::InvalidCase(format!(
                "initial impeller velocity has {} entries, expected {}",
                v.len(),
                st_i.n_modal
            )));
        }
        blades.kernel.get_mut().set_initial_velocity(v);
    }
    if let Some(v) = &case.initial_velocity.casing {
        match (st_c, casing.flexible_mut()) {
            (Some(s), Some(f)) if v.len() == s.n_modal => {
                f.kernel.get_mut().set_initial_velocity(v)
            }
            _ => {
                return Err(SimError::InvalidCase(
                    "initial casing velocity needs a flexible casing and one entry per DOF".into(),
                ));
            }
        }
    }
    Ok(())
}
