use serde::Deserialize;

use super::*;
use crate::io::container::SinewWriter;

#[derive(Serialize, Deserialize)]
struct TestManifest {
    format: String,
    version: u32,
}

impl Versioned for TestManifest {
    fn format_version(&self) -> (&str, u32) {
        (&self.format, self.version)
    }
}

const LAYOUT: Layout = Layout {
    manifest: "manifest.json",
    data: "numbers.sinew",
    what: "a test manifest",
    format: "test-set",
    version: 1,
};

fn manifest(version: u32) -> TestManifest {
    TestManifest {
        format: "test-set".into(),
        version,
    }
}

/// A one-triangle template under `t.` with the given `content` and triangle.
fn numbers(content: &str, tri: [u32; 3]) -> Result<Vec<u8>, WriterError> {
    let mut w = SinewWriter::new(ArtifactKind::Performance);
    w.meta("content", content);
    w.f32s("t.template", &[3, 3], &[0., 0., 0., 1., 0., 0., 0., 1., 0.])?;
    w.u32s("t.tri", &[1, 3], &tri)?;
    w.to_bytes()
}

fn read_set(dir: &Path, rule: Option<ManifestProblem>) -> Result<Mesh, DataSetError> {
    read(
        dir,
        &LAYOUT,
        |_: &TestManifest| rule.map_or(Ok(()), Err),
        |_, (), bytes| Sections::open(bytes, ArtifactKind::Performance, "test")?.template("t", 3),
    )
}

/// Without the published data: a set round-trips, and each fault is refused as its own variant
/// with the file it is about.
#[test]
fn a_set_round_trips_and_each_fault_is_its_variant() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let e = read_set(dir, None).unwrap_err();
    assert!(
        matches!(&e, DataSetError::ManifestRead { path, .. } if path.ends_with("manifest.json")),
        "{e:?}"
    );

    write(dir, &LAYOUT, numbers("test", [0, 1, 2]), &manifest(1)).unwrap();
    let mesh = read_set(dir, None).unwrap();
    assert_eq!(mesh.positions, [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
    assert_eq!(mesh.polygons, [vec![0, 1, 2]]);

    let rule = ManifestProblem::NoGroup {
        name: "jawOpen".into(),
    };
    let e = read_set(dir, Some(rule.clone())).unwrap_err();
    assert!(
        matches!(&e, DataSetError::Manifest { path, source } if path.ends_with("manifest.json") && *source == rule),
        "{e:?}"
    );

    write(dir, &LAYOUT, numbers("test", [0, 1, 2]), &manifest(2)).unwrap();
    let e = read_set(dir, None).unwrap_err();
    assert!(
        matches!(
            e,
            DataSetError::ManifestVersion {
                version: 2,
                expected_version: 1,
                ..
            }
        ),
        "{e:?}"
    );

    write(dir, &LAYOUT, numbers("other", [0, 1, 2]), &manifest(1)).unwrap();
    let e = read_set(dir, None).unwrap_err();
    assert!(
        matches!(&e, DataSetError::Contents { path, source: ContentError::Content { expected: "test", found: Some(found) } }
            if path.ends_with("numbers.sinew") && found == "other"),
        "{e:?}"
    );
    let DataSetError::Contents { source, .. } = &e else {
        unreachable!()
    };
    assert_eq!(
        source.to_string(),
        "not test data (its metadata says content=other)"
    );

    write(dir, &LAYOUT, numbers("test", [0, 1, 3]), &manifest(1)).unwrap();
    let e = read_set(dir, None).unwrap_err();
    assert!(
        matches!(&e, DataSetError::Contents { source: ContentError::VertexIndex { name }, .. } if name == "t.tri"),
        "{e:?}"
    );

    std::fs::write(dir.join("numbers.sinew"), b"not a sinew file").unwrap();
    let e = read_set(dir, None).unwrap_err();
    assert!(
        matches!(&e, DataSetError::Data(ContainerError::Invalid { path, .. }) if path.ends_with("numbers.sinew")),
        "{e:?}"
    );

    std::fs::write(dir.join("manifest.json"), b"{").unwrap();
    let e = read_set(dir, None).unwrap_err();
    assert!(
        matches!(
            e,
            DataSetError::ManifestJson {
                what: "a test manifest",
                ..
            }
        ),
        "{e:?}"
    );

    let bad = Err(WriterError::BadName {
        name: String::new(),
    });
    let e = write(dir, &LAYOUT, bad, &manifest(1)).unwrap_err();
    assert!(
        matches!(&e, DataSetError::Encode { path, .. } if path.ends_with("numbers.sinew")),
        "{e:?}"
    );
    assert_eq!(count(7).unwrap(), 7);
}
