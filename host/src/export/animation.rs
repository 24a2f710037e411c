//! The exported animation `performance`: one keyframe per frame at i / fps, LINEAR samplers for
//! the morph weights (node `face`), the jaw's and the head's translation and rotation.
//!
//! Looping (`--loop`): after the N frames the first frame is keyed once more, at N / fps, so the
//! clip lasts N / fps, its last keyframe equals its first, and an engine that repeats it goes from
//! frame N − 1 back to frame 0 over one frame's time, as between any two frames, never jumping.
//! Each rotation keeps the sign of the one before it (q and −q are one rotation), so that a
//! plain linear blend of neighbouring keys, as some engines do, takes the short way too. The
//! rotations are unit quaternions of the core's matrices ([`quaternion`]).

use gltf_json as json;
use json::validation::Checked::Valid;
use sinew_core::aim::AimActor;

use sinew_core::InputError;
use sinew_core::linalg::Mat3;

use super::jaw::keyed_weight;
use super::place::Place;
use crate::aim::play::Frame;
use crate::io::glb::Builder;

/// The nodes the animation moves.
pub(crate) struct Animated {
    /// The skinned face mesh (morph weights).
    pub(crate) face: json::Index<json::Node>,
    /// The jaw joint.
    pub(crate) jaw: json::Index<json::Node>,
    /// The head joint.
    pub(crate) head: json::Index<json::Node>,
}

/// The keyframes of `frames`: the frames, then with `looped` the first again.
pub(crate) fn keyframes(frames: &[Frame], looped: bool) -> Vec<&Frame> {
    let mut keys: Vec<&Frame> = frames.iter().collect();
    if looped && let Some(first) = frames.first() {
        keys.push(first);
    }
    keys
}

/// `q`, or `−q` where that lies nearer to `before`.
fn continuous(q: [f32; 4], before: Option<&[f32]>) -> [f32; 4] {
    match before {
        Some(p) if p.iter().zip(&q).map(|(a, b)| a * b).sum::<f32>() < 0.0 => q.map(|x| -x),
        _ => q,
    }
}

/// Adds the animation over `frames` (keyed at i / fps; the first again at N / fps when
/// `looped`); each keyframe's morph weights are the frame's held to [0, 1]
/// (`super::jaw::keyed_weight`; the compensation carries the rest), then `extra` zeros for targets the
/// animation does not drive, then the frame's `compensation` weights (`super::jaw`; one list
/// per frame, or none). A frame whose head or jaw the core refuses is returned with its index.
#[allow(clippy::too_many_arguments)]
pub(crate) fn animate(
    b: &mut Builder,
    actor: &AimActor<'_>,
    frames: &[Frame],
    fps: f32,
    looped: bool,
    extra: usize,
    compensation: &[Vec<f32>],
    place: &Place,
    pivot_m: [f32; 3],
    nodes: &Animated,
) -> Result<(), (usize, InputError)> {
    use json::accessor::Type;
    use json::animation::Property;
    let keys = keyframes(frames, looped);
    let times: Vec<f32> = (0..keys.len()).map(|i| i as f32 / fps).collect();
    let input = b.floats(&times, Type::Scalar, true, None);
    let mut weights = Vec::new();
    let (mut jt, mut jr, mut ht, mut hr) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (key, f) in keys.iter().enumerate() {
        let frame = key % frames.len();
        weights.extend(f.weights.iter().map(|&w| keyed_weight(w)));
        weights.extend(std::iter::repeat_n(0.0, extra));
        if let Some(c) = compensation.get(frame) {
            weights.extend_from_slice(c);
        }
        let pose = actor
            .pose_from_9d(&f.jaw, &f.head)
            .map_err(|source| (frame, source))?;
        let t = pose.jaw.rigid.trans;
        jt.extend(
            place
                .offsets(&[t.x, t.y, t.z])
                .iter()
                .zip(pivot_m)
                .map(|(t, p)| p + t),
        );
        let q = continuous(
            quaternion(&place.rotation(&pose.jaw.rigid.rot)),
            jr.last_chunk::<4>().map(|c| c.as_slice()),
        );
        jr.extend(q);
        let head_rot = place.rotation(&pose.head.rot);
        ht.extend(place.head_translation(&head_rot, pose.head.trans));
        let q = continuous(
            quaternion(&head_rot),
            hr.last_chunk::<4>().map(|c| c.as_slice()),
        );
        hr.extend(q);
    }
    let outputs = [
        (
            nodes.face,
            Property::MorphTargetWeights,
            b.floats(&weights, Type::Scalar, false, None),
        ),
        (
            nodes.jaw,
            Property::Translation,
            b.floats(&jt, Type::Vec3, false, None),
        ),
        (
            nodes.jaw,
            Property::Rotation,
            b.floats(&jr, Type::Vec4, false, None),
        ),
        (
            nodes.head,
            Property::Translation,
            b.floats(&ht, Type::Vec3, false, None),
        ),
        (
            nodes.head,
            Property::Rotation,
            b.floats(&hr, Type::Vec4, false, None),
        ),
    ];
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    for (i, (node, path, output)) in outputs.into_iter().enumerate() {
        samplers.push(json::animation::Sampler {
            extensions: None,
            extras: None,
            input,
            interpolation: Valid(json::animation::Interpolation::Linear),
            output,
        });
        channels.push(json::animation::Channel {
            sampler: json::Index::new(i as u32),
            target: json::animation::Target {
                extensions: None,
                extras: None,
                node,
                path: Valid(path),
            },
            extensions: None,
            extras: None,
        });
    }
    b.root.push(json::Animation {
        extensions: None,
        extras: None,
        channels,
        name: Some("performance".into()),
        samplers,
    });
    Ok(())
}

/// A unit quaternion `[x, y, z, w]` of a rotation matrix (Shepperd's method, in f64).
pub fn quaternion(m: &Mat3) -> [f32; 4] {
    let c = m.cols.map(|v| [v.x, v.y, v.z].map(f64::from));
    // r[i][j]: row i, column j.
    let r = |i: usize, j: usize| c[j][i];
    let trace = r(0, 0) + r(1, 1) + r(2, 2);
    let q = if trace > 0.0 {
        let s = (trace + 1.0).sqrt() * 2.0;
        [
            (r(2, 1) - r(1, 2)) / s,
            (r(0, 2) - r(2, 0)) / s,
            (r(1, 0) - r(0, 1)) / s,
            s / 4.0,
        ]
    } else if r(0, 0) > r(1, 1) && r(0, 0) > r(2, 2) {
        let s = (1.0 + r(0, 0) - r(1, 1) - r(2, 2)).sqrt() * 2.0;
        [
            s / 4.0,
            (r(0, 1) + r(1, 0)) / s,
            (r(0, 2) + r(2, 0)) / s,
            (r(2, 1) - r(1, 2)) / s,
        ]
    } else if r(1, 1) > r(2, 2) {
        let s = (1.0 + r(1, 1) - r(0, 0) - r(2, 2)).sqrt() * 2.0;
        [
            (r(0, 1) + r(1, 0)) / s,
            s / 4.0,
            (r(1, 2) + r(2, 1)) / s,
            (r(0, 2) - r(2, 0)) / s,
        ]
    } else {
        let s = (1.0 + r(2, 2) - r(0, 0) - r(1, 1)).sqrt() * 2.0;
        [
            (r(0, 2) + r(2, 0)) / s,
            (r(1, 2) + r(2, 1)) / s,
            s / 4.0,
            (r(1, 0) - r(0, 1)) / s,
        ]
    };
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    q.map(|v| (v / n) as f32)
}
