//! The recorded output of a simulation (decimated time series and summary numbers).

use serde::{Deserialize, Serialize};

/// Energies of one structure (J), see [`crate::dynamics::kernel::Energies`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EnergySeries {
    /// Kinetic energy at each sample (J).
    pub kinetic: Vec<f64>,
    /// Strain energy at each sample (J).
    pub strain: Vec<f64>,
}

/// Output of [`crate::dynamics::simulate::simulate`]: the series of every sample step and the
/// run's [`RunSummary`]. Every series has one entry per sample (`time.len()`); per-blade
/// series are indexed `[blade][sample]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SimulationOutput {
    /// Sample times (s).
    pub time: Vec<f64>,
    /// Radial displacement (m, rotating frame, positive outward) of each blade's leading-edge
    /// tip node (contact row 0), `[blade][sample]`.
    pub blade_le_radial: Vec<Vec<f64>>,
    /// Radial displacement (m, rotating frame, positive outward) of each blade's trailing-edge
    /// node (last contact row), `[blade][sample]`.
    pub blade_te_radial: Vec<Vec<f64>>,
    /// Radial displacement (m, positive outward) of the requested casing contact nodes
    /// (`Case::casing_probes` order; empty for a rigid casing).
    pub casing_radial: Vec<Vec<f64>>,
    /// Per blade, sum over its tip nodes of the normal contact force λ (N) at the sample step.
    pub blade_normal_force: Vec<Vec<f64>>,
    /// Per blade, sum of the tangential (friction) force magnitudes μλ (N) at the sample step.
    pub blade_tangential_force: Vec<Vec<f64>>,
    /// Minimum predicted gap d* over all blade-tip nodes at the sample step (m).
    pub min_gap: Vec<f64>,
    /// Largest residual penetration after correction (m, ≥ 0) at the sample step:
    /// re-projection of the corrected blade nodes on the corrected spline. Only sample steps
    /// synthesise the corrected casing surface (aside: the state never reads it), so only
    /// they are checked.
    pub residual_penetration: Vec<f64>,
    /// Work (J) of the imposed rotation through the contact forces, see
    /// [`crate::dynamics::recorder::Sample::drive_work`].
    pub drive_work: Vec<f64>,
    /// Impeller energies (J, half-step form).
    pub impeller_energy: EnergySeries,
    /// Casing energies (J, half-step form).
    pub casing_energy: EnergySeries,
    /// Impeller strain energy per nodal diameter (J), `[k][sample]`, paper eqs. (20)–(22).
    pub impeller_nd_strain_energy: Vec<Vec<f64>>,
    /// Largest wear of each coating row (m) at each sample, `[row][sample]` (empty without a
    /// coating).
    pub coating_max_wear: Vec<Vec<f64>>,
    /// Per blade, sum over its tip nodes of the coating force magnitude (N, along the casing
    /// normal) applied at the sample step, `[blade][sample]` (empty without a coating).
    pub coating_blade_force: Vec<Vec<f64>>,
    /// The case's probes (`Case::probes` order), `[probe][sample]`, m or N.
    pub probes: Vec<Vec<f64>>,
    /// The run's scalar results.
    pub summary: RunSummary,
}

/// Final state of the abradable coating (paper §4, Figs. 12–13). Rows are the impeller contact
/// rows (leading edge first); element `i` of a row is centred at the fixed-frame angle
/// `2π (i + ½)/η`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CoatingOutput {
    /// Number of elements per row η.
    pub eta: usize,
    /// Initial coating thickness e_abr (m).
    pub thickness: f64,
    /// Final wear profile per row (m, removed depth `ε_p e_abr ∈ [0, e_abr]`), `[row][element]`.
    pub final_wear: Vec<Vec<f64>>,
    /// Number of fully removed elements (wear = e_abr) per row at the end of the run.
    pub removed_elements: Vec<usize>,
    /// Largest per-blade coating force (N) over every step of the run (not only samples).
    pub peak_force: f64,
    /// Largest wear over the whole coating at the end of the run (m).
    pub max_wear_final: f64,
    /// Number of steps in which at least one blade node loaded the coating.
    pub coating_steps: usize,
    /// Time steps a blade tip spends over one element, `2π / (η |Ω| h)`. Below about 1 the
    /// tips skip elements (they are loaded only at the sampled positions) and the wear profile
    /// becomes spiky: refine h or coarsen η.
    pub steps_per_element: f64,
}

/// Wall-clock time (s) of each stage of the time loop (paper Fig. 4), summed over the run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StageSeconds {
    /// Predictors of both structures (modal recurrence and boundary synthesis).
    pub predict: f64,
    /// Control points of the casing spline from the predicted casing nodes.
    pub spline: f64,
    /// Blade-tip nodes and their closest points on the spline.
    pub projection: f64,
    /// Friction directions, the contact matrix `W` and the active-set solve.
    pub contact_solve: f64,
    /// Corrections of both structures, refreshed spline and residual re-projection.
    pub correction: f64,
    /// Time shift, probes and everything else.
    pub other: f64,
}

impl StageSeconds {
    /// Sum of all stages (s).
    pub fn total(&self) -> f64 {
        self.predict
            + self.spline
            + self.projection
            + self.contact_solve
            + self.correction
            + self.other
    }
}

/// Which stage of [`StageSeconds`] a [`StageClock::lap`] closes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// [`StageSeconds::predict`]: the predictors of both structures.
    Predict,
    /// [`StageSeconds::spline`]: the casing spline's control points.
    Spline,
    /// [`StageSeconds::projection`]: blade-tip nodes projected on the spline.
    Projection,
    /// [`StageSeconds::contact_solve`]: friction directions, `W` and the active-set solve.
    ContactSolve,
    /// [`StageSeconds::correction`]: corrections of both structures.
    Correction,
    /// [`StageSeconds::other`]: everything else.
    Other,
}

/// Lap timer of the time loop: each [`StageClock::lap`] charges the time since the previous
/// lap to one stage (one `Instant::now()` per lap, ~20 ns).
#[derive(Clone, Debug)]
pub struct StageClock {
    last: std::time::Instant,
    /// Accumulated seconds per stage.
    pub seconds: StageSeconds,
}

impl Default for StageClock {
    fn default() -> Self {
        Self::new()
    }
}

impl StageClock {
    /// Starts the clock now with every stage at zero.
    pub fn new() -> Self {
        Self {
            last: std::time::Instant::now(),
            seconds: StageSeconds::default(),
        }
    }

    /// Charges the time since the previous lap to `stage`.
    #[inline]
    pub fn lap(&mut self, stage: Stage) {
        let now = std::time::Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        let s = &mut self.seconds;
        *match stage {
            Stage::Predict => &mut s.predict,
            Stage::Spline => &mut s.spline,
            Stage::Projection => &mut s.projection,
            Stage::ContactSolve => &mut s.contact_solve,
            Stage::Correction => &mut s.correction,
            Stage::Other => &mut s.other,
        } += dt;
    }
}
/// Scalar results of a run (the series go to the
/// [`Recorder`](crate::dynamics::recorder::Recorder)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunSummary {
    /// Time step h (s).
    pub time_step: f64,
    /// Stability limit of the explicit scheme, 2/ω_max (s), ω_max (rad/s) the highest natural
    /// angular frequency of the impeller and casing ROMs (the smaller limit of the two).
    pub stability_limit: f64,
    /// Time steps per revolution at the rotation speed Ω, `2π / (|Ω| h)` (infinite at Ω = 0).
    pub steps_per_revolution: f64,
    /// Number of time steps of the run.
    pub n_steps: usize,
    /// Number of steps with at least one contact candidate.
    pub contact_steps: usize,
    /// Number of (step, node) pairs with a positive multiplier λ.
    pub active_contacts: usize,
    /// Steps that end with at least one closed contact (a positive multiplier).
    pub closed_contact_steps: usize,
    /// Largest residual penetration after a contact correction (m, over every step). On a
    /// casing surface box 4b measures it on every step (the corrected tips projected on the
    /// predicted surface moved by the casing's correction under them) and sample steps
    /// measure it again on the corrected surface itself; imposed gaps are exact on every step.
    pub max_residual_penetration: f64,
    /// Steps whose residual penetration exceeds the gap tolerance
    /// [`GAP_TOLERANCE`](crate::dynamics::simulate::GAP_TOLERANCE) × casing radius.
    pub steps_over_gap_tolerance: usize,
    /// The maxima over every step of the run (not only the sample steps).
    pub peaks: Peaks,
    /// Wall-clock time of the stepping loop (s).
    pub loop_seconds: f64,
    /// The loop's wall-clock time split by stage (s).
    pub stage_seconds: StageSeconds,
    /// The coating's final state (`None` without a coating).
    pub coating: Option<CoatingOutput>,
    /// Time steps actually run: `n_steps`, or fewer when a runaway stopped the run.
    pub steps_run: usize,
    /// The runaway that stopped the run early (`numerics.stop_on_runaway`), if any.
    pub runaway: Option<crate::dynamics::runaway::Runaway>,
}

/// Largest absolute values over every time step of a run: the maxima a sweep reports, the
/// same whatever `numerics.decimation` (a sample every 100 µs would miss up to a third of a
/// 2.75 kHz peak).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Peaks {
    /// Radial displacement (m) of any blade's leading-edge tip node.
    pub blade_le_radial: f64,
    /// Radial displacement (m) of any blade's trailing-edge tip node.
    pub blade_te_radial: f64,
    /// Radial displacement (m) of any blade's leading-edge tip node low-passed at
    /// [`BLADE_BAND_HZ`](crate::dynamics::low_pass::BLADE_BAND_HZ): the blade's vibration
    /// without the impact ringing above it that reduced models converge slowly. `None` when
    /// the step is longer than `1/(4 BLADE_BAND_HZ)`.
    pub blade_le_radial_lowpass: Option<f64>,
    /// The same at the trailing edge (m).
    pub blade_te_radial_lowpass: Option<f64>,
    /// Radial displacement (m) of the case's casing probe nodes, read every
    /// [`CASING_PEAK_INTERVAL`](crate::dynamics::simulate::CASING_PEAK_INTERVAL) of simulated
    /// time (every step when h is longer).
    pub casing_radial: f64,
    /// Normal contact force summed over a blade (N).
    pub contact_normal_force: f64,
    /// Abradable-coating force summed over a blade (N).
    pub coating_force: f64,
}

impl Peaks {
    /// Largest |blade-tip radial displacement| (m), leading or trailing edge.
    pub fn blade_radial(&self) -> f64 {
        self.blade_le_radial.max(self.blade_te_radial)
    }
}

// ---------------------------------------------------------------------------------------
// Probes selected by the case: displacements of contact and recovery nodes, contact forces
// and gaps of blade-tip nodes.

use crate::model::rom::{CyclicRom, Recovery};
use nalgebra::Vector3;

/// What a probe measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProbeQuantity {
    /// Displacement (m) along `component`.
    Displacement,
    /// Gap (m) of a blade-tip node to the casing, after the step's correction.
    Gap,
    /// Normal contact force λ (N) on a blade-tip node.
    NormalForce,
    /// Friction force magnitude μλ (N) on a blade-tip node (0 when it sticks or is free).
    TangentialForce,
}

/// A displacement component: x, y, z of the node's sector frame (for sector or blade 0, the
/// model's frame: rotating for an impeller, fixed for a casing), or radial, tangential
/// (counter-clockwise about +z) and axial (+z) at the node's reference position.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProbeComponent {
    /// x of the node's sector frame.
    X,
    /// y of the node's sector frame.
    Y,
    /// z of the node's sector frame (the rotation axis).
    Z,
    /// Radial, positive outward, at the node's reference position.
    Radial,
    /// Tangential, counter-clockwise about +z, at the node's reference position.
    Tangential,
    /// Axial, along +z (same direction as [`ProbeComponent::Z`]).
    Axial,
}

impl ProbeComponent {
    /// Name used in column names.
    pub fn name(self) -> &'static str {
        match self {
            ProbeComponent::X => "x",
            ProbeComponent::Y => "y",
            ProbeComponent::Z => "z",
            ProbeComponent::Radial => "radial",
            ProbeComponent::Tangential => "tangential",
            ProbeComponent::Axial => "axial",
        }
    }

    /// Unit vector of the component at reference position `p` (m, sector frame).
    pub fn direction(self, p: &[f64; 3]) -> Vector3<f64> {
        let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
        let er = if r > 0.0 {
            Vector3::new(p[0] / r, p[1] / r, 0.0)
        } else {
            Vector3::x()
        };
        match self {
            ProbeComponent::X => Vector3::x(),
            ProbeComponent::Y => Vector3::y(),
            ProbeComponent::Z => Vector3::z(),
            ProbeComponent::Radial => er,
            ProbeComponent::Tangential => Vector3::new(-er.y, er.x, 0.0),
            ProbeComponent::Axial => Vector3::z(),
        }
    }
}

/// One probe as the spec gives it (JSON `scenario.probes[i]`). The node is one of:
/// - `node`: a recovery node of the impeller ROM (FE id given at import), displacement only;
/// - `point`: a named recovery node of a built-in model, displacement only: on blade `blade`
///   (default 0) of the impeller (`leading_edge_mid_span`, `trailing_edge_mid_span`), or with
///   `sector`, on that sector of a flexible casing (`outer_mid_meridian`);
/// - `contact_node`: an impeller contact node by its FE id (imported models);
/// - `blade` and `row`: impeller contact node `row` (0 = leading edge) of blade `blade`;
/// - `sector` and `row`: contact node `row` of sector `sector` of a flexible casing,
///   displacement only.
///
/// `blade` (default 0) also picks the blade of a `node` or `contact_node`. `component` is
/// required for a displacement and refused otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    /// FE id of a recovery node of the impeller ROM (displacement only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<usize>,
    /// Name of a built-in model's recovery node (impeller, or casing with `sector`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub point: Option<String>,
    /// FE id of an impeller contact node (imported models).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_node: Option<usize>,
    /// Blade index (0-based; default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blade: Option<usize>,
    /// Sector index (0-based) of a flexible casing's contact node.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sector: Option<usize>,
    /// Contact row (0 = leading edge), with `blade` or `sector`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row: Option<usize>,
    /// What the probe measures.
    pub quantity: ProbeQuantity,
    /// Displacement component; required for a displacement, refused otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub component: Option<ProbeComponent>,
}

/// Which node a resolved probe reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProbeTarget {
    /// Recovery node `index` (in [`Recovery::nodes`]) of blade `blade`.
    Recovery {
        /// Blade index (0-based).
        blade: usize,
        /// Index in [`Recovery::nodes`].
        index: usize,
    },
    /// Impeller contact node `index` (in `contact_nodes`) of blade `blade`.
    Blade {
        /// Blade index (0-based).
        blade: usize,
        /// Index in the impeller ROM's `contact_nodes`.
        index: usize,
    },
    /// Recovery node `index` (in the casing ROM's [`Recovery::nodes`]) of casing sector `sector`.
    CasingRecovery {
        /// Casing sector index (0-based).
        sector: usize,
        /// Index in the casing ROM's [`Recovery::nodes`].
        index: usize,
    },
    /// Casing contact node `index` of sector `sector`.
    Casing {
        /// Casing sector index (0-based).
        sector: usize,
        /// Index in the casing ROM's `contact_nodes`.
        index: usize,
    },
}

/// A probe checked against the models: its node, what it measures, its column.
#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    /// The node the probe reads.
    pub target: ProbeTarget,
    /// What the probe measures.
    pub quantity: ProbeQuantity,
    /// Unit vector of the displacement component in the node's sector frame (zero otherwise).
    pub direction: Vector3<f64>,
    /// Time-series column, e.g. `node1353_y_m`, `contact188_gap_m`,
    /// `contact188_normal_force_n`, `blade0_row3_radial_m`, `casing2_row1_radial_m`.
    pub column: String,
    /// Unit of the values: `m` or `N`.
    pub unit: &'static str,
}

/// Why a probe of the spec cannot be measured: the field at fault (JSON name) and the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeError {
    /// Index of the probe in the spec's list.
    pub index: usize,
    /// Field of the probe at fault (`node`, `contact_node`, `quantity`, …); empty when the
    /// probe as a whole is at fault (no node, or two).
    pub field: &'static str,
    /// Why the probe cannot be measured.
    pub reason: String,
}

impl std::fmt::Display for ProbeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "probe {} ({}): {}", self.index, self.field, self.reason)
    }
}

/// Resolves the probes of a case against its impeller and (flexible) casing ROMs; every
/// nonexistent node, missing or superfluous field is an error naming the field, and so is a
/// probe that repeats an earlier one (two time-series columns of one name).
pub fn resolve_probes(
    specs: &[ProbeSpec],
    impeller: &CyclicRom,
    casing: Option<&CyclicRom>,
) -> Result<Vec<Probe>, ProbeError> {
    let mut probes: Vec<Probe> = Vec::with_capacity(specs.len());
    for (index, s) in specs.iter().enumerate() {
        let fail = |field, reason| ProbeError {
            index,
            field,
            reason,
        };
        let probe = resolve_one(s, impeller, casing).map_err(|(f, r)| fail(f, r))?;
        if let Some(first) = probes.iter().position(|p| p.column == probe.column) {
            let reason = format!("repeats probe {first} (column `{}`)", probe.column);
            return Err(fail("", reason));
        }
        probes.push(probe);
    }
    Ok(probes)
}

type FieldError = (&'static str, String);

fn resolve_one(
    s: &ProbeSpec,
    imp: &CyclicRom,
    casing: Option<&CyclicRom>,
) -> Result<Probe, FieldError> {
    let named = s.point.is_some();
    let given = [
        s.node.is_some(),
        s.contact_node.is_some(),
        named,
        s.sector.is_some() && !named,
        s.row.is_some() && s.sector.is_none() && !named,
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err((
            "",
            "give exactly one of `node`, `point`, `contact_node`, `blade` + `row` or `sector` + \
             `row`"
                .into(),
        ));
    }
    let (target, position, prefix) = if let Some(name) = &s.point {
        named_point(s, name, imp, casing)?
    } else if let Some(id) = s.node {
        let blade = check_blade(s.blade, imp)?;
        let index = recovery_index(&imp.recovery, id)?;
        let p = imp.recovery.nodes[index].position;
        let target = ProbeTarget::Recovery { blade, index };
        (target, p, blade_prefix(blade, format!("node{id}")))
    } else if let Some(id) = s.contact_node {
        let blade = check_blade(s.blade, imp)?;
        let index = imp
            .contact_nodes
            .iter()
            .position(|c| c.id == Some(id))
            .ok_or_else(|| ("contact_node", contact_id_reason(id, imp)))?;
        let p = imp.contact_nodes[index].position;
        let target = ProbeTarget::Blade { blade, index };
        (target, p, blade_prefix(blade, format!("contact{id}")))
    } else if let Some(sector) = s.sector {
        let rom = casing_of_probe(s, casing)?;
        let row = s
            .row
            .ok_or(("row", "a casing probe needs `row`".to_string()))?;
        check_index("sector", sector, rom.n_sectors, "casing sectors")?;
        check_index(
            "row",
            row,
            rom.n_contact(),
            "casing contact nodes per sector",
        )?;
        let target = ProbeTarget::Casing { sector, index: row };
        let p = rom.contact_nodes[row].position;
        (target, p, format!("casing{sector}_row{row}"))
    } else {
        let row = s.row.unwrap_or(0);
        let blade = s.blade.ok_or((
            "blade",
            "`row` needs `blade` (or `sector` for the casing)".to_string(),
        ))?;
        check_index("blade", blade, imp.n_sectors, "blades")?;
        check_index("row", row, imp.n_contact(), "contact nodes per blade")?;
        let target = ProbeTarget::Blade { blade, index: row };
        let p = imp.contact_nodes[row].position;
        (target, p, format!("blade{blade}_row{row}"))
    };
    finish_probe(s, target, &position, prefix)
}

/// The flexible casing a probe with `sector` reads; an error for a rigid casing or a probe
/// that also names a `blade`.
fn casing_of_probe<'a>(
    s: &ProbeSpec,
    casing: Option<&'a CyclicRom>,
) -> Result<&'a CyclicRom, FieldError> {
    let rom = casing.ok_or_else(|| {
        (
            "sector",
            "a casing probe needs a flexible casing (a rigid casing does not move)".to_string(),
        )
    })?;
    if s.blade.is_some() {
        return Err(("blade", "a casing probe takes `sector`, not `blade`".into()));
    }
    Ok(rom)
}

/// A named recovery node of a built-in model: of the impeller (blade `blade`, default 0), or of
/// the flexible casing with `sector`.
fn named_point(
    s: &ProbeSpec,
    name: &str,
    imp: &CyclicRom,
    casing: Option<&CyclicRom>,
) -> Result<(ProbeTarget, [f64; 3], String), FieldError> {
    if s.row.is_some() {
        return Err(("row", "a `point` takes no `row`".into()));
    }
    let index = |rom: &CyclicRom, what: &str| {
        rom.recovery.named(name).ok_or_else(|| {
            let names: Vec<&str> = (rom.recovery.nodes.iter())
                .filter_map(|n| n.name.as_deref())
                .collect();
            let reason = if names.is_empty() {
                format!(
                    "the {what} ROM has no named recovery nodes (named nodes belong to built-in \
                     models; an imported model's recovery nodes are probed by `node`)"
                )
            } else {
                format!("`{name}` is not a named node of the {what} (it has {names:?})")
            };
            ("point", reason)
        })
    };
    if let Some(sector) = s.sector {
        let rom = casing_of_probe(s, casing)?;
        check_index("sector", sector, rom.n_sectors, "casing sectors")?;
        let index = index(rom, "casing")?;
        let target = ProbeTarget::CasingRecovery { sector, index };
        let p = rom.recovery.nodes[index].position;
        Ok((target, p, format!("casing{sector}_{name}")))
    } else {
        let blade = check_blade(s.blade, imp)?;
        let index = index(imp, "impeller")?;
        let p = imp.recovery.nodes[index].position;
        let target = ProbeTarget::Recovery { blade, index };
        Ok((target, p, blade_prefix(blade, name.to_string())))
    }
}

/// The quantity's checks, direction, column name and unit.
fn finish_probe(
    s: &ProbeSpec,
    target: ProbeTarget,
    position: &[f64; 3],
    prefix: String,
) -> Result<Probe, FieldError> {
    let blade_node = matches!(target, ProbeTarget::Blade { .. });
    let (direction, suffix, unit) = match (s.quantity, s.component) {
        (ProbeQuantity::Displacement, Some(c)) => {
            (c.direction(position), format!("{}_m", c.name()), "m")
        }
        (ProbeQuantity::Displacement, None) => {
            return Err((
                "component",
                "a displacement needs `component` (x, y, z, radial, tangential or axial)".into(),
            ));
        }
        (_, Some(_)) => {
            return Err(("component", "only a displacement takes a component".into()));
        }
        (q, None) if !blade_node => {
            return Err((
                "quantity",
                format!(
                    "{q:?} is measured at blade-tip contact nodes only (`contact_node` or \
                     `blade` + `row`); this node has displacements only"
                ),
            ));
        }
        (ProbeQuantity::Gap, None) => (Vector3::zeros(), "gap_m".to_string(), "m"),
        (ProbeQuantity::NormalForce, None) => (Vector3::zeros(), "normal_force_n".to_string(), "N"),
        (ProbeQuantity::TangentialForce, None) => {
            (Vector3::zeros(), "tangential_force_n".to_string(), "N")
        }
    };
    Ok(Probe {
        target,
        quantity: s.quantity,
        direction,
        column: format!("{prefix}_{suffix}"),
        unit,
    })
}

fn blade_prefix(blade: usize, name: String) -> String {
    if blade == 0 {
        name
    } else {
        format!("blade{blade}_{name}")
    }
}

fn check_blade(blade: Option<usize>, imp: &CyclicRom) -> Result<usize, FieldError> {
    let b = blade.unwrap_or(0);
    check_index("blade", b, imp.n_sectors, "blades")?;
    Ok(b)
}

fn check_index(field: &'static str, i: usize, n: usize, what: &str) -> Result<(), FieldError> {
    if i < n {
        Ok(())
    } else {
        Err((
            field,
            format!("{i} does not exist: the model has {n} {what} (0..{n})"),
        ))
    }
}

fn recovery_index(rec: &Recovery, id: usize) -> Result<usize, FieldError> {
    rec.position_of(id).ok_or_else(|| {
        let ids: Vec<usize> = rec.nodes.iter().map(|n| n.id).collect();
        let reason = if ids.is_empty() {
            format!(
                "node {id} cannot be recovered: the impeller ROM has no recovery nodes (list \
                 it in the import spec's `recovery_nodes` and import again)"
            )
        } else {
            format!("node {id} is not a recovery node of the impeller ROM (it has {ids:?})")
        };
        ("node", reason)
    })
}

fn contact_id_reason(id: usize, imp: &CyclicRom) -> String {
    let ids: Vec<usize> = imp.contact_nodes.iter().filter_map(|c| c.id).collect();
    if ids.is_empty() {
        format!(
            "contact node {id}: the impeller's contact nodes carry no FE ids (built-in or \
             format-1 model); address them by `blade` and `row`"
        )
    } else {
        format!("{id} is not a contact node of the impeller (its contact nodes are {ids:?})")
    }
}

/// Evaluates recovery rows on the harmonic state of a structure: the displacement (m, sector
/// frame) of a recovery node in sector `s`,
/// `u = Σ_k w_k [cos kθ_s (R_re a + R_im b) + sin kθ_s (R_re b − R_im a)]` with `(a, b)` the
/// real-form coordinates of nodal diameter k (`x̃ = a − i b`, `ũ = R x̃`, `u_s = Re(ũ e^{ikθ_s})`,
/// DESIGN §2.2) and `w_k` the weight of the orthonormal sector DFT.
#[derive(Clone, Debug)]
pub struct RecoveryEval {
    n_sectors: usize,
    /// Per nodal diameter: offset of its real-form vector, part size n, real flag, w_k.
    blocks: Vec<(usize, usize, bool, f64)>,
}

impl RecoveryEval {
    /// From the block layout of a [`crate::dynamics::structure::Structure`].
    pub fn new(st: &crate::dynamics::structure::Structure) -> Self {
        Self {
            n_sectors: st.n_sectors,
            blocks: st
                .blocks
                .iter()
                .map(|b| (b.offset, b.n, b.real, st.dft_weight(b.k)))
                .collect(),
        }
    }

    /// Displacement of recovery node `index` in sector `sector` for the harmonic state `x`
    /// (concatenated real-form vectors, see [`crate::dynamics::kernel::StructureKernel::harmonic_state`]).
    pub fn displacement(
        &self,
        rec: &Recovery,
        index: usize,
        sector: usize,
        x: &[f64],
    ) -> Vector3<f64> {
        let mut u = Vector3::zeros();
        let alpha = std::f64::consts::TAU / self.n_sectors as f64;
        for (k, (&(off, n, real, w), rows)) in self.blocks.iter().zip(&rec.rows).enumerate() {
            let th = ((k * sector) % self.n_sectors) as f64 * alpha;
            let (c, s) = (th.cos(), th.sin());
            let a = &x[off..off + n];
            for d in 0..3 {
                let r = 3 * index + d;
                let dot = |m: &nalgebra::DMatrix<f64>, v: &[f64]| -> f64 {
                    v.iter().enumerate().map(|(j, vj)| m[(r, j)] * vj).sum()
                };
                u[d] += w * c * dot(&rows.re, a);
                if !real {
                    let b = &x[off + n..off + 2 * n];
                    u[d] += w * (c * dot(&rows.im, b) + s * (dot(&rows.re, b) - dot(&rows.im, a)));
                }
            }
        }
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{SyntheticSpec, synthetic_rom};
    use crate::model::rom::{ComplexRows, Component, RecoveryNode};

    /// A 3-blade impeller with FE ids 188, 190 on its contact nodes and recovery node 1353.
    fn impeller() -> CyclicRom {
        let mut imp = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 3, 2, 1));
        imp.contact_nodes[0].id = Some(188);
        imp.contact_nodes[1].id = Some(190);
        let rows = imp
            .harmonics
            .iter()
            .map(|h| ComplexRows {
                re: nalgebra::DMatrix::zeros(3, h.mass.size()),
                im: nalgebra::DMatrix::zeros(3, h.mass.size()),
            })
            .collect();
        imp.recovery = Recovery {
            nodes: vec![RecoveryNode {
                id: 1353,
                position: [0.0, 0.2, 0.0],
                name: None,
            }],
            rows,
        };
        imp
    }

    fn spec(json: serde_json::Value) -> ProbeSpec {
        serde_json::from_value(json).unwrap()
    }

    #[test]
    fn probes_resolve_to_named_columns_and_directions() {
        let imp = impeller();
        let cas = synthetic_rom(&SyntheticSpec::small(Component::Casing, 4, 3, 1));
        let specs = [
            spec(serde_json::json!({"node": 1353, "quantity": "displacement", "component": "y"})),
            spec(serde_json::json!({"contact_node": 188, "quantity": "gap"})),
            spec(serde_json::json!({"contact_node": 190, "blade": 2, "quantity": "normal_force"})),
            spec(serde_json::json!({"blade": 1, "row": 1, "quantity": "tangential_force"})),
            spec(
                serde_json::json!({"sector": 3, "row": 2, "quantity": "displacement", "component": "radial"}),
            ),
            spec(
                serde_json::json!({"node": 1353, "quantity": "displacement", "component": "tangential"}),
            ),
        ];
        let p = resolve_probes(&specs, &imp, Some(&cas)).unwrap();
        let cols: Vec<&str> = p.iter().map(|p| p.column.as_str()).collect();
        assert_eq!(
            cols,
            [
                "node1353_y_m",
                "contact188_gap_m",
                "blade2_contact190_normal_force_n",
                "blade1_row1_tangential_force_n",
                "casing3_row2_radial_m",
                "node1353_tangential_m",
            ]
        );
        let units: Vec<&str> = p.iter().map(|p| p.unit).collect();
        assert_eq!(units, ["m", "m", "N", "N", "m", "m"]);
        assert_eq!(p[2].target, ProbeTarget::Blade { blade: 2, index: 1 });
        // Node 1353 sits on +y: its tangential direction is −x.
        assert!((p[5].direction - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-15);
    }

    /// A probe that repeats an earlier one (the same contact node and quantity twice) would
    /// write a second column of the same name: refused, naming both.
    #[test]
    fn a_repeated_probe_is_refused() {
        let imp = impeller();
        let specs = [
            spec(serde_json::json!({"contact_node": 188, "quantity": "gap"})),
            spec(serde_json::json!({"node": 1353, "quantity": "displacement", "component": "y"})),
            spec(serde_json::json!({"contact_node": 188, "quantity": "gap"})),
        ];
        let e = resolve_probes(&specs, &imp, None).unwrap_err();
        assert_eq!((e.index, e.field), (2, ""));
        assert!(
            e.reason.contains("repeats probe 0") && e.reason.contains("contact188_gap_m"),
            "{e}"
        );
    }

    #[test]
    fn nonexistent_nodes_and_wrong_quantities_name_their_field() {
        let imp = impeller();
        let bad = |json: serde_json::Value, casing: Option<&CyclicRom>| {
            resolve_probes(&[spec(json)], &imp, casing).unwrap_err()
        };
        let e = bad(
            serde_json::json!({"node": 7, "quantity": "displacement", "component": "y"}),
            None,
        );
        assert_eq!(e.field, "node");
        assert!(e.reason.contains("[1353]"), "{e}");
        let e = bad(
            serde_json::json!({"contact_node": 5, "quantity": "gap"}),
            None,
        );
        assert_eq!(e.field, "contact_node");
        assert!(e.reason.contains("[188, 190]"), "{e}");
        let e = bad(
            serde_json::json!({"blade": 3, "row": 0, "quantity": "gap"}),
            None,
        );
        assert_eq!(e.field, "blade");
        let e = bad(
            serde_json::json!({"sector": 0, "row": 0, "quantity": "displacement", "component": "x"}),
            None,
        );
        assert!(e.field == "sector" && e.reason.contains("flexible"), "{e}");
        let e = bad(serde_json::json!({"node": 1353, "quantity": "gap"}), None);
        assert_eq!(e.field, "quantity");
        let e = bad(
            serde_json::json!({"contact_node": 188, "quantity": "displacement"}),
            None,
        );
        assert_eq!(e.field, "component");
        let e = bad(
            serde_json::json!({"contact_node": 188, "quantity": "gap", "component": "x"}),
            None,
        );
        assert_eq!(e.field, "component");
        let e = bad(
            serde_json::json!({"node": 1353, "contact_node": 188, "quantity": "gap"}),
            None,
        );
        assert_eq!(e.field, "");
        // A model without recovery rows says how to get them.
        let mut plain = impeller();
        plain.recovery = Recovery::default();
        let e = resolve_probes(
            &[spec(
                serde_json::json!({"node": 1353, "quantity": "displacement", "component": "y"}),
            )],
            &plain,
            None,
        )
        .unwrap_err();
        assert!(e.reason.contains("recovery_nodes"), "{e}");
    }

    /// Named nodes of a built-in model: on a blade of the impeller, or with `sector` on the
    /// casing; unknown names, a `row`, or a model without names are refused on `point`/`row`.
    #[test]
    fn named_points_resolve_on_impeller_and_casing() {
        let mut imp = impeller();
        imp.recovery.nodes[0].name = Some("leading_edge_mid_span".into());
        let mut cas = synthetic_rom(&SyntheticSpec::small(Component::Casing, 4, 3, 1));
        cas.recovery = Recovery {
            nodes: vec![RecoveryNode {
                id: 7,
                position: [0.3, 0.0, 0.01],
                name: Some("outer_mid_meridian".into()),
            }],
            rows: (cas.harmonics.iter())
                .map(|h| ComplexRows {
                    re: nalgebra::DMatrix::zeros(3, h.mass.size()),
                    im: nalgebra::DMatrix::zeros(3, h.mass.size()),
                })
                .collect(),
        };
        cas.validate().unwrap();
        let specs = [
            spec(
                serde_json::json!({"point": "leading_edge_mid_span", "blade": 2, "quantity": "displacement", "component": "y"}),
            ),
            spec(
                serde_json::json!({"point": "outer_mid_meridian", "sector": 3, "quantity": "displacement", "component": "radial"}),
            ),
        ];
        let p = resolve_probes(&specs, &imp, Some(&cas)).unwrap();
        assert_eq!(p[0].column, "blade2_leading_edge_mid_span_y_m");
        assert_eq!(p[0].target, ProbeTarget::Recovery { blade: 2, index: 0 });
        assert_eq!(p[1].column, "casing3_outer_mid_meridian_radial_m");
        assert_eq!(
            p[1].target,
            ProbeTarget::CasingRecovery {
                sector: 3,
                index: 0
            }
        );
        assert!((p[1].direction - Vector3::x()).norm() < 1e-15);

        let bad = |json: serde_json::Value, imp: &CyclicRom| {
            resolve_probes(&[spec(json)], imp, Some(&cas)).unwrap_err()
        };
        let e = bad(
            serde_json::json!({"point": "tip", "quantity": "displacement", "component": "y"}),
            &imp,
        );
        assert!(
            e.field == "point" && e.reason.contains("leading_edge_mid_span"),
            "{e}"
        );
        let e = bad(
            serde_json::json!({"point": "outer_mid_meridian", "sector": 4, "quantity": "displacement", "component": "y"}),
            &imp,
        );
        assert_eq!(e.field, "sector", "{e}");
        let e = bad(
            serde_json::json!({"point": "leading_edge_mid_span", "row": 0, "quantity": "displacement", "component": "y"}),
            &imp,
        );
        assert_eq!(e.field, "row", "{e}");
        let e = bad(
            serde_json::json!({"point": "leading_edge_mid_span", "quantity": "gap"}),
            &imp,
        );
        assert_eq!(e.field, "quantity", "{e}");
        let e = bad(
            serde_json::json!({"point": "leading_edge_mid_span", "quantity": "displacement", "component": "y"}),
            &impeller(),
        );
        assert!(
            e.field == "point" && e.reason.contains("no named recovery nodes"),
            "{e}"
        );
    }
}
