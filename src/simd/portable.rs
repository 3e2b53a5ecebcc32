//! The portable twins of the explicit kernels in [`super::x86`]: plain Rust with the same
//! order of operations, lane for lane. `FMA` chooses fused multiply-adds (bit-identical to
//! the explicit kernels) or separate products and sums (the portable path on a CPU without a
//! fused multiply-add). Preconditions as in the dispatching functions of [`super`], which
//! check them.

use super::madd;

/// [`super::expand`]: per column in order, `x_a += V_a η₁ − V_b η₂`, `x_b += V_b η₁ + V_a η₂`
/// (as `(x + v_a s₁) − v_b s₂`, the explicit kernel's `fnmadd(v_b, s₂, fmadd(v_a, s₁, x))`).
pub fn expand<const PAIRED: bool, const FMA: bool>(
    basis: &[f64],
    h: usize,
    eta: &[f64],
    x: &mut [f64],
) {
    let (stride, n) = if PAIRED {
        (2 * h, eta.len() / 2)
    } else {
        (h, eta.len())
    };
    let (e1, e2) = eta.split_at(n);
    let x = &mut x[..stride];
    x.fill(0.0);
    let (xa, xb) = x.split_at_mut(h);
    for (p, &s1) in e1.iter().enumerate() {
        let col = &basis[stride * p..stride * (p + 1)];
        let (va, vb) = col.split_at(h);
        if !PAIRED {
            for (x, &v) in xa.iter_mut().zip(va) {
                *x = madd::<FMA>(v, s1, *x);
            }
            continue;
        }
        let s2 = e2[p];
        for r in 0..h {
            xa[r] = madd::<FMA>(-vb[r], s2, madd::<FMA>(va[r], s1, xa[r]));
            xb[r] = madd::<FMA>(va[r], s2, madd::<FMA>(vb[r], s1, xb[r]));
        }
    }
}

/// [`super::project`]: per column, bands of up to 16 rows, four lanes each (lane `l` takes
/// the rows `≡ l mod 4` of the band), reduced `(l₀ + l₁) + (l₂ + l₃)`; the first band's sum
/// stored, the others' added.
pub fn project<const PAIRED: bool, const FMA: bool>(
    basis: &[f64],
    h: usize,
    x: &[f64],
    g: &mut [f64],
) {
    let (stride, n) = if PAIRED {
        (2 * h, g.len() / 2)
    } else {
        (h, g.len())
    };
    let (g1, g2) = g.split_at_mut(n);
    let (xa, xb) = x[..stride].split_at(h);
    let sum = |l: [f64; 4]| (l[0] + l[1]) + (l[2] + l[3]);
    for p in 0..n {
        let (va, vb) = basis[stride * p..stride * (p + 1)].split_at(h);
        let mut r0 = 0;
        while r0 < h {
            let band = r0..r0 + 16.min(h - r0);
            let (mut a1, mut a2) = ([0.0f64; 4], [0.0f64; 4]);
            for r in band.clone() {
                let l = r % 4;
                a1[l] = madd::<FMA>(va[r], xa[r], a1[l]);
                if PAIRED {
                    a1[l] = madd::<FMA>(vb[r], xb[r], a1[l]);
                    a2[l] = madd::<FMA>(-vb[r], xa[r], madd::<FMA>(va[r], xb[r], a2[l]));
                }
            }
            let (s1, s2) = (sum(a1), sum(a2));
            // Stored by the first band, added by the others (a sum commutes exactly).
            g1[p] = if r0 == 0 { s1 } else { g1[p] + s1 };
            if PAIRED {
                g2[p] = if r0 == 0 { s2 } else { g2[p] + s2 };
            }
            r0 = band.end;
        }
    }
}

/// [`super::dft_rows`]: per harmonic and row, the loaded sectors in order.
pub fn dft_rows<const FMA: bool>(
    weights: &[(f64, f64)],
    nh: usize,
    loaded: &[usize],
    fload: &[f64],
    nbp: usize,
    rows: &mut [f64],
) {
    for (k, x) in rows.chunks_exact_mut(2 * nbp).take(nh).enumerate() {
        let (xa, xb) = x.split_at_mut(nbp);
        xa.fill(0.0);
        xb.fill(0.0);
        for (&s, f) in loaded.iter().zip(fload.chunks_exact(nbp)) {
            let (c, sn) = weights[s * nh + k];
            for ((a, b), &f) in xa.iter_mut().zip(xb.iter_mut()).zip(f) {
                *a = madd::<FMA>(c, f, *a);
                *b = madd::<FMA>(sn, f, *b);
            }
        }
    }
}

/// [`super::fold_sums`]: per row, the harmonics `k0, k0 + step, …` in order.
pub fn fold_sums<const FMA: bool>(
    weights: &[(f64, f64)],
    rows: &[f64],
    nbp: usize,
    k0: usize,
    step: usize,
    e: &mut [f64],
    o: &mut [f64],
) {
    let (e, o) = (&mut e[..nbp], &mut o[..nbp]);
    e.fill(0.0);
    o.fill(0.0);
    for k in (k0..weights.len()).step_by(step) {
        let (c, s) = weights[k];
        let (a, b) = rows[2 * k * nbp..2 * (k + 1) * nbp].split_at(nbp);
        for r in 0..nbp {
            e[r] = madd::<FMA>(c, a[r], e[r]);
            o[r] = madd::<FMA>(s, b[r], o[r]);
        }
    }
}

/// [`super::store_folded`]: per row, the four (or two) sectors written in the explicit
/// kernel's order, so that coinciding sectors keep the same last write.
pub fn store_folded(
    target: &mut [f64],
    nb: usize,
    [ep, op, em, om]: [&[f64]; 4],
    s: usize,
    half: Option<usize>,
) {
    let ns = target.len() / nb;
    for v in 0..nb {
        let (mut e, mut o) = (ep[v], op[v]);
        if let Some(half) = half {
            let (e2, o2) = (em[v], om[v]);
            let (ed, od) = (e - e2, o - o2);
            (e, o) = (e + e2, o + o2);
            target[(half - s) * nb + v] = ed - od;
            target[(half + s) * nb + v] = ed + od;
        }
        target[(ns - s) % ns * nb + v] = e - o;
        target[s * nb + v] = e + o;
    }
}

/// [`super::meridian_sums`]: per entry, four lanes over the rows, then reduced.
pub fn meridian_sums<const FMA: bool>(
    t: &[f64],
    stride: usize,
    first: usize,
    w: &[[f64; 4]; 4],
) -> [f64; 12] {
    let mut v = [0.0f64; 12];
    for (ve, t) in v.iter_mut().zip(t.chunks_exact(stride * stride)) {
        let row = |a: usize| &t[first + a * stride..][..4];
        let mut lanes: [f64; 4] = std::array::from_fn(|b| w[0][b] * row(0)[b]);
        for (a, wa) in w.iter().enumerate().skip(1) {
            let row = row(a);
            for b in 0..4 {
                lanes[b] = madd::<FMA>(wa[b], row[b], lanes[b]);
            }
        }
        *ve = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    }
    v
}

/// [`super::largest_move`]: in runs of four points (as the explicit kernel's three vectors of
/// squares), point `i` of a run sums its squares `(x² + y²) + z²` (`i` even) or
/// `(y² + z²) + x²` (`i` odd); the points past the last run `(x² + y²) + z²`.
pub fn largest_move(last: &mut [f64], now: &[f64]) -> f64 {
    let mut largest = 0.0f64;
    let runs = now.len() / 12 * 12;
    for (i, (l, x)) in last
        .chunks_exact_mut(3)
        .zip(now.chunks_exact(3))
        .enumerate()
    {
        let sq: [f64; 3] = std::array::from_fn(|c| (x[c] - l[c]) * (x[c] - l[c]));
        let d2 = if 3 * i < runs && i % 2 == 1 {
            (sq[1] + sq[2]) + sq[0]
        } else {
            (sq[0] + sq[1]) + sq[2]
        };
        largest = largest.max(d2);
        l.copy_from_slice(x);
    }
    largest.sqrt()
}
