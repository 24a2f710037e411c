//! Tests of recording, verifying and measuring replays.

use super::*;
use crate::aim::model::IDENTITY_9D;

fn golden() -> Vec<u8> {
    std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/aim-procedural.sinew"
    ))
    .unwrap()
}

fn frames(m: usize, n: usize) -> Vec<Frame> {
    (0..n)
        .map(|f| Frame {
            head: IDENTITY_9D,
            jaw: IDENTITY_9D,
            weights: (0..m).map(|j| (f * j) as f32 * 0.1).collect(),
        })
        .collect()
}

#[test]
fn record_then_verify_passes_and_a_changed_model_is_refused() {
    let model = golden();
    let m = AimActor::from_bytes(&model).unwrap().shape_count();
    let file = sinew_core::SinewFile::from_bytes(&model).unwrap();
    let mut w = SinewWriter::from_file(&file).unwrap();
    w.meta("note", "another model");
    let other = w.to_bytes().unwrap();
    assert_eq!(w.remove_prefixed("q16."), 3);
    let no_q16 = w.to_bytes().unwrap();
    for mode in [Mode::F32, Mode::Q16, Mode::Fast] {
        let r = record(&model, mode, &frames(m, 3)).unwrap();
        let v = verify(&model, &r).unwrap();
        assert_eq!(v.mode, mode);
        assert_eq!(v.frames.len(), 3);
        assert_eq!(v.first_mismatch, None);
        // Another model (one metadata entry more) is refused by content hash.
        let err = verify(&other, &r).unwrap_err();
        assert!(
            matches!(
                err,
                ReplayError::Refused(CoreReplayError::WrongModel { .. })
            ),
            "{err:?}"
        );
    }
    // Q16 needs the cache.
    let err = record(&no_q16, Mode::Q16, &frames(m, 1)).unwrap_err();
    assert!(
        matches!(
            err,
            ReplayError::Frame {
                frame: 0,
                source: CoreReplayError::NoQ16Cache
            }
        ),
        "{err:?}"
    );
}

#[test]
fn deviations_of_the_modes_on_the_golden_actor() {
    let model = golden();
    let m = AimActor::from_bytes(&model).unwrap().shape_count();
    let dev = |mode| deviation(&model, &record(&model, mode, &frames(m, 4)).unwrap()).unwrap();
    let exact = dev(Mode::F32);
    assert_eq!((exact.max_mm, exact.max_normal_diff), (0.0, 0.0));
    // Q16.16 of centimetres: steps of 1.5e-4 mm, a few roundings per vertex.
    let q = dev(Mode::Q16);
    assert!(q.max_mm > 0.0 && q.max_mm < 1e-2, "{q:?}");
    assert!(q.mean_mm <= q.max_mm);
    // Fast: positions bit-identical, normals within the approximation's 0.2 %.
    let f = dev(Mode::Fast);
    assert_eq!(f.max_mm, 0.0);
    assert!(f.max_normal_diff > 0.0 && f.max_normal_diff < 2e-3, "{f:?}");
}

/// The tiny synthetic decoder, and 4 frames of inputs.
fn s2d_fixture() -> (Vec<u8>, Vec<Vec<f32>>, Vec<f32>) {
    let model = crate::s2d::synthetic::tiny_baked_decoder().1;
    let (width, v) = {
        let d = S2dDecoder::from_bytes(&model).unwrap();
        (d.input_len(), d.vertex_count())
    };
    let inputs = (0..4)
        .map(|f| (0..width).map(|i| (f * 7 + i) as f32 * 0.01).collect())
        .collect();
    let neutral = (0..3 * v).map(|i| i as f32 * 0.1).collect();
    (model, inputs, neutral)
}

#[test]
fn s2d_record_then_verify_and_refusals() {
    let (model, inputs, neutral) = s2d_fixture();
    for n in [None, Some(neutral.as_slice())] {
        let r = record_s2d(&model, &inputs, n).unwrap();
        let v = verify(&model, &r).unwrap();
        assert_eq!((v.frames.len(), v.first_mismatch), (4, None));
        assert_eq!(
            s2d_inputs(&r).unwrap(),
            (inputs.clone(), n.map(<[f32]>::to_vec))
        );
    }
    let with = record_s2d(&model, &inputs, Some(&neutral)).unwrap();
    let without = record_s2d(&model, &inputs, None).unwrap();
    // Decoding onto another neutral changes every frame's hash.
    let (a, b) = (
        verify(&model, &with).unwrap(),
        verify(&model, &without).unwrap(),
    );
    assert!(
        a.frames
            .iter()
            .zip(&b.frames)
            .all(|(x, y)| x.hash != y.hash)
    );
    // Another decoder (one metadata entry more) is refused by content hash.
    let file = sinew_core::SinewFile::from_bytes(&model).unwrap();
    let mut w = SinewWriter::from_file(&file).unwrap();
    w.meta("note", "another model");
    let err = verify(&w.to_bytes().unwrap(), &with).unwrap_err();
    assert!(
        matches!(
            err,
            ReplayError::Refused(CoreReplayError::WrongModel { .. })
        ),
        "{err:?}"
    );
    // An AIM actor with an S2D replay, and an S2D decoder with an AIM replay.
    let err = verify(&golden(), &with).unwrap_err();
    assert!(matches!(err, ReplayError::S2dReplayForAim), "{err:?}");
    let aim = golden();
    let m = AimActor::from_bytes(&aim).unwrap().shape_count();
    let aim_replay = record(&aim, Mode::F32, &frames(m, 2)).unwrap();
    let err = verify(&model, &aim_replay).unwrap_err();
    assert!(matches!(err, ReplayError::AimReplayForS2d), "{err:?}");
    // Recording refuses wrong lengths, naming them.
    let err = record_s2d(&model, &[vec![0.0; 5]], None).unwrap_err();
    assert!(
        matches!(
            err,
            ReplayError::InputLength {
                frame: 0,
                inputs: 5,
                ..
            }
        ),
        "{err:?}"
    );
    let err = record_s2d(&model, &inputs, Some(&neutral[1..])).unwrap_err();
    assert!(
        matches!(err, ReplayError::NeutralLength { values, .. } if values == neutral.len() - 1),
        "{err:?}"
    );
}

#[test]
fn an_s2d_tampered_frame_is_named() {
    let (model, inputs, neutral) = s2d_fixture();
    let good = record_s2d(&model, &inputs, Some(&neutral)).unwrap();
    // Frame 1's input changed after recording: re-record, then put the good hashes back.
    let mut changed = inputs.clone();
    changed[1][0] += 0.25;
    let bad = record_s2d(&model, &changed, Some(&neutral)).unwrap();
    let hashes: Vec<u32> = sinew_core::SinewFile::from_bytes(&good)
        .unwrap()
        .u32_tensor(FRAME_HASHES, &[4, 2])
        .unwrap()
        .iter()
        .collect();
    let file = sinew_core::SinewFile::from_bytes(&bad).unwrap();
    let mut w = SinewWriter::from_file(&file).unwrap();
    w.remove_prefixed(FRAME_HASHES);
    w.u32s(FRAME_HASHES, &[4, 2], &hashes).unwrap();
    let v = verify(&model, &w.to_bytes().unwrap()).unwrap();
    assert_eq!(v.first_mismatch, Some(1));
    assert!(v.frames[1].to_string().contains("DIFFERS"));
    assert!(v.frames.iter().filter(|c| !c.ok()).count() == 1);
}

#[test]
fn a_corrupted_hash_names_its_frame() {
    let model = golden();
    let m = AimActor::from_bytes(&model).unwrap().shape_count();
    let good = record(&model, Mode::F32, &frames(m, 4)).unwrap();
    // Re-record with frame 2's input changed, but frame 2's hash from the good recording:
    // verification must name frame 2 as the first that differs.
    let mut changed = frames(m, 4);
    changed[2].weights[0] += 0.5;
    let bad = record(&model, Mode::F32, &changed).unwrap();
    let good_r = AimReplay::from_bytes(&good).unwrap();
    let bad_r = AimReplay::from_bytes(&bad).unwrap();
    assert_ne!(good_r.expected(2), bad_r.expected(2));
    let file = sinew_core::SinewFile::from_bytes(&bad).unwrap();
    let mut hashes: Vec<u32> = Vec::new();
    for f in 0..4 {
        let h = if f == 2 {
            good_r.expected(f)
        } else {
            bad_r.expected(f)
        }
        .unwrap();
        hashes.extend(hash_words(h));
    }
    // Swap the hash section for the mixed list.
    let mut w2 = SinewWriter::new(ArtifactKind::Replay);
    w2.meta("mode", "f32");
    for s in file.sections().filter(|s| s.name().starts_with("replay.")) {
        if s.name() == FRAME_HASHES {
            w2.u32s(FRAME_HASHES, &[4, 2], &hashes).unwrap();
        } else {
            let dims: Vec<usize> = s.dims().iter().map(|&d| d as usize).collect();
            match s.f32s() {
                Some(v) => w2.f32s(s.name(), &dims, &v.iter().collect::<Vec<_>>()),
                None => w2.u32s(
                    s.name(),
                    &dims,
                    &s.u32s().unwrap().iter().collect::<Vec<_>>(),
                ),
            }
            .unwrap();
        }
    }
    let v = verify(&model, &w2.to_bytes().unwrap()).unwrap();
    assert_eq!(v.first_mismatch, Some(2));
    assert!(v.frames[2].to_string().contains("DIFFERS"));
    assert!(v.frames[3].ok());
}

#[test]
fn replay_commands_name_the_file_that_failed() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("actor.sinew");
    std::fs::write(&model, golden()).unwrap();
    let missing = dir.path().join("missing.sinew");
    let err = replay_verify(&model, &missing).unwrap_err();
    assert!(matches!(
        &err,
        ReplayFileError::Container(ContainerError::Read { path, .. }) if *path == missing
    ));

    let poses = dir.path().join("poses.json");
    std::fs::write(&poses, "{\"frames\": [").unwrap();
    let out = dir.path().join("replay.sinew");
    let err = replay_record(&model, &poses, &out, Mode::F32).unwrap_err();
    assert!(matches!(
        &err,
        ReplayFileError::Poses(PoseFileError::Parse { path, .. }) if *path == poses
    ));
    assert!(!out.exists());

    // A pose file of no frames is refused before anything is recorded.
    std::fs::write(&poses, "{\"frames\": []}").unwrap();
    let err = replay_record(&model, &poses, &out, Mode::F32).unwrap_err();
    assert!(matches!(
        err,
        ReplayFileError::Poses(PoseFileError::NoFrames { .. })
    ));

    // An S2D decoder records in f32 only.
    let decoder = dir.path().join("decoder.sinew");
    std::fs::write(&decoder, s2d_fixture().0).unwrap();
    let err = replay_record(&decoder, &poses, &out, Mode::Q16).unwrap_err();
    assert!(matches!(err, ReplayFileError::S2dMode { mode: Mode::Q16 }));
    assert!(!out.exists());
}
