//! Model specs: from geometric parameters to reduced-order models (mesh → FE matrices →
//! cyclic Craig–Bampton). Pure numerics; the on-disk cache lives in [`crate::app`].

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::model::fe::{
    FeError, assemble_element_set, assemble_sector, initial_displacement_stiffness,
};
use crate::model::mesh::{CasingGeometry, ImpellerGeometry, MeshError, SectorMesh};
use crate::model::reduction::{ReductionError, ReductionOptions, reduce_cyclic};
use crate::model::rom::{Component, CyclicRom, Damping};

/// Everything that can stop a model build; the message names the stage and the cause.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The parametric geometry or its mesh is invalid.
    #[error("{component} geometry: {source}")]
    Mesh {
        /// `"impeller"` or `"casing"`.
        component: &'static str,
        /// The mesher's error.
        source: MeshError,
    },
    /// The finite-element assembly (or the centrifugal prestress) failed.
    #[error("{component} finite elements: {source}")]
    Fe {
        /// `"impeller"` or `"casing"`.
        component: &'static str,
        /// The assembly's error.
        source: FeError,
    },
    /// The cyclic Craig–Bampton reduction failed.
    #[error("{component} reduction: {source}")]
    Reduction {
        /// `"impeller"` or `"casing"`.
        component: &'static str,
        /// The reduction's error.
        source: ReductionError,
    },
    /// The model spec itself is invalid (unknown field, wrong type); the message says where.
    #[error("{0}")]
    Invalid(String),
}

/// Build parameters of the casing ROM.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CasingSpec {
    /// Parametric geometry (defaults: [`CasingGeometry::default`]).
    pub geometry: CasingGeometry,
    /// Fixed-interface modes per nodal diameter (default [`DEFAULT_MODES_PER_DIAMETER`];
    /// paper: 10).
    pub modes_per_diameter: usize,
    /// Damping stored in the ROM.
    pub damping: Damping,
}

/// Fixed-interface modes per nodal diameter of the built-in models: the smallest count at
/// which doubling it moves every maximum of case study 1's nominal job and its wear profile
/// by less than 2 % with the default (massless) boundary (`docs/validation.md`, "Converged
/// ROMs": 10 → 20 moves the leading edge by 3.1 %, 20 → 40 everything by ≤ 1.4 %).
pub const DEFAULT_MODES_PER_DIAMETER: usize = 20;

impl Default for CasingSpec {
    fn default() -> Self {
        Self {
            geometry: CasingGeometry::default(),
            modes_per_diameter: DEFAULT_MODES_PER_DIAMETER,
            damping: Damping::default(),
        }
    }
}

/// Build parameters of the impeller ROM.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImpellerSpec {
    /// Parametric geometry (defaults: [`ImpellerGeometry::default`]).
    pub geometry: ImpellerGeometry,
    /// Fixed-interface modes per nodal diameter (default [`DEFAULT_MODES_PER_DIAMETER`];
    /// paper: 10).
    pub modes_per_diameter: usize,
    /// Rotation speeds (rad/s) of the stored modal data (Campbell diagram, interaction criterion).
    pub omega_grid_rad_s: Vec<f64>,
    /// How K(Ω) follows the speed (default: the consistent tangent, as CalculiX's prestressed
    /// perturbation step).
    #[serde(skip_serializing_if = "Prestress::is_default")]
    pub prestress: Prestress,
    /// Damping stored in the ROM.
    pub damping: Damping,
    /// Blade modes kept for structural mistuning ([`crate::model::rom::BladeModes`]): 0 (the
    /// default, not written, so that a tuned model keeps its identity) keeps none.
    #[serde(skip_serializing_if = "is_zero")]
    pub blade_modes: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

impl Default for ImpellerSpec {
    fn default() -> Self {
        Self {
            geometry: ImpellerGeometry::default(),
            modes_per_diameter: DEFAULT_MODES_PER_DIAMETER,
            // 0 to 7000 rad/s (67,000 rpm) brackets the speed range of a small turboshaft
            // compressor and its first casing/impeller coincidences.
            omega_grid_rad_s: (0..=14).map(|i| 500.0 * i as f64).collect(),
            prestress: Prestress::default(),
            damping: Damping::default(),
            blade_modes: 0,
        }
    }
}

/// A model spec file: both components, each with defaults.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelSpec {
    /// How to build the impeller ROM.
    pub impeller: ImpellerSpec,
    /// How to build the casing ROM.
    pub casing: CasingSpec,
}

impl ModelSpec {
    /// Parses a model spec from JSON; unknown fields are errors.
    pub fn from_json(value: Value) -> Result<Self, BuildError> {
        serde_json::from_value(value).map_err(|e| BuildError::Invalid(format!("model spec: {e}")))
    }
}

/// How the impeller's stiffness follows the rotation speed, K(Ω) = K0 + Ω² K1 + Ω⁴ K2, both
/// from the linear centrifugal prestate (the nodal-diameter-0 static solution under `ρ Ω² r`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Prestress {
    /// Stress stiffening and spin softening: K1 = K_σ − M_s, K2 = 0 (the classic model; 1 %
    /// stiffer than CalculiX's prestressed solve at 3500 rad/s, 4 % at 7000 rad/s).
    StressStiffening,
    /// The consistent tangent, as CalculiX's perturbation step after a linear `*STATIC`
    /// step forms it (the default): K1 = K_σ + K_u1 − M_s and K2 = K_u2, with the
    /// initial-displacement stiffness K_u ([`crate::model::fe::element_displacement_stiffness`]);
    /// the reduction basis then also holds the fixed-interface modes and the change of the
    /// constraint modes at the grid's top speed. The 20-mode ROM is within 8.6e-4 of
    /// CalculiX at 3500 and 7000 rad/s (`docs/validation.md`, "Prestressed frequencies").
    #[default]
    Consistent,
}

impl Prestress {
    /// Whether this is the default (left out of serialized specs, so that job ids of
    /// existing specs do not change; the job identity and the ROM cache's revision say that
    /// the default changed).
    pub fn is_default(&self) -> bool {
        *self == Prestress::default()
    }
}

/// How [`reduce_sector`] reduces a sector.
#[derive(Clone, Debug, PartialEq)]
pub struct SectorReduction {
    /// Fixed-interface modes per nodal diameter.
    pub modes_per_diameter: usize,
    /// Rotation speeds (rad/s) of the modal data.
    pub omega_grid: Vec<f64>,
    /// Blade modes kept for structural mistuning (0: none; [`crate::model::rom::BladeModes`]).
    pub blade_modes: usize,
}

/// Assembles a sector mesh and reduces it (cyclic Craig–Bampton, `modes_per_diameter`
/// fixed-interface modes per nodal diameter, modal data at every speed of `omega_grid`, rad/s;
/// the impeller's K(Ω) from its centrifugal prestate, as `prestress` says): the shared tail of
/// the built-in models and of the cyclic CalculiX import. `name` is stored in the ROM.
pub fn reduce_sector(
    component: Component,
    mesh: &SectorMesh,
    reduction: SectorReduction,
    prestress: Prestress,
    damping: Damping,
    name: String,
) -> Result<CyclicRom, BuildError> {
    let (label, rotating) = match component {
        Component::Casing => ("casing", false),
        Component::Impeller => ("impeller", true),
    };
    let SectorReduction {
        modes_per_diameter,
        omega_grid,
        blade_modes,
    } = reduction;
    if modes_per_diameter == 0 {
        return Err(BuildError::Invalid(format!(
            "{label}.modes_per_diameter must be at least 1"
        )));
    }
    if blade_modes > 0 && mesh.blade_elements.is_empty() {
        return Err(BuildError::Invalid(format!(
            "{label}.blade_modes: the {label} sector names no blade elements"
        )));
    }
    let fe_error = |source| BuildError::Fe {
        component: label,
        source,
    };
    let mut mats = assemble_sector(mesh, rotating).map_err(fe_error)?;
    let mut speed_basis = None;
    if let (Prestress::Consistent, Some(u1), Some(k1)) =
        (prestress, &mats.prestate, &mats.centrifugal)
    {
        let [ku1, ku2] = initial_displacement_stiffness(mesh, u1).map_err(fe_error)?;
        mats.centrifugal = Some(k1 + &ku1);
        mats.centrifugal_quartic = Some(ku2);
        speed_basis = omega_grid
            .iter()
            .copied()
            .reduce(f64::max)
            .filter(|&w| w > 0.0);
    }
    let blade = if blade_modes > 0 {
        Some(assemble_element_set(mesh, &mesh.blade_elements).map_err(fe_error)?)
    } else {
        None
    };
    let opts = ReductionOptions {
        modes_per_diameter,
        omega_grid,
        component,
        name,
        damping,
        recovery_points: mesh.named_nodes.clone(),
        speed_basis,
        blade_modes,
    };
    reduce_cyclic(mesh, &mats, blade.as_ref(), &opts).map_err(|source| BuildError::Reduction {
        component: label,
        source,
    })
}

/// Builds and reduces one built-in component ([`reduce_sector`]); `spec` is recorded as the
/// ROM's provenance.
fn reduce_built_in(
    component: Component,
    mesh: Result<SectorMesh, MeshError>,
    reduction: SectorReduction,
    prestress: Prestress,
    damping: Damping,
    spec: &impl Serialize,
) -> Result<CyclicRom, BuildError> {
    let label = match component {
        Component::Casing => "casing",
        Component::Impeller => "impeller",
    };
    let mesh = mesh.map_err(|source| BuildError::Mesh {
        component: label,
        source,
    })?;
    let name = format!("built-in {label}");
    let mut rom = reduce_sector(component, &mesh, reduction, prestress, damping, name)?;
    rom.provenance = serde_json::json!({ "builtin": spec, "rubscan": env!("CARGO_PKG_VERSION") });
    Ok(rom)
}

/// Checks a grid of rotation speeds (rad/s) for the impeller's modal data: finite, ≥ 0 and
/// strictly increasing (the Campbell data are interpolated along it); `field` names it.
pub fn check_omega_grid(field: &str, grid: &[f64]) -> Result<(), BuildError> {
    if grid.iter().any(|w| !w.is_finite() || *w < 0.0) {
        return Err(BuildError::Invalid(format!(
            "{field}: speeds must be finite and ≥ 0"
        )));
    }
    if let Some(i) = (1..grid.len()).find(|&i| grid[i] <= grid[i - 1]) {
        return Err(BuildError::Invalid(format!(
            "{field}: speeds must be strictly increasing, entry {i} ({} rad/s) follows {} rad/s",
            grid[i],
            grid[i - 1]
        )));
    }
    Ok(())
}

/// Builds the casing ROM: mesh, FE assembly, cyclic Craig–Bampton.
pub fn build_casing(spec: &CasingSpec) -> Result<CyclicRom, BuildError> {
    reduce_built_in(
        Component::Casing,
        spec.geometry.build(),
        SectorReduction {
            modes_per_diameter: spec.modes_per_diameter,
            omega_grid: vec![0.0],
            blade_modes: 0,
        },
        Prestress::default(),
        spec.damping,
        spec,
    )
}

/// Builds the impeller ROM with its centrifugal prestress `K(Ω) = K0 + Ω² K1 + Ω⁴ K2` ([`Prestress`]).
pub fn build_impeller(spec: &ImpellerSpec) -> Result<CyclicRom, BuildError> {
    check_omega_grid("impeller.omega_grid_rad_s", &spec.omega_grid_rad_s)?;
    let grid = spec.omega_grid_rad_s.clone();
    reduce_built_in(
        Component::Impeller,
        spec.geometry.build(),
        SectorReduction {
            modes_per_diameter: spec.modes_per_diameter,
            omega_grid: grid,
            blade_modes: spec.blade_modes,
        },
        spec.prestress,
        spec.damping,
        spec,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_rejects_unknown_fields_and_zero_modes() {
        let err = ModelSpec::from_json(serde_json::json!({"casing": {"modez": 3}}))
            .unwrap_err()
            .to_string();
        assert!(err.contains("modez"), "{err}");
        let spec = CasingSpec {
            modes_per_diameter: 0,
            ..CasingSpec::default()
        };
        assert!(
            build_casing(&spec)
                .unwrap_err()
                .to_string()
                .contains("modes_per_diameter")
        );
    }

    /// The Campbell data are interpolated along the speed grid: an unsorted or repeated
    /// speed is refused before anything is built, naming the entry.
    #[test]
    fn an_unsorted_speed_grid_is_refused_with_its_entry() {
        for (grid, entry) in [(vec![0.0, 1500.0, 500.0], 2), (vec![0.0, 0.0], 1)] {
            let spec = ImpellerSpec {
                omega_grid_rad_s: grid,
                ..ImpellerSpec::default()
            };
            let err = build_impeller(&spec).unwrap_err().to_string();
            assert!(
                err.contains("omega_grid_rad_s")
                    && err.contains("strictly increasing")
                    && err.contains(&format!("entry {entry}")),
                "{err}"
            );
        }
    }

    /// 60 fixed-interface modes per nodal diameter build: on nodal diameter 0 their Krylov
    /// space is the whole space and modes 54–60 still need the shifted refinement (56 of 60
    /// without it). The richer basis contains the default one, so no ROM frequency rises
    /// (Rayleigh–Ritz). With the classic prestress, whose basis is the fixed-interface modes
    /// at rest alone, so that the mode counts are exact.
    #[test]
    fn the_impeller_builds_with_60_modes_per_diameter() {
        let classic = ImpellerSpec {
            prestress: Prestress::StressStiffening,
            ..ImpellerSpec::default()
        };
        let few = build_impeller(&classic).unwrap();
        let spec = ImpellerSpec {
            modes_per_diameter: 60,
            ..classic
        };
        let many = build_impeller(&spec).unwrap();
        assert_eq!(
            many.harmonics[0].n_modes,
            few.harmonics[0].n_modes + 60 - DEFAULT_MODES_PER_DIAMETER
        );
        for (a, b) in few.modal_data.iter().zip(&many.modal_data) {
            for (fa, fb) in a.frequencies.iter().zip(&b.frequencies) {
                for (x, y) in fa.iter().zip(fb) {
                    assert!(
                        *y <= x * (1.0 + 1e-9),
                        "ND {}: {y} Hz > {x} Hz",
                        a.nodal_diameter
                    );
                }
            }
        }
    }

    #[test]
    fn small_casing_builds_and_validates() {
        let mut spec = CasingSpec::default();
        spec.geometry.n_sectors = 8;
        spec.modes_per_diameter = 3;
        let rom = build_casing(&spec).unwrap();
        assert_eq!(rom.n_sectors, 8);
        assert_eq!(rom.harmonics.len(), 5);
        assert_eq!(rom.n_contact(), spec.geometry.contact_nodes);
        assert_eq!(rom.validate(), Ok(()));
    }
}
