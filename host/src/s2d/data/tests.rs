//! Tests of [`super`] (data).

use super::*;
use crate::io::container::ContainerError;
use crate::io::data::data_dir;
use crate::io::dataset::{ContentError, DataSetError, Entry, ManifestProblem};

fn small() -> PairsConfig {
    PairsConfig {
        seed: 7,
        identities: 4,
        pairs: 24,
        max_shapes: 3,
        expressions: Expressions::Shared,
    }
}

#[test]
fn draw_is_seeded_and_groups_partition_the_shapes() {
    let names: Vec<String> = (0..53).map(|i| format!("s{i:02}")).collect();
    let a = draw(&small(), &names, 100);
    assert_eq!(a, draw(&small(), &names, 100));
    let other = PairsConfig { seed: 8, ..small() };
    assert_ne!(a.2, draw(&other, &names, 100).2);
    let (ids, groups, pairs) = a;
    assert_eq!(ids.len(), 4);
    assert!(ids.iter().all(|w| w.len() == 100));
    // N(0, 1): over 400 draws the mean is near 0 and the variance near 1.
    let all: Vec<f64> = ids.iter().flatten().map(|&w| f64::from(w)).collect();
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    let var = all.iter().map(|w| (w - mean).powi(2)).sum::<f64>() / all.len() as f64;
    assert!(mean.abs() < 0.15 && (var - 1.0).abs() < 0.2, "{mean} {var}");
    let mut seen: Vec<usize> = groups.iter().flatten().copied().collect();
    seen.sort_unstable();
    assert_eq!(seen, (0..53).collect::<Vec<_>>());
    assert!(groups.iter().all(|g| g.len() == 13 || g.len() == 14));
    for (p, spec) in pairs.iter().enumerate() {
        assert_eq!(spec.identity, p % 4);
        assert!((1..=3).contains(&spec.shapes.len()));
        for c in &spec.shapes {
            let e: usize = c.shape[1..].parse().unwrap();
            assert!(groups[spec.group].contains(&e));
            assert!(c.weight > 0.0 && c.weight <= 1.0);
        }
    }
    assert!((0..SHAPE_GROUPS).all(|g| pairs.iter().any(|s| s.group == g)));
}

#[test]
fn real_pairs_are_deterministic_and_round_trip() {
    let Some(root) = data_dir() else { return };
    let kit = IctFaceKit::open(&root.join("ict-facekit")).unwrap();
    let t = std::time::Instant::now();
    let set = generate(&kit, &small()).unwrap();
    eprintln!("{} pairs generated in {:?}", set.len(), t.elapsed());
    assert_eq!(set.vertices(), 9409);
    assert_eq!(set.deltas.len(), 53);
    // The landmarks are ICT's 68, unchanged by the face-region crop.
    assert_eq!(set.manifest.landmarks, kit.landmarks68().unwrap());
    let bytes = set.to_bytes().unwrap();
    let again = generate(&kit, &small()).unwrap();
    assert_eq!(bytes, again.to_bytes().unwrap(), "same seed, other bytes");
    let dir = tempfile::tempdir().unwrap();
    set.write(dir.path()).unwrap();
    let back = PairSet::read(dir.path()).unwrap();
    assert_eq!(back.manifest, set.manifest);
    assert_eq!(back.to_bytes().unwrap(), bytes);

    // The expressive landmarks are the neutral's plus the named deltas at the landmark
    // vertices.
    let p = 5;
    let (n, e) = set.landmark_pair(p);
    let (l, w) = (set.manifest.landmarks[30] as usize, &set.combinations[p]);
    let mut expect = set.neutral(p)[l];
    for &(x, wt) in w {
        for (e, d) in expect
            .iter_mut()
            .zip(set.delta(set.manifest.pairs[p].identity, x)[l])
        {
            *e += wt * d;
        }
    }
    assert_eq!((n[30], e[30]), (set.neutral(p)[l], expect));
    // The identities differ, and the sample matches the decoder's input width.
    assert_ne!(set.neutrals[0], set.neutrals[1]);
    let s = set.sample(p, InputNormalisation::Frobenius).unwrap();
    assert_eq!((s.input.len(), s.displacement.len()), (204, 3 * 9409));
    assert!(s.input.iter().any(|v| v.abs() > 1e-4));

    // A manifest that disagrees with the numbers is refused, naming the file.
    let mpath = dir.path().join(MANIFEST_FILE);
    let mut m = set.manifest.clone();
    m.pairs[3].shapes[0].weight *= 0.5;
    std::fs::write(&mpath, serde_json::to_string(&m).unwrap()).unwrap();
    let err = PairSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::Contents { path, source: ContentError::Entry { name, entry: Entry::Pair(3) } }
            if path.ends_with(DATA_FILE) && name == "pairs.weights"),
        "{err:?}"
    );
    let msg = format!("{:#}", anyhow::Error::from(err));
    assert!(
        msg.contains("pairs.sinew") && msg.contains("pair 3"),
        "{msg}"
    );
    m = set.manifest.clone();
    m.pairs[2].shapes[0].shape = "smile".into();
    std::fs::write(&mpath, serde_json::to_string(&m).unwrap()).unwrap();
    let err = PairSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::Manifest { path, source: ManifestProblem::UnknownExpression { entry: Some(Entry::Pair(2)), name } }
            if path.ends_with(MANIFEST_FILE) && name == "smile"),
        "{err:?}"
    );
    std::fs::write(&mpath, "{").unwrap();
    let err = PairSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::ManifestJson { path, .. } if path.ends_with(MANIFEST_FILE)),
        "{err:?}"
    );
    assert!(err.to_string().contains("manifest.json"), "{err}");
    // A truncated data file is refused, naming it.
    std::fs::write(&mpath, serde_json::to_string(&set.manifest).unwrap()).unwrap();
    let dpath = dir.path().join(DATA_FILE);
    std::fs::write(&dpath, &bytes[..bytes.len() / 2]).unwrap();
    let err = PairSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::Data(ContainerError::Invalid { path, .. }) if path.ends_with(DATA_FILE)),
        "{err:?}"
    );
}

/// Transferred expressions: one delta per identity and shape, close to the kit's shared
/// delta but shaped by each identity, stored and read back per identity.
#[test]
fn transferred_expressions_follow_each_identity() {
    let Some(root) = data_dir() else { return };
    let kit = IctFaceKit::open(&root.join("ict-facekit")).unwrap();
    let shared = generate(&kit, &small()).unwrap();
    let config = PairsConfig {
        expressions: Expressions::Transferred,
        ..small()
    };
    let t = std::time::Instant::now();
    let set = generate(&kit, &config).unwrap();
    eprintln!(
        "{} identities transferred in {:?}",
        set.neutrals.len(),
        t.elapsed()
    );
    let (ids, shapes) = (set.neutrals.len(), set.manifest.expressions.len());
    assert_eq!(set.deltas.len(), ids * shapes);
    assert_eq!(set.neutrals, shared.neutrals);
    let norm = |d: &[[f32; 3]]| -> f64 {
        d.iter()
            .flatten()
            .map(|&c| f64::from(c) * f64::from(c))
            .sum::<f64>()
            .sqrt()
    };
    let diff = |a: &[[f32; 3]], b: &[[f32; 3]]| -> f64 {
        let d: Vec<[f32; 3]> = a
            .iter()
            .zip(b)
            .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
            .collect();
        norm(&d)
    };
    let mut relative = Vec::new();
    for i in 0..ids {
        for e in 0..shapes {
            let (d, s) = (set.delta(i, e), shared.delta(i, e));
            let ratio = norm(d) / norm(s);
            assert!(
                (0.5..2.0).contains(&ratio),
                "identity {i} shape {e}: {ratio}"
            );
            relative.push(diff(d, s) / norm(s));
        }
    }
    let mean = relative.iter().sum::<f64>() / relative.len() as f64;
    let max = relative.iter().copied().fold(0.0, f64::max);
    eprintln!("transferred vs shared deltas: mean relative difference {mean:.3}, max {max:.3}");
    // The deltas follow the identity (not the kit's vectors copied), but stay the same
    // expressions.
    assert!(mean > 0.02 && max < 0.8, "{mean} {max}");
    assert!(diff(set.delta(0, 7), set.delta(1, 7)) > 0.01 * norm(set.delta(0, 7)));
    // A pair's displacement sums its identity's own deltas.
    let p = 5;
    let identity = set.manifest.pairs[p].identity;
    let mut expect = vec![[0.0f32; 3]; set.vertices()];
    for &(e, w) in &set.combinations[p] {
        for (x, d) in expect.iter_mut().zip(set.delta(identity, e)) {
            for c in 0..3 {
                x[c] += w * d[c];
            }
        }
    }
    assert_eq!(set.displacement(p), expect);
    // Same bytes on a second run, and through the files.
    let bytes = set.to_bytes().unwrap();
    assert_eq!(generate(&kit, &config).unwrap().to_bytes().unwrap(), bytes);
    let dir = tempfile::tempdir().unwrap();
    set.write(dir.path()).unwrap();
    let back = PairSet::read(dir.path()).unwrap();
    assert_eq!(back.manifest.config.expressions, Expressions::Transferred);
    assert_eq!(back.to_bytes().unwrap(), bytes);
    // A manifest claiming shared deltas does not read a transferred file.
    let mut m = set.manifest.clone();
    m.config.expressions = Expressions::Shared;
    let mpath = dir.path().join(MANIFEST_FILE);
    std::fs::write(&mpath, serde_json::to_string(&m).unwrap()).unwrap();
    let err = PairSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::Contents { path, source: ContentError::Section { name, .. } }
            if path.ends_with(DATA_FILE) && name == "pairs.delta"),
        "{err:?}"
    );
    // A manifest from before the field (no `expressions`) means shared deltas, whatever the
    // default is now: it is refused the same way.
    let mut old = serde_json::to_value(&set.manifest).unwrap();
    old["config"].as_object_mut().unwrap().remove("expressions");
    std::fs::write(&mpath, old.to_string()).unwrap();
    let err = PairSet::read(dir.path()).unwrap_err();
    assert!(
        matches!(&err, DataSetError::Contents { source: ContentError::Section { name, .. }, .. }
            if name == "pairs.delta"),
        "{err:?}"
    );
}

#[test]
fn bad_config_is_refused() {
    let c = PairsConfig {
        identities: 1,
        ..small()
    };
    assert_eq!(c.validate(), Err(InvalidPairsConfig::Identities));
    let c = PairsConfig {
        pairs: 0,
        ..small()
    };
    assert_eq!(c.validate(), Err(InvalidPairsConfig::Pairs));
    let c = PairsConfig {
        max_shapes: 0,
        ..small()
    };
    assert_eq!(c.validate(), Err(InvalidPairsConfig::MaxShapes));
}

#[test]
fn a_missing_kit_folder_is_refused_by_variant() {
    let dir = tempfile::tempdir().unwrap();
    let e = generate_to(
        &dir.path().join("no-kit"),
        &dir.path().join("out"),
        &small(),
        None,
    )
    .unwrap_err();
    assert!(matches!(e, PairsError::Kit(_)), "{e:?}");
    assert!(e.to_string().contains("no-kit"), "{e}");
}
