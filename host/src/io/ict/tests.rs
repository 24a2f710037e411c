use super::*;
use crate::io::data::data_dir;

fn kit() -> Option<IctFaceKit> {
    let dir = data_dir()?.join("ict-facekit");
    Some(IctFaceKit::open(&dir).unwrap())
}

fn norm(v: [f32; 3]) -> f32 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

#[test]
fn kit_listing_and_landmarks() {
    let Some(kit) = kit() else { return };
    let names = kit.expression_names();
    assert_eq!(names.len(), 53);
    assert!(names.windows(2).all(|w| w[0] < w[1]));
    // The kit's own list of expressions agrees with the folder.
    let listed: Vec<String> =
        serde_json::from_value(kit.vertex_indices["expressions"].clone()).unwrap();
    assert_eq!(listed, names);
    assert_eq!(kit.identity_count(), 100);
    for name in DEFAULT_SHAPES {
        assert!(names.iter().any(|n| n == name), "{name}");
    }
    let lm = kit.landmarks68().unwrap();
    // First, chin and last landmarks as the upstream README lists them.
    assert_eq!((lm[0], lm[8], lm[67]), (1225, 966, 5966));
    // iBUG 8 (chin) lies on the mid-plane; 36 and 45 (outer eye corners) mirror each other,
    // and the subject's right (iBUG 36) is at negative x.
    let p = &kit.neutral().positions;
    assert_eq!(p[lm[8] as usize][0], 0.0);
    assert!(p[lm[36] as usize][0] < -4.0);
    assert_eq!(p[lm[36] as usize][0], -p[lm[45] as usize][0]);

    let err = kit
        .actor(&[], &["jawOpen", "smile"], FACE_REGION)
        .unwrap_err();
    assert!(
        matches!(&err, IctError::UnknownExpression { name, valid, .. }
            if name == "smile" && valid.iter().any(|v| v == "mouthSmile_L")),
        "{err:?}"
    );
    let msg = err.to_string();
    assert!(
        msg.contains("expressions") && msg.contains("\"smile\""),
        "{msg}"
    );
    assert!(matches!(
        kit.actor(&[], &["jawOpen", "jawOpen"], FACE_REGION),
        Err(IctError::RepeatedExpression { name, .. }) if name == "jawOpen"
    ));
    assert!(matches!(
        kit.actor(&[0.0; 101], &[], FACE_REGION),
        Err(IctError::TooManyWeights {
            given: 101,
            count: 100,
            ..
        })
    ));
    assert!(matches!(
        kit.actor(&[f32::NAN], &[], FACE_REGION),
        Err(IctError::WeightNotFinite { .. })
    ));
    assert!(matches!(
        kit.actor(&[], &[], 0..30_000),
        Err(IctError::Region {
            vertices: 26_719,
            ..
        })
    ));
    assert!(matches!(
        kit.identity_delta(100),
        Err(IctError::UnknownIdentity {
            mode: 100,
            count: 100,
            ..
        })
    ));
}

/// A folder that is not a kit is refused with the missing file or the broken rule named,
/// without the published data.
#[test]
fn broken_kits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let err = IctFaceKit::open(dir.path()).unwrap_err();
    assert!(
        matches!(&err, IctError::Mesh(MeshError::Read { path, .. })
            if path.ends_with("generic_neutral_mesh.obj")),
        "{err:?}"
    );
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::fs::write(dir.path().join("generic_neutral_mesh.obj"), tri).unwrap();
    std::fs::write(dir.path().join("vertex_indices.json"), "{").unwrap();
    let err = IctFaceKit::open(dir.path()).unwrap_err();
    assert!(
        matches!(&err, IctError::Json { path, .. } if path.ends_with("vertex_indices.json")),
        "{err:?}"
    );
    std::fs::write(dir.path().join("vertex_indices.json"), "{}").unwrap();
    let err = IctFaceKit::open(dir.path()).unwrap_err();
    assert!(
        matches!(&err, IctError::List { path, .. } if path.ends_with("expressions")),
        "{err:?}"
    );
    std::fs::create_dir(dir.path().join("expressions")).unwrap();
    let err = IctFaceKit::open(dir.path()).unwrap_err();
    assert!(matches!(err, IctError::NoExpressions { .. }), "{err:?}");
    std::fs::write(dir.path().join("expressions/jawOpen.obj"), tri).unwrap();
    std::fs::create_dir(dir.path().join("identities")).unwrap();
    std::fs::write(dir.path().join("identities/identity001.obj"), tri).unwrap();
    let err = IctFaceKit::open(dir.path()).unwrap_err();
    assert!(
        matches!(
            err,
            IctError::IdentityGap {
                missing: 0,
                next: 1,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("identities"), "{err}");
    std::fs::rename(
        dir.path().join("identities/identity001.obj"),
        dir.path().join("identities/identity000.obj"),
    )
    .unwrap();
    let kit = IctFaceKit::open(dir.path()).unwrap();
    assert!(matches!(
        kit.landmarks68(),
        Err(IctError::NoLandmarks { .. })
    ));
    std::fs::write(dir.path().join("expressions/jawOpen.obj"), "v 0 0 0\n").unwrap();
    let err = kit.expression_delta("jawOpen").unwrap_err();
    assert!(
        matches!(&err, IctError::Mesh(MeshError::TopologyCounts { path, .. })
            if path.ends_with("jawOpen.obj")),
        "{err:?}"
    );
}

#[test]
fn default_actor() {
    let Some(kit) = kit() else { return };
    let t = std::time::Instant::now();
    let actor = kit.actor(&[], &DEFAULT_SHAPES, FACE_REGION).unwrap();
    eprintln!("default ICT actor built in {:?}", t.elapsed());
    assert_eq!(actor.shapes.len(), 20);
    assert_eq!(actor.names.len(), 20);
    assert_eq!(actor.names[0], "neutral");
    assert_eq!(actor.names[1], "jawOpen");
    assert!(actor.shapes.iter().all(|s| s.len() == 9_409));
    assert_eq!(actor.template.positions.len(), 9_409);
    assert_eq!(actor.template.polygons.len(), 9_230);
    assert_eq!(actor.template.polygon_uvs.len(), 9_230);
    actor.template.validate().unwrap();
    // With no identity weights the template is the generic neutral's face.
    assert_eq!(
        actor.template.positions[..],
        kit.neutral().positions[..9_409]
    );
    assert_eq!(actor.shapes[0], actor.template.positions);
    assert_eq!(actor.units, crate::io::units::Unit::Centimetre);
    assert!(actor.source.contains("MIT") && actor.source.contains("USC"));

    // The data README: jawOpen moves some vertex by 4.2 cm, mouthSmile_L by 1.6 cm.
    let max_disp = |s: usize| {
        actor.shapes[s]
            .iter()
            .zip(&actor.shapes[0])
            .map(|(a, b)| norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]]))
            .fold(0.0f32, f32::max)
    };
    let jaw = max_disp(1);
    let smile = max_disp(5);
    eprintln!("max displacement: jawOpen {jaw} cm, mouthSmile_L {smile} cm");
    assert!((jaw - 4.2).abs() < 0.1, "{jaw}");
    assert!((smile - 1.6).abs() < 0.1, "{smile}");

    // All 68 landmarks lie in the face region, which keeps the first 9,409 vertices in
    // order, so their indices are unchanged.
    let lm = kit.landmarks68().unwrap();
    assert_eq!(actor.landmarks.iter().flatten().count(), 68);
    for (a, &b) in actor.landmarks.iter().zip(&lm) {
        assert_eq!(*a, Some(b));
    }
}

#[test]
fn identity_weights_change_the_neutral_not_the_deltas() {
    let Some(kit) = kit() else { return };
    let actor = kit.actor(&[0.0, 1.5], &["jawOpen"], 0..6706).unwrap();
    let d1 = kit.identity_delta(1).unwrap();
    let jaw = kit.expression_delta("jawOpen").unwrap();
    assert_eq!(actor.template.positions.len(), 6_706);
    assert!(actor.source.contains("1:1.5"), "{}", actor.source);
    let mut moved = 0.0f32;
    for v in 0..6706 {
        let n = kit.neutral().positions[v];
        let a = actor.shapes[0][v];
        let off = [a[0] - n[0], a[1] - n[1], a[2] - n[2]];
        for c in 0..3 {
            assert!((off[c] - 1.5 * d1[v][c]).abs() < 1e-4);
            let e = actor.shapes[1][v][c] - a[c];
            assert!((e - jaw[v][c]).abs() < 1e-4);
        }
        moved = moved.max(norm(off));
    }
    eprintln!("identity mode 1 at 1.5 sigma moves the face by up to {moved} cm");
    assert!(moved > 0.1, "{moved}");
}
