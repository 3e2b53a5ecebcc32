//! Time series of one simulation as a Parquet table, streamed while it runs: one `Float64`
//! column per probe, the unit in the column name suffix and in the field metadata (`unit`).

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use arrow_array::{ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;

use crate::dynamics::recorder::{RecordError, Recorder, Sample};
use crate::io::atomic::AtomicFile;

/// The name of a time-series column: `name`, `{prefix}{index}_{suffix}`, or a probe's own
/// column name (see [`crate::dynamics::probes::Probe::column`]).
enum ColumnName<'a> {
    Plain(&'static str),
    Indexed(&'static str, usize, &'static str),
    Probe(&'a str),
}

impl ColumnName<'_> {
    fn text(&self) -> String {
        match self {
            ColumnName::Plain(n) => (*n).to_string(),
            ColumnName::Indexed(p, i, s) => format!("{p}{i}_{s}"),
            ColumnName::Probe(n) => (*n).to_string(),
        }
    }
}

/// Calls `f` with the name, unit and value of every column of a sample, in table order; the
/// case's probes come last, in the case's order.
fn each_column<'a>(s: &Sample<'a>, mut f: impl FnMut(ColumnName<'a>, &'static str, f64)) {
    f(ColumnName::Plain("time_s"), "s", s.time);
    let mut per = |prefix, suffix, unit, values: &[f64]| {
        for (i, v) in values.iter().enumerate() {
            f(ColumnName::Indexed(prefix, i, suffix), unit, *v);
        }
    };
    per("blade", "le_radial_m", "m", s.blade_le_radial);
    per("blade", "te_radial_m", "m", s.blade_te_radial);
    per("casing_probe", "radial_m", "m", s.casing_radial);
    per("blade", "normal_force_n", "N", s.blade_normal_force);
    per("blade", "tangential_force_n", "N", s.blade_tangential_force);
    per(
        "impeller_nd",
        "strain_energy_j",
        "J",
        s.impeller_nd_strain_energy,
    );
    if let Some(c) = &s.coating {
        per("coating_row", "max_wear_m", "m", c.max_wear);
        per("blade", "coating_force_n", "N", c.blade_force);
    }
    f(ColumnName::Plain("min_gap_m"), "m", s.min_gap);
    f(
        ColumnName::Plain("residual_penetration_m"),
        "m",
        s.residual_penetration,
    );
    f(ColumnName::Plain("drive_work_j"), "J", s.drive_work);
    let e = s.impeller_energy;
    f(
        ColumnName::Plain("impeller_kinetic_energy_j"),
        "J",
        e.kinetic,
    );
    f(ColumnName::Plain("impeller_strain_energy_j"), "J", e.strain);
    if let Some(e) = s.casing_energy {
        f(ColumnName::Plain("casing_kinetic_energy_j"), "J", e.kinetic);
        f(ColumnName::Plain("casing_strain_energy_j"), "J", e.strain);
    }
    for (p, v) in s.probe_columns.iter().zip(s.probes) {
        f(ColumnName::Probe(&p.column), p.unit, *v);
    }
}

/// A [`Recorder`] that streams the samples of a simulation to a Parquet file, one row per
/// sample and one `Float64` column per probe (names end in their unit, which is also in the
/// field metadata), in row groups of [`TimeSeriesWriter::ROW_GROUP`] rows: its memory does not
/// grow with the run. The file appears, whole, only when [`TimeSeriesWriter::finish`] succeeds.
pub struct TimeSeriesWriter {
    path: std::path::PathBuf,
    schema: Option<Arc<Schema>>,
    writer: Option<ArrowWriter<AtomicFile>>,
    file: Option<AtomicFile>,
    columns: Vec<Vec<f64>>,
}

impl TimeSeriesWriter {
    /// Rows buffered per row group (8 MiB for 16 columns).
    pub const ROW_GROUP: usize = 65_536;

    /// Starts the file `path` (written under a temporary name until [`Self::finish`]).
    pub fn create(path: &Path) -> Result<Self> {
        let file =
            AtomicFile::create(path).with_context(|| format!("creating {}", path.display()))?;
        Ok(Self {
            path: path.to_path_buf(),
            schema: None,
            writer: None,
            file: Some(file),
            columns: Vec::new(),
        })
    }

    fn start(&mut self, sample: &Sample<'_>) -> Result<()> {
        let mut fields = Vec::new();
        each_column(sample, |name, unit, _| {
            fields.push(
                Field::new(name.text(), DataType::Float64, false)
                    .with_metadata(HashMap::from([("unit".to_string(), unit.to_string())])),
            );
        });
        let schema = Arc::new(Schema::new(fields));
        let props = WriterProperties::builder()
            .set_compression(Compression::ZSTD(ZstdLevel::try_new(3)?))
            .set_max_row_group_row_count(Some(Self::ROW_GROUP))
            .build();
        let file = self.file.take().context("time series already started")?;
        self.writer = Some(ArrowWriter::try_new(file, schema.clone(), Some(props))?);
        self.columns = vec![Vec::with_capacity(Self::ROW_GROUP); schema.fields().len()];
        self.schema = Some(schema);
        Ok(())
    }

    fn flush_rows(&mut self) -> Result<()> {
        let (Some(schema), Some(writer)) = (&self.schema, self.writer.as_mut()) else {
            return Ok(());
        };
        if self.columns.first().is_none_or(Vec::is_empty) {
            return Ok(());
        }
        let arrays: Vec<ArrayRef> = self
            .columns
            .iter_mut()
            .map(|c| Arc::new(Float64Array::from(std::mem::take(c))) as ArrayRef)
            .collect();
        writer.write(&RecordBatch::try_new(schema.clone(), arrays)?)?;
        Ok(())
    }

    /// Writes the last rows and the footer, then commits the file (synced, renamed).
    pub fn finish(mut self) -> Result<()> {
        let path = self.path.clone();
        let ctx = || format!("writing {}", path.display());
        if self.writer.is_none() {
            // No sample: a table with an empty time column.
            let file = self.file.take().context("time series already finished")?;
            let schema = Arc::new(Schema::new(vec![
                Field::new("time_s", DataType::Float64, false)
                    .with_metadata(HashMap::from([("unit".to_string(), "s".to_string())])),
            ]));
            self.writer = Some(ArrowWriter::try_new(file, schema, None)?);
        }
        self.flush_rows().with_context(ctx)?;
        let writer = self.writer.take().context("time series already finished")?;
        let file = writer.into_inner().with_context(ctx)?;
        file.commit().with_context(ctx)
    }
}

impl Recorder for TimeSeriesWriter {
    fn record(&mut self, sample: &Sample<'_>) -> Result<(), RecordError> {
        if self.schema.is_none() {
            self.start(sample)?;
        }
        let mut col = self.columns.iter_mut();
        let mut missing = false;
        each_column(sample, |_, _, v| match col.next() {
            Some(c) => c.push(v),
            None => missing = true,
        });
        if missing || col.next().is_some() {
            return Err("a sample does not have the columns of the first one".into());
        }
        if self.columns[0].len() >= Self::ROW_GROUP {
            self.flush_rows()?;
        }
        Ok(())
    }
}

/// Reads the columns of a time-series file whose names `keep` accepts, in file order, as
/// `(name, values)`; errors name the file (and the column that is not `Float64`).
pub fn read_columns(path: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<(String, Vec<f64>)>> {
    use parquet::arrow::ProjectionMask;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .with_context(|| format!("{}: not a Parquet table", path.display()))?;
    let names: Vec<String> = builder
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect();
    let picked: Vec<usize> = (0..names.len()).filter(|&i| keep(&names[i])).collect();
    let mask = ProjectionMask::roots(builder.parquet_schema(), picked.iter().copied());
    let reader = builder
        .with_projection(mask)
        .build()
        .with_context(|| format!("reading {}", path.display()))?;
    let mut out: Vec<(String, Vec<f64>)> = picked
        .iter()
        .map(|&i| (names[i].clone(), Vec::new()))
        .collect();
    for batch in reader {
        let batch = batch.with_context(|| format!("reading {}", path.display()))?;
        for (k, (name, values)) in out.iter_mut().enumerate() {
            let col = batch
                .column(k)
                .as_any()
                .downcast_ref::<Float64Array>()
                .with_context(|| format!("{}: column {name} is not float64", path.display()))?;
            values.extend_from_slice(col.values());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::Array;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

    /// A streamed series reads back with its columns, units and values; nothing appears under
    /// the final name before `finish`, and a writer dropped unfinished leaves nothing.
    #[test]
    fn streamed_samples_read_back_and_appear_only_when_finished() {
        use crate::dynamics::kernel::Energies;
        let dir = std::env::temp_dir().join(format!("rubscan-tsw-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let path = dir.join("ts.parquet");
        let sample = |i: usize| {
            let t = i as f64 * 1e-6;
            (t, [t * 2.0, -t], [0.5 * t])
        };
        let record = |w: &mut TimeSeriesWriter, i: usize| {
            let (t, le, nd) = sample(i);
            let s = Sample {
                time: t,
                blade_le_radial: &le,
                blade_te_radial: &le,
                casing_radial: &[],
                blade_normal_force: &[0.0, 1.0],
                blade_tangential_force: &[0.0, 0.1],
                min_gap: -t,
                residual_penetration: 0.0,
                drive_work: 0.0,
                impeller_energy: Energies::default(),
                casing_energy: None,
                impeller_nd_strain_energy: &nd,
                coating: None,
                probe_columns: &[],
                probes: &[],
            };
            w.record(&s).unwrap();
        };
        {
            let mut w = TimeSeriesWriter::create(&path).unwrap();
            record(&mut w, 0);
        }
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        let mut w = TimeSeriesWriter::create(&path).unwrap();
        let n = 3 * TimeSeriesWriter::ROW_GROUP / 2;
        for i in 0..n {
            record(&mut w, i);
        }
        assert!(!path.exists());
        w.finish().unwrap();
        let reader =
            ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(&path).unwrap()).unwrap();
        assert_eq!(reader.metadata().num_row_groups(), 2);
        let schema = reader.schema().clone();
        let le1 = schema.index_of("blade1_le_radial_m").unwrap();
        assert_eq!(schema.field(le1).metadata()["unit"], "m");
        assert_eq!(
            schema
                .field(schema.index_of("impeller_nd0_strain_energy_j").unwrap())
                .metadata()["unit"],
            "J"
        );
        assert!(schema.index_of("casing_kinetic_energy_j").is_err());
        let mut values = Vec::new();
        for batch in reader.build().unwrap() {
            let batch = batch.unwrap();
            let col = batch
                .column(le1)
                .as_any()
                .downcast_ref::<Float64Array>()
                .unwrap();
            values.extend_from_slice(col.values());
        }
        let expect: Vec<f64> = (0..n).map(|i| sample(i).1[1]).collect();
        assert_eq!(values, expect);
        // read_columns: the chosen columns over both row groups, in file order.
        let cols = read_columns(&path, |c| c == "blade1_le_radial_m" || c == "time_s").unwrap();
        let names: Vec<&str> = cols.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["time_s", "blade1_le_radial_m"]);
        assert_eq!(cols[1].1, expect);
        assert_eq!(cols[0].1.len(), n);
        std::fs::write(dir.join("bad.parquet"), b"PAR1 nonsense").unwrap();
        let err = format!(
            "{:#}",
            read_columns(&dir.join("bad.parquet"), |_| true).unwrap_err()
        );
        assert!(err.contains("bad.parquet"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The case's probes get one column each, after the built-in ones, named by node and
    /// component with their unit in the field metadata; the values are the probes'.
    #[test]
    fn probe_columns_are_named_by_node_and_carry_their_units() {
        use crate::dynamics::kernel::Energies;
        use crate::dynamics::probes::{Probe, ProbeQuantity, ProbeTarget};
        let dir = std::env::temp_dir().join(format!("rubscan-tsp-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let path = dir.join("p.parquet");
        let probe = |column: &str, unit, quantity| Probe {
            target: ProbeTarget::Blade { blade: 0, index: 0 },
            quantity,
            direction: nalgebra::Vector3::y(),
            column: column.into(),
            unit,
        };
        let probes = [
            probe("node1353_y_m", "m", ProbeQuantity::Displacement),
            probe("contact188_gap_m", "m", ProbeQuantity::Gap),
            probe("contact188_normal_force_n", "N", ProbeQuantity::NormalForce),
        ];
        let mut w = TimeSeriesWriter::create(&path).unwrap();
        for i in 0..5 {
            let values = [1e-6 * i as f64, -2e-6, 10.0 * i as f64];
            let s = Sample {
                time: i as f64,
                blade_le_radial: &[0.0],
                blade_te_radial: &[0.0],
                casing_radial: &[],
                blade_normal_force: &[0.0],
                blade_tangential_force: &[0.0],
                min_gap: 0.0,
                residual_penetration: 0.0,
                drive_work: 0.0,
                impeller_energy: Energies::default(),
                casing_energy: None,
                impeller_nd_strain_energy: &[],
                coating: None,
                probe_columns: &probes,
                probes: &values,
            };
            w.record(&s).unwrap();
        }
        w.finish().unwrap();
        let reader =
            ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(&path).unwrap()).unwrap();
        let schema = reader.schema().clone();
        let n = schema.fields().len();
        let names: Vec<&str> = schema.fields()[n - 3..]
            .iter()
            .map(|f| f.name().as_str())
            .collect();
        assert_eq!(
            names,
            [
                "node1353_y_m",
                "contact188_gap_m",
                "contact188_normal_force_n"
            ]
        );
        let units: Vec<&str> = schema.fields()[n - 3..]
            .iter()
            .map(|f| f.metadata()["unit"].as_str())
            .collect();
        assert_eq!(units, ["m", "m", "N"]);
        let batch = reader.build().unwrap().next().unwrap().unwrap();
        let col = |i: usize| {
            let c = batch
                .column(i)
                .as_any()
                .downcast_ref::<Float64Array>()
                .unwrap();
            c.values().to_vec()
        };
        assert_eq!(col(n - 1), [0.0, 10.0, 20.0, 30.0, 40.0]);
        assert_eq!(col(n - 2), [-2e-6; 5]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
