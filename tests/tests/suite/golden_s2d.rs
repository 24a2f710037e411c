//! Golden S2D replay: a small S2D decoder trained briefly on real ICT-FaceKit pairs (the face
//! region decimated to 1,177 vertices; committed, see NOTICE and docs/S2D.md for the commands)
//! decodes 16 frames of real ICT expressions, transferred onto another identity's neutral. The
//! replay (`s2d-ict.replay.sinew`: the decoder's content hash, each frame's decoder input, the
//! neutral, the per-frame hashes) is pinned byte for byte, with a readable hash list beside it.
//! The same replay runs on every firmware target.
//!
//! The inputs come from the ICT-FaceKit data, so only `UPDATE_EXPECT=1` with the data present
//! rebuilds them; otherwise the test re-records the committed replay's own inputs and checks the
//! bytes, which pins the decoder's arithmetic all the same.

use std::fmt::Write;

use sinew_core::s2d::S2dDecoder;
use sinew_host::replay::{record_s2d, s2d_inputs, verify};
use sinew_tests::{check, check_bytes, golden_dir};

const MODEL: &str = "s2d-ict.sinew";
const REPLAY: &str = "s2d-ict.replay.sinew";
const HASHES: &str = "s2d-ict.hashes";

/// The decimation factor the golden decoder's pairs were made with (`sinew data s2d-pairs
/// --decimate 8`).
const DECIMATE: usize = 8;

fn read(name: &str) -> Vec<u8> {
    let path = golden_dir().join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: golden file missing ({e})", path.display()))
}

/// The expression weights of frame `f` (of 16): a smile with raised inner brows builds over
/// frames 0..8 (frame 0 is the neutral), then the jaw opens while the smile fades (to 1/8 of
/// it at frame 15).
fn weights(f: usize) -> Vec<(&'static str, f32)> {
    if f < 8 {
        let t = f as f32 / 7.0;
        vec![
            ("mouthSmile_L", t),
            ("mouthSmile_R", t),
            ("browInnerUp_L", 0.5 * t),
            ("browInnerUp_R", 0.5 * t),
        ]
    } else {
        let t = (f - 7) as f32 / 8.0;
        vec![
            ("mouthSmile_L", 1.0 - t),
            ("mouthSmile_R", 1.0 - t),
            ("browInnerUp_L", 0.5),
            ("browInnerUp_R", 0.5),
            ("jawOpen", t),
        ]
    }
}

/// The real input sequence (only under `UPDATE_EXPECT=1`): ICT pairs generated as for the
/// decoder's training set (seed 1) and decimated the same way; identity 0 performs the 16
/// frames of [`weights`] (landmark inputs as in training), decoded onto identity 1's neutral.
fn real_sequence(model: &[u8]) -> (Vec<Vec<f32>>, Option<Vec<f32>>) {
    use sinew_host::s2d::data::{Expressions, PairsConfig, generate};
    use sinew_host::s2d::decoder::InputNormalisation::Frobenius;
    use sinew_host::s2d::train::landmark_input;
    let root = sinew_tests::data_dir("ict-facekit")
        .expect("UPDATE_EXPECT=1 for the S2D replay needs the ICT-FaceKit data ($SINEW_DATA)");
    let kit = sinew_host::io::ict::IctFaceKit::open(&root).unwrap();
    // The kit's shared deltas, the default when the decoder was made.
    let config = PairsConfig {
        expressions: Expressions::Shared,
        ..PairsConfig::default()
    };
    let set = generate(&kit, &config)
        .unwrap()
        .decimated(DECIMATE)
        .unwrap();
    let dec = S2dDecoder::from_bytes(model).unwrap();
    assert_eq!(dec.vertex_count(), set.vertices());
    assert!(
        dec.landmarks()
            .iter()
            .eq(set.manifest.landmarks.iter().copied()),
        "the golden decoder's landmarks differ from the decimated pairs'"
    );
    let source = &set.neutrals[0];
    let index = |name: &str| {
        set.manifest
            .expressions
            .iter()
            .position(|e| e == name)
            .unwrap()
    };
    let inputs = (0..16)
        .map(|f| {
            let mut face = source.clone();
            for (name, w) in weights(f) {
                for (p, d) in face.iter_mut().zip(set.delta(0, index(name))) {
                    for c in 0..3 {
                        p[c] += w * d[c];
                    }
                }
            }
            landmark_input(
                Frobenius,
                &set.landmarks_of(source),
                &set.landmarks_of(&face),
            )
            .unwrap()
        })
        .collect();
    let target = set.neutrals[1].iter().flatten().copied().collect();
    (inputs, Some(target))
}

#[test]
fn ict_decoder_replay_is_pinned() {
    let model = read(MODEL);
    let dec = S2dDecoder::from_bytes(&model).unwrap();
    let (inputs, neutral) = if std::env::var_os("UPDATE_EXPECT").is_some_and(|v| v == "1") {
        real_sequence(&model)
    } else {
        s2d_inputs(&read(REPLAY)).unwrap()
    };
    assert_eq!(inputs.len(), 16);
    let replay = record_s2d(&model, &inputs, neutral.as_deref()).unwrap();
    check_bytes(REPLAY, &replay);
    let v = verify(&model, &read(REPLAY)).unwrap();
    assert_eq!(v.first_mismatch, None);
    // Frames differ from each other: the sequence really moves.
    assert_ne!(v.frames[1].hash, v.frames[15].hash);
    let mut text = String::new();
    writeln!(
        text,
        "# {MODEL}: {} vertices, {} inputs, {} scratch values; per frame: the decoded vertices \
         (f32 bits), decoded onto the replay's neutral",
        dec.vertex_count(),
        dec.input_len(),
        dec.scratch_len()
    )
    .unwrap();
    for c in &v.frames {
        writeln!(text, "s2d {} {:016x}", c.frame, c.hash).unwrap();
    }
    check(HASHES, &text);
}

/// Frame 0 of the golden sequence is the neutral itself: its input is zero, and the decoder's
/// output is the neutral plus whatever the network gives for no motion (small after training).
#[test]
fn the_golden_sequence_starts_at_rest() {
    let (inputs, neutral) = s2d_inputs(&read(REPLAY)).unwrap();
    assert!(inputs[0].iter().all(|&x| x == 0.0));
    assert!(inputs[15].iter().any(|&x| x != 0.0));
    let model = read(MODEL);
    let dec = S2dDecoder::from_bytes(&model).unwrap();
    let mut scratch = vec![0.0; dec.scratch_len()];
    let mut out = vec![0.0; 3 * dec.vertex_count()];
    dec.displacements(&inputs[0], &mut scratch, &mut out)
        .unwrap();
    let rest = out.iter().fold(0.0f32, |m, &x| m.max(x.abs()));
    // ICT is in cm: under 2 mm of drift at rest, against centimetres of motion at frame 15.
    assert!(rest < 0.2, "largest displacement at rest {rest} cm");
    dec.displacements(&inputs[15], &mut scratch, &mut out)
        .unwrap();
    let open = out.iter().fold(0.0f32, |m, &x| m.max(x.abs()));
    assert!(
        open > 5.0 * rest,
        "frame 15 moves {open} cm, rest {rest} cm"
    );
    assert_eq!(neutral.map(|n| n.len()), Some(3 * dec.vertex_count()));
}
