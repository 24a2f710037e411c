//! The `sinew` binary as a user runs it: the demo end to end (short), then bake, play, edit and
//! inspect on its outputs, and clear errors on bad input.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::{err, ok, repo, s, sinew};

#[test]
fn demo_then_every_command_on_its_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let report = ok(&["demo", "--out", s(&out), "--iterations", "20", "--quiet"]);
    let report: serde_json::Value = serde_json::from_str(&report).unwrap();
    for key in [
        "shapes",
        "vertices",
        "iterations",
        "seconds",
        "mean_error_mm",
        "median_error_mm",
        "p95_error_mm",
        "max_error_mm",
        "constrained_fraction",
        "negative_thickness_count",
    ] {
        assert!(report.get(key).is_some(), "report lacks {key}");
    }
    assert_eq!(report["shapes"], 20);
    assert_eq!(report["iterations"], 20);
    for f in [
        "actor.sinew",
        "report.json",
        "actor.config.json",
        "loss.png",
        "error.png",
        "anatomy.png",
        "playback.png",
        "skin.obj",
        "anatomy.obj",
        "poses.json",
    ] {
        assert!(out.join(f).is_file(), "demo did not write {f}");
    }
    assert_eq!(std::fs::read_dir(out.join("play")).unwrap().count(), 24);

    let model = out.join("actor.sinew");
    let inspect: serde_json::Value =
        serde_json::from_str(&ok(&["inspect", s(&model), "--json"])).unwrap();
    assert_eq!(inspect["kind"], "aim-actor");
    assert_eq!(inspect["checksums"], "ok");

    // Re-bake playback-only from the checkpoint: the core loads it without networks.
    let small = dir.path().join("small.sinew");
    ok(&[
        "bake",
        "--checkpoint",
        s(&out.join("actor.ckpt")),
        "--out",
        s(&small),
        "--playback-only",
        "--q16",
    ]);
    let bytes = std::fs::read(&small).unwrap();
    let actor = sinew_core::aim::AimActor::from_bytes(&bytes).unwrap();
    assert!(actor.networks().is_none());
    assert!(actor.q16().is_some(), "--q16 adds the fixed-point cache");
    let full = std::fs::read(&model).unwrap();
    let full = sinew_core::aim::AimActor::from_bytes(&full).unwrap();
    assert_eq!(
        actor.rest(),
        full.rest(),
        "re-baked cache differs from the trained bake"
    );

    // Play: one OBJ per frame; a bad pose file is named in the error.
    let frames = dir.path().join("frames");
    ok(&[
        "play",
        "--model",
        s(&model),
        "--poses",
        s(&out.join("poses.json")),
        "--out",
        s(&frames),
    ]);
    assert_eq!(std::fs::read_dir(&frames).unwrap().count(), 24);
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"frames": [{"weights": [1.0]}]}"#).unwrap();
    let e = err(&[
        "play",
        "--model",
        s(&model),
        "--poses",
        s(&bad),
        "--out",
        s(&frames),
    ]);
    assert!(e.contains("bad.json") && e.contains("weights"), "{e}");

    // Replays: record in every mode, verify; the wrong model and a tampered replay fail.
    for mode in ["f32", "q16", "fast"] {
        let replay = dir.path().join(format!("replay.{mode}.sinew"));
        let poses = out.join("poses.json");
        let args = [
            "replay",
            "record",
            "--model",
            s(&small),
            "--poses",
            s(&poses),
            "--out",
            s(&replay),
            "--mode",
            mode,
        ];
        assert!(ok(&args).contains("24 frames"));
        let v = ok(&[
            "replay",
            "verify",
            "--model",
            s(&small),
            "--replay",
            s(&replay),
        ]);
        assert!(
            v.contains("24 frames") && v.contains("bit-identical"),
            "{v}"
        );
        let e = err(&[
            "replay",
            "verify",
            "--model",
            s(&model),
            "--replay",
            s(&replay),
        ]);
        assert!(e.contains("recorded with model"), "{e}");
    }
    let e = err(&[
        "replay",
        "record",
        "--model",
        s(&model),
        "--poses",
        s(&out.join("poses.json")),
        "--out",
        s(&dir.path().join("x.sinew")),
        "--mode",
        "q16",
    ]);
    assert!(e.contains("Q16.16 cache"), "{e}");
    let e = err(&[
        "replay",
        "verify",
        "--model",
        s(&small),
        "--replay",
        s(&small),
    ]);
    assert!(e.contains("small.sinew") && e.contains("replay"), "{e}");

    // Edit: thicker tissue on the first vertices moves exactly those.
    let region = dir.path().join("region.json");
    std::fs::write(&region, "[0, 1, 2, 3, 4]").unwrap();
    let edited = dir.path().join("edited");
    ok(&[
        "edit",
        "thickness",
        "--model",
        s(&model),
        "--mask",
        s(&region),
        "--scale",
        "2",
        "--out",
        s(&edited),
    ]);
    assert!(edited.join("edit.png").is_file() && edited.join("edited_neutral.obj").is_file());
    std::fs::write(&region, "[999999]").unwrap();
    let e = err(&[
        "edit",
        "thickness",
        "--model",
        s(&model),
        "--mask",
        s(&region),
        "--scale",
        "2",
        "--out",
        s(&edited),
    ]);
    assert!(
        e.contains("region.json") && e.contains("out of range"),
        "{e}"
    );
}

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
fn bad_files_are_named_and_fail() {
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk.sinew");
    std::fs::write(
        &junk,
        b"this is not a model at all, only some plain text, longer than a header",
    )
    .unwrap();
    let e = err(&["inspect", s(&junk)]);
    assert!(e.contains("junk.sinew") && e.contains("magic"), "{e}");
    let e = err(&["inspect", s(&dir.path().join("missing.sinew"))]);
    assert!(e.contains("missing.sinew"), "{e}");
    assert!(ok(&["--version"]).contains(env!("CARGO_PKG_VERSION")));
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

/// `sinew` with `env` set (and `SINEW_SEED`, `SINEW_DATA`, `SINEW_CACHE` removed unless `env`
/// sets them).
fn sinew_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sinew"));
    cmd.args(args)
        .env_remove("SINEW_SEED")
        .env_remove("SINEW_DATA")
        .env_remove("SINEW_CACHE");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run sinew")
}

/// The seed a command says it uses (`seed N (override with --seed or SINEW_SEED)` on stderr).
fn said_seed(out: &Output) -> u64 {
    let stderr = String::from_utf8_lossy(&out.stderr);
    let line = stderr
        .lines()
        .find(|l| l.starts_with("seed "))
        .unwrap_or_else(|| panic!("no seed line in:\n{stderr}"));
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// The hierarchy cache of `train s2d` follows the same rule: `--cache` beats `SINEW_CACHE`,
/// which beats the temporary folder. The command says its cache before reading the pairs, so a
/// missing pairs folder is enough.
#[test]
fn the_cache_flag_beats_sinew_cache_which_beats_the_default() {
    let dir = tempfile::tempdir().unwrap();
    let (missing, out) = (dir.path().join("missing"), dir.path().join("m.sinew"));
    let report = dir.path().join("r.json");
    let args = [
        "train",
        "s2d",
        "--pairs",
        s(&missing),
        "--protocol",
        "expression",
        "--out",
        s(&out),
        "--report",
        s(&report),
    ];
    let said_cache = |out: &Output| -> String {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let line = stderr
            .lines()
            .find_map(|l| l.strip_prefix("hierarchy cache "))
            .unwrap_or_else(|| panic!("no cache line in:\n{stderr}"))
            .to_owned();
        line.strip_suffix(" (override with --cache or SINEW_CACHE)")
            .unwrap_or_else(|| panic!("{line}"))
            .to_owned()
    };
    let plain = sinew_env(&args, &[]);
    assert!(!plain.status.success(), "a missing pairs folder must fail");
    assert_eq!(
        said_cache(&plain),
        std::env::temp_dir()
            .join("sinew-cache")
            .display()
            .to_string()
    );
    let (env_dir, flag_dir) = (dir.path().join("from-env"), dir.path().join("from-flag"));
    let env = sinew_env(&args, &[("SINEW_CACHE", s(&env_dir))]);
    assert_eq!(
        said_cache(&env),
        s(&env_dir),
        "SINEW_CACHE beats the default"
    );
    let flag = [args.as_slice(), &["--cache", s(&flag_dir)]].concat();
    let both = sinew_env(&flag, &[("SINEW_CACHE", s(&env_dir))]);
    assert_eq!(said_cache(&both), s(&flag_dir), "--cache beats SINEW_CACHE");
    let help = ok(&["train", "s2d", "--help"]);
    assert!(
        help.contains("SINEW_CACHE"),
        "--help names SINEW_CACHE:\n{help}"
    );
}

/// One rule for every command family: a flag beats its environment variable, which beats the
/// default. Each command stops right after saying its seed (its data folder does not exist).
#[test]
fn flags_beat_the_environment_which_beats_the_default() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing");
    let out = dir.path().join("out");
    let report = dir.path().join("r.json");
    let commands: [(Vec<&str>, u64); 3] = [
        (
            vec![
                "train",
                "aim",
                "--data",
                s(&missing),
                "--out",
                s(&out),
                "--report",
                s(&report),
            ],
            sinew_host::aim::AimConfig::default().seed,
        ),
        (
            vec![
                "train",
                "s2d",
                "--pairs",
                s(&missing),
                "--protocol",
                "expression",
                "--out",
                s(&out),
                "--report",
                s(&report),
            ],
            sinew_host::s2d::train::TrainConfig::default().seed,
        ),
        (
            vec!["data", "s2d-pairs", "--data", s(&missing), "--out", s(&out)],
            sinew_host::s2d::data::PairsConfig::default().seed,
        ),
    ];
    for (args, default) in commands {
        let plain = sinew_env(&args, &[]);
        assert!(
            !plain.status.success(),
            "{args:?} on a missing folder must fail"
        );
        assert_eq!(said_seed(&plain), default, "{args:?}: the default seed");
        let env = sinew_env(&args, &[("SINEW_SEED", "4242")]);
        assert_eq!(
            said_seed(&env),
            4242,
            "{args:?}: SINEW_SEED beats the default"
        );
        let flag = [args.as_slice(), &["--seed", "7"]].concat();
        let both = sinew_env(&flag, &[("SINEW_SEED", "4242")]);
        assert_eq!(said_seed(&both), 7, "{args:?}: --seed beats SINEW_SEED");
        let help = ok(&[args[0], args[1], "--help"]);
        assert!(
            help.contains("SINEW_SEED"),
            "{args:?} --help names SINEW_SEED:\n{help}"
        );
    }
    // SINEW_DATA is where the template bones are, unless --templates says otherwise.
    let bones = |extra: &[&str], env: &[(&str, &str)]| {
        let args = [
            &["bones", "fit", "--data", s(&missing), "--out", s(&out)],
            extra,
        ]
        .concat();
        String::from_utf8_lossy(&sinew_env(&args, env).stderr).into_owned()
    };
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    assert!(
        bones(&[], &[]).contains("../shared/data"),
        "default templates folder"
    );
    assert!(bones(&[], &[("SINEW_DATA", s(&a))]).contains(s(&a)));
    assert!(bones(&["--templates", s(&b)], &[("SINEW_DATA", s(&a))]).contains(s(&b)));
    assert!(ok(&["bones", "fit", "--help"]).contains("SINEW_DATA"));
}

#[test]
fn view_prints_its_address_first_serves_and_stops_after_its_deadline() {
    use std::io::{BufRead, BufReader, Read, Write};
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data");
    let model = data.join("aim-procedural.sinew");
    let replay = data.join("aim-procedural.f32.replay.sinew");
    let start = std::time::Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_sinew"))
        .args(["view", s(&model), "--replay", s(&replay), "--port", "0"])
        .args(["--exit-after-seconds", "2"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let url = lines.next().unwrap().unwrap();
    let port: u16 = url
        .strip_prefix("http://127.0.0.1:")
        .and_then(|rest| rest.strip_suffix('/'))
        .unwrap_or_else(|| panic!("first line {url:?} is not the address"))
        .parse()
        .unwrap();
    let mut stream = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    write!(
        stream,
        "GET /config.json HTTP/1.0\r\nHost: 127.0.0.1:{port}\r\n\r\n"
    )
    .unwrap();
    let mut answer = String::new();
    stream.read_to_string(&mut answer).unwrap();
    assert!(answer.starts_with("HTTP/1.0 200"), "{answer}");
    assert!(
        answer.contains("\"aim-procedural.f32.replay.sinew\""),
        "{answer}"
    );
    let status = child.wait().unwrap();
    assert!(status.success(), "{status}");
    let took = start.elapsed();
    assert!(took.as_secs_f64() >= 2.0 && took.as_secs() < 30, "{took:?}");
}

#[test]
fn view_names_a_bad_model_and_fails() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.sinew");
    std::fs::write(&bad, b"not a model").unwrap();
    let e = err(&["view", s(&bad), "--port", "0"]);
    assert!(e.contains("bad.sinew"), "{e}");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data");
    // An S2D decoder plays a landmark track, not an AIM replay.
    let s2d = data.join("s2d-ict.sinew");
    let replay = data.join("aim-ict.f32.replay.sinew");
    let e = err(&["view", s(&s2d), "--replay", s(&replay), "--port", "0"]);
    assert!(
        e.contains("aim-ict.f32.replay.sinew") && e.contains("is for an AIM actor"),
        "{e}"
    );
    // A performance fitted to the ICT actor, given with the procedural one.
    let model = data.join("aim-procedural.sinew");
    let fit = data.join("fit-ict.sinew");
    let e = err(&["view", s(&model), "--performance", s(&fit), "--port", "0"]);
    assert!(
        e.contains("fit-ict.sinew") && e.contains("was fitted to another actor"),
        "{e}"
    );
}

#[test]
fn play_arkit_and_export_gltf_on_the_golden_actor() {
    let dir = tempfile::tempdir().unwrap();
    let model = repo("tests/data/aim-ict.sinew");
    let capture = repo("tests/data/arkit-sample.csv");
    let frames = dir.path().join("frames");
    let out = sinew(&[
        "play",
        "--model",
        &model,
        "--arkit",
        &capture,
        "--out",
        s(&frames),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("cannot play these capture channels") && stderr.contains("MouthClose"));
    assert!(frames.join("frame_00029.obj").exists() && !frames.join("frame_00030.obj").exists());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(frames.join("arkit.json")).unwrap()).unwrap();
    assert_eq!(summary["frames"], 30);
    let unplayable = summary["mapping"]["unplayable"].as_array().unwrap();
    assert!(unplayable.iter().any(|c| c == "HeadYaw"));
    assert_eq!(unplayable.len(), 42);

    let glb = dir.path().join("face.glb");
    let report = ok(&[
        "export",
        "gltf",
        "--model",
        &model,
        "--arkit",
        &capture,
        "--bones",
        "--out",
        s(&glb),
    ]);
    let report: serde_json::Value = serde_json::from_str(&report).unwrap();
    assert_eq!(report["frames"], 30);
    assert_eq!(report["morph_targets"], 19);
    let bytes = std::fs::read(&glb).unwrap();
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(report["bytes"], bytes.len());
    let posed = dir.path().join("posed.glb");
    ok(&[
        "export",
        "gltf",
        "--model",
        &model,
        "--poses",
        &repo("host/tests/gltf/poses.json"),
        "--fps",
        "24",
        "--out",
        s(&posed),
    ]);

    // Bad input: the file and line named, nothing written.
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "Timecode,BlendshapeCount,JawOpen\n00:00:00:00.000,1,0.5\nx,1,half\n",
    )
    .unwrap();
    let e = err(&[
        "play",
        "--model",
        &model,
        "--arkit",
        s(&bad),
        "--out",
        s(&dir.path().join("no")),
    ]);
    assert!(
        e.contains("bad.csv:3: JawOpen: `half` is not a finite number"),
        "{e}"
    );
    let none = dir.path().join("none.glb");
    let e = err(&[
        "export",
        "gltf",
        "--model",
        &model,
        "--arkit",
        s(&bad),
        "--out",
        s(&none),
    ]);
    assert!(e.contains("bad.csv:3"), "{e}");
    assert!(!none.exists());
    let e = err(&["export", "gltf", "--model", &capture, "--out", s(&none)]);
    assert!(e.contains("arkit-sample.csv"), "{e}");
    let e = err(&["play", "--model", &model, "--out", s(&frames)]);
    assert!(e.contains("--poses") || e.contains("--arkit"), "{e}");
}

#[test]
fn play_performance_plays_the_golden_fit_and_refuses_another_actor() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frames");
    let perf = repo("tests/data/fit-ict.sinew");
    let said = ok(&[
        "play",
        "--model",
        &repo("tests/data/aim-ict.sinew"),
        "--performance",
        &perf,
        "--out",
        s(&out),
    ]);
    assert!(said.contains("4 frames"), "{said}");
    let mesh = std::fs::read_to_string(out.join("frame_00003.obj")).unwrap();
    assert_eq!(mesh.lines().filter(|l| l.starts_with("v ")).count(), 4705);
    assert!(!out.join("frame_00004.obj").exists());

    let e = err(&[
        "play",
        "--model",
        &repo("tests/data/aim-procedural.sinew"),
        "--performance",
        &perf,
        "--out",
        s(&dir.path().join("other")),
    ]);
    assert!(e.contains("fit-ict.sinew") && e.contains("model"), "{e}");
    let e = err(&[
        "play",
        "--model",
        &repo("tests/data/aim-ict.sinew"),
        "--performance",
        &repo("tests/data/aim-ict.f32.replay.sinew"),
        "--out",
        s(&dir.path().join("other")),
    ]);
    assert!(
        e.contains("aim-ict.f32.replay.sinew") && e.contains("kind"),
        "{e}"
    );
}

#[test]
fn fit_bakes_a_performance_that_play_reproduces() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let perf = dir.path().join("perf");
    let model = repo("tests/data/aim-ict.sinew");
    ok(&[
        "data",
        "performance",
        "--data",
        s(&root.join("ict-facekit")),
        "--actor",
        &model,
        "--frames",
        "2",
        "--out",
        s(&perf),
    ]);
    let fit = dir.path().join("fit.sinew");
    let report = dir.path().join("report.json");
    ok(&[
        "fit",
        "--model",
        &model,
        "--target",
        s(&perf),
        "--out",
        s(&fit),
        "--report",
        s(&report),
        "--iterations",
        "20",
        "--hidden",
        "16",
        "--code",
        "4",
    ]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["frames"], 2);
    let played = dir.path().join("played");
    ok(&[
        "play",
        "--model",
        &model,
        "--performance",
        s(&fit),
        "--out",
        s(&played),
    ]);
    for f in 0..2 {
        let name = format!("frame_{f:05}.obj");
        assert_eq!(
            std::fs::read(played.join(&name)).unwrap(),
            std::fs::read(dir.path().join("fit.meshes").join(&name)).unwrap(),
            "{name}: the fit's meshes are the core's playback"
        );
    }
    // A global fit animates a glTF rig.
    let global = dir.path().join("global.sinew");
    ok(&[
        "fit",
        "--model",
        &model,
        "--target",
        s(&perf),
        "--out",
        s(&global),
        "--report",
        s(&report),
        "--iterations",
        "20",
        "--hidden",
        "16",
        "--global",
    ]);
    let glb = dir.path().join("fit.glb");
    let summary = ok(&[
        "export",
        "gltf",
        "--model",
        &model,
        "--performance",
        s(&global),
        "--out",
        s(&glb),
    ]);
    let summary: serde_json::Value = serde_json::from_str(&summary).unwrap();
    assert_eq!(summary["frames"], 2);
    assert_eq!(&std::fs::read(&glb).unwrap()[..4], b"glTF");
}
