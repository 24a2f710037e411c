//! Inputs the core refuses instead of guessing (issue #37): a NaN, infinite, out-of-range or
//! degenerate head, jaw or coefficient is refused in every numeric mode with an error naming the
//! argument and the value, and a file whose checksums are valid but whose numbers could pose to
//! a non-finite value is refused at load naming the section and the value. Before, a NaN or
//! degenerate rotation became the identity with status OK, a NaN coefficient posed to NaN in f32
//! and to zero in Q16.16, and a cache holding 3.4e38 loaded and posed to NaN.

use sinew_core::aim::AimActor;
use sinew_core::error::{Argument, Bound, InputError, InputErrorKind, SectionName};
use sinew_core::motion::MotionGenerator;
use sinew_core::performance::Performance;
use sinew_core::q16::Q16;
use sinew_core::replay::{FrameBuffers, Mode, ReplayError, pose_frame_hash};
use sinew_core::s2d::S2dDecoder;
use sinew_core::{EvalError, FormatError};
use sinew_tests::{map_f32, with_f32};

const ACTOR: &[u8] = include_bytes!("../../data/aim-procedural.sinew");
const IDENTITY: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
const MODES: [Mode; 3] = [Mode::F32, Mode::Q16, Mode::Fast];

/// The identity with value `i` set to `v`.
fn with(i: usize, v: f32) -> [f32; 9] {
    let mut p = IDENTITY;
    p[i] = v;
    p
}

fn refused(argument: Argument, index: usize, kind: InputErrorKind) -> InputError {
    InputError::new(argument, index, kind)
}

/// Buffers of one frame of `actor`, every output filled with 7 so that a write shows.
struct Frame {
    positions: Vec<f32>,
    normals: Vec<f32>,
    positions_q16: Vec<Q16>,
    weights: Vec<f32>,
    weights_q16: Vec<Q16>,
}

impl Frame {
    fn new(actor: &AimActor<'_>, weights: &[f32]) -> Self {
        let n = 3 * actor.vertex_count();
        Self {
            positions: vec![7.0; n],
            normals: vec![7.0; n],
            positions_q16: vec![Q16::from_num(7); n],
            weights: weights.to_vec(),
            weights_q16: vec![Q16::ZERO; weights.len()],
        }
    }

    fn hash(
        &mut self,
        actor: &AimActor<'_>,
        mode: Mode,
        head: &[f32; 9],
        jaw: &[f32; 9],
    ) -> Result<u64, ReplayError> {
        let mut buf = FrameBuffers {
            positions: &mut self.positions,
            normals: &mut self.normals,
            positions_q16: &mut self.positions_q16,
            weights: &mut self.weights,
            weights_q16: &mut self.weights_q16,
        };
        pose_frame_hash(actor, mode, head, jaw, &mut buf)
    }

    fn untouched(&self) -> bool {
        self.positions
            .iter()
            .chain(&self.normals)
            .all(|&x| x == 7.0)
            && self.positions_q16.iter().all(|&x| x == Q16::from_num(7))
    }
}

#[test]
fn refused_heads_jaws_and_coefficients_are_named_in_every_mode() {
    use InputErrorKind::{Degenerate, NonFinite, OutOfRange};
    let actor = AimActor::from_bytes(ACTOR).unwrap();
    let zeros = vec![0.0f32; actor.shape_count()];
    let weights_with = |i: usize, v: f32| {
        let mut w = zeros.clone();
        w[i] = v;
        w
    };
    let nan = f32::NAN;
    let cases = [
        // A NaN or infinite rotation value.
        (
            with(0, nan),
            IDENTITY,
            zeros.clone(),
            refused(Argument::Head, 0, NonFinite),
        ),
        (
            IDENTITY,
            with(4, f32::INFINITY),
            zeros.clone(),
            refused(Argument::Jaw, 4, NonFinite),
        ),
        (
            IDENTITY,
            [nan; 9],
            zeros.clone(),
            refused(Argument::Jaw, 0, NonFinite),
        ),
        // All zero, a zero column, parallel or anti-parallel columns, columns too short.
        (
            [0.0; 9],
            IDENTITY,
            zeros.clone(),
            refused(Argument::Head, 0, Degenerate),
        ),
        (
            IDENTITY,
            with(0, 0.0),
            zeros.clone(),
            refused(Argument::Jaw, 0, Degenerate),
        ),
        (
            with(4, 0.0),
            IDENTITY,
            zeros.clone(),
            refused(Argument::Head, 3, Degenerate),
        ),
        (
            [1.0, 2.0, 3.0, -2.0, -4.0, -6.0, 0.0, 0.0, 0.0],
            IDENTITY,
            zeros.clone(),
            refused(Argument::Head, 3, Degenerate),
        ),
        (
            IDENTITY.map(|x| x * 1e-30),
            IDENTITY,
            zeros.clone(),
            refused(Argument::Head, 0, Degenerate),
        ),
        // Scaled by 1e20: the squares overflow f32.
        (
            IDENTITY,
            IDENTITY.map(|x| x * 1e20),
            zeros.clone(),
            refused(Argument::Jaw, 0, OutOfRange),
        ),
        // A NaN or huge translation.
        (
            with(7, nan),
            IDENTITY,
            zeros.clone(),
            refused(Argument::Head, 7, NonFinite),
        ),
        (
            IDENTITY,
            with(8, -1e20),
            zeros.clone(),
            refused(Argument::Jaw, 8, OutOfRange),
        ),
        // A NaN, infinite or huge coefficient.
        (
            IDENTITY,
            IDENTITY,
            weights_with(2, nan),
            refused(Argument::Weights, 2, NonFinite),
        ),
        (
            IDENTITY,
            IDENTITY,
            weights_with(0, f32::NEG_INFINITY),
            refused(Argument::Weights, 0, NonFinite),
        ),
        (
            IDENTITY,
            IDENTITY,
            weights_with(5, 1e20),
            refused(Argument::Weights, 5, OutOfRange),
        ),
    ];
    for (head, jaw, weights, expected) in cases {
        for mode in MODES {
            let mut frame = Frame::new(&actor, &weights);
            let got = frame.hash(&actor, mode, &head, &jaw);
            assert_eq!(got, Err(ReplayError::Input(expected)), "{mode}: {expected}");
            assert!(frame.untouched(), "{mode}: {expected}: nothing is written");
        }
        // The f32 entry itself: the pose or the coefficients, and the message names both.
        let direct = actor
            .pose_from_9d(&jaw, &head)
            .map_err(EvalError::from)
            .and_then(|pose| {
                let mut out = vec![0.0; 3 * actor.vertex_count()];
                actor.pose(&pose, &weights, &mut out)
            });
        assert_eq!(direct, Err(EvalError::Input(expected)));
        let message = expected.to_string();
        let name = format!("{}[{}", expected.argument.name(), expected.index);
        assert!(message.starts_with(&name), "{message}");
    }
}

#[test]
fn refusal_messages_read_as_sentences() {
    use InputErrorKind::{Degenerate, NonFinite, OutOfRange};
    let cases = [
        (
            refused(Argument::Head, 3, NonFinite),
            "head[3] is NaN or infinite",
        ),
        (
            refused(Argument::Jaw, 0, OutOfRange),
            "jaw[0] is outside ±1e6",
        ),
        (
            refused(Argument::Jaw, 7, OutOfRange),
            "jaw[7] is outside ±1e5",
        ),
        (
            refused(Argument::Weights, 2, OutOfRange),
            "weights[2] is outside ±1e3",
        ),
        (
            refused(Argument::Mask, 9, OutOfRange),
            "mask[9] is outside [0, 1]",
        ),
        (
            refused(Argument::Head, 0, Degenerate),
            "head[0..3], the 6D rotation's first column, is shorter than 1e-6",
        ),
        (
            refused(Argument::Jaw, 3, Degenerate),
            "jaw[3..6], the 6D rotation's second column, is shorter than 1e-6 or parallel to the \
             first",
        ),
        (
            refused(Argument::Neutral, 0, Degenerate),
            "neutral: the landmarks all coincide (the set has no size to normalise by)",
        ),
    ];
    for (e, text) in cases {
        assert_eq!(e.to_string(), text);
    }
}

#[test]
fn a_file_with_valid_crcs_whose_cache_holds_3_4e38_is_refused_at_load() {
    let bad = with_f32(ACTOR, "cache.e", 7, 3.4e38);
    // The container is intact: only the value's role refuses it.
    assert!(sinew_core::SinewFile::from_bytes(&bad).is_ok());
    let err = AimActor::from_bytes(&bad).unwrap_err();
    assert_eq!(
        err,
        FormatError::ValueOutOfRange {
            section: SectionName::new("cache.e"),
            index: 7,
            bound: Bound::Coordinate,
        }
    );
    assert_eq!(
        err.to_string(),
        "section cache.e: value 7 is outside ±1e5, the limit of a length"
    );
    // Each section evaluation reads, and a NaN named by section and index.
    for (name, index, value, bound) in [
        ("cache.s0", 4, -2e5, Bound::Coordinate),
        ("cache.k", 0, 1e4, Bound::Factor),
        ("jaw.pivot", 2, 1e30, Bound::Coordinate),
        ("tpl.pos", 11, 3.4e38, Bound::Coordinate),
    ] {
        let index: u32 = index;
        assert_eq!(
            AimActor::from_bytes(&with_f32(ACTOR, name, index as usize, value)).unwrap_err(),
            FormatError::ValueOutOfRange {
                section: SectionName::new(name),
                index,
                bound,
            },
            "{name}"
        );
    }
    let err = AimActor::from_bytes(&with_f32(ACTOR, "cache.s0", 5, f32::NAN)).unwrap_err();
    assert_eq!(
        err,
        FormatError::NonFiniteValue {
            section: SectionName::new("cache.s0"),
            index: 5,
        }
    );
    assert_eq!(
        err.to_string(),
        "section cache.s0: value 5 is NaN or infinite"
    );
    // An index is named the same way (written as the bits of 1,000 in the u32 section).
    let err =
        AimActor::from_bytes(&with_f32(ACTOR, "tpl.tri", 4, f32::from_bits(1000))).unwrap_err();
    assert_eq!(err, FormatError::index_out_of_range("tpl.tri", 4));
    assert_eq!(
        err.to_string(),
        "section tpl.tri: value 4 is an index out of range"
    );
}

/// At the limits, a valid file with accepted inputs poses to finite numbers in every mode: the
/// bounds are what make that a promise.
#[test]
fn the_worst_accepted_case_stays_finite_in_every_mode() {
    let m = AimActor::from_bytes(ACTOR).unwrap().shape_count();
    let alternate = |i: usize, limit: f32| if i.is_multiple_of(2) { limit } else { -limit };
    let bytes = map_f32(ACTOR, "cache.e", |i, _| alternate(i, 1e5));
    let bytes = map_f32(&bytes, "cache.k", |_, _| 1e3);
    let bytes = map_f32(&bytes, "cache.s0", |i, _| alternate(i / 3, 1e5));
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let weights: Vec<f32> = (0..m)
        .map(|j| if j.is_multiple_of(2) { 1e3 } else { -1e3 })
        .collect();
    let head = [1e6, -1e6, 1e6, 1e6, 1e6, -1e6, 1e5, -1e5, 1e5];
    let jaw = [-1e6, 1e6, 1e6, 1e6, 1e6, 1e6, -1e5, 1e5, 1e5];
    for mode in MODES {
        let mut frame = Frame::new(&actor, &weights);
        frame.hash(&actor, mode, &head, &jaw).unwrap();
        match mode {
            Mode::Q16 => assert!(
                frame
                    .positions_q16
                    .iter()
                    .any(|&x| x == Q16::MAX || x == Q16::MIN)
            ),
            _ => {
                let all = frame.positions.iter().chain(&frame.normals);
                assert!(all.clone().all(|x| x.is_finite()), "{mode}");
            }
        }
    }
}

#[test]
fn the_s2d_decoder_refuses_its_inputs_by_index() {
    let decoder = S2dDecoder::from_bytes(include_bytes!("../../data/s2d-ict.sinew")).unwrap();
    let mut input = vec![0.0f32; decoder.input_len()];
    let mut scratch = vec![0.0f32; decoder.scratch_len()];
    let mut out = vec![0.0f32; 3 * decoder.vertex_count()];
    input[17] = f32::NAN;
    assert_eq!(
        decoder.decode(&input, &mut scratch, &mut out),
        Err(EvalError::Input(refused(
            Argument::Input,
            17,
            InputErrorKind::NonFinite
        )))
    );
    input[17] = 2e3;
    assert_eq!(
        decoder.decode(&input, &mut scratch, &mut out),
        Err(EvalError::Input(refused(
            Argument::Input,
            17,
            InputErrorKind::OutOfRange
        )))
    );
    input[17] = 0.0;
    let mut neutral: Vec<f32> = decoder.neutral().iter().collect();
    neutral[30] = f32::INFINITY;
    assert_eq!(
        decoder.decode_onto(&neutral, &input, &mut scratch, &mut out),
        Err(EvalError::Input(refused(
            Argument::Neutral,
            30,
            InputErrorKind::NonFinite
        )))
    );
    // A landmark set whose points coincide has no size to normalise by.
    let same = vec![1.0f32; decoder.input_len()];
    let moved: Vec<f32> = (0..decoder.input_len()).map(|i| i as f32).collect();
    assert_eq!(
        decoder.input(&same, &moved, &mut input),
        Err(EvalError::Input(refused(
            Argument::Neutral,
            0,
            InputErrorKind::Degenerate
        )))
    );
}

#[test]
fn the_motion_generator_refuses_a_nan_intensity() {
    let generator =
        MotionGenerator::from_bytes(include_bytes!("../../data/motion-ict.sinew")).unwrap();
    let mut scratch = vec![0.0f32; generator.scratch_len()];
    let mut curve = vec![0.0f32; generator.curve_len()];
    let neutral: Vec<f32> = (0..generator.dims()).map(|i| (i % 7) as f32).collect();
    for (intensity, kind) in [
        (f32::NAN, InputErrorKind::NonFinite),
        (1e4, InputErrorKind::OutOfRange),
    ] {
        assert_eq!(
            generator.landmarks(0, 1, intensity, &neutral, &mut scratch, &mut curve),
            Err(EvalError::Input(refused(Argument::Intensity, 0, kind)))
        );
    }
    generator
        .landmarks(0, 1, 1.0, &neutral, &mut scratch, &mut curve)
        .unwrap();
    assert!(curve.iter().all(|x| x.is_finite()));
}

#[test]
fn a_performance_with_a_degenerate_frame_is_refused_at_load() {
    let fit = include_bytes!("../../data/fit-ict.sinew");
    assert!(Performance::from_bytes(fit).is_ok());
    // Frame 2's jaw rotation (values 9..15 of its row of 18) with a zero first column.
    let mut bytes = fit.to_vec();
    for i in 0..3 {
        bytes = with_f32(&bytes, "perf.pose", 2 * 18 + 9 + i, 0.0);
    }
    assert_eq!(
        Performance::from_bytes(&bytes).unwrap_err(),
        FormatError::ValueOutOfRange {
            section: SectionName::new("perf.pose"),
            index: 2 * 18 + 9,
            bound: Bound::Rotation,
        }
    );
    // A frame code beyond the factor limit.
    assert_eq!(
        Performance::from_bytes(&with_f32(fit, "perf.z", 3, 5e3)).unwrap_err(),
        FormatError::ValueOutOfRange {
            section: SectionName::new("perf.z"),
            index: 3,
            bound: Bound::Factor,
        }
    );
}

/// A copy of the valid `.sinew` file `bytes` with the text `from` replaced by `to` (as long) in
/// its bytes (e.g. in the metadata), every checksum recomputed.
fn with_text(bytes: &[u8], from: &[u8], to: &[u8]) -> Vec<u8> {
    assert_eq!(from.len(), to.len());
    let at = bytes
        .windows(from.len())
        .position(|w| w == from)
        .unwrap_or_else(|| panic!("no {}", String::from_utf8_lossy(from)));
    let mut out = bytes.to_vec();
    out[at..at + to.len()].copy_from_slice(to);
    sinew_tests::reseal(&mut out);
    out
}

/// A copy of the valid `.sinew` file `bytes` with its `f32` section `name` replaced by zeros of
/// `dims` (moved to the end of the file).
fn with_zeros(bytes: &[u8], name: &str, dims: &[usize]) -> Vec<u8> {
    let file = sinew_core::SinewFile::from_bytes(bytes).unwrap();
    let mut w = sinew_host::SinewWriter::from_file(&file).unwrap();
    assert_eq!(w.remove_prefixed(name), 1, "{name}");
    w.f32s(name, dims, &vec![0.0; dims.iter().product()])
        .unwrap();
    w.to_bytes().unwrap()
}

/// Issue #37: a load error names the section (or the metadata line and key) and the value at
/// fault, in words, never a Rust value: a misshapen section, a count past this build's limit, a
/// metadata entry a kind requires that is absent or of a value it does not take, and metadata
/// text that is not `key=value` lines or not UTF-8.
#[test]
fn load_errors_name_the_section_line_and_value_at_fault() {
    let refused = |bytes: &[u8]| AimActor::from_bytes(bytes).unwrap_err();
    let err = refused(&with_zeros(ACTOR, "jaw.pivot", &[4]));
    assert_eq!(err, FormatError::incompatible_shapes("jaw.pivot"));
    assert_eq!(
        err.to_string(),
        "section jaw.pivot has a shape that does not fit with the others"
    );
    let v = AimActor::from_bytes(ACTOR).unwrap().vertex_count();
    let err = refused(&with_zeros(ACTOR, "cache.e", &[v, 3]));
    assert_eq!(err, FormatError::incompatible_shapes("cache.e"));
    let too_many = sinew_core::aim::MAX_SHAPES + 1;
    let err = refused(&with_zeros(ACTOR, "cache.e", &[v, too_many, 3]));
    assert_eq!(
        err,
        FormatError::limit_exceeded("cache.e", too_many, sinew_core::aim::MAX_SHAPES)
    );
    assert_eq!(
        err.to_string(),
        format!(
            "section cache.e: a count of {too_many} exceeds this build's limit of {}",
            sinew_core::aim::MAX_SHAPES
        )
    );

    // A replay's mode: of a value no replay takes, absent, or one an S2D replay does not take.
    let replay = include_bytes!("../../data/aim-procedural.q16.replay.sinew");
    let mode = |bytes: &[u8]| sinew_core::replay::AimReplay::from_bytes(bytes).unwrap_err();
    let err = mode(&with_text(replay, b"mode=q16", b"mode=q64"));
    assert_eq!(
        err.to_string(),
        "metadata line 1: mode has a value this artefact does not take"
    );
    let err = mode(&with_text(replay, b"mode=q16", b"node=q16"));
    assert_eq!(err.to_string(), "metadata has no mode entry");
    let s2d = include_bytes!("../../data/s2d-ict.replay.sinew");
    let err = sinew_core::replay::S2dReplay::from_bytes(&with_text(s2d, b"mode=f32", b"mode=q16"))
        .unwrap_err();
    assert_eq!(
        err,
        FormatError::BadMetadata {
            key: SectionName::new("mode"),
            line: 1,
        }
    );
    // Text that is not key=value lines, or not UTF-8, fails the container, naming the line.
    let container = |bytes: &[u8]| sinew_core::SinewFile::from_bytes(bytes).unwrap_err();
    let err = container(&with_text(replay, b"frames=16", b"frames 16"));
    assert_eq!(
        err.to_string(),
        "metadata line 3 is not UTF-8 key=value text"
    );
    let err = container(&with_text(replay, b"model=", b"mo\xFFel="));
    assert_eq!(
        err.to_string(),
        "metadata line 2 is not UTF-8 key=value text"
    );
    // A second metadata section is refused by its index, as a name that is not `meta`.
    let mut w =
        sinew_host::SinewWriter::from_file(&sinew_core::SinewFile::from_bytes(ACTOR).unwrap())
            .unwrap();
    let kind = sinew_core::format::SectionKind::Metadata;
    w.raw(kind, "notes", b"a=b\n".to_vec()).unwrap();
    let bytes = w.to_bytes().unwrap();
    let index = (0..)
        .find(|&i| {
            let e = sinew_core::format::HEADER_LEN + i * sinew_core::format::SECTION_ENTRY_LEN;
            bytes[e + 4..e + 9] == *b"notes"
        })
        .unwrap();
    assert_eq!(
        container(&bytes),
        FormatError::BadName {
            section: index as u16
        }
    );

    // A motion generator's content, named by its line.
    let motion = include_bytes!("../../data/motion-ict.sinew");
    let file = sinew_core::SinewFile::from_bytes(motion).unwrap();
    let line = 1 + file
        .metadata()
        .iter()
        .position(|(k, _)| k == "content")
        .unwrap();
    let mut w = sinew_host::SinewWriter::from_file(&file).unwrap();
    w.meta("content", "s2d-replay");
    let err = MotionGenerator::from_bytes(&w.to_bytes().unwrap()).unwrap_err();
    assert_eq!(
        err,
        FormatError::BadMetadata {
            key: SectionName::new("content"),
            line: line as u32,
        }
    );
}
