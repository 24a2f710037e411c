//! `sinew bones fit` and the bones of an ICT-FaceKit actor: template skull and jaw fitted to the
//! neutral through its iBUG-68 landmarks ([`crate::anatomy::bones::fit`]), written with a picture
//! of the constraints they give.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::io::ict::{FACE_REGION, IctFaceKit};
use crate::io::mesh::Mesh;

/// Fits the template bones in `templates` (a folder holding `artisynth-jaw/` and
/// `skull-odedstein/`) to an ICT-FaceKit neutral, using its iBUG-68 landmarks.
pub fn fit_bones(
    neutral: &Mesh,
    landmarks: &[u32],
    templates: &Path,
) -> Result<crate::anatomy::bones::FittedBones> {
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
) -> Result<crate::anatomy::bones::FitReport> {
    let kit = IctFaceKit::open(data)?;
    let neutral = kit.neutral_of(identity)?;
    let fitted = fit_bones(&neutral, &kit.landmarks68()?, templates)?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    fitted.skull.write(&out.join("skull.obj"))?;
    fitted.jaw.write(&out.join("jaw.obj"))?;
    crate::io::atomic::write(
        &out.join("fit.json"),
        serde_json::to_string_pretty(&fitted.report)?.as_bytes(),
    )?;
    let (face, _) = neutral.submesh(|v| FACE_REGION.contains(&v));
    let anchors = crate::anatomy::constraints::anchors(
        &face,
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
    crate::figures::render::Image::hstack(&[bone_img, skin]).write_png(&out.join("bones.png"))?;
    Ok(fitted.report)
}

/// Checks that `root` holds the template bones (`artisynth-jaw/`, `skull-odedstein/`) and
/// returns it; the error names the folder and what is missing.
pub fn bone_templates(root: &Path) -> Result<PathBuf> {
    if root.join("artisynth-jaw").is_dir() {
        Ok(root.to_path_buf())
    } else {
        bail!(
            "{}: no template bones (artisynth-jaw, skull-odedstein) there; pass --bones DIR, or --templates DIR or SINEW_DATA",
            root.display()
        )
    }
}
