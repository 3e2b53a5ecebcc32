//! Explicit SIMD: every kernel written with `core::arch` intrinsics, each with a portable
//! twin that computes the same thing, and the choice between them made once.
//!
//! # Choosing the instruction set
//! An [`Isa`] names the code path: [`Isa::PORTABLE`] (plain Rust, any CPU) or AVX2 + FMA
//! (x86-64 only, [`Isa::avx2_fma`]). A value naming AVX2 + FMA exists only on a CPU that has
//! them, so the dispatching functions below are safe. [`Isa::selected`] is the path new
//! kernels take: the CPU's best ([`Isa::best`], detected once), unless
//! - the environment variable `RUBSCAN_SIMD=portable` (read once per process) forces the
//!   portable path (`auto`, empty or unset: the best; any other value is reported on stderr
//!   and ignored), or
//! - [`force`] overrides it on the calling thread while its guard lives (tests).
//!
//! The kernels that own SIMD work (`ModalKernel`, `ControlFlexTable`) take [`Isa::selected`]
//! when they are built and keep it, so a time step never detects anything.
//!
//! # Dispatch
//! Each kernel here takes the `Isa` first and runs [`x86`] (intrinsics) or [`portable`].
//! [`compiled_for`] runs a caller's closure compiled for the chosen instruction set (the
//! domain code around the kernels, so that its own loops vectorise four wide and the
//! kernels inline into it).
//!
//! # Same results
//! The portable twins follow the explicit kernels' order of operations exactly (the same
//! partial sums, lanes and reductions). Their multiply-adds are fused when `FMA`
//! (`f64::mul_add`) and plain products and sums otherwise; the portable path fuses when the
//! build targets a CPU with a fused multiply-add ([`FUSED`], e.g. `-C target-cpu=native`,
//! or aarch64), because without one `mul_add` is a slow library call. So:
//! - **bit-identical on both paths** (whatever the build): [`store_folded`] (sums and
//!   differences only) and [`largest_move`] (for finite inputs);
//! - the multiply-add kernels [`expand`], [`project`], [`dft_rows`], [`fold_sums`] and
//!   [`meridian_sums`]: **bit-identical** to the fused twin (`FMA = true`, what the tests
//!   check), and on a portable path without FMA they differ by the rounding of the separate
//!   products, a few units of round-off of the sum of the absolute terms (the tests bound it
//!   by `1e-14` of that sum).

pub mod portable;
#[cfg(target_arch = "x86_64")]
pub mod x86;

use std::cell::Cell;
use std::sync::OnceLock;

/// Whether the portable path fuses its multiply-adds: true when `f64::mul_add` is one
/// instruction of the compilation target (x86-64 built with the `fma` feature, aarch64).
pub const FUSED: bool = cfg!(any(target_feature = "fma", target_arch = "aarch64"));

/// The environment variable that forces the portable path: `RUBSCAN_SIMD=portable`.
pub const ENV_VAR: &str = "RUBSCAN_SIMD";

/// An instruction-set choice for the SIMD kernels (see the module doc). A value naming
/// explicit SIMD exists only on a CPU that has it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Isa(Level);

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Level {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2Fma,
}

impl Isa {
    /// Plain Rust, on any CPU.
    pub const PORTABLE: Isa = Isa(Level::Portable);

    /// AVX2 and FMA, if this CPU has both (detected once).
    pub fn avx2_fma() -> Option<Isa> {
        #[cfg(target_arch = "x86_64")]
        {
            static HAS: OnceLock<bool> = OnceLock::new();
            let has = *HAS.get_or_init(|| {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            });
            if has {
                return Some(Isa(Level::Avx2Fma));
            }
        }
        None
    }

    /// The fastest path this CPU runs, whatever the environment says.
    pub fn best() -> Isa {
        Isa::avx2_fma().unwrap_or(Isa::PORTABLE)
    }

    /// The path new kernels take: the thread's [`force`]d choice if any, else the process's
    /// (`RUBSCAN_SIMD`, read once, else [`Isa::best`]).
    pub fn selected() -> Isa {
        FORCED.with(Cell::get).unwrap_or_else(process_choice)
    }

    /// Whether this is the portable path.
    pub fn is_portable(self) -> bool {
        self.0 == Level::Portable
    }

    /// Whether the multiply-adds of this path are fused (one rounding).
    #[inline(always)]
    pub fn fused(self) -> bool {
        match self.0 {
            Level::Portable => FUSED,
            #[cfg(target_arch = "x86_64")]
            Level::Avx2Fma => true,
        }
    }

    /// A short name: `portable` or `avx2+fma`.
    pub fn name(self) -> &'static str {
        match self.0 {
            Level::Portable => "portable",
            #[cfg(target_arch = "x86_64")]
            Level::Avx2Fma => "avx2+fma",
        }
    }
}

impl std::fmt::Display for Isa {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The process-wide choice: `RUBSCAN_SIMD` read once, else the best path.
fn process_choice() -> Isa {
    static CHOICE: OnceLock<Isa> = OnceLock::new();
    *CHOICE.get_or_init(|| {
        let value = std::env::var(ENV_VAR).unwrap_or_default();
        match parse_choice(&value) {
            Some(true) => Isa::PORTABLE,
            Some(false) => Isa::best(),
            None => {
                eprintln!("{ENV_VAR}={value:?} not understood (portable or auto): auto");
                Isa::best()
            }
        }
    })
}

/// `Some(true)` for the portable path, `Some(false)` for the best one, `None` if unknown.
fn parse_choice(value: &str) -> Option<bool> {
    match value.trim().to_ascii_lowercase().as_str() {
        "portable" => Some(true),
        "" | "auto" => Some(false),
        _ => None,
    }
}

thread_local! {
    static FORCED: Cell<Option<Isa>> = const { Cell::new(None) };
}

/// Forces [`Isa::selected`] to `isa` on the calling thread until the guard drops (then the
/// previous choice comes back). For tests: kernels built meanwhile keep `isa`.
pub fn force(isa: Isa) -> ForcedIsa {
    ForcedIsa {
        previous: FORCED.with(|f| f.replace(Some(isa))),
    }
}

/// The guard of [`force`]: restores the thread's previous choice when dropped.
#[must_use = "the override ends when the guard drops"]
pub struct ForcedIsa {
    previous: Option<Isa>,
}

impl Drop for ForcedIsa {
    fn drop(&mut self) {
        FORCED.with(|f| f.set(self.previous));
    }
}

/// Runs `f` compiled for `isa`: for AVX2 + FMA through a function with those target features
/// into which `f` (called once) is inlined, so the loops of `f` vectorise four wide and the
/// explicit kernels inline into them; `f` receives `isa` as a constant, so its own dispatches
/// fold away.
#[inline(always)]
pub fn compiled_for<R>(isa: Isa, f: impl FnOnce(Isa) -> R) -> R {
    match isa.0 {
        Level::Portable => f(Isa::PORTABLE),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: an `Isa` naming AVX2 + FMA exists only on a CPU that has them.
        Level::Avx2Fma => unsafe { x86::with_avx2_fma(|| f(Isa(Level::Avx2Fma))) },
    }
}

/// `a·b + c`, fused if `FMA` (`f64::mul_add`), else a product and a sum.
#[inline(always)]
pub(crate) fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA { a.mul_add(b, c) } else { a * b + c }
}

/// `a·b + c` with the rounding of `isa` ([`Isa::fused`]).
#[inline(always)]
pub fn madd_for(isa: Isa, a: f64, b: f64, c: f64) -> f64 {
    if isa.fused() {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// Boundary rows `x = Φ_b η` from a stored half basis, with half height `h` (a multiple of 4).
/// `PAIRED` (a complex harmonic): `basis` holds `n = η.len()/2` columns `[V_a; V_b]` of `2h`
/// rows, `η = [η₁; η₂]`, and `x[..2h] = [V_a η₁ − V_b η₂; V_b η₁ + V_a η₂]` (the product with
/// `[V, JV]`, `J [a; b] = [−b; a]`). Otherwise (a real harmonic) `basis` holds `n = η.len()`
/// columns of `h` rows and `x[..h] = V η`. Each row accumulates over the columns in order.
#[inline(always)]
pub fn expand<const PAIRED: bool>(isa: Isa, basis: &[f64], h: usize, eta: &[f64], x: &mut [f64]) {
    let (parts, n) = if PAIRED {
        (2, eta.len() / 2)
    } else {
        (1, eta.len())
    };
    assert!(basis.len() >= parts * h * n && x.len() >= parts * h && h.is_multiple_of(4));
    match isa.0 {
        Level::Portable => portable::expand::<PAIRED, FUSED>(basis, h, eta, x),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 + FMA present (the `Isa` says so); the bounds are checked above.
        Level::Avx2Fma => unsafe { x86::expand::<PAIRED>(basis, h, eta, x) },
    }
}

/// Modal projection `g = Φ_bᵀ x` of one harmonic's boundary rows (the transpose of
/// [`expand`], same layouts): `PAIRED`, `g = [V_aᵀ x_a + V_bᵀ x_b; V_aᵀ x_b − V_bᵀ x_a]`
/// (`g.len()/2` columns); otherwise `g = Vᵀ x[..h]`. Each dot product is summed in bands of
/// up to 16 rows, four lanes per band reduced as `(l₀ + l₁) + (l₂ + l₃)`, the bands added in
/// order.
#[inline(always)]
pub fn project<const PAIRED: bool>(isa: Isa, basis: &[f64], h: usize, x: &[f64], g: &mut [f64]) {
    let (parts, n) = if PAIRED {
        (2, g.len() / 2)
    } else {
        (1, g.len())
    };
    assert!(basis.len() >= parts * h * n && x.len() >= parts * h && h.is_multiple_of(4));
    match isa.0 {
        Level::Portable => portable::project::<PAIRED, FUSED>(basis, h, x, g),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 + FMA present (the `Isa` says so); the bounds are checked above.
        Level::Avx2Fma => unsafe { x86::project::<PAIRED>(basis, h, x, g) },
    }
}

/// Direct real DFT rows of every harmonic over a few loaded sectors: harmonic k's rows
/// `[x_a; x_b]` at `rows[2k·nbp..]` get `x_a = Σ_j c_j f_j`, `x_b = Σ_j s_j f_j` over the
/// `loaded` sectors `s_j` in order, with `(c_j, s_j) = weights[s_j·nh + k]` and
/// `f_j = fload[j·nbp..(j + 1)·nbp]`; `nbp` is a multiple of 4, `nh` harmonics are written.
#[inline(always)]
pub fn dft_rows(
    isa: Isa,
    weights: &[(f64, f64)],
    nh: usize,
    loaded: &[usize],
    fload: &[f64],
    nbp: usize,
    rows: &mut [f64],
) {
    assert!(nbp.is_multiple_of(4) && rows.len() >= 2 * nbp * nh);
    assert!(fload.len() >= loaded.len() * nbp);
    assert!(loaded.iter().all(|&s| (s + 1) * nh <= weights.len()));
    match isa.0 {
        Level::Portable => portable::dft_rows::<FUSED>(weights, nh, loaded, fload, nbp, rows),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 + FMA present (the `Isa` says so); the bounds are checked above.
        Level::Avx2Fma => unsafe { x86::dft_rows(weights, nh, loaded, fload, nbp, rows) },
    }
}

/// The partial sums of one sector of the folded inverse DFT: `e = Σ_k c_k a_k` and
/// `o = Σ_k s_k b_k` over the harmonics `k = k0, k0 + step, …` (< `weights.len()`) in order,
/// with `(c_k, s_k) = weights[k]` and the rows `[a_k; b_k]` of harmonic k at `2k·nbp` in
/// `rows`; `nbp` (a multiple of 4) rows of `e`, `o` are written.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn fold_sums(
    isa: Isa,
    weights: &[(f64, f64)],
    rows: &[f64],
    nbp: usize,
    k0: usize,
    step: usize,
    e: &mut [f64],
    o: &mut [f64],
) {
    assert!(nbp.is_multiple_of(4) && e.len() >= nbp && o.len() >= nbp && step > 0);
    assert!(rows.len() >= 2 * nbp * weights.len());
    match isa.0 {
        Level::Portable => portable::fold_sums::<FUSED>(weights, rows, nbp, k0, step, e, o),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 + FMA present (the `Isa` says so); the bounds are checked above.
        Level::Avx2Fma => unsafe { x86::fold_sums(weights, rows, nbp, k0, step, e, o) },
    }
}

/// The sectors of one folded inverse-DFT sum from its partial sums `[E₊, O₊, E₋, O₋]`
/// (rows `..nb` read): `u_{N−s} = E − O`, `u_s = E + O` with `E = E₊ + E₋`, `O = O₊ + O₋`,
/// and with `half = Some(N/2)` (N even) first `u_{N/2−s} = E' − O'`, `u_{N/2+s} = E' + O'`
/// with `E' = E₊ − E₋`, `O' = O₊ − O₋` (N odd: `E₋ = O₋ = 0`, not read). Where sectors
/// coincide (s = 0, s = N/4) the last write wins. `target` holds N sectors of `nb` rows;
/// each sum holds at least `nb` rounded up to a multiple of 4 rows.
#[inline(always)]
pub fn store_folded(
    isa: Isa,
    target: &mut [f64],
    nb: usize,
    sums: [&[f64]; 4],
    s: usize,
    half: Option<usize>,
) {
    let ns = target.len() / nb;
    assert!(target.len() == ns * nb && s <= ns / 2);
    assert!(half.is_none_or(|h| 2 * h == ns && s <= h));
    let padded = nb.div_ceil(4) * 4;
    assert!(sums.iter().all(|x| x.len() >= padded));
    match isa.0 {
        Level::Portable => portable::store_folded(target, nb, sums, s, half),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 present (the `Isa` says so); the bounds are checked above.
        Level::Avx2Fma => unsafe { x86::store_folded(target, nb, sums, s, half) },
    }
}

/// `V[e] = Σ_a Σ_b w[a][b] t_e[first + a·stride + b]` for the nine entries `e` of nine
/// `stride × stride` blocks `t` (entry-major): the meridian contraction of the casing's
/// pair flexibility. Lanes 9..12 are zero. Per entry, four lanes `b`, each
/// `((w₀ t₀ + w₁ t₁) + w₂ t₂) + w₃ t₃` over the rows `a`, then `(b₀ + b₁) + (b₂ + b₃)`.
#[inline(always)]
pub fn meridian_sums(
    isa: Isa,
    t: &[f64],
    stride: usize,
    first: usize,
    w: &[[f64; 4]; 4],
) -> [f64; 12] {
    // The last row read of the last block lies inside `t`.
    assert!(first + 3 * stride + 4 <= stride * stride && t.len() >= 9 * stride * stride);
    match isa.0 {
        Level::Portable => portable::meridian_sums::<FUSED>(t, stride, first, w),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 + FMA present (the `Isa` says so); the bounds are checked above.
        Level::Avx2Fma => unsafe { x86::meridian_sums(t, stride, first, w) },
    }
}

/// The largest distance between the points of `last` and `now` (coordinate triples, the
/// same number), which then replace `last`. Each squared distance sums its three squares in
/// the order of the explicit kernel's lanes (see [`portable::largest_move`]).
#[inline(always)]
pub fn largest_move(isa: Isa, last: &mut [f64], now: &[f64]) -> f64 {
    assert!(last.len() == now.len() && last.len().is_multiple_of(3));
    match isa.0 {
        Level::Portable => portable::largest_move(last, now),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: AVX2 present (the `Isa` says so); the lengths are checked above.
        Level::Avx2Fma => unsafe { x86::largest_move(last, now) },
    }
}

#[cfg(test)]
mod tests;
