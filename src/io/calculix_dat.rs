//! Reader of the eigenvalue tables CalculiX prints to a job's `.dat` file for a cyclic
//! symmetry `*FREQUENCY` step (`*SELECT CYCLIC SYMMETRY MODES`): one
//! `E I G E N V A L U E   O U T P U T` table per nodal diameter, rows
//! `nodal diameter, mode, eigenvalue (rad²/s²), ω (rad/s), f (Hz), imaginary part (rad/s)`.
//!
//! CalculiX's cyclic solve doubles the datum sector (the cosine and sine parts of the
//! travelling waves), so it prints every frequency of a nodal diameter twice, nodal diameters
//! 0 and N/2 included. [`distinct_pairs`] folds the pairs back to one frequency each, the
//! count a cyclic ROM or a harmonic solve gives.

use std::path::Path;

use crate::io::text_lines::{ImportError, LineReader};

/// The frequencies of one nodal diameter as CalculiX printed them.
#[derive(Clone, Debug, PartialEq)]
pub struct NodalDiameterFrequencies {
    /// Nodal diameter k.
    pub nodal_diameter: usize,
    /// Frequencies (Hz, the `CYCLES/TIME` column with the time unit s), in CalculiX's order
    /// (ascending, each twice).
    pub frequencies_hz: Vec<f64>,
}

/// Why a table is refused when no cyclic row follows its header (a non-cyclic `.dat` has five
/// columns).
const NO_ROWS: &str = "eigenvalue table without rows of six columns (nodal diameter, mode, \
                       eigenvalue, ω, f, imaginary part): not a cyclic symmetry step?";

/// Header line of each eigenvalue table.
const HEADER: &str = "E I G E N V A L U E   O U T P U T";

/// Reads every cyclic eigenvalue table of `dat`, in file order. Errors name the file and line
/// (a malformed row, a table without rows, no table at all).
pub fn read_cyclic_frequencies(dat: &Path) -> Result<Vec<NodalDiameterFrequencies>, ImportError> {
    let mut rd = LineReader::open(dat)?;
    let mut out: Vec<NodalDiameterFrequencies> = Vec::new();
    // Inside a table: the line of its header, and whether its rows have started.
    let mut table: Option<(usize, bool)> = None;
    while let Some(l) = rd.next_line()? {
        let t = l.text.trim();
        if t.contains(HEADER) {
            if let Some((at, false)) = table {
                return Err(ImportError::line(dat, at, NO_ROWS));
            }
            table = Some((l.no, false));
            continue;
        }
        let Some((at, started)) = table else { continue };
        let f: Vec<&str> = t.split_whitespace().collect();
        let row = f.len() == 6 && f[0].parse::<usize>().is_ok() && f[1].parse::<usize>().is_ok();
        if !row {
            if started {
                table = None;
            }
            continue;
        }
        let k: usize = f[0].parse().expect("checked above");
        let hz: f64 = f[4]
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| l.err(format!("frequency column '{}' is not a number", f[4])))?;
        if !started {
            out.push(NodalDiameterFrequencies {
                nodal_diameter: k,
                frequencies_hz: Vec::new(),
            });
            table = Some((at, true));
        }
        let current = out.last_mut().expect("pushed at the table's first row");
        if current.nodal_diameter != k {
            return Err(l.err(format!(
                "nodal diameter {k} inside the table of nodal diameter {}",
                current.nodal_diameter
            )));
        }
        current.frequencies_hz.push(hz);
    }
    if let Some((at, false)) = table {
        return Err(ImportError::line(dat, at, NO_ROWS));
    }
    if out.is_empty() {
        return Err(ImportError::file(
            dat,
            "no cyclic eigenvalue table (E I G E N V A L U E   O U T P U T)",
        ));
    }
    Ok(out)
}

/// The distinct frequencies of a CalculiX cyclic table: `hz` holds each twice in a row
/// (see the module notes); returns the first of each pair, or the index of the first pair
/// whose two values differ by more than `tol` relative, or an odd count.
pub fn distinct_pairs(hz: &[f64], tol: f64) -> Result<Vec<f64>, usize> {
    let mut out = Vec::with_capacity(hz.len() / 2);
    for (i, pair) in hz.chunks(2).enumerate() {
        match pair {
            [a, b] if (a - b).abs() <= tol * a.abs().max(b.abs()) => out.push(*a),
            _ => return Err(i),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::calculix::tests::{scratch, write};

    const TABLE: &str = "
     E I G E N V A L U E   O U T P U T

  NODAL   MODE NO    EIGENVALUE                      FREQUENCY
 DIAMETER                                    REAL PART            IMAGINARY PART
                                    (RAD/TIME)      (CYCLES/TIME)   (RAD/TIME)

    3          1   0.2150330E+09   0.1466400E+05   0.2333848E+04   0.0000000E+00
    3          2   0.2150330E+09   0.1466400E+05   0.2333848E+04   0.0000000E+00

     P A R T I C I P A T I O N   F A C T O R S

MODE NO.   X-COMPONENT     Y-COMPONENT     Z-COMPONENT     X-ROTATION      Y-ROTATION      Z-ROTATION

      1   0.1227423E-01   0.5144424E-03  -0.5353282E-01  -0.2849707E-03   0.6798093E-02  -0.5295174E-15
";

    #[test]
    fn reads_tables_per_nodal_diameter_and_folds_pairs() {
        let dir = scratch("dat-ok");
        let text = format!("{TABLE}{}", TABLE.replace("    3    ", "    4    "));
        let got = read_cyclic_frequencies(&write(&dir, "a.dat", &text)).unwrap();
        assert_eq!(got.len(), 2);
        assert_eq!((got[0].nodal_diameter, got[1].nodal_diameter), (3, 4));
        assert_eq!(got[0].frequencies_hz, vec![2333.848, 2333.848]);
        assert_eq!(
            distinct_pairs(&got[1].frequencies_hz, 1e-6),
            Ok(vec![2333.848])
        );
        assert_eq!(distinct_pairs(&[1.0, 1.0, 2.0, 2.1], 1e-6), Err(1));
        assert_eq!(distinct_pairs(&[1.0, 1.0, 2.0], 1e-6), Err(1));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_tables_are_refused_with_file_and_line() {
        let dir = scratch("dat-bad");
        let bad = TABLE.replace("0.2333848E+04", "0.23338x8E+04");
        let err = read_cyclic_frequencies(&write(&dir, "b.dat", &bad))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("b.dat:8:") && err.contains("not a number"),
            "{err}"
        );
        let empty = "     E I G E N V A L U E   O U T P U T\n\n nothing\n";
        let err = read_cyclic_frequencies(&write(&dir, "c.dat", empty))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("c.dat:1:") && err.contains("without rows"),
            "{err}"
        );
        let err = read_cyclic_frequencies(&write(&dir, "d.dat", "no table\n"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("d.dat") && err.contains("no cyclic eigenvalue"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
