//! `rubscan stability` end to end: an invalid spec is refused with a non-zero exit status, a
//! valid one prints the table, the onset and the critical wave speed, and writes the diagram.

use std::process::Command;

fn rubscan() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rubscan"))
}

#[test]
fn an_invalid_spec_is_refused() {
    let dir = std::env::temp_dir().join(format!("rubscan-stability-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.json");
    std::fs::write(
        &bad,
        r#"{"name": "x", "grid": {"speed": {"unit": "rad_s", "values": [-1]}}}"#,
    )
    .unwrap();
    let out = rubscan().arg("stability").arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(!String::from_utf8_lossy(&out.stderr).is_empty());
    let out = rubscan()
        .args([
            "stability",
            "sweeps/quickstart.json",
            "--from",
            "5",
            "--to",
            "1",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_valid_spec_prints_the_table_and_writes_the_diagram() {
    let dir = std::env::temp_dir().join(format!("rubscan-stability-ok-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("stability.png");
    let out = rubscan()
        .args([
            "stability",
            "sweeps/quickstart.json",
            "--from",
            "2000",
            "--to",
            "5000",
        ])
        .args(["--count", "31", "-o"])
        .arg(&png)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{out:?}");
    assert!(
        // 4376.8 rad/s with the paper's 10 modes per nodal diameter; 20 lower it (Rayleigh–Ritz).
        text.contains("casing critical wave speed 4376.6 rad/s (nodal diameter 5)"),
        "{text}"
    );
    assert!(text.contains("μ = 0.15: predicted onset"), "{text}");
    let rows = text
        .lines()
        .filter(|l| l.contains("stable") || l.contains("GROWS"));
    assert_eq!(rows.count(), 31, "{text}");
    // The quickstart's own speeds are stable; the top of the range grows.
    let row = |w: &str| {
        text.lines()
            .find(|l| l.trim_start().starts_with(w))
            .unwrap()
            .to_string()
    };
    assert!(
        row("2000.0").contains("stable") && row("5000.0").contains("GROWS"),
        "{text}"
    );
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
    std::fs::remove_dir_all(&dir).ok();
}
