//! `sinew bones fit` and the bones of an ICT-FaceKit actor: template skull and jaw fitted to the
//! neutral through its iBUG-68 landmarks ([`crate::anatomy::bones::fit`]), written with a picture
//! of the constraints they give.

use std::path::{Path, PathBuf};

use crate::anatomy::bones::BonesError;
use crate::figures::render::PngError;
use crate::io::atomic::AtomicWriteError;
use crate::io::ict::{FACE_REGION, IctError, IctFaceKit};
use crate::io::mesh::{Mesh, MeshError};

/// Why `sinew bones fit` failed; every variant names the file or folder.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BonesFitError {
    /// The folder holds no template bones.
    #[error(
        "{}: no template bones (artisynth-jaw, skull-odedstein) there; pass --bones DIR, or \
         --templates DIR or SINEW_DATA",
        path.display()
    )]
    NoTemplates {
        /// The folder.
        path: PathBuf,
    },
    /// The ICT-FaceKit folder could not be read.
    #[error(transparent)]
    Kit(#[from] IctError),
    /// The templates could not be loaded or fitted.
    #[error(transparent)]
    Bones(#[from] BonesError),
    /// The output folder could not be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// A fitted bone could not be written.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The report could not be laid out as JSON.
    #[error("{}: cannot lay out the report", path.display())]
    Report {
        /// The report file.
        path: PathBuf,
        /// What the JSON writer said.
        #[source]
        source: serde_json::Error,
    },
    /// The report could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// The picture could not be written.
    #[error(transparent)]
    Png(#[from] PngError),
}

/// Fits the template bones in `templates` (a folder holding `artisynth-jaw/` and
/// `skull-odedstein/`) to an ICT-FaceKit neutral, using its iBUG-68 landmarks.
pub fn fit_bones(
    neutral: &Mesh,
    landmarks: &[u32],
    templates: &Path,
) -> Result<crate::anatomy::bones::FittedBones, BonesError> {
    let ibug: Vec<Option<u32>> = landmarks.iter().map(|&l| Some(l)).collect();
    let skin = crate::anatomy::bones::SkinLandmarks::from_ibug68(neutral, &ibug, 10.0)?;
    let t = crate::anatomy::bones::load_templates(templates)?;
    crate::anatomy::bones::fit(neutral, &skin, &t)
}

/// `sinew bones fit`: fits template bones to the ICT neutral of `identity` (weights of the kit's
/// identity modes; empty: the generic neutral) and writes `skull.obj`, `jaw.obj`,
/// `fit.json` and a picture (`bones.png`: the bones, and the skin coloured by the tissue
/// thickness of its constraints).
pub fn bones_fit(
    data: &Path,
    identity: &[f32],
    templates: &Path,
    out: &Path,
) -> Result<crate::anatomy::bones::FitReport, BonesFitError> {
    let kit = IctFaceKit::open(data)?;
    let neutral = kit.neutral_of(identity)?;
    let (face, _) = neutral.submesh(|v| FACE_REGION.contains(&v));
    bones_fit_on(&neutral, &kit.landmarks68()?, &face, templates, out)
}

/// `sinew bones fit` on any neutral: fits the template bones in `templates` to `neutral` by its
/// 68 iBUG landmark vertices and writes what [`bones_fit`] writes, the picture showing `face`
/// (the part of the neutral that is the face, in its coordinates).
pub fn bones_fit_on(
    neutral: &Mesh,
    landmarks: &[u32],
    face: &Mesh,
    templates: &Path,
    out: &Path,
) -> Result<crate::anatomy::bones::FitReport, BonesFitError> {
    let fitted = fit_bones(neutral, landmarks, templates)?;
    crate::io::atomic::create_folder(out, "folder")?;
    fitted.skull.write(&out.join("skull.obj"))?;
    fitted.jaw.write(&out.join("jaw.obj"))?;
    let report = out.join("fit.json");
    let json =
        serde_json::to_string_pretty(&fitted.report).map_err(|source| BonesFitError::Report {
            path: report.clone(),
            source,
        })?;
    crate::io::atomic::write(&report, json.as_bytes())?;
    let anchors = crate::anatomy::constraints::anchors(
        face,
        &fitted.skull,
        &fitted.jaw,
        crate::anatomy::constraints::DEFAULT_MAX_DEPTH,
    );
    let thickness: Vec<f32> = anchors
        .iter()
        .map(|a| a.map_or(f32::NAN, |a| a.thickness * 10.0))
        .collect();
    let view = crate::figures::render::View {
        yaw_deg: 35.0,
        pitch_deg: 0.0,
        width: 560,
        height: 560,
    };
    let tri = face.triangles();
    let skin = crate::figures::render::render_heatmap(
        &face.positions,
        &tri,
        &thickness,
        0.0,
        25.0,
        "mm",
        "constraint thickness",
        &view,
    );
    let mut bones = fitted.skull.clone();
    let offset = bones.positions.len() as u32;
    bones.positions.extend(&fitted.jaw.positions);
    bones.polygons.extend(
        fitted
            .jaw
            .polygons
            .iter()
            .map(|p| p.iter().map(|i| i + offset).collect()),
    );
    let colors: Vec<[u8; 3]> = (0..bones.positions.len())
        .map(|i| {
            if (i as u32) < offset {
                [225, 215, 190]
            } else {
                [190, 205, 230]
            }
        })
        .collect();
    let bone_img =
        crate::figures::render::render(&bones.positions, &bones.triangles(), &colors, &view);
    crate::figures::render::Image::hstack(&[bone_img, skin]).save_png(&out.join("bones.png"))?;
    Ok(fitted.report)
}

/// Checks that `root` holds the template bones (`artisynth-jaw/`, `skull-odedstein/`) and
/// returns it; the error names the folder and what is missing.
pub fn bone_templates(root: &Path) -> Result<PathBuf, BonesFitError> {
    if root.join("artisynth-jaw").is_dir() {
        Ok(root.to_path_buf())
    } else {
        Err(BonesFitError::NoTemplates {
            path: root.to_path_buf(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_folder_without_templates_or_kit_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let err = bone_templates(dir.path()).unwrap_err();
        assert!(matches!(&err, BonesFitError::NoTemplates { path } if path == dir.path()));
        let err = bones_fit(dir.path(), &[], dir.path(), &dir.path().join("out")).unwrap_err();
        assert!(matches!(err, BonesFitError::Kit(_)), "{err}");
        assert!(!dir.path().join("out").exists());
    }
}
