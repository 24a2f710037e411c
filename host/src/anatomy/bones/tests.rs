//! The bone fit's tests: the alignment maths on synthetic data, the fit on the real kit.

use super::*;
use crate::geometry::align::{M3, det3, quat_to_mat};
use std::collections::BTreeMap;

use crate::io::data::data_dir;

/// A small deterministic generator in [-1, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
    fn v3(&mut self) -> V3 {
        [self.next(), self.next(), self.next()]
    }
}

fn rotation(axis: V3, angle: f64) -> M3 {
    let [x, y, z] = normalize(axis);
    let (s, c) = ((angle / 2.0).sin(), (angle / 2.0).cos());
    quat_to_mat([c, x * s, y * s, z * s])
}

#[test]
fn similarity_is_recovered_and_proper() {
    let mut g = Lcg(7);
    let r = rotation([0.3, -1.0, 0.5], 2.5);
    let truth = Affine {
        a: r.map(|row| row.map(|v| v * 0.1)),
        t: [1.0, -2.0, 3.0],
    };
    let x: Vec<V3> = (0..20).map(|_| scale(g.v3(), 50.0)).collect();
    let y: Vec<V3> = x.iter().map(|p| truth.apply(*p)).collect();
    let f = fit_similarity(&x, &y, &vec![1.0; x.len()]);
    for i in 0..3 {
        for j in 0..3 {
            assert!((f.a[i][j] - truth.a[i][j]).abs() < 1e-12);
        }
        assert!((f.t[i] - truth.t[i]).abs() < 1e-10);
    }
    assert!(det3(f.a) > 0.0);
    assert!((f.scale() - 0.1).abs() < 1e-12);
    // A mirrored target cannot be matched by a rotation: the fit stays proper.
    let ym: Vec<V3> = y.iter().map(|p| [-p[0], p[1], p[2]]).collect();
    assert!(det3(fit_similarity(&x, &ym, &vec![1.0; x.len()]).a) > 0.0);
}

#[test]
fn affine_is_recovered_and_inverts() {
    let mut g = Lcg(11);
    let truth = Affine {
        a: [[1.1, 0.2, 0.0], [-0.1, 0.9, 0.3], [0.05, 0.0, 1.2]],
        t: [0.5, 0.0, -1.0],
    };
    let x: Vec<V3> = (0..30).map(|_| g.v3()).collect();
    let y: Vec<V3> = x.iter().map(|p| truth.apply(*p)).collect();
    let f = fit_affine(&x, &y, &vec![1.0; x.len()]).unwrap();
    let back = f.inverse().unwrap();
    for p in &x {
        assert!(norm(sub(f.apply(*p), truth.apply(*p))) < 1e-10);
        assert!(norm(sub(back.apply(f.apply(*p)), *p)) < 1e-10);
    }
    // Coplanar points leave the normal direction free: no affine map.
    let flat: Vec<V3> = x.iter().map(|p| [p[0], p[1], 0.0]).collect();
    assert!(fit_affine(&flat, &y, &vec![1.0; x.len()]).is_none());
    let sv = singular_values([[3.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 2.0]]);
    assert!(
        (sv[0] - 3.0).abs() < 1e-12 && (sv[1] - 2.0).abs() < 1e-12 && (sv[2] - 1.0).abs() < 1e-12
    );
}

#[test]
fn grid_nearest_matches_brute_force() {
    let mut g = Lcg(3);
    let pts: Vec<V3> = (0..2000).map(|_| scale(g.v3(), 10.0)).collect();
    let grid = Grid::new(&pts, 0.7);
    for _ in 0..200 {
        let q = scale(g.v3(), 14.0);
        let brute = (0..pts.len())
            .map(|i| (i, norm(sub(pts[i], q))))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
            .unwrap();
        assert_eq!(grid.nearest(&pts, q), Some(brute));
        // The 27-cell search finds the true nearest whenever it is within one cell.
        let near = grid.nearest_where(&pts, q, |_| true);
        if brute.1 < 0.7 {
            assert_eq!(near, Some(brute));
        }
        // A filter is honoured.
        if let Some((i, _)) = grid.nearest_where(&pts, q, |i| i % 2 == 1) {
            assert_eq!(i % 2, 1);
        }
    }
}

/// A flat `n × n` grid of unit quads in the z = 0 plane, normals +z.
fn sheet(n: u32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push([i as f32, j as f32, 0.0]);
        }
    }
    let mut polygons = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let v = j * (n + 1) + i;
            polygons.push(vec![v, v + 1, v + n + 2, v + n + 1]);
        }
    }
    Mesh::new(positions, polygons)
}

#[test]
fn geodesic_patches_split_between_sources() {
    let m = sheet(10);
    let pos: Vec<V3> = m.positions.iter().map(|p| to64(*p)).collect();
    // Sources at (2, 5) and (8, 5), radius 2.5 and 10.
    let labels = geodesic_labels(&m, &pos, &[(5 * 11 + 2, 2.5), (5 * 11 + 8, 10.0)]);
    assert_eq!(labels[5 * 11 + 2], Some(0));
    assert_eq!(labels[5 * 11 + 4], Some(0));
    assert_eq!(labels[5 * 11 + 5], Some(1)); // 3 from source 0 (beyond its radius), 3 from source 1
    assert_eq!(labels[5 * 11], Some(0)); // 2 from source 0
    assert_eq!(labels[8 * 11 + 2], Some(1)); // 3 from source 0 (too far), 9 from source 1
    assert_eq!(labels[0], None); // 7 from source 0, 13 from source 1: beyond both radii
    let comp = components(&m);
    assert!(comp.iter().all(|&c| c == 0));
    let n = oriented_normals(&m, &comp);
    assert!(n.iter().all(|v| v[2].abs() > 0.99));
}

#[test]
fn behind_skin_sees_points_in_front_and_behind() {
    // Skin: a closed cube of side 10 around the origin (6 faces of 2 triangles).
    let p: Vec<[f32; 3]> = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { -5.0 } else { 5.0 },
                if i & 2 == 0 { -5.0 } else { 5.0 },
                if i & 4 == 0 { -5.0 } else { 5.0 },
            ]
        })
        .collect();
    let quads = [
        [0u32, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let skin = Mesh::new(p, quads.iter().map(|q| q.to_vec()).collect());
    let frame = FaceFrame {
        left: [1.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        forward: [0.0, 0.0, 1.0],
    };
    let inside = [[0.0, 0.0, 4.0], [4.0, 0.0, 0.0], [0.0, 4.5, 0.0]];
    let r = behind_skin(&skin, &frame, &inside, 2.0, 0.1);
    assert_eq!(r, BehindSkin { near: 3, behind: 3 });
    let outside = [[0.0, 0.0, 6.0], [-5.5, 1.0, 1.0], [0.0, 0.0, 4.0]];
    let r = behind_skin(&skin, &frame, &outside, 2.0, 0.1);
    assert_eq!(r, BehindSkin { near: 3, behind: 1 });
    // Deep inside (more than near_depth from every face): not near.
    let deep = [[0.0, 0.0, 0.0]];
    assert_eq!(behind_skin(&skin, &frame, &deep, 2.0, 0.1).near, 0);
}

#[test]
fn landmark_file_is_consistent() {
    let s = spec().unwrap();
    let names: Vec<&str> = s.landmarks.iter().map(|l| l.name.as_str()).collect();
    for n in [
        "nasion",
        "menton",
        "zygion_l",
        "zygion_r",
        "pogonion",
        "prosthion",
        "glabella",
        "gonion_l",
        "gonion_r",
    ] {
        assert!(names.contains(&n), "{n} missing");
    }
    for l in &s.landmarks {
        if l.skin.is_some() {
            assert!(l.fstt_mm.is_some_and(|d| d > 0.0 && d < 25.0), "{}", l.name);
        }
        // Cranium landmarks used in the fit must survive the cut.
        if l.template == Template::Cranium && l.skin.is_some() {
            assert!(
                l.position[s.templates.cranium.keep_axis] >= s.templates.cranium.keep_min,
                "{}",
                l.name
            );
        }
    }
    for [c, m] in &s.cranium_registration.pairs {
        assert!(names.contains(&c.as_str()) && names.contains(&m.as_str()));
    }
    let w = s
        .landmarks
        .iter()
        .filter(|l| l.weight.unwrap_or(1.0) > 0.0 && l.skin.is_some());
    assert!(w.count() >= 10);
}

#[test]
fn missing_template_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let e = load_templates(dir.path()).unwrap_err();
    assert!(
        matches!(&e, BonesError::TemplateMissing { path, .. } if path.ends_with("artisynth-jaw/jaw.obj")),
        "{e}"
    );
    // A damaged template is refused by the mesh reader, naming the file.
    std::fs::create_dir_all(dir.path().join("artisynth-jaw")).unwrap();
    std::fs::write(dir.path().join("artisynth-jaw/jaw.obj"), "v 1 2\nf 1 2 3\n").unwrap();
    let e = load_templates(dir.path()).unwrap_err();
    assert!(
        matches!(
            &e,
            BonesError::Mesh(crate::io::mesh::MeshError::Parse { .. })
        ),
        "{e}"
    );
}

#[test]
fn real_ict_fit_places_bones_under_the_skin() {
    let Some(dir) = data_dir() else { return };
    let t0 = std::time::Instant::now();
    let templates = load_templates(&dir).unwrap();
    let reg = templates.cranium_registration;
    println!(
        "templates: jaw {} v, maxilla {} v, cranium {} v; cranium registration {:.2} mm/unit, \
         median {:.2} mm (kept pairs {:.2} mm); {:.1} s",
        templates.jaw.positions.len(),
        templates.maxilla.positions.len(),
        templates.cranium.positions.len(),
        reg.scale,
        reg.median_mm,
        reg.kept_median_mm,
        t0.elapsed().as_secs_f32()
    );
    let kit = crate::io::ict::IctFaceKit::open(&dir.join("ict-facekit")).unwrap();
    let neutral = kit.neutral();
    let ibug: Vec<Option<u32>> = kit.landmarks68().unwrap().into_iter().map(Some).collect();
    let skin = SkinLandmarks::from_ibug68(neutral, &ibug, 10.0).unwrap();
    let fitted = fit(neutral, &skin, &templates).unwrap();
    let rep = &fitted.report;
    println!("fit done at {:.1} s", t0.elapsed().as_secs_f32());
    for g in &rep.groups {
        println!(
            "{:?}: {:?}, scale {:?}, {} targets, {} pairs, median {:.3} cm, rms {:.3} cm, {} its, behind skin {}/{} = {:.3}",
            g.bone,
            g.model,
            g.scale,
            g.targets,
            g.pairs,
            g.median_residual,
            g.rms_residual,
            g.iterations,
            g.behind_skin.behind,
            g.behind_skin.near,
            g.behind_skin.fraction()
        );
    }
    // Constraints of the face region against the fitted bones.
    let face = 0..crate::io::ict::FACE_REGION.end as usize;
    let normals = neutral.vertex_normals();
    let st = fitted.skull.triangles();
    let jt = fitted.jaw.triangles();
    let bones = [
        (Bone::Skull, &fitted.skull.positions[..], &st[..]),
        (Bone::Jaw, &fitted.jaw.positions[..], &jt[..]),
    ];
    let params = crate::anatomy::constraints::ConstraintParams::new(2.5);
    let tc = std::time::Instant::now();
    let c = crate::anatomy::constraints::compute(
        &neutral.positions[face.clone()],
        &normals[face.clone()],
        &bones,
        &params,
    );
    println!(
        "constraints: {} skin vertices x {} bone triangles in {:.2} s (debug build)",
        face.len(),
        st.len() + jt.len(),
        tc.elapsed().as_secs_f32()
    );
    println!(
        "constraint fraction on the ICT face region (max depth 25 mm): {:.3}",
        c.fraction()
    );
    for (depth, min_cos) in [(1.0, 0.3), (1.5, 0.3), (1.5, 0.7), (2.5, 0.3), (2.5, 0.7)] {
        let p = crate::anatomy::constraints::ConstraintParams {
            max_depth: depth,
            min_cos,
        };
        let k = crate::anatomy::constraints::compute(
            &neutral.positions[face.clone()],
            &normals[face.clone()],
            &bones,
            &p,
        );
        let mut eq1: Vec<f32> = k
            .per_vertex
            .iter()
            .zip(&neutral.positions)
            .filter_map(|(c, s)| {
                let r = c.as_ref()?.reconstruct();
                Some(
                    ((r[0] - s[0]).powi(2) + (r[1] - s[1]).powi(2) + (r[2] - s[2]).powi(2)).sqrt()
                        * 10.0,
                )
            })
            .collect();
        eq1.sort_by(f32::total_cmp);
        println!(
            "max depth {} mm, min cos {min_cos}: fraction {:.3}, eq. 1 residual median {:.2} mm, p95 {:.2} mm",
            depth * 10.0,
            k.fraction(),
            eq1[eq1.len() / 2],
            eq1[eq1.len() * 95 / 100]
        );
    }
    println!("landmark | bone | fstt mm | ray mm | fit residual mm | depth mm");
    let mut ray_at = BTreeMap::new();
    for l in &rep.landmarks {
        let ray = c
            .per_vertex
            .get(l.skin_vertex as usize)
            .copied()
            .flatten()
            .map(|k| k.thickness * 10.0);
        ray_at.insert(l.name.clone(), ray);
        println!(
            "{} | {:?} | {:.1} | {} | {:.1} | {:.1}",
            l.name,
            l.bone,
            l.fstt_mm,
            ray.map_or("-".into(), |v| format!("{v:.1}")),
            l.residual * 10.0,
            l.depth_mm
        );
    }
    println!("total {:.1} s", t0.elapsed().as_secs_f32());
    for g in &rep.groups {
        assert!(
            g.behind_skin.near > 1000,
            "{:?}: too few bone vertices near the face",
            g.bone
        );
        assert!(
            g.behind_skin.fraction() >= 0.9,
            "{:?}: {:?}",
            g.bone,
            g.behind_skin
        );
        assert!(
            g.scale.iter().all(|s| (0.8..1.25).contains(s)),
            "{:?} scale {:?}",
            g.bone,
            g.scale
        );
    }
    for (name, want) in [("nasion", 7.0), ("menton", 8.0)] {
        let got = ray_at[name].unwrap_or_else(|| panic!("{name}: no constraint"));
        assert!(
            (got - want).abs() <= 3.0,
            "{name}: ray thickness {got:.1} mm, fstt {want} mm"
        );
    }
    assert!(c.fraction() > 0.1, "constraint fraction {}", c.fraction());
}

#[test]
fn too_few_landmarks_names_the_bone_in_words() {
    let e = BonesError::TooFewLandmarks {
        bone: Bone::Jaw,
        count: 2,
    };
    assert_eq!(
        e.to_string(),
        "only 2 weighted skin landmarks for the jaw; 3 needed"
    );
}

#[test]
fn a_template_is_named_as_the_landmark_file_spells_it() {
    for name in ["jaw", "maxilla", "cranium"] {
        let t: templates::Template = serde_json::from_str(&format!("{name:?}")).unwrap();
        assert_eq!(t.name(), name);
    }
}
