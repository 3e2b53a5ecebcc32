//! The 20-node serendipity hexahedron (Hex20): its nodes in natural coordinates and its shape
//! functions. The mesh builder orders element nodes by it; the element matrices integrate with it.

/// Natural coordinates (ξ, η, ζ) of the 20 Hex20 nodes, in the order documented on [`SectorMesh`](super::mesh::SectorMesh).
pub(crate) const HEX20_NATURAL: [[f64; 3]; 20] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [0.0, -1.0, -1.0],
    [1.0, 0.0, -1.0],
    [0.0, 1.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, -1.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [-1.0, 0.0, 1.0],
    [-1.0, -1.0, 0.0],
    [1.0, -1.0, 0.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
];

/// Hex20 serendipity shape functions N_a(ξ, η, ζ) and their derivatives ∂N_a/∂(ξ, η, ζ).
pub(crate) fn hex20_shape(xi: [f64; 3]) -> ([f64; 20], [[f64; 3]; 20]) {
    let mut n = [0.0; 20];
    let mut dn = [[0.0; 3]; 20];
    let [x, y, z] = xi;
    for (a, p) in HEX20_NATURAL.iter().enumerate() {
        let [xa, ya, za] = *p;
        if a < 8 {
            let (fa, fb, fc) = (1.0 + x * xa, 1.0 + y * ya, 1.0 + z * za);
            let s = x * xa + y * ya + z * za - 2.0;
            n[a] = 0.125 * fa * fb * fc * s;
            dn[a] = [
                0.125 * xa * fb * fc * (s + fa),
                0.125 * ya * fa * fc * (s + fb),
                0.125 * za * fa * fb * (s + fc),
            ];
        } else if xa == 0.0 {
            let (fb, fc) = (1.0 + y * ya, 1.0 + z * za);
            n[a] = 0.25 * (1.0 - x * x) * fb * fc;
            dn[a] = [
                -0.5 * x * fb * fc,
                0.25 * (1.0 - x * x) * ya * fc,
                0.25 * (1.0 - x * x) * fb * za,
            ];
        } else if ya == 0.0 {
            let (fa, fc) = (1.0 + x * xa, 1.0 + z * za);
            n[a] = 0.25 * (1.0 - y * y) * fa * fc;
            dn[a] = [
                0.25 * (1.0 - y * y) * xa * fc,
                -0.5 * y * fa * fc,
                0.25 * (1.0 - y * y) * fa * za,
            ];
        } else {
            let (fa, fb) = (1.0 + x * xa, 1.0 + y * ya);
            n[a] = 0.25 * (1.0 - z * z) * fa * fb;
            dn[a] = [
                0.25 * (1.0 - z * z) * xa * fb,
                0.25 * (1.0 - z * z) * fa * ya,
                -0.5 * z * fa * fb,
            ];
        }
    }
    (n, dn)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape_functions_interpolate_and_differentiate() {
        for (a, p) in HEX20_NATURAL.iter().enumerate() {
            let (n, _) = hex20_shape(*p);
            for (b, v) in n.iter().enumerate() {
                assert!((v - if a == b { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
        let xi = [0.31, -0.47, 0.83];
        let (n, dn) = hex20_shape(xi);
        assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        let h = 1e-6;
        for r in 0..3 {
            let (mut xp, mut xm) = (xi, xi);
            xp[r] += h;
            xm[r] -= h;
            let (np, nm) = (hex20_shape(xp).0, hex20_shape(xm).0);
            for a in 0..20 {
                assert!((dn[a][r] - (np[a] - nm[a]) / (2.0 * h)).abs() < 1e-8);
            }
        }
    }
}
