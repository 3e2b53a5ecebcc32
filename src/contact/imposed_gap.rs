//! The imposed-gap rigid casing, the form of the public NASA Rotor 37 rubbing benchmark
//! (Piollet, Nyssen & Batailly, JSV 460, 2019, eqs. 3–4; DESIGN §9): instead of a casing
//! surface, each blade-tip node meets the casing along a fixed direction of its blade's frame,
//! at a gap prescribed as a function `g(θ)` of the angle `θ = Ω t + φ_node` the node has reached
//! in the fixed frame. The casing is rigid and fixed; the blade sweeps past its profile.

use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// The gap `g(θ)` (m) of the casing at the fixed-frame angle θ (rad), 2π-periodic; negative
/// values impose a penetration that the contact removes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum GapProfile {
    /// `n` Gaussian lobes (the benchmark's profile, n = 2):
    /// `g(θ) = g_m (1 − 2 exp(−((s − ½)/w)²))` with `s = mod(θ, 2π/n) / (2π/n)`, so that the
    /// gap is about `g_m` between the lobes and `−g_m` at their centres `θ = (k + ½) 2π/n`.
    GaussianLobes {
        /// Mean gap g_m (m), > 0.
        #[serde(rename = "mean_gap_m")]
        mean_gap: f64,
        /// Lobe width w, a fraction of the lobe period, in (0, 1].
        width: f64,
        /// Number of lobes n ≥ 1.
        lobes: usize,
    },
    /// Gaps `g_i` (m) at N ≥ 3 equally spaced angles `θ_i = 2π i / N`, interpolated by a
    /// periodic cubic Hermite spline with centred slopes (Catmull–Rom: C¹, exact at the
    /// stations).
    Tabulated {
        /// The gaps g_i (m).
        #[serde(rename = "gaps_m")]
        gaps: Vec<f64>,
    },
}

/// The fixed direction along which each blade-tip node meets the casing.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum GapDirection {
    /// The outward radial direction of the node's reference position, `(x, y, 0)/r` in its
    /// blade's frame (the benchmark's choice).
    #[default]
    Radial,
    /// One outward unit vector per contact node of the reference blade (its frame, in the
    /// order of the ROM's contact nodes); normalised on use.
    PerNode(Vec<[f64; 3]>),
}

/// An imposed-gap rigid casing: its profile and the direction of each node's gap.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImposedGap {
    /// The gap as a function of the fixed-frame angle.
    pub profile: GapProfile,
    /// The direction of each node's gap (default: radial).
    #[serde(default)]
    pub direction: GapDirection,
}

impl GapProfile {
    /// The number of lobes of a Gaussian profile; `None` for a tabulated one.
    pub fn lobes(&self) -> Option<usize> {
        match self {
            GapProfile::GaussianLobes { lobes, .. } => Some(*lobes),
            GapProfile::Tabulated { .. } => None,
        }
    }

    /// Checks the profile's parameters; the error names the parameter.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            GapProfile::GaussianLobes {
                mean_gap,
                width,
                lobes,
            } => {
                if !(mean_gap.is_finite() && *mean_gap > 0.0) {
                    return Err(format!("mean_gap = {mean_gap} m must be finite and > 0"));
                }
                if !(width.is_finite() && *width > 0.0 && *width <= 1.0) {
                    return Err(format!("width = {width} must lie in (0, 1]"));
                }
                if *lobes == 0 {
                    return Err("lobes must be ≥ 1".into());
                }
            }
            GapProfile::Tabulated { gaps } => {
                if gaps.len() < 3 {
                    return Err(format!("needs at least 3 gaps, got {}", gaps.len()));
                }
                if let Some(i) = gaps.iter().position(|g| !g.is_finite()) {
                    return Err(format!("gap {i} is not finite"));
                }
            }
        }
        Ok(())
    }

    /// The gap `g(θ)` (m) and its slope `dg/dθ` (m/rad) at the fixed-frame angle θ (rad).
    /// The gap's rate seen by a node turning at Ω is `Ω dg/dθ`.
    pub fn at(&self, theta: f64) -> (f64, f64) {
        match self {
            GapProfile::GaussianLobes {
                mean_gap,
                width,
                lobes,
            } => {
                let period = TAU / *lobes as f64;
                let s = theta.rem_euclid(period) / period;
                let x = (s - 0.5) / width;
                let e = (-x * x).exp();
                let gap = mean_gap * (1.0 - 2.0 * e);
                // dg/ds = 4 g_m x e / w, ds/dθ = 1/period.
                (gap, 4.0 * mean_gap * x * e / (width * period))
            }
            GapProfile::Tabulated { gaps } => {
                let n = gaps.len();
                let step = TAU / n as f64;
                let u = theta.rem_euclid(TAU) / step;
                // `u` may round up to exactly n.
                let i = (u.floor() as usize).min(n - 1);
                let t = u - i as f64;
                let at = |k: isize| gaps[k.rem_euclid(n as isize) as usize];
                let k = i as isize;
                let (p0, p1) = (at(k), at(k + 1));
                let (m0, m1) = (0.5 * (p1 - at(k - 1)), 0.5 * (at(k + 2) - p0));
                let (t2, t3) = (t * t, t * t * t);
                let gap = (2.0 * t3 - 3.0 * t2 + 1.0) * p0
                    + (t3 - 2.0 * t2 + t) * m0
                    + (-2.0 * t3 + 3.0 * t2) * p1
                    + (t3 - t2) * m1;
                let dgdt = (6.0 * t2 - 6.0 * t) * p0
                    + (3.0 * t2 - 4.0 * t + 1.0) * m0
                    + (-6.0 * t2 + 6.0 * t) * p1
                    + (3.0 * t2 - 2.0 * t) * m1;
                (gap, dgdt / step)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn lobes(n: usize) -> GapProfile {
        GapProfile::GaussianLobes {
            mean_gap: 3.56e-4,
            width: 0.15,
            lobes: n,
        }
    }

    /// The slope is the derivative of the value: centred differences agree to O(δ²).
    fn check_slope(p: &GapProfile, thetas: impl Iterator<Item = f64>, tol: f64) {
        let d = 1e-6;
        for th in thetas {
            let (_, slope) = p.at(th);
            let fd = (p.at(th + d).0 - p.at(th - d).0) / (2.0 * d);
            assert!(
                (slope - fd).abs() <= tol,
                "θ = {th}: slope {slope:e} vs finite difference {fd:e}"
            );
        }
    }

    #[test]
    fn gaussian_lobes_take_the_benchmark_values() {
        let p = lobes(2);
        let gm = 3.56e-4;
        // Lobe centres θ = π/2 + kπ: −g_m, slope 0; between the lobes (θ = 0, π): g_m up to
        // 2 g_m exp(−(0.5/0.15)²) ≈ 1.1e-5 g_m.
        for k in 0..4 {
            let (g, s) = p.at(PI / 2.0 + k as f64 * PI);
            assert!((g + gm).abs() < 1e-15 && s.abs() < 1e-12, "{g} {s}");
            let (g, _) = p.at(k as f64 * PI + 1e-9);
            assert!((g - gm).abs() < 2.0 * (-(0.5f64 / 0.15).powi(2)).exp() * gm * 1.01);
        }
        // One lobe's half-depth points: g = 0 where exp(−x²) = ½, x = ±√ln 2.
        let x = 2f64.ln().sqrt();
        let theta = PI * (0.5 + 0.15 * x);
        assert!(p.at(theta).0.abs() < 1e-15);
        // The benchmark's rate, written out: dg/dt = 4 Ω g_m/(π w) · x/w · exp(−x²) for n = 2.
        let omega = 1344.0;
        let th = 1.3;
        let xs = ((th % PI) / PI - 0.5) / 0.15;
        let expect = 4.0 * omega * gm / (PI * 0.15) * xs * (-xs * xs).exp();
        assert!((omega * p.at(th).1 - expect).abs() < 1e-12 * expect.abs());
        // n lobes repeat with period 2π/n.
        let p5 = lobes(5);
        for th in [0.1, 0.7, 2.9] {
            let (a, b) = (p5.at(th), p5.at(th + TAU / 5.0));
            assert!((a.0 - b.0).abs() < 1e-15 && (a.1 - b.1).abs() < 1e-12);
        }
        check_slope(&p, (0..200).map(|i| 0.031 * i as f64 + 0.01), 1e-9 * gm);
        check_slope(
            &p5,
            (0..200).map(|i| 0.031 * i as f64 + 0.01),
            1e-9 * gm * 5.0,
        );
    }

    #[test]
    fn tabulated_profile_interpolates_its_stations_smoothly() {
        // Samples of a smooth periodic function: the interpolant is exact at the stations,
        // converges at O(h³) between them, and its slope is its derivative.
        let f = |t: f64| 1e-4 * (1.0 + 0.5 * (2.0 * t).cos() + 0.2 * t.sin());
        let err = |n: usize| {
            let p = GapProfile::Tabulated {
                gaps: (0..n).map(|i| f(TAU * i as f64 / n as f64)).collect(),
            };
            for i in 0..n {
                let th = TAU * i as f64 / n as f64;
                assert!((p.at(th).0 - f(th)).abs() < 1e-18, "station {i}");
            }
            check_slope(&p, (0..97).map(|i| 0.0647 * i as f64 + 0.003), 1e-12);
            (0..500)
                .map(|i| {
                    let th = TAU * (i as f64 + 0.37) / 500.0;
                    (p.at(th).0 - f(th)).abs()
                })
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (err(32), err(64));
        assert!(e2 < e1 / 6.0, "errors {e1:e} → {e2:e}: not third order");
        // θ far outside [0, 2π) wraps; a value just below 2π rounds onto the last interval.
        let p = GapProfile::Tabulated {
            gaps: vec![1.0, 2.0, 3.0],
        };
        assert!((p.at(-TAU).0 - 1.0).abs() < 1e-12 && (p.at(5.0 * TAU).0 - 1.0).abs() < 1e-12);
        assert!(p.at(TAU - 1e-17).0.is_finite());
    }

    #[test]
    fn invalid_profiles_name_their_parameter() {
        let bad = [
            (
                GapProfile::GaussianLobes {
                    mean_gap: -1e-4,
                    width: 0.15,
                    lobes: 2,
                },
                "mean_gap",
            ),
            (
                GapProfile::GaussianLobes {
                    mean_gap: 1e-4,
                    width: 0.0,
                    lobes: 2,
                },
                "width",
            ),
            (
                GapProfile::GaussianLobes {
                    mean_gap: 1e-4,
                    width: 0.1,
                    lobes: 0,
                },
                "lobes",
            ),
            (
                GapProfile::Tabulated {
                    gaps: vec![1e-4; 2],
                },
                "at least 3",
            ),
            (
                GapProfile::Tabulated {
                    gaps: vec![1e-4, f64::NAN, 0.0],
                },
                "gap 1",
            ),
        ];
        for (p, word) in bad {
            let e = p.validate().unwrap_err();
            assert!(e.contains(word), "{e}");
        }
        assert!(lobes(2).validate().is_ok());
    }
}
