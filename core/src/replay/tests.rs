//! The replays of `tests/data/` verified frame by frame through the core.

use super::*;
use std::vec;
use std::vec::Vec;

const ACTOR: &[u8] = include_bytes!("../../../tests/data/aim-procedural.sinew");
const ACTOR_REPLAYS: [&[u8]; 3] = [
    include_bytes!("../../../tests/data/aim-procedural.f32.replay.sinew"),
    include_bytes!("../../../tests/data/aim-procedural.q16.replay.sinew"),
    include_bytes!("../../../tests/data/aim-procedural.fast.replay.sinew"),
];
const DECODER: &[u8] = include_bytes!("../../../tests/data/s2d-ict.sinew");
const DECODER_REPLAY: &[u8] = include_bytes!("../../../tests/data/s2d-ict.replay.sinew");

#[test]
fn hash_words_are_low_word_first_and_read_back() {
    let h = 0x0123_4567_89AB_CDEF_u64;
    assert_eq!(hash_words(h), [0x89AB_CDEF, 0x0123_4567]);
    let bytes: Vec<u8> = hash_words(h).iter().flat_map(|w| w.to_le_bytes()).collect();
    assert_eq!(word_pair(&U32s::new(&bytes).unwrap(), 0), Some(h));
    let replay = AimReplay::from_bytes(ACTOR_REPLAYS[0]).unwrap();
    assert_eq!(replay.model_hash(), model_hash(ACTOR));
}

#[test]
fn golden_aim_replays_verify_frame_by_frame() {
    let actor = AimActor::from_bytes(ACTOR).unwrap();
    let (n, m) = (3 * actor.vertex_count(), actor.shape_count());
    for bytes in ACTOR_REPLAYS {
        let replay = AimReplay::from_bytes(bytes).unwrap();
        let (mut p, mut nrm, mut w) = (vec![0.0; n], vec![0.0; n], vec![0.0; m]);
        let (mut pq, mut wq) = (vec![Q16::ZERO; n], vec![Q16::ZERO; m]);
        let mut buf = FrameBuffers {
            positions: &mut p,
            normals: &mut nrm,
            positions_q16: &mut pq,
            weights: &mut w,
            weights_q16: &mut wq,
        };
        let mut checks = Vec::new();
        let first_bad = verify(ACTOR, &actor, &replay, &mut buf, |c| checks.push(*c));
        assert_eq!(first_bad, Ok(None), "{}", replay.mode());
        assert_eq!(checks.len(), replay.frames());
        assert!(
            checks
                .iter()
                .enumerate()
                .all(|(f, c)| c.frame == f && c.ok())
        );
        let last = check_frame(&actor, &replay, replay.frames() - 1, &mut buf).unwrap();
        assert_eq!(last, checks[replay.frames() - 1]);
        assert_eq!(
            check_frame(&actor, &replay, replay.frames(), &mut buf),
            Err(ReplayError::Buffer(BufferError::Input))
        );
    }
}

#[test]
fn golden_s2d_replay_verifies_frame_by_frame() {
    let decoder = S2dDecoder::from_bytes(DECODER).unwrap();
    let replay = S2dReplay::from_bytes(DECODER_REPLAY).unwrap();
    let v = 3 * decoder.vertex_count();
    let mut input = vec![0.0; decoder.input_len()];
    let mut neutral = vec![0.0; v];
    let mut scratch = vec![0.0; decoder.scratch_len()];
    let mut vertices = vec![0.0; v];
    let mut buf = S2dBuffers {
        input: &mut input,
        neutral: &mut neutral,
        scratch: &mut scratch,
        vertices: &mut vertices,
    };
    let mut checks = Vec::new();
    let first_bad = verify_s2d(DECODER, &decoder, &replay, &mut buf, |c| checks.push(*c));
    assert_eq!(first_bad, Ok(None));
    assert_eq!(checks.len(), replay.frames());
    assert!(checks.iter().all(FrameCheck::ok));
    assert_eq!(
        check_s2d_frame(&decoder, &replay, replay.frames(), &mut buf),
        Err(ReplayError::Buffer(BufferError::Input))
    );
    // The neutral goes in whole or not at all.
    assert_eq!(
        replay.copy_neutral(&mut vec![0.0; v - 3]),
        Err(BufferError::Input)
    );
    assert_eq!(replay.copy_neutral(&mut []), Err(BufferError::Input));
    // Without the neutral, frame 0 decodes onto the template, which is another face.
    let mut empty = [];
    buf.neutral = &mut empty;
    let onto_template = check_s2d_frame(&decoder, &replay, 0, &mut buf).unwrap();
    assert_eq!(onto_template.expected, checks[0].expected);
    assert!(!onto_template.ok());
}
