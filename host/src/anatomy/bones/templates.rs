//! The template bones and the bone landmark file (`host/data/bone_landmarks.json`): the
//! ArtiSynth jaw and maxilla and the upper odedstein skull, registered once into one frame.

use super::error::BonesError;
use crate::anatomy::constraints::Bone;
use crate::geometry::align::fit_similarity;
use crate::geometry::spatial::{Grid, cell_for};
use crate::geometry::vec3::{to32, to64};
use crate::io::mesh::Mesh;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::Path;

#[derive(Debug, Deserialize)]
pub(crate) struct Spec {
    pub(crate) templates: TemplatesSpec,
    pub(crate) cranium_registration: RegistrationSpec,
    pub(crate) calvarium: CalvariumSpec,
    pub(crate) patches: Vec<SkinPatch>,
    pub(crate) landmarks: Vec<LandmarkSpec>,
}

#[derive(Debug, Deserialize)]
pub(crate) struct TemplatesSpec {
    pub(crate) jaw: FileSpec,
    pub(crate) maxilla: FileSpec,
    pub(crate) cranium: CraniumSpec,
}

#[derive(Debug, Deserialize)]
pub(crate) struct FileSpec {
    pub(crate) file: String,
}

#[derive(Debug, Deserialize)]
pub(crate) struct CraniumSpec {
    pub(crate) file: String,
    pub(crate) keep_axis: usize,
    pub(crate) keep_min: f32,
}

#[derive(Debug, Deserialize)]
pub(crate) struct RegistrationSpec {
    pub(crate) pairs: Vec<[String; 2]>,
    pub(crate) iterations: usize,
    pub(crate) keep_fraction: f64,
}

#[derive(Debug, Deserialize)]
pub(crate) struct CalvariumSpec {
    pub(crate) above_brows_mm: f32,
    pub(crate) thickness_mm: f32,
}

#[derive(Debug, Deserialize)]
pub(crate) struct LandmarkSpec {
    pub(crate) name: String,
    pub(crate) template: Template,
    pub(crate) vertex: u32,
    pub(crate) position: [f32; 3],
    pub(crate) skin: Option<SkinRule>,
    pub(crate) fstt_mm: Option<f32>,
    pub(crate) patch_mm: Option<f32>,
    pub(crate) weight: Option<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum Template {
    Jaw,
    Maxilla,
    Cranium,
}

impl Template {
    /// The template's name, as the landmark file spells it.
    pub(crate) const fn name(self) -> &'static str {
        match self {
            Self::Jaw => "jaw",
            Self::Maxilla => "maxilla",
            Self::Cranium => "cranium",
        }
    }
}

/// How a bone landmark's skin landmark is found from the 68 iBUG landmarks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SkinRule {
    /// The iBUG landmark's own vertex.
    Ibug {
        /// iBUG index, 0-based.
        ibug: usize,
    },
    /// The skin vertex nearest to `(1 - t) a + t b` for iBUG landmarks `a`, `b`, searched on the
    /// connected skin of `a` (so teeth and eyeballs are never chosen).
    Between {
        /// The two iBUG indices.
        between: [usize; 2],
        /// Interpolation parameter.
        t: f32,
    },
    /// Among skin vertices within `radius_mm` of the iBUG landmark, the one whose normal points
    /// most downward (down = from iBUG 27 towards iBUG 8).
    LowestNear {
        /// iBUG index.
        lowest_near: usize,
        /// Search radius in mm.
        radius_mm: f32,
    },
}

/// An ICP target patch with no bone landmark: skin around a skin landmark, pushed in by a
/// thickness, matched to the nearest surface of one bone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkinPatch {
    /// Name, used as the skin landmark's name in `SkinLandmarks`.
    pub name: String,
    /// The bone under the patch.
    pub bone: Bone,
    /// How its centre is found.
    pub skin: SkinRule,
    /// Assumed soft-tissue thickness (mm).
    pub fstt_mm: f32,
    /// Geodesic radius (mm).
    pub patch_mm: f32,
}

/// The landmark data file, compiled in.
const LANDMARKS_JSON: &str = include_str!("../../../data/bone_landmarks.json");

pub(crate) fn spec() -> Result<Spec, BonesError> {
    serde_json::from_str(LANDMARKS_JSON).map_err(BonesError::LandmarkFile)
}

/// One bone landmark on the templates, in the templates' common (ArtiSynth) frame, mm.
#[derive(Clone, Debug, PartialEq)]
pub struct BoneLandmark {
    /// Name, e.g. `"nasion"`.
    pub name: String,
    /// The bone it lies on.
    pub bone: Bone,
    /// Position in the templates' frame (mm).
    pub position: [f32; 3],
    /// How its skin landmark is found.
    pub skin: SkinRule,
    /// Expected soft-tissue thickness (mm).
    pub fstt_mm: f32,
    /// Geodesic radius of its ICP target patch on the skin (mm; 0 for none).
    pub patch_mm: f32,
    /// Weight in the initial fit and the ICP (0: reported only).
    pub weight: f32,
}

/// How the odedstein skull was put into the ArtiSynth frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CraniumRegistration {
    /// mm per skull unit.
    pub scale: f32,
    /// Median distance (mm) from maxilla vertices to the registered skull, over all of them.
    pub median_mm: f32,
    /// Median over the kept (closest) pairs of the last iteration (mm).
    pub kept_median_mm: f32,
}

/// The template bones, all in one frame (ArtiSynth's: x = subject's left, -y = anterior,
/// z = up; mm).
#[derive(Clone, Debug)]
pub struct BoneTemplates {
    /// The mandible (`artisynth-jaw/jaw.obj`).
    pub jaw: Mesh,
    /// The maxilla and midface (`artisynth-jaw/maxilla.obj`).
    pub maxilla: Mesh,
    /// The upper skull cut from `skull-odedstein/skull.obj`, registered into this frame.
    pub cranium: Mesh,
    /// Landmarks with a skin counterpart.
    pub landmarks: Vec<BoneLandmark>,
    /// Target patches without a bone landmark.
    pub patches: Vec<SkinPatch>,
    /// How the cranium was registered.
    pub cranium_registration: CraniumRegistration,
    /// Calvarium ICP targets start this far (mm) above the brows...
    pub calvarium_above_brows_mm: f32,
    /// ... and lie this far (mm) under the skin.
    pub calvarium_thickness_mm: f32,
}

/// Reads the template bones from the data folder (`artisynth-jaw/`, `skull-odedstein/`), checks
/// every landmark vertex against `host/data/bone_landmarks.json`, cuts and registers the
/// cranium. Errors name the missing or mismatching file.
pub fn load_templates(data_dir: &Path) -> Result<BoneTemplates, BonesError> {
    let spec = spec()?;
    let read = |file: &str| -> Result<Mesh, BonesError> {
        let path = data_dir.join(file);
        if !path.is_file() {
            return Err(BonesError::TemplateMissing {
                path,
                readme: data_dir.join("README.md"),
            });
        }
        Ok(Mesh::read(&path)?)
    };
    let jaw = read(&spec.templates.jaw.file)?;
    let maxilla = read(&spec.templates.maxilla.file)?;
    let skull = read(&spec.templates.cranium.file)?;
    let mesh_of = |t: Template| match t {
        Template::Jaw => (&jaw, &spec.templates.jaw.file),
        Template::Maxilla => (&maxilla, &spec.templates.maxilla.file),
        Template::Cranium => (&skull, &spec.templates.cranium.file),
    };
    // Every landmark must sit where the file says: a different version of a template file would
    // silently move the landmarks otherwise.
    for l in &spec.landmarks {
        let (mesh, file) = mesh_of(l.template);
        let p =
            mesh.positions
                .get(l.vertex as usize)
                .ok_or_else(|| BonesError::LandmarkVertex {
                    path: data_dir.join(file),
                    landmark: l.name.clone(),
                    vertex: l.vertex,
                    vertices: mesh.positions.len(),
                })?;
        let scale = 1.0 + l.position.iter().fold(0.0f32, |m, c| m.max(c.abs()));
        if (0..3).any(|k| (p[k] - l.position[k]).abs() > 1e-4 * scale) {
            return Err(BonesError::LandmarkMoved {
                path: data_dir.join(file),
                vertex: l.vertex,
                landmark: l.name.clone(),
                at: *p,
                expected: l.position,
            });
        }
    }
    let by_name: HashMap<&str, &LandmarkSpec> = spec
        .landmarks
        .iter()
        .map(|l| (l.name.as_str(), l))
        .collect();

    // Register the skull into the maxilla's frame: fit maxilla -> skull, then invert.
    let reg = &spec.cranium_registration;
    let mut src = Vec::new();
    let mut dst = Vec::new();
    for [c, m] in &reg.pairs {
        let get = |n: &str, want: Template| -> Result<[f64; 3], BonesError> {
            let l = by_name
                .get(n)
                .filter(|l| l.template == want)
                .ok_or_else(|| BonesError::RegistrationPair {
                    name: n.to_string(),
                    want: want.name().to_owned(),
                })?;
            Ok(to64(l.position))
        };
        src.push(get(m, Template::Maxilla)?);
        dst.push(get(c, Template::Cranium)?);
    }
    if src.len() < 3 {
        return Err(BonesError::TooFewPairs);
    }
    let w = vec![1.0; src.len()];
    let mut to_skull = fit_similarity(&src, &dst, &w);
    let skull_pts: Vec<[f64; 3]> = skull.positions.iter().map(|p| to64(*p)).collect();
    let max_pts: Vec<[f64; 3]> = maxilla.positions.iter().map(|p| to64(*p)).collect();
    let grid = Grid::new(&skull_pts, cell_for(&skull_pts, 40));
    let mut kept_median = 0.0;
    for _ in 0..reg.iterations {
        let mut pairs: Vec<(f64, usize, usize)> = max_pts
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                grid.nearest(&skull_pts, to_skull.apply(*p))
                    .map(|(j, d)| (d, i, j))
            })
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let keep = ((pairs.len() as f64 * reg.keep_fraction) as usize)
            .max(3)
            .min(pairs.len());
        pairs.truncate(keep);
        kept_median = pairs.get(keep / 2).map_or(0.0, |p| p.0);
        let s: Vec<[f64; 3]> = pairs.iter().map(|p| max_pts[p.1]).collect();
        let d: Vec<[f64; 3]> = pairs.iter().map(|p| skull_pts[p.2]).collect();
        to_skull = fit_similarity(&s, &d, &vec![1.0; s.len()]);
    }
    let mut all: Vec<f64> = max_pts
        .iter()
        .filter_map(|p| grid.nearest(&skull_pts, to_skull.apply(*p)).map(|x| x.1))
        .collect();
    all.sort_by(f64::total_cmp);
    let skull_scale = to_skull.scale();
    let to_frame = to_skull
        .inverse()
        .ok_or(BonesError::DegenerateRegistration)?;

    // Cut the skull above the plane and map it into the frame.
    let cut = &spec.templates.cranium;
    if cut.keep_axis > 2 {
        return Err(BonesError::KeepAxis);
    }
    let (mut cranium, _) =
        skull.submesh(|v| skull.positions[v as usize][cut.keep_axis] >= cut.keep_min);
    for p in &mut cranium.positions {
        *p = to32(to_frame.apply(to64(*p)));
    }
    cranium.uvs.clear();
    cranium.polygon_uvs.clear();

    let mut landmarks = Vec::new();
    for l in &spec.landmarks {
        let Some(skin) = l.skin.clone() else { continue };
        let (bone, position) = match l.template {
            Template::Jaw => (Bone::Jaw, l.position),
            Template::Maxilla => (Bone::Skull, l.position),
            Template::Cranium => (Bone::Skull, to32(to_frame.apply(to64(l.position)))),
        };
        landmarks.push(BoneLandmark {
            name: l.name.clone(),
            bone,
            position,
            skin,
            fstt_mm: l.fstt_mm.ok_or_else(|| BonesError::NoThickness {
                name: l.name.clone(),
            })?,
            patch_mm: l.patch_mm.unwrap_or(0.0),
            weight: l.weight.unwrap_or(1.0),
        });
    }
    Ok(BoneTemplates {
        jaw,
        maxilla,
        cranium,
        landmarks,
        patches: spec.patches.clone(),
        cranium_registration: CraniumRegistration {
            scale: (1.0 / skull_scale) as f32,
            median_mm: all
                .get(all.len() / 2)
                .map_or(f32::NAN, |d| (*d / skull_scale) as f32),
            kept_median_mm: (kept_median / skull_scale) as f32,
        },
        calvarium_above_brows_mm: spec.calvarium.above_brows_mm,
        calvarium_thickness_mm: spec.calvarium.thickness_mm,
    })
}
