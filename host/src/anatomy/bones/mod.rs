//! `sinew bones fit`: places template skull and jaw bones inside an actor's neutral face, as AIM
//! section 4.1 needs ("we fit a template skull and jaw only to the neutral shape"), so that the
//! sparse anatomical constraints ([`crate::anatomy::constraints`], AIM eq. 12) can be computed.
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

use serde::Serialize;

use crate::anatomy::constraints::Bone;
use crate::geometry::align::{
    Affine, cofactor, fit_affine, fit_similarity, mat_vec, singular_values,
};
use crate::geometry::spatial::{Grid, bbox, components, geodesic_labels, oriented_normals};
use crate::geometry::vec3::{V3, dot, norm, normalize, scale, sub, to32, to64};
use crate::io::mesh::Mesh;

pub use self::behind::*;
pub use self::error::BonesError;
pub use self::landmarks::*;
pub use self::templates::*;

mod behind;
mod error;
mod landmarks;
mod templates;

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
) -> Result<FittedBones, BonesError> {
    let mm = check_inputs(neutral, skin_landmarks)?;
    let frame = FaceFrame::new(neutral, skin_landmarks)?;
    let skin = Skin::of(neutral);
    let pairs = landmark_pairs(templates, skin_landmarks, &skin, mm)?;
    let mirror = Mirror::midsagittal(&frame, skin_landmarks, &skin.pos);
    let init = initial_similarity(&pairs, &mirror);
    let (mut targets, taken) = patch_targets(neutral, &skin, &pairs, templates, skin_landmarks, mm);
    let closed_head = calvarium_targets(
        &skin,
        &taken,
        &frame,
        skin_landmarks,
        templates,
        mm,
        &mut targets,
    )?;
    let fit = GroupFit {
        neutral,
        frame: &frame,
        targets: &targets,
        pairs: &pairs,
        init,
        mirror,
        closed_head,
        mm,
    };
    let (skull_report, skull_tf) = fit.group(Bone::Skull, &templates.skull_points());
    let (jaw_report, jaw_tf) = fit.group(Bone::Jaw, &templates.jaw_points());
    let tf_of = |b: Bone| match b {
        Bone::Skull => skull_tf,
        Bone::Jaw => jaw_tf,
    };
    let landmarks = landmark_reports(&pairs, tf_of, &skin.pos, mm);
    let (skull, jaw) = templates.placed(&skull_tf, &jaw_tf);
    Ok(FittedBones {
        skull,
        jaw,
        report: FitReport {
            mm_per_unit: mm as f32,
            frame,
            cranium_registration: templates.cranium_registration,
            groups: vec![skull_report, jaw_report],
            landmarks,
        },
    })
}

/// The skin's mm per unit, once the neutral and the skin landmarks are known to fit together.
fn check_inputs(neutral: &Mesh, skin_landmarks: &SkinLandmarks) -> Result<f64, BonesError> {
    let mm = skin_landmarks.mm_per_unit as f64;
    if !(mm > 0.0 && mm.is_finite()) {
        return Err(BonesError::MmPerUnit {
            mm_per_unit: skin_landmarks.mm_per_unit,
        });
    }
    neutral
        .validate()
        .map_err(|source| BonesError::InvalidNeutral {
            purpose: "fit bones to",
            source,
        })?;
    let nv = neutral.positions.len();
    if let Some((n, v)) = skin_landmarks
        .vertices
        .iter()
        .find(|(_, v)| **v as usize >= nv)
    {
        return Err(BonesError::SkinLandmarkVertex {
            name: n.clone(),
            vertex: *v,
            vertices: nv,
        });
    }
    Ok(mm)
}

/// The neutral skin as the fit reads it: positions in `f64`, outward normals, and the connected
/// component of each vertex.
struct Skin {
    pos: Vec<V3>,
    normals: Vec<V3>,
    comp: Vec<u32>,
}

impl Skin {
    fn of(neutral: &Mesh) -> Self {
        let comp = components(neutral);
        let normals = oriented_normals(neutral, &comp);
        let pos = neutral.positions.iter().map(|p| to64(*p)).collect();
        Self { pos, normals, comp }
    }
}

/// A bone landmark and its skin landmark pushed in by the expected thickness.
struct LandmarkPair<'a> {
    lm: &'a BoneLandmark,
    /// The skin vertex.
    vertex: u32,
    /// Where the bone landmark belongs, skin units.
    target: V3,
}

impl LandmarkPair<'_> {
    fn weighted(&self) -> bool {
        self.lm.weight > 0.0
    }
}

/// Every bone landmark whose skin landmark the face has, paired with its target under the skin;
/// [`BonesError::TooFewLandmarks`] unless each bone has three weighted ones.
fn landmark_pairs<'a>(
    templates: &'a BoneTemplates,
    skin_landmarks: &SkinLandmarks,
    skin: &Skin,
    mm: f64,
) -> Result<Vec<LandmarkPair<'a>>, BonesError> {
    let pairs: Vec<LandmarkPair<'_>> = templates
        .landmarks
        .iter()
        .filter_map(|lm| {
            let v = *skin_landmarks.vertices.get(&lm.name)?;
            let d = lm.fstt_mm as f64 / mm;
            let target = sub(skin.pos[v as usize], scale(skin.normals[v as usize], d));
            Some(LandmarkPair {
                lm,
                vertex: v,
                target,
            })
        })
        .collect();
    for bone in [Bone::Skull, Bone::Jaw] {
        let n = pairs
            .iter()
            .filter(|p| p.lm.bone == bone && p.weighted())
            .count();
        if n < 3 {
            return Err(BonesError::TooFewLandmarks { bone, count: n });
        }
    }
    Ok(pairs)
}

/// The start of both groups' ICP: Horn's similarity from the weighted landmark pairs, each also
/// used mirrored.
fn initial_similarity(pairs: &[LandmarkPair<'_>], mirror: &Mirror) -> Affine {
    let (mut x, mut y, mut w) = (Vec::new(), Vec::new(), Vec::new());
    for p in pairs.iter().filter(|p| p.weighted()) {
        x.push(to64(p.lm.position));
        y.push(p.target);
        w.push(p.lm.weight as f64);
    }
    let (x, y, w) = mirror.symmetrize(&x, &y, &w);
    fit_similarity(&x, &y, &w)
}

/// The ICP targets of the geodesic patches around the weighted landmarks and the templates'
/// extra patches, each pushed in by its thickness; and which skin vertices they took.
fn patch_targets(
    neutral: &Mesh,
    skin: &Skin,
    pairs: &[LandmarkPair<'_>],
    templates: &BoneTemplates,
    skin_landmarks: &SkinLandmarks,
    mm: f64,
) -> (Vec<Target>, Vec<bool>) {
    // Each source: (skin vertex, radius, thickness in units, bone).
    let mut sources: Vec<(u32, f64, f64, Bone)> = pairs
        .iter()
        .filter(|p| p.weighted())
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
    let label = geodesic_labels(neutral, &skin.pos, &radii);
    let mut targets = Vec::new();
    let mut taken = vec![false; skin.pos.len()];
    for (v, l) in label.iter().enumerate() {
        let Some(k) = *l else { continue };
        let (centre, _, d, bone) = sources[k];
        if dot(skin.normals[v], skin.normals[centre as usize]) < PAIR_MIN_COS {
            continue;
        }
        taken[v] = true;
        targets.push(Target {
            point: sub(skin.pos[v], scale(skin.normals[v], d)),
            normal: skin.normals[v],
            bone,
        });
    }
    (targets, taken)
}

/// Adds the calvarium's targets (the nasion's component above the brows, not `taken` by a
/// patch, pushed in by the calvarium's thickness) to `targets`; whether the skin is a whole head
/// (enough of them face backwards).
fn calvarium_targets(
    skin: &Skin,
    taken: &[bool],
    frame: &FaceFrame,
    skin_landmarks: &SkinLandmarks,
    templates: &BoneTemplates,
    mm: f64,
    targets: &mut Vec<Target>,
) -> Result<bool, BonesError> {
    let pos = &skin.pos;
    let up = to64(frame.up);
    let forward = to64(frame.forward);
    let nasion =
        *skin_landmarks
            .vertices
            .get("nasion")
            .ok_or_else(|| BonesError::SkinLandmarkMissing {
                name: "nasion".to_string(),
                needed_for: "the calvarium targets",
            })?;
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
    for v in 0..pos.len() {
        if taken[v] || skin.comp[v] != skin.comp[nasion as usize] || dot(pos[v], up) <= above {
            continue;
        }
        if dot(skin.normals[v], forward) < -0.3 {
            backward += 1;
        }
        targets.push(Target {
            point: sub(pos[v], scale(skin.normals[v], calv_d)),
            normal: skin.normals[v],
            bone: Bone::Skull,
        });
    }
    Ok(backward >= CLOSED_HEAD_TARGETS)
}

/// A bone group's template points and their normals (mm frame).
struct GroupPoints {
    points: Vec<V3>,
    normals: Vec<V3>,
}

impl BoneTemplates {
    /// The skull group's points: the maxilla's, then the cranium's.
    fn skull_points(&self) -> GroupPoints {
        GroupPoints {
            points: (self.maxilla.positions.iter())
                .chain(&self.cranium.positions)
                .map(|p| to64(*p))
                .collect(),
            normals: (self.maxilla.vertex_normals().into_iter())
                .chain(self.cranium.vertex_normals())
                .map(to64)
                .collect(),
        }
    }

    /// The jaw group's points.
    fn jaw_points(&self) -> GroupPoints {
        GroupPoints {
            points: self.jaw.positions.iter().map(|p| to64(*p)).collect(),
            normals: self.jaw.vertex_normals().into_iter().map(to64).collect(),
        }
    }

    /// The skull (maxilla and cranium, one mesh, maxilla vertices first) and the jaw moved by
    /// their fitted transforms.
    fn placed(&self, skull_tf: &Affine, jaw_tf: &Affine) -> (Mesh, Mesh) {
        let moved = |m: &Mesh, tf: &Affine| {
            Mesh::new(
                m.positions
                    .iter()
                    .map(|p| to32(tf.apply(to64(*p))))
                    .collect(),
                m.polygons.clone(),
            )
        };
        let mut skull = moved(&self.maxilla, skull_tf);
        let offset = skull.positions.len() as u32;
        let cranium = moved(&self.cranium, skull_tf);
        skull.positions.extend(cranium.positions);
        skull.polygons.extend(
            cranium
                .polygons
                .into_iter()
                .map(|p| p.into_iter().map(|v| v + offset).collect()),
        );
        (skull, moved(&self.jaw, jaw_tf))
    }
}

/// What every group's fit shares.
struct GroupFit<'a> {
    neutral: &'a Mesh,
    frame: &'a FaceFrame,
    targets: &'a [Target],
    pairs: &'a [LandmarkPair<'a>],
    init: Affine,
    mirror: Mirror,
    closed_head: bool,
    mm: f64,
}

impl GroupFit<'_> {
    /// One group's ICP from the initial similarity (the skull of a whole head affine, unless
    /// that stretches it more than [`MAX_ANISOTROPY`]), its report and its transform.
    fn group(&self, bone: Bone, template: &GroupPoints) -> (GroupReport, Affine) {
        let mm = self.mm;
        let tg: Vec<Target> = (self.targets.iter().copied())
            .filter(|t| t.bone == bone)
            .collect();
        let lm: Vec<([f64; 3], [f64; 3], f64)> = self
            .pairs
            .iter()
            .filter(|p| p.lm.bone == bone && p.weighted())
            .map(|p| (to64(p.lm.position), p.target, p.lm.weight as f64))
            .collect();
        let icp = Icp {
            src: &template.points,
            normals: &template.normals,
            targets: &tg,
            landmarks: &lm,
            cell: CELL_MM / mm,
            floor: REJECT_FLOOR_MM / mm,
            mirror: self.mirror,
        };
        let mut model = if bone == Bone::Skull && self.closed_head {
            Model::Affine
        } else {
            Model::Similarity
        };
        let mut run = icp.run(self.init, model);
        let sv = singular_values(run.tf.a);
        if model == Model::Affine && sv[0] > MAX_ANISOTROPY * sv[2] {
            model = Model::Similarity;
            run = icp.run(self.init, model);
        }
        let sv = singular_values(run.tf.a);
        let moved: Vec<[f32; 3]> = (template.points.iter())
            .map(|p| to32(run.tf.apply(*p)))
            .collect();
        let behind = behind_skin(
            self.neutral,
            self.frame,
            &moved,
            (NEAR_DEPTH_MM as f64 / mm) as f32,
            (1.0 / mm) as f32,
        );
        let report = GroupReport {
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
        };
        (report, run.tf)
    }
}

/// Each landmark after the fit: how far its fitted bone point lies from its target and from the
/// skin.
fn landmark_reports(
    pairs: &[LandmarkPair<'_>],
    tf_of: impl Fn(Bone) -> Affine,
    pos: &[V3],
    mm: f64,
) -> Vec<LandmarkReport> {
    pairs
        .iter()
        .map(|p| {
            let b = tf_of(p.lm.bone).apply(to64(p.lm.position));
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
        .collect()
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
    /// The templates are mirror-symmetric about their x = 0 plane; every pair is also used
    /// mirrored (template across x = 0, skin across the face's midsagittal plane), so the fit
    /// maps one plane onto the other and cannot yaw or roll the bones to one side. The skin's
    /// plane has normal `left` and passes through the midline landmarks and the zygia's
    /// midpoint.
    fn midsagittal(frame: &FaceFrame, skin_landmarks: &SkinLandmarks, pos: &[V3]) -> Self {
        let left = to64(frame.left);
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
        Self {
            left,
            offset: acc.iter().sum::<f64>() / acc.len().max(1) as f64,
        }
    }

    fn template(&self, p: V3) -> V3 {
        [-p[0], p[1], p[2]]
    }

    fn skin(&self, p: V3) -> V3 {
        sub(p, scale(self.left, 2.0 * (dot(p, self.left) - self.offset)))
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

#[cfg(test)]
mod tests;
