//! On-disk cache of built ROMs, keyed by a hash of the component spec, the rubscan version,
//! the ROM format version and the reduction's numerics revision: a second `model build` (or
//! sweep) of the same spec loads instantly.

use std::path::PathBuf;

use anyhow::Result;

use crate::io::content_hash::content_hash;
use crate::io::rom_file;
use crate::model::build::{BuildError, CasingSpec, ImpellerSpec, build_casing, build_impeller};
use crate::model::reduction::NUMERICS_REVISION;
use crate::model::rom::{CyclicRom, ROM_FORMAT_VERSION};

/// Directory of the ROM cache: `$RUBSCAN_CACHE_DIR`, else `$XDG_CACHE_HOME/rubscan`, else
/// `$HOME/.cache/rubscan`, else `.rubscan-cache`.
pub fn cache_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("RUBSCAN_CACHE_DIR") {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(d).join("rubscan");
    }
    std::env::var_os("HOME").map_or_else(
        || PathBuf::from(".rubscan-cache"),
        |h| PathBuf::from(h).join(".cache/rubscan"),
    )
}

/// Loads a ROM from the cache, or builds it with `build` and stores it. The key hashes the
/// component spec, the rubscan version, the ROM format version and the reduction's
/// [`NUMERICS_REVISION`], so any change rebuilds; a cached ROM without recovery nodes (written
/// before the built-in named nodes) is rebuilt.
pub fn cached_rom<S: serde::Serialize>(
    kind: &str,
    spec: &S,
    build: impl FnOnce(&S) -> Result<CyclicRom, BuildError>,
) -> Result<(CyclicRom, bool)> {
    cached_rom_in(&cache_dir(), kind, spec, build)
}

/// [`cached_rom`] with the cache in `dir`.
fn cached_rom_in<S: serde::Serialize>(
    dir: &std::path::Path,
    kind: &str,
    spec: &S,
    build: impl FnOnce(&S) -> Result<CyclicRom, BuildError>,
) -> Result<(CyclicRom, bool)> {
    let key = serde_json::json!({ "kind": kind, "spec": spec, "version": env!("CARGO_PKG_VERSION"), "format": ROM_FORMAT_VERSION, "numerics": NUMERICS_REVISION });
    let path = dir.join(format!("{kind}-{}.rom", content_hash(&key)));
    // A missing or unreadable cache entry is rebuilt, and so is one written before the built-in
    // models carried the recovery rows of their named nodes (same key, no recovery nodes).
    if let Ok(rom) = rom_file::load(&path)
        && !rom.recovery.nodes.is_empty()
    {
        return Ok((rom, true));
    }
    let rom = build(spec)?;
    // A cache that cannot be written only costs time later.
    if let Err(e) = rom_file::save(&rom, &path) {
        eprintln!("warning: ROM cache not written: {e}");
    }
    Ok((rom, false))
}

/// Builds (or loads from the cache) the impeller ROM of a spec.
pub fn impeller_rom(spec: &ImpellerSpec) -> Result<CyclicRom> {
    Ok(cached_rom("impeller", spec, build_impeller)?.0)
}

/// Builds (or loads from the cache) the casing ROM of a spec.
pub fn casing_rom(spec: &CasingSpec) -> Result<CyclicRom> {
    Ok(cached_rom("casing", spec, build_casing)?.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{SyntheticSpec, synthetic_rom};
    use crate::model::rom::{ComplexRows, Component, Recovery, RecoveryNode};

    /// A cached ROM is reused; one without recovery nodes (cached before the built-in models
    /// had named nodes) is rebuilt and replaced.
    #[test]
    fn cached_rom_without_recovery_nodes_is_rebuilt() {
        let dir = std::env::temp_dir().join(format!("rubscan-cache-test-{}", std::process::id()));
        let mut rom = synthetic_rom(&SyntheticSpec::small(Component::Casing, 4, 2, 1));
        rom.recovery = Recovery {
            nodes: vec![RecoveryNode {
                id: 3,
                position: [0.1, 0.0, 0.0],
                name: Some("outer_mid_meridian".into()),
            }],
            rows: (rom.harmonics.iter())
                .map(|h| ComplexRows {
                    re: nalgebra::DMatrix::zeros(3, h.mass.size()),
                    im: nalgebra::DMatrix::zeros(3, h.mass.size()),
                })
                .collect(),
        };
        let spec = "spec";
        let built = |r: &CyclicRom| {
            let r = r.clone();
            move |_: &&str| Ok(r)
        };
        let (first, hit) = cached_rom_in(&dir, "casing", &spec, built(&rom)).unwrap();
        assert!(!hit);
        assert_eq!(first, rom);
        let (_, hit) = cached_rom_in(&dir, "casing", &spec, built(&rom)).unwrap();
        assert!(hit, "a cached ROM with recovery nodes is reused");

        // Overwrite the entry with the same ROM without recovery nodes.
        let entry = std::fs::read_dir(&dir)
            .unwrap()
            .next()
            .unwrap()
            .unwrap()
            .path();
        let mut old = rom.clone();
        old.recovery = Recovery::default();
        rom_file::save(&old, &entry).unwrap();
        let (again, hit) = cached_rom_in(&dir, "casing", &spec, built(&rom)).unwrap();
        assert!(!hit, "a cached ROM without recovery nodes is rebuilt");
        assert_eq!(again.recovery, rom.recovery);
        assert_eq!(rom_file::load(&entry).unwrap().recovery, rom.recovery);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
