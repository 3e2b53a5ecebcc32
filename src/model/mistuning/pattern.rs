//! Mistuning patterns: the per-blade values `δ_s` of a structural mistuning, given one per
//! blade, alternating, or drawn at random for a Monte Carlo sample.
//!
//! A drawn pattern is a pure function of `(seed, sample, blade count)`: sample `m` is stream
//! `m` of the ChaCha8 generator keyed by `seed` (`rand_chacha`, whose output is fixed by its
//! specification on every platform), so a sample does not depend on which other samples a
//! run, a shard or a resume draws, nor on the thread count.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal, StandardUniform};
use serde::{Deserialize, Serialize};

use super::MistuningError;

/// Largest standard deviation of a drawn pattern: 20 % blade-to-blade scatter in modulus is
/// already a different design, and it keeps every drawn `δ` above −1 by five deviations.
pub const MAX_SIGMA: f64 = 0.2;

/// The law the blade values of a drawn pattern follow (zero mean, standard deviation σ).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scatter {
    /// Normal, N(0, σ²): the manufacturing scatter of the literature's Monte Carlo studies.
    #[default]
    Normal,
    /// Uniform on [−√3 σ, √3 σ] (bounded: no blade beyond 1.73 σ).
    Uniform,
}

/// A structural mistuning pattern: how blade `s`'s Young's modulus factor `1 + δ_s` is given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum StiffnessPattern {
    /// One `δ_s` per blade, blade 0 first.
    Explicit {
        /// The values (dimensionless, each > −1).
        values: Vec<f64>,
    },
    /// The intentional pattern of alternate blades: `δ_s = +a` on even blades, `−a` on odd
    /// ones (an even blade count keeps the wheel `N_b/2`-periodic).
    Alternating {
        /// The amplitude `a` (dimensionless, in [0, 1)).
        amplitude: f64,
    },
    /// Monte Carlo sample `sample` of independent draws of standard deviation `sigma`.
    Random {
        /// Standard deviation σ (dimensionless, in [0, [`MAX_SIGMA`]]).
        sigma: f64,
        /// Key of the generator: the study's seed.
        seed: u64,
        /// Index of the sample (the generator's stream).
        sample: u64,
        /// The law of the draws.
        #[serde(default)]
        scatter: Scatter,
    },
}

impl StiffnessPattern {
    /// The values `δ_s` for a wheel of `n_blades`, checked ([`super::check_stiffness_pattern`]);
    /// `field` names the pattern in errors.
    pub fn values(&self, field: &str, n_blades: usize) -> Result<Vec<f64>, MistuningError> {
        let values = match *self {
            StiffnessPattern::Explicit { ref values } => values.clone(),
            StiffnessPattern::Alternating { amplitude } => {
                check_range(field, "amplitude", amplitude, 1.0)?;
                (0..n_blades)
                    .map(|s| if s % 2 == 0 { amplitude } else { -amplitude })
                    .collect()
            }
            StiffnessPattern::Random {
                sigma,
                seed,
                sample,
                scatter,
            } => {
                check_range(field, "sigma", sigma, MAX_SIGMA)?;
                drawn(n_blades, sigma, seed, sample, scatter)
            }
        };
        super::check_stiffness_pattern(field, &values, n_blades)?;
        Ok(values)
    }
}

/// `value` finite and in `[0, max]` (`[0, max)` for `max = 1`), or the error naming it.
fn check_range(field: &str, name: &str, value: f64, max: f64) -> Result<(), MistuningError> {
    let ok = value.is_finite() && value >= 0.0 && (value < max || (max < 1.0 && value == max));
    if ok {
        return Ok(());
    }
    Err(MistuningError::Parameter {
        field: format!("{field}.{name}"),
        value,
        reason: if max < 1.0 {
            format!("must be finite and in [0, {max}]")
        } else {
            format!("must be finite and in [0, {max})")
        },
    })
}

/// Sample `sample` of `n_blades` independent draws of standard deviation `sigma`.
fn drawn(n_blades: usize, sigma: f64, seed: u64, sample: u64, scatter: Scatter) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(sample);
    (0..n_blades)
        .map(|_| match scatter {
            Scatter::Normal => {
                let z: f64 = StandardNormal.sample(&mut rng);
                sigma * z
            }
            Scatter::Uniform => {
                let u: f64 = StandardUniform.sample(&mut rng);
                sigma * 3f64.sqrt() * (2.0 * u - 1.0)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random(sigma: f64, seed: u64, sample: u64, scatter: Scatter) -> StiffnessPattern {
        StiffnessPattern::Random {
            sigma,
            seed,
            sample,
            scatter,
        }
    }

    /// A sample is a pure function of (seed, sample, blade count): drawn twice, or after
    /// other samples, it is the same; another sample or seed differs; the first blades of a
    /// longer wheel's pattern are the shorter wheel's.
    #[test]
    fn a_sample_depends_on_its_seed_and_index_only() {
        let p = random(0.05, 7, 3, Scatter::Normal);
        let a = p.values("m", 24).unwrap();
        let _ = random(0.05, 7, 2, Scatter::Normal).values("m", 24).unwrap();
        assert_eq!(p.values("m", 24).unwrap(), a);
        assert_ne!(
            random(0.05, 7, 4, Scatter::Normal).values("m", 24).unwrap(),
            a
        );
        assert_ne!(
            random(0.05, 8, 3, Scatter::Normal).values("m", 24).unwrap(),
            a
        );
        assert_eq!(p.values("m", 36).unwrap()[..24], a[..]);
    }

    /// Over 20,000 blades the draws have mean 0 and standard deviation σ (within four
    /// standard errors), and the uniform law never leaves ±√3 σ.
    #[test]
    fn draws_have_the_asked_mean_and_deviation() {
        let n = 20_000;
        for scatter in [Scatter::Normal, Scatter::Uniform] {
            let v = random(0.05, 1, 0, scatter).values("m", n).unwrap();
            let mean = v.iter().sum::<f64>() / n as f64;
            let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
            assert!(
                mean.abs() < 4.0 * 0.05 / (n as f64).sqrt(),
                "{scatter:?}: mean {mean}"
            );
            assert!(
                (sd / 0.05 - 1.0).abs() < 4.0 / (2.0 * n as f64).sqrt(),
                "{scatter:?}: sd {sd}"
            );
            if scatter == Scatter::Uniform {
                assert!(v.iter().all(|x| x.abs() <= 3f64.sqrt() * 0.05));
            }
        }
        assert_eq!(
            random(0.0, 1, 0, Scatter::Normal).values("m", 5).unwrap(),
            vec![0.0; 5]
        );
    }

    #[test]
    fn alternating_and_explicit_patterns() {
        let alt = StiffnessPattern::Alternating { amplitude: 0.05 };
        assert_eq!(alt.values("m", 4).unwrap(), vec![0.05, -0.05, 0.05, -0.05]);
        let exp = StiffnessPattern::Explicit {
            values: vec![0.01, 0.0, -0.02],
        };
        assert_eq!(exp.values("m", 3).unwrap(), vec![0.01, 0.0, -0.02]);
    }

    /// Bad values are refused with the field: a pattern of the wrong length, δ ≤ −1, σ < 0, NaN
    /// or above the maximum, an amplitude of 1 or more; a spec with an unknown field too.
    #[test]
    fn bad_patterns_name_the_field() {
        let cases: Vec<(StiffnessPattern, &str)> = vec![
            (
                StiffnessPattern::Explicit {
                    values: vec![0.0; 3],
                },
                "3 values for 4 blades",
            ),
            (
                StiffnessPattern::Explicit {
                    values: vec![0.0, -1.0, 0.0, 0.0],
                },
                "m[1] = -1",
            ),
            (random(-0.01, 0, 0, Scatter::Normal), "m.sigma"),
            (random(f64::NAN, 0, 0, Scatter::Normal), "m.sigma"),
            (random(0.25, 0, 0, Scatter::Normal), "m.sigma"),
            (
                StiffnessPattern::Alternating { amplitude: 1.0 },
                "m.amplitude",
            ),
        ];
        for (pattern, needle) in cases {
            let err = pattern.values("m", 4).unwrap_err().to_string();
            assert!(err.contains(needle), "{pattern:?}: {err}");
        }
        let err = serde_json::from_value::<StiffnessPattern>(serde_json::json!({
            "kind": "random", "sigma": 0.01, "seed": 1, "sample": 0, "sigmaa": 2
        }))
        .unwrap_err()
        .to_string();
        assert!(err.contains("sigmaa"), "{err}");
    }
}
