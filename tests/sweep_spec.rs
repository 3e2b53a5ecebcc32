//! Sweep specs: every example in sweeps/ validates; malformed specs fail with the JSON
//! path and the reason, and nothing is written.

use std::path::{Path, PathBuf};

use rubscan::sweep::spec::{SpecError, load_spec, parse_spec};
use rubscan::sweep::synthetic::SyntheticSimulator;
use rubscan::sweep::{RunOptions, plan, run_sweep};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn every_example_sweep_validates_and_plans() {
    let mut n = 0;
    for entry in std::fs::read_dir(root().join("sweeps")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "json") {
            let spec = load_spec(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let p = plan(&spec).unwrap();
            assert!(!p.jobs.is_empty(), "{}", path.display());
            n += 1;
        }
    }
    assert!(n >= 3, "expected the three example sweeps, found {n}");
}

fn base() -> serde_json::Value {
    serde_json::json!({
        "name": "bad",
        "models": {"impeller": {"builtin": {}}, "casing": {"builtin": {}}},
        "scenario": {"duration_s": 0.01},
        "grid": {"speed": {"unit": "rad_s", "values": [100.0]}, "friction": [0.1]}
    })
}

/// Writes `text` as a spec file in a fresh directory, tries to load it and, if that
/// succeeded, to run it; returns the error text and checks that no output was created.
fn load_and_try_run(tag: &str, text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("rubscan-badspec-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("spec.json");
    std::fs::write(&file, text).unwrap();
    let out = dir.join("out");
    let err = match load_spec(&file) {
        Err(e) => e.to_string(),
        Ok(spec) => {
            let opts = RunOptions::new(&out);
            run_sweep(&spec, &opts, &SyntheticSimulator::default())
                .expect_err("a malformed spec must not run")
                .to_string()
        }
    };
    assert!(!out.exists(), "{tag}: output written for a malformed spec");
    std::fs::remove_dir_all(&dir).unwrap();
    err
}

fn with(f: impl FnOnce(&mut serde_json::Value)) -> String {
    let mut v = base();
    f(&mut v);
    v.to_string()
}

#[test]
fn malformed_specs_name_path_and_reason() {
    let e = load_and_try_run("json", "{\"name\": \"bad\",\n \"models\": }");
    assert!(e.contains("not valid JSON") && e.contains("line 2"), "{e}");

    let e = load_and_try_run(
        "unknown",
        &with(|v| v["grid"]["speeds"] = serde_json::json!([1.0])),
    );
    assert!(e.contains("/grid: ") && e.contains("speeds"), "{e}");

    let e = load_and_try_run(
        "type",
        &with(|v| v["grid"]["friction"] = serde_json::json!("0.1")),
    );
    assert!(
        e.contains("/grid/friction: ") && e.contains("not of type \"array\""),
        "{e}"
    );

    let e = load_and_try_run(
        "negfriction",
        &with(|v| v["grid"]["friction"] = serde_json::json!([0.1, -0.1])),
    );
    assert!(
        e.contains("/grid/friction/1: -0.1 is less than the minimum of 0"),
        "{e}"
    );

    let e = load_and_try_run(
        "empty",
        &with(|v| v["grid"]["friction"] = serde_json::json!([])),
    );
    assert!(e.contains("/grid/friction: "), "{e}");

    let e = load_and_try_run(
        "speed0",
        &with(|v| v["grid"]["speed"]["values"] = serde_json::json!([100.0, -5.0])),
    );
    assert!(e.contains("/grid/speed/values/1: "), "{e}");

    let e = load_and_try_run(
        "zip",
        &with(|v| {
            v["grid"]["friction"] = serde_json::json!([0.1, 0.2]);
            v["grid"]["zip"] = serde_json::json!(["speed", "friction"]);
        }),
    );
    assert!(
        e.contains("/grid/zip/1: zipped axes need equal lengths"),
        "{e}"
    );
}

#[test]
fn spec_built_in_code_is_validated_before_writing() {
    // Bypasses the schema: run_sweep must still reject it without creating the output dir.
    let mut spec = parse_spec(&base().to_string()).unwrap();
    spec.grid.friction = vec![-0.5];
    let out = std::env::temp_dir().join(format!("rubscan-codespec-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let err = run_sweep(
        &spec,
        &RunOptions::new(&out),
        &SyntheticSimulator::default(),
    )
    .unwrap_err();
    let spec_err = err.downcast_ref::<SpecError>().expect("a SpecError");
    assert_eq!(spec_err.issues()[0].path, "/grid/friction/0");
    assert!(!Path::new(&out).exists());
}

/// A refinement request that cannot work is refused from the file, at its JSON pointer,
/// before anything is written; a sound one plans the grid's jobs with their usual ids.
#[test]
fn refinement_requests_are_checked_up_front_and_keep_the_grids_ids() {
    let refine = |v: &mut serde_json::Value, r: serde_json::Value| {
        v["grid"]["speed"] = serde_json::json!({"unit": "rad_s",
            "range": {"start": 3500, "stop": 5300, "count": 9}, "refine": r});
    };
    for (tag, r, want) in [
        (
            "tol0",
            serde_json::json!({"tolerance_rad_s": 0.0, "max_jobs": 4}),
            "/grid/speed/refine/tolerance_rad_s: ",
        ),
        (
            "tolfine",
            serde_json::json!({"tolerance_rad_s": 1e-9, "max_jobs": 4}),
            "/grid/speed/refine/tolerance_rad_s: 1e-9 rad/s is below the float resolution",
        ),
        (
            "budget0",
            serde_json::json!({"tolerance_rad_s": 20.0, "max_jobs": 0}),
            "/grid/speed/refine/max_jobs: ",
        ),
        (
            "column",
            serde_json::json!({"tolerance_rad_s": 20.0, "max_jobs": 4, "peak_of": "max_blade_te_radial"}),
            "did you mean `max_blade_te_radial_m`?",
        ),
        (
            "nothing",
            serde_json::json!({"tolerance_rad_s": 20.0, "max_jobs": 4, "boundary": false}),
            "/grid/speed/refine: asks for nothing",
        ),
    ] {
        let e = load_and_try_run(tag, &with(|v| refine(v, r)));
        assert!(e.contains(want), "{tag}: {e}");
    }
    let e = load_and_try_run(
        "onespeed",
        &with(|v| {
            v["grid"]["speed"]["refine"] =
                serde_json::json!({"tolerance_rad_s": 1.0, "max_jobs": 4})
        }),
    );
    assert!(
        e.contains("/grid/speed/refine: refinement needs at least 2 speeds"),
        "{e}"
    );
    // A sound request: the grid's jobs and ids are those of the same grid without it.
    let mut v = base();
    refine(
        &mut v,
        serde_json::json!({"tolerance_rad_s": 20.0, "max_jobs": 12, "peak_of": "max_blade_te_radial_m"}),
    );
    let with_refine = plan(&parse_spec(&v.to_string()).unwrap()).unwrap();
    v["grid"]["speed"].as_object_mut().unwrap().remove("refine");
    let without = plan(&parse_spec(&v.to_string()).unwrap()).unwrap();
    let ids = |p: &rubscan::sweep::Plan| p.jobs.iter().map(|j| j.id.clone()).collect::<Vec<_>>();
    assert_eq!(with_refine.jobs.len(), 9);
    assert_eq!(ids(&with_refine), ids(&without));
}
