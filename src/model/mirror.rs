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

use super::rom::{ComplexRows, CyclicRom, HermitianMatrix};
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
            mirror_hermitian(&mut h.mass, &d);
            h.stiffness.iter_mut().for_each(|k| mirror_hermitian(k, &d));
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
            mirror_rows(rows, &dr, &db);
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

/// `C ← D conj(C) D` for a Hermitian `C = re + i im` and a diagonal ±1 `D`.
fn mirror_hermitian(c: &mut HermitianMatrix, d: &DVector<f64>) {
    let dd = DMatrix::from_fn(d.len(), d.len(), |i, j| d[i] * d[j]);
    c.re.component_mul_assign(&dd);
    c.im.component_mul_assign(&dd);
    c.im.neg_mut();
}

/// `R ← D_r conj(R) D_b` for diagonal ±1 `D_r` (rows) and `D_b` (columns).
fn mirror_rows(r: &mut ComplexRows, dr: &DVector<f64>, db: &DVector<f64>) {
    let dd = DMatrix::from_fn(dr.len(), db.len(), |i, j| dr[i] * db[j]);
    r.re.component_mul_assign(&dd);
    r.im.component_mul_assign(&dd);
    r.im.neg_mut();
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
