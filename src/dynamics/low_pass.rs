//! The peak of a signal's content below a band edge, followed on every time step.
//!
//! A blade tip's raw radial peak carries the ringing that contact and coating impacts excite
//! above 15 kHz, in modes that a reduced model with tens of modes per nodal diameter converges
//! slowly: on the headline scan, from 20 to 40 modes per diameter, the raw peaks move by up to
//! 6.9 % and the peaks low-passed at 15 kHz by at most 1.4 % (`docs/validation.md`,
//! "Converged ROMs"). The results table therefore also reports the blade-tip peaks of the
//! displacement low-passed at [`BLADE_BAND_HZ`].
//!
//! The filter is a fourth-order Bessel low-pass: of the classic all-pole filters it has the
//! flattest group delay, so the in-band components of a multi-tone motion keep their relative
//! phases and the filtered peak is the in-band motion's peak (a step overshoots by 0.8 %,
//! against 11 % for a Butterworth filter of the same order). The price is a soft band edge:
//! −1.1 % at 2.75 kHz (the built-in impeller's response), −79 % at twice the edge. It is discretised by the bilinear
//! transform prewarped at the band edge, so its gain at [`BLADE_BAND_HZ`] is exactly
//! `1/√2` at every time step and the filter is the same analog filter, up to `O((ω h)²)`,
//! whatever the step.

/// Band edge (Hz) of the blade-tip peaks low-passed ([`LowPassPeak`]): the −3 dB frequency of
/// their filter. Five times the built-in impeller's 2.75 kHz response; the highest edge at
/// which the headline scan's low-passed peaks converge at 20 modes per nodal diameter (at
/// 20 kHz they move by up to 2.4 % from 20 to 40 modes).
pub const BLADE_BAND_HZ: f64 = 15e3;

/// Poles of the fourth-order Bessel low-pass normalised to −3 dB at 1 rad/s, one of each
/// conjugate pair: `(−Re p, |p|)`.
const BESSEL4_POLES: [(f64, f64); 2] = [
    (0.995_208_764_350_272, 1.603_357_516_216_970_4),
    (1.370_067_830_551_442_2, 1.430_171_559_993_988_4),
];

/// One second-order section `w² / (s² + 2σ s + w²)` after the bilinear transform, direct
/// form II transposed; `a` excludes the leading 1.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
}

impl Biquad {
    /// The section with pole real part `−sigma` and modulus `w` (rad/s), discretised at step
    /// `h` (s) with the bilinear transform's `s = k (z − 1)/(z + 1)`.
    fn bilinear(sigma: f64, w: f64, k: f64) -> Self {
        let (kk, w2) = (k * k, w * w);
        let a0 = kk + 2.0 * sigma * k + w2;
        Self {
            b: [w2 / a0, 2.0 * w2 / a0, w2 / a0],
            a: [2.0 * (w2 - kk) / a0, (kk - 2.0 * sigma * k + w2) / a0],
        }
    }

    /// Output for input `x`, advancing `state`.
    #[inline]
    fn step(&self, state: &mut [f64; 2], x: f64) -> f64 {
        let y = self.b[0] * x + state[0];
        state[0] = self.b[1] * x - self.a[0] * y + state[1];
        state[1] = self.b[2] * x - self.a[1] * y;
        y
    }

    /// The state in which a constant input `x` passes unchanged (unit gain at DC).
    fn rest_state(&self, x: f64) -> [f64; 2] {
        let s1 = (self.b[2] - self.a[1]) * x;
        [(self.b[1] - self.a[0]) * x + s1, s1]
    }
}

/// The fourth-order Bessel low-pass at a band edge, discretised at a time step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BesselLowPass {
    sections: [Biquad; 2],
}

impl BesselLowPass {
    /// The filter with −3 dB at `band_hz` (Hz) for samples every `h` (s). Requires
    /// `0 < band_hz < 1/(2h)` (below the Nyquist frequency).
    pub fn new(band_hz: f64, h: f64) -> Self {
        let wc = std::f64::consts::TAU * band_hz;
        let k = wc / (0.5 * wc * h).tan();
        Self {
            sections: BESSEL4_POLES.map(|(sigma, w)| Biquad::bilinear(sigma * wc, w * wc, k)),
        }
    }

    /// Gain `|H(e^{iωh})|` at frequency `f` (Hz) for the step `h` it was built for.
    pub fn gain(&self, f: f64, h: f64) -> f64 {
        let z = rubscan_fft::Complex64::from_polar(1.0, std::f64::consts::TAU * f * h);
        self.sections
            .iter()
            .map(|s| {
                let num = s.b[0] * z * z + s.b[1] * z + s.b[2];
                let den = z * z + s.a[0] * z + s.a[1];
                (num / den).norm()
            })
            .product()
    }
}

/// The largest |output| of a [`BesselLowPass`] over a bundle of signals sampled together
/// (one per blade), each filter started at rest on its first sample.
#[derive(Clone, Debug, PartialEq)]
pub struct LowPassPeak {
    filter: BesselLowPass,
    /// Per signal, the two sections' states; empty until the first sample.
    states: Vec<[[f64; 2]; 2]>,
    peak: f64,
}

impl LowPassPeak {
    /// A tracker for `filter`, no sample seen.
    pub fn new(filter: BesselLowPass) -> Self {
        Self {
            filter,
            states: Vec::new(),
            peak: 0.0,
        }
    }

    /// Feeds one sample of every signal (same order on every call) and raises the peak.
    pub fn push(&mut self, samples: impl ExactSizeIterator<Item = f64> + Clone) {
        let [first, second] = self.filter.sections;
        if self.states.is_empty() {
            let rest = |x| [first.rest_state(x), second.rest_state(x)];
            self.states = samples.clone().map(rest).collect();
        }
        for ([s1, s2], x) in self.states.iter_mut().zip(samples) {
            let y = second.step(s2, first.step(s1, x));
            self.peak = self.peak.max(y.abs());
        }
    }

    /// Largest |filtered value| so far (the signals' unit).
    pub fn peak(&self) -> f64 {
        self.peak
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const H: f64 = 3.5e-7;

    /// Gain of the analog prototype at `f/band`, from its poles: the digital filter must be
    /// this filter up to the bilinear transform's warping.
    fn analog_gain(ratio: f64) -> f64 {
        let s = rubscan_fft::Complex64::new(0.0, ratio);
        BESSEL4_POLES
            .iter()
            .map(|&(sigma, w)| (w * w / (s * s + 2.0 * sigma * s + w * w)).norm())
            .product()
    }

    #[test]
    fn the_poles_are_the_bessel_polynomial_at_minus_3_db() {
        // The reverse Bessel polynomial θ₄(s) = s⁴ + 10 s³ + 45 s² + 105 s + 105 (unit delay
        // at DC), rescaled to −3 dB at 1 rad/s: its roots are the poles times ω₃.
        let [(s1, w1), (s2, w2)] = BESSEL4_POLES;
        let quad = |sigma: f64, w: f64| [1.0, 2.0 * sigma, w * w];
        let (p, q) = (quad(s1, w1), quad(s2, w2));
        let product = [
            1.0,
            p[1] + q[1],
            p[2] + q[2] + p[1] * q[1],
            p[1] * q[2] + p[2] * q[1],
            p[2] * q[2],
        ];
        let w3 = 105f64.powf(0.25) / product[4].powf(0.25);
        let theta = [1.0, 10.0, 45.0, 105.0, 105.0];
        for (i, (&c, &t)) in product.iter().zip(&theta).enumerate() {
            let scaled = c * w3.powi(i as i32);
            assert!(
                (scaled - t).abs() < 1e-12 * t,
                "coefficient {i}: {scaled} vs {t}"
            );
        }
        assert!((analog_gain(1.0) - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-14);
    }

    #[test]
    fn the_digital_filter_is_the_analog_one_with_its_band_edge_exact() {
        let f = BesselLowPass::new(BLADE_BAND_HZ, H);
        assert!((f.gain(0.0, H) - 1.0).abs() < 1e-12);
        assert!((f.gain(BLADE_BAND_HZ, H) - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12);
        // The bilinear transform maps the digital frequency f to the analog f_a with
        // tan(π f h) / tan(π f_c h) = f_a / f_c: there the two gains are equal.
        let warped = |ratio: f64| {
            let x = std::f64::consts::PI * BLADE_BAND_HZ * H;
            (ratio * x).tan() / x.tan()
        };
        for ratio in [0.05, 0.1375, 0.5, 2.0, 4.0] {
            let digital = f.gain(ratio * BLADE_BAND_HZ, H);
            let analog = analog_gain(warped(ratio));
            assert!(
                (digital / analog - 1.0).abs() < 1e-10,
                "{ratio}: {digital} vs {analog}"
            );
        }
    }

    /// Peak of `x(t)` sampled every `H` over `duration`, low-passed; `x` is faded in over
    /// its first 0.5 ms (a raised cosine), so that no start-up transient adds to the peak.
    fn filtered_peak(duration: f64, x: impl Fn(f64) -> f64) -> f64 {
        let mut peak = LowPassPeak::new(BesselLowPass::new(BLADE_BAND_HZ, H));
        let fade = |t: f64| 0.5 - 0.5 * (std::f64::consts::PI * (t / 5e-4).min(1.0)).cos();
        for n in 0..(duration / H) as usize {
            let t = n as f64 * H;
            let v = fade(t) * x(t);
            peak.push([v, -v].into_iter());
        }
        peak.peak()
    }

    #[test]
    fn an_in_band_tone_keeps_its_peak_and_ringing_above_the_band_is_removed() {
        let tone = |t: f64| 1e-5 * (std::f64::consts::TAU * 2750.0 * t).sin();
        let ringing = |t: f64| 3e-6 * (std::f64::consts::TAU * 80e3 * t).sin();
        let plain = filtered_peak(2e-3, tone);
        // The analog filter's gain at 2.75 kHz.
        let expected = 1e-5 * analog_gain(2750.0 / BLADE_BAND_HZ);
        assert!(
            (plain / expected - 1.0).abs() < 1e-3,
            "{plain} vs {expected}"
        );
        let rung = filtered_peak(2e-3, |t| tone(t) + ringing(t));
        // 80 kHz is over five band edges up, where the Bessel filter passes under 1 %: at
        // most that much of the ringing reaches the peak.
        let passed = BesselLowPass::new(BLADE_BAND_HZ, H).gain(80e3, H);
        assert!(passed < 0.01, "{passed}");
        assert!(
            (rung - plain).abs() <= 1.01 * passed * 3e-6,
            "{rung} vs {plain}"
        );
    }

    #[test]
    fn a_signal_at_rest_from_its_first_sample_passes_unchanged() {
        let mut peak = LowPassPeak::new(BesselLowPass::new(BLADE_BAND_HZ, H));
        for _ in 0..300 {
            peak.push([4e-5, -2e-5].into_iter());
        }
        assert!((peak.peak() / 4e-5 - 1.0).abs() < 1e-12, "{}", peak.peak());
    }

    #[test]
    fn a_two_tone_in_band_motion_keeps_its_peak_as_the_filter_keeps_phases() {
        // 2 kHz and 6 kHz in phase: a peak where both crest (every 0.5 ms from 0.625 ms). A
        // filter whose delay differed between the tones would move one crest off the other.
        let tau = std::f64::consts::TAU;
        let x = |t: f64| {
            let a = tau * 2e3 * (t - 1.25e-4);
            1e-5 * a.cos() + 5e-6 * (3.0 * a).cos()
        };
        let peak = filtered_peak(3e-3, x);
        let gain = |f: f64| analog_gain(f / BLADE_BAND_HZ);
        let gains = 1e-5 * gain(2e3) + 5e-6 * gain(6e3);
        assert!((peak / gains - 1.0).abs() < 2e-3, "{peak} vs {gains}");
    }
}
