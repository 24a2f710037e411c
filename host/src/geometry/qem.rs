//! Quadric error metric decimation (Garland and Heckbert 1997) by half-edge collapses: a mesh
//! simplified to a target vertex count, keeping a subset of its vertices, as the S2D mesh
//! hierarchy's down-sampling needs.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use crate::geometry::topology::incident_triangles;
use crate::geometry::vec3::{cross, dot, norm2, scale, sub, to64};

/// Weight of the boundary-plane quadrics relative to the area-weighted face quadrics (qslim's
/// default): high enough that open borders (neck, eye and mouth holes) keep their shape.
const BOUNDARY_WEIGHT: f64 = 1000.0;
/// A collapse whose new triangle's doubled area is below this fraction of its longest edge
/// squared is refused as degenerate.
const MIN_AREA_RATIO: f64 = 1e-6;

/// A symmetric 4×4 error quadric `Q` (Garland–Heckbert eq. 2: `Δ(v) = vᵀ Q v`), upper triangle.
#[derive(Clone, Copy, Debug, Default)]
struct Quadric([f64; 10]);

impl Quadric {
    /// `w · p pᵀ` for the plane `n·x + d = 0`, `p = (n, d)`.
    fn plane(n: [f64; 3], d: f64, w: f64) -> Self {
        let [a, b, c] = n;
        Self([
            w * a * a,
            w * a * b,
            w * a * c,
            w * a * d,
            w * b * b,
            w * b * c,
            w * b * d,
            w * c * c,
            w * c * d,
            w * d * d,
        ])
    }

    fn add(&mut self, o: &Self) {
        for (x, y) in self.0.iter_mut().zip(&o.0) {
            *x += y;
        }
    }

    fn sum(&self, o: &Self) -> Self {
        let mut s = *self;
        s.add(o);
        s
    }

    /// `vᵀ Q v` with `v = (x, y, z, 1)`.
    fn eval(&self, p: [f64; 3]) -> f64 {
        let [q00, q01, q02, q03, q11, q12, q13, q22, q23, q33] = self.0;
        let [x, y, z] = p;
        x * (q00 * x + 2.0 * (q01 * y + q02 * z + q03))
            + y * (q11 * y + 2.0 * (q12 * z + q13))
            + z * (q22 * z + 2.0 * q23)
            + q33
    }
}

/// A half-edge collapse `from → to` waiting in the queue, with the vertex versions it was
/// computed for (stale once either vertex changed).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    cost: f64,
    from: u32,
    to: u32,
    from_version: u32,
    to_version: u32,
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Candidate {
    // A total order: cost first, then the vertex indices, so ties never depend on heap history.
    fn cmp(&self, other: &Self) -> Ordering {
        self.cost
            .total_cmp(&other.cost)
            .then(self.from.cmp(&other.from))
            .then(self.to.cmp(&other.to))
            .then(self.from_version.cmp(&other.from_version))
            .then(self.to_version.cmp(&other.to_version))
    }
}

/// The decimation state of one level.
struct Decimator {
    pos: Vec<[f64; 3]>,
    tris: Vec<[u32; 3]>,
    tri_alive: Vec<bool>,
    /// Alive incident triangles of each vertex, increasing.
    incident: Vec<Vec<u32>>,
    vertex_alive: Vec<bool>,
    quadric: Vec<Quadric>,
    version: Vec<u32>,
    heap: BinaryHeap<Reverse<Candidate>>,
}

/// A decimation that cannot reach its target.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecimateError {
    /// Every remaining collapse would flip, degenerate or disconnect the surface.
    #[error(
        "cannot decimate {vertices} vertices to {target}: every remaining collapse would flip, \
         degenerate or disconnect the surface (stopped at {stopped_at})"
    )]
    Stuck {
        /// The mesh's vertices.
        vertices: usize,
        /// The vertex count asked for.
        target: usize,
        /// The vertices left when no collapse remained.
        stopped_at: usize,
    },
}

/// Decimates one level to `target` vertices. Returns the kept vertices (increasing) and the
/// coarse triangles in the kept vertices' numbering (in the order of the fine triangles they
/// came from).
pub(crate) fn decimate(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    target: usize,
) -> Result<(Vec<u32>, Vec<[u32; 3]>), DecimateError> {
    let n = positions.len();
    let mut d = Decimator {
        pos: positions.iter().map(|&p| to64(p)).collect(),
        tris: triangles.to_vec(),
        tri_alive: vec![true; triangles.len()],
        incident: incident_triangles(n, triangles),
        vertex_alive: vec![true; n],
        quadric: vec![Quadric::default(); n],
        version: vec![0; n],
        heap: BinaryHeap::new(),
    };
    d.init_quadrics();
    for v in 0..n as u32 {
        for w in d.neighbours(v) {
            d.push(v, w);
        }
    }
    let mut alive = n;
    while alive > target {
        let Some(Reverse(c)) = d.heap.pop() else {
            return Err(DecimateError::Stuck {
                vertices: n,
                target,
                stopped_at: alive,
            });
        };
        if !d.vertex_alive[c.from as usize]
            || !d.vertex_alive[c.to as usize]
            || d.version[c.from as usize] != c.from_version
            || d.version[c.to as usize] != c.to_version
        {
            continue;
        }
        if !d.can_collapse(c.from, c.to) {
            continue;
        }
        d.collapse(c.from, c.to);
        alive -= 1;
    }
    let kept: Vec<u32> = (0..n as u32)
        .filter(|&v| d.vertex_alive[v as usize])
        .collect();
    let mut new_index = vec![u32::MAX; n];
    for (j, &v) in kept.iter().enumerate() {
        new_index[v as usize] = j as u32;
    }
    let coarse = d
        .tris
        .iter()
        .zip(&d.tri_alive)
        .filter(|(_, alive)| **alive)
        .map(|(t, _)| t.map(|v| new_index[v as usize]))
        .collect();
    Ok((kept, coarse))
}

impl Decimator {
    fn init_quadrics(&mut self) {
        for t in &self.tris {
            let p = t.map(|v| self.pos[v as usize]);
            let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
            let len = norm2(n).sqrt();
            if len == 0.0 {
                continue;
            }
            let unit = scale(n, 1.0 / len);
            // Area weighting keeps the error independent of how finely a region is meshed.
            let q = Quadric::plane(unit, -dot(unit, p[0]), 0.5 * len);
            for &v in t {
                self.quadric[v as usize].add(&q);
            }
        }
        // Boundary edges: a plane through the edge, perpendicular to its face, weighted by the
        // edge length squared (Garland and Heckbert, section 6.1).
        for ti in 0..self.tris.len() {
            let t = self.tris[ti];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if self.edge_faces(a, b).len() != 1 {
                    continue;
                }
                let p = t.map(|v| self.pos[v as usize]);
                let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
                let e = sub(self.pos[b as usize], self.pos[a as usize]);
                let m = cross(e, n);
                let len = norm2(m).sqrt();
                if len == 0.0 {
                    continue;
                }
                let unit = scale(m, 1.0 / len);
                let q = Quadric::plane(
                    unit,
                    -dot(unit, self.pos[a as usize]),
                    BOUNDARY_WEIGHT * norm2(e),
                );
                self.quadric[a as usize].add(&q);
                self.quadric[b as usize].add(&q);
            }
        }
    }

    /// Alive triangles holding both `a` and `b`.
    fn edge_faces(&self, a: u32, b: u32) -> Vec<u32> {
        self.incident[a as usize]
            .iter()
            .copied()
            .filter(|&t| self.tris[t as usize].contains(&b))
            .collect()
    }

    /// Neighbours of `v`, increasing.
    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self.incident[v as usize]
            .iter()
            .flat_map(|&t| self.tris[t as usize])
            .filter(|&w| w != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    fn is_boundary_vertex(&self, v: u32) -> bool {
        self.neighbours(v)
            .into_iter()
            .any(|w| self.edge_faces(v, w).len() == 1)
    }

    fn push(&mut self, from: u32, to: u32) {
        // Garland–Heckbert eq. 2 at the kept position: Δ = p_vᵀ (Q_u + Q_v) p_v
        let q = self.quadric[from as usize].sum(&self.quadric[to as usize]);
        self.heap.push(Reverse(Candidate {
            cost: q.eval(self.pos[to as usize]),
            from,
            to,
            from_version: self.version[from as usize],
            to_version: self.version[to as usize],
        }));
    }

    /// Whether collapsing `u` onto `v` keeps the surface a manifold without flipped,
    /// degenerate or duplicate triangles and without stranding a vertex.
    fn can_collapse(&self, u: u32, v: u32) -> bool {
        let shared = self.edge_faces(u, v);
        if shared.is_empty() || shared.len() > 2 {
            return false;
        }
        let opposite: Vec<u32> = shared
            .iter()
            .map(|&t| {
                self.tris[t as usize]
                    .into_iter()
                    .find(|&x| x != u && x != v)
                    .unwrap_or(u)
            })
            .collect();
        // Link condition (Dey et al.): the common neighbours are exactly the opposite vertices.
        let nu = self.neighbours(u);
        let nv = self.neighbours(v);
        let mut common: Vec<u32> = nu
            .iter()
            .copied()
            .filter(|w| nv.binary_search(w).is_ok())
            .collect();
        common.sort_unstable();
        let mut opp = opposite.clone();
        opp.sort_unstable();
        if common != opp {
            return false;
        }
        // An interior edge between two boundary vertices would pinch the surface at `v`.
        if shared.len() == 2 && self.is_boundary_vertex(u) && self.is_boundary_vertex(v) {
            return false;
        }
        // Every opposite vertex must keep a triangle, and so must `v`.
        for &w in &opposite {
            let lost = shared
                .iter()
                .filter(|t| self.tris[**t as usize].contains(&w))
                .count();
            if self.incident[w as usize].len() <= lost {
                return false;
            }
        }
        let survivors: Vec<u32> = self.incident[u as usize]
            .iter()
            .copied()
            .filter(|t| !shared.contains(t))
            .collect();
        if self.incident[v as usize].len() - shared.len() + survivors.len() == 0 {
            return false;
        }
        let pv = self.pos[v as usize];
        for &t in &survivors {
            let tri = self.tris[t as usize];
            let old = tri.map(|x| self.pos[x as usize]);
            let new = tri.map(|x| if x == u { pv } else { self.pos[x as usize] });
            let n_old = cross(sub(old[1], old[0]), sub(old[2], old[0]));
            let n_new = cross(sub(new[1], new[0]), sub(new[2], new[0]));
            if dot(n_old, n_new) <= 0.0 {
                return false;
            }
            let longest = (0..3)
                .map(|k| norm2(sub(new[k], new[(k + 1) % 3])))
                .fold(0.0, f64::max);
            if norm2(n_new).sqrt() <= MIN_AREA_RATIO * longest {
                return false;
            }
            // The moved triangle must not coincide with one already at `v`.
            let mut key = tri.map(|x| if x == u { v } else { x });
            key.sort_unstable();
            let duplicate = self.incident[v as usize].iter().any(|&s| {
                let mut k = self.tris[s as usize];
                k.sort_unstable();
                !shared.contains(&s) && k == key
            });
            if duplicate {
                return false;
            }
        }
        true
    }

    fn collapse(&mut self, u: u32, v: u32) {
        let shared = self.edge_faces(u, v);
        for &t in &shared {
            self.tri_alive[t as usize] = false;
            for x in self.tris[t as usize] {
                self.incident[x as usize].retain(|&s| s != t);
            }
        }
        let moved = std::mem::take(&mut self.incident[u as usize]);
        for &t in &moved {
            for x in &mut self.tris[t as usize] {
                if *x == u {
                    *x = v;
                }
            }
            let list = &mut self.incident[v as usize];
            if let Err(i) = list.binary_search(&t) {
                list.insert(i, t);
            }
        }
        self.vertex_alive[u as usize] = false;
        let qu = self.quadric[u as usize];
        self.quadric[v as usize].add(&qu);

        // Costs change on edges at `v`; feasibility may change on edges at `v` and its
        // neighbours. Renew every candidate touching them.
        let mut ring = self.neighbours(v);
        ring.push(v);
        ring.sort_unstable();
        for &r in &ring {
            self.version[r as usize] += 1;
        }
        for &a in &ring {
            for b in self.neighbours(a) {
                if ring.binary_search(&b).is_ok() && b < a {
                    continue;
                }
                self.push(a, b);
                self.push(b, a);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_target_no_collapse_reaches_is_refused() {
        // A tetrahedron: every collapse below four vertices would flatten the closed surface.
        let positions = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let err = decimate(&positions, &triangles, 1).unwrap_err();
        assert!(matches!(
            err,
            DecimateError::Stuck {
                vertices: 4,
                target: 1,
                ..
            }
        ));
    }
}
