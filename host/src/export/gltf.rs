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
//! - With the glTF rig the actor was learned from (`--rig`), the rest of the character: its
//!   other meshes under the head joint, or the jaw joint for those that belong to the jaw
//!   (lower teeth, tongue), its materials, textures and images (`super::carry`); a VRM 1.0
//!   avatar's `VRMC_vrm` with its expressions bound to the learned shapes (`super::vrm`).
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

use std::path::Path;

use gltf_json as json;
use serde::Serialize;
use sinew_core::aim::AimActor;

pub use super::animation::quaternion;
use super::animation::{Animated, animate};
pub use super::error::{ExportError, GltfError};
use super::face::{Shapes, write_bones, write_face, write_skeleton};
pub use super::jaw::{
    MAX_DIRECTIONS as MAX_JAW_COMPENSATION, TOLERANCE_M as JAW_COMPENSATION_TOLERANCE_M,
    joint_weight, keyed_weight,
};
pub use super::names::{Names, Targets};
use super::place::{Place, PlaceError};
use crate::aim::play::{Frame, PoseFile};
use crate::io::glb::Builder;
use crate::io::rig::Scenery;
use crate::io::units::UnknownUnit;

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
    /// Compress the geometry and animation with `EXT_meshopt_compression`, losslessly
    /// (`crate::io::glb_compress`).
    pub compress: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            fps: 30.0,
            bones: false,
            names: Names::Actor,
            looped: false,
            compress: false,
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
    /// Meshes carried from the rig beside the face (`--rig`: eyes, teeth).
    pub carried_meshes: usize,
    /// The carried meshes that ride the jaw joint (lower teeth, tongue), by name; the others
    /// ride the head (`super::carry::rides_jaw`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub carried_on_jaw: Vec<String>,
    /// What the rig has that the export does not carry (`--rig`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub dropped: Vec<String>,
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
    rig: Option<&Path>,
) -> Result<Summary, ExportError> {
    let fps = options.fps;
    if !(fps.is_finite() && fps > 0.0) {
        return Err(ExportError::Fps { fps });
    }
    let bytes = crate::io::container::read(model)?;
    let actor = crate::io::container::actor(model, &bytes)?;
    let (poses, unplayable) = match frames {
        Frames::None => (Vec::new(), Vec::new()),
        Frames::Poses(p) => (PoseFile::read(p, actor.shape_count())?.frames, Vec::new()),
        Frames::Arkit(p) => {
            let playback = crate::aim::arkit::playback(&actor, p)?;
            (playback.frames, playback.mapping.unplayable)
        }
        Frames::Performance(p) => (performance_frames(&bytes, &actor, p)?, Vec::new()),
    };
    let in_model = |source| ExportError::Gltf {
        path: model.to_path_buf(),
        source,
    };
    let scenery = match rig {
        Some(path) => {
            let record =
                crate::aim::play::rig_record(&actor).map_err(|e| in_model(GltfError::Rig(e)))?;
            let mesh = record.as_ref().map(|r| r.mesh.as_str());
            Some(Scenery::read(path, mesh).map_err(ExportError::Rig)?)
        }
        None => None,
    };
    let (glb, mut summary) =
        glb_carrying(&actor, &poses, options, scenery.as_ref()).map_err(in_model)?;
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

/// The `.glb` bytes of `actor` with an animation of `frames` (none when empty), as `options`
/// say.
pub fn glb(
    actor: &AimActor<'_>,
    frames: &[Frame],
    options: &Options,
) -> Result<(Vec<u8>, Summary), GltfError> {
    glb_carrying(actor, frames, options, None)
}

/// [`glb`], carrying the rest of the character (`scenery`: the other meshes, materials and
/// textures of the glTF rig the actor was learned from; `super::carry`) when given.
pub fn glb_carrying(
    actor: &AimActor<'_>,
    frames: &[Frame],
    options: &Options,
    scenery: Option<&Scenery>,
) -> Result<(Vec<u8>, Summary), GltfError> {
    let scale = metres_per_unit(actor)?;
    let place = Place::of(actor, scale).map_err(|e| match e {
        PlaceError::Rig(e) => GltfError::Rig(e),
        PlaceError::Uv(e) => GltfError::Uv(e),
    })?;
    let shapes = Shapes::of(actor, frames, scale, options.names)?;
    let mut b = Builder::new();
    let rig = match scenery {
        Some(scenery) => Some((scenery, rig_transform(actor, scenery)?)),
        None => None,
    };
    let face_material = scenery.and_then(super::carry::face_material);
    let face = write_face(&mut b, actor, &place, &shapes, face_material);
    let skeleton = write_skeleton(&mut b, actor, &place, &face);
    let mut scene_nodes = vec![skeleton.root, skeleton.face_node];
    if options.bones {
        scene_nodes.push(write_bones(&mut b, actor, &place, &face, skeleton.skin)?);
    }
    let mut carried = None;
    let mut vrm_dropped = Vec::new();
    if let Some((scenery, transform)) = rig {
        let rest: Vec<f32> = (0..3 * actor.vertex_count())
            .map(|i| actor.rest().at(i))
            .collect();
        let face_rest = super::carry::FaceRest {
            points: place
                .points(&rest)
                .chunks_exact(3)
                .map(|p| [p[0], p[1], p[2]].map(f64::from))
                .collect(),
            k: actor
                .skinning_weights()
                .iter()
                .map(|k| f64::from(joint_weight(k)))
                .collect(),
            pivot: skeleton.pivot,
        };
        let (nodes, lists) = super::carry::carry(&mut b, scenery, &transform, &face_rest)
            .ok_or_else(|| {
                crate::rig::record::RecordError::Invalid(
                    "its node transform cannot be inverted".into(),
                )
            })?;
        attach(&mut b, skeleton.head, nodes.head);
        attach(&mut b, skeleton.jaw, nodes.jaw);
        let mut lists = lists;
        let shapes: Vec<Option<String>> = (0..actor.shape_count())
            .map(|j| actor.shape_name(j).map(str::to_owned))
            .collect();
        let vrm_nodes = super::vrm::Nodes {
            face: skeleton.face_node.value(),
            face_mesh: face.mesh.value(),
            head: skeleton.head.value(),
            jaw: skeleton.jaw.value(),
        };
        if let Some(vrm) = &scenery.vrm {
            let (extension, dropped) = super::vrm::rebind(vrm, &shapes, &vrm_nodes);
            lists.root_extensions.push(("VRMC_vrm".into(), extension));
            lists.extensions.push(("VRMC_vrm".into(), false));
            vrm_dropped = dropped;
        } else if let Some(vrm) = &scenery.vrm0 {
            let (extension, dropped) = super::vrm::rebind_0x(vrm, &shapes, &vrm_nodes);
            lists.root_extensions.push(("VRM".into(), extension));
            lists.extensions.push(("VRM".into(), false));
            vrm_dropped = dropped;
        }
        carried = Some(lists);
    }
    if !frames.is_empty() {
        let nodes = Animated {
            face: skeleton.face_node,
            jaw: skeleton.jaw,
            head: skeleton.head,
        };
        animate(
            &mut b,
            actor,
            frames,
            options.fps,
            options.looped,
            shapes.named.combined.len(),
            &shapes.compensation.weights,
            &place,
            skeleton.pivot,
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
    let glb = match (&carried, options.compress) {
        (None, false) => b.finish()?,
        (carried, compress) => b.finish_as(
            |doc| {
                if let Some(c) = carried {
                    c.apply(doc);
                }
            },
            compress,
        )?,
    };
    let summary = Summary {
        vertices: place.vertices(),
        seam_copies: place.seam_copies(),
        texture_coordinates: face.uvs,
        morph_targets: face.targets,
        combined_targets: shapes
            .named
            .combined
            .iter()
            .map(|(n, _)| n.clone())
            .collect(),
        frames: frames.len(),
        keyframes: super::animation::keyframes(frames, options.looped).len(),
        clamped_weights: face.clamped,
        max_clamp: face.max_clamp,
        jaw_compensation_targets: shapes.compensation.targets.len(),
        jaw_compensation_directions: shapes.compensation.directions,
        coefficients_outside_unit: frames
            .iter()
            .flat_map(|f| &f.weights)
            .filter(|&&w| keyed_weight(w) != w)
            .count(),
        jaw_compensation_residual_mm: shapes.compensation.residual_m * 1000.0,
        metres_per_unit: scale,
        carried_meshes: carried.as_ref().map_or(0, |c| c.meshes),
        carried_on_jaw: carried.as_ref().map_or_else(Vec::new, |c| c.on_jaw.clone()),
        dropped: scenery
            .map_or_else(Vec::new, |s| s.dropped.clone())
            .into_iter()
            .chain(vrm_dropped)
            .collect(),
        unplayable: Vec::new(),
        bytes: glb.len(),
    };
    Ok((glb, summary))
}

/// The rig's node transform, the scenery checked against the actor: it must be that of the
/// glTF rig the actor records, with as many skin vertices.
fn rig_transform(actor: &AimActor<'_>, scenery: &Scenery) -> Result<[[f64; 4]; 4], GltfError> {
    let mismatch = |what: String| GltfError::Rig(crate::rig::record::RecordError::Invalid(what));
    let Some(record) = crate::aim::play::rig_record(actor)? else {
        return Err(mismatch(
            "the actor was not learned from a rig, so there is no rig to carry".into(),
        ));
    };
    if record.welded.len() != scenery.skin_vertices {
        return Err(mismatch(format!(
            "the rig's skin mesh {:?} has {} vertices where the actor's rig had {}",
            record.mesh,
            scenery.skin_vertices,
            record.welded.len()
        )));
    }
    Ok(record.node_transform)
}

/// Makes `children` children of `parent`.
fn attach(
    b: &mut Builder,
    parent: json::Index<json::Node>,
    children: Vec<json::Index<json::Node>>,
) {
    if children.is_empty() {
        return;
    }
    let node = &mut b.root.nodes[parent.value()];
    node.children.get_or_insert_with(Vec::new).extend(children);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::container::ContainerError;

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
        let err = export(&model, &out, Frames::None, &zero, None).unwrap_err();
        assert!(matches!(err, ExportError::Fps { .. }), "{err}");
        let missing = dir.path().join("missing.sinew");
        let err = export(&missing, &out, Frames::None, &Options::default(), None).unwrap_err();
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
            None,
        )
        .unwrap_err();
        assert!(
            matches!(&err, ExportError::NotAPerformance { path, .. } if *path == model),
            "{err}"
        );
        let poses = dir.path().join("poses.json");
        std::fs::write(&poses, "{\"frames\": [{\"weights\": [1e40]}]}").unwrap();
        let err = export(
            &model,
            &out,
            Frames::Poses(&poses),
            &Options::default(),
            None,
        )
        .unwrap_err();
        assert!(matches!(err, ExportError::Poses(_)), "{err}");
        let err = export(
            &model,
            &out,
            Frames::None,
            &Options::default(),
            Some(dir.path()),
        )
        .unwrap_err();
        // A folder is an OBJ rig; this one has no neutral.obj.
        assert!(matches!(err, ExportError::Rig(_)), "{err}");
        let source = std::error::Error::source(&err).map(ToString::to_string);
        assert!(source.is_some_and(|s| s.contains("neutral.obj")), "{err}");
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
