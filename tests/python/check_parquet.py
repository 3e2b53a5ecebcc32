"""Reads rubscan's Parquet outputs with pyarrow and pandas (run by .ci/run).

usage: check_parquet.py <sweep results.parquet> <simulate timeseries.parquet>
Checks the documented columns (schemas/results.md), their types and units, and that
pandas loads both tables.
"""
import re
import sys
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

results, series = Path(sys.argv[1]), Path(sys.argv[2])

doc = Path(__file__).resolve().parents[2] / "schemas" / "results.md"
documented = set(re.findall(r"^\| `([a-z0-9_]+)` \|", doc.read_text(), flags=re.M))
table = pq.read_table(results)
names = set(table.schema.names)
missing = documented - names
assert not missing, f"documented columns missing from {results}: {sorted(missing)}"
undocumented = names - documented
assert not undocumented, f"columns not documented in {doc}: {sorted(undocumented)}"
assert table.schema.field("speed_rad_s").type == pa.float64()
assert pa.types.is_list(table.schema.field("fourier_peaks").type)
df = pd.read_parquet(results)
assert len(df) == table.num_rows > 0
assert (df["status"] == "ok").all(), df[["status"]]

ts = pq.read_table(series)
for field in ts.schema:
    assert field.metadata and b"unit" in field.metadata, f"{field.name} has no unit"
    assert field.type == pa.float64()
tdf = pd.read_parquet(series)
assert "time_s" in tdf.columns and tdf["time_s"].is_monotonic_increasing
print(f"pyarrow/pandas: {table.num_rows} jobs x {len(names)} columns; {len(tdf)} samples x {len(tdf.columns)} probes: OK")
