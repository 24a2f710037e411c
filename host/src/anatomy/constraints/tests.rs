//! Tests of [`super`] (constraints).

use super::*;

/// Positions, triangles, normals.
type Soup = (Vec<[f32; 3]>, Vec<[u32; 3]>, Vec<[f32; 3]>);

/// A UV sphere: positions, triangles (outward winding), outward normals.
fn sphere(r: f32, rings: u32, segs: u32, center: [f32; 3]) -> Soup {
    let mut p = vec![[center[0], center[1], center[2] + r]];
    let mut n = vec![[0.0, 0.0, 1.0]];
    for i in 1..rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segs {
            let ph = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
            let u = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            n.push(u);
            p.push([
                center[0] + r * u[0],
                center[1] + r * u[1],
                center[2] + r * u[2],
            ]);
        }
    }
    p.push([center[0], center[1], center[2] - r]);
    n.push([0.0, 0.0, -1.0]);
    let south = (p.len() - 1) as u32;
    let ring = |i: u32, j: u32| 1 + (i - 1) * segs + (j % segs);
    let mut t = Vec::new();
    for j in 0..segs {
        t.push([0, ring(1, j), ring(1, j + 1)]);
        t.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segs {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            t.push([a, c, d]);
            t.push([a, d, b]);
        }
    }
    (p, t, n)
}

fn len(a: [f32; 3]) -> f32 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

#[test]
fn sphere_in_sphere_constrains_every_vertex() {
    let (skin, _, normals) = sphere(10.0, 24, 48, [0.0; 3]);
    let (bp, bt, _) = sphere(8.0, 60, 120, [0.0; 3]);
    let c = compute(
        &skin,
        &normals,
        &[(Bone::Skull, &bp, &bt)],
        &ConstraintParams::new(5.0),
    );
    assert_eq!(c.per_vertex.len(), skin.len());
    assert_eq!(c.count(), skin.len());
    assert_eq!(c.fraction(), 1.0);
    assert_eq!(c.skipped_triangles, 0);
    for (s, k) in skin.iter().zip(&c.per_vertex) {
        let k = k.unwrap();
        // The inner sphere is faceted: its flat triangles lie up to r(1 - cos(π/60)) ≈ 0.011
        // inside the true sphere.
        assert!(
            (k.thickness - 2.0).abs() < 0.02,
            "thickness {}",
            k.thickness
        );
        assert!((len(k.bone_point) - 8.0).abs() < 0.02);
        let radial = [s[0] / 10.0, s[1] / 10.0, s[2] / 10.0];
        let cos = k.normal[0] * radial[0] + k.normal[1] * radial[1] + k.normal[2] * radial[2];
        assert!(cos > 0.995, "normal not radial: cos {cos}");
        let r = k.reconstruct();
        assert!(len([r[0] - s[0], r[1] - s[1], r[2] - s[2]]) < 0.2);
        assert_eq!(k.bone, Bone::Skull);
    }
}

#[test]
fn normal_faces_skin_whatever_the_winding() {
    let (skin, _, normals) = sphere(10.0, 8, 16, [0.0; 3]);
    let (bp, bt, _) = sphere(8.0, 16, 32, [0.0; 3]);
    let flipped: Vec<[u32; 3]> = bt.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let p = ConstraintParams::new(5.0);
    let a = compute(&skin, &normals, &[(Bone::Jaw, &bp, &bt)], &p);
    let b = compute(&skin, &normals, &[(Bone::Jaw, &bp, &flipped)], &p);
    assert_eq!(a.count(), skin.len());
    assert_eq!(b.count(), skin.len());
    for ((s, ka), kb) in skin.iter().zip(&a.per_vertex).zip(&b.per_vertex) {
        // Rays through shared edges may pick a different (equally near) neighbour, so
        // compare what is well defined: depth, bone, and that the normal faces the skin.
        let (ka, kb) = (ka.unwrap(), kb.unwrap());
        assert!((ka.thickness - kb.thickness).abs() < 1e-5);
        assert_eq!((ka.bone, kb.bone), (Bone::Jaw, Bone::Jaw));
        for k in [ka, kb] {
            let to_skin = [
                s[0] - k.bone_point[0],
                s[1] - k.bone_point[1],
                s[2] - k.bone_point[2],
            ];
            let cos =
                (k.normal[0] * to_skin[0] + k.normal[1] * to_skin[1] + k.normal[2] * to_skin[2])
                    / len(to_skin);
            assert!(cos > 0.9, "normal does not face the skin: cos {cos}");
        }
    }
}

#[test]
fn max_depth_excludes_deep_bone() {
    let (skin, _, normals) = sphere(10.0, 8, 16, [0.0; 3]);
    let (bp, bt, _) = sphere(8.0, 16, 32, [0.0; 3]);
    let c = compute(
        &skin,
        &normals,
        &[(Bone::Skull, &bp, &bt)],
        &ConstraintParams::new(1.5),
    );
    assert_eq!(c.count(), 0);
    assert_eq!(c.fraction(), 0.0);
}

#[test]
fn nearest_of_two_bones_wins() {
    // Two parallel plates under a skin point: the nearer one (the jaw) must be reported.
    let plate = |z: f32| {
        (
            vec![
                [-1.0, -1.0, z],
                [1.0, -1.0, z],
                [1.0, 1.0, z],
                [-1.0, 1.0, z],
            ],
            vec![[0u32, 1, 2], [0, 2, 3]],
        )
    };
    let (p1, t1) = plate(-3.0);
    let (p2, t2) = plate(-1.0);
    let skin = [[0.1f32, 0.2, 0.0]];
    let up = [[0.0f32, 0.0, 2.0]];
    let bones = [
        (Bone::Skull, &p1[..], &t1[..]),
        (Bone::Jaw, &p2[..], &t2[..]),
    ];
    let c = compute(&skin, &up, &bones, &ConstraintParams::new(10.0));
    let k = c.per_vertex[0].unwrap();
    assert_eq!(k.bone, Bone::Jaw);
    assert!((k.thickness - 1.0).abs() < 1e-6);
    assert_eq!(k.normal, [0.0, 0.0, 1.0]);
    assert_eq!(k.bone_point, [0.1, 0.2, -1.0]);
}

#[test]
fn grazing_hits_are_rejected() {
    // A plate tilted 80° from horizontal under a skin point whose normal is +z: the ray meets
    // it at |cos| = cos(80°) ≈ 0.17, below the default bound but above a looser one.
    let a = 80f32.to_radians();
    let (c, s) = (a.cos(), a.sin());
    // Plane through (0, 0, -1) with normal (s, 0, c) rotated from +z about y.
    let q = |u: f32, v: f32| [u * c, v, -1.0 - u * s];
    let pos = [q(-5.0, -5.0), q(5.0, -5.0), q(5.0, 5.0), q(-5.0, 5.0)];
    let tris = [[0u32, 1, 2], [0, 2, 3]];
    let skin = [[0.0f32, 0.0, 0.0]];
    let up = [[0.0f32, 0.0, 1.0]];
    let bones = [(Bone::Skull, &pos[..], &tris[..])];
    let strict = compute(&skin, &up, &bones, &ConstraintParams::new(10.0));
    assert_eq!(strict.count(), 0);
    let loose = compute(
        &skin,
        &up,
        &bones,
        &ConstraintParams {
            max_depth: 10.0,
            min_cos: 0.1,
        },
    );
    let k = loose.per_vertex[0].unwrap();
    assert!((k.thickness - 1.0).abs() < 1e-5);
    assert!((k.normal[2] - c).abs() < 1e-5 && k.normal[0] > 0.0);
}

#[test]
fn bad_input_is_skipped_not_fatal() {
    let pos = vec![[0.0f32, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]];
    let tris = vec![[0u32, 1, 2], [0, 1, 7], [0, 0, 1]];
    let skin = [[0.2f32, 0.2, 0.0], [f32::NAN, 0.0, 0.0], [0.2, 0.2, 0.0]];
    let normals = [[0.0f32, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]];
    let c = compute(
        &skin,
        &normals[..2],
        &[(Bone::Skull, &pos, &tris)],
        &ConstraintParams::new(5.0),
    );
    assert_eq!(c.skipped_triangles, 2);
    assert!(c.per_vertex[0].is_some());
    assert!(c.per_vertex[1].is_none() && c.per_vertex[2].is_none());
    assert_eq!(c.fraction_of([0, 1, 99]), 1.0 / 3.0);
}

#[test]
fn threaded_matches_sequential_and_brute_force() {
    // Enough vertices to use the threads; compare with a brute-force loop over triangles.
    let (skin, _, normals) = sphere(10.0, 40, 40, [0.3, -0.2, 0.1]);
    let (bp, bt, _) = sphere(8.0, 12, 20, [0.0; 3]);
    let p = ConstraintParams::new(4.0);
    let c = compute(&skin, &normals, &[(Bone::Skull, &bp, &bt)], &p);
    assert!(skin.len() >= 512);
    let (scene, _) = Scene::build(&[(Bone::Skull, &bp, &bt)]);
    for (i, s) in skin.iter().enumerate() {
        let m = to64(normals[i]);
        let d = [-m[0] / norm(m), -m[1] / norm(m), -m[2] / norm(m)];
        let brute = scene
            .tris
            .iter()
            .filter_map(|t| intersect(t, to64(*s), d))
            .filter(|&t| t <= 4.0)
            .fold(f64::INFINITY, f64::min);
        match c.per_vertex[i] {
            Some(k) => assert!((k.thickness as f64 - brute).abs() < 1e-5),
            None => assert!(brute.is_infinite() || brute > 0.0),
        }
    }
    assert_eq!(c.fraction(), 1.0);
}
