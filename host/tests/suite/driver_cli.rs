//! The live driver as a user runs it: `sinew train driver` (checkpoints, --resume, the loss
//! picture, the report), `sinew drive` over an OpenFace 2.0 CSV (a lost frame holds the last
//! pose), and the clear errors of bad tracks and of a driver of another actor, with no output.

use std::path::Path;

use sinew_core::aim::AimActor;
use sinew_host::driver::sample::Sampler;
use sinew_host::driver::{DriverConfig, landmark_vertices};
use sinew_host::io::openface::{OpenFaceFrame, write_csv};
use sinew_host::training::random::Stream;

use crate::common::{NO_DEFAULT_DEVICE, err, ok, ok_with, repo, s};

const TRAIN: [&str; 10] = [
    "--steps",
    "40",
    "--hidden",
    "16",
    "--batch",
    "32",
    "--checkpoint-every",
    "20",
    "--quiet",
    "--seed=4",
];

/// An OpenFace track of the golden actor's own landmarks seen by a 1000 px camera at (320, 240).
fn track(frames: usize) -> Vec<OpenFaceFrame> {
    let bytes = std::fs::read(repo("tests/data/aim-ict.sinew")).unwrap();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let vertices = landmark_vertices(Path::new("aim-ict.sinew"), &actor).unwrap();
    let sampler = Sampler::new(&actor, &vertices, &DriverConfig::default());
    let mut rng = Stream::seed_from_u64(9);
    (0..frames)
        .map(|_| {
            let s = sampler.sample(&mut rng);
            OpenFaceFrame {
                pixels: s
                    .input
                    .chunks_exact(2)
                    .flat_map(|p| [320.0 + 1000.0 * p[0], 240.0 + 1000.0 * p[1]])
                    .collect(),
                world: Vec::new(),
                confidence: 0.98,
                success: true,
                timestamp: None,
            }
        })
        .collect()
}

#[test]
fn a_driver_trains_resumes_and_drives_a_track_holding_lost_frames() {
    let dir = tempfile::tempdir().unwrap();
    let actor = repo("tests/data/aim-ict.sinew");
    let out = dir.path().join("driver.sinew");
    let report = dir.path().join("driver.json");
    let mut args = vec!["train", "driver", "--model", &actor, "--out", s(&out)];
    args.extend(["--report", s(&report)]);
    args.extend(TRAIN);
    ok(&args);
    let first = std::fs::read(&out).unwrap();
    assert!(dir.path().join("driver.losses.png").is_file());
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(r["history"].as_array().unwrap().len(), 40);
    // Resuming the finished run re-bakes the same driver; another seed is another run.
    let ckpt = dir.path().join("driver.ckpt");
    let mut resume = args.clone();
    resume.extend(["--resume", s(&ckpt)]);
    ok_with(&resume, &[NO_DEFAULT_DEVICE]);
    assert_eq!(std::fs::read(&out).unwrap(), first);
    let seed = resume.iter().position(|a| *a == "--seed=4").unwrap();
    resume[seed] = "--seed=5";
    let e = err(&resume);
    assert!(
        e.contains("settings.seed: 4 in the checkpoint, 5 now"),
        "{e}"
    );

    let mut frames = track(5);
    frames[2].success = false;
    frames[3].confidence = 0.1;
    let csv = dir.path().join("track.csv");
    std::fs::write(&csv, write_csv(&frames, 30.0)).unwrap();
    let played = dir.path().join("played");
    let drive = [
        "drive",
        "--model",
        &actor,
        "--driver",
        s(&out),
        "--landmarks",
        s(&csv),
        "--out",
        s(&played),
        "--intrinsics",
        "1000,1000,320,240",
        // Frames drawn apart, not a motion: the lost-frame rules off.
        "--lost-rules",
        "0,0,0,0",
    ];
    ok(&drive);
    let obj = |f: usize| std::fs::read(played.join(format!("frame_{f:05}.obj"))).unwrap();
    assert_eq!(obj(2), obj(1), "a lost frame holds the last pose");
    assert_eq!(obj(3), obj(1), "so does an unsure one");
    assert_ne!(obj(4), obj(1));
    assert!(played.join("strip.png").is_file());
    // The filter changes later frames, not the first.
    let filtered = dir.path().join("filtered");
    let mut with_filter = drive.to_vec();
    with_filter[8] = s(&filtered);
    with_filter.extend(["--filter", "1,0.1,30"]);
    ok(&with_filter);
    let fobj = |f: usize| std::fs::read(filtered.join(format!("frame_{f:05}.obj"))).unwrap();
    assert_eq!(fobj(0), obj(0));
    assert_ne!(fobj(4), obj(4));
}

#[test]
fn bad_tracks_and_another_actors_driver_are_refused_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let actor = repo("tests/data/aim-ict.sinew");
    let driver = dir.path().join("d.sinew");
    let mut args = vec!["train", "driver", "--model", &actor, "--out", s(&driver)];
    args.extend(TRAIN);
    args[5 + 2] = "2"; // two steps are enough to have a driver
    ok(&args);
    let good = write_csv(&track(3), 30.0);
    let lines: Vec<&str> = good.lines().collect();
    let cases = [
        (
            format!("{}\n{}\n1, 2, 3\n", lines[0], lines[1]),
            "row 3 has 3 columns",
        ),
        (
            format!(
                "{}\n{}\n",
                lines[0],
                lines[1].replacen(", 0.98", ", nan", 1)
            ),
            "row 2, column confidence: nan is not finite",
        ),
        (
            format!(
                "{}\n{}\n",
                lines[0],
                lines[1].replacen(", 0.98", ", high", 1)
            ),
            "row 2, column confidence: \"high\" is not a number",
        ),
    ];
    for (i, (text, expected)) in cases.iter().enumerate() {
        let csv = dir.path().join(format!("bad{i}.csv"));
        std::fs::write(&csv, text).unwrap();
        let out = dir.path().join(format!("out{i}"));
        let e = err(&[
            "drive",
            "--model",
            &actor,
            "--driver",
            s(&driver),
            "--landmarks",
            s(&csv),
            "--out",
            s(&out),
            "--intrinsics",
            "1000,1000,320,240",
        ]);
        assert!(
            e.contains(&format!("bad{i}.csv")) && e.contains(expected),
            "{e}"
        );
        assert!(!out.exists(), "no partial output");
    }
    let csv = dir.path().join("good.csv");
    std::fs::write(&csv, &good).unwrap();
    let out = dir.path().join("other");
    let other = repo("tests/data/aim-procedural.sinew");
    let e = err(&[
        "drive",
        "--model",
        &other,
        "--driver",
        s(&driver),
        "--landmarks",
        s(&csv),
        "--out",
        s(&out),
        "--intrinsics",
        "1000,1000,320,240",
    ]);
    assert!(e.contains("d.sinew") && e.contains("another actor"), "{e}");
    assert!(!out.exists());
    let e = err(&[
        "drive",
        "--model",
        &actor,
        "--driver",
        s(&driver),
        "--landmarks",
        s(&csv),
        "--out",
        s(&out),
    ]);
    assert!(e.contains("--intrinsics"), "{e}");
}

/// A fit that starts where the driver puts the head and jaw: with the performance's own heads
/// and jaws as the driven poses (a perfect driver), 20 steps end nearer the truth than from
/// rest (the first step's error is F_T's random first output's as much as the start's); `sinew fit --start driver` needs its driver, binds it to the actor
/// and records its hash, and a driver without `--start driver` is refused.
#[test]
fn a_fit_refines_the_drivers_answer() {
    use sinew_host::fit::aim::{FitConfig, Mode, Start, fit_from};
    use sinew_host::io::performance::Performance;
    use sinew_host::performance::{PerformanceConfig, generate};
    use sinew_host::training::backend::Backend;
    let Some(data) = sinew_host::io::data::data_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let actor_path = repo("tests/data/aim-ict.sinew");
    let perf_dir = dir.path().join("perf");
    let config = PerformanceConfig {
        seed: 3,
        frames: 2,
        ..PerformanceConfig::default()
    };
    generate(
        &data.join("ict-facekit"),
        Some(Path::new(&actor_path)),
        &config,
        &perf_dir,
    )
    .unwrap();
    let perf = Performance::read(&perf_dir).unwrap();
    let bytes = std::fs::read(&actor_path).unwrap();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let truth: Vec<[f32; 18]> = perf
        .manifest
        .parameters
        .iter()
        .map(|p| std::array::from_fn(|i| if i < 9 { p.head[i] } else { p.jaw[i - 9] }))
        .collect();
    let fit = |start, driven: Option<&[[f32; 18]]>| {
        let config = FitConfig {
            iterations: 20,
            mode: Mode::TwoD,
            start,
            ..FitConfig::default()
        };
        fit_from(&actor, &perf, &config, Backend::Flex, None, driven).unwrap()
    };
    let rest = fit(Start::Identity, None);
    let driven = fit(Start::Driver, Some(&truth));
    let (r, d) = (rest.mean_error_mm, driven.mean_error_mm);
    assert!(d < 0.8 * r, "from the driver {d} mm, from rest {r} mm");
    let config = FitConfig {
        iterations: 20,
        mode: Mode::TwoD,
        start: Start::Driver,
        ..FitConfig::default()
    };
    assert!(
        fit_from(
            &actor,
            &perf,
            &config,
            Backend::Flex,
            None,
            Some(&truth[..1])
        )
        .is_err()
    );

    let driver = dir.path().join("driver.sinew");
    let mut train = vec![
        "train",
        "driver",
        "--model",
        &actor_path,
        "--out",
        s(&driver),
    ];
    train.extend(TRAIN);
    ok(&train);
    let out = dir.path().join("fit.sinew");
    let report = dir.path().join("fit.json");
    let mut args = vec!["fit", "--model", &actor_path, "--target", s(&perf_dir)];
    args.extend(["--out", s(&out), "--report", s(&report), "--mode", "2d"]);
    args.extend(["--iterations", "5", "--start", "driver"]);
    let e = err(&args);
    assert!(e.contains("--start driver needs the driver"), "{e}");
    let mut with = args.clone();
    with.extend(["--driver", s(&driver)]);
    ok(&with);
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let hash = format!(
        "{:016x}",
        sinew_core::replay::model_hash(&std::fs::read(&driver).unwrap())
    );
    assert_eq!(r["fit"]["config"]["driver"], hash.as_str());
    let start = args.iter().position(|a| *a == "driver").unwrap();
    let mut identity = with.clone();
    identity[start] = "identity";
    let e = err(&identity);
    assert!(e.contains("only read with --start driver"), "{e}");
}

/// The `v` lines of an OBJ, flattened.
fn obj_positions(path: &Path) -> Vec<f32> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .flat_map(|l| l.split_whitespace().map(|x| x.parse::<f32>().unwrap()))
        .collect()
}

/// A 3D driver drives an OpenFace CSV's 3D landmarks (millimetres, the camera's axes) wherever
/// the camera saw the head: the same track seen from 60 cm ahead and from 90 cm ahead and aside
/// plays the same frames, and they move.
#[test]
fn a_three_d_driver_drives_openface_millimetres_wherever_the_camera_stood() {
    let dir = tempfile::tempdir().unwrap();
    let actor = repo("tests/data/aim-ict.sinew");
    let out = dir.path().join("driver3d.sinew");
    let mut args = vec!["train", "driver", "--model", &actor, "--out", s(&out)];
    args.extend(["--input", "3d"]);
    args.extend(TRAIN);
    ok(&args);

    let bytes = std::fs::read(&actor).unwrap();
    let golden = AimActor::from_bytes(&bytes).unwrap();
    let vertices = landmark_vertices(Path::new("aim-ict.sinew"), &golden).unwrap();
    let config = DriverConfig {
        input: sinew_core::driver::Space::World,
        ..DriverConfig::default()
    };
    let sampler = Sampler::new(&golden, &vertices, &config);
    let mut rng = Stream::seed_from_u64(11);
    let faces: Vec<Vec<f32>> = (0..4).map(|_| sampler.sample(&mut rng).input).collect();
    let mut played = Vec::new();
    for (name, [dx, dy, dz]) in [
        ("ahead", [0.0, 0.0, 600.0]),
        ("aside", [150.0, -40.0, 900.0]),
    ] {
        // The actor's centimetres as OpenFace's camera sees them: mm, y down, z away.
        let rows: Vec<OpenFaceFrame> = faces
            .iter()
            .map(|p| OpenFaceFrame {
                pixels: Vec::new(),
                world: p
                    .chunks_exact(3)
                    .flat_map(|q| [10.0 * q[0] + dx, dy - 10.0 * q[1], dz - 10.0 * q[2]])
                    .collect(),
                confidence: 0.97,
                success: true,
                timestamp: None,
            })
            .collect();
        let csv = dir.path().join(format!("{name}.csv"));
        std::fs::write(&csv, write_csv(&rows, 30.0)).unwrap();
        let frames = dir.path().join(name);
        ok(&[
            "drive",
            "--model",
            &actor,
            "--driver",
            s(&out),
            "--landmarks",
            s(&csv),
            "--out",
            s(&frames),
            "--lost-rules",
            "0,0,0,0",
        ]);
        played.push(
            (0..4)
                .map(|f| obj_positions(&frames.join(format!("frame_{f:05}.obj"))))
                .collect::<Vec<_>>(),
        );
    }
    let apart = |a: &[f32], b: &[f32]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max)
    };
    for (f, (ahead, aside)) in played[0].iter().zip(&played[1]).enumerate() {
        let d = apart(ahead, aside);
        assert!(d < 1e-3, "frame {f}: {d} cm between the two cameras");
    }
    assert!(
        apart(&played[0][0], &played[0][3]) > 0.01,
        "the frames move"
    );
    // A 2D driver cannot read a CSV of 3D landmarks only.
    let two_d = dir.path().join("driver2d.sinew");
    let mut args = vec!["train", "driver", "--model", &actor, "--out", s(&two_d)];
    args.extend(TRAIN);
    ok(&args);
    let e = err(&[
        "drive",
        "--model",
        &actor,
        "--driver",
        s(&two_d),
        "--landmarks",
        s(&dir.path().join("ahead.csv")),
        "--out",
        s(&dir.path().join("none")),
        "--intrinsics",
        "1000,1000,320,240",
    ]);
    assert!(e.contains("x_0 … y_67"), "{e}");
    assert!(!dir.path().join("none").exists());
}

/// A run's standard error, the run required to have succeeded.
fn warned(out: std::process::Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `sinew drive --calibrate-frames` on the golden live track (a tracker's convention, a rest at
/// the start, four failures): the calibration, the lost frames and the frame without a face are
/// reported by number, the lost ones hold the last pose; a calibration over frames where the face
/// moves names them in a warning; bad settings are refused naming the flag, with no output.
#[test]
fn drive_calibrates_reports_lost_frames_and_warns_of_a_moving_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let track = repo("tests/data/driver-ict-live.csv");
    let out = dir.path().join("live");
    let run = |calibrate: &str, out: &Path| drive_live(&["--calibrate-frames", calibrate], out);
    let done = run("6", &out);
    assert!(done.status.success());
    let said = String::from_utf8_lossy(&done.stderr);
    assert!(
        said.contains("calibrated on frames 0-5 (6 frames)"),
        "{said}"
    );
    assert!(
        said.contains("10 frames lost to the rules (the last pose held): 6-11, 21-23, 32"),
        "{said}"
    );
    assert!(
        said.contains("1 frames without a face in the track: 45"),
        "{said}"
    );
    assert!(!said.contains("warning"), "{said}");
    let obj = |f: usize| std::fs::read(out.join(format!("frame_{f:05}.obj"))).unwrap();
    assert_eq!(obj(0), obj(5), "the calibration frames are written at rest");
    assert_eq!(
        obj(6),
        obj(5),
        "before any frame is driven, a lost one stays at rest"
    );
    assert_eq!(obj(23), obj(20), "a lost run holds the last pose");
    assert_eq!(obj(45), obj(44), "so does a frame without a face");
    assert_ne!(obj(20), obj(19));
    // A calibration during which the mouth opened and the brows rose for a frame (3): the
    // warning names it.
    let mut rows = sinew_host::io::openface::read(Path::new(&track)).unwrap();
    for row in &mut rows[3..4] {
        for l in 48..68 {
            row.pixels[2 * l + 1] += 25.0;
        }
        for l in 17..27 {
            row.pixels[2 * l + 1] -= 10.0;
        }
    }
    let moving = dir.path().join("moving.csv");
    std::fs::write(&moving, write_csv(&rows, 30.0)).unwrap();
    let said = warned(drive_track(
        s(&moving),
        &["--calibrate-frames", "6"],
        &dir.path().join("moving"),
    ));
    assert!(
        said.contains("warning: the face was not at rest on calibration frames 3 (up to"),
        "{said}"
    );
    // A calibration through which the face talks (the mouth 30 px down and up in turn): every
    // frame deviates alike, so the warning names the whole calibration.
    let mut rows = sinew_host::io::openface::read(Path::new(&track)).unwrap();
    for (i, row) in rows[..6].iter_mut().enumerate() {
        let shift = if i % 2 == 0 { 30.0 } else { -30.0 };
        for l in 48..68 {
            row.pixels[2 * l + 1] += shift;
        }
    }
    let talking = dir.path().join("talking.csv");
    std::fs::write(&talking, write_csv(&rows, 30.0)).unwrap();
    let said = warned(drive_track(
        s(&talking),
        &["--calibrate-frames", "6"],
        &dir.path().join("talking"),
    ));
    assert!(
        said.contains("warning: the face was not at rest during the calibration, frames 0-5 ("),
        "{said}"
    );
    // Bad settings name their flag and write nothing.
    let refused = dir.path().join("refused");
    for (flags, message) in [
        (
            ["--calibrate-frames", "5000"],
            "--calibrate-frames: live[0] is outside [0, 1e3]",
        ),
        (
            ["--lost-rules", "0.2,-1,8,0.5"],
            "--lost-rules: live[2] is outside [0, 1e3]",
        ),
        (
            ["--lost-rules", "0.2,40"],
            "--lost-rules: expected RESIDUAL,SPEED,TURN,REACQUIRE",
        ),
    ] {
        let done = drive_live(&flags, &refused);
        assert!(!done.status.success());
        let e = String::from_utf8_lossy(&done.stderr);
        assert!(e.contains(message), "{e}");
        assert!(!refused.exists());
    }
}

/// `--calibration-depth` replaces the driver's share of the calibrated head's depth for the run
/// (docs/FIT.md, "The head's depth"): 0 drives the golden driver, which records none, exactly as
/// without it; 1 moves the driven heads after the calibration and leaves the calibration's own
/// frames at rest; a share outside 0 to 1 is refused.
#[test]
fn drive_takes_a_calibration_depth_share_for_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let mut args = vec!["--calibrate-frames", "6"];
        args.extend_from_slice(extra);
        (drive_live(&args, &out), out)
    };
    let obj = |out: &Path, f: usize| std::fs::read(out.join(format!("frame_{f:05}.obj"))).unwrap();
    let (plain, plain_out) = run(&[], "plain");
    let (zero, zero_out) = run(&["--calibration-depth", "0"], "zero");
    let (one, one_out) = run(&["--calibration-depth", "1"], "one");
    for done in [&plain, &zero, &one] {
        assert!(
            done.status.success(),
            "{}",
            String::from_utf8_lossy(&done.stderr)
        );
    }
    for f in [0, 5, 12, 30, 59] {
        assert_eq!(obj(&plain_out, f), obj(&zero_out, f), "frame {f}");
    }
    assert_eq!(obj(&one_out, 3), obj(&plain_out, 3), "calibrating at rest");
    assert_ne!(obj(&one_out, 30), obj(&plain_out, 30));
    let (refused, _) = run(&["--calibration-depth", "1.5"], "refused");
    assert!(!refused.status.success());
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(said.contains("--calibration-depth 1.5"), "{said}");
}

/// `sinew drive` of the golden actor and driver on the golden live track through its camera,
/// into `out`, with `extra` arguments.
fn drive_live(extra: &[&str], out: &Path) -> std::process::Output {
    drive_track(&repo("tests/data/driver-ict-live.csv"), extra, out)
}

/// `sinew drive` of the golden actor and driver on `track` through the live track's camera,
/// into `out`, with `extra` arguments.
fn drive_track(track: &str, extra: &[&str], out: &Path) -> std::process::Output {
    let (actor, driver) = (
        repo("tests/data/aim-ict.sinew"),
        repo("tests/data/driver-ict.sinew"),
    );
    let mut args = vec![
        "drive",
        "--model",
        &actor,
        "--driver",
        &driver,
        "--landmarks",
        track,
        "--intrinsics",
        "1200,1200,320,240",
        "--out",
        s(out),
    ];
    args.extend_from_slice(extra);
    crate::common::sinew(&args)
}
