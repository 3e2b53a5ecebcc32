//! Every explicit kernel against its portable twin, on the same pseudo-random inputs with
//! sizes that leave partial bands and runs: bit for bit against the fused twin, and within
//! round-off against the twin the portable path runs (unfused on a CPU without FMA). Without
//! AVX2 + FMA the explicit side is skipped (with a note), and the portable twins are still
//! checked against plain reference sums.

use super::*;
use crate::fixtures::Lcg;

/// The explicit path, or `None` with a note that its comparisons are skipped.
fn explicit(test: &str) -> Option<Isa> {
    let isa = Isa::avx2_fma();
    if isa.is_none() {
        eprintln!("{test}: no AVX2 + FMA on this CPU, explicit kernel not compared");
    }
    isa
}

fn random(rng: &mut Lcg, n: usize) -> Vec<f64> {
    (0..n).map(|_| rng.next()).collect()
}

/// Same bits, with the first difference named.
fn assert_bits(got: &[f64], want: &[f64], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    for (i, (a, b)) in got.iter().zip(want).enumerate() {
        assert!(a.to_bits() == b.to_bits(), "{what}[{i}]: {a:e} vs {b:e}");
    }
}

/// Within `1e-14 · scale[i]` (the sum of the absolute terms of entry i).
fn assert_close(got: &[f64], want: &[f64], scale: &[f64], what: &str) {
    for (i, ((a, b), s)) in got.iter().zip(want).zip(scale).enumerate() {
        assert!(
            (a - b).abs() <= 1e-14 * s,
            "{what}[{i}]: {a:e} vs {b:e} (scale {s:e})"
        );
    }
}

/// Column p of `[V, JV]` (2h rows) from the stored half basis of n columns.
fn paired_column(v: &[f64], h: usize, n: usize, p: usize, r: usize) -> f64 {
    let c = &v[(p % n) * 2 * h..(p % n + 1) * 2 * h];
    match (p < n, r < h) {
        (true, _) => c[r],
        (false, true) => -c[h + r],
        (false, false) => c[r - h],
    }
}

/// Heights (multiples of 4) with whole and partial 16-row bands, and column counts odd and
/// even.
const SHAPES: [(usize, usize); 6] = [(4, 3), (12, 7), (16, 25), (20, 6), (36, 5), (8, 1)];

#[test]
fn expand_twins_agree_and_equal_the_naive_product() {
    let mut rng = Lcg(11);
    for (h, n) in SHAPES {
        let (v, eta) = (random(&mut rng, 2 * h * n), random(&mut rng, 2 * n));
        let (v, eta) = (&v[..], &eta[..]);
        // Paired: x = [V, JV] η; real: x = V η over the first h·n entries.
        let mut fused = vec![0.0; 2 * h];
        portable::expand::<true, true>(v, h, eta, &mut fused);
        let mut plain = vec![0.0; 2 * h];
        portable::expand::<true, false>(v, h, eta, &mut plain);
        let terms = |r: usize| (0..2 * n).map(move |p| (paired_column(v, h, n, p, r), eta[p]));
        let want: Vec<f64> = (0..2 * h)
            .map(|r| terms(r).map(|(a, b)| a * b).sum::<f64>())
            .collect();
        let scale: Vec<f64> = (0..2 * h)
            .map(|r| terms(r).map(|(a, b)| (a * b).abs()).sum::<f64>())
            .collect();
        assert_close(&fused, &want, &scale, "paired expand (fused) vs naive");
        assert_close(&plain, &want, &scale, "paired expand (plain) vs naive");
        let mut real = vec![0.0; h];
        portable::expand::<false, true>(v, h, &eta[..n], &mut real);
        let mut real_plain = vec![0.0; h];
        portable::expand::<false, false>(v, h, &eta[..n], &mut real_plain);
        let want_real: Vec<f64> = (0..h)
            .map(|r| (0..n).map(|p| v[p * h + r] * eta[p]).sum::<f64>())
            .collect();
        let scale_real: Vec<f64> = (0..h)
            .map(|r| (0..n).map(|p| (v[p * h + r] * eta[p]).abs()).sum::<f64>())
            .collect();
        assert_close(&real, &want_real, &scale_real, "real expand vs naive");
        assert_close(&real_plain, &want_real, &scale_real, "real expand vs naive");
        let Some(isa) = explicit("expand") else {
            continue;
        };
        let mut got = vec![f64::NAN; 2 * h];
        expand::<true>(isa, v, h, eta, &mut got);
        assert_bits(&got, &fused, &format!("paired expand h={h} n={n}"));
        let mut got = vec![f64::NAN; h];
        expand::<false>(isa, v, h, &eta[..n], &mut got);
        assert_bits(&got, &real, &format!("real expand h={h} n={n}"));
    }
}

#[test]
fn project_twins_agree_and_equal_the_naive_product() {
    let mut rng = Lcg(12);
    for (h, n) in SHAPES {
        let (v, x) = (random(&mut rng, 2 * h * n), random(&mut rng, 2 * h));
        let (v, x) = (&v[..], &x[..]);
        let mut fused = vec![0.0; 2 * n];
        portable::project::<true, true>(v, h, x, &mut fused);
        let mut plain = vec![0.0; 2 * n];
        portable::project::<true, false>(v, h, x, &mut plain);
        let terms = |p: usize| (0..2 * h).map(move |r| paired_column(v, h, n, p, r) * x[r]);
        let want: Vec<f64> = (0..2 * n).map(|p| terms(p).sum::<f64>()).collect();
        let scale: Vec<f64> = (0..2 * n)
            .map(|p| terms(p).map(f64::abs).sum::<f64>())
            .collect();
        assert_close(&fused, &want, &scale, "paired project (fused) vs naive");
        assert_close(&plain, &want, &scale, "paired project (plain) vs naive");
        let mut real = vec![0.0; n];
        portable::project::<false, true>(v, h, &x[..h], &mut real);
        let want_real: Vec<f64> = (0..n)
            .map(|p| (0..h).map(|r| v[p * h + r] * x[r]).sum::<f64>())
            .collect();
        let scale_real: Vec<f64> = (0..n)
            .map(|p| (0..h).map(|r| (v[p * h + r] * x[r]).abs()).sum::<f64>())
            .collect();
        assert_close(&real, &want_real, &scale_real, "real project vs naive");
        let Some(isa) = explicit("project") else {
            continue;
        };
        let mut got = vec![f64::NAN; 2 * n];
        project::<true>(isa, v, h, x, &mut got);
        assert_bits(&got, &fused, &format!("paired project h={h} n={n}"));
        let mut got = vec![f64::NAN; n];
        project::<false>(isa, v, h, &x[..h], &mut got);
        assert_bits(&got, &real, &format!("real project h={h} n={n}"));
    }
}

#[test]
fn dft_rows_twins_agree_and_equal_the_naive_sums() {
    let mut rng = Lcg(13);
    let (nh, ns) = (5, 10);
    for (nbp, loaded) in [
        (4, vec![2]),
        (12, vec![0, 3, 7]),
        (20, vec![1, 2, 3, 4, 9]),
        (36, vec![6, 8]),
        (16, vec![]),
    ] {
        let weights: Vec<(f64, f64)> = (0..ns * nh).map(|_| (rng.next(), rng.next())).collect();
        let fload = random(&mut rng, loaded.len() * nbp);
        let run = |f: &dyn Fn(&mut [f64])| {
            let mut rows = vec![f64::NAN; 2 * nbp * nh];
            f(&mut rows);
            rows
        };
        let fused = run(&|x| portable::dft_rows::<true>(&weights, nh, &loaded, &fload, nbp, x));
        let plain = run(&|x| portable::dft_rows::<false>(&weights, nh, &loaded, &fload, nbp, x));
        let term = |k: usize, part: usize, r: usize, j: usize| {
            let (c, s) = weights[loaded[j] * nh + k];
            (if part == 0 { c } else { s }) * fload[j * nbp + r]
        };
        let (mut want, mut scale) = (Vec::<f64>::new(), Vec::<f64>::new());
        for k in 0..nh {
            for part in 0..2 {
                for r in 0..nbp {
                    let js = 0..loaded.len();
                    want.push(js.clone().map(|j| term(k, part, r, j)).sum::<f64>());
                    scale.push(js.map(|j| term(k, part, r, j).abs()).sum::<f64>());
                }
            }
        }
        assert_close(&fused, &want, &scale, "dft rows (fused) vs naive");
        assert_close(&plain, &want, &scale, "dft rows (plain) vs naive");
        let Some(isa) = explicit("dft_rows") else {
            continue;
        };
        let got = run(&|x| dft_rows(isa, &weights, nh, &loaded, &fload, nbp, x));
        assert_bits(
            &got,
            &fused,
            &format!("dft rows nbp={nbp} loaded={loaded:?}"),
        );
    }
}

#[test]
fn fold_sums_twins_agree_and_equal_the_naive_sums() {
    let mut rng = Lcg(14);
    for (nbp, nh) in [(4, 1), (12, 6), (20, 7), (36, 4), (16, 26)] {
        let weights: Vec<(f64, f64)> = (0..nh).map(|_| (rng.next(), rng.next())).collect();
        let rows = random(&mut rng, 2 * nbp * nh);
        for (k0, step) in [(0, 1), (0, 2), (1, 2)] {
            let run = |f: &dyn Fn(&mut [f64], &mut [f64])| {
                let (mut e, mut o) = (vec![f64::NAN; nbp], vec![f64::NAN; nbp]);
                f(&mut e, &mut o);
                [e, o].concat()
            };
            let fused =
                run(&|e, o| portable::fold_sums::<true>(&weights, &rows, nbp, k0, step, e, o));
            let plain =
                run(&|e, o| portable::fold_sums::<false>(&weights, &rows, nbp, k0, step, e, o));
            let term = |part: usize, r: usize, k: usize| {
                let (c, s) = weights[k];
                (if part == 0 { c } else { s }) * rows[2 * k * nbp + part * nbp + r]
            };
            let (mut want, mut scale) = (Vec::<f64>::new(), Vec::<f64>::new());
            for part in 0..2 {
                for r in 0..nbp {
                    let ks = (k0..nh).step_by(step);
                    want.push(ks.clone().map(|k| term(part, r, k)).sum::<f64>());
                    scale.push(ks.map(|k| term(part, r, k).abs()).sum::<f64>());
                }
            }
            assert_close(&fused, &want, &scale, "fold sums (fused) vs naive");
            assert_close(&plain, &want, &scale, "fold sums (plain) vs naive");
            let Some(isa) = explicit("fold_sums") else {
                continue;
            };
            let got = run(&|e, o| fold_sums(isa, &weights, &rows, nbp, k0, step, e, o));
            assert_bits(
                &got,
                &fused,
                &format!("fold sums nbp={nbp} nh={nh} k0={k0}"),
            );
        }
    }
}

#[test]
fn store_folded_twins_write_the_same_sectors() {
    let mut rng = Lcg(15);
    // N a multiple of four (s = N/4 coincides), even, odd; nb with partial groups of four.
    for (ns, nb) in [(12usize, 9usize), (10, 6), (7, 5), (8, 4), (4, 1)] {
        let padded = nb.div_ceil(4) * 4;
        let even = ns % 2 == 0;
        let last = if even { ns / 4 } else { ns / 2 };
        let (mut port, mut expl) = (vec![f64::NAN; ns * nb], vec![f64::NAN; ns * nb]);
        let isa = explicit("store_folded");
        for s in 0..=last {
            let sums: Vec<Vec<f64>> = (0..4).map(|_| random(&mut rng, padded)).collect();
            let sums = [&sums[0][..], &sums[1], &sums[2], &sums[3]];
            let half = even.then_some(ns / 2);
            store_folded(Isa::PORTABLE, &mut port, nb, sums, s, half);
            // The sums of sector s: u_s = E + O with E, O over both parity classes.
            let (e, o) = (sums[0][0] + sums[2][0], sums[1][0] + sums[3][0]);
            let e = if even { e } else { sums[0][0] };
            let o = if even { o } else { sums[1][0] };
            assert_eq!(port[s * nb].to_bits(), (e + o).to_bits(), "N {ns} s {s}");
            if let Some(isa) = isa {
                store_folded(isa, &mut expl, nb, sums, s, half);
            }
        }
        // Every sector written (N even: s ≤ N/4 and its images cover all).
        assert!(
            port.iter().all(|x| !x.is_nan()),
            "N {ns}: a sector not written"
        );
        if isa.is_some() {
            assert_bits(&expl, &port, &format!("store folded N={ns} nb={nb}"));
        }
    }
}

#[test]
fn meridian_sums_twins_agree_and_equal_the_naive_sums() {
    let mut rng = Lcg(16);
    for stride in [4, 5, 7] {
        let t = random(&mut rng, 9 * stride * stride);
        let w: [[f64; 4]; 4] = std::array::from_fn(|_| std::array::from_fn(|_| rng.next()));
        // Every corner of the block that a 4 × 4 window fits in.
        for first in [
            0,
            stride - 4,
            (stride - 4) * stride,
            (stride - 4) * (stride + 1),
        ] {
            let fused = portable::meridian_sums::<true>(&t, stride, first, &w);
            let plain = portable::meridian_sums::<false>(&t, stride, first, &w);
            let term = |e: usize, a: usize, b: usize| {
                w[a][b] * t[e * stride * stride + first + a * stride + b]
            };
            let pairs = || (0..4).flat_map(|a| (0..4).map(move |b| (a, b)));
            let mut want = [0.0; 12];
            let mut scale = [0.0; 12];
            for e in 0..9 {
                want[e] = pairs().map(|(a, b)| term(e, a, b)).sum();
                scale[e] = pairs().map(|(a, b)| term(e, a, b).abs()).sum();
            }
            assert_close(&fused, &want, &scale, "meridian sums (fused) vs naive");
            assert_close(&plain, &want, &scale, "meridian sums (plain) vs naive");
            assert_eq!(fused[9..], [0.0; 3]);
            let Some(isa) = explicit("meridian_sums") else {
                continue;
            };
            let got = meridian_sums(isa, &t, stride, first, &w);
            assert_bits(
                &got,
                &fused,
                &format!("meridian sums stride={stride} first={first}"),
            );
        }
    }
}

#[test]
fn largest_move_twins_agree_and_find_the_far_point() {
    let mut rng = Lcg(17);
    // Whole runs of four points, partial runs, and the far point in every lane.
    for n in [1, 4, 7, 14, 16] {
        for far in 0..n {
            let last = random(&mut rng, 3 * n);
            let mut now: Vec<f64> = last.iter().map(|x| x + 1e-6 * rng.next()).collect();
            for c in 0..3 {
                now[3 * far + c] = last[3 * far + c] + rng.next();
            }
            let d = &now[3 * far..3 * far + 3];
            let l = &last[3 * far..3 * far + 3];
            let want = d
                .iter()
                .zip(l)
                .map(|(x, l)| (x - l) * (x - l))
                .sum::<f64>()
                .sqrt();
            let mut port = last.clone();
            let got = largest_move(Isa::PORTABLE, &mut port, &now);
            assert!((got - want).abs() <= 1e-15 * want, "{n} points, far {far}");
            assert_eq!(port, now);
            let Some(isa) = explicit("largest_move") else {
                continue;
            };
            let mut expl = last.clone();
            let got_expl = largest_move(isa, &mut expl, &now);
            assert_eq!(got_expl.to_bits(), got.to_bits(), "{n} points, far {far}");
            assert_eq!(expl, now);
        }
    }
}

#[test]
fn the_override_holds_on_its_thread_until_dropped() {
    let before = Isa::selected();
    {
        let _portable = force(Isa::PORTABLE);
        assert!(Isa::selected().is_portable());
        if let Some(isa) = Isa::avx2_fma() {
            let _nested = force(isa);
            assert_eq!(Isa::selected(), isa);
        }
        assert!(Isa::selected().is_portable());
        // Another thread keeps the process's choice.
        let other = std::thread::spawn(Isa::selected).join().unwrap();
        assert_eq!(other, process_choice());
    }
    assert_eq!(Isa::selected(), before);
    assert_eq!(Isa::best().is_portable(), Isa::avx2_fma().is_none());
}

#[test]
fn the_environment_switch_is_parsed() {
    assert_eq!(parse_choice("portable"), Some(true));
    assert_eq!(parse_choice(" Portable\n"), Some(true));
    assert_eq!(parse_choice(""), Some(false));
    assert_eq!(parse_choice("auto"), Some(false));
    assert_eq!(parse_choice("avx512"), None);
    // The CI's portable run: the process's choice follows the variable.
    let forced = std::env::var(ENV_VAR).is_ok_and(|v| parse_choice(&v) == Some(true));
    assert_eq!(
        process_choice().is_portable(),
        forced || Isa::avx2_fma().is_none()
    );
}

/// A closure run through `compiled_for` receives the path it was asked for.
#[test]
fn compiled_for_passes_the_path_on() {
    assert!(compiled_for(Isa::PORTABLE, |isa| isa.is_portable()));
    if let Some(isa) = explicit("compiled_for") {
        assert_eq!(compiled_for(isa, |i| i), isa);
    }
}
