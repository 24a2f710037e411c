//! The rest of a glTF rig's character carried into its actor's export (`sinew export gltf
//! --rig`): the other meshes stand where they stood in the rig's scene, the materials, textures,
//! samplers and images come through with their indices, the face wears the skin's material, and
//! what cannot be carried is listed.

use crate::common::{named, named_index, procedural_actor};
use serde_json::{Value, json};
use sinew_core::aim::AimActor;
use sinew_host::export::gltf::{GltfError, Options, glb_carrying};
use sinew_host::io::rig::{RigFile, RigFormat, Scenery};
use sinew_host::io::units::Unit;
use sinew_host::rig::record::Record;

/// Column-major product of two 4 × 4 matrices.
fn mul(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|c| std::array::from_fn(|r| (0..4).map(|k| a[k][r] * b[c][k]).sum()))
}

fn apply(m: &[[f64; 4]; 4], p: [f32; 3]) -> [f64; 3] {
    std::array::from_fn(|r| (0..3).map(|c| m[c][r] * f64::from(p[c])).sum::<f64>() + m[3][r])
}

/// A node's local matrix from its JSON (`matrix`, or a translation and a rotation).
fn local(node: &Value) -> [[f64; 4]; 4] {
    if let Some(m) = node.get("matrix") {
        return std::array::from_fn(|c| std::array::from_fn(|r| m[4 * c + r].as_f64().unwrap()));
    }
    let t = |k: usize| {
        node.get("translation")
            .map_or(0.0, |t| t[k].as_f64().unwrap())
    };
    let q: Vec<f64> = node.get("rotation").map_or(vec![0.0, 0.0, 0.0, 1.0], |q| {
        (0..4).map(|k| q[k].as_f64().unwrap()).collect()
    });
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + z * w),
            2.0 * (x * z - y * w),
            0.0,
        ],
        [
            2.0 * (x * y - z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z + x * w),
            0.0,
        ],
        [
            2.0 * (x * z + y * w),
            2.0 * (y * z - x * w),
            1.0 - 2.0 * (x * x + y * y),
            0.0,
        ],
        [t(0), t(1), t(2), 1.0],
    ]
}

/// The scene transform of the node named `name` in a document's JSON.
fn world_of(doc: &Value, name: &str) -> [[f64; 4]; 4] {
    let nodes = doc["nodes"].as_array().unwrap();
    let target = named_index(doc, "nodes", name);
    let mut chain = vec![target];
    while let Some(parent) = nodes.iter().position(|n| {
        n["children"]
            .as_array()
            .is_some_and(|c| c.contains(&json!(chain[chain.len() - 1])))
    }) {
        chain.push(parent);
    }
    chain
        .iter()
        .rev()
        .fold(sinew_host::io::rig::IDENTITY, |m, &n| {
            mul(&m, &local(&nodes[n]))
        })
}

/// A triangle of eyes in the rig's scene.
const EYES: [[f32; 3]; 3] = [[0.03, 0.02, 0.05], [-0.03, 0.02, 0.05], [0.0, 0.05, 0.04]];
/// An image's bytes (a PNG signature and a body: the export copies it, never decodes it).
const PNG: &[u8] = b"\x89PNG\r\n\x1a\nimage body of the skin's texture";

/// The procedural face as a glTF rig: its skin mesh `head` under a turned and moved node, with
/// a textured material (its texture coordinates transformed by `KHR_texture_transform`), and an
/// `eyes` mesh of its own material under a parent node.
fn rig_file(
    neutral: &sinew_host::io::mesh::Mesh,
    node_transform: [[f64; 4]; 4],
) -> (Value, Vec<u8>) {
    let rig = RigFile {
        path: "head".into(),
        format: RigFormat::Gltf,
        mesh_name: "head".into(),
        neutral: neutral.clone(),
        shape_names: vec!["a".into()],
        deltas: vec![vec![[0.0, 0.001, 0.0]; neutral.positions.len()]],
        node_transform,
        units: Some(Unit::Metre),
        extensions: Vec::new(),
        avatar: None,
    };
    let bytes = rig.glb().unwrap();
    let (text, bin) = sinew_host::io::glb::read(&bytes).unwrap();
    let mut doc: Value = serde_json::from_slice(text).unwrap();
    let mut bin = bin.to_vec();
    let view = |bin: &mut Vec<u8>, doc: &mut Value, bytes: &[u8]| -> usize {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let views = doc["bufferViews"].as_array_mut().unwrap();
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let image = view(&mut bin, &mut doc, PNG);
    let floats = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
    let eyes: Vec<f32> = EYES.iter().flatten().copied().collect();
    let pos = view(&mut bin, &mut doc, &floats(&eyes));
    let nrm = view(&mut bin, &mut doc, &floats(&[0.0, 0.0, 1.0].repeat(3)));
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(
        json!({"bufferView": pos, "componentType": 5126, "count": 3, "type": "VEC3",
        "min": [-0.03, 0.02, 0.04], "max": [0.03, 0.05, 0.05]}),
    );
    accessors.push(json!({"bufferView": nrm, "componentType": 5126, "count": 3, "type": "VEC3"}));
    let n = accessors.len();
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["meshes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "eyes", "primitives": [{"attributes":
            {"POSITION": n - 2, "NORMAL": n - 1}, "material": 1}]}));
    doc["materials"] = json!([
        {"name": "skin", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
            "extensions": {"KHR_texture_transform": {"scale": [0.5, 0.5]}}}}},
        {"name": "eye", "emissiveFactor": [1, 1, 1],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}}
    ]);
    doc["textures"] = json!([{"source": 0, "sampler": 0}]);
    doc["samplers"] = json!([{"magFilter": 9729}]);
    doc["images"] = json!([{"bufferView": image, "mimeType": "image/png", "name": "skin"}]);
    doc["extensionsUsed"] = json!(["KHR_texture_transform", "KHR_materials_emissive_strength"]);
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"name": "eyes", "mesh": 1, "translation": [0.0, 0.01, 0.0]}));
    nodes.push(json!({"name": "eyeRig", "children": [nodes.len() - 1],
        "rotation": [0.0, 0.259_19, 0.0, 0.965_82], "translation": [0.1, 1.5, 0.2]}));
    let root = nodes.len() - 1;
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(root));
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    doc["buffers"][0]["byteLength"] = json!(bin.len());
    (doc, bin)
}

#[test]
fn a_glb_rigs_other_meshes_and_materials_come_through_in_place() {
    let set = sinew_host::aim::testing::procedural_training_set(8);
    let v = set.template.positions.len();
    // The skin's node turned a quarter about y and moved, so that the face and the eyes stand
    // in the scene through different transforms.
    let node_transform = [
        [0.0, 0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0],
        [0.3, 1.2, -0.1, 1.0],
    ];
    let (doc, bin) = rig_file(&set.template, node_transform);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("character.glb");
    let text = serde_json::to_vec(&doc).unwrap();
    std::fs::write(&path, sinew_host::io::glb::write(&text, &bin).unwrap()).unwrap();
    let scenery = Scenery::read(&path, Some("head")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((scenery.skin_vertices, scenery.parts.len()), (v, 1));

    let record = |vertices: usize| Record {
        format: "gltf".into(),
        mesh: "head".into(),
        units: "m".parse().unwrap(),
        up: "+y".parse().unwrap(),
        forward: "+z".parse().unwrap(),
        node_transform,
        placement: sinew_host::io::rig::IDENTITY,
        welded: (0..vertices as u32).map(|i| i % v as u32).collect(),
        polygons: set.template.polygons.clone(),
        uvs: Vec::new(),
        polygon_uvs: Vec::new(),
    };
    let actor_of = |r: &Record| {
        procedural_actor(
            &set,
            vec![
                ("units".into(), "m".into()),
                (
                    sinew_host::rig::record::KEY.into(),
                    serde_json::to_string(r).unwrap(),
                ),
            ],
        )
    };
    let bytes = actor_of(&record(v));
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let (file, summary) = glb_carrying(&actor, &[], &Options::default(), Some(&scenery)).unwrap();
    assert_eq!(summary.carried_meshes, 1);
    assert!(summary.dropped.is_empty(), "{:?}", summary.dropped);
    let (text, out_bin) = sinew_host::io::glb::read(&file).unwrap();
    let out: Value = serde_json::from_slice(text).unwrap();

    // The eyes stand where they stood in the rig's scene, to f32 rounding.
    let (before, after) = (world_of(&doc, "eyes"), world_of(&out, "eyes"));
    for p in EYES {
        let (a, b) = (apply(&before, p), apply(&after, p));
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-6, "{a:?} {b:?}");
        }
    }
    // They follow the head: their node hangs below the head joint.
    let head = named_index(&out, "nodes", "head");
    let eyes = named_index(&out, "nodes", "eyes");
    assert!(
        out["nodes"][head]["children"]
            .as_array()
            .unwrap()
            .contains(&json!(eyes))
    );

    // Materials, textures, samplers and images with their indices; the face wears a copy of
    // the skin's material without the transform its coordinates already carry.
    assert_eq!(out["materials"][0], doc["materials"][0]);
    assert_eq!(out["materials"][1], doc["materials"][1]);
    assert_eq!(out["materials"][2]["name"], "skin");
    assert!(
        out["materials"][2]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]
            .get("KHR_texture_transform")
            .is_none()
    );
    let face = named(&out, "meshes", "face");
    assert_eq!(face["primitives"][0]["material"], 2);
    assert_eq!(out["textures"], doc["textures"]);
    assert_eq!(out["samplers"], doc["samplers"]);
    let image = &out["images"][0];
    assert_eq!(image["mimeType"], "image/png");
    let view = &out["bufferViews"][image["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = view["byteLength"].as_u64().unwrap() as usize;
    assert_eq!(&out_bin[start..start + len], PNG);
    for e in ["KHR_texture_transform", "KHR_materials_emissive_strength"] {
        assert!(
            out["extensionsUsed"]
                .as_array()
                .unwrap()
                .contains(&json!(e)),
            "{e}"
        );
    }
    // Sinew reads its own export again: the face as the skin, the eyes beside it.
    let again = dir.path().join("export.glb");
    std::fs::write(&again, &file).unwrap();
    let read = RigFile::read(&again, None).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(read.mesh_name, "face");
    let carried = Scenery::read(&again, None).unwrap();
    assert_eq!(carried.parts.len(), 1);
    assert_eq!(carried.parts[0].primitives[0].positions, EYES.to_vec());

    // An actor whose rig had other vertices than this file's skin is refused.
    let other = actor_of(&record(v + 1));
    let actor = AimActor::from_bytes(&other).unwrap();
    let err = glb_carrying(&actor, &[], &Options::default(), Some(&scenery)).unwrap_err();
    assert!(matches!(err, GltfError::Rig(_)), "{err}");
    // So is an actor learned from no rig.
    let plain = procedural_actor(&set, vec![("units".into(), "m".into())]);
    let actor = AimActor::from_bytes(&plain).unwrap();
    let err = glb_carrying(&actor, &[], &Options::default(), Some(&scenery)).unwrap_err();
    assert!(err.to_string().contains("no rig"), "{err}");
}

/// Adds a mesh of one triangle at `points` (its node's own coordinates) on a new node `node` (its
/// JSON: name, transform); returns the node's index.
fn add_part(doc: &mut Value, bin: &mut Vec<u8>, points: &[[f32; 3]; 3], node: Value) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let bytes: Vec<u8> = points
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
    let view = views.len() - 1;
    bin.extend_from_slice(&bytes);
    let lo: Vec<f32> = (0..3)
        .map(|k| points.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min))
        .collect();
    let hi: Vec<f32> = (0..3)
        .map(|k| {
            points
                .iter()
                .map(|p| p[k])
                .fold(f32::NEG_INFINITY, f32::max)
        })
        .collect();
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(
        json!({"bufferView": view, "componentType": 5126, "count": 3,
        "type": "VEC3", "min": lo, "max": hi}),
    );
    let accessor = accessors.len() - 1;
    let meshes = doc["meshes"].as_array_mut().unwrap();
    meshes.push(
        json!({"name": node["name"], "primitives": [{"attributes": {"POSITION": accessor}}]}),
    );
    let mut node = node;
    node["mesh"] = json!(meshes.len() - 1);
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(node);
    let index = nodes.len() - 1;
    doc["buffers"][0]["byteLength"] = json!(bin.len());
    index
}

/// Carried meshes that belong to the jaw ride the jaw joint (docs/ENGINES.md, "The rest of the
/// character"): lower teeth, nearest the face where the actor learned to follow the jaw, and a
/// mesh the rig hangs on a node named like a jaw; eyes, nearest where it learned to stay, ride
/// the head. Through an animation that opens the jaw and turns the head, the lower teeth move
/// as the core's jaw transform moves the face (T_g(T_b(x)), AIM eq. 17 with k = 1) and the eyes
/// as its head transform, within 1 µm: f32 rounding of node matrices and keyed quaternions.
#[test]
fn lower_teeth_follow_the_jaw() {
    use crate::common::gltf::{Gltf, axis_angle, trs_matrix};
    use sinew_core::linalg::Vec3;
    // The golden ICT actor (its learned k follows the jaw about the chin and mouth), recorded
    // as learned from a glTF rig in metres of its own vertices and triangles.
    let golden = crate::common::gltf::golden();
    let learned = AimActor::from_bytes(&golden).unwrap();
    let v = learned.vertex_count();
    let scale = 0.01f32;
    let polygons: Vec<Vec<u32>> = learned
        .triangles()
        .indices()
        .iter()
        .collect::<Vec<u32>>()
        .chunks_exact(3)
        .map(<[u32]>::to_vec)
        .collect();
    // The skin node turned a quarter about y and moved; the glTF rig in metres.
    let node_transform = [
        [0.0, 0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0],
        [0.3, 1.2, -0.1, 1.0],
    ];
    // The rig's own coordinates of a scene point (the node transform is rigid).
    let own = |q: [f64; 3]| -> [f32; 3] {
        let m = &node_transform;
        let d: [f64; 3] = std::array::from_fn(|r| q[r] - m[3][r]);
        std::array::from_fn(|c| (0..3).map(|r| m[c][r] * d[r]).sum::<f64>() as f32)
    };
    let skin = sinew_host::io::mesh::Mesh::new(
        (0..v)
            .map(|i| {
                own(std::array::from_fn(|c| {
                    f64::from(scale * learned.rest().at(3 * i + c))
                }))
            })
            .collect(),
        polygons.clone(),
    );
    let record = Record {
        node_transform,
        ..crate::common::plain_record("gltf", "head", v, polygons)
    };
    let mut writer = sinew_host::io::container::SinewWriter::from_file(learned.file()).unwrap();
    writer.meta(
        sinew_host::rig::record::KEY,
        serde_json::to_string(&record).unwrap(),
    );
    let bytes = writer.to_bytes().unwrap();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    // A face vertex in the exported frame: the rig's own, in metres.
    let rest = |i: usize| -> [f32; 3] { skin.positions[i] };
    let k: Vec<f32> = actor
        .skinning_weights()
        .iter()
        .map(sinew_host::export::gltf::joint_weight)
        .collect();
    // The vertices with the most and the least jaw, among those with no other vertex within
    // a millimetre (where the lips meet at rest, an upper lip's vertex stands on a lower's).
    let alone = |i: usize| {
        (0..v).all(|j| {
            j == i || {
                let (a, b) = (rest(i), rest(j));
                (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f32>() > 1e-6
            }
        })
    };
    let by_k = |most: bool| {
        (0..v)
            .filter(|&i| alone(i))
            .max_by(|&a, &b| {
                let o = k[a].total_cmp(&k[b]);
                if most { o } else { o.reverse() }
            })
            .unwrap()
    };
    let (chin, brow) = (by_k(true), by_k(false));
    assert!(k[chin] > 0.5 && k[brow] < 0.5, "{} {}", k[chin], k[brow]);
    // Each mesh a triangle 0.1 mm about a face vertex, far nearer it than any other.
    let about = |i: usize| -> [[f32; 3]; 3] {
        let p = rest(i);
        [
            [p[0] + 1e-4, p[1], p[2] - 1e-4],
            [p[0] - 1e-4, p[1], p[2] - 1e-4],
            [p[0], p[1] + 1e-4, p[2] - 1e-4],
        ]
    };
    let (mut doc, mut bin) = rig_file(&skin, node_transform);
    let flat: Vec<f64> = node_transform.iter().flatten().copied().collect();
    // The lower teeth and the eyelashes stand in the skin's frame, under the skin's transform;
    // the tongue hangs below a node named like a jaw, beside the brow where the face learned to
    // keep still, so that only the rig's hierarchy puts it on the jaw.
    let teeth = add_part(
        &mut doc,
        &mut bin,
        &about(chin),
        json!({"name": "teethLower", "matrix": flat}),
    );
    let lashes = add_part(
        &mut doc,
        &mut bin,
        &about(brow),
        json!({"name": "lashes", "matrix": flat}),
    );
    let tongue = add_part(&mut doc, &mut bin, &about(brow), json!({"name": "tongue"}));
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(json!({"name": "Jaw_Bone", "children": [tongue], "matrix": flat}));
    let jaw_bone = nodes.len() - 1;
    for n in [teeth, lashes, jaw_bone] {
        doc["scenes"][0]["nodes"]
            .as_array_mut()
            .unwrap()
            .push(json!(n));
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("character.glb");
    let text = serde_json::to_vec(&doc).unwrap();
    std::fs::write(&path, sinew_host::io::glb::write(&text, &bin).unwrap()).unwrap();
    let scenery = Scenery::read(&path, Some("head")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scenery.parts.len(), 4);

    // The jaw opens by up to 0.3 rad and slides, the head turns and moves.
    let id = sinew_host::aim::model::IDENTITY_9D;
    let frames: Vec<sinew_host::aim::play::Frame> = (0..4)
        .map(|f| {
            let a = f as f64 / 3.0;
            let mut jaw = [0.0f32; 9];
            jaw[..6].copy_from_slice(&sinew_core::rotation::to_6d(&axis_angle(
                [1.0, 0.0, 0.0],
                0.3 * a,
            )));
            jaw[6..].copy_from_slice(&[0.0, -0.2 * a as f32, 0.1 * a as f32]);
            let mut head = id;
            head[..6].copy_from_slice(&sinew_core::rotation::to_6d(&axis_angle(
                [0.0, 1.0, 0.0],
                -0.2 * a,
            )));
            head[6..].copy_from_slice(&[1.0 * a as f32, 0.0, -2.0 * a as f32]);
            sinew_host::aim::play::Frame {
                head,
                jaw,
                weights: vec![0.5; actor.shape_count()],
            }
        })
        .collect();
    let (file, summary) =
        glb_carrying(&actor, &frames, &Options::default(), Some(&scenery)).unwrap();
    assert_eq!(summary.carried_meshes, 4);
    let g = Gltf::parse(&file);
    // The export's frame is the rig's own.
    let face = g.attribute(gltf_json::mesh::Semantic::Positions);
    assert_eq!(face.len(), 3 * v);
    for i in 0..v {
        for c in 0..3 {
            assert!(
                (face[3 * i + c] - f64::from(rest(i)[c])).abs() < 1e-6,
                "{i}"
            );
        }
    }
    assert_eq!(summary.carried_on_jaw, ["teethLower", "tongue"]);
    // The core's transforms act on the face frame: the scene in centimetres.
    let metres = |x: Vec3| [x.x, x.y, x.z].map(|c| f64::from(c * scale));
    let centimetres = |p: [f32; 3]| {
        let q = apply(&node_transform, p);
        Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32) * (1.0 / scale)
    };
    let (out_text, _) = sinew_host::io::glb::read(&file).unwrap();
    let out: Value = serde_json::from_slice(out_text).unwrap();
    let index = |name: &str| named_index(&out, "nodes", name);
    let animated = [index("head"), index("jaw")];
    // A node's scene transform at time t: animated joints by their keys, others by their JSON.
    let world = |node: usize, t: f64| {
        let mut chain = vec![node];
        while let Some(parent) = out["nodes"].as_array().unwrap().iter().position(|n| {
            n["children"]
                .as_array()
                .is_some_and(|c| c.contains(&json!(chain[chain.len() - 1])))
        }) {
            chain.push(parent);
        }
        chain
            .iter()
            .rev()
            .fold(sinew_host::io::rig::IDENTITY, |m, &n| {
                let own = if animated.contains(&n) {
                    // `trs_matrix` is row-major; these matrices are column-major.
                    let (tr, q) = g.trs(n, t);
                    let m = trs_matrix(tr, q);
                    std::array::from_fn(|c| std::array::from_fn(|r| m[r][c]))
                } else {
                    local(&out["nodes"][n])
                };
                mul(&m, &own)
            })
    };
    let mut worst = 0.0f64;
    for (f, frame) in frames.iter().enumerate() {
        let t = f64::from(f as f32 / 30.0);
        let pose = actor.pose_from_9d(&frame.jaw, &frame.head).unwrap();
        for (name, at, on_jaw) in [
            ("teethLower", chin, true),
            ("lashes", brow, false),
            ("tongue", brow, true),
        ] {
            let m = world(index(name), t);
            for p in about(at) {
                let x = centimetres(p);
                let moved = if on_jaw { pose.jaw.apply(x) } else { x };
                let want = metres(pose.head.apply(moved));
                let got = apply(&m, p);
                for c in 0..3 {
                    worst = worst.max((want[c] - got[c]).abs());
                }
            }
        }
        if f == 3 {
            // The open jaw moves the teeth by millimetres: a test that would catch them left
            // on the head.
            let x = centimetres(rest(chin));
            let d = (pose.jaw.apply(x) - x).norm() * scale;
            assert!(d > 1e-3, "{d} m");
        }
    }
    assert!(worst < 1e-6, "worst {worst} m");
    eprintln!("carried meshes on the jaw: worst {:.3e} m", worst);
}

/// A VRM 1.0 avatar's export keeps `VRMC_vrm`: the expressions the actor learned bound to their
/// exported morph targets, the avatar's `meta`, a humanoid of the head and jaw joints; the
/// expressions it did not learn listed in `dropped`. Read back as a rig, the export gives the
/// learned shapes by expression.
#[test]
fn a_vrm_avatars_expressions_are_bound_to_the_learned_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let (out, file, dropped) = exported_avatar(dir.path(), "VRMC_vrm", |skin| {
        json!({"specVersion": "1.0",
        "meta": {"name": "avatar", "licenseUrl": "https://vrm.dev/licenses/1.0/"},
        "humanoid": {"humanBones": {"head": {"node": skin}}},
        "expressions": {
            "preset": {"aa": {"morphTargetBinds": [{"node": skin, "index": 0, "weight": 1.0}]},
                       "blink": {"morphTargetBinds": [{"node": skin, "index": 0, "weight": 0.5}]}},
            "custom": {"jawOpen": {"morphTargetBinds": [{"node": skin, "index": 0, "weight": 0.8}],
                                   "isBinary": false}}}})
    });
    assert!(dropped.contains("expression blink"), "{dropped}");
    assert!(!dropped.contains("expression aa"), "{dropped}");
    assert!(!dropped.contains("VRMC_vrm"), "{dropped}");
    let vrm = &out["extensions"]["VRMC_vrm"];
    let face = named_index(&out, "nodes", "face");
    assert_eq!(
        vrm["expressions"]["preset"]["aa"]["morphTargetBinds"],
        json!([{"node": face, "index": 0, "weight": 1.0}])
    );
    assert_eq!(
        vrm["expressions"]["custom"]["jawOpen"]["morphTargetBinds"][0]["index"],
        1
    );
    assert_eq!(vrm["expressions"]["custom"]["jawOpen"]["isBinary"], false);
    assert_eq!(vrm["meta"]["name"], "avatar");
    read_back_avatar(dir.path(), &file, "1.0");
}

/// The procedural rig as a VRM avatar whose root extension `name` is `extension(skin node)`
/// (the skin is mesh 0), and its actor ([`avatar_actor`]) exported with it (`--rig`): the
/// export's JSON, its bytes and the report's `dropped` lines, the export listing the extension.
fn exported_avatar(
    dir: &std::path::Path,
    name: &str,
    extension: impl FnOnce(usize) -> Value,
) -> (Value, Vec<u8>, String) {
    let set = sinew_host::aim::testing::procedural_training_set(8);
    let (mut doc, bin) = rig_file(&set.template, sinew_host::io::rig::IDENTITY);
    let skin = doc["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n["mesh"] == 0)
        .unwrap();
    doc["extensionsUsed"]
        .as_array_mut()
        .unwrap()
        .push(json!(name));
    doc["extensions"] = json!({ name: extension(skin) });
    let path = dir.join("avatar.vrm");
    let text = serde_json::to_vec(&doc).unwrap();
    std::fs::write(&path, sinew_host::io::glb::write(&text, &bin).unwrap()).unwrap();
    let scenery = Scenery::read(&path, Some("head")).unwrap_or_else(|e| panic!("{e}"));
    let kept = if name == "VRM" {
        &scenery.vrm0
    } else {
        &scenery.vrm
    };
    assert!(kept.is_some(), "{name} not read");
    let bytes = avatar_actor(&set);
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let (file, summary) = glb_carrying(&actor, &[], &Options::default(), Some(&scenery)).unwrap();
    let (text, _) = sinew_host::io::glb::read(&file).unwrap();
    let out: Value = serde_json::from_slice(text).unwrap();
    assert!(
        out["extensionsUsed"]
            .as_array()
            .unwrap()
            .contains(&json!(name))
    );
    (out, file, summary.dropped.join("\n"))
}

/// The export `file` read back as a VRM `version` rig: the learned shapes by expression, each
/// its exported target whole.
fn read_back_avatar(dir: &std::path::Path, file: &[u8], version: &str) {
    let again = dir.join("export.vrm");
    std::fs::write(&again, file).unwrap();
    let read = RigFile::read(&again, None).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(read.mesh_name, "face");
    let mut got = read.shape_names.clone();
    got.sort();
    assert_eq!(got, ["aa", "jawOpen"]);
    let avatar = read.avatar.as_ref().unwrap();
    assert_eq!(avatar.version, version);
    for e in &avatar.expressions {
        assert_eq!(e.binds, [(e.name.clone(), 1.0)], "{}", e.name);
    }
}

/// An actor of the procedural set learned from a glTF rig in metres, its shapes 1 and 2 named
/// `aa` and `jawOpen`.
fn avatar_actor(set: &sinew_host::aim::TrainingSet) -> Vec<u8> {
    let v = set.template.positions.len();
    let mut names = set.names.clone();
    assert!(names.len() >= 3, "{names:?}");
    names[1] = "aa".into();
    names[2] = "jawOpen".into();
    let record = crate::common::plain_record("gltf", "head", v, set.template.polygons.clone());
    procedural_actor(
        set,
        vec![
            ("units".into(), "m".into()),
            ("shapes".into(), names.join(",")),
            (
                sinew_host::rig::record::KEY.into(),
                serde_json::to_string(&record).unwrap(),
            ),
        ],
    )
}

/// A VRM 0.x avatar's export keeps `VRM`: the blend shape groups the actor learned (a preset
/// under its VRM 1.0 name, a custom one by its own) bound to their exported morph targets at
/// weight 100 on the face mesh, the avatar's `meta` and material properties, a humanoid of the
/// head and jaw joints; the groups it did not learn listed in `dropped`. Read back as a rig, the
/// export gives the learned shapes by group.
#[test]
fn a_vrm_0x_avatars_blend_shape_groups_are_bound_to_the_learned_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let (out, file, dropped) = exported_avatar(dir.path(), "VRM", |skin| {
        json!({"specVersion": "0.0", "exporterVersion": "UniVRM-0.99",
        "meta": {"title": "avatar", "licenseName": "CC_BY"},
        "humanoid": {"humanBones": [{"bone": "head", "node": skin}, {"bone": "hips", "node": skin}]},
        "materialProperties": [{"name": "skin", "shader": "VRM/MToon"}],
        "blendShapeMaster": {"blendShapeGroups": [
            {"name": "A", "presetName": "a", "binds": [{"mesh": 0, "index": 0, "weight": 100}]},
            {"name": "Blink", "presetName": "blink", "binds": [{"mesh": 0, "index": 0, "weight": 50}]},
            {"name": "jawOpen", "presetName": "unknown", "isBinary": false,
             "binds": [{"mesh": 0, "index": 0, "weight": 80}]}]}})
    });
    assert!(dropped.contains("blend shape group blink"), "{dropped}");
    assert!(!dropped.contains("group aa"), "{dropped}");
    assert!(!dropped.contains("extension VRM"), "{dropped}");
    assert!(
        dropped.contains("humanoid's bones other than head and jaw"),
        "{dropped}"
    );
    let vrm = &out["extensions"]["VRM"];
    let face = named(&out, "nodes", "face");
    let groups = vrm["blendShapeMaster"]["blendShapeGroups"]
        .as_array()
        .unwrap();
    assert_eq!(groups.len(), 2);
    assert_eq!(groups[0]["presetName"], "a");
    assert_eq!(
        groups[0]["binds"],
        json!([{"mesh": face["mesh"], "index": 0, "weight": 100.0}])
    );
    assert_eq!(groups[1]["name"], "jawOpen");
    assert_eq!(groups[1]["binds"][0]["index"], 1);
    assert_eq!(vrm["meta"]["title"], "avatar");
    assert_eq!(vrm["materialProperties"][0]["shader"], "VRM/MToon");
    read_back_avatar(dir.path(), &file, "0.x");
}
