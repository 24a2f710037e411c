//! `sinew data face-template`: makes the face template that finds a rig's landmarks
//! (`crate::rig::template`) from ICT-FaceKit and the template bones: the generic neutral's face
//! region decimated by quadric error to [`TARGET_VERTICES`] (every kept vertex a kit vertex), the
//! kit's 68 landmark vertices as the closest points of the decimated surface, and the jaw hinge
//! of the bones `sinew bones fit` places in the kit. It lives beside the demo face, which is
//! made the same way, because it needs the bone fit.

use std::path::Path;

use super::demo_face::DemoFaceError;
use crate::geometry::surface::Surface;
use crate::geometry::vec3::to64;
use crate::io::ict::{FACE_REGION, ICT_ATTRIBUTION, IctFaceKit};
use crate::rig::template::{FORMAT, FaceTemplate};

/// The template's vertex count.
pub const TARGET_VERTICES: usize = 2_500;

/// Makes the template from the kit in `data` and the bone templates in `templates`. The same
/// inputs give the same template.
pub fn make(data: &Path, templates: &Path) -> Result<FaceTemplate, DemoFaceError> {
    let kit = IctFaceKit::open(data)?;
    let actor = kit.actor(&[], &[], FACE_REGION)?;
    let templates = crate::anatomy::fit::bone_templates(templates)?;
    let fitted = crate::anatomy::fit::fit_bones(kit.neutral(), &kit.landmarks68()?, &templates)?;
    let tris = actor.template.triangles();
    let (kept, triangles) =
        crate::geometry::qem::decimate(&actor.template.positions, &tris, TARGET_VERTICES)
            .map_err(DemoFaceError::Decimate)?;
    let points: Vec<[f64; 3]> = kept
        .iter()
        .map(|&v| to64(actor.template.positions[v as usize]))
        .collect();
    let surface = Surface::new(points.clone(), triangles.clone());
    let landmarks = actor
        .landmarks
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let l = l.ok_or(DemoFaceError::Landmark { landmark: k })?;
            let at = to64(actor.template.positions[l as usize]);
            let (p, _) = surface
                .closest(at)
                .ok_or(DemoFaceError::Landmark { landmark: k })?;
            Ok((p.triangle, p.weights.map(|w| (w * 1e6).round() / 1e6)))
        })
        .collect::<Result<Vec<_>, DemoFaceError>>()?;
    Ok(FaceTemplate {
        format: FORMAT.into(),
        source: format!(
            "{ICT_ATTRIBUTION}; generic neutral, vertex region {FACE_REGION:?} decimated to {} \
             vertices by Sinew, its 68 iBUG landmarks; jaw hinge of ArtiSynth's jaw (BSD-style) \
             fitted by Sinew",
            points.len()
        ),
        positions: points.iter().map(|&p| FaceTemplate::quantise(p)).collect(),
        triangles,
        kit_vertices: kept.iter().map(|&v| v + FACE_REGION.start).collect(),
        landmarks,
        jaw_pivot: FaceTemplate::quantise(to64(super::data::jaw_pivot(&fitted.jaw))),
    })
}

/// `sinew data face-template`: [`make`], written atomically to `out`.
pub fn write(data: &Path, templates: &Path, out: &Path) -> Result<FaceTemplate, DemoFaceError> {
    let template = make(data, templates)?;
    let bytes = template.encode()?;
    crate::io::atomic::write(out, &bytes)?;
    Ok(template)
}
