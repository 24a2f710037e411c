//! Tests of [`super`] (experiment).

use super::*;
use crate::s2d::objective::LossVariant;

#[test]
fn stats_and_paths() {
    let s = ErrorStats::of(&[1.0, 3.0], None);
    assert_eq!((s.mean_error_mm, s.std_error_mm), (2.0, 1.0));
    assert_eq!(
        fold_model_path(Path::new("out/m.sinew"), 2),
        Path::new("out/m.fold2.sinew")
    );
    assert_eq!(
        fold_model_path(Path::new("out/m.sinew"), 0),
        Path::new("out/m.sinew")
    );
    assert_eq!(plot_path(Path::new("r/rep.json")), Path::new("r/rep.png"));
    assert_eq!(
        fold_checkpoint_path(Path::new("out/m.sinew"), 0),
        Path::new("out/m.ckpt")
    );
    assert_eq!(
        fold_checkpoint_path(Path::new("out/m.sinew"), 3),
        Path::new("out/m.fold3.ckpt")
    );
    let (l, w) = Objective::Dr.loss_and_weights(&[0.0, 1.0]);
    assert_eq!((l, w), (LossVariant::Paper, vec![0.0, 0.0]));
    let (_, w) = Objective::DrUnweighted.loss_and_weights(&[0.0, 1.0]);
    assert_eq!(w, [1.0, 1.0]);
    let (_, w) = Objective::Code.loss_and_weights(&[0.0, 1.0]);
    assert_eq!(w, [1.0, 0.0]);
}

/// Each held-out item's errors average the vertices of exactly the test pairs that involve
/// it, per method; an item no test pair involves gets no pairs and zero error.
#[test]
fn held_out_errors_average_the_pairs_that_involve_each_item() {
    let s = Split {
        protocol: Protocol::Expression,
        fold: 0,
        held_out: vec!["a".into(), "b".into(), "c".into()],
        train: vec![0, 1],
        test: vec![2, 5, 7],
    };
    // Pair 2 uses a, pair 5 a and b, pair 7 b.
    let involves = |p: usize, item: &str| match item {
        "a" => p == 2 || p == 5,
        "b" => p == 5 || p == 7,
        _ => false,
    };
    // Two vertices a pair; method m (1 to 4) has errors m × [1, 2 | 3, 4 | 5, 6].
    let e: Vec<Vec<f32>> = (1..=4)
        .map(|m| (1..=6).map(|x| (m * x) as f32).collect())
        .collect();
    let h = per_held_out(&s, involves, 2, [&e[0], &e[1], &e[2], &e[3]]);
    let got: Vec<_> = h
        .iter()
        .map(|h| {
            (
                h.held_out.as_str(),
                h.pairs,
                [h.s2d_mm, h.pca99_mm, h.pca_max_mm, h.dl_3dmm_mm],
            )
        })
        .collect();
    assert_eq!(
        got,
        [
            ("a", 2, [2.5, 5.0, 7.5, 10.0]),
            ("b", 2, [4.5, 9.0, 13.5, 18.0]),
            ("c", 0, [0.0; 4]),
        ]
    );
}

/// Small real pair sets (8 identities, 160 pairs, seed 3) of each kind, generated once for
/// the tests of this module that use them; none without the data.
fn real_pairs(expressions: Expressions) -> Option<&'static PairSet> {
    static SETS: [std::sync::OnceLock<PairSet>; 2] =
        [std::sync::OnceLock::new(), std::sync::OnceLock::new()];
    let root = crate::io::data::data_dir()?;
    let slot = &SETS[usize::from(expressions == Expressions::Transferred)];
    Some(slot.get_or_init(|| {
        let kit = crate::io::ict::IctFaceKit::open(&root.join("ict-facekit")).unwrap();
        let config = super::super::data::PairsConfig {
            seed: 3,
            identities: 8,
            pairs: 160,
            max_shapes: 3,
            expressions,
        };
        super::super::data::generate(&kit, &config).unwrap()
    }))
}

/// On real pairs the larger PCA fits at least as well as pca99, and on the identity split
/// (ICT's expression deltas are shared by all identities) it is nearly exact.
#[test]
fn pca_max_is_no_worse_than_pca99_on_real_pairs() {
    let Some(set) = real_pairs(Expressions::Shared) else {
        return;
    };
    for protocol in [Protocol::Identity, Protocol::Expression] {
        let s = split(&set.manifest, protocol, 0).unwrap();
        let all = baseline_errors(set, &s, &[]).unwrap();
        let [(p99, k99), (pmax, kmax), (dl, atoms)] = [all.pca99, all.pca_max, all.dl_3dmm];
        let (a, b) = (ErrorStats::of(&p99, None), ErrorStats::of(&pmax, None));
        let d = ErrorStats::of(&dl, None);
        let f = ErrorStats::of(&all.span_floor.0, None);
        eprintln!(
            "{protocol}: pca99 ({k99}) {:.4} mm, pca_max ({kmax}) {:.4} mm, DL-3DMM ({atoms}) \
             {:.4} mm, span floor {:.4} mm",
            a.mean_error_mm, b.mean_error_mm, d.mean_error_mm, f.mean_error_mm
        );
        assert!(
            f.mean_error_mm < d.mean_error_mm.min(b.mean_error_mm),
            "{protocol}"
        );
        assert!(k99 <= kmax);
        assert!(b.mean_error_mm <= a.mean_error_mm * 1.001, "{protocol}");
        if protocol == Protocol::Identity {
            // Both models span the test displacements: only the prior's bias is left.
            assert!(b.mean_error_mm < 0.05, "{}", b.mean_error_mm);
            assert!(d.mean_error_mm < 0.1, "{}", d.mean_error_mm);
            assert!(f.mean_error_mm < 0.02, "{}", f.mean_error_mm);
        } else {
            assert!(d.mean_error_mm < 1.1 * b.mean_error_mm, "{protocol}");
        }
        assert!(atoms > kmax, "an overcomplete dictionary: {atoms} atoms");
    }
}

/// With identity-specific (transferred) expressions the identity split is no longer
/// spanned by the training identities: `pca_max` misses the unseen identities' own way of
/// performing each expression, by far more than the ridge's bias it had on shared deltas.
#[test]
fn transferred_expressions_make_the_identity_split_a_test() {
    let mut pca_max = Vec::new();
    for expressions in [Expressions::Shared, Expressions::Transferred] {
        let Some(set) = real_pairs(expressions) else {
            return;
        };
        let s = split(&set.manifest, Protocol::Identity, 0).unwrap();
        let (pmax, kmax) = baseline_errors(set, &s, &[]).unwrap().pca_max;
        let e = ErrorStats::of(&pmax, None).mean_error_mm;
        eprintln!("identity split, {expressions:?} expressions: pca_max ({kmax}) {e:.4} mm");
        pca_max.push(e);
    }
    assert!(pca_max[1] > 5.0 * pca_max[0], "{pca_max:?}");
}

/// `eval s2d` refuses, by variant, a fold count out of range, a model that `train s2d` did not
/// make, one trained on pairs of another seed, and a fold in another fold's place, each naming
/// the model.
#[test]
fn eval_refuses_models_of_other_runs_by_variant() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("eval.json");
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/s2d-ict.sinew");
    assert!(matches!(
        eval_s2d(&golden, dir.path(), 0, &report),
        Err(ExperimentError::Folds(0))
    ));
    let Some(set) = real_pairs(Expressions::Shared) else {
        return;
    };
    let pairs = dir.path().join("pairs");
    set.write(&pairs).unwrap();

    // An AIM actor has no S2D protocol in its metadata.
    let actor = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-ict.sinew");
    let err = eval_s2d(&actor, &pairs, 1, &report).unwrap_err();
    assert!(
        matches!(&err, ExperimentError::NoProtocol { path, protocol: None } if *path == actor),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        format!(
            "{}: no S2D protocol in the metadata; train it with `sinew train s2d`",
            actor.display()
        )
    );
    // The golden decoder was trained on pairs of seed 1; these have seed 3.
    let err = eval_s2d(&golden, &pairs, 1, &report).unwrap_err();
    assert!(
        matches!(&err, ExperimentError::PairsSeed { path, model_seed, pairs_seed: 3, .. }
            if *path == golden && model_seed == "1"),
        "{err:?}"
    );
    assert!(err.to_string().contains("s2d-ict.sinew"), "{err}");
    // A damaged file is refused by the container reader, naming it.
    let damaged = dir.path().join("damaged.sinew");
    let mut bytes = std::fs::read(&golden).unwrap();
    bytes.truncate(bytes.len() / 2);
    std::fs::write(&damaged, &bytes).unwrap();
    assert!(matches!(
        eval_s2d(&damaged, &pairs, 1, &report),
        Err(ExperimentError::Container(_))
    ));
    assert!(!report.exists(), "no report is written for a refused run");
}
