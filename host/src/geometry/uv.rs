//! Texture coordinates per triangle corner: read from either of a mesh's layouts, carried onto
//! another resolution of the same surface, recorded in a baked actor's metadata (`uv`), and split
//! at seams for formats that hold one coordinate per vertex (glTF's `TEXCOORD_0`).
//!
//! A seam is a vertex whose corners disagree: the kit's and most rigs' texture atlases cut the
//! surface open, so one position has two or more coordinates. Such a vertex is split into one
//! copy per coordinate, so that no triangle's coordinates jump across the texture.

use serde::{Deserialize, Serialize};

use crate::geometry::surface::{Surface, closest_point_on_triangle};
use crate::geometry::topology::incident_triangles;
use crate::geometry::vec3::{V3, norm2, sub, to64};
use crate::io::mesh::Mesh;

/// The metadata key of a baked actor's texture coordinates.
pub const KEY: &str = "uv";

/// Coordinates closer than this in both components are one coordinate (a file's duplicate `vt`
/// lines at one place, or one point interpolated in two triangles that share an edge).
pub const SAME: f32 = 1e-6;

/// Texture coordinates per triangle corner: corner `c` of triangle `t` has `uvs[corners[3t + c]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct CornerUvs {
    /// The coordinates.
    pub uvs: Vec<[f32; 2]>,
    /// Per triangle corner, an index into `uvs`.
    pub corners: Vec<u32>,
}

/// Why a recorded `uv` entry cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum UvError {
    /// The value is not the entry's JSON.
    #[error("metadata `uv` is not a texture-coordinate record")]
    Json(#[source] serde_json::Error),
    /// A record that does not fit the actor.
    #[error("metadata `uv`: {0}")]
    Invalid(String),
}

/// The metadata entry: per vertex (`corners` absent) when every vertex has one coordinate, per
/// triangle corner otherwise.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Record {
    uvs: Vec<[f32; 2]>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    corners: Vec<u32>,
}

fn same(a: [f32; 2], b: [f32; 2]) -> bool {
    (a[0] - b[0]).abs() <= SAME && (a[1] - b[1]).abs() <= SAME
}

impl CornerUvs {
    /// A mesh's coordinates over its fan triangulation ([`Mesh::triangles`], in its order), from
    /// either layout; `None` for a mesh without them.
    pub fn of_mesh(mesh: &Mesh) -> Option<Self> {
        if mesh.uvs.is_empty() {
            return None;
        }
        let corners: Vec<u32> = if mesh.polygon_uvs.is_empty() {
            mesh.triangles().into_iter().flatten().collect()
        } else {
            let fanned = Mesh {
                positions: Vec::new(),
                polygons: mesh.polygon_uvs.clone(),
                uvs: Vec::new(),
                polygon_uvs: Vec::new(),
            };
            fanned.triangles().into_iter().flatten().collect()
        };
        Some(Self {
            uvs: mesh.uvs.clone(),
            corners,
        })
    }

    /// The coordinate at barycentric `w` of triangle `t`.
    fn at(&self, t: usize, w: V3) -> [f32; 2] {
        let c = |k: usize| self.uvs[self.corners[3 * t + k] as usize].map(f64::from);
        let (a, b, d) = (c(0), c(1), c(2));
        std::array::from_fn(|i| (w[0] * a[i] + w[1] * b[i] + w[2] * d[i]) as f32)
    }

    /// This surface's coordinates (`source` with `self` over its fan triangulation) carried onto
    /// another mesh of the same surface, `points` and `triangles` (a decimated copy, or another
    /// resolution of the same face).
    ///
    /// Each corner takes the coordinate of the closest point of the source surface; where that
    /// point lies on a seam it has one coordinate per chart that meets there, and the corner takes
    /// the one nearest to the coordinate of its triangle's centre, so that the triangle stays in
    /// one chart. A triangle whose corners lie in different charts away from any seam (a
    /// decimation that cut across the seam) cannot be mapped without a jump; ICT-FaceKit's face
    /// region has no seam, so a kit actor has none.
    pub fn transfer(&self, source: &Mesh, points: &[[f32; 3]], triangles: &[[u32; 3]]) -> Self {
        let src_tris = source.triangles();
        let src_points: Vec<V3> = source.positions.iter().map(|&p| to64(p)).collect();
        let incident = incident_triangles(src_points.len(), &src_tris);
        let surface = Surface::new(src_points.clone(), src_tris.clone());
        // Every coordinate a point has: one per source triangle about its nearest vertex whose
        // closest point is (to rounding) the nearest of all.
        let candidates = |q: V3| -> Vec<[f32; 2]> {
            let Some((v, _)) = surface.nearest_vertex(q) else {
                return Vec::new();
            };
            let hits: Vec<(usize, V3, f64)> = incident[v]
                .iter()
                .map(|&t| {
                    let tri = src_tris[t as usize].map(|i| src_points[i as usize]);
                    let (p, w) = closest_point_on_triangle(q, &tri);
                    (t as usize, w, norm2(sub(p, q)).sqrt())
                })
                .collect();
            let best = hits.iter().map(|h| h.2).fold(f64::INFINITY, f64::min);
            let mut out: Vec<[f32; 2]> = Vec::new();
            for (t, w, d) in hits {
                if d <= best + 1e-9 * (1.0 + best) {
                    let uv = self.at(t, w);
                    if !out.iter().any(|&o| same(o, uv)) {
                        out.push(uv);
                    }
                }
            }
            out
        };
        let per_vertex: Vec<Vec<[f32; 2]>> = points.iter().map(|&p| candidates(to64(p))).collect();
        let mut uvs = Vec::new();
        let mut first = Vec::with_capacity(points.len());
        for c in &per_vertex {
            first.push(uvs.len() as u32);
            uvs.extend_from_slice(if c.is_empty() { &[[0.0; 2]] } else { c });
        }
        let mut corners = Vec::with_capacity(3 * triangles.len());
        for tri in triangles {
            let centre: V3 = std::array::from_fn(|i| {
                tri.iter()
                    .map(|&v| f64::from(points[v as usize][i]))
                    .sum::<f64>()
                    / 3.0
            });
            let target = candidates(centre).first().copied();
            for &v in tri {
                let c = &per_vertex[v as usize];
                let pick = match target {
                    Some(t) if c.len() > 1 => (0..c.len())
                        .min_by(|&a, &b| {
                            let d = |k: usize| {
                                let (du, dv) = (c[k][0] - t[0], c[k][1] - t[1]);
                                du * du + dv * dv
                            };
                            d(a).total_cmp(&d(b))
                        })
                        .unwrap_or(0),
                    _ => 0,
                };
                corners.push(first[v as usize] + pick as u32);
            }
        }
        Self { uvs, corners }
    }

    /// The metadata value for an actor whose triangles are `triangles` (flat, three per
    /// triangle): per vertex when no vertex is on a seam, per corner otherwise.
    pub fn metadata(&self, triangles: &[u32], vertices: usize) -> Result<String, UvError> {
        let mut per_vertex: Vec<Option<[f32; 2]>> = vec![None; vertices];
        let mut seams = false;
        for (&v, &c) in triangles.iter().zip(&self.corners) {
            let uv = self.uvs[c as usize];
            match per_vertex[v as usize] {
                Some(have) => seams |= !same(have, uv),
                None => per_vertex[v as usize] = Some(uv),
            }
        }
        let record = if seams {
            Record {
                uvs: self.uvs.clone(),
                corners: self.corners.clone(),
            }
        } else {
            Record {
                uvs: per_vertex.iter().map(|u| u.unwrap_or([0.0; 2])).collect(),
                corners: Vec::new(),
            }
        };
        serde_json::to_string(&record).map_err(UvError::Json)
    }

    /// Reads a metadata value for an actor of `vertices` vertices and `triangles` (flat).
    pub fn parse(value: &str, triangles: &[u32], vertices: usize) -> Result<Self, UvError> {
        let r: Record = serde_json::from_str(value).map_err(UvError::Json)?;
        if let Some(i) = r
            .uvs
            .iter()
            .position(|u| !u[0].is_finite() || !u[1].is_finite())
        {
            return Err(UvError::Invalid(format!(
                "coordinate {i} is not a finite number"
            )));
        }
        if r.corners.is_empty() {
            if r.uvs.len() != vertices {
                return Err(UvError::Invalid(format!(
                    "{} per-vertex coordinates for an actor of {vertices} vertices",
                    r.uvs.len()
                )));
            }
            return Ok(Self {
                uvs: r.uvs,
                corners: triangles.to_vec(),
            });
        }
        if r.corners.len() != triangles.len() {
            return Err(UvError::Invalid(format!(
                "{} corners for an actor of {} triangles ({} corners)",
                r.corners.len(),
                triangles.len() / 3,
                triangles.len()
            )));
        }
        if let Some(c) = r.corners.iter().find(|&&c| c as usize >= r.uvs.len()) {
            return Err(UvError::Invalid(format!(
                "corner names coordinate {c}, past its {}",
                r.uvs.len()
            )));
        }
        Ok(Self {
            uvs: r.uvs,
            corners: r.corners,
        })
    }

    /// Splits the vertices of `triangles` (flat, over `vertices` vertices) where their corners
    /// disagree: vertex `v` keeps index `v` with the coordinate of its first corner, and each
    /// further coordinate it has becomes a copy appended after the last vertex. A vertex in no
    /// triangle keeps (0, 0).
    pub fn split(&self, triangles: &[u32], vertices: usize) -> Split {
        let mut uvs: Vec<Option<[f32; 2]>> = vec![None; vertices];
        let mut source: Vec<u32> = (0..vertices as u32).collect();
        // Per vertex, its copies beyond the first: (coordinate, exported index).
        let mut copies: Vec<Vec<([f32; 2], u32)>> = vec![Vec::new(); vertices];
        let mut out = Vec::with_capacity(triangles.len());
        for (&v, &c) in triangles.iter().zip(&self.corners) {
            let uv = self.uvs[c as usize];
            let vi = v as usize;
            let index = match uvs[vi] {
                None => {
                    uvs[vi] = Some(uv);
                    v
                }
                Some(have) if same(have, uv) => v,
                Some(_) => match copies[vi].iter().find(|(u, _)| same(*u, uv)) {
                    Some(&(_, i)) => i,
                    None => {
                        let i = source.len() as u32;
                        source.push(v);
                        uvs.push(Some(uv));
                        copies[vi].push((uv, i));
                        i
                    }
                },
            };
            out.push(index);
        }
        Split {
            source,
            triangles: out,
            uvs: uvs.into_iter().map(|u| u.unwrap_or([0.0; 2])).collect(),
        }
    }
}

/// Vertices split at seams.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    /// Per output vertex, the vertex it copies (the identity over the first `vertices`).
    pub source: Vec<u32>,
    /// The triangles over the output vertices, flat.
    pub triangles: Vec<u32>,
    /// Per output vertex, its coordinate.
    pub uvs: Vec<[f32; 2]>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two quads side by side, vertices 0..3 along the bottom and 3..6 along the top, with
    /// coordinates per corner that agree at the shared edge (no seam).
    fn strip() -> Mesh {
        let positions = (0..2)
            .flat_map(|y| (0..3).map(move |x| [x as f32, y as f32, 0.0]))
            .collect();
        Mesh {
            positions,
            polygons: vec![vec![0, 1, 4, 3], vec![1, 2, 5, 4]],
            uvs: (0..2)
                .flat_map(|y| (0..3).map(move |x| [x as f32 / 2.0, y as f32]))
                .collect(),
            polygon_uvs: vec![vec![0, 1, 4, 3], vec![1, 2, 5, 4]],
        }
    }

    #[test]
    fn seam_vertices_are_split_and_triangles_keep_their_corners() {
        // A seam along the shared edge's lower vertex: vertex 1 has u = 0.5 in the left quad and
        // u = 0.9 in the right one.
        let mut mesh = strip();
        mesh.uvs.push([0.9, 0.0]);
        mesh.polygon_uvs[1][0] = 6;
        let uv = CornerUvs::of_mesh(&mesh).unwrap();
        let tris: Vec<u32> = mesh.triangles().into_iter().flatten().collect();
        let split = uv.split(&tris, 6);
        assert_eq!(
            split.source,
            [0, 1, 2, 3, 4, 5, 1],
            "vertex 1 is split once"
        );
        for (k, (&v, &c)) in split.triangles.iter().zip(&uv.corners).enumerate() {
            assert_eq!(split.uvs[v as usize], uv.uvs[c as usize], "corner {k}");
            assert_eq!(split.source[v as usize], tris[k], "corner {k}");
        }
        // The metadata keeps the seam, per corner, and reads back to the same split.
        let text = uv.metadata(&tris, 6).unwrap();
        assert!(text.contains("corners"), "{text}");
        let back = CornerUvs::parse(&text, &tris, 6).unwrap();
        assert_eq!(back.split(&tris, 6), split);
    }

    #[test]
    fn seamless_coordinates_are_recorded_per_vertex() {
        let mesh = strip();
        let uv = CornerUvs::of_mesh(&mesh).unwrap();
        let tris: Vec<u32> = mesh.triangles().into_iter().flatten().collect();
        let text = uv.metadata(&tris, 6).unwrap();
        assert!(!text.contains("corners"), "{text}");
        let back = CornerUvs::parse(&text, &tris, 6).unwrap();
        assert_eq!(back.split(&tris, 6), uv.split(&tris, 6));
        assert_eq!(uv.split(&tris, 6).source.len(), 6);
    }

    #[test]
    fn bad_records_are_refused() {
        let tris = [0u32, 1, 2];
        for (text, want) in [
            (
                "{\"uvs\": [[0, 0]]}",
                "1 per-vertex coordinates for an actor of 3",
            ),
            ("{\"uvs\": [[0, 0]], \"corners\": [0, 0]}", "2 corners"),
            (
                "{\"uvs\": [[0, 0]], \"corners\": [0, 0, 4]}",
                "coordinate 4, past its 1",
            ),
            ("{\"uvs\": 3}", "not a texture-coordinate record"),
        ] {
            let err = CornerUvs::parse(text, &tris, 3).unwrap_err();
            assert!(err.to_string().contains(want), "{text}: {err}");
        }
    }

    #[test]
    fn transfer_onto_a_subset_keeps_charts() {
        // A seam across the middle of a 3 x 2 grid: the left half in one chart, the right in
        // another that starts at u = 0.6, both meeting at column 1.
        let positions: Vec<[f32; 3]> = (0..2)
            .flat_map(|y| (0..3).map(move |x| [x as f32, y as f32, 0.0]))
            .collect();
        let mesh = Mesh {
            positions: positions.clone(),
            polygons: vec![vec![0, 1, 4, 3], vec![1, 2, 5, 4]],
            uvs: vec![
                [0.0, 0.0],
                [0.2, 0.0],
                [0.0, 1.0],
                [0.2, 1.0],
                [0.6, 0.0],
                [0.8, 0.0],
                [0.6, 1.0],
                [0.8, 1.0],
            ],
            polygon_uvs: vec![vec![0, 1, 3, 2], vec![4, 5, 7, 6]],
        };
        let uv = CornerUvs::of_mesh(&mesh).unwrap();
        // The same grid as triangles of another order: each triangle stays in its chart.
        let target = [[4, 1, 0], [0, 3, 4], [2, 5, 4], [4, 1, 2]];
        let moved = uv.transfer(&mesh, &positions, &target);
        let flat: Vec<u32> = target.iter().flatten().copied().collect();
        let split = moved.split(&flat, 6);
        let u = |k: usize| split.uvs[split.triangles[k] as usize][0];
        for t in 0..2 {
            assert!(
                (0..3).all(|c| u(3 * t + c) <= 0.2),
                "triangle {t} in the left chart"
            );
        }
        for t in 2..4 {
            assert!(
                (0..3).all(|c| u(3 * t + c) >= 0.6),
                "triangle {t} in the right chart"
            );
        }
        assert_eq!(split.source.len(), 8, "vertices 1 and 4 are split");
    }
}
