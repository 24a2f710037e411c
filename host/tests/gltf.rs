//! The exported glTF rig posed the way a glTF engine poses it (glTF 2.0 spec, "Skins" and
//! "Morph Targets": base + Σ w·target, then Σ weight·(joint world · inverse bind) over the
//! joints, with the joints' TRS sampled from the animation) against sinew-core's playback of the
//! same frames on the golden ICT actor. The evaluator below reads only the .glb, so it checks
//! what an engine would see.

mod common;

use common::gltf::{Gltf, axis_angle, golden, pose_gltf};
use gltf_json as json;
use sinew_core::aim::AimActor;
use sinew_core::linalg::{Mat3, Vec3};
use sinew_host::aim::play::Frame;
use sinew_host::export::gltf::{Names, Options, glb, joint_weight, metres_per_unit};
use sinew_host::training::tolerance::{GLTF_RIG, GLTF_ROUNDING};

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
