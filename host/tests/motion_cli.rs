//! `sinew data motions` and `sinew train motion` as a user runs them: a small motion set from the
//! real ICT-FaceKit, read back by the library with its seeded split, a few training steps with a
//! checkpoint resumed, and clear errors on bad input.

use std::process::{Command, Output};

use sinew_host::motion::data::{MotionSet, Split};

fn sinew(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sinew"))
        .args(args)
        .env_remove("SINEW_SEED")
        .output()
        .expect("run sinew")
}

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
        sinew(&a)
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
    // Resuming the finished run's checkpoint bakes the same generator.
    let ckpt = dir.path().join("gen.ckpt");
    let run = train(&["--resume", ckpt.to_str().unwrap()]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(std::fs::read(&model).unwrap(), first);
    // Resuming with other settings is refused, naming the checkpoint state.
    let run = train(&["--resume", ckpt.to_str().unwrap(), "--lr", "0.01"]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("state.json") && stderr.contains("other settings"),
        "{stderr}"
    );
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
