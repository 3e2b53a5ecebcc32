//! The sweep results table `results.parquet`: one row per finished job, sorted by job
//! index (so the table does not depend on thread count, sharding or merging).
//!
//! Every column carries its unit in its name (`_m`, `_n`, `_hz`, `_rad_s`, `_s`, `_j`,
//! `_pa`) and in the Parquet/Arrow field metadata (`unit`, `description`);
//! `schemas/results.md` documents every column. See [`COLUMNS`].

use std::collections::HashMap;
use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use arrow_array::builder::{
    ArrayBuilder, Float64Builder, ListBuilder, StringBuilder, StructBuilder, UInt32Builder,
};
use arrow_array::{
    Array, ArrayRef, BooleanArray, Float64Array, ListArray, RecordBatch, StringArray, StructArray,
    UInt32Array, UInt64Array,
};
use arrow_schema::{DataType, Field, Fields, Schema};
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;

use crate::dynamics::runaway::Runaway;
use crate::io::atomic::AtomicFile;
use crate::sweep::checkpoint::{JobRecord, JobStatus};
use crate::sweep::planner::{CoatingParams, CoatingValue, JobParams, Plan};

/// Column name, unit (`"1"` = dimensionless, `""` = not a quantity) and description,
/// in table order.
pub const COLUMNS: &[(&str, &str, &str)] = &[
    ("job_index", "", "position of the job in the plan (0-based)"),
    (
        "job_id",
        "",
        "stable job id (FNV-1a 64 of the resolved parameters, 16 hex digits)",
    ),
    ("speed_rad_s", "rad/s", "rotation speed Ω"),
    ("friction", "1", "Coulomb friction coefficient μ"),
    ("clearance_m", "m", "clearance; null = model default"),
    (
        "coating_young_pa",
        "Pa",
        "abradable Young's modulus E when given as absolute value",
    ),
    (
        "coating_young_scale",
        "1",
        "factor on the nominal E when given as scale",
    ),
    (
        "coating_hardening_pa",
        "Pa",
        "abradable plastic modulus K when given as absolute value",
    ),
    (
        "coating_hardening_scale",
        "1",
        "factor on the nominal K when given as scale",
    ),
    (
        "coating_yield_stress_pa",
        "Pa",
        "abradable yield stress σ_Y when given as absolute value",
    ),
    (
        "coating_yield_stress_scale",
        "1",
        "factor on the nominal σ_Y when given as scale",
    ),
    (
        "coating_thickness_m",
        "m",
        "abradable thickness e_abr when given as absolute value",
    ),
    (
        "coating_thickness_scale",
        "1",
        "factor on the nominal e_abr when given as scale",
    ),
    (
        "refinement_round",
        "",
        "refinement round that added the job (0: the grid)",
    ),
    (
        "status",
        "",
        "\"ok\" (bounded response), \"unstable\" (runaway found, job stopped) or \"failed\"",
    ),
    ("reason", "", "failure reason; null unless failed"),
    (
        "drive_work_j",
        "J",
        "work of the rotation through the contact forces over the run (to its stop)",
    ),
    (
        "runaway_onset_s",
        "s",
        "unstable: onset of the growth (the energy envelope block it starts from)",
    ),
    (
        "runaway_detected_s",
        "s",
        "unstable: time the runaway was confirmed and the job stopped",
    ),
    (
        "growth_rate_per_s",
        "1/s",
        "unstable: amplitude growth rate σ (half the fitted slope of ln E)",
    ),
    ("growth_fit_r2", "1", "unstable: R² of that exponential fit"),
    (
        "runaway_energy_growth",
        "1",
        "unstable: energy envelope ratio from onset to detection",
    ),
    (
        "runaway_drive_work_j",
        "J",
        "unstable: work of the rotation from onset to detection",
    ),
    (
        "growing_wave_frequency_hz",
        "Hz",
        "unstable: fixed-frame frequency of the growing casing wave",
    ),
    (
        "growing_wave_rotating_frequency_hz",
        "Hz",
        "unstable: its frequency in the rotating frame (signed, > 0 ahead of the blades)",
    ),
    (
        "growing_nodal_diameter",
        "",
        "unstable: nodal diameter of the growing wave",
    ),
    (
        "growing_wave_forward",
        "",
        "unstable: whether the casing wave travels in the sense of rotation (fixed frame)",
    ),
    (
        "runaway_at_solve_breakdown",
        "",
        "unstable: whether the growth broke the contact solve and was confirmed there",
    ),
    (
        "max_blade_le_radial_m",
        "m",
        "max |radial displacement| of blade leading edges, over every time step",
    ),
    (
        "max_blade_te_radial_m",
        "m",
        "max |radial displacement| of blade trailing edges, over every time step",
    ),
    (
        "max_blade_le_radial_lowpass_m",
        "m",
        "max |radial displacement| of blade leading edges low-passed at 15 kHz (4th-order Bessel), over every time step; null when the step cannot resolve 15 kHz",
    ),
    (
        "max_blade_te_radial_lowpass_m",
        "m",
        "the same at blade trailing edges",
    ),
    (
        "max_casing_radial_m",
        "m",
        "max |radial displacement| of casing probes, read every 2 µs of simulated time (every step when longer)",
    ),
    (
        "max_contact_normal_force_n",
        "N",
        "max normal contact force per blade, over every time step",
    ),
    (
        "max_coating_force_n",
        "N",
        "max abradable coating force per blade, over every time step",
    ),
    (
        "predicted_stable",
        "",
        "linear stability prediction at the job's Ω and μ: whether a persistent rub settles",
    ),
    (
        "predicted_growth_rate_per_s",
        "1/s",
        "its most unstable coupled wave's growth rate Re λ (null without a flexible casing)",
    ),
    (
        "predicted_nodal_diameter",
        "",
        "that wave's casing nodal diameter",
    ),
    (
        "predicted_frequency_hz",
        "Hz",
        "that wave's fixed-frame frequency",
    ),
    (
        "wear_profile_m",
        "m",
        "final wear depth [station leading→trailing edge][angle 2πk/n]",
    ),
    (
        "fourier_peaks",
        "",
        "spectrum peaks {frequency_hz (Hz), engine_order (1), amplitude_m (m)}",
    ),
    (
        "strain_energy_per_nd_j",
        "J",
        "strain energy per nodal diameter k = 0..=N/2",
    ),
    (
        "residual_penetration_m",
        "m",
        "largest penetration left after a contact correction, over every step",
    ),
    (
        "steps_over_gap_tolerance",
        "",
        "steps whose residual penetration exceeds the gap tolerance",
    ),
    (
        "critical_speed_rad_s",
        "rad/s",
        "nearest critical speed Ω* of the interaction criterion",
    ),
    (
        "critical_nodal_diameter",
        "",
        "nodal diameter of that critical speed",
    ),
    (
        "critical_compatibility",
        "1",
        "spatial compatibility of the coinciding modes at the contact, in [0, 1]",
    ),
    (
        "spectrum_df_hz",
        "Hz",
        "frequency resolution of spectrum_amplitude_m",
    ),
    (
        "spectrum_amplitude_m",
        "m",
        "blade-tip radial displacement amplitude spectrum at f = k·df",
    ),
    ("wall_time_s", "s", "wall-clock time of the job"),
];

fn f64_col(v: impl IntoIterator<Item = Option<f64>>) -> ArrayRef {
    let mut b = Float64Builder::new();
    for x in v {
        b.append_option(x);
    }
    Arc::new(b.finish())
}

fn coating_cols(vals: &[Option<CoatingValue>]) -> (ArrayRef, ArrayRef) {
    let abs = vals.iter().map(|v| match v {
        Some(CoatingValue::Absolute(x)) => Some(*x),
        _ => None,
    });
    let scale = vals.iter().map(|v| match v {
        Some(CoatingValue::Scale(x)) => Some(*x),
        _ => None,
    });
    (f64_col(abs), f64_col(scale))
}

fn list_f64<'a>(rows: impl Iterator<Item = Option<&'a [f64]>>) -> ArrayRef {
    let mut b = ListBuilder::new(Float64Builder::new());
    for r in rows {
        match r {
            Some(v) => {
                b.values().append_slice(v);
                b.append(true);
            }
            None => b.append(false),
        }
    }
    Arc::new(b.finish())
}

fn peak_fields() -> Fields {
    Fields::from(vec![
        Field::new("frequency_hz", DataType::Float64, false),
        Field::new("engine_order", DataType::Float64, false),
        Field::new("amplitude_m", DataType::Float64, false),
    ])
}

/// A float64 runaway column: its name and how a runaway gives its value.
type RunawayColumn = (&'static str, fn(&Runaway) -> Option<f64>);

/// The runaway columns of an `unstable` row that are float64 (null on other rows), in table
/// order.
const RUNAWAY_F64: [RunawayColumn; 8] = [
    ("runaway_onset_s", |r| Some(r.onset_time_s)),
    ("runaway_detected_s", |r| Some(r.detected_time_s)),
    ("growth_rate_per_s", |r| Some(r.growth_rate_per_s)),
    ("growth_fit_r2", |r| Some(r.growth_fit_r2)),
    ("runaway_energy_growth", |r| Some(r.energy_growth)),
    ("runaway_drive_work_j", |r| Some(r.drive_work_j)),
    ("growing_wave_frequency_hz", |r| r.frequency_hz),
    ("growing_wave_rotating_frequency_hz", |r| {
        r.rotating_frame_frequency_hz
    }),
];

/// Appends the runaway columns of `rows` to `cols`.
fn runaway_columns(rows: &[&(usize, JobRecord)], cols: &mut Vec<ArrayRef>) {
    let runaway = |r: &JobRecord| r.result.as_ref().and_then(|x| x.runaway);
    for (_, get) in RUNAWAY_F64 {
        cols.push(f64_col(
            rows.iter().map(|(_, r)| runaway(r).and_then(|x| get(&x))),
        ));
    }
    cols.push(Arc::new(UInt32Array::from_iter(
        rows.iter()
            .map(|(_, r)| runaway(r).and_then(|x| x.nodal_diameter)),
    )));
    cols.push(Arc::new(BooleanArray::from_iter(
        rows.iter().map(|(_, r)| runaway(r).and_then(|x| x.forward)),
    )));
    cols.push(Arc::new(BooleanArray::from_iter(
        rows.iter()
            .map(|(_, r)| runaway(r).map(|x| x.at_solve_breakdown)),
    )));
}

/// Appends the prediction columns of `rows` to `cols`.
fn predicted_columns(rows: &[&(usize, JobRecord)], cols: &mut Vec<ArrayRef>) {
    let predicted = |r: &JobRecord| r.result.as_ref().and_then(|x| x.predicted);
    cols.push(Arc::new(BooleanArray::from_iter(
        rows.iter().map(|(_, r)| predicted(r).map(|p| p.stable)),
    )));
    cols.push(f64_col(
        rows.iter()
            .map(|(_, r)| predicted(r).map(|p| p.growth_rate_per_s)),
    ));
    cols.push(Arc::new(UInt32Array::from_iter(
        rows.iter()
            .map(|(_, r)| predicted(r).map(|p| p.nodal_diameter)),
    )));
    cols.push(f64_col(
        rows.iter()
            .map(|(_, r)| predicted(r).map(|p| p.frequency_hz)),
    ));
}

/// The prediction of row `i` read back from its columns (`None` when null, or the table
/// predates them).
fn predicted_of_row(b: &RecordBatch, i: usize) -> Result<Option<crate::sweep::PredictedStability>> {
    if b.column_by_name("predicted_stable").is_none() {
        return Ok(None);
    }
    let stable = column::<BooleanArray>(b, "predicted_stable")?;
    let rate = column::<Float64Array>(b, "predicted_growth_rate_per_s")?;
    let nd = column::<UInt32Array>(b, "predicted_nodal_diameter")?;
    let f = column::<Float64Array>(b, "predicted_frequency_hz")?;
    if !stable.is_valid(i) {
        return Ok(None);
    }
    let need = |a: &Float64Array, name: &str| {
        opt_f64(a, i).with_context(|| format!("row {i}: {name} is null for a prediction"))
    };
    Ok(Some(crate::sweep::PredictedStability {
        stable: stable.value(i),
        growth_rate_per_s: need(rate, "predicted_growth_rate_per_s")?,
        nodal_diameter: nd.value(i),
        frequency_hz: need(f, "predicted_frequency_hz")?,
    }))
}

/// The runaway of row `i` read back from its columns (`None` when the row has none, or the
/// table predates them).
fn runaway_of_row(b: &RecordBatch, i: usize) -> Result<Option<Runaway>> {
    if b.column_by_name(RUNAWAY_F64[0].0).is_none() {
        return Ok(None);
    }
    let mut v = [None; 8];
    for (x, (name, _)) in v.iter_mut().zip(RUNAWAY_F64) {
        *x = opt_f64(column::<Float64Array>(b, name)?, i);
    }
    let Some(onset_time_s) = v[0] else {
        return Ok(None);
    };
    let nd = column::<UInt32Array>(b, "growing_nodal_diameter")?;
    let forward = column::<BooleanArray>(b, "growing_wave_forward")?;
    // Tables before this column held only the watch's confirmations.
    let at_breakdown = (b.column_by_name("runaway_at_solve_breakdown").is_some())
        .then(|| column::<BooleanArray>(b, "runaway_at_solve_breakdown"))
        .transpose()?;
    let need = |x: Option<f64>, k: usize| {
        x.with_context(|| format!("row {i}: {} is null for a runaway", RUNAWAY_F64[k].0))
    };
    Ok(Some(Runaway {
        onset_time_s,
        detected_time_s: need(v[1], 1)?,
        growth_rate_per_s: need(v[2], 2)?,
        growth_fit_r2: need(v[3], 3)?,
        energy_growth: need(v[4], 4)?,
        drive_work_j: need(v[5], 5)?,
        frequency_hz: v[6],
        rotating_frame_frequency_hz: v[7],
        nodal_diameter: nd.is_valid(i).then(|| nd.value(i)),
        forward: forward.is_valid(i).then(|| forward.value(i)),
        at_solve_breakdown: at_breakdown.is_some_and(|a| a.is_valid(i) && a.value(i)),
    }))
}

/// The plan's columns of a job: `job_index` to `refinement_round` of [`COLUMNS`].
const PLAN_COLUMNS: usize = 14;

/// The columns that say what a job is (`job_index` … `refinement_round`, the first
/// [`PLAN_COLUMNS`] of [`COLUMNS`]) for rows `(index, id, parameters, refinement round)`.
fn plan_columns(rows: &[(usize, &str, &JobParams, u32)]) -> Vec<ArrayRef> {
    let mut cols: Vec<ArrayRef> = Vec::with_capacity(COLUMNS.len());
    cols.push(Arc::new(arrow_array::UInt64Array::from_iter_values(
        rows.iter().map(|r| r.0 as u64),
    )));
    cols.push(Arc::new(arrow_array::StringArray::from_iter_values(
        rows.iter().map(|r| r.1),
    )));
    cols.push(f64_col(rows.iter().map(|r| Some(r.2.speed_rad_s))));
    cols.push(f64_col(rows.iter().map(|r| Some(r.2.friction))));
    cols.push(f64_col(rows.iter().map(|r| r.2.clearance_m)));
    for get in [
        |c: &CoatingParams| c.young,
        |c: &CoatingParams| c.hardening,
        |c: &CoatingParams| c.yield_stress,
        |c: &CoatingParams| c.thickness,
    ] {
        let vals: Vec<Option<CoatingValue>> = rows.iter().map(|r| get(&r.2.coating)).collect();
        let (a, s) = coating_cols(&vals);
        cols.push(a);
        cols.push(s);
    }
    cols.push(Arc::new(UInt32Array::from_iter_values(
        rows.iter().map(|r| r.3),
    )));
    debug_assert_eq!(cols.len(), PLAN_COLUMNS);
    cols
}

/// The jobs of a plan as a table: the results table's first columns (`job_index` …
/// `refinement_round`, with their units as field metadata), one row per job.
pub fn plan_batch(plan: &Plan) -> Result<RecordBatch> {
    let rows: Vec<_> = (plan.jobs.iter())
        .map(|j| {
            let round = plan.refinement_round(j.index);
            (j.index, j.id.as_str(), &j.params, round)
        })
        .collect();
    let cols = plan_columns(&rows);
    let schema = Arc::new(table_schema(&cols));
    RecordBatch::try_new(schema, cols).context("building the plan table")
}

/// Builds the results table from job records `(job index, record)`; rows are sorted by index.
pub(crate) fn results_batch(rows: &[(usize, JobRecord)]) -> Result<RecordBatch> {
    let mut rows: Vec<&(usize, JobRecord)> = rows.iter().collect();
    rows.sort_by_key(|(i, _)| *i);
    let res = |f: fn(&crate::sweep::JobResult) -> Option<f64>| -> ArrayRef {
        f64_col(rows.iter().map(|(_, r)| r.result.as_ref().and_then(f)))
    };
    let plan_rows: Vec<_> = (rows.iter())
        .map(|(i, r)| (*i, r.id.as_str(), &r.params, r.refinement_round))
        .collect();
    let mut cols = plan_columns(&plan_rows);
    let mut status = StringBuilder::new();
    let mut reason = StringBuilder::new();
    for (_, r) in &rows {
        match &r.status {
            JobStatus::Ok => {
                status.append_value("ok");
                reason.append_null();
            }
            JobStatus::Unstable => {
                status.append_value("unstable");
                reason.append_null();
            }
            JobStatus::Failed { reason: why } => {
                status.append_value("failed");
                reason.append_value(why);
            }
        }
    }
    cols.push(Arc::new(status.finish()));
    cols.push(Arc::new(reason.finish()));
    cols.push(res(|r| r.drive_work_j));
    runaway_columns(&rows, &mut cols);
    cols.push(res(|r| Some(r.maxima.blade_le_radial_m)));
    cols.push(res(|r| Some(r.maxima.blade_te_radial_m)));
    cols.push(res(|r| r.maxima.blade_le_radial_lowpass_m));
    cols.push(res(|r| r.maxima.blade_te_radial_lowpass_m));
    cols.push(res(|r| Some(r.maxima.casing_radial_m)));
    cols.push(res(|r| Some(r.maxima.contact_normal_force_n)));
    cols.push(res(|r| Some(r.maxima.coating_force_n)));

    predicted_columns(&rows, &mut cols);
    let mut wear = ListBuilder::new(ListBuilder::new(Float64Builder::new()));
    let mut peaks = ListBuilder::new(StructBuilder::new(
        peak_fields(),
        vec![
            Box::new(Float64Builder::new()) as Box<dyn ArrayBuilder>,
            Box::new(Float64Builder::new()),
            Box::new(Float64Builder::new()),
        ],
    ));
    for (_, r) in &rows {
        match &r.result {
            Some(res) => {
                for station in &res.wear_profile_m {
                    wear.values().values().append_slice(station);
                    wear.values().append(true);
                }
                wear.append(true);
                let sb = peaks.values();
                for p in &res.fourier_peaks {
                    for (k, v) in [p.frequency_hz, p.engine_order, p.amplitude_m]
                        .into_iter()
                        .enumerate()
                    {
                        sb.field_builder::<Float64Builder>(k)
                            .context("peak struct field builder")?
                            .append_value(v);
                    }
                    sb.append(true);
                }
                peaks.append(true);
            }
            None => {
                wear.append(false);
                peaks.append(false);
            }
        }
    }
    cols.push(Arc::new(wear.finish()));
    cols.push(Arc::new(peaks.finish()));
    cols.push(list_f64(rows.iter().map(|(_, r)| {
        r.result
            .as_ref()
            .map(|x| x.strain_energy_per_nd_j.as_slice())
    })));
    cols.push(res(|r| Some(r.residual_penetration_m)));
    cols.push(Arc::new(UInt64Array::from_iter(rows.iter().map(
        |(_, r)| r.result.as_ref().and_then(|x| x.steps_over_gap_tolerance),
    ))));
    cols.push(res(|r| r.critical_speed.map(|c| c.speed_rad_s)));
    let mut nd = UInt32Builder::new();
    for (_, r) in &rows {
        nd.append_option(
            r.result
                .as_ref()
                .and_then(|x| x.critical_speed)
                .map(|c| c.nodal_diameter),
        );
    }
    cols.push(Arc::new(nd.finish()));
    cols.push(res(|r| r.critical_speed.map(|c| c.compatibility)));
    cols.push(res(|r| r.spectrum.as_ref().map(|s| s.df_hz)));
    cols.push(list_f64(rows.iter().map(|(_, r)| {
        r.result
            .as_ref()
            .and_then(|x| x.spectrum.as_ref())
            .map(|s| s.amplitude_m.as_slice())
    })));
    cols.push(f64_col(rows.iter().map(|(_, r)| Some(r.wall_time_s))));

    let schema = Arc::new(table_schema(&cols));
    RecordBatch::try_new(schema, cols).context("building the results table")
}

/// The table's schema for its columns `cols` (in [`COLUMNS`] order): names, nullability, and
/// each column's unit and description as field metadata.
fn table_schema(cols: &[ArrayRef]) -> Schema {
    let fields: Vec<Field> = COLUMNS
        .iter()
        .zip(cols)
        .map(|(&(name, unit, desc), col)| {
            let nullable = !matches!(
                name,
                "job_index"
                    | "job_id"
                    | "speed_rad_s"
                    | "friction"
                    | "refinement_round"
                    | "status"
                    | "wall_time_s"
            );
            let mut md = HashMap::new();
            if !unit.is_empty() {
                md.insert("unit".to_string(), unit.to_string());
            }
            md.insert("description".to_string(), desc.to_string());
            Field::new(name, col.data_type().clone(), nullable).with_metadata(md)
        })
        .collect();
    Schema::new(fields)
}

/// Writes the results table to `path` atomically ([`AtomicFile`]), ZSTD compressed.
pub(crate) fn write_results(path: &Path, rows: &[(usize, JobRecord)]) -> Result<()> {
    let batch = results_batch(rows)?;
    let write = || -> Result<()> {
        let props = WriterProperties::builder()
            .set_compression(Compression::ZSTD(ZstdLevel::try_new(3)?))
            .build();
        let mut w = ArrowWriter::try_new(AtomicFile::create(path)?, batch.schema(), Some(props))?;
        w.write(&batch)?;
        w.into_inner()?.commit()?;
        Ok(())
    };
    write().with_context(|| format!("cannot write {}", path.display()))
}

/// Reads a results table back (all batches).
pub fn read_results(path: &Path) -> Result<Vec<RecordBatch>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .with_context(|| format!("{}: not a Parquet table", path.display()))?
        .with_batch_size(1 << 16)
        .build()?;
    reader
        .map(|b| b.context("reading results.parquet"))
        .collect()
}

/// Column `name` of a results batch as type `T`, or an error naming the column.
fn column<'a, T: 'static>(batch: &'a RecordBatch, name: &str) -> Result<&'a T> {
    batch
        .column_by_name(name)
        .with_context(|| format!("column {name} missing"))?
        .as_any()
        .downcast_ref::<T>()
        .with_context(|| format!("column {name} has an unexpected type"))
}

/// The `f64` of row `i` of a nullable column (`None` when null).
fn opt_f64(a: &Float64Array, i: usize) -> Option<f64> {
    a.is_valid(i).then(|| a.value(i))
}

/// The `f64` list of row `i` of a list column.
fn f64_list(a: &ListArray, i: usize, name: &str) -> Result<Vec<f64>> {
    let v = a.value(i);
    let v = v
        .as_any()
        .downcast_ref::<Float64Array>()
        .with_context(|| format!("column {name}: items are not float64"))?;
    Ok(v.values().to_vec())
}

/// Coating setting of row `i` from its absolute / scale column pair.
fn coating_value(abs: &Float64Array, scale: &Float64Array, i: usize) -> Option<CoatingValue> {
    opt_f64(abs, i)
        .map(CoatingValue::Absolute)
        .or_else(|| opt_f64(scale, i).map(CoatingValue::Scale))
}

/// The job records `(job index, record)` of one results batch: the inverse of
/// [`results_batch`] (every field of a record is a column of the table).
fn records_of_batch(b: &RecordBatch) -> Result<Vec<(usize, JobRecord)>> {
    let f = |name: &str| column::<Float64Array>(b, name);
    let index = column::<UInt64Array>(b, "job_index")?;
    let id = column::<StringArray>(b, "job_id")?;
    let (speed, friction, clearance) = (f("speed_rad_s")?, f("friction")?, f("clearance_m")?);
    let pair = |q: &str, unit: &str| -> Result<(&Float64Array, &Float64Array)> {
        Ok((
            f(&format!("coating_{q}_{unit}"))?,
            f(&format!("coating_{q}_scale"))?,
        ))
    };
    let young = pair("young", "pa")?;
    let hardening = pair("hardening", "pa")?;
    let yield_stress = pair("yield_stress", "pa")?;
    let thickness = pair("thickness", "m")?;
    let status = column::<StringArray>(b, "status")?;
    // Absent from tables written before refinement existed.
    let round = b
        .column_by_name("refinement_round")
        .map(|_| column::<UInt32Array>(b, "refinement_round"))
        .transpose()?;
    let reason = column::<StringArray>(b, "reason")?;
    let maxima: Vec<&Float64Array> = [
        "max_blade_le_radial_m",
        "max_blade_te_radial_m",
        "max_casing_radial_m",
        "max_contact_normal_force_n",
        "max_coating_force_n",
    ]
    .into_iter()
    .map(f)
    .collect::<Result<_>>()?;
    let wear = column::<ListArray>(b, "wear_profile_m")?;
    let peaks = column::<ListArray>(b, "fourier_peaks")?;
    let energy = column::<ListArray>(b, "strain_energy_per_nd_j")?;
    let residual = f("residual_penetration_m")?;
    // Absent from tables written before the count existed.
    let over_tolerance = b
        .column_by_name("steps_over_gap_tolerance")
        .map(|_| column::<UInt64Array>(b, "steps_over_gap_tolerance"))
        .transpose()?;
    let crit_speed = f("critical_speed_rad_s")?;
    let crit_nd = column::<UInt32Array>(b, "critical_nodal_diameter")?;
    let crit_compat = f("critical_compatibility")?;
    let df = f("spectrum_df_hz")?;
    let spectrum = column::<ListArray>(b, "spectrum_amplitude_m")?;
    let wall = f("wall_time_s")?;
    let mut out = Vec::with_capacity(b.num_rows());
    for i in 0..b.num_rows() {
        let params = JobParams {
            speed_rad_s: speed.value(i),
            friction: friction.value(i),
            clearance_m: opt_f64(clearance, i),
            coating: CoatingParams {
                young: coating_value(young.0, young.1, i),
                hardening: coating_value(hardening.0, hardening.1, i),
                yield_stress: coating_value(yield_stress.0, yield_stress.1, i),
                thickness: coating_value(thickness.0, thickness.1, i),
            },
        };
        let (state, result) = match status.value(i) {
            outcome @ ("ok" | "unstable") => (
                if outcome == "ok" {
                    JobStatus::Ok
                } else {
                    JobStatus::Unstable
                },
                Some(result_of_row(
                    b,
                    i,
                    &RowColumns {
                        maxima: &maxima,
                        wear,
                        peaks,
                        energy,
                        residual,
                        over_tolerance,
                        crit: (crit_speed, crit_nd, crit_compat),
                        spectrum: (df, spectrum),
                    },
                )?),
            ),
            "failed" => (
                JobStatus::Failed {
                    reason: if reason.is_valid(i) {
                        reason.value(i)
                    } else {
                        ""
                    }
                    .to_string(),
                },
                None,
            ),
            other => anyhow::bail!(
                "row {i}: status {other:?} (expected \"ok\", \"unstable\" or \"failed\")"
            ),
        };
        out.push((
            index.value(i) as usize,
            JobRecord {
                format_version: crate::sweep::checkpoint::JOB_RECORD_VERSION,
                id: id.value(i).to_string(),
                params,
                status: state,
                result,
                wall_time_s: wall.value(i),
                refinement_round: round.map_or(0, |r| r.value(i)),
            },
        ));
    }
    Ok(out)
}

/// The result columns of a batch, for [`result_of_row`].
struct RowColumns<'a> {
    maxima: &'a [&'a Float64Array],
    wear: &'a ListArray,
    peaks: &'a ListArray,
    energy: &'a ListArray,
    residual: &'a Float64Array,
    over_tolerance: Option<&'a UInt64Array>,
    crit: (&'a Float64Array, &'a UInt32Array, &'a Float64Array),
    spectrum: (&'a Float64Array, &'a ListArray),
}

/// The [`JobResult`](crate::sweep::JobResult) of row `i` of an ok or unstable job.
fn result_of_row(b: &RecordBatch, i: usize, c: &RowColumns<'_>) -> Result<crate::sweep::JobResult> {
    let need = |a: &Float64Array, name: &str| {
        opt_f64(a, i).with_context(|| format!("row {i}: {name} is null for an ok job"))
    };
    let m: Vec<f64> = c
        .maxima
        .iter()
        .map(|a| need(a, "a maximum"))
        .collect::<Result<_>>()?;
    let stations = c.wear.value(i);
    let stations = stations
        .as_any()
        .downcast_ref::<ListArray>()
        .context("column wear_profile_m: items are not lists")?;
    let wear_profile_m = (0..stations.len())
        .map(|s| f64_list(stations, s, "wear_profile_m"))
        .collect::<Result<_>>()?;
    let peaks = c.peaks.value(i);
    let peaks = peaks
        .as_any()
        .downcast_ref::<StructArray>()
        .context("column fourier_peaks: items are not structs")?;
    let field = |k: usize| {
        peaks
            .column(k)
            .as_any()
            .downcast_ref::<Float64Array>()
            .context("column fourier_peaks: fields are not float64")
    };
    let (pf, pe, pa) = (field(0)?, field(1)?, field(2)?);
    let fourier_peaks = (0..peaks.len())
        .map(|k| crate::sweep::FourierPeak {
            frequency_hz: pf.value(k),
            engine_order: pe.value(k),
            amplitude_m: pa.value(k),
        })
        .collect();
    let (cs, cn, cc) = c.crit;
    let critical_speed = match (opt_f64(cs, i), cn.is_valid(i), opt_f64(cc, i)) {
        (Some(speed_rad_s), true, Some(compatibility)) => Some(crate::sweep::CriticalSpeed {
            speed_rad_s,
            nodal_diameter: cn.value(i),
            compatibility,
        }),
        _ => None,
    };
    let (df, amp) = c.spectrum;
    let spectrum = match opt_f64(df, i) {
        Some(df_hz) if amp.is_valid(i) => Some(crate::sweep::Spectrum {
            df_hz,
            amplitude_m: f64_list(amp, i, "spectrum_amplitude_m")?,
        }),
        _ => None,
    };
    Ok(crate::sweep::JobResult {
        maxima: crate::sweep::Maxima {
            blade_le_radial_m: m[0],
            blade_te_radial_m: m[1],
            blade_le_radial_lowpass_m: optional_f64(b, "max_blade_le_radial_lowpass_m", i)?,
            blade_te_radial_lowpass_m: optional_f64(b, "max_blade_te_radial_lowpass_m", i)?,
            casing_radial_m: m[2],
            contact_normal_force_n: m[3],
            coating_force_n: m[4],
        },
        wear_profile_m,
        fourier_peaks,
        strain_energy_per_nd_j: f64_list(c.energy, i, "strain_energy_per_nd_j")?,
        residual_penetration_m: need(c.residual, "residual_penetration_m")?,
        steps_over_gap_tolerance: c
            .over_tolerance
            .and_then(|a| a.is_valid(i).then(|| a.value(i))),
        critical_speed,
        spectrum,
        drive_work_j: optional_f64(b, "drive_work_j", i)?,
        predicted: predicted_of_row(b, i)?,
        runaway: runaway_of_row(b, i)?,
    })
}

/// Row `i` of the Float64 column `name`, `None` when null or absent (tables written before
/// the column existed).
fn optional_f64(b: &RecordBatch, name: &str, i: usize) -> Result<Option<f64>> {
    Ok(b.column_by_name(name)
        .map(|_| column::<Float64Array>(b, name))
        .transpose()?
        .and_then(|a| opt_f64(a, i)))
}

/// Reads the job records `(job index, record)` back from a results table, in table order
/// (the inverse of the writer: a table written from records reads back as those records).
/// Errors name the file and the column or row at fault.
pub fn read_records(path: &Path) -> Result<Vec<(usize, JobRecord)>> {
    let mut out = Vec::new();
    for b in read_results(path)? {
        out.extend(records_of_batch(&b).with_context(|| format!("{}", path.display()))?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_md_documents_every_column_with_unit() {
        let doc = include_str!("../../schemas/results.md");
        for (name, unit, _) in COLUMNS {
            let line = doc
                .lines()
                .find(|l| l.starts_with(&format!("| `{name}` |")))
                .unwrap_or_else(|| panic!("column {name} missing from schemas/results.md"));
            if !unit.is_empty() {
                assert!(
                    line.contains(&format!("| {unit} |")),
                    "unit of {name} in results.md: {line}"
                );
            }
        }
    }

    /// The plan table has the results table's parameter columns, in order and with their
    /// units, and one row per job with its parameters.
    #[test]
    fn plan_table_has_the_results_parameter_columns() {
        let spec = crate::sweep::parse_spec(include_str!("../../tests/data/small_sweep.json"));
        let plan = crate::sweep::plan(&spec.unwrap()).unwrap();
        let b = plan_batch(&plan).unwrap();
        assert_eq!(b.num_rows(), plan.jobs.len());
        assert_eq!(COLUMNS[PLAN_COLUMNS - 1].0, "refinement_round");
        let results = results_batch(&[]).unwrap();
        for (k, field) in b.schema().fields().iter().enumerate() {
            assert_eq!(field.as_ref(), results.schema().field(k));
        }
        assert_eq!(b.num_columns(), PLAN_COLUMNS);
        let speeds = b.column(2).as_any().downcast_ref::<Float64Array>().unwrap();
        for j in &plan.jobs {
            assert_eq!(speeds.value(j.index), j.params.speed_rad_s);
        }
    }

    #[test]
    fn empty_table_has_all_columns() {
        let b = results_batch(&[]).unwrap();
        assert_eq!(b.num_rows(), 0);
        assert_eq!(b.num_columns(), COLUMNS.len());
    }

    /// Records with every optional field set and unset, ok and failed.
    fn sample_records() -> Vec<(usize, JobRecord)> {
        use crate::sweep::{CriticalSpeed, FourierPeak, JobResult, Maxima, Spectrum};
        let params = |w: f64| JobParams {
            speed_rad_s: w,
            friction: 0.15,
            clearance_m: None,
            coating: CoatingParams::default(),
        };
        let full = JobResult {
            maxima: Maxima {
                blade_le_radial_m: 1e-4,
                blade_te_radial_m: 2e-4,
                blade_le_radial_lowpass_m: Some(0.9e-4),
                blade_te_radial_lowpass_m: Some(1.8e-4),
                casing_radial_m: 3e-4,
                contact_normal_force_n: 12.5,
                coating_force_n: 0.5,
            },
            wear_profile_m: vec![vec![0.0, 1e-5, 2e-5], vec![3e-5, 0.0, 1e-6]],
            fourier_peaks: vec![FourierPeak {
                frequency_hz: 700.0,
                engine_order: 2.0,
                amplitude_m: 1e-5,
            }],
            strain_energy_per_nd_j: vec![1.0, 1e-20, 0.3],
            residual_penetration_m: 1e-13,
            steps_over_gap_tolerance: Some(3),
            critical_speed: Some(CriticalSpeed {
                speed_rad_s: 6891.0,
                nodal_diameter: 5,
                compatibility: 0.135,
            }),
            spectrum: Some(Spectrum {
                df_hz: 83.3,
                amplitude_m: vec![1e-7, 2e-6, 3e-8],
            }),
            drive_work_j: Some(2.5e4),
            predicted: Some(crate::sweep::PredictedStability {
                stable: false,
                growth_rate_per_s: 2583.0,
                nodal_diameter: 5,
                frequency_hz: 3553.0,
            }),
            runaway: None,
        };
        let unstable = JobResult {
            runaway: Some(Runaway {
                onset_time_s: 4.1e-3,
                detected_time_s: 6.3e-3,
                growth_rate_per_s: 612.0,
                growth_fit_r2: 0.93,
                energy_growth: 12.5,
                drive_work_j: 3.1e4,
                nodal_diameter: Some(5),
                frequency_hz: Some(3841.5),
                forward: Some(true),
                rotating_frame_frequency_hz: Some(10.2),
                at_solve_breakdown: true,
            }),
            ..full.clone()
        };
        let mut coated = params(2500.0);
        coated.clearance_m = Some(5e-4);
        coated.coating = CoatingParams {
            young: Some(CoatingValue::Scale(0.1)),
            hardening: Some(CoatingValue::Absolute(1e9)),
            yield_stress: None,
            thickness: Some(CoatingValue::Absolute(2e-3)),
        };
        let rec = |id: &str, p, status, result| JobRecord {
            format_version: crate::sweep::checkpoint::JOB_RECORD_VERSION,
            id: id.into(),
            params: p,
            status,
            result,
            wall_time_s: 1.25,
            refinement_round: 0,
        };
        let mut refined = rec("d", params(4000.0), JobStatus::Unstable, Some(unstable));
        refined.refinement_round = 2;
        vec![
            (0, rec("a", params(2000.0), JobStatus::Ok, Some(full))),
            (
                1,
                rec("b", coated, JobStatus::Ok, Some(JobResult::default())),
            ),
            (
                2,
                rec(
                    "c",
                    params(3000.0),
                    JobStatus::Failed {
                        reason: "diverged".into(),
                    },
                    None,
                ),
            ),
            (3, refined),
        ]
    }

    #[test]
    fn records_read_back_as_written() {
        let dir = std::env::temp_dir().join(format!("rubscan-table-rt-{}", std::process::id()));
        let path = dir.join("results.parquet");
        let rows = sample_records();
        write_results(&path, &rows).unwrap();
        assert_eq!(read_records(&path).unwrap(), rows);
        // A table without one of the columns is refused, naming the file and the column.
        let batch = results_batch(&rows).unwrap();
        let mut cut = batch.clone();
        cut.remove_column(batch.schema().index_of("strain_energy_per_nd_j").unwrap());
        let err = records_of_batch(&cut).unwrap_err().to_string();
        assert!(err.contains("strain_energy_per_nd_j"), "{err}");
        // A table from before the residual count reads back with the count unknown.
        let mut old = batch.clone();
        old.remove_column(batch.schema().index_of("steps_over_gap_tolerance").unwrap());
        let read = records_of_batch(&old).unwrap();
        assert_eq!(
            read[0].1.result.as_ref().unwrap().steps_over_gap_tolerance,
            None
        );
        // A table from before the low-passed blade peaks reads back without them.
        for name in [
            "max_blade_le_radial_lowpass_m",
            "max_blade_te_radial_lowpass_m",
        ] {
            old.remove_column(old.schema().index_of(name).unwrap());
        }
        let maxima = records_of_batch(&old).unwrap()[0]
            .1
            .result
            .as_ref()
            .unwrap()
            .maxima;
        let written = rows[0].1.result.as_ref().unwrap().maxima;
        assert!(written.blade_le_radial_lowpass_m.is_some());
        assert_eq!(maxima.blade_le_radial_lowpass_m, None);
        assert_eq!(maxima.blade_te_radial_lowpass_m, None);
        assert_eq!(maxima.blade_te_radial_m, written.blade_te_radial_m);
        std::fs::write(&path, b"not parquet").unwrap();
        let err = format!("{:#}", read_records(&path).unwrap_err());
        assert!(err.contains("results.parquet"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Refinement's `quantity_of` reads what the table writes, and every column is either a
    /// peak quantity or one of the other columns (a new column must choose its side).
    #[test]
    fn peak_quantities_are_the_tables_numeric_result_columns() {
        use crate::sweep::refine::{OTHER_COLUMNS, PEAK_QUANTITIES, quantity_of};
        use arrow_array::Array;
        // The record whose result has every field set.
        let (_, record) = sample_records().swap_remove(0);
        let result = record.result.clone().unwrap();
        let batch = results_batch(&[(0, record)]).unwrap();
        for &name in PEAK_QUANTITIES {
            let col = batch
                .column_by_name(name)
                .unwrap_or_else(|| panic!("{name}"));
            let any = col.as_any();
            let value = if let Some(c) = any.downcast_ref::<arrow_array::Float64Array>() {
                c.value(0)
            } else if let Some(c) = any.downcast_ref::<arrow_array::UInt64Array>() {
                c.value(0) as f64
            } else if let Some(c) = any.downcast_ref::<arrow_array::UInt32Array>() {
                f64::from(c.value(0))
            } else {
                panic!("{name} is a {:?} column", col.data_type())
            };
            assert_eq!(Some(value), quantity_of(name, &result), "{name}");
        }
        for (name, _, _) in COLUMNS {
            assert!(
                PEAK_QUANTITIES.contains(name) ^ OTHER_COLUMNS.contains(name),
                "column {name}: a peak quantity or excluded, not both or neither"
            );
        }
        assert_eq!(quantity_of("wall_time_s", &result), None);
    }
}
