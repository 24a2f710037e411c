//! The rest of a glTF rig's character carried into its actor's export (`--rig`), so that the
//! file replaces the character in a scene: each other mesh (eyes, teeth) as a child of the head
//! joint, or of the jaw joint where it belongs to the jaw ([`rides_jaw`]: lower teeth, tongue),
//! standing where it stood in the rig's scene at rest and following the head's or the jaw's
//! motion; the materials, textures, samplers and images as the rig wrote them (their indices kept), and
//! the skin's material on the face. What cannot be carried is listed (`Scenery::dropped`).

use std::collections::BTreeMap;

use gltf_json as json;
use json::validation::Checked::Valid;

use crate::geometry::align::inv3;
use crate::io::glb::Builder;
use crate::io::rig::Scenery;

/// The parts placed, and what the finished document takes from the rig.
#[derive(Debug, Default)]
pub(super) struct Carried {
    /// The materials (the rig's, then the face's copy), textures, samplers and images.
    pub lists: BTreeMap<&'static str, Vec<serde_json::Value>>,
    /// Extensions the materials and textures use, with whether the rig required each.
    pub extensions: Vec<(String, bool)>,
    /// The meshes carried.
    pub meshes: usize,
    /// The carried meshes that ride the jaw joint, by name.
    pub on_jaw: Vec<String>,
    /// Extensions of the document's root (a VRM avatar's `VRMC_vrm`, `super::vrm`), by name.
    pub root_extensions: Vec<(String, serde_json::Value)>,
}

impl Carried {
    /// Puts the rig's lists into the finished document's JSON.
    pub(super) fn apply(&self, doc: &mut serde_json::Value) {
        for (name, value) in &self.root_extensions {
            doc["extensions"][name.as_str()] = value.clone();
        }
        for (key, list) in &self.lists {
            if !list.is_empty() {
                doc[*key] = serde_json::Value::Array(list.clone());
            }
        }
        for (name, required) in &self.extensions {
            for (key, wanted) in [("extensionsUsed", true), ("extensionsRequired", *required)] {
                if !wanted {
                    continue;
                }
                let list = doc
                    .as_object_mut()
                    .map(|o| o.entry(key).or_insert_with(|| serde_json::json!([])));
                if let Some(serde_json::Value::Array(list)) = list
                    && !list.iter().any(|v| v == name)
                {
                    list.push(name.clone().into());
                }
            }
        }
    }
}

/// The inverse of a column-major affine 4 × 4 matrix, or `None` when singular.
fn inverse(m: &[[f64; 4]; 4]) -> Option<[[f64; 4]; 4]> {
    let a: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| m[c][r]));
    let i = inv3(a)?;
    let t = [m[3][0], m[3][1], m[3][2]];
    let it: [f64; 3] = std::array::from_fn(|r| -(0..3).map(|k| i[r][k] * t[k]).sum::<f64>());
    Some(std::array::from_fn(|c| {
        std::array::from_fn(|r| match (c, r) {
            (3, 3) => 1.0,
            (3, r) => it[r],
            (_, 3) => 0.0,
            (c, r) => i[r][c],
        })
    }))
}

/// Column-major product.
fn mul(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|c| std::array::from_fn(|r| (0..4).map(|k| a[k][r] * b[c][k]).sum()))
}

/// The face's material in the finished document: the copy of the skin's, after the rig's own.
pub(super) fn face_material(scenery: &Scenery) -> Option<json::Index<json::Material>> {
    scenery
        .skin_material
        .filter(|&m| m < scenery.materials.len())
        .map(|_| json::Index::new(scenery.materials.len() as u32))
}

/// The face at rest in the exported frame (the head joint's), as [`rides_jaw`] reads it.
pub(super) struct FaceRest {
    /// The actor's rest vertices.
    pub points: Vec<[f64; 3]>,
    /// Their jaw skin weights as glTF carries them (the learned k held to [0, 1]).
    pub k: Vec<f64>,
    /// The jaw pivot, the jaw joint's rest translation.
    pub pivot: [f32; 3],
}

/// The share of the jaw above which a carried mesh rides the jaw joint: a mesh goes where most
/// of it is.
pub const JAW_SHARE: f64 = 0.5;

/// Whether a carried mesh whose vertices stand at `points` (exported frame) rides the jaw: the
/// rig hangs it on a jaw (`on_jaw`), or the mean, over its vertices, of the jaw weight of the
/// face vertex nearest each exceeds [`JAW_SHARE`]. The nearest face vertex is looked for within
/// one cell of a grid of an eighth of the face's largest extent (2 cm on a 16 cm face) around
/// the vertex; a vertex with no face vertex that near counts as the head's. So lower teeth and
/// a tongue, nearest the lower lip and chin, which the actor learned to follow the jaw, ride
/// it; eyes, upper teeth and hair, nearest the lids, the upper lip or nothing, stay on the head.
/// A carried mesh moves rigidly with the joint it rides: teeth and tongue are rigid with the
/// jaw, and a blend would shear them.
pub(super) fn rides_jaw(on_jaw: bool, points: &[[f64; 3]], face: &FaceRest) -> bool {
    use crate::geometry::spatial::{Grid, cell_for};
    if on_jaw {
        return true;
    }
    if points.is_empty() || face.points.is_empty() {
        return false;
    }
    let grid = Grid::new(&face.points, cell_for(&face.points, 8));
    let total: f64 = points
        .iter()
        .map(|&p| {
            grid.nearest_where(&face.points, p, |_| true)
                .map_or(0.0, |(i, _)| face.k[i])
        })
        .sum();
    total / points.len() as f64 > JAW_SHARE
}

/// `m` applied to the point `p`.
fn apply(m: &[[f64; 4]; 4], p: [f32; 3]) -> [f64; 3] {
    std::array::from_fn(|r| (0..3).map(|c| m[c][r] * f64::from(p[c])).sum::<f64>() + m[3][r])
}

/// The nodes written by [`carry`]: those to hang below the head joint and below the jaw joint.
pub(super) struct Nodes {
    /// Children of the head joint.
    pub head: Vec<json::Index<json::Node>>,
    /// Children of the jaw joint.
    pub jaw: Vec<json::Index<json::Node>>,
}

/// Writes `scenery`'s meshes as children of the head joint, or of the jaw joint where they ride
/// it ([`rides_jaw`] over `face`), the head's scene transform at rest being the rig's node
/// transform `node_transform`; returns their nodes and what the document takes from the rig.
/// `None` when the node transform cannot be inverted.
pub(super) fn carry(
    b: &mut Builder,
    scenery: &Scenery,
    node_transform: &[[f64; 4]; 4],
    face: &FaceRest,
) -> Option<(Nodes, Carried)> {
    use json::accessor::Type;
    use json::buffer::Target::ArrayBuffer;
    let to_head = inverse(node_transform)?;
    // The jaw joint stands at the pivot in the head's frame, unturned: its rest frame is the
    // head's moved by the pivot.
    let p = face.pivot.map(f64::from);
    let mut to_jaw = crate::io::rig::IDENTITY;
    to_jaw[3] = [-p[0], -p[1], -p[2], 1.0];
    let mut nodes = Nodes {
        head: Vec::new(),
        jaw: Vec::new(),
    };
    let mut on_jaw = Vec::new();
    let mut meshes = 0;
    for part in &scenery.parts {
        let mut primitives = Vec::new();
        for p in &part.primitives {
            let flat3 = |v: &[[f32; 3]]| -> Vec<f32> { v.iter().flatten().copied().collect() };
            let mut attributes = BTreeMap::new();
            attributes.insert(
                Valid(json::mesh::Semantic::Positions),
                b.floats(&flat3(&p.positions), Type::Vec3, true, Some(ArrayBuffer)),
            );
            if let Some(n) = &p.normals {
                attributes.insert(
                    Valid(json::mesh::Semantic::Normals),
                    b.floats(&flat3(n), Type::Vec3, false, Some(ArrayBuffer)),
                );
            }
            if let Some(uv) = &p.uvs {
                let flat: Vec<f32> = uv.iter().flatten().copied().collect();
                attributes.insert(
                    Valid(json::mesh::Semantic::TexCoords(0)),
                    b.floats(&flat, Type::Vec2, false, Some(ArrayBuffer)),
                );
            }
            primitives.push(json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(b.indices(&p.triangles)),
                material: p.material.map(|m| json::Index::new(m as u32)),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            });
        }
        if primitives.is_empty() {
            continue;
        }
        let mesh = b.root.push(json::Mesh {
            extensions: None,
            extras: None,
            name: Some(part.name.clone()),
            primitives,
            weights: None,
        });
        meshes += 1;
        let in_head = mul(&to_head, &part.world);
        let points: Vec<[f64; 3]> = part
            .primitives
            .iter()
            .flat_map(|p| p.positions.iter().map(|&x| apply(&in_head, x)))
            .collect();
        let jaw = rides_jaw(part.on_jaw, &points, face);
        let local = if jaw { mul(&to_jaw, &in_head) } else { in_head };
        let matrix: [f32; 16] = std::array::from_fn(|k| local[k / 4][k % 4] as f32);
        let node = b.root.push(json::Node {
            name: Some(part.name.clone()),
            mesh: Some(mesh),
            matrix: Some(matrix),
            ..Default::default()
        });
        if jaw {
            nodes.jaw.push(node);
            on_jaw.push(part.name.clone());
        } else {
            nodes.head.push(node);
        }
    }
    let mut images = Vec::new();
    for image in &scenery.images {
        let view = b.view(&image.bytes, None);
        let mut v = serde_json::json!({"bufferView": view.value(), "mimeType": image.mime_type});
        if let Some(name) = &image.name {
            v["name"] = name.clone().into();
        }
        images.push(v);
    }
    // The face's material: a copy of the skin's, its texture transforms taken off (the rig's
    // reader applied them to the face's texture coordinates), at `face_material`'s index.
    let mut materials = scenery.materials.clone();
    if let Some(mut m) = scenery
        .skin_material
        .and_then(|m| materials.get(m).cloned())
    {
        untransformed(&mut m);
        materials.push(m);
    }
    let lists = BTreeMap::from([
        ("materials", materials),
        ("textures", scenery.textures.clone()),
        ("samplers", scenery.samplers.clone()),
        ("images", images),
    ]);
    Some((
        nodes,
        Carried {
            lists,
            extensions: scenery.extensions.clone(),
            meshes,
            on_jaw,
            root_extensions: Vec::new(),
        },
    ))
}

/// Takes `KHR_texture_transform` off every texture reference of a material that reads texture
/// coordinate set 0: the rig's reader applied it to the face's coordinates already.
fn untransformed(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(o) => {
            if o.contains_key("index")
                && o.get("texCoord").and_then(|t| t.as_u64()).unwrap_or(0) == 0
                && let Some(serde_json::Value::Object(ext)) = o.get_mut("extensions")
            {
                ext.remove("KHR_texture_transform");
            }
            for child in o.values_mut() {
                untransformed(child);
            }
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(untransformed),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_affine_inverse_undoes_its_matrix() {
        let m = [
            [0.0, 2.0, 0.0, 0.0],
            [-2.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 2.0, 0.0],
            [0.1, 1.5, -0.2, 1.0],
        ];
        let p = mul(&inverse(&m).unwrap(), &m);
        for (c, col) in p.iter().enumerate() {
            for (r, v) in col.iter().enumerate() {
                assert!((v - f64::from(u8::from(c == r))).abs() < 1e-12, "{p:?}");
            }
        }
        assert!(inverse(&[[0.0; 4]; 4]).is_none());
    }

    #[test]
    fn texture_transforms_on_set_0_are_taken_off() {
        let mut m = serde_json::json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
            "extensions": {"KHR_texture_transform": {"scale": [2, 2]}, "EXT_other": {}}}},
            "normalTexture": {"index": 1, "texCoord": 1,
            "extensions": {"KHR_texture_transform": {"offset": [0.5, 0]}}}});
        untransformed(&mut m);
        let base = &m["pbrMetallicRoughness"]["baseColorTexture"]["extensions"];
        assert!(base.get("KHR_texture_transform").is_none() && base.get("EXT_other").is_some());
        assert!(m["normalTexture"]["extensions"]["KHR_texture_transform"].is_object());
    }
}
