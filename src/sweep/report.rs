//! `rubscan report`: the paper's figures from a sweep's results directory: the response
//! against Ω with the jobs' outcomes and the predictions ([`crate::sweep::scan_figure`]),
//! time histories of selected jobs with their wear profiles (Figs. 16–17), strain energy per
//! nodal diameter
//! (Fig. 18), the Campbell diagram with the critical speeds and their mode compatibility
//! (Fig. 19) and the interaction map zoomed to the band that matters (Fig. 20), all as PNG,
//! plus one `index.html` showing them with units in the captions.
//!
//! Inputs: `manifest.json` (the spec, hence the models for the Campbell diagram),
//! `results.parquet` (the per-job table) and, when the sweep ran with `--timeseries`,
//! `timeseries/<job id>.parquet`. A missing or malformed manifest or table stops the report
//! before anything is written, naming the file; a missing series or unloadable models only
//! leave their panels out, with a note on the page. No figure is drawn without data: without
//! stored series the time-history panels are left out with one note saying how to get them.

use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::io::atomic::write_atomic;
use crate::io::timeseries::read_columns;
use crate::sweep::checkpoint::Outcomes;
use crate::sweep::figures::{
    HistoryPanel, JobHistory, NdEnergyData, TimeHistoryData, history_panels, nd_energy_bars,
    time_histories,
};
use crate::sweep::planner::slice_label;
use crate::sweep::plots::{
    CampbellData, CasingMode, ImpellerBranch, ModeLine, PlotError, PlotLabels, SpectrumColumn,
    campbell_diagram, deepest_wear, interaction_data_from_records, interaction_map,
};
use crate::sweep::scan_figure::{
    DEFAULT_SCAN_QUANTITY, FIRST_SCAN_LINES, ScanOverlays, ScanQuantity, response_against_speed,
    scan_caption, scan_data, scan_rows,
};
use crate::sweep::simulator::ModelSimulator;
use crate::sweep::spec::CasingSource;
use crate::sweep::table::read_records;
use crate::sweep::{CriticalSpeed, JobRecord, SweepSpec, read_manifest};

/// Jobs overlaid in the per-job figures when none are named: more lines are unreadable.
pub const DEFAULT_MAX_JOBS: usize = 6;

/// Why a report could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file of the results directory is missing or malformed (or a named job is not in it).
    #[error("{}: {reason}", path.display())]
    Input {
        /// The file (or directory) at fault.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// An option is out of range (named, with the reason).
    #[error("{0}")]
    Option(String),
    /// A figure could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// `index.html` could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The page.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// A results directory as read for a report.
#[derive(Debug, Clone)]
pub struct ResultsDir {
    /// The directory.
    pub dir: PathBuf,
    /// The sweep spec stored in its manifest.
    pub spec: SweepSpec,
    /// Its table: `(job index, record)` in job order.
    pub records: Vec<(usize, JobRecord)>,
}

/// Reads `manifest.json` and `results.parquet` of `dir`; errors name the file at fault.
pub fn load_results(dir: &Path) -> Result<ResultsDir, ReportError> {
    let input = |path: PathBuf, reason: String| ReportError::Input { path, reason };
    if !dir.is_dir() {
        let reason = if dir.exists() {
            "not a directory (expected the output directory of `rubscan run` or `merge`)"
        } else {
            "not a results directory (no such directory)"
        };
        return Err(input(dir.to_path_buf(), reason.into()));
    }
    let manifest_path = dir.join("manifest.json");
    let manifest = read_manifest(dir).map_err(|e| {
        let reason = format!("{:#}", e.root_cause());
        let reason = if manifest_path.exists() {
            format!("malformed manifest: {reason}")
        } else {
            "missing (not the output directory of `rubscan run` or `merge`?)".into()
        };
        input(manifest_path.clone(), reason)
    })?;
    let table = dir.join("results.parquet");
    if !table.is_file() {
        let reason = if table.is_dir() {
            "a directory, not the Parquet table of the sweep"
        } else if table.exists() {
            "not a regular file, not the Parquet table of the sweep"
        } else {
            "missing (the sweep has not finished?)"
        };
        return Err(input(table, reason.into()));
    }
    let records = read_records(&table).map_err(|e| input(table.clone(), format!("{e:#}")))?;
    if !records.iter().any(|(_, r)| r.succeeded()) {
        return Err(input(table, "no successful job to report".into()));
    }
    Ok(ResultsDir {
        dir: dir.to_path_buf(),
        spec: manifest.spec,
        records,
    })
}

/// Largest blade radial displacement of a job (m), leading or trailing edge; 0 when failed.
fn blade_peak(r: &JobRecord) -> f64 {
    r.result.as_ref().map_or(0.0, |x| {
        x.maxima.blade_le_radial_m.max(x.maxima.blade_te_radial_m)
    })
}

/// The jobs to overlay (job indices, in job order) when there are more than `max` ok jobs:
/// one factor at a time around the strongest response, in this priority order:
/// 1. the job with the largest blade displacement (the resonance, if the scan has one);
/// 2. at that job's other parameters (its slice), the lowest and the highest speed;
/// 3. at that job's speed, the first and the last slice of the grid (other μ, coating, …);
/// 4. the middle speed of the slice, then the middle slice.
///
/// With `max` or fewer ok jobs, all of them. Failed jobs are never selected.
pub fn select_jobs(records: &[(usize, JobRecord)], max: usize) -> Vec<usize> {
    let ok: Vec<&(usize, JobRecord)> = records.iter().filter(|(_, r)| r.succeeded()).collect();
    if ok.len() <= max {
        let mut all: Vec<usize> = ok.iter().map(|(i, _)| *i).collect();
        all.sort_unstable();
        return all;
    }
    let peak = ok
        .iter()
        .max_by(|a, b| {
            blade_peak(&a.1)
                .total_cmp(&blade_peak(&b.1))
                .then(b.0.cmp(&a.0))
        })
        .map(|(i, r)| (*i, r))
        .expect("more than max ≥ 0 ok jobs");
    let key = slice_label(&peak.1.params);
    let mut slice: Vec<&(usize, JobRecord)> = ok
        .iter()
        .copied()
        .filter(|(_, r)| slice_label(&r.params) == key)
        .collect();
    slice.sort_by(|a, b| {
        a.1.params
            .speed_rad_s
            .total_cmp(&b.1.params.speed_rad_s)
            .then(a.0.cmp(&b.0))
    });
    // Slices in grid order, each represented by its job at the peak's speed.
    let mut at_speed: Vec<&(usize, JobRecord)> = ok
        .iter()
        .copied()
        .filter(|(_, r)| r.params.speed_rad_s == peak.1.params.speed_rad_s)
        .collect();
    at_speed.sort_by_key(|(i, _)| *i);
    let ends = |v: &[&(usize, JobRecord)]| -> [Option<usize>; 3] {
        [
            v.first().map(|x| x.0),
            v.last().map(|x| x.0),
            v.get(v.len() / 2).map(|x| x.0),
        ]
    };
    let [s_lo, s_hi, s_mid] = ends(&slice);
    let [g_first, g_last, g_mid] = ends(&at_speed);
    let mut chosen: Vec<usize> = Vec::new();
    for i in [Some(peak.0), s_lo, s_hi, g_first, g_last, s_mid, g_mid]
        .into_iter()
        .flatten()
    {
        if chosen.len() < max && !chosen.contains(&i) {
            chosen.push(i);
        }
    }
    chosen.sort_unstable();
    chosen
}

/// Upper frequency (Hz) of an interaction map's band: 1.2 × the highest of `floor_hz` (the
/// first engine order of the excitation and the modes that must show) and each column's
/// dominant response (its largest amplitude, the static bin f = 0 excluded), capped at the
/// spectra's extent. The band then holds the excitation, the modes and where each job
/// responds most, instead of the whole 0–f_Nyquist range whose upper part is small broadband
/// content.
pub fn interaction_band_hz(columns: &[SpectrumColumn], floor_hz: f64) -> f64 {
    let mut top = floor_hz.max(0.0);
    let mut extent: f64 = 0.0;
    for c in columns {
        extent = extent.max(c.df_hz * c.amplitude_m.len() as f64);
        let peak = c
            .amplitude_m
            .iter()
            .enumerate()
            .skip(1)
            .max_by(|a, b| a.1.total_cmp(b.1));
        if let Some((k, &a)) = peak
            && a > 0.0
        {
            top = top.max((k + 1) as f64 * c.df_hz);
        }
    }
    let band = 1.2 * top;
    if extent > 0.0 && band > 0.0 {
        band.min(extent)
    } else if band > 0.0 {
        band
    } else {
        extent
    }
}

/// Number of lobes of the sweep's casing distortion (1 when it has none): the engine orders
/// of the excitation are its multiples.
pub fn lobes(spec: &SweepSpec) -> u32 {
    match &spec.models.casing {
        CasingSource::Rigid(r) => r.lobes,
        CasingSource::ImposedGap(g) => g.profile.lobes().unwrap_or(1) as u32,
        _ => spec.scenario.lobes.unwrap_or(2),
    }
    .max(1)
}

/// The nodal diameters a Campbell diagram shows. Without `focus`, those of the critical
/// speeds in increasing order (at most 6). With a `focus` speed range (the sweep's), those of
/// the critical speeds nearest to it (inside first, then by distance; the most compatible
/// first among equals), at most 4: the modes that can matter for the sweep.
pub fn focus_diameters(crit: &[CriticalSpeed], focus: Option<(f64, f64)>) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::new();
    match focus {
        None => {
            out = crit.iter().map(|c| c.nodal_diameter).collect();
            out.sort_unstable();
            out.dedup();
            out.truncate(6);
        }
        Some((lo, hi)) => {
            let dist = |w: f64| (lo - w).max(w - hi).max(0.0);
            let mut by: Vec<&CriticalSpeed> = crit.iter().collect();
            by.sort_by(|a, b| {
                dist(a.speed_rad_s)
                    .total_cmp(&dist(b.speed_rad_s))
                    .then(b.compatibility.total_cmp(&a.compatibility))
            });
            for c in by {
                if out.len() < 4 && !out.contains(&c.nodal_diameter) {
                    out.push(c.nodal_diameter);
                }
            }
        }
    }
    out
}

/// The Campbell diagram of a sweep's models: for the nodal diameters of
/// [`focus_diameters`], the first casing mode and the first two impeller branches over the
/// impeller's speed grid, and the critical speeds of those diameters; `focus` is also shaded.
pub fn campbell_data(sim: &ModelSimulator, focus: Option<(f64, f64)>) -> CampbellData {
    let imp = sim.impeller();
    let diameters = focus_diameters(sim.critical_speeds(), focus);
    let speeds = imp
        .modal_data
        .first()
        .map(|m| m.omega.clone())
        .unwrap_or_default();
    let impeller = diameters
        .iter()
        .flat_map(|&n| {
            let k = crate::analysis::interaction::aliased_nodal_diameter(n as usize, imp.n_sectors);
            let md = &imp.modal_data[k];
            (0..md.frequencies.first().map_or(0, Vec::len).min(2)).map(move |p| ImpellerBranch {
                nodal_diameter: n,
                omega_rad_s: md.frequencies.iter().map(|f| TAU * f[p]).collect(),
            })
        })
        .collect();
    let casing = sim.casing_rom().map_or(vec![], |rom| {
        diameters
            .iter()
            .filter_map(|&n| rom.modal_data.get(n as usize))
            .map(|m| CasingMode {
                nodal_diameter: m.nodal_diameter as u32,
                omega_rad_s: TAU * m.frequencies[0][0],
            })
            .collect()
    });
    CampbellData {
        speeds_rad_s: speeds,
        casing,
        impeller,
        critical_speeds: sim
            .critical_speeds()
            .iter()
            .filter(|c| diameters.contains(&c.nodal_diameter))
            .copied()
            .collect(),
        speed_band_rad_s: focus,
    }
}

/// The first impeller mode of each of `diameters` over speed, in the rotating frame (where
/// the blade-tip spectrum is measured): the modes an interaction map shows beside the engine
/// orders.
pub fn blade_mode_lines(sim: &ModelSimulator, diameters: &[u32]) -> Vec<ModeLine> {
    let imp = sim.impeller();
    diameters
        .iter()
        .filter_map(|&n| {
            let k = crate::analysis::interaction::aliased_nodal_diameter(n as usize, imp.n_sectors);
            let md = imp.modal_data.get(k)?;
            Some(ModeLine {
                label: format!("blade mode 1, n = {n}"),
                speeds_rad_s: md.omega.clone(),
                frequency_hz: md.frequencies.iter().map(|f| f[0]).collect(),
            })
        })
        .collect()
}

/// Options of [`write_report`].
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// Output directory (default `<results dir>/report`).
    pub output_dir: Option<PathBuf>,
    /// Job indices to overlay; empty: chosen by [`select_jobs`].
    pub jobs: Vec<usize>,
    /// At most this many jobs chosen by [`select_jobs`], ≥ 1 (0 is refused: a report with
    /// no job overlaid is not what anyone asks for, and `--max-jobs 0` must not silently
    /// mean something else).
    pub max_jobs: usize,
}

impl Default for ReportOptions {
    /// The default output directory, jobs chosen by [`select_jobs`], at most
    /// [`DEFAULT_MAX_JOBS`] of them.
    fn default() -> Self {
        ReportOptions {
            output_dir: None,
            jobs: Vec::new(),
            max_jobs: DEFAULT_MAX_JOBS,
        }
    }
}

/// What [`write_report`] wrote.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// The page.
    pub index: PathBuf,
    /// The figures, in page order.
    pub figures: Vec<PathBuf>,
    /// The jobs overlaid (job indices).
    pub selected: Vec<usize>,
    /// What was left out and why.
    pub notes: Vec<String>,
    /// Labels of the Campbell diagram (placed and left out), when drawn.
    pub campbell_labels: Option<PlotLabels>,
    /// Labels of each interaction map drawn.
    pub interaction_labels: Vec<PlotLabels>,
    /// Labels of the response-against-Ω figure, when drawn.
    pub scan_labels: Option<PlotLabels>,
}

/// One figure of the page: file name, title and caption (HTML-escaped when written).
struct Figure {
    file: String,
    title: String,
    caption: String,
}

/// A job's legend text: index, speed and the other parameters.
fn job_label(i: usize, r: &JobRecord) -> String {
    format!(
        "job {i}: Ω = {:.0} rad/s, {}",
        r.params.speed_rad_s,
        slice_label(&r.params)
    )
}

/// The overlaid jobs' histories: series from `timeseries/<id>.parquet` where stored. The jobs
/// without a stored series are pushed to `absent`; an unreadable one is a note.
fn histories(
    res: &ResultsDir,
    chosen: &[&(usize, JobRecord)],
    notes: &mut Vec<String>,
    absent: &mut Vec<usize>,
) -> TimeHistoryData {
    let probe = res.spec.scenario.casing_probes.first();
    let mut jobs = Vec::new();
    for (i, r) in chosen {
        let mut h = JobHistory {
            label: job_label(*i, r),
            wear_m: r
                .result
                .as_ref()
                .map_or(vec![], |x| deepest_wear(&x.wear_profile_m)),
            ..Default::default()
        };
        let path = res.dir.join("timeseries").join(format!("{}.parquet", r.id));
        let wanted = [
            "time_s",
            "blade0_te_radial_m",
            "casing_probe0_radial_m",
            "blade0_normal_force_n",
        ];
        match read_columns(&path, |c| wanted.contains(&c)) {
            Ok(cols) => {
                for (name, v) in cols {
                    match name.as_str() {
                        "time_s" => h.time_s = v,
                        "blade0_te_radial_m" => h.blade_te_radial_m = v,
                        "casing_probe0_radial_m" => h.casing_radial_m = v,
                        _ => h.normal_force_n = v,
                    }
                }
            }
            Err(e) if path.exists() => {
                notes.push(format!("job {i}: {e:#}; its series are left out"))
            }
            Err(_) => absent.push(*i),
        }
        jobs.push(h);
    }
    TimeHistoryData {
        jobs,
        casing_probe: probe.map_or("casing probe 0".into(), |p| {
            format!("casing sector {}, contact node {}", p[0], p[1])
        }),
    }
}

/// The jobs to overlay: `opts.jobs` (each must be an ok job of the table) or [`select_jobs`].
fn chosen_jobs<'a>(
    res: &'a ResultsDir,
    opts: &ReportOptions,
) -> Result<Vec<&'a (usize, JobRecord)>, ReportError> {
    let table = res.dir.join("results.parquet");
    let ids = if opts.jobs.is_empty() {
        select_jobs(&res.records, opts.max_jobs)
    } else {
        opts.jobs.clone()
    };
    ids.iter()
        .map(|&i| {
            res.records
                .iter()
                .find(|(k, r)| *k == i && r.succeeded())
                .ok_or_else(|| ReportError::Input {
                    path: table.clone(),
                    reason: format!("job {i} is not a successful job of this table"),
                })
        })
        .collect()
}

/// The Campbell diagram's entry on the page.
fn campbell_figure(
    figures: &mut Vec<Figure>,
    diameters: &[u32],
    focus: (f64, f64),
    labels: &PlotLabels,
) {
    figures.push(Figure {
        file: "campbell.png".into(),
        title: "Campbell diagram (Fig. 19)".into(),
        caption: format!(
            "Fixed-frame frequencies (Hz) against the rotation speed Ω (rad/s) for the \
                 nodal diameters n = {} of the critical speeds nearest the sweep \
                 (shaded: {:.0}–{:.0} rad/s): casing modes ω_c/2π (dashed), impeller waves \
                 (nΩ − ω_b)/2π (solid). Dots: critical speeds Ω*ₙ, labelled with the \
                 compatibility C ∈ [0, 1] of the two mode shapes at the contact.{}",
            diameters
                .iter()
                .map(u32::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            focus.0,
            focus.1,
            if labels.dropped.is_empty() {
                String::new()
            } else {
                format!(
                    " Not labelled for lack of room: {}.",
                    labels.dropped.join("; ")
                )
            }
        ),
    });
}

/// One interaction map per slice of the grid with two speeds or more (jobs sharing every
/// parameter but the speed), zoomed by [`interaction_band_hz`], with the `modes` drawn.
fn interaction_figures(
    res: &ResultsDir,
    modes: &[ModeLine],
    out: &Path,
    figures: &mut Vec<Figure>,
    report: &mut Report,
) -> Result<(), ReportError> {
    let n_lobes = lobes(&res.spec);
    let mut slices: Vec<(String, Vec<&JobRecord>)> = Vec::new();
    for (_, r) in res.records.iter().filter(|(_, r)| r.succeeded()) {
        let key = slice_label(&r.params);
        match slices.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(r),
            None => slices.push((key, vec![r])),
        }
    }
    for (k, (label, recs)) in slices.iter().enumerate() {
        let mut data = interaction_data_from_records(
            recs.iter().copied(),
            (1..=12).map(|e| e * n_lobes).collect(),
        );
        let mut distinct: Vec<f64> = data.columns.iter().map(|c| c.speed_rad_s).collect();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        if distinct.len() < 2 {
            continue;
        }
        let w_max = distinct[distinct.len() - 1];
        // The band must show the first engine order of the excitation and the blade modes.
        let floor = modes
            .iter()
            .flat_map(|m| m.speeds_rad_s.iter().zip(&m.frequency_hz))
            .filter(|&(&w, _)| w >= distinct[0] && w <= w_max)
            .map(|(_, &f)| f)
            .fold(f64::from(n_lobes) * w_max / TAU, f64::max);
        data.max_frequency_hz = Some(interaction_band_hz(&data.columns, floor));
        data.mode_lines = modes.to_vec();
        data.subtitle = label.clone();
        let file = if slices.len() == 1 {
            "interaction_map.png".to_string()
        } else {
            format!("interaction_map_{k}.png")
        };
        let labels = interaction_map(&data, &out.join(&file))?;
        figures.push(Figure {
            file,
            title: format!("Interaction map, {label} (Fig. 20)"),
            caption: format!(
                "Amplitude spectrum of blade 0's leading-edge radial displacement over the \
                 steady window (colour: log10 of the amplitude in m) against the rotation \
                 speed Ω (rad/s) and the frequency (Hz, rotating frame), up to {:.0} Hz (1.2 × the highest of the first engine \
                 order, the modes shown and each job's dominant frequency). White: engine \
                 orders (multiples of the {n_lobes} lobes); pink dashed: first blade mode of the \
                 nodal diameters of the Campbell diagram; red: critical speeds Ω* (rad/s).",
                data.max_frequency_hz.unwrap_or(0.0)
            ),
        });
        report.interaction_labels.push(labels);
    }
    if report.interaction_labels.is_empty() {
        report
            .notes
            .push("no interaction map: no slice of the grid has two speeds with spectra".into());
    }
    Ok(())
}

/// How to get the series the time-history panels need (one line on the page).
const SERIES_HINT: &str = "`rubscan run <spec> --timeseries` stores them for every job; \
                           `rubscan simulate <spec> --job <i>` runs one job with its series";

/// The time histories of the `chosen` jobs, with the panels that have data; a note instead of
/// empty panels when no job has a stored series.
fn history_figure(
    res: &ResultsDir,
    chosen: &[&(usize, JobRecord)],
    out: &Path,
    figures: &mut Vec<Figure>,
    notes: &mut Vec<String>,
) -> Result<(), ReportError> {
    let mut absent = Vec::new();
    let data = histories(res, chosen, notes, &mut absent);
    let panels = history_panels(&data);
    let has_series = panels.iter().any(|p| *p != HistoryPanel::Wear);
    if !has_series {
        notes.push(format!(
            "time histories left out: no time series stored for the jobs shown ({SERIES_HINT}){}",
            if panels.is_empty() {
                ""
            } else {
                "; their final wear profiles are shown alone"
            }
        ));
    } else if !absent.is_empty() {
        let jobs: Vec<String> = absent.iter().map(usize::to_string).collect();
        notes.push(format!(
            "no time series stored for job(s) {} ({SERIES_HINT})",
            jobs.join(", ")
        ));
    }
    if panels.is_empty() {
        return Ok(());
    }
    time_histories(&data, &out.join("time_histories.png"))?;
    let parts: Vec<String> = panels
        .iter()
        .enumerate()
        .map(|(k, p)| match panels.len() {
            1 => p.description(&data.casing_probe),
            _ => format!(
                "({}) {}",
                (b'a' + k as u8) as char,
                p.description(&data.casing_probe)
            ),
        })
        .collect();
    figures.push(Figure {
        file: "time_histories.png".into(),
        title: if has_series {
            "Time histories and wear (Figs. 16–17)".into()
        } else {
            "Final wear profiles (Fig. 17)".into()
        },
        caption: format!("{}. One colour per job.", parts.join("; ")),
    });
    Ok(())
}

/// Strain energy per nodal diameter of the `chosen` jobs (Fig. 18), or a note.
fn energy_figure(
    chosen: &[&(usize, JobRecord)],
    out: &Path,
    figures: &mut Vec<Figure>,
    notes: &mut Vec<String>,
) -> Result<(), ReportError> {
    let energy = NdEnergyData {
        jobs: chosen
            .iter()
            .map(|(i, r)| {
                let e = r
                    .result
                    .as_ref()
                    .map_or(vec![], |x| x.strain_energy_per_nd_j.clone());
                (job_label(*i, r), e)
            })
            .collect(),
    };
    match nd_energy_bars(&energy, &out.join("nd_strain_energy.png")) {
        Ok(()) => figures.push(Figure {
            file: "nd_strain_energy.png".into(),
            title: "Strain energy per nodal diameter (Fig. 18)".into(),
            caption: "Impeller strain energy of each nodal diameter n_d (J, log10 scale; bars \
                      rise from the axis floor to their value), mean over the steady window of \
                      each job; one colour per job."
                .into(),
        }),
        Err(PlotError::Empty(why)) => notes.push(format!("no Fig. 18: {why}")),
        Err(e) => return Err(e.into()),
    }
    Ok(())
}

/// The quantity of the response-against-Ω figure: the spec's `refine.peak_of` when it names a
/// drawable column (the quantity the scan was refined on), else [`DEFAULT_SCAN_QUANTITY`].
fn scan_quantity(spec: &SweepSpec) -> ScanQuantity {
    spec.grid
        .speed
        .refine
        .as_ref()
        .and_then(|r| r.peak_of.as_deref())
        .and_then(ScanQuantity::of)
        .or_else(|| ScanQuantity::of(DEFAULT_SCAN_QUANTITY))
        .expect("the default scan quantity is a table column")
}

/// The response against Ω with the outcomes and the predictions (first on the page), when
/// some speed line has two speeds or more; a note otherwise.
fn scan_figure(
    res: &ResultsDir,
    sim: Option<&ModelSimulator>,
    out: &Path,
    figures: &mut Vec<Figure>,
    report: &mut Report,
) -> Result<(), ReportError> {
    let quantity = scan_quantity(&res.spec);
    let rows = scan_rows(&res.records, &quantity);
    let overlays = sim.map_or_else(ScanOverlays::default, |s| ScanOverlays {
        critical_speeds: Some(s.critical_speeds().to_vec()),
        critical_wave_speed: s
            .casing_wave_speed()
            .ok()
            .flatten()
            .map(|(w, n)| (w, n as u32)),
    });
    let data = scan_data(&rows, &quantity, &overlays, FIRST_SCAN_LINES);
    let scanned = data.lines.iter().any(|l| {
        l.points
            .windows(2)
            .any(|w| w[0].speed_rad_s != w[1].speed_rad_s)
    });
    if !scanned {
        report.notes.push(
            "no response-against-Ω figure: every speed line of the grid has a single speed".into(),
        );
        return Ok(());
    }
    let labels = response_against_speed(&data, &out.join("response_vs_speed.png"))?;
    figures.push(Figure {
        file: "response_vs_speed.png".into(),
        title: "Response against rotation speed: outcomes and predictions".into(),
        caption: scan_caption(&data, &labels),
    });
    report.scan_labels = Some(labels);
    Ok(())
}

/// Writes the report of the results directory `dir` (see the module doc) and returns what
/// it wrote. Inputs are read and checked before any file is written.
pub fn write_report(dir: &Path, opts: &ReportOptions) -> Result<Report, ReportError> {
    if opts.max_jobs == 0 {
        return Err(ReportError::Option(
            "--max-jobs 0: must be ≥ 1 (the number of jobs overlaid when no --job is named)".into(),
        ));
    }
    let res = load_results(dir)?;
    let chosen = chosen_jobs(&res, opts)?;
    let out = opts
        .output_dir
        .clone()
        .unwrap_or_else(|| dir.join("report"));
    let mut report = Report {
        index: out.join("index.html"),
        selected: chosen.iter().map(|(i, _)| *i).collect(),
        ..Default::default()
    };
    let mut figures = Vec::new();
    let sim = ModelSimulator::new(&res.spec)
        .map_err(|e| {
            report.notes.push(format!(
                "models of the spec not loaded ({e:#}): no Campbell diagram, no mode lines, no \
                 critical wave speed"
            ))
        })
        .ok();

    scan_figure(&res, sim.as_ref(), &out, &mut figures, &mut report)?;
    history_figure(&res, &chosen, &out, &mut figures, &mut report.notes)?;
    energy_figure(&chosen, &out, &mut figures, &mut report.notes)?;

    let speeds: Vec<f64> = res
        .records
        .iter()
        .filter(|(_, r)| r.succeeded())
        .map(|(_, r)| r.params.speed_rad_s)
        .collect();
    let focus = (
        speeds.iter().copied().fold(f64::INFINITY, f64::min),
        speeds.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    let mut diameters = vec![];
    if let Some(sim) = &sim {
        let camp = campbell_data(sim, Some(focus));
        diameters = focus_diameters(sim.critical_speeds(), Some(focus));
        match campbell_diagram(&camp, &out.join("campbell.png")) {
            Ok(labels) => {
                campbell_figure(&mut figures, &diameters, focus, &labels);
                report.campbell_labels = Some(labels);
            }
            Err(PlotError::Empty(_)) => report.notes.push(
                "no Campbell diagram: the linear interaction criterion finds no critical speed \
                 for these models"
                    .into(),
            ),
            Err(e) => return Err(e.into()),
        }
    }

    let modes = sim
        .as_ref()
        .map_or(vec![], |s| blade_mode_lines(s, &diameters));
    interaction_figures(&res, &modes, &out, &mut figures, &mut report)?;

    let html = index_html(&res, &chosen, &figures, &report, sim.as_ref());
    write_atomic(&report.index, html.as_bytes()).map_err(|source| ReportError::Write {
        path: report.index.clone(),
        source,
    })?;
    report.figures = figures.iter().map(|f| out.join(&f.file)).collect();
    Ok(report)
}

/// `s` with the HTML special characters escaped.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The page: title, the selected jobs, the figures with captions, the critical speeds and
/// the notes.
fn index_html(
    res: &ResultsDir,
    chosen: &[&(usize, JobRecord)],
    figures: &[Figure],
    report: &Report,
    sim: Option<&ModelSimulator>,
) -> String {
    let ok = res.records.iter().filter(|(_, r)| r.succeeded()).count();
    let outcomes = Outcomes::of(res.records.iter().map(|(_, r)| r));
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>rubscan report: {name}</title>\n<style>\n\
         body {{ font-family: sans-serif; max-width: 1320px; margin: 1em auto; }}\n\
         figure {{ margin: 1em 0; }} img {{ max-width: 100%; border: 1px solid #ccc; }}\n\
         table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #bbb; padding: 2px 8px; }}\n\
         td {{ text-align: right; }}\n</style>\n</head>\n<body>\n\
         <h1>rubscan report: {name}</h1>\n<p>{desc}</p>\n\
         <p>{n} jobs: {o} ok, {u} unstable (runaway found: a finding, not a failure), {f} \
         failed. Quantities in SI units (m, N, J, s, rad/s) unless a caption says \
         otherwise.</p>\n",
        name = escape(&res.spec.name),
        desc = escape(res.spec.description.as_deref().unwrap_or("")),
        n = res.records.len(),
        o = outcomes.ok,
        u = outcomes.unstable,
        f = outcomes.failed,
    );
    let _ = write!(
        h,
        "<h2>Jobs shown</h2>\n<p>{}</p>\n<table>\n<tr><th>job</th><th>id</th><th>Ω (rad/s)</th>\
         <th>other parameters</th><th>max blade radial (µm)</th><th>max casing radial (µm)</th></tr>\n",
        if chosen.len() == ok {
            "All successful (ok or unstable) jobs.".to_string()
        } else {
            format!(
                "{} of {ok} jobs: the strongest blade response, then the lowest and highest \
                 speed of its slice, the first and last slice at its speed, the middle ones.",
                chosen.len()
            )
        }
    );
    for (i, r) in chosen {
        let m = r.result.as_ref().map(|x| x.maxima).unwrap_or_default();
        let _ = writeln!(
            h,
            "<tr><td>{i}</td><td>{}</td><td>{:.1}</td><td style=\"text-align:left\">{}</td>\
             <td>{:.2}</td><td>{:.2}</td></tr>",
            escape(&r.id),
            r.params.speed_rad_s,
            escape(&slice_label(&r.params)),
            1e6 * m.blade_le_radial_m.max(m.blade_te_radial_m),
            1e6 * m.casing_radial_m
        );
    }
    h.push_str("</table>\n");
    for f in figures {
        let _ = write!(
            h,
            "<h2>{title}</h2>\n<figure>\n<a href=\"{file}\"><img src=\"{file}\" alt=\"{title}\"></a>\n\
             <figcaption>{caption}</figcaption>\n</figure>\n",
            title = escape(&f.title),
            file = escape(&f.file),
            caption = escape(&f.caption)
        );
    }
    if let Some(sim) = sim {
        h.push_str(
            "<h2>Critical speeds of the linear interaction criterion</h2>\n<table>\n\
             <tr><th>Ω* (rad/s)</th><th>n</th><th>compatibility C</th></tr>\n",
        );
        for c in sim.critical_speeds() {
            let _ = writeln!(
                h,
                "<tr><td>{:.1}</td><td>{}</td><td>{:.3}</td></tr>",
                c.speed_rad_s, c.nodal_diameter, c.compatibility
            );
        }
        h.push_str("</table>\n");
    }
    if !report.notes.is_empty() {
        h.push_str("<h2>Notes</h2>\n<ul>\n");
        for n in &report.notes {
            let _ = writeln!(h, "<li>{}</li>", escape(n));
        }
        h.push_str("</ul>\n");
    }
    h.push_str("</body>\n</html>\n");
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::{CoatingParams, JobParams, JobResult, JobStatus, Maxima};

    /// An ok job at `speed` with friction `mu` whose blade peaks at `peak_m`.
    fn rec(speed: f64, mu: f64, peak_m: f64) -> JobRecord {
        JobRecord {
            format_version: crate::sweep::checkpoint::JOB_RECORD_VERSION,
            id: format!("{speed}-{mu}"),
            params: JobParams {
                speed_rad_s: speed,
                friction: mu,
                clearance_m: None,
                coating: CoatingParams::default(),
            },
            status: JobStatus::Ok,
            result: Some(JobResult {
                maxima: Maxima {
                    blade_te_radial_m: peak_m,
                    ..Default::default()
                },
                ..Default::default()
            }),
            wall_time_s: 0.0,
            refinement_round: 0,
        }
    }

    /// A 21-speed scan with a resonance at speed 13: the peak, both ends and the middle.
    #[test]
    fn scan_selects_peak_ends_and_middle() {
        let records: Vec<(usize, JobRecord)> = (0..21)
            .map(|i| {
                let w = 6000.0 + 50.0 * i as f64;
                (i, rec(w, 0.15, 1e-4 / (1.0 + (i as f64 - 13.0).powi(2))))
            })
            .collect();
        assert_eq!(select_jobs(&records, 6), vec![0, 10, 13, 20]);
        // Capped by priority: the peak and the ends first.
        assert_eq!(select_jobs(&records, 2), vec![0, 13]);
        // Few jobs: all of them, failed ones excepted.
        let mut few = records[..4].to_vec();
        few[1].1.status = JobStatus::Failed { reason: "x".into() };
        few[1].1.result = None;
        assert_eq!(select_jobs(&few, 6), vec![0, 2, 3]);
    }

    /// One speed, nine slices (3 μ × 3 coatings as in case study 1): the strongest, and the
    /// first, middle and last slice.
    #[test]
    fn one_speed_many_slices_selects_along_the_grid() {
        let records: Vec<(usize, JobRecord)> = (0..9)
            .map(|i| {
                (
                    i,
                    rec(3000.0, 0.01 * i as f64, if i == 5 { 2e-4 } else { 1e-4 }),
                )
            })
            .collect();
        assert_eq!(select_jobs(&records, 6), vec![0, 4, 5, 8]);
    }

    fn column(w: f64, df: f64, peak_hz: f64) -> SpectrumColumn {
        SpectrumColumn {
            speed_rad_s: w,
            df_hz: df,
            // Broadband floor 1 % of the peak up to 50 kHz, a peak at `peak_hz`, and a large
            // static bin that must not count.
            amplitude_m: (0..5000)
                .map(|k| {
                    let f = k as f64 * df;
                    if k == 0 {
                        1.0
                    } else {
                        1e-7 + 1e-5 * (-((f - peak_hz) / 20.0).powi(2)).exp()
                    }
                })
                .collect(),
        }
    }

    #[test]
    fn band_holds_the_dominant_response_and_the_floor() {
        let cols = [column(1000.0, 10.0, 800.0), column(1100.0, 10.0, 1000.0)];
        let band = interaction_band_hz(&cols, 300.0);
        assert!((band - 1.2 * 1010.0).abs() < 1e-9, "{band}");
        // A floor above the peaks (a mode that must show) sets the band.
        assert!((interaction_band_hz(&cols, 2000.0) - 2400.0).abs() < 1e-9);
        // Never beyond the spectra.
        assert!((interaction_band_hz(&cols, 1e9) - 50_000.0).abs() < 1e-9);
    }

    #[test]
    fn focus_keeps_the_critical_speeds_near_the_sweep() {
        let c = |w: f64, n: u32, compat: f64| CriticalSpeed {
            speed_rad_s: w,
            nodal_diameter: n,
            compatibility: compat,
        };
        let crit = [
            c(6494.0, 8, 0.74),
            c(6510.0, 9, 0.79),
            c(6891.0, 5, 0.41),
            c(6918.0, 13, 0.51),
            c(6833.0, 10, 0.92),
            c(3000.0, 2, 0.99),
        ];
        // Inside the scan first (most compatible first), then the nearest.
        assert_eq!(
            focus_diameters(&crit, Some((6750.0, 8130.0))),
            vec![10, 13, 5, 9]
        );
        assert_eq!(focus_diameters(&crit, None), vec![2, 5, 8, 9, 10, 13]);
    }
}
