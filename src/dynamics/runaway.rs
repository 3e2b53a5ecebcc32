//! Online detection of a runaway: the structures' vibration energy growing exponentially,
//! fed by the work of the imposed rotation, after the external load has stopped growing.
//!
//! Above a flexible casing's critical wave speed a closed rotating contact can feed the
//! casing's waves (forward, slower than the blades) with the rotation's energy (the
//! moving-load instability: Iwan & Moeller 1976, rotor and stator exchanged;
//! `tests/supercritical.rs`). The simulation then
//! grows until the contact solve gives up. That growth is the answer a scan asks for, so it
//! is detected while it happens and the job stops with its figures.
//!
//! # Criterion
//! The energy `E(t)` (kinetic + strain, both structures) is divided by the square of the
//! largest amplitude factor `r(t)` the external load has reached so far (1 without a load):
//! the response of a bounded system to a load of amplitude `r` is of order `r`, its energy of
//! order `r²` (with a clearance it is `∝ (r − r_c)² ≤ r²`), so `E / r²` stays bounded while
//! the load grows and only an instability makes it grow by decades. It is watched once the
//! load has reached half its amplitude (`r ≥ ½`, a factor of at most 4) because the fastest
//! runaways (well above the critical wave speed) have grown by decades, and broken the
//! contact solve, before the load's ramp ends. That energy is reduced to its envelope: the
//! largest sample of each block of one period `T_w` of the wave that can grow (the casing's
//! critical wave, else the impeller's slowest mode). The growth
//! may start from any block lower than every later one (a candidate onset: the response can
//! settle on a plateau or dip before it runs away); a runaway is confirmed when, over the
//! blocks from one candidate onset to the last,
//! 1. at least [`MIN_PERIODS`] periods have passed (several periods of the growing wave) and
//!    the envelope grew by at least [`MIN_ENERGY_GROWTH`], or at least [`FAST_MIN_PERIODS`]
//!    and [`FAST_MIN_ENERGY_GROWTH`] (a growth that would break the contact solve first),
//! 2. the last block is the largest,
//! 3. `ln E` fits a straight line in time with `R² ≥` [`MIN_FIT_R2`] (exponential growth),
//! 4. the second half's slope is at least [`MIN_SLOPE_RATIO`] of the first half's: the
//!    growth does not slow down (a forced or beating build-up from a small amplitude, or
//!    one that saturates into a limit cycle, decelerates; a runaway does not),
//! 5. the (undivided) energy gained is at most the rotation's work through the contact
//!    forces and at least [`MIN_STORED_SHARE`] of it: the growth is fed by the drive, not by
//!    the load, and stores a fair share of what the drive does (a forced rub, even one
//!    building up into a resonance, dissipates nearly all of it in friction).
//!
//! Of the onsets that pass, the one whose window fits an exponential best is reported. A
//! growth that takes the contact solve past exactness, or breaks it, before it is confirmed
//! (far above the critical wave speed the contact forces reach hundreds of kN within five
//! periods) is confirmed there ([`RunawayMonitor::at_breakdown`]) when it passes tests 1–3
//! and 5 with the unfinished block as its last: the growth has outrun the solve, which a
//! bounded response does not (what test 4 stands for), and a growth that long and that
//! large, fed by the drive, is no forced build-up (test 1's fast branch).
//! ring-down never passes 2 (its last block is its lowest), so it is never called unstable.
//! The amplitude growth rate is half the fitted slope of `ln E`.
//!
//! The wave's nodal diameter and frequency come from [`WaveTracker`], which follows the
//! phase of one casing harmonic on the contact surface once the envelope has doubled.

use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Fewest wave periods between the onset and the confirmation of a runaway.
pub const MIN_PERIODS: usize = 6;
/// Smallest energy growth (ratio of envelopes) that confirms a runaway: an amplitude growth
/// of √10 ≈ 3.2.
pub const MIN_ENERGY_GROWTH: f64 = 10.0;
/// Smallest share of the rotation's work that a runaway stores as vibration energy. The
/// runaways of the built-in models store 0.2–0.7 of it; the resonant build-ups of the
/// Rotor 37 blade against a rigid two-lobe casing (decades of growth, then a bounded
/// response) store 0.003–0.014, the rest going to friction.
pub const MIN_STORED_SHARE: f64 = 0.05;
/// Fewest periods, and smallest energy growth, that confirm a fast runaway. Far above the
/// critical wave speed the energy grows up to sevenfold per period and breaks the contact
/// solve within five (case study 2 at 1.18 Ω*₅); two decades in four periods is no forced
/// build-up (a resonance captured as the contact stiffens the blade gains one decade in
/// four, Rotor 37 two-lobe scan).
pub const FAST_MIN_PERIODS: usize = 4;
/// See [`FAST_MIN_PERIODS`].
pub const FAST_MIN_ENERGY_GROWTH: f64 = 100.0;
/// Smallest coefficient of determination of the exponential fit of the envelope.
pub const MIN_FIT_R2: f64 = 0.8;
/// Smallest ratio of the second half's growth rate to the first half's. An algebraic build-up
/// `E ∝ t²` from rest (a forced response, or beats from a node) gives at most 0.57 over a
/// decade of growth, and less over more; the runaways of case study 2 give 0.9 to 3.9.
pub const MIN_SLOPE_RATIO: f64 = 0.7;
/// Envelope growth (ratio) above which the wave's phase is tracked.
const ARM_GROWTH: f64 = 2.0;
/// Most blocks kept since the onset candidate (bounded memory on a long bounded response).
const MAX_BLOCKS: usize = 4096;

/// A runaway detected by [`RunawayMonitor`]: when it started, how fast it grew and which wave.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Runaway {
    /// Onset (s): the mid-time of the envelope block the growth starts from (of the candidate
    /// onsets that confirm it, the one with the best exponential fit; module doc).
    pub onset_time_s: f64,
    /// Time (s) at which the runaway was confirmed and the simulation stopped.
    pub detected_time_s: f64,
    /// Amplitude growth rate σ (1/s): half the fitted slope of `ln E` over onset → detection.
    pub growth_rate_per_s: f64,
    /// Coefficient of determination R² of that exponential fit, in [0, 1].
    pub growth_fit_r2: f64,
    /// Growth of the energy envelope from the onset to the detection (ratio ≥ 10).
    pub energy_growth: f64,
    /// Work (J) the rotation did through the contact forces from the onset to the detection.
    pub drive_work_j: f64,
    /// Nodal diameter of the growing wave: the casing's largest radial harmonic on its
    /// contact surface while the envelope grew (the impeller's harmonic holding the most
    /// strain energy at detection, without a flexible casing).
    pub nodal_diameter: Option<u32>,
    /// Frequency (Hz, fixed frame, ≥ 0) of the growing casing wave, from its phase rate on
    /// the contact surface over the last three periods; `None` without a flexible casing or
    /// when too few samples were tracked.
    pub frequency_hz: Option<f64>,
    /// Whether the casing wave travels in the sense of rotation in the fixed frame; `None` as
    /// above. Above the critical wave speed the wave that grows is the casing's forward wave
    /// dragged along by the rotating contact: backward in the rotating frame when slower
    /// than the blades (Iwan & Moeller's anomalous Doppler wave, frames exchanged).
    pub forward: Option<bool>,
    /// Its frequency in the rotating frame (Hz, signed: positive when it travels ahead of the
    /// blades), `f − kΩ/2π` for a forward wave of nodal diameter k; `None` as above.
    pub rotating_frame_frequency_hz: Option<f64>,
    /// Whether the growth took the contact solve past exactness (a residual penetration
    /// above `EXACT_CONTACT_SHARE` of the blade-tip level) or broke it before the watch's
    /// steady-rate test could confirm it, and was confirmed there
    /// ([`RunawayMonitor::at_breakdown`]). A step that broke is not kept.
    #[serde(default)]
    pub at_solve_breakdown: bool,
}

/// One block of the energy envelope.
#[derive(Debug, Clone, Copy)]
struct Block {
    /// Block index `⌊(t − start) / T_w⌋`.
    index: i64,
    /// Largest energy of the block divided by the largest load factor so far squared (J), and
    /// the energy (J) then.
    energy: f64,
    raw_energy: f64,
    /// The block's mid-time (s): where its envelope sample stands in the fit (the time of
    /// the largest sample would wander within the block and bias the slopes).
    time: f64,
    /// Drive work (J) at the block's last sample.
    drive_work: f64,
}

/// A confirmed exponential growth of the energy envelope (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Growth {
    /// Onset (s): the mid-time of the envelope block the growth starts from.
    pub onset_time_s: f64,
    /// Time (s) of the sample that confirmed the growth.
    pub detected_time_s: f64,
    /// Fitted slope of `ln E` (1/s): twice the amplitude growth rate.
    pub energy_rate_per_s: f64,
    /// R² of that fit.
    pub fit_r2: f64,
    /// Envelope ratio from the onset block to the last one.
    pub energy_growth: f64,
    /// Drive work (J) from the onset block to the last one.
    pub drive_work_j: f64,
}

/// Watches the energy of a running simulation for a runaway (module doc).
#[derive(Debug, Clone)]
pub struct RunawayMonitor {
    period: f64,
    /// Time (s) the watch started (the load reached half its amplitude) and the largest load
    /// factor so far.
    start: Option<f64>,
    peak_load: f64,
    current: Option<Block>,
    /// Finished blocks since the lowest one (its front), in time order.
    blocks: VecDeque<Block>,
    closed: u64,
}

impl RunawayMonitor {
    /// A monitor with envelope blocks of `period` (s, > 0: one period of the wave that can grow).
    pub fn new(period: f64) -> Self {
        Self {
            period,
            start: None,
            peak_load: 0.0,
            current: None,
            blocks: VecDeque::new(),
            closed: 0,
        }
    }

    /// Takes the sample at time `t` (s): vibration energy `energy` (J) of both structures, the
    /// drive work (J) so far and the external load's amplitude factor `load` in [0, 1] (1
    /// without a load). Returns the growth when this sample confirms a runaway.
    pub fn observe(&mut self, t: f64, energy: f64, drive_work: f64, load: f64) -> Option<Growth> {
        self.peak_load = self.peak_load.max(load);
        if self.peak_load < 0.5 {
            return None;
        }
        let start = *self.start.get_or_insert(t);
        let index = ((t - start) / self.period).floor() as i64;
        let per_load = energy / (self.peak_load * self.peak_load);
        if let Some(b) = self.current.as_mut().filter(|b| b.index == index) {
            if per_load > b.energy {
                (b.energy, b.raw_energy) = (per_load, energy);
            }
            b.drive_work = drive_work;
            return None;
        }
        let done = self.current.replace(Block {
            index,
            energy: per_load,
            raw_energy: energy,
            time: start + (index as f64 + 0.5) * self.period,
            drive_work,
        })?;
        self.push(done);
        self.closed += 1;
        self.confirmed(t, true)
    }

    /// The growth at time `t` (s) when the contact solve has lost exactness or broken down:
    /// the blocks since a candidate onset, the unfinished one last, passing every test of the
    /// criterion but the steady rate (module doc). `None` when they do not: the breakdown is
    /// then no finding.
    pub fn at_breakdown(&self, t: f64) -> Option<Growth> {
        let mut upto_now = self.clone();
        upto_now.push(self.current?);
        upto_now.confirmed(t, false)
    }

    /// Whether the envelope has grown by [`ARM_GROWTH`] since its lowest block: a candidate
    /// runaway whose wave is worth tracking.
    pub fn armed(&self) -> bool {
        match (self.blocks.front(), self.blocks.back()) {
            (Some(lo), Some(hi)) => hi.energy >= ARM_GROWTH * lo.energy,
            _ => false,
        }
    }

    /// Envelope blocks closed so far (a caller refreshes what it tracks when this changes).
    pub fn closed_blocks(&self) -> u64 {
        self.closed
    }

    /// Keeps a closed block; the blocks before the lowest one can no longer start a growth
    /// window (module doc) and are dropped.
    fn push(&mut self, done: Block) {
        if self.blocks.front().is_none_or(|lo| done.energy < lo.energy) {
            self.blocks.clear();
        }
        self.blocks.push_back(done);
        if self.blocks.len() > MAX_BLOCKS {
            self.blocks.pop_front();
            let lowest = (0..self.blocks.len())
                .min_by(|&a, &b| self.blocks[a].energy.total_cmp(&self.blocks[b].energy))
                .unwrap_or(0);
            self.blocks.drain(..lowest);
        }
    }

    /// The growth when the blocks from a candidate onset (a block lower than every later
    /// one) to the last pass every test of the criterion (test 4 only when `steady_rate`); of
    /// several such onsets, the one whose window fits an exponential best.
    fn confirmed(&self, t: f64, steady_rate: bool) -> Option<Growth> {
        let hi = self.blocks.back()?;
        // Candidate onsets, latest first, with whether no later block exceeds the last.
        let mut onsets = Vec::new();
        let (mut lowest, mut highest) = (f64::INFINITY, f64::NEG_INFINITY);
        for (j, b) in self.blocks.iter().enumerate().rev() {
            highest = highest.max(b.energy);
            if b.energy < lowest {
                lowest = b.energy;
                onsets.push((j, highest <= hi.energy));
            }
        }
        (onsets.into_iter())
            .filter(|&(_, last_largest)| last_largest)
            .filter_map(|(j, _)| self.growth_from(j, t, steady_rate))
            .max_by(|a, b| a.fit_r2.total_cmp(&b.fit_r2))
    }

    /// The growth over the blocks from `onset` to the last, confirmed at time `t` (s), when
    /// they pass tests 1–5 (test 4 only when `steady_rate`; the last block being known to be
    /// their largest).
    fn growth_from(&self, onset: usize, t: f64, steady_rate: bool) -> Option<Growth> {
        let (lo, hi) = (&self.blocks[onset], self.blocks.back()?);
        let (periods, growth) = (self.blocks.len() - onset - 1, hi.energy / lo.energy);
        let long_enough = |min_periods, min_growth| periods >= min_periods && growth >= min_growth;
        if !(long_enough(MIN_PERIODS, MIN_ENERGY_GROWTH)
            || long_enough(FAST_MIN_PERIODS, FAST_MIN_ENERGY_GROWTH))
        {
            return None;
        }
        let fed = hi.drive_work - lo.drive_work;
        let gained = hi.raw_energy - lo.raw_energy;
        if !(gained <= fed && gained >= MIN_STORED_SHARE * fed) {
            return None;
        }
        let all: Vec<(f64, f64)> = (self.blocks.iter().skip(onset))
            .map(|b| (b.time, b.energy.ln()))
            .collect();
        let (slope, r2) = line_fit(&all)?;
        let half = all.len() / 2;
        let (early_slope, _) = line_fit(&all[..=half])?;
        let (late_slope, _) = line_fit(&all[half..])?;
        let steady = late_slope >= MIN_SLOPE_RATIO * early_slope || !steady_rate;
        if !(slope > 0.0 && r2 >= MIN_FIT_R2 && steady) {
            return None;
        }
        Some(Growth {
            onset_time_s: lo.time,
            detected_time_s: t,
            energy_rate_per_s: slope,
            fit_r2: r2,
            energy_growth: growth,
            drive_work_j: fed,
        })
    }
}

/// Least-squares line through `(x, y)` points: its slope and its R² (`None` for fewer than
/// three points or no spread in x or y).
fn line_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if points.len() < 3 {
        return None;
    }
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in points {
        let (dx, dy) = (x - mx, y - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    if !(sxx > 0.0 && syy > 0.0) {
        return None;
    }
    Some((sxy / sxx, sxy * sxy / (sxx * syy)))
}

/// Follows the phase of one casing harmonic on the contact surface: the complex amplitude
/// `c_k(t) = Σ_s u_r(s) e^{−ikθ_s}` of nodal diameter k of one row's radial displacement
/// (the simulation takes the external load's quasi-static distortion out first).
/// A wave `u_r = A cos(kθ − ψ(t))` gives `c_k ∝ e^{−iψ}`: the wave travels toward +θ
/// (counter-clockwise about +z) when `ψ` grows, and its fixed-frame frequency is
/// `|dψ/dt| / 2π`.
#[derive(Debug, Clone, Default)]
pub struct WaveTracker {
    /// The nodal diameter and casing row followed (`None`: nothing followed yet).
    pub target: Option<(usize, usize)>,
    /// Length (s) of the latest stretch of samples the phase rate is measured over.
    span: f64,
    /// The phase ψ (rad) of the last sample, and the samples `(t, unwrapped ψ)` of the last
    /// `span`.
    last_phase: f64,
    recent: VecDeque<(f64, f64)>,
}

impl WaveTracker {
    /// A tracker that measures the phase rate over the last `span` seconds of samples (a
    /// few periods: the growing wave dominates the latest ones).
    pub fn new(span: f64) -> Self {
        Self {
            span,
            ..Self::default()
        }
    }

    /// Follows nodal diameter `k` on casing row `row` from now on (a new target restarts).
    pub fn follow(&mut self, k: usize, row: usize) {
        if self.target != Some((k, row)) {
            *self = Self {
                target: Some((k, row)),
                ..Self::new(self.span)
            };
        }
    }

    /// Takes the harmonic's complex amplitude `(re, im)` at time `t` (s). Samples must come
    /// more often than twice per wave period (the phase is unwrapped between them).
    pub fn observe(&mut self, t: f64, re: f64, im: f64) {
        let psi = -im.atan2(re);
        let unwrapped = match self.recent.back() {
            None => psi,
            Some(&(_, prev)) => {
                let mut d = psi - self.last_phase;
                d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
                prev + d
            }
        };
        self.last_phase = psi;
        self.recent.push_back((t, unwrapped));
        while self
            .recent
            .front()
            .is_some_and(|&(t0, _)| t - t0 > self.span)
        {
            self.recent.pop_front();
        }
    }

    /// The phase rate dψ/dt (rad/s) over the last span of samples: positive for a wave
    /// travelling toward +θ. `None` before two samples.
    pub fn phase_rate(&self) -> Option<f64> {
        let (&(t0, p0), &(t1, p1)) = (self.recent.front()?, self.recent.back()?);
        (t1 > t0).then(|| (p1 - p0) / (t1 - t0))
    }
}

/// The casing harmonic `c_k = Σ_s u_s e^{−ikθ_s}` (`θ_s = 2πs/N`) of the values `u_s` of one
/// row over the N sectors, as `(re, im)`.
pub fn sector_harmonic(values: impl ExactSizeIterator<Item = f64>, k: usize) -> (f64, f64) {
    let n = values.len() as f64;
    values.enumerate().fold((0.0, 0.0), |(re, im), (s, u)| {
        let th = std::f64::consts::TAU * (k * s) as f64 / n;
        (re + u * th.cos(), im - u * th.sin())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// Feeds `energy(t)` (with a drive work that always covers it twice) sampled every `dt`
    /// up to `t_end`; returns the growth that confirmed a runaway, if any.
    fn watch(energy: impl Fn(f64) -> f64, period: f64, dt: f64, t_end: f64) -> Option<Growth> {
        watch_loaded(energy, |_| 1.0, period, dt, t_end)
    }

    /// The same under an external load of amplitude factor `load(t)`.
    fn watch_loaded(
        energy: impl Fn(f64) -> f64,
        load: impl Fn(f64) -> f64,
        period: f64,
        dt: f64,
        t_end: f64,
    ) -> Option<Growth> {
        let mut m = RunawayMonitor::new(period);
        let n = (t_end / dt) as usize;
        (0..=n).find_map(|i| {
            let t = i as f64 * dt;
            m.observe(t, energy(t), 2.0 * energy(t), load(t))
        })
    }

    /// An oscillating energy (a standing wave exchanges kinetic and strain energy twice per
    /// period) under an envelope `env`.
    fn wave(env: impl Fn(f64) -> f64, f: f64) -> impl Fn(f64) -> f64 {
        move |t| env(t) * (1.0 + 0.3 * (2.0 * TAU * f * t).cos())
    }

    #[test]
    fn an_exponential_growth_is_confirmed_with_its_rate() {
        let (f, sigma) = (3500.0, 300.0);
        let g = watch(wave(|t| (2.0 * sigma * t).exp(), f), 1.0 / f, 1e-6, 0.05).unwrap();
        let measured = 0.5 * g.energy_rate_per_s;
        assert!(
            (measured - sigma).abs() < 0.03 * sigma,
            "{measured} vs {sigma}"
        );
        assert!(
            g.fit_r2 > 0.99 && g.energy_growth >= MIN_ENERGY_GROWTH,
            "{g:?}"
        );
        // Confirmed as soon as the energy grew tenfold (ln 10 / 2σ ≈ 3.8 ms), not much later.
        let t10 = 10f64.ln() / (2.0 * sigma);
        assert!(g.detected_time_s < t10 + 3.0 / f, "{g:?}");
    }

    /// A growth of sevenfold per period is called after four periods, before the six a
    /// slower one needs; a decade gained in four periods that then stops is not.
    #[test]
    fn a_fast_runaway_is_called_after_four_periods_and_two_decades() {
        let f = 3500.0;
        let sigma = 0.5 * 7f64.ln() * f;
        let g = watch(wave(|t| (2.0 * sigma * t).exp(), f), 1.0 / f, 1e-6, 0.01).unwrap();
        // Four periods after the first block closes (the block in which the growth starts).
        assert!(g.detected_time_s < 5.01 / f, "{g:?}");
        let sigma = 0.5 * 10f64.ln() / 4.0 * f;
        let capture = |t: f64| (2.0 * sigma * t).exp().min(10.0);
        assert!(watch(wave(capture, f), 1.0 / f, 1e-6, 0.01).is_none());
    }

    /// A growth that slows down as it runs (ln E ∝ √t: four decades in six periods, the
    /// second half's rate half the first's) is not confirmed by the watch; when the contact
    /// solve breaks under it, it is confirmed at the breakdown. A bounded response, or a
    /// decade gained and then held, is not: that breakdown is a failure.
    #[test]
    fn a_growth_that_breaks_the_solve_is_confirmed_at_the_breakdown() {
        let f = 3500.0;
        let fed = |env: &dyn Fn(f64) -> f64, t_end: f64| {
            let mut m = RunawayMonitor::new(1.0 / f);
            let energy = wave(env, f);
            let n = (t_end * 1e6) as usize;
            let called = (0..=n).find_map(|i| {
                let t = i as f64 * 1e-6;
                m.observe(t, energy(t), 2.0 * energy(t), 1.0)
            });
            (m, called)
        };
        let slowing = |t: f64| (1e4f64.ln() / 6f64.sqrt() * (t * f).sqrt()).exp();
        let t_break = 6.6 / f;
        let (m, called) = fed(&slowing, t_break);
        assert!(called.is_none(), "{called:?}");
        let g = m.at_breakdown(t_break).expect("confirmed at the breakdown");
        assert!(g.energy_growth >= FAST_MIN_ENERGY_GROWTH, "{g:?}");
        assert_eq!(g.detected_time_s, t_break);
        for bounded in [
            &(|_: f64| 1.0) as &dyn Fn(f64) -> f64,
            &|t: f64| (t * f).powi(2).min(10.0),
            &|t: f64| (-50.0 * t).exp(),
        ] {
            let (m, _) = fed(bounded, t_break);
            assert!(m.at_breakdown(t_break).is_none());
        }
    }

    #[test]
    fn a_ring_down_is_never_called() {
        let f = 3500.0;
        assert!(watch(wave(|t| (-50.0 * t).exp(), f), 1.0 / f, 1e-6, 0.1).is_none());
        // A ring-down with beats (two close frequencies) neither.
        let beat = |t: f64| (-30.0 * t).exp() * (1.0 + (TAU * 200.0 * t).cos()).max(1e-9);
        let g = watch(wave(beat, f), 1.0 / f, 1e-6, 0.1);
        assert!(g.is_none(), "{g:?}");
    }

    #[test]
    fn a_build_up_that_slows_down_is_not_a_runaway() {
        let f = 3500.0;
        // Forced resonance from rest, E ∝ (1 − e^{−ζωt})²: grows by decades, then saturates.
        let forced = |t: f64| (1.0 - (-40.0 * t).exp()).powi(2) + 1e-12;
        assert!(watch(wave(forced, f), 1.0 / f, 1e-6, 0.2).is_none());
        // Undamped build-up, E ∝ t² from a small start: algebraic, decelerating in ln E.
        let algebraic = |t: f64| (1e-4 + t).powi(2);
        assert!(watch(wave(algebraic, f), 1.0 / f, 1e-6, 0.2).is_none());
        // An exponential growth into a limit cycle: called only if it is confirmed before
        // it saturates, which takes a decade of growth at a steady rate (here it stops at 4×).
        let limit = |t: f64| (2.0 * 300.0 * t).exp().min(4.0);
        assert!(watch(wave(limit, f), 1.0 / f, 1e-6, 0.2).is_none());
    }

    /// While a load ramps up to t_r the energy of a bounded response grows with the load's
    /// square, from contact onward faster (a clearance: `∝ (r − r_c)²`); neither is called,
    /// even with a contact that ends up holding 50 times the load's energy. A runaway that
    /// starts during the ramp is called before the ramp ends, its rate biased up by the
    /// contact's share of the build-up (here the threefold of the built-in models' ramps).
    #[test]
    fn a_load_ramp_is_not_a_runaway_but_a_runaway_during_it_is() {
        let (f, t_r) = (3500.0, 4e-3);
        let ramp = move |t: f64| (t / t_r).min(1.0);
        let contact = move |stiffness: f64| {
            move |t: f64| {
                let r = ramp(t);
                r * r + stiffness * (r - 0.6).max(0.0).powi(2)
            }
        };
        for stiffness in [12.0, 300.0] {
            let g = watch_loaded(wave(contact(stiffness), f), ramp, 1.0 / f, 1e-6, 0.02);
            assert!(g.is_none(), "{g:?}");
        }
        let stiff_contact = contact(12.0);
        let sigma = 1500.0;
        let runaway = move |t: f64| stiff_contact(t) * (2.0 * sigma * t).exp();
        let g = watch_loaded(wave(runaway, f), ramp, 1.0 / f, 1e-6, 0.02).unwrap();
        assert!(g.detected_time_s < t_r, "{g:?}");
        let measured = 0.5 * g.energy_rate_per_s;
        assert!(
            measured > sigma && measured < 1.25 * sigma,
            "{measured} vs {sigma}"
        );
    }

    /// A response that settles, dips and only then runs away: the growth is timed from the
    /// dip (the lowest block before it), not from the first low block.
    #[test]
    fn a_runaway_after_a_plateau_is_timed_from_its_own_onset() {
        let (f, sigma, t0) = (3500.0, 800.0, 6e-3);
        let env = move |t: f64| {
            let hump = 1.0 + 2.0 * (-((t - 3e-3) / 1e-3).powi(2)).exp();
            hump * (2.0 * sigma * (t - t0).max(0.0)).exp()
        };
        let g = watch(wave(env, f), 1.0 / f, 1e-6, 0.03).unwrap();
        assert!(
            (g.onset_time_s - t0).abs() < 2.0 / f,
            "onset {} s vs {t0} s",
            g.onset_time_s
        );
        let measured = 0.5 * g.energy_rate_per_s;
        assert!(
            (measured - sigma).abs() < 0.05 * sigma,
            "{measured} vs {sigma}"
        );
    }

    #[test]
    fn growth_not_fed_by_the_drive_or_storing_little_of_its_work_is_not_a_runaway() {
        let f = 3500.0;
        let e = wave(|t| (600.0 * t).exp(), f);
        // No drive work; a drive work 40 times the energy (friction takes nearly all of
        // it); the same growth storing half the drive's work, which is called.
        let called = [0.0, 40.0, 2.0].map(|work_per_energy| {
            let mut m = RunawayMonitor::new(1.0 / f);
            (0..50_000).find_map(|i| {
                let t = i as f64 * 1e-6;
                m.observe(t, e(t), work_per_energy * e(t), 1.0)
            })
        });
        assert!(called[0].is_none() && called[1].is_none(), "{called:?}");
        assert!(called[2].is_some());
    }

    #[test]
    fn the_tracker_gives_the_signed_phase_rate_of_a_travelling_wave() {
        let (n, k, f) = (100, 5, 3400.0);
        for dir in [1.0, -1.0] {
            let mut tr = WaveTracker::new(1e-3);
            tr.follow(k, 4);
            for i in 0..400 {
                let t = i as f64 * 2e-5;
                let psi = dir * TAU * f * t;
                let u = (0..n).map(|s| 1e-3 * (k as f64 * TAU * s as f64 / n as f64 - psi).cos());
                let (re, im) = sector_harmonic(u, k);
                tr.observe(t, re, im);
            }
            let rate = tr.phase_rate().unwrap();
            assert!((rate - dir * TAU * f).abs() < 1e-6 * TAU * f, "{rate}");
        }
    }
}
