//! The rest of a glTF rig's character carried into its actor's export (`sinew export gltf
//! --rig`): the other meshes stand where they stood in the rig's scene, the materials, textures,
//! samplers and images come through with their indices, the face wears the skin's material, and
//! what cannot be carried is listed.

mod common;

use common::procedural_actor;
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
    let target = nodes.iter().position(|n| n["name"] == name).unwrap();
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
fn rig_file(set: &sinew_host::aim::TrainingSet, node_transform: [[f64; 4]; 4]) -> (Value, Vec<u8>) {
    let rig = RigFile {
        path: "head".into(),
        format: RigFormat::Gltf,
        mesh_name: "head".into(),
        neutral: set.template.clone(),
        shape_names: vec!["a".into()],
        deltas: vec![vec![[0.0, 0.001, 0.0]; set.template.positions.len()]],
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
    let (doc, bin) = rig_file(&set, node_transform);
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
    let head = out["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n["name"] == "head")
        .unwrap();
    let eyes = out["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n["name"] == "eyes")
        .unwrap();
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
    let face = out["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == "face")
        .unwrap();
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
