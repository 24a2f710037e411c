//! The exported glTF rig posed the way a glTF engine poses it (glTF 2.0 spec, "Skins" and
//! "Morph Targets": base + Σ w·target, then Σ weight·(joint world · inverse bind) over the
//! joints, with the joints' TRS sampled from the animation) against sinew-core's playback of the
//! same frames on the golden ICT actor. The evaluator below reads only the .glb, so it checks
//! what an engine would see.

use crate::common::gltf::{Gltf, axis_angle, golden, pose_gltf, pose_gltf_keeping};
use gltf_json as json;
use sinew_core::aim::AimActor;
use sinew_host::aim::play::Frame;
use sinew_host::export::gltf::{
    JAW_COMPENSATION_TOLERANCE_M, MAX_JAW_COMPENSATION, Names, Options, glb, joint_weight,
    metres_per_unit,
};
use sinew_host::training::tolerance::GLTF_RIG;

/// 30 frames: every coefficient on a smooth curve, the jaw opening along its learned jawOpen
/// transform (blended in from the identity), and the head turning and moving.
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

/// Every morph weight the animation keys lies in [0, 1], the range of a DCC's sliders (Blender
/// clamps its shape keys there).
fn keyed_weights_are_sliders(g: &Gltf) {
    for anim in &g.root.animations {
        for ch in &anim.channels {
            if ch.target.path
                == json::validation::Checked::Valid(json::animation::Property::MorphTargetWeights)
            {
                let out = g.accessor(anim.samplers[ch.sampler.value()].output);
                if let Some((i, w)) = out
                    .iter()
                    .enumerate()
                    .find(|(_, w)| !(0.0..=1.0).contains(*w))
                {
                    panic!("keyed morph weight {i} is {w}, outside [0, 1]");
                }
            }
        }
    }
}

#[test]
fn exported_rig_poses_as_the_core_plays() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let frames = frames(&actor);
    let (file, summary) = glb(&actor, &frames, &Options::default()).unwrap();
    let g = Gltf::parse(&file);
    keyed_weights_are_sliders(&g);
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
    // The jaw opens by some 20° and every shape plays at once: the correctives turned by the
    // jaw need compensation, and a few targets give it.
    let m = actor.shape_count();
    let compensation = summary.jaw_compensation_targets;
    assert!(
        (1..=MAX_JAW_COMPENSATION).contains(&summary.jaw_compensation_directions),
        "{}",
        summary.jaw_compensation_directions
    );
    assert!(
        (summary.jaw_compensation_directions..=2 * summary.jaw_compensation_directions)
            .contains(&compensation),
        "{compensation}"
    );
    assert!(summary.jaw_compensation_residual_mm <= JAW_COMPENSATION_TOLERANCE_M * 1e3);
    assert_eq!(g.target_names().len(), m + compensation);
    assert!(
        frames
            .iter()
            .any(|f| f.jaw != sinew_host::aim::model::IDENTITY_9D),
        "the frames must move the jaw"
    );
    let v = actor.vertex_count();
    let named_only = pose_gltf_keeping(&g, m);
    let (mut worst_core, mut worst_named) = (0.0f64, 0.0f64);
    let mut core = vec![0.0f32; 3 * v];
    for (f, (frame, gl)) in frames.iter().zip(&posed).enumerate() {
        let pose = actor.pose_from_9d(&frame.jaw, &frame.head).unwrap();
        actor.pose(&pose, &frame.weights, &mut core).unwrap();
        let gl_units: Vec<f32> = gl.iter().map(|x| (x / scale) as f32).collect();
        for i in 0..3 * v {
            worst_core = worst_core.max(f64::from((gl_units[i] - core[i]).abs()));
            worst_named = worst_named.max((named_only[f][i] / scale - f64::from(core[i])).abs());
        }
        if let Some((i, a, b)) = GLTF_RIG.first_violation(&gl_units, &core) {
            panic!("frame {f}, value {i}: glTF {a}, core {b}; worst so far {worst_core:e}");
        }
    }
    // Without its compensation, the same animation lands millimetres astray.
    assert!(worst_named > 0.1, "{worst_named} cm");
    eprintln!(
        "glTF rig vs sinew-core on {} frames of the golden ICT actor: max |Δ| {worst_core:.3e} cm \
         with {compensation} compensation targets from {} directions ({:.2e} mm left), \
         {worst_named:.3e} cm without; {} of {v} jaw weights clamped (max {:.4})",
        frames.len(),
        summary.jaw_compensation_directions,
        summary.jaw_compensation_residual_mm,
        summary.clamped_weights,
        summary.max_clamp
    );
}

/// Every shape's target is compensated for its own learned jaw: each shape whose learned jaw
/// turns by more than `MOVES_JAW_DEGREES` (0.5°; jawOpen, and mouth shapes such as mouthFunnel
/// and the smiles) alone at 1, with the jaw the core's rule gives it, driven by name without
/// the animation's compensation (as an engine drives the rig live), poses as the core does, up
/// to glTF's clamped jaw weights.
#[test]
fn a_jaw_shape_driven_by_name_poses_as_the_core() {
    use sinew_host::aim::arkit::{MOVES_JAW_DEGREES, jaw_degrees};
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let m = actor.shape_count();
    let names = sinew_host::aim::play::corrective_names(&actor);
    let id = sinew_host::aim::model::IDENTITY_9D;
    let moving: Vec<usize> = jaw_degrees(&actor)
        .iter()
        .enumerate()
        .filter(|(_, d)| **d > MOVES_JAW_DEGREES)
        .map(|(s, _)| s)
        .collect();
    assert!(
        moving.len() > 4,
        "{moving:?}: more than the four jaw shapes"
    );
    let mut frames = vec![Frame {
        head: id,
        jaw: id,
        weights: vec![0.0; m],
    }];
    for &s in &moving {
        let weights: Vec<f32> = (0..m).map(|j| f32::from(u8::from(j == s))).collect();
        frames.push(Frame {
            head: id,
            jaw: actor.jaw_from_weights(&weights).unwrap(),
            weights,
        });
    }
    let (file, _) = glb(&actor, &frames, &Options::default()).unwrap();
    let g = Gltf::parse(&file);
    let named = pose_gltf_keeping(&g, m);
    let v = actor.vertex_count();
    for (f, frame) in frames.iter().enumerate().skip(1) {
        let pose = actor.pose_from_9d(&frame.jaw, &id).unwrap();
        let mut core = vec![0.0f32; 3 * v];
        actor.pose(&pose, &frame.weights, &mut core).unwrap();
        let jaw = pose.jaw;
        let worst = (0..v)
            .map(|i| {
                let k = actor.skinning_weights().at(i);
                let x = sinew_core::linalg::Vec3::new(
                    actor.rest().at(3 * i),
                    actor.rest().at(3 * i + 1),
                    actor.rest().at(3 * i + 2),
                );
                let moved = jaw.apply(x);
                // What glTF's clamped skin weights alone leave: LBS with k and with clamp(k).
                let clamp = f64::from((k - joint_weight(k)).abs())
                    * f64::from(
                        (moved - x)
                            .to_array()
                            .iter()
                            .map(|d| d * d)
                            .sum::<f32>()
                            .sqrt(),
                    );
                (0..3)
                    .map(|c| {
                        (named[f][3 * i + c] / 0.01 - f64::from(core[3 * i + c])).abs() - clamp
                    })
                    .fold(f64::MIN, f64::max)
            })
            .fold(f64::MIN, f64::max);
        let name = &names[moving[f - 1]];
        assert!(
            worst < 1e-5,
            "{name}: {worst} cm beyond the clamped weights' part"
        );
    }
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
    let c = summary.jaw_compensation_targets;
    assert_eq!(names.len(), m + 2 + c, "{names:?}");
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
    assert_eq!(weights.len(), frames.len() * (m + 2 + c));
    for key in weights.chunks_exact(m + 2 + c) {
        assert_eq!(&key[m..m + 2], [0.0, 0.0]);
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

/// A capture no performer makes (every shape and the jaw drawn anew each frame, 200 frames)
/// needs more directions than the export gives: it takes all of them, reports what is left, and
/// the rig stays within that of the core.
#[test]
fn an_unruly_animation_reports_what_compensation_leaves() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let m = actor.shape_count();
    let names = sinew_host::aim::play::corrective_names(&actor);
    let poses = sinew_host::aim::eval::training_poses(&actor).unwrap();
    let jaws: Vec<[f32; 9]> = ["jawOpen", "jawLeft", "jawRight", "jawForward"]
        .iter()
        .map(|n| poses[names.iter().position(|s| s == n).unwrap() + 1])
        .collect();
    let id = sinew_host::aim::model::IDENTITY_9D;
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut draw = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let frames: Vec<Frame> = (0..200)
        .map(|_| {
            let mut jaw = id;
            for learned in &jaws {
                let w = draw();
                for (j, v) in jaw.iter_mut().enumerate() {
                    *v += w * (learned[j] - id[j]);
                }
            }
            Frame {
                head: id,
                jaw,
                weights: (0..m).map(|_| draw()).collect(),
            }
        })
        .collect();
    let (file, summary) = glb(&actor, &frames, &Options::default()).unwrap();
    assert_eq!(summary.jaw_compensation_directions, MAX_JAW_COMPENSATION);
    assert!(summary.jaw_compensation_targets <= 2 * MAX_JAW_COMPENSATION);
    keyed_weights_are_sliders(&Gltf::parse(&file));
    let left_cm = summary.jaw_compensation_residual_mm / 10.0;
    assert!(left_cm < 0.05, "{left_cm} cm");
    let posed = pose_gltf(&Gltf::parse(&file));
    let v = actor.vertex_count();
    let mut core = vec![0.0f32; 3 * v];
    let mut worst = 0.0f64;
    for (frame, gl) in frames.iter().zip(&posed) {
        let pose = actor.pose_from_9d(&frame.jaw, &frame.head).unwrap();
        actor.pose(&pose, &frame.weights, &mut core).unwrap();
        for (g, c) in gl.iter().zip(&core) {
            worst = worst.max((g / 0.01 - f64::from(*c)).abs());
        }
    }
    assert!(worst <= left_cm + 1e-4, "{worst} cm, {left_cm} cm reported");
    eprintln!(
        "200 unruly frames: {} compensation targets from {} directions, {worst:.3e} cm, \
         {left_cm:.3e} cm reported",
        summary.jaw_compensation_targets, summary.jaw_compensation_directions
    );
}

/// A pose file's coefficients may lie outside [0, 1] (a fit, an artist's exaggeration): the
/// named targets are keyed held to [0, 1] and the compensation carries the rest, so the rig still
/// poses as the core does and every keyed weight stays a slider's.
#[test]
fn coefficients_outside_the_sliders_range_are_carried_by_the_compensation() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let mut frames = frames(&actor);
    let m = actor.shape_count();
    for (f, frame) in frames.iter_mut().enumerate() {
        // Every third shape swings from −0.5 to 1.5.
        for j in (0..m).step_by(3) {
            frame.weights[j] = 2.0 * frame.weights[j] - 0.5;
        }
        if f == 0 {
            frame.weights[1] = 1.25;
        }
    }
    let outside = frames
        .iter()
        .flat_map(|f| &f.weights)
        .filter(|w| !(0.0..=1.0).contains(*w))
        .count();
    let (file, summary) = glb(&actor, &frames, &Options::default()).unwrap();
    assert_eq!(summary.coefficients_outside_unit, outside);
    assert!(outside > 30, "{outside}");
    let g = Gltf::parse(&file);
    keyed_weights_are_sliders(&g);
    assert!(summary.jaw_compensation_residual_mm <= JAW_COMPENSATION_TOLERANCE_M * 1e3);
    let posed = pose_gltf(&g);
    let v = actor.vertex_count();
    let mut core = vec![0.0f32; 3 * v];
    for (f, (frame, gl)) in frames.iter().zip(&posed).enumerate() {
        let pose = actor.pose_from_9d(&frame.jaw, &frame.head).unwrap();
        actor.pose(&pose, &frame.weights, &mut core).unwrap();
        let gl_units: Vec<f32> = gl.iter().map(|x| (x / 0.01) as f32).collect();
        if let Some((i, a, b)) = GLTF_RIG.first_violation(&gl_units, &core) {
            panic!("frame {f}, value {i}: glTF {a}, core {b}");
        }
    }
    eprintln!(
        "{outside} coefficients outside [0, 1]: {} compensation targets from {} directions, \
         {:.2e} mm left",
        summary.jaw_compensation_targets,
        summary.jaw_compensation_directions,
        summary.jaw_compensation_residual_mm
    );
}

/// `--compress`: every view the accessors read is compressed with `EXT_meshopt_compression`
/// (required, its fallback buffer empty), losslessly: Sinew's reader finds the same face, bit
/// for bit, in a file a fraction of the size.
#[test]
fn a_compressed_export_reads_as_the_uncompressed_one() {
    let bytes = golden();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let frames = frames(&actor);
    let (plain, _) = glb(&actor, &frames, &Options::default()).unwrap();
    let options = Options {
        compress: true,
        ..Options::default()
    };
    let (packed, summary) = glb(&actor, &frames, &options).unwrap();
    assert_eq!(summary.bytes, packed.len());
    assert!(
        packed.len() * 10 < plain.len() * 9,
        "compressed {} bytes, uncompressed {}",
        packed.len(),
        plain.len()
    );
    let (text, _) = sinew_host::io::glb::read(&packed).unwrap();
    let doc: serde_json::Value = serde_json::from_slice(text).unwrap();
    let ext = sinew_host::io::glb_compress::EXTENSION;
    assert!(
        doc["extensionsRequired"]
            .as_array()
            .unwrap()
            .contains(&ext.into())
    );
    assert_eq!(doc["buffers"][1]["extensions"][ext]["fallback"], true);
    let views = doc["bufferViews"].as_array().unwrap();
    let accessed: std::collections::BTreeSet<u64> = doc["accessors"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|a| a["bufferView"].as_u64())
        .collect();
    for v in &accessed {
        assert!(
            views[*v as usize]["extensions"][ext].is_object(),
            "view {v}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let read = |name: &str, file: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, file).unwrap();
        sinew_host::io::rig::RigFile::read(&path, None).unwrap_or_else(|e| panic!("{e}"))
    };
    let (a, b) = (read("plain.glb", &plain), read("packed.glb", &packed));
    assert_eq!(a.neutral.positions, b.neutral.positions);
    assert_eq!(a.neutral.polygons, b.neutral.polygons);
    assert_eq!(a.deltas, b.deltas);
    assert_eq!(a.shape_names, b.shape_names);
}
