//! Closest points on triangle meshes: the closest point of one triangle (Ericson), and a
//! surface that answers closest-point queries through a grid over its vertices, for the S2D
//! hierarchy's up-sampling and a rig's registration.

use rstar::RTree;
use rstar::primitives::GeomWithData;

use crate::geometry::topology::incident_triangles;
use crate::geometry::vec3::{V3, add, dot, norm2, scale, sub};

/// The closest point of triangle `t` to `p` and its barycentric weights, clamped to the
/// triangle (Ericson, "Real-Time Collision Detection", 5.1.5: Voronoi regions of the corners,
/// edges and face).
pub(crate) fn closest_point_on_triangle(p: [f64; 3], t: &[[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let [a, b, c] = *t;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let s = d1 / (d1 - d3);
        return (add(a, scale(ab, s)), [1.0 - s, s, 0.0]);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let s = d2 / (d2 - d6);
        return (add(a, scale(ac, s)), [1.0 - s, 0.0, s]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, scale(sub(c, b), s)), [0.0, 1.0 - s, s]);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (add(a, add(scale(ab, v), scale(ac, w))), [1.0 - v - w, v, w])
}

/// Points in an R*-tree, each carrying its index.
pub(crate) fn point_tree(points: &[V3]) -> RTree<GeomWithData<V3, usize>> {
    RTree::bulk_load(
        points
            .iter()
            .enumerate()
            .map(|(i, &p)| GeomWithData::new(p, i))
            .collect(),
    )
}

/// A point on a surface: its triangle, barycentric weights and position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SurfacePoint {
    /// The triangle.
    pub(crate) triangle: u32,
    /// Barycentric weights of its corners.
    pub(crate) weights: V3,
    /// The position.
    pub(crate) position: V3,
}

/// A triangle mesh ready for closest-point queries: its vertices in an R*-tree.
pub(crate) struct Surface {
    pub(crate) points: Vec<V3>,
    pub(crate) triangles: Vec<[u32; 3]>,
    incident: Vec<Vec<u32>>,
    tree: RTree<GeomWithData<V3, usize>>,
}

impl Surface {
    pub(crate) fn new(points: Vec<V3>, triangles: Vec<[u32; 3]>) -> Self {
        let incident = incident_triangles(points.len(), &triangles);
        let tree = point_tree(&points);
        Self {
            points,
            triangles,
            incident,
            tree,
        }
    }

    /// The vertex nearest to `q`, and its distance.
    pub(crate) fn nearest_vertex(&self, q: V3) -> Option<(usize, f64)> {
        let hit = self.tree.nearest_neighbor(q)?;
        Some((hit.data, norm2(sub(self.points[hit.data], q)).sqrt()))
    }

    /// The closest point to `q` among the triangles around the vertex nearest to it (the closest
    /// point of the whole surface wherever the mesh is finer than its curvature; a vertex
    /// without triangles is its own answer, on no triangle).
    pub(crate) fn closest(&self, q: V3) -> Option<(SurfacePoint, usize)> {
        let (v, _) = self.nearest_vertex(q)?;
        let mut best: Option<SurfacePoint> = None;
        for &t in &self.incident[v] {
            let tri = self.triangles[t as usize].map(|i| self.points[i as usize]);
            let (p, w) = closest_point_on_triangle(q, &tri);
            if best.is_none_or(|b| norm2(sub(p, q)) < norm2(sub(b.position, q))) {
                best = Some(SurfacePoint {
                    triangle: t,
                    weights: w,
                    position: p,
                });
            }
        }
        Some((
            best.unwrap_or(SurfacePoint {
                triangle: u32::MAX,
                weights: [1.0, 0.0, 0.0],
                position: self.points[v],
            }),
            v,
        ))
    }

    /// The position at a triangle's barycentric weights, over `points` (this surface's
    /// positions or a deformed copy in the same topology).
    pub(crate) fn at(&self, points: &[V3], triangle: u32, weights: V3) -> V3 {
        let [a, b, c] = self.triangles[triangle as usize].map(|i| points[i as usize]);
        add(
            add(scale(a, weights[0]), scale(b, weights[1])),
            scale(c, weights[2]),
        )
    }
}

/// Whether two directions are within `max_degrees` of each other.
pub(crate) fn agree(a: V3, b: V3, max_degrees: f64) -> bool {
    let n = (norm2(a) * norm2(b)).sqrt();
    n > 0.0 && dot(a, b) / n >= max_degrees.to_radians().cos()
}
