//! The S2D commands as a user runs them: `train s2d --help`, `s2d hierarchy`, and a pair set
//! generated, trained on, evaluated and applied end to end, with clear errors on bad input.

use std::path::Path;

use crate::common::{err, ok, s};

/// `train s2d --help` gives the default budget that runs without `--epochs`/`--folds`, from the
/// constants the command uses, so the two cannot drift apart.
#[test]
fn train_s2d_help_names_its_defaults() {
    let help = ok(&["train", "s2d", "--help"]);
    let epochs = format!(
        "[default: {}; {} with --paper-protocol]",
        sinew_host::s2d::experiment::DEFAULT_EPOCHS,
        sinew_host::s2d::train::TrainConfig::default().epochs
    );
    let folds = format!(
        "[default: 1; {} with --paper-protocol]",
        sinew_host::s2d::protocol::FOLDS
    );
    assert!(help.contains(&epochs), "no {epochs} in:\n{help}");
    assert!(help.contains(&folds), "no {folds} in:\n{help}");
}

#[test]
fn s2d_hierarchy_writes_a_file_and_names_bad_templates() {
    let dir = tempfile::tempdir().unwrap();
    // A 6 × 6 grid of quads, slightly bumped.
    let mut obj = String::new();
    for y in 0..7 {
        for x in 0..7 {
            obj += &format!(
                "v {x} {y} {}\n",
                f32::from(((x * 7 + y * 3) % 5) as u8) * 0.01
            );
        }
    }
    for y in 0..6 {
        for x in 0..6 {
            let id = |x: u32, y: u32| y * 7 + x + 1;
            obj += &format!(
                "f {} {} {} {}\n",
                id(x, y),
                id(x + 1, y),
                id(x + 1, y + 1),
                id(x, y + 1)
            );
        }
    }
    let template = dir.path().join("grid.obj");
    std::fs::write(&template, obj).unwrap();
    let out = dir.path().join("h.sinew");
    let said = ok(&[
        "s2d",
        "hierarchy",
        "--template",
        s(&template),
        "--out",
        s(&out),
        "--factors",
        "4,4",
    ]);
    assert!(said.contains("[49, 13, 4]"), "{said}");
    let pinned = dir.path().join("pinned.sinew");
    let said = ok(&[
        "s2d",
        "hierarchy",
        "--template",
        s(&template),
        "--out",
        s(&pinned),
        "--factors",
        "4,4",
        "--spiral-lengths",
        "9,8,3",
    ]);
    assert!(said.contains("spiral lengths [9, 8, 3]"), "{said}");
    let bytes = std::fs::read(&out).unwrap();
    let h = sinew_host::s2d::hierarchy::from_bytes(&bytes).unwrap();
    assert_eq!(h.levels.len(), 3);
    let inspect: serde_json::Value =
        serde_json::from_str(&ok(&["inspect", s(&out), "--json"])).unwrap();
    assert_eq!(inspect["checksums"], "ok");

    // Three triangles on one edge: the error names the file and the edge.
    let bad = dir.path().join("fin.obj");
    std::fs::write(
        &bad,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
    )
    .unwrap();
    let e = err(&["s2d", "hierarchy", "--template", s(&bad), "--out", s(&out)]);
    assert!(
        e.contains("fin.obj") && e.contains("non-manifold edge"),
        "{e}"
    );
    // The earlier output is untouched.
    assert_eq!(std::fs::read(&out).unwrap(), bytes);
}

#[test]
fn s2d_pairs_train_and_eval_end_to_end() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let kit = root.join("ict-facekit");
    let dir = tempfile::tempdir().unwrap();
    let pairs = dir.path().join("pairs");
    let said = ok(&[
        "data",
        "s2d-pairs",
        "--data",
        s(&kit),
        "--out",
        s(&pairs),
        "--seed",
        "5",
        "--identities",
        "4",
        "--pairs",
        "24",
    ]);
    assert!(said.contains("24 pairs of 4 identities"), "{said}");
    let model = dir.path().join("m.sinew");
    let report = dir.path().join("r.json");
    // `train s2d` of one epoch on the identity split, `folds` folds; what it printed.
    let train = |out: &Path, report: &Path, folds: &str| {
        ok(&[
            "train",
            "s2d",
            "--pairs",
            s(&pairs),
            "--protocol",
            "identity",
            "--out",
            s(out),
            "--report",
            s(report),
            "--epochs",
            "1",
            "--folds",
            folds,
            "--quiet",
        ])
    };
    let said = train(&model, &report, "1");
    assert!(said.contains("identity split, 1 fold(s)"), "{said}");
    // Identity fold 0 trains on 18 pairs: a dictionary of one atom per sample at most.
    assert!(said.contains("DL-3DMM (18 atoms)"), "{said}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["protocol"], "identity");
    assert_eq!(r["folds"], 1);
    // Identity fold 0 holds out identity 0 of 4: its 6 pairs.
    assert_eq!(r["test_pairs"], 6);
    for v in [
        &r["mean_error_mm"],
        &r["std_error_mm"],
        &r["baselines"]["pca99"]["mean_error_mm"],
        &r["baselines"]["pca_max"]["std_error_mm"],
        &r["baselines"]["dl_3dmm"]["mean_error_mm"],
        &r["baselines"]["span_floor"]["mean_error_mm"],
    ] {
        assert!(v.as_f64().unwrap() >= 0.0, "{r}");
    }
    assert!(r["mean_error_mm"].as_f64().unwrap() > 0.0);
    // One held-out identity: every test pair involves it, so its breakdown is the fold's.
    let fold = &r["per_fold"][0];
    let held = fold["per_held_out"].as_array().unwrap();
    assert_eq!(held.len(), 1, "{fold}");
    assert_eq!(held[0]["held_out"], fold["held_out"][0]);
    assert_eq!(held[0]["pairs"], fold["test_pairs"]);
    let (a, b) = (
        held[0]["s2d_mm"].as_f64().unwrap(),
        fold["s2d"]["mean_error_mm"].as_f64().unwrap(),
    );
    assert!((a - b).abs() <= 1e-9 * b, "{a} against {b}");
    let png = std::fs::read(dir.path().join("r.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");

    // eval reads the protocol and fold from the model and reproduces the S2D error.
    let report2 = dir.path().join("e.json");
    ok(&[
        "eval",
        "s2d",
        "--model",
        s(&model),
        "--pairs",
        s(&pairs),
        "--report",
        s(&report2),
    ]);
    let e: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report2).unwrap()).unwrap();
    assert_eq!(e["mean_error_mm"], r["mean_error_mm"]);
    assert_eq!(e["baselines"], r["baselines"]);

    // Two folds trained together, then evaluated together: the same pooled report.
    let two = dir.path().join("two.sinew");
    let report_two = dir.path().join("two.json");
    train(&two, &report_two, "2");
    let r2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_two).unwrap()).unwrap();
    let eval_two = dir.path().join("e2.json");
    // `eval s2d --folds F --model M`, succeeding or failing as `succeeds` says; what it printed.
    let eval = |folds: &str, model: &Path, succeeds: bool| {
        let args = [
            "eval",
            "s2d",
            "--model",
            s(model),
            "--pairs",
            s(&pairs),
            "--report",
            s(&eval_two),
            "--folds",
            folds,
        ];
        if succeeds { ok(&args) } else { err(&args) }
    };
    let said = eval("2", &two, true);
    assert!(
        said.contains("identity split, 2 fold(s), 12 test pairs"),
        "{said}"
    );
    let e2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&eval_two).unwrap()).unwrap();
    for key in [
        "folds",
        "test_pairs",
        "mean_error_mm",
        "std_error_mm",
        "baselines",
    ] {
        assert_eq!(e2[key], r2[key], "{key}");
    }
    // A third fold was never trained; fold 0's model is not a fold-1 model.
    let said = eval("3", &two, false);
    assert!(said.contains("two.fold2.sinew"), "{said}");
    std::fs::copy(&model, dir.path().join("m.fold1.sinew")).unwrap();
    let said = eval("2", &model, false);
    assert!(said.contains("m.fold1.sinew: a model of fold 0"), "{said}");

    // `--mirror` on the expression split: fold 0 also trains on the mirror image of each
    // training pair whose shapes' mirrored twins (`x_L` ↔ `x_R`, `mouthLeft` ↔ `mouthRight`, a
    // symmetric shape itself) are all training shapes, and so do its baselines.
    let expression = |out: &Path, report: &Path, extra: &[&str]| {
        let mut args = vec![
            "train",
            "s2d",
            "--pairs",
            s(&pairs),
            "--protocol",
            "expression",
            "--out",
            s(out),
            "--report",
            s(report),
            "--epochs",
            "1",
            "--quiet",
        ];
        args.extend_from_slice(extra);
        ok(&args);
        serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(report).unwrap())
            .unwrap()
    };
    let mirrored = dir.path().join("mir.sinew");
    let r = expression(&mirrored, &dir.path().join("mir.json"), &["--mirror"]);
    let fold = &r["per_fold"][0];
    let held: Vec<&str> = fold["held_out"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h.as_str().unwrap())
        .collect();
    let twin = |name: &str| {
        if let Some(stem) = name.strip_suffix("_L") {
            format!("{stem}_R")
        } else if let Some(stem) = name.strip_suffix("_R") {
            format!("{stem}_L")
        } else if name.contains("Left") {
            name.replace("Left", "Right")
        } else {
            name.replace("Right", "Left")
        }
    };
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(pairs.join("manifest.json")).unwrap())
            .unwrap();
    let shapes_of = |p: &serde_json::Value| -> Vec<String> {
        p["shapes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["shape"].as_str().unwrap().to_owned())
            .collect()
    };
    let training: Vec<Vec<String>> = manifest["pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(shapes_of)
        .filter(|shapes| !shapes.iter().any(|x| held.contains(&x.as_str())))
        .collect();
    let expected = training
        .iter()
        .filter(|shapes| shapes.iter().all(|x| !held.contains(&twin(x).as_str())))
        .count();
    assert!(0 < expected && expected < training.len(), "{expected}");
    assert_eq!(fold["train_pairs"], training.len(), "{fold}");
    assert_eq!(fold["mirrored_pairs"], expected, "{fold}");
    // `eval s2d` sees the mirror in the model's metadata and rebuilds the same baselines.
    eval("1", &mirrored, true);
    let e: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&eval_two).unwrap()).unwrap();
    assert_eq!(e["mean_error_mm"], r["mean_error_mm"]);
    assert_eq!(e["baselines"], r["baselines"]);
    assert_eq!(e["per_fold"][0]["mirrored_pairs"], expected);
    // Without --mirror the baselines learn from the unmirrored pairs alone, and the report
    // names no mirrored pairs.
    let plain = expression(
        &dir.path().join("plain.sinew"),
        &dir.path().join("plain.json"),
        &[],
    );
    assert!(plain["per_fold"][0].get("mirrored_pairs").is_none());
    assert_ne!(
        plain["baselines"]["pca_max"]["mean_error_mm"],
        r["baselines"]["pca_max"]["mean_error_mm"]
    );
    // A linear decoder on neutral-scaled input: the artefact names both, and `eval s2d` feeds
    // it the input it was trained on (the same errors as training reported).
    let linear = dir.path().join("linear.sinew");
    let lr = expression(
        &linear,
        &dir.path().join("linear.json"),
        &["--activation", "identity", "--input", "neutral-scale"],
    );
    let bytes = std::fs::read(&linear).unwrap();
    let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
    let code = |name: &str| file.section(name).unwrap().u32s().unwrap().iter().next();
    assert_eq!(
        code("s2d.act"),
        Some(sinew_core::nn::Activation::Identity.code())
    );
    assert_eq!(
        code("s2d.input"),
        Some(sinew_core::s2d::INPUT_NEUTRAL_SCALE)
    );
    eval("1", &linear, true);
    let e: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&eval_two).unwrap()).unwrap();
    assert_eq!(e["mean_error_mm"], lr["mean_error_mm"]);
    assert_ne!(lr["mean_error_mm"], plain["mean_error_mm"]);

    // Applications on real faces of the decoder's template (the ICT face region).
    let ict = sinew_host::io::ict::IctFaceKit::open(&kit).unwrap();
    let (face, _) = ict
        .neutral()
        .submesh(|v| sinew_host::io::ict::FACE_REGION.contains(&v));
    let delta = ict.expression_delta("jawOpen").unwrap();
    let open: Vec<[f32; 3]> = face
        .positions
        .iter()
        .zip(&delta)
        .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
        .collect();
    let neutral_obj = dir.path().join("neutral.obj");
    let open_obj = dir.path().join("frames").join("open.obj");
    face.write(&neutral_obj).unwrap();
    std::fs::create_dir_all(open_obj.parent().unwrap()).unwrap();
    face.with_positions(open.clone()).write(&open_obj).unwrap();
    let out = dir.path().join("neutralised.obj");
    ok(&[
        "s2d",
        "neutralize",
        "--model",
        s(&model),
        "--input",
        s(&open_obj),
        "--out",
        s(&out),
    ]);
    let got = sinew_host::io::mesh::Mesh::read(&out).unwrap();
    assert_eq!(got.positions.len(), face.positions.len());
    assert_ne!(got.positions, open, "neutralising moves the face");
    let frames = dir.path().join("transferred");
    let said = ok(&[
        "s2d",
        "transfer",
        "--model",
        s(&model),
        "--source-neutral",
        s(&neutral_obj),
        "--source",
        s(open_obj.parent().unwrap()),
        "--target",
        s(&neutral_obj),
        "--out",
        s(&frames),
    ]);
    assert!(said.contains("1 frames"), "{said}");
    assert!(frames.join("frame_00000.obj").is_file());
    let e = err(&[
        "s2d",
        "neutralize",
        "--model",
        s(&model),
        "--input",
        s(&pairs.join("manifest.json")),
        "--out",
        s(&out),
    ]);
    assert!(e.contains("manifest.json"), "{e}");

    // Bad input names the file.
    let e = err(&[
        "eval",
        "s2d",
        "--model",
        s(&pairs.join("pairs.sinew")),
        "--pairs",
        s(&pairs),
        "--report",
        s(&report2),
    ]);
    assert!(e.contains("pairs.sinew") && e.contains("protocol"), "{e}");
    let e = err(&[
        "train",
        "s2d",
        "--pairs",
        s(&dir.path().join("nowhere")),
        "--protocol",
        "expression",
        "--out",
        s(&model),
        "--report",
        s(&report),
    ]);
    assert!(e.contains("nowhere") && e.contains("manifest.json"), "{e}");
}
