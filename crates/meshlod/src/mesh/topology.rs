//! Connectivity in flat arrays: point→triangles (CSR) and edge→triangles.
//!
//! Built on *points* (positions welded by [`super::Weld`]), so attribute seams are not
//! boundaries. Every array is a dense `Vec` indexed by `u32` ids, built in
//! O(n log n) by sorting edge keys; nothing is a per-element object.
//!
//! Definitions (the same as the shared meshes' `MANIFEST.md`):
//! - an *edge* is an unordered pair of distinct points that are consecutive in some
//!   triangle ([`Topology`] also lists the loop `{a,a}` of a degenerate triangle
//!   `a a b`, with that triangle twice on `{a,b}`; statistics skip loops and count each
//!   triangle once per edge);
//! - a *boundary edge* is used by exactly one triangle, a *non-manifold edge* by
//!   more than two;
//! - a *non-manifold point* lies on a non-manifold edge, or its triangles form more
//!   than one fan (a "bow-tie");
//! - *components* are the classes of points joined by edges (isolated points, used by
//!   no triangle, are not counted).

/// How a point's neighbourhood looks; decides what a simplifier may do with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VertexKind {
    /// Interior of a 2-manifold: one closed fan.
    Manifold,
    /// On an open boundary: one open fan with exactly two boundary edges.
    Border,
    /// Several wedges with different attributes share the position (an attribute
    /// seam). Topology classification alone never returns this; attribute-aware
    /// code refines `Manifold`/`Border` into `Seam`.
    Seam,
    /// Anything else: non-manifold edges, several fans, isolated.
    Complex,
    /// Never moved or removed (user lock mask).
    Locked,
}

/// Point-level connectivity of a triangle list.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Number of points (ids are `0..point_count`).
    pub point_count: usize,
    /// CSR offsets into [`Self::point_triangles`]: the triangles around point `p` are
    /// `point_triangles[point_offsets[p]..point_offsets[p + 1]]`.
    pub point_offsets: Vec<u32>,
    /// Triangle ids, grouped by point (a triangle appears once per distinct corner point).
    pub point_triangles: Vec<u32>,
    /// Unique undirected edges `[a, b]` with `a <= b`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// CSR offsets into [`Self::edge_triangles`], one more than `edges`.
    pub edge_offsets: Vec<u32>,
    /// Triangle ids using each edge (a triangle appears twice for an edge it uses twice).
    pub edge_triangles: Vec<u32>,
}

impl Topology {
    /// Builds the connectivity of `triangles`, whose entries are point ids below
    /// `point_count`.
    ///
    /// # Panics
    /// Panics if a triangle refers to a point `>= point_count` (validate first).
    #[must_use]
    pub fn build(triangles: &[[u32; 3]], point_count: usize) -> Self {
        // Point -> triangles, counting each distinct corner once.
        let mut counts = vec![0u32; point_count + 1];
        for t in triangles {
            for (k, &p) in t.iter().enumerate() {
                if !t[..k].contains(&p) {
                    counts[p as usize + 1] += 1;
                }
            }
        }
        for i in 0..point_count {
            counts[i + 1] += counts[i];
        }
        let point_offsets = counts;
        let mut fill = point_offsets.clone();
        let mut point_triangles = vec![0u32; *point_offsets.last().unwrap_or(&0) as usize];
        for (ti, t) in triangles.iter().enumerate() {
            for (k, &p) in t.iter().enumerate() {
                if !t[..k].contains(&p) {
                    let slot = &mut fill[p as usize];
                    point_triangles[*slot as usize] = ti as u32;
                    *slot += 1;
                }
            }
        }

        // Edges: sort (key, triangle) pairs.
        let mut keyed: Vec<(u64, u32)> = Vec::with_capacity(triangles.len() * 3);
        for (ti, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let (a, b) = if a <= b { (a, b) } else { (b, a) };
                keyed.push(((u64::from(a) << 32) | u64::from(b), ti as u32));
            }
        }
        keyed.sort_unstable();
        let mut edges = Vec::new();
        let mut edge_offsets = Vec::new();
        let mut edge_triangles = Vec::with_capacity(keyed.len());
        let mut prev = u64::MAX;
        for &(key, ti) in &keyed {
            if key != prev {
                edges.push([(key >> 32) as u32, key as u32]);
                edge_offsets.push(edge_triangles.len() as u32);
                prev = key;
            }
            edge_triangles.push(ti);
        }
        edge_offsets.push(edge_triangles.len() as u32);
        Self {
            point_count,
            point_offsets,
            point_triangles,
            edges,
            edge_offsets,
            edge_triangles,
        }
    }

    /// Triangles around point `p`.
    #[must_use]
    pub fn triangles_of_point(&self, p: u32) -> &[u32] {
        let p = p as usize;
        &self.point_triangles[self.point_offsets[p] as usize..self.point_offsets[p + 1] as usize]
    }

    /// Number of triangle sides on edge `e`.
    #[must_use]
    pub fn edge_valence(&self, e: usize) -> u32 {
        self.edge_offsets[e + 1] - self.edge_offsets[e]
    }

    /// Triangles on edge `e`.
    #[must_use]
    pub fn triangles_of_edge(&self, e: usize) -> &[u32] {
        &self.edge_triangles[self.edge_offsets[e] as usize..self.edge_offsets[e + 1] as usize]
    }

    /// Index of edge `{a, b}` in [`Self::edges`], by binary search.
    #[must_use]
    pub fn find_edge(&self, a: u32, b: u32) -> Option<usize> {
        let key = if a <= b { [a, b] } else { [b, a] };
        self.edges.binary_search(&key).ok()
    }

    /// Number of points with at least one triangle.
    #[must_use]
    pub fn referenced_points(&self) -> usize {
        (0..self.point_count)
            .filter(|&p| self.point_offsets[p + 1] > self.point_offsets[p])
            .count()
    }

    /// Number of fans (edge-connected classes of triangles) around point `p`, with
    /// triangles joined when they share an edge through `p`. A manifold or border
    /// point has one fan; a bow-tie has two or more.
    #[must_use]
    pub fn fan_count(&self, p: u32, triangles: &[[u32; 3]]) -> usize {
        let tris = self.triangles_of_point(p);
        if tris.len() <= 1 {
            return tris.len();
        }
        // (other point, local triangle index) pairs; equal other points join triangles.
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(tris.len() * 2);
        for (li, &t) in tris.iter().enumerate() {
            for &q in &triangles[t as usize] {
                if q != p {
                    pairs.push((q, li as u32));
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut parent: Vec<u32> = (0..tris.len() as u32).collect();
        fn find(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                parent[x as usize] = parent[parent[x as usize] as usize];
                x = parent[x as usize];
            }
            x
        }
        for w in pairs.windows(2) {
            if w[0].0 == w[1].0 {
                let (a, b) = (find(&mut parent, w[0].1), find(&mut parent, w[1].1));
                if a != b {
                    parent[a.max(b) as usize] = a.min(b);
                }
            }
        }
        (0..tris.len() as u32)
            .filter(|&i| find(&mut parent, i) == i)
            .count()
    }

    /// Classifies every point as [`VertexKind::Manifold`], [`VertexKind::Border`] or
    /// [`VertexKind::Complex`] (isolated points are `Complex`).
    #[must_use]
    pub fn classify(&self, triangles: &[[u32; 3]]) -> Vec<VertexKind> {
        let mut boundary_edges = vec![0u32; self.point_count];
        let mut bad = vec![false; self.point_count];
        for (e, &[a, b]) in self.edges.iter().enumerate() {
            let v = self.edge_valence(e);
            if a == b || v > 2 {
                bad[a as usize] = true;
                bad[b as usize] = true;
            } else if v == 1 {
                boundary_edges[a as usize] += 1;
                boundary_edges[b as usize] += 1;
            }
        }
        (0..self.point_count as u32)
            .map(|p| {
                let pi = p as usize;
                if bad[pi] || self.triangles_of_point(p).is_empty() {
                    return VertexKind::Complex;
                }
                if self.fan_count(p, triangles) != 1 {
                    return VertexKind::Complex;
                }
                match boundary_edges[pi] {
                    0 => VertexKind::Manifold,
                    2 => VertexKind::Border,
                    _ => VertexKind::Complex,
                }
            })
            .collect()
    }
}

/// Disjoint-set forest with path halving and union by smaller id (deterministic).
#[derive(Debug, Clone)]
pub struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    /// `n` singleton sets.
    #[must_use]
    pub fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
        }
    }

    /// Makes it `n` singleton sets again, reusing its storage.
    pub fn reset(&mut self, n: usize) {
        self.parent.clear();
        self.parent.extend(0..n as u32);
    }

    /// Representative of `x`'s set.
    pub fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let g = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = g;
            x = g;
        }
        x
    }

    /// Joins the sets of `a` and `b`; returns true if they were different.
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        self.parent[hi as usize] = lo;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing edge 1-2:
    /// ```text
    ///  0---1
    ///  | / |
    ///  2---3
    /// ```
    #[test]
    fn quad_edges_and_kinds() {
        let tris = [[0, 2, 1], [1, 2, 3]];
        let topo = Topology::build(&tris, 4);
        assert_eq!(topo.edges.len(), 5);
        let shared = topo.find_edge(2, 1).unwrap();
        assert_eq!(topo.edge_valence(shared), 2);
        assert_eq!(topo.triangles_of_point(1), &[0, 1]);
        assert!(topo
            .classify(&tris)
            .iter()
            .all(|&k| k == VertexKind::Border));
    }

    /// Two triangles touching at point 0 only (a bow-tie):
    /// ```text
    ///  1       3
    ///  | \   / |
    ///  |  0    |
    ///  | /   \ |
    ///  2       4
    /// ```
    #[test]
    fn bow_tie_is_complex() {
        let tris = [[0, 1, 2], [0, 3, 4]];
        let topo = Topology::build(&tris, 5);
        assert_eq!(topo.fan_count(0, &tris), 2);
        assert_eq!(topo.classify(&tris)[0], VertexKind::Complex);
        assert_eq!(topo.classify(&tris)[1], VertexKind::Border);
    }

    /// A tetrahedron is closed: every edge has two triangles, every point is manifold.
    #[test]
    fn tetrahedron_is_closed_manifold() {
        let tris = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let topo = Topology::build(&tris, 4);
        assert_eq!(topo.edges.len(), 6);
        assert!((0..6).all(|e| topo.edge_valence(e) == 2));
        assert!(topo
            .classify(&tris)
            .iter()
            .all(|&k| k == VertexKind::Manifold));
    }
}
