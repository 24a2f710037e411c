//! Fuzzes the value bounds behind the loaders: a golden file of `tests/data/` with the fuzzer's
//! edits written into its section data and every checksum recomputed, so that each input passes
//! the container's checks and reaches the typed loader's shape, index and value checks. Whatever
//! loads is then evaluated with bounded random inputs in every numeric mode, and every output
//! must be finite: no valid file poses to a non-finite number. Inputs the core refuses are
//! allowed; a panic or a non-finite output is a finding.
//! Run: `cd core/fuzz && cargo fuzz run values -s none` (docs/ROBUSTNESS.md).
//!
//! An input is: one byte choosing the golden, one byte counting the edits (at most
//! [`MAX_EDITS`]), the edits (9 bytes each: section, element index, the element's new 4 bytes),
//! then bytes that seed the evaluation's inputs.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sinew_core::aim::AimActor;
use sinew_core::format::{
    CRC32, Dtype, ENTRY_CRC, HEADER_CRC, HEADER_CRC_OFFSET, HEADER_LEN, SECTION_ENTRY_LEN,
};
use sinew_core::layout::{MAX_COORDINATE, MAX_FACTOR, MAX_ROTATION_ENTRY};
use sinew_core::motion::{LABELS, MotionGenerator};
use sinew_core::performance::{Performance, play_frame_hash};
use sinew_core::q16::Q16;
use sinew_core::replay::{FrameBuffers, Mode, ReplayError, model_hash, pose_frame_hash};
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_core::{EvalError, SinewFile};

const AIM_PROCEDURAL: &[u8] = include_bytes!("../../../tests/data/aim-procedural.sinew");
const AIM_ICT: &[u8] = include_bytes!("../../../tests/data/aim-ict.sinew");
const S2D_ICT: &[u8] = include_bytes!("../../../tests/data/s2d-ict.sinew");
const MOTION_ICT: &[u8] = include_bytes!("../../../tests/data/motion-ict.sinew");
const FIT_ICT: &[u8] = include_bytes!("../../../tests/data/fit-ict.sinew");

/// Most edits one input applies.
const MAX_EDITS: usize = 16;
/// Bytes of one edit.
const EDIT_LEN: usize = 9;

/// What the chosen golden is, and the untouched golden it is evaluated with.
#[derive(Clone, Copy)]
enum Golden {
    /// An AIM actor, posed in every mode.
    Aim(&'static [u8]),
    /// The S2D decoder, decoded onto its template and onto another neutral.
    S2d,
    /// The motion generator, played with the golden S2D decoder as a sequence.
    Motion,
    /// The fitted performance, played on the golden ICT actor.
    Performance,
}

/// The goldens, by the input's first byte: the small actor most often (a thousand executions a
/// second), the 2.6 MB ICT actor and the performance played on it least (tens a second).
const GOLDENS: [Golden; 10] = [
    Golden::Aim(AIM_PROCEDURAL),
    Golden::Aim(AIM_PROCEDURAL),
    Golden::Aim(AIM_PROCEDURAL),
    Golden::Aim(AIM_PROCEDURAL),
    Golden::Aim(AIM_PROCEDURAL),
    Golden::S2d,
    Golden::S2d,
    Golden::Motion,
    Golden::Aim(AIM_ICT),
    Golden::Performance,
];

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    let golden = GOLDENS[usize::from(which) % GOLDENS.len()];
    let file = match golden {
        Golden::Aim(bytes) => bytes,
        Golden::S2d => S2D_ICT,
        Golden::Motion => MOTION_ICT,
        Golden::Performance => FIT_ICT,
    };
    let (count, rest) = rest.split_first().map_or((0, rest), |(&n, r)| (n, r));
    let edits = (usize::from(count) % (MAX_EDITS + 1)).min(rest.len() / EDIT_LEN);
    let (edits, seed) = rest.split_at(edits * EDIT_LEN);
    let bytes = edited(file, edits);
    let mut rng = Rng(model_hash(seed) | 1);
    match golden {
        Golden::Aim(_) => aim(&bytes, &mut rng),
        Golden::S2d => s2d(&bytes, &mut rng),
        Golden::Motion => motion(&bytes, &mut rng),
        Golden::Performance => performance(&bytes, &mut rng),
    }
});

/// `file` with each edit (section, element, 4 bytes: the element's new bits, or for a byte
/// section its new first byte) written in, then every section CRC and the header CRC
/// recomputed.
fn edited(file: &[u8], edits: &[u8]) -> Vec<u8> {
    let golden = SinewFile::from_bytes(file).expect("the goldens are valid");
    let sections: Vec<_> = golden.sections().collect();
    let mut out = file.to_vec();
    for edit in edits.chunks_exact(EDIT_LEN) {
        let section = &sections[usize::from(edit[0]) % sections.len()];
        let size = section.dtype.map_or(1, Dtype::size);
        let elements = section.data().len() / size;
        if elements == 0 {
            continue;
        }
        let index = u32::from_le_bytes(edit[1..5].try_into().unwrap()) as usize % elements;
        let at = section.offset as usize + index * size;
        out[at..at + size].copy_from_slice(&edit[5..5 + size]);
    }
    for (i, section) in sections.iter().enumerate() {
        let start = section.offset as usize;
        let crc = CRC32.checksum(&out[start..start + section.data().len()]);
        let entry = HEADER_LEN + i * SECTION_ENTRY_LEN;
        out[ENTRY_CRC.at(entry)].copy_from_slice(&crc.to_le_bytes());
    }
    let table_end = HEADER_LEN + sections.len() * SECTION_ENTRY_LEN;
    let mut digest = CRC32.digest();
    digest.update(&out[..HEADER_CRC_OFFSET]);
    digest.update(&out[HEADER_LEN..table_end]);
    let crc = digest.finalize();
    out[HEADER_CRC.range()].copy_from_slice(&crc.to_le_bytes());
    out
}

/// SplitMix64: the evaluation's inputs from the input's last bytes.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A value within ±`limit`, often at the limit itself (where overflow would start), else
    /// small or anywhere in between.
    fn within(&mut self, limit: f32) -> f32 {
        let sign = if self.next() & 1 == 0 { 1.0 } else { -1.0 };
        sign * match self.next() % 4 {
            0 => limit,
            1 => limit * self.unit(),
            2 => self.unit(),
            _ => 0.0,
        }
    }

    /// A head or jaw: six rotation values and a translation within their limits. Often a
    /// rotation the core refuses as degenerate; that is allowed.
    fn transform(&mut self) -> [f32; 9] {
        std::array::from_fn(|i| {
            if i < 6 {
                self.within(MAX_ROTATION_ENTRY)
            } else {
                self.within(MAX_COORDINATE)
            }
        })
    }
}

fn finite(values: &[f32]) -> bool {
    values.iter().all(|x| x.is_finite())
}

/// Poses a loaded actor with bounded inputs in every mode; accepted inputs must give finite
/// positions and normals.
fn aim(bytes: &[u8], rng: &mut Rng) {
    let Ok(actor) = AimActor::from_bytes(bytes) else {
        return;
    };
    let (n, m) = (3 * actor.vertex_count(), actor.shape_count());
    let weights: Vec<f32> = (0..m).map(|_| rng.within(MAX_FACTOR)).collect();
    let (head, jaw) = (rng.transform(), rng.transform());
    for mode in [Mode::F32, Mode::Fast, Mode::Q16] {
        let (mut positions, mut normals) = (vec![0.0f32; n], vec![0.0f32; n]);
        let mut positions_q16 = vec![Q16::ZERO; n];
        let (mut w, mut wq) = (weights.clone(), vec![Q16::ZERO; m]);
        let mut buf = FrameBuffers {
            positions: &mut positions,
            normals: &mut normals,
            positions_q16: &mut positions_q16,
            weights: &mut w,
            weights_q16: &mut wq,
        };
        match pose_frame_hash(&actor, mode, &head, &jaw, &mut buf) {
            Ok(_) => assert!(
                finite(&positions) && finite(&normals),
                "{mode}: a non-finite output from accepted inputs"
            ),
            Err(ReplayError::Input(_)) => {}
            Err(ReplayError::NoQ16Cache) if actor.q16().is_none() => {}
            Err(e) => panic!("{mode}: {e}"),
        }
    }
}

/// Decodes a loaded decoder's bounded inputs onto its template and onto a bounded neutral.
fn s2d(bytes: &[u8], rng: &mut Rng) {
    let Ok(decoder) = S2dDecoder::from_bytes(bytes) else {
        return;
    };
    let input: Vec<f32> = (0..decoder.input_len())
        .map(|_| rng.within(MAX_FACTOR))
        .collect();
    let neutral: Vec<f32> = (0..3 * decoder.vertex_count())
        .map(|_| rng.within(MAX_COORDINATE))
        .collect();
    let mut scratch = vec![0.0f32; decoder.scratch_len()];
    let mut out = vec![0.0f32; 3 * decoder.vertex_count()];
    decoder.decode(&input, &mut scratch, &mut out).unwrap();
    assert!(finite(&out), "decode: a non-finite output");
    decoder
        .decode_onto(&neutral, &input, &mut scratch, &mut out)
        .unwrap();
    assert!(finite(&out), "decode_onto: a non-finite output");
    let landmarks: Vec<f32> = (0..decoder.input_len())
        .map(|_| rng.within(MAX_COORDINATE))
        .collect();
    let mut derived = vec![0.0f32; decoder.input_len()];
    match decoder.input(&input, &landmarks, &mut derived) {
        Ok(()) => assert!(finite(&derived), "input: a non-finite output"),
        Err(EvalError::Input(_)) => {}
        Err(e) => panic!("input: {e}"),
    }
}

/// Plays a loaded generator with the golden decoder: the curve from a bounded intensity must
/// be finite, and so must every frame the decoder accepts.
fn motion(bytes: &[u8], rng: &mut Rng) {
    let Ok(generator) = MotionGenerator::from_bytes(bytes) else {
        return;
    };
    let decoder = S2dDecoder::from_bytes(S2D_ICT).expect("the golden decoder");
    let Ok(sequence) = Sequence::new(generator, decoder) else {
        return;
    };
    let mut curve = vec![0.0f32; sequence.curve_len()];
    let mut input = vec![0.0f32; sequence.input_len()];
    let mut scratch = vec![0.0f32; sequence.scratch_len()];
    let mut vertices = vec![0.0f32; sequence.vertex_len()];
    let mut buf = SequenceBuffers {
        curve: &mut curve,
        input: &mut input,
        neutral: &[],
        scratch: &mut scratch,
        vertices: &mut vertices,
    };
    let label = (rng.next() % LABELS as u64) as usize;
    let intensity = rng.within(MAX_FACTOR);
    sequence
        .curve(label, rng.next(), intensity, &mut buf)
        .unwrap();
    assert!(finite(buf.curve), "curve: a non-finite landmark");
    let t = 1 + (rng.next() % 30) as usize;
    match sequence.frame(t, &mut buf) {
        Ok(()) => assert!(finite(buf.vertices), "frame {t}: a non-finite vertex"),
        Err(EvalError::Input(_)) => {}
        Err(e) => panic!("frame {t}: {e}"),
    }
}

/// Plays one frame of a loaded performance on the golden ICT actor; it must be finite.
fn performance(bytes: &[u8], rng: &mut Rng) {
    let Ok(perf) = Performance::from_bytes(bytes) else {
        return;
    };
    let actor = AimActor::from_bytes(AIM_ICT).expect("the golden actor");
    if perf.shape_count() != actor.shape_count() {
        return;
    }
    if perf
        .point_count()
        .is_some_and(|p| p != actor.vertex_count())
    {
        return;
    }
    let f = (rng.next() % perf.frames() as u64) as usize;
    let mut scratch = vec![0.0f32; perf.scratch_len()];
    let mut positions = vec![0.0f32; 3 * actor.vertex_count()];
    let mut normals = vec![0.0f32; positions.len()];
    play_frame_hash(&perf, &actor, f, &mut scratch, &mut positions, &mut normals).unwrap();
    assert!(
        finite(&positions) && finite(&normals),
        "frame {f}: a non-finite output"
    );
}
