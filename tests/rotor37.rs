//! NASA Rotor 37 blade (CalculiX model in `../shared/rotor37`, see its README): run CalculiX,
//! import its stored matrices, reduce them (Craig–Bampton on the 16 blade-tip nodes, 50
//! fixed-interface modes) and compare the reduced model's eigenfrequencies with the ones
//! CalculiX's own Lanczos solver prints in `blade.dat` (step 1 of the deck): an independent
//! reference.
//!
//! Needs `ccx` (Debian `calculix-ccx`) on the PATH; without it the test fails when the
//! environment variable `CI` is set and prints a skip note otherwise. The model folder is
//! looked up in `$RUBSCAN_ROTOR37_DIR`, then `../shared/rotor37` and `../../shared/rotor37`
//! relative to the package (the second one serves git worktrees under `wt/<name>`).

use rubscan::io::calculix::{
    CalculixImportSpec, ContactSelection, Units, import_calculix, read_calculix_mesh,
};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Blade-tip contact nodes, leading edge → trailing edge (README of the model).
const TIP: [usize; 16] = [
    188, 190, 192, 194, 196, 198, 200, 203, 253, 255, 257, 259, 261, 263, 265, 267,
];

/// Fixed-interface modes kept in the reduction.
const N_MODES: usize = 50;

fn model_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RUBSCAN_ROTOR37_DIR") {
        return Some(PathBuf::from(d));
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    ["../shared/rotor37", "../../shared/rotor37"]
        .iter()
        .map(|r| root.join(r))
        .find(|d| d.join("blade.inp").is_file())
}

fn find_ccx() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("ccx"))
        .find(|p| p.is_file())
}

/// Skips (prints why) unless `CI` is set, in which case a missing prerequisite fails.
fn skip_or_fail(why: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("{why} (required because CI is set)");
    }
    eprintln!("SKIPPED rotor37: {why}");
}

/// Removes the scratch folder (≈ 250 MB of matrices) even if the test fails.
struct Scratch(PathBuf);
impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Frequencies (Hz, time unit s) of the first `*FREQUENCY` step printed in a CalculiX `.dat`.
fn dat_frequencies(dat: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(dat).expect("blade.dat readable");
    let start = text
        .find("E I G E N V A L U E   O U T P U T")
        .expect("eigenvalue output in blade.dat");
    let mut out = Vec::new();
    let mut started = false;
    for line in text[start..].lines().skip(1) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let numeric = f.len() == 5 && f[0].parse::<usize>().is_ok();
        if numeric {
            started = true;
            out.push(f[3].parse::<f64>().expect("frequency column"));
        } else if started {
            break;
        }
    }
    out
}

fn relative_errors(rom: &[f64], reference: &[f64]) -> Vec<f64> {
    rom.iter()
        .zip(reference)
        .map(|(a, b)| (a - b) / b)
        .collect()
}

#[test]
fn rotor37_reduced_frequencies_match_calculix() {
    let Some(src) = model_dir() else {
        return skip_or_fail("model folder shared/rotor37 not found");
    };
    let Some(ccx) = find_ccx() else {
        return skip_or_fail("ccx (Debian calculix-ccx) is not on the PATH");
    };
    let work = std::env::temp_dir().join(format!("rubscan-rotor37-{}", std::process::id()));
    std::fs::create_dir_all(&work).unwrap();
    let _guard = Scratch(work.clone());
    for f in ["blade.inp", "blade.msh"] {
        std::fs::copy(src.join(f), work.join(f)).unwrap();
    }

    let t = Instant::now();
    let log = std::fs::File::create(work.join("ccx.log")).unwrap();
    let status = Command::new(&ccx)
        .arg("blade")
        .current_dir(&work)
        .env("OMP_NUM_THREADS", "1")
        .stdout(log.try_clone().unwrap())
        .stderr(log)
        .status()
        .expect("ccx runs");
    let ccx_time = t.elapsed();
    assert!(
        status.success(),
        "ccx failed ({status}); see {}",
        work.join("ccx.log").display()
    );
    let produced = std::fs::read(work.join("blade.dof")).expect("ccx wrote blade.dof");
    let shipped = std::fs::read(src.join("blade.dof")).unwrap();
    assert!(
        produced == shipped,
        "the DOF map written by ccx differs from the shipped blade.dof"
    );
    let reference = dat_frequencies(&work.join("blade.dat"));
    assert!(reference.len() >= 10, "blade.dat lists {reference:?}");

    let spec = CalculixImportSpec::from_job(
        &work,
        "blade",
        ContactSelection::Nodes(TIP.to_vec()),
        N_MODES,
        Units::MmTonneSecond,
    );
    let t = Instant::now();
    let rom = import_calculix(&spec).expect("import and reduction");
    let import_time = t.elapsed();

    let f = &rom.modal_data[0].frequencies[0];
    let err = relative_errors(&f[..10], &reference[..10]);
    eprintln!("ccx {ccx_time:.1?}, import + reduction {import_time:.1?}");
    eprintln!("mode  CalculiX (Hz)  ROM (Hz)  rel. error");
    for p in 0..10 {
        eprintln!(
            "{:4}  {:13.4}  {:9.4}  {:+.2e}",
            p + 1,
            reference[p],
            f[p],
            err[p]
        );
    }
    for (p, e) in err.iter().enumerate() {
        assert!(
            e.abs() < 1e-3,
            "mode {}: ROM {} Hz vs CalculiX {} Hz",
            p + 1,
            f[p],
            reference[p]
        );
    }

    // The ROM: one sector, 16 contact nodes with 48 boundary DOFs + 50 modes, SI positions.
    assert_eq!(rom.n_sectors, 1);
    assert_eq!(rom.n_contact(), 16);
    assert_eq!(rom.harmonics[0].mass.size(), 48 + N_MODES);
    let mesh = read_calculix_mesh(&work.join("blade.inp")).unwrap();
    for (c, id) in rom.contact_nodes.iter().zip(TIP) {
        for (p, x) in c.position.iter().zip(mesh.nodes[&id]) {
            assert!((p - 1e-3 * x).abs() <= 1e-15 * x.abs().max(1.0));
        }
    }
}

/// Import + reduction only, on an existing CalculiX run (`$RUBSCAN_ROTOR37_RUN`, default
/// `/tmp/r37`), to time it: `/usr/bin/time -v <test binary> --ignored --exact rotor37_import_timing`.
/// With `RUBSCAN_SEQUENTIAL` set, faer runs single-threaded.
#[test]
#[ignore]
fn rotor37_import_timing() {
    if std::env::var_os("RUBSCAN_SEQUENTIAL").is_some() {
        faer::set_global_parallelism(faer::Par::Seq);
    }
    let run = std::env::var_os("RUBSCAN_ROTOR37_RUN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/tmp/r37"));
    let spec = CalculixImportSpec::from_job(
        &run,
        "blade",
        ContactSelection::Nodes(TIP.to_vec()),
        N_MODES,
        Units::MmTonneSecond,
    );
    let t = Instant::now();
    let rom = import_calculix(&spec).expect("import and reduction");
    eprintln!("import + reduction: {:.2?}", t.elapsed());
    let reference = dat_frequencies(&run.join("blade.dat"));
    let f = &rom.modal_data[0].frequencies[0];
    for (p, e) in relative_errors(&f[..10], &reference[..10])
        .iter()
        .enumerate()
    {
        eprintln!(
            "mode {:2}: {:10.4} Hz vs {:10.4} Hz  {e:+.2e}",
            p + 1,
            f[p],
            reference[p]
        );
    }
}
