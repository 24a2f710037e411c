//! The Rust layer under the WebAssembly module, on the host: the golden replays played through
//! [`Model`] and [`Replay`] hash as recorded, and [`frame_hash`] of positions and normals is the
//! core's own `replay::pose_frame_hash` in the f32 mode. (The same replays through the JavaScript
//! API, in WebAssembly: `core/wasm/test/golden.test.mjs`.)
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use sinew_core::aim::AimActor;
use sinew_core::replay::{FrameBuffers, Mode};
use sinew_wasm::{FrameInputs, Kind, Model, Replay, frame_hash};

fn data(name: &str) -> Vec<u8> {
    let path = format!("{}/../../tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn aim_replays_hash_as_recorded_and_as_the_core_hashes() {
    for name in ["aim-procedural", "aim-ict"] {
        let bytes = data(&format!("{name}.sinew"));
        let model = Model::load(bytes.clone()).unwrap();
        let replay = Replay::load(data(&format!("{name}.f32.replay.sinew"))).unwrap();
        assert_eq!((model.kind(), replay.kind()), (Kind::Aim, Kind::Aim));
        replay.check(&model).unwrap();
        let actor = AimActor::from_bytes(&bytes).unwrap();
        assert_eq!(model.triangle_count(), actor.triangles().len());
        assert_eq!(model.triangles().len(), 3 * model.triangle_count());
        assert!(!replay.has_neutral());
        let v3 = 3 * actor.vertex_count();
        let (mut p, mut n) = (vec![0.0; v3], vec![0.0; v3]);
        for f in 0..replay.frames() {
            let FrameInputs::Aim {
                head,
                jaw,
                coefficients,
            } = replay.frame(f).unwrap()
            else {
                panic!("an AIM replay gave another kind of frame");
            };
            let positions = model.pose(&head, &jaw, &coefficients).unwrap();
            let normals = model.normals(&positions).unwrap();
            let hash = frame_hash(&[&positions, &normals]);
            assert_eq!(hash, replay.expected(f).unwrap(), "{name} frame {f}");
            let mut w = coefficients.clone();
            let mut buf = FrameBuffers {
                positions: &mut p,
                normals: &mut n,
                positions_q16: &mut [],
                weights: &mut w,
                weights_q16: &mut [],
            };
            let core =
                sinew_core::replay::pose_frame_hash(&actor, Mode::F32, &head, &jaw, &mut buf);
            assert_eq!(
                hash,
                core.unwrap(),
                "{name} frame {f}: the core's pose_frame_hash"
            );
        }
    }
}

#[test]
fn the_s2d_replay_hashes_as_recorded() {
    let mut model = Model::load(data("s2d-ict.sinew")).unwrap();
    let replay = Replay::load(data("s2d-ict.replay.sinew")).unwrap();
    replay.check(&model).unwrap();
    assert!(replay.has_neutral());
    assert_eq!(model.triangle_count(), 0);
    let neutral = replay.neutral().unwrap();
    for f in 0..replay.frames() {
        let FrameInputs::S2d(input) = replay.frame(f).unwrap() else {
            panic!("an S2D replay gave another kind of frame");
        };
        let vertices = model.decode(&input, Some(&neutral)).unwrap();
        assert_eq!(frame_hash(&[&vertices]), replay.expected(f).unwrap());
    }
    assert!(replay.frame(replay.frames()).is_err());
}

#[test]
fn errors_carry_the_cores_messages() {
    let bytes = data("aim-procedural.sinew");
    let err = Model::load(bytes[..100].to_vec()).unwrap_err();
    assert_eq!(
        err.to_string(),
        sinew_core::FormatError::LengthMismatch {
            header: bytes.len() as u32,
            actual: 100
        }
        .to_string()
    );
    let err = Model::load(data("s2d-ict.replay.sinew")).unwrap_err();
    assert!(err.message().starts_with("the artefact is of another kind"));
    let mut s2d = Model::load(data("s2d-ict.sinew")).unwrap();
    assert!(s2d.pose(&[0.0; 9], &[0.0; 9], &[]).is_err());
    assert!(s2d.decode(&[0.0; 3], None).is_err());
}
