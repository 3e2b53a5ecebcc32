//! The quickstart's results table, the README's main job, is a fixed point: the same spec
//! gives the stored reference table bit for bit (all but the wall time). A change to the
//! numbers must come with a new reference and the reason for it in its commit.

use crate::common;
use common::{quickstart_output, table_without_timing};

use std::path::Path;

#[test]
fn quickstart_table_equals_the_stored_reference() {
    let reference = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/quickstart_reference");
    let got = table_without_timing(quickstart_output());
    let want = table_without_timing(&reference);
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.schema(), w.schema());
        for (i, field) in w.schema().fields().iter().enumerate() {
            assert_eq!(g.column(i), w.column(i), "column {}", field.name());
        }
    }
}
