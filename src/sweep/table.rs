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
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, Fields, Schema};
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;

use crate::io::atomic::AtomicFile;
use crate::sweep::checkpoint::{JobRecord, JobStatus};
use crate::sweep::planner::CoatingValue;

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
    ("status", "", "\"ok\" or \"failed\""),
    ("reason", "", "failure reason; null when ok"),
    (
        "max_blade_le_radial_m",
        "m",
        "max |radial displacement| of blade leading edges",
    ),
    (
        "max_blade_te_radial_m",
        "m",
        "max |radial displacement| of blade trailing edges",
    ),
    (
        "max_casing_radial_m",
        "m",
        "max |radial displacement| of casing probes",
    ),
    (
        "max_contact_normal_force_n",
        "N",
        "max normal contact force per blade",
    ),
    (
        "max_coating_force_n",
        "N",
        "max abradable coating force per blade",
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
        "largest penetration left at the end",
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

/// Builds the results table from job records `(job index, record)`; rows are sorted by index.
pub(crate) fn results_batch(rows: &[(usize, JobRecord)]) -> Result<RecordBatch> {
    let mut rows: Vec<&(usize, JobRecord)> = rows.iter().collect();
    rows.sort_by_key(|(i, _)| *i);
    let res = |f: fn(&crate::sweep::JobResult) -> Option<f64>| -> ArrayRef {
        f64_col(rows.iter().map(|(_, r)| r.result.as_ref().and_then(f)))
    };
    let mut cols: Vec<ArrayRef> = Vec::with_capacity(COLUMNS.len());
    cols.push(Arc::new(arrow_array::UInt64Array::from_iter_values(
        rows.iter().map(|(i, _)| *i as u64),
    )));
    cols.push(Arc::new(arrow_array::StringArray::from_iter_values(
        rows.iter().map(|(_, r)| r.id.as_str()),
    )));
    cols.push(f64_col(
        rows.iter().map(|(_, r)| Some(r.params.speed_rad_s)),
    ));
    cols.push(f64_col(rows.iter().map(|(_, r)| Some(r.params.friction))));
    cols.push(f64_col(rows.iter().map(|(_, r)| r.params.clearance_m)));
    for get in [
        |c: &crate::sweep::CoatingParams| c.young,
        |c: &crate::sweep::CoatingParams| c.hardening,
        |c: &crate::sweep::CoatingParams| c.yield_stress,
        |c: &crate::sweep::CoatingParams| c.thickness,
    ] {
        let vals: Vec<Option<CoatingValue>> =
            rows.iter().map(|(_, r)| get(&r.params.coating)).collect();
        let (a, s) = coating_cols(&vals);
        cols.push(a);
        cols.push(s);
    }
    let mut status = StringBuilder::new();
    let mut reason = StringBuilder::new();
    for (_, r) in &rows {
        match &r.status {
            JobStatus::Ok => {
                status.append_value("ok");
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
    cols.push(res(|r| Some(r.maxima.blade_le_radial_m)));
    cols.push(res(|r| Some(r.maxima.blade_te_radial_m)));
    cols.push(res(|r| Some(r.maxima.casing_radial_m)));
    cols.push(res(|r| Some(r.maxima.contact_normal_force_n)));
    cols.push(res(|r| Some(r.maxima.coating_force_n)));

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

    let fields: Vec<Field> = COLUMNS
        .iter()
        .zip(&cols)
        .map(|(&(name, unit, desc), col)| {
            let nullable = !matches!(
                name,
                "job_index" | "job_id" | "speed_rad_s" | "friction" | "status" | "wall_time_s"
            );
            let mut md = HashMap::new();
            if !unit.is_empty() {
                md.insert("unit".to_string(), unit.to_string());
            }
            md.insert("description".to_string(), desc.to_string());
            Field::new(name, col.data_type().clone(), nullable).with_metadata(md)
        })
        .collect();
    let schema = Arc::new(Schema::new(fields));
    RecordBatch::try_new(schema, cols).context("building the results table")
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
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)?
        .with_batch_size(1 << 16)
        .build()?;
    reader
        .map(|b| b.context("reading results.parquet"))
        .collect()
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

    #[test]
    fn empty_table_has_all_columns() {
        let b = results_batch(&[]).unwrap();
        assert_eq!(b.num_rows(), 0);
        assert_eq!(b.num_columns(), COLUMNS.len());
    }
}
