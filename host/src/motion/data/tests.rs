use super::*;
use crate::io::data::data_dir;
use crate::io::dataset::{ContentError, DataSetError, Entry, ManifestProblem};
use crate::motion::srvf;

fn small() -> MotionsConfig {
    MotionsConfig {
        seed: 5,
        identities: 2,
        per_class: 3,
    }
}

#[test]
fn draw_is_seeded_and_splits_the_first_repetition() {
    let names = used_expressions();
    let config = small();
    let (ids, seqs, weights) = draw(&config, &names, 7);
    assert_eq!(
        draw(&config, &names, 7),
        (ids.clone(), seqs.clone(), weights.clone())
    );
    let other = MotionsConfig { seed: 6, ..small() };
    assert_ne!(draw(&other, &names, 7).1, seqs);
    assert_eq!(ids.len(), 2);
    assert_eq!(seqs.len(), 2 * 12 * 3);
    let tests: Vec<&SequenceSpec> = seqs.iter().filter(|s| s.split == Split::Test).collect();
    assert_eq!(
        tests.len(),
        2 * 12,
        "one test sequence per identity and label"
    );
    assert!(tests.iter().all(|s| s.repetition == 0));
    let e = names.len();
    for (s, w) in seqs.iter().zip(&weights) {
        assert!((FRAMES_RANGE.0..=FRAMES_RANGE.1).contains(&s.frames));
        assert_eq!(w.len(), s.frames * e);
        // Neutral first, exactly; weights in [0, 1]; only the pattern's deltas move.
        assert!(w[..e].iter().all(|&x| x == 0.0));
        assert!(w.iter().all(|x| (0.0..=1.0).contains(x)));
        let last = &w[(s.frames - 1) * e..];
        for (k, name) in names.iter().enumerate() {
            if !s.parts.iter().any(|p| p.shape == *name) {
                assert!(w.iter().skip(k).step_by(e).all(|&x| x == 0.0), "{name}");
            }
        }
        assert!(
            last.iter().any(|&x| x > 0.2),
            "{}: reaches an apex",
            s.label
        );
    }
    // mouth_side plays both sides.
    let sides: Vec<usize> = seqs
        .iter()
        .filter(|s| s.label == "mouth_side")
        .map(|s| s.variant)
        .collect();
    assert!(sides.contains(&0) && sides.contains(&1));
}

#[test]
fn bad_config_is_refused() {
    let none = MotionsConfig {
        identities: 0,
        ..small()
    };
    assert_eq!(none.validate(), Err(InvalidMotionsConfig::Identities));
    let one = MotionsConfig {
        per_class: 1,
        ..small()
    };
    assert_eq!(one.validate(), Err(InvalidMotionsConfig::PerClass));
}

#[test]
fn real_motions_are_consistent_round_trip_and_separate_the_classes() {
    let Some(root) = data_dir() else { return };
    let kit = IctFaceKit::open(&root.join("ict-facekit")).unwrap();
    let config = small();
    eprintln!("seed {}", config.seed);
    let started = std::time::Instant::now();
    let set = generate(&kit, &config).unwrap();
    eprintln!("{} sequences in {:?}", set.len(), started.elapsed());
    assert_eq!(set.vertices(), FACE_REGION.len());
    assert_eq!(set.deltas.len(), 2 * set.manifest.expressions.len());

    // The stored landmarks are the dense frames' landmark vertices, bit for bit; frame 0 is the
    // identity's neutral.
    for s in [0, 17, set.len() - 1] {
        let spec = &set.manifest.sequences[s];
        for f in [0, spec.frames / 2, spec.frames - 1] {
            let dense = set.frame(s, f);
            let lmk: Vec<f32> = set
                .manifest
                .landmarks
                .iter()
                .flat_map(|&l| dense[l as usize])
                .collect();
            assert_eq!(lmk, set.landmark_frame(s, f), "sequence {s} frame {f}");
        }
        let neutral: Vec<f32> = set
            .manifest
            .landmarks
            .iter()
            .flat_map(|&l| set.neutral(s)[l as usize])
            .collect();
        assert_eq!(set.landmark_frame(s, 0), neutral);
    }

    // Identity-specific: the same label and weights move two identities' landmarks differently.
    let e = set.manifest.expressions.len();
    let jaw = set
        .manifest
        .expressions
        .iter()
        .position(|n| n == "jawOpen")
        .unwrap();
    let moved = |i: usize| -> Vec<f32> {
        let mut w = vec![0.0f32; 2 * e];
        w[e + jaw] = 1.0;
        let a = frame_of(
            &set.neutrals[i],
            &set.deltas,
            i,
            &w,
            e,
            1,
            Some(&set.manifest.landmarks),
        );
        let b = frame_of(
            &set.neutrals[i],
            &set.deltas,
            i,
            &w,
            e,
            0,
            Some(&set.manifest.landmarks),
        );
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .map(|(x, y)| x - y)
            .collect()
    };
    let (d0, d1) = (moved(0), moved(1));
    let diff: f32 = d0.iter().zip(&d1).map(|(a, b)| (a - b).abs()).sum();
    let size: f32 = d0.iter().map(|a| a.abs()).sum();
    assert!(
        diff > 0.01 * size,
        "jawOpen moves both identities alike ({diff} of {size})"
    );

    // Round trip through the folder.
    let dir = tempfile::tempdir().unwrap();
    set.write(dir.path()).unwrap();
    let back = MotionSet::read(dir.path()).unwrap();
    assert_eq!(back.manifest, set.manifest);
    assert_eq!(back.weights, set.weights);
    assert_eq!(back.landmarks, set.landmarks);
    assert_eq!(back.neutrals, set.neutrals);

    // A manifest that moves a sequence across the split is refused, naming the file.
    let mut bad = set.manifest.clone();
    bad.sequences[1].split = Split::Test;
    let json = serde_json::to_string(&bad).unwrap();
    crate::io::atomic::write(&dir.path().join(MANIFEST_FILE), json.as_bytes()).unwrap();
    let err = MotionSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::Manifest { path, source: ManifestProblem::Split { entry: Entry::Sequence(1), .. } }
            if path.ends_with(MANIFEST_FILE)),
        "{err:?}"
    );
    let msg = format!("{:#}", anyhow::Error::from(err));
    assert!(
        msg.contains(MANIFEST_FILE) && msg.contains("repetition"),
        "{msg}"
    );
    // Weights that disagree with the stored landmarks are refused.
    let mut tampered = set.clone();
    tampered.weights[3][e * 5] = 0.5;
    tampered.write(dir.path()).unwrap();
    let err = MotionSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::Contents { path, source: ContentError::Frame { entry: Entry::Sequence(3), .. } }
            if path.ends_with(DATA_FILE)),
        "{err:?}"
    );

    // The SRVF separates the classes: sequences of one class lie nearer each other on the sphere
    // (geodesic distance) than sequences of different classes.
    let q: Vec<Vec<f32>> = (0..set.len())
        .map(|s| srvf::encode(&set.landmark_frames(s)).unwrap().q)
        .collect();
    let (mut within, mut across) = ((0.0f64, 0usize), (0.0f64, 0usize));
    for a in 0..q.len() {
        for b in a + 1..q.len() {
            let d = f64::from(srvf::distance(&q[a], &q[b]).unwrap());
            if set.label(a) == set.label(b) {
                within = (within.0 + d, within.1 + 1);
            } else {
                across = (across.0 + d, across.1 + 1);
            }
        }
    }
    let (within, across) = (within.0 / within.1 as f64, across.0 / across.1 as f64);
    eprintln!("mean geodesic distance within a class {within:.3}, across classes {across:.3}");
    assert!(within < 0.7 * across, "within {within}, across {across}");
}

#[test]
fn a_missing_kit_folder_is_refused_by_variant() {
    let dir = tempfile::tempdir().unwrap();
    let config = MotionsConfig {
        identities: 1,
        per_class: 2,
        ..MotionsConfig::default()
    };
    let e = generate_to(&dir.path().join("no-kit"), &dir.path().join("out"), &config).unwrap_err();
    assert!(matches!(e, MotionDataError::Kit(_)), "{e:?}");
    assert!(e.to_string().contains("no-kit"), "{e}");
}
