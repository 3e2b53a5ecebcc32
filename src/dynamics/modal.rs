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
//! - **Half the basis.** A complex harmonic's real form commutes with `J = [[0, −I], [I, 0]]`,
//!   so its eigenvectors are stored as J-pairs and only one vector per pair is kept
//!   (`paired_modes`): the casing bases (51 harmonics × 32 padded rows × 25 columns) take
//!   326 KB instead of 612 KB, i.e. they fit in L2.
//! - **Spline folded in** (`ModalKernel::fold_spline`, casing only): the channels are the
//!   spline's control points (eq. 13 per nodal diameter), so no spline solve per step.
//! - **One pass per contact step.** [`StructureKernel::correct_then_predict`] does, per nodal
//!   diameter while its basis is in L1: `Δη_k = diag(1/a) Φ_b,kᵀ F_k`, `ΔU_k = Φ_b,k Δη_k`
//!   (added to the kept harmonic rows of the predicted channels) and the next step's predictor
//!   `Φ_b,k η*_{n+2,k}`; then one inverse real DFT per channel for each.
//! - **Sparse loads.** Contact forces sit on the few sectors under the touching patches: their
//!   sector DFT is summed directly (`forces_to_rows`, up to `DIRECT_DFT_SECTORS` sectors)
//!   instead of one FFT per channel, with the weights read from a table.
//! - **Folded synthesis.** The boundary of all sectors is summed directly too
//!   (`rows_to_boundary`, up to `DIRECT_SYNTH_SECTORS` sectors): the symmetries of the DFT
//!   weights under s ↦ N − s and s ↦ N/2 − s give four sectors from the sums of one, a
//!   quarter of the products. On the paper's casing (N = 100) this costs half the
//!   instructions of 15 real FFTs with their packing.
//! - **Harmonic-major rows.** The spectra are kept as the per-ND real rows `[a; b]` that the
//!   products read and write in place; the sector DFTs do the complex packing.
//! - The per-ND products of a complex harmonic take both halves of a J-pair in one pass over
//!   the stored half basis ([`simd::expand`], [`simd::project`], for the real harmonics
//!   too). Those and the sector DFTs' direct sums are the kernels of [`crate::simd`]:
//!   explicit AVX2/FMA code or its portable twin, the choice made once when the kernel is
//!   built ([`ModalKernel::isa`]), and the per-step passes run compiled for it
//!   ([`simd::compiled_for`]).
use crate::contact::CasingSpline;
use crate::dynamics::kernel::{Energies, StructureKernel};
use crate::dynamics::structure::{NdBlock, Structure, StructureError};
use crate::model::eigen::EigenError;
use crate::simd::{self, Isa};
use nalgebra::{DMatrix, DVector};
use rubscan_fft::{Complex64, ComplexToReal, RealFftPlanner64, RealToComplex};
use std::sync::Arc;

#[derive(Clone)]
struct Block {
    offset: usize,
    /// Real-form order: `n` (real harmonic) or `2n`.
    dim: usize,
    /// Stored basis columns `n` (one per complex mode pair, see `paired_modes`).
    n: usize,
    real: bool,
    /// DFT weight w_k.
    w: f64,
    /// Boundary rows of the first `n` basis vectors, column-major (column p at `p*rows..`):
    /// `[v_a; v_b]` for a complex harmonic, `v_a` for a real one, each part padded with zero
    /// rows to `nbp` (a multiple of the SIMD width). The partner columns `J v` are implicit.
    phib: Vec<f64>,
    /// The same columns mapped to the per-step channels when they differ from the contact
    /// nodes (see [`ModalKernel::fold_spline`]); empty otherwise.
    chan: Vec<f64>,
    rows: usize,
}

impl Block {
    /// The basis of the per-step channels (predict, correct, response).
    #[inline]
    fn step_basis(&self) -> &[f64] {
        if self.chan.is_empty() {
            &self.phib
        } else {
            &self.chan
        }
    }
}

/// The fast modal/FFT kernel of one structure.
#[derive(Clone)]
pub struct ModalKernel {
    ns: usize,
    nb: usize,
    h: f64,
    blocks: Vec<Block>,
    omega2: Vec<f64>,
    /// Per mode 1 (dynamic) or 0 (static, massless boundary): a static mode has no kinetic
    /// energy and its strain energy is that of `η_n` alone.
    inertial: Vec<f64>,
    c1: Vec<f64>,
    c2: Vec<f64>,
    /// `h²/2` (s²): `c₃ = 1/a` of each mode is [`c3_of`] its `c₂` (not stored: a third
    /// coefficient stream less per step).
    half_h2: f64,
    /// `η_{n−1}`; between a fused correction (`pred_amplitude` set) and `advance`, the
    /// predictor `η*_{n+2}` instead, which `advance` rotates into `eta_next`: three buffers,
    /// not four, cycle through the cache.
    eta_prev: Vec<f64>,
    eta: Vec<f64>,
    eta_next: Vec<f64>,
    gload: Vec<f64>,
    /// Modal load `Φᵀ f` of [`StructureKernel::add_inertial_load`] on the inertial modes (0 on
    /// the static ones), for the next predictor; `inertial_loaded` while it is not used up.
    inertial_load: Vec<f64>,
    inertial_loaded: bool,
    /// `a g_load + inertial_load` of a predictor that carries an inertial load (work buffer).
    load_sum: Vec<f64>,
    /// Per block: whether its part of `gload` is nonzero (the load term of an unloaded
    /// harmonic is not read).
    block_loaded: Vec<bool>,
    ub: Vec<f64>,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
    /// Harmonic rows `Φ_b,k η_k` of every nodal diameter k at `k · 2nbp` (`[a; b]` of the
    /// real form, see [`expand`]): the spectra in the form the per-ND products read and
    /// write; the sector DFTs convert (`rows_to_boundary`, `forces_to_rows`). Work buffer.
    spec: Vec<f64>,
    /// Harmonic rows of the current `u_{n+1}` channels (set by predict, updated by correct).
    spec_state: Vec<f64>,
    /// Predictor of the next step formed during the last correction (see
    /// [`StructureKernel::correct_then_predict`]): its harmonic rows (its modal coordinates
    /// are in `eta_prev`), and the load amplitude it used (`None`: not formed, or used up).
    spec_pred: Vec<f64>,
    pred_amplitude: Option<f64>,
    /// Order of the last pass of `apply_force_spectrum` over the harmonics: alternated, so
    /// that a pass starts on the bases the previous one used last, which are still in L2
    /// (the bases of all harmonics are not, at the paper's size).
    descending: bool,
    /// Harmonic rows `(a, b)` of the last force passed to correct/response (`a = w Re X_k`,
    /// `b = −w Im X_k` of its sector DFT `X_k`).
    fspec: Vec<f64>,
    /// Modal increment of one block (`dim` ≤ max block size).
    deta: Vec<f64>,
    /// Boundary rows per part, padded: `nb` rounded up to a multiple of 4.
    nbp: usize,
    tbuf: Vec<f64>,
    /// Real DFT weights `(w_k cos kθ_s, w_k sin kθ_s)` at `s·(N/2 + 1) + k`, `θ_s = 2πs/N`
    /// (sine 0 for a real harmonic), of both directions: `a_k = Σ_s c f_s`, `b_k = Σ_s s f_s`
    /// and `u_s = Σ_k (c a_k + s b_k)` (see [`sector_dft_weights`]). `N(N/2 + 1)` pairs: 82 KB
    /// for the paper's casing, of which a step reads the rows s ≤ N/4 and the loaded sectors.
    dft_weights: Vec<(f64, f64)>,
    /// Sectors with a nonzero load in the last `forces_to_rows` (work buffer).
    loaded: Vec<usize>,
    /// Their loads, `nbp` rows each (work buffer).
    fload: Vec<f64>,
    /// The four partial sums of one sector of the folded inverse DFT, `nbp` rows each
    /// (work buffer, see [`ModalKernel::folded_rows_to_boundary`]).
    fold: Vec<f64>,
    cbuf: Vec<Complex64>,
    /// The `c2r` spectra of every boundary channel (`nb` × N/2+1, channel-major; work buffer).
    spectra: Vec<Complex64>,
    scratch: Vec<Complex64>,
    xb: Vec<f64>,
    tmp_eta: Vec<f64>,
    /// Physical→harmonic map of the modal part: for each block, (physical offset of modal coords).
    phys_modal: Vec<usize>,
    n_modes: Vec<usize>,
    modes_full: Vec<DMatrix<f64>>,
    masses: Vec<DMatrix<f64>>,
    /// The SIMD path of the per-step kernels, chosen at construction.
    isa: Isa,
}

impl ModalKernel {
    /// Builds the kernel for `st` with time step `h` (s); `h` is checked by the caller. Fails
    /// only if the eigenvectors of a complex harmonic cannot be paired (see `paired_modes`).
    /// Its SIMD path is [`Isa::selected`] at this call.
    pub fn new(st: &Structure, h: f64) -> Result<Self, StructureError> {
        let st = &*st.discretized(h);
        let ns = st.n_sectors;
        let nb = st.n_boundary;
        let mut planner = RealFftPlanner64::new();
        let r2c = planner.plan_fft_forward(ns);
        let c2r = planner.plan_fft_inverse(ns);
        let nspec = ns / 2 + 1;
        let mut blocks = Vec::new();
        let (mut omega2, mut c1, mut c2, mut inertial) = (vec![], vec![], vec![], vec![]);
        let half_h2 = 0.5 * h * h;
        let mut phys_modal = vec![];
        let mut n_modes = vec![];
        let mut modes_full = vec![];
        let mut masses = vec![];
        let nbp = nb.div_ceil(4) * 4;
        for b in &st.blocks {
            let PairedBasis {
                modes,
                omega: omegas,
                damping,
            } = if b.real {
                PairedBasis {
                    modes: b.modes.clone(),
                    omega: b.omega.clone(),
                    damping: b.damping_coef.clone(),
                }
            } else {
                paired_modes(b).map_err(|source| StructureError::Eigen {
                    name: st.name.clone(),
                    k: b.k,
                    source,
                })?
            };
            let rows = if b.real { nbp } else { 2 * nbp };
            let n = b.n;
            let mut phib = vec![0.0; rows * n];
            for p in 0..n {
                for r in 0..nb {
                    phib[p * rows + r] = modes[(r, p)];
                    if !b.real {
                        phib[p * rows + nbp + r] = modes[(b.n + r, p)];
                    }
                }
            }
            for p in 0..b.dim {
                let (w, c) = (omegas[p % n], damping[p % n]);
                let a = 1.0 / (h * h) + c / (2.0 * h);
                omega2.push(w * w);
                c1.push((2.0 / (h * h) - w * w) / a);
                c2.push(-(1.0 / (h * h) - c / (2.0 * h)) / a);
                inertial.push(if p % n < n - b.n_static { 1.0 } else { 0.0 });
            }
            blocks.push(Block {
                offset: b.offset,
                dim: b.dim,
                n,
                real: b.real,
                w: st.dft_weight(b.k),
                phib,
                chan: Vec::new(),
                rows,
            });
            phys_modal.push(st.physical_modal_offset(b.k));
            n_modes.push(b.n_modes);
            modes_full.push(modes);
            masses.push(b.mass.clone());
        }
        let n = st.n_modal;
        let n_blocks = blocks.len();
        let scratch_len = r2c.get_scratch_len().max(c2r.get_scratch_len());
        let dft_weights = sector_dft_weights(ns, &blocks);
        Ok(Self {
            ns,
            nb,
            h,
            blocks,
            omega2,
            c1,
            c2,
            inertial,
            half_h2,
            eta_prev: vec![0.0; n],
            eta: vec![0.0; n],
            eta_next: vec![0.0; n],
            gload: vec![0.0; n],
            inertial_load: vec![0.0; n],
            inertial_loaded: false,
            load_sum: vec![0.0; n],
            block_loaded: vec![false; n_blocks],
            ub: vec![0.0; ns * nb],
            r2c,
            c2r,
            spec: vec![0.0; 2 * nbp * nspec],
            spec_state: vec![0.0; 2 * nbp * nspec],
            fspec: vec![0.0; 2 * nbp * nspec],
            spec_pred: vec![0.0; 2 * nbp * nspec],
            pred_amplitude: None,
            descending: false,
            deta: vec![0.0; st.blocks.iter().map(|b| b.dim).max().unwrap_or(0)],
            tbuf: vec![0.0; ns],
            dft_weights,
            loaded: Vec::with_capacity(ns),
            fload: vec![0.0; DIRECT_DFT_SECTORS * nbp],
            fold: vec![0.0; 4 * nbp],
            cbuf: vec![Complex64::new(0.0, 0.0); nspec],
            spectra: vec![Complex64::new(0.0, 0.0); nb * nspec],
            scratch: vec![Complex64::new(0.0, 0.0); scratch_len],
            xb: vec![0.0; 2 * nbp],
            nbp,
            tmp_eta: vec![0.0; n],
            phys_modal,
            n_modes,
            modes_full,
            masses,
            isa: Isa::selected(),
        })
    }

    /// The SIMD path of the per-step kernels (fixed at construction).
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Static boundary displacements `K(Ω)⁻¹ f` (m) of boundary forces `f` (N, sector-major),
    /// through the modal decomposition (`η_p = φ_pᵀ f / ω_p²`). Fails if a mode with zero
    /// frequency is loaded.
    pub(crate) fn static_boundary(
        &mut self,
        forces: &[f64],
        out: &mut [f64],
    ) -> Result<(), String> {
        self.tmp_eta.iter_mut().for_each(|x| *x = 0.0);
        self.add_response(forces, Which::Tmp);
        let h2 = self.half_h2;
        let gmax = self
            .tmp_eta
            .iter()
            .zip(&self.c2)
            .fold(0.0f64, |m, (t, &c2)| m.max((t / c3_of(c2, h2)).abs()));
        for i in 0..self.tmp_eta.len() {
            let g = self.tmp_eta[i] / c3_of(self.c2[i], h2);
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
    #[cfg(test)]
    pub(crate) fn modal_coordinates(&self) -> &[f64] {
        &self.eta
    }

    /// Contact-node displacements (sector-major) of modal coordinates `which` into `out`, or the
    /// per-step channels into `ub` with `out_is_ub` (keeping the harmonic rows in `spec_state` for the
    /// next correction).
    fn boundary_of(&mut self, which: Which, out_is_ub: bool, out: &mut [f64]) {
        let eta: &[f64] = match which {
            Which::Next => &self.eta_next,
            Which::Current => &self.eta,
            Which::Tmp => &self.tmp_eta,
        };
        let spec = if out_is_ub {
            &mut self.spec_state
        } else {
            &mut self.spec
        };
        let stride = 2 * self.nbp;
        for (k, b) in self.blocks.iter().enumerate() {
            let basis = if out_is_ub { b.step_basis() } else { &b.phib };
            let x = &mut spec[k * stride..k * stride + b.rows];
            expand(self.isa, b, basis, &eta[b.offset..b.offset + b.dim], x);
        }
        if out_is_ub {
            self.rows_to_boundary(true, &mut []);
        } else {
            self.rows_to_boundary(false, out);
        }
    }

    /// Inverse real DFT of every boundary channel of the harmonic rows `spec_state` (into `ub`)
    /// or `spec` (into `out`): `u_s = Σ_k w_k (a_k cos kθ_s + b_k sin kθ_s)` (module doc of
    /// `structure`). Up to [`DIRECT_SYNTH_SECTORS`] sectors the sums are taken directly,
    /// folded by symmetry ([`ModalKernel::folded_rows_to_boundary`]); otherwise one
    /// inverse real FFT per channel, harmonic k entering its spectrum as `w a` (real
    /// harmonic) or `w (a − i b)/2`.
    fn rows_to_boundary(&mut self, state: bool, out: &mut [f64]) {
        if self.ns <= DIRECT_SYNTH_SECTORS {
            simd::compiled_for(self.isa, |isa| {
                self.folded_rows_to_boundary(isa, state, out);
            });
            return;
        }
        let (nb, nbp) = (self.nb, self.nbp);
        let (rows, target): (&[f64], &mut [f64]) = if state {
            (&self.spec_state, &mut self.ub)
        } else {
            (&self.spec, out)
        };
        // All channels' spectra first, harmonic by harmonic: contiguous reads of the rows.
        let nspec = self.cbuf.len();
        for (k, (b, x)) in self
            .blocks
            .iter()
            .zip(rows.chunks_exact(2 * nbp))
            .enumerate()
        {
            let spectra = self.spectra.iter_mut().skip(k).step_by(nspec);
            if b.real {
                for (c, a) in spectra.zip(&x[..nb]) {
                    *c = Complex64::new(b.w * a, 0.0);
                }
            } else {
                let (wa, wb) = (0.5 * b.w, -0.5 * b.w);
                for (c, (a, bb)) in spectra.zip(x[..nb].iter().zip(&x[nbp..nbp + nb])) {
                    *c = Complex64::new(wa * a, wb * bb);
                }
            }
        }
        for (r, spectrum) in self.spectra.chunks_exact_mut(nspec).enumerate() {
            self.c2r
                .process_with_scratch(spectrum, &mut self.tbuf, &mut self.scratch)
                .expect("FFT buffer sizes are fixed at construction");
            for (u, t) in target.chunks_exact_mut(nb).zip(&self.tbuf) {
                u[r] = *t;
            }
        }
    }

    /// [`ModalKernel::rows_to_boundary`] as direct sums folded by the symmetries of the
    /// weights: sector N − s has the cosines of sector s and the opposite sines, and sector
    /// N/2 − s (N even) the cosines times (−1)^k and the sines times −(−1)^k. So per sector
    /// s ≤ N/4 four partial sums over the harmonics, `E± = Σ_{k even/odd} c_k a_k` and
    /// `O± = Σ_{k even/odd} s_k b_k`, give four sectors:
    /// `u_s = E + O`, `u_{N−s} = E − O` (`E = E₊ + E₋`, `O = O₊ + O₋`),
    /// `u_{N/2−s} = E' − O'`, `u_{N/2+s} = E' + O'` (`E' = E₊ − E₋`, `O' = O₊ − O₋`);
    /// for odd N only the first fold applies (sectors s ≤ N/2). A quarter of the products
    /// of the plain sums; the sums of a band of up to 16 rows stay in registers
    /// ([`simd::fold_sums`], [`simd::store_folded`]).
    #[inline(always)]
    fn folded_rows_to_boundary(&mut self, isa: Isa, state: bool, out: &mut [f64]) {
        let (nb, nbp, ns) = (self.nb, self.nbp, self.ns);
        let nh = self.blocks.len();
        let (rows, target): (&[f64], &mut [f64]) = if state {
            (&self.spec_state, &mut self.ub)
        } else {
            (&self.spec, out)
        };
        let even = ns.is_multiple_of(2);
        // Parity classes of the harmonics summed apart: both when N is even, all at once if not.
        let (last, stride) = if even { (ns / 4, 2) } else { (ns / 2, 1) };
        let (e, rest) = self.fold.split_at_mut(nbp);
        let (o, rest) = rest.split_at_mut(nbp);
        let (e_odd, o_odd) = rest.split_at_mut(nbp);
        for s in 0..=last {
            let w = &self.dft_weights[s * nh..(s + 1) * nh];
            simd::fold_sums(isa, w, rows, nbp, 0, stride, e, o);
            if even {
                simd::fold_sums(isa, w, rows, nbp, 1, stride, e_odd, o_odd);
            }
            let sums = [&*e, &*o, &*e_odd, &*o_odd];
            simd::store_folded(isa, target, nb, sums, s, even.then_some(ns / 2));
        }
    }

    /// Forward real DFT of every boundary channel of the sector-major `forces` into the
    /// harmonic rows `fspec`: `X_k = Σ_s f_s e^{−ikθ_s}` gives `a = w Re X_k`, `b = −w Im X_k`.
    /// Contact loads sit on a few sectors (a patch spans four), so up to
    /// [`DIRECT_DFT_SECTORS`] loaded sectors are summed directly, which costs far less than one
    /// FFT per channel; otherwise one real FFT per loaded channel.
    fn forces_to_rows(&mut self, forces: &[f64]) {
        let (nb, nbp, ns) = (self.nb, self.nbp, self.ns);
        self.loaded.clear();
        for (s, f) in forces.chunks_exact(nb).enumerate() {
            // Any nonzero entry, ±0 alike (an OR of the bits without the sign vectorises).
            if f.iter().fold(0u64, |acc, x| acc | (x.to_bits() << 1)) != 0 {
                self.loaded.push(s);
            }
        }
        if self.loaded.len() <= DIRECT_DFT_SECTORS {
            // Rows nb..nbp of `fload` stay zero from construction.
            for (fl, &s) in self.fload.chunks_exact_mut(nbp).zip(&self.loaded) {
                fl[..nb].copy_from_slice(&forces[s * nb..(s + 1) * nb]);
            }
            let (weights, nh) = (&self.dft_weights, self.blocks.len());
            simd::dft_rows(
                self.isa,
                weights,
                nh,
                &self.loaded,
                &self.fload,
                nbp,
                &mut self.fspec,
            );
            return;
        }
        for r in 0..nb {
            let mut any = false;
            for s in 0..ns {
                let f = forces[s * nb + r];
                any |= f != 0.0;
                self.tbuf[s] = f;
            }
            let rows = self.fspec.chunks_exact_mut(2 * nbp).zip(&self.blocks);
            if !any {
                for (x, _) in rows {
                    x[r] = 0.0;
                    x[nbp + r] = 0.0;
                }
                continue;
            }
            self.r2c
                .process_with_scratch(&mut self.tbuf, &mut self.cbuf, &mut self.scratch)
                .expect("FFT buffer sizes are fixed at construction");
            for ((x, b), f) in rows.zip(&self.cbuf) {
                x[r] = b.w * f.re;
                x[nbp + r] = if b.real { 0.0 } else { -b.w * f.im };
            }
        }
    }

    /// Fused `A⁻¹ f` of the force rows in `fspec`, one nodal diameter at a time:
    /// `Δη = diag(1/a) Φ_bᵀ F_k`, then `ΔU_k = Φ_b Δη` while Φ_b is hot in cache. `target`
    /// says where the increment goes (see [`ForceTarget`]). With `next = Some(a)` (and a state
    /// target), the predictor of the following step with load amplitude `a` is formed in the
    /// same pass, into `eta_prev` (η_{n−1} is no longer needed) and `spec_pred`, so that a
    /// contact step reads each basis once from memory. The harmonics are independent:
    /// successive passes take them in opposite orders (see `descending`), with the same
    /// results.
    fn apply_force_spectrum(&mut self, target: ForceTarget, next: Option<f64>) {
        // Compiled for the kernel's path: the per-mode loops (scaling, accumulation, the
        // predictor recurrence) vectorise with it. Same arithmetic on every path: Rust does
        // not contract `a * b + c` into FMAs.
        simd::compiled_for(self.isa, |isa| {
            self.apply_force_spectrum_impl(isa, target, next);
        });
    }

    #[inline(always)]
    fn apply_force_spectrum_impl(&mut self, isa: Isa, target: ForceTarget, next: Option<f64>) {
        let stride = 2 * self.nbp;
        let nh = self.blocks.len();
        self.descending = !self.descending;
        let inertial = match next {
            Some(a) if self.inertial_loaded => {
                self.sum_loads(a);
                true
            }
            _ => false,
        };
        for i in 0..nh {
            let k = if self.descending { nh - 1 - i } else { i };
            let b = &self.blocks[k];
            let chunk = k * stride..k * stride + b.rows;
            let xb = &mut self.xb[..b.rows];
            let r = b.offset..b.offset + b.dim;
            let deta = &mut self.deta[..b.dim];
            project(isa, b, b.step_basis(), &self.fspec[chunk.clone()], deta);
            match target {
                ForceTarget::Response => {
                    for (x, &c2) in deta.iter_mut().zip(&self.c2[r]) {
                        *x *= c3_of(c2, self.half_h2);
                    }
                    expand(isa, b, b.step_basis(), deta, &mut self.spec[chunk]);
                }
                ForceTarget::State { channels } => {
                    let coefs = [&self.c1[r.clone()], &self.c2[r.clone()]];
                    let load = if inertial {
                        Some((&self.load_sum[r.clone()], 1.0))
                    } else {
                        next.filter(|&a| a != 0.0 && self.block_loaded[k])
                            .map(|a| (&self.gload[r.clone()], a))
                    };
                    let pred = next.map(|_| &mut self.eta_prev[r.clone()]);
                    let past = (&self.eta[r.clone()], load);
                    correct_modes(deta, &mut self.eta_next[r], coefs, self.half_h2, past, pred);
                    if channels {
                        expand(isa, b, b.step_basis(), deta, xb);
                        add_to(&mut self.spec_state[chunk.clone()], xb);
                    }
                    if next.is_some() {
                        let pred = &self.eta_prev[b.offset..b.offset + b.dim];
                        expand(isa, b, b.step_basis(), pred, &mut self.spec_pred[chunk]);
                    }
                }
            }
        }
        self.pred_amplitude = next;
    }

    /// The load of a predictor with pattern amplitude `a` and the inertial load, into
    /// `load_sum` (read with amplitude 1).
    fn sum_loads(&mut self, a: f64) {
        let loads = self.gload.iter().zip(&self.inertial_load);
        for (s, (g, h)) in self.load_sum.iter_mut().zip(loads) {
            *s = a * g + h;
        }
    }

    /// The inertial load has been read by the predictor of its step.
    fn use_up_inertial_load(&mut self) {
        if self.inertial_loaded {
            self.inertial_load.fill(0.0);
            self.inertial_loaded = false;
        }
    }

    /// Modal forces `Φᵀ P f` of boundary forces `f` (sector-major), scaled by `1/a_p`, added to `dst`.
    fn add_response(&mut self, forces: &[f64], dst: Which) {
        let stride = 2 * self.nbp;
        self.forces_to_rows(forces);
        let eta: &mut [f64] = match dst {
            Which::Next => &mut self.eta_next,
            Which::Current => &mut self.eta,
            Which::Tmp => &mut self.tmp_eta,
        };
        for (k, b) in self.blocks.iter().enumerate() {
            let g = &mut self.deta[..b.dim];
            let x = &self.fspec[k * stride..k * stride + b.rows];
            project(self.isa, b, &b.phib, x, g);
            for p in 0..b.dim {
                eta[b.offset + p] += c3_of(self.c2[b.offset + p], self.half_h2) * g[p];
            }
        }
    }

    /// Folds the casing spline into the kernel (eq. 13 per nodal diameter): the per-step
    /// channels become the control points `Q[c][k]`, rows `k = 1..=M`, of each column class
    /// `cl = c − 1` in the frame rotated by `cl·α` (the ghost rows and wrap columns follow
    /// from eqs. 10–11), and [`StructureKernel::correct`] takes forces on those control
    /// points. `B` is rotation-equivariant, so in sector-local frames it is block circulant
    /// over sectors and acts per nodal diameter as one `3M × 3M` complex matrix `Ĥ_k`; the
    /// stored bases become `Ĥ_k Φ_b,k`. A step then costs what a contact-node step costs and
    /// the global spline solve disappears. Requires `3M` boundary DOFs per sector.
    pub(crate) fn fold_spline(&mut self, spline: &CasingSpline) -> Result<(), String> {
        let (ns, nb) = (self.ns, self.nb);
        let m = spline.nodes_per_sector();
        if spline.n_sectors() != ns || 3 * m != nb {
            return Err(format!(
                "spline of {} × {} nodes does not match a kernel of {ns} sectors × {nb} boundary DOFs",
                spline.n_sectors(),
                m
            ));
        }
        let hk = surface_harmonics(spline).map_err(|e| e.to_string())?;
        let nbp = self.nbp;
        for (k, b) in self.blocks.iter_mut().enumerate() {
            let h = &hk[k];
            let mut chan = vec![0.0; b.phib.len()];
            for p in 0..b.n {
                let col = &b.phib[p * b.rows..(p + 1) * b.rows];
                let out = &mut chan[p * b.rows..(p + 1) * b.rows];
                for r in 0..nb {
                    let mut z = Complex64::new(0.0, 0.0);
                    for c in 0..nb {
                        let v = if b.real {
                            Complex64::new(col[c], 0.0)
                        } else {
                            Complex64::new(col[c], -col[nbp + c])
                        };
                        z += h[(r, c)] * v;
                    }
                    out[r] = z.re;
                    if !b.real {
                        out[nbp + r] = -z.im;
                    }
                }
            }
            b.chan = chan;
        }
        Ok(())
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

/// `x += d`, elementwise (a per-mode loop of the kernel, on slices of one length).
#[inline(always)]
fn add_to(x: &mut [f64], d: &[f64]) {
    x.iter_mut().zip(d).for_each(|(x, d)| *x += d);
}

/// `c₃ = 1/a = (1 − c₂) h²/2` of a mode from its `c₂` (`half_h2` = h²/2): with
/// `a = 1/h² + c/2h`, `c₂ = −(1/h² − c/2h)/a = 1 − 2/(h² a)`. Plain operations (never
/// contracted into an FMA, which would be a libm call on a CPU without one), so the same
/// bits wherever and however the kernel is compiled.
#[inline(always)]
fn c3_of(c2: f64, half_h2: f64) -> f64 {
    (1.0 - c2) * half_h2
}

/// Central-difference predictor per mode: `η_{n+1} = c₁ η_n + c₂ η_{n−1} + c₃ a g` with
/// `[c₁, c₂]`, `c₃` by [`c3_of`], `[η_n, η_{n−1}]` and `load = (g, a)` (`g`: the modal load
/// pattern, `a` its amplitude). Without load (`None`, as after the release) the load term is
/// not read.
#[inline(always)]
fn predictor(
    out: &mut [f64],
    [c1, c2]: [&[f64]; 2],
    half_h2: f64,
    [e1, e0]: [&[f64]; 2],
    load: Option<(&[f64], f64)>,
) {
    let n = out.len();
    let (c1, c2, e1, e0) = (&c1[..n], &c2[..n], &e1[..n], &e0[..n]);
    match load {
        None => {
            for i in 0..n {
                out[i] = c1[i] * e1[i] + c2[i] * e0[i];
            }
        }
        Some((g, a)) => {
            let g = &g[..n];
            for i in 0..n {
                out[i] = c1[i] * e1[i] + c2[i] * e0[i] + c3_of(c2[i], half_h2) * a * g[i];
            }
        }
    }
}

/// The correction of one block's modes by their projected forces `g` (`Φ_bᵀ F`), in one
/// pass: `Δη = c₃ g` (into `g`), `η_{n+1} += Δη`, and with `pred` the predictor of the
/// following step from the corrected state, `pred = c₁ η_{n+1} + c₂ η_n + c₃ a g_load`
/// (the arithmetic of [`predictor`]), with `past = (η_n, load)` and `load = (g_load, a)`.
#[inline(always)]
fn correct_modes(
    g: &mut [f64],
    eta_next: &mut [f64],
    [c1, c2]: [&[f64]; 2],
    half_h2: f64,
    (e0, load): (&[f64], Option<(&[f64], f64)>),
    pred: Option<&mut [f64]>,
) {
    let n = g.len();
    let (eta_next, c1, c2, e0) = (&mut eta_next[..n], &c1[..n], &c2[..n], &e0[..n]);
    match (pred, load) {
        (None, _) => {
            for i in 0..n {
                g[i] *= c3_of(c2[i], half_h2);
                eta_next[i] += g[i];
            }
        }
        (Some(pred), None) => {
            let pred = &mut pred[..n];
            for i in 0..n {
                g[i] *= c3_of(c2[i], half_h2);
                eta_next[i] += g[i];
                pred[i] = c1[i] * eta_next[i] + c2[i] * e0[i];
            }
        }
        (Some(pred), Some((gl, a))) => {
            let (pred, gl) = (&mut pred[..n], &gl[..n]);
            for i in 0..n {
                let c3 = c3_of(c2[i], half_h2);
                g[i] *= c3;
                eta_next[i] += g[i];
                pred[i] = c1[i] * eta_next[i] + c2[i] * e0[i] + c3 * a * gl[i];
            }
        }
    }
}

/// Boundary rows `x = Φ_b η` of one harmonic from the stored half basis `basis`: `x = V η₁ + J V η₂`
/// with `J [a; b] = [−b; a]` (complex harmonic, `η = [η₁; η₂]`), or `x = V η` (real harmonic).
#[inline(always)]
fn expand(isa: Isa, b: &Block, basis: &[f64], eta: &[f64], x: &mut [f64]) {
    if b.real {
        simd::expand::<false>(isa, basis, b.rows, &eta[..b.n], x);
    } else {
        simd::expand::<true>(isa, basis, b.rows / 2, &eta[..2 * b.n], x);
    }
}

/// Modal projection `g = Φ_bᵀ x` of one harmonic's boundary rows: `g₁ = Vᵀ x` and
/// `g₂ = (J V)ᵀ x = Vᵀ [x_b; −x_a]`.
#[inline(always)]
fn project(isa: Isa, b: &Block, basis: &[f64], x: &[f64], g: &mut [f64]) {
    if b.real {
        simd::project::<false>(isa, basis, b.rows, x, &mut g[..b.n]);
    } else {
        simd::project::<true>(isa, basis, b.rows / 2, x, &mut g[..2 * b.n]);
    }
}

/// The real DFT weights `(w_k cos kθ_s, w_k sin kθ_s)` of N sectors and the harmonic
/// `blocks` k = 0..=N/2, at `s·(N/2 + 1) + k`, the sine 0 for a real harmonic. The angles
/// are reduced to `2πm/N`, m = ks mod N ≤ N/2, so that the table has the exact symmetries
/// the folded inverse DFT relies on, and exact zeros at the quarter turns.
fn sector_dft_weights(ns: usize, blocks: &[Block]) -> Vec<(f64, f64)> {
    let unit = |m: usize| -> (f64, f64) {
        let (m, sign) = if 2 * m > ns { (ns - m, -1.0) } else { (m, 1.0) };
        let (c, s) = if m == 0 {
            (1.0, 0.0)
        } else if 2 * m == ns {
            (-1.0, 0.0)
        } else if 4 * m == ns {
            (0.0, 1.0)
        } else {
            let t = std::f64::consts::TAU * m as f64 / ns as f64;
            (t.cos(), t.sin())
        };
        (c, sign * s)
    };
    let mut w = Vec::with_capacity(ns * blocks.len());
    for s in 0..ns {
        for (k, b) in blocks.iter().enumerate() {
            let (c, sn) = unit(k * s % ns);
            w.push((b.w * c, if b.real { 0.0 } else { b.w * sn }));
        }
    }
    w
}

/// `Ĥ_k = Σ_m H(m) e^{−ikmα}`, k = 0..=N/2: the spline map from the contact-node
/// displacements of sector `i` (its local frame) to the control points `Q[c][1..=M]` of class
/// `cl = c − 1` (frame rotated by `cl·α`), `H(cl − i)`, probed column by column on sector 0.
fn surface_harmonics(
    spline: &CasingSpline,
) -> Result<Vec<nalgebra::DMatrix<Complex64>>, crate::contact::SplineError> {
    let (ns, m) = (spline.n_sectors(), spline.nodes_per_sector());
    let nb = 3 * m;
    let alpha = 2.0 * std::f64::consts::PI / ns as f64;
    let mut disp = vec![nalgebra::Vector3::zeros(); ns * m];
    let mut dq = vec![nalgebra::Vector3::zeros(); spline.n_control()];
    // h[cl][(row, col)] = H(cl).
    let mut h = vec![DMatrix::<f64>::zeros(nb, nb); ns];
    for j in 0..m {
        for d in 0..3 {
            disp.iter_mut()
                .for_each(|x| *x = nalgebra::Vector3::zeros());
            disp[j][d] = 1.0;
            spline.control_points(&disp, &mut dq)?;
            for (cl, hc) in h.iter_mut().enumerate() {
                let rt = crate::model::cyclic::rot_z(cl as f64 * alpha).transpose();
                for r in 0..m {
                    let v = rt * dq[spline.control_index(cl + 1, r + 1)];
                    for e in 0..3 {
                        hc[(3 * r + e, 3 * j + d)] = v[e];
                    }
                }
            }
        }
    }
    Ok((0..=ns / 2)
        .map(|k| {
            let mut hk = nalgebra::DMatrix::<Complex64>::zeros(nb, nb);
            for (cl, hc) in h.iter().enumerate() {
                let ph = Complex64::from_polar(1.0, -(((k * cl) % ns) as f64) * alpha);
                hk.zip_apply(hc, |a, b| *a += ph * b);
            }
            hk
        })
        .collect())
}

/// The re-paired eigenbasis of a complex harmonic (see `paired_modes`).
#[derive(Clone)]
struct PairedBasis {
    /// `[v_1 … v_n, Jv_1 … Jv_n]`, M-orthonormal.
    modes: DMatrix<f64>,
    /// ω_p (rad/s) and damping coefficient c_p (1/s) of pair p.
    omega: Vec<f64>,
    damping: Vec<f64>,
}

/// Re-pairs the eigenvectors of a complex harmonic's real form.
///
/// The real form `[[A, B], [−B, A]]` of a Hermitian matrix commutes with
/// `J = [[0, −I], [I, 0]]`, so every eigenspace is `J`-invariant and, `MJ` being
/// antisymmetric, `v ⟂_M Jv`. An M-orthonormal eigenbasis can therefore be chosen as
/// `[v_1 … v_n, Jv_1 … Jv_n]`: the fast kernel then stores only the `v_p` (half the memory
/// traffic per step) and gets `Jv_p` by a swap of halves. Eigenvalue clusters are re-orthonormalised
/// (Gram–Schmidt in the M inner product); the frequency and damping of each pair are its Rayleigh
/// quotients `vᵀKv`, `vᵀDv`.
fn paired_modes(b: &NdBlock) -> Result<PairedBasis, EigenError> {
    let (n, dim) = (b.n, b.dim);
    let j_of = |v: &DVector<f64>| {
        let mut w = DVector::zeros(dim);
        for r in 0..n {
            w[r] = -v[n + r];
            w[n + r] = v[r];
        }
        w
    };
    // The scale of the dynamic modes' eigenvalues (static modes, all at 2/h², come last).
    let lmax = (b.omega[..b.first_static()].iter())
        .fold(0.0f64, |m, w| m.max(w * w))
        .max(1.0);
    let tol = 1e-9 * lmax;
    let mut chosen: Vec<DVector<f64>> = Vec::with_capacity(n);
    // `M v` and `M J v` of each chosen vector: the projections read them instead of `M x`
    // of each candidate after each subtraction (the static modes of a massless boundary are
    // one cluster of `2 · 3n_c` equal eigenvalues, where that was most of a kernel's build).
    let mut mass_chosen: Vec<(DVector<f64>, DVector<f64>)> = Vec::with_capacity(n);
    let mut start = 0;
    while start < dim {
        // A cluster of (numerically) equal eigenvalues, of even size.
        let mut end = start + 1;
        while end < dim
            && ((end - start) % 2 == 1
                || (b.omega[end].powi(2) - b.omega[end - 1].powi(2)).abs() <= tol)
        {
            end += 1;
        }
        let first = chosen.len();
        for c in start..end {
            if 2 * (chosen.len() - first) == end - start {
                break;
            }
            let mut x = b.modes.column(c).into_owned();
            for _ in 0..2 {
                for (v, (mv, mjv)) in chosen[first..].iter().zip(&mass_chosen[first..]) {
                    x -= v * mv.dot(&x);
                    x -= j_of(v) * mjv.dot(&x);
                }
            }
            let mx = &b.mass * &x;
            let norm = x.dot(&mx).max(0.0).sqrt();
            if norm > 0.5 {
                let v = x / norm;
                let mjv = &b.mass * j_of(&v);
                mass_chosen.push((mx / norm, mjv));
                chosen.push(v);
            }
        }
        if 2 * (chosen.len() - first) != end - start {
            return Err(EigenError::NotPaired { start, end });
        }
        start = end;
    }
    let mut modes = DMatrix::zeros(dim, dim);
    let (mut om, mut damp) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for (p, v) in chosen.iter().enumerate() {
        modes.column_mut(p).copy_from(v);
        modes.column_mut(n + p).copy_from(&j_of(v));
        om.push(v.dot(&(&b.stiffness * v)).max(0.0).sqrt());
        damp.push(v.dot(&(&b.damping * v)));
    }
    Ok(PairedBasis {
        modes,
        omega: om,
        damping: damp,
    })
}

#[derive(Clone, Copy)]
enum Which {
    Next,
    Current,
    Tmp,
}

/// Most loaded sectors for which [`ModalKernel::forces_to_rows`] sums the DFT directly
/// (`(N/2 + 1)·S·2nb` products against `nb` real FFTs of length N).
const DIRECT_DFT_SECTORS: usize = 24;

/// Most sectors for which [`ModalKernel::rows_to_boundary`] sums the inverse DFT directly,
/// folded: about `(N/4 + 1)(N/2 + 1)·2nb` products against `nb` real FFTs of length N with
/// their packing, which grow as N log N and cost less from a few hundred sectors on.
const DIRECT_SYNTH_SECTORS: usize = 256;

/// Relative size (to the largest modal load) below which a harmonic's modal load pattern is
/// round-off of the sector DFT and taken as zero (see `set_load_pattern`).
const LOAD_ROUND_OFF: f64 = 1e-13;

/// Where [`ModalKernel::apply_force_spectrum`] puts `A⁻¹ f`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ForceTarget {
    /// The channels of the response alone, into `spec` (no change of state).
    Response,
    /// Added to `η_{n+1}`, and with `channels` to its harmonic rows `spec_state`.
    State { channels: bool },
}

impl StructureKernel for ModalKernel {
    fn n_sectors(&self) -> usize {
        self.ns
    }
    fn n_boundary(&self) -> usize {
        self.nb
    }
    fn set_load_pattern(&mut self, pattern: &[f64]) {
        self.pred_amplitude = None;
        // g = Φᵀ P f: reuse the response path with c3 divided out.
        self.tmp_eta.iter_mut().for_each(|x| *x = 0.0);
        self.add_response(pattern, Which::Tmp);
        for (g, (t, &c2)) in self.gload.iter_mut().zip(self.tmp_eta.iter().zip(&self.c2)) {
            *g = t / c3_of(c2, self.half_h2);
        }
        // A harmonic the pattern does not load gets round-off from the sector DFT (a lobed
        // load is one harmonic): flushed to zero, so that the step skips its load term.
        let peak = self.gload.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        for (b, loaded) in self.blocks.iter().zip(&mut self.block_loaded) {
            let g = &mut self.gload[b.offset..b.offset + b.dim];
            *loaded = g.iter().any(|x| x.abs() > LOAD_ROUND_OFF * peak);
            if !*loaded {
                g.fill(0.0);
            }
        }
    }
    fn set_initial_velocity(&mut self, velocity: &[f64]) {
        self.pred_amplitude = None;
        let mut v = vec![0.0; self.eta.len()];
        self.physical_to_modal(velocity, &mut v);
        self.eta.iter_mut().for_each(|x| *x = 0.0);
        for (p, vp) in self.eta_prev.iter_mut().zip(&v) {
            *p = -self.h * vp;
        }
    }
    fn predict(&mut self, amplitude: f64) {
        if self.pred_amplitude.take() == Some(amplitude) {
            // Formed by the last correct_then_predict, from the same η_n, η_{n−1}; `advance`
            // has rotated its modal coordinates into `eta_next`.
            std::mem::swap(&mut self.spec_state, &mut self.spec_pred);
            self.rows_to_boundary(true, &mut []);
            self.use_up_inertial_load();
            return;
        }
        let load = if self.inertial_loaded {
            self.sum_loads(amplitude);
            Some((&self.load_sum[..], 1.0))
        } else {
            (amplitude != 0.0).then_some((&self.gload[..], amplitude))
        };
        predictor(
            &mut self.eta_next,
            [&self.c1, &self.c2],
            self.half_h2,
            [&self.eta, &self.eta_prev],
            load,
        );
        self.use_up_inertial_load();
        self.boundary_of(Which::Next, true, &mut []);
    }
    fn boundary(&self) -> &[f64] {
        &self.ub
    }
    fn add_inertial_load(&mut self, forces: &[f64]) {
        // A predictor formed before this load would miss it: `predict` forms it again.
        self.pred_amplitude = None;
        self.forces_to_rows(forces);
        let stride = 2 * self.nbp;
        for (k, b) in self.blocks.iter().enumerate() {
            let g = &mut self.deta[..b.dim];
            project(self.isa, b, b.step_basis(), &self.fspec[k * stride..], g);
            let r = b.offset..b.offset + b.dim;
            let (dst, w) = (&mut self.inertial_load[r.clone()], &self.inertial[r]);
            for ((x, g), w) in dst.iter_mut().zip(g.iter()).zip(w) {
                *x += w * g;
            }
        }
        self.inertial_loaded = true;
    }
    fn correct(&mut self, forces: &[f64]) {
        self.forces_to_rows(forces);
        self.apply_force_spectrum(ForceTarget::State { channels: true }, None);
        self.rows_to_boundary(true, &mut []);
    }
    fn correct_then_predict(&mut self, forces: &[f64], next_amplitude: f64) {
        self.forces_to_rows(forces);
        self.apply_force_spectrum(ForceTarget::State { channels: true }, Some(next_amplitude));
        self.rows_to_boundary(true, &mut []);
    }
    fn correct_state_then_predict(&mut self, forces: &[f64], next_amplitude: f64) {
        self.forces_to_rows(forces);
        self.apply_force_spectrum(ForceTarget::State { channels: false }, Some(next_amplitude));
    }
    fn response(&mut self, forces: &[f64], out: &mut [f64]) {
        self.forces_to_rows(forces);
        self.apply_force_spectrum(ForceTarget::Response, None);
        self.rows_to_boundary(false, out);
    }
    fn advance(&mut self) {
        // (η_{n−1}, η_n, η_{n+1}) → (η_n, η_{n+1}, η_{n−1}): the last slot is rewritten by the
        // next predictor, or already holds it after a fused correction.
        std::mem::swap(&mut self.eta_prev, &mut self.eta);
        std::mem::swap(&mut self.eta, &mut self.eta_next);
    }
    fn energies(&self) -> Energies {
        // Four lanes of partial sums in a fixed order, deterministic: whole chunks of four as
        // arrays (so the loop is vectorised), then the tail into the first lanes.
        // A static mode (weight 0) adds no kinetic energy and `ω² η_n²`; the products by the
        // weights 1 and 0 are exact, so a structure without static modes keeps its bits.
        let (mut kinetic, mut strain) = ([0.0f64; 4], [0.0f64; 4]);
        let mut add = |eta: &[f64], prev: &[f64], omega2: &[f64], weight: &[f64]| {
            for j in 0..eta.len() {
                let d = eta[j] - prev[j];
                kinetic[j] += weight[j] * (d * d);
                let lagged = weight[j] * prev[j] + (1.0 - weight[j]) * eta[j];
                strain[j] += omega2[j] * eta[j] * lagged;
            }
        };
        let (eta, eta_tail) = self.eta.as_chunks::<4>();
        let (prev, prev_tail) = self.eta_prev.as_chunks::<4>();
        let (omega2, omega2_tail) = self.omega2.as_chunks::<4>();
        let (weight, weight_tail) = self.inertial.as_chunks::<4>();
        for (((e, p), w), m) in eta.iter().zip(prev).zip(omega2).zip(weight) {
            add(e, p, w, m);
        }
        add(eta_tail, prev_tail, omega2_tail, weight_tail);
        let sum = |x: [f64; 4]| (x[0] + x[1]) + (x[2] + x[3]);
        Energies {
            kinetic: 0.5 * sum(kinetic) / (self.h * self.h),
            strain: 0.5 * sum(strain),
        }
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
    fn map_to_surface(&mut self, spline: &CasingSpline) -> Result<bool, String> {
        self.fold_spline(spline).map(|()| true)
    }
    fn node_displacements(&mut self, out: &mut [f64]) {
        self.boundary_of(Which::Current, false, out);
    }
    fn boundary_functional(&mut self, weights: &[f64]) -> Vec<f64> {
        // u = S Φ_b η with S the inverse sector DFT, so wᵀ u = (Φ_bᵀ Sᵀ w)ᵀ η, and Sᵀ is the
        // forward DFT of a load (`forces_to_rows`).
        let stride = 2 * self.nbp;
        self.forces_to_rows(weights);
        let mut g = vec![0.0; self.eta.len()];
        for (k, b) in self.blocks.iter().enumerate() {
            let x = &self.fspec[k * stride..k * stride + b.rows];
            project(self.isa, b, &b.phib, x, &mut g[b.offset..b.offset + b.dim]);
        }
        g
    }
    fn functional_value(&self, functional: &[f64]) -> f64 {
        // Read on every step over the whole modal state: eight lanes of partial sums in a fixed
        // order (deterministic, and the compiler vectorises them), then the tail.
        let (g, g_tail) = functional.as_chunks::<8>();
        let (eta, eta_tail) = self.eta[..functional.len()].as_chunks::<8>();
        let mut lanes = [0.0f64; 8];
        for (g, e) in g.iter().zip(eta) {
            for l in 0..8 {
                lanes[l] += g[l] * e[l];
            }
        }
        let tail: f64 = g_tail.iter().zip(eta_tail).map(|(g, e)| g * e).sum();
        let quads = [0, 2, 4, 6].map(|l| lanes[l] + lanes[l + 1]);
        (quads[0] + quads[1]) + (quads[2] + quads[3]) + tail
    }
    fn harmonic_state(&self, out: &mut [f64]) {
        // x_k = Φ_k η_k: the basis is M-orthonormal (see `physical_to_modal`).
        for (b, modes) in self.blocks.iter().zip(&self.modes_full) {
            let eta = &self.eta[b.offset..b.offset + b.dim];
            for (i, o) in out[b.offset..b.offset + b.dim].iter_mut().enumerate() {
                *o = (0..b.dim).map(|j| modes[(i, j)] * eta[j]).sum();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The harmonic rows of a load equal the naive real DFT `a_k = w Σ_s cos(kθ_s) f_s`,
    /// `b_k = w Σ_s sin(kθ_s) f_s`, for a load on three sectors (direct sums) and on every
    /// sector (FFTs).
    #[test]
    fn force_rows_equal_the_naive_dft() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let ns = 40;
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, ns, 3, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let mut k = ModalKernel::new(&st, 0.3 * st.stability_limit()).unwrap();
        let (nb, nbp) = (k.nb, k.nbp);
        let mut rng = crate::fixtures::Lcg(5);
        for loaded in [vec![3, 4, 27], (0..ns).collect::<Vec<_>>()] {
            assert_eq!(loaded.len() <= DIRECT_DFT_SECTORS, loaded.len() == 3);
            let mut f = vec![0.0; ns * nb];
            for &s in &loaded {
                f[s * nb..(s + 1) * nb]
                    .iter_mut()
                    .for_each(|x| *x = rng.next());
            }
            k.forces_to_rows(&f);
            for (kk, b) in k.blocks.iter().enumerate() {
                for r in 0..nb {
                    let (mut a, mut bs) = (0.0, 0.0);
                    for s in 0..ns {
                        let t = std::f64::consts::TAU * (kk * s) as f64 / ns as f64;
                        a += b.w * t.cos() * f[s * nb + r];
                        bs += if b.real {
                            0.0
                        } else {
                            b.w * t.sin() * f[s * nb + r]
                        };
                    }
                    let x = &k.fspec[kk * 2 * nbp..];
                    assert!((x[r] - a).abs() < 1e-13, "k {kk} row {r}: {} vs {a}", x[r]);
                    assert!((x[nbp + r] - bs).abs() < 1e-13, "k {kk} row {r}");
                }
            }
        }
    }

    /// The inverse of the above, `rows_to_boundary`, against the naive sums
    /// `u_s = Σ_k w_k (a_k cos kθ_s + b_k sin kθ_s)`: folded direct sums for N a multiple of
    /// four, even but not, and odd, and FFTs beyond `DIRECT_SYNTH_SECTORS`.
    #[test]
    fn boundary_equals_the_naive_inverse_dft() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let mut rng = crate::fixtures::Lcg(9);
        // Contact nodes 3, 5, 2, 4: 9, 15, 6 and 12 rows per sector, so every partial last
        // band of four rows is stored.
        for (ns, nc) in [
            (10, 3),
            (40, 5),
            (37, 2),
            (DIRECT_SYNTH_SECTORS + 4, 4),
            (12, 4),
        ] {
            let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, ns, nc, 2));
            let st = Structure::new(&rom, 0.0).unwrap();
            let mut k = ModalKernel::new(&st, 0.3 * st.stability_limit()).unwrap();
            let (nb, nbp) = (k.nb, k.nbp);
            for (x, b) in k.spec.chunks_exact_mut(2 * nbp).zip(&k.blocks) {
                for r in 0..nb {
                    x[r] = rng.next();
                    x[nbp + r] = if b.real { 0.0 } else { rng.next() };
                }
            }
            let mut out = vec![0.0; ns * nb];
            k.rows_to_boundary(false, &mut out);
            for s in 0..ns {
                for r in 0..nb {
                    let mut u = 0.0;
                    for (kk, (x, b)) in k.spec.chunks_exact(2 * nbp).zip(&k.blocks).enumerate() {
                        let t = std::f64::consts::TAU * (kk * s) as f64 / ns as f64;
                        u += b.w * (x[r] * t.cos() + x[nbp + r] * t.sin());
                    }
                    let got = out[s * nb + r];
                    assert!(
                        (got - u).abs() < 1e-13,
                        "N {ns} sector {s} row {r}: {got} vs {u}"
                    );
                }
            }
        }
    }

    /// `correct_then_predict` + `predict` gives exactly the state and channels of `correct` +
    /// `predict` (the same arithmetic in the same order), and the fused predictor is used.
    #[test]
    fn fused_correction_and_prediction_equal_the_separate_calls() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 8, 3, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let h = 0.3 * st.stability_limit();
        let nb = 9;
        let pattern: Vec<f64> = (0..8 * nb)
            .map(|i| ((i * 13 % 7) as f64 - 3.0) * 1e3)
            .collect();
        // a: separate calls; b: fused; c: fused without the corrected channels.
        let mut k: Vec<ModalKernel> = (0..3).map(|_| ModalKernel::new(&st, h).unwrap()).collect();
        k.iter_mut().for_each(|x| x.set_load_pattern(&pattern));
        let mut corrected = vec![0.0; 8 * nb];
        for step in 0..20 {
            let amp = (step as f64 * 0.3).sin();
            let f: Vec<f64> = (0..8 * nb)
                .map(|i| ((i + step) % 5) as f64 * 10.0 - 20.0)
                .collect();
            k.iter_mut().for_each(|x| x.predict(amp));
            assert_eq!(k[0].boundary(), k[1].boundary(), "step {step}");
            assert_eq!(k[0].boundary(), k[2].boundary(), "step {step}");
            let next = ((step + 1) as f64 * 0.3).sin();
            k[0].correct(&f);
            k[1].correct_then_predict(&f, next);
            k[2].correct_state_then_predict(&f, next);
            assert_eq!(k[1].pred_amplitude, Some(next));
            assert_eq!(k[2].pred_amplitude, Some(next));
            assert_eq!(k[0].boundary(), k[1].boundary());
            k.iter_mut().for_each(|x| x.advance());
            assert_eq!(k[0].modal_coordinates(), k[2].modal_coordinates());
            k[2].node_displacements(&mut corrected);
            let mut reference = vec![0.0; 8 * nb];
            k[0].node_displacements(&mut reference);
            assert_eq!(corrected, reference);
        }
    }

    /// A boundary functional on the modal state (`boundary_functional`, by reciprocity) gives
    /// the value `wᵀ u` of the node displacements it weights, for a one-node probe and a
    /// weight on every sector: the load's sector DFT summed directly (one sector, or 8) and by
    /// FFTs (40 loaded sectors).
    #[test]
    fn boundary_functionals_equal_the_weighted_node_displacements() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let nb = 9;
        for ns in [8, 40] {
            let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, ns, 3, 2));
            let st = Structure::new(&rom, 0.0).unwrap();
            let mut k = ModalKernel::new(&st, 0.3 * st.stability_limit()).unwrap();
            let mut probe = vec![0.0; ns * nb];
            probe[(ns - 1) * nb + 3..(ns - 1) * nb + 6].copy_from_slice(&[0.6, -0.8, 0.0]);
            let spread: Vec<f64> = (0..ns * nb)
                .map(|i| ((i * 7 % 11) as f64 - 5.0) * 0.1)
                .collect();
            let g: Vec<Vec<f64>> = [&probe, &spread].map(|w| k.boundary_functional(w)).into();
            let mut u = vec![0.0; ns * nb];
            for step in 0..6 {
                let f: Vec<f64> = (0..ns * nb)
                    .map(|i| ((i + step) % 5) as f64 * 10.0 - 20.0)
                    .collect();
                k.predict(0.0);
                k.correct(&f);
                k.advance();
                k.node_displacements(&mut u);
                for (w, g) in [&probe, &spread].into_iter().zip(&g) {
                    let direct: f64 = w.iter().zip(&u).map(|(a, b)| a * b).sum();
                    let scale = u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    assert!(scale > 0.0);
                    let value = k.functional_value(g);
                    assert!(
                        (value - direct).abs() <= 1e-12 * scale * ns as f64,
                        "{ns} sectors, step {step}: {value} against {direct}"
                    );
                }
            }
        }
    }

    /// A lobed load (one harmonic of the sector DFT) marks only its harmonic as loaded, the
    /// others' round-off being flushed, and the held load then moves the fast kernel as it
    /// moves the dense reference, with and without the fused predictor.
    #[test]
    fn a_lobed_load_loads_one_harmonic_and_matches_the_dense_kernel() {
        use crate::dynamics::dense::DenseKernel;
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let (ns, nb) = (8, 9);
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, ns, 3, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let h = 0.3 * st.stability_limit();
        let lobe = |s: usize| (std::f64::consts::TAU * 2.0 * s as f64 / ns as f64).cos();
        let pattern: Vec<f64> = (0..ns * nb)
            .map(|i| lobe(i / nb) * ((i % nb) as f64 - 4.0) * 1e3)
            .collect();
        let mut fused = ModalKernel::new(&st, h).unwrap();
        let mut plain = ModalKernel::new(&st, h).unwrap();
        let mut dense = DenseKernel::new(&st, h);
        fused.set_load_pattern(&pattern);
        plain.set_load_pattern(&pattern);
        dense.set_load_pattern(&pattern);
        assert_eq!(fused.block_loaded, [false, false, true, false, false]);
        let f: Vec<f64> = (0..ns * nb)
            .map(|i| ((i % 7) as f64 - 3.0) * 10.0)
            .collect();
        let (mut scale, mut worst) = (0.0f64, 0.0f64);
        for step in 0..200 {
            let amp = 1.0 - 0.5f64.powi(step / 10);
            let next = 1.0 - 0.5f64.powi((step + 1) / 10);
            fused.predict(amp);
            plain.predict(amp);
            dense.predict(amp);
            assert_eq!(fused.boundary(), plain.boundary(), "step {step}");
            if step % 3 == 0 {
                fused.correct_then_predict(&f, next);
                plain.correct(&f);
                dense.correct(&f);
            }
            for (a, b) in fused.boundary().iter().zip(dense.boundary()) {
                scale = scale.max(b.abs());
                worst = worst.max((a - b).abs());
            }
            for k in [
                &mut fused as &mut dyn StructureKernel,
                &mut plain,
                &mut dense,
            ] {
                k.advance();
            }
        }
        assert!(worst <= 1e-12 * scale, "{worst:e} vs {scale:e}");
    }

    /// A kernel built on the portable path ([`simd::force`]) follows one built on the best
    /// path through loaded, rubbing steps (direct sector DFTs, folded synthesis, fused
    /// predictor): equal to round-off (the portable path may not fuse its multiply-adds).
    #[test]
    fn the_portable_kernel_follows_the_explicit_one() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let best = Isa::best();
        if best.is_portable() {
            eprintln!("no explicit SIMD path on this CPU: portable kernel not compared");
            return;
        }
        let (ns, nc) = (20, 3);
        let nb = 3 * nc;
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, ns, nc, 2));
        let st = Structure::new(&rom, 0.0).unwrap();
        let h = 0.3 * st.stability_limit();
        let mut explicit = {
            let _best = simd::force(best);
            ModalKernel::new(&st, h).unwrap()
        };
        let mut portable = {
            let _portable = simd::force(Isa::PORTABLE);
            ModalKernel::new(&st, h).unwrap()
        };
        assert_eq!((explicit.isa(), portable.isa()), (best, Isa::PORTABLE));
        let pattern: Vec<f64> = (0..ns * nb)
            .map(|i| ((i * 7 % 11) as f64 - 5.0) * 1e3)
            .collect();
        explicit.set_load_pattern(&pattern);
        portable.set_load_pattern(&pattern);
        let (mut scale, mut worst) = (0.0f64, 0.0f64);
        for step in 0..100 {
            let amp = (step as f64 * 0.1).sin();
            let next = ((step + 1) as f64 * 0.1).sin();
            // A load on three sectors, moving round.
            let mut f = vec![0.0; ns * nb];
            for s in [step % ns, (step + 1) % ns, (step + 7) % ns] {
                for r in 0..nb {
                    f[s * nb + r] = ((r + step) % 5) as f64 * 10.0 - 20.0;
                }
            }
            for k in [&mut explicit, &mut portable] {
                k.predict(amp);
                k.correct_then_predict(&f, next);
            }
            for (a, b) in portable.boundary().iter().zip(explicit.boundary()) {
                scale = scale.max(b.abs());
                worst = worst.max((a - b).abs());
            }
            explicit.advance();
            portable.advance();
        }
        assert!(scale > 0.0);
        assert!(worst <= 1e-12 * scale, "{worst:e} vs {scale:e}");
    }

    /// The re-paired basis of every complex harmonic is an M-orthonormal eigenbasis of
    /// `(K(Ω), M)` whose second half is `J` times the first (checked against the matrices, not
    /// against the construction).
    #[test]
    fn paired_modes_are_an_orthonormal_eigenbasis_with_j_partners() {
        use crate::fixtures::{SyntheticSpec, synthetic_rom};
        use crate::model::rom::Component;
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 6, 3, 4));
        let st = Structure::new(&rom, 800.0).unwrap();
        let mut checked = 0;
        for b in st.blocks.iter().filter(|b| !b.real) {
            let PairedBasis {
                modes: v,
                omega: om,
                damping: damp,
            } = paired_modes(b).unwrap();
            let n = b.n;
            let id = v.transpose() * &b.mass * &v;
            let kd = v.transpose() * &b.stiffness * &v;
            let dd = v.transpose() * &b.damping * &v;
            let kscale = b.omega.last().unwrap().powi(2);
            for i in 0..b.dim {
                for j in 0..b.dim {
                    let e = if i == j { 1.0 } else { 0.0 };
                    assert!(
                        (id[(i, j)] - e).abs() < 1e-10,
                        "VᵀMV[{i},{j}] = {}",
                        id[(i, j)]
                    );
                    let k = if i == j { om[i % n].powi(2) } else { 0.0 };
                    assert!((kd[(i, j)] - k).abs() < 1e-9 * kscale, "VᵀKV[{i},{j}]");
                    let d = if i == j { damp[i % n] } else { 0.0 };
                    assert!((dd[(i, j)] - d).abs() < 1e-9 * damp[n - 1].abs().max(1.0));
                }
            }
            for p in 0..n {
                for r in 0..n {
                    assert_eq!(v[(r, n + p)], -v[(n + r, p)]);
                    assert_eq!(v[(n + r, n + p)], v[(r, p)]);
                }
            }
            // The pair frequencies are the eigenvalues, each twice.
            let mut f: Vec<f64> = om.iter().chain(&om).cloned().collect();
            f.sort_by(f64::total_cmp);
            for (a, e) in f.iter().zip(&b.omega) {
                assert!((a - e).abs() <= 1e-8 * e.max(1.0), "{a} vs {e}");
            }
            checked += 1;
        }
        assert!(checked > 0);
    }
}
