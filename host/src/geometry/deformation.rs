//! Deformation transfer between two meshes of one topology (Sumner & Popović 2004, "Deformation
//! Transfer for Triangle Meshes"), in its Poisson form (Botsch, Sumner, Pauly & Gross 2006):
//! the source's deformation of each triangle, a 3 × 3 map, is applied to the target's triangle,
//! and the target vertices that match those maps best in the least-squares sense are found by one
//! sparse solve.
//!
//! Used to make ICT-FaceKit's expressions identity-specific (`s2d::data::Expressions::Transferred`
//! and the motions of `sinew data motions`): the kit's 53 expression deltas are the same vectors for every identity, so a smile moves a
//! narrow and a wide mouth by the same centimetres; transferred onto an identity, the smile
//! stretches that identity's own triangles the way it stretches the generic neutral's.
//!
//! For source triangle t with corners s0, s1, s2 and its deformed corners s̃, the deformation
//! gradient is S_t = Ṽ V⁻¹ with V = [s1 − s0, s2 − s0, n / √|n|] (n the unnormalised normal:
//! the fourth column makes V invertible and scales like the edges). On the target, ∇φ_i are
//! the gradients of the piecewise-linear hat functions of its neutral triangle (area A_t), and
//! the target's deformed positions x minimise Σ_t A_t ‖Σ_i x_i ∇φ_iᵀ − S_t‖²_F. Its normal
//! equations are, per coordinate, L x = Σ_t A_t ∇φ_i · S_t, with L the cotangent Laplacian of
//! the target neutral. Solved for the displacement d = x − y (y the target neutral) the right
//! side uses S_t − I, so a small expression gives a small, accurately rounded right side.
//!
//! L is singular (a translation costs nothing), so the system adds a weak pull of d toward the
//! source's own displacement: (L + εM) d = b + εM δ, M the lumped vertex areas and
//! ε = [`ANCHOR`] · trace(L) / trace(M), too weak to bend anything but enough to fix the
//! translation. With the target equal to the source, d = δ exactly (tested).
//!
//! The system matrix depends on the target only, so one Cholesky factorisation (after a reverse
//! Cuthill–McKee ordering that keeps its fill small) serves every expression of an identity.
//! Everything runs in f64 in a fixed order: the same meshes give the same bytes.

use nalgebra::DMatrix;
use nalgebra_sparse::{
    CooMatrix, CscMatrix,
    factorization::{CholeskyError, CscCholesky},
};

use crate::geometry::align::{M3, inverse_unless_singular, mat_mul};
use crate::geometry::vec3::{V3, cross, dot, norm, sub};

/// The pull toward the source displacement, relative to the Laplacian: fixes the translation
/// the Laplacian leaves free while changing the lowest-frequency shape of the result by about
/// `ANCHOR / λ₁` (λ₁ ≈ 10⁻² for a face of unit-ish scale): a few parts in 10⁴.
pub const ANCHOR: f64 = 1e-6;

/// Why a deformation transfer could not be prepared or applied. The variants of
/// [`Transfer::new`] carry the name the caller gave the target (`what`).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TransferError {
    /// Source and target have different vertex counts.
    #[error("{what}: {target} vertices, the source has {source_vertices}")]
    VertexCount {
        /// The target's name.
        what: String,
        /// The target's vertices.
        target: usize,
        /// The source's vertices.
        source_vertices: usize,
    },
    /// A mesh without triangles.
    #[error("{what}: no triangles")]
    NoTriangles {
        /// The target's name.
        what: String,
    },
    /// A triangle indexes past the vertices.
    #[error("{what}: triangle {triangle:?} indexes past {vertices} vertices")]
    IndexOutOfRange {
        /// The target's name.
        what: String,
        /// The triangle.
        triangle: [u32; 3],
        /// The vertex count.
        vertices: usize,
    },
    /// A vertex of the source or target with a NaN or infinite coordinate.
    #[error("{what}: vertex {vertex} is not finite")]
    NonFinite {
        /// The target's name.
        what: String,
        /// The vertex.
        vertex: usize,
    },
    /// A vertex no triangle uses.
    #[error("{what}: vertex {vertex} is in no triangle")]
    Unused {
        /// The target's name.
        what: String,
        /// The vertex.
        vertex: usize,
    },
    /// A degenerate triangle of the source.
    #[error("{what}: triangle {index} {triangle:?} of the source is degenerate")]
    DegenerateSource {
        /// The target's name.
        what: String,
        /// The triangle's index.
        index: usize,
        /// The triangle.
        triangle: [u32; 3],
    },
    /// A degenerate triangle of the target.
    #[error("{what}: triangle {index} {triangle:?} is degenerate")]
    DegenerateTarget {
        /// The target's name.
        what: String,
        /// The triangle's index.
        index: usize,
        /// The triangle.
        triangle: [u32; 3],
    },
    /// The Cholesky factorisation of the system failed.
    #[error("{what}: cannot factorise the transfer system")]
    Factorise {
        /// The target's name.
        what: String,
        /// What the factorisation said.
        #[source]
        source: CholeskyError,
    },
    /// A source displacement of the wrong length.
    #[error("delta {delta}: {vertices} vertices, the mesh has {mesh}")]
    DeltaLength {
        /// The displacement's index.
        delta: usize,
        /// Its vertices.
        vertices: usize,
        /// The mesh's vertices.
        mesh: usize,
    },
    /// A source displacement with a NaN or infinite value.
    #[error("delta {delta} is not finite")]
    DeltaNonFinite {
        /// The displacement's index.
        delta: usize,
    },
    /// A source displacement that collapses a triangle.
    #[error("delta {delta} collapses source triangle {index} {triangle:?}")]
    Collapse {
        /// The displacement's index.
        delta: usize,
        /// The triangle's index.
        index: usize,
        /// The triangle.
        triangle: [u32; 3],
    },
}

fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn widen(p: [f32; 3]) -> V3 {
    [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]
}

/// A triangle's corners, from `points`.
fn corners(points: &[[f32; 3]], t: [u32; 3]) -> [V3; 3] {
    t.map(|i| widen(points[i as usize]))
}

/// `[e1, e2, n / √|n|]` of a triangle as columns (row-major 3 × 3), and `|n|` (twice its area).
fn frame(c: [V3; 3]) -> (M3, f64) {
    let (e1, e2) = (sub(c[1], c[0]), sub(c[2], c[0]));
    let n = cross(e1, e2);
    let len = norm(n);
    let n4 = scale(n, 1.0 / len.sqrt());
    (
        [
            [e1[0], e2[0], n4[0]],
            [e1[1], e2[1], n4[1]],
            [e1[2], e2[2], n4[2]],
        ],
        len,
    )
}

/// Whether triangle `c`, whose edge cross product has length `n2` (twice its area), is too thin
/// to define a frame.
fn degenerate(c: [V3; 3], n2: f64) -> bool {
    let (e1, e2) = (sub(c[1], c[0]), sub(c[2], c[0]));
    !n2.is_finite() || n2 <= 1e-12 * (dot(e1, e1) + dot(e2, e2))
}

/// Reverse Cuthill–McKee order of the vertices of `triangles` (`order[k]` is the vertex placed
/// at position k), which keeps the Laplacian's Cholesky factor narrow. Each connected component
/// starts at its lowest-degree vertex (ties: lowest index); neighbours are visited by degree,
/// then index, so the order is reproducible.
fn reverse_cuthill_mckee(vertices: usize, triangles: &[[u32; 3]]) -> Vec<usize> {
    let mut adjacency: Vec<Vec<usize>> = vec![Vec::new(); vertices];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            adjacency[a].push(b);
            adjacency[b].push(a);
        }
    }
    for n in &mut adjacency {
        n.sort_unstable();
        n.dedup();
    }
    let degree: Vec<usize> = adjacency.iter().map(Vec::len).collect();
    let mut starts: Vec<usize> = (0..vertices).collect();
    starts.sort_by_key(|&v| (degree[v], v));
    let mut seen = vec![false; vertices];
    let mut order = Vec::with_capacity(vertices);
    for s in starts {
        if seen[s] {
            continue;
        }
        seen[s] = true;
        let mut head = order.len();
        order.push(s);
        while head < order.len() {
            let v = order[head];
            head += 1;
            let mut next: Vec<usize> = adjacency[v].iter().copied().filter(|&u| !seen[u]).collect();
            next.sort_by_key(|&u| (degree[u], u));
            for u in next {
                seen[u] = true;
                order.push(u);
            }
        }
    }
    order.reverse();
    order
}

/// A prepared transfer from one source neutral to one target neutral of the same triangles.
#[derive(Debug)]
pub struct Transfer {
    triangles: Vec<[u32; 3]>,
    source: Vec<[f32; 3]>,
    /// V⁻¹ of each source triangle.
    source_inverse: Vec<M3>,
    /// A_t ∇φ_i of each target triangle's corners.
    gradients: Vec<[V3; 3]>,
    /// ε M_ii.
    anchor: Vec<f64>,
    /// The row of each vertex in the factorised (reordered) system.
    row_of: Vec<usize>,
    factor: CscCholesky<f64>,
}

impl Transfer {
    /// Prepares transfers from `source` to `target`, both positions of the mesh `triangles`
    /// (every vertex in some triangle). `what` names the target in errors.
    ///
    /// # Errors
    /// If the counts differ, an index is out of range, a vertex is in no triangle, a triangle of
    /// either mesh is degenerate, or the system cannot be factorised.
    pub fn new(
        source: &[[f32; 3]],
        target: &[[f32; 3]],
        triangles: &[[u32; 3]],
        what: &str,
    ) -> Result<Self, TransferError> {
        let n = target.len();
        let what = || what.to_string();
        if source.len() != n {
            return Err(TransferError::VertexCount {
                what: what(),
                target: n,
                source_vertices: source.len(),
            });
        }
        if triangles.is_empty() {
            return Err(TransferError::NoTriangles { what: what() });
        }
        if let Some(t) = triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(TransferError::IndexOutOfRange {
                what: what(),
                triangle: *t,
                vertices: n,
            });
        }
        if let Some(i) = source
            .iter()
            .chain(target)
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(TransferError::NonFinite {
                what: what(),
                vertex: i % n,
            });
        }
        let mut used = vec![false; n];
        triangles
            .iter()
            .flatten()
            .for_each(|&i| used[i as usize] = true);
        if let Some(i) = used.iter().position(|&u| !u) {
            return Err(TransferError::Unused {
                what: what(),
                vertex: i,
            });
        }
        let mut source_inverse = Vec::with_capacity(triangles.len());
        let mut gradients = Vec::with_capacity(triangles.len());
        let mut areas = Vec::with_capacity(triangles.len());
        for (k, &t) in triangles.iter().enumerate() {
            let s = corners(source, t);
            let (v, len) = frame(s);
            let inv = inverse_unless_singular(v).filter(|_| !degenerate(s, len));
            let Some(inv) = inv else {
                return Err(TransferError::DegenerateSource {
                    what: what(),
                    index: k,
                    triangle: t,
                });
            };
            source_inverse.push(inv);
            let c = corners(target, t);
            let (e1, e2) = (sub(c[1], c[0]), sub(c[2], c[0]));
            let nrm = cross(e1, e2);
            let len = norm(nrm);
            if degenerate(c, len) {
                return Err(TransferError::DegenerateTarget {
                    what: what(),
                    index: k,
                    triangle: t,
                });
            }
            let unit = scale(nrm, 1.0 / len);
            // A ∇φ_i = n̂ × (opposite edge, counter-clockwise) / 2.
            gradients.push([0, 1, 2].map(|i| {
                let (a, b) = (c[(i + 1) % 3], c[(i + 2) % 3]);
                scale(cross(unit, sub(b, a)), 0.5)
            }));
            areas.push(0.5 * len);
        }
        let order = reverse_cuthill_mckee(n, triangles);
        let mut row_of = vec![0usize; n];
        for (k, &v) in order.iter().enumerate() {
            row_of[v] = k;
        }
        let mut mass = vec![0.0f64; n];
        let mut coo = CooMatrix::new(n, n);
        let mut trace_l = 0.0;
        for ((t, g), &area) in triangles.iter().zip(&gradients).zip(&areas) {
            for i in 0..3 {
                mass[t[i] as usize] += area / 3.0;
                for j in 0..3 {
                    let l = dot(g[i], g[j]) / area;
                    coo.push(row_of[t[i] as usize], row_of[t[j] as usize], l);
                    if i == j {
                        trace_l += l;
                    }
                }
            }
        }
        let eps = ANCHOR * trace_l / mass.iter().sum::<f64>();
        let anchor: Vec<f64> = mass.iter().map(|m| eps * m).collect();
        for (v, &a) in anchor.iter().enumerate() {
            coo.push(row_of[v], row_of[v], a);
        }
        let factor = CscCholesky::factor(&CscMatrix::from(&coo)).map_err(|source| {
            TransferError::Factorise {
                what: what(),
                source,
            }
        })?;
        Ok(Self {
            triangles: triangles.to_vec(),
            source: source.to_vec(),
            source_inverse,
            gradients,
            anchor,
            row_of,
            factor,
        })
    }

    /// The target's displacements for each source displacement in `deltas` (one solve for all).
    ///
    /// # Errors
    /// If a delta has the wrong length, is not finite, or deforms a source triangle into a
    /// degenerate one.
    pub fn apply(&self, deltas: &[&[[f32; 3]]]) -> Result<Vec<Vec<[f32; 3]>>, TransferError> {
        let n = self.source.len();
        let mut rhs = DMatrix::<f64>::zeros(n, 3 * deltas.len());
        let row_of = &self.row_of;
        for (j, delta) in deltas.iter().enumerate() {
            if delta.len() != n {
                return Err(TransferError::DeltaLength {
                    delta: j,
                    vertices: delta.len(),
                    mesh: n,
                });
            }
            if !delta.iter().flatten().all(|c| c.is_finite()) {
                return Err(TransferError::DeltaNonFinite { delta: j });
            }
            let deformed: Vec<[f32; 3]> = self
                .source
                .iter()
                .zip(*delta)
                .map(|(s, d)| [s[0] + d[0], s[1] + d[1], s[2] + d[2]])
                .collect();
            for (k, ((&t, inv), g)) in self
                .triangles
                .iter()
                .zip(&self.source_inverse)
                .zip(&self.gradients)
                .enumerate()
            {
                let c = corners(&deformed, t);
                let (v, len) = frame(c);
                if degenerate(c, len) {
                    return Err(TransferError::Collapse {
                        delta: j,
                        index: k,
                        triangle: t,
                    });
                }
                let mut s = mat_mul(v, *inv);
                for (d, row) in s.iter_mut().enumerate() {
                    row[d] -= 1.0;
                }
                for (i, &vert) in t.iter().enumerate() {
                    let r = row_of[vert as usize];
                    for (coord, srow) in s.iter().enumerate() {
                        rhs[(r, 3 * j + coord)] += dot(g[i], *srow);
                    }
                }
            }
            for (v, d) in delta.iter().enumerate() {
                for (coord, &x) in d.iter().enumerate() {
                    rhs[(row_of[v], 3 * j + coord)] += self.anchor[v] * f64::from(x);
                }
            }
        }
        let solution = self.factor.solve(&rhs);
        Ok((0..deltas.len())
            .map(|j| {
                (0..n)
                    .map(|v| {
                        let r = row_of[v];
                        [0, 1, 2].map(|c| solution[(r, 3 * j + c)] as f32)
                    })
                    .collect()
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bumpy grid, `w × h` vertices, two triangles per cell.
    fn grid(w: usize, h: usize) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let points = (0..h)
            .flat_map(|y| {
                (0..w).map(move |x| {
                    let (fx, fy) = (x as f32, y as f32);
                    [fx, fy, 0.3 * (0.7 * fx).sin() * (0.5 * fy).cos()]
                })
            })
            .collect();
        let mut tris = Vec::new();
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                let i = (y * w + x) as u32;
                let (r, u, ru) = (i + 1, i + w as u32, i + w as u32 + 1);
                tris.push([i, r, ru]);
                tris.push([i, ru, u]);
            }
        }
        (points, tris)
    }

    /// A smooth, non-rigid displacement: a bulge and a shear.
    fn bulge(points: &[[f32; 3]]) -> Vec<[f32; 3]> {
        points
            .iter()
            .map(|p| {
                let r2 = (p[0] - 4.0).powi(2) + (p[1] - 3.0).powi(2);
                let b = 0.8 * (-r2 / 6.0).exp();
                [0.1 * p[1], 0.05 * p[0], b]
            })
            .collect()
    }

    fn max_diff(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
        a.iter()
            .zip(b)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
            .fold(0.0, f32::max)
    }

    #[test]
    fn onto_the_source_itself_gives_the_source_delta() {
        let (points, tris) = grid(9, 7);
        let delta = bulge(&points);
        let t = Transfer::new(&points, &points, &tris, "grid").unwrap();
        let out = t.apply(&[&delta]).unwrap();
        assert!(
            max_diff(&out[0], &delta) < 1e-5,
            "{}",
            max_diff(&out[0], &delta)
        );
    }

    #[test]
    fn onto_a_scaled_target_the_delta_scales() {
        // Deformation gradients do not change with scale, so on a target twice the size the
        // same expression moves every vertex twice as far, plus one translation, which no
        // gradient sees: the anchor picks it so that the target's area-weighted mean
        // displacement is the source's, here -mean(δ) away from 2δ.
        let (points, tris) = grid(9, 7);
        let big: Vec<[f32; 3]> = points.iter().map(|p| p.map(|c| 2.0 * c)).collect();
        let delta = bulge(&points);
        let t = Transfer::new(&points, &big, &tris, "grid").unwrap();
        let out = t.apply(&[&delta]).unwrap();
        let offset: Vec<[f32; 3]> = out[0]
            .iter()
            .zip(&delta)
            .map(|(o, d)| [0, 1, 2].map(|c| o[c] - 2.0 * d[c]))
            .collect();
        let peak = delta.iter().flatten().fold(0.0f32, |m, c| m.max(c.abs()));
        let constant = vec![offset[0]; offset.len()];
        assert!(
            max_diff(&offset, &constant) < 1e-3 * peak,
            "{}",
            max_diff(&offset, &constant)
        );
        assert!(
            offset[0].iter().any(|c| c.abs() > 0.01),
            "the translation is the anchor's"
        );
    }

    #[test]
    fn a_stretched_target_gets_its_own_delta() {
        // The target is the source with its right half stretched in x: the transferred bulge
        // differs from the source's (it follows the target's triangles), is deterministic, and
        // is solved for several deltas at once exactly as one at a time.
        let (points, tris) = grid(9, 7);
        let target: Vec<[f32; 3]> = points
            .iter()
            .map(|p| {
                [
                    if p[0] > 4.0 {
                        4.0 + 1.5 * (p[0] - 4.0)
                    } else {
                        p[0]
                    },
                    p[1],
                    p[2],
                ]
            })
            .collect();
        let delta = bulge(&points);
        let zero = vec![[0.0f32; 3]; points.len()];
        let t = Transfer::new(&points, &target, &tris, "grid").unwrap();
        let both = t.apply(&[&delta, &zero]).unwrap();
        let one = t.apply(&[&delta]).unwrap();
        assert_eq!(both[0], one[0]);
        assert!(max_diff(&both[1], &zero) < 1e-6, "no expression, no motion");
        assert!(
            max_diff(&one[0], &delta) > 0.05,
            "the stretch shows in the result"
        );
        let again = Transfer::new(&points, &target, &tris, "grid").unwrap();
        assert_eq!(again.apply(&[&delta]).unwrap(), one);
    }

    #[test]
    fn bad_meshes_are_refused_with_their_name() {
        let (points, tris) = grid(4, 4);
        let mut flat = points.clone();
        flat[5] = flat[4];
        flat[6] = flat[4];
        let e = Transfer::new(&points, &flat, &tris, "identity 3").unwrap_err();
        assert!(
            matches!(&e, TransferError::DegenerateTarget { what, .. } if what == "identity 3"),
            "{e}"
        );
        let e = Transfer::new(&points, &points[..10], &tris, "x").unwrap_err();
        assert!(
            matches!(
                e,
                TransferError::VertexCount {
                    target: 10,
                    source_vertices: 16,
                    ..
                }
            ),
            "{e}"
        );
        let mut lonely = points.clone();
        lonely.push([9.0, 9.0, 9.0]);
        let e = Transfer::new(&lonely, &lonely, &tris, "x").unwrap_err();
        assert!(matches!(e, TransferError::Unused { vertex: 16, .. }), "{e}");
        let t = Transfer::new(&points, &points, &tris, "x").unwrap();
        let e = t.apply(&[&points[..3]]).unwrap_err();
        assert!(
            matches!(
                e,
                TransferError::DeltaLength {
                    delta: 0,
                    vertices: 3,
                    mesh: 16
                }
            ),
            "{e}"
        );
    }
}
