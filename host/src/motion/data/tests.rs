use super::*;
use crate::io::data::data_dir;
use crate::io::dataset::{ContentError, DataSetError, Entry, ManifestProblem};
use crate::motion::srvf;

fn small() -> MotionsConfig {
    MotionsConfig {
        seed: 5,
        identities: 2,
        per_class: 3,
        ..MotionsConfig::default()
    }
}

#[test]
fn draw_is_seeded_and_splits_the_first_repetition() {
    let names = stored_expressions();
    let config = small();
    let (ids, styles, seqs, weights) = draw(&config, &names, 7);
    assert_eq!(
        draw(&config, &names, 7),
        (ids.clone(), styles.clone(), seqs.clone(), weights.clone())
    );
    assert_eq!(styles.len(), 2);
    assert!(styles.iter().all(|s| s.len() == 12));
    let other = MotionsConfig { seed: 6, ..small() };
    assert_ne!(draw(&other, &names, 7).2, seqs);
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
        // Neutral first, exactly; weights in [0, 1]; only the style's and the co-activations'
        // deltas move.
        assert!(w[..e].iter().all(|&x| x == 0.0));
        assert!(w.iter().all(|x| (0.0..=1.0).contains(x)));
        for (k, name) in names.iter().enumerate() {
            let used = s.parts.iter().any(|p| p.shape == *name)
                || s.events
                    .iter()
                    .any(|ev| ev.shapes.iter().any(|n| n == name));
            if !used {
                assert!(w.iter().skip(k).step_by(e).all(|&x| x == 0.0), "{name}");
            }
        }
        assert!(w.iter().any(|&x| x > 0.02), "{}: moves", s.label);
        assert!(s.tracking_noise > 0.0);
    }
    // Without difficulty, every sequence plays its label's pattern, rises to its apex and stays.
    let plain = MotionsConfig {
        variation: Variation::none(),
        ..small()
    };
    let (_, _, seqs, weights) = draw(&plain, &names, 7);
    for (s, w) in seqs.iter().zip(&weights) {
        let pattern = PATTERNS[crate::motion::classes::label_index(&s.label).unwrap()][s.variant];
        let shapes: Vec<&str> = s.parts.iter().map(|p| p.shape.as_str()).collect();
        let expected: Vec<&str> = pattern.iter().map(|p| p.0).collect();
        assert_eq!(shapes, expected);
        assert!(s.events.is_empty() && s.tracking_noise == 0.0 && s.mix.is_none());
        assert_eq!(s.envelope, Envelope::flat());
        let last = &w[(s.frames - 1) * e..];
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
    for (variation, option) in [
        (
            Variation {
                difficulty: -0.5,
                ..Variation::default()
            },
            "--difficulty",
        ),
        (
            Variation {
                lean: 1.5,
                ..Variation::default()
            },
            "--lean",
        ),
        (
            Variation {
                tracking_noise: f32::NAN,
                ..Variation::default()
            },
            "--tracking-noise",
        ),
    ] {
        let e = MotionsConfig {
            variation,
            ..small()
        }
        .validate()
        .unwrap_err();
        assert!(
            matches!(e, InvalidMotionsConfig::Knob { option: o, .. } if o == option),
            "{e:?}"
        );
        assert!(e.to_string().starts_with(option), "{e}");
    }
}

#[test]
fn real_motions_are_consistent_round_trip_and_keep_the_classes_apart() {
    let Some(root) = data_dir() else { return };
    let kit = IctFaceKit::open(&root.join("ict-facekit")).unwrap();
    let config = small();
    eprintln!("seed {}", config.seed);
    let started = std::time::Instant::now();
    let set = generate(&kit, &config).unwrap();
    eprintln!("{} sequences in {:?}", set.len(), started.elapsed());
    assert_eq!(set.vertices(), FACE_REGION.len());
    assert_eq!(set.deltas.len(), 2 * set.manifest.expressions.len());

    // The stored landmarks are the dense frames' landmark vertices plus the sequence's tracking
    // noise, bit for bit; frame 0 is the identity's neutral.
    for s in [0, 17, set.len() - 1] {
        let spec = &set.manifest.sequences[s];
        let d = 3 * set.manifest.landmarks.len();
        let noise = crate::motion::variation::tracking_noise(
            config.seed,
            s,
            spec.frames,
            d,
            spec.tracking_noise,
        );
        for f in [0, spec.frames / 2, spec.frames - 1] {
            let dense = set.frame(s, f);
            let lmk: Vec<f32> = set
                .manifest
                .landmarks
                .iter()
                .flat_map(|&l| dense[l as usize])
                .zip(&noise[f * d..(f + 1) * d])
                .map(|(x, n)| if f == 0 { x } else { x + n })
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

    // The tracking noise is on the landmarks only: frame 0 is exact, later frames are off the
    // dense frame's landmark vertices by about the noise's σ.
    let spec = &set.manifest.sequences[5];
    let dense = set.frame(5, spec.frames - 1);
    let off: Vec<f32> = set
        .manifest
        .landmarks
        .iter()
        .flat_map(|&l| dense[l as usize])
        .zip(set.landmark_frame(5, spec.frames - 1))
        .map(|(a, b)| b - a)
        .collect();
    let rms = (off.iter().map(|x| x * x).sum::<f32>() / off.len() as f32).sqrt();
    assert!(
        (0.5 * spec.tracking_noise..2.0 * spec.tracking_noise).contains(&rms),
        "{rms}"
    );

    // A set written by version 1 (no variation: no styles, envelopes, events or noise) is read.
    let v1_dir = tempfile::tempdir().unwrap();
    let mut v1 = set.clone();
    v1.manifest.config.variation = Variation::none();
    v1.manifest.styles.clear();
    for (s, spec) in v1.manifest.sequences.iter_mut().enumerate() {
        spec.envelope = Envelope::flat();
        spec.events.clear();
        spec.tracking_noise = 0.0;
        spec.mix = None;
        v1.landmarks[s] = tracked(
            v1.manifest.config.seed,
            s,
            spec,
            &v1.neutrals[spec.identity],
            &v1.deltas,
            &v1.weights[s],
            e,
            &v1.manifest.landmarks,
        );
    }
    v1.write(v1_dir.path()).unwrap();
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(v1_dir.path().join(MANIFEST_FILE)).unwrap()).unwrap();
    json["version"] = 1.into();
    let m = json.as_object_mut().unwrap();
    m.remove("styles");
    m["config"].as_object_mut().unwrap().remove("variation");
    for seq in m["sequences"].as_array_mut().unwrap() {
        let seq = seq.as_object_mut().unwrap();
        for key in ["mix", "envelope", "events", "tracking_noise"] {
            seq.remove(key);
        }
    }
    let v1_manifest = serde_json::to_vec(&json).unwrap();
    crate::io::atomic::write(&v1_dir.path().join(MANIFEST_FILE), &v1_manifest).unwrap();
    let old = MotionSet::read(v1_dir.path()).unwrap();
    assert_eq!(old.manifest.version, 1);
    assert_eq!(old.manifest.config.variation, Variation::none());
    assert_eq!(old.landmarks, v1.landmarks);
    // A later version than this reader knows is refused, saying which.
    json["version"] = 3.into();
    crate::io::atomic::write(
        &v1_dir.path().join(MANIFEST_FILE),
        &serde_json::to_vec(&json).unwrap(),
    )
    .unwrap();
    let err = MotionSet::read(v1_dir.path()).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains(MANIFEST_FILE) && msg.contains("version 3") && msg.contains("version 2"),
        "{msg}"
    );

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
    // The classes overlap by design (version 2), but a class's sequences still lie nearer each
    // other than other classes' do.
    assert!(within < across, "within {within}, across {across}");
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

#[test]
fn more_identities_than_the_kit_has_are_refused_naming_the_option() {
    let Some(root) = data_dir() else { return };
    let kit = IctFaceKit::open(&root.join("ict-facekit")).unwrap();
    let config = MotionsConfig {
        identities: kit.identity_count() + 1,
        ..small()
    };
    let e = generate(&kit, &config).unwrap_err();
    assert!(
        matches!(e, MotionDataError::TooManyIdentities { asked, modes, .. } if asked == modes + 1),
        "{e:?}"
    );
    assert!(
        e.to_string().starts_with("--identities") && e.to_string().contains("ict-facekit"),
        "{e}"
    );
}
