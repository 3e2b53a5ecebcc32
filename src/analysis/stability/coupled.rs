//! The time-invariant eigenproblem of one impeller class ν in the rotating frame.
//!
//! Coordinates: the modal coordinates `η_p` of the impeller block ν and of every casing
//! harmonic `k ≡ ν (mod N_b)`, casing ones scaled by `1/√ρ` (`ρ = N_c/N_b`) so that the
//! coupled operator is Hermitian for μ = 0 without damping. A mode of shift `δ_p` (`kΩ` for
//! the casing, 0 for the impeller) obeys, for solutions `e^{λt}`,
//!
//! `[(λ − iδ)² + c (λ − iδ) + ω²] η_p + Σ_j conj(F_jp) N_j = 0`,
//!
//! and the held rows close the system: `G η − R N = N / k_c` (`R` the residual flexibility of
//! the condensed modes, `k_c = ∞` for the bilateral constraint). With `S = (R + I/k_c)⁻¹`:
//! `λ² η + λ (C − 2iΔ) η + (W² − Δ² − iΔC + Fᴴ S G) η = 0`, solved as a standard eigenproblem of
//! the first-order form `[η; λη]`. With nothing condensed and `k_c = ∞` (`S` undefined), the
//! constraint `G η = 0` is imposed by `η = Z p` (`G Z = 0`) and the equations are projected on
//! `W` (`F W = 0`, which removes the unknown `N`).

use super::modes::{BlockModes, ContactRows, casing_rows, impeller_rows};
use super::{ContactModel, CoupledWave, Predictor, StabilityError, hz};
use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{ComputeEigenvectors, evd_cplx, evd_scratch};
use faer::linalg::solvers::DenseSolveCore;
use faer::prelude::Solve;
use faer::{Mat, MatRef, Par, c64};
use std::f64::consts::TAU;

/// One eigenvalue of a class with the casing harmonic that dominates its eigenvector.
#[derive(Clone, Copy, Debug)]
pub(super) struct RawWave {
    /// Rotating-frame eigenvalue λ (1/s).
    pub lambda: c64,
    /// Signed casing harmonic with the largest share of the casing energy.
    pub casing_k: i64,
    /// Fraction of the modal energy in the casing.
    pub casing_share: f64,
}

impl RawWave {
    /// The wave as reported at speed `omega` (rad/s), `impeller_nd` its impeller diameter.
    pub fn describe(&self, omega: f64, impeller_nd: usize) -> CoupledWave {
        let k = self.casing_k as f64;
        // Fixed-frame casing field e^{i(kφ + ω_f t)}: phase speed −ω_f/k.
        let w_fixed = self.lambda.im - k * omega;
        CoupledWave {
            nodal_diameter: self.casing_k.unsigned_abs() as usize,
            impeller_nodal_diameter: impeller_nd,
            growth_rate_per_s: self.lambda.re,
            frequency_hz: hz(w_fixed.abs()),
            rotating_frequency_hz: hz(self.lambda.im.abs()),
            backward: k * w_fixed > 0.0,
            backward_in_rotating_frame: k * self.lambda.im > 0.0,
            casing_share: self.casing_share,
            quasi_static: self.lambda.im.abs() <= self.lambda.re.abs(),
        }
    }
}

/// Every eigenvalue of one class.
pub(super) struct ClassSolution {
    pub waves: Vec<RawWave>,
}

/// The retained modes of a class: per mode its frequency, damping, shift and owner (`None`:
/// the impeller, `Some(k)`: casing harmonic k), and its contact rows; and the residual
/// flexibility of the condensed ones.
struct Retained {
    omega: Vec<f64>,
    damping: Vec<f64>,
    shift: Vec<f64>,
    owner: Vec<Option<i64>>,
    gap: Vec<Vec<c64>>,
    force: Vec<Vec<c64>>,
    residual: Mat<c64>,
    condensed: usize,
}

/// The signed casing harmonics of class `class`: `k ≡ class (mod N_b)`, `2|k| < N_c`.
pub(super) fn class_harmonics(class: usize, n_blades: usize, n_casing: usize) -> Vec<i64> {
    let kmax = ((n_casing - 1) / 2) as i64;
    (-kmax..=kmax)
        .filter(|k| k.rem_euclid(n_blades as i64) == class as i64)
        .collect()
}

/// Splits the modes of the class's blocks into retained and condensed ones.
fn split_modes(
    pred: &Predictor<'_>,
    blocks: &[(Option<i64>, &BlockModes, ContactRows)],
    omega: f64,
) -> Retained {
    let m = pred.iface.rows.len();
    let cut = pred.opts.mode_cutoff_hz.map(|f| TAU * f);
    let mut r = Retained {
        omega: vec![],
        damping: vec![],
        shift: vec![],
        owner: vec![],
        gap: vec![],
        force: vec![],
        residual: Mat::zeros(m, m),
        condensed: 0,
    };
    for (owner, modes, rows) in blocks {
        let delta = owner.map_or(0.0, |k| k as f64 * omega);
        for p in 0..modes.omega.len() {
            let (w, c) = (modes.omega[p], modes.damping[p]);
            let gap: Vec<c64> = (0..m).map(|j| rows.gap[(j, p)]).collect();
            let force: Vec<c64> = (0..m).map(|j| rows.force[(j, p)]).collect();
            let in_band = cut.is_none_or(|cut| (delta + w).abs().min((delta - w).abs()) <= cut);
            if in_band {
                r.omega.push(w);
                r.damping.push(c);
                r.shift.push(delta);
                r.owner.push(*owner);
                r.gap.push(gap);
                r.force.push(force);
            } else {
                // Quasi-static in the rotating frame: η = −Σ conj(F) N / κ at λ = 0.
                let kappa = c64::new(w * w - delta * delta, -c * delta);
                for (j, g) in gap.iter().enumerate() {
                    for (l, f) in force.iter().enumerate() {
                        r.residual[(j, l)] += g * f.conj() / kappa;
                    }
                }
                r.condensed += 1;
            }
        }
    }
    r
}

/// Solves class `class` at `omega` (rad/s); `imp` are the impeller block's modes,
/// `conjugate` whether the class is the negative impeller harmonic.
pub(super) fn solve_class(
    pred: &Predictor<'_>,
    imp: &BlockModes,
    conjugate: bool,
    omega: f64,
    class: usize,
) -> Result<ClassSolution, StabilityError> {
    let n_b = pred.impeller.n_sectors;
    let scale = (n_b as f64 / pred.n_casing as f64).sqrt();
    let mut blocks = vec![(None, imp, impeller_rows(&pred.iface, imp, conjugate))];
    for k in class_harmonics(class, n_b, pred.n_casing) {
        let modes = &pred.casing_modes[k.unsigned_abs() as usize];
        blocks.push((Some(k), modes, casing_rows(&pred.iface, modes, k, scale)));
    }
    if omega == 0.0 {
        // No sliding, no friction direction: the force acts along the normal only.
        for (_, _, rows) in &mut blocks {
            rows.force = rows.gap.clone();
        }
    }
    let ret = split_modes(pred, &blocks, omega);
    let fail = |reason: String| StabilityError::Solve {
        class,
        omega,
        reason,
    };
    let spring = match pred.opts.contact {
        ContactModel::Bilateral => None,
        ContactModel::Spring { stiffness_n_per_m } => Some(stiffness_n_per_m),
    };
    let m = pred.iface.rows.len();
    let (state, coords) = if m > 0 && ret.condensed == 0 && spring.is_none() {
        constrained_state(&ret).map_err(fail)?
    } else {
        let mut compliance = ret.residual.clone();
        for j in 0..m {
            compliance[(j, j)] += spring.map_or(0.0, |k| 1.0 / k);
        }
        (
            compliant_state(&ret, compliance.as_ref()).map_err(fail)?,
            None,
        )
    };
    let (values, vectors) = eigen(state.as_ref()).map_err(fail)?;
    let n = ret.omega.len();
    let waves = (0..values.len())
        .map(|i| {
            let x = vectors.col(i);
            let eta: Vec<c64> = match &coords {
                None => (0..n).map(|p| x[p]).collect(),
                Some(z) => {
                    let half = z.ncols();
                    (0..n)
                        .map(|p| (0..half).map(|q| z[(p, q)] * x[q]).sum())
                        .collect()
                }
            };
            classify(&ret, values[i], &eta, class, n_b, pred.n_casing)
        })
        .collect();
    Ok(ClassSolution { waves })
}

/// The diagonal modal stiffness `ω² − δ² − iδc` and damping `c − 2iδ` of the retained modes.
fn modal_diagonals(r: &Retained) -> (Vec<c64>, Vec<c64>) {
    (0..r.omega.len())
        .map(|p| {
            let (w, c, d) = (r.omega[p], r.damping[p], r.shift[p]);
            (c64::new(w * w - d * d, -d * c), c64::new(c, -2.0 * d))
        })
        .unzip()
}

/// The first-order form of `λ² η + λ C η + K η = 0` (`K`, `C` n × n) on `[η; λη/s]`:
/// `[[0, s I], [−K/s, −C]]`, with `s = √max|K_ii|` a frequency scale that balances the two
/// halves (unscaled, the eigenvalues of the undamped waves lose about `|λ|` times round-off).
/// The eigenvalues are those of `[[0, I], [−K, −C]]`, the first half of each eigenvector is `η`.
fn first_order(k: MatRef<'_, c64>, c: MatRef<'_, c64>) -> Mat<c64> {
    let n = k.nrows();
    let kmax = (0..n).map(|i| k[(i, i)].norm()).fold(0.0, f64::max);
    let s = if kmax > 0.0 { kmax.sqrt() } else { 1.0 };
    let mut a = Mat::zeros(2 * n, 2 * n);
    for i in 0..n {
        a[(i, n + i)] = c64::new(s, 0.0);
        for j in 0..n {
            a[(n + i, j)] = -k[(i, j)] / s;
            a[(n + i, n + j)] = -c[(i, j)];
        }
    }
    a
}

/// The first-order matrix with the contact as a compliance `R + I/k_c` (invertible).
fn compliant_state(r: &Retained, compliance: MatRef<'_, c64>) -> Result<Mat<c64>, String> {
    let (m, n) = (compliance.nrows(), r.omega.len());
    let (kd, cd) = modal_diagonals(r);
    let mut k = Mat::from_fn(n, n, |i, j| if i == j { kd[i] } else { c64::new(0.0, 0.0) });
    let c = Mat::from_fn(n, n, |i, j| if i == j { cd[i] } else { c64::new(0.0, 0.0) });
    if m > 0 {
        let g = Mat::from_fn(m, n, |j, p| r.gap[p][j]);
        let f = Mat::from_fn(m, n, |j, p| r.force[p][j]);
        let lu = compliance.partial_piv_lu();
        let s_g = lu.solve(&g);
        let cond = compliance.norm_l2() * lu.inverse().norm_l2();
        if !(cond.is_finite() && cond < 1e13) {
            return Err(format!(
                "the contact compliance is singular (condition {cond:.2e}): condense more modes \
                 (a lower mode cutoff) or use a finite contact stiffness"
            ));
        }
        k += f.adjoint() * s_g;
    }
    Ok(first_order(k.as_ref(), c.as_ref()))
}

/// Orthonormal basis (columns) of the null space of `a` (m × n, full row rank).
fn null_space(a: MatRef<'_, c64>) -> Result<Mat<c64>, String> {
    let (m, n) = (a.nrows(), a.ncols());
    let qr = a.adjoint().qr();
    let r = qr.R();
    let scale = (0..m).map(|i| r[(i, i)].norm()).fold(0.0, f64::max);
    if scale == 0.0 || (0..m).any(|i| r[(i, i)].norm() <= 1e-12 * scale) {
        return Err("the held rows are linearly dependent".into());
    }
    let q = qr.compute_Q();
    Ok(q.subcols(m, n - m).to_owned())
}

/// The first-order matrix with the bilateral constraint imposed exactly on all modes, and the
/// basis `Z` that maps its coordinates back to the modal ones.
fn constrained_state(r: &Retained) -> Result<(Mat<c64>, Option<Mat<c64>>), String> {
    let (m, n) = (r.gap[0].len(), r.omega.len());
    let g = Mat::from_fn(m, n, |j, p| r.gap[p][j]);
    let f = Mat::from_fn(m, n, |j, p| r.force[p][j]);
    let z = null_space(g.as_ref())?;
    let w = null_space(f.as_ref())?;
    let (kd, cd) = modal_diagonals(r);
    let scaled = |d: &[c64]| Mat::from_fn(n, z.ncols(), |i, j| d[i] * z[(i, j)]);
    let wh = w.adjoint();
    let mass = wh * &z;
    let lu = mass.partial_piv_lu();
    let k = lu.solve(wh * scaled(&kd));
    let c = lu.solve(wh * scaled(&cd));
    if !(k.norm_l2().is_finite() && c.norm_l2().is_finite()) {
        return Err("the projected mass Wᴴ Z is singular".into());
    }
    Ok((first_order(k.as_ref(), c.as_ref()), Some(z)))
}

/// Eigenvalues and right eigenvectors of `a` (sequential: the scans parallelise over speeds).
fn eigen(a: MatRef<'_, c64>) -> Result<(Vec<c64>, Mat<c64>), String> {
    let n = a.nrows();
    let mut s = Diag::<c64>::zeros(n);
    let mut u = Mat::<c64>::zeros(n, n);
    let scratch = evd_scratch::<c64>(
        n,
        ComputeEigenvectors::No,
        ComputeEigenvectors::Yes,
        Par::Seq,
        Default::default(),
    );
    evd_cplx(
        a,
        s.as_mut(),
        None,
        Some(u.as_mut()),
        Par::Seq,
        MemStack::new(&mut MemBuffer::new(scratch)),
        Default::default(),
    )
    .map_err(|e| format!("eigenvalue iteration failed ({e:?})"))?;
    Ok(((0..n).map(|i| s[i]).collect(), u))
}

/// The dominant casing harmonic and casing share of eigenvector `eta` (modal coordinates) of
/// eigenvalue `lambda`: modal energy `|η|² (ω² + |λ − iδ|²)` in each block's own frame.
fn classify(
    r: &Retained,
    lambda: c64,
    eta: &[c64],
    class: usize,
    n_b: usize,
    n_c: usize,
) -> RawWave {
    let harmonics = class_harmonics(class, n_b, n_c);
    let mut casing = vec![0.0; harmonics.len()];
    let mut total = 0.0;
    for (p, e) in eta.iter().enumerate() {
        let own = lambda - c64::new(0.0, r.shift[p]);
        let energy = e.norm_sqr() * (r.omega[p] * r.omega[p] + own.norm_sqr());
        total += energy;
        if let Some(k) = r.owner[p]
            && let Some(i) = harmonics.iter().position(|&h| h == k)
        {
            casing[i] += energy;
        }
    }
    let casing_total: f64 = casing.iter().sum();
    let lowest = || {
        *harmonics
            .iter()
            .min_by_key(|k| (k.abs(), -k.signum()))
            .unwrap_or(&0)
    };
    let casing_k = if casing_total > 0.0 {
        let i = (0..casing.len())
            .max_by(|&a, &b| casing[a].total_cmp(&casing[b]))
            .unwrap_or(0);
        harmonics[i]
    } else {
        lowest()
    };
    RawWave {
        lambda,
        casing_k,
        casing_share: if total > 0.0 {
            casing_total / total
        } else {
            0.0
        },
    }
}
