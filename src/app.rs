//! The subcommands of the `rubscan` binary as library calls, so tests, notebooks
//! or services can run them without the CLI. Errors carry the file or field at fault.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};

use crate::dynamics::structure::Structure;
use crate::io::{model_cache, rom_file};
use crate::model::build::{ModelSpec, build_casing, build_impeller};

pub use crate::io::model_cache::{casing_rom, impeller_rom};
use crate::model::rom::CyclicRom;

/// `rubscan model info`: a human-readable summary of a ROM file (sizes, frequencies per
/// nodal diameter at the lowest and highest rotation speed of its modal data).
pub fn model_info(path: &Path) -> Result<String> {
    let rom = rom_file::load(path)?;
    Ok(describe_rom(&rom))
}

/// Summary text of a ROM: sizes, then per nodal diameter the first natural frequencies (Hz).
pub fn describe_rom(rom: &CyclicRom) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "name: {} ({:?})", rom.name, rom.component);
    let _ = writeln!(
        s,
        "sectors: {}, contact nodes per sector: {}, nodal diameters: 0..={}, assembled DOFs: {}",
        rom.n_sectors,
        rom.n_contact(),
        rom.max_nodal_diameter(),
        rom.n_dofs()
    );
    let _ = writeln!(s, "damping: {:?}", rom.damping);
    let speeds = rom
        .modal_data
        .first()
        .map_or(vec![0.0], |m| m.omega.clone());
    for omega in [
        speeds.first().copied().unwrap_or(0.0),
        speeds.last().copied().unwrap_or(0.0),
    ] {
        if let Ok(st) = Structure::new(rom, omega) {
            let _ = writeln!(
                s,
                "Ω = {omega:.1} rad/s: highest ROM frequency {:.4e} rad/s, explicit stability limit h < 2/ω_max = {:.4e} s",
                st.omega_max,
                st.stability_limit()
            );
        }
    }
    for md in &rom.modal_data {
        for (i, omega) in md.omega.iter().enumerate() {
            if i != 0 && i + 1 != md.omega.len() {
                continue;
            }
            let freqs: Vec<String> = md.frequencies[i]
                .iter()
                .take(6)
                .map(|f| format!("{f:.1}"))
                .collect();
            let _ = writeln!(
                s,
                "k = {:>3}  Ω = {:>8.1} rad/s  f [Hz]: {}",
                md.nodal_diameter,
                omega,
                freqs.join(", ")
            );
        }
    }
    s
}

/// Reads a model spec file (JSON, unknown fields rejected); `None` gives the built-in defaults.
pub fn read_model_spec(path: Option<&Path>) -> Result<ModelSpec> {
    let Some(path) = path else {
        return Ok(ModelSpec::default());
    };
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let value: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: malformed JSON", path.display()))?;
    ModelSpec::from_json(value).with_context(|| path.display().to_string())
}

/// `rubscan model build`: builds (or loads from the cache) the impeller and casing ROMs of a
/// spec and writes `impeller.rom` and `casing.rom` to `output`; prints timings and sizes.
pub fn model_build(spec: Option<&Path>, output: &Path) -> Result<()> {
    let spec = read_model_spec(spec)?;
    for (kind, file) in [("impeller", "impeller.rom"), ("casing", "casing.rom")] {
        let start = std::time::Instant::now();
        let (rom, cached) = match kind {
            "impeller" => model_cache::cached_rom(kind, &spec.impeller, build_impeller)?,
            _ => model_cache::cached_rom(kind, &spec.casing, build_casing)?,
        };
        let path = output.join(file);
        rom_file::save(&rom, &path)?;
        eprintln!(
            "{kind}: {} in {:.2} s ({}), {} sectors, {} contact nodes per sector, {} assembled DOFs -> {}",
            if cached { "loaded from cache" } else { "built" },
            start.elapsed().as_secs_f64(),
            model_cache::cache_dir().display(),
            rom.n_sectors,
            rom.n_contact(),
            rom.n_dofs(),
            path.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn info_names_the_missing_file() {
        let err = model_info(Path::new("/nonexistent/x.rom"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("/nonexistent/x.rom"), "{err}");
    }
}
