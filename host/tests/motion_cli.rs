//! `sinew data motions` as a user runs it: a small motion set from the real ICT-FaceKit, read back
//! by the library with its seeded split, and clear errors on bad input.

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
    // Reading a folder that holds no motion set names the manifest.
    let err = format!("{:#}", MotionSet::read(dir.path()).unwrap_err());
    assert!(err.contains("manifest.json"), "{err}");
}
