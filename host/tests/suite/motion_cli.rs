//! `sinew data motions`, `train motion`, `generate`, `interpolate` and `eval motion` as a user
//! runs them: a small motion set from the real ICT-FaceKit, read back by the library with its
//! seeded split, a few training steps with a checkpoint resumed, meshes generated through the
//! golden S2D decoder, Table 3's evaluation of the briefly trained generator, and clear errors on
//! bad input.

use crate::common::{NO_DEFAULT_DEVICE, err, ok as ok_run, sinew, sinew_with};

use sinew_host::motion::data::{MotionSet, Split};

#[test]
fn data_motions_writes_a_seeded_split_set() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let kit = root.join("ict-facekit");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("motions");
    let args = [
        "data",
        "motions",
        "--data",
        kit.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--seed",
        "3",
        "--identities",
        "1",
        "--per-class",
        "2",
    ];
    let run = sinew(&args);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("seed 3"), "the seed is printed: {stderr}");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        stdout.contains("24 synthetic sequences (12 train, 12 test)"),
        "{stdout}"
    );
    let set = MotionSet::read(&out).unwrap();
    assert_eq!(set.manifest.config.seed, 3);
    let test = set.split(Split::Test);
    assert_eq!(test.len(), 12);
    // One test sequence per label, each the first of its label.
    for (k, &s) in test.iter().enumerate() {
        assert_eq!(set.label(s), k);
        assert_eq!(set.manifest.sequences[s].repetition, 0);
    }
    // Same seed, same bytes.
    let again = dir.path().join("again");
    let mut args2 = args;
    args2[5] = again.to_str().unwrap();
    assert!(sinew(&args2).status.success());
    for file in ["motions.sinew", "manifest.json"] {
        assert_eq!(
            std::fs::read(out.join(file)).unwrap(),
            std::fs::read(again.join(file)).unwrap(),
            "{file}"
        );
    }

    // How hard the set is: the ground truth's accuracy alone, per label and confused.
    let gt = dir.path().join("gt.json");
    let stdout = ok_run(&[
        "eval",
        "motion",
        "--motions",
        out.to_str().unwrap(),
        "--report",
        gt.to_str().unwrap(),
        "--epochs",
        "2",
        "--quiet",
    ]);
    assert!(
        stdout.contains("ground truth (Gen-LM)") && stdout.contains("mouth_side"),
        "{stdout}"
    );
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&gt).unwrap()).unwrap();
    let confusion = json["confusion"].as_array().unwrap();
    assert_eq!(confusion.len(), 12);
    let counted: u64 = confusion
        .iter()
        .flat_map(|r| r.as_array().unwrap())
        .map(|n| n.as_u64().unwrap())
        .sum();
    assert_eq!(counted, 12, "one test sequence per label");
    assert_eq!(json["set"]["variation"]["difficulty"], 1.0);

    // A few training steps: the generator, its loss curves, the report and a checkpoint.
    let model = dir.path().join("gen.sinew");
    let report = dir.path().join("gen.json");
    let train = |extra: &[&str]| {
        let mut a = vec![
            "train",
            "motion",
            "--motions",
            out.to_str().unwrap(),
            "--out",
            model.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
            "--steps",
            "3",
            "--batch",
            "4",
            "--hidden",
            "16,16",
            "--checkpoint-every",
            "2",
            "--quiet",
        ];
        a.extend_from_slice(extra);
        // Every run here reads or writes its Adam states on its own device, never burn's
        // default one.
        sinew_with(&a, &[NO_DEFAULT_DEVICE])
    };
    let run = train(&[]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let first = std::fs::read(&model).unwrap();
    let file = sinew_core::SinewFile::from_bytes_of_kind(
        &first,
        sinew_core::ArtifactKind::MotionGenerator,
    )
    .unwrap();
    assert_eq!(file.metadata().get("content"), Some("motion-generator"));
    assert!(dir.path().join("gen.losses.png").is_file());
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(json["history"].as_array().unwrap().len(), 3);
    // The label guide is on by default: its cross-entropy is in every step's losses.
    let classes = json["history"][0]["classes"].as_f64().unwrap();
    assert!(classes > 0.0 && classes.is_finite(), "{classes}");
    // Resuming the finished run's checkpoint bakes the same generator.
    let ckpt = dir.path().join("gen.ckpt");
    let run = train(&["--resume", ckpt.to_str().unwrap()]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(std::fs::read(&model).unwrap(), first);
    // Resuming with other settings is refused, naming the checkpoint state and the setting.
    let run = train(&["--resume", ckpt.to_str().unwrap(), "--lr", "0.01"]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("state.json")
            && stderr.contains("another run")
            && stderr.contains("settings.lr:")
            && stderr.contains("0.01 now"),
        "{stderr}"
    );
    // A learning rate or a loss weight that is no number for training is refused, naming it.
    for (option, value) in [
        ("--lr", "-1"),
        ("--lr", "NaN"),
        ("--rec-weight", "-0.5"),
        ("--diversity-weight", "-1"),
        ("--class-weight", "NaN"),
        ("--class-weight", "-2"),
    ] {
        let run = train(&[&format!("{option}={value}")]);
        assert!(!run.status.success(), "{option} {value}");
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(
            stderr.contains(option) && stderr.contains(value),
            "{stderr}"
        );
    }

    generate_and_interpolate(dir.path(), &model);
    eval_motion(dir.path(), &out, &model);
}

/// `sinew eval motion` on the small set with the just-trained generator and the golden decoder:
/// a few epochs, two diversity seeds; then bad input.
fn eval_motion(dir: &std::path::Path, motions: &std::path::Path, model: &std::path::Path) {
    let decoder = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/s2d-ict.sinew");
    let report = dir.join("eval.json");
    let (m, s) = (model.to_str().unwrap(), motions.to_str().unwrap());
    let eval = |model: &str, decoder: &str, motions: &str| {
        sinew(&[
            "eval",
            "motion",
            "--model",
            model,
            "--decoder",
            decoder,
            "--motions",
            motions,
            "--report",
            report.to_str().unwrap(),
            "--epochs",
            "3",
            "--diversity-seeds",
            "2",
            "--seed",
            "4",
            "--quiet",
        ])
    };
    let run = eval(m, decoder, s);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("seed 4"), "{stderr}");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        stdout.contains("Gen-LM") && stdout.contains("Det-LM"),
        "{stdout}"
    );
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(json["test_sequences"], 12);
    assert_eq!(json["train_sequences"], 12);
    assert_eq!(json["settings"]["classifier"]["epochs"], 3);
    assert_eq!(json["classifier_losses"].as_array().unwrap().len(), 3);
    assert!(json["seconds"].as_f64().unwrap() > 0.0);
    for row in ["gen_lm", "det_lm"] {
        let r = &json[row];
        for key in ["accuracy_gt", "accuracy_motion3dgan", "accuracy_lstm"] {
            let a = r[key].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&a), "{row}.{key} = {a}");
        }
        assert_eq!(r["frechet_train"].is_null(), row == "det_lm", "{row}");
        for key in ["frechet_motion3dgan", "frechet_lstm"] {
            let f = r[key].as_f64().unwrap();
            assert!(f.is_finite() && f >= 0.0, "{row}.{key} = {f}");
        }
        // One test motion a label: each label's offset is that motion's squared distance from
        // the ground truth's in the classifier's features, never negative, and 0 for no label.
        for key in ["label_mean_offset_motion3dgan", "label_mean_offset_lstm"] {
            let offsets: Vec<f64> = r[key]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            assert_eq!(offsets.len(), 12, "{row}.{key}");
            assert!(
                offsets.iter().all(|o| o.is_finite() && *o >= 0.0)
                    && offsets.iter().any(|o| *o > 0.0),
                "{row}.{key} = {offsets:?}"
            );
        }
        // Seeds make Motion3DGAN's motions differ; the LSTM's repeat (computed, not assumed: the
        // distance of a motion from itself is 0 up to the rounding of its inner product).
        let (gan, lstm) = (
            r["diversity"].as_f64().unwrap(),
            r["diversity_lstm"].as_f64().unwrap(),
        );
        assert!(
            gan > 1e-3 && (0.0..1e-5).contains(&lstm),
            "{row}: {gan} {lstm}"
        );
        // One identity: no ground-truth pairs of a label.
        assert!(r["diversity_gt"].is_null(), "{row}");
    }
    let generated = json["generated"].as_array().unwrap();
    assert_eq!(generated.len(), 12);
    assert_eq!(generated[0]["label"], "bareteeth");
    assert_eq!(generated[0]["seed"], 4_000_000);
    assert_eq!(generated[11]["seed"], 4_000_011);

    // Bad input, each named: a decoder of another landmark count, a file of another kind as the
    // generator, a folder without a motion set.
    let tiny = dir.join("tiny-decoder.sinew");
    std::fs::write(&tiny, sinew_host::s2d::synthetic::tiny_baked_decoder().1).unwrap();
    let run = eval(m, tiny.to_str().unwrap(), s);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{stderr}");
    assert!(
        stderr.contains("tiny-decoder.sinew") && stderr.contains("reads 2 landmarks"),
        "{stderr}"
    );
    let run = eval(decoder, decoder, s);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success()
            && stderr.contains("s2d-ict.sinew")
            && stderr.contains("not a Motion3DGAN generator"),
        "{stderr}"
    );
    let missing = dir.join("no-motions-here");
    let run = eval(m, decoder, missing.to_str().unwrap());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success()
            && stderr.contains("no-motions-here")
            && stderr.contains("manifest.json"),
        "{stderr}"
    );
}

/// `sinew generate` and `sinew interpolate` with the just-trained generator and the golden S2D
/// decoder (68 ICT landmarks), on the decoder's own neutral written as an OBJ.
fn generate_and_interpolate(dir: &std::path::Path, model: &std::path::Path) {
    let decoder = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/s2d-ict.sinew");
    let bytes = std::fs::read(decoder).unwrap();
    let dec = sinew_core::s2d::S2dDecoder::from_bytes(&bytes).unwrap();
    let pos: Vec<f32> = dec.neutral().iter().collect();
    let neutral = dir.join("neutral.obj");
    // A face of the decoder's vertices given as the neutral (any faces do for the strip).
    let n = pos.len() as u32 / 3;
    let mesh = sinew_host::io::mesh::Mesh::new(
        sinew_host::io::mesh::points(pos),
        (0..n - 2)
            .step_by(3)
            .map(|i| vec![i, i + 1, i + 2])
            .collect(),
    );
    mesh.write(&neutral).unwrap();
    let (m, n) = (model.to_str().unwrap(), neutral.to_str().unwrap());
    let frames = dir.join("frames");
    let gen_args = |out: &std::path::Path, label: &str| {
        sinew(&[
            "generate",
            "--model",
            m,
            "--decoder",
            decoder,
            "--label",
            label,
            "--seed",
            "7",
            "--neutral",
            n,
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let run = gen_args(&frames, "mouth_open");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for f in 1..=30 {
        let obj = frames.join(format!("frame_{f:02}.obj"));
        let frame = sinew_host::io::mesh::Mesh::read(&obj).unwrap();
        assert_eq!(frame.positions.len(), mesh.positions.len());
    }
    assert!(!frames.join("frame_31.obj").exists());
    assert!(frames.join("strip.png").is_file());
    // The same seed gives the same bytes; the apex moved away from the neutral.
    let again = dir.join("again-frames");
    assert!(gen_args(&again, "mouth_open").status.success());
    let apex = std::fs::read(frames.join("frame_30.obj")).unwrap();
    assert_eq!(apex, std::fs::read(again.join("frame_30.obj")).unwrap());
    let moved = sinew_host::io::mesh::Mesh::read(&frames.join("frame_30.obj")).unwrap();
    let read_back = sinew_host::io::mesh::Mesh::read(&neutral).unwrap();
    assert!(moved.positions != read_back.positions);

    let between = dir.join("between");
    let run = sinew(&[
        "interpolate",
        "--model",
        m,
        "--decoder",
        decoder,
        "--from",
        "mouth_open",
        "--to",
        "eyebrow",
        "--steps",
        "4",
        "--seed",
        "7",
        "--neutral",
        n,
        "--out",
        between.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(between.join("frame_04.obj").is_file() && !between.join("frame_05.obj").exists());
    assert!(between.join("strip.png").is_file());

    // Bad input: an unknown label, a generator of another kind, a neutral of another size.
    let run = gen_args(&dir.join("x"), "smile");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && stderr.contains("unknown label \"smile\""),
        "{stderr}"
    );
    assert!(stderr.contains("gen.sinew"), "{stderr}");
    let stderr = err(&[
        "generate",
        "--model",
        decoder,
        "--decoder",
        decoder,
        "--label",
        "mouth_open",
        "--neutral",
        n,
        "--out",
        dir.join("y").to_str().unwrap(),
    ]);
    assert!(stderr.contains("not a Motion3DGAN generator"), "{stderr}");
    assert!(stderr.contains("s2d-ict.sinew"), "{stderr}");
    let stderr = err(&[
        "generate",
        "--model",
        m,
        "--decoder",
        decoder,
        "--label",
        "mouth_open",
        "--neutral",
        n,
        "--intensity=-1",
        "--out",
        dir.join("w").to_str().unwrap(),
    ]);
    assert!(stderr.contains("--intensity -1"), "{stderr}");
    let small = dir.join("small.obj");
    std::fs::write(&small, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let stderr = err(&[
        "generate",
        "--model",
        m,
        "--decoder",
        decoder,
        "--label",
        "mouth_open",
        "--neutral",
        small.to_str().unwrap(),
        "--out",
        dir.join("z").to_str().unwrap(),
    ]);
    assert!(stderr.contains("small.obj"), "{stderr}");
    assert!(stderr.contains("the decoder's template has"), "{stderr}");
}

#[test]
fn data_motions_names_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-kit-here");
    let out = dir.path().join("motions");
    let run = sinew(&[
        "data",
        "motions",
        "--data",
        missing.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("no-kit-here"), "{stderr}");
    let run = sinew(&[
        "data",
        "motions",
        "--data",
        missing.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--per-class",
        "1",
    ]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("at least 2 sequences"), "{stderr}");
    // Knobs out of range are refused naming the option, before the kit is read.
    for (knob, value, says) in [
        (
            "--difficulty",
            "-1",
            "--difficulty -1: must be a finite number of at least 0",
        ),
        ("--mix", "1.5", "--mix 1.5: must be a number from 0 to 1"),
        ("--coactivation", "NaN", "--coactivation NaN"),
    ] {
        let flag = format!("{knob}={value}");
        let run = sinew(&[
            "data",
            "motions",
            "--data",
            missing.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            &flag,
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && stderr.contains(says), "{stderr}");
    }
    // The evaluation takes a generator and a decoder together, or neither.
    let stderr = err(&[
        "eval",
        "motion",
        "--model",
        "gen.sinew",
        "--motions",
        missing.to_str().unwrap(),
        "--report",
        dir.path().join("r.json").to_str().unwrap(),
    ]);
    assert!(stderr.contains("--decoder"), "{stderr}");
    // Training on a folder that holds no motion set names its manifest.
    let run = sinew(&[
        "train",
        "motion",
        "--motions",
        missing.to_str().unwrap(),
        "--out",
        dir.path().join("g.sinew").to_str().unwrap(),
    ]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("no-kit-here") && stderr.contains("manifest.json"),
        "{stderr}"
    );
    // Reading a folder that holds no motion set names the manifest.
    let err = format!("{:#}", MotionSet::read(dir.path()).unwrap_err());
    assert!(err.contains("manifest.json"), "{err}");
}
