//! Golden generated sequence: a small Motion3DGAN generator (`motion-ict.sinew`, hidden 16, 16;
//! committed, see NOTICE and docs/MOTION.md for the commands) makes the landmark curve of one
//! label and seed at intensity 1 on the golden S2D decoder's template neutral, and the decoder
//! (`s2d-ict.sinew`) decodes its 30 frames onto that neutral, all through
//! `sinew_core::sequence::Sequence`. Each frame's hash (the decoded vertices' f32 bits, the hash
//! of every golden) is pinned in `motion-ict.hashes`, whose `sequence` line tells the firmware
//! targets what to generate; the same hashes are checked on every firmware target.

use std::fmt::Write;

use sinew_core::SinewFile;
use sinew_core::motion::MotionGenerator;
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_core::srvf::FRAMES;
use sinew_tests::{check, golden_dir};

const GENERATOR: &str = "motion-ict.sinew";
const DECODER: &str = "s2d-ict.sinew";
const HASHES: &str = "motion-ict.hashes";
/// The golden sequence: CoMA's mouth_open, from seed 7, at the training motions' mean length.
const LABEL: &str = "mouth_open";
const SEED: u64 = 7;
const INTENSITY: f32 = 1.0;

fn read(name: &str) -> Vec<u8> {
    let path = golden_dir().join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: golden file missing ({e})", path.display()))
}

/// The label's index in the generator's `labels` metadata.
fn label_index(generator: &[u8]) -> usize {
    let file = SinewFile::from_bytes(generator).unwrap();
    let labels = file.metadata().get("labels").unwrap();
    labels.split(',').position(|l| l == LABEL).unwrap()
}

/// Frames 1 to 30 of the golden sequence through the core, each frame's vertices.
fn core_frames(generator: &[u8], decoder: &[u8]) -> Vec<Vec<f32>> {
    let seq = Sequence::new(
        MotionGenerator::from_bytes(generator).unwrap(),
        S2dDecoder::from_bytes(decoder).unwrap(),
    )
    .unwrap();
    let mut curve = vec![0.0; seq.curve_len()];
    let mut input = vec![0.0; seq.input_len()];
    let mut scratch = vec![0.0; seq.scratch_len()];
    let mut vertices = vec![0.0; seq.vertex_len()];
    let mut buf = SequenceBuffers {
        curve: &mut curve,
        input: &mut input,
        neutral: &[],
        scratch: &mut scratch,
        vertices: &mut vertices,
    };
    seq.curve(label_index(generator), SEED, INTENSITY, &mut buf)
        .unwrap();
    (1..=FRAMES)
        .map(|t| {
            seq.frame(t, &mut buf).unwrap();
            buf.vertices.to_vec()
        })
        .collect()
}

#[test]
fn the_generated_sequence_is_pinned() {
    let generator = read(GENERATOR);
    let decoder = read(DECODER);
    // Small enough for the firmware's flash beside the other goldens.
    assert!(generator.len() < 512 * 1024, "{} bytes", generator.len());
    let frames = core_frames(&generator, &decoder);
    let dec = S2dDecoder::from_bytes(&decoder).unwrap();
    let generator_model = MotionGenerator::from_bytes(&generator).unwrap();
    let mut text = String::new();
    writeln!(
        text,
        "# {GENERATOR} (noise {}, {} coordinates) through {DECODER} ({} vertices) onto the \
         decoder's template neutral; the sequence: label name, label index, seed, intensity; \
         per frame 1 to {FRAMES}: the decoded vertices (f32 bits)",
        generator_model.noise_len(),
        generator_model.dims(),
        dec.vertex_count()
    )
    .unwrap();
    writeln!(
        text,
        "sequence {LABEL} {} {SEED} {INTENSITY}",
        label_index(&generator)
    )
    .unwrap();
    for (i, v) in frames.iter().enumerate() {
        let hash = sinew_core::hash::frame_hash(v);
        writeln!(text, "motion {} {hash:016x}", i + 1).unwrap();
    }
    check(HASHES, &text);
    // The sequence moves: every frame differs from the next.
    assert!(frames.windows(2).all(|w| w[0] != w[1]));
}

/// `sinew generate` (the host function behind the command) writes the pinned frames: on the
/// decoder's template neutral written as an OBJ, every frame it writes hashes to the pinned
/// value, so the command and the firmware play one path.
#[test]
fn sinew_generate_writes_the_pinned_frames() {
    use sinew_host::io::mesh::{Mesh, points};
    use sinew_host::motion::generate::{Generate, generate};
    let dir = tempfile::tempdir().unwrap();
    let decoder = read(DECODER);
    let dec = S2dDecoder::from_bytes(&decoder).unwrap();
    let pos: Vec<f32> = dec.neutral().iter().collect();
    // The golden decoder stores no triangles; any faces do for the strip's pictures.
    let n = pos.len() as u32 / 3;
    let faces = (0..n - 2)
        .step_by(3)
        .map(|i| vec![i, i + 1, i + 2])
        .collect();
    let neutral = dir.path().join("neutral.obj");
    Mesh::new(points(pos), faces).write(&neutral).unwrap();
    let out = dir.path().join("frames");
    let opts = Generate {
        model: golden_dir().join(GENERATOR),
        decoder: golden_dir().join(DECODER),
        neutral: Some(neutral),
        seed: SEED,
        intensity: INTENSITY,
        out: out.clone(),
    };
    generate(&opts, LABEL).unwrap();
    let pinned = String::from_utf8(read(HASHES)).unwrap();
    for t in 1..=FRAMES {
        let frame = Mesh::read(&out.join(format!("frame_{t:02}.obj"))).unwrap();
        let values: Vec<f32> = frame.positions.iter().flatten().copied().collect();
        let line = format!("motion {t} {:016x}", sinew_core::hash::frame_hash(&values));
        assert!(
            pinned.lines().any(|l| l == line),
            "frame {t}: {line} is not pinned"
        );
    }
}
