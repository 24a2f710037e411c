//! A glTF rig whose indices point past the lists they index (an attribute, a morph target or
//! the indices naming an accessor that does not exist, an accessor or a compressed view naming
//! a buffer view or buffer that does not exist, a node naming a missing mesh): each is refused
//! with an error that names the file and the item, and none panics.

use serde_json::{Value, json};
use sinew_host::io::mesh::Mesh;
use sinew_host::io::rig::{IDENTITY, RigFile, RigFormat, RigReadError};
use sinew_host::io::units::Unit;

/// A 4 × 3 grid in metres with texture coordinates and two shapes.
fn small_rig() -> RigFile {
    let (nx, ny) = (4u32, 3u32);
    let positions: Vec<[f32; 3]> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| [0.02 * i as f32, 1.5 + 0.02 * j as f32, 0.1]))
        .collect();
    let uvs = positions.iter().map(|p| [p[0], p[1] - 1.5]).collect();
    let mut polygons = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let a = j * nx + i;
            polygons.push(vec![a, a + 1, a + nx]);
            polygons.push(vec![a + 1, a + nx + 1, a + nx]);
        }
    }
    let deltas = (0..2)
        .map(|k| {
            (0..positions.len())
                .map(|v| [0.001 * (k + 1) as f32, 0.0005 * v as f32, 0.0])
                .collect()
        })
        .collect();
    let mut neutral = Mesh::new(positions, polygons);
    neutral.uvs = uvs;
    RigFile {
        path: "small".into(),
        format: RigFormat::Gltf,
        mesh_name: "head".into(),
        neutral,
        shape_names: vec!["a".into(), "b".into()],
        deltas,
        node_transform: IDENTITY,
        units: Some(Unit::Metre),
        extensions: Vec::new(),
        avatar: None,
    }
}

/// The small rig written as a `.glb` with its JSON edited by `edit`; returns what reading it
/// gives, and fails the test if reading panicked.
fn read_edited(name: &str, edit: impl FnOnce(&mut Value)) -> Result<RigFile, RigReadError> {
    let bytes = small_rig().glb().unwrap();
    let (text, bin) = sinew_host::io::glb::read(&bytes).unwrap();
    let mut doc: Value = serde_json::from_slice(text).unwrap();
    edit(&mut doc);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("{name}.glb"));
    let text = serde_json::to_vec(&doc).unwrap();
    std::fs::write(&path, sinew_host::io::glb::write(&text, bin).unwrap()).unwrap();
    std::panic::catch_unwind(|| RigFile::read(&path, None))
        .unwrap_or_else(|_| panic!("{name}: reading panicked"))
}

/// An edit of a document's JSON.
type Edit = Box<dyn FnOnce(&mut Value)>;

/// The indices of the rig's document past the end of their lists: refused, naming the file and
/// the item.
#[test]
fn indices_past_their_lists_are_refused_by_item() {
    // The unedited file reads, so each refusal below is the edit's doing.
    let plain = read_edited("plain", |_| {}).unwrap();
    assert_eq!(plain.shape_names, ["a", "b"]);

    let primitive = "/meshes/0/primitives/0";
    let cases: Vec<(&str, &str, Edit)> = vec![
        (
            "position",
            "attributes[\"POSITION\"]: accessor 99",
            Box::new(move |d| {
                d.pointer_mut(primitive).unwrap()["attributes"]["POSITION"] = json!(99)
            }),
        ),
        (
            "texcoord",
            "TEXCOORD_0",
            Box::new(move |d| {
                d.pointer_mut(primitive).unwrap()["attributes"]["TEXCOORD_0"] = json!(99);
            }),
        ),
        (
            "target",
            "primitives[0].targets[1].positions",
            Box::new(move |d| {
                d.pointer_mut(primitive).unwrap()["targets"][1]["POSITION"] = json!(99)
            }),
        ),
        (
            "primitives[0].indices",
            "primitives[0].indices",
            Box::new(move |d| d.pointer_mut(primitive).unwrap()["indices"] = json!(99)),
        ),
        (
            "view",
            "accessors[0].bufferView",
            Box::new(|d| d["accessors"][0]["bufferView"] = json!(99)),
        ),
        (
            "buffer",
            "bufferViews[0].buffer",
            Box::new(|d| d["bufferViews"][0]["buffer"] = json!(99)),
        ),
        (
            "node-mesh",
            "nodes[0].mesh",
            Box::new(|d| d["nodes"][0]["mesh"] = json!(99)),
        ),
        (
            "scene-node",
            "scenes[0].nodes[0]",
            Box::new(|d| d["scenes"][0]["nodes"][0] = json!(99)),
        ),
    ];
    for (name, item, edit) in cases {
        let e = read_edited(name, edit).expect_err(name);
        let message = e.to_string();
        assert!(matches!(e, RigReadError::Gltf { .. }), "{name}: {message}");
        assert!(
            message.contains(&format!("{name}.glb")),
            "{name}: {message}"
        );
        assert!(message.contains(item), "{name}: {message}");
    }

    // A meshopt-compressed view naming a buffer past the list: refused by its view.
    let e = read_edited("meshopt-buffer", |d| {
        d["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
        d["bufferViews"][0]["extensions"] = json!({"EXT_meshopt_compression": {
            "buffer": 99, "byteLength": 16, "byteStride": 12, "count": 12, "mode": "ATTRIBUTES"}});
    })
    .expect_err("meshopt-buffer");
    assert!(matches!(e, RigReadError::BufferView { view: 0, .. }), "{e}");
    assert!(
        e.to_string().contains("meshopt-buffer.glb") && e.to_string().contains("99"),
        "{e}"
    );
}
