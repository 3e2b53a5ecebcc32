//! Linear interaction criterion (Batailly, Meingast & Legrand 2015; paper §6, DESIGN §5):
//! critical speeds where a backward impeller wave, seen from the fixed frame, coincides
//! with a forward casing wave of the same number of lobes, with a spatial compatibility
//! score of the two mode shapes at the contact interface; and engine-order crossings of
//! the impeller modes for a rigid n-lobe casing.
//!
//! # Coincidence condition
//! An impeller mode of nodal diameter `k` and rotating-frame angular frequency `ω_b(Ω)`
//! (rad/s) is sampled by the `N_b` blades. Seen from the fixed frame it contains an
//! `n`-lobe wave of angular frequency `n Ω − ω_b(Ω)` for every `n ≥ 1` with
//! `n ≡ ±k (mod N_b)` (aliasing: the blades cannot tell `k` from `jN_b ± k` lobes). The
//! critical speeds `Ω*` of casing mode `q` with `n` nodal diameters solve
//! `n Ω − ω_b,p(Ω) = ω_c,q` (paper \[1\]), with `k = min(n mod N_b, N_b − n mod N_b)`.
//!
//! `ω_b,p(Ω)` is interpolated on the impeller's speed grid as a function of `Ω²`
//! (piecewise linear, or natural cubic spline); roots are searched only inside the grid
//! (no extrapolation), except for a single-point grid, which means speed-independent
//! frequencies and gives the closed-form root. Mode `p` is the `p`-th frequency in
//! ascending order at every grid speed (no mode tracking through veerings).
//!
//! # Spatial compatibility
//! Each mode shape is reduced to its complex normal amplitude along the contact line:
//! - meridional coordinate `s ∈ [0, 1]` of each contact node = normalised cumulative chord
//!   length of the nodes sorted by row (leading edge `s = 0`, trailing edge `s = 1`) in the
//!   meridian half-plane `(r, z)`;
//! - normal direction = normal to that meridian polyline in `(r, z)` (central differences),
//!   which is the radial direction for an axial flow path and the axial one at a radial
//!   outlet; a single contact node uses the radial direction;
//! - amplitude `w_j = n_r (ũ_x cos φ_j + ũ_y sin φ_j) + n_z ũ_z` for node `j` at angle
//!   `φ_j` in sector 0, then referred to the `n`-lobe wave at angle 0:
//!   `ŵ_j = w_j e^{−i n φ_j}` (for `n ≡ −k`, `w_j` is conjugated first), so that blade-tip
//!   nodes at different angles (lean, sweep) compare with the casing nodes at `θ = 0`;
//! - both amplitudes are interpolated linearly onto a common uniform `s` grid and
//!   `score = |⟨ŵ_b, ŵ_c⟩| / (‖ŵ_b‖ ‖ŵ_c‖)` with the trapezoidal Hermitian inner product:
//!   1 for proportional shapes (any complex factor), 0 for shapes that do not overlap
//!   (e.g. leading-edge vs trailing-edge localised, paper Fig. 21), in `[0, 1]` by
//!   Cauchy–Schwarz.
//!
//! The impeller shape is taken at the grid speed nearest to `Ω*`.

use crate::model::rom::{ContactNode, CyclicRom, ModalData};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;
use thiserror::Error;

/// Invalid modal data or options; every variant names what is wrong.
#[derive(Debug, Error, PartialEq)]
pub enum InteractionError {
    /// A sector count of zero.
    #[error("`n_sectors` of the {which} must be at least 1")]
    NoSectors {
        /// Which structure: `"impeller"` or `"casing"`.
        which: &'static str,
    },
    /// The speed grid is empty, not finite, negative or not strictly increasing.
    #[error("{which} nodal diameter {k}: speed grid {reason}")]
    BadGrid {
        /// Which structure: `"impeller"` or `"casing"`.
        which: &'static str,
        /// Nodal diameter of the offending modal data.
        k: usize,
        /// What is wrong with the grid.
        reason: &'static str,
    },
    /// Frequencies have the wrong number of rows or a non-finite / negative value.
    #[error("{which} nodal diameter {k}: frequencies {reason}")]
    BadFrequencies {
        /// Which structure: `"impeller"` or `"casing"`.
        which: &'static str,
        /// Nodal diameter of the offending modal data.
        k: usize,
        /// What is wrong with the frequencies.
        reason: &'static str,
    },
    /// Mode shapes have the wrong size.
    #[error(
        "{which} nodal diameter {k}: mode shape (grid {i}, mode {p}) has {got} entries, expected {expected}"
    )]
    ShapeLength {
        /// Which structure: `"impeller"` or `"casing"`.
        which: &'static str,
        /// Nodal diameter of the offending modal data.
        k: usize,
        /// Index in the speed grid.
        i: usize,
        /// Mode index within the nodal diameter.
        p: usize,
        /// Number of entries found.
        got: usize,
        /// Number of entries expected (3 per contact node).
        expected: usize,
    },
    /// Two contact nodes share a row, so the contact line is ambiguous.
    #[error("{which}: contact nodes {a} and {b} share row {row}")]
    DuplicateRow {
        /// Which structure: `"impeller"` or `"casing"`.
        which: &'static str,
        /// Index of the first contact node.
        a: usize,
        /// Index of the second contact node.
        b: usize,
        /// The row both claim.
        row: usize,
    },
    /// A non-finite contact node coordinate.
    #[error("{which}: contact node {index} has a non-finite coordinate")]
    NodeNotFinite {
        /// Which structure: `"impeller"` or `"casing"`.
        which: &'static str,
        /// Index of the contact node.
        index: usize,
    },
    /// An option out of range.
    #[error("option `{name}`: {reason}")]
    BadOption {
        /// Name of the option.
        name: &'static str,
        /// Why its value is rejected.
        reason: &'static str,
    },
}

/// How `ω_b(Ω)` is interpolated between grid speeds, in the variable `Ω²`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// Piecewise linear in `Ω²`: robust, no overshoot; exact when `ω` is affine in `Ω²`.
    #[default]
    Linear,
    /// Natural cubic spline in `Ω²` (smoother; falls back to linear on two points).
    CubicSpline,
}

/// Options of [`critical_speeds`] and [`engine_order_crossings`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CriterionOptions {
    /// Interpolation of the impeller frequencies in `Ω²`.
    pub interpolation: Interpolation,
    /// Largest number of lobes `n` (casing nodal diameter) considered; `None` = all the
    /// casing's nodal diameters.
    pub max_nodal_diameter: Option<usize>,
    /// Sign-change scan: sub-intervals per grid interval (catches two roots in one
    /// interval).
    pub subdivisions: usize,
    /// Points of the common meridional grid for the compatibility score.
    pub profile_points: usize,
}

impl Default for CriterionOptions {
    fn default() -> Self {
        Self {
            interpolation: Interpolation::Linear,
            max_nodal_diameter: None,
            subdivisions: 16,
            profile_points: 201,
        }
    }
}

impl CriterionOptions {
    fn validate(&self) -> Result<(), InteractionError> {
        if self.subdivisions == 0 {
            return Err(InteractionError::BadOption {
                name: "subdivisions",
                reason: "must be at least 1",
            });
        }
        if self.profile_points < 2 {
            return Err(InteractionError::BadOption {
                name: "profile_points",
                reason: "must be at least 2",
            });
        }
        Ok(())
    }
}

/// The modal data of one cyclic structure with the geometry of its contact nodes.
#[derive(Clone, Copy, Debug)]
pub struct InterfaceModes<'a> {
    /// Number of sectors (blades for the impeller).
    pub n_sectors: usize,
    /// Contact nodes of sector 0 (positions in m, rows LE → TE).
    pub contact_nodes: &'a [ContactNode],
    /// Free-vibration data per nodal diameter (frequencies in Hz).
    pub modal_data: &'a [ModalData],
}

impl<'a> InterfaceModes<'a> {
    /// Borrows the relevant parts of a ROM.
    pub fn from_rom(rom: &'a CyclicRom) -> Self {
        Self {
            n_sectors: rom.n_sectors,
            contact_nodes: &rom.contact_nodes,
            modal_data: &rom.modal_data,
        }
    }
}

/// One predicted critical speed (paper §6, Fig. 19).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CriticalSpeed {
    /// Number of lobes `n` of the coinciding waves = casing nodal diameter.
    pub nodal_diameter: usize,
    /// Impeller nodal diameter `k` (equals `n` unless aliased: `n ≡ ±k mod N_b`).
    pub impeller_nodal_diameter: usize,
    /// Impeller mode index `p` (0-based, ascending frequency) within its nodal diameter.
    pub impeller_mode: usize,
    /// Casing mode index `q` (0-based, ascending frequency) within its nodal diameter.
    pub casing_mode: usize,
    /// Critical rotation speed Ω* (rad/s).
    pub omega_rad_s: f64,
    /// Fixed-frame frequency of the coinciding waves `ω_c,q / 2π` (Hz).
    pub frequency_hz: f64,
    /// Spatial compatibility of the two shapes at the interface, in `[0, 1]`; `None` when
    /// either structure stores no mode shapes.
    pub compatibility: Option<f64>,
}

/// A crossing of an impeller mode with an engine-order line (rigid n-lobe casing).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EngineOrderCrossing {
    /// Engine order `E` (a multiple of the casing's lobe count).
    pub engine_order: usize,
    /// Impeller nodal diameter excited, `min(E mod N_b, N_b − E mod N_b)`.
    pub nodal_diameter: usize,
    /// Impeller mode index `p` within that nodal diameter.
    pub impeller_mode: usize,
    /// Rotation speed Ω (rad/s) where `E Ω = ω_b,p(Ω)`.
    pub omega_rad_s: f64,
    /// Rotating-frame frequency of the mode there, `E Ω / 2π` (Hz).
    pub frequency_hz: f64,
}

/// Nodal diameter excited on an `n_sectors`-sector wheel by an `order`-lobe pattern:
/// `min(order mod N, N − order mod N)` (DESIGN §5, aliasing).
pub fn aliased_nodal_diameter(order: usize, n_sectors: usize) -> usize {
    let r = order % n_sectors;
    r.min(n_sectors - r)
}

/// Interpolant of one mode's angular frequency (rad/s) as a function of `x = Ω²`.
struct Branch {
    x: Vec<f64>,
    y: Vec<f64>,
    /// Second derivatives `d²y/dx²` at the knots (all zero = linear).
    m: Vec<f64>,
}

impl Branch {
    fn new(omega: &[f64], freq_hz: &[f64], interp: Interpolation) -> Self {
        let x: Vec<f64> = omega.iter().map(|w| w * w).collect();
        let y: Vec<f64> = freq_hz.iter().map(|f| TAU * f).collect();
        let m = match interp {
            Interpolation::CubicSpline if x.len() >= 3 => natural_spline(&x, &y),
            _ => vec![0.0; x.len()],
        };
        Self { x, y, m }
    }

    /// `ω(Ω)` for Ω inside the grid (clamped to the end intervals otherwise).
    fn eval(&self, omega: f64) -> f64 {
        let n = self.x.len();
        if n == 1 {
            return self.y[0];
        }
        let x = omega * omega;
        let i = self.x.partition_point(|&xi| xi <= x).clamp(1, n - 1) - 1;
        let h = self.x[i + 1] - self.x[i];
        let a = (self.x[i + 1] - x) / h;
        let b = 1.0 - a;
        a * self.y[i]
            + b * self.y[i + 1]
            + ((a * a * a - a) * self.m[i] + (b * b * b - b) * self.m[i + 1]) * h * h / 6.0
    }
}

/// Second derivatives of the natural cubic spline through `(x_i, y_i)` (Thomas algorithm).
fn natural_spline(x: &[f64], y: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut m = vec![0.0; n];
    // Interior equations: h_{i-1} m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_i m_{i+1} = 6 (Δ_i − Δ_{i-1}).
    let mut c_prime = vec![0.0; n];
    let mut d_prime = vec![0.0; n];
    for i in 1..n - 1 {
        let h0 = x[i] - x[i - 1];
        let h1 = x[i + 1] - x[i];
        let rhs = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
        let diag = 2.0 * (h0 + h1) - h0 * c_prime[i - 1];
        c_prime[i] = h1 / diag;
        d_prime[i] = (rhs - h0 * d_prime[i - 1]) / diag;
    }
    for i in (1..n - 1).rev() {
        m[i] = d_prime[i] - c_prime[i] * m[i + 1];
    }
    m
}

fn check_modal(which: &'static str, md: &ModalData, n_dof: usize) -> Result<(), InteractionError> {
    let k = md.nodal_diameter;
    let bad_grid = |reason| InteractionError::BadGrid { which, k, reason };
    if md.omega.is_empty() {
        return Err(bad_grid("is empty"));
    }
    if md.omega.iter().any(|w| !w.is_finite() || *w < 0.0) {
        return Err(bad_grid("has a negative or non-finite speed"));
    }
    if md.omega.windows(2).any(|w| w[1] <= w[0]) {
        return Err(bad_grid("is not strictly increasing"));
    }
    let bad_f = |reason| InteractionError::BadFrequencies { which, k, reason };
    if md.frequencies.len() != md.omega.len() {
        return Err(bad_f("need one row per grid speed"));
    }
    if md
        .frequencies
        .iter()
        .flatten()
        .any(|f| !f.is_finite() || *f < 0.0)
    {
        return Err(bad_f("contain a negative or non-finite value"));
    }
    for shapes in [&md.shapes_re, &md.shapes_im] {
        if shapes.is_empty() {
            continue;
        }
        if shapes.len() != md.omega.len() {
            return Err(bad_f("mode shapes need one entry per grid speed"));
        }
        for (i, row) in shapes.iter().enumerate() {
            for (p, s) in row.iter().enumerate() {
                if s.len() != n_dof {
                    return Err(InteractionError::ShapeLength {
                        which,
                        k,
                        i,
                        p,
                        got: s.len(),
                        expected: n_dof,
                    });
                }
            }
        }
    }
    Ok(())
}

fn n_modes(md: &ModalData) -> usize {
    md.frequencies.iter().map(Vec::len).min().unwrap_or(0)
}

/// Roots of `g` in `[lo, hi]`: sign-change scan on `subdivisions` sub-intervals then
/// bisection to machine precision.
fn roots_in(g: &dyn Fn(f64) -> f64, lo: f64, hi: f64, subdivisions: usize, out: &mut Vec<f64>) {
    let step = (hi - lo) / subdivisions as f64;
    let mut a = lo;
    let mut ga = g(a);
    for j in 1..=subdivisions {
        let b = if j == subdivisions {
            hi
        } else {
            lo + step * j as f64
        };
        let gb = g(b);
        if ga == 0.0 {
            out.push(a);
        } else if ga * gb < 0.0 {
            out.push(bisect(g, a, b, ga));
        }
        a = b;
        ga = gb;
    }
}

fn bisect(g: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, mut ga: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (a + b);
        if mid <= a || mid >= b {
            break;
        }
        let gm = g(mid);
        if gm == 0.0 {
            return mid;
        }
        if ga * gm < 0.0 {
            b = mid;
        } else {
            a = mid;
            ga = gm;
        }
    }
    0.5 * (a + b)
}

/// All roots of `n Ω − ω_b(Ω) − c = 0` over the branch's grid (or the closed form for a
/// single-point grid).
fn branch_roots(branch: &Branch, n: f64, c: f64, subdivisions: usize, out: &mut Vec<f64>) {
    out.clear();
    if branch.x.len() == 1 {
        let w = (c + branch.y[0]) / n;
        if w >= 0.0 {
            out.push(w);
        }
        return;
    }
    let g = |w: f64| n * w - branch.eval(w) - c;
    let nodes: Vec<f64> = branch.x.iter().map(|x| x.sqrt()).collect();
    for win in nodes.windows(2) {
        roots_in(&g, win[0], win[1], subdivisions, out);
    }
    let last = *nodes.last().unwrap_or(&0.0);
    if g(last) == 0.0 {
        out.push(last);
    }
}

/// Complex normal amplitude of a mode along the contact line, referred to the `lobes`-lobe
/// wave at angle 0, with the meridional coordinates of the nodes (see module docs).
pub struct InterfaceProfile {
    /// Meridional coordinate of each contact node, ascending in `[0, 1]`.
    pub s: Vec<f64>,
    /// Real part of the normal amplitude at each node.
    pub re: Vec<f64>,
    /// Imaginary part of the normal amplitude at each node.
    pub im: Vec<f64>,
}

/// Geometry of a contact line: node order (by row), meridional coordinate, normal in
/// `(r, z)` and angle of each node.
struct ContactLine {
    order: Vec<usize>,
    s: Vec<f64>,
    normal: Vec<(f64, f64)>,
    phi: Vec<f64>,
}

impl ContactLine {
    fn new(which: &'static str, nodes: &[ContactNode]) -> Result<Self, InteractionError> {
        for (index, nd) in nodes.iter().enumerate() {
            if nd.position.iter().any(|c| !c.is_finite()) {
                return Err(InteractionError::NodeNotFinite { which, index });
            }
        }
        let mut order: Vec<usize> = (0..nodes.len()).collect();
        order.sort_by_key(|&i| nodes[i].row);
        for w in order.windows(2) {
            if nodes[w[0]].row == nodes[w[1]].row {
                return Err(InteractionError::DuplicateRow {
                    which,
                    a: w[0],
                    b: w[1],
                    row: nodes[w[0]].row,
                });
            }
        }
        let rz: Vec<(f64, f64)> = order
            .iter()
            .map(|&i| {
                let p = nodes[i].position;
                (p[0].hypot(p[1]), p[2])
            })
            .collect();
        let mut s = vec![0.0; rz.len()];
        for j in 1..rz.len() {
            s[j] = s[j - 1] + (rz[j].0 - rz[j - 1].0).hypot(rz[j].1 - rz[j - 1].1);
        }
        let total = *s.last().unwrap_or(&0.0);
        if total > 0.0 {
            s.iter_mut().for_each(|v| *v /= total);
        }
        let n = rz.len();
        let normal = (0..n)
            .map(|j| {
                if n < 2 {
                    return (1.0, 0.0);
                }
                let (a, b) = (j.saturating_sub(1), (j + 1).min(n - 1));
                let (tr, tz) = (rz[b].0 - rz[a].0, rz[b].1 - rz[a].1);
                let len = tr.hypot(tz);
                if len == 0.0 {
                    (1.0, 0.0)
                } else {
                    (-tz / len, tr / len)
                }
            })
            .collect();
        let phi = order
            .iter()
            .map(|&i| nodes[i].position[1].atan2(nodes[i].position[0]))
            .collect();
        Ok(Self {
            order,
            s,
            normal,
            phi,
        })
    }

    /// Normal amplitude profile of the shape `(re, im)` (3 entries per node, node-major).
    fn profile(&self, re: &[f64], im: &[f64], lobes: usize, conjugate: bool) -> InterfaceProfile {
        let n = self.order.len();
        let (mut pr, mut pi) = (vec![0.0; n], vec![0.0; n]);
        for (j, &node) in self.order.iter().enumerate() {
            let (nr, nz) = self.normal[j];
            let (c, s) = (self.phi[j].cos(), self.phi[j].sin());
            let comp =
                |v: &[f64]| nr * (v[3 * node] * c + v[3 * node + 1] * s) + nz * v[3 * node + 2];
            let wr = comp(re);
            let wi = if im.is_empty() { 0.0 } else { comp(im) };
            let wi = if conjugate { -wi } else { wi };
            let ang = -(lobes as f64) * self.phi[j];
            let (ca, sa) = (ang.cos(), ang.sin());
            pr[j] = wr * ca - wi * sa;
            pi[j] = wr * sa + wi * ca;
        }
        InterfaceProfile {
            s: self.s.clone(),
            re: pr,
            im: pi,
        }
    }
}

fn interp_linear(s: &[f64], v: &[f64], t: f64) -> f64 {
    let n = s.len();
    if n == 1 {
        return v[0];
    }
    let i = s.partition_point(|&x| x <= t).clamp(1, n - 1) - 1;
    let h = s[i + 1] - s[i];
    if h <= 0.0 {
        return v[i];
    }
    let a = ((t - s[i]) / h).clamp(0.0, 1.0);
    v[i] * (1.0 - a) + v[i + 1] * a
}

/// Spatial compatibility `|⟨a, b⟩| / (‖a‖ ‖b‖) ∈ [0, 1]` of two interface profiles on a
/// common uniform grid of `points` meridional stations (trapezoidal Hermitian inner
/// product); 0 if either profile vanishes.
pub fn compatibility(a: &InterfaceProfile, b: &InterfaceProfile, points: usize) -> f64 {
    let points = points.max(2);
    let (mut dr, mut di, mut na, mut nb) = (0.0, 0.0, 0.0, 0.0);
    for g in 0..points {
        let t = g as f64 / (points - 1) as f64;
        let w = if g == 0 || g == points - 1 { 0.5 } else { 1.0 };
        let (ar, ai) = (interp_linear(&a.s, &a.re, t), interp_linear(&a.s, &a.im, t));
        let (br, bi) = (interp_linear(&b.s, &b.re, t), interp_linear(&b.s, &b.im, t));
        // conj(a) b
        dr += w * (ar * br + ai * bi);
        di += w * (ar * bi - ai * br);
        na += w * (ar * ar + ai * ai);
        nb += w * (br * br + bi * bi);
    }
    if na == 0.0 || nb == 0.0 {
        return 0.0;
    }
    (dr.hypot(di) / (na * nb).sqrt()).min(1.0)
}

fn has_shapes(md: &ModalData) -> bool {
    !md.shapes_re.is_empty()
}

/// Critical speeds of the linear interaction criterion `n Ω − ω_b,p(Ω) = ω_c,q` for every
/// casing nodal diameter `n ≥ 1` whose (aliased) impeller nodal diameter has data, every
/// impeller mode `p` and casing mode `q`, sorted by increasing Ω*. The impeller data are
/// rotating-frame frequencies on a speed grid; the casing data are fixed-frame (first grid
/// point used).
pub fn critical_speeds(
    impeller: &InterfaceModes,
    casing: &InterfaceModes,
    opts: &CriterionOptions,
) -> Result<Vec<CriticalSpeed>, InteractionError> {
    opts.validate()?;
    if impeller.n_sectors == 0 {
        return Err(InteractionError::NoSectors { which: "impeller" });
    }
    if casing.n_sectors == 0 {
        return Err(InteractionError::NoSectors { which: "casing" });
    }
    for md in impeller.modal_data {
        check_modal("impeller", md, 3 * impeller.contact_nodes.len())?;
    }
    for md in casing.modal_data {
        check_modal("casing", md, 3 * casing.contact_nodes.len())?;
    }
    let blade_line = ContactLine::new("impeller", impeller.contact_nodes)?;
    let casing_line = ContactLine::new("casing", casing.contact_nodes)?;
    let nb = impeller.n_sectors;
    let mut table = Vec::new();
    let mut roots = Vec::new();
    for cmd in casing.modal_data {
        let n = cmd.nodal_diameter;
        if n == 0 || opts.max_nodal_diameter.is_some_and(|m| n > m) {
            continue;
        }
        let k = aliased_nodal_diameter(n, nb);
        let conjugate = n % nb != k;
        let Some(imd) = impeller.modal_data.iter().find(|m| m.nodal_diameter == k) else {
            continue;
        };
        for p in 0..n_modes(imd) {
            let freqs: Vec<f64> = imd.frequencies.iter().map(|row| row[p]).collect();
            let branch = Branch::new(&imd.omega, &freqs, opts.interpolation);
            for (q, &fc) in cmd.frequencies[0].iter().enumerate() {
                branch_roots(&branch, n as f64, TAU * fc, opts.subdivisions, &mut roots);
                for &w in &roots {
                    let compat = (has_shapes(imd) && has_shapes(cmd)).then(|| {
                        let i = nearest_index(&imd.omega, w);
                        let pb = blade_line.profile(
                            &imd.shapes_re[i][p],
                            imd.shapes_im.get(i).map_or(&[][..], |v| &v[p]),
                            n,
                            conjugate,
                        );
                        let pc = casing_line.profile(
                            &cmd.shapes_re[0][q],
                            cmd.shapes_im.first().map_or(&[][..], |v| &v[q]),
                            n,
                            false,
                        );
                        compatibility(&pb, &pc, opts.profile_points)
                    });
                    table.push(CriticalSpeed {
                        nodal_diameter: n,
                        impeller_nodal_diameter: k,
                        impeller_mode: p,
                        casing_mode: q,
                        omega_rad_s: w,
                        frequency_hz: fc,
                        compatibility: compat,
                    });
                }
            }
        }
    }
    table.sort_by(|a, b| a.omega_rad_s.total_cmp(&b.omega_rad_s));
    Ok(table)
}

fn nearest_index(grid: &[f64], w: f64) -> usize {
    grid.iter()
        .enumerate()
        .min_by(|a, b| (a.1 - w).abs().total_cmp(&(b.1 - w).abs()))
        .map_or(0, |(i, _)| i)
}

/// Engine-order crossings `E Ω = ω_b,p(Ω)` of the impeller modes for a rigid casing with
/// `lobes` lobes (`E = lobes, 2·lobes, …, ≤ max_engine_order`), each aliased onto nodal
/// diameter `min(E mod N_b, N_b − E mod N_b)`; sorted by increasing Ω.
pub fn engine_order_crossings(
    impeller: &[ModalData],
    n_blades: usize,
    lobes: usize,
    max_engine_order: usize,
    opts: &CriterionOptions,
) -> Result<Vec<EngineOrderCrossing>, InteractionError> {
    opts.validate()?;
    if n_blades == 0 {
        return Err(InteractionError::NoSectors { which: "impeller" });
    }
    if lobes == 0 {
        return Err(InteractionError::BadOption {
            name: "lobes",
            reason: "must be at least 1",
        });
    }
    for md in impeller {
        // Shapes are not used here: accept any shape size.
        let stripped = ModalData {
            shapes_re: Vec::new(),
            shapes_im: Vec::new(),
            ..md.clone()
        };
        check_modal("impeller", &stripped, 0)?;
    }
    let mut out = Vec::new();
    let mut roots = Vec::new();
    for e in (lobes..=max_engine_order).step_by(lobes) {
        let k = aliased_nodal_diameter(e, n_blades);
        let Some(md) = impeller.iter().find(|m| m.nodal_diameter == k) else {
            continue;
        };
        for p in 0..n_modes(md) {
            let freqs: Vec<f64> = md.frequencies.iter().map(|row| row[p]).collect();
            let branch = Branch::new(&md.omega, &freqs, opts.interpolation);
            // E Ω − ω_b(Ω) = 0: the same root finder with c = 0.
            branch_roots(&branch, e as f64, 0.0, opts.subdivisions, &mut roots);
            for &w in &roots {
                out.push(EngineOrderCrossing {
                    engine_order: e,
                    nodal_diameter: k,
                    impeller_mode: p,
                    omega_rad_s: w,
                    frequency_hz: e as f64 * w / TAU,
                });
            }
        }
    }
    out.sort_by(|a, b| a.omega_rad_s.total_cmp(&b.omega_rad_s));
    Ok(out)
}

/// The critical speed of `table` nearest to `omega` (rad/s), if any. Filter the table
/// first (e.g. on `compatibility`) to ignore harmless coincidences.
#[cfg(test)]
pub(crate) fn nearest_critical(table: &[CriticalSpeed], omega: f64) -> Option<&CriticalSpeed> {
    table.iter().min_by(|a, b| {
        (a.omega_rad_s - omega)
            .abs()
            .total_cmp(&(b.omega_rad_s - omega).abs())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Contact nodes on a straight conical meridian from (r0, z0) to (r1, z1), node `j` at
    /// angle `phi(j)`.
    fn line(
        n: usize,
        r: (f64, f64),
        z: (f64, f64),
        phi: impl Fn(usize) -> f64,
    ) -> Vec<ContactNode> {
        (0..n)
            .map(|j| {
                let t = j as f64 / (n - 1) as f64;
                let rr = r.0 + t * (r.1 - r.0);
                let zz = z.0 + t * (z.1 - z.0);
                let f = phi(j);
                ContactNode {
                    position: [rr * f.cos(), rr * f.sin(), zz],
                    row: j,
                    id: None,
                }
            })
            .collect()
    }

    /// Complex shape whose normal amplitude at node `j` (meridional coordinate t_j) is
    /// `f(t_j) e^{i(n φ_j + ψ)}`, i.e. an n-lobe wave with profile f.
    fn shape(
        nodes: &[ContactNode],
        normal: (f64, f64),
        lobes: usize,
        psi: f64,
        f: impl Fn(f64) -> f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = nodes.len();
        let (mut re, mut im) = (vec![0.0; 3 * n], vec![0.0; 3 * n]);
        for (j, nd) in nodes.iter().enumerate() {
            let t = j as f64 / (n - 1) as f64;
            let phi = nd.position[1].atan2(nd.position[0]);
            let a = f(t);
            let ang = lobes as f64 * phi + psi;
            let dir = [normal.0 * phi.cos(), normal.0 * phi.sin(), normal.1];
            for d in 0..3 {
                re[3 * j + d] = a * ang.cos() * dir[d];
                im[3 * j + d] = a * ang.sin() * dir[d];
            }
        }
        (re, im)
    }

    /// Normal in (r, z) of the straight meridian from (r0, z0) to (r1, z1).
    fn normal_of(r: (f64, f64), z: (f64, f64)) -> (f64, f64) {
        let (tr, tz) = (r.1 - r.0, z.1 - z.0);
        let l = tr.hypot(tz);
        (-tz / l, tr / l)
    }

    fn modal(k: usize, omega: &[f64], freqs_rad: &[Vec<f64>]) -> ModalData {
        ModalData {
            nodal_diameter: k,
            omega: omega.to_vec(),
            frequencies: freqs_rad
                .iter()
                .map(|r| r.iter().map(|w| w / TAU).collect())
                .collect(),
            shapes_re: vec![],
            shapes_im: vec![],
        }
    }

    /// Roots of b Ω² − n Ω + (a + c) = 0 (b > 0), ascending.
    fn quad_roots(a: f64, b: f64, n: f64, c: f64) -> [f64; 2] {
        let disc = (n * n - 4.0 * b * (a + c)).sqrt();
        [(n - disc) / (2.0 * b), (n + disc) / (2.0 * b)]
    }

    fn interface<'a>(
        n_sectors: usize,
        contact_nodes: &'a [ContactNode],
        modal_data: &'a [ModalData],
    ) -> InterfaceModes<'a> {
        InterfaceModes {
            n_sectors,
            contact_nodes,
            modal_data,
        }
    }

    fn casing_nodes() -> Vec<ContactNode> {
        line(5, (0.20, 0.25), (0.0, 0.05), |_| 0.0)
    }
    fn blade_nodes() -> Vec<ContactNode> {
        line(7, (0.1995, 0.2495), (0.0, 0.05), |j| 0.01 * j as f64)
    }

    #[test]
    fn critical_speeds_match_analytic_roots() {
        // ω_b = a + b Ω² is affine in Ω²: linear interpolation is exact, so the roots are
        // the analytic ones. Grid 0..5000 rad/s, 11 points.
        let grid: Vec<f64> = (0..=10).map(|i| 500.0 * i as f64).collect();
        let (a0, b0) = (TAU * 300.0, 5e-4);
        let a1 = TAU * 350.0; // speed-independent mode
        let freqs: Vec<Vec<f64>> = grid.iter().map(|w| vec![a0 + b0 * w * w, a1]).collect();
        let imp_md = vec![modal(3, &grid, &freqs)];
        let wc = TAU * 200.0;
        let cas_md = vec![modal(3, &[0.0], &[vec![wc]]), modal(1, &[0.0], &[vec![wc]])];
        let (bn, cn) = (blade_nodes(), casing_nodes());
        let imp = interface(12, &bn, &imp_md);
        let cas = interface(100, &cn, &cas_md);
        for interp in [Interpolation::Linear, Interpolation::CubicSpline] {
            let opts = CriterionOptions {
                interpolation: interp,
                ..Default::default()
            };
            let table = critical_speeds(&imp, &cas, &opts).unwrap();
            let [r0, r1] = quad_roots(a0, b0, 3.0, wc);
            let r2 = (a1 + wc) / 3.0;
            assert!(r1 < 5000.0, "both roots inside the grid");
            assert_eq!(table.len(), 3, "{table:?}");
            let mut expected = [(r0, 0), (r1, 0), (r2, 1)];
            expected.sort_by(|x, y| x.0.total_cmp(&y.0));
            for (row, &(w, p)) in table.iter().zip(&expected) {
                assert_relative_eq!(row.omega_rad_s, w, max_relative = 1e-8);
                assert_eq!(row.impeller_mode, p);
                assert_eq!((row.nodal_diameter, row.impeller_nodal_diameter), (3, 3));
                assert_eq!(row.casing_mode, 0);
                assert_relative_eq!(row.frequency_hz, 200.0, max_relative = 1e-12);
                assert!(row.compatibility.is_none());
            }
            let near = nearest_critical(&table, r1 + 10.0).unwrap();
            assert_relative_eq!(near.omega_rad_s, r1, max_relative = 1e-8);
        }
    }

    #[test]
    fn two_roots_in_one_grid_interval() {
        let grid = [0.0, 5000.0];
        let (a, b) = (TAU * 300.0, 5e-4);
        let freqs: Vec<Vec<f64>> = grid.iter().map(|w| vec![a + b * w * w]).collect();
        let imp_md = vec![modal(3, &grid, &freqs)];
        let wc = TAU * 200.0;
        let cas_md = vec![modal(3, &[0.0], &[vec![wc]])];
        let (bn, cn) = (blade_nodes(), casing_nodes());
        let imp = interface(12, &bn, &imp_md);
        let cas = interface(100, &cn, &cas_md);
        let table = critical_speeds(&imp, &cas, &CriterionOptions::default()).unwrap();
        let r = quad_roots(a, b, 3.0, wc);
        assert_eq!(table.len(), 2);
        assert_relative_eq!(table[0].omega_rad_s, r[0], max_relative = 1e-8);
        assert_relative_eq!(table[1].omega_rad_s, r[1], max_relative = 1e-8);
    }

    #[test]
    fn aliased_casing_nodal_diameters() {
        // 12 blades: casing 14 lobes ≡ +2, casing 10 lobes ≡ −2 (mod 12) both reach the
        // impeller's 2-ND mode; 1 lobe has no impeller data and is skipped.
        let grid = [0.0, 1000.0, 2000.0];
        let (a, b) = (TAU * 500.0, 1e-4);
        let freqs: Vec<Vec<f64>> = grid.iter().map(|w| vec![a + b * w * w]).collect();
        let imp_md = vec![modal(2, &grid, &freqs)];
        let wc = TAU * 800.0;
        let cas_md: Vec<ModalData> = [1, 10, 14]
            .iter()
            .map(|&n| modal(n, &[0.0], &[vec![wc]]))
            .collect();
        let (bn, cn) = (blade_nodes(), casing_nodes());
        let imp = interface(12, &bn, &imp_md);
        let cas = interface(100, &cn, &cas_md);
        let table = critical_speeds(&imp, &cas, &CriterionOptions::default()).unwrap();
        assert_eq!(table.len(), 2, "{table:?}");
        for row in &table {
            assert_eq!(row.impeller_nodal_diameter, 2);
            let n = row.nodal_diameter as f64;
            let r = quad_roots(a, b, n, wc)[0];
            assert_relative_eq!(row.omega_rad_s, r, max_relative = 1e-8);
        }
        let opts = CriterionOptions {
            max_nodal_diameter: Some(12),
            ..Default::default()
        };
        let table = critical_speeds(&imp, &cas, &opts).unwrap();
        assert_eq!(table.len(), 1);
        assert_eq!(table[0].nodal_diameter, 10);
        assert_eq!(aliased_nodal_diameter(14, 12), 2);
        assert_eq!(aliased_nodal_diameter(10, 12), 2);
        assert_eq!(aliased_nodal_diameter(12, 12), 0);
        assert_eq!(aliased_nodal_diameter(6, 12), 6);
    }

    #[test]
    fn cubic_spline_beats_linear_on_smooth_branch() {
        // ω_b = sqrt(ω0² + c Ω²) (centrifugal stiffening); exact root of
        // n Ω − ω_b = ω_c from (n² − c) Ω² − 2 n ω_c Ω + ω_c² − ω0² = 0.
        let (w0, c, n, wc) = (TAU * 400.0, 4.0, 5.0, TAU * 150.0);
        let grid: Vec<f64> = (0..=8).map(|i| 250.0 * i as f64).collect();
        let freqs: Vec<Vec<f64>> = grid
            .iter()
            .map(|w| vec![(w0 * w0 + c * w * w).sqrt()])
            .collect();
        let imp_md = vec![modal(5, &grid, &freqs)];
        let cas_md = vec![modal(5, &[0.0], &[vec![wc]])];
        let (bn, cn) = (blade_nodes(), casing_nodes());
        let imp = interface(20, &bn, &imp_md);
        let cas = interface(100, &cn, &cas_md);
        let qa = n * n - c;
        let qb = -2.0 * n * wc;
        let qc = wc * wc - w0 * w0;
        let exact = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
        assert!(exact < 2000.0);
        let err = |interp| {
            let opts = CriterionOptions {
                interpolation: interp,
                ..Default::default()
            };
            let t = critical_speeds(&imp, &cas, &opts).unwrap();
            assert_eq!(t.len(), 1);
            ((t[0].omega_rad_s - exact) / exact).abs()
        };
        let (el, ec) = (err(Interpolation::Linear), err(Interpolation::CubicSpline));
        assert!(ec < 1e-4 && ec < 0.25 * el, "linear {el:e}, cubic {ec:e}");
    }

    #[test]
    fn engine_order_crossings_rigid_two_lobe_casing() {
        // 12 blades, 2 lobes: E = 2, 4, ..., 24 excite ND 2, 4, 6, 4, 2, 0, 2, ...
        let grid = [0.0, 3000.0];
        let (a, b) = (TAU * 1000.0, 2e-4);
        let freqs: Vec<Vec<f64>> = grid.iter().map(|w| vec![a + b * w * w]).collect();
        let imp_md: Vec<ModalData> = [0, 2, 4, 6]
            .iter()
            .map(|&k| modal(k, &grid, &freqs))
            .collect();
        let out = engine_order_crossings(&imp_md, 12, 2, 24, &CriterionOptions::default()).unwrap();
        for x in &out {
            let e = x.engine_order as f64;
            assert_eq!(x.engine_order % 2, 0);
            assert_eq!(x.nodal_diameter, aliased_nodal_diameter(x.engine_order, 12));
            // E Ω = a + b Ω²: the smaller root (the larger is beyond the grid).
            let r = (e - (e * e - 4.0 * a * b).sqrt()) / (2.0 * b);
            assert_relative_eq!(x.omega_rad_s, r, max_relative = 1e-8);
            assert_relative_eq!(x.frequency_hz, e * r / TAU, max_relative = 1e-12);
        }
        // E Ω = a + b Ω² has real roots only for E² ≥ 4ab (E ≥ 4.98), and the smaller
        // root lies inside the grid when it is ≤ 3000: E ≥ a/3000 + 3000 b = 2.69.
        let expected: Vec<usize> = (2..=24)
            .step_by(2)
            .filter(|&e| (e * e) as f64 >= 4.0 * a * b)
            .collect();
        let mut got: Vec<usize> = out.iter().map(|x| x.engine_order).collect();
        got.sort();
        assert_eq!(got, expected);
        let e12 = out.iter().find(|x| x.engine_order == 12).unwrap();
        assert_eq!(e12.nodal_diameter, 0);
    }

    #[test]
    fn compatibility_identical_and_phase_invariant() {
        let (cr, cz) = ((0.20, 0.25), (0.0, 0.05));
        let cn = casing_nodes();
        let bn = blade_nodes();
        let nrm = normal_of(cr, cz);
        let lobes = 5;
        // Profile affine in s: both linear interpolations are exact ⇒ score 1.
        let f = |t: f64| 1.0 + 2.0 * t;
        let (cre, cim) = shape(&cn, nrm, lobes, 0.0, f);
        let (bre, bim) = shape(&bn, nrm, lobes, 1.234, f);
        let cl = ContactLine::new("casing", &cn).unwrap();
        let bl = ContactLine::new("impeller", &bn).unwrap();
        let pc = cl.profile(&cre, &cim, lobes, false);
        let pb = bl.profile(&bre, &bim, lobes, false);
        assert_relative_eq!(compatibility(&pb, &pc, 201), 1.0, max_relative = 1e-12);
        // Smooth profile on different node sets: close to 1.
        let g = |t: f64| (std::f64::consts::PI * t).sin() + 0.3;
        let pc = cl.profile(
            &shape(&cn, nrm, lobes, 0.0, g).0,
            &shape(&cn, nrm, lobes, 0.0, g).1,
            lobes,
            false,
        );
        let (gre, gim) = shape(&bn, nrm, lobes, -0.4, g);
        let pb = bl.profile(&gre, &gim, lobes, false);
        let score = compatibility(&pb, &pc, 201);
        assert!(score > 0.99 && score <= 1.0, "{score}");
        // Without referring the leaned blade nodes to the lobe phase, the score drops: the
        // correction matters (5 lobes × 0.06 rad of lean).
        let pb_wrong = bl.profile(&gre, &gim, 0, false);
        assert!(compatibility(&pb_wrong, &pc, 201) < score);
    }

    #[test]
    fn compatibility_le_vs_te_localised_is_small() {
        let (cr, cz) = ((0.20, 0.25), (0.0, 0.05));
        let nrm = normal_of(cr, cz);
        let cn = line(11, cr, cz, |_| 0.0);
        let bn = line(11, (0.1995, 0.2495), cz, |_| 0.0);
        let le = |t: f64| (-(t / 0.15).powi(2)).exp();
        let te = |t: f64| (-((1.0 - t) / 0.15).powi(2)).exp();
        let imp_shape = shape(&bn, nrm, 5, 0.0, le);
        let cas_shape = shape(&cn, nrm, 5, 0.0, te);
        let imp_md = vec![ModalData {
            shapes_re: vec![vec![imp_shape.0.clone()]; 2],
            shapes_im: vec![vec![imp_shape.1.clone()]; 2],
            ..modal(5, &[0.0, 2000.0], &[vec![TAU * 100.0], vec![TAU * 100.0]])
        }];
        let cas_md = vec![ModalData {
            shapes_re: vec![vec![cas_shape.0.clone()]],
            shapes_im: vec![vec![cas_shape.1.clone()]],
            ..modal(5, &[0.0], &[vec![TAU * 50.0]])
        }];
        let imp = interface(20, &bn, &imp_md);
        let cas = interface(100, &cn, &cas_md);
        let t = critical_speeds(&imp, &cas, &CriterionOptions::default()).unwrap();
        assert_eq!(t.len(), 1);
        assert_relative_eq!(t[0].omega_rad_s, TAU * 150.0 / 5.0, max_relative = 1e-8);
        let score = t[0].compatibility.unwrap();
        assert!(score < 1e-2, "{score}");
        // Same shapes on both sides: compatible.
        let cas_md2 = vec![ModalData {
            shapes_re: vec![vec![shape(&cn, nrm, 5, 0.0, le).0]],
            shapes_im: vec![vec![shape(&cn, nrm, 5, 0.0, le).1]],
            ..modal(5, &[0.0], &[vec![TAU * 50.0]])
        }];
        let cas2 = InterfaceModes {
            modal_data: &cas_md2,
            ..cas
        };
        let t = critical_speeds(&imp, &cas2, &CriterionOptions::default()).unwrap();
        assert_relative_eq!(t[0].compatibility.unwrap(), 1.0, max_relative = 1e-9);
    }

    #[test]
    fn rejects_bad_data() {
        let (bn, cn) = (blade_nodes(), casing_nodes());
        let bad = vec![modal(3, &[0.0, 0.0], &[vec![1.0], vec![1.0]])];
        let cas_md = vec![modal(3, &[0.0], &[vec![1.0]])];
        let imp = interface(12, &bn, &bad);
        let cas = interface(100, &cn, &cas_md);
        assert!(matches!(
            critical_speeds(&imp, &cas, &CriterionOptions::default()),
            Err(InteractionError::BadGrid {
                which: "impeller",
                k: 3,
                ..
            })
        ));
        let good = vec![modal(3, &[0.0, 1.0], &[vec![1.0], vec![f64::NAN]])];
        let imp = InterfaceModes {
            modal_data: &good,
            ..imp
        };
        assert!(matches!(
            critical_speeds(&imp, &cas, &CriterionOptions::default()),
            Err(InteractionError::BadFrequencies { .. })
        ));
        let mut dup = casing_nodes();
        dup[1].row = 0;
        let ok = vec![modal(3, &[0.0, 1.0], &[vec![1.0], vec![1.0]])];
        let imp = InterfaceModes {
            modal_data: &ok,
            ..imp
        };
        let cas = InterfaceModes {
            contact_nodes: &dup,
            ..cas
        };
        assert!(matches!(
            critical_speeds(&imp, &cas, &CriterionOptions::default()),
            Err(InteractionError::DuplicateRow {
                which: "casing",
                ..
            })
        ));
        assert!(engine_order_crossings(&ok, 0, 2, 10, &CriterionOptions::default()).is_err());
        assert!(engine_order_crossings(&ok, 12, 0, 10, &CriterionOptions::default()).is_err());
    }
}
