//! The quickstart's results table, the README's main job, is a fixed point: the same spec
//! gives the stored reference table bit for bit (all but the wall time). A change to the
//! numbers must come with a new reference and the reason for it in its commit.

mod common;
use common::table_without_timing;

use std::path::Path;
use std::process::Command;

#[test]
fn quickstart_table_equals_the_stored_reference() {
    let out = std::env::temp_dir().join(format!("rubscan-quickstart-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let st = Command::new(env!("CARGO_BIN_EXE_rubscan"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["run", "sweeps/quickstart.json", "--threads", "2", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let reference = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/quickstart_reference");
    let (got, want) = (table_without_timing(&out), table_without_timing(&reference));
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.schema(), w.schema());
        for (i, field) in w.schema().fields().iter().enumerate() {
            assert_eq!(g.column(i), w.column(i), "column {}", field.name());
        }
    }
    std::fs::remove_dir_all(&out).unwrap();
}
