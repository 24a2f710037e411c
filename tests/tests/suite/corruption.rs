//! Every truncation and every single-bit flip of the header and section table of a small valid
//! file of each artefact kind gives an error, never a panic and never a silent load.

use sinew_core::format::{HEADER_LEN, SECTION_ENTRY_LEN, SinewFile};
use sinew_core::network::load_mlp;
use sinew_core::nn::Activation;
use sinew_host::SinewWriter;
use sinew_host::training::nn::{LayerWeights, write_mlp};
use sinew_tests::Rng;

/// A network artefact: metadata and a 3→4→2 MLP with a sine and a GELU layer.
fn small_network() -> Vec<u8> {
    let mut rng = Rng::new(1);
    let mut w = SinewWriter::new(sinew_core::ArtifactKind::Network);
    w.meta("units", "cm").meta("tool", "sinew-tests");
    let layers = [
        LayerWeights {
            weight: rng.vec(12, -1.0, 1.0),
            bias: rng.vec(4, -1.0, 1.0),
            inputs: 3,
            outputs: 4,
            activation: Activation::Sine { omega0: 30.0 },
        },
        LayerWeights {
            weight: rng.vec(8, -1.0, 1.0),
            bias: rng.vec(2, -1.0, 1.0),
            inputs: 4,
            outputs: 2,
            activation: Activation::Gelu,
        },
    ];
    write_mlp(&mut w, "mlp", &layers).unwrap();
    w.to_bytes().unwrap()
}

/// An S2D decoder on a tiny synthetic hierarchy (8 → 3 vertices), 2 landmarks.
fn small_s2d() -> Vec<u8> {
    sinew_host::s2d::synthetic::tiny_baked_decoder().1
}

/// Loads as far as a user would: container, then the typed artefact.
fn load(kind: &str, bytes: &[u8]) -> Result<(), sinew_core::FormatError> {
    match kind {
        "network" => load_mlp(&SinewFile::from_bytes(bytes)?, "mlp").map(|_| ()),
        "replay" => sinew_core::replay::AimReplay::from_bytes(bytes).map(|_| ()),
        "s2d-replay" => sinew_core::replay::S2dReplay::from_bytes(bytes).map(|_| ()),
        "s2d-decoder" => sinew_core::s2d::S2dDecoder::from_bytes(bytes).map(|_| ()),
        _ => sinew_core::aim::AimActor::from_bytes(bytes).map(|_| ()),
    }
}

/// One small valid file of each artefact kind that exists.
fn artefacts() -> Vec<(&'static str, Vec<u8>)> {
    let aim = std::fs::read(sinew_tests::golden_dir().join("aim-procedural.sinew"))
        .expect("golden AIM actor (tests/data)");
    let replay = std::fs::read(sinew_tests::golden_dir().join("aim-procedural.q16.replay.sinew"))
        .expect("golden replay (tests/data)");
    let s2d_replay = std::fs::read(sinew_tests::golden_dir().join("s2d-ict.replay.sinew"))
        .expect("golden S2D replay (tests/data)");
    vec![
        ("s2d-replay", s2d_replay),
        ("network", small_network()),
        ("aim-actor", aim),
        ("replay", replay),
        ("s2d-decoder", small_s2d()),
    ]
}

/// The writer's bytes are pinned: a change of layout shows up here (and the file seeds the fuzzer).
#[test]
fn small_network_bytes_are_pinned() {
    sinew_tests::check_bytes("network-small.sinew", &small_network());
}

#[test]
fn valid_files_load() {
    for (kind, bytes) in artefacts() {
        assert!(
            load(kind, &bytes).is_ok(),
            "{kind}: the uncorrupted file must load"
        );
    }
}

#[test]
fn every_truncation_is_an_error() {
    for (kind, bytes) in artefacts() {
        for len in 0..bytes.len() {
            assert!(
                load(kind, &bytes[..len]).is_err(),
                "{kind}: truncation to {len} bytes loaded"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(
            load(kind, &longer).is_err(),
            "{kind}: a trailing byte loaded"
        );
    }
}

#[test]
fn every_bit_flip_in_header_and_table_is_an_error() {
    for (kind, bytes) in artefacts() {
        let count = SinewFile::from_bytes(&bytes).unwrap().section_count();
        let table_end = HEADER_LEN + count * SECTION_ENTRY_LEN;
        for byte in 0..table_end {
            for bit in 0..8 {
                let mut bad = bytes.clone();
                bad[byte] ^= 1 << bit;
                assert!(
                    load(kind, &bad).is_err(),
                    "{kind}: flipping bit {bit} of byte {byte} loaded silently"
                );
            }
        }
    }
}

#[test]
fn every_bit_flip_in_data_is_an_error() {
    // The section CRCs cover the data; the zero-padding rule covers the gaps. Every data byte
    // of the small network; every 7th of the larger actor (each check reads the whole file).
    for (kind, bytes) in artefacts() {
        let count = SinewFile::from_bytes(&bytes).unwrap().section_count();
        let stride = if bytes.len() < 4096 { 1 } else { 7 };
        for byte in (HEADER_LEN + count * SECTION_ENTRY_LEN..bytes.len()).step_by(stride) {
            for bit in 0..8 {
                let mut bad = bytes.clone();
                bad[byte] ^= 1 << bit;
                assert!(
                    load(kind, &bad).is_err(),
                    "{kind}: flipping bit {bit} of data byte {byte} loaded silently"
                );
            }
        }
    }
}
