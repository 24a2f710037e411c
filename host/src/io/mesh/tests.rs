//! Tests of [`super`] (mesh), and the small meshes other tests build on.

use super::*;

use crate::io::data::data_dir;

/// A unit quad and a triangle sharing an edge, with a UV seam (5 UVs for 5 corners' worth
/// of distinct coordinates).
fn quad_and_triangle() -> Mesh {
    Mesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.5, 0.25],
        ],
        polygons: vec![vec![0, 1, 2, 3], vec![1, 4, 2]],
        uvs: vec![
            [0.0, 0.0],
            [0.5, 0.0],
            [0.5, 1.0],
            [0.0, 1.0],
            [1.0, 0.5],
            [0.6, 0.1],
        ],
        polygon_uvs: vec![vec![0, 1, 2, 3], vec![5, 4, 2]],
    }
}

/// Per-corner UV values, which survive any re-indexing of the UV list.
fn corner_uvs(m: &Mesh) -> Vec<Vec<[f32; 2]>> {
    m.polygon_uvs
        .iter()
        .map(|p| p.iter().map(|&t| m.uvs[t as usize]).collect())
        .collect()
}

#[test]
fn obj_round_trip_keeps_quads_and_uvs() {
    let dir = tempfile::tempdir().unwrap();
    let m = quad_and_triangle();
    for name in ["m.obj", "m.obj.gz"] {
        let p = dir.path().join(name);
        m.write(&p).unwrap();
        assert_eq!(Mesh::read(&p).unwrap(), m, "{name}");
    }
}

#[test]
fn ply_round_trip_keeps_quads_and_uvs() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.ply");
    let m = quad_and_triangle();
    m.write(&p).unwrap();
    let r = Mesh::read(&p).unwrap();
    assert_eq!(r.positions, m.positions);
    assert_eq!(r.polygons, m.polygons);
    assert_eq!(corner_uvs(&r), corner_uvs(&m));

    // Per-vertex UVs take the vertex s/t path.
    let mut pv = m.clone();
    pv.polygon_uvs.clear();
    pv.uvs = (0..5)
        .map(|i| [i as f32 * 0.25, 1.0 - i as f32 * 0.125])
        .collect();
    pv.write(&p).unwrap();
    assert_eq!(Mesh::read(&p).unwrap(), pv);
}

#[test]
fn reads_ascii_ply_with_double_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.ply");
    std::fs::write(
        &p,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n\
         property double z\nproperty float u\nproperty float v\n\
         element face 1\nproperty list uchar uint vertex_indices\nend_header\n\
         0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0.5 0 1\n4 0 1 2 3\n",
    )
    .unwrap();
    let m = Mesh::read(&p).unwrap();
    assert_eq!(m.positions[3], [0.0, 1.0, 0.5]);
    assert_eq!(m.polygons, vec![vec![0, 1, 2, 3]]);
    assert_eq!(m.uvs[2], [1.0, 1.0]);
    assert!(m.polygon_uvs.is_empty());
}

#[test]
fn obj_reader_handles_groups_negative_indices_and_normals() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("g.obj");
    // Two groups share one vertex list; the second uses a vertex defined before the first
    // group's faces and negative indices. Positions must stay in file order.
    std::fs::write(
        &p,
        "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0 1.0\ng a\nusemtl x\nf 1//1 2//1 3//1\n\
         g b\nv 0 1 0\nvn 0 0 1\nf -4 -2 -1\n",
    )
    .unwrap();
    let m = Mesh::read(&p).unwrap();
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.positions[3], [0.0, 1.0, 0.0]);
    assert_eq!(m.polygons, vec![vec![0, 1, 2], vec![0, 2, 3]]);
    assert!(m.uvs.is_empty() && m.polygon_uvs.is_empty());
}

#[test]
fn malformed_files_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    type Check = fn(&MeshError) -> bool;
    let cases: [(&str, &str, Check); 7] = [
        ("bad_number.obj", "v 0 0 zero\n", |e| {
            matches!(
                e,
                MeshError::Parse {
                    line: Some(1),
                    reason: ParseReason::BadNumber { .. },
                    ..
                }
            )
        }),
        (
            "bad_index.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
            |e| {
                matches!(
                    e,
                    MeshError::Inconsistent {
                        source: InvalidMesh::VertexOutOfRange {
                            polygon: 0,
                            vertex: 8,
                            vertices: 3
                        },
                        ..
                    }
                )
            },
        ),
        ("short_face.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", |e| {
            matches!(
                e,
                MeshError::Parse {
                    line: Some(3),
                    reason: ParseReason::FaceTooSmall { corners: 2 },
                    ..
                }
            )
        }),
        (
            "zero_index.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            |e| {
                matches!(
                    e,
                    MeshError::Parse {
                        line: Some(4),
                        reason: ParseReason::ZeroIndex { what: "vertex" },
                        ..
                    }
                )
            },
        ),
        (
            "garbage.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nend_head",
            |e| {
                matches!(
                    e,
                    MeshError::Parse {
                        line: None,
                        reason: ParseReason::Ply(_),
                        ..
                    }
                )
            },
        ),
        ("notgz.obj.gz", "v 0 0 0\n", |e| {
            matches!(e, MeshError::Gzip { .. })
        }),
        ("mesh.stl", "solid\n", |e| {
            matches!(e, MeshError::UnknownFormat { .. })
        }),
    ];
    for (name, text, check) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let err = Mesh::read(&p).unwrap_err();
        assert!(check(&err), "{name}: {err:?}");
        assert!(err.to_string().contains(name), "{err}");
    }
    let missing = dir.path().join("missing.obj");
    let err = Mesh::read(&missing).unwrap_err();
    assert!(
        matches!(&err, MeshError::Read { path, source }
            if path == &missing && source.kind() == std::io::ErrorKind::NotFound),
        "{err:?}"
    );

    // The chain the binary prints reads file, problem, line, reason.
    let p = dir.path().join("short_face.obj");
    let msg = format!("{:#}", anyhow::Error::from(Mesh::read(&p).unwrap_err()));
    assert_eq!(
        msg,
        format!(
            "{}: not a valid mesh: line 3: face with 2 corners (at least 3 needed)",
            p.display()
        )
    );
}

#[test]
fn inconsistent_meshes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = quad_and_triangle();
    m.positions[2][1] = f32::NAN;
    assert!(matches!(
        m.validate(),
        Err(InvalidMesh::NonFiniteVertex { vertex: 2, .. })
    ));
    let p = dir.path().join("nan.obj");
    assert!(matches!(
        m.write(&p),
        Err(MeshError::WriteInconsistent {
            source: InvalidMesh::NonFiniteVertex { vertex: 2, .. },
            ..
        })
    ));
    assert!(!p.exists());

    let mut m = quad_and_triangle();
    m.polygon_uvs[1].pop();
    assert_eq!(
        m.validate(),
        Err(InvalidMesh::UvCornerCount {
            polygon: 1,
            corners: 3,
            uv_indices: 2
        })
    );
}

#[test]
fn geometry_helpers() {
    let m = quad_and_triangle();
    assert_eq!(
        m.triangles(),
        vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]],
        "fan triangulation keeps orientation"
    );
    assert_eq!(m.bounds(), ([0.0, 0.0, 0.0], [2.0, 1.0, 0.25]));
    // The quad is counter-clockwise seen from +z, so its corners' normals point to +z.
    let n = m.vertex_normals();
    assert_eq!(n[0], [0.0, 0.0, 1.0]);
    assert_eq!(n[3], [0.0, 0.0, 1.0]);
    let len = |v: [f32; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    assert!((len(n[4]) - 1.0).abs() < 1e-6 && n[4][2] > 0.9);

    // Keeping vertices 1, 2, 4 keeps only the triangle, renumbered in order.
    let (sub, old) = m.submesh(|v| v != 0 && v != 3);
    assert_eq!(old, vec![1, 2, 4]);
    assert_eq!(sub.polygons, vec![vec![0, 2, 1]]);
    assert_eq!(sub.positions[2], [2.0, 0.5, 0.25]);
    assert_eq!(corner_uvs(&sub), vec![corner_uvs(&m)[1].clone()]);
    sub.validate().unwrap();

    let moved = m.with_positions(vec![[1.0; 3]; 5]);
    assert_eq!(moved.polygons, m.polygons);
    m.check_same_topology(&moved, Path::new("x.obj")).unwrap();
    let err = m
        .check_same_topology(&sub, Path::new("other.obj"))
        .unwrap_err();
    assert!(
        matches!(&err, MeshError::TopologyCounts {
            path,
            expected_vertices: 5,
            vertices: 3,
            ..
        } if path == Path::new("other.obj")),
        "{err:?}"
    );
    let mut flipped = m.clone();
    flipped.polygons[1].reverse();
    let err = m
        .check_same_topology(&flipped, Path::new("f.obj"))
        .unwrap_err();
    assert!(
        matches!(err, MeshError::TopologyPolygon { polygon: 1, .. }),
        "{err:?}"
    );
}

#[test]
fn ict_neutral_counts_and_expression_topology() {
    let Some(data) = data_dir() else { return };
    let dir = data.join("ict-facekit");
    let t = std::time::Instant::now();
    let neutral = Mesh::read(&dir.join("generic_neutral_mesh.obj")).unwrap();
    eprintln!("ICT neutral read in {:?}", t.elapsed());
    assert_eq!(neutral.positions.len(), 26_719);
    assert_eq!(neutral.polygons.len(), 26_384);
    assert_eq!(neutral.uvs.len(), 28_911);
    assert_eq!(neutral.polygon_uvs.len(), 26_384);
    assert_eq!(
        neutral.polygons.iter().filter(|p| p.len() == 4).count(),
        25_836
    );
    // The first vertex and face of the file, as written there.
    assert_eq!(neutral.positions[0], [0.0, -2.48251, 11.8387]);
    assert_eq!(neutral.polygons[0], vec![873, 11, 870, 872]);
    assert_eq!(neutral.polygon_uvs[0], vec![0, 1, 2, 3]);

    let t = std::time::Instant::now();
    let path = dir.join("expressions/jawOpen.obj.gz");
    let jaw = Mesh::read(&path).unwrap();
    eprintln!("ICT jawOpen.obj.gz read in {:?}", t.elapsed());
    neutral.check_same_topology(&jaw, &path).unwrap();
    assert_ne!(jaw.positions, neutral.positions);

    // Cross-check against tobj, an independent parser: every corner of every polygon must
    // land on the same coordinates (tobj renumbers vertices, so compare through corners).
    let (models, _) = tobj::load_obj(
        dir.join("generic_neutral_mesh.obj"),
        &tobj::LoadOptions {
            single_index: false,
            triangulate: false,
            ..Default::default()
        },
    )
    .unwrap();
    let ours: Vec<[f32; 3]> = neutral
        .polygons
        .iter()
        .flatten()
        .map(|&v| neutral.positions[v as usize])
        .collect();
    let theirs: Vec<[f32; 3]> = models
        .iter()
        .flat_map(|m| {
            m.mesh.indices.iter().map(|&i| {
                let p = &m.mesh.positions[3 * i as usize..3 * i as usize + 3];
                [p[0], p[1], p[2]]
            })
        })
        .collect();
    assert_eq!(ours, theirs);
}
