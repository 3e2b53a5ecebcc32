//! Test and benchmark fixtures (not part of the library's API, hidden from its documentation;
//! compiled in every build, so that the unit tests need no second build of the library to wait
//! for): synthetic cyclic Craig–Bampton ROMs with realistic sizes and spectra, and the
//! deterministic generator [`Lcg`] behind them and behind the randomised unit tests.
//!
//! A **test and benchmark fixture** (not a physical model): it lets the dynamics be tested and
//! timed before the finite-element pipeline delivers real ROMs. Per sector: `n_c` contact nodes
//! (3 boundary DOFs each, lumped mass `m_b`, springs to ground and to the neighbouring
//! sectors' nodes through a non-symmetric coupling that yields genuinely complex (Hermitian)
//! harmonic blocks) and `n_m` fixed-interface modes with unit modal mass, frequencies spread
//! geometrically over `[f_low, f_high]` and stiffening with the nodal diameter, inertially coupled
//! to the boundary. An impeller gets a centrifugal term `K1` (stiffening per (rad/s)²).

use crate::model::rom::{
    Component, ContactNode, CyclicRom, Damping, HarmonicBlock, HermitianMatrix,
};
use nalgebra::DMatrix;
use std::f64::consts::PI;

/// Parameters of a synthetic ROM.
#[derive(Clone, Debug)]
pub struct SyntheticSpec {
    /// Impeller (rotating frame) or casing (fixed frame).
    pub component: Component,
    /// Number of sectors N (casing) or blades N_b (impeller).
    pub n_sectors: usize,
    /// Contact nodes per sector, ordered leading → trailing edge.
    pub n_contact: usize,
    /// Fixed-interface modes per nodal diameter.
    pub n_modes: usize,
    /// Lumped mass per boundary DOF (kg).
    pub boundary_mass: f64,
    /// Boundary spring scale (N/m).
    pub boundary_stiffness: f64,
    /// Lowest fixed-interface modal frequency at k = 0 (Hz).
    pub f_low: f64,
    /// Highest fixed-interface modal frequency at k = 0 (Hz).
    pub f_high: f64,

    /// Radius of the contact surface (m): casing nodes sit on it, blade tips inside it.
    pub radius: f64,
    /// Axial length of the contact line (m).
    pub length: f64,
    /// Radial clearance of blade tips below `radius` (m), impeller only.
    pub clearance: f64,
    /// Damping model.
    pub damping: Damping,
}

impl SyntheticSpec {
    /// A small model for tests: N sectors, n_c contact nodes, n_m modes per ND.
    pub fn small(component: Component, n_sectors: usize, n_contact: usize, n_modes: usize) -> Self {
        Self {
            component,
            n_sectors,
            n_contact,
            n_modes,
            boundary_mass: 0.05,
            boundary_stiffness: 2e8,
            f_low: if component == Component::Casing {
                300.0
            } else {
                500.0
            },
            f_high: if component == Component::Casing {
                8e3
            } else {
                1.2e4
            },
            radius: 0.2,
            length: 0.04,
            clearance: 1e-4,
            damping: Damping::Modal { ratio: 0.0 },
        }
    }

    /// The paper-scale casing (N = 100, M = 5, 10 modes per ND).
    pub fn paper_casing() -> Self {
        Self {
            damping: Damping::Modal { ratio: 0.005 },
            ..Self::small(Component::Casing, 100, 5, 10)
        }
    }

    /// The paper-scale impeller (N_b = 10, 5 tip nodes, 10 modes per ND).
    pub fn paper_impeller() -> Self {
        Self {
            damping: Damping::Modal { ratio: 0.005 },
            ..Self::small(Component::Impeller, 10, 5, 10)
        }
    }
}

/// Deterministic pseudo-random numbers in [−1, 1) (fixtures and tests: no rand crate).
pub(crate) struct Lcg(pub(crate) u64);
impl Lcg {
    pub(crate) fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// Builds a synthetic cyclic ROM (see the module doc); always passes `CyclicRom::validate`.
pub fn synthetic_rom(spec: &SyntheticSpec) -> CyclicRom {
    let ns = spec.n_sectors.max(1);
    let nc = spec.n_contact;
    let nb = 3 * nc;
    let nm = spec.n_modes;
    let n = nb + nm;
    let kmax = ns / 2;
    let alpha = 2.0 * PI / ns as f64;
    let mut rng = Lcg(match spec.component {
        Component::Casing => 17,
        Component::Impeller => 29,
    });
    let kb = spec.boundary_stiffness;
    // Sector self stiffness: ground springs (stiffer radially) + springs along the tip line.
    let mut kself = DMatrix::<f64>::zeros(nb, nb);
    for j in 0..nc {
        for d in 0..3 {
            kself[(3 * j + d, 3 * j + d)] = kb * [3.0, 2.0, 2.5][d];
        }
        if j + 1 < nc {
            for d in 0..3 {
                let (a, b) = (3 * j + d, 3 * (j + 1) + d);
                kself[(a, a)] += 0.5 * kb;
                kself[(b, b)] += 0.5 * kb;
                kself[(a, b)] -= 0.5 * kb;
                kself[(b, a)] -= 0.5 * kb;
            }
        }
    }
    // Coupling to the next sector (non-symmetric: gives complex harmonic blocks), ‖C‖ ≤ 0.6 kb.
    let mut coup = DMatrix::<f64>::zeros(nb, nb);
    for i in 0..nb {
        coup[(i, i)] = -0.4 * kb;
        for j in 0..nb {
            coup[(i, j)] += 0.2 * kb * rng.next() / nb as f64;
        }
    }
    // Inertial coupling boundary ↔ modes, small enough to keep M positive definite.
    let mut e = DMatrix::<f64>::zeros(nb, nm);
    for v in e.iter_mut() {
        *v = rng.next();
    }
    let fro = e.norm().max(1e-300);
    e *= 0.3 * spec.boundary_mass.sqrt() / fro;
    let harmonics = (0..=kmax)
        .map(|k| {
            let real = k == 0 || 2 * k == ns;
            let phi = k as f64 * alpha;
            let (mut kre, mut kim) = (DMatrix::zeros(n, n), DMatrix::zeros(n, n));
            let cs = &coup + coup.transpose();
            let ca = &coup - coup.transpose();
            let kbb = &kself + cs * phi.cos();
            kre.view_mut((0, 0), (nb, nb)).copy_from(&kbb);
            if !real {
                kim.view_mut((0, 0), (nb, nb)).copy_from(&(ca * phi.sin()));
            }
            let mut k1 = DMatrix::zeros(n, n);
            let kk = if kmax > 0 {
                k as f64 / kmax as f64
            } else {
                0.0
            };
            for m in 0..nm {
                let t = if nm > 1 {
                    m as f64 / (nm - 1) as f64
                } else {
                    0.0
                };
                let f = spec.f_low * (spec.f_high / spec.f_low).powf(t) * (1.0 + 0.5 * kk * kk);
                let w2 = (2.0 * PI * f).powi(2);
                kre[(nb + m, nb + m)] = w2;
                if spec.component == Component::Impeller {
                    // Centrifugal stiffening: +10 % of ω² at 1000 rad/s.
                    k1[(nb + m, nb + m)] = 0.1 * w2 / 1e6;
                }
            }
            let mut mre = DMatrix::<f64>::identity(n, n);
            for i in 0..nb {
                mre[(i, i)] = spec.boundary_mass;
            }
            mre.view_mut((0, nb), (nb, nm)).copy_from(&e);
            mre.view_mut((nb, 0), (nm, nb)).copy_from(&e.transpose());
            HarmonicBlock {
                nodal_diameter: k,
                n_modes: nm,
                mass: HermitianMatrix::real(mre),
                stiffness: [
                    HermitianMatrix { re: kre, im: kim },
                    HermitianMatrix::real(k1),
                    HermitianMatrix::real(DMatrix::zeros(n, n)),
                ],
            }
        })
        .collect();
    let contact_nodes = (0..nc)
        .map(|j| {
            let z = if nc > 1 {
                spec.length * j as f64 / (nc - 1) as f64
            } else {
                0.0
            };
            let r = match spec.component {
                Component::Casing => spec.radius,
                Component::Impeller => spec.radius - spec.clearance,
            };
            ContactNode {
                position: [r, 0.0, z],
                row: j,
                id: None,
            }
        })
        .collect();
    CyclicRom {
        name: format!("synthetic-{:?}-N{}-nc{}-nm{}", spec.component, ns, nc, nm).to_lowercase(),
        component: spec.component,
        n_sectors: ns,
        contact_nodes,
        harmonics,
        modal_data: vec![],
        damping: spec.damping,
        provenance: serde_json::json!({"synthetic": true}),
        recovery: Default::default(),
        blade_modes: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_roms_validate_at_paper_scale_and_small() {
        for spec in [
            SyntheticSpec::paper_casing(),
            SyntheticSpec::paper_impeller(),
            SyntheticSpec::small(Component::Casing, 8, 3, 2),
            SyntheticSpec::small(Component::Impeller, 4, 2, 2),
            SyntheticSpec::small(Component::Impeller, 5, 2, 2),
        ] {
            let rom = synthetic_rom(&spec);
            assert_eq!(rom.validate(), Ok(()), "{}", rom.name);
        }
        let rom = synthetic_rom(&SyntheticSpec::paper_casing());
        assert_eq!(rom.n_dofs(), 100 * 15 + 10 * 100);
        // Complex harmonics really are complex.
        assert!(rom.harmonics[3].stiffness[0].im.amax() > 0.0);
    }
}
