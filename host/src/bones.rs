//! `sinew bones fit`: places template skull and jaw bones inside an actor's neutral face, as AIM
//! section 4.1 needs ("we fit a template skull and jaw only to the neutral shape"), so that the
//! sparse anatomical constraints ([`crate::constraints`], AIM eq. 12) can be computed.
//!
//! The method, its numbers and the landmark list are in `docs/BONES.md`; in short:
//! 1. Templates ([`load_templates`]): the ArtiSynth mandible (the jaw) and maxilla, and the upper
//!    part of the odedstein skull (vault, forehead, orbits, nasal bones) cut above a plane and
//!    registered once into the ArtiSynth frame (similarity from four landmark pairs, then trimmed
//!    ICP of the maxilla against the whole skull). Maxilla + upper skull form the skull bone.
//! 2. Landmarks (`host/data/bone_landmarks.json`): bone vertices picked once on the templates,
//!    each mapped to a skin landmark derived from the 68 iBUG landmarks and to a soft-tissue
//!    thickness from the FSTT table ([`SkinLandmarks::from_ibug68`]).
//! 3. Initial similarity (Horn's closed form, the same minimiser as Umeyama's) from every bone
//!    landmark to its skin landmark pushed inward along the skin normal by the thickness.
//! 4. ICP per bone group against the skin "pushed inward by the expected thickness": geodesic
//!    patches around the skin landmarks and along the jaw line (each with its thickness) and
//!    the forehead and scalp (the calvarium). Correspondences are the nearest template vertex
//!    with a compatible normal; pairs beyond three median distances are dropped; the landmark
//!    pairs stay in the objective with 30 % of the weight so the fit cannot slide away; every
//!    pair is also used mirrored, so the symmetric templates stay symmetric in the face. The
//!    jaw gets a similarity; the skull a general affine map when the skin is a whole head (so
//!    the template vault can take the head's proportions), a similarity otherwise.

use std::cmp::Ordering;
use std::collections::{BTreeMap, BinaryHeap, HashMap};
use std::path::Path;

use anyhow::{Context, Result, anyhow, bail};
use serde::{Deserialize, Serialize};

use crate::constraints::Bone;
use crate::mesh::Mesh;
use crate::vec3::{V3, cross, dot, norm, sub};

/// The landmark data file, compiled in.
const LANDMARKS_JSON: &str = include_str!("../data/bone_landmarks.json");
/// The data file's name in messages.
const LANDMARKS_NAME: &str = "host/data/bone_landmarks.json";

/// The landmarks' share of the ICP objective (their summed weight relative to the surface pairs).
const LANDMARK_SHARE: f64 = 0.3;
/// Most ICP iterations per bone group.
const ICP_ITERATIONS: usize = 30;
/// A surface pair is dropped when farther apart than this many median distances...
const REJECT_MEDIANS: f64 = 3.0;
/// ... unless it is closer than this (mm): a floor, so a converged fit keeps its pairs.
const REJECT_FLOOR_MM: f64 = 3.0;
/// Correspondence search cell (mm): pairs up to this far apart are always found.
const CELL_MM: f64 = 8.0;
/// Smallest `|cos|` between a target's skin normal and a template vertex normal to pair them.
const PAIR_MIN_COS: f64 = 0.5;
/// Skull-group affine fits whose singular values differ by more than this ratio fall back to a
/// similarity: the head's proportions never need more, a larger stretch means a bad fit.
const MAX_ANISOTROPY: f64 = 1.3;
/// A skin with at least this many backward-facing calvarium targets is a whole head.
const CLOSED_HEAD_TARGETS: usize = 100;
/// Depth behind the skin (mm) within which a bone vertex counts as "near the face" in
/// [`behind_skin`].
pub const NEAR_DEPTH_MM: f32 = 25.0;

// ---------------------------------------------------------------------------------------------
// The landmark file.

#[derive(Debug, Deserialize)]
struct Spec {
    templates: TemplatesSpec,
    cranium_registration: RegistrationSpec,
    calvarium: CalvariumSpec,
    patches: Vec<SkinPatch>,
    landmarks: Vec<LandmarkSpec>,
}

#[derive(Debug, Deserialize)]
struct TemplatesSpec {
    jaw: FileSpec,
    maxilla: FileSpec,
    cranium: CraniumSpec,
}

#[derive(Debug, Deserialize)]
struct FileSpec {
    file: String,
}

#[derive(Debug, Deserialize)]
struct CraniumSpec {
    file: String,
    keep_axis: usize,
    keep_min: f32,
}

#[derive(Debug, Deserialize)]
struct RegistrationSpec {
    pairs: Vec<[String; 2]>,
    iterations: usize,
    keep_fraction: f64,
}

#[derive(Debug, Deserialize)]
struct CalvariumSpec {
    above_brows_mm: f32,
    thickness_mm: f32,
}

#[derive(Debug, Deserialize)]
struct LandmarkSpec {
    name: String,
    template: Template,
    vertex: u32,
    position: [f32; 3],
    skin: Option<SkinRule>,
    fstt_mm: Option<f32>,
    patch_mm: Option<f32>,
    weight: Option<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Template {
    Jaw,
    Maxilla,
    Cranium,
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
    /// Name, used as the skin landmark's name in [`SkinLandmarks`].
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

fn spec() -> Result<Spec> {
    serde_json::from_str(LANDMARKS_JSON).with_context(|| format!("{LANDMARKS_NAME}: invalid"))
}

// ---------------------------------------------------------------------------------------------
// Templates.

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
pub fn load_templates(data_dir: &Path) -> Result<BoneTemplates> {
    let spec = spec()?;
    let read = |file: &str| -> Result<Mesh> {
        let path = data_dir.join(file);
        if !path.is_file() {
            bail!(
                "{}: missing (a bone template; the data folder is described in {})",
                path.display(),
                data_dir.join("README.md").display()
            );
        }
        Mesh::read(&path)
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
        let p = mesh.positions.get(l.vertex as usize).ok_or_else(|| {
            anyhow!(
                "{}: landmark {} names vertex {}, but the file has {} vertices",
                data_dir.join(file).display(),
                l.name,
                l.vertex,
                mesh.positions.len()
            )
        })?;
        let scale = 1.0 + l.position.iter().fold(0.0f32, |m, c| m.max(c.abs()));
        if (0..3).any(|k| (p[k] - l.position[k]).abs() > 1e-4 * scale) {
            bail!(
                "{}: vertex {} (landmark {}) is at {:?}, {LANDMARKS_NAME} expects {:?}: not the \
                 published file?",
                data_dir.join(file).display(),
                l.vertex,
                l.name,
                p,
                l.position
            );
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
        let get = |n: &str, want: Template| -> Result<[f64; 3]> {
            let l = by_name
                .get(n)
                .filter(|l| l.template == want)
                .ok_or_else(|| {
                    anyhow!(
                        "{LANDMARKS_NAME}: registration pair names {n}, not a {want:?} landmark"
                    )
                })?;
            Ok(v64(l.position))
        };
        src.push(get(m, Template::Maxilla)?);
        dst.push(get(c, Template::Cranium)?);
    }
    if src.len() < 3 {
        bail!("{LANDMARKS_NAME}: cranium registration needs at least 3 pairs");
    }
    let w = vec![1.0; src.len()];
    let mut to_skull = fit_similarity(&src, &dst, &w);
    let skull_pts: Vec<[f64; 3]> = skull.positions.iter().map(|p| v64(*p)).collect();
    let max_pts: Vec<[f64; 3]> = maxilla.positions.iter().map(|p| v64(*p)).collect();
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
        .ok_or_else(|| anyhow!("cranium registration failed: degenerate transform"))?;

    // Cut the skull above the plane and map it into the frame.
    let cut = &spec.templates.cranium;
    if cut.keep_axis > 2 {
        bail!("{LANDMARKS_NAME}: keep_axis must be 0, 1 or 2");
    }
    let (mut cranium, _) =
        skull.submesh(|v| skull.positions[v as usize][cut.keep_axis] >= cut.keep_min);
    for p in &mut cranium.positions {
        *p = v32(to_frame.apply(v64(*p)));
    }
    cranium.uvs.clear();
    cranium.polygon_uvs.clear();

    let mut landmarks = Vec::new();
    for l in &spec.landmarks {
        let Some(skin) = l.skin.clone() else { continue };
        let (bone, position) = match l.template {
            Template::Jaw => (Bone::Jaw, l.position),
            Template::Maxilla => (Bone::Skull, l.position),
            Template::Cranium => (Bone::Skull, v32(to_frame.apply(v64(l.position)))),
        };
        landmarks.push(BoneLandmark {
            name: l.name.clone(),
            bone,
            position,
            skin,
            fstt_mm: l.fstt_mm.ok_or_else(|| {
                anyhow!(
                    "{LANDMARKS_NAME}: landmark {} has a skin rule but no fstt_mm",
                    l.name
                )
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

// ---------------------------------------------------------------------------------------------
// Skin landmarks.

/// Skin landmarks on an actor's neutral mesh: landmark name (as in the bone landmark file) →
/// skin vertex, plus the mesh's unit.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinLandmarks {
    /// Skin vertex of each landmark by name.
    pub vertices: BTreeMap<String, u32>,
    /// Millimetres per mesh unit (10 for ICT's cm).
    pub mm_per_unit: f32,
}

impl SkinLandmarks {
    /// Derives the skin landmarks from the 68 iBUG landmark vertices (`None` where a landmark is
    /// not on the mesh; landmarks that need it are left out), following each bone landmark's
    /// [`SkinRule`].
    pub fn from_ibug68(neutral: &Mesh, ibug: &[Option<u32>], mm_per_unit: f32) -> Result<Self> {
        if ibug.len() != 68 {
            bail!("{} iBUG landmarks given, 68 expected", ibug.len());
        }
        if !(mm_per_unit > 0.0 && mm_per_unit.is_finite()) {
            bail!("mm per unit must be positive, got {mm_per_unit}");
        }
        neutral
            .validate()
            .context("the neutral mesh to find skin landmarks on")?;
        let nv = neutral.positions.len();
        if let Some(v) = ibug.iter().flatten().find(|&&v| v as usize >= nv) {
            bail!("iBUG landmark vertex {v} is not below the mesh's {nv} vertices");
        }
        let comp = components(neutral);
        let normals = oriented_normals(neutral, &comp);
        let p = |k: usize| ibug.get(k).copied().flatten();
        let spec = spec()?;
        let rules = spec
            .landmarks
            .iter()
            .filter_map(|l| Some((&l.name, l.skin.as_ref()?)))
            .chain(spec.patches.iter().map(|p| (&p.name, &p.skin)));
        let mut vertices = BTreeMap::new();
        for (name, rule) in rules {
            let v = match *rule {
                SkinRule::Ibug { ibug } => p(ibug),
                SkinRule::Between { between: [a, b], t } => match (p(a), p(b)) {
                    (Some(a), Some(b)) => {
                        let (pa, pb) = (
                            v64(neutral.positions[a as usize]),
                            v64(neutral.positions[b as usize]),
                        );
                        let q = lerp(pa, pb, t as f64);
                        nearest_in_component(neutral, &comp, comp[a as usize], q)
                    }
                    _ => None,
                },
                SkinRule::LowestNear {
                    lowest_near,
                    radius_mm,
                } => match (p(lowest_near), p(27), p(8)) {
                    (Some(c), Some(top), Some(chin)) => {
                        let down = normalize(sub(
                            v64(neutral.positions[chin as usize]),
                            v64(neutral.positions[top as usize]),
                        ));
                        let centre = v64(neutral.positions[c as usize]);
                        let r = (radius_mm / mm_per_unit) as f64;
                        (0..nv)
                            .filter(|&v| comp[v] == comp[c as usize])
                            .filter(|&v| norm(sub(v64(neutral.positions[v]), centre)) <= r)
                            .max_by(|&a, &b| {
                                dot(normals[a], down)
                                    .total_cmp(&dot(normals[b], down))
                                    .then(b.cmp(&a))
                            })
                            .map(|v| v as u32)
                    }
                    _ => None,
                },
            };
            if let Some(v) = v {
                vertices.insert(name.clone(), v);
            }
        }
        Ok(Self {
            vertices,
            mm_per_unit,
        })
    }
}

/// An orthonormal frame of the face from its skin landmarks: `up` from menton to nasion, `left`
/// from the right to the left zygion made orthogonal to `up`, and `forward = left × up`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FaceFrame {
    /// The subject's left.
    pub left: [f32; 3],
    /// Up.
    pub up: [f32; 3],
    /// Anterior.
    pub forward: [f32; 3],
}

impl FaceFrame {
    /// The frame from the `nasion`, `menton`, `zygion_l` and `zygion_r` skin landmarks.
    pub fn new(neutral: &Mesh, skin: &SkinLandmarks) -> Result<Self> {
        let get = |n: &str| -> Result<[f64; 3]> {
            let v = skin.vertices.get(n).ok_or_else(|| {
                anyhow!("skin landmark {n} is missing (needed for the face frame)")
            })?;
            neutral
                .positions
                .get(*v as usize)
                .map(|p| v64(*p))
                .ok_or_else(|| anyhow!("skin landmark {n} is vertex {v}, beyond the mesh"))
        };
        let up = normalize(sub(get("nasion")?, get("menton")?));
        let l = sub(get("zygion_l")?, get("zygion_r")?);
        let left = normalize(sub(l, scale3(up, dot(l, up))));
        let forward = cross(left, up);
        if !(norm(up) > 0.5 && norm(left) > 0.5) {
            bail!("degenerate skin landmarks: cannot build the face frame");
        }
        Ok(Self {
            left: v32(left),
            up: v32(up),
            forward: v32(forward),
        })
    }
}

// ---------------------------------------------------------------------------------------------
// The fit.

/// How a bone group's transform was fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Model {
    /// Rotation, uniform scale, translation.
    Similarity,
    /// General linear map + translation.
    Affine,
}

/// One bone group's fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupReport {
    /// The bone.
    pub bone: Bone,
    /// The transform model used.
    pub model: Model,
    /// Template (mm frame) → skin, as a 3×4 matrix `[A | t]`, rows.
    pub transform: [[f32; 4]; 3],
    /// Singular values of `A` times the skin's mm per unit: 1 means life size.
    pub scale: [f32; 3],
    /// ICP target points on the skin.
    pub targets: usize,
    /// Surface pairs used in the last iteration.
    pub pairs: usize,
    /// Median distance of those pairs, skin units.
    pub median_residual: f32,
    /// RMS distance of those pairs, skin units.
    pub rms_residual: f32,
    /// ICP iterations run.
    pub iterations: usize,
    /// Bone vertices checked by [`behind_skin`] and how many were behind the skin.
    pub behind_skin: BehindSkin,
}

/// One landmark after the fit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LandmarkReport {
    /// Name.
    pub name: String,
    /// Bone.
    pub bone: Bone,
    /// Weight in the fit.
    pub weight: f32,
    /// Skin vertex.
    pub skin_vertex: u32,
    /// Expected thickness (mm).
    pub fstt_mm: f32,
    /// Distance from the fitted bone landmark to the skin landmark pushed in by `fstt_mm`, skin
    /// units.
    pub residual: f32,
    /// Distance from the fitted bone landmark to the skin landmark, mm.
    pub depth_mm: f32,
}

/// What [`fit`] did, residuals in the skin's unit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitReport {
    /// mm per skin unit.
    pub mm_per_unit: f32,
    /// The face frame.
    pub frame: FaceFrame,
    /// How the cranium template was registered.
    pub cranium_registration: CraniumRegistration,
    /// Per group: skull first, then jaw.
    pub groups: Vec<GroupReport>,
    /// Per landmark.
    pub landmarks: Vec<LandmarkReport>,
}

/// Bones fitted to a neutral face, in the face's frame and unit.
#[derive(Clone, Debug)]
pub struct FittedBones {
    /// Maxilla and upper skull, one mesh (maxilla vertices first).
    pub skull: Mesh,
    /// The mandible.
    pub jaw: Mesh,
    /// How the fit went.
    pub report: FitReport,
}

/// A target of the ICP: a point under the skin and the skin normal there.
#[derive(Clone, Copy, Debug)]
struct Target {
    point: [f64; 3],
    normal: [f64; 3],
    bone: Bone,
}

/// Fits the template bones to `neutral` (see the module docs). `skin_landmarks` must hold
/// `nasion`, `menton`, `zygion_l`, `zygion_r` and at least three weighted landmarks per bone.
pub fn fit(
    neutral: &Mesh,
    skin_landmarks: &SkinLandmarks,
    templates: &BoneTemplates,
) -> Result<FittedBones> {
    let mm = skin_landmarks.mm_per_unit as f64;
    if !(mm > 0.0 && mm.is_finite()) {
        bail!("mm per unit must be positive, got {mm}");
    }
    neutral
        .validate()
        .context("the neutral mesh to fit bones to")?;
    let nv = neutral.positions.len();
    if let Some((n, v)) = skin_landmarks
        .vertices
        .iter()
        .find(|(_, v)| **v as usize >= nv)
    {
        bail!("skin landmark {n} is vertex {v}, beyond the mesh's {nv} vertices");
    }
    let frame = FaceFrame::new(neutral, skin_landmarks)?;
    let comp = components(neutral);
    let normals = oriented_normals(neutral, &comp);
    let pos: Vec<[f64; 3]> = neutral.positions.iter().map(|p| v64(*p)).collect();

    // Landmark pairs: bone landmark → skin landmark pushed in by the expected thickness.
    struct Pair<'a> {
        lm: &'a BoneLandmark,
        vertex: u32,
        target: [f64; 3],
    }
    let pairs: Vec<Pair<'_>> = templates
        .landmarks
        .iter()
        .filter_map(|lm| {
            let v = *skin_landmarks.vertices.get(&lm.name)?;
            let d = lm.fstt_mm as f64 / mm;
            let target = sub(pos[v as usize], scale3(normals[v as usize], d));
            Some(Pair {
                lm,
                vertex: v,
                target,
            })
        })
        .collect();
    for bone in [Bone::Skull, Bone::Jaw] {
        let n = pairs
            .iter()
            .filter(|p| p.lm.bone == bone && p.lm.weight > 0.0)
            .count();
        if n < 3 {
            bail!("only {n} weighted skin landmarks for the {bone:?}; 3 needed");
        }
    }
    let (lx, ly, lw): (Vec<_>, Vec<_>, Vec<_>) = {
        let mut x = Vec::new();
        let mut y = Vec::new();
        let mut w = Vec::new();
        for p in pairs.iter().filter(|p| p.lm.weight > 0.0) {
            x.push(v64(p.lm.position));
            y.push(p.target);
            w.push(p.lm.weight as f64);
        }
        (x, y, w)
    };
    // Symmetry: the templates are mirror-symmetric about their x = 0 plane; every pair is also
    // used mirrored (template across x = 0, skin across the face's midsagittal plane), so the
    // fit maps one plane onto the other and cannot yaw or roll the bones to one side. The
    // plane has normal `left` and passes through the midline landmarks and the zygia's midpoint.
    let left = v64(frame.left);
    let mid_offset = {
        let mut acc = Vec::new();
        for n in ["nasion", "menton"] {
            if let Some(&v) = skin_landmarks.vertices.get(n) {
                acc.push(dot(pos[v as usize], left));
            }
        }
        if let (Some(&a), Some(&b)) = (
            skin_landmarks.vertices.get("zygion_l"),
            skin_landmarks.vertices.get("zygion_r"),
        ) {
            acc.push(0.5 * (dot(pos[a as usize], left) + dot(pos[b as usize], left)));
        }
        acc.iter().sum::<f64>() / acc.len().max(1) as f64
    };
    let mirror = Mirror {
        left,
        offset: mid_offset,
    };
    let (lx, ly, lw) = mirror.symmetrize(&lx, &ly, &lw);
    let init = fit_similarity(&lx, &ly, &lw);

    // ICP targets: geodesic patches around the weighted landmarks and the extra patches, then
    // the calvarium. Each source: (skin vertex, radius, thickness in units, bone).
    let mut sources: Vec<(u32, f64, f64, Bone)> = pairs
        .iter()
        .filter(|p| p.lm.weight > 0.0)
        .map(|p| {
            (
                p.vertex,
                p.lm.patch_mm as f64 / mm,
                p.lm.fstt_mm as f64 / mm,
                p.lm.bone,
            )
        })
        .collect();
    for patch in &templates.patches {
        if let Some(&v) = skin_landmarks.vertices.get(&patch.name) {
            sources.push((
                v,
                patch.patch_mm as f64 / mm,
                patch.fstt_mm as f64 / mm,
                patch.bone,
            ));
        }
    }
    let radii: Vec<(u32, f64)> = sources.iter().map(|s| (s.0, s.1)).collect();
    let label = geodesic_labels(neutral, &pos, &radii);
    let mut targets = Vec::new();
    let mut taken = vec![false; nv];
    for (v, l) in label.iter().enumerate() {
        let Some(k) = *l else { continue };
        let (centre, _, d, bone) = sources[k];
        if dot(normals[v], normals[centre as usize]) < PAIR_MIN_COS {
            continue;
        }
        taken[v] = true;
        targets.push(Target {
            point: sub(pos[v], scale3(normals[v], d)),
            normal: normals[v],
            bone,
        });
    }
    let up = v64(frame.up);
    let forward = v64(frame.forward);
    let nasion = *skin_landmarks
        .vertices
        .get("nasion")
        .ok_or_else(|| anyhow!("skin landmark nasion is missing"))?;
    let brow = ["supraorbitale_r", "supraorbitale_l"]
        .iter()
        .filter_map(|n| skin_landmarks.vertices.get(*n))
        .map(|&v| dot(pos[v as usize], up))
        .fold(f64::NEG_INFINITY, f64::max);
    let brow = if brow.is_finite() {
        brow
    } else {
        dot(pos[nasion as usize], up)
    };
    let above = brow + templates.calvarium_above_brows_mm as f64 / mm;
    let calv_d = templates.calvarium_thickness_mm as f64 / mm;
    let mut backward = 0;
    for v in 0..nv {
        if taken[v] || comp[v] != comp[nasion as usize] || dot(pos[v], up) <= above {
            continue;
        }
        if dot(normals[v], forward) < -0.3 {
            backward += 1;
        }
        targets.push(Target {
            point: sub(pos[v], scale3(normals[v], calv_d)),
            normal: normals[v],
            bone: Bone::Skull,
        });
    }
    let closed_head = backward >= CLOSED_HEAD_TARGETS;

    // The two groups.
    let skull_src: Vec<[f64; 3]> = templates
        .maxilla
        .positions
        .iter()
        .chain(&templates.cranium.positions)
        .map(|p| v64(*p))
        .collect();
    let skull_n: Vec<[f64; 3]> = templates
        .maxilla
        .vertex_normals()
        .into_iter()
        .chain(templates.cranium.vertex_normals())
        .map(v64)
        .collect();
    let jaw_src: Vec<[f64; 3]> = templates.jaw.positions.iter().map(|p| v64(*p)).collect();
    let jaw_n: Vec<[f64; 3]> = templates
        .jaw
        .vertex_normals()
        .into_iter()
        .map(v64)
        .collect();

    let mut groups = Vec::new();
    let mut transforms = Vec::new();
    for (bone, src, srcn) in [
        (Bone::Skull, &skull_src, &skull_n),
        (Bone::Jaw, &jaw_src, &jaw_n),
    ] {
        let tg: Vec<Target> = targets.iter().copied().filter(|t| t.bone == bone).collect();
        let lm: Vec<([f64; 3], [f64; 3], f64)> = pairs
            .iter()
            .filter(|p| p.lm.bone == bone && p.lm.weight > 0.0)
            .map(|p| (v64(p.lm.position), p.target, p.lm.weight as f64))
            .collect();
        let icp = Icp {
            src,
            normals: srcn,
            targets: &tg,
            landmarks: &lm,
            cell: CELL_MM / mm,
            floor: REJECT_FLOOR_MM / mm,
            mirror,
        };
        let mut model = if bone == Bone::Skull && closed_head {
            Model::Affine
        } else {
            Model::Similarity
        };
        let mut run = icp.run(init, model);
        let sv = singular_values(run.tf.a);
        if model == Model::Affine && sv[0] > MAX_ANISOTROPY * sv[2] {
            model = Model::Similarity;
            run = icp.run(init, model);
        }
        let sv = singular_values(run.tf.a);
        let moved: Vec<[f32; 3]> = src.iter().map(|p| v32(run.tf.apply(*p))).collect();
        let behind = behind_skin(
            neutral,
            &frame,
            &moved,
            (NEAR_DEPTH_MM as f64 / mm) as f32,
            (1.0 / mm) as f32,
        );
        groups.push(GroupReport {
            bone,
            model,
            transform: run.tf.matrix(),
            scale: [
                (sv[0] * mm) as f32,
                (sv[1] * mm) as f32,
                (sv[2] * mm) as f32,
            ],
            targets: tg.len(),
            pairs: run.pairs,
            median_residual: run.median as f32,
            rms_residual: run.rms as f32,
            iterations: run.iterations,
            behind_skin: behind,
        });
        transforms.push((bone, run.tf));
    }
    let tf_of = |b: Bone| {
        transforms
            .iter()
            .find(|t| t.0 == b)
            .map(|t| t.1)
            .unwrap_or(init)
    };

    let landmarks = pairs
        .iter()
        .map(|p| {
            let b = tf_of(p.lm.bone).apply(v64(p.lm.position));
            LandmarkReport {
                name: p.lm.name.clone(),
                bone: p.lm.bone,
                weight: p.lm.weight,
                skin_vertex: p.vertex,
                fstt_mm: p.lm.fstt_mm,
                residual: norm(sub(b, p.target)) as f32,
                depth_mm: (norm(sub(b, pos[p.vertex as usize])) * mm) as f32,
            }
        })
        .collect();
    let moved = |m: &Mesh, tf: &Affine| {
        Mesh::new(
            m.positions.iter().map(|p| v32(tf.apply(v64(*p)))).collect(),
            m.polygons.clone(),
        )
    };
    let skull_tf = tf_of(Bone::Skull);
    let mut skull = moved(&templates.maxilla, &skull_tf);
    let offset = skull.positions.len() as u32;
    let cranium = moved(&templates.cranium, &skull_tf);
    skull.positions.extend(cranium.positions);
    skull.polygons.extend(
        cranium
            .polygons
            .into_iter()
            .map(|p| p.into_iter().map(|v| v + offset).collect()),
    );
    let jaw = moved(&templates.jaw, &tf_of(Bone::Jaw));
    Ok(FittedBones {
        skull,
        jaw,
        report: FitReport {
            mm_per_unit: mm as f32,
            frame,
            cranium_registration: templates.cranium_registration,
            groups,
            landmarks,
        },
    })
}

/// The ICP problem of one bone group.
struct Icp<'a> {
    /// Template vertices (mm frame).
    src: &'a [[f64; 3]],
    /// Template vertex normals.
    normals: &'a [[f64; 3]],
    targets: &'a [Target],
    /// (template point, target point, weight).
    landmarks: &'a [([f64; 3], [f64; 3], f64)],
    /// Search cell, skin units.
    cell: f64,
    /// Rejection floor, skin units.
    floor: f64,
    /// Pairs are used mirrored too.
    mirror: Mirror,
}

/// The two mirror planes: the templates' `x = 0` and the skin's plane `left · p = offset`.
#[derive(Clone, Copy, Debug)]
struct Mirror {
    left: V3,
    offset: f64,
}

impl Mirror {
    fn template(&self, p: V3) -> V3 {
        [-p[0], p[1], p[2]]
    }

    fn skin(&self, p: V3) -> V3 {
        sub(
            p,
            scale3(self.left, 2.0 * (dot(p, self.left) - self.offset)),
        )
    }

    /// The pairs followed by their mirror images.
    fn symmetrize(&self, x: &[V3], y: &[V3], w: &[f64]) -> (Vec<V3>, Vec<V3>, Vec<f64>) {
        let mut xs = x.to_vec();
        let mut ys = y.to_vec();
        let mut ws = w.to_vec();
        xs.extend(x.iter().map(|p| self.template(*p)));
        ys.extend(y.iter().map(|p| self.skin(*p)));
        ws.extend_from_slice(w);
        (xs, ys, ws)
    }
}

struct IcpRun {
    tf: Affine,
    pairs: usize,
    median: f64,
    rms: f64,
    iterations: usize,
}

impl Icp<'_> {
    fn run(&self, init: Affine, model: Model) -> IcpRun {
        let mut tf = init;
        let mut out = IcpRun {
            tf,
            pairs: 0,
            median: f64::NAN,
            rms: f64::NAN,
            iterations: 0,
        };
        // Probe points to measure how much an update moves the bone.
        let (lo, hi) = bbox(self.src);
        let probes: Vec<[f64; 3]> = (0..8)
            .map(|c| {
                [
                    if c & 1 == 0 { lo[0] } else { hi[0] },
                    if c & 2 == 0 { lo[1] } else { hi[1] },
                    if c & 4 == 0 { lo[2] } else { hi[2] },
                ]
            })
            .collect();
        for it in 0..ICP_ITERATIONS {
            let cof = cofactor(tf.a);
            let moved: Vec<[f64; 3]> = self.src.iter().map(|p| tf.apply(*p)).collect();
            let mnorm: Vec<[f64; 3]> = self
                .normals
                .iter()
                .map(|n| normalize(mat_vec(cof, *n)))
                .collect();
            let grid = Grid::new(&moved, self.cell);
            let found: Vec<(usize, usize, f64)> = self
                .targets
                .iter()
                .enumerate()
                .filter_map(|(ti, t)| {
                    grid.nearest_where(&moved, t.point, |j| {
                        dot(mnorm[j], t.normal).abs() >= PAIR_MIN_COS
                    })
                    .map(|(j, d)| (ti, j, d))
                })
                .collect();
            let mut ds: Vec<f64> = found.iter().map(|f| f.2).collect();
            ds.sort_by(f64::total_cmp);
            let median = ds.get(ds.len() / 2).copied().unwrap_or(0.0);
            let limit = (REJECT_MEDIANS * median).max(self.floor);
            let kept: Vec<&(usize, usize, f64)> = found.iter().filter(|f| f.2 <= limit).collect();
            let mut x = Vec::with_capacity(kept.len() + self.landmarks.len());
            let mut y = Vec::with_capacity(x.capacity());
            let mut w = Vec::with_capacity(x.capacity());
            for f in &kept {
                x.push(self.src[f.1]);
                y.push(self.targets[f.0].point);
                w.push(1.0);
            }
            let lw_sum: f64 = self.landmarks.iter().map(|l| l.2).sum();
            let share = if lw_sum > 0.0 {
                LANDMARK_SHARE * (kept.len().max(1) as f64) / lw_sum
            } else {
                0.0
            };
            for l in self.landmarks {
                x.push(l.0);
                y.push(l.1);
                w.push(l.2 * share);
            }
            let (x, y, w) = self.mirror.symmetrize(&x, &y, &w);
            let next = match model {
                Model::Similarity => fit_similarity(&x, &y, &w),
                Model::Affine => {
                    fit_affine(&x, &y, &w).unwrap_or_else(|| fit_similarity(&x, &y, &w))
                }
            };
            let change = probes
                .iter()
                .map(|p| norm(sub(next.apply(*p), tf.apply(*p))))
                .fold(0.0, f64::max);
            tf = next;
            let rms =
                (kept.iter().map(|f| f.2 * f.2).sum::<f64>() / kept.len().max(1) as f64).sqrt();
            out = IcpRun {
                tf,
                pairs: kept.len(),
                median,
                rms,
                iterations: it + 1,
            };
            // Converged when no template corner moves by more than a hundredth of a millimetre.
            if change < 0.01 * self.floor / REJECT_FLOOR_MM {
                break;
            }
        }
        out
    }
}

// ---------------------------------------------------------------------------------------------
// Behind the skin.

/// How many bone vertices near the face lie behind the skin (see [`behind_skin`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct BehindSkin {
    /// Vertices near the face.
    pub near: usize,
    /// Of those, the ones behind the skin in every view.
    pub behind: usize,
}

impl BehindSkin {
    /// `behind / near` (1 when nothing is near).
    pub fn fraction(&self) -> f32 {
        if self.near == 0 {
            1.0
        } else {
            self.behind as f32 / self.near as f32
        }
    }
}

/// Checks that bone points lie inside the skin, seen from four sides. The whole skin mesh is
/// rendered into depth maps (pixel size `pixel`, in the skin's unit) looking from the front,
/// the left, the right and the top of the face frame. A point is *near the face* if in some view
/// a skin pixel covers it and it lies in front of that skin or less than `near_depth` behind it;
/// it is *behind the skin* if in no covering view it lies in front of the skin.
///
/// Why views and not the nearest skin vertex: near the mouth and eyes the nearest skin vertex is
/// often on an inner lip or eyelid rim whose normal faces the teeth or the orbit, which would
/// call a tooth "in front of the skin". A depth map asks the right question: is there skin
/// between this bone point and the outside?
pub fn behind_skin(
    skin: &Mesh,
    frame: &FaceFrame,
    points: &[[f32; 3]],
    near_depth: f32,
    pixel: f32,
) -> BehindSkin {
    let (l, u, f) = (v64(frame.left), v64(frame.up), v64(frame.forward));
    let views = [
        (l, u, f),
        (f, u, scale3(l, -1.0)),
        (scale3(f, -1.0), u, l),
        (l, scale3(f, -1.0), u),
    ];
    let tris = skin.triangles();
    let maps: Vec<DepthMap> = views
        .iter()
        .map(|&(a, b, c)| DepthMap::render(&skin.positions, &tris, a, b, c, pixel as f64))
        .collect();
    let mut out = BehindSkin::default();
    for p in points {
        let p = v64(*p);
        let (mut near, mut front) = (false, false);
        for (m, &(a, b, c)) in maps.iter().zip(&views) {
            let Some(depth) = m.depth(dot(p, a), dot(p, b)) else {
                continue;
            };
            let z = dot(p, c);
            if z > depth {
                front = true;
                near = true;
            } else if z > depth - near_depth as f64 {
                near = true;
            }
        }
        if near {
            out.near += 1;
            if !front {
                out.behind += 1;
            }
        }
    }
    out
}

/// The largest `c` coordinate of the skin over a pixel grid in the `(a, b)` plane.
struct DepthMap {
    lo: [f64; 2],
    pixel: f64,
    w: usize,
    h: usize,
    depth: Vec<f64>,
}

impl DepthMap {
    fn render(pos: &[[f32; 3]], tris: &[[u32; 3]], a: V3, b: V3, c: V3, pixel: f64) -> Self {
        let proj: Vec<[f64; 3]> = pos
            .iter()
            .map(|p| {
                let p = v64(*p);
                [dot(p, a), dot(p, b), dot(p, c)]
            })
            .collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in &proj {
            for k in 0..2 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
        // Keep the map to at most 2048 pixels a side whatever the unit.
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(0.0);
        let pixel = if pixel > 0.0 {
            pixel.max(span / 2048.0)
        } else {
            span / 2048.0
        };
        let (w, h) = if proj.is_empty() || pixel.is_nan() || pixel <= 0.0 {
            (0, 0)
        } else {
            (
                ((hi[0] - lo[0]) / pixel) as usize + 2,
                ((hi[1] - lo[1]) / pixel) as usize + 2,
            )
        };
        let mut m = Self {
            lo,
            pixel,
            w,
            h,
            depth: vec![f64::NEG_INFINITY; w * h],
        };
        if w == 0 {
            return m;
        }
        for t in tris {
            let [p0, p1, p2] = t.map(|i| proj[i as usize]);
            let d = (p1[1] - p2[1]) * (p0[0] - p2[0]) + (p2[0] - p1[0]) * (p0[1] - p2[1]);
            if d.abs() < 1e-30 {
                continue;
            }
            let px = |x: f64, k: usize| (x - m.lo[k]) / m.pixel;
            let x0 = px(p0[0].min(p1[0]).min(p2[0]), 0).floor().max(0.0) as usize;
            let x1 = (px(p0[0].max(p1[0]).max(p2[0]), 0).ceil() as usize).min(w - 1);
            let y0 = px(p0[1].min(p1[1]).min(p2[1]), 1).floor().max(0.0) as usize;
            let y1 = (px(p0[1].max(p1[1]).max(p2[1]), 1).ceil() as usize).min(h - 1);
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    let (x, y) = (m.lo[0] + ix as f64 * m.pixel, m.lo[1] + iy as f64 * m.pixel);
                    let l0 = ((p1[1] - p2[1]) * (x - p2[0]) + (p2[0] - p1[0]) * (y - p2[1])) / d;
                    let l1 = ((p2[1] - p0[1]) * (x - p2[0]) + (p0[0] - p2[0]) * (y - p2[1])) / d;
                    let l2 = 1.0 - l0 - l1;
                    if l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9 {
                        continue;
                    }
                    let z = l0 * p0[2] + l1 * p1[2] + l2 * p2[2];
                    let cell = &mut m.depth[iy * w + ix];
                    if z > *cell {
                        *cell = z;
                    }
                }
            }
        }
        m
    }

    /// The skin depth at the pixel nearest `(x, y)`, if skin covers it.
    fn depth(&self, x: f64, y: f64) -> Option<f64> {
        let ix = ((x - self.lo[0]) / self.pixel).round();
        let iy = ((y - self.lo[1]) / self.pixel).round();
        if !(ix >= 0.0 && iy >= 0.0 && (ix as usize) < self.w && (iy as usize) < self.h) {
            return None;
        }
        let d = self.depth[iy as usize * self.w + ix as usize];
        d.is_finite().then_some(d)
    }
}

// ---------------------------------------------------------------------------------------------
// Mesh helpers.

/// Connected component of every vertex (over polygon edges), numbered by lowest vertex.
fn components(mesh: &Mesh) -> Vec<u32> {
    let n = mesh.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for poly in &mesh.polygons {
        for w in poly.windows(2) {
            let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
            // Union towards the lower root, so the labels do not depend on polygon order.
            match a.cmp(&b) {
                Ordering::Less => parent[b as usize] = a,
                Ordering::Greater => parent[a as usize] = b,
                Ordering::Equal => {}
            }
        }
    }
    (0..n as u32).map(|v| find(&mut parent, v)).collect()
}

/// Vertex normals, flipped per component if they point inward on the whole (the component's
/// normals then mostly point away from its centroid).
fn oriented_normals(mesh: &Mesh, comp: &[u32]) -> Vec<[f64; 3]> {
    let mut normals: Vec<[f64; 3]> = mesh.vertex_normals().into_iter().map(v64).collect();
    let mut centre: HashMap<u32, ([f64; 3], usize)> = HashMap::new();
    for (v, p) in mesh.positions.iter().enumerate() {
        let e = centre.entry(comp[v]).or_insert(([0.0; 3], 0));
        e.0 = add(e.0, v64(*p));
        e.1 += 1;
    }
    let mut score: HashMap<u32, f64> = HashMap::new();
    for (v, p) in mesh.positions.iter().enumerate() {
        let (c, n) = centre[&comp[v]];
        let c = scale3(c, 1.0 / n as f64);
        *score.entry(comp[v]).or_insert(0.0) += dot(normals[v], sub(v64(*p), c));
    }
    for (v, n) in normals.iter_mut().enumerate() {
        if score[&comp[v]] < 0.0 {
            *n = scale3(*n, -1.0);
        }
    }
    normals
}

/// The vertex of component `c` nearest to `q` (lowest index on ties).
fn nearest_in_component(mesh: &Mesh, comp: &[u32], c: u32, q: [f64; 3]) -> Option<u32> {
    mesh.positions
        .iter()
        .enumerate()
        .filter(|(v, _)| comp[*v] == c)
        .map(|(v, p)| (norm(sub(v64(*p), q)), v))
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, v)| v as u32)
}

/// Multi-source Dijkstra over mesh edges: every vertex within its nearest source's radius gets
/// that source's index. Ties go to the lower source index.
fn geodesic_labels(mesh: &Mesh, pos: &[[f64; 3]], sources: &[(u32, f64)]) -> Vec<Option<usize>> {
    let n = pos.len();
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    for poly in &mesh.polygons {
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    #[derive(PartialEq)]
    struct Item(f64, usize, u32);
    impl Eq for Item {}
    impl PartialOrd for Item {
        fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Item {
        // Reversed: BinaryHeap is a max-heap and we want the smallest distance first.
        fn cmp(&self, o: &Self) -> Ordering {
            o.0.total_cmp(&self.0)
                .then(o.1.cmp(&self.1))
                .then(o.2.cmp(&self.2))
        }
    }
    let mut dist = vec![f64::INFINITY; n];
    let mut label: Vec<Option<usize>> = vec![None; n];
    let mut heap = BinaryHeap::new();
    for (k, &(v, r)) in sources.iter().enumerate() {
        if r > 0.0 && (v as usize) < n {
            heap.push(Item(0.0, k, v));
        }
    }
    while let Some(Item(d, k, v)) = heap.pop() {
        let vi = v as usize;
        if label[vi].is_some() {
            continue;
        }
        label[vi] = Some(k);
        dist[vi] = d;
        for &w in &adj[vi] {
            let nd = d + norm(sub(pos[w as usize], pos[vi]));
            if nd <= sources[k].1 && nd < dist[w as usize] && label[w as usize].is_none() {
                dist[w as usize] = nd;
                heap.push(Item(nd, k, w));
            }
        }
    }
    label
}

// ---------------------------------------------------------------------------------------------
// Nearest neighbours.

/// A uniform grid over points for nearest-neighbour queries.
pub(crate) struct Grid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl Grid {
    pub(crate) fn new(pts: &[[f64; 3]], cell: f64) -> Self {
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, p) in pts.iter().enumerate() {
            cells.entry(Self::key(p, cell)).or_default().push(i as u32);
        }
        Self { cell, cells }
    }

    fn key(p: &[f64; 3], cell: f64) -> [i64; 3] {
        p.map(|x| (x / cell).floor() as i64)
    }

    /// The nearest point passing `ok` within the 27 cells around `q` (so anything closer than
    /// one cell is always found): index and distance; ties go to the lower index.
    pub(crate) fn nearest_where(
        &self,
        pts: &[[f64; 3]],
        q: [f64; 3],
        ok: impl Fn(usize) -> bool,
    ) -> Option<(usize, f64)> {
        let k = Self::key(&q, self.cell);
        let mut best: Option<(usize, f64)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                        continue;
                    };
                    for &i in list {
                        let i = i as usize;
                        let d = norm(sub(pts[i], q));
                        let better = match best {
                            None => true,
                            Some((bi, bd)) => d < bd || (d == bd && i < bi),
                        };
                        if better && ok(i) {
                            best = Some((i, d));
                        }
                    }
                }
            }
        }
        best
    }

    /// The exact nearest point: grows the searched shell of cells until no closer point can be
    /// outside it.
    fn nearest(&self, pts: &[[f64; 3]], q: [f64; 3]) -> Option<(usize, f64)> {
        if pts.is_empty() {
            return None;
        }
        let k = Self::key(&q, self.cell);
        let mut best: Option<(usize, f64)> = None;
        for r in 0i64.. {
            for dx in -r..=r {
                for dy in -r..=r {
                    for dz in -r..=r {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                            continue;
                        }
                        let Some(list) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                            continue;
                        };
                        for &i in list {
                            let i = i as usize;
                            let d = norm(sub(pts[i], q));
                            if best.is_none_or(|(bi, bd)| d < bd || (d == bd && i < bi)) {
                                best = Some((i, d));
                            }
                        }
                    }
                }
            }
            // Every point outside shell r is at least r cells away.
            if let Some((_, bd)) = best
                && bd <= r as f64 * self.cell
            {
                break;
            }
            // Far outside the data: stop once the shell covers every cell.
            if r > 1 << 20 {
                break;
            }
        }
        best
    }
}

/// A cell size giving about `per_side` cells along the largest extent of `pts`.
fn cell_for(pts: &[[f64; 3]], per_side: usize) -> f64 {
    let (lo, hi) = bbox(pts);
    let span = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if span > 0.0 {
        span / per_side as f64
    } else {
        1.0
    }
}

fn bbox(pts: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if pts.is_empty() {
        ([0.0; 3], [0.0; 3])
    } else {
        (lo, hi)
    }
}

// ---------------------------------------------------------------------------------------------
// Transforms.

type M3 = [[f64; 3]; 3];

/// `x ↦ a x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Affine {
    a: M3,
    t: V3,
}

impl Affine {
    fn apply(&self, p: V3) -> V3 {
        add(mat_vec(self.a, p), self.t)
    }

    /// Uniform scale (cube root of the determinant's magnitude).
    fn scale(&self) -> f64 {
        det3(self.a).abs().cbrt()
    }

    fn inverse(&self) -> Option<Affine> {
        let inv = inv3(self.a)?;
        Some(Affine {
            a: inv,
            t: scale3(mat_vec(inv, self.t), -1.0),
        })
    }

    fn matrix(&self) -> [[f32; 4]; 3] {
        let r = |i: usize| {
            [
                self.a[i][0] as f32,
                self.a[i][1] as f32,
                self.a[i][2] as f32,
                self.t[i] as f32,
            ]
        };
        [r(0), r(1), r(2)]
    }
}

/// Weighted means and centred cross-covariance `Σ w (y - ȳ)(x - x̄)ᵀ` and `Σ w (x - x̄)(x - x̄)ᵀ`.
fn moments(x: &[V3], y: &[V3], w: &[f64]) -> (V3, V3, M3, M3, f64) {
    let ws: f64 = w.iter().sum();
    let ws = if ws > 0.0 { ws } else { 1.0 };
    let mut mx = [0.0; 3];
    let mut my = [0.0; 3];
    for ((p, q), &wi) in x.iter().zip(y).zip(w) {
        mx = add(mx, scale3(*p, wi / ws));
        my = add(my, scale3(*q, wi / ws));
    }
    let mut cyx = [[0.0; 3]; 3];
    let mut cxx = [[0.0; 3]; 3];
    for ((p, q), &wi) in x.iter().zip(y).zip(w) {
        let (xc, yc) = (sub(*p, mx), sub(*q, my));
        for i in 0..3 {
            for j in 0..3 {
                cyx[i][j] += wi * yc[i] * xc[j];
                cxx[i][j] += wi * xc[i] * xc[j];
            }
        }
    }
    (mx, my, cyx, cxx, ws)
}

/// The rotation `R` maximising `tr(Rᵀ C_yx)`, i.e. the rotation of the weighted least-squares
/// fit `y ≈ R x + t` (or `s R x + t`) given the centred cross-covariance `C_yx` of
/// [`moments`]: Horn 1987's quaternion solution (the minimiser Umeyama 1991 gives in closed
/// form), always a proper rotation.
fn horn_rotation(cyx: &M3) -> M3 {
    // Horn's S_ab = Σ x_a y_b = cyx[b][a].
    let s = |a: usize, b: usize| cyx[b][a];
    let n = [
        [
            s(0, 0) + s(1, 1) + s(2, 2),
            s(1, 2) - s(2, 1),
            s(2, 0) - s(0, 2),
            s(0, 1) - s(1, 0),
        ],
        [
            s(1, 2) - s(2, 1),
            s(0, 0) - s(1, 1) - s(2, 2),
            s(0, 1) + s(1, 0),
            s(2, 0) + s(0, 2),
        ],
        [
            s(2, 0) - s(0, 2),
            s(0, 1) + s(1, 0),
            -s(0, 0) + s(1, 1) - s(2, 2),
            s(1, 2) + s(2, 1),
        ],
        [
            s(0, 1) - s(1, 0),
            s(2, 0) + s(0, 2),
            s(1, 2) + s(2, 1),
            -s(0, 0) - s(1, 1) + s(2, 2),
        ],
    ];
    let (vals, vecs) = jacobi_eigen(n);
    let best = (0..4).fold(0, |b, i| if vals[i] > vals[b] { i } else { b });
    quat_to_mat([vecs[0][best], vecs[1][best], vecs[2][best], vecs[3][best]])
}

/// The weighted least-squares similarity `y ≈ s R x + t` (Horn 1987's quaternion solution; it
/// is the minimiser Umeyama 1991 gives in closed form and always a proper rotation).
fn fit_similarity(x: &[V3], y: &[V3], w: &[f64]) -> Affine {
    let (mx, my, cyx, cxx, _) = moments(x, y, w);
    let r = horn_rotation(&cyx);
    let var = cxx[0][0] + cxx[1][1] + cxx[2][2];
    // s = Σ w (y - ȳ)·R(x - x̄) / Σ w |x - x̄|² = tr(Rᵀ C_yx) / tr(C_xx).
    let mut num = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            num += r[i][j] * cyx[i][j];
        }
    }
    let sc = if var > 0.0 { num / var } else { 1.0 };
    let a = r.map(|row| row.map(|v| v * sc));
    Affine {
        a,
        t: sub(my, mat_vec(a, mx)),
    }
}

/// A rigid transform `x ↦ R x + t` from [`fit_rigid`], in `f64`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidFit {
    /// The rotation `R`, row-major (`rotation[i][j]` is row `i`, column `j`); proper.
    pub rotation: [[f64; 3]; 3],
    /// The translation `t`, added after rotating.
    pub translation: [f64; 3],
}

impl RigidFit {
    /// `R p + t`.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        add(mat_vec(self.rotation, p), self.translation)
    }
}

/// The least-squares rigid transform `y ≈ R x + t` taking the points `x` to the corresponding
/// points `y` (Horn 1987's quaternion rotation, as in the bone fit's similarity, without the
/// scale). `None` when the two lists differ in length, a coordinate is not finite, or the
/// points `x` do not determine a rotation: fewer than three, or (nearly) collinear (the second
/// principal variance under 1e-9 of the first).
pub fn fit_rigid(x: &[[f32; 3]], y: &[[f32; 3]]) -> Option<RigidFit> {
    if x.len() != y.len() || x.len() < 3 {
        return None;
    }
    let x: Vec<V3> = x.iter().copied().map(v64).collect();
    let y: Vec<V3> = y.iter().copied().map(v64).collect();
    if x.iter().chain(&y).flatten().any(|c| !c.is_finite()) {
        return None;
    }
    let (mx, my, cyx, cxx, _) = moments(&x, &y, &vec![1.0; x.len()]);
    let (mut spread, _) = jacobi_eigen(cxx);
    spread.sort_by(|a, b| b.total_cmp(a));
    if !(spread[0] > 0.0 && spread[1] > 1e-9 * spread[0]) {
        return None;
    }
    let rotation = horn_rotation(&cyx);
    Some(RigidFit {
        rotation,
        translation: sub(my, mat_vec(rotation, mx)),
    })
}

/// The weighted least-squares affine map `y ≈ A x + t`: `A = C_yx C_xx⁻¹`. `None` when the
/// points are (nearly) coplanar.
fn fit_affine(x: &[V3], y: &[V3], w: &[f64]) -> Option<Affine> {
    let (mx, my, cyx, cxx, _) = moments(x, y, w);
    let inv = inv3(cxx)?;
    let a = mat_mul(cyx, inv);
    Some(Affine {
        a,
        t: sub(my, mat_vec(a, mx)),
    })
}

/// Eigenvalues and eigenvectors (columns) of a symmetric matrix by cyclic Jacobi rotations.
fn jacobi_eigen<const N: usize>(mut a: [[f64; N]; N]) -> ([f64; N], [[f64; N]; N]) {
    let mut v = [[0.0; N]; N];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..64 {
        let off: f64 = (0..N)
            .flat_map(|i| (0..N).map(move |j| (i, j)))
            .filter(|(i, j)| i != j)
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let scale: f64 = (0..N).map(|i| a[i][i] * a[i][i]).sum::<f64>() + off;
        if off <= 1e-30 * scale.max(1e-300) {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in a.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (rp, rq) = (a[p], a[q]);
                for k in 0..N {
                    a[p][k] = c * rp[k] - s * rq[k];
                    a[q][k] = s * rp[k] + c * rq[k];
                }
                for row in v.iter_mut() {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    let mut vals = [0.0; N];
    for (i, val) in vals.iter_mut().enumerate() {
        *val = a[i][i];
    }
    (vals, v)
}

/// Singular values of a 3×3 matrix, largest first.
fn singular_values(a: M3) -> [f64; 3] {
    let ata = mat_mul(transpose(a), a);
    let (vals, _) = jacobi_eigen(ata);
    let mut s = vals.map(|v| v.max(0.0).sqrt());
    s.sort_by(|x, y| y.total_cmp(x));
    s
}

fn quat_to_mat(q: [f64; 4]) -> M3 {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let [w, x, y, z] = if n > 0.0 {
        q.map(|c| c / n)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    };
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

fn v64(p: [f32; 3]) -> V3 {
    p.map(f64::from)
}
fn v32(p: V3) -> [f32; 3] {
    p.map(|c| c as f32)
}
fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale3(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn normalize(a: V3) -> V3 {
    let n = norm(a);
    if n > 0.0 {
        scale3(a, 1.0 / n)
    } else {
        [0.0; 3]
    }
}
fn lerp(a: V3, b: V3, t: f64) -> V3 {
    add(scale3(a, 1.0 - t), scale3(b, t))
}
fn mat_vec(m: M3, v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}
fn mat_mul(a: M3, b: M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    c
}
fn transpose(a: M3) -> M3 {
    [
        [a[0][0], a[1][0], a[2][0]],
        [a[0][1], a[1][1], a[2][1]],
        [a[0][2], a[1][2], a[2][2]],
    ]
}
/// The cofactor matrix: `det(a) a⁻ᵀ`, which maps normals (up to length and sign).
fn cofactor(a: M3) -> M3 {
    [cross(a[1], a[2]), cross(a[2], a[0]), cross(a[0], a[1])]
}
fn det3(a: M3) -> f64 {
    dot(a[0], cross(a[1], a[2]))
}
fn inv3(a: M3) -> Option<M3> {
    let d = det3(a);
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if d.is_nan() || d.abs() <= 1e-12 * scale * scale * scale {
        return None;
    }
    // a⁻¹ = cofactor(a)ᵀ / det.
    Some(transpose(cofactor(a)).map(|row| row.map(|v| v / d)))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::testing::data_dir;

    /// A small deterministic generator in [-1, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
        fn v3(&mut self) -> V3 {
            [self.next(), self.next(), self.next()]
        }
    }

    fn rotation(axis: V3, angle: f64) -> M3 {
        let [x, y, z] = normalize(axis);
        let (s, c) = ((angle / 2.0).sin(), (angle / 2.0).cos());
        quat_to_mat([c, x * s, y * s, z * s])
    }

    #[test]
    fn similarity_is_recovered_and_proper() {
        let mut g = Lcg(7);
        let r = rotation([0.3, -1.0, 0.5], 2.5);
        let truth = Affine {
            a: r.map(|row| row.map(|v| v * 0.1)),
            t: [1.0, -2.0, 3.0],
        };
        let x: Vec<V3> = (0..20).map(|_| scale3(g.v3(), 50.0)).collect();
        let y: Vec<V3> = x.iter().map(|p| truth.apply(*p)).collect();
        let f = fit_similarity(&x, &y, &vec![1.0; x.len()]);
        for i in 0..3 {
            for j in 0..3 {
                assert!((f.a[i][j] - truth.a[i][j]).abs() < 1e-12);
            }
            assert!((f.t[i] - truth.t[i]).abs() < 1e-10);
        }
        assert!(det3(f.a) > 0.0);
        assert!((f.scale() - 0.1).abs() < 1e-12);
        // A mirrored target cannot be matched by a rotation: the fit stays proper.
        let ym: Vec<V3> = y.iter().map(|p| [-p[0], p[1], p[2]]).collect();
        assert!(det3(fit_similarity(&x, &ym, &vec![1.0; x.len()]).a) > 0.0);
    }

    #[test]
    fn affine_is_recovered_and_inverts() {
        let mut g = Lcg(11);
        let truth = Affine {
            a: [[1.1, 0.2, 0.0], [-0.1, 0.9, 0.3], [0.05, 0.0, 1.2]],
            t: [0.5, 0.0, -1.0],
        };
        let x: Vec<V3> = (0..30).map(|_| g.v3()).collect();
        let y: Vec<V3> = x.iter().map(|p| truth.apply(*p)).collect();
        let f = fit_affine(&x, &y, &vec![1.0; x.len()]).unwrap();
        let back = f.inverse().unwrap();
        for p in &x {
            assert!(norm(sub(f.apply(*p), truth.apply(*p))) < 1e-10);
            assert!(norm(sub(back.apply(f.apply(*p)), *p)) < 1e-10);
        }
        // Coplanar points leave the normal direction free: no affine map.
        let flat: Vec<V3> = x.iter().map(|p| [p[0], p[1], 0.0]).collect();
        assert!(fit_affine(&flat, &y, &vec![1.0; x.len()]).is_none());
        let sv = singular_values([[3.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 2.0]]);
        assert!(
            (sv[0] - 3.0).abs() < 1e-12
                && (sv[1] - 2.0).abs() < 1e-12
                && (sv[2] - 1.0).abs() < 1e-12
        );
    }

    #[test]
    fn grid_nearest_matches_brute_force() {
        let mut g = Lcg(3);
        let pts: Vec<V3> = (0..2000).map(|_| scale3(g.v3(), 10.0)).collect();
        let grid = Grid::new(&pts, 0.7);
        for _ in 0..200 {
            let q = scale3(g.v3(), 14.0);
            let brute = (0..pts.len())
                .map(|i| (i, norm(sub(pts[i], q))))
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
                .unwrap();
            assert_eq!(grid.nearest(&pts, q), Some(brute));
            // The 27-cell search finds the true nearest whenever it is within one cell.
            let near = grid.nearest_where(&pts, q, |_| true);
            if brute.1 < 0.7 {
                assert_eq!(near, Some(brute));
            }
            // A filter is honoured.
            if let Some((i, _)) = grid.nearest_where(&pts, q, |i| i % 2 == 1) {
                assert_eq!(i % 2, 1);
            }
        }
    }

    /// A flat `n × n` grid of unit quads in the z = 0 plane, normals +z.
    fn sheet(n: u32) -> Mesh {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                positions.push([i as f32, j as f32, 0.0]);
            }
        }
        let mut polygons = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let v = j * (n + 1) + i;
                polygons.push(vec![v, v + 1, v + n + 2, v + n + 1]);
            }
        }
        Mesh::new(positions, polygons)
    }

    #[test]
    fn geodesic_patches_split_between_sources() {
        let m = sheet(10);
        let pos: Vec<V3> = m.positions.iter().map(|p| v64(*p)).collect();
        // Sources at (2, 5) and (8, 5), radius 2.5 and 10.
        let labels = geodesic_labels(&m, &pos, &[(5 * 11 + 2, 2.5), (5 * 11 + 8, 10.0)]);
        assert_eq!(labels[5 * 11 + 2], Some(0));
        assert_eq!(labels[5 * 11 + 4], Some(0));
        assert_eq!(labels[5 * 11 + 5], Some(1)); // 3 from source 0 (beyond its radius), 3 from source 1
        assert_eq!(labels[5 * 11], Some(0)); // 2 from source 0
        assert_eq!(labels[8 * 11 + 2], Some(1)); // 3 from source 0 (too far), 9 from source 1
        assert_eq!(labels[0], None); // 7 from source 0, 13 from source 1: beyond both radii
        let comp = components(&m);
        assert!(comp.iter().all(|&c| c == 0));
        let n = oriented_normals(&m, &comp);
        assert!(n.iter().all(|v| v[2].abs() > 0.99));
    }

    #[test]
    fn behind_skin_sees_points_in_front_and_behind() {
        // Skin: a closed cube of side 10 around the origin (6 faces of 2 triangles).
        let p: Vec<[f32; 3]> = (0..8)
            .map(|i| {
                [
                    if i & 1 == 0 { -5.0 } else { 5.0 },
                    if i & 2 == 0 { -5.0 } else { 5.0 },
                    if i & 4 == 0 { -5.0 } else { 5.0 },
                ]
            })
            .collect();
        let quads = [
            [0u32, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let skin = Mesh::new(p, quads.iter().map(|q| q.to_vec()).collect());
        let frame = FaceFrame {
            left: [1.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            forward: [0.0, 0.0, 1.0],
        };
        let inside = [[0.0, 0.0, 4.0], [4.0, 0.0, 0.0], [0.0, 4.5, 0.0]];
        let r = behind_skin(&skin, &frame, &inside, 2.0, 0.1);
        assert_eq!(r, BehindSkin { near: 3, behind: 3 });
        let outside = [[0.0, 0.0, 6.0], [-5.5, 1.0, 1.0], [0.0, 0.0, 4.0]];
        let r = behind_skin(&skin, &frame, &outside, 2.0, 0.1);
        assert_eq!(r, BehindSkin { near: 3, behind: 1 });
        // Deep inside (more than near_depth from every face): not near.
        let deep = [[0.0, 0.0, 0.0]];
        assert_eq!(behind_skin(&skin, &frame, &deep, 2.0, 0.1).near, 0);
    }

    #[test]
    fn landmark_file_is_consistent() {
        let s = spec().unwrap();
        let names: Vec<&str> = s.landmarks.iter().map(|l| l.name.as_str()).collect();
        for n in [
            "nasion",
            "menton",
            "zygion_l",
            "zygion_r",
            "pogonion",
            "prosthion",
            "glabella",
            "gonion_l",
            "gonion_r",
        ] {
            assert!(names.contains(&n), "{n} missing");
        }
        for l in &s.landmarks {
            if l.skin.is_some() {
                assert!(l.fstt_mm.is_some_and(|d| d > 0.0 && d < 25.0), "{}", l.name);
            }
            // Cranium landmarks used in the fit must survive the cut.
            if l.template == Template::Cranium && l.skin.is_some() {
                assert!(
                    l.position[s.templates.cranium.keep_axis] >= s.templates.cranium.keep_min,
                    "{}",
                    l.name
                );
            }
        }
        for [c, m] in &s.cranium_registration.pairs {
            assert!(names.contains(&c.as_str()) && names.contains(&m.as_str()));
        }
        let w = s
            .landmarks
            .iter()
            .filter(|l| l.weight.unwrap_or(1.0) > 0.0 && l.skin.is_some());
        assert!(w.count() >= 10);
    }

    #[test]
    fn missing_template_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let e = load_templates(dir.path()).unwrap_err();
        assert!(format!("{e:#}").contains("jaw.obj: missing"), "{e:#}");
    }

    #[test]
    fn real_ict_fit_places_bones_under_the_skin() {
        let Some(dir) = data_dir() else { return };
        let t0 = std::time::Instant::now();
        let templates = load_templates(&dir).unwrap();
        let reg = templates.cranium_registration;
        println!(
            "templates: jaw {} v, maxilla {} v, cranium {} v; cranium registration {:.2} mm/unit, \
             median {:.2} mm (kept pairs {:.2} mm); {:.1} s",
            templates.jaw.positions.len(),
            templates.maxilla.positions.len(),
            templates.cranium.positions.len(),
            reg.scale,
            reg.median_mm,
            reg.kept_median_mm,
            t0.elapsed().as_secs_f32()
        );
        let kit = crate::ict::IctFaceKit::open(&dir.join("ict-facekit")).unwrap();
        let neutral = kit.neutral();
        let ibug: Vec<Option<u32>> = kit.landmarks68().unwrap().into_iter().map(Some).collect();
        let skin = SkinLandmarks::from_ibug68(neutral, &ibug, 10.0).unwrap();
        let fitted = fit(neutral, &skin, &templates).unwrap();
        let rep = &fitted.report;
        println!("fit done at {:.1} s", t0.elapsed().as_secs_f32());
        for g in &rep.groups {
            println!(
                "{:?}: {:?}, scale {:?}, {} targets, {} pairs, median {:.3} cm, rms {:.3} cm, {} its, behind skin {}/{} = {:.3}",
                g.bone,
                g.model,
                g.scale,
                g.targets,
                g.pairs,
                g.median_residual,
                g.rms_residual,
                g.iterations,
                g.behind_skin.behind,
                g.behind_skin.near,
                g.behind_skin.fraction()
            );
        }
        // Constraints of the face region against the fitted bones.
        let face = 0..crate::ict::FACE_REGION.end as usize;
        let normals = neutral.vertex_normals();
        let st = fitted.skull.triangles();
        let jt = fitted.jaw.triangles();
        let bones = [
            (Bone::Skull, &fitted.skull.positions[..], &st[..]),
            (Bone::Jaw, &fitted.jaw.positions[..], &jt[..]),
        ];
        let params = crate::constraints::ConstraintParams::new(2.5);
        let tc = std::time::Instant::now();
        let c = crate::constraints::compute(
            &neutral.positions[face.clone()],
            &normals[face.clone()],
            &bones,
            &params,
        );
        println!(
            "constraints: {} skin vertices x {} bone triangles in {:.2} s (debug build)",
            face.len(),
            st.len() + jt.len(),
            tc.elapsed().as_secs_f32()
        );
        println!(
            "constraint fraction on the ICT face region (max depth 25 mm): {:.3}",
            c.fraction()
        );
        for (depth, min_cos) in [(1.0, 0.3), (1.5, 0.3), (1.5, 0.7), (2.5, 0.3), (2.5, 0.7)] {
            let p = crate::constraints::ConstraintParams {
                max_depth: depth,
                min_cos,
            };
            let k = crate::constraints::compute(
                &neutral.positions[face.clone()],
                &normals[face.clone()],
                &bones,
                &p,
            );
            let mut eq1: Vec<f32> = k
                .per_vertex
                .iter()
                .zip(&neutral.positions)
                .filter_map(|(c, s)| {
                    let r = c.as_ref()?.reconstruct();
                    Some(
                        ((r[0] - s[0]).powi(2) + (r[1] - s[1]).powi(2) + (r[2] - s[2]).powi(2))
                            .sqrt()
                            * 10.0,
                    )
                })
                .collect();
            eq1.sort_by(f32::total_cmp);
            println!(
                "max depth {} mm, min cos {min_cos}: fraction {:.3}, eq. 1 residual median {:.2} mm, p95 {:.2} mm",
                depth * 10.0,
                k.fraction(),
                eq1[eq1.len() / 2],
                eq1[eq1.len() * 95 / 100]
            );
        }
        println!("landmark | bone | fstt mm | ray mm | fit residual mm | depth mm");
        let mut ray_at = BTreeMap::new();
        for l in &rep.landmarks {
            let ray = c
                .per_vertex
                .get(l.skin_vertex as usize)
                .copied()
                .flatten()
                .map(|k| k.thickness * 10.0);
            ray_at.insert(l.name.clone(), ray);
            println!(
                "{} | {:?} | {:.1} | {} | {:.1} | {:.1}",
                l.name,
                l.bone,
                l.fstt_mm,
                ray.map_or("-".into(), |v| format!("{v:.1}")),
                l.residual * 10.0,
                l.depth_mm
            );
        }
        println!("total {:.1} s", t0.elapsed().as_secs_f32());
        for g in &rep.groups {
            assert!(
                g.behind_skin.near > 1000,
                "{:?}: too few bone vertices near the face",
                g.bone
            );
            assert!(
                g.behind_skin.fraction() >= 0.9,
                "{:?}: {:?}",
                g.bone,
                g.behind_skin
            );
            assert!(
                g.scale.iter().all(|s| (0.8..1.25).contains(s)),
                "{:?} scale {:?}",
                g.bone,
                g.scale
            );
        }
        for (name, want) in [("nasion", 7.0), ("menton", 8.0)] {
            let got = ray_at[name].unwrap_or_else(|| panic!("{name}: no constraint"));
            assert!(
                (got - want).abs() <= 3.0,
                "{name}: ray thickness {got:.1} mm, fstt {want} mm"
            );
        }
        assert!(c.fraction() > 0.1, "constraint fraction {}", c.fraction());
    }
}
