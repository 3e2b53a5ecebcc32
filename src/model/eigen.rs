//! The dense generalized eigensolver of every caller: all eigenpairs of a Hermitian-definite
//! pencil `K x = λ M x` by the Cholesky route (`M = L Lᴴ`, `C = L⁻¹ K L⁻ᴴ`, `C = U S Uᴴ`,
//! `X = L⁻ᴴ U`), eigenvalues ascending and eigenvectors mass-normalized (`Xᴴ M X = I`).
//! The reductions use it on complex harmonic blocks, the time integrator and the component
//! reduction on real (nalgebra) matrices.

use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::traits::ComplexField;
use faer::traits::math_utils::{add, conj, mul_real, real};
use faer::{Mat, MatRef, Par, Side, c64};
use nalgebra::DMatrix;

/// Why the pencil has no Cholesky-route eigendecomposition.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EigenError {
    /// `M` is not positive definite.
    #[error("mass matrix not positive definite (Cholesky failed)")]
    MassNotDefinite,
    /// The eigenvalue iteration of the reduced problem did not converge.
    #[error("eigenvalue iteration did not converge")]
    NoConvergence,
    /// Eigenvectors of a double eigenvalue of a complex block's real form that do not pair
    /// into the two phases `(x, J x)` of one complex mode.
    #[error("eigenvectors {start}..{end} of the real form do not pair into J-partners")]
    NotPaired {
        /// First index of the cluster of equal eigenvalues.
        start: usize,
        /// One past its last index.
        end: usize,
    },
}

/// All eigenpairs of `K x = λ M x` (complex Hermitian blocks). With `real`, the imaginary parts
/// are ignored and the eigenvectors are real (a complex solver would return them with arbitrary
/// phases).
pub(crate) fn dense_gen_eigen(
    k: MatRef<'_, c64>,
    m: MatRef<'_, c64>,
    real: bool,
) -> Result<(Vec<f64>, Mat<c64>), EigenError> {
    if real {
        let kr = Mat::from_fn(k.nrows(), k.ncols(), |i, j| k[(i, j)].re);
        let mr = Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)].re);
        let (lam, x) = cholesky_route(kr.as_ref(), mr.as_ref(), false)?;
        Ok((
            lam,
            Mat::from_fn(x.nrows(), x.ncols(), |i, j| c64::new(x[(i, j)], 0.0)),
        ))
    } else {
        cholesky_route(k, m, false)
    }
}

/// All eigenpairs of the real symmetric-definite pencil `K x = λ M x`, after symmetrizing `K`,
/// `M` and the reduced matrix against round-off (assembled matrices are symmetric only to it).
pub fn symmetric_gen_eigen(
    k: &DMatrix<f64>,
    m: &DMatrix<f64>,
) -> Result<(Vec<f64>, DMatrix<f64>), EigenError> {
    let n = k.nrows();
    let kf = Mat::<f64>::from_fn(n, n, |i, j| k[(i, j)]);
    let mf = Mat::<f64>::from_fn(n, n, |i, j| m[(i, j)]);
    let (lam, x) = cholesky_route(kf.as_ref(), mf.as_ref(), true)?;
    Ok((lam, DMatrix::from_fn(n, n, |i, j| x[(i, j)])))
}

/// `A ← (A + Aᴴ)/2`.
fn hermitian_part<T: ComplexField<Real = f64>>(a: MatRef<'_, T>) -> Mat<T> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| {
        mul_real(&add(&a[(i, j)], &conj(&a[(j, i)])), &0.5)
    })
}

/// All eigenpairs of a small dense Hermitian-definite pencil by the Cholesky route, ascending,
/// `M`-normalized; with `symmetrize`, `K`, `M` and the reduced matrix are first made exactly
/// Hermitian (they are computed products, Hermitian only to round-off).
pub(crate) fn cholesky_route<T: ComplexField<Real = f64>>(
    k: MatRef<'_, T>,
    m: MatRef<'_, T>,
    symmetrize: bool,
) -> Result<(Vec<f64>, Mat<T>), EigenError> {
    let n = k.nrows();
    let (k, m) = if symmetrize {
        (hermitian_part(k), hermitian_part(m))
    } else {
        (k.to_owned(), m.to_owned())
    };
    let llt = m
        .llt(Side::Lower)
        .map_err(|_| EigenError::MassNotDefinite)?;
    let l = llt.L();
    let mut c = k;
    solve_lower_triangular_in_place(l, c.as_mut(), Par::Seq);
    let mut c2 = c.adjoint().to_owned();
    solve_lower_triangular_in_place(l, c2.as_mut(), Par::Seq);
    if symmetrize {
        // The self-adjoint solver reads the lower triangle only.
        c2 = hermitian_part(c2.as_ref());
    }
    let evd = c2
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| EigenError::NoConvergence)?;
    let s = evd.S().column_vector();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| real(&s[a]).total_cmp(&real(&s[b])));
    let lam = order.iter().map(|&i| real(&s[i])).collect();
    let u = evd.U();
    let mut x = Mat::from_fn(n, n, |i, j| u[(i, order[j])].clone());
    solve_upper_triangular_in_place(l.adjoint(), x.as_mut(), Par::Seq);
    Ok((lam, x))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3-DOF chain with known eigenvalues: `K = k tridiag(−1, 2, −1)`, `M = m I`:
    /// `λ_j = (2k/m)(1 − cos(jπ/4))`.
    #[test]
    fn chain_eigenvalues_and_mass_normalization() {
        let (kk, mm) = (3.0, 2.0);
        let k = DMatrix::from_row_slice(3, 3, &[2., -1., 0., -1., 2., -1., 0., -1., 2.]) * kk;
        let m = DMatrix::identity(3, 3) * mm;
        let (lam, x) = symmetric_gen_eigen(&k, &m).unwrap();
        for (j, l) in lam.iter().enumerate() {
            let exact = 2.0 * kk / mm * (1.0 - ((j + 1) as f64 * std::f64::consts::PI / 4.0).cos());
            assert!((l - exact).abs() < 1e-13 * exact, "{l} vs {exact}");
        }
        let xtmx = x.transpose() * &m * &x;
        assert!((xtmx - DMatrix::identity(3, 3)).amax() < 1e-13);
        let residual = &k * &x - &m * &x * DMatrix::from_diagonal(&lam.clone().into());
        assert!(residual.amax() < 1e-12 * kk);
        // The complex entry point, real or not, gives the same eigenvalues.
        let kc = Mat::from_fn(3, 3, |i, j| c64::new(k[(i, j)], 0.0));
        let mc = Mat::from_fn(3, 3, |i, j| c64::new(m[(i, j)], 0.0));
        for real in [true, false] {
            let (lc, _) = dense_gen_eigen(kc.as_ref(), mc.as_ref(), real).unwrap();
            for (a, b) in lc.iter().zip(&lam) {
                assert!((a - b).abs() < 1e-13 * b);
            }
        }
        assert_eq!(
            symmetric_gen_eigen(&k, &(-m)).unwrap_err(),
            EigenError::MassNotDefinite
        );
    }
}
