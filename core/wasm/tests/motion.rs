//! The Rust layer under the WebAssembly module, on the host: the golden generated sequence
//! (`motion-ict` through `s2d-ict`) hashes as `motion-ict.hashes` lists and as the core's own
//! `Sequence` computes it, the Q16 and fast pose outputs hash as their replays, and the shape
//! names are the recorded ones. (The same through the JavaScript API:
//! `core/wasm/test/motion.test.mjs`, `engine.test.mjs`.)
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic
)]

use sinew_core::hash::frame_hash as core_hash;
use sinew_core::motion::MotionGenerator;
use sinew_core::replay::AimReplay;
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_wasm::{Model, Motion, frame_hash, frame_hash_q16};

fn data(name: &str) -> Vec<u8> {
    let path = format!("{}/../../tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn the_golden_sequence_hashes_as_listed_and_as_the_core_computes() {
    let text = String::from_utf8(data("motion-ict.hashes")).unwrap();
    let seq: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("sequence "))
        .unwrap()
        .split(' ')
        .collect();
    let (label, seed, intensity): (usize, u64, f32) = (
        seq[2].parse().unwrap(),
        seq[3].parse().unwrap(),
        seq[4].parse().unwrap(),
    );
    let decoder = Model::load(data("s2d-ict.sinew")).unwrap();
    let motion = Motion::load(data("motion-ict.sinew")).unwrap();
    assert_eq!(motion.label_names()[label], seq[1]);
    let curve = motion
        .curve(&decoder, label, seed, intensity, None)
        .unwrap();

    let (g, d) = (data("motion-ict.sinew"), data("s2d-ict.sinew"));
    let core = Sequence::new(
        MotionGenerator::from_bytes(&g).unwrap(),
        S2dDecoder::from_bytes(&d).unwrap(),
    )
    .unwrap();
    let (mut c, mut input) = (vec![0.0; core.curve_len()], vec![0.0; core.input_len()]);
    let (mut scratch, mut vertices) = (vec![0.0; core.scratch_len()], vec![0.0; core.vertex_len()]);
    let mut buf = SequenceBuffers {
        curve: &mut c,
        input: &mut input,
        neutral: &[],
        scratch: &mut scratch,
        vertices: &mut vertices,
    };
    core.curve(label, seed, intensity, &mut buf).unwrap();
    assert_eq!(curve, buf.curve);
    let mut listed = 0;
    for line in text.lines().filter(|l| l.starts_with("motion ")) {
        let f: Vec<&str> = line.split(' ').collect();
        let t: usize = f[1].parse().unwrap();
        let v = motion.frame(&decoder, &curve, t, None).unwrap();
        assert_eq!(format!("{:016x}", frame_hash(&[&v])), f[2], "frame {t}");
        assert_eq!(
            frame_hash(&[&v]),
            core.decode_frame_hash(t, &mut buf).unwrap()
        );
        assert_eq!(core_hash(&v), frame_hash(&[&v]));
        listed += 1;
    }
    assert_eq!(listed, motion.frame_count());
}

#[test]
fn q16_and_fast_poses_hash_as_their_replays_and_names_are_recorded() {
    let model = Model::load(data("aim-ict.sinew")).unwrap();
    for mode in ["q16", "fast"] {
        let bytes = data(&format!("aim-ict.{mode}.replay.sinew"));
        let replay = AimReplay::from_bytes(&bytes).unwrap();
        let mut w = vec![0.0; model.shape_count()];
        for f in 0..replay.frames() {
            let (head, jaw) = replay.frame(f, &mut w).unwrap();
            let hash = if mode == "q16" {
                frame_hash_q16(&model.pose_q16(&head, &jaw, &w).unwrap())
            } else {
                let (p, n) = model.pose_fast(&head, &jaw, &w).unwrap();
                frame_hash(&[&p, &n])
            };
            assert_eq!(Some(hash), replay.expected(f), "{mode} frame {f}");
        }
    }
    let bytes = data("aim-ict.sinew");
    let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
    let recorded: Vec<&str> = file.metadata().get("shapes").unwrap().split(',').collect();
    assert_eq!(model.shape_names(), recorded[1..]);
}
