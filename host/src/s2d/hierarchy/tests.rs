//! Tests of [`super`] (hierarchy).

use super::*;
use crate::io::data::data_dir;
use std::time::Instant;

fn tri_mesh(positions: Vec<[f32; 3]>, faces: &[&[u32]]) -> Mesh {
    Mesh::new(positions, faces.iter().map(|f| f.to_vec()).collect())
}

/// Checks every structural promise of a hierarchy and returns the mean distance of each
/// level's vertices to their up-sampled coarse positions.
fn check(h: &Hierarchy) -> Vec<f64> {
    let mut mean_dist = Vec::new();
    for (i, l) in h.levels.iter().enumerate() {
        let n = l.positions.len();
        assert_eq!(l.spirals.len(), (n + 1) * l.spiral_len, "level {i}");
        for (v, row) in l.spirals.chunks_exact(l.spiral_len).enumerate() {
            assert_eq!(row[0] as usize, v, "level {i}: spiral {v} starts elsewhere");
            assert!(row.iter().all(|&s| s as usize <= n));
            // A real spiral never repeats a vertex; only the padding repeats the dummy.
            let mut real: Vec<u32> = row.iter().copied().filter(|&s| s as usize != n).collect();
            if v < n {
                let len = real.len();
                real.sort_unstable();
                real.dedup();
                assert_eq!(real.len(), len, "level {i}: spiral {v} repeats a vertex");
            }
        }
        assert!(l.triangles.iter().flatten().all(|&v| (v as usize) < n));
        // Every level stays a valid manifold mesh.
        let m = Mesh::new(
            l.positions.clone(),
            l.triangles.iter().map(|t| t.to_vec()).collect(),
        );
        checked_triangles(&m).unwrap_or_else(|e| panic!("level {i}: {e:#}"));
    }
    for (i, (d, u)) in h.down.iter().zip(&h.up).enumerate() {
        let (n, m) = (h.levels[i].positions.len(), h.levels[i + 1].positions.len());
        assert_eq!((d.rows, d.cols), (m + 1, n + 1));
        assert_eq!((u.rows, u.cols), (n + 1, m + 1));
        for r in 0..d.rows {
            let (a, b) = (d.row_ptr[r] as usize, d.row_ptr[r + 1] as usize);
            assert_eq!(b - a, 1, "D{i} row {r}");
            assert_eq!(d.values[a], 1.0);
        }
        assert_eq!(*d.col_idx.last().unwrap() as usize, n);
        let mut selected = vec![u32::MAX; n + 1];
        for (r, &c) in d.col_idx.iter().enumerate() {
            selected[c as usize] = r as u32;
            // Coarse vertex r is fine vertex c.
            if r < m {
                assert_eq!(
                    h.levels[i + 1].positions[r],
                    h.levels[i].positions[c as usize]
                );
            }
        }
        let mut total = 0.0;
        assert_eq!(selected.len(), u.rows);
        for (r, &sel) in selected.iter().enumerate() {
            let (a, b) = (u.row_ptr[r] as usize, u.row_ptr[r + 1] as usize);
            assert!(
                (1..=3).contains(&(b - a)),
                "U{i} row {r} has {} entries",
                b - a
            );
            let sum: f32 = u.values[a..b].iter().sum();
            assert!((sum - 1.0).abs() < 1e-6, "U{i} row {r} sums to {sum}");
            assert!(u.values[a..b].iter().all(|&w| w > 0.0 && w <= 1.0));
            if sel != u32::MAX {
                assert_eq!(&u.col_idx[a..b], &[sel], "U{i} row {r}");
                assert_eq!(u.values[a], 1.0);
            }
            if r < n {
                let mut q = [0.0f64; 3];
                for k in a..b {
                    let p = h.levels[i + 1].positions[u.col_idx[k] as usize];
                    for c in 0..3 {
                        q[c] += f64::from(u.values[k]) * f64::from(p[c]);
                    }
                }
                total += norm2(sub(q, to64(h.levels[i].positions[r]))).sqrt();
            }
        }
        mean_dist.push(total / n as f64);
    }
    mean_dist
}

fn summary(name: &str, unit: &str, h: &Hierarchy, dist: &[f64], seconds: f64) {
    let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
    let lens: Vec<usize> = h.levels.iter().map(|l| l.spiral_len).collect();
    let d: Vec<String> = dist.iter().map(|d| format!("{d:.3e}")).collect();
    eprintln!(
        "{name}: vertices {sizes:?}, spiral lengths {lens:?}, mean |U·x_coarse − x| per \
         level [{}] {unit}, built in {seconds:.2} s",
        d.join(", ")
    );
}

/// FLAME: the reference's level sizes exactly; spiral lengths compared with the reference's
/// `[15, 14, 9, 9, 7]` (see docs/S2D.md for why they differ).
#[test]
fn flame_hierarchy() {
    let Some(dir) = data_dir() else { return };
    let mesh = Mesh::read(&dir.join("flame/FLAME_template.ply")).unwrap();
    let t = Instant::now();
    let h = build(&mesh, &DEFAULT_FACTORS).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
    assert_eq!(sizes, [5023, 1256, 314, 79, 20]);
    let dist = check(&h);
    summary("FLAME", "m", &h, &dist, seconds);
    // FLAME is in metres: the 5023 → 1256 up-sampling stays well under a millimetre on
    // average, the coarsest levels within a few centimetres.
    assert!(dist[0] < 1e-3, "{dist:?}");
    assert!(dist.iter().all(|&d| d < 0.02), "{dist:?}");
    let lens: Vec<usize> = h.levels.iter().map(|l| l.spiral_len).collect();
    assert_eq!(lens, FLAME_SPIRAL_LENGTHS);

    // Byte-identical when built again, and read back unchanged.
    let config = Config::default();
    let key = cache_key(&mesh, &config);
    let bytes = to_bytes(&h, key, &config).unwrap();
    let again = to_bytes(&build(&mesh, &DEFAULT_FACTORS).unwrap(), key, &config).unwrap();
    assert!(bytes == again, "two builds differ");
    assert_eq!(from_bytes(&bytes).unwrap(), h);

    // Pinned to the reference's lengths, the spirals give the reference network's shapes.
    let pinned = Config::reference_flame();
    let hp = build_with(&mesh, &pinned).unwrap();
    check(&hp);
    let lens: Vec<usize> = hp.levels.iter().map(|l| l.spiral_len).collect();
    assert_eq!(lens, spirals::REFERENCE_FLAME_LENGTHS);
    assert_eq!(hp.up, h.up);
    assert!(matches!(
        build_with(
            &mesh,
            &Config {
                spiral_lengths: Some(vec![9; 4]),
                ..pinned
            }
        ),
        Err(BuildError::SpiralLengths { levels: 5, .. })
    ));
}

/// Spiral lengths Sinew's construction gives on FLAME (reference: `[15, 14, 9, 9, 7]`).
const FLAME_SPIRAL_LENGTHS: [usize; 5] = [15, 13, 9, 9, 7];

#[test]
fn ict_face_region_hierarchy() {
    let Some(dir) = data_dir() else { return };
    let full = Mesh::read(&dir.join("ict-facekit/generic_neutral_mesh.obj")).unwrap();
    let region = crate::io::ict::FACE_REGION;
    let (mesh, _) = full.submesh(|v| region.contains(&v));
    let t = Instant::now();
    let h = build(&mesh, &DEFAULT_FACTORS).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    let n = mesh.positions.len();
    let mut expect = vec![n];
    for _ in 0..4 {
        expect.push(expect.last().unwrap().div_ceil(4));
    }
    let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
    assert_eq!(sizes, expect);
    let dist = check(&h);
    summary("ICT face region", "cm", &h, &dist, seconds);
    // ICT-FaceKit is in centimetres.
    assert!(dist[0] < 0.1, "{dist:?}");
}

#[test]
fn cache_builds_once_and_reads_back() {
    let Some(dir) = data_dir() else { return };
    let mesh = Mesh::read(&dir.join("flame/FLAME_template.ply")).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let factors = [4, 4];
    let config = Config {
        factors: factors.to_vec(),
        spiral_lengths: None,
    };
    let h = cached(&mesh, &factors, tmp.path()).unwrap();
    let path = cache_path(&mesh, &config, tmp.path());
    let written = std::fs::read(&path).unwrap();
    let again = cached(&mesh, &factors, tmp.path()).unwrap();
    assert_eq!(h, again);
    assert_eq!(std::fs::read(&path).unwrap(), written);
    // A different factor list is a different entry; a corrupt entry is rebuilt.
    let other = Config {
        factors: vec![4, 3],
        spiral_lengths: None,
    };
    assert_ne!(cache_path(&mesh, &other, tmp.path()), path);
    let other = Config {
        spiral_lengths: Some(vec![9, 9, 9]),
        ..config
    };
    assert_ne!(cache_path(&mesh, &other, tmp.path()), path);
    std::fs::write(&path, b"garbage").unwrap();
    assert_eq!(cached(&mesh, &factors, tmp.path()).unwrap(), h);
    assert_eq!(std::fs::read(&path).unwrap(), written);
}

/// A `k × k` grid of unit squares split into triangles, counter-clockwise seen from +z.
fn grid(k: u32) -> Mesh {
    let mut positions = Vec::new();
    for y in 0..=k {
        for x in 0..=k {
            // A small bump so that the quadrics are not all zero.
            let z = ((x * 7 + y * 3) % 5) as f32 * 0.01;
            positions.push([x as f32, y as f32, z]);
        }
    }
    let id = |x: u32, y: u32| y * (k + 1) + x;
    let mut polygons = Vec::new();
    for y in 0..k {
        for x in 0..k {
            polygons.push(vec![id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)]);
        }
    }
    Mesh::new(positions, polygons)
}

#[test]
fn quad_grid_decimates_and_keeps_its_border() {
    let mesh = grid(12);
    let h = build(&mesh, &[4, 4]).unwrap();
    let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
    assert_eq!(sizes, [169, 43, 11]);
    check(&h);
    // The four corners survive every level: moving one would cost a boundary plane.
    let corners = [[0.0, 0.0], [12.0, 0.0], [0.0, 12.0], [12.0, 12.0]];
    for l in &h.levels {
        for c in corners {
            assert!(l.positions.iter().any(|p| p[0] == c[0] && p[1] == c[1]));
        }
    }
}

#[test]
fn sections_round_trip_and_bad_ones_are_named() {
    let h = build(&grid(8), &[4, 4]).unwrap();
    let config = Config {
        factors: vec![4, 4],
        spiral_lengths: Some(vec![7, 6, 5]),
    };
    let bytes = to_bytes(&h, 7, &config).unwrap();
    assert_eq!(from_bytes(&bytes).unwrap(), h);
    let f = SinewFile::from_bytes(&bytes).unwrap();
    assert_eq!(f.metadata().get("key"), Some("0000000000000007"));
    assert_eq!(f.metadata().get("factors"), Some("4,4"));
    assert_eq!(f.metadata().get("spiral_lengths"), Some("7,6,5"));

    let rewrite = |h: &Hierarchy| {
        let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
        write_sections(h, &mut w, "s2d", Sections::All).unwrap();
        from_bytes(&w.to_bytes().unwrap()).unwrap_err()
    };
    let mut bad = h.clone();
    bad.levels[1].spirals[0] = 1000;
    let e = rewrite(&bad);
    assert!(
        matches!(&e, SectionError::Format { name, .. } if name == "s2d.h1.spiral"),
        "{e:?}"
    );
    let mut bad = h.clone();
    bad.up[0].col_idx[0] = 1000;
    let e = rewrite(&bad);
    assert!(
        matches!(&e, SectionError::Format { name, .. } if name == "s2d.u0"),
        "{e:?}"
    );
    let mut bad = h.clone();
    bad.levels[0].triangles[0][0] = 1000;
    let e = rewrite(&bad);
    assert!(
        matches!(&e, SectionError::VertexIndex { name } if name == "s2d.h0.tri"),
        "{e:?}"
    );
    let damaged = to_bytes(&h, 7, &config).unwrap();
    assert!(matches!(
        from_bytes(&damaged[..damaged.len() / 2]),
        Err(SectionError::NotASinewFile(_))
    ));
}

#[test]
fn rejects_bad_meshes_naming_the_culprit() {
    let err = |m: &Mesh| match build(m, &DEFAULT_FACTORS) {
        Err(BuildError::Surface(e)) => e,
        other => panic!("{other:?}"),
    };
    let p = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    assert_eq!(err(&Mesh::default()), SurfaceError::NoVertices);
    assert_eq!(err(&tri_mesh(p.clone(), &[])), SurfaceError::NoFaces);
    // Three triangles on edge (0, 1).
    let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[1, 0, 3], &[0, 1, 4]]));
    assert!(
        matches!(&e, SurfaceError::NonManifoldEdge { edge: (0, 1), faces } if faces.len() == 3),
        "{e:?}"
    );
    let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[0, 1, 3]]));
    assert_eq!(
        e,
        SurfaceError::Orientation {
            faces: (0, 1),
            edge: (0, 1)
        }
    );
    let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[0, 1, 1]]));
    assert_eq!(e, SurfaceError::RepeatedVertex { face: 1, vertex: 1 });
    let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[0, 2, 7]]));
    assert_eq!(
        e,
        SurfaceError::VertexIndex {
            face: 1,
            vertex: 7,
            vertices: 5
        }
    );
    // Vertex 3 lies on the line through 0 and 1.
    let mut q = p.clone();
    q[3] = [2.0, 0.0, 0.0];
    let e = err(&tri_mesh(q, &[&[0, 2, 1], &[0, 1, 3]]));
    assert!(matches!(e, SurfaceError::ZeroArea { face: 1, .. }), "{e:?}");
    let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[1, 0, 3]]));
    assert_eq!(e, SurfaceError::IsolatedVertex { vertex: 4 });
    // Two fans meeting only at vertex 0 (a bow tie).
    let bow = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 0.0, 0.0],
        [-1.0, -1.0, 0.0],
    ];
    let e = err(&tri_mesh(bow, &[&[0, 1, 2], &[0, 3, 4]]));
    assert!(
        matches!(e, SurfaceError::NonManifoldVertex { vertex: 0, .. }),
        "{e:?}"
    );
    // A single triangle cannot lose a vertex.
    let e = build(&tri_mesh(p[..3].to_vec(), &[&[0, 1, 2]]), &DEFAULT_FACTORS).unwrap_err();
    assert!(matches!(e, BuildError::Decimate { level: 0, .. }), "{e:?}");
    assert!(matches!(
        build(&grid(3), &[1]),
        Err(BuildError::Factor {
            index: 0,
            factor: 1
        })
    ));
}

fn print_statistics(name: &str, mesh: &crate::io::mesh::Mesh) {
    use super::super::spirals::{dilate, natural, reference_schedule};
    let h = build(mesh, &DEFAULT_FACTORS).unwrap();
    for (i, (l, (steps, dil))) in h.levels.iter().zip(reference_schedule(5)).enumerate() {
        let lens: Vec<f64> = natural(&l.positions, &l.triangles, steps)
            .unwrap()
            .iter()
            .map(|s| dilate(s, dil).len() as f64)
            .collect();
        let n = lens.len() as f64;
        let mean = lens.iter().sum::<f64>() / n;
        let std = (lens.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        eprintln!(
            "{name} level {i}: {} vertices, dilated natural length mean {mean:.3} std \
             {std:.3} → mean + 2 std = {:.3}",
            l.positions.len(),
            mean + 2.0 * std
        );
    }
}

/// The statistics behind the spiral lengths on FLAME and the ICT face region (printed for
/// docs/S2D.md).
#[test]
fn spiral_statistics_on_real_meshes() {
    let Some(dir) = crate::io::data::data_dir() else {
        return;
    };
    let flame = crate::io::mesh::Mesh::read(&dir.join("flame/FLAME_template.ply")).unwrap();
    print_statistics("FLAME", &flame);
    let ict =
        crate::io::mesh::Mesh::read(&dir.join("ict-facekit/generic_neutral_mesh.obj")).unwrap();
    let region = crate::io::ict::FACE_REGION;
    let (face, _) = ict.submesh(|v| region.contains(&v));
    print_statistics("ICT face region", &face);
}

#[test]
fn a_missing_or_broken_template_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let config = Config {
        factors: vec![4],
        spiral_lengths: None,
    };
    let out = dir.path().join("h.sinew");
    let missing = dir.path().join("missing.obj");
    let e = s2d_hierarchy(&missing, &out, &config).unwrap_err();
    assert!(matches!(e, HierarchyError::Mesh(_)), "{e:?}");
    assert!(e.to_string().contains("missing.obj"), "{e}");
    // Two triangles on the same three vertices: read, then refused by name.
    let twice = dir.path().join("twice.obj");
    std::fs::write(&twice, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3\n").unwrap();
    let e = s2d_hierarchy(&twice, &out, &config).unwrap_err();
    assert!(
        matches!(&e, HierarchyError::BuildFile { path, source: BuildError::Surface(_) } if *path == twice),
        "{e:?}"
    );
    assert!(!out.exists());
}
