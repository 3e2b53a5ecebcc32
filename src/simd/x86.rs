//! The explicit AVX2/FMA kernels (x86-64). Each is `unsafe`: the caller guarantees that the
//! CPU has the features and the bounds stated under `# Safety` (the dispatching functions of
//! [`super`] check them and hold an [`super::Isa`] that proves the features). Their portable
//! twins are in [`super::portable`].

use std::arch::x86_64::{
    __m256d, _mm_add_pd, _mm_add_sd, _mm_load_sd, _mm_loadu_pd, _mm_store_sd, _mm_storeu_pd,
    _mm256_add_pd, _mm256_blend_pd, _mm256_castpd256_pd128, _mm256_extractf128_pd, _mm256_fmadd_pd,
    _mm256_fnmadd_pd, _mm256_hadd_pd, _mm256_loadu_pd, _mm256_max_pd, _mm256_mul_pd,
    _mm256_permute2f128_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd, _mm256_sub_pd,
};

/// `f::<W>(args)`, or `f::<W, G…>(args)` for `f::<G…>(args)`, with the compile-time width
/// `W = min(left, 4)` (`left ≥ 1`): the kernels take bands of up to four vectors or columns,
/// with their accumulators in registers.
macro_rules! by_width {
    ($left:expr, $f:ident $(::<$($g:tt),*>)? ($($arg:expr),*)) => {
        match $left {
            1 => $f::<1 $($(, $g)*)?>($($arg),*),
            2 => $f::<2 $($(, $g)*)?>($($arg),*),
            3 => $f::<3 $($(, $g)*)?>($($arg),*),
            _ => $f::<4 $($(, $g)*)?>($($arg),*),
        }
    };
}

/// Runs `f` in a function compiled with AVX2 and FMA, into which `f` is inlined (see
/// [`super::compiled_for`]).
///
/// # Safety
/// The CPU has AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) unsafe fn with_avx2_fma<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// [`super::expand`] in bands of up to 16 rows per part, their sums in registers: one pass
/// over the half basis, each entry loaded once for the two products of a J-pair.
///
/// # Safety
/// The CPU has AVX2 and FMA; `h` is a multiple of 4, `basis.len() ≥ parts·h·n`,
/// `x.len() ≥ parts·h` (`parts` = 2 and `n = η.len()/2` if `PAIRED`, else 1 and `η.len()`).
#[target_feature(enable = "avx2,fma")]
#[inline]
pub unsafe fn expand<const PAIRED: bool>(basis: &[f64], h: usize, eta: &[f64], x: &mut [f64]) {
    let n = if PAIRED { eta.len() / 2 } else { eta.len() };
    let (e1, e2) = eta.split_at(n);
    let mut r = 0;
    while r < h {
        // SAFETY: rows r..r + 4W of each part lie inside every column and `x` (caller).
        unsafe { by_width!((h - r) / 4, expand_band::<PAIRED>(basis, h, e1, e2, x, r)) }
        r += 16.min(h - r);
    }
}

/// Rows `r0..r0 + 4W` of each part of [`expand`] (`e2` is read only if `PAIRED`).
///
/// # Safety
/// The CPU has AVX2 and FMA; `r0 + 4W ≤ h`, `basis.len() ≥ parts·h·e1.len()`,
/// `x.len() ≥ parts·h` (`parts` = 2 if `PAIRED`, else 1), `e2.len() ≥ e1.len()` if `PAIRED`.
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn expand_band<const W: usize, const PAIRED: bool>(
    basis: &[f64],
    h: usize,
    e1: &[f64],
    e2: &[f64],
    x: &mut [f64],
    r0: usize,
) {
    // SAFETY: the caller guarantees the bounds.
    unsafe {
        let stride = if PAIRED { 2 * h } else { h };
        let mut xa = [_mm256_setzero_pd(); W];
        let mut xb = [_mm256_setzero_pd(); W];
        for (p, &a1) in e1.iter().enumerate() {
            let s1 = _mm256_set1_pd(a1);
            let col = basis.as_ptr().add(stride * p + r0);
            if !PAIRED {
                for (i, xa) in xa.iter_mut().enumerate() {
                    *xa = _mm256_fmadd_pd(_mm256_loadu_pd(col.add(4 * i)), s1, *xa);
                }
                continue;
            }
            let s2 = _mm256_set1_pd(*e2.get_unchecked(p));
            for i in 0..W {
                let va = _mm256_loadu_pd(col.add(4 * i));
                let vb = _mm256_loadu_pd(col.add(h + 4 * i));
                xa[i] = _mm256_fnmadd_pd(vb, s2, _mm256_fmadd_pd(va, s1, xa[i]));
                xb[i] = _mm256_fmadd_pd(va, s2, _mm256_fmadd_pd(vb, s1, xb[i]));
            }
        }
        for i in 0..W {
            _mm256_storeu_pd(x.as_mut_ptr().add(r0 + 4 * i), xa[i]);
            if PAIRED {
                _mm256_storeu_pd(x.as_mut_ptr().add(h + r0 + 4 * i), xb[i]);
            }
        }
    }
}

/// [`super::project`] in bands of up to 16 rows per part, whose `x` is loaded once while the
/// columns go by two (the paper's casing and impeller have one band).
///
/// # Safety
/// The CPU has AVX2 and FMA; `h` is a multiple of 4, `basis.len() ≥ parts·h·n`,
/// `x.len() ≥ parts·h` (`parts` = 2 and `n = g.len()/2` if `PAIRED`, else 1 and `g.len()`).
#[target_feature(enable = "avx2,fma")]
#[inline]
pub unsafe fn project<const PAIRED: bool>(basis: &[f64], h: usize, x: &[f64], g: &mut [f64]) {
    let n = if PAIRED { g.len() / 2 } else { g.len() };
    let (g1, g2) = g.split_at_mut(n);
    let mut r = 0;
    while r < h {
        // SAFETY: rows r..r + 4V of each part lie inside every column and `x` (caller).
        unsafe { by_width!((h - r) / 4, project_band::<PAIRED>(basis, h, x, g1, g2, r)) }
        r += 16.min(h - r);
    }
}

/// Rows `r0..r0 + 4V` of each part of [`project`], for all columns (`g2` is written only
/// if `PAIRED`): the sums are stored by the first band (`r0 = 0`) and added by the others.
/// `x` of the band is loaded once, not per column; two columns at a time, their four sums
/// reduced together. (With 16 paired rows that copy of `x` fills 8 of the 16 AVX2 registers,
/// and the compiler keeps it on the stack and reloads it per column; split accumulators, or
/// 8-row bands of four columns, measured no faster.)
///
/// # Safety
/// The CPU has AVX2 and FMA; `r0 + 4V ≤ h`, `basis.len() ≥ parts·h·g1.len()`,
/// `x.len() ≥ parts·h` (`parts` = 2 if `PAIRED`, else 1), `g2.len() = g1.len()` if `PAIRED`.
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn project_band<const V: usize, const PAIRED: bool>(
    basis: &[f64],
    h: usize,
    x: &[f64],
    g1: &mut [f64],
    g2: &mut [f64],
    r0: usize,
) {
    let stride = if PAIRED { 2 * h } else { h };
    let n = g1.len();
    // SAFETY: the caller guarantees the bounds (columns p < n of `g1`, `g2`).
    unsafe {
        let xp = x.as_ptr().add(r0);
        let xa: [__m256d; V] = std::array::from_fn(|i| _mm256_loadu_pd(xp.add(4 * i)));
        let xb: [__m256d; V] = std::array::from_fn(|i| {
            if PAIRED {
                _mm256_loadu_pd(xp.add(h + 4 * i))
            } else {
                _mm256_setzero_pd()
            }
        });
        // `sums = [g₁ of column p, g₁ of p + 1, g₂ of p, g₂ of p + 1]`: its halves go to
        // `g₁`, `g₂` (`width` columns), stored by the first band and added by the others.
        let (g1, g2) = (g1.as_mut_ptr(), g2.as_mut_ptr());
        let put = |p: usize, sums: __m256d, width: usize| {
            let halves = [
                _mm256_castpd256_pd128(sums),
                _mm256_extractf128_pd::<1>(sums),
            ];
            for (g, half) in [g1, g2]
                .into_iter()
                .zip(halves)
                .take(if PAIRED { 2 } else { 1 })
            {
                let dst = g.add(p);
                match (width, r0) {
                    (2, 0) => _mm_storeu_pd(dst, half),
                    (2, _) => _mm_storeu_pd(dst, _mm_add_pd(half, _mm_loadu_pd(dst))),
                    (_, 0) => _mm_store_sd(dst, half),
                    _ => _mm_store_sd(dst, _mm_add_sd(half, _mm_load_sd(dst))),
                }
            }
        };
        let column = |p: usize| -> (__m256d, __m256d) {
            let col = basis.as_ptr().add(stride * p + r0);
            let (mut a1, mut a2) = (_mm256_setzero_pd(), _mm256_setzero_pd());
            for i in 0..V {
                let va = _mm256_loadu_pd(col.add(4 * i));
                a1 = _mm256_fmadd_pd(va, xa[i], a1);
                if PAIRED {
                    let vb = _mm256_loadu_pd(col.add(h + 4 * i));
                    a1 = _mm256_fmadd_pd(vb, xb[i], a1);
                    a2 = _mm256_fnmadd_pd(vb, xa[i], _mm256_fmadd_pd(va, xb[i], a2));
                }
            }
            (a1, a2)
        };
        let mut p = 0;
        while p + 2 <= n {
            let ((a, c), (b, d)) = (column(p), column(p + 1));
            put(p, lane_sums4(a, b, c, d), 2);
            p += 2;
        }
        if p < n {
            let (a, c) = column(p);
            let z = _mm256_setzero_pd();
            put(p, lane_sums4(a, z, c, z), 1);
        }
    }
}

/// [`super::dft_rows`]: per harmonic, bands of up to 16 rows whose sums stay in registers
/// over the loaded sectors.
///
/// # Safety
/// The CPU has AVX2 and FMA; `nbp` is a multiple of 4, `rows.len() ≥ 2·nbp·nh`,
/// `fload.len() ≥ loaded.len()·nbp`, `(s + 1)·nh ≤ weights.len()` for every `s` in `loaded`.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub unsafe fn dft_rows(
    weights: &[(f64, f64)],
    nh: usize,
    loaded: &[usize],
    fload: &[f64],
    nbp: usize,
    rows: &mut [f64],
) {
    for (k, x) in rows.chunks_exact_mut(2 * nbp).take(nh).enumerate() {
        let (xa, xb) = x.split_at_mut(nbp);
        // Harmonic k's weight of sector s at s·nh + k < weights.len() (caller).
        let weights = weights.get(k..).unwrap_or_default();
        let mut r = 0;
        while r < nbp {
            // SAFETY: rows r..r + 4W lie inside every load and in `xa`, `xb` (caller); the
            // weight of a loaded sector s at s·nh of `weights[k..]`.
            unsafe {
                by_width!(
                    (nbp - r) / 4,
                    dft_band(weights, nh, loaded, fload, nbp, r, xa, xb)
                )
            }
            r += 16.min(nbp - r);
        }
    }
}

/// Rows `r0..r0 + 4W` of [`dft_rows`].
///
/// # Safety
/// The CPU has AVX2 and FMA; `r0 + 4W ≤ nbp ≤ xa.len(), xb.len()`,
/// `fload.len() ≥ loaded.len()·nbp`, `s·nh < weights.len()` for every `s` in `loaded`.
#[target_feature(enable = "avx2,fma")]
#[inline]
#[allow(clippy::too_many_arguments)]
unsafe fn dft_band<const W: usize>(
    weights: &[(f64, f64)],
    nh: usize,
    loaded: &[usize],
    fload: &[f64],
    nbp: usize,
    r0: usize,
    xa: &mut [f64],
    xb: &mut [f64],
) {
    // SAFETY: the caller guarantees the bounds.
    unsafe {
        let mut sa = [_mm256_setzero_pd(); W];
        let mut sb = [_mm256_setzero_pd(); W];
        for (j, &s) in loaded.iter().enumerate() {
            let &(c, s) = weights.get_unchecked(s * nh);
            let (c, s) = (_mm256_set1_pd(c), _mm256_set1_pd(s));
            let f = fload.as_ptr().add(j * nbp + r0);
            for i in 0..W {
                let v = _mm256_loadu_pd(f.add(4 * i));
                sa[i] = _mm256_fmadd_pd(c, v, sa[i]);
                sb[i] = _mm256_fmadd_pd(s, v, sb[i]);
            }
        }
        for i in 0..W {
            _mm256_storeu_pd(xa.as_mut_ptr().add(r0 + 4 * i), sa[i]);
            _mm256_storeu_pd(xb.as_mut_ptr().add(r0 + 4 * i), sb[i]);
        }
    }
}

/// [`super::fold_sums`]: bands of up to 16 rows whose sums stay in registers over the
/// harmonics.
///
/// # Safety
/// The CPU has AVX2 and FMA; `nbp` is a multiple of 4, `nbp ≤ e.len(), o.len()`,
/// `rows.len() ≥ 2·nbp·weights.len()`, `step > 0`.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub unsafe fn fold_sums(
    weights: &[(f64, f64)],
    rows: &[f64],
    nbp: usize,
    k0: usize,
    step: usize,
    e: &mut [f64],
    o: &mut [f64],
) {
    let mut r = 0;
    while r < nbp {
        // SAFETY: rows r..r + 4W lie inside both parts of every harmonic and the sums (caller).
        unsafe {
            by_width!(
                (nbp - r) / 4,
                fold_band(weights, rows, nbp, r, k0, step, e, o)
            )
        }
        r += 16.min(nbp - r);
    }
}

/// Rows `r0..r0 + 4W` of [`fold_sums`].
///
/// # Safety
/// The CPU has AVX2 and FMA; `r0 + 4W ≤ nbp ≤ e.len(), o.len()`,
/// `rows.len() ≥ 2·nbp·weights.len()`, `step > 0`.
#[target_feature(enable = "avx2,fma")]
#[inline]
#[allow(clippy::too_many_arguments)]
unsafe fn fold_band<const W: usize>(
    weights: &[(f64, f64)],
    rows: &[f64],
    nbp: usize,
    r0: usize,
    k0: usize,
    step: usize,
    e: &mut [f64],
    o: &mut [f64],
) {
    // SAFETY: the caller guarantees the bounds.
    unsafe {
        let mut se = [_mm256_setzero_pd(); W];
        let mut so = [_mm256_setzero_pd(); W];
        let mut a = rows.as_ptr().wrapping_add(2 * k0 * nbp + r0);
        for &(c, s) in weights.iter().skip(k0).step_by(step) {
            let (c, s) = (_mm256_set1_pd(c), _mm256_set1_pd(s));
            for i in 0..W {
                se[i] = _mm256_fmadd_pd(c, _mm256_loadu_pd(a.add(4 * i)), se[i]);
                so[i] = _mm256_fmadd_pd(s, _mm256_loadu_pd(a.add(nbp + 4 * i)), so[i]);
            }
            a = a.wrapping_add(2 * step * nbp);
        }
        for i in 0..W {
            _mm256_storeu_pd(e.as_mut_ptr().add(r0 + 4 * i), se[i]);
            _mm256_storeu_pd(o.as_mut_ptr().add(r0 + 4 * i), so[i]);
        }
    }
}

/// [`super::store_folded`], four rows at a time (the last group stored partially).
///
/// # Safety
/// The CPU has AVX2; `target.len() = N·nb`, `s ≤ N/2` (`s ≤ half` and `2·half = N` if
/// `half` is given), every sum holds `nb` rounded up to a multiple of 4 rows.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub unsafe fn store_folded(
    target: &mut [f64],
    nb: usize,
    [ep, op, em, om]: [&[f64]; 4],
    s: usize,
    half: Option<usize>,
) {
    let ns = target.len() / nb;
    let t = target.as_mut_ptr();
    // SAFETY: rows v..v + 4 of the sums exist (v < nb ≤ their length, a multiple of 4); each
    // sector's rows start inside `target` and only its `nb` rows are written.
    unsafe {
        for v in (0..nb).step_by(4) {
            let store = |m: usize, x| store_rows(t.add(m * nb + v), x, nb - v);
            let (mut e, mut o) = (
                _mm256_loadu_pd(ep[v..].as_ptr()),
                _mm256_loadu_pd(op[v..].as_ptr()),
            );
            if let Some(half) = half {
                let (e2, o2) = (
                    _mm256_loadu_pd(em[v..].as_ptr()),
                    _mm256_loadu_pd(om[v..].as_ptr()),
                );
                let (ed, od) = (_mm256_sub_pd(e, e2), _mm256_sub_pd(o, o2));
                (e, o) = (_mm256_add_pd(e, e2), _mm256_add_pd(o, o2));
                store(half - s, _mm256_sub_pd(ed, od));
                store(half + s, _mm256_add_pd(ed, od));
            }
            store((ns - s) % ns, _mm256_sub_pd(e, o));
            store(s, _mm256_add_pd(e, o));
        }
    }
}

/// Stores the first `min(n, 4)` lanes of `x` at `p` by plain stores of 4, 2 and 1 values
/// (AMD cores execute masked stores slowly).
///
/// # Safety
/// The CPU has AVX2; `p` is valid for `min(n, 4)` writes.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_rows(p: *mut f64, x: __m256d, n: usize) {
    // SAFETY: the caller guarantees the bounds.
    unsafe {
        if n >= 4 {
            _mm256_storeu_pd(p, x);
            return;
        }
        let (low, high) = (_mm256_castpd256_pd128(x), _mm256_extractf128_pd::<1>(x));
        match n {
            3 => {
                _mm_storeu_pd(p, low);
                _mm_store_sd(p.add(2), high);
            }
            2 => _mm_storeu_pd(p, low),
            _ => _mm_store_sd(p, low),
        }
    }
}

/// The lane sums of four accumulators as one vector `[Σa, Σb, Σc, Σd]`, each summed as
/// `(x₀ + x₁) + (x₂ + x₃)`: the reduction of the dot products.
#[target_feature(enable = "avx2")]
#[inline]
fn lane_sums4(a: __m256d, b: __m256d, c: __m256d, d: __m256d) -> __m256d {
    let (ab, cd) = (_mm256_hadd_pd(a, b), _mm256_hadd_pd(c, d));
    _mm256_add_pd(
        _mm256_permute2f128_pd::<0x20>(ab, cd),
        _mm256_permute2f128_pd::<0x31>(ab, cd),
    )
}

/// [`super::meridian_sums`]: one vector per row of four, nine accumulators in registers,
/// their lane sums reduced four at a time.
///
/// # Safety
/// The CPU has AVX2 and FMA; `first + 3·stride + 4 ≤ stride²`, `t.len() ≥ 9·stride²`.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub unsafe fn meridian_sums(
    t: &[f64],
    stride: usize,
    first: usize,
    w: &[[f64; 4]; 4],
) -> [f64; 12] {
    let st = stride;
    let mut v = [0.0f64; 12];
    // SAFETY: every row read lies inside `t` (caller); `v` holds 12 values.
    unsafe {
        let wv: [__m256d; 4] = std::array::from_fn(|a| _mm256_loadu_pd(w[a].as_ptr()));
        let acc: [__m256d; 9] = std::array::from_fn(|e| {
            let row = |a: usize| _mm256_loadu_pd(t.as_ptr().add(e * st * st + first + a * st));
            let s = _mm256_mul_pd(wv[0], row(0));
            let s = _mm256_fmadd_pd(wv[1], row(1), s);
            let s = _mm256_fmadd_pd(wv[2], row(2), s);
            _mm256_fmadd_pd(wv[3], row(3), s)
        });
        let z = _mm256_setzero_pd();
        let p = v.as_mut_ptr();
        _mm256_storeu_pd(p, lane_sums4(acc[0], acc[1], acc[2], acc[3]));
        _mm256_storeu_pd(p.add(4), lane_sums4(acc[4], acc[5], acc[6], acc[7]));
        _mm256_storeu_pd(p.add(8), lane_sums4(acc[8], z, z, z));
    }
    v
}

/// [`super::largest_move`] over flat runs of four points (twelve coordinates, three vectors
/// `[x₀ y₀ z₀ x₁] [y₁ z₁ x₂ y₂] [z₂ x₃ y₃ z₃]` of squared differences `a, b, c`): the four
/// squared distances are `blend(hadd(a, b), hadd(b, c)) + [a₂ a₃ c₀ c₁]`.
///
/// # Safety
/// The CPU has AVX2; `last.len() = now.len()`, a multiple of 3.
#[target_feature(enable = "avx2")]
pub unsafe fn largest_move(last: &mut [f64], now: &[f64]) -> f64 {
    let mut runs_last = last.chunks_exact_mut(12);
    let mut runs_now = now.chunks_exact(12);
    let mut largest = _mm256_setzero_pd();
    for (l, x) in (&mut runs_last).zip(&mut runs_now) {
        // SAFETY: both runs hold 12 values.
        unsafe {
            let mut sq = [_mm256_setzero_pd(); 3];
            for (i, sq) in sq.iter_mut().enumerate() {
                let (xv, lv) = (x.as_ptr().add(4 * i), l.as_mut_ptr().add(4 * i));
                let xv = _mm256_loadu_pd(xv);
                let d = _mm256_sub_pd(xv, _mm256_loadu_pd(lv));
                *sq = _mm256_mul_pd(d, d);
                _mm256_storeu_pd(lv, xv);
            }
            let [a, b, c] = sq;
            let pairs = _mm256_blend_pd::<0b1100>(_mm256_hadd_pd(a, b), _mm256_hadd_pd(b, c));
            let dist2 = _mm256_add_pd(pairs, _mm256_permute2f128_pd::<0x21>(a, c));
            largest = _mm256_max_pd(largest, dist2);
        }
    }
    let mut lanes = [0.0f64; 4];
    // SAFETY: four lanes into four values.
    unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), largest) };
    let mut largest = lanes.iter().fold(0.0f64, |m, v| m.max(*v));
    let (l, x) = (runs_last.into_remainder(), runs_now.remainder());
    for (l, x) in l.chunks_exact_mut(3).zip(x.chunks_exact(3)) {
        let d2: f64 = l.iter().zip(x).map(|(l, x)| (x - l) * (x - l)).sum();
        largest = largest.max(d2);
        l.copy_from_slice(x);
    }
    largest.sqrt()
}
