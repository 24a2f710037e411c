//! Rigs in: glTF and OBJ-folder rigs built by the tests in other topologies than the kit's, in
//! a scene's frame and units, resolved by `sinew_host::rig` and `sinew rig inspect`; and bad
//! rigs refused by name.

use std::path::Path;

use crate::common::{NO_DEFAULT_DEVICE, err, named, ok, ok_with, s};
use sinew_host::io::rig::{RigFile, RigReadError};
use sinew_host::io::units::Unit;
use sinew_host::rig::sample::{Placement, Sample, sample};
use sinew_host::rig::template::FaceTemplate;
use sinew_host::rig::{Axis, Rig, RigError, RigOptions};

/// The built-in face template as a rig: re-meshed to `vertices`, with a jaw that opens (the
/// part below the mouth turned 15° about a hinge), a smile on one side and a blink, under
/// names in four spellings.
fn template_rig(vertices: usize, placement: &Placement) -> Sample {
    let t = FaceTemplate::builtin().unwrap();
    let points: Vec<[f32; 3]> = t.points().iter().map(|p| p.map(|v| v as f32)).collect();
    let surface_point = |(tri, w): (u32, [f64; 3])| -> [f64; 3] {
        let c = t.triangles[tri as usize].map(|i| t.points()[i as usize]);
        [0, 1, 2].map(|k| c[0][k] * w[0] + c[1][k] * w[1] + c[2][k] * w[2])
    };
    let landmarks: Vec<[f64; 3]> = t.landmarks.iter().map(|&l| surface_point(l)).collect();
    let mouth = landmarks[62];
    let pivot = t.jaw_pivot_cm();
    let (sn, cs) = 15f64.to_radians().sin_cos();
    let jaw: Vec<[f32; 3]> = points
        .iter()
        .map(|&p| {
            if f64::from(p[1]) >= mouth[1] {
                return p;
            }
            let (y, z) = (f64::from(p[1]) - pivot[1], f64::from(p[2]) - pivot[2]);
            [
                p[0],
                (cs * y - sn * z + pivot[1]) as f32,
                (sn * y + cs * z + pivot[2]) as f32,
            ]
        })
        .collect();
    let bump = |centre: [f64; 3], lift: [f32; 3]| -> Vec<[f32; 3]> {
        points
            .iter()
            .map(|&p| {
                let d2: f64 = (0..3).map(|k| (f64::from(p[k]) - centre[k]).powi(2)).sum();
                let w = (-d2 / 2.0).exp() as f32;
                [p[0] + w * lift[0], p[1] + w * lift[1], p[2] + w * lift[2]]
            })
            .collect()
    };
    let shapes = vec![
        ("jawOpen".to_owned(), jaw),
        (
            "mouthSmile.L".to_owned(),
            bump(landmarks[54], [0.4, 0.5, 0.0]),
        ),
        (
            "MouthSmileRight".to_owned(),
            bump(landmarks[48], [-0.4, 0.5, 0.0]),
        ),
        (
            "eyeBlink_L".to_owned(),
            bump(landmarks[44], [0.0, -0.3, 0.0]),
        ),
    ];
    sample(
        &points,
        &t.triangles,
        &shapes,
        &landmarks,
        vertices,
        placement,
    )
    .unwrap()
}

fn options(up: Axis, forward: Axis) -> RigOptions {
    RigOptions {
        up,
        forward: Some(forward),
        ..RigOptions::default()
    }
}

/// Mean distance (mm) of the rig's landmarks from the sample's.
fn landmark_error(rig: &Rig, truth: &[[f64; 3]]) -> f64 {
    sinew_host::rig::inspect::landmark_error(rig, truth).mean
}

#[test]
fn a_glb_head_in_metres_turned_off_the_origin_lands_in_the_face_frame() {
    let dir = tempfile::tempdir().unwrap();
    let sample = template_rig(1_800, &Placement::scene(30.0, [0.25, 1.6, -0.4]));
    let path = dir.path().join("head.glb");
    sample.file.write_glb(&path).unwrap();
    let rig = Rig::open(&path, &RigOptions::default()).unwrap();
    assert_eq!(rig.conventions.units, Unit::Metre);
    assert!(!rig.conventions.units_guessed);
    assert_eq!(rig.file.vertex_count(), sample.file.vertex_count());
    // The seam's vertices are split in the file and welded for learning.
    assert_eq!(rig.weld.len(), 1_800);
    assert!(rig.file.vertex_count() > 1_800 + 20);
    assert!(rig.face.positions.len() == 1_800);
    let e = landmark_error(&rig, &sample.landmarks);
    assert!(e < 1.0, "landmark error {e} mm");
    // The face frame is the kit's: the head stands up and looks along +z there, whatever the
    // scene's node transform, and each shape's offsets come along in centimetres.
    let up = rig.landmarks.landmarks[27].face[1] - rig.landmarks.landmarks[8].face[1];
    assert!(up > 8.0, "nose bridge above the chin by {up} cm");
    let nose_ahead = rig.landmarks.landmarks[30].face[2] - rig.landmarks.landmarks[0].face[2];
    assert!(
        nose_ahead > 5.0,
        "nose ahead of the jaw line by {nose_ahead} cm"
    );
    let jaw = rig.names().iter().position(|n| n == "jawOpen").unwrap();
    let chin = rig.landmarks.landmarks[8].welded_vertex as usize;
    let drop = -rig.deltas[jaw][chin][1];
    assert!(drop > 1.0, "the chin drops {drop} cm with jawOpen");
    // Every spelling binds to ARKit; the rest is listed as missing.
    let bound = |a: &str| {
        rig.arkit
            .iter()
            .find(|(n, _)| n == a)
            .map(|(_, s)| {
                s.iter()
                    .map(|&i| rig.names()[i].clone())
                    .collect::<Vec<_>>()
            })
            .unwrap()
    };
    assert_eq!(bound("jawOpen"), ["jawOpen"]);
    assert_eq!(bound("mouthSmileLeft"), ["mouthSmile.L"]);
    assert_eq!(bound("mouthSmileRight"), ["MouthSmileRight"]);
    assert_eq!(bound("eyeBlinkLeft"), ["eyeBlink_L"]);
    assert_eq!(rig.arkit_missing().len(), 48);
    // Back in the rig's own frame, the landmarks are where the sample put them.
    for (l, t) in rig.landmarks.landmarks.iter().zip(&sample.landmarks) {
        let d: f64 = (0..3)
            .map(|k| (l.position[k] - t[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(d < 0.005, "{d} m");
    }
}

#[test]
fn an_obj_folder_in_millimetres_z_up_needs_its_axes_and_guesses_its_unit() {
    let dir = tempfile::tempdir().unwrap();
    let placement = Placement {
        units: Unit::Millimetre,
        up: Axis::PosZ,
        forward: Axis::NegY,
        seam: true,
        ..Placement::kit()
    };
    let sample = template_rig(1_400, &placement);
    let folder = dir.path().join("head");
    sample.file.write_obj_folder(&folder).unwrap();
    let wrong = Rig::open(&folder, &RigOptions::default()).unwrap_err();
    let message = wrong.to_string();
    assert!(
        message.contains("--up +z --forward -y"),
        "the error names the axes: {message}"
    );
    let rig = Rig::open(&folder, &options(Axis::PosZ, Axis::NegY)).unwrap();
    assert_eq!(rig.conventions.units, Unit::Millimetre);
    assert!(rig.conventions.units_guessed);
    let e = landmark_error(&rig, &sample.landmarks);
    assert!(e < 1.0, "landmark error {e} mm");
    // Told the unit, the rig is read in it.
    let cm = Rig::open(
        &folder,
        &RigOptions {
            units: Some(Unit::Centimetre),
            ..options(Axis::PosZ, Axis::NegY)
        },
    );
    assert!(cm.is_err() || cm.unwrap().conventions.units == Unit::Centimetre);
}

#[test]
fn rig_inspect_writes_the_report_and_the_picture() {
    let dir = tempfile::tempdir().unwrap();
    let sample = template_rig(1_600, &Placement::scene(-60.0, [0.0, 1.7, 0.3]));
    let glb = dir.path().join("head.glb");
    sample.file.write_glb(&glb).unwrap();
    let truth = dir.path().join("truth.json");
    std::fs::write(&truth, serde_json::to_vec(&sample.landmarks).unwrap()).unwrap();
    let report = dir.path().join("rig.json");
    let pictures = dir.path().join("pictures");
    let out = ok(&[
        "rig",
        "inspect",
        s(&glb),
        "--report",
        s(&report),
        "--pictures",
        s(&pictures),
        "--truth",
        s(&truth),
    ]);
    assert!(out.contains("landmark error"), "{out}");
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(r["units"], "m");
    assert_eq!(r["up"], "+y");
    assert_eq!(r["vertex_count"], sample.file.vertex_count());
    assert_eq!(r["welded_vertex_count"], 1_600);
    assert_eq!(r["shapes"].as_array().unwrap().len(), 4);
    assert_eq!(r["arkit"]["bound"]["jawOpen"][0], "jawOpen");
    assert_eq!(r["arkit"]["missing"].as_array().unwrap().len(), 48);
    let landmarks = r["landmarks"].as_array().unwrap();
    assert_eq!(landmarks.len(), 68);
    assert_eq!(landmarks[0]["position"].as_array().unwrap().len(), 3);
    assert!(landmarks[0]["vertex"].as_u64().unwrap() < sample.file.vertex_count() as u64);
    assert!(r["landmark_error_mm"]["mean"].as_f64().unwrap() < 1.0);
    // The symmetry plane's normal is the head's left-right axis in the mesh's own frame.
    let normal = r["symmetry_plane"]["normal"][0].as_f64().unwrap();
    assert!(normal.abs() > 0.98, "{}", r["symmetry_plane"]);
    assert_eq!(r["jaw_pivot"].as_array().unwrap().len(), 3);
    let png = std::fs::read(pictures.join("landmarks.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"));
}

/// A rig file's glTF JSON and binary chunk, changed by `edit`, written to `path`.
fn edited_glb(file: &RigFile, path: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let bytes = file.glb().unwrap();
    let (json, bin) = sinew_host::io::glb::read(&bytes).unwrap();
    let mut v: serde_json::Value = serde_json::from_slice(json).unwrap();
    edit(&mut v);
    let text = serde_json::to_vec(&v).unwrap();
    std::fs::write(path, sinew_host::io::glb::write(&text, bin).unwrap()).unwrap();
}

#[test]
fn bad_rigs_are_refused_naming_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sample = template_rig(900, &Placement::kit());
    let read = |p: &Path| RigFile::read(p, None).unwrap_err();

    let p = d.join("compressed.glb");
    edited_glb(&sample.file, &p, |v| {
        v["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression"]);
        v["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    });
    let e = read(&p);
    assert!(
        matches!(&e, RigReadError::Compressed { extension, .. } if extension == "KHR_draco_mesh_compression")
    );
    assert!(e.to_string().contains("compressed.glb"), "{e}");

    let p = d.join("targetless.glb");
    edited_glb(&sample.file, &p, |v| {
        v["meshes"][0]["primitives"][0]
            .as_object_mut()
            .unwrap()
            .remove("targets");
        v["meshes"][0].as_object_mut().unwrap().remove("weights");
    });
    assert!(matches!(
        read(&p),
        RigReadError::NoMorphTargets { meshes: 1, .. }
    ));

    let p = d.join("short-target.glb");
    edited_glb(&sample.file, &p, |v| {
        let a = v["meshes"][0]["primitives"][0]["targets"][1]["POSITION"]
            .as_u64()
            .unwrap();
        v["accessors"][a as usize]["count"] = serde_json::json!(10);
    });
    let e = read(&p);
    assert!(
        matches!(&e, RigReadError::Attribute { what, .. } if what.contains("morph target 1")),
        "{e}"
    );

    let bytes = sample.file.glb().unwrap();
    let p = d.join("truncated.glb");
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let e = read(&p);
    assert!(matches!(&e, RigReadError::Gltf { .. }), "{e}");
    assert!(e.to_string().contains("truncated.glb"));

    let p = d.join("named.glb");
    sample.file.write_glb(&p).unwrap();
    let e = RigFile::read(&p, Some("eyes")).unwrap_err();
    assert!(matches!(&e, RigReadError::NoSuchMesh { names, .. } if names == &["head"]));

    // An OBJ folder whose shape has another vertex count, or a NaN.
    let folder = d.join("obj");
    sample.file.write_obj_folder(&folder).unwrap();
    let shape = folder.join("shapes/jawOpen.obj");
    let text = std::fs::read_to_string(&shape).unwrap();
    let first_v = text.find("\nv ").unwrap();
    let cut: String =
        text[..first_v].to_owned() + &text[text[first_v + 1..].find('\n').unwrap() + first_v + 1..];
    std::fs::write(&shape, &cut).unwrap();
    let e = read(&folder);
    assert!(
        matches!(&e, RigReadError::VertexCount { path, .. } if path == &shape)
            || matches!(&e, RigReadError::Mesh(_)),
        "{e}"
    );
    std::fs::write(
        &shape,
        text.replacen("\nv ", "\nv NaN ", 1).replacen("NaN ", "", 0),
    )
    .unwrap();
    let nan = text.replacen("\nv ", "\nv nan 0 0 #", 1);
    std::fs::write(&shape, nan).unwrap();
    let e = read(&folder);
    assert!(e.to_string().contains("jawOpen.obj"), "{e}");

    // No shapes at all.
    let bare = d.join("bare");
    std::fs::create_dir_all(&bare).unwrap();
    std::fs::copy(folder.join("neutral.obj"), bare.join("neutral.obj")).unwrap();
    assert!(matches!(read(&bare), RigReadError::NoShapes { .. }));
}

#[test]
fn what_is_no_face_or_no_surface_is_refused_before_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sample = template_rig(900, &Placement::kit());
    // Every vertex at one point: nothing to register onto.
    let mut flat = sample.file.clone();
    for p in &mut flat.neutral.positions {
        *p = [1.0, 2.0, 3.0];
    }
    let p = d.join("point.glb");
    flat.write_glb(&p).unwrap();
    let e = Rig::open(&p, &RigOptions::default()).unwrap_err();
    assert!(matches!(e, RigError::Registration { .. }), "{e}");
    // A landmarks file whose points lie off the mesh, or that is too short.
    let p = d.join("head.glb");
    sample.file.write_glb(&p).unwrap();
    let off = d.join("off.json");
    let far: Vec<[f64; 3]> = sample
        .landmarks
        .iter()
        .map(|l| [l[0], l[1], l[2] + 0.05])
        .collect();
    std::fs::write(&off, serde_json::to_vec(&far).unwrap()).unwrap();
    let e = Rig::open(
        &p,
        &RigOptions {
            landmarks: Some(off.clone()),
            ..RigOptions::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("off the rig's surface"), "{e}");
    assert!(e.to_string().contains("off.json"), "{e}");
    // Given on the mesh, by vertex, they are taken as they are.
    let by_vertex = d.join("vertices.json");
    let vertices: Vec<u32> = (0..68).map(|k| k * 5).collect();
    std::fs::write(&by_vertex, serde_json::to_vec(&vertices).unwrap()).unwrap();
    let rig = Rig::open(
        &p,
        &RigOptions {
            landmarks: Some(by_vertex),
            ..RigOptions::default()
        },
    )
    .unwrap();
    assert_eq!(rig.landmarks.landmarks[3].vertex, 15);
    // The command line writes no report for a refused rig.
    let report = d.join("rig.json");
    let stderr = err(&[
        "rig",
        "inspect",
        s(&d.join("point.glb")),
        "--report",
        s(&report),
    ]);
    assert!(stderr.contains("point.glb"), "{stderr}");
    assert!(!report.exists());
    let stderr = err(&[
        "rig",
        "inspect",
        s(&d.join("nothing.fbx")),
        "--report",
        s(&report),
    ]);
    assert!(stderr.contains("not a rig"), "{stderr}");
}

/// ICT-FaceKit identities that are not the template's, re-meshed and placed as a scene's and a
/// studio's OBJs would be: their landmarks are found within the documented error.
#[test]
fn kit_identities_in_other_topologies_find_their_landmarks() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let kit = root.join("ict-facekit");
    let cases = [
        (
            vec![1.5, -1.0, 0.8, 1.0, -1.2],
            6_000,
            Placement::scene(30.0, [0.25, 1.6, -0.4]),
            RigOptions::default(),
        ),
        (
            vec![-2.0, 1.5, 0.0, -1.0, 2.0, 1.0],
            4_000,
            Placement {
                units: Unit::Millimetre,
                up: Axis::PosZ,
                forward: Axis::NegY,
                seam: true,
                ..Placement::kit()
            },
            options(Axis::PosZ, Axis::NegY),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (k, (identity, vertices, placement, opts)) in cases.into_iter().enumerate() {
        let sample =
            sinew_host::rig::sample::from_kit(&kit, &identity, vertices, &placement).unwrap();
        let path = if placement.units == Unit::Metre {
            let path = dir.path().join(format!("rig{k}.glb"));
            sample.file.write_glb(&path).unwrap();
            path
        } else {
            let path = dir.path().join(format!("rig{k}"));
            sample.file.write_obj_folder(&path).unwrap();
            path
        };
        let rig = Rig::open(&path, &opts).unwrap();
        assert_eq!(rig.names().len(), 53);
        assert_eq!(rig.arkit_missing(), ["tongueOut"]);
        let e = sinew_host::rig::inspect::landmark_error(&rig, &sample.landmarks);
        assert!(
            e.mean < 1.5 && e.max < 5.0,
            "rig {k}: mean {} mm, max {} mm",
            e.mean,
            e.max
        );
    }
}

/// A rig learned, measured, played from an ARKit capture and given back in its own frame:
/// `bones fit --rig`, `train aim --rig` (a short run on a few shapes), `eval aim --rig`, and
/// `play --arkit` writing the rig's own vertices (seams split), units and texture coordinates.
#[test]
fn a_rig_is_learned_and_played_back_in_its_own_frame() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sample = sinew_host::rig::sample::from_kit(
        &root.join("ict-facekit"),
        &[0.8, -1.0],
        2_500,
        &Placement::scene(-20.0, [0.1, 1.5, 0.2]),
    )
    .unwrap();
    let rig = d.join("head.glb");
    sample.file.write_glb(&rig).unwrap();
    let templates = s(&root);
    let bones = d.join("bones");
    ok(&[
        "bones",
        "fit",
        "--rig",
        s(&rig),
        "--templates",
        templates,
        "--out",
        s(&bones),
    ]);
    for f in ["skull.obj", "jaw.obj", "fit.json", "bones.png"] {
        assert!(bones.join(f).exists(), "{f}");
    }
    let model = d.join("actor.sinew");
    let report = d.join("report.json");
    let train = [
        "train",
        "aim",
        "--rig",
        s(&rig),
        "--shapes",
        "jawOpen,mouthSmile_L,eyeBlink_R,browInnerUp_L,mouthFunnel,cheekPuff_L",
        "--bones",
        s(&bones),
        "--out",
        s(&model),
        "--report",
        s(&report),
        "--iterations",
        "150",
        "--quiet",
    ];
    ok(&train);
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(r["shapes"], 7);
    // It started from the built-in prior, at the prior's learning rate, and says so.
    let meta = |key: &str| {
        let bytes = std::fs::read(&model).unwrap();
        let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
        file.metadata().get(key).map(str::to_owned)
    };
    assert_eq!(
        meta("prior").as_deref(),
        Some("prior-ict.sinew (6 of 6 shapes)")
    );
    let config: serde_json::Value = serde_json::from_str(&meta("config").unwrap()).unwrap();
    assert_eq!(
        config["lr"].as_f64(),
        Some(sinew_host::aim::prior::LEARNING_RATE)
    );
    // Resumed without repeating the rate, the run keeps the one it began with; its Adam state
    // goes onto the training device, never burn's default one (NO_DEFAULT_DEVICE).
    let ckpt = d.join("actor.ckpt");
    let resume = [&train[..], &["--resume", s(&ckpt)]].concat();
    ok_with(&resume, &[NO_DEFAULT_DEVICE]);
    let jaw = r["jaw_degrees"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p[0] == "jawOpen")
        .unwrap()[1]
        .as_f64()
        .unwrap();
    assert!(jaw > 10.0, "jawOpen turns the jaw by {jaw}°");
    let eval = d.join("eval.json");
    ok(&[
        "eval",
        "aim",
        "--model",
        s(&model),
        "--rig",
        s(&rig),
        "--bones",
        s(&bones),
        "--report",
        s(&eval),
    ]);
    let e: serde_json::Value = serde_json::from_slice(&std::fs::read(&eval).unwrap()).unwrap();
    assert_eq!(e["mean_error_mm"], r["mean_error_mm"]);
    // Baked again on another mesh, the actor no longer carries the rig record (which maps the
    // rig's vertices onto the training template's); baked on its own template it does.
    let own = sinew_host::io::mesh::Mesh::read(&ckpt.join("template.obj")).unwrap();
    let moved = sinew_host::io::mesh::Mesh::new(
        own.positions.iter().map(|p| p.map(|x| x * 1.001)).collect(),
        own.polygons.clone(),
    );
    let other = d.join("other.obj");
    moved.write(&other).unwrap();
    let has_record = |path: &std::path::Path| {
        let bytes = std::fs::read(path).unwrap();
        let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
        file.metadata().get("rig").is_some()
    };
    for (template, kept) in [(None, true), (Some(&other), false)] {
        let baked = d.join("rebaked.sinew");
        let mut args = vec!["bake", "--checkpoint", s(&ckpt), "--out", s(&baked)];
        if let Some(t) = template {
            args.extend(["--template", s(t)]);
        }
        ok(&args);
        assert_eq!(has_record(&baked), kept, "{template:?}");
    }
    // The kit actor's golden fit retargeted onto the rig's actor (another topology, 4 of its 19
    // shapes): matched through the face template, each rig shape playing the kit shape of its
    // name; the rig's face moves as the kit actor's does at the same places.
    let retargeted = d.join("retarget");
    let (source, fit) = (
        crate::common::repo("tests/data/aim-ict.sinew"),
        crate::common::repo("tests/data/fit-ict.sinew"),
    );
    ok(&[
        "retarget",
        "--source",
        &source,
        "--target",
        s(&model),
        "--fit",
        &fit,
        "--out",
        s(&retargeted),
    ]);
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(retargeted.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["correspondence"], "template");
    assert_eq!(r["shapes_at_rest"], serde_json::json!([]));
    let (source, fit) = (std::fs::read(source).unwrap(), std::fs::read(fit).unwrap());
    let target = std::fs::read(&model).unwrap();
    let (moved, _) = sinew_host::fit::bake::play(&source, &fit).unwrap();
    let perf = std::fs::read(retargeted.join("target.sinew")).unwrap();
    let (played, _) = sinew_host::fit::bake::play(&target, &perf).unwrap();
    let rest = |bytes: &[u8]| -> Vec<[f32; 3]> {
        let a = sinew_core::aim::AimActor::from_bytes(bytes).unwrap();
        let flat: Vec<f32> = a.template().iter().collect();
        flat.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()
    };
    let (from, to) = (rest(&source), rest(&target));
    let nearest: Vec<usize> = to
        .iter()
        .map(|p| {
            (0..from.len())
                .min_by(|&a, &b| {
                    let d = |q: [f32; 3]| (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f32>();
                    d(from[a]).total_cmp(&d(from[b]))
                })
                .unwrap()
        })
        .collect();
    for (f, (src, dst)) in moved.iter().zip(&played).enumerate() {
        let (mut off, mut motion) = (0.0f64, 0.0f64);
        for (v, &o) in nearest.iter().enumerate() {
            let a: [f32; 3] = std::array::from_fn(|k| src[3 * o + k] - from[o][k]);
            let b: [f32; 3] = std::array::from_fn(|k| dst[3 * v + k] - to[v][k]);
            off += f64::from((0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt());
            motion += f64::from((0..3).map(|k| a[k].powi(2)).sum::<f32>().sqrt());
        }
        assert!(
            off < 0.35 * motion,
            "frame {f}: the rig moves {off} cm away from the kit actor's {motion} cm (sums)"
        );
    }

    // Shapes the rig lacks are refused by name.
    let stderr = err(&[
        "train",
        "aim",
        "--rig",
        s(&rig),
        "--shapes",
        "smile",
        "--bones",
        s(&bones),
        "--out",
        s(&d.join("x.sinew")),
        "--report",
        s(&d.join("x.json")),
    ]);
    assert!(stderr.contains("no shape \"smile\""), "{stderr}");

    // Played from a capture, each frame is the rig's own mesh: its vertex count (seams split),
    // its texture coordinates, its unit and place in the scene's node.
    let frames = d.join("frames");
    let capture = crate::common::repo("tests/data/arkit-sample.csv");
    ok(&[
        "play",
        "--model",
        s(&model),
        "--arkit",
        &capture,
        "--out",
        s(&frames),
    ]);
    let first = sinew_host::io::mesh::Mesh::read(&frames.join("frame_00000.obj")).unwrap();
    assert_eq!(first.positions.len(), sample.file.vertex_count());
    assert_eq!(first.uvs.len(), sample.file.neutral.uvs.len());
    assert_eq!(first.polygons.len(), sample.file.neutral.polygons.len());
    // At rest the actor gives back the rig's neutral (metres, the mesh's own coordinates), as
    // closely as a short training learned it.
    let dist: Vec<f32> = first
        .positions
        .iter()
        .zip(&sample.file.neutral.positions)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt())
        .collect();
    let mean = dist.iter().sum::<f32>() / dist.len() as f32;
    let worst = dist.iter().copied().fold(0.0f32, f32::max);
    assert!(
        mean < 0.0015 && worst < 0.01,
        "rest frame {mean} m (max {worst}) from the neutral"
    );
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(frames.join("arkit.json")).unwrap()).unwrap();
    assert_eq!(summary["mapping"]["head"][0], "HeadYaw");

    // Each shape alone at weight 1, played from a capture, is the rig's own shape within that
    // shape's training error (the report's, in mm; the rig is in metres), its learned jaw
    // included: the mouth shapes turn the jaw too.
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let per_shape = r["per_shape"].as_array().unwrap();
    let names: Vec<String> = per_shape[1..]
        .iter()
        .map(|p| p[0].as_str().unwrap().to_string())
        .collect();
    let degrees = r["jaw_degrees"].as_array().unwrap();
    eprintln!("learned jaws: {degrees:?}");
    let each = d.join("each.csv");
    std::fs::write(&each, crate::common::each_shape_capture(&names)).unwrap();
    let each_frames = d.join("each");
    ok(&[
        "play",
        "--model",
        s(&model),
        "--arkit",
        s(&each),
        "--out",
        s(&each_frames),
    ]);
    for (i, name) in names.iter().enumerate() {
        let frame =
            sinew_host::io::mesh::Mesh::read(&each_frames.join(format!("frame_{:05}.obj", i + 1)))
                .unwrap();
        let k = sample
            .file
            .shape_names
            .iter()
            .position(|n| n == name)
            .unwrap();
        let want: Vec<[f32; 3]> = sample
            .file
            .neutral
            .positions
            .iter()
            .zip(&sample.file.deltas[k])
            .map(|(p, d)| std::array::from_fn(|c| p[c] + d[c]))
            .collect();
        let (mean, max) = crate::common::distances(&frame.positions, &want);
        let (mean, max) = (mean * 1e3, max * 1e3);
        let trained = &per_shape[i + 1][1];
        let (train_mean, train_max) = (
            trained["mean"].as_f64().unwrap(),
            trained["max"].as_f64().unwrap(),
        );
        eprintln!(
            "{name}: played {mean:.4} mm (max {max:.3}), trained {train_mean:.4} mm (max {train_max:.3})"
        );
        // Seam vertices count once in training and once per copy here, so the means differ
        // by their weight; the largest error is the same vertex's.
        assert!(
            mean <= 1.05 * train_mean + 1e-3 && max <= train_max + 1e-3,
            "{name}: played {mean} mm (max {max}) against its training {train_mean} (max {train_max})"
        );
    }

    // Exported, the rig comes back as a glTF of its own vertices, texture coordinates and shape
    // names, in its own frame under its node transform; Sinew reads it as a rig again.
    // The capture opens the jaw, so the export adds targets that compensate its animation; they
    // are no shapes of the rig and are not read back as such.
    let glb = d.join("actor.glb");
    let report: serde_json::Value = serde_json::from_str(&ok(&[
        "export",
        "gltf",
        "--model",
        s(&model),
        "--arkit",
        &capture,
        "--out",
        s(&glb),
    ]))
    .unwrap();
    assert!(report["jaw_compensation_targets"].as_u64().unwrap() > 0);
    let back = RigFile::read(&glb, Some("face")).unwrap();
    assert_eq!(back.vertex_count(), sample.file.vertex_count());
    assert_eq!(back.neutral.uvs, sample.file.neutral.uvs);
    assert_eq!(back.shape_names, names);
    let mean = back
        .neutral
        .positions
        .iter()
        .zip(&sample.file.neutral.positions)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt())
        .sum::<f32>()
        / back.vertex_count() as f32;
    assert!(
        mean < 0.0015,
        "the exported rest is {mean} m from the rig's neutral"
    );
    let bytes = std::fs::read(&glb).unwrap();
    let (json, _) = sinew_host::io::glb::read(&bytes).unwrap();
    let doc: serde_json::Value = serde_json::from_slice(json).unwrap();
    let root = named(&doc, "nodes", "rig");
    let matrix: Vec<f64> = root["matrix"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let want: Vec<f64> = sample
        .file
        .node_transform
        .iter()
        .flatten()
        .copied()
        .collect();
    for (m, w) in matrix.iter().zip(&want) {
        assert!(
            (m - w).abs() < 1e-6,
            "node transform {matrix:?} against {want:?}"
        );
    }
}
