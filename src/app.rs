//! The subcommands of the `rubscan` binary as library calls, so tests, notebooks
//! or services can run them without the CLI. Errors carry the file or field at fault.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;

use crate::io::rom_file;
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

/// `rubscan model build`: builds (or loads from the cache) the impeller and casing ROMs.
pub fn model_build(spec: Option<&Path>, output: &Path) -> Result<()> {
    let _ = (spec, output);
    anyhow::bail!("model build is not available yet")
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
