//! ROM files: a safetensors container of little-endian `f64` tensors plus JSON
//! metadata, readable from Python without rubscan
//! (`safetensors.numpy.load_file(path)` and `safe_open(path, "np").metadata()`).
//! The layout is specified in `schemas/rom-format.md`.
//!
//! Writing is atomic (temporary file + rename); loading checks every tensor's
//! presence and shape, then [`CyclicRom::validate`] (finiteness, Hermitian
//! symmetry, positive-definite mass).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use safetensors::tensor::{Dtype, SafeTensors, TensorView};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::model::rom::{
    BladeModes, ComplexRows, Component, ContactNode, CyclicRom, Damping, HarmonicBlock,
    HermitianMatrix, ModalData, ROM_FORMAT_OLDEST_READ, ROM_FORMAT_VERSION, Recovery, RecoveryNode,
    RomError,
};

/// Value of the `format` metadata key.
pub const FORMAT_NAME: &str = "rubscan-rom";

/// Everything that can go wrong reading or writing a ROM file; each variant names the file.
#[derive(Debug, Error)]
pub enum RomFileError {
    /// The file cannot be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file cannot be written.
    #[error("{path}: cannot write: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not a valid safetensors container.
    #[error("{path}: not a valid safetensors container (truncated or corrupted?): {source}")]
    Container {
        /// The file.
        path: PathBuf,
        /// The safetensors parsing error.
        source: safetensors::SafeTensorError,
    },
    /// The metadata or tensors do not follow the ROM file layout.
    #[error("{path}: {reason}")]
    Layout {
        /// The file.
        path: PathBuf,
        /// What is wrong with the layout.
        reason: String,
    },
    /// The file holds a well-formed but invalid ROM.
    #[error("{path}: invalid model: {source}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Why the ROM fails validation.
        source: RomError,
    },
}

/// JSON metadata stored under the `rom` key of the safetensors header.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RomMeta {
    name: String,
    component: Component,
    n_sectors: usize,
    units: String,
    damping: Damping,
    contact_rows: Vec<usize>,
    modes_per_diameter: Vec<usize>,
    modal_omega_count: Vec<usize>,
    provenance: serde_json::Value,
    /// FE node id of each contact node (imported models; format 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    contact_node_ids: Option<Vec<usize>>,
    /// Ids of the recovery nodes (format 2; empty: no recovery matrix).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    recovery_node_ids: Vec<usize>,
    /// Name of each recovery node (`null` for an unnamed one; absent when none is named: the
    /// documented nodes of a built-in model have names).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    recovery_node_names: Vec<Option<String>>,
    /// Number of blade modes for mistuning (absent: none).
    #[serde(default, skip_serializing_if = "is_zero")]
    blade_mode_count: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

const MATRIX_NAMES: [&str; 4] = ["mass", "k0", "k1", "k2"];

/// Writes `rom` to `path` atomically (temporary file in the same directory, then rename).
pub fn save(rom: &CyclicRom, path: &Path) -> Result<(), RomFileError> {
    let bytes = to_bytes(rom).map_err(|e| RomFileError::Layout {
        path: path.into(),
        reason: e.to_string(),
    })?;
    crate::io::atomic::write_atomic(path, &bytes).map_err(|source| RomFileError::Write {
        path: path.into(),
        source,
    })
}

/// Reads and validates a ROM file.
pub fn load(path: &Path) -> Result<CyclicRom, RomFileError> {
    let bytes = std::fs::read(path).map_err(|source| RomFileError::Read {
        path: path.into(),
        source,
    })?;
    from_bytes(&bytes, path)
}

/// Serialises a ROM to the safetensors byte layout.
pub fn to_bytes(rom: &CyclicRom) -> Result<Vec<u8>, safetensors::SafeTensorError> {
    let mut tensors: Vec<(String, Vec<usize>, Vec<u8>)> = Vec::new();
    let mut push = |name: String, shape: Vec<usize>, values: &mut dyn Iterator<Item = f64>| {
        let bytes: Vec<u8> = values.flat_map(f64::to_le_bytes).collect();
        tensors.push((name, shape, bytes));
    };
    let nodes = &rom.contact_nodes;
    push(
        "contact_nodes.position".into(),
        vec![nodes.len(), 3],
        &mut nodes.iter().flat_map(|n| n.position),
    );
    for h in &rom.harmonics {
        let mats = [&h.mass, &h.stiffness[0], &h.stiffness[1], &h.stiffness[2]];
        for (name, m) in MATRIX_NAMES.iter().zip(mats) {
            for (part, d) in [("re", &m.re), ("im", &m.im)] {
                push(
                    format!("harmonic.{}.{name}.{part}", h.nodal_diameter),
                    vec![d.nrows(), d.ncols()],
                    &mut row_major(d),
                );
            }
        }
    }
    let rec = &rom.recovery;
    if !rec.nodes.is_empty() {
        push(
            "recovery.position".into(),
            vec![rec.nodes.len(), 3],
            &mut rec.nodes.iter().flat_map(|n| n.position),
        );
        for (k, b) in rec.rows.iter().enumerate() {
            for (part, d) in [("re", &b.re), ("im", &b.im)] {
                push(
                    format!("recovery.{k}.{part}"),
                    vec![d.nrows(), d.ncols()],
                    &mut row_major(d),
                );
            }
        }
    }
    let blade = &rom.blade_modes;
    if !blade.omega2.is_empty() {
        push(
            "blade_modes.omega2".into(),
            vec![blade.omega2.len()],
            &mut blade.omega2.iter().copied(),
        );
        for (k, b) in blade.rows.iter().enumerate() {
            for (part, d) in [("re", &b.re), ("im", &b.im)] {
                push(
                    format!("blade_modes.{k}.{part}"),
                    vec![d.nrows(), d.ncols()],
                    &mut row_major(d),
                );
            }
        }
    }
    for (k, md) in rom.modal_data.iter().enumerate() {
        let n_omega = md.omega.len();
        let n_p = md.frequencies.first().map_or(0, Vec::len);
        // The reader expects 3 n_c values a shape, also when there is no shape to measure.
        let n_s = 3 * nodes.len();
        push(
            format!("modal.{k}.omega"),
            vec![n_omega],
            &mut md.omega.iter().copied(),
        );
        push(
            format!("modal.{k}.frequencies"),
            vec![n_omega, n_p],
            &mut md.frequencies.iter().flatten().copied(),
        );
        for (part, s) in [("re", &md.shapes_re), ("im", &md.shapes_im)] {
            push(
                format!("modal.{k}.shapes.{part}"),
                vec![n_omega, n_p, n_s],
                &mut s.iter().flatten().flatten().copied(),
            );
        }
    }
    let meta = RomMeta {
        name: rom.name.clone(),
        component: rom.component,
        n_sectors: rom.n_sectors,
        units: "SI (m, kg, s, N); frequencies in Hz; rotation speeds in rad/s".into(),
        damping: rom.damping,
        contact_rows: nodes.iter().map(|n| n.row).collect(),
        modes_per_diameter: rom.harmonics.iter().map(|h| h.n_modes).collect(),
        modal_omega_count: rom.modal_data.iter().map(|m| m.omega.len()).collect(),
        provenance: rom.provenance.clone(),
        contact_node_ids: nodes.iter().map(|n| n.id).collect(),
        recovery_node_ids: rec.nodes.iter().map(|n| n.id).collect(),
        recovery_node_names: if rec.nodes.iter().any(|n| n.name.is_some()) {
            rec.nodes.iter().map(|n| n.name.clone()).collect()
        } else {
            vec![]
        },
        blade_mode_count: blade.omega2.len(),
    };
    let info = HashMap::from([
        ("format".to_string(), FORMAT_NAME.to_string()),
        ("format_version".to_string(), ROM_FORMAT_VERSION.to_string()),
        (
            "rom".to_string(),
            serde_json::to_string(&meta).expect("metadata serialises"),
        ),
    ]);
    let views = tensors
        .iter()
        .map(|(name, shape, bytes)| {
            Ok((
                name.clone(),
                TensorView::new(Dtype::F64, shape.clone(), bytes)?,
            ))
        })
        .collect::<Result<Vec<_>, safetensors::SafeTensorError>>()?;
    safetensors::serialize(views, Some(info))
}

fn row_major(m: &DMatrix<f64>) -> impl Iterator<Item = f64> + '_ {
    (0..m.nrows()).flat_map(move |i| (0..m.ncols()).map(move |j| m[(i, j)]))
}

/// The `rom` metadata of a ROM file's header, after the `format` and `format_version` checks;
/// contact rows must be below the number of contact nodes.
fn read_meta(bytes: &[u8], path: &Path) -> Result<RomMeta, RomFileError> {
    let layout = |reason: String| RomFileError::Layout {
        path: path.into(),
        reason,
    };
    let (_, header) =
        SafeTensors::read_metadata(bytes).map_err(|source| RomFileError::Container {
            path: path.into(),
            source,
        })?;
    let info = header.metadata().clone().unwrap_or_default();
    if info.get("format").map(String::as_str) != Some(FORMAT_NAME) {
        return Err(layout(format!(
            "metadata key `format` must be `{FORMAT_NAME}` (not a rubscan ROM file?)"
        )));
    }
    let version = info.get("format_version").cloned().unwrap_or_default();
    let readable = version
        .parse::<u32>()
        .is_ok_and(|v| (ROM_FORMAT_OLDEST_READ..=ROM_FORMAT_VERSION).contains(&v));
    if !readable {
        return Err(layout(format!(
            "format_version `{version}` is not supported (this rubscan reads versions \
             {ROM_FORMAT_OLDEST_READ} to {ROM_FORMAT_VERSION}): rebuild the file with \
             `rubscan model build` (built-in model) or `rubscan model import` (imported model)"
        )));
    }
    let meta_json = info
        .get("rom")
        .ok_or_else(|| layout("metadata key `rom` is missing".into()))?;
    let meta: RomMeta =
        serde_json::from_str(meta_json).map_err(|e| layout(format!("metadata `rom`: {e}")))?;

    let n_c = meta.contact_rows.len();
    if let Some((i, r)) = meta
        .contact_rows
        .iter()
        .enumerate()
        .find(|(_, r)| **r >= n_c)
    {
        return Err(layout(format!(
            "metadata contact_rows[{i}] = {r}: a row index must be below the number of contact nodes ({n_c})"
        )));
    }
    if let Some(ids) = &meta.contact_node_ids
        && ids.len() != n_c
    {
        return Err(layout(format!(
            "metadata contact_node_ids has {} entries, expected one per contact node ({n_c})",
            ids.len()
        )));
    }
    Ok(meta)
}

/// Parses and validates the safetensors bytes of a ROM; `path` only labels errors.
pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<CyclicRom, RomFileError> {
    let layout = |reason: String| RomFileError::Layout {
        path: path.into(),
        reason,
    };
    let st = SafeTensors::deserialize(bytes).map_err(|source| RomFileError::Container {
        path: path.into(),
        source,
    })?;
    let meta = read_meta(bytes, path)?;
    let tensor = |name: &str, shape: &[usize]| -> Result<Vec<f64>, RomFileError> {
        let t = st
            .tensor(name)
            .map_err(|_| layout(format!("tensor `{name}` is missing")))?;
        if t.dtype() != Dtype::F64 {
            return Err(layout(format!(
                "tensor `{name}` has dtype {:?}, expected F64",
                t.dtype()
            )));
        }
        if t.shape() != shape {
            return Err(layout(format!(
                "tensor `{name}` has shape {:?}, expected {shape:?}",
                t.shape()
            )));
        }
        Ok(t.data()
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect())
    };

    let n_c = meta.contact_rows.len();
    let positions = tensor("contact_nodes.position", &[n_c, 3])?;
    let contact_nodes = meta
        .contact_rows
        .iter()
        .zip(positions.chunks_exact(3))
        .enumerate()
        .map(|(j, (&row, p))| ContactNode {
            position: [p[0], p[1], p[2]],
            row,
            id: meta.contact_node_ids.as_ref().map(|ids| ids[j]),
        })
        .collect();
    let kmax = meta.n_sectors / 2;
    if meta.modes_per_diameter.len() != kmax + 1 {
        return Err(layout(format!(
            "metadata lists {} modes_per_diameter entries, expected {} for {} sectors",
            meta.modes_per_diameter.len(),
            kmax + 1,
            meta.n_sectors
        )));
    }
    let mut harmonics = Vec::with_capacity(kmax + 1);
    for (k, &n_modes) in meta.modes_per_diameter.iter().enumerate() {
        let n = n_modes.checked_add(3 * n_c).ok_or_else(|| {
            layout(format!(
                "metadata modes_per_diameter[{k}] = {n_modes} is too large"
            ))
        })?;
        let read = |name: &str| -> Result<HermitianMatrix, RomFileError> {
            let part = |p: &str| {
                tensor(&format!("harmonic.{k}.{name}.{p}"), &[n, n])
                    .map(|v| DMatrix::from_row_slice(n, n, &v))
            };
            Ok(HermitianMatrix {
                re: part("re")?,
                im: part("im")?,
            })
        };
        harmonics.push(HarmonicBlock {
            nodal_diameter: k,
            n_modes,
            mass: read("mass")?,
            stiffness: [read("k0")?, read("k1")?, read("k2")?],
        });
    }
    let recovery = read_recovery(&meta, &harmonics, &tensor, path)?;
    let blade_modes = read_blade_modes(meta.blade_mode_count, &harmonics, &tensor)?;
    let mut modal_data = Vec::with_capacity(meta.modal_omega_count.len());
    for (k, &n_omega) in meta.modal_omega_count.iter().enumerate() {
        let omega = tensor(&format!("modal.{k}.omega"), &[n_omega])?;
        let name = format!("modal.{k}.frequencies");
        let n_p = st
            .tensor(&name)
            .map(|t| t.shape().get(1).copied().unwrap_or(0))
            .unwrap_or(0);
        let freqs = tensor(&name, &[n_omega, n_p])?;
        let n_s = 3 * n_c;
        // The shape checks bound n_omega (the omega tensor holds n_omega values), so the
        // loops below are as long as the file; any of n_p, n_s may be 0.
        let shapes = |p: &str| -> Result<Vec<Vec<Vec<f64>>>, RomFileError> {
            let flat = tensor(&format!("modal.{k}.shapes.{p}"), &[n_omega, n_p, n_s])?;
            Ok((0..n_omega)
                .map(|o| {
                    (0..n_p)
                        .map(|q| flat[(o * n_p + q) * n_s..][..n_s].to_vec())
                        .collect()
                })
                .collect())
        };
        modal_data.push(ModalData {
            nodal_diameter: k,
            omega,
            frequencies: (0..n_omega)
                .map(|o| freqs[o * n_p..][..n_p].to_vec())
                .collect(),
            shapes_re: shapes("re")?,
            shapes_im: shapes("im")?,
        });
    }
    let rom = CyclicRom {
        name: meta.name,
        component: meta.component,
        n_sectors: meta.n_sectors,
        contact_nodes,
        harmonics,
        modal_data,
        damping: meta.damping,
        provenance: meta.provenance,
        recovery,
        blade_modes: Box::new(blade_modes),
    };
    rom.validate().map_err(|source| RomFileError::Invalid {
        path: path.into(),
        source,
    })?;
    Ok(rom)
}

/// Reads the named `F64` tensor of the expected shape (row-major values).
type TensorReader<'a> = dyn Fn(&str, &[usize]) -> Result<Vec<f64>, RomFileError> + 'a;

/// The recovery matrix of a file (format 2): `recovery.position` and one `recovery.{k}.{re,im}`
/// block of `3 n_r × (3 n_c + n_m(k))` per harmonic, for the `recovery_node_ids` of the metadata.
fn read_recovery(
    meta: &RomMeta,
    harmonics: &[HarmonicBlock],
    tensor: &TensorReader<'_>,
    path: &Path,
) -> Result<Recovery, RomFileError> {
    let ids = &meta.recovery_node_ids;
    if ids.is_empty() {
        return Ok(Recovery::default());
    }
    let names = &meta.recovery_node_names;
    if !names.is_empty() && names.len() != ids.len() {
        return Err(RomFileError::Layout {
            path: path.into(),
            reason: format!(
                "recovery_node_names has {} entries, recovery_node_ids {}",
                names.len(),
                ids.len()
            ),
        });
    }
    let positions = tensor("recovery.position", &[ids.len(), 3])?;
    let nodes = ids
        .iter()
        .zip(positions.chunks_exact(3))
        .enumerate()
        .map(|(i, (&id, p))| RecoveryNode {
            id,
            position: [p[0], p[1], p[2]],
            name: names.get(i).cloned().flatten(),
        })
        .collect();
    let rows = read_rows("recovery", 3 * ids.len(), harmonics, tensor)?;
    Ok(Recovery { nodes, rows })
}

/// One `{prefix}.{k}.{re,im}` block of `n_rows × (3 n_c + n_m(k))` per harmonic.
fn read_rows(
    prefix: &str,
    n_rows: usize,
    harmonics: &[HarmonicBlock],
    tensor: &TensorReader<'_>,
) -> Result<Vec<ComplexRows>, RomFileError> {
    harmonics
        .iter()
        .enumerate()
        .map(|(k, h)| {
            let n = h.mass.size();
            let part = |p: &str| {
                tensor(&format!("{prefix}.{k}.{p}"), &[n_rows, n])
                    .map(|v| DMatrix::from_row_slice(n_rows, n, &v))
            };
            Ok(ComplexRows {
                re: part("re")?,
                im: part("im")?,
            })
        })
        .collect()
}

/// The blade modes of a file: `blade_modes.omega2` and one `blade_modes.{k}.{re,im}` block of
/// `n_bm × (3 n_c + n_m(k))` per harmonic (none when the metadata counts none).
fn read_blade_modes(
    count: usize,
    harmonics: &[HarmonicBlock],
    tensor: &TensorReader<'_>,
) -> Result<BladeModes, RomFileError> {
    if count == 0 {
        return Ok(BladeModes::default());
    }
    let omega2 = tensor("blade_modes.omega2", &[count])?;
    let rows = read_rows("blade_modes", count, harmonics, tensor)?;
    Ok(BladeModes { omega2, rows })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error of reading `rom`'s bytes back, as a file named `name`.
    fn error_reading(rom: &CyclicRom, name: &str) -> String {
        from_bytes(&to_bytes(rom).unwrap(), Path::new(name))
            .unwrap_err()
            .to_string()
    }

    /// A 4-sector ROM with a complex harmonic (k = 1) and modal data.
    fn sample_rom() -> CyclicRom {
        let n_c = 2;
        let harmonics = (0..=2)
            .map(|k| {
                let n = 3 * n_c + 1;
                let mut re = DMatrix::identity(n, n) * (2.0 + k as f64);
                re[(0, 1)] = 0.3;
                re[(1, 0)] = 0.3;
                let mut im = DMatrix::zeros(n, n);
                if k == 1 {
                    im[(0, 2)] = 0.1;
                    im[(2, 0)] = -0.1;
                }
                let h = HermitianMatrix { re, im };
                HarmonicBlock {
                    nodal_diameter: k,
                    n_modes: 1,
                    mass: h.clone(),
                    stiffness: [
                        h.clone(),
                        HermitianMatrix::real(DMatrix::identity(n, n) * 0.5),
                        HermitianMatrix::real(DMatrix::zeros(n, n)),
                    ],
                }
            })
            .collect();
        CyclicRom {
            name: "sample".into(),
            component: Component::Impeller,
            n_sectors: 4,
            contact_nodes: vec![
                ContactNode {
                    position: [0.1, 0.0, 0.0],
                    row: 0,
                    id: None,
                },
                ContactNode {
                    position: [0.11, 0.0, 0.02],
                    row: 1,
                    id: None,
                },
            ],
            harmonics,
            modal_data: vec![ModalData {
                nodal_diameter: 0,
                omega: vec![0.0, 100.0],
                frequencies: vec![vec![10.0, 20.0], vec![11.0, 21.0]],
                shapes_re: vec![
                    vec![vec![1.0; 6], vec![2.0; 6]],
                    vec![vec![3.0; 6], vec![4.0; 6]],
                ],
                shapes_im: vec![vec![vec![0.0; 6]; 2]; 2],
            }],
            damping: Damping::Rayleigh {
                alpha: 1.0,
                beta: 1e-6,
            },
            provenance: serde_json::json!({"test": true}),
            recovery: Default::default(),
            blade_modes: Default::default(),
        }
    }

    #[test]
    fn round_trip_preserves_everything() {
        let rom = sample_rom();
        let bytes = to_bytes(&rom).unwrap();
        let back = from_bytes(&bytes, Path::new("mem.rom")).unwrap();
        assert_eq!(back, rom);
    }

    /// `sample_rom` with FE ids on its contact nodes and a recovery matrix of two nodes.
    fn sample_rom_with_recovery() -> CyclicRom {
        let mut rom = sample_rom();
        for (j, c) in rom.contact_nodes.iter_mut().enumerate() {
            c.id = Some(100 + j);
        }
        let nr = 6;
        rom.recovery = Recovery {
            nodes: vec![
                RecoveryNode {
                    id: 7,
                    position: [0.05, 0.01, 0.0],
                    name: None,
                },
                RecoveryNode {
                    id: 1353,
                    position: [0.06, -0.01, 0.02],
                    name: Some("leading_edge_mid_span".into()),
                },
            ],
            rows: rom
                .harmonics
                .iter()
                .map(|h| {
                    let n = h.mass.size();
                    let re = DMatrix::from_fn(nr, n, |i, j| (i * n + j) as f64 * 0.25 - 1.0);
                    let im = if rom_is_real(h.nodal_diameter) {
                        DMatrix::zeros(nr, n)
                    } else {
                        DMatrix::from_fn(nr, n, |i, j| (i as f64 - j as f64) * 0.5)
                    };
                    ComplexRows { re, im }
                })
                .collect(),
        };
        rom
    }

    /// k = 0 and k = N/2 = 2 are the real harmonics of the 4-sector sample.
    fn rom_is_real(k: usize) -> bool {
        k == 0 || k == 2
    }

    /// `bytes` (a ROM file) with its header's `format_version` set to `version`.
    fn with_version(bytes: &[u8], version: &str) -> Vec<u8> {
        let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
        let mut header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
        header["__metadata__"]["format_version"] = serde_json::json!(version);
        let text = header.to_string();
        let mut out = (text.len() as u64).to_le_bytes().to_vec();
        out.extend_from_slice(text.as_bytes());
        out.extend_from_slice(&bytes[8 + n..]);
        out
    }

    #[test]
    fn recovery_matrix_and_contact_ids_round_trip() {
        let rom = sample_rom_with_recovery();
        assert_eq!(rom.validate(), Ok(()));
        let bytes = to_bytes(&rom).unwrap();
        let back = from_bytes(&bytes, Path::new("rec.rom")).unwrap();
        assert_eq!(back, rom);
        assert_eq!(back.recovery.position_of(1353), Some(1));
        // A recovery block of the wrong width is named.
        let mut bad = rom.clone();
        bad.recovery.rows[1].re = DMatrix::zeros(6, 3);
        let err = error_reading(&bad, "w.rom");
        assert!(
            err.starts_with("w.rom:") && err.contains("recovery.1.re"),
            "{err}"
        );
    }

    /// Blade shapes for mistuning survive the file; a block of the wrong width is named, and
    /// a file without them reads as a model without blade shapes.
    #[test]
    fn blade_modes_round_trip() {
        let mut rom = sample_rom_with_recovery();
        *rom.blade_modes = BladeModes {
            omega2: vec![4e8, 9e8],
            rows: rom
                .harmonics
                .iter()
                .enumerate()
                .map(|(k, h)| {
                    let n = h.mass.size();
                    let real = crate::model::cyclic::is_real_harmonic(k, rom.n_sectors);
                    ComplexRows {
                        re: DMatrix::from_fn(2, n, |i, j| (i + 2 * j + k) as f64),
                        im: DMatrix::from_fn(2, n, |i, j| if real { 0.0 } else { (i * j) as f64 }),
                    }
                })
                .collect(),
        };
        assert_eq!(rom.validate(), Ok(()));
        let back = from_bytes(&to_bytes(&rom).unwrap(), Path::new("b.rom")).unwrap();
        assert_eq!(back, rom);
        let mut bad = rom.clone();
        bad.blade_modes.rows[1].im = DMatrix::zeros(2, 3);
        let err = error_reading(&bad, "w.rom");
        assert!(err.contains("blade_modes.1.im"), "{err}");
        let plain = sample_rom_with_recovery();
        let back = from_bytes(&to_bytes(&plain).unwrap(), Path::new("p.rom")).unwrap();
        assert!(back.blade_modes.omega2.is_empty());
    }

    #[test]
    fn version_1_file_is_read_without_recovery_and_unknown_versions_say_how_to_rebuild() {
        // A version-1 file: the layout of today's file without the recovery tensors and ids.
        let v1 = with_version(&to_bytes(&sample_rom()).unwrap(), "1");
        let back = from_bytes(&v1, Path::new("old.rom")).unwrap();
        assert_eq!(back, sample_rom());
        assert!(back.recovery.nodes.is_empty());
        assert!(back.contact_nodes.iter().all(|c| c.id.is_none()));
        for version in ["0", "3", "x"] {
            let bytes = with_version(&to_bytes(&sample_rom()).unwrap(), version);
            let err = from_bytes(&bytes, Path::new("new.rom"))
                .unwrap_err()
                .to_string();
            assert!(
                err.starts_with("new.rom:")
                    && err.contains(&format!("format_version `{version}`"))
                    && err.contains("rubscan model build")
                    && err.contains("rubscan model import"),
                "{err}"
            );
        }
    }

    #[test]
    fn truncated_file_is_rejected_with_its_name() {
        let bytes = to_bytes(&sample_rom()).unwrap();
        for cut in [4, bytes.len() / 2, bytes.len() - 1] {
            let err = from_bytes(&bytes[..cut], Path::new("cut.rom"))
                .unwrap_err()
                .to_string();
            assert!(err.starts_with("cut.rom:"), "{err}");
        }
    }

    #[test]
    fn corrupted_contents_are_rejected_with_clear_errors() {
        let mut rom = sample_rom();
        rom.harmonics[1].mass.re[(0, 1)] = f64::NAN;
        let err = error_reading(&rom, "nan.rom");
        assert!(err.contains("non-finite") && err.contains("mass"), "{err}");

        let mut rom = sample_rom();
        rom.harmonics[2].mass.re[(0, 3)] = 1.0;
        let err = error_reading(&rom, "asym.rom");
        assert!(err.contains("not Hermitian"), "{err}");

        let mut rom = sample_rom();
        rom.harmonics[0].stiffness[0] = HermitianMatrix::real(DMatrix::identity(3, 3));
        let err = error_reading(&rom, "shape.rom");
        assert!(
            err.contains("harmonic.0.k0.re") && err.contains("shape"),
            "{err}"
        );
    }

    #[test]
    fn foreign_safetensors_file_is_rejected() {
        let data = [0u8; 8];
        let view = TensorView::new(Dtype::F64, vec![1], &data).unwrap();
        let bytes = safetensors::serialize([("x", view)], None).unwrap();
        let err = from_bytes(&bytes, Path::new("other.safetensors"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("format"), "{err}");
    }

    /// `bytes` (a ROM file) with its `rom` metadata JSON changed by `edit`.
    fn with_meta(bytes: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
        let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
        let mut header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
        let info = &mut header["__metadata__"]["rom"];
        let mut meta: serde_json::Value = serde_json::from_str(info.as_str().unwrap()).unwrap();
        edit(&mut meta);
        *info = serde_json::Value::String(meta.to_string());
        let text = header.to_string();
        let mut out = (text.len() as u64).to_le_bytes().to_vec();
        out.extend_from_slice(text.as_bytes());
        out.extend_from_slice(&bytes[8 + n..]);
        out
    }

    // Regressions found by tests/readers_never_panic.rs.

    #[test]
    fn huge_modes_per_diameter_is_rejected_not_overflowed() {
        // `3 n_c + n_modes` overflowed (panic in debug, wrong size in release).
        let bytes = with_meta(&to_bytes(&sample_rom()).unwrap(), |m| {
            m["modes_per_diameter"][1] = serde_json::json!(u64::MAX);
        });
        let err = from_bytes(&bytes, Path::new("big.rom"))
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("big.rom:") && err.contains("modes_per_diameter[1]"),
            "{err}"
        );
    }

    #[test]
    fn contact_row_beyond_the_contact_nodes_is_rejected() {
        // A corrupt row index was accepted, then sized per-row arrays in the simulation.
        let bytes = with_meta(&to_bytes(&sample_rom()).unwrap(), |m| {
            m["contact_rows"][1] = serde_json::json!(1u64 << 40);
        });
        let err = from_bytes(&bytes, Path::new("row.rom"))
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("row.rom:") && err.contains("contact_rows[1]"),
            "{err}"
        );
    }

    #[test]
    fn modal_data_without_frequencies_round_trips() {
        // `chunks(n_p * n_s)` panicked on n_p = 0 (no frequency per speed, or no speed).
        let mut rom = sample_rom();
        rom.modal_data[0] = ModalData {
            nodal_diameter: 0,
            omega: vec![],
            frequencies: vec![],
            shapes_re: vec![],
            shapes_im: vec![],
        };
        let back = from_bytes(&to_bytes(&rom).unwrap(), Path::new("m.rom")).unwrap();
        assert_eq!(back, rom);
        rom.modal_data[0] = ModalData {
            nodal_diameter: 0,
            omega: vec![0.0, 10.0],
            frequencies: vec![vec![]; 2],
            shapes_re: vec![vec![]; 2],
            shapes_im: vec![vec![]; 2],
        };
        let back = from_bytes(&to_bytes(&rom).unwrap(), Path::new("m.rom")).unwrap();
        assert_eq!(back, rom);
    }

    #[test]
    fn rom_without_contact_nodes_is_rejected() {
        // n_s = 3 n_c = 0: `chunks(0)` panicked before the model was validated.
        let mut rom = sample_rom();
        rom.contact_nodes.clear();
        let one = HermitianMatrix::real(DMatrix::identity(1, 1));
        for h in &mut rom.harmonics {
            h.mass = one.clone();
            h.stiffness = [one.clone(), one.clone(), one.clone()];
        }
        rom.modal_data[0].shapes_re = vec![vec![vec![]; 2]; 2];
        rom.modal_data[0].shapes_im = vec![vec![vec![]; 2]; 2];
        let err = error_reading(&rom, "nc.rom");
        assert!(
            err.starts_with("nc.rom:") && err.contains("contact"),
            "{err}"
        );
    }

    #[test]
    fn atomic_save_then_load() {
        let dir = std::env::temp_dir().join(format!("rubscan-romfile-{}", std::process::id()));
        let path = dir.join("m.rom");
        save(&sample_rom(), &path).unwrap();
        assert_eq!(load(&path).unwrap(), sample_rom());
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "no temporary file left behind"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
