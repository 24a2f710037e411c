use super::*;
use crate::io::data;

/// MediaPipe's canonical face from the data folder, or `None` (the test skips) where it is absent.
fn canonical() -> Option<PathBuf> {
    Some(data::data_dir()?.join("mediapipe/canonical_face_model.obj"))
}

#[test]
fn the_points_are_mirror_pairs_of_the_canonical_face() {
    let Some(path) = canonical() else { return };
    let face = Mesh::read(&path).unwrap();
    let p = |l: usize| face.positions[usize::from(IBUG_POINTS[l])];
    // iBUG's mirror pairs: the outline, the brows, the nose's base, the eyes, the lips.
    let mut pairs: Vec<(usize, usize)> = (0..8).map(|i| (i, 16 - i)).collect();
    pairs.extend((0..5).map(|i| (17 + i, 26 - i)));
    pairs.extend([(31, 35), (32, 34)]);
    pairs.extend([(36, 45), (37, 44), (38, 43), (39, 42), (40, 47), (41, 46)]);
    pairs.extend([(48, 54), (49, 53), (50, 52), (59, 55), (58, 56)]);
    pairs.extend([(60, 64), (61, 63), (67, 65)]);
    for (a, b) in pairs {
        let (pa, pb) = (p(a), p(b));
        let mirrored = [-pb[0], pb[1], pb[2]];
        let d = (0..3)
            .map(|c| (pa[c] - mirrored[c]).powi(2))
            .sum::<f32>()
            .sqrt();
        assert!(d < 0.05, "iBUG {a} and {b}: {d} cm from mirror images");
        assert!(
            pa[0] < 0.0,
            "iBUG {a} is on the face's right (image left): {pa:?}"
        );
    }
    // The midline points sit on the plane x = 0.
    for l in [8, 27, 28, 29, 30, 33, 51, 57, 62, 66] {
        assert!(p(l)[0].abs() < 1e-4, "iBUG {l} off the midline: {:?}", p(l));
    }
}

#[test]
fn the_canonical_face_placed_on_the_golden_actor_lands_at_ibugs_places() {
    let Some(path) = canonical() else { return };
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-ict.sinew");
    let bytes = std::fs::read(&model).unwrap();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let found = actor_vertices(&model, &actor, &path).unwrap();
    let ibug = super::super::landmark_vertices(&model, &actor).unwrap();
    let tpl = actor.template();
    let at = |v: u32| -> [f32; 3] { std::array::from_fn(|c| tpl.at(3 * v as usize + c)) };
    let dist = |a: [f32; 3], b: [f32; 3]| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f32>().sqrt();
    // Away from the outline (whose conventions differ: a ring of the face against the jaw's
    // silhouette), MediaPipe's points land within a centimetre of iBUG's landmark vertices.
    let mut worst = (0.0f32, 0);
    for l in 17..68 {
        let d = dist(at(found[l]), at(ibug[l]));
        if d > worst.0 {
            worst = (d, l);
        }
    }
    assert!(
        worst.0 < 1.0,
        "iBUG {} lies {} cm from MediaPipe's point",
        worst.1,
        worst.0
    );
    // A file that is not the canonical face is refused by name.
    let e = actor_vertices(&model, &actor, &model.with_file_name("nope.obj")).unwrap_err();
    assert!(e.to_string().contains("nope.obj"), "{e}");
}

#[test]
fn a_track_reads_the_mapped_points_in_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.jsonl");
    let points: Vec<String> = (0..478)
        .map(|k| {
            format!(
                "[{}, {}, 0.0]",
                (k % 100) as f64 / 100.0,
                (k / 100) as f64 / 10.0
            )
        })
        .collect();
    let line = format!(
        "{{\"width\": 640, \"height\": 480, \"landmarks\": [{}]}}",
        points.join(",")
    );
    std::fs::write(
        &path,
        format!("{line}\n{{\"width\": 640, \"height\": 480, \"landmarks\": []}}\n"),
    )
    .unwrap();
    let camera = Intrinsics {
        fx: 100.0,
        fy: 100.0,
        cx: 320.0,
        cy: 240.0,
    };
    let t = read_track(&path, Some(camera)).unwrap();
    assert_eq!(t.frames.len(), 2);
    assert_eq!(t.frames[1], None, "no face: a lost frame");
    assert_eq!(t.times, vec![0.0, 1.0 / 30.0]);
    let f = t.frames[0].as_ref().unwrap();
    for (l, &i) in IBUG_POINTS.iter().enumerate() {
        let i = usize::from(i);
        let (u, v) = (
            (i % 100) as f32 / 100.0 * 640.0,
            (i / 100) as f32 / 10.0 * 480.0,
        );
        let want = [(u - 320.0) / 100.0, (v - 240.0) / 100.0];
        assert!(
            (f[2 * l] - want[0]).abs() < 1e-5 && (f[2 * l + 1] - want[1]).abs() < 1e-5,
            "landmark {l}"
        );
    }
    // A bad row is named, and nothing is read.
    std::fs::write(&path, line.replacen("[0, 0, 0.0]", "[0, 0]", 1)).unwrap();
    let e = read_track(&path, None).unwrap_err().to_string();
    assert!(e.contains("t.jsonl: row 1: point 0 has 2 values"), "{e}");
}
