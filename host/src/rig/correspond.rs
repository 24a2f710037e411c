//! Dense correspondence between two faces of any topologies, through the built-in face template:
//! the template is registered onto each face (as `rig inspect` registers it onto a rig), and a
//! point of one face goes to the other by its place on the template (triangle and barycentric
//! weights), carried with its offset from the template's surface.
//!
//! Both faces are given in Sinew's face frame (centimetres, +Y up, +Z forward), as every baked
//! actor's template is, whether it was learned from the kit or from a rig.

use std::path::Path;

use super::landmarks::{Found, Target, register_template};
use super::template::FaceTemplate;
use super::{Conventions, RigError};
use crate::geometry::surface::Surface;
use crate::geometry::vec3::{V3, add, sub};
use crate::geometry::weld::Weld;
use crate::io::rig::IDENTITY;
use crate::io::units::Unit;

/// A face registered by the built-in template: per template vertex, its place on the face.
#[derive(Clone, Debug)]
pub struct Registered {
    /// The template vertices on the face (face frame, cm), in the template's order.
    pub points: Vec<V3>,
    /// The template's triangles.
    pub triangles: Vec<[u32; 3]>,
}

/// Registers the built-in face template onto the face `points`/`triangles` (face frame, cm;
/// `path` names the file the face came from, for errors).
///
/// # Errors
/// [`RigError::Template`] if the built-in template cannot be read; [`RigError::Registration`]
/// if the face has no triangles or extent, or the template does not hold on it.
pub fn register_face(
    path: &Path,
    points: &[V3],
    triangles: &[[u32; 3]],
) -> Result<Registered, RigError> {
    let template = FaceTemplate::builtin()?;
    let n = u32::try_from(points.len()).map_err(|_| RigError::Registration {
        path: path.to_owned(),
        what: format!("{} vertices are more than a face can have", points.len()),
    })?;
    let weld = Weld {
        welded: (0..n).collect(),
        first: (0..n).collect(),
    };
    let conventions = Conventions {
        units: Unit::Centimetre,
        units_guessed: false,
        up: super::Axis::PosY,
        forward: super::Axis::PosZ,
        node_transform: IDENTITY,
        placement: IDENTITY,
    };
    let target = Target {
        path,
        surface: Surface::new(points.to_vec(), triangles.to_vec()),
        weld: &weld,
        conventions: &conventions,
        vertices: points.len(),
    };
    let Found { registered, .. } = register_template(&target, &template)?;
    let points = registered.ok_or_else(|| RigError::Registration {
        path: path.to_owned(),
        what: "the registration kept no correspondence".into(),
    })?;
    Ok(Registered {
        points,
        triangles: template.triangles,
    })
}

/// Per vertex of `to_face` (the face `to` is registered on), the corresponding point on the face
/// `from` is registered on: the vertex's closest point on `to`'s registered template, at the
/// same triangle and weights on `from`'s, plus the vertex's offset from that closest point.
pub fn carry(from: &Registered, to: &Registered, to_face: &[V3]) -> Vec<V3> {
    let surface = Surface::new(to.points.clone(), to.triangles.clone());
    to_face
        .iter()
        .map(|&p| match surface.closest(p) {
            Some((hit, _)) if hit.triangle != u32::MAX => add(
                surface.at(&from.points, hit.triangle, hit.weights),
                sub(p, hit.position),
            ),
            Some((_, v)) => add(from.points[v], sub(p, to.points[v])),
            None => p,
        })
        .collect()
}
