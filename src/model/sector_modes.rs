//! Natural frequencies of the *unreduced* cyclic sector finite-element model, per nodal
//! diameter, at rest or spinning (the impeller's linear prestress, [`Tangent`]): the
//! reference the Craig–Bampton ROM approximates, and what an
//! external FE solver's cyclic symmetry solve of the same mesh must reproduce (issue 40, the
//! CalculiX check in `docs/validation.md`).
//!
//! For each nodal diameter `k = 0..=N/2` the sector matrices K0 and M become the complex
//! Hermitian harmonic matrices over the independent DOFs ([`crate::model::cyclic`]); the
//! lowest eigenpairs come from the sparse block Krylov solver on the Cholesky factor of the
//! harmonic stiffness ([`crate::model::sparse_eigen`]), converged to the relative residual
//! [`TOLERANCE`]. Each frequency of a nodal diameter 0 < k < N/2 appears once (its −k twin
//! is the complex conjugate mode).

use faer::c64;
use faer::sparse::SparseColMat;
use rayon::prelude::*;

use crate::model::component::scaled;
use crate::model::cyclic::{CyclicDofMap, CyclicError, SectorTopology};
use crate::model::fe::{FeError, assemble_sector, initial_displacement_stiffness};
use crate::model::mesh::SectorMesh;
use crate::model::reduction::signed_hz;
use crate::model::sparse_eigen::{
    CholeskyFactor, Pencil, SparseEigenError, SparseEigenOptions, lowest_eigenpairs,
};

/// Relative residual `‖K φ − λ M φ‖ ≤ TOLERANCE ‖K φ‖` of every returned mode: far below the
/// 1e-3 of the comparisons it serves.
pub const TOLERANCE: f64 = 1e-10;

/// Why the unreduced frequencies could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum SectorModesError {
    /// The mesh is invalid or an element is inverted.
    #[error("finite elements: {0}")]
    Fe(#[from] FeError),
    /// The cyclic topology is inconsistent.
    #[error("cyclic sector: {0}")]
    Cyclic(#[from] CyclicError),
    /// The eigensolver failed (e.g. the harmonic stiffness is singular: an unclamped sector).
    #[error("nodal diameter {k}: {source}")]
    Eigen {
        /// Nodal diameter.
        k: usize,
        /// The solver's error.
        source: SparseEigenError,
    },
}

/// Which tangent stiffness of the spinning sector [`unreduced_frequencies`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tangent {
    /// rubscan's K(Ω) = K0 + Ω² K1: stress stiffening and spin softening (the ROMs' model).
    StressStiffening,
    /// K(Ω) plus the initial-displacement stiffness `Ω² K_u1 + Ω⁴ K_u2` of the linear
    /// prestate: the consistent linearisation, as CalculiX's perturbation step forms it.
    WithInitialDisplacement,
}

/// The lowest `n_modes` natural frequencies (Hz, ascending) of every nodal diameter
/// `0..=N/2` (outer index) of the unreduced sector model of `mesh` turning at `omega` rad/s
/// (at rest for 0) with the `tangent` stiffness. Fewer when a harmonic problem has fewer DOFs.
pub fn unreduced_frequencies(
    mesh: &SectorMesh,
    n_modes: usize,
    omega: f64,
    tangent: Tangent,
) -> Result<Vec<Vec<f64>>, SectorModesError> {
    let mats = assemble_sector(mesh, omega != 0.0)?;
    let w2 = omega * omega;
    let mut stiffness = match &mats.centrifugal {
        Some(k1) => &mats.stiffness + &scaled(k1, w2),
        None => mats.stiffness.clone(),
    };
    if let (Tangent::WithInitialDisplacement, Some(u1)) = (tangent, &mats.prestate) {
        let [ku1, ku2] = initial_displacement_stiffness(mesh, u1)?;
        stiffness = &(&stiffness + &scaled(&ku1, w2)) + &scaled(&ku2, w2 * w2);
    }
    let topo = SectorTopology::of(mesh);
    let map = CyclicDofMap::new(&topo, &[])?;
    (0..=mesh.n_sectors / 2)
        .into_par_iter()
        .map(|k| harmonic_frequencies(&map, &stiffness, &mats.mass, k, n_modes))
        .collect()
}

/// The lowest `n_modes` frequencies (Hz) of nodal diameter `k`.
fn harmonic_frequencies(
    map: &CyclicDofMap,
    stiffness: &SparseColMat<usize, f64>,
    mass: &SparseColMat<usize, f64>,
    k: usize,
    n_modes: usize,
) -> Result<Vec<f64>, SectorModesError> {
    let n = map.n_independent();
    let harmonic = |a| -> Result<SparseColMat<usize, c64>, SectorModesError> {
        let t = map.harmonic_triplets(a, k)?;
        Ok(SparseColMat::try_new_from_triplets(n, n, &t)
            .map_err(|e| CyclicError::Sparse(format!("{e:?}")))?)
    };
    let (kk, mm) = (harmonic(stiffness)?, harmonic(mass)?);
    let eigen = |source| SectorModesError::Eigen { k, source };
    let factor = CholeskyFactor::new(&kk, faer::Par::Seq).map_err(eigen)?;
    let pencil = Pencil {
        stiffness: &kk,
        mass: &mm,
        factor: &factor,
    };
    let start = faer::Mat::<c64>::zeros(n, 0);
    let opts = SparseEigenOptions {
        tolerance: TOLERANCE,
        par: faer::Par::Seq,
    };
    let pairs = lowest_eigenpairs(&pencil, n_modes.min(n), start.as_ref(), &opts).map_err(eigen)?;
    Ok(pairs.values.into_iter().map(signed_hz).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::build::{CasingSpec, ImpellerSpec, Prestress, build_casing, build_impeller};
    use crate::model::mesh::CasingGeometry;
    use crate::model::mesh::ImpellerGeometry;

    /// Sixty modes on every nodal diameter of the default casing sector (λ₆₀/λ₁ ≈ 80 on
    /// nodal diameter 0, where shift-invert at 0 alone stopped at 59 of 60 above the
    /// tolerance), each to the residual [`TOLERANCE`]. None is missed or spurious on nodal
    /// diameter 0: by Sylvester's law of inertia, `K − σ M` has exactly `j` negative
    /// eigenvalues for `σ` between the j-th and (j+1)-th returned eigenvalues (a dense
    /// Hermitian eigensolve of `K − σ M`, independent of the sparse solver).
    #[test]
    fn sixty_modes_per_diameter_on_the_default_casing_meet_the_tolerance() {
        let mesh = CasingGeometry::default().build().unwrap();
        let modes = 60;
        let sparse = unreduced_frequencies(&mesh, modes, 0.0, Tangent::StressStiffening).unwrap();
        assert!(sparse.iter().all(|f| f.len() == modes));
        let mats = assemble_sector(&mesh, false).unwrap();
        let map = CyclicDofMap::new(&SectorTopology::of(&mesh), &[]).unwrap();
        let n = map.n_independent();
        let dense = |a| {
            let t = map.harmonic_triplets(a, 0).unwrap();
            SparseColMat::<usize, c64>::try_new_from_triplets(n, n, &t)
                .unwrap()
                .to_dense()
        };
        let (k, m) = (dense(&mats.stiffness), dense(&mats.mass));
        let lambda: Vec<f64> = sparse[0]
            .iter()
            .map(|f| (2.0 * std::f64::consts::PI * f).powi(2))
            .collect();
        for j in 1..modes {
            let sigma = 0.5 * (lambda[j - 1] + lambda[j]);
            let shifted = &k - faer::Scale(c64::new(sigma, 0.0)) * &m;
            let below = shifted
                .self_adjoint_eigenvalues(faer::Side::Lower)
                .unwrap()
                .iter()
                .filter(|&&e| e < 0.0)
                .count();
            assert_eq!(below, j, "eigenvalues below {sigma:e} rad²/s²");
        }
    }

    /// The ROM is a Rayleigh–Ritz approximation of this model: its frequencies bound the
    /// unreduced ones from above, and converge to them as fixed-interface modes are added.
    #[test]
    fn the_rom_bounds_the_unreduced_frequencies_from_above() {
        let geometry = CasingGeometry {
            n_sectors: 8,
            ..CasingGeometry::default()
        };
        let exact = unreduced_frequencies(
            &geometry.build().unwrap(),
            5,
            0.0,
            Tangent::StressStiffening,
        )
        .unwrap();
        assert_eq!(exact.len(), 5);
        let mut errors = Vec::new();
        for modes in [10, 40] {
            let rom = build_casing(&CasingSpec {
                geometry: geometry.clone(),
                modes_per_diameter: modes,
                ..CasingSpec::default()
            })
            .unwrap();
            let mut worst: f64 = 0.0;
            for (k, fe) in exact.iter().enumerate() {
                let red = &rom.modal_data[k].frequencies[0];
                for (p, (a, b)) in red.iter().zip(fe).enumerate() {
                    assert!(*a >= b * (1.0 - 1e-9), "k = {k} mode {p}: ROM {a} < FE {b}");
                    worst = worst.max((a - b) / b);
                }
            }
            errors.push(worst);
        }
        println!("casing N = 8, worst ROM/FE difference with 10 and 40 modes per ND: {errors:?}");
        assert!(errors[1] < errors[0]);
    }

    /// The consistent prestress's ROM (basis enriched at the grid's top speed) against the
    /// unreduced sector with the same tangent, at that speed and halfway to it: within 1e-3 on
    /// the first 3 modes of every nodal diameter. The stress-stiffening ROM has no enrichment
    /// and is unchanged by the option (its spec and ids do not mention it).
    #[test]
    fn the_consistent_prestress_rom_follows_its_unreduced_model_at_speed() {
        let geometry = ImpellerGeometry {
            n_blades: 4,
            ..ImpellerGeometry::default()
        };
        let spec = ImpellerSpec {
            geometry: geometry.clone(),
            modes_per_diameter: 10,
            omega_grid_rad_s: vec![0.0, 3500.0, 7000.0],
            prestress: Prestress::Consistent,
            ..ImpellerSpec::default()
        };
        let rom = build_impeller(&spec).unwrap();
        let mesh = geometry.build().unwrap();
        for (grid, omega) in [(1, 3500.0), (2, 7000.0)] {
            let exact =
                unreduced_frequencies(&mesh, 3, omega, Tangent::WithInitialDisplacement).unwrap();
            let mut worst = 0.0f64;
            for (m, e) in rom.modal_data.iter().zip(&exact) {
                for (r, x) in m.frequencies[grid].iter().zip(e) {
                    worst = worst.max((r - x).abs() / x);
                }
            }
            println!("consistent ROM at {omega} rad/s: worst relative difference {worst:.2e}");
            assert!(worst < 1e-3, "{omega} rad/s: {worst:e}");
        }
        let plain = serde_json::to_value(ImpellerSpec::default()).unwrap();
        assert!(plain.get("prestress").is_none());
    }
}
