//! `sinew export gltf`: a baked AIM actor as a glTF 2.0 rig (docs/ENGINES.md).
//!
//! - The skin's neutral s0 is the base mesh (positions, area-weighted normals, the template's
//!   triangles); each corrective e_j is a morph target named after the actor's shape (mesh
//!   `extras.targetNames`), with its normal change.
//! - A skin of two joints: the root joint `head` (T_g: the node's rotation and translation) and
//!   its child `jaw`, whose rest translation is the pivot p, so that its animated translation
//!   p + t and rotation R give T_b(x) = R (x − p) + p + t through the inverse bind matrix
//!   translate(−p). Each vertex is weighted k on the jaw and 1 − k on the head.
//! - With frames, one animation (`super::animation`): morph weights, the jaw's and the head's
//!   rotation (a unit quaternion from the 6D rotation's matrix) and translation, keyed at frame
//!   i / fps, and with [`Options::looped`] the first frame again at N / fps.
//! - Texture coordinates (`TEXCOORD_0`) where the actor has them: a rig's, or a kit actor's
//!   metadata `uv`, with vertices split at seams (`super::place`).
//! - Morph target names the actor's, or ARKit's ([`Names`], `super::names`).
//!
//! Coordinates are in metres (glTF's unit) from the artefact's `units`; the axes (x to the
//! actor's left, y up, z forward) are glTF's already.
//!
//! - With frames, more morph targets (`jawCompensation1`, …; one or two for each of at most
//!   [`MAX_JAW_COMPENSATION`] directions) keyed by the animation, counted in the mesh's
//!   `extras.sinewCompensationTargets`.
//! - Every keyed morph weight lies in [0, 1], where a DCC's sliders clamp (Blender's shape
//!   keys): a coefficient outside is keyed held to [0, 1] ([`keyed_weight`]) and the
//!   compensation targets carry the rest.
//!
//! glTF morphs before it skins, where AIM eq. 17 adds the correctives after the jaw's LBS, and
//! glTF's skin weights lie in [0, 1] where the learned k may stray outside: `super::jaw` makes up
//! for both, and `training::tolerance::GLTF_RIG` gives what is left.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use gltf_json as json;
use json::validation::Checked::Valid;
use serde::Serialize;
use sinew_core::FormatError;
use sinew_core::aim::AimActor;
use sinew_core::replay::ReplayError;

pub use super::animation::quaternion;
use super::animation::{Animated, animate};
use super::jaw::{Compensation, Skin, compensate, shape_deltas};
pub use super::jaw::{
    MAX_DIRECTIONS as MAX_JAW_COMPENSATION, TOLERANCE_M as JAW_COMPENSATION_TOLERANCE_M,
    joint_weight, keyed_weight,
};
pub use super::names::{Names, Targets};
use super::place::{Place, PlaceError};
use crate::aim::arkit::ArkitError;
use crate::aim::play::{Frame, PoseFile, PoseFileError, corrective_names};
use crate::geometry::uv::UvError;
use crate::io::atomic::AtomicWriteError;
use crate::io::container::ContainerError;
use crate::io::glb::{Builder, GlbError};
use crate::io::rig::COMPENSATION_KEY;
use crate::io::units::UnknownUnit;

/// Why `sinew export gltf` failed; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// A frame rate that is not a positive number.
    #[error("--fps must be a positive number, got {fps}")]
    Fps {
        /// The rate given.
        fps: f32,
    },
    /// The model or performance file could not be read or is no `.sinew` artefact.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The model is not an AIM actor.
    #[error("{}", path.display())]
    NotAnActor {
        /// The model file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// The pose file is unreadable or does not fit the actor.
    #[error(transparent)]
    Poses(#[from] PoseFileError),
    /// The capture could not be read or mapped onto the actor.
    #[error(transparent)]
    Arkit(#[from] ArkitError),
    /// The performance file is not a fitted performance.
    #[error("{}: not a fitted performance", path.display())]
    NotAPerformance {
        /// The performance file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A performance fitted to another actor.
    #[error("{}", path.display())]
    OtherActor {
        /// The performance file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: ReplayError,
    },
    /// A local fit, whose coefficients glTF's per-mesh morph weights cannot carry.
    #[error(
        "{}: a local fit's coefficients vary over the face, which glTF's per-mesh morph \
         weights cannot carry; fit with --global for an engine, or write the meshes with \
         sinew play --performance",
        path.display()
    )]
    LocalFit {
        /// The performance file.
        path: PathBuf,
    },
    /// A performance frame whose coefficients or transforms cannot be read.
    #[error("{}: frame {frame} unreadable", path.display())]
    Frame {
        /// The performance file.
        path: PathBuf,
        /// The frame.
        frame: usize,
    },
    /// The actor could not be laid out as glTF.
    #[error("{}: cannot export", path.display())]
    Gltf {
        /// The model file.
        path: PathBuf,
        /// Why.
        #[source]
        source: GltfError,
    },
    /// The `.glb` could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}

/// Why an actor could not be laid out as a glTF rig.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GltfError {
    /// The artefact's `units` metadata names no known unit.
    #[error(transparent)]
    Units(#[from] UnknownUnit),
    /// A cache section of the wrong shape or type.
    #[error("{name}")]
    Section {
        /// The section.
        name: String,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// The core refused the jaw transform learned for a shape (`train.jaw`).
    #[error("the jaw transform learned for {shape}")]
    LearnedJaw {
        /// The shape.
        shape: String,
        /// What the core said.
        #[source]
        source: sinew_core::InputError,
    },
    /// The core refused a frame's head or jaw (a degenerate or out-of-range transform).
    #[error("frame {frame}")]
    Frame {
        /// The frame.
        frame: usize,
        /// What the core said.
        #[source]
        source: sinew_core::InputError,
    },
    /// The glTF document could not be serialised.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The container could not be laid out.
    #[error(transparent)]
    Glb(#[from] GlbError),
    /// The actor's record of its rig is broken.
    #[error(transparent)]
    Rig(#[from] crate::rig::record::RecordError),
    /// The actor's texture coordinates (metadata `uv`) do not fit it.
    #[error(transparent)]
    Uv(#[from] UvError),
}

impl From<crate::io::glb::BuildError> for GltfError {
    fn from(e: crate::io::glb::BuildError) -> Self {
        match e {
            crate::io::glb::BuildError::Json(e) => Self::Json(e),
            crate::io::glb::BuildError::Glb(e) => Self::Glb(e),
        }
    }
}

/// Where the animation's frames come from.
#[derive(Clone, Copy, Debug)]
pub enum Frames<'a> {
    /// No animation: the rig only.
    None,
    /// A pose file (`sinew play`'s format).
    Poses(&'a Path),
    /// A Live Link Face capture (`sinew play --arkit`'s mapping).
    Arkit(&'a Path),
    /// A fitted performance of this actor (`sinew fit --out FIT.sinew`) with one coefficient
    /// vector per frame.
    Performance(&'a Path),
}

/// How to export, besides the actor and its frames.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Frames per second of the animation.
    pub fps: f32,
    /// Add the anatomy surface (bone points b0) as a second mesh.
    pub bones: bool,
    /// How the morph targets are named.
    pub names: Names,
    /// Key the first frame again after the last, so that the animation loops without a jump
    /// (`super::animation`).
    pub looped: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            fps: 30.0,
            bones: false,
            names: Names::Actor,
            looped: false,
        }
    }
}

/// What an export wrote, for the command's report.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Vertices of the base mesh (seam copies included).
    pub vertices: usize,
    /// Vertices added where texture coordinates disagree at a vertex (seams).
    pub seam_copies: usize,
    /// Whether the mesh carries texture coordinates (`TEXCOORD_0`).
    pub texture_coordinates: bool,
    /// Morph targets: the actor's corrective shapes, then the combined ARKit ones.
    pub morph_targets: usize,
    /// Morph targets under ARKit's name that sum shapes ARKit does not split by side.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub combined_targets: Vec<String>,
    /// Animation frames (0 without one).
    pub frames: usize,
    /// Animation keyframes: the frames, and with looping the first once more.
    pub keyframes: usize,
    /// Vertices whose learned jaw weight k lies outside [0, 1], clamped for glTF.
    pub clamped_weights: usize,
    /// Largest |k − clamp(k)|.
    pub max_clamp: f32,
    /// Morph targets that make the animation's frames pose as in the core despite glTF's
    /// morphing before skinning and the named targets' weights held to [0, 1]
    /// (`jawCompensation1`, …; `super::jaw`).
    pub jaw_compensation_targets: usize,
    /// The directions those targets come from: each one target, or two where the frames take
    /// it both ways.
    pub jaw_compensation_directions: usize,
    /// Frame coefficients outside [0, 1], keyed held to [0, 1] with the compensation carrying
    /// the rest (0 for captures, whose channels lie in [0, 1]).
    pub coefficients_outside_unit: usize,
    /// The largest displacement, in mm, that they leave uncompensated in any frame and vertex.
    pub jaw_compensation_residual_mm: f64,
    /// Metres per model unit.
    pub metres_per_unit: f32,
    /// Capture channels the actor cannot play (ARKit frames only).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub unplayable: Vec<String>,
    /// Bytes written.
    pub bytes: usize,
}

/// `sinew export gltf`: reads the actor (and its frames), writes the `.glb` atomically.
pub fn export(
    model: &Path,
    out: &Path,
    frames: Frames<'_>,
    options: &Options,
) -> Result<Summary, ExportError> {
    let fps = options.fps;
    if !(fps.is_finite() && fps > 0.0) {
        return Err(ExportError::Fps { fps });
    }
    let bytes = crate::io::container::read(model)?;
    let actor = AimActor::from_bytes(&bytes).map_err(|source| ExportError::NotAnActor {
        path: model.to_path_buf(),
        source,
    })?;
    let (poses, unplayable) = match frames {
        Frames::None => (Vec::new(), Vec::new()),
        Frames::Poses(p) => (PoseFile::read(p, actor.shape_count())?.frames, Vec::new()),
        Frames::Arkit(p) => {
            let playback = crate::aim::arkit::playback(&actor, p)?;
            (playback.frames, playback.mapping.unplayable)
        }
        Frames::Performance(p) => (performance_frames(&bytes, &actor, p)?, Vec::new()),
    };
    let (glb, mut summary) = glb(&actor, &poses, options).map_err(|source| ExportError::Gltf {
        path: model.to_path_buf(),
        source,
    })?;
    crate::io::atomic::write(out, &glb)?;
    summary.unplayable = unplayable;
    Ok(summary)
}

/// The frames of a global fit of `actor` (whose bytes are `actor_bytes`); a local fit is refused:
/// its coefficients vary over the face, and glTF's morph weights are one per mesh.
fn performance_frames(
    actor_bytes: &[u8],
    actor: &AimActor<'_>,
    path: &Path,
) -> Result<Vec<Frame>, ExportError> {
    let bytes = crate::io::container::read(path)?;
    let perf = sinew_core::performance::Performance::from_bytes(&bytes).map_err(|source| {
        ExportError::NotAPerformance {
            path: path.to_path_buf(),
            source,
        }
    })?;
    perf.check_actor(actor_bytes, actor)
        .map_err(|source| ExportError::OtherActor {
            path: path.to_path_buf(),
            source,
        })?;
    if perf.is_local() {
        return Err(ExportError::LocalFit {
            path: path.to_path_buf(),
        });
    }
    (0..perf.frames())
        .map(|f| {
            let mut weights = vec![0.0; perf.shape_count()];
            let (head, jaw) = perf.head_jaw(f).unwrap_or_default();
            perf.global_weights(f, &mut weights)
                .ok_or_else(|| ExportError::Frame {
                    path: path.to_path_buf(),
                    frame: f,
                })?;
            Ok(Frame { head, jaw, weights })
        })
        .collect()
}

/// Metres per unit of the artefact's `units` metadata (1 when it records none).
pub fn metres_per_unit(actor: &AimActor<'_>) -> Result<f32, UnknownUnit> {
    match actor.file().metadata().get("units") {
        Some(u) => {
            let unit: crate::io::units::Unit = u.parse()?;
            Ok((unit.mm() / 1000.0) as f32)
        }
        None => Ok(1.0),
    }
}

fn node(name: &str) -> json::Node {
    json::Node {
        name: Some(name.to_string()),
        ..Default::default()
    }
}

/// Unit vertex normals of `positions` (`[V, 3]`); a vertex in no triangle gets +z (glTF requires
/// unit normals on every vertex).
fn unit_normals(actor: &AimActor<'_>, positions: &[f32]) -> Vec<f32> {
    let mut n = vec![0.0; positions.len()];
    // The buffers have the actor's vertex count, so the core cannot refuse them.
    let _ = actor.normals(positions, &mut n);
    for v in n.chunks_exact_mut(3) {
        if v.iter().all(|x| *x == 0.0) {
            v[2] = 1.0;
        }
    }
    n
}

/// The `.glb` bytes of `actor` with an animation of `frames` (none when empty), as `options`
/// say.
pub fn glb(
    actor: &AimActor<'_>,
    frames: &[Frame],
    options: &Options,
) -> Result<(Vec<u8>, Summary), GltfError> {
    use json::accessor::{ComponentType, Type};
    use json::buffer::Target::ArrayBuffer;
    let v = actor.vertex_count();
    let m = actor.shape_count();
    let scale = metres_per_unit(actor)?;
    let place = Place::of(actor, scale).map_err(|e| match e {
        PlaceError::Rig(e) => GltfError::Rig(e),
        PlaceError::Uv(e) => GltfError::Uv(e),
    })?;
    let v_out = place.vertices();
    let file = actor.file();
    let section = |name: &str, shape: &[u32]| {
        file.f32_tensor(name, shape)
            .map_err(|source| GltfError::Section {
                name: name.to_string(),
                source,
            })
    };
    let (v32, m32) = (v as u32, m as u32);
    let correctives = section("cache.e", &[v32, m32, 3])?;
    let rest: Vec<f32> = actor.rest().iter().collect();
    let skin = Skin::of(actor, &correctives);
    let shape_names = corrective_names(actor);
    // Every shape's target is undone by its own learned jaw, which the core's rule gives it
    // alone at weight 1 (`sinew_core::jaw`).
    let learned: Vec<(usize, [f32; 9])> = actor.learned_jaws().map_or_else(Vec::new, |jaws| {
        (0..jaws.shape_count())
            .map(|s| (s, jaws.shape(s)))
            .collect()
    });
    let deltas =
        shape_deltas(actor, &skin, &learned).map_err(|(s, source)| GltfError::LearnedJaw {
            shape: shape_names[s].clone(),
            source,
        })?;
    let compensation = if frames.is_empty() {
        Compensation::default()
    } else {
        compensate(actor, &skin, &deltas, frames, f64::from(scale))
            .map_err(|(frame, source)| GltfError::Frame { frame, source })?
    };
    let mut b = Builder::new();

    // Base mesh.
    let normals = unit_normals(actor, &rest);
    let positions = place.points(&place.spread(&rest, 3));
    let normals_out = place.normals(&place.spread(&normals, 3));
    let pos = b.floats(&positions, Type::Vec3, true, Some(ArrayBuffer));
    let nrm = b.floats(&normals_out, Type::Vec3, false, Some(ArrayBuffer));
    let indices = b.indices(place.triangles());
    let uvs = place
        .uvs()
        .map(|uv| b.floats(&uv, Type::Vec2, false, Some(ArrayBuffer)));

    // Skin weights: k on the jaw (joint 1), 1 − k on the head (joint 0). A vertex wholly on one
    // joint names only that joint, since glTF's validator warns of joints used with zero weight.
    let mut weights = Vec::with_capacity(4 * v);
    let mut joint_ids = Vec::with_capacity(4 * v);
    let (mut clamped, mut max_clamp) = (0, 0.0f32);
    for k in actor.skinning_weights().iter() {
        let w = joint_weight(k);
        if w != k {
            clamped += 1;
            max_clamp = max_clamp.max((w - k).abs());
        }
        let (j, ws) = if w == 0.0 {
            ([0u8, 0, 0, 0], [1.0, 0.0, 0.0, 0.0])
        } else if w == 1.0 {
            ([1, 0, 0, 0], [1.0, 0.0, 0.0, 0.0])
        } else {
            ([1, 0, 0, 0], [w, 1.0 - w, 0.0, 0.0])
        };
        joint_ids.extend_from_slice(&j);
        weights.extend_from_slice(&ws);
    }
    let joints_view = b.view(&place.spread(&joint_ids, 4), Some(ArrayBuffer));
    let joints = b.accessor(
        joints_view,
        v_out,
        ComponentType::U8,
        Type::Vec4,
        None,
        None,
    );
    let skin_weights = b.floats(
        &place.spread(&weights, 4),
        Type::Vec4,
        false,
        Some(ArrayBuffer),
    );

    // Morph targets: each shape's displacement (its corrective compensated for its learned jaw,
    // `super::jaw`) and the normal change it makes, then each combined ARKit target's
    // (the sum of its shapes'), then the animation's jaw compensation.
    let named = Targets::of(&shape_names, options.names);
    let sums: Vec<Vec<usize>> = (0..m)
        .map(|j| vec![j])
        .chain(named.combined.iter().map(|(_, shapes)| shapes.clone()))
        .collect();
    let mut targets = Vec::with_capacity(sums.len());
    let mut shaped = rest.clone();
    for shapes in &sums {
        let delta: Vec<f32> = (0..v)
            .flat_map(|i| (0..3).map(move |c| (i, c)))
            .map(|(i, c)| shapes.iter().map(|&j| deltas[(i * m + j) * 3 + c]).sum())
            .collect();
        for ((s, r), d) in shaped.iter_mut().zip(&rest).zip(&delta) {
            *s = r + d;
        }
        let moved = place.normals(&place.spread(&unit_normals(actor, &shaped), 3));
        let dn: Vec<f32> = moved.iter().zip(&normals_out).map(|(a, b)| a - b).collect();
        let dp = place.offsets(&place.spread(&delta, 3));
        targets.push(json::mesh::MorphTarget {
            positions: Some(b.floats(&dp, Type::Vec3, true, Some(ArrayBuffer))),
            normals: Some(b.floats(&dn, Type::Vec3, false, Some(ArrayBuffer))),
            tangents: None,
        });
    }
    // The compensation moves positions only: its normal change is far below shading's notice.
    if !compensation.targets.is_empty() {
        let zeros = b.floats(&vec![0.0; 3 * v_out], Type::Vec3, false, Some(ArrayBuffer));
        for t in &compensation.targets {
            let dp = place.offsets(&place.spread(t, 3));
            targets.push(json::mesh::MorphTarget {
                positions: Some(b.floats(&dp, Type::Vec3, true, Some(ArrayBuffer))),
                normals: Some(zeros),
                tangents: None,
            });
        }
    }
    let mut names = named.all_names();
    names.extend((0..compensation.targets.len()).map(super::jaw::target_name));
    let primitive = |attributes: BTreeMap<_, _>, targets| json::mesh::Primitive {
        attributes,
        extensions: None,
        extras: None,
        indices: Some(indices),
        material: None,
        mode: Valid(json::mesh::Mode::Triangles),
        targets,
    };
    let skinned = |p, n| {
        BTreeMap::from([
            (Valid(json::mesh::Semantic::Positions), p),
            (Valid(json::mesh::Semantic::Normals), n),
            (Valid(json::mesh::Semantic::Joints(0)), joints),
            (Valid(json::mesh::Semantic::Weights(0)), skin_weights),
        ])
    };
    let targets_len = targets.len();
    let mut face_attributes = skinned(pos, nrm);
    if let Some(uv) = uvs {
        face_attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), uv);
    }
    let mut extras = serde_json::json!({ "targetNames": names });
    if !compensation.targets.is_empty() {
        extras[COMPENSATION_KEY] = compensation.targets.len().into();
    }
    let face = b.root.push(json::Mesh {
        extensions: None,
        extras: Some(serde_json::value::to_raw_value(&extras)?),
        name: Some("face".into()),
        primitives: vec![primitive(face_attributes, Some(targets))],
        weights: Some(vec![0.0; targets_len]),
    });

    // Joints: head (root) and jaw at the pivot.
    let pivot = actor.jaw_pivot();
    let pivot_out = place.points(&[pivot.x, pivot.y, pivot.z]);
    let pivot_m = [pivot_out[0], pivot_out[1], pivot_out[2]];
    let jaw = b.root.push(json::Node {
        translation: Some(pivot_m),
        ..node("jaw")
    });
    let head = b.root.push(json::Node {
        children: Some(vec![jaw]),
        ..node("head")
    });
    #[rustfmt::skip]
    let ibm: [f32; 32] = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        -pivot_m[0], -pivot_m[1], -pivot_m[2], 1.0,
    ];
    let ibm = b.floats(&ibm, Type::Mat4, false, None);
    let skin = b.root.push(json::Skin {
        extensions: None,
        extras: None,
        inverse_bind_matrices: Some(ibm),
        joints: vec![head, jaw],
        name: Some("face".into()),
        skeleton: Some(head),
    });
    let face_node = b.root.push(json::Node {
        mesh: Some(face),
        skin: Some(skin),
        ..node("face")
    });
    // A rig's node transform sits above the skeleton, so that the face stands where the rig
    // stood in its scene.
    let root = match place.node_transform() {
        Some(matrix) => b.root.push(json::Node {
            children: Some(vec![head]),
            matrix: Some(matrix),
            ..node("rig")
        }),
        None => head,
    };
    let mut scene_nodes = vec![root, face_node];

    if options.bones {
        let bone: Vec<f32> = section("cache.b0", &[v32, 3])?.iter().collect();
        let bn = place.normals(&place.spread(&unit_normals(actor, &bone), 3));
        let bp = place.points(&place.spread(&bone, 3));
        let bpos = b.floats(&bp, Type::Vec3, true, Some(ArrayBuffer));
        let bnrm = b.floats(&bn, Type::Vec3, false, Some(ArrayBuffer));
        let mesh = b.root.push(json::Mesh {
            extensions: None,
            extras: None,
            name: Some("bones".into()),
            primitives: vec![primitive(skinned(bpos, bnrm), None)],
            weights: None,
        });
        scene_nodes.push(b.root.push(json::Node {
            mesh: Some(mesh),
            skin: Some(skin),
            ..node("bones")
        }));
    }

    if !frames.is_empty() {
        let nodes = Animated {
            face: face_node,
            jaw,
            head,
        };
        animate(
            &mut b,
            actor,
            frames,
            options.fps,
            options.looped,
            named.combined.len(),
            &compensation.weights,
            &place,
            pivot_m,
            &nodes,
        )
        .map_err(|(frame, source)| GltfError::Frame { frame, source })?;
    }
    let scene = b.root.push(json::Scene {
        extensions: None,
        extras: None,
        name: Some("actor".into()),
        nodes: scene_nodes,
    });
    b.root.scene = Some(scene);
    let glb = b.finish()?;
    let summary = Summary {
        vertices: v_out,
        seam_copies: place.seam_copies(),
        texture_coordinates: uvs.is_some(),
        morph_targets: targets_len,
        combined_targets: named.combined.iter().map(|(n, _)| n.clone()).collect(),
        frames: frames.len(),
        keyframes: super::animation::keyframes(frames, options.looped).len(),
        clamped_weights: clamped,
        max_clamp,
        jaw_compensation_targets: compensation.targets.len(),
        jaw_compensation_directions: compensation.directions,
        coefficients_outside_unit: frames
            .iter()
            .flat_map(|f| &f.weights)
            .filter(|&&w| keyed_weight(w) != w)
            .count(),
        jaw_compensation_residual_mm: compensation.residual_m * 1000.0,
        metres_per_unit: scale,
        unplayable: Vec::new(),
        bytes: glb.len(),
    };
    Ok((glb, summary))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_inputs_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let model = dir.path().join("actor.sinew");
        std::fs::write(
            &model,
            std::fs::read(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../tests/data/aim-procedural.sinew"
            ))
            .unwrap(),
        )
        .unwrap();
        let out = dir.path().join("actor.glb");
        let zero = Options {
            fps: 0.0,
            ..Options::default()
        };
        let err = export(&model, &out, Frames::None, &zero).unwrap_err();
        assert!(matches!(err, ExportError::Fps { .. }), "{err}");
        let missing = dir.path().join("missing.sinew");
        let err = export(&missing, &out, Frames::None, &Options::default()).unwrap_err();
        assert!(
            matches!(&err, ExportError::Container(ContainerError::Read { path, .. }) if *path == missing),
            "{err}"
        );
        // The actor is no performance of itself.
        let err = export(
            &model,
            &out,
            Frames::Performance(&model),
            &Options::default(),
        )
        .unwrap_err();
        assert!(
            matches!(&err, ExportError::NotAPerformance { path, .. } if *path == model),
            "{err}"
        );
        let poses = dir.path().join("poses.json");
        std::fs::write(&poses, "{\"frames\": [{\"weights\": [1e40]}]}").unwrap();
        let err = export(&model, &out, Frames::Poses(&poses), &Options::default()).unwrap_err();
        assert!(matches!(err, ExportError::Poses(_)), "{err}");
        assert!(!out.exists());
    }

    #[test]
    fn an_actor_of_an_unknown_unit_is_refused() {
        use crate::aim::bake::{BakeInput, bake};
        let set = crate::aim::testing::procedural_training_set(8);
        let config = crate::aim::testing::small_aim_config(1);
        let device = crate::training::backend::Backend::Flex.device(0).unwrap();
        let net = crate::aim::model::AimNet::new(&config, set.shapes.len(), &device);
        let triangles = set.template.triangles();
        let input = BakeInput {
            points: &set.template.positions,
            triangles: &triangles,
            jaw_pivot: set.jaw_pivot,
            normalisation: crate::aim::model::normalisation(&set.template.positions),
            playback_only: true,
            metadata: vec![("units".into(), "furlong".into())],
        };
        let (bytes, _) = bake(&net, &input, &device).unwrap();
        let actor = AimActor::from_bytes(&bytes).unwrap();
        let err = glb(&actor, &[], &Options::default()).unwrap_err();
        assert!(matches!(err, GltfError::Units(_)), "{err}");
    }
}
