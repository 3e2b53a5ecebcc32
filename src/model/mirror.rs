//! The mirror image of a cyclic ROM through the plane y = 0 (which holds the axis): the model
//! that turns clockwise exactly as the original turns counter-clockwise.
//!
//! The reflection `D = diag(1, −1, 1)` maps sector s (at the angle sα) onto the reflected
//! reference sector at −sα; numbering the reflected sectors by that angle, the mirrored
//! structure is cyclic with the same N and its reference sector the reflection of the
//! original's. A response `u_s = Re(ũ_k e^{iksα})` is mapped to `D u_{−s}`, whose harmonic k is
//! `D conj(ũ_k)`: every complex harmonic quantity is conjugated, with the y components of
//! physical DOFs negated. The fixed-interface modes of the mirrored sector are the conjugated
//! reflections of the original's (same frequencies), so in that basis each reduced matrix is
//! `D_b conj(C_k) D_b`, `D_b` negating the boundary DOFs' y entries and leaving the modal
//! coordinates.

use super::rom::CyclicRom;
use nalgebra::{DMatrix, DVector};

impl CyclicRom {
    /// The mirror image of this model through the plane y = 0 (module doc): positions,
    /// reduced matrices, mode shapes and recovery rows reflected. Frequencies and damping are
    /// unchanged. Mirroring twice gives the original.
    pub fn mirrored(&self) -> CyclicRom {
        let mut m = self.clone();
        let reflect = |p: &mut [f64; 3]| p[1] = -p[1];
        m.contact_nodes
            .iter_mut()
            .for_each(|c| reflect(&mut c.position));
        m.recovery
            .nodes
            .iter_mut()
            .for_each(|n| reflect(&mut n.position));
        let nb = self.n_boundary();
        for h in &mut m.harmonics {
            let d = boundary_reflection(nb, h.mass.re.nrows());
            for c in std::iter::once(&mut h.mass).chain(&mut h.stiffness) {
                conjugate_reflected(&mut c.re, &mut c.im, &d, &d);
            }
        }
        for md in &mut m.modal_data {
            let d = boundary_reflection(nb, nb);
            for (re, im) in md.shapes_re.iter_mut().zip(&mut md.shapes_im) {
                for (r, i) in re.iter_mut().zip(im.iter_mut()) {
                    for (j, (x, y)) in r.iter_mut().zip(i.iter_mut()).enumerate() {
                        *x *= d[j];
                        *y *= -d[j];
                    }
                }
            }
        }
        let nr = 3 * self.recovery.nodes.len();
        for rows in &mut m.recovery.rows {
            let (dr, db) = (
                boundary_reflection(nr, nr),
                boundary_reflection(nb, rows.re.ncols()),
            );
            conjugate_reflected(&mut rows.re, &mut rows.im, &dr, &db);
        }
        m
    }
}

/// The diagonal of `D_b` for a vector of `n` entries whose first `n_physical` are x, y, z
/// triples: −1 on their y entries, 1 elsewhere.
fn boundary_reflection(n_physical: usize, n: usize) -> DVector<f64> {
    DVector::from_fn(n, |i, _| {
        if i < n_physical && i % 3 == 1 {
            -1.0
        } else {
            1.0
        }
    })
}

/// `C ← D_r conj(C) D_c` for a complex matrix `C = re + i im` and diagonal ±1 matrices `D_r`
/// (rows) and `D_c` (columns).
fn conjugate_reflected(
    re: &mut DMatrix<f64>,
    im: &mut DMatrix<f64>,
    rows: &DVector<f64>,
    cols: &DVector<f64>,
) {
    let signs = DMatrix::from_fn(rows.len(), cols.len(), |i, j| rows[i] * cols[j]);
    re.component_mul_assign(&signs);
    im.component_mul_assign(&signs);
    im.neg_mut();
}

#[cfg(test)]
mod tests {
    use crate::fixtures::{SyntheticSpec, synthetic_rom};
    use crate::model::rom::Component;

    #[test]
    fn mirroring_twice_gives_the_original_and_once_changes_it() {
        let rom = synthetic_rom(&SyntheticSpec::small(Component::Impeller, 8, 3, 2));
        let once = rom.mirrored();
        assert_ne!(once, rom);
        assert_eq!(once.mirrored(), rom);
        once.validate().unwrap();
        // A y-free node stays; the others are reflected.
        for (a, b) in rom.contact_nodes.iter().zip(&once.contact_nodes) {
            assert_eq!([a.position[0], -a.position[1], a.position[2]], b.position);
        }
    }
}
