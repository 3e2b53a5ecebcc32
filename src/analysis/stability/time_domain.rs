//! The second formulation (tests only): the same linearised rub written in the FIXED frame on
//! the assembled physical ROMs, where the coupling is time-periodic (each tip sweeps the casing
//! sectors once per revolution), and its Floquet exponents from the monodromy matrix of one
//! revolution integrated in time (classical RK4).
//!
//! Nothing here uses the harmonic blocks, the rotating-frame shift, the aliasing classes or
//! the modal condensation of the prediction: the impeller's and the casing's physical matrices
//! come from [`Structure::assemble_physical`], the tips sit at their fixed-frame angles
//! `Ωt + 2πs/N_b + φ_j`, and the casing displacement under a tip is the trigonometric
//! interpolation of its sector nodes, `(1/N) Σ_{|k| ≤ (N−1)/2} e^{ik(φ − θ_s − ψ_r)}` (odd N, so
//! that it is real and has no Nyquist term). The contact is a spring `N = k_c g`. Its growth
//! rates `ln|μ|/T` must equal the predicted `Re λ` of the spring model with every mode kept.

use super::StabilityOptions;
use super::interface::Interface;
use crate::dynamics::structure::Structure;
use crate::model::rom::CyclicRom;
use nalgebra::{DMatrix, DVector};
use std::f64::consts::TAU;

/// The fixed-frame system: physical matrices of both structures side by side, and the contact
/// rows at any time.
pub(super) struct FixedFrame {
    m_inv: DMatrix<f64>,
    k: DMatrix<f64>,
    d: DMatrix<f64>,
    n_imp: usize,
    n_blades: usize,
    nb_imp: usize,
    n_casing: usize,
    nb_cas: usize,
    omega: f64,
    stiffness: f64,
    iface: Interface,
}

/// The real trigonometric interpolation kernel of an odd `n`-sector ring at angle `x` (rad).
fn kernel(n: usize, x: f64) -> f64 {
    let kmax = (n - 1) / 2;
    (1.0 + 2.0 * (1..=kmax).map(|k| (k as f64 * x).cos()).sum::<f64>()) / n as f64
}

impl FixedFrame {
    /// The system at speed `omega` (rad/s) with contact stiffness `stiffness` (N/m).
    pub fn new(
        imp: &CyclicRom,
        cas: &CyclicRom,
        omega: f64,
        stiffness: f64,
        opts: &StabilityOptions,
    ) -> Self {
        assert!(
            cas.n_sectors % 2 == 1,
            "the interpolation needs an odd casing"
        );
        let (mi, ki, di) = Structure::new(imp, omega).unwrap().assemble_physical();
        let (mc, kc, dc) = Structure::new(cas, 0.0).unwrap().assemble_physical();
        let (ni, nc) = (mi.nrows(), mc.nrows());
        let block = |a: &DMatrix<f64>, b: &DMatrix<f64>| {
            let mut out = DMatrix::zeros(ni + nc, ni + nc);
            out.view_mut((0, 0), (ni, ni)).copy_from(a);
            out.view_mut((ni, ni), (nc, nc)).copy_from(b);
            out
        };
        Self {
            m_inv: block(&mi, &mc).try_inverse().unwrap(),
            k: block(&ki, &kc),
            d: block(&di, &dc),
            n_imp: ni,
            n_blades: imp.n_sectors,
            nb_imp: imp.n_boundary(),
            n_casing: cas.n_sectors,
            nb_cas: cas.n_boundary(),
            omega,
            stiffness,
            iface: Interface::new(imp, cas, opts).unwrap(),
        }
    }

    /// Gap rows `G(t)` and force rows `F(t)` (one per blade and held row): the penetration is
    /// `G x`, the generalized contact force `−Fᵀ N`.
    fn contact_rows(&self, t: f64) -> (DMatrix<f64>, DMatrix<f64>) {
        let n = self.k.nrows();
        let rows = self.n_blades * self.iface.rows.len();
        let (mut g, mut f) = (DMatrix::zeros(rows, n), DMatrix::zeros(rows, n));
        for s in 0..self.n_blades {
            let blade_angle = self.omega * t + TAU * s as f64 / self.n_blades as f64;
            for (j, row) in self.iface.rows.iter().enumerate() {
                let i = s * self.iface.rows.len() + j;
                for a in 0..3 {
                    let dof = s * self.nb_imp + 3 * row.tip_node + a;
                    g[(i, dof)] += row.tip_normal[a];
                    f[(i, dof)] += row.tip_force[a];
                }
                for term in &row.casing {
                    for sc in 0..self.n_casing {
                        let theta = TAU * sc as f64 / self.n_casing as f64;
                        let x = blade_angle + term.angle_offset - theta;
                        let w = term.weight * kernel(self.n_casing, x);
                        for a in 0..3 {
                            let dof = self.n_imp + sc * self.nb_cas + 3 * term.node + a;
                            g[(i, dof)] -= w * term.normal[a];
                            f[(i, dof)] -= w * term.force[a];
                        }
                    }
                }
            }
        }
        (g, f)
    }

    /// First-order matrix `[[0, I], [−M⁻¹(K + k_c Fᵀ G), −M⁻¹ D]]` at time `t` (s).
    fn state_matrix(&self, t: f64) -> DMatrix<f64> {
        let n = self.k.nrows();
        let (g, f) = self.contact_rows(t);
        let stiff = &self.k + f.transpose() * g * self.stiffness;
        let mut a = DMatrix::zeros(2 * n, 2 * n);
        a.view_mut((0, n), (n, n)).fill_with_identity();
        a.view_mut((n, 0), (n, n))
            .copy_from(&(-(&self.m_inv * stiff)));
        a.view_mut((n, n), (n, n))
            .copy_from(&(-(&self.m_inv * &self.d)));
        a
    }

    /// Floquet growth rates `ln|μ_i|/T` (1/s) of one revolution `T = 2π/Ω`, integrated with
    /// `steps` RK4 steps, sorted descending.
    pub fn floquet_growth_rates(&self, steps: usize) -> Vec<f64> {
        let period = TAU / self.omega;
        let h = period / steps as f64;
        let n2 = 2 * self.k.nrows();
        let mut y = DMatrix::<f64>::identity(n2, n2);
        for i in 0..steps {
            let t = i as f64 * h;
            let (a0, a1, a2) = (
                self.state_matrix(t),
                self.state_matrix(t + 0.5 * h),
                self.state_matrix(t + h),
            );
            let k1 = &a0 * &y;
            let k2 = &a1 * (&y + &k1 * (0.5 * h));
            let k3 = &a1 * (&y + &k2 * (0.5 * h));
            let k4 = &a2 * (&y + &k3 * h);
            y += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
        }
        let eig = y.complex_eigenvalues();
        let mut rates: Vec<f64> = eig.iter().map(|m| m.norm().ln() / period).collect();
        rates.sort_by(|a, b| b.total_cmp(a));
        rates
    }

    /// Largest natural frequency (rad/s) of the coupled system frozen at `t = 0`, to size the
    /// time step.
    pub fn max_frequency(&self) -> f64 {
        let a = self.state_matrix(0.0);
        let e: DVector<_> = a.complex_eigenvalues();
        e.iter().map(|z| z.norm()).fold(0.0, f64::max)
    }
}
