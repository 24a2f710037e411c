//! The exported glTF rig posed the way a glTF engine poses it (glTF 2.0 spec, "Skins" and
//! "Morph Targets": base + Σ w·target, then Σ weight·(joint world · inverse bind) over the
//! joints, with the joints' TRS sampled from the animation) against sinew-core's playback of the
//! same frames on the golden ICT actor. The evaluator below reads only the .glb, so it checks
//! what an engine would see.

use std::path::Path;

use gltf_json as json;
use json::validation::Checked::Valid;
use sinew_core::aim::AimActor;
use sinew_core::linalg::{Mat3, Vec3};
use sinew_host::aim::play::Frame;
use sinew_host::export::gltf::{Names, Options, glb, joint_weight, metres_per_unit};
use sinew_host::training::tolerance::{GLTF_RIG, GLTF_ROUNDING};

type M4 = [[f64; 4]; 4];

fn golden() -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-ict.sinew");
    std::fs::read(p).unwrap()
}

/// A rotation about a unit axis, as the core's matrix.
fn axis_angle(axis: [f64; 3], angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    let r = [
        [
            c + x * x * (1.0 - c),
            x * y * (1.0 - c) - z * s,
            x * z * (1.0 - c) + y * s,
        ],
        [
            y * x * (1.0 - c) + z * s,
            c + y * y * (1.0 - c),
            y * z * (1.0 - c) - x * s,
        ],
        [
            z * x * (1.0 - c) - y * s,
            z * y * (1.0 - c) + x * s,
            c + z * z * (1.0 - c),
        ],
    ];
    let col = |j: usize| Vec3::new(r[0][j] as f32, r[1][j] as f32, r[2][j] as f32);
    Mat3::from_cols(col(0), col(1), col(2))
}

/// 30 frames: every coefficient on a smooth curve, the jaw opening along its learned jawOpen
/// transform (blended in from the identity, as the ARKit mapping does), and the head turning and
/// moving.
fn frames(actor: &AimActor<'_>) -> Vec<Frame> {
    let m = actor.shape_count();
    let learned = sinew_host::aim::eval::training_poses(actor).unwrap()[1];
    (0..30)
        .map(|f| {
            let t = f as f64 / 29.0;
            let weights = (0..m)
                .map(|j| (0.5 - 0.5 * (2.0 * std::f64::consts::PI * t + j as f64).cos()) as f32)
                .collect();
            let open = (std::f64::consts::PI * t).sin() as f32;
            let id = sinew_host::aim::model::IDENTITY_9D;
            let jaw: [f32; 9] = std::array::from_fn(|i| id[i] + open * (learned[i] - id[i]));
            let yaw = axis_angle(
                [0.0, 1.0, 0.0],
                0.4 * (2.0 * std::f64::consts::PI * t).sin(),
            );
            let mut head = [0.0f32; 9];
            head[..6].copy_from_slice(&sinew_core::rotation::to_6d(&yaw));
            head[6..].copy_from_slice(&[1.5 * t as f32, -0.5 * t as f32, 0.25]);
            Frame { head, jaw, weights }
        })
        .collect()
}

struct Gltf {
    root: json::Root,
    bin: Vec<u8>,
}

impl Gltf {
    fn parse(file: &[u8]) -> Self {
        let (text, bin) = sinew_host::io::glb::read(file).unwrap();
        Self {
            root: serde_json::from_slice(text).unwrap(),
            bin: bin.to_vec(),
        }
    }

    /// The face mesh's primitive.
    fn face(&self) -> &json::mesh::Primitive {
        &self.root.meshes[0].primitives[0]
    }

    fn attribute(&self, s: json::mesh::Semantic) -> Vec<f64> {
        self.accessor(self.face().attributes[&Valid(s)])
    }

    fn target_names(&self) -> Vec<String> {
        let extras: serde_json::Value =
            serde_json::from_str(self.root.meshes[0].extras.as_ref().unwrap().get()).unwrap();
        serde_json::from_value(extras["targetNames"].clone()).unwrap()
    }

    fn accessor(&self, i: json::Index<json::Accessor>) -> Vec<f64> {
        let a = &self.root.accessors[i.value()];
        let view = &self.root.buffer_views[a.buffer_view.unwrap().value()];
        let start = view.byte_offset.map_or(0, |o| o.0 as usize)
            + a.byte_offset.map_or(0, |o| o.0 as usize);
        let Valid(kind) = a.type_ else {
            panic!("accessor type")
        };
        let n = a.count.0 as usize * kind.multiplicity();
        let Valid(json::accessor::GenericComponentType(c)) = a.component_type else {
            panic!("component type")
        };
        let bytes = &self.bin[start..];
        match c {
            json::accessor::ComponentType::F32 => bytes
                .chunks_exact(4)
                .take(n)
                .map(|b| f64::from(f32::from_le_bytes(b.try_into().unwrap())))
                .collect(),
            json::accessor::ComponentType::U8 => bytes[..n].iter().map(|b| f64::from(*b)).collect(),
            json::accessor::ComponentType::U32 => bytes
                .chunks_exact(4)
                .take(n)
                .map(|b| f64::from(u32::from_le_bytes(b.try_into().unwrap())))
                .collect(),
            other => panic!("component type {other:?} not read here"),
        }
    }

    /// `(translation, rotation xyzw)` of a node at time `t`: the animated values where a channel
    /// targets it (linear, slerp for the rotation), else its rest values.
    fn trs(&self, node: usize, t: f64) -> ([f64; 3], [f64; 4]) {
        let n = &self.root.nodes[node];
        let mut tr = n.translation.unwrap_or([0.0; 3]).map(f64::from);
        let mut rot = n
            .rotation
            .map_or([0.0, 0.0, 0.0, 1.0], |q| q.0.map(f64::from));
        for anim in &self.root.animations {
            for ch in &anim.channels {
                if ch.target.node.value() != node {
                    continue;
                }
                let s = &anim.samplers[ch.sampler.value()];
                let times = self.accessor(s.input);
                let out = self.accessor(s.output);
                let k = times.iter().rposition(|x| *x <= t).unwrap_or(0);
                let (k1, a) = if k + 1 < times.len() {
                    (k + 1, (t - times[k]) / (times[k + 1] - times[k]))
                } else {
                    (k, 0.0)
                };
                match ch.target.path {
                    Valid(json::animation::Property::Translation) => {
                        tr = std::array::from_fn(|i| {
                            out[3 * k + i] * (1.0 - a) + out[3 * k1 + i] * a
                        })
                    }
                    Valid(json::animation::Property::Rotation) => {
                        let q0: [f64; 4] = std::array::from_fn(|i| out[4 * k + i]);
                        let q1: [f64; 4] = std::array::from_fn(|i| out[4 * k1 + i]);
                        rot = slerp(q0, q1, a);
                    }
                    _ => {}
                }
            }
        }
        (tr, rot)
    }

    fn morph_weights(&self, node: usize, t: f64, m: usize) -> Vec<f64> {
        for anim in &self.root.animations {
            for ch in &anim.channels {
                if ch.target.node.value() == node
                    && ch.target.path == Valid(json::animation::Property::MorphTargetWeights)
                {
                    let s = &anim.samplers[ch.sampler.value()];
                    let times = self.accessor(s.input);
                    let out = self.accessor(s.output);
                    let k = times
                        .iter()
                        .position(|x| (*x - t).abs() < 1e-9)
                        .expect("keyframe");
                    return out[m * k..m * (k + 1)].to_vec();
                }
            }
        }
        vec![0.0; m]
    }

    /// A node's world matrix: its parents' times its own TRS.
    fn world(&self, node: usize, t: f64) -> M4 {
        let (tr, q) = self.trs(node, t);
        let local = trs_matrix(tr, q);
        let parent = self.root.nodes.iter().position(|p| {
            p.children
                .as_ref()
                .is_some_and(|c| c.iter().any(|c| c.value() == node))
        });
        match parent {
            Some(p) => mul(&self.world(p, t), &local),
            None => local,
        }
    }
}

fn slerp(q0: [f64; 4], mut q1: [f64; 4], a: f64) -> [f64; 4] {
    let mut d: f64 = (0..4).map(|i| q0[i] * q1[i]).sum();
    if d < 0.0 {
        q1 = q1.map(|x| -x);
        d = -d;
    }
    if a == 0.0 || d > 1.0 - 1e-12 {
        return std::array::from_fn(|i| q0[i] * (1.0 - a) + q1[i] * a);
    }
    let th = d.acos();
    let (s0, s1) = (((1.0 - a) * th).sin() / th.sin(), (a * th).sin() / th.sin());
    std::array::from_fn(|i| q0[i] * s0 + q1[i] * s1)
}

fn trs_matrix(t: [f64; 3], q: [f64; 4]) -> M4 {
    let [x, y, z, w] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
            t[0],
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
            t[1],
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
            t[2],
        ],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

fn mul(a: &M4, b: &M4) -> M4 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..4).map(|k| a[r][k] * b[k][c]).sum()))
}

fn apply(m: &M4, p: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
}

/// Every frame of the face mesh posed by glTF's rules, in metres, `[frames][V·3]`.
fn pose_gltf(g: &Gltf) -> Vec<Vec<f64>> {
    let face = g
        .root
        .nodes
        .iter()
        .position(|n| n.name.as_deref() == Some("face"))
        .unwrap();
    let node = &g.root.nodes[face];
    let mesh = &g.root.meshes[node.mesh.unwrap().value()];
    let skin = &g.root.skins[node.skin.unwrap().value()];
    let prim = &mesh.primitives[0];
    let attr = |s: json::mesh::Semantic| g.accessor(prim.attributes[&Valid(s)]);
    let base = attr(json::mesh::Semantic::Positions);
    let joints = attr(json::mesh::Semantic::Joints(0));
    let weights = attr(json::mesh::Semantic::Weights(0));
    let targets: Vec<Vec<f64>> = prim
        .targets
        .as_ref()
        .unwrap()
        .iter()
        .map(|t| g.accessor(t.positions.unwrap()))
        .collect();
    let ibm = g.accessor(skin.inverse_bind_matrices.unwrap());
    let times = {
        let anim = &g.root.animations[0];
        g.accessor(anim.samplers[0].input)
    };
    times
        .iter()
        .map(|&t| {
            let w = g.morph_weights(face, t, targets.len());
            let jm: Vec<M4> = skin
                .joints
                .iter()
                .enumerate()
                .map(|(j, n)| {
                    // Inverse bind matrices are column-major.
                    let b: M4 =
                        std::array::from_fn(|r| std::array::from_fn(|c| ibm[16 * j + 4 * c + r]));
                    mul(&g.world(n.value(), t), &b)
                })
                .collect();
            let mut out = Vec::with_capacity(base.len());
            for v in 0..base.len() / 3 {
                let p: [f64; 3] = std::array::from_fn(|c| {
                    base[3 * v + c]
                        + (0..targets.len())
                            .map(|j| w[j] * targets[j][3 * v + c])
                            .sum::<f64>()
                });
                let mut s = [0.0; 3];
                for i in 0..4 {
                    let q = apply(&jm[joints[4 * v + i] as usize], p);
                    for c in 0..3 {
                        s[c] += weights[4 * v + i] * q[c];
                    }
                }
                out.extend(s);
            }
            out
        })
        .collect()
}

#[test]
fn exported_rig_poses_as_the_core_plays() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let frames = frames(&actor);
    let (file, summary) = glb(&actor, &frames, &Options::default()).unwrap();
    let g = Gltf::parse(&file);
    let names = g.root.meshes[0].extras.as_ref().unwrap().get();
    assert!(
        names.contains("\"jawOpen\"") && names.contains("\"noseSneer_R\""),
        "{names}"
    );
    let unit = metres_per_unit(&actor).unwrap();
    assert_eq!(unit, 0.01f32, "the ICT actor is in centimetres");
    let scale = f64::from(unit);
    let posed = pose_gltf(&g);
    assert_eq!(posed.len(), frames.len());

    let v = actor.vertex_count();
    let m = actor.shape_count();
    let e = actor
        .file()
        .f32_tensor("cache.e", &[v as u32, m as u32, 3])
        .unwrap();
    assert!(
        frames
            .iter()
            .any(|f| f.jaw != sinew_host::aim::model::IDENTITY_9D),
        "the frames must move the jaw"
    );
    let (mut worst_core, mut worst_rounding) = (0.0f64, 0.0f64);
    let mut core = vec![0.0f32; 3 * v];
    for (f, (frame, gl)) in frames.iter().zip(&posed).enumerate() {
        let pose = actor.pose_from_9d(&frame.jaw, &frame.head).unwrap();
        actor.pose(&pose, &frame.weights, &mut core).unwrap();
        let gl_units: Vec<f32> = gl.iter().map(|x| (x / scale) as f32).collect();
        for i in 0..3 * v {
            worst_core = worst_core.max(f64::from((gl_units[i] - core[i]).abs()));
        }
        if let Some((i, a, b)) = GLTF_RIG.first_violation(&gl_units, &core) {
            panic!("frame {f}, value {i}: glTF {a}, core {b}; worst so far {worst_core:e}");
        }
        // What glTF's rules should give, from the actor's own arrays in f64: the morphed skin,
        // then LBS about the pivot with the clamped weight, then the head.
        let jaw = pose.jaw;
        let to64 = |v: Vec3| [v.x, v.y, v.z].map(f64::from);
        let rot = |m: &Mat3, p: [f64; 3]| -> [f64; 3] {
            let c = m.cols.map(to64);
            std::array::from_fn(|r| c[0][r] * p[0] + c[1][r] * p[1] + c[2][r] * p[2])
        };
        let (pv, jt, ht) = (
            to64(jaw.pivot),
            to64(jaw.rigid.trans),
            to64(pose.head.trans),
        );
        let mut expected = Vec::with_capacity(3 * v);
        for i in 0..v {
            let x: [f64; 3] = std::array::from_fn(|c| {
                f64::from(actor.rest().at(3 * i + c))
                    + (0..m)
                        .map(|j| f64::from(frame.weights[j]) * f64::from(e.at((i * m + j) * 3 + c)))
                        .sum::<f64>()
            });
            let k = f64::from(joint_weight(actor.skinning_weights().at(i)));
            let r = rot(&jaw.rigid.rot, std::array::from_fn(|c| x[c] - pv[c]));
            let lbs: [f64; 3] =
                std::array::from_fn(|c| k * (r[c] + pv[c] + jt[c]) + (1.0 - k) * x[c]);
            let h = rot(&pose.head.rot, lbs);
            expected.extend((0..3).map(|c| (h[c] + ht[c]) as f32));
        }
        if let Some((i, a, b)) = GLTF_ROUNDING.first_violation(&gl_units, &expected) {
            panic!("frame {f}, value {i}: glTF {a}, glTF's rules on the actor {b}");
        }
        for i in 0..3 * v {
            worst_rounding = worst_rounding.max(f64::from((gl_units[i] - expected[i]).abs()));
        }
    }
    eprintln!(
        "glTF rig vs sinew-core on {} frames of the golden ICT actor: max |Δ| {worst_core:.3e} cm; \
         vs glTF's rules in f64: {worst_rounding:.3e} cm; {} of {v} jaw weights clamped (max {:.4})",
        frames.len(),
        summary.clamped_weights,
        summary.max_clamp
    );
}

#[test]
fn rest_export_has_the_rig_without_animation() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let bones = Options {
        bones: true,
        ..Options::default()
    };
    let (file, summary) = glb(&actor, &[], &bones).unwrap();
    let (text, _) = sinew_host::io::glb::read(&file).unwrap();
    let root: json::Root = serde_json::from_slice(text).unwrap();
    assert!(root.animations.is_empty());
    assert_eq!(root.meshes.len(), 2, "face and bones");
    assert_eq!(root.skins[0].joints.len(), 2);
    assert_eq!(summary.morph_targets, 19);
    assert_eq!(summary.vertices, 4705);
    let jaw = root
        .nodes
        .iter()
        .find(|n| n.name.as_deref() == Some("jaw"))
        .unwrap();
    let p = actor.jaw_pivot();
    assert_eq!(jaw.translation, Some([p.x * 0.01, p.y * 0.01, p.z * 0.01]));
}

/// With ARKit's names, the golden actor's sided shapes take ARKit's spelling and the two shapes
/// ARKit does not split (`browInnerUp`, `cheekPuff`) get a target of their own, which the
/// animation leaves at 0, so the rig still poses as before.
#[test]
fn arkit_names_bind_by_name_and_leave_the_pose_alone() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let frames = frames(&actor);
    let options = Options {
        names: Names::Arkit,
        ..Options::default()
    };
    let (file, summary) = glb(&actor, &frames, &options).unwrap();
    let g = Gltf::parse(&file);
    let names = g.target_names();
    let own = sinew_host::aim::play::corrective_names(&actor);
    let m = own.len();
    assert_eq!(names.len(), m + 2, "{names:?}");
    assert_eq!(summary.combined_targets, ["browInnerUp", "cheekPuff"]);
    for (a, b) in [
        ("mouthSmile_L", "mouthSmileLeft"),
        ("noseSneer_R", "noseSneerRight"),
        ("eyeBlink_R", "eyeBlinkRight"),
        ("jawOpen", "jawOpen"),
        ("browInnerUp_L", "browInnerUp_L"),
    ] {
        let j = own.iter().position(|n| n == a).unwrap();
        assert_eq!(names[j], b);
    }
    // Each combined target is the sum of its sides: here one side each.
    let targets = g.face().targets.as_ref().unwrap();
    for (combined, side) in [(m, "browInnerUp_L"), (m + 1, "cheekPuff_L")] {
        let j = own.iter().position(|n| n == side).unwrap();
        assert_eq!(
            g.accessor(targets[combined].positions.unwrap()),
            g.accessor(targets[j].positions.unwrap()),
            "{}",
            names[combined]
        );
    }
    let anim = &g.root.animations[0];
    let weights = g.accessor(anim.samplers[0].output);
    assert_eq!(weights.len(), frames.len() * (m + 2));
    for key in weights.chunks_exact(m + 2) {
        assert_eq!(&key[m..], [0.0, 0.0]);
    }
    let plain = Gltf::parse(&glb(&actor, &frames, &Options::default()).unwrap().0);
    assert_eq!(pose_gltf(&g), pose_gltf(&plain));
}

/// Looping keys the first frame once more, one frame after the last: the clip's end equals its
/// start, and everything before is the unlooped animation.
#[test]
fn a_looped_animation_ends_where_it_starts() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let frames = frames(&actor);
    let options = Options {
        looped: true,
        ..Options::default()
    };
    let (file, summary) = glb(&actor, &frames, &options).unwrap();
    assert_eq!((summary.frames, summary.keyframes), (30, 31));
    let g = Gltf::parse(&file);
    let anim = &g.root.animations[0];
    let times = g.accessor(anim.samplers[0].input);
    assert_eq!(times.len(), 31);
    assert_eq!(times[30], f64::from(30.0f32 / 30.0));
    for s in &anim.samplers {
        let out = g.accessor(s.output);
        let w = out.len() / 31;
        let (first, last) = (&out[..w], &out[30 * w..]);
        // A rotation may come back as −q, the same rotation.
        let flipped: Vec<f64> = last.iter().map(|x| -x).collect();
        assert!(
            first == last || (w == 4 && first == flipped),
            "{first:?} {last:?}"
        );
    }
    let posed = pose_gltf(&g);
    assert_eq!(posed[30], posed[0]);
    let plain = pose_gltf(&Gltf::parse(
        &glb(&actor, &frames, &Options::default()).unwrap().0,
    ));
    let worst = posed[..30]
        .iter()
        .flatten()
        .zip(plain.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // Only a rotation's sign may differ, which changes nothing but rounding.
    assert!(worst < 1e-9, "{worst}");
}

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

/// An untrained actor of the procedural face with `metadata` (its caches are whatever the
/// network gives: the export's layout, not the learning, is under test).
fn procedural_actor(
    set: &sinew_host::aim::TrainingSet,
    metadata: Vec<(String, String)>,
) -> Vec<u8> {
    use sinew_host::aim::bake::{BakeInput, bake};
    let config = sinew_host::aim::testing::small_aim_config(1);
    let device = sinew_host::training::backend::Backend::Flex
        .device(0)
        .unwrap();
    let net = sinew_host::aim::model::AimNet::new(&config, set.shapes.len(), &device);
    let triangles = set.template.triangles();
    let input = BakeInput {
        points: &set.template.positions,
        triangles: &triangles,
        jaw_pivot: set.jaw_pivot,
        normalisation: sinew_host::aim::model::normalisation(&set.template.positions),
        playback_only: true,
        metadata,
    };
    bake(&net, &input, &device).unwrap().0
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
