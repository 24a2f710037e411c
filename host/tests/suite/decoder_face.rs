//! The face a decoder decodes onto by default, as a user meets it: `sinew generate` and
//! `sinew interpolate` without `--neutral`, and `sinew s2d template`, which writes that face, on
//! the golden decoder and on a decoder baked without its template's triangles (as decoders were
//! from 2026-11-23 to 2026-11-26), which `sinew s2d add-triangles` gives them.

use crate::common::{err, ok, s};

use sinew_host::io::container::SinewWriter;
use sinew_host::io::decoder_face::{self, TRIANGLES};
use sinew_host::io::mesh::Mesh;

fn golden(name: &str) -> String {
    format!("{}/../tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The golden decoder's bytes without its template's triangles, as a decoder baked before
/// 2026-11-27 is.
fn without_triangles() -> Vec<u8> {
    let bytes = std::fs::read(golden("s2d-ict.sinew")).unwrap();
    let file = sinew_core::SinewFile::from_bytes(&bytes).unwrap();
    let mut w = SinewWriter::from_file(&file).unwrap();
    assert_eq!(w.remove_prefixed(TRIANGLES), 1);
    w.to_bytes().unwrap()
}

/// The golden decoder plays on its own face: `sinew generate` without `--neutral` decodes the
/// golden generator's motion onto the decoder's template, with its triangles, and
/// `sinew s2d template` writes that face.
#[test]
fn the_golden_decoder_plays_on_its_own_face() {
    let dir = tempfile::tempdir().unwrap();
    let decoder = golden("s2d-ict.sinew");
    let template = decoder_face::template(
        std::path::Path::new(&decoder),
        &std::fs::read(&decoder).unwrap(),
    )
    .unwrap();
    assert_eq!(template.positions.len(), 1177);
    assert!(
        template.polygons.len() > 2000,
        "{}",
        template.polygons.len()
    );
    let frames = dir.path().join("frames");
    ok(&[
        "generate",
        "--model",
        &golden("motion-ict.sinew"),
        "--decoder",
        &decoder,
        "--label",
        "mouth_open",
        "--seed",
        "7",
        "--out",
        s(&frames),
    ]);
    let apex = Mesh::read(&frames.join("frame_30.obj")).unwrap();
    assert_eq!(apex.polygons, template.polygons);
    assert_ne!(apex.positions, template.positions);
    assert!(frames.join("strip.png").is_file());
    let face = dir.path().join("face.obj");
    ok(&["s2d", "template", "--model", &decoder, "--out", s(&face)]);
    let written = Mesh::read(&face).unwrap();
    assert_eq!(written.positions, template.positions);
    assert_eq!(written.polygons, template.polygons);
    // It has its triangles already: nothing to add.
    let stderr = err(&[
        "s2d",
        "add-triangles",
        "--model",
        &decoder,
        "--pairs",
        s(dir.path()),
        "--out",
        s(&dir.path().join("again.sinew")),
    ]);
    assert!(
        stderr.contains("s2d-ict.sinew") && stderr.contains("triangles already"),
        "{stderr}"
    );
    assert!(!dir.path().join("again.sinew").exists());
}

/// A decoder baked without its template's triangles: the template command and `generate`
/// without `--neutral` refuse it, naming the decoder and the command that makes its face.
#[test]
fn a_decoder_without_triangles_is_refused_with_the_cure() {
    let dir = tempfile::tempdir().unwrap();
    let old = dir.path().join("s2d-old.sinew");
    std::fs::write(&old, without_triangles()).unwrap();
    let decoder = s(&old).to_owned();
    let stderr = err(&[
        "s2d",
        "template",
        "--model",
        &decoder,
        "--out",
        s(&dir.path().join("face.obj")),
    ]);
    assert!(
        stderr.contains("s2d-old.sinew") && stderr.contains("carries no template triangles"),
        "{stderr}"
    );
    assert!(stderr.contains("--pairs PAIRS"), "{stderr}");
    assert!(!dir.path().join("face.obj").exists());
    for command in [
        vec!["generate", "--label", "mouth_open"],
        vec!["interpolate", "--from", "mouth_open", "--to", "eyebrow"],
    ] {
        let mut args = command.clone();
        let (model, out) = (golden("motion-ict.sinew"), dir.path().join("frames"));
        args.extend_from_slice(&["--model", &model, "--decoder", &decoder, "--out", s(&out)]);
        let stderr = err(&args);
        assert!(
            stderr.contains("s2d-old.sinew")
                && stderr.contains("carries no template triangles")
                && stderr.contains("sinew s2d template"),
            "{stderr}"
        );
    }
}

/// On real data: a decoder without triangles (the golden one's bytes before 2026-12-01) given its
/// face from the pairs it was trained on, by `s2d template --pairs` and by `s2d add-triangles`,
/// which makes the golden decoder bit for bit; a decoder trained here (whose bake carries the
/// triangles) written by `s2d template` without pairs, and `generate` and `interpolate` on that
/// decoder without `--neutral`, whose frames are its template moved, with its triangles.
#[test]
fn the_decoders_own_template_is_the_default_face() {
    let Some(root) = sinew_host::io::data::data_dir() else {
        return;
    };
    let kit = root.join("ict-facekit");
    let dir = tempfile::tempdir().unwrap();
    let pairs = dir.path().join("pairs");
    // The golden decoder's pairs (docs/S2D.md), fewer of them: the template is the same.
    ok(&[
        "data",
        "s2d-pairs",
        "--data",
        s(&kit),
        "--out",
        s(&pairs),
        "--decimate",
        "8",
        "--expressions",
        "shared",
        "--identities",
        "2",
        "--pairs",
        "24",
    ]);
    let golden_face = dir.path().join("golden-face.obj");
    let old = dir.path().join("s2d-old.sinew");
    std::fs::write(&old, without_triangles()).unwrap();
    let decoder = s(&old).to_owned();
    ok(&[
        "s2d",
        "template",
        "--model",
        &decoder,
        "--pairs",
        s(&pairs),
        "--out",
        s(&golden_face),
    ]);
    let face = Mesh::read(&golden_face).unwrap();
    // `add-triangles` gives the old decoder its face's triangles: the golden decoder again.
    let added = dir.path().join("s2d-added.sinew");
    ok(&[
        "s2d",
        "add-triangles",
        "--model",
        &decoder,
        "--pairs",
        s(&pairs),
        "--out",
        s(&added),
    ]);
    assert!(
        std::fs::read(&added).unwrap() == std::fs::read(golden("s2d-ict.sinew")).unwrap(),
        "add-triangles does not give the golden decoder back"
    );
    let bytes = std::fs::read(&decoder).unwrap();
    let neutral: Vec<f32> = sinew_core::s2d::S2dDecoder::from_bytes(&bytes)
        .unwrap()
        .neutral()
        .iter()
        .collect();
    let positions: Vec<f32> = face.positions.iter().flatten().copied().collect();
    assert_eq!(positions, neutral);
    assert!(
        face.polygons.len() > 2000,
        "{} triangles",
        face.polygons.len()
    );

    // A small decoder trained on those pairs carries its template's triangles.
    let model = dir.path().join("s2d.sinew");
    ok(&[
        "train",
        "s2d",
        "--pairs",
        s(&pairs),
        "--protocol",
        "expression",
        "--out",
        s(&model),
        "--report",
        s(&dir.path().join("s2d.json")),
        "--epochs",
        "1",
        "--factors",
        "4,4,4",
        "--fc-features",
        "4",
        "--filters",
        "4,4,4",
        "--cache",
        s(&dir.path().join("cache")),
        "--quiet",
    ]);
    let own_face = dir.path().join("own-face.obj");
    let stdout = ok(&[
        "s2d",
        "template",
        "--model",
        s(&model),
        "--out",
        s(&own_face),
    ]);
    assert!(stdout.contains("1177 vertices"), "{stdout}");
    let own = Mesh::read(&own_face).unwrap();
    assert_eq!(own.positions, face.positions);
    assert_eq!(own.polygons, face.polygons);

    let generator = golden("motion-ict.sinew");
    let frames = dir.path().join("frames");
    ok(&[
        "generate",
        "--model",
        &generator,
        "--decoder",
        s(&model),
        "--label",
        "mouth_open",
        "--out",
        s(&frames),
    ]);
    let apex = Mesh::read(&frames.join("frame_30.obj")).unwrap();
    assert_eq!(apex.polygons, own.polygons);
    assert_ne!(apex.positions, own.positions);
    // The same as with the face written out and given.
    let given = dir.path().join("given");
    ok(&[
        "generate",
        "--model",
        &generator,
        "--decoder",
        s(&model),
        "--label",
        "mouth_open",
        "--neutral",
        s(&own_face),
        "--out",
        s(&given),
    ]);
    assert_eq!(
        std::fs::read(frames.join("frame_30.obj")).unwrap(),
        std::fs::read(given.join("frame_30.obj")).unwrap()
    );
    let between = dir.path().join("between");
    ok(&[
        "interpolate",
        "--model",
        &generator,
        "--decoder",
        s(&model),
        "--from",
        "mouth_open",
        "--to",
        "eyebrow",
        "--steps",
        "3",
        "--out",
        s(&between),
    ]);
    assert!(between.join("frame_03.obj").is_file() && between.join("strip.png").is_file());
}
