//! Time series of one simulation as a Parquet table: one `Float64` column per
//! probe, the unit in the column name suffix and in the field metadata (`unit`).

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result, ensure};
use arrow_array::{ArrayRef, Float64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;

use crate::io::rom_file::write_atomic;

/// One column of a time-series table.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    /// Column name, ending in its unit (`_m`, `_n`, `_s`, `_j`).
    pub name: String,
    /// Unit written to the field metadata (e.g. `m`).
    pub unit: &'static str,
    /// One value per sample.
    pub values: Vec<f64>,
}

/// Encodes equally long columns as a ZSTD-compressed Parquet file in memory.
pub fn to_parquet_bytes(columns: &[Column]) -> Result<Vec<u8>> {
    let rows = columns.first().map_or(0, |c| c.values.len());
    for c in columns {
        ensure!(
            c.values.len() == rows,
            "column `{}` has {} rows, expected {rows}",
            c.name,
            c.values.len()
        );
    }
    let fields: Vec<Field> = columns
        .iter()
        .map(|c| {
            Field::new(&c.name, DataType::Float64, false)
                .with_metadata(HashMap::from([("unit".to_string(), c.unit.to_string())]))
        })
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let arrays: Vec<ArrayRef> = columns
        .iter()
        .map(|c| Arc::new(Float64Array::from(c.values.clone())) as ArrayRef)
        .collect();
    let batch = RecordBatch::try_new(schema.clone(), arrays)?;
    let props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::try_new(3)?))
        .build();
    let mut bytes = Vec::new();
    let mut writer = ArrowWriter::try_new(&mut bytes, schema, Some(props))?;
    writer.write(&batch)?;
    writer.close()?;
    Ok(bytes)
}

/// Writes the columns to `path` atomically.
pub fn write(path: &Path, columns: &[Column]) -> Result<()> {
    let bytes =
        to_parquet_bytes(columns).with_context(|| format!("encoding {}", path.display()))?;
    write_atomic(path, &bytes)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::Array;
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

    #[test]
    fn columns_round_trip_with_units() {
        let cols = vec![
            Column {
                name: "time_s".into(),
                unit: "s",
                values: vec![0.0, 1e-6, 2e-6],
            },
            Column {
                name: "blade0_le_radial_m".into(),
                unit: "m",
                values: vec![1e-5, -2e-5, 3e-5],
            },
        ];
        let path = std::env::temp_dir().join(format!("rubscan-ts-{}.parquet", std::process::id()));
        write(&path, &cols).unwrap();
        let reader =
            ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(&path).unwrap()).unwrap();
        std::fs::remove_file(&path).unwrap();
        let field = reader.schema().field(1).clone();
        assert_eq!(field.metadata().get("unit").map(String::as_str), Some("m"));
        let batch = reader.build().unwrap().next().unwrap().unwrap();
        let col = batch
            .column(1)
            .as_any()
            .downcast_ref::<Float64Array>()
            .unwrap();
        assert_eq!(col.values().to_vec(), cols[1].values);
        assert_eq!(col.len(), 3);
    }

    #[test]
    fn ragged_columns_are_rejected() {
        let cols = vec![
            Column {
                name: "a_m".into(),
                unit: "m",
                values: vec![0.0],
            },
            Column {
                name: "b_m".into(),
                unit: "m",
                values: vec![],
            },
        ];
        assert!(
            to_parquet_bytes(&cols)
                .unwrap_err()
                .to_string()
                .contains("`b_m`")
        );
    }
}
