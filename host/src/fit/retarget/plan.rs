//! What a retargeting needs to know about its two actors, worked out once: where each target
//! vertex sits on the source (the points `F_W` is evaluated at) and which of the source's shapes
//! each of the target's correctives plays.
//!
//! Actors in vertex correspondence (the same vertex count and triangles) map vertex to vertex.
//! Actors of other topologies map through the built-in face template, registered onto both
//! rest shapes ([`crate::rig::correspond`]). Shapes map by name, compared as ARKit bindings are
//! (`mouthSmile_L` = `mouthSmileLeft`); a side the source has only unsplit plays the unsplit
//! shape, an unsplit target shape plays the mean of the source's two sides, and a target shape
//! with no counterpart stays at rest.

use sinew_core::aim::AimActor;
use sinew_core::tensor::F32s;

use super::input::{Input, RetargetError};
use crate::fit::baseline::actor_shape_names;
use crate::geometry::surface::Surface;
use crate::geometry::vec3::{V3, add, scale, sub, to64};
use crate::io::arkit::comparable;
use crate::rig::correspond::{carry, register_face};

/// Where a target vertex sits on the source's rest shape: at a triangle's barycentric weights (or
/// a vertex, off any triangle), with its offset from that place.
#[derive(Clone, Copy, Debug)]
pub(super) enum Anchor {
    /// On triangle `triangle` at `weights`, plus `offset`.
    Triangle {
        /// The source triangle.
        triangle: u32,
        /// Its corners' barycentric weights.
        weights: V3,
        /// From that point to the carried vertex (cm).
        offset: V3,
    },
    /// At source vertex `vertex`, plus `offset`.
    Vertex {
        /// The source vertex.
        vertex: usize,
        /// From it to the carried vertex (cm).
        offset: V3,
    },
    /// Nowhere on the source (it has no vertices): the carried point itself.
    Free(V3),
}

/// How the target's vertices and shapes take the source's.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Per target vertex, the corresponding point on the source's rest shape (face frame, cm);
    /// `None` when the actors are in vertex correspondence.
    pub(super) on_source: Option<Vec<Anchor>>,
    /// Per target shape, the source shapes it plays (their mean); empty: none, at rest.
    pub(super) shapes: Vec<Vec<usize>>,
    /// The target's shapes that no source shape plays, by name.
    pub unmatched: Vec<String>,
    /// The source's triangles, which the anchors' triangles index (across topologies).
    source_triangles: Vec<[u32; 3]>,
}

impl Plan {
    /// The plan for retargeting from `source` onto `target` (both AIM actors).
    ///
    /// # Errors
    /// [`RetargetError::NoSharedShapes`] if the actors share no shape (by name) and their shape
    /// counts differ; [`RetargetError::Correspondence`] if the template cannot be registered
    /// onto either rest shape; [`RetargetError::ShapeNames`] for an actor whose `shapes`
    /// metadata does not start with `neutral`.
    pub fn new(
        (source, src): (Input<'_>, &AimActor<'_>),
        (target, dst): (Input<'_>, &AimActor<'_>),
    ) -> Result<Self, RetargetError> {
        let same_topology = src.vertex_count() == dst.vertex_count()
            && src
                .triangles()
                .indices()
                .iter()
                .eq(dst.triangles().indices().iter());
        let (on_source, source_surface) = if same_topology {
            (None, None)
        } else {
            let register = |input: Input<'_>, actor: &AimActor<'_>| {
                let (points, triangles) = rest_shape(actor);
                register_face(input.path, &points, &triangles)
                    .map(|r| (r, points, triangles))
                    .map_err(|e| RetargetError::Correspondence {
                        path: input.path.to_owned(),
                        source: Box::new(e),
                    })
            };
            let (from, points, triangles) = register(source, src)?;
            let (to, target_points, _) = register(target, dst)?;
            // Each carried vertex placed once on the source's surface: `points` then only
            // interpolates whatever the source's F_W points are.
            let surface = Surface::new(points, triangles);
            let anchors = carry(&from, &to, &target_points)
                .into_iter()
                .map(|q| match surface.closest(q) {
                    Some((hit, _)) if hit.triangle != u32::MAX => Anchor::Triangle {
                        triangle: hit.triangle,
                        weights: hit.weights,
                        offset: sub(q, hit.position),
                    },
                    Some((_, vertex)) => Anchor::Vertex {
                        vertex,
                        offset: sub(q, surface.points[vertex]),
                    },
                    None => Anchor::Free(q),
                })
                .collect();
            (Some(anchors), Some(surface))
        };
        let names =
            |input: Input<'_>, actor: &AimActor<'_>| -> Result<Vec<String>, RetargetError> {
                let names = actor_shape_names(input.path, input.bytes).map_err(|e| {
                    RetargetError::ShapeNames {
                        path: input.path.to_owned(),
                        source: Box::new(e),
                    }
                })?;
                // The neutral first, then one name per corrective; an actor whose list does not
                // fit its correctives is matched by position.
                let names: Vec<String> = names.into_iter().skip(1).collect();
                Ok(if names.len() == actor.shape_count() {
                    names
                } else {
                    (0..actor.shape_count())
                        .map(|i| format!("shape {i}"))
                        .collect()
                })
            };
        let source_triangles = source_surface.map(|s| s.triangles).unwrap_or_default();
        let (from, to) = (names(source, src)?, names(target, dst)?);
        let shapes = match_shapes(&from, &to);
        let unmatched: Vec<String> = to
            .iter()
            .zip(&shapes)
            .filter(|(_, s)| s.is_empty())
            .map(|(n, _)| n.clone())
            .collect();
        if !to.is_empty() && unmatched.len() == to.len() {
            if from.len() != to.len() {
                return Err(RetargetError::NoSharedShapes {
                    source_actor: source.path.to_owned(),
                    target_actor: target.path.to_owned(),
                    source_shapes: from.len(),
                    target_shapes: to.len(),
                });
            }
            // Unnamed shapes on both sides, as many: by position, as before names were kept.
            return Ok(Self {
                on_source,
                shapes: (0..to.len()).map(|i| vec![i]).collect(),
                unmatched: Vec::new(),
                source_triangles,
            });
        }
        Ok(Self {
            on_source,
            shapes,
            unmatched,
            source_triangles,
        })
    }

    /// `vertex` for actors in vertex correspondence, `template` for others.
    pub fn correspondence(&self) -> &'static str {
        if self.on_source.is_some() {
            "template"
        } else {
            "vertex"
        }
    }

    /// Whether the target plays the source's shapes one for one, in order.
    pub(super) fn shapes_in_order(&self, source_shapes: usize) -> bool {
        self.shapes.len() == source_shapes
            && self
                .shapes
                .iter()
                .enumerate()
                .all(|(i, s)| s.as_slice() == [i])
    }

    /// Per target shape, the mean over its source shapes of `values` (one per source shape).
    pub(super) fn remap(&self, values: &[f32]) -> Vec<f32> {
        self.shapes
            .iter()
            .map(|from| {
                if from.is_empty() {
                    0.0
                } else {
                    from.iter().map(|&j| values[j]).sum::<f32>() / from.len() as f32
                }
            })
            .collect()
    }

    /// The points `F_W` is evaluated at for each target vertex: `at` (one per source vertex:
    /// the source's template, or the points a retargeted source performance carries) carried to
    /// the target's vertices.
    pub(super) fn points(&self, at: F32s<'_>) -> Vec<f32> {
        let at: Vec<V3> = at
            .iter()
            .collect::<Vec<f32>>()
            .chunks_exact(3)
            .map(|p| to64([p[0], p[1], p[2]]))
            .collect();
        let Some(on_source) = &self.on_source else {
            return at.iter().flat_map(|p| p.map(|v| v as f32)).collect();
        };
        on_source
            .iter()
            .flat_map(|anchor| {
                let p = match *anchor {
                    Anchor::Triangle {
                        triangle,
                        weights,
                        offset,
                    } => {
                        let [a, b, c] =
                            self.source_triangles[triangle as usize].map(|i| at[i as usize]);
                        let on = add(
                            add(scale(a, weights[0]), scale(b, weights[1])),
                            scale(c, weights[2]),
                        );
                        add(on, offset)
                    }
                    Anchor::Vertex { vertex, offset } => add(at[vertex], offset),
                    Anchor::Free(q) => q,
                };
                p.map(|v| v as f32)
            })
            .collect()
    }
}

/// An actor's rest shape: its template's vertices (face frame, cm) and triangles.
fn rest_shape(actor: &AimActor<'_>) -> (Vec<V3>, Vec<[u32; 3]>) {
    let flat: Vec<f32> = actor.template().iter().collect();
    let points = flat
        .chunks_exact(3)
        .map(|p| to64([p[0], p[1], p[2]]))
        .collect();
    let indices: Vec<u32> = actor.triangles().indices().iter().collect();
    let triangles = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    (points, triangles)
}

/// Per name of `to`, the names of `from` it plays: the same name (as [`comparable`] reduces
/// it); for a side (`…left`/`…right`) the source lacks, the unsplit shape; for an unsplit shape
/// the source has only split, both sides.
fn match_shapes(from: &[String], to: &[String]) -> Vec<Vec<usize>> {
    let keys: Vec<String> = from.iter().map(|n| comparable(n)).collect();
    let find = |key: &str| keys.iter().position(|k| k == key);
    to.iter()
        .map(|name| {
            let key = comparable(name);
            if let Some(j) = find(&key) {
                return vec![j];
            }
            for side in ["left", "right"] {
                if let Some(stem) = key.strip_suffix(side)
                    && !stem.is_empty()
                {
                    return find(stem).into_iter().collect();
                }
            }
            match (find(&format!("{key}left")), find(&format!("{key}right"))) {
                (Some(l), Some(r)) => vec![l, r],
                _ => Vec::new(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::match_shapes;

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| (*s).to_owned()).collect()
    }

    #[test]
    fn shapes_match_by_arkit_spelling_and_side() {
        let from = names(&["jawOpen", "mouthSmile_L", "mouthSmile_R", "browInnerUp"]);
        let to = names(&[
            "JawOpen",
            "mouthSmileLeft",
            "mouthSmile",
            "browInnerUp_L",
            "cheekPuff",
        ]);
        assert_eq!(
            match_shapes(&from, &to),
            vec![vec![0], vec![1], vec![1, 2], vec![3], vec![]]
        );
    }
}
