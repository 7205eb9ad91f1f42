//! Exact closest point on a triangle, by Voronoi regions.
//!
//! The plane of triangle `abc` is divided into seven Voronoi regions: three vertex
//! regions, three edge regions and the face. The query point's barycentric-style dot
//! products decide the region; the closest point is then the vertex, the projection on
//! the edge, or the projection on the plane. This is the classic test order described
//! in Ericson, *Real-Time Collision Detection* (2005), §5.1.5, written here in f64.
//! Degenerate triangles (zero area) fall into an edge or vertex region naturally.

/// A 3-vector in f64.
pub type V3 = [f64; 3];

#[inline]
pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
fn add_scaled(a: V3, s: f64, d: V3) -> V3 {
    [a[0] + s * d[0], a[1] + s * d[1], a[2] + s * d[2]]
}

/// Squared Euclidean distance.
#[inline]
#[must_use]
pub fn dist2(a: V3, b: V3) -> f64 {
    let d = sub(a, b);
    dot(d, d)
}

/// Which Voronoi region of the triangle the closest point lies in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    /// A corner: 0 = a, 1 = b, 2 = c.
    Vertex(u8),
    /// An edge: 0 = ab, 1 = bc, 2 = ca.
    Edge(u8),
    /// The interior of the face.
    Face,
}

/// Closest point to `p` on triangle `(a, b, c)` and the region it lies in.
#[must_use]
#[inline(always)]
pub fn closest_point(p: V3, a: V3, b: V3, c: V3) -> (V3, Region) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Region::Vertex(0));
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Region::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    // Each edge's denominator is its squared length: zero only when two corners
    // coincide, which the degenerate path below handles (0/0 would give NaN).
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 - d3 > 0.0 {
        let t = d1 / (d1 - d3);
        return (add_scaled(a, t, ab), Region::Edge(0));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Region::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 - d6 > 0.0 {
        let t = d2 / (d2 - d6);
        return (add_scaled(a, t, ac), Region::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 && (d4 - d3) + (d5 - d6) > 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add_scaled(b, t, sub(c, b)), Region::Edge(1));
    }
    let denom = va + vb + vc;
    if denom <= 0.0 || !denom.is_finite() {
        // Degenerate (zero area) triangle that slipped through: best of its edges.
        return closest_on_degenerate(p, a, b, c);
    }
    let v = vb / denom;
    let w = vc / denom;
    (
        [
            a[0] + ab[0] * v + ac[0] * w,
            a[1] + ab[1] * v + ac[1] * w,
            a[2] + ab[2] * v + ac[2] * w,
        ],
        Region::Face,
    )
}

/// Closest point on a segment `ab` and its parameter in `[0, 1]`.
#[must_use]
pub fn closest_on_segment(p: V3, a: V3, b: V3) -> (V3, f64) {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    if len2 <= 0.0 {
        return (a, 0.0);
    }
    let t = (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0);
    (add_scaled(a, t, ab), t)
}

fn closest_on_degenerate(p: V3, a: V3, b: V3, c: V3) -> (V3, Region) {
    let cands = [
        (closest_on_segment(p, a, b).0, Region::Edge(0)),
        (closest_on_segment(p, b, c).0, Region::Edge(1)),
        (closest_on_segment(p, c, a).0, Region::Edge(2)),
    ];
    let mut best = cands[0];
    for c in &cands[1..] {
        if dist2(p, c.0) < dist2(p, best.0) {
            best = *c;
        }
    }
    best
}

/// Barycentric weights of `q` (a point of the triangle's plane) in `(a, b, c)`,
/// clamped to the triangle; a degenerate triangle gives the nearest corner's weights.
#[must_use]
pub(crate) fn barycentric(q: V3, a: V3, b: V3, c: V3) -> [f64; 3] {
    let (v0, v1, v2) = (sub(b, a), sub(c, a), sub(q, a));
    let (d00, d01, d11) = (dot(v0, v0), dot(v0, v1), dot(v1, v1));
    let (d20, d21) = (dot(v2, v0), dot(v2, v1));
    let den = d00 * d11 - d01 * d01;
    if den > 1e-300 && den > 1e-14 * d00 * d11 {
        let v = (d11 * d20 - d01 * d21) / den;
        let w = (d00 * d21 - d01 * d20) / den;
        let mut x = [1.0 - v - w, v, w].map(|x| x.max(0.0));
        let s: f64 = x.iter().sum();
        if s > 0.0 {
            x = x.map(|y| y / s);
            return x;
        }
    }
    // Degenerate: the nearest corner.
    let d = [dist2(q, a), dist2(q, b), dist2(q, c)];
    let k = (0..3).fold(0, |m, i| if d[i] < d[m] { i } else { m });
    let mut w = [0.0; 3];
    w[k] = 1.0;
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The triangle a=(0,0,0), b=(2,0,0), c=(0,2,0) in the z=0 plane:
    /// ```text
    ///  y
    ///  2 c
    ///    | \
    ///    |   \
    ///  0 a----b  x
    ///    0    2
    /// ```
    const A: V3 = [0.0, 0.0, 0.0];
    const B: V3 = [2.0, 0.0, 0.0];
    const C: V3 = [0.0, 2.0, 0.0];

    fn check(p: V3, want: V3, region: Region) {
        let (q, r) = closest_point(p, A, B, C);
        assert_eq!(r, region, "region of {p:?}");
        assert!(dist2(q, want) < 1e-24, "{p:?} -> {q:?}, want {want:?}");
    }

    #[test]
    fn every_voronoi_region() {
        check([-1.0, -1.0, 3.0], A, Region::Vertex(0));
        check([3.0, -1.0, -2.0], B, Region::Vertex(1));
        check([-0.5, 3.0, 1.0], C, Region::Vertex(2));
        check([1.0, -1.0, 5.0], [1.0, 0.0, 0.0], Region::Edge(0));
        check([2.0, 2.0, -1.0], [1.0, 1.0, 0.0], Region::Edge(1));
        check([-3.0, 1.5, 0.0], [0.0, 1.5, 0.0], Region::Edge(2));
        check([0.5, 0.5, 7.0], [0.5, 0.5, 0.0], Region::Face);
    }

    #[test]
    fn agrees_with_dense_sampling() {
        // Brute force: the closest of a fine barycentric grid is never closer than the
        // exact answer, and is within the grid spacing of it.
        let tris = [
            (A, B, C),
            ([0.3, -1.0, 2.0], [1.5, 0.7, -0.4], [-0.8, 0.2, 0.9]),
            ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]), // degenerate
            // Two corners coinciding, each pair in turn (an edge of zero length:
            // its parameter would be 0/0).
            ([0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [2.0, 1.0, 0.5]),
            ([0.5, 0.5, 0.0], [2.0, 1.0, 0.5], [0.5, 0.5, 0.0]),
            ([2.0, 1.0, 0.5], [0.5, 0.5, 0.0], [0.5, 0.5, 0.0]),
        ];
        let mut s = 12345u64;
        let mut rnd = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 6.0 - 3.0
        };
        for &(a, b, c) in &tris {
            for _ in 0..200 {
                let p = [rnd(), rnd(), rnd()];
                let (q, _) = closest_point(p, a, b, c);
                let exact = dist2(p, q).sqrt();
                let n = 60;
                let mut best = f64::INFINITY;
                for i in 0..=n {
                    for j in 0..=(n - i) {
                        let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                        let x = [
                            a[0] + (b[0] - a[0]) * u + (c[0] - a[0]) * v,
                            a[1] + (b[1] - a[1]) * u + (c[1] - a[1]) * v,
                            a[2] + (b[2] - a[2]) * u + (c[2] - a[2]) * v,
                        ];
                        best = best.min(dist2(p, x).sqrt());
                    }
                }
                assert!(exact <= best + 1e-12, "exact {exact} > sampled {best}");
                assert!(best - exact < 0.1, "exact {exact} far below sampled {best}");
            }
        }
    }
}
