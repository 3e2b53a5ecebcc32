//! The dense reference kernel: the assembled physical ROM (ARCH ordering: boundary DOFs of
//! every sector, then every modal coordinate) with dense matrices and a precomputed dense
//! `A⁻¹`. Straightforward and obviously right; it cross-checks the fast kernel.

use crate::dynamics::kernel::{Energies, StructureKernel};
use crate::dynamics::structure::Structure;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::DenseSolveCore;
use faer::{Accum, Mat, MatRef, Par};
use nalgebra::DMatrix;

/// Dense central-difference kernel of one structure.
#[derive(Clone)]
pub(crate) struct DenseKernel {
    ns: usize,
    nb: usize,
    h: f64,
    /// A⁻¹ = (M/h² + D/2h)⁻¹.
    ainv: Mat<f64>,
    /// K − 2M/h².
    kp: Mat<f64>,
    /// M/h² − D/2h.
    mp: Mat<f64>,
    m: Mat<f64>,
    k: Mat<f64>,
    /// Physical → harmonic map and per-ND stiffness (for the strain energy per ND).
    p: DMatrix<f64>,
    k_nd: Vec<(usize, DMatrix<f64>)>,
    /// With a massless boundary: the static modes, whose energy is counted apart.
    statics: Option<StaticModes>,
    u_prev: Mat<f64>,
    u: Mat<f64>,
    u_next: Mat<f64>,
    rhs: Mat<f64>,
    fload: Mat<f64>,
    /// The inertial modes' part of `A⁻¹ f` for the loads of
    /// [`StructureKernel::add_inertial_load`], added to the next predictor.
    inertial_du: Option<Mat<f64>>,
    ub: Vec<f64>,
}

/// The static modes of a massless-boundary structure (see [`Structure::discretized`]): the
/// `M'`-orthogonal projector on them, per nodal diameter, in harmonic coordinates.
#[derive(Clone)]
struct StaticModes {
    /// Per block: offset and `Φ_s Φ_sᵀ M'` (dim × dim).
    projectors: Vec<(usize, DMatrix<f64>)>,
}

impl StaticModes {
    fn new(st: &Structure) -> Self {
        let projectors = (st.blocks.iter())
            .map(|b| {
                let phi = b.modes.columns(b.first_static(), b.dim - b.first_static());
                (b.offset, phi * (phi.transpose() * &b.mass))
            })
            .collect();
        Self { projectors }
    }

    /// The static part `Pᵀ ⊕_k (Φ_s Φ_sᵀ M')_k P u` of a physical state `u`.
    fn project(&self, p: &DMatrix<f64>, u: &Mat<f64>) -> Mat<f64> {
        let x = p * nalgebra::DVector::from_fn(u.nrows(), |i, _| u[(i, 0)]);
        let mut xs = nalgebra::DVector::zeros(x.len());
        for (off, proj) in &self.projectors {
            let n = proj.nrows();
            xs.rows_mut(*off, n).copy_from(&(proj * x.rows(*off, n)));
        }
        let us = p.transpose() * xs;
        Mat::from_fn(us.len(), 1, |i, _| us[i])
    }
}

fn to_faer(m: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

impl DenseKernel {
    /// Assembles the physical ROM of `st` and inverts `A` for time step `h` (s).
    pub fn new(st: &Structure, h: f64) -> Self {
        let st = &*st.discretized(h);
        let (m, k, d) = st.assemble_physical();
        let n = m.nrows();
        let a = to_faer(&(&m / (h * h) + &d / (2.0 * h)));
        let ainv = a.partial_piv_lu().inverse();
        let kp = to_faer(&(&k - &m * (2.0 / (h * h))));
        let mp = to_faer(&(&m / (h * h) - &d / (2.0 * h)));
        let k_nd = st
            .blocks
            .iter()
            .map(|b| (b.offset, b.stiffness.clone()))
            .collect();
        let statics = st.has_static_modes().then(|| StaticModes::new(st));
        Self {
            ns: st.n_sectors,
            nb: st.n_boundary,
            h,
            ainv,
            kp,
            mp,
            m: to_faer(&m),
            k: to_faer(&k),
            p: st.physical_to_harmonic(),
            k_nd,
            statics,
            u_prev: Mat::zeros(n, 1),
            u: Mat::zeros(n, 1),
            u_next: Mat::zeros(n, 1),
            rhs: Mat::zeros(n, 1),
            fload: Mat::zeros(n, 1),
            inertial_du: None,
            ub: vec![0.0; st.n_sectors * st.n_boundary],
        }
    }

    /// The boundary block of `A⁻¹` (the boundary flexibility), `N·3n_c` square.
    pub(crate) fn boundary_flexibility(&self) -> MatRef<'_, f64> {
        let nbt = self.ns * self.nb;
        self.ainv.as_ref().submatrix(0, 0, nbt, nbt)
    }

    fn refresh(&mut self) {
        for (i, x) in self.ub.iter_mut().enumerate() {
            *x = self.u_next[(i, 0)];
        }
    }

    fn quad(mat: &Mat<f64>, x: &Mat<f64>, y: &Mat<f64>) -> f64 {
        let mut t = Mat::<f64>::zeros(x.nrows(), 1);
        matmul(
            t.as_mut(),
            Accum::Replace,
            mat.as_ref(),
            y.as_ref(),
            1.0,
            Par::Seq,
        );
        (0..x.nrows()).map(|i| x[(i, 0)] * t[(i, 0)]).sum()
    }
}

impl StructureKernel for DenseKernel {
    fn n_sectors(&self) -> usize {
        self.ns
    }
    fn n_boundary(&self) -> usize {
        self.nb
    }
    fn set_load_pattern(&mut self, pattern: &[f64]) {
        self.fload.fill(0.0);
        for (i, f) in pattern.iter().enumerate() {
            self.fload[(i, 0)] = *f;
        }
    }
    fn set_initial_velocity(&mut self, velocity: &[f64]) {
        self.u.fill(0.0);
        for (i, v) in velocity.iter().enumerate() {
            self.u_prev[(i, 0)] = -self.h * v;
        }
    }
    fn predict(&mut self, amplitude: f64) {
        let n = self.rhs.nrows();
        for i in 0..n {
            self.rhs[(i, 0)] = amplitude * self.fload[(i, 0)];
        }
        matmul(
            self.rhs.as_mut(),
            Accum::Add,
            self.kp.as_ref(),
            self.u.as_ref(),
            -1.0,
            Par::Seq,
        );
        matmul(
            self.rhs.as_mut(),
            Accum::Add,
            self.mp.as_ref(),
            self.u_prev.as_ref(),
            -1.0,
            Par::Seq,
        );
        matmul(
            self.u_next.as_mut(),
            Accum::Replace,
            self.ainv.as_ref(),
            self.rhs.as_ref(),
            1.0,
            Par::Seq,
        );
        if let Some(du) = self.inertial_du.take() {
            self.u_next += du;
        }
        self.refresh();
    }
    fn boundary(&self) -> &[f64] {
        &self.ub
    }
    fn add_inertial_load(&mut self, forces: &[f64]) {
        let nbt = forces.len();
        let f = MatRef::from_column_major_slice(forces, nbt, 1);
        let a = self.ainv.as_ref().submatrix(0, 0, self.ainv.nrows(), nbt);
        let mut du = Mat::<f64>::zeros(self.ainv.nrows(), 1);
        matmul(du.as_mut(), Accum::Replace, a, f, 1.0, Par::Seq);
        if let Some(s) = &self.statics {
            du -= s.project(&self.p, &du);
        }
        match &mut self.inertial_du {
            Some(acc) => *acc += du,
            None => self.inertial_du = Some(du),
        }
    }
    fn correct(&mut self, forces: &[f64]) {
        let nbt = forces.len();
        let f = MatRef::from_column_major_slice(forces, nbt, 1);
        let a = self.ainv.as_ref().submatrix(0, 0, self.ainv.nrows(), nbt);
        matmul(self.u_next.as_mut(), Accum::Add, a, f, 1.0, Par::Seq);
        self.refresh();
    }
    fn response(&mut self, forces: &[f64], out: &mut [f64]) {
        let nbt = forces.len();
        let f = MatRef::from_column_major_slice(forces, nbt, 1);
        let mut o = Mat::<f64>::zeros(nbt, 1);
        matmul(
            o.as_mut(),
            Accum::Replace,
            self.boundary_flexibility(),
            f,
            1.0,
            Par::Seq,
        );
        for (i, x) in out.iter_mut().enumerate() {
            *x = o[(i, 0)];
        }
    }
    fn advance(&mut self) {
        std::mem::swap(&mut self.u_prev, &mut self.u);
        std::mem::swap(&mut self.u, &mut self.u_next);
    }
    fn energies(&self) -> Energies {
        let (mut u, mut u_prev) = (self.u.clone(), self.u_prev.clone());
        let mut statics = Energies::default();
        if let Some(s) = &self.statics {
            // Static parts out of both states: no kinetic energy, strain `½ u_sᵀ K u_s` at n.
            let us = s.project(&self.p, &self.u);
            statics.strain = 0.5 * Self::quad(&self.k, &us, &us);
            u -= &us;
            u_prev -= s.project(&self.p, &self.u_prev);
        }
        let mut v = u.clone();
        for i in 0..v.nrows() {
            v[(i, 0)] = (u[(i, 0)] - u_prev[(i, 0)]) / self.h;
        }
        Energies {
            kinetic: 0.5 * Self::quad(&self.m, &v, &v),
            strain: 0.5 * Self::quad(&self.k, &u, &u_prev) + statics.strain,
        }
    }
    fn nd_strain_energy(&self, out: &mut [f64]) {
        let u = nalgebra::DVector::from_fn(self.u.nrows(), |i, _| self.u[(i, 0)]);
        let x = &self.p * u;
        for (o, (off, k)) in out.iter_mut().zip(&self.k_nd) {
            let xk = x.rows(*off, k.nrows());
            *o = 0.5 * xk.dot(&(k * xk));
        }
    }
    fn is_finite(&self) -> bool {
        (0..self.u_next.nrows()).all(|i| self.u_next[(i, 0)].is_finite())
    }
    fn harmonic_state(&self, out: &mut [f64]) {
        let u = nalgebra::DVector::from_fn(self.u.nrows(), |i, _| self.u[(i, 0)]);
        out.copy_from_slice((&self.p * u).as_slice());
    }
}
