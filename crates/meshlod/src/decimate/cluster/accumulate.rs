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
    #[inline(always)]
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
    #[inline(always)]
    fn from_parts(p: [[f64; 3]; 3], c: [f64; 3], len: f64, inv: f64) -> Self {
        // `len > 0 && len < ∞` written so that it stays two comparisons (as a
        // class test it compiles to some twenty integer instructions): a positive
        // length has a positive inverse unless it is infinite.
        if len > 0.0 && inv > 0.0 {
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
#[inline(always)]
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
#[inline(always)]
pub(crate) fn prepare_block(
    n: usize,
    mut corners: impl FnMut(usize) -> [[f32; 3]; 3],
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
#[inline(always)]
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
        _ => clamp(regularised_minimum(q, mean)),
    };
    let err = q.distance(q.evaluate(x));
    (x, Some(err))
}

/// The regularisation weight of [`regularised_minimum`], relative to `tr(A)`.
const REGULARISATION: f64 = 3e-3;

/// The fallback of an ill-conditioned cell: the minimiser of `Δ(x) + λ‖x − c‖²`
/// with `λ = 3·10⁻³·tr(A)` (a Tikhonov-regularised solve toward the cell's mean `c`):
/// `(A + λI) y = −(A c + b)`, `x = c + y`, one 3×3 solve by cofactors, always
/// positive definite.
///
/// Along an eigenvector of `A` with eigenvalue `l` the point takes the fraction
/// `l / (l + λ)` of the full step: all of it where `A` is well determined, none
/// where it is flat. It is the smooth form of Lindstrom's pseudo-inverse rule
/// (which drops eigenvalues below 10⁻³ of the largest), without eigenvectors.
/// `tr(A)` is the cell's area, so `λ‖x − c‖²` prices a move along the surface at
/// `3·10⁻³` of a move off it: 10⁻³ let the noise of scanned, nearly flat cells
/// (their small eigenvalues are noise, not shape) pull the point toward the cell's
/// border, 10⁻² rounded off real creases; 2–5·10⁻³ all gave the same gains.
/// Returns `c` when the quadric is zero or not finite.
fn regularised_minimum(q: &Quadric, c: [f64; 3]) -> [f64; 3] {
    let m = &q.m;
    let l = REGULARISATION * (m[0] + m[4] + m[7]);
    let (a00, a01, a02) = (m[0] + l, m[1], m[2]);
    let (a11, a12, a22) = (m[4] + l, m[5], m[7] + l);
    let c00 = a11 * a22 - a12 * a12;
    let c01 = a02 * a12 - a01 * a22;
    let c02 = a01 * a12 - a02 * a11;
    let det = a00 * c00 + a01 * c01 + a02 * c02;
    if !(det > 0.0 && det.is_finite()) {
        return c;
    }
    let c11 = a00 * a22 - a02 * a02;
    let c12 = a01 * a02 - a00 * a12;
    let c22 = a00 * a11 - a01 * a01;
    // The residual at the mean (the quadric's own A, not the regularised one).
    let r = [
        m[0] * c[0] + m[1] * c[1] + m[2] * c[2] + m[3],
        m[1] * c[0] + m[4] * c[1] + m[5] * c[2] + m[6],
        m[2] * c[0] + m[5] * c[1] + m[7] * c[2] + m[8],
    ];
    let inv = 1.0 / det;
    let x = [
        c[0] - (c00 * r[0] + c01 * r[1] + c02 * r[2]) * inv,
        c[1] - (c01 * r[0] + c11 * r[1] + c12 * r[2]) * inv,
        c[2] - (c02 * r[0] + c12 * r[1] + c22 * r[2]) * inv,
    ];
    if x.iter().all(|v| v.is_finite()) {
        x
    } else {
        c
    }
}

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

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

    /// A crease (triangles in the planes z = 0.3 and y = 0.6, rank 2, so the plain
    /// solve refuses): the regularised fallback lands on the crease line to within
    /// 1% of the mean's distance from it (λ = 3·10⁻³·tr(A) over the smaller
    /// eigenvalue), and along the line (the flat direction) keeps the mean's x
    /// exactly.
    #[test]
    fn crease_cell_lands_on_the_crease() {
        let mut acc = [Acc::default()];
        let tris = [
            [[0.1f32, 0.6, 0.3], [0.9, 0.6, 0.3], [0.5, 0.1, 0.3]],
            [[0.2, 0.6, 0.3], [0.7, 0.6, 0.3], [0.4, 0.6, 0.9]],
        ];
        for tri in &tris {
            let t = Prepared::new(tri, [0.0; 3]);
            add_triangle::<true>(&mut acc, 0, [0; 3], &t, [t.area; 3]);
        }
        let q = local_quadric(&acc[0], [0.0; 3]);
        let mean = acc[0].wsum.map(|x| x / acc[0].w);
        assert!(q.solve(mean, DEFAULT_CONDITION).is_none());
        let (x, err) = representative(&acc[0], [0.0; 3], 1.0, Representative::Quadric);
        let (y, z) = (f64::from(0.6f32), f64::from(0.3f32));
        let off = (mean[1] - y).abs().max((mean[2] - z).abs());
        assert!(off > 0.05, "{mean:?}");
        assert!((x[1] - y).abs() < 1e-2 * off, "{x:?}");
        assert!((x[2] - z).abs() < 1e-2 * off, "{x:?}");
        assert!((x[0] - mean[0]).abs() < 1e-12, "{x:?} vs {mean:?}");
        assert!(err.unwrap() < 1e-2 * off, "{err:?}");
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
