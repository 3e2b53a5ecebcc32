//! The runaway watch of the time loop (after box 6): on sample steps, the structures' energy
//! and the drive work go to a [`RunawayMonitor`]; once the envelope has doubled, the largest
//! radial harmonic of the casing's contact surface (less the load's quasi-static distortion)
//! is followed ([`WaveTracker`]) so that a confirmed runaway names its wave.

use super::{Casing, FlexibleCasing, Simulation, node_disp};
use crate::dynamics::runaway::{Growth, Runaway, RunawayMonitor, WaveTracker, sector_harmonic};
use crate::dynamics::structure::Structure;
use std::f64::consts::TAU;

/// Periods of the critical wave over which the growing wave's frequency is measured: the
/// latest ones, where it dominates the load's release and the other waves.
const WAVE_PERIODS: f64 = 3.0;

/// What the watch keeps between sample steps.
pub(super) struct RunawayWatch {
    monitor: RunawayMonitor,
    wave: WaveTracker,
    /// Envelope blocks closed when the followed harmonic was last chosen.
    chosen_at_block: Option<u64>,
    /// Strain energy per nodal diameter of the impeller (J), scratch.
    nd_energy: Vec<f64>,
}

impl RunawayWatch {
    /// A watch whose envelope blocks last one period of the wave that can grow: the
    /// flexible casing's critical wave (`casing_wave`: its speed Ω_c in rad/s and nodal
    /// diameter k, frequency k Ω_c), else the impeller's slowest mode at the case's speed.
    /// `None` when no period is known.
    pub(super) fn new(casing_wave: Option<(f64, usize)>, impeller: &Structure) -> Option<Self> {
        let omega = match casing_wave {
            Some((speed, k)) => speed * k as f64,
            None => (impeller.blocks.iter())
                .flat_map(|b| b.omega.iter().copied())
                .filter(|w| *w > 0.0)
                .fold(f64::INFINITY, f64::min),
        };
        (omega.is_finite() && omega > 0.0).then(|| Self {
            monitor: RunawayMonitor::new(TAU / omega),
            wave: WaveTracker::new(WAVE_PERIODS * TAU / omega),
            chosen_at_block: None,
            nd_energy: Vec::new(),
        })
    }
}

impl Simulation<'_> {
    /// Watches for a runaway on sample steps (after box 6, whose energies it reads); sets
    /// `self.runaway` when one is confirmed.
    pub(super) fn watch_runaway(&mut self) {
        if !self.sample_step || self.runaway.is_some() {
            return;
        }
        let Some(mut watch) = self.watch.take() else {
            return;
        };
        let load = match self.case.load {
            Some(_) => self.case.load_factor(self.t1),
            None => 1.0,
        };
        let growth = (watch.monitor).observe(self.t1, self.sample_energy, self.drive_work, load);
        if growth.is_none() && watch.monitor.armed() {
            self.follow_wave(&mut watch);
        }
        // The wave followed so far names the runaway (choosing again on the confirming
        // sample could restart its phase).
        if let Some(g) = growth {
            self.runaway = Some(self.runaway_of(g, &mut watch, false));
        }
        self.watch = Some(watch);
    }

    /// The runaway when this step's contact solve has lost exactness or broken down under a
    /// growth that the watch confirms at the step before, the last one kept
    /// ([`RunawayMonitor::at_breakdown`]); `None` when it sees no such growth: the breakdown
    /// is then no finding.
    pub(super) fn runaway_at_breakdown(&mut self) -> Option<Runaway> {
        let t = self.steps_done as f64 * self.summary.time_step;
        let mut watch = self.watch.take()?;
        let runaway = (watch.monitor.armed())
            .then(|| watch.monitor.at_breakdown(t))
            .flatten()
            .map(|g| self.runaway_of(g, &mut watch, true));
        self.watch = Some(watch);
        runaway
    }

    /// The finding of a confirmed growth `g`, named by the wave followed so far.
    fn runaway_of(&mut self, g: Growth, watch: &mut RunawayWatch, at_breakdown: bool) -> Runaway {
        let (nodal_diameter, rate) = self.growing_wave(watch);
        // ψ̇ − k ω_z: the phase rate seen from the rotating frame; both signed about +z,
        // then taken in the sense of rotation.
        let sense = self.case.rotation.sign();
        let relative = rate
            .zip(nodal_diameter)
            .map(|(r, k)| sense * (r - k as f64 * self.case.angular_velocity()));
        Runaway {
            onset_time_s: g.onset_time_s,
            detected_time_s: g.detected_time_s,
            growth_rate_per_s: 0.5 * g.energy_rate_per_s,
            growth_fit_r2: g.fit_r2,
            energy_growth: g.energy_growth,
            drive_work_j: g.drive_work_j,
            nodal_diameter,
            frequency_hz: rate.map(|r| r.abs() / TAU),
            forward: rate.map(|r| sense * r > 0.0),
            rotating_frame_frequency_hz: relative.map(|r| r / TAU),
            at_solve_breakdown: at_breakdown,
        }
    }

    /// Follows the flexible casing's largest radial harmonic (k ≥ 1) on the contact surface,
    /// choosing it again whenever an envelope block has closed.
    fn follow_wave(&mut self, watch: &mut RunawayWatch) {
        let Casing::Surface(cs) = &mut self.casing else {
            return;
        };
        let (rows, ns) = (cs.rows, cs.n_sectors);
        let Some(f) = cs.flexible.as_mut() else {
            return;
        };
        let kernel = f.kernel.get_mut();
        kernel.node_displacements(&mut f.nodes);
        // The wave, not the load's distortion (which may still be ramping up).
        let load = self.case.load_factor(self.t1);
        for (u, d) in f.nodes.iter_mut().zip(&f.load_distortion) {
            *u -= load * d;
        }
        let closed = watch.monitor.closed_blocks();
        if watch.chosen_at_block != Some(closed) {
            // The wave a reader sees: the largest radial harmonic on the contact surface
            // (strain energy would favour the short waves under the blade tips).
            let (k, row) = (1..=ns / 2)
                .flat_map(|k| (0..rows).map(move |j| (k, j)))
                .map(|(k, j)| {
                    let (re, im) = sector_harmonic(radial_row(f, ns, rows, j), k);
                    ((k, j), re.hypot(im))
                })
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or((1, 0), |(kj, _)| kj);
            watch.wave.follow(k, row);
            watch.chosen_at_block = Some(closed);
        }
        if let Some((k, row)) = watch.wave.target {
            let (re, im) = sector_harmonic(radial_row(f, ns, rows, row), k);
            watch.wave.observe(self.t1, re, im);
        }
    }

    /// The nodal diameter of the growing wave and its phase rate (rad/s, positive forward):
    /// the followed casing harmonic, or the impeller's most energetic one without a flexible
    /// casing (whose phase is not followed).
    fn growing_wave(&mut self, watch: &mut RunawayWatch) -> (Option<u32>, Option<f64>) {
        if let Some((k, _)) = watch.wave.target {
            return (Some(k as u32), watch.wave.phase_rate());
        }
        let kernel = self.blades.kernel.get();
        watch.nd_energy.resize(self.nd_energy.len(), 0.0);
        kernel.nd_strain_energy(&mut watch.nd_energy);
        (Some(most_energetic(&watch.nd_energy) as u32), None)
    }
}

/// Radial displacements (m) of casing row `row` in each of the `ns` sectors, from the node
/// displacements last computed into `f.nodes`.
fn radial_row(
    f: &FlexibleCasing,
    ns: usize,
    rows: usize,
    row: usize,
) -> impl ExactSizeIterator<Item = f64> + '_ {
    (0..ns).map(move |s| f.radial[row].dot(&node_disp(&f.nodes, s, 3 * rows, row)))
}

/// The nodal diameter k ≥ 1 with the most energy (0 when only k = 0 exists).
fn most_energetic(per_nd: &[f64]) -> usize {
    (1..per_nd.len())
        .max_by(|&a, &b| per_nd[a].total_cmp(&per_nd[b]))
        .unwrap_or(0)
}
