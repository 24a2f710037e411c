//! The `sinew` binary as a user runs it: the demo end to end (short), then bake, play, edit and
//! inspect on its outputs; clear errors on bad input; and the one rule for settings (a flag beats
//! the environment, which beats the default). The S2D commands are in `s2d_cli.rs`, viewing,
//! playing and fitting performances in `playback_cli.rs`.

use std::process::{Command, Output};

use crate::common::{err, ok, s};

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

/// Accuracy targets that cannot be met or make no sense are refused before any work, naming the
/// option.
#[test]
fn train_aim_refuses_targets_that_make_no_sense() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.sinew");
    let report = dir.path().join("a.json");
    for (flags, says) in [
        (
            &["--target-mean", "-0.1"][..],
            "--target-mean -0.1: an error target is a positive number",
        ),
        (&["--target-p95", "inf"][..], "--target-p95 inf"),
        (
            &["--target-mean", "0.2", "--target-p95", "0.1"][..],
            "--target-p95 0.1 is below --target-mean 0.2",
        ),
        (
            &["--target-jaw-degrees", "-5"][..],
            "--target-jaw-degrees -5",
        ),
        (&["--check-every", "0"][..], "--check-every 0"),
    ] {
        let mut args = vec![
            "train",
            "aim",
            "--data",
            "no-such-kit",
            "--out",
            s(&out),
            "--report",
            s(&report),
        ];
        args.extend_from_slice(flags);
        let e = err(&args);
        assert!(e.contains(says), "{flags:?}: {e}");
        assert!(!out.exists() && !report.exists());
    }
    let e = err(&[
        "train",
        "aim",
        "--data",
        "no-such-kit",
        "--out",
        s(&out),
        "--report",
        s(&report),
        "--no-target",
        "--target-mean",
        "0.2",
    ]);
    assert!(e.contains("--no-target"), "{e}");
    // A prior that is not an actor, or missing, is refused naming the file, before any work.
    let not_actor = dir.path().join("prior.sinew");
    std::fs::write(&not_actor, b"SINEW but not really").unwrap();
    for prior in [not_actor, dir.path().join("missing.sinew")] {
        let e = err(&[
            "train",
            "aim",
            "--data",
            "no-such-kit",
            "--out",
            s(&out),
            "--report",
            s(&report),
            "--prior",
            s(&prior),
        ]);
        assert!(e.contains(s(&prior)), "{e}");
        assert!(!out.exists() && !report.exists());
    }
}
