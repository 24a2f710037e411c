//! VRM avatars as rigs: VRM 1.0 (`VRMC_vrm`) and 0.x (`VRM`) expressions become the shapes by
//! their binds, bad binds are refused by expression, and a VRM 0.x avatar faces −z unbidden.

use serde_json::{Value, json};
use sinew_host::io::rig::{ExpressionProblem, RigFile, RigReadError, Treatment};
use sinew_host::io::units::Unit;

use crate::rig_formats::{Doc, grid_rig};

/// The grid rig as a VRM avatar with a second, eyelash, mesh that has more morph targets.
fn avatar(extension: Value) -> Doc {
    let rig = grid_rig(&[
        "Fcl_MTH_A",
        "Fcl_MTH_Smile_L",
        "Fcl_MTH_Smile_R",
        "Fcl_EYE_Close",
    ]);
    let mut doc = Doc::of(&rig);
    let lashes = doc.json["meshes"][0].clone();
    let mut lashes = lashes;
    lashes["name"] = json!("lashes");
    let targets = lashes["primitives"][0]["targets"]
        .as_array()
        .unwrap()
        .clone();
    lashes["primitives"][0]["targets"] = json!([targets.clone(), targets].concat());
    lashes["weights"] = json!(vec![0.0; 8]);
    lashes["extras"] = json!({});
    let mesh = doc.push("meshes", lashes);
    let node = doc.push("nodes", json!({"mesh": mesh, "name": "lashes"}));
    doc.json["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(node));
    doc.push("nodes", json!({"name": "empty"}));
    for name in extension.as_object().unwrap().keys() {
        doc.uses(name, false);
    }
    doc.json["extensions"] = extension;
    doc
}

fn vrm1(custom: Value) -> Value {
    json!({"VRMC_vrm": {"specVersion": "1.0", "expressions": {
        "preset": {
            "aa": {"morphTargetBinds": [{"node": 0, "index": 0, "weight": 1.0}]},
            "happy": {"morphTargetBinds": [{"node": 0, "index": 1, "weight": 1.0},
                                           {"node": 0, "index": 2, "weight": 1.0}]},
            "blink": {"morphTargetBinds": [{"node": 0, "index": 3, "weight": 1.0},
                                           {"node": 1, "index": 5, "weight": 1.0}]},
            "lookUp": {}
        },
        "custom": custom}}})
}

/// VRM 1.0 and 0.x avatars: each expression a shape, the weighted sum of its binds on the face
/// (the mesh the binds reach, not the one with the most targets); presets under VRM 1.0's
/// names; ARKit-named custom expressions bound to ARKit by the usual name rules; expressions
/// that bind nothing on the face, and binds on other meshes, reported.
#[test]
fn vrm_expressions_become_the_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let rig = grid_rig(&[
        "Fcl_MTH_A",
        "Fcl_MTH_Smile_L",
        "Fcl_MTH_Smile_R",
        "Fcl_EYE_Close",
    ]);
    let sum = |binds: &[(usize, f32)]| -> Vec<[f32; 3]> {
        (0..rig.vertex_count())
            .map(|v| {
                std::array::from_fn(|k| binds.iter().map(|&(t, w)| w * rig.deltas[t][v][k]).sum())
            })
            .collect()
    };
    let v1 = dir.path().join("avatar.vrm");
    avatar(vrm1(json!({"jawOpen": {"morphTargetBinds": [{"node": 0, "index": 0, "weight": 0.7}]},
                       "MouthSmileLeft": {"morphTargetBinds": [{"node": 0, "index": 1, "weight": 0.5}]}})))
    .write(&v1);
    let v0 = dir.path().join("avatar0.vrm");
    avatar(json!({"VRM": {"blendShapeMaster": {"blendShapeGroups": [
        {"name": "A", "presetName": "a", "binds": [{"mesh": 0, "index": 0, "weight": 100}]},
        {"name": "Joy", "presetName": "joy", "binds": [{"mesh": 0, "index": 1, "weight": 100}, {"mesh": 0, "index": 2, "weight": 100}]},
        {"name": "Blink", "presetName": "blink", "binds": [{"mesh": 0, "index": 3, "weight": 100}, {"mesh": 1, "index": 5, "weight": 100}]},
        {"name": "LookUp", "presetName": "lookup", "binds": []},
        {"name": "jawOpen", "presetName": "unknown", "binds": [{"mesh": 0, "index": 0, "weight": 70}]},
        {"name": "MouthSmileLeft", "presetName": "unknown", "binds": [{"mesh": 0, "index": 1, "weight": 50}]}
    ]}}}))
    .write(&v0);
    let want = |name: &str| match name {
        "aa" => sum(&[(0, 1.0)]),
        "happy" => sum(&[(1, 1.0), (2, 1.0)]),
        "blink" => sum(&[(3, 1.0)]),
        "jawOpen" => sum(&[(0, 0.7)]),
        _ => sum(&[(1, 0.5)]),
    };
    // In the file's order: VRM 1.0's objects as written (here alphabetically), presets first;
    // VRM 0.x's list as it is.
    for (path, version, order) in [
        (
            &v1,
            "1.0",
            ["aa", "blink", "happy", "MouthSmileLeft", "jawOpen"],
        ),
        (
            &v0,
            "0.x",
            ["aa", "happy", "blink", "jawOpen", "MouthSmileLeft"],
        ),
    ] {
        let read = RigFile::read(path, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(read.mesh_name, "head", "{version}");
        assert_eq!(read.shape_names, order, "{version}");
        for (name, got) in read.shape_names.iter().zip(&read.deltas) {
            for (g, w) in got.iter().zip(&want(name)) {
                for k in 0..3 {
                    assert!((g[k] - w[k]).abs() <= 1e-7, "{version} {name}");
                }
            }
        }
        let avatar = read.avatar.as_ref().unwrap();
        assert_eq!(avatar.version, version);
        let expression = |n: &str| avatar.expressions.iter().find(|e| e.name == n).unwrap();
        assert_eq!(
            expression("happy").binds,
            [
                ("Fcl_MTH_Smile_L".to_owned(), 1.0),
                ("Fcl_MTH_Smile_R".to_owned(), 1.0)
            ]
        );
        assert!(expression("happy").preset && !expression("jawOpen").preset);
        let dropped: Vec<&str> = avatar.dropped.iter().map(|d| d.name.as_str()).collect();
        assert_eq!(dropped, ["blink", "lookUp"], "{version}");
        let arkit = sinew_host::io::arkit::arkit_bindings(&read.shape_names);
        let bound = |a: &str| arkit.iter().find(|(n, _)| n == a).unwrap().1.clone();
        let at = |n: &str| read.shape_names.iter().position(|s| s == n).unwrap();
        assert_eq!(bound("jawOpen"), [at("jawOpen")]);
        assert_eq!(bound("mouthSmileLeft"), [at("MouthSmileLeft")]);
        let name = if version == "1.0" { "VRMC_vrm" } else { "VRM" };
        assert!(
            read.extensions
                .iter()
                .any(|e| e.treatment == Treatment::Decoded && e.name == name)
        );
    }
}

/// Bad binds are refused naming the file and the expression: a target the mesh lacks, a
/// non-finite weight, a node without a mesh, an expression defined twice.
#[test]
fn bad_vrm_binds_are_refused_by_expression() {
    let dir = tempfile::tempdir().unwrap();
    type Check = fn(&ExpressionProblem) -> bool;
    let cases: Vec<(&str, Value, Check)> = vec![
        (
            "past",
            vrm1(
                json!({"jawOpen": {"morphTargetBinds": [{"node": 0, "index": 4, "weight": 1.0}]}}),
            ),
            |p| {
                matches!(
                    p,
                    ExpressionProblem::NoSuchTarget {
                        index: 4,
                        targets: 4,
                        ..
                    }
                )
            },
        ),
        (
            "nan",
            vrm1(
                json!({"jawOpen": {"morphTargetBinds": [{"node": 0, "index": 0, "weight": "NaN"}]}}),
            ),
            |p| matches!(p, ExpressionProblem::NonFiniteWeight { .. }),
        ),
        (
            "huge",
            vrm1(
                json!({"jawOpen": {"morphTargetBinds": [{"node": 0, "index": 0, "weight": 1e300}]}}),
            ),
            |p| matches!(p, ExpressionProblem::NonFiniteWeight { .. }),
        ),
        (
            "meshless",
            vrm1(
                json!({"jawOpen": {"morphTargetBinds": [{"node": 2, "index": 0, "weight": 1.0}]}}),
            ),
            |p| matches!(p, ExpressionProblem::NoSuchMesh { .. }),
        ),
        (
            "twice",
            vrm1(json!({"happy": {"morphTargetBinds": [{"node": 0, "index": 0, "weight": 1.0}]}})),
            |p| matches!(p, ExpressionProblem::Repeated),
        ),
        (
            "twice0",
            json!({"VRM": {"blendShapeMaster": {"blendShapeGroups": [
            {"name": "Joy", "presetName": "joy", "binds": [{"mesh": 0, "index": 1, "weight": 100}]},
            {"name": "Joy2", "presetName": "joy", "binds": [{"mesh": 0, "index": 2, "weight": 100}]}]}}}),
            |p| matches!(p, ExpressionProblem::Repeated),
        ),
    ];
    for (name, extension, check) in cases {
        let path = dir.path().join(format!("{name}.vrm"));
        avatar(extension).write(&path);
        let e = RigFile::read(&path, None).unwrap_err();
        assert!(
            matches!(&e, RigReadError::Expression { what, .. } if check(what)),
            "{name}: {e}"
        );
        assert!(e.to_string().contains(&format!("{name}.vrm")), "{e}");
    }
    // A key written twice in one object, which a JSON map would silently collapse.
    let path = dir.path().join("key-twice.vrm");
    let mut doc = avatar(vrm1(json!({"jawOpen": {"morphTargetBinds": []}})));
    let text = serde_json::to_string(&doc.json).unwrap().replacen(
        "\"jawOpen\":{\"morphTargetBinds\":[]}",
        "\"jawOpen\":{\"morphTargetBinds\":[]},\"jawOpen\":{\"morphTargetBinds\":[]}",
        1,
    );
    doc.json = Value::Null;
    while !doc.bin.len().is_multiple_of(4) {
        doc.bin.push(0);
    }
    std::fs::write(
        &path,
        sinew_host::io::glb::write(text.as_bytes(), &doc.bin).unwrap(),
    )
    .unwrap();
    let e = RigFile::read(&path, None).unwrap_err();
    assert!(
        matches!(&e, RigReadError::Expression { expression, what: ExpressionProblem::Repeated, .. } if expression == "jawOpen"),
        "{e}"
    );
}

/// A VRM 0.x avatar faces −z, as that specification turns it: read with no `--forward`, its
/// conventions say so (`forward` −z, the head's placement near the identity) and its landmarks
/// are where they are. The same head without the `VRM` extension reads as glTF's +z, its face
/// found turned half about the up axis; told `--forward +z`, the avatar reads as that head.
#[test]
fn a_vrm_0x_avatar_faces_minus_z_without_being_told() {
    use sinew_host::rig::sample::{Placement, from_kit};
    use sinew_host::rig::{Axis, Rig, RigOptions};
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let placement = Placement {
        units: Unit::Metre,
        forward: Axis::NegZ,
        ..Placement::kit()
    };
    let sample = from_kit(&root.join("ict-facekit"), &[0.3, -0.5], 2_500, &placement).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut doc = Doc::of(&sample.file);
    let plain = dir.path().join("head.glb");
    doc.write(&plain);
    let at = |name: &str| {
        let i = sample.file.shape_names.iter().position(|n| n == name);
        i.unwrap()
    };
    doc.uses("VRM", false);
    doc.json["extensions"] = json!({"VRM": {"blendShapeMaster": {"blendShapeGroups": [
        {"name": "jawOpen", "presetName": "unknown",
         "binds": [{"mesh": 0, "index": at("jawOpen"), "weight": 100}]},
        {"name": "Blink_L", "presetName": "blink_l",
         "binds": [{"mesh": 0, "index": at("eyeBlink_L"), "weight": 100}]}
    ]}}});
    let avatar = dir.path().join("head.vrm");
    doc.write(&avatar);

    // The placement's turn about the up axis, in degrees (0: the conventions face the way the
    // head does).
    let turn = |rig: &Rig| {
        let m = rig.conventions.placement;
        m[2][0].atan2(m[0][0]).to_degrees().abs()
    };
    let told = RigOptions {
        forward: Some(Axis::PosZ),
        ..RigOptions::default()
    };
    for (path, options, forward, turned) in [
        (&avatar, &RigOptions::default(), Axis::NegZ, false),
        (&plain, &RigOptions::default(), Axis::PosZ, true),
        (&avatar, &told, Axis::PosZ, true),
    ] {
        let rig = Rig::open(path, options).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(rig.conventions.forward, forward, "{}", path.display());
        assert_eq!(
            turn(&rig) > 170.0,
            turned,
            "{}: turned {}°",
            path.display(),
            turn(&rig)
        );
        assert!(turn(&rig) > 170.0 || turn(&rig) < 10.0, "{}", turn(&rig));
        let e = sinew_host::rig::inspect::landmark_error(&rig, &sample.landmarks);
        assert!(
            e.mean < 1.5 && e.max < 5.0,
            "{}: mean {} mm, max {} mm",
            path.display(),
            e.mean,
            e.max
        );
    }
}
