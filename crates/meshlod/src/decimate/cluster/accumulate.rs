//! What a cell accumulates from the triangles that touch it, and the representative
//! point computed from it.
//!
//! Every cell sums, **in triangle order**, the contributions of the triangles with a
//! corner in it. Both the in-memory path (parallel over ranges of cells) and the
//! streaming path (sequential) add the same contributions in the same order, so
//! they produce bit-identical sums whatever the thread count.

use super::Representative;
use crate::quadric::{Quadric, DEFAULT_CONDITION};

/// The smallest corner weight: a zero weight (a zero-area triangle, a zero user
/// weight) counts as this, so a cell whose corners all weigh zero gets their plain
/// mean, while against any real weight it vanishes (for areas above ~10⁻¹³⁴ it is
/// below their rounding).
pub(crate) const MIN_WEIGHT: f64 = 1e-150;

/// A triangle prepared once: corners relative to the grid origin (f64), its area,
/// and its area-weighted plane quadric `A·(n, d)(n, d)ᵀ` in the grid frame (origin
/// at the grid origin), the 10 entries in the order of [`Quadric::m`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Prepared {
    pub p: [[f64; 3]; 3],
    pub area: f64,
    pub q: [f64; 10],
}

impl Prepared {
    /// A zero-area triangle at the origin (a placeholder).
    pub const ZERO: Self = Self {
        p: [[0.0; 3]; 3],
        area: 0.0,
        q: [0.0; 10],
    };

    /// Prepares the triangle `corners` for a grid at `origin`.
    #[inline]
    pub fn new(corners: &[[f32; 3]; 3], origin: [f64; 3]) -> Self {
        let (p, c, len2) = cross(corners, origin);
        let len = len2.sqrt();
        Self::from_parts(p, c, len, 1.0 / len)
    }

    /// The rest of [`Self::new`] from the corners, the cross product `c` of the
    /// edges, its length and the inverse of its length.
    ///
    /// With `n = c/|c|`, `d = −n·p₀` and area `|c|/2`, the quadric entries are
    /// `A nᵢnⱼ = s cᵢcⱼ`, `A nᵢd = s cᵢe` and `A d² = s e²` where `s = 1/(2|c|)`
    /// and `e = −c·p₀`: one division for all.
    #[inline]
    fn from_parts(p: [[f64; 3]; 3], c: [f64; 3], len: f64, inv: f64) -> Self {
        if len > 0.0 && len.is_finite() {
            let s = 0.5 * inv;
            let e = -(c[0] * p[0][0] + c[1] * p[0][1] + c[2] * p[0][2]);
            let sc = c.map(|x| s * x);
            Self {
                p,
                area: 0.5 * len,
                q: [
                    sc[0] * c[0],
                    sc[0] * c[1],
                    sc[0] * c[2],
                    sc[0] * e,
                    sc[1] * c[1],
                    sc[1] * c[2],
                    sc[1] * e,
                    sc[2] * c[2],
                    sc[2] * e,
                    s * e * e,
                ],
            }
        } else {
            Self { p, ..Self::ZERO }
        }
    }
}

/// Triangles per block of [`prepare_block`].
pub(crate) const BLOCK: usize = 64;

/// The corners relative to `origin`, the cross product of the edges and its squared
/// length.
#[inline]
fn cross(corners: &[[f32; 3]; 3], origin: [f64; 3]) -> ([[f64; 3]; 3], [f64; 3], f64) {
    let p = corners.map(|c| std::array::from_fn(|k| f64::from(c[k]) - origin[k]));
    let e1 = sub(p[1], p[0]);
    let e2 = sub(p[2], p[0]);
    let c = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    (p, c, c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
}

/// A block of up to [`BLOCK`] triangles between [`prepare_block`] and their
/// [`Self::plane`]s: corners, cross products, their lengths and inverse lengths.
pub(crate) struct Block {
    p: [[[f64; 3]; 3]; BLOCK],
    c: [[f64; 3]; BLOCK],
    len: [f64; BLOCK],
    inv: [f64; BLOCK],
}

impl Block {
    /// An empty block.
    pub fn new() -> Self {
        Self {
            p: [[[0.0; 3]; 3]; BLOCK],
            c: [[0.0; 3]; BLOCK],
            len: [0.0; BLOCK],
            inv: [0.0; BLOCK],
        }
    }

    /// The prepared triangle `i`: [`Prepared::new`] bit for bit (computed where it
    /// is added, so that it stays in registers).
    #[inline(always)]
    pub fn plane(&self, i: usize) -> Prepared {
        Prepared::from_parts(self.p[i], self.c[i], self.len[i], self.inv[i])
    }
}

/// The first half of [`Prepared::new`] on `n ≤ BLOCK` triangles, `corners(i)` for
/// `i < n`, into `out` (then [`Block::plane`]): the square roots and divisions in
/// loops of their own so that they pipeline (and vectorise).
#[inline]
pub(crate) fn prepare_block(
    n: usize,
    corners: impl Fn(usize) -> [[f32; 3]; 3],
    origin: [f64; 3],
    out: &mut Block,
) {
    let n = n.min(BLOCK);
    for i in 0..n {
        let (p, ci, l2) = cross(&corners(i), origin);
        out.p[i] = p;
        out.c[i] = ci;
        out.len[i] = l2;
    }
    for l in &mut out.len[..n] {
        *l = l.sqrt();
    }
    for (v, l) in out.inv[..n].iter_mut().zip(&out.len[..n]) {
        *v = 1.0 / *l;
    }
}

/// The sums of one cell (120 bytes).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Acc {
    /// Σ of the area-weighted plane quadrics ([`Prepared::q`], grid frame) of the
    /// triangles touching the cell, once per triangle; only filled for
    /// [`Representative::Quadric`].
    pub q: [f64; 10],
    /// Σ of their areas (the quadric's weight).
    pub qw: f64,
    /// Σ wᵢ pᵢ over the corners in the cell (relative to the grid origin), each
    /// weight at least [`MIN_WEIGHT`].
    pub wsum: [f64; 3],
    /// Σ wᵢ (positive for every cell that has a corner).
    pub w: f64,
}

impl Acc {
    /// Adds a triangle's plane quadric.
    #[inline(always)]
    pub fn add_plane(&mut self, t: &Prepared) {
        for i in 0..10 {
            self.q[i] += t.q[i];
        }
        self.qw += t.area;
    }

    /// Adds a corner `p` of weight `w`.
    #[inline(always)]
    pub fn add_corner(&mut self, p: [f64; 3], w: f64) {
        for j in 0..3 {
            self.wsum[j] += w * p[j];
        }
        self.w += w;
    }

    /// Adds three corners of one weight `w`.
    #[inline(always)]
    pub fn add_corners(&mut self, p: &[[f64; 3]; 3], w: f64) {
        for j in 0..3 {
            self.wsum[j] += w * (p[0][j] + p[1][j] + p[2][j]);
        }
        self.w += 3.0 * w;
    }
}

/// Adds triangle `t` with corner cells `c` and corner weights `w` to the cells
/// among `start .. start + accs.len()` (the in-memory workers own a range of cells;
/// the others pass 0 and all cells): each corner to its cell, the plane quadric
/// (when `QUADRIC`) once to each distinct cell (Lindstrom 2000), also when all three
/// corners share one cell (the triangle is dropped, but its plane still shapes the
/// cell's representative).
#[inline(always)]
pub(crate) fn add_triangle<const QUADRIC: bool>(
    accs: &mut [Acc],
    start: u32,
    c: [u32; 3],
    t: &Prepared,
    w: [f64; 3],
) {
    if c[0] == c[1] && c[1] == c[2] {
        if let Some(a) = accs.get_mut(c[0].wrapping_sub(start) as usize) {
            if QUADRIC {
                a.add_plane(t);
            }
            if w[0] == w[1] && w[1] == w[2] {
                a.add_corners(&t.p, w[0]);
            } else {
                for k in 0..3 {
                    a.add_corner(t.p[k], w[k]);
                }
            }
        }
        return;
    }
    for k in 0..3 {
        if let Some(a) = accs.get_mut(c[k].wrapping_sub(start) as usize) {
            let first = !((k >= 1 && c[k] == c[0]) || (k == 2 && c[2] == c[1]));
            if QUADRIC && first {
                a.add_plane(t);
            }
            a.add_corner(t.p[k], w[k]);
        }
    }
}

#[cfg(test)]
#[test]
fn blocks_prepare_bit_for_bit() {
    let tris: Vec<[[f32; 3]; 3]> = (0..100)
        .map(|i| {
            let f = i as f32;
            [
                [f.sin(), f.cos(), 0.3 * f],
                [f.cos() * 2.0, 1.0 + f, f.sin()],
                // Every tenth triangle is degenerate (a repeated corner).
                if i % 10 == 0 {
                    [f.sin(), f.cos(), 0.3 * f]
                } else {
                    [0.5, -f, 2.0]
                },
            ]
        })
        .collect();
    let origin = [-1.0, -2.0, 0.5];
    let mut out = Block::new();
    prepare_block(tris.len() - BLOCK, |i| tris[BLOCK + i], origin, &mut out);
    for i in 0..tris.len() - BLOCK {
        let a = Prepared::new(&tris[BLOCK + i], origin);
        let b = out.plane(i);
        assert_eq!(
            (a.p, a.area.to_bits(), a.q.map(f64::to_bits)),
            (b.p, b.area.to_bits(), b.q.map(f64::to_bits)),
            "triangle {i}"
        );
    }
}

/// The quadric of `acc` moved to the frame whose origin is `k` (the cell's minimum
/// corner, relative to the grid origin): for `x = y + k`, `b' = b + A k` and
/// `c' = c + (b + b')·k`.
pub(crate) fn local_quadric(acc: &Acc, k: [f64; 3]) -> Quadric {
    let m = &acc.q;
    let ak = [
        m[0] * k[0] + m[1] * k[1] + m[2] * k[2],
        m[1] * k[0] + m[4] * k[1] + m[5] * k[2],
        m[2] * k[0] + m[5] * k[1] + m[7] * k[2],
    ];
    let b = [m[3] + ak[0], m[6] + ak[1], m[8] + ak[2]];
    let c = m[9] + (m[3] + b[0]) * k[0] + (m[6] + b[1]) * k[1] + (m[8] + b[2]) * k[2];
    Quadric {
        m: [m[0], m[1], m[2], b[0], m[4], m[5], b[1], m[7], b[2], c],
        weight: acc.qw,
    }
}

/// The representative of a cell, in the cell's local frame, and its error: for the
/// quadric representative the area-weighted RMS distance to the cell's planes
/// ([`Quadric::distance`]), otherwise `None`.
pub(crate) fn representative(
    acc: &Acc,
    corner: [f64; 3],
    cell: f64,
    how: Representative,
) -> ([f64; 3], Option<f64>) {
    let mean = if acc.w > 0.0 {
        acc.wsum.map(|x| x / acc.w)
    } else {
        std::array::from_fn(|k| corner[k] + 0.5 * cell)
    };
    let clamp = |p: [f64; 3]| -> [f64; 3] { p.map(|v| v.clamp(0.0, cell)) };
    let mean = clamp(std::array::from_fn(|k| mean[k] - corner[k]));
    if how != Representative::Quadric || acc.qw <= 0.0 {
        let err = (how == Representative::Quadric).then_some(0.0);
        return (mean, err);
    }
    let q = &local_quadric(acc, corner);
    let inside = |x: &[f64; 3]| x.iter().all(|&v| (0.0..=cell).contains(&v));
    let x = match q.solve(mean, DEFAULT_CONDITION) {
        Some(x) if inside(&x) => x,
        _ => clamp(pseudo_inverse_minimum(q, mean)),
    };
    let err = q.distance(q.evaluate(x));
    (x, Some(err))
}

/// Lindstrom's rank-deficient minimiser: `x = c − A⁺ (A c + b)`, with the
/// pseudo-inverse `A⁺` dropping eigenvalues below `10⁻³` of the largest, so that
/// along flat directions the point stays at `c` (the cell's mean).
fn pseudo_inverse_minimum(q: &Quadric, c: [f64; 3]) -> [f64; 3] {
    let m = &q.m;
    let a = [[m[0], m[1], m[2]], [m[1], m[4], m[5]], [m[2], m[5], m[7]]];
    let r: [f64; 3] = std::array::from_fn(|i| {
        a[i][0] * c[0] + a[i][1] * c[1] + a[i][2] * c[2] + [m[3], m[6], m[8]][i]
    });
    if let Some(x) = closed_form_minimum(&a, r, c) {
        return x;
    }
    let (values, vectors) = eigen_symmetric(a);
    let top = values.iter().fold(0.0f64, |acc, &v| acc.max(v.abs()));
    if !(top > 0.0 && top.is_finite()) {
        return c;
    }
    let mut x = c;
    for (i, &l) in values.iter().enumerate() {
        if l > 1e-3 * top {
            let v = [vectors[0][i], vectors[1][i], vectors[2][i]];
            let s = (v[0] * r[0] + v[1] * r[1] + v[2] * r[2]) / l;
            for k in 0..3 {
                x[k] -= s * v[k];
            }
        }
    }
    if x.iter().all(|v| v.is_finite()) {
        x
    } else {
        c
    }
}

#[inline]
fn dot(u: [f64; 3], v: [f64; 3]) -> f64 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

#[inline]
fn cross3(u: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// The eigenvalues of the symmetric `a`, largest first, in closed form (the
/// trigonometric solution of the characteristic cubic, Smith 1961); absolute error
/// about `10⁻¹⁵` of the largest.
fn eigenvalues(a: &[[f64; 3]; 3]) -> Option<[f64; 3]> {
    let p1 = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    let q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    let d = [a[0][0] - q, a[1][1] - q, a[2][2] - q];
    let p2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * p1;
    if !(p2.is_finite() && q.is_finite()) {
        return None;
    }
    if p2 == 0.0 {
        return Some([q; 3]);
    }
    let p = (p2 / 6.0).sqrt();
    let b = [
        [d[0] / p, a[0][1] / p, a[0][2] / p],
        [a[1][0] / p, d[1] / p, a[1][2] / p],
        [a[2][0] / p, a[2][1] / p, d[2] / p],
    ];
    let r = (0.5 * dot(b[0], cross3(b[1], b[2]))).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let l1 = q + 2.0 * p * phi.cos();
    let l3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    Some([l1, 3.0 * q - l1 - l3, l3])
}

/// A unit vector spanning the null space of `a − λ I` for a simple eigenvalue `λ`:
/// the largest cross product of two of its rows.
fn eigenvector(a: &[[f64; 3]; 3], l: f64) -> Option<[f64; 3]> {
    let row =
        |i: usize| -> [f64; 3] { std::array::from_fn(|j| a[i][j] - if i == j { l } else { 0.0 }) };
    let (r0, r1, r2) = (row(0), row(1), row(2));
    let mut best = cross3(r0, r1);
    for x in [cross3(r0, r2), cross3(r1, r2)] {
        if dot(x, x) > dot(best, best) {
            best = x;
        }
    }
    let n = dot(best, best).sqrt();
    (n > 0.0 && n.is_finite()).then(|| best.map(|x| x / n))
}

/// `m⁻¹ v` by Cramer's rule (`None` for a zero or non-finite determinant).
fn solve3(m: &[[f64; 3]; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let det = dot(m[0], cross3(m[1], m[2]));
    if !(det != 0.0 && det.is_finite()) {
        return None;
    }
    let col = |i: usize| -> [f64; 3] { [m[0][i], m[1][i], m[2][i]] };
    let (c0, c1, c2) = (col(0), col(1), col(2));
    Some([
        dot(v, cross3(c1, c2)) / det,
        dot(c0, cross3(v, c2)) / det,
        dot(c0, cross3(c1, v)) / det,
    ])
}

/// [`pseudo_inverse_minimum`] without iterations, `x = c − A⁺ r`: eigenvalues in
/// closed form, then
/// - all three above the threshold: `A⁻¹ r`;
/// - two: with `v₃` the small eigenvector, `A⁺ r` solves
///   `(A + (λ₁ − λ₃) v₃v₃ᵀ) y = r − v₃ (v₃·r)` (a system with eigenvalues λ₁, λ₂,
///   λ₁);
/// - one (a flat cell, the common case): `v₁ (v₁·r) / λ₁`.
///
/// `None` when an eigenvector would be ill-determined (two eigenvalues within 1%
/// of each other across the threshold) or on non-finite values: the caller then
/// uses the Jacobi decomposition.
fn closed_form_minimum(a: &[[f64; 3]; 3], r: [f64; 3], c: [f64; 3]) -> Option<[f64; 3]> {
    let [l1, l2, l3] = eigenvalues(a)?;
    if !(l1 > 0.0 && l1.is_finite()) {
        return None;
    }
    let t = 1e-3 * l1;
    let y = if l3 > t {
        solve3(a, r)?
    } else if l2 > t {
        if l2 - l3 < 1e-2 * l2 {
            return None;
        }
        let v3 = eigenvector(a, l3)?;
        let k = l1 - l3;
        let m: [[f64; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| a[i][j] + k * v3[i] * v3[j]));
        let vr = dot(v3, r);
        solve3(&m, std::array::from_fn(|i| r[i] - vr * v3[i]))?
    } else {
        let v1 = eigenvector(a, l1)?;
        let s = dot(v1, r) / l1;
        v1.map(|x| s * x)
    };
    let x = [c[0] - y[0], c[1] - y[1], c[2] - y[2]];
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Eigenvalues and eigenvectors (columns of the returned matrix) of a symmetric 3×3
/// matrix by cyclic Jacobi rotations.
pub(crate) fn eigen_symmetric(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for (p, qq) in [(0usize, 1usize), (0, 2), (1, 2)] {
            let apq = a[p][qq];
            if apq == 0.0 {
                continue;
            }
            let theta = (a[qq][qq] - a[p][p]) / (2.0 * apq);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J for the rotation J in the (p, q) plane.
            for k in 0..3 {
                let akp = a[k][p];
                let akq = a[k][qq];
                a[k][p] = c * akp - s * akq;
                a[k][qq] = s * akp + c * akq;
            }
            for k in 0..3 {
                let apk = a[p][k];
                let aqk = a[qq][k];
                a[p][k] = c * apk - s * aqk;
                a[qq][k] = s * apk + c * aqk;
            }
            for row in &mut v {
                let vp = row[p];
                let vq = row[qq];
                row[p] = c * vp - s * vq;
                row[qq] = s * vp + c * vq;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_diagonalises() {
        let a = [[4.0, 1.0, 2.0], [1.0, 3.0, 0.5], [2.0, 0.5, 5.0]];
        let (l, v) = eigen_symmetric(a);
        for i in 0..3 {
            let x = [v[0][i], v[1][i], v[2][i]];
            for r in 0..3 {
                let ax = a[r][0] * x[0] + a[r][1] * x[1] + a[r][2] * x[2];
                assert!((ax - l[i] * x[r]).abs() < 1e-9, "{ax} vs {}", l[i] * x[r]);
            }
        }
        let trace: f64 = l.iter().sum();
        assert!((trace - 12.0).abs() < 1e-9);
    }

    /// The closed form gives the Jacobi decomposition's point for one, two and
    /// three eigenvalues above the threshold, and declines where an eigenvector is
    /// ill-determined.
    #[test]
    fn closed_form_matches_jacobi() {
        let n = [0.36f64, 0.48, 0.8];
        let u = [0.8f64, -0.6, 0.0];
        let w = cross3(n, u);
        let r = [0.3, -0.2, 0.5];
        let c = [0.1, 0.2, 0.3];
        for (l2, l3, expect) in [
            (0.0, 0.0, true),
            (1e-4, 0.0, true),
            (1e-4, 1e-5, true),
            (0.05, 0.0, true),
            (0.3, 1e-5, true),
            (0.01, 2e-4, true),
            (0.5, 0.2, true),
            (1.0, 1.0, true),
            (1.0005e-3, 0.9995e-3, false),
        ] {
            let a: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| n[i] * n[j] + l2 * u[i] * u[j] + l3 * w[i] * w[j])
            });
            let fast = closed_form_minimum(&a, r, c);
            assert_eq!(fast.is_some(), expect, "{l2} {l3}");
            if let Some(x) = fast {
                let (values, vectors) = eigen_symmetric(a);
                let top = values.iter().fold(0.0f64, |m, &v| m.max(v));
                let mut y = c;
                for (i, &l) in values.iter().enumerate() {
                    if l > 1e-3 * top {
                        let v = [vectors[0][i], vectors[1][i], vectors[2][i]];
                        let s = (v[0] * r[0] + v[1] * r[1] + v[2] * r[2]) / l;
                        for k in 0..3 {
                            y[k] -= s * v[k];
                        }
                    }
                }
                for k in 0..3 {
                    assert!((x[k] - y[k]).abs() < 1e-8, "{l2} {l3}: {x:?} vs {y:?}");
                }
            }
        }
    }

    /// A flat cell (all triangles in the plane z = 0.3 of a unit cell): the quadric is
    /// rank 1, so the representative keeps the mean's x and y and lands on the plane.
    #[test]
    fn flat_cell_projects_the_mean_onto_the_plane() {
        let mut acc = [Acc::default()];
        let tri = [[1.1, 2.1, 3.3], [1.9, 2.2, 3.3], [1.2, 2.7, 3.3]];
        let t = Prepared::new(&tri, [0.0; 3]);
        add_triangle::<true>(&mut acc, 0, [0; 3], &t, [t.area; 3]);
        let corner = [1.0, 2.0, 3.0];
        let (x, err) = representative(&acc[0], corner, 1.0, Representative::Quadric);
        assert!((x[2] + 3.0 - f64::from(3.3f32)).abs() < 1e-12, "{x:?}");
        assert!(
            (x[0] - 0.4).abs() < 1e-6 && (x[1] - 1.0 / 3.0).abs() < 1e-6,
            "{x:?}"
        );
        assert!(err.unwrap() < 1e-7, "{err:?}");
    }

    /// Three orthogonal planes meeting at (0.25, 0.5, 0.75): the corner is found.
    #[test]
    fn corner_cell_finds_the_corner() {
        let mut acc = [Acc::default()];
        let c = [0.25f32, 0.5, 0.75];
        let tris = [
            [c, [c[0] + 0.2, c[1], c[2]], [c[0], c[1] + 0.2, c[2]]],
            [c, [c[0], c[1] + 0.2, c[2]], [c[0], c[1], c[2] + 0.2]],
            [c, [c[0], c[1], c[2] + 0.2], [c[0] + 0.2, c[1], c[2]]],
        ];
        for tri in &tris {
            let t = Prepared::new(tri, [0.0; 3]);
            add_triangle::<true>(&mut acc, 0, [0; 3], &t, [1.0; 3]);
        }
        let (x, err) = representative(&acc[0], [0.0; 3], 1.0, Representative::Quadric);
        for k in 0..3 {
            assert!((x[k] - f64::from(c[k])).abs() < 1e-6, "{x:?}");
        }
        assert!(err.unwrap() < 1e-6);
        let (avg, _) = representative(&acc[0], [0.0; 3], 1.0, Representative::Average);
        assert!((avg[0] - (0.25 + 0.4 / 9.0)).abs() < 1e-6, "{avg:?}");
    }
}
