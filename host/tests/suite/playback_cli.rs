//! Playing models back as a user does: `sinew view` serving on 127.0.0.1, `play` of an ARKit
//! capture and `export gltf` on the golden actor, and a fitted performance baked by `fit` and
//! played by `play --performance`, with clear errors on bad input.

use std::path::Path;
use std::process::Command;

use crate::common::{err, ok, repo, s, sinew};

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

/// `--webcam` without MediaPipe's files says which command installs them; a driver with neither
/// a track nor the webcam is refused naming both ways; a render's frame rate must be positive.
#[test]
fn view_webcam_names_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let model = repo("tests/data/aim-ict.sinew");
    let driver = repo("tests/data/driver-ict-mediapipe.sinew");
    let empty = dir.path().join("tracker");
    std::fs::create_dir(&empty).unwrap();
    let e = err(&[
        "view",
        &model,
        "--driver",
        &driver,
        "--webcam",
        "--tracker-dir",
        s(&empty),
        "--port",
        "0",
    ]);
    assert!(
        e.contains(
            "tracker: MediaPipe Face Mesh's web files are not there (face_mesh.js is missing)"
        ) && e.contains("npm install @mediapipe/face_mesh@0.4.1633559619"),
        "{e}"
    );
    let e = err(&["view", &model, "--driver", &driver, "--port", "0"]);
    assert!(
        e.contains("--landmarks TRACK") && e.contains("--webcam"),
        "{e}"
    );
    let e = err(&["render", s(dir.path()), "--out", s(&empty), "--fps", "0"]);
    assert!(e.contains("--fps 0"), "{e}");
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
    assert!(!unplayable.iter().any(|c| c == "HeadYaw"));
    assert_eq!(summary["mapping"]["head"][0], "HeadYaw");
    assert_eq!(unplayable.len(), 39);

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
    // The 19 shapes, and the targets that compensate the capture's open jaw.
    let compensation = report["jaw_compensation_targets"].as_u64().unwrap();
    assert!(compensation > 0, "{report}");
    assert_eq!(report["morph_targets"], 19 + compensation);
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
    // Every setting not given on the command line is the library's default.
    let given = sinew_host::fit::setup::FitConfig {
        iterations: 20,
        hidden: 16,
        code: 4,
        ..Default::default()
    };
    assert_eq!(r["fit"]["config"], serde_json::to_value(&given).unwrap());
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
