use std::path::{Path, PathBuf};

use sinew_core::aim::AimActor;

use super::*;
use crate::io::container::ContainerError;
use crate::io::data::data_dir;
use crate::io::dataset::DataSetError;
use crate::io::mesh::MeshError;
use crate::io::performance::{Camera, MANIFEST, Performance, PerformanceError};

pub(crate) fn golden_actor() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-ict.sinew")
}

fn kit_dir() -> Option<PathBuf> {
    Some(data_dir()?.join("ict-facekit"))
}

fn small(seed: u64) -> PerformanceConfig {
    PerformanceConfig {
        seed,
        frames: 3,
        noise_mm: 0.1,
        ..PerformanceConfig::default()
    }
}

#[test]
fn pinhole_projection() {
    let cam = Camera {
        width: 640,
        height: 480,
        fx: 1000.0,
        fy: 800.0,
        cx: 320.0,
        cy: 240.0,
        position: [1.0, 2.0, 50.0],
    };
    assert_eq!(cam.project([1.0, 2.0, 0.0]), Some([320.0, 240.0]));
    // 5 cm right and up at 50 cm: 100 px right (fx/10) and 80 px up (v points down).
    assert_eq!(cam.project([6.0, 7.0, 0.0]), Some([420.0, 160.0]));
    assert_eq!(cam.project([0.0, 0.0, 60.0]), None);
    assert!(cam.inside([0.0, 479.5]) && !cam.inside([640.0, 10.0]) && !cam.inside([-0.1, 0.0]));
}

#[test]
fn generation_is_seeded_and_matches_the_actor() {
    let Some(kit) = kit_dir() else { return };
    let dirs = [(); 3].map(|()| tempfile::tempdir().unwrap());
    let actor = golden_actor();
    let a = generate(&kit, Some(&actor), &small(7), dirs[0].path()).unwrap();
    let b = generate(&kit, Some(&actor), &small(7), dirs[1].path()).unwrap();
    let c = generate(&kit, Some(&actor), &small(8), dirs[2].path()).unwrap();
    assert_eq!(a, b);
    assert_ne!(a.parameters, c.parameters);
    for file in &a.files {
        let x = std::fs::read(dirs[0].path().join(file)).unwrap();
        assert_eq!(
            x,
            std::fs::read(dirs[1].path().join(file)).unwrap(),
            "{file}"
        );
    }
    assert!(a.synthetic && a.source.starts_with("synthetic"));
    assert_eq!(a.expressions.len(), 53);
    assert_eq!(a.vertices, 4_705);
    assert!(a.jaw_pivot.is_some());
    // Smooth trajectories that move: every weight stays in [0, 1], some are active, and the
    // head moves from frame to frame.
    let w = |f: usize| &a.parameters[f].weights;
    assert!(w(0).iter().all(|x| (0.0..=1.0).contains(x)));
    assert!(w(0).iter().filter(|&&x| x > 0.0).count() > 5);
    assert_ne!(a.parameters[0].head, a.parameters[1].head);

    let perf = Performance::read(dirs[0].path()).unwrap();
    assert_eq!(perf.frames.len(), 3);
    // Vertex correspondence: the actor's template is the kit's face region at kit_vertices.
    let bytes = std::fs::read(&actor).unwrap();
    let model = AimActor::from_bytes(&bytes).unwrap();
    assert_eq!(perf.polygons.len(), model.triangles().len());
    let face = IctFaceKit::open(&kit).unwrap();
    let tpl = model.template();
    for (i, &v) in a.kit_vertices.iter().enumerate() {
        let p = face.neutral().positions[v as usize];
        assert_eq!(p, [tpl.at(3 * i), tpl.at(3 * i + 1), tpl.at(3 * i + 2)]);
    }
    // The landmark tracks are the mesh's landmark vertices through the camera.
    for (f, positions) in perf.frames.iter().enumerate() {
        for (l, &v) in a.landmarks.vertices.iter().enumerate() {
            let uv = a.camera.project(positions[v as usize]).unwrap();
            let got = a.landmarks.pixels[f][l];
            assert!((uv[0] - got[0]).abs() < 1e-3 && (uv[1] - got[1]).abs() < 1e-3);
            assert!(a.camera.inside(got));
        }
    }
    // iBUG 36 (the subject's right eye corner, negative x) is left of 45 in the image.
    let px = &a.landmarks.pixels[0];
    assert!(px[36][0] < px[45][0] && px[8][1] > px[30][1], "{px:?}");
}

#[test]
fn landmark_noise_moves_the_tracks_and_not_the_meshes() {
    let Some(kit) = kit_dir() else { return };
    let dirs = [(); 2].map(|()| tempfile::tempdir().unwrap());
    let actor = golden_actor();
    let clean = generate(&kit, Some(&actor), &small(7), dirs[0].path()).unwrap();
    let noisy_config = PerformanceConfig {
        landmark_noise_px: 2.0,
        ..small(7)
    };
    let noisy = generate(&kit, Some(&actor), &noisy_config, dirs[1].path()).unwrap();
    assert_eq!(noisy.landmark_noise_px, 2.0);
    assert_eq!(clean.parameters, noisy.parameters);
    for file in &clean.files {
        assert_eq!(
            std::fs::read(dirs[0].path().join(file)).unwrap(),
            std::fs::read(dirs[1].path().join(file)).unwrap(),
            "{file}"
        );
    }
    // 3 frames × 68 landmarks × 2 coordinates of N(0, 2²) pixels.
    let d: Vec<f32> = clean
        .landmarks
        .pixels
        .iter()
        .flatten()
        .zip(noisy.landmarks.pixels.iter().flatten())
        .flat_map(|(a, b)| [b[0] - a[0], b[1] - a[1]])
        .collect();
    let n = d.len() as f32;
    let mean = d.iter().sum::<f32>() / n;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / (n - 1.0)).sqrt();
    assert!(mean.abs() < 0.3 && (sd - 2.0).abs() < 0.3, "{mean} {sd}");
    // The manifest reads back with it; a negative value is refused.
    assert_eq!(
        Performance::read(dirs[1].path())
            .unwrap()
            .manifest
            .landmark_noise_px,
        2.0
    );
    let bad = PerformanceConfig {
        landmark_noise_px: -1.0,
        ..small(7)
    };
    assert_eq!(
        bad.validate(),
        Err(InvalidPerformanceConfig::LandmarkNoisePx(-1.0))
    );
}

#[test]
fn bad_performances_are_refused_naming_the_file() {
    let Some(kit) = kit_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let config = PerformanceConfig {
        frames: 2,
        ..small(3)
    };
    generate(&kit, Some(&golden_actor()), &config, dir.path()).unwrap();
    let frame1 = dir.path().join("frame_00001.obj");
    let text = std::fs::read_to_string(&frame1).unwrap();
    let err = |dir: &Path| Performance::read(dir).unwrap_err();

    // A NaN coordinate.
    let nan = {
        let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let i = lines.iter().position(|l| l.starts_with("v ")).unwrap();
        lines[i] = "v NaN 0 0".into();
        lines.join("\n")
    };
    std::fs::write(&frame1, nan).unwrap();
    let e = err(dir.path());
    assert!(
        matches!(&e, PerformanceError::Mesh(MeshError::Parse { path, .. } | MeshError::Inconsistent { path, .. })
            if path.ends_with("frame_00001.obj")),
        "{e:?}"
    );

    // Too few vertices (the last vertex dropped, faces referring to it dropped too).
    let last = text.lines().filter(|l| l.starts_with("v ")).count();
    let fewer: Vec<&str> = {
        let mut seen = 0;
        text.lines()
            .filter(|l| {
                if l.starts_with("v ") {
                    seen += 1;
                    return seen < last;
                }
                !(l.starts_with("f ") && l.split_whitespace().any(|t| t == last.to_string()))
            })
            .collect()
    };
    std::fs::write(&frame1, fewer.join("\n")).unwrap();
    let e = err(dir.path());
    assert!(
        matches!(&e, PerformanceError::VertexCount { path, found: 4704, expected: 4705 }
            if path.ends_with("frame_00001.obj")),
        "{e:?}"
    );
    assert!(
        e.to_string().contains("frame_00001.obj: 4704 vertices"),
        "{e}"
    );

    // A missing frame.
    std::fs::remove_file(&frame1).unwrap();
    let e = err(dir.path());
    assert!(
        matches!(&e, PerformanceError::MissingFrame { path, frame: 1, .. }
            if path.ends_with("frame_00001.obj")),
        "{e:?}"
    );

    // A manifest that disagrees with itself.
    let path = dir.path().join(MANIFEST);
    let mut m: Manifest = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    m.frames = 5;
    std::fs::write(&path, serde_json::to_string(&m).unwrap()).unwrap();
    let e = err(dir.path());
    assert!(
        matches!(&e, PerformanceError::ListLength { path, list: "files", len: 2, frames: 5 }
            if path.ends_with(MANIFEST)),
        "{e:?}"
    );
    // Not a manifest at all.
    std::fs::write(&path, "[]").unwrap();
    let e = err(dir.path());
    assert!(
        matches!(&e, PerformanceError::Manifest(DataSetError::ManifestJson { path, .. })
            if path.ends_with(MANIFEST)),
        "{e:?}"
    );
}

#[test]
fn an_actor_off_the_kit_is_refused() {
    let Some(kit) = kit_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let procedural =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-procedural.sinew");
    let e = generate(&kit, Some(&procedural), &small(1), dir.path()).unwrap_err();
    assert!(
        matches!(&e, GenerateError::OffTheKit { path, .. } if *path == procedural),
        "{e:?}"
    );
    let e = generate(
        &kit,
        None,
        &PerformanceConfig {
            frames: 0,
            ..small(1)
        },
        dir.path(),
    );
    assert!(
        matches!(
            e,
            Err(GenerateError::Config(InvalidPerformanceConfig::NoFrames))
        ),
        "{e:?}"
    );
}

#[test]
fn a_missing_kit_folder_or_actor_file_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let e = generate(
        &dir.path().join("no-kit"),
        None,
        &small(1),
        &dir.path().join("out"),
    )
    .unwrap_err();
    assert!(matches!(e, GenerateError::Kit(_)), "{e:?}");
    assert!(e.to_string().contains("no-kit"), "{e}");
    let Some(kit) = kit_dir() else { return };
    let missing = dir.path().join("missing.sinew");
    let e = generate(&kit, Some(&missing), &small(1), &dir.path().join("out")).unwrap_err();
    assert!(
        matches!(&e, GenerateError::ActorFile(ContainerError::Read { path, .. }) if *path == missing),
        "{e:?}"
    );
}
