//! The fast kernel: per-nodal-diameter modal coordinates and a real FFT over sectors.
//!
//! The mass-normalized eigenvectors Φ_k of each nodal diameter diagonalise M, K(Ω) and the
//! (modal or Rayleigh) damping (see [`crate::dynamics::structure`]), so the predictor is a
//! scalar three-term recurrence per mode: with `a_p = 1/h² + c_p/2h`,
//! `η*_{n+1} = [(2/h² − ω_p²) η_n − (1/h² − c_p/2h) η_{n−1} + φ_pᵀ f_n] / a_p`, and
//! `A⁻¹ = Pᵀ (⊕_k Φ_k diag(1/a) Φ_kᵀ) P`. Boundary displacements are the boundary rows of
//! Φ_k η_k per nodal diameter followed by an inverse real DFT over sectors (realfft, planned
//! once); boundary forces go the other way. No allocation per step.
//!
//! # Speed
//! The per-ND products are small dense GEMVs over the column-major boundary rows Φ_b,k
//! ([`gemv`], [`gemv_t`]: four columns at a time, lane accumulators, AVX2 when the CPU has it).
//! A correction is fused per nodal diameter: `Δη_k = diag(1/a) Φ_b,kᵀ F_k` and
//! `ΔU_k = Φ_b,k Δη_k` while Φ_b,k is still in L1, added to the kept spectrum of the
//! predicted boundary, then one inverse real DFT per boundary channel. So a contact step reads
//! each Φ_b,k from memory twice (predict, correct) instead of three times.

use crate::dynamics::kernel::{Energies, StructureKernel};
use crate::dynamics::structure::Structure;
use realfft::num_complex::Complex64;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::sync::Arc;

struct Block {
    offset: usize,
    dim: usize,
    real: bool,
    /// DFT weight w_k.
    w: f64,
    /// Boundary rows of Φ_k (nb or 2nb rows), column-major: column p at `p*rows..`.
    phib: Vec<f64>,
    rows: usize,
}

/// The fast modal/FFT kernel of one structure.
pub struct ModalKernel {
    ns: usize,
    nb: usize,
    h: f64,
    blocks: Vec<Block>,
    omega2: Vec<f64>,
    c1: Vec<f64>,
    c2: Vec<f64>,
    c3: Vec<f64>,
    eta_prev: Vec<f64>,
    eta: Vec<f64>,
    eta_next: Vec<f64>,
    gload: Vec<f64>,
    ub: Vec<f64>,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
    /// Spectra per boundary channel, `nb × (N/2+1)` (work buffer).
    spec: Vec<Complex64>,
    /// Spectrum of the current `u_{n+1}` boundary (set by predict, updated by correct).
    spec_state: Vec<Complex64>,
    /// Spectrum of the last force passed to correct/response.
    fspec: Vec<Complex64>,
    /// Modal increment of one block (`dim` ≤ max block size) and its boundary image.
    deta: Vec<f64>,
    dub: Vec<f64>,
    tbuf: Vec<f64>,
    cbuf: Vec<Complex64>,
    scratch: Vec<Complex64>,
    xb: Vec<f64>,
    tmp_eta: Vec<f64>,
    /// Physical→harmonic map of the modal part: for each block, (physical offset of modal coords).
    phys_modal: Vec<usize>,
    n_modes: Vec<usize>,
    modes_full: Vec<nalgebra::DMatrix<f64>>,
    masses: Vec<nalgebra::DMatrix<f64>>,
}

impl ModalKernel {
    /// Builds the kernel for `st` with time step `h` (s); `h` is checked by the caller.
    pub fn new(st: &Structure, h: f64) -> Self {
        let ns = st.n_sectors;
        let nb = st.n_boundary;
        let mut planner = RealFftPlanner::<f64>::new();
        let r2c = planner.plan_fft_forward(ns);
        let c2r = planner.plan_fft_inverse(ns);
        let nspec = ns / 2 + 1;
        let mut blocks = Vec::new();
        let (mut omega2, mut c1, mut c2, mut c3) = (vec![], vec![], vec![], vec![]);
        let mut phys_modal = vec![];
        let mut n_modes = vec![];
        let mut modes_full = vec![];
        let mut masses = vec![];
        for b in &st.blocks {
            let rows = if b.real { nb } else { 2 * nb };
            let mut phib = vec![0.0; rows * b.dim];
            for p in 0..b.dim {
                for (r, row) in b.boundary_rows(nb).enumerate() {
                    phib[p * rows + r] = b.modes[(row, p)];
                }
            }
            for p in 0..b.dim {
                let (w, c) = (b.omega[p], b.damping_coef[p]);
                let a = 1.0 / (h * h) + c / (2.0 * h);
                omega2.push(w * w);
                c1.push((2.0 / (h * h) - w * w) / a);
                c2.push(-(1.0 / (h * h) - c / (2.0 * h)) / a);
                c3.push(1.0 / a);
            }
            blocks.push(Block {
                offset: b.offset,
                dim: b.dim,
                real: b.real,
                w: st.dft_weight(b.k),
                phib,
                rows,
            });
            phys_modal.push(st.physical_modal_offset(b.k));
            n_modes.push(b.n_modes);
            modes_full.push(b.modes.clone());
            masses.push(b.mass.clone());
        }
        let n = st.n_modal;
        let scratch_len = r2c.get_scratch_len().max(c2r.get_scratch_len());
        Self {
            ns,
            nb,
            h,
            blocks,
            omega2,
            c1,
            c2,
            c3,
            eta_prev: vec![0.0; n],
            eta: vec![0.0; n],
            eta_next: vec![0.0; n],
            gload: vec![0.0; n],
            ub: vec![0.0; ns * nb],
            r2c,
            c2r,
            spec: vec![Complex64::new(0.0, 0.0); nb * nspec],
            spec_state: vec![Complex64::new(0.0, 0.0); nb * nspec],
            fspec: vec![Complex64::new(0.0, 0.0); nb * nspec],
            deta: vec![0.0; st.blocks.iter().map(|b| b.dim).max().unwrap_or(0)],
            dub: vec![0.0; 2 * nb],
            tbuf: vec![0.0; ns],
            cbuf: vec![Complex64::new(0.0, 0.0); nspec],
            scratch: vec![Complex64::new(0.0, 0.0); scratch_len],
            xb: vec![0.0; 2 * nb],
            tmp_eta: vec![0.0; n],
            phys_modal,
            n_modes,
            modes_full,
            masses,
        }
    }

    /// Static boundary displacements `K(Ω)⁻¹ f` (m) of boundary forces `f` (N, sector-major),
    /// through the modal decomposition (`η_p = φ_pᵀ f / ω_p²`). Fails if a mode with zero
    /// frequency is loaded.
    pub fn static_boundary(&mut self, forces: &[f64], out: &mut [f64]) -> Result<(), String> {
        self.tmp_eta.iter_mut().for_each(|x| *x = 0.0);
        self.add_response(forces, Which::Tmp);
        let gmax = self
            .tmp_eta
            .iter()
            .zip(&self.c3)
            .fold(0.0f64, |m, (t, c)| m.max((t / c).abs()));
        for i in 0..self.tmp_eta.len() {
            let g = self.tmp_eta[i] / self.c3[i];
            if self.omega2[i] > 0.0 {
                self.tmp_eta[i] = g / self.omega2[i];
            } else if g.abs() > 1e-12 * gmax {
                return Err(format!(
                    "the load excites a zero-frequency mode (modal coordinate {i}): no static response"
                ));
            } else {
                self.tmp_eta[i] = 0.0;
            }
        }
        self.boundary_of(Which::Tmp, false, out);
        Ok(())
    }

    /// Modal coordinates of step n (after `advance`), flat over nodal diameters.
    pub fn modal_coordinates(&self) -> &[f64] {
        &self.eta
    }

    /// Boundary displacements (sector-major) of modal coordinates `eta` into `out` (or into
    /// `ub` with `out_is_ub`, keeping the spectrum in `spec_state` for the next correction).
    fn boundary_of(&mut self, which: Which, out_is_ub: bool, out: &mut [f64]) {
        let nspec = self.ns / 2 + 1;
        let nb = self.nb;
        let eta: &[f64] = match which {
            Which::Next => &self.eta_next,
            Which::Tmp => &self.tmp_eta,
        };
        let spec = if out_is_ub {
            &mut self.spec_state
        } else {
            &mut self.spec
        };
        for (k, b) in self.blocks.iter().enumerate() {
            let xb = &mut self.xb[..b.rows];
            xb.iter_mut().for_each(|x| *x = 0.0);
            gemv(&b.phib, b.rows, &eta[b.offset..b.offset + b.dim], xb);
            // c2r computes x_s = Σ_k X_k e^{ikθ_s} over the full spectrum; see the module doc of
            // `structure` for the orthonormal convention u_s = Σ_k w_k (a_k cos + b_k sin).
            if b.real {
                for (r, x) in xb.iter().enumerate() {
                    spec[r * nspec + k] = Complex64::new(b.w * x, 0.0);
                }
            } else {
                for r in 0..nb {
                    spec[r * nspec + k] =
                        Complex64::new(0.5 * b.w * xb[r], -0.5 * b.w * xb[nb + r]);
                }
            }
        }
        if out_is_ub {
            self.spectrum_to_boundary(true, &mut []);
        } else {
            self.spectrum_to_boundary(false, out);
        }
    }

    /// Inverse real DFT of every boundary channel of `spec_state` (into `ub`) or `spec` (into `out`).
    fn spectrum_to_boundary(&mut self, state: bool, out: &mut [f64]) {
        let nspec = self.ns / 2 + 1;
        let nb = self.nb;
        let (spec, target): (&[Complex64], &mut [f64]) = if state {
            (&self.spec_state, &mut self.ub)
        } else {
            (&self.spec, out)
        };
        for r in 0..nb {
            self.cbuf.copy_from_slice(&spec[r * nspec..(r + 1) * nspec]);
            self.c2r
                .process_with_scratch(&mut self.cbuf, &mut self.tbuf, &mut self.scratch)
                .expect("FFT buffer sizes are fixed at construction");
            for (s, t) in self.tbuf.iter().enumerate() {
                target[s * nb + r] = *t;
            }
        }
    }

    /// Forward real DFT of every boundary channel of the sector-major `forces` into `fspec`
    /// (a channel without load gets a zero spectrum without an FFT).
    fn forces_to_spectrum(&mut self, forces: &[f64]) {
        let nspec = self.ns / 2 + 1;
        let (nb, ns) = (self.nb, self.ns);
        for r in 0..nb {
            let mut any = false;
            for s in 0..ns {
                let f = forces[s * nb + r];
                any |= f != 0.0;
                self.tbuf[s] = f;
            }
            let dst = &mut self.fspec[r * nspec..(r + 1) * nspec];
            if !any {
                dst.iter_mut().for_each(|x| *x = Complex64::new(0.0, 0.0));
                continue;
            }
            self.r2c
                .process_with_scratch(&mut self.tbuf, &mut self.cbuf, &mut self.scratch)
                .expect("FFT buffer sizes are fixed at construction");
            dst.copy_from_slice(&self.cbuf);
        }
    }

    /// Fused `A⁻¹ f` of the force spectrum in `fspec`, one nodal diameter at a time:
    /// `Δη = diag(1/a) Φ_bᵀ F_k`, then `ΔU_k = Φ_b Δη` while Φ_b is hot in cache. With
    /// `state`, `Δη` is added to `η_{n+1}` and `ΔU` to `spec_state`; otherwise `spec` is
    /// overwritten with `ΔU` (the response alone).
    fn apply_force_spectrum(&mut self, state: bool) {
        let nspec = self.ns / 2 + 1;
        let nb = self.nb;
        for (k, b) in self.blocks.iter().enumerate() {
            let xb = &mut self.xb[..b.rows];
            // r2c gives X_k = Σ_s u_s e^{−ikθ_s}: a_k = w Re X_k, b_k = −w Im X_k.
            for r in 0..nb {
                let x = self.fspec[r * nspec + k];
                xb[r] = b.w * x.re;
                if !b.real {
                    xb[nb + r] = -b.w * x.im;
                }
            }
            let deta = &mut self.deta[..b.dim];
            gemv_t(&b.phib, b.rows, xb, deta);
            for (d, c) in deta.iter_mut().zip(&self.c3[b.offset..b.offset + b.dim]) {
                *d *= c;
            }
            if state {
                for (e, d) in self.eta_next[b.offset..b.offset + b.dim]
                    .iter_mut()
                    .zip(deta.iter())
                {
                    *e += d;
                }
            }
            let dub = &mut self.dub[..b.rows];
            dub.iter_mut().for_each(|x| *x = 0.0);
            gemv(&b.phib, b.rows, deta, dub);
            let spec = if state {
                &mut self.spec_state
            } else {
                &mut self.spec
            };
            if b.real {
                for (r, x) in dub.iter().enumerate() {
                    let z = Complex64::new(b.w * x, 0.0);
                    let e = &mut spec[r * nspec + k];
                    *e = if state { *e + z } else { z };
                }
            } else {
                for r in 0..nb {
                    let z = Complex64::new(0.5 * b.w * dub[r], -0.5 * b.w * dub[nb + r]);
                    let e = &mut spec[r * nspec + k];
                    *e = if state { *e + z } else { z };
                }
            }
        }
    }

    /// Modal forces `Φᵀ P f` of boundary forces `f` (sector-major), scaled by `1/a_p`, added to `dst`.
    fn add_response(&mut self, forces: &[f64], dst: Which) {
        let nspec = self.ns / 2 + 1;
        let nb = self.nb;
        self.forces_to_spectrum(forces);
        let eta: &mut [f64] = match dst {
            Which::Next => &mut self.eta_next,
            Which::Tmp => &mut self.tmp_eta,
        };
        for (k, b) in self.blocks.iter().enumerate() {
            let xb = &mut self.xb[..b.rows];
            for r in 0..nb {
                let x = self.fspec[r * nspec + k];
                xb[r] = b.w * x.re;
                if !b.real {
                    xb[nb + r] = -b.w * x.im;
                }
            }
            let g = &mut self.deta[..b.dim];
            gemv_t(&b.phib, b.rows, xb, g);
            for p in 0..b.dim {
                eta[b.offset + p] += self.c3[b.offset + p] * g[p];
            }
        }
    }

    /// Modal coordinates `Φᵀ M x` of a physical vector (assembled ordering): harmonic transform
    /// then projection. Used for initial conditions and load patterns (not per step).
    fn physical_to_modal(&self, v: &[f64], out: &mut [f64]) {
        let (ns, nb) = (self.ns, self.nb);
        let alpha = 2.0 * std::f64::consts::PI / ns as f64;
        for (bi, b) in self.blocks.iter().enumerate() {
            let n = if b.real { b.dim } else { b.dim / 2 };
            let k = bi as f64;
            let mut x = nalgebra::DVector::zeros(b.dim);
            let parts = if b.real { 1 } else { 2 };
            for part in 0..parts {
                for s in 0..ns {
                    let th = k * s as f64 * alpha;
                    let f = b.w * if part == 0 { th.cos() } else { th.sin() };
                    for r in 0..nb {
                        x[part * n + r] += f * v[s * nb + r];
                    }
                }
                for m in 0..self.n_modes[bi] {
                    x[part * n + nb + m] = v[self.phys_modal[bi] + part * self.n_modes[bi] + m];
                }
            }
            let eta = self.modes_full[bi].transpose() * (&self.masses[bi] * x);
            out[b.offset..b.offset + b.dim].copy_from_slice(eta.as_slice());
        }
    }
}

#[derive(Clone, Copy)]
enum Which {
    Next,
    Tmp,
}

impl StructureKernel for ModalKernel {
    fn n_sectors(&self) -> usize {
        self.ns
    }
    fn n_boundary(&self) -> usize {
        self.nb
    }
    fn set_load_pattern(&mut self, pattern: &[f64]) {
        // g = Φᵀ P f: reuse the response path with c3 divided out.
        self.tmp_eta.iter_mut().for_each(|x| *x = 0.0);
        self.add_response(pattern, Which::Tmp);
        for (g, (t, c3)) in self.gload.iter_mut().zip(self.tmp_eta.iter().zip(&self.c3)) {
            *g = t / c3;
        }
    }
    fn set_initial_velocity(&mut self, velocity: &[f64]) {
        let mut v = vec![0.0; self.eta.len()];
        self.physical_to_modal(velocity, &mut v);
        self.eta.iter_mut().for_each(|x| *x = 0.0);
        for (p, vp) in self.eta_prev.iter_mut().zip(&v) {
            *p = -self.h * vp;
        }
    }
    fn predict(&mut self, amplitude: f64) {
        for i in 0..self.eta.len() {
            self.eta_next[i] = self.c1[i] * self.eta[i]
                + self.c2[i] * self.eta_prev[i]
                + self.c3[i] * amplitude * self.gload[i];
        }
        self.boundary_of(Which::Next, true, &mut []);
    }
    fn boundary(&self) -> &[f64] {
        &self.ub
    }
    fn correct(&mut self, forces: &[f64]) {
        self.forces_to_spectrum(forces);
        self.apply_force_spectrum(true);
        self.spectrum_to_boundary(true, &mut []);
    }
    fn response(&mut self, forces: &[f64], out: &mut [f64]) {
        self.forces_to_spectrum(forces);
        self.apply_force_spectrum(false);
        self.spectrum_to_boundary(false, out);
    }
    fn advance(&mut self) {
        std::mem::swap(&mut self.eta_prev, &mut self.eta);
        std::mem::swap(&mut self.eta, &mut self.eta_next);
    }
    fn energies(&self) -> Energies {
        let h2 = self.h * self.h;
        let mut e = Energies::default();
        for i in 0..self.eta.len() {
            let d = self.eta[i] - self.eta_prev[i];
            e.kinetic += 0.5 * d * d / h2;
            e.strain += 0.5 * self.omega2[i] * self.eta[i] * self.eta_prev[i];
        }
        e
    }
    fn nd_strain_energy(&self, out: &mut [f64]) {
        for (o, b) in out.iter_mut().zip(&self.blocks) {
            *o = (b.offset..b.offset + b.dim)
                .map(|i| 0.5 * self.omega2[i] * self.eta[i] * self.eta[i])
                .sum();
        }
    }
    fn is_finite(&self) -> bool {
        self.eta_next.iter().all(|x| x.is_finite())
    }
}

/// `y += A x` for a column-major `A` with `rows` rows (`x.len()` columns): four columns at a
/// time so that each pass over `y` does four FMAs per element. AVX2/FMA code when available
/// (runtime check), SSE2 otherwise; both compute the same sums in the same order.
#[inline]
pub fn gemv(a: &[f64], rows: usize, x: &[f64], y: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports the enabled features (checked just above).
            unsafe { gemv_avx2(a, rows, x, y) };
            return;
        }
    }
    gemv_impl(a, rows, x, y);
}

/// `y = Aᵀ x` for a column-major `A` with `rows` rows (`y.len()` columns): four columns at a
/// time with four lane accumulators each (a fixed summation order, whatever the SIMD width).
#[inline]
pub fn gemv_t(a: &[f64], rows: usize, x: &[f64], y: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports the enabled features (checked just above).
            unsafe { gemv_t_avx2(a, rows, x, y) };
            return;
        }
    }
    gemv_t_impl(a, rows, x, y);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn gemv_avx2(a: &[f64], rows: usize, x: &[f64], y: &mut [f64]) {
    gemv_impl(a, rows, x, y)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn gemv_t_avx2(a: &[f64], rows: usize, x: &[f64], y: &mut [f64]) {
    gemv_t_impl(a, rows, x, y)
}

#[inline(always)]
fn gemv_impl(a: &[f64], rows: usize, x: &[f64], y: &mut [f64]) {
    let y = &mut y[..rows];
    let cols = x.len();
    let a = &a[..rows * cols];
    let mut p = 0;
    while p + 4 <= cols {
        let (x0, x1, x2, x3) = (x[p], x[p + 1], x[p + 2], x[p + 3]);
        let c = &a[p * rows..(p + 4) * rows];
        let (c0, rest) = c.split_at(rows);
        let (c1, rest) = rest.split_at(rows);
        let (c2, c3) = rest.split_at(rows);
        for r in 0..rows {
            y[r] += (x0 * c0[r] + x1 * c1[r]) + (x2 * c2[r] + x3 * c3[r]);
        }
        p += 4;
    }
    while p < cols {
        let xp = x[p];
        let c = &a[p * rows..(p + 1) * rows];
        for r in 0..rows {
            y[r] += xp * c[r];
        }
        p += 1;
    }
}

#[inline(always)]
fn dot_lanes(c: &[f64], x: &[f64]) -> f64 {
    let n = x.len();
    let c = &c[..n];
    let mut acc = [0.0f64; 4];
    let mut r = 0;
    while r + 4 <= n {
        for l in 0..4 {
            acc[l] += c[r + l] * x[r + l];
        }
        r += 4;
    }
    let mut tail = 0.0;
    while r < n {
        tail += c[r] * x[r];
        r += 1;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[inline(always)]
fn gemv_t_impl(a: &[f64], rows: usize, x: &[f64], y: &mut [f64]) {
    let x = &x[..rows];
    for (p, yp) in y.iter_mut().enumerate() {
        *yp = dot_lanes(&a[p * rows..(p + 1) * rows], x);
    }
}

#[cfg(test)]
mod gemv_tests {
    use super::*;

    /// Both GEMVs against the plain triple loop, for sizes with and without remainders.
    #[test]
    fn gemv_and_transpose_match_the_naive_products() {
        for (rows, cols) in [(1, 1), (3, 5), (15, 25), (30, 50), (7, 9)] {
            let a: Vec<f64> = (0..rows * cols)
                .map(|i| ((i * 37 % 101) as f64 - 50.0) / 7.0)
                .collect();
            let x: Vec<f64> = (0..cols).map(|i| (i as f64 * 0.3).sin()).collect();
            let z: Vec<f64> = (0..rows).map(|i| (i as f64 * 0.7).cos()).collect();
            let mut y = vec![1.0; rows];
            gemv(&a, rows, &x, &mut y);
            let mut g = vec![0.0; cols];
            gemv_t(&a, rows, &z, &mut g);
            for r in 0..rows {
                let e: f64 = 1.0 + (0..cols).map(|p| a[p * rows + r] * x[p]).sum::<f64>();
                assert!((y[r] - e).abs() <= 1e-13 * e.abs().max(1.0));
            }
            for p in 0..cols {
                let e: f64 = (0..rows).map(|r| a[p * rows + r] * z[r]).sum();
                assert!((g[p] - e).abs() <= 1e-13 * e.abs().max(1.0));
            }
        }
    }
}
