//! The parts of an exported actor's document, each written by one step of `super::gltf`: the
//! morph targets' makings, the face mesh with its skin weights and targets, the skeleton, and
//! the anatomy surface.

use std::collections::BTreeMap;

use gltf_json as json;
use json::validation::Checked::Valid;
use sinew_core::aim::AimActor;

use super::error::GltfError;
use super::jaw::{Compensation, Skin, compensate, joint_weight, shape_deltas};
use super::names::{Names, Targets};
use super::place::Place;
use crate::aim::play::{Frame, corrective_names};
use crate::io::glb::Builder;
use crate::io::rig::COMPENSATION_KEY;

pub(super) fn node(name: &str) -> json::Node {
    json::Node {
        name: Some(name.to_string()),
        ..Default::default()
    }
}

/// Unit vertex normals of `positions` (`[V, 3]`); a vertex in no triangle gets +z (glTF requires
/// unit normals on every vertex).
pub(super) fn unit_normals(actor: &AimActor<'_>, positions: &[f32]) -> Vec<f32> {
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

/// What the morph targets and the animation's compensation are made of.
pub(super) struct Shapes {
    /// Each shape's displacement `[V, M, 3]`, compensated for its learned jaw.
    pub(super) deltas: Vec<f32>,
    /// The compensation targets and weights of the animation.
    pub(super) compensation: Compensation,
    /// The target names.
    pub(super) named: Targets,
    /// The shapes each target sums: one each, then each combined ARKit target's.
    pub(super) sums: Vec<Vec<usize>>,
}

impl Shapes {
    pub(super) fn of(
        actor: &AimActor<'_>,
        frames: &[Frame],
        scale: f32,
        names: Names,
    ) -> Result<Self, GltfError> {
        let (v, m) = (actor.vertex_count(), actor.shape_count());
        let correctives = section(actor, "cache.e", &[v as u32, m as u32, 3])?;
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
        let named = Targets::of(&shape_names, names);
        let sums = (0..m)
            .map(|j| vec![j])
            .chain(named.combined.iter().map(|(_, shapes)| shapes.clone()))
            .collect();
        Ok(Self {
            deltas,
            compensation,
            named,
            sums,
        })
    }
}

/// A cache section of the actor.
pub(super) fn section<'a>(
    actor: &AimActor<'a>,
    name: &str,
    shape: &[u32],
) -> Result<sinew_core::F32s<'a>, GltfError> {
    actor
        .file()
        .f32_tensor(name, shape)
        .map_err(|source| GltfError::Section {
            name: name.to_string(),
            source,
        })
}

/// The face mesh written: its accessors and what the summary reports of it.
pub(super) struct Face {
    pub(super) mesh: json::Index<json::Mesh>,
    pub(super) joints: json::Index<json::Accessor>,
    pub(super) weights: json::Index<json::Accessor>,
    pub(super) indices: json::Index<json::Accessor>,
    pub(super) uvs: bool,
    pub(super) targets: usize,
    pub(super) clamped: usize,
    pub(super) max_clamp: f32,
}

/// The face: the base mesh (rest positions, normals, texture coordinates), its skin weights,
/// and its morph targets (each shape's displacement and normal change, each combined ARKit
/// target's, then the animation's jaw compensation).
pub(super) fn write_face(
    b: &mut Builder,
    actor: &AimActor<'_>,
    place: &Place,
    shapes: &Shapes,
    material: Option<json::Index<json::Material>>,
) -> Face {
    use json::accessor::{ComponentType, Type};
    use json::buffer::Target::ArrayBuffer;
    let (v, m, v_out) = (actor.vertex_count(), actor.shape_count(), place.vertices());
    let rest: Vec<f32> = actor.rest().iter().collect();
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

    let deltas = &shapes.deltas;
    let mut targets = Vec::with_capacity(shapes.sums.len());
    let mut shaped = rest.clone();
    for sum in &shapes.sums {
        let delta: Vec<f32> = (0..v)
            .flat_map(|i| (0..3).map(move |c| (i, c)))
            .map(|(i, c)| sum.iter().map(|&j| deltas[(i * m + j) * 3 + c]).sum())
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
    let compensation = &shapes.compensation;
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
    let mut names = shapes.named.all_names();
    names.extend((0..compensation.targets.len()).map(super::jaw::target_name));
    let targets_len = targets.len();
    let mut attributes = skinned(pos, nrm, joints, skin_weights);
    if let Some(uv) = uvs {
        attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), uv);
    }
    let mut extras = serde_json::json!({ "targetNames": names });
    if !compensation.targets.is_empty() {
        extras[COMPENSATION_KEY] = compensation.targets.len().into();
    }
    let mesh = b.root.push(json::Mesh {
        extensions: None,
        // A list of strings and a count always serialise.
        extras: serde_json::value::to_raw_value(&extras).ok(),
        name: Some("face".into()),
        primitives: vec![json::mesh::Primitive {
            material,
            targets: Some(targets),
            ..primitive(attributes, indices)
        }],
        weights: Some(vec![0.0; targets_len]),
    });
    Face {
        mesh,
        joints,
        weights: skin_weights,
        indices,
        uvs: uvs.is_some(),
        targets: targets_len,
        clamped,
        max_clamp,
    }
}

/// A triangle primitive of `attributes` over `indices`, without material or targets.
pub(super) fn primitive(
    attributes: BTreeMap<
        json::validation::Checked<json::mesh::Semantic>,
        json::Index<json::Accessor>,
    >,
    indices: json::Index<json::Accessor>,
) -> json::mesh::Primitive {
    json::mesh::Primitive {
        attributes,
        extensions: None,
        extras: None,
        indices: Some(indices),
        material: None,
        mode: Valid(json::mesh::Mode::Triangles),
        targets: None,
    }
}

/// A skinned mesh's attributes: positions, normals, joints and weights.
pub(super) fn skinned(
    positions: json::Index<json::Accessor>,
    normals: json::Index<json::Accessor>,
    joints: json::Index<json::Accessor>,
    weights: json::Index<json::Accessor>,
) -> BTreeMap<json::validation::Checked<json::mesh::Semantic>, json::Index<json::Accessor>> {
    BTreeMap::from([
        (Valid(json::mesh::Semantic::Positions), positions),
        (Valid(json::mesh::Semantic::Normals), normals),
        (Valid(json::mesh::Semantic::Joints(0)), joints),
        (Valid(json::mesh::Semantic::Weights(0)), weights),
    ])
}

/// The skeleton's nodes and the skin.
pub(super) struct Skeleton {
    pub(super) head: json::Index<json::Node>,
    pub(super) jaw: json::Index<json::Node>,
    pub(super) skin: json::Index<json::Skin>,
    pub(super) face_node: json::Index<json::Node>,
    /// The scene's root above the skeleton: the rig's node transform, else the head.
    pub(super) root: json::Index<json::Node>,
    /// The jaw pivot in the exported frame.
    pub(super) pivot: [f32; 3],
}

/// The joints (the head as root, the jaw at the pivot), the skin, the face's node, and a rig's
/// node transform above the skeleton, so that the face stands where the rig stood in its scene.
pub(super) fn write_skeleton(
    b: &mut Builder,
    actor: &AimActor<'_>,
    place: &Place,
    face: &Face,
) -> Skeleton {
    use json::accessor::Type;
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
        mesh: Some(face.mesh),
        skin: Some(skin),
        ..node("face")
    });
    let root = match place.node_transform() {
        Some(matrix) => b.root.push(json::Node {
            children: Some(vec![head]),
            matrix: Some(matrix),
            ..node("rig")
        }),
        None => head,
    };
    Skeleton {
        head,
        jaw,
        skin,
        face_node,
        root,
        pivot: pivot_m,
    }
}

/// The anatomy surface (the learned bone points b0) as a second mesh on the face's skin.
pub(super) fn write_bones(
    b: &mut Builder,
    actor: &AimActor<'_>,
    place: &Place,
    face: &Face,
    skin: json::Index<json::Skin>,
) -> Result<json::Index<json::Node>, GltfError> {
    use json::accessor::Type;
    use json::buffer::Target::ArrayBuffer;
    let v32 = actor.vertex_count() as u32;
    let bone: Vec<f32> = section(actor, "cache.b0", &[v32, 3])?.iter().collect();
    let bn = place.normals(&place.spread(&unit_normals(actor, &bone), 3));
    let bp = place.points(&place.spread(&bone, 3));
    let bpos = b.floats(&bp, Type::Vec3, true, Some(ArrayBuffer));
    let bnrm = b.floats(&bn, Type::Vec3, false, Some(ArrayBuffer));
    let mesh = b.root.push(json::Mesh {
        extensions: None,
        extras: None,
        name: Some("bones".into()),
        primitives: vec![primitive(
            skinned(bpos, bnrm, face.joints, face.weights),
            face.indices,
        )],
        weights: None,
    });
    Ok(b.root.push(json::Node {
        mesh: Some(mesh),
        skin: Some(skin),
        ..node("bones")
    }))
}
