//! Left–right mirroring of a face template and of everything on its topology: the vertex
//! symmetry map, mirrored positions and displacements, and which expression shape is which
//! one's mirror image.
//!
//! `train s2d --mirror` adds the mirror image of training pairs to the training set. A face
//! mirrored left to right is still a face, and its expression is the mirrored expression: a
//! `mouthLeft` pair mirrored is close to a `mouthRight` pair. So that the expression protocol
//! still tests shapes the decoder has not seen in any form, [`partners`] finds each shape's
//! mirror image among the shapes and the trainer mirrors only the pairs whose shapes' images are
//! training shapes too (`experiment::train_s2d`).
//!
//! The mirror plane is `x = c`, the middle of the template's extent in x (Sinew's templates, ICT
//! and FLAME, put the face's left–right axis on x). A template is mirror-symmetric when every
//! vertex's image lies within [`TOLERANCE`] of the bounding box diagonal of a vertex and the map
//! is its own inverse. Polygons need not mirror onto polygons: mirroring moves per-vertex data
//! only, and ICT's triangulated quads split their mirrored twins along the other diagonal.

use crate::geometry::spatial::Grid;
use crate::io::mesh::Mesh;

/// How far (relative to the template's bounding-box diagonal) a vertex's mirror image may lie
/// from the vertex it is mapped to. ICT-FaceKit's face region is symmetric to 1.4 × 10⁻⁴ of its
/// diagonal (0.05 mm, measured by the test named at [`PARTNER_RESIDUAL`]).
pub const TOLERANCE: f64 = 1e-3;

/// The largest relative residual ‖M(δ_a) − δ_b‖ / ‖δ_a‖ at which shape b counts as shape a's
/// mirror image ([`partners`]). On ICT-FaceKit every shape has one, within 3.3 % on the kit's
/// deltas and 5.8 % on those transferred to an identity, and the next-nearest shape lies at least
/// 30 % away (`tests::ict_face_region_is_symmetric_and_its_sided_shapes_pair_up`).
pub const PARTNER_RESIDUAL: f64 = 0.25;

/// A template that has no left–right symmetry.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SymmetryError {
    /// A template without vertices.
    #[error("the template has no vertices")]
    Empty,
    /// A template whose vertices all lie at one point.
    #[error("the template's vertices all lie at one point")]
    Point,
    /// A vertex with no vertex at its mirror image.
    #[error(
        "the template is not left-right symmetric about x = {centre}: no vertex lies within \
         {tolerance:.3e} of vertex {vertex}'s mirror image ({:.4}, {:.4}, {:.4})",
        image[0],
        image[1],
        image[2]
    )]
    NoImage {
        /// The mirror plane's x.
        centre: f32,
        /// The distance within which an image must lie.
        tolerance: f64,
        /// The vertex.
        vertex: usize,
        /// Its mirror image.
        image: [f64; 3],
    },
    /// Two vertices with one image: the map is not an involution.
    #[error(
        "the template is not left-right symmetric about x = {centre}: vertex {vertex}'s image \
         is vertex {image}, whose image is vertex {back}"
    )]
    NotInvolution {
        /// The mirror plane's x.
        centre: f32,
        /// The vertex.
        vertex: usize,
        /// Its image.
        image: u32,
        /// The image's image.
        back: usize,
    },
}

/// The left–right symmetry of a template.
#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    /// `map[i]`: the vertex at vertex i's mirror image.
    map: Vec<u32>,
    /// The mirror plane is `x = centre`.
    centre: f32,
}

impl Mirror {
    /// The symmetry of `template` about the plane through the middle of its x extent.
    ///
    /// # Errors
    /// If the template is empty, or not mirror-symmetric (a vertex without a vertex at its
    /// image, or two vertices with one image), naming the first offending vertex.
    pub fn of(template: &Mesh) -> Result<Self, SymmetryError> {
        let points: Vec<[f64; 3]> = template
            .positions
            .iter()
            .map(|p| p.map(f64::from))
            .collect();
        if points.is_empty() {
            return Err(SymmetryError::Empty);
        }
        let (lo, hi) = template.bounds();
        let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
        let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
        if diagonal.is_nan() || diagonal <= 0.0 {
            return Err(SymmetryError::Point);
        }
        let centre = (0.5 * (lo[0] + hi[0])) as f32;
        let tolerance = TOLERANCE * diagonal;
        let grid = Grid::new(&points, tolerance);
        let c = f64::from(centre);
        let mut map = Vec::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            let image = [2.0 * c - p[0], p[1], p[2]];
            match grid.nearest_where(&points, image, |_| true) {
                Some((j, d)) if d <= tolerance => map.push(j as u32),
                _ => {
                    return Err(SymmetryError::NoImage {
                        centre,
                        tolerance,
                        vertex: i,
                        image,
                    });
                }
            }
        }
        for (i, &j) in map.iter().enumerate() {
            let back = map[j as usize] as usize;
            if back != i {
                return Err(SymmetryError::NotInvolution {
                    centre,
                    vertex: i,
                    image: j,
                    back,
                });
            }
        }
        Ok(Self { map, centre })
    }

    /// The vertex map: `map()[i]` is the vertex at vertex i's mirror image.
    pub fn map(&self) -> &[u32] {
        &self.map
    }

    /// The mirror plane's x.
    pub fn centre(&self) -> f32 {
        self.centre
    }

    /// Positions on the template's topology, mirrored: vertex i takes vertex `map[i]`'s position
    /// reflected in the plane.
    ///
    /// # Panics
    /// If `points` is not one position per template vertex.
    pub fn positions(&self, points: &[[f32; 3]]) -> Vec<[f32; 3]> {
        assert_eq!(points.len(), self.map.len(), "one position per vertex");
        let twice = 2.0 * self.centre;
        self.map
            .iter()
            .map(|&j| {
                let p = points[j as usize];
                [twice - p[0], p[1], p[2]]
            })
            .collect()
    }

    /// Displacements (vectors) on the template's topology, mirrored: vertex i takes vertex
    /// `map[i]`'s vector with its x negated.
    ///
    /// # Panics
    /// If `vectors` is not one vector per template vertex.
    pub fn vectors(&self, vectors: &[[f32; 3]]) -> Vec<[f32; 3]> {
        assert_eq!(vectors.len(), self.map.len(), "one vector per vertex");
        self.map
            .iter()
            .map(|&j| {
                let v = vectors[j as usize];
                [-v[0], v[1], v[2]]
            })
            .collect()
    }
}

/// Each shape's mirror image among `shapes` (deltas on the mirrored template): the shape b
/// nearest to the mirrored delta M(δ_a), when within [`PARTNER_RESIDUAL`] of ‖δ_a‖; a symmetric
/// shape is its own image. `None` for a shape whose image is no shape of the set (or a zero
/// delta).
///
/// # Panics
/// If a delta is not one vector per template vertex.
pub fn partners(mirror: &Mirror, shapes: &[&[[f32; 3]]]) -> Vec<Option<usize>> {
    nearest_images(mirror, shapes)
        .into_iter()
        .map(|near| near.and_then(|(b, r, _)| (r <= PARTNER_RESIDUAL).then_some(b)))
        .collect()
}

/// For each shape a with a non-zero delta: the shape b nearest to M(δ_a), the relative residual
/// ‖M(δ_a) − δ_b‖ / ‖δ_a‖, and the next-nearest shape's.
fn nearest_images(mirror: &Mirror, shapes: &[&[[f32; 3]]]) -> Vec<Option<(usize, f64, f64)>> {
    let distance = |a: &[[f32; 3]], b: Option<&[[f32; 3]]>| -> f64 {
        a.iter()
            .enumerate()
            .flat_map(|(i, p)| {
                let q = b.map_or([0.0; 3], |b| b[i]);
                (0..3).map(move |k| (f64::from(p[k]) - f64::from(q[k])).powi(2))
            })
            .sum::<f64>()
            .sqrt()
    };
    shapes
        .iter()
        .map(|delta| {
            let image = mirror.vectors(delta);
            let size = distance(&image, None);
            if size == 0.0 {
                return None;
            }
            let mut near = (0, f64::INFINITY, f64::INFINITY);
            for (b, other) in shapes.iter().enumerate() {
                let r = distance(&image, Some(other)) / size;
                if r < near.1 {
                    near = (b, r, near.1);
                } else if r < near.2 {
                    near.2 = r;
                }
            }
            Some(near)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::data::data_dir;
    use crate::io::ict::IctFaceKit;
    use crate::s2d::decoder::InputNormalisation;

    /// A strip of quads symmetric about x = 1: columns x = 0, 1, 2 (the middle column maps to
    /// itself) and rows y = 0, 1, 2.
    fn strip() -> Mesh {
        let positions = (0..3)
            .flat_map(|y| (0..3).map(move |x| [x as f32, y as f32, 0.1 * (x as f32 - 1.0).abs()]))
            .collect();
        let at = |x: u32, y: u32| y * 3 + x;
        let polygons = (0..2)
            .flat_map(|y| {
                (0..2).map(move |x| vec![at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y + 1)])
            })
            .collect();
        Mesh::new(positions, polygons)
    }

    #[test]
    fn a_symmetric_strip_maps_columns_onto_their_mirrors() {
        let m = Mirror::of(&strip()).unwrap();
        assert_eq!(m.centre(), 1.0);
        assert_eq!(m.map(), &[2, 1, 0, 5, 4, 3, 8, 7, 6]);
        let moved: Vec<[f32; 3]> = strip()
            .positions
            .iter()
            .map(|p| [p[0] + 0.5, p[1], p[2]])
            .collect();
        // Mirroring positions reflects them in x = 1: vertex 0 takes vertex 2's (2.5 → −0.5).
        assert_eq!(m.positions(&moved)[0], [-0.5, 0.0, 0.1]);
        let v: Vec<[f32; 3]> = (0..9).map(|i| [i as f32, 1.0, 2.0]).collect();
        let w = m.vectors(&v);
        assert_eq!(w[0], [-2.0, 1.0, 2.0]);
        assert_eq!(w[4], [-4.0, 1.0, 2.0]);
        // Twice is the identity.
        assert_eq!(m.vectors(&w), v);
        assert_eq!(m.positions(&m.positions(&moved)), moved);
    }

    #[test]
    fn asymmetric_templates_are_refused() {
        let mut bent = strip();
        bent.positions[0][1] += 0.3;
        let e = Mirror::of(&bent).unwrap_err();
        assert!(
            matches!(e, SymmetryError::NoImage { vertex: 0, .. }),
            "{e:?}"
        );
        // Vertex 1 moved onto vertex 0's mirror image: vertices 0 and 1 both map to vertex 2,
        // and vertex 2's image is vertex 0.
        let mut crowded = strip();
        crowded.positions[1] = [2.0, 0.0, 0.1];
        let e = Mirror::of(&crowded).unwrap_err();
        assert!(matches!(e, SymmetryError::NotInvolution { .. }), "{e:?}");
        let empty = Mesh {
            positions: Vec::new(),
            ..strip()
        };
        assert_eq!(Mirror::of(&empty), Err(SymmetryError::Empty));
    }

    #[test]
    fn partners_pair_mirrored_shapes_and_leave_lopsided_ones_alone() {
        let m = Mirror::of(&strip()).unwrap();
        let left: Vec<[f32; 3]> = (0..9)
            .map(|i| {
                if i % 3 == 0 {
                    [0.0, 0.0, 1.0]
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        let right = m.vectors(&left);
        let both: Vec<[f32; 3]> = left
            .iter()
            .zip(&right)
            .map(|(a, b)| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            .collect();
        // Only the left column and the middle's x: its image (right column, negated x) is none.
        let lopsided: Vec<[f32; 3]> = (0..9)
            .map(|i| {
                [
                    if i % 3 == 1 { 1.0 } else { 0.0 },
                    0.0,
                    if i % 3 == 0 { 1.0 } else { 0.0 },
                ]
            })
            .collect();
        let zero = vec![[0.0f32; 3]; 9];
        let shapes = [&left[..], &right, &both, &lopsided, &zero];
        assert_eq!(
            partners(&m, &shapes),
            vec![Some(1), Some(0), Some(2), None, None]
        );
    }

    /// The mirrored twin of each ICT shape by name: `_L` ↔ `_R`, `Left` ↔ `Right`, else itself.
    fn twin(name: &str) -> String {
        if let Some(stem) = name.strip_suffix("_L") {
            format!("{stem}_R")
        } else if let Some(stem) = name.strip_suffix("_R") {
            format!("{stem}_L")
        } else if name.contains("Left") {
            name.replace("Left", "Right")
        } else {
            name.replace("Right", "Left")
        }
    }

    /// The kit's face region maps onto itself, every sided shape pairs with its twin (on the
    /// kit's deltas and on those transferred to an identity), and a pair mirrored is the pair of
    /// the twin shape.
    #[test]
    fn ict_face_region_is_symmetric_and_its_sided_shapes_pair_up() {
        use super::super::data::{Expressions, PairsConfig, generate};
        let Some(root) = data_dir() else { return };
        let kit = IctFaceKit::open(&root.join("ict-facekit")).unwrap();
        let config = PairsConfig {
            identities: 2,
            pairs: 2,
            expressions: Expressions::Shared,
            ..Default::default()
        };
        let mut set = generate(&kit, &config).unwrap();
        let m = Mirror::of(&set.template).unwrap();
        let points = &set.template.positions;
        let gap = m
            .map()
            .iter()
            .enumerate()
            .map(|(i, &j)| {
                let (p, q) = (points[i], points[j as usize]);
                let d = [2.0 * m.centre() - q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
            })
            .fold(0.0f32, f32::max);
        let on_plane = m
            .map()
            .iter()
            .enumerate()
            .filter(|&(i, &j)| i == j as usize)
            .count();
        eprintln!(
            "ICT face region: mirror plane x = {}, largest gap {gap} cm, {on_plane} vertices on it",
            m.centre()
        );
        assert_eq!(m.map().len(), 9409);
        assert!(
            m.centre().abs() < 1e-5 && gap < 0.006,
            "{} {gap}",
            m.centre()
        );
        assert_eq!(on_plane, 131);
        let names = set.manifest.expressions.clone();
        let index = |n: &str| names.iter().position(|x| x == n).unwrap();
        let transferred = generate(
            &kit,
            &PairsConfig {
                expressions: Expressions::Transferred,
                ..config
            },
        )
        .unwrap();
        // The largest residual of a twin and the smallest of a next-nearest shape, per set.
        for (what, set, worst_twin) in [
            ("kit", &set, 0.034),
            ("transferred to identity 1", &transferred, 0.059),
        ] {
            let deltas: Vec<&[[f32; 3]]> = (0..names.len()).map(|e| set.delta(1, e)).collect();
            let near = nearest_images(&m, &deltas);
            let mut bounds = (0.0f64, f64::INFINITY);
            for (e, name) in names.iter().enumerate() {
                let (b, r, next) = near[e].unwrap();
                assert_eq!(names[b], twin(name), "{what}: {name}");
                bounds = (bounds.0.max(r), bounds.1.min(next));
            }
            eprintln!(
                "{what}: twins within {:.4}, next-nearest from {:.3}",
                bounds.0, bounds.1
            );
            assert!(
                bounds.0 < worst_twin && bounds.1 > 0.29,
                "{what}: {bounds:?}"
            );
            let p = partners(&m, &deltas);
            assert!(p.iter().zip(&near).all(|(p, n)| *p == n.map(|n| n.0)));
        }
        // On the (symmetric) generic neutral, `mouthLeft` at 0.8 mirrored is `mouthRight` at 0.8.
        set.neutrals[0] = set.template.positions.clone();
        set.manifest.pairs[0].identity = 0;
        set.manifest.pairs[1].identity = 0;
        set.combinations[0] = vec![(index("mouthLeft"), 0.8)];
        set.combinations[1] = vec![(index("mouthRight"), 0.8)];
        let (mirrored, twin) = (
            set.mirrored_sample(0, &m, InputNormalisation::Frobenius)
                .unwrap(),
            set.sample(1, InputNormalisation::Frobenius).unwrap(),
        );
        let relative = |a: &[f32], b: &[f32]| {
            let d: f32 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
            let n: f32 = b.iter().map(|y| y * y).sum();
            (d / n).sqrt()
        };
        let d = relative(&mirrored.displacement, &twin.displacement);
        let i = relative(&mirrored.input, &twin.input);
        assert!(d < 0.01 && i < 0.01, "displacement {d}, input {i}");
        // Mirrored twice, the original.
        let back = m.vectors(&m.vectors(set.delta(0, index("mouthLeft"))));
        assert_eq!(back, set.delta(0, index("mouthLeft")));
    }
}
