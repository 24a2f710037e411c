//! An OBJ-folder rig's material carried into its actor's export (`sinew export gltf --rig
//! FOLDER`): the material library `neutral.obj` names, its diffuse colour and map, the image
//! bytes as written; the other materials its faces use listed in the report's `dropped`; a
//! texture that is not there refused naming it.

use std::path::Path;

use crate::common::{named, procedural_actor};
use serde_json::Value;
use sinew_core::aim::AimActor;
use sinew_host::export::gltf::{Options, glb_carrying};
use sinew_host::figures::render::Image;
use sinew_host::io::rig::Scenery;

/// An OBJ folder holding the procedural set's template as `neutral.obj` (its first half of
/// polygons in material `skin`, the rest in `lips`), `head.mtl` and the skin's texture.
fn obj_rig(dir: &Path, set: &sinew_host::aim::TrainingSet) {
    let t = &set.template;
    let mut obj = String::from("mtllib head.mtl\no head\n");
    for p in &t.positions {
        obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    let half = t.polygons.len() / 2;
    for (i, poly) in t.polygons.iter().enumerate() {
        if i == 0 {
            obj += "usemtl skin\n";
        } else if i == half {
            obj += "usemtl lips\n";
        }
        let corners: Vec<String> = poly.iter().map(|v| (v + 1).to_string()).collect();
        obj += &format!("f {}\n", corners.join(" "));
    }
    std::fs::write(dir.join("neutral.obj"), obj).unwrap();
    std::fs::write(
        dir.join("head.mtl"),
        "newmtl skin\nKd 0.8 0.6 0.5\nd 1\nmap_Kd textures/skin.png\n\nnewmtl lips\nKd 0.7 0.3 0.3\n",
    )
    .unwrap();
    std::fs::create_dir_all(dir.join("textures")).unwrap();
    Image::new(4, 2, [200, 150, 120])
        .save_png(&dir.join("textures/skin.png"))
        .unwrap();
}

#[test]
fn an_obj_rigs_material_and_texture_are_carried() {
    let set = sinew_host::aim::testing::procedural_training_set(8);
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("head");
    std::fs::create_dir(&rig).unwrap();
    obj_rig(&rig, &set);
    let scenery = Scenery::read(&rig, None).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scenery.skin_vertices, set.template.positions.len());
    assert_eq!(scenery.materials.len(), 1);
    assert_eq!(scenery.skin_material, Some(0));
    assert!(scenery.parts.is_empty());
    let png = std::fs::read(rig.join("textures/skin.png")).unwrap();
    assert_eq!(scenery.images.len(), 1);
    assert_eq!(scenery.images[0].bytes, png);
    assert_eq!(scenery.images[0].mime_type, "image/png");
    let dropped = scenery.dropped.join("\n");
    assert!(dropped.contains("the material lips"), "{dropped}");

    let v = set.template.positions.len();
    let record = crate::common::plain_record("obj", "neutral", v, set.template.polygons.clone());
    let bytes = procedural_actor(
        &set,
        vec![
            ("units".into(), "m".into()),
            (
                sinew_host::rig::record::KEY.into(),
                serde_json::to_string(&record).unwrap(),
            ),
        ],
    );
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let (file, summary) = glb_carrying(&actor, &[], &Options::default(), Some(&scenery)).unwrap();
    assert!(summary.dropped.join("\n").contains("the material lips"));
    let (text, bin) = sinew_host::io::glb::read(&file).unwrap();
    let out: Value = serde_json::from_slice(text).unwrap();
    let face = named(&out, "meshes", "face");
    let material = &out["materials"][face["primitives"][0]["material"].as_u64().unwrap() as usize];
    assert_eq!(material["name"], "skin");
    let pbr = &material["pbrMetallicRoughness"];
    let colour: Vec<f64> = serde_json::from_value(pbr["baseColorFactor"].clone()).unwrap();
    for (got, want) in colour.iter().zip([0.8, 0.6, 0.5, 1.0]) {
        assert!((got - want).abs() < 1e-6, "{colour:?}");
    }
    let texture = &out["textures"][pbr["baseColorTexture"]["index"].as_u64().unwrap() as usize];
    let image = &out["images"][texture["source"].as_u64().unwrap() as usize];
    assert_eq!(image["mimeType"], "image/png");
    let view = &out["bufferViews"][image["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = view["byteLength"].as_u64().unwrap() as usize;
    assert_eq!(&bin[start..start + len], &png[..]);

    // A texture the library names and the folder lacks: refused, naming it.
    std::fs::remove_file(rig.join("textures/skin.png")).unwrap();
    let e = Scenery::read(&rig, None).unwrap_err().to_string();
    assert!(e.contains("head.mtl") && e.contains("skin.png"), "{e}");
}
