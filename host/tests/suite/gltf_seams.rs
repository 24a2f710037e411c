//! Texture coordinates in the glTF export: a kit actor's recorded at bake time (metadata `uv`),
//! a rig actor's per corner (an OBJ rig's `vt`), and the kit's carried onto the golden actor, each
//! split at seams with the morph targets and skin duplicated to match, read back from the `.glb`.

use crate::common::gltf::{Gltf, axis_angle, golden, pose_gltf};
use crate::common::procedural_actor;
use gltf_json as json;
use sinew_core::aim::AimActor;
use sinew_host::aim::play::Frame;
use sinew_host::export::gltf::{Options, glb};
use sinew_host::training::tolerance::GLTF_RIG;

/// The procedural face with texture coordinates per corner: a planar map whose right half lies
/// half a sheet over, so the polygons along the middle meet at a seam (their shared vertices have
/// two coordinates).
fn seamed(mesh: &mut sinew_host::io::mesh::Mesh) {
    let (lo, hi) = mesh.bounds();
    let mid = 0.5 * (lo[0] + hi[0]);
    let mut uvs = Vec::new();
    let mut corners = Vec::new();
    for poly in &mesh.polygons {
        let right = poly
            .iter()
            .map(|&v| mesh.positions[v as usize][0])
            .sum::<f32>()
            > mid * poly.len() as f32;
        corners.push(
            poly.iter()
                .map(|&v| {
                    let p = mesh.positions[v as usize];
                    let u = 0.5 * (p[0] - lo[0]) / (hi[0] - lo[0]);
                    uvs.push([
                        u + if right { 0.5 } else { 0.0 },
                        (p[1] - lo[1]) / (hi[1] - lo[1]),
                    ]);
                    (uvs.len() - 1) as u32
                })
                .collect(),
        );
    }
    mesh.uvs = uvs;
    mesh.polygon_uvs = corners;
}

/// Checks an export split at seams against the mesh it came from: `corners` (per exported
/// triangle corner, in the export's order) the vertex of the source mesh and its coordinate, and
/// `points` that mesh's rest positions in metres. Every corner shows its own coordinate (no
/// triangle smeared across the seam), and a seam copy carries its vertex's position, normal,
/// morph targets and skin. Returns the number of seam copies.
fn check_split(g: &Gltf, corners: &[(u32, [f32; 2])], points: &[[f32; 3]]) -> usize {
    use json::mesh::Semantic;
    let prim = g.face();
    let indices = g.accessor(prim.indices.unwrap());
    assert_eq!(indices.len(), corners.len());
    let uv = g.attribute(Semantic::TexCoords(0));
    let pos = g.attribute(Semantic::Positions);
    let n = pos.len() / 3;
    assert_eq!(uv.len(), 2 * n);
    let mut source = vec![None; n];
    for (k, (&i, &(v, want))) in indices.iter().zip(corners).enumerate() {
        let i = i as usize;
        assert_eq!([uv[2 * i] as f32, uv[2 * i + 1] as f32], want, "corner {k}");
        assert!(
            *source[i].get_or_insert(v) == v,
            "exported vertex {i} shows two vertices"
        );
    }
    let original = points.len();
    for (i, s) in source.iter().enumerate() {
        let Some(s) = *s else { continue };
        let s = s as usize;
        for c in 0..3 {
            assert!(
                (pos[3 * i + c] - f64::from(points[s][c])).abs() < 1e-6,
                "vertex {i} stands where vertex {s} does"
            );
        }
        if i >= original {
            let same =
                |a: &[f64], w: usize| assert_eq!(a[w * i..w * (i + 1)], a[w * s..w * (s + 1)]);
            same(&g.attribute(Semantic::Normals), 3);
            same(&g.attribute(Semantic::Joints(0)), 4);
            same(&g.attribute(Semantic::Weights(0)), 4);
            for t in prim.targets.as_ref().unwrap() {
                same(&g.accessor(t.positions.unwrap()), 3);
                same(&g.accessor(t.normals.unwrap()), 3);
            }
        } else {
            assert_eq!(i, s, "vertex {i} keeps its index");
        }
    }
    n - original
}

/// A kit-style actor baked on a template with coordinates records them (metadata `uv`), and its
/// export splits the vertices along the seam.
#[test]
fn a_kit_actors_coordinates_are_recorded_at_bake_and_split_at_seams() {
    let mut set = sinew_host::aim::testing::procedural_training_set(8);
    seamed(&mut set.template);
    let triangles = set.template.triangles();
    let metadata: Vec<(String, String)> =
        sinew_host::aim::bake::uv_metadata(&[], &set.template, &triangles, None)
            .unwrap()
            .into_iter()
            .chain([("units".to_string(), "cm".to_string())])
            .collect();
    let bytes = procedural_actor(&set, metadata);
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let (file, summary) = glb(&actor, &frames_of(&actor), &Options::default()).unwrap();
    let g = Gltf::parse(&file);
    let uvs = sinew_host::geometry::uv::CornerUvs::of_mesh(&set.template).unwrap();
    let corners: Vec<(u32, [f32; 2])> = triangles
        .iter()
        .flatten()
        .zip(&uvs.corners)
        .map(|(&v, &c)| (v, uvs.uvs[c as usize]))
        .collect();
    let metres: Vec<[f32; 3]> = rest(&actor).iter().map(|p| p.map(|x| x * 0.01)).collect();
    let copies = check_split(&g, &corners, &metres);
    assert_eq!(copies, summary.seam_copies);
    assert!(summary.texture_coordinates);
    // One column of vertices (the middle, top to bottom) is split.
    assert_eq!(copies, 8, "{summary:?}");
    posed_as_the_core(&g, &actor, &corners);
}

/// An actor learned from an OBJ rig (texture coordinates per corner, vertices shared across the
/// seam) is exported on the rig's vertices, split where its corners disagree.
#[test]
fn a_rig_actors_corner_coordinates_are_split_at_seams() {
    use sinew_host::rig::record::Record;
    let mut set = sinew_host::aim::testing::procedural_training_set(8);
    seamed(&mut set.template);
    let v = set.template.positions.len();
    // The rig holds its vertices in reverse order, in millimetres, z up and y back.
    let welded: Vec<u32> = (0..v as u32).rev().collect();
    let unweld = |p: &Vec<u32>| p.iter().map(|&a| (v - 1) as u32 - a).collect::<Vec<u32>>();
    let record = Record {
        format: "obj".into(),
        mesh: "neutral".into(),
        units: "mm".parse().unwrap(),
        up: "+z".parse().unwrap(),
        forward: "-y".parse().unwrap(),
        node_transform: sinew_host::io::rig::IDENTITY,
        placement: sinew_host::io::rig::IDENTITY,
        welded: welded.clone(),
        polygons: set.template.polygons.iter().map(unweld).collect(),
        uvs: set.template.uvs.clone(),
        polygon_uvs: set.template.polygon_uvs.clone(),
    };
    let metadata = vec![
        ("units".to_string(), "cm".to_string()),
        (
            sinew_host::rig::record::KEY.to_string(),
            serde_json::to_string(&record).unwrap(),
        ),
    ];
    let bytes = procedural_actor(&set, metadata);
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let (file, summary) = glb(&actor, &[], &Options::default()).unwrap();
    let g = Gltf::parse(&file);
    let rig_mesh = record.mesh(&rest(&actor));
    let uvs = sinew_host::geometry::uv::CornerUvs::of_mesh(&rig_mesh).unwrap();
    let corners: Vec<(u32, [f32; 2])> = rig_mesh
        .triangles()
        .iter()
        .flatten()
        .zip(&uvs.corners)
        .map(|(&r, &c)| (r, uvs.uvs[c as usize]))
        .collect();
    // The rig's frame, metres: x stays, y is −z of the face, z is y, from millimetres.
    let metres: Vec<[f32; 3]> = rig_mesh
        .positions
        .iter()
        .map(|p| p.map(|x| x * 0.001))
        .collect();
    let copies = check_split(&g, &corners, &metres);
    assert_eq!((copies, summary.seam_copies), (8, 8), "{summary:?}");
    assert_eq!(summary.vertices, v + 8);
}

/// The actor's rest skin s0 (the exported base mesh, in actor units).
fn rest(actor: &AimActor<'_>) -> Vec<[f32; 3]> {
    sinew_host::io::mesh::points(actor.rest().iter())
}

/// Frames for an untrained actor: its coefficients on steps, the head turning. The jaw stays
/// shut, as an untrained skinning weight strays far outside glTF's [0, 1].
fn frames_of(actor: &AimActor<'_>) -> Vec<Frame> {
    let m = actor.shape_count();
    (0..5)
        .map(|f| {
            let mut head = [0.0f32; 9];
            let yaw = axis_angle([0.0, 1.0, 0.0], 0.1 * f as f64);
            head[..6].copy_from_slice(&sinew_core::rotation::to_6d(&yaw));
            Frame {
                head,
                jaw: sinew_host::aim::model::IDENTITY_9D,
                weights: (0..m).map(|j| 0.2 * ((f + j) % 4) as f32).collect(),
            }
        })
        .collect()
}

/// The split export poses as the core does at every corner's vertex.
fn posed_as_the_core(g: &Gltf, actor: &AimActor<'_>, corners: &[(u32, [f32; 2])]) {
    let posed = pose_gltf(g);
    let indices = g.accessor(g.face().indices.unwrap());
    let frames = frames_of(actor);
    let mut core = vec![0.0f32; 3 * actor.vertex_count()];
    for (frame, gl) in frames.iter().zip(&posed) {
        let pose = actor.pose_from_9d(&frame.jaw, &frame.head).unwrap();
        actor.pose(&pose, &frame.weights, &mut core).unwrap();
        for (&i, &(v, _)) in indices.iter().zip(corners) {
            let (i, v) = (i as usize, v as usize);
            let gl: Vec<f32> = (0..3).map(|c| (gl[3 * i + c] * 100.0) as f32).collect();
            let _ = GLTF_RIG
                .first_violation(&gl, &core[3 * v..3 * v + 3])
                .map(|(c, a, b)| {
                    panic!("exported vertex {i} (actor {v}) axis {c}: glTF {a}, core {b}")
                });
        }
    }
}

/// The golden ICT actor with the kit's coordinates carried onto its decimated template as
/// `sinew bake --template` records them: each of its vertices is a kit vertex, so each takes that
/// vertex's coordinate, and the kit's face region has no seam, so nothing is split.
#[test]
fn the_kits_coordinates_carried_onto_the_golden_actor() {
    use sinew_host::geometry::uv::CornerUvs;
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let kit = sinew_host::io::ict::IctFaceKit::open(&root.join("ict-facekit")).unwrap();
    let face = kit
        .actor(&[], &[], sinew_host::io::ict::FACE_REGION)
        .unwrap()
        .template;
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let template = sinew_host::io::mesh::Mesh::of_actor(&actor);
    let triangles = template.triangles();
    let (_, value) = sinew_host::aim::bake::uv_metadata(&[], &template, &triangles, Some(&face))
        .unwrap()
        .unwrap();
    assert!(!value.contains("corners"), "recorded per vertex");
    let flat: Vec<u32> = triangles.iter().flatten().copied().collect();
    let uvs = CornerUvs::parse(&value, &flat, actor.vertex_count()).unwrap();
    let kit_uvs = CornerUvs::of_mesh(&face).unwrap();
    let mut kit_uv = vec![None; face.positions.len()];
    for (&v, &c) in face.triangles().iter().flatten().zip(&kit_uvs.corners) {
        kit_uv[v as usize] = Some(kit_uvs.uvs[c as usize]);
    }
    for (i, p) in template.positions.iter().enumerate() {
        let k = face
            .positions
            .iter()
            .position(|q| q == p)
            .expect("a kit vertex");
        assert_eq!(Some(uvs.uvs[i]), kit_uv[k], "vertex {i} (kit vertex {k})");
    }
    let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
    let mut w = sinew_host::io::container::SinewWriter::from_file(&file).unwrap();
    w.meta(sinew_host::geometry::uv::KEY, &value);
    let with_uv = w.to_bytes().unwrap();
    let actor = AimActor::from_bytes(&with_uv).unwrap();
    let (file, summary) = glb(&actor, &[], &Options::default()).unwrap();
    assert!(summary.texture_coordinates);
    assert_eq!((summary.vertices, summary.seam_copies), (4705, 0));
    let g = Gltf::parse(&file);
    let exported = g.attribute(json::mesh::Semantic::TexCoords(0));
    let want: Vec<f64> = uvs.uvs.iter().flatten().map(|&x| f64::from(x)).collect();
    assert_eq!(exported, want);
    eprintln!(
        "golden actor with the kit's coordinates: {} bytes of metadata uv",
        value.len()
    );
}
