//! AIM end to end on the procedural actor: training lowers the error, a resumed run reaches the
//! same weights bit for bit, and the baked cache agrees with the networks evaluated by the core.

use sinew_core::aim::AimActor;
use sinew_host::aim::AimConfig;
use sinew_host::aim::bake::{BakeInput, bake};
use sinew_host::aim::eval::shape_errors;
use sinew_host::aim::testing::aim_train_options;
use sinew_host::aim::train::train;
use sinew_host::training::backend::Backend;

/// Training runs one at a time in this process: burn's CPU kernels split reductions across the
/// shared thread pool according to the work in flight, so two trainings at once round differently
/// (a resumed run then differs from an uninterrupted one). Alone, a run is bit-reproducible.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn small_set() -> sinew_host::aim::TrainingSet {
    sinew_host::aim::testing::procedural_training_set(16)
}

fn tiny_config(iterations: usize) -> AimConfig {
    AimConfig {
        checkpoint_every: 5,
        ..sinew_host::aim::testing::small_aim_config(iterations)
    }
}

fn baked(
    net: &sinew_host::aim::model::AimNet,
    set: &sinew_host::aim::TrainingSet,
    norm: [f32; 4],
) -> Vec<u8> {
    let tri = set.template.triangles();
    let input = BakeInput {
        points: &set.template.positions,
        triangles: &tri,
        jaw_pivot: set.jaw_pivot,
        normalisation: norm,
        playback_only: false,
        metadata: vec![],
    };
    bake(net, &input, &Backend::Flex.device(0).unwrap())
        .unwrap()
        .0
}

/// Trains `config` on `set` straight through and, in another folder, stopped after step 7 and
/// resumed (`between` sees that folder in between); asserts both runs end at the same weights
/// and returns the resumed run's folder.
fn assert_resumed_run_matches(
    set: &sinew_host::aim::TrainingSet,
    config: &AimConfig,
    between: impl FnOnce(&std::path::Path),
) -> tempfile::TempDir {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let whole = train(set, config, &aim_train_options(a.path(), false, None)).unwrap();
    let first = train(set, config, &aim_train_options(b.path(), false, Some(7))).unwrap();
    assert!(!first.complete);
    assert_eq!(first.state.steps_done, 7);
    between(b.path());
    let rest = train(set, config, &aim_train_options(b.path(), true, None)).unwrap();
    assert!(rest.complete);
    let norm = whole.state.normalisation;
    assert_eq!(
        baked(&whole.model, set, norm),
        baked(&rest.model, set, norm),
        "resumed run differs from the uninterrupted one"
    );
    b
}

#[test]
fn resumed_training_reaches_the_same_weights() {
    let _serial = SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let set = small_set();
    let config = tiny_config(12);
    let dir = assert_resumed_run_matches(&set, &config, |dir| {
        // The checkpoint at step 7 replaced the one at step 5.
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(
            names,
            ["model-7.bpk", "optim-7.bpk", "state.json", "template.obj"]
        );
        // Resume from it in the layout of checkpoints written before the weight files were
        // named in state.json (model.bpk, optim.bpk, no CRCs): they must keep working.
        std::fs::rename(dir.join("model-7.bpk"), dir.join("model.bpk")).unwrap();
        std::fs::rename(dir.join("optim-7.bpk"), dir.join("optim.bpk")).unwrap();
        let state_path = dir.join("state.json");
        let mut state: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&state_path).unwrap()).unwrap();
        for field in ["model_file", "model_crc", "optim_file", "optim_crc"] {
            assert!(
                state.as_object_mut().unwrap().remove(field).is_some(),
                "{field}"
            );
        }
        std::fs::write(&state_path, serde_json::to_vec(&state).unwrap()).unwrap();
    });
    // A different configuration must not resume silently.
    let other = AimConfig { seed: 7, ..config };
    assert!(train(&set, &other, &aim_train_options(dir.path(), true, None)).is_err());
}

#[test]
fn resumed_training_with_the_paper_jaw_reaches_the_same_weights() {
    let _serial = SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    // The default (above) fits the jaw transforms from the bones, which the resumed run must take
    // from the checkpoint rather than fit again; the paper's identity start and objective too.
    let config = AimConfig {
        jaw_init: sinew_host::aim::config::JawInit::Identity,
        lambda_jaw: 0.0,
        ..tiny_config(12)
    };
    assert_resumed_run_matches(&small_set(), &config, |_| {});
}

#[test]
fn training_learns_the_procedural_actor_and_the_core_agrees() {
    let _serial = SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let set = small_set();
    let config = tiny_config(300);
    let dir = tempfile::tempdir().unwrap();
    let early = train(
        &set,
        &AimConfig {
            iterations: 1,
            ..config.clone()
        },
        &aim_train_options(&dir.path().join("early"), false, None),
    )
    .unwrap();
    let trained = train(
        &set,
        &config,
        &aim_train_options(&dir.path().join("full"), false, None),
    )
    .unwrap();
    let norm = trained.state.normalisation;
    let err = |net| {
        let bytes = baked(net, &set, norm);
        let actor = AimActor::from_bytes(&bytes).unwrap();
        shape_errors(&actor, &set.names, &set.shapes, set.mm_per_unit)
            .unwrap()
            .overall
    };
    let (before, after) = (err(&early.model), err(&trained.model));
    eprintln!(
        "mean error: {:.3} mm after 1 step, {:.3} mm after 300",
        before.mean, after.mean
    );
    assert!(
        after.mean < 0.5 * before.mean,
        "training did not learn: {before:?} → {after:?}"
    );

    // The baked cache is the networks' output: the core's network evaluation reproduces it.
    let bytes = baked(&trained.model, &set, norm);
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let nets = actor.networks().expect("networks baked");
    let mut scratch = vec![0.0; nets.scratch_len()];
    let mut e = vec![0.0; nets.corrective_len()];
    let tol = sinew_host::training::tolerance::SIREN;
    for i in (0..actor.vertex_count()).step_by(37) {
        let c = sinew_core::linalg::Vec3::new(
            actor.template().at(3 * i),
            actor.template().at(3 * i + 1),
            actor.template().at(3 * i + 2),
        );
        let p = nets.eval(c, &mut e, &mut scratch).unwrap();
        let cached = [
            actor.rest().at(3 * i),
            actor.rest().at(3 * i + 1),
            actor.rest().at(3 * i + 2),
        ];
        for (core, burn) in p.skin.to_array().iter().zip(cached) {
            assert!(
                tol.accepts(*core, burn),
                "vertex {i}: core {core} vs burn {burn}"
            );
        }
        assert!(tol.accepts(p.k, actor.skinning_weights().at(i)));
    }
}

#[test]
fn softplus_thickness_is_positive_and_the_core_agrees() {
    let _serial = SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let set = small_set();
    let config = AimConfig {
        thickness_activation: sinew_host::aim::config::ThicknessActivation::Softplus,
        ..tiny_config(60)
    };
    let dir = tempfile::tempdir().unwrap();
    let trained = train(&set, &config, &aim_train_options(dir.path(), false, None)).unwrap();
    let bytes = baked(&trained.model, &set, trained.state.normalisation);
    let actor = AimActor::from_bytes(&bytes).unwrap();
    assert!(
        actor.thickness().iter().all(|d| d > 0.0),
        "softplus thickness must be positive"
    );
    assert_eq!(
        actor
            .file()
            .section("aim.dact")
            .unwrap()
            .u32s()
            .unwrap()
            .at(0),
        sinew_core::aim::THICKNESS_SOFTPLUS
    );
    // The core applies the same activation when it evaluates the networks.
    let nets = actor.networks().expect("networks baked");
    let mut scratch = vec![0.0; nets.scratch_len()];
    let mut e = vec![0.0; nets.corrective_len()];
    let tol = sinew_host::training::tolerance::SIREN;
    for i in (0..actor.vertex_count()).step_by(29) {
        let c = sinew_core::linalg::Vec3::new(
            actor.template().at(3 * i),
            actor.template().at(3 * i + 1),
            actor.template().at(3 * i + 2),
        );
        let p = nets.eval(c, &mut e, &mut scratch).unwrap();
        let cached = actor.thickness().at(i);
        assert!(
            tol.accepts(p.thickness, cached),
            "vertex {i}: core {} vs burn {cached}",
            p.thickness
        );
    }
}

/// A run that aims for an accuracy stops at the first check that meets it, having measured what
/// the baked actor measures; resumed there, it stops at once; a target out of reach runs every
/// step and says by how much it missed.
#[test]
fn training_stops_at_its_target_and_says_why() {
    use sinew_host::aim::target::{Ending, Target};
    let _serial = SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let set = small_set();
    let config = tiny_config(60);
    let with = |dir: &std::path::Path, resume: bool, target: Target| {
        let mut options = aim_train_options(dir, resume, None);
        options.target = Some(target);
        train(&set, &config, &options).unwrap()
    };
    // Out of reach: every step runs, a check every 10.
    let far = tempfile::tempdir().unwrap();
    let unreachable = Target {
        mean_mm: 1e-6,
        p95_mm: 1e-6,
        every: 10,
        ..Target::default()
    };
    let all = with(far.path(), false, unreachable.clone());
    assert!(all.complete);
    assert_eq!(all.ending, Ending::Steps);
    assert_eq!(all.state.steps_done, 60);
    let steps: Vec<usize> = all.state.checks.iter().map(|c| c.step).collect();
    assert_eq!(steps, [10, 20, 30, 40, 50, 60]);
    let checks = &all.state.checks;
    let missed = unreachable.shortfall(&checks[5], Some(&checks[4]));
    assert!(missed[0].starts_with("mean "), "{missed:?}");
    // The last check measures what the baked actor's report measures.
    let actor_bytes = baked(&all.model, &set, all.state.normalisation);
    let actor = AimActor::from_bytes(&actor_bytes).unwrap();
    let report = shape_errors(&actor, &set.names, &set.shapes, set.mm_per_unit).unwrap();
    let mean = checks[5].mean_mm;
    assert!(
        (mean - report.overall.mean).abs() <= 1e-3 * report.overall.mean,
        "checked {mean} mm, baked {} mm",
        report.overall.mean
    );

    // A target the run meets part way: the accuracy of the check at step 30, loose enough for
    // the jaw. The same run (bit-reproducible) stops at the first check that meets it.
    let target = Target {
        mean_mm: checks[2].mean_mm,
        p95_mm: checks[2].p95_mm.max(checks[2].mean_mm),
        jaw_settle_degrees: 180.0,
        every: 10,
        ..Target::default()
    };
    let first = (0..checks.len())
        .find(|&i| target.met(&checks[i], i.checked_sub(1).map(|p| &checks[p])))
        .unwrap();
    assert!(first <= 2 && checks[first].step < 60, "{checks:?}");
    let near = tempfile::tempdir().unwrap();
    let stopped = with(near.path(), false, target.clone());
    assert!(stopped.complete);
    assert_eq!(stopped.ending, Ending::Target);
    assert_eq!(stopped.state.steps_done, checks[first].step);
    assert_eq!(stopped.state.checks[..], checks[..=first]);
    // Resumed with the same target, it is already there: no step, no new check.
    let again = with(near.path(), true, target);
    assert_eq!(again.ending, Ending::AlreadyMet);
    assert_eq!(again.state.steps_done, checks[first].step);
    assert_eq!(again.state.checks.len(), first + 1);
}

/// A run started from a prior begins exactly where the prior ended (its networks, normalisation
/// and jaw transforms, shape by shape by name, in any order); a prior that cannot start the run
/// (other network sizes or units, no networks, not an actor) is refused naming the file.
#[test]
fn a_prior_starts_a_run_where_it_ended() {
    use sinew_host::aim::prior::{Prior, PriorError};
    use sinew_host::aim::target::measure;
    let _serial = SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let set = small_set();
    let config = tiny_config(30);
    let dir = tempfile::tempdir().unwrap();
    let trained = train(&set, &config, &aim_train_options(dir.path(), false, None)).unwrap();
    let bake_with = |playback_only: bool| {
        let tri = set.template.triangles();
        let input = BakeInput {
            points: &set.template.positions,
            triangles: &tri,
            jaw_pivot: set.jaw_pivot,
            normalisation: trained.state.normalisation,
            playback_only,
            metadata: sinew_host::aim::bake::metadata(&set, &config).unwrap(),
        };
        let device = Backend::Flex.device(0).unwrap();
        bake(&trained.model, &input, &device).unwrap().0
    };
    let path = dir.path().join("prior.sinew");
    std::fs::write(&path, bake_with(false)).unwrap();
    let prior = Prior::read(&path).unwrap();
    assert_eq!(prior.normalisation, trained.state.normalisation);
    let device = Backend::Flex.device(config.seed).unwrap();
    let units = set.units.name();
    let fresh_jaw = vec![sinew_host::aim::model::IDENTITY_9D; set.names.len() - 1];
    let start = prior
        .start(&config, &set.names, units, &fresh_jaw, &device)
        .unwrap();
    let (ended, began) = (
        measure(&trained.model, &set, trained.state.normalisation, 30),
        measure(&start, &set, prior.normalisation, 30),
    );
    assert_eq!(ended, began, "the start is the prior's end");

    // Shapes are matched by name: with the correctives listed in reverse, E's outputs and the
    // jaw transforms come reversed.
    let mut reversed = set.names.clone();
    reversed[1..].reverse();
    let flipped = prior
        .start(&config, &reversed, units, &fresh_jaw, &device)
        .unwrap();
    let m = set.names.len() - 1;
    let x = sinew_host::training::nn::tensor(vec![0.1, -0.2, 0.3, 0.0, 0.5, -0.4], [2, 3], &device);
    let e = |net: &sinew_host::aim::model::AimNet| {
        sinew_host::training::nn::to_vec(net.predict(x.clone(), x.clone()).correctives)
    };
    let (a, b) = (e(&start), e(&flipped));
    let jaw =
        |net: &sinew_host::aim::model::AimNet| sinew_host::training::nn::to_vec(net.jaw.val());
    let (ja, jb) = (jaw(&start), jaw(&flipped));
    for j in 0..m {
        for p in 0..2 {
            let at = |v: &[f32], s: usize| v[(p * m + s) * 3..(p * m + s) * 3 + 3].to_vec();
            assert_eq!(at(&a, j), at(&b, m - 1 - j), "shape {j}, point {p}");
        }
        assert_eq!(ja[9 * j..9 * j + 9], jb[9 * (m - 1 - j)..9 * (m - j)]);
    }
    // A shape the prior does not know starts fresh; one it knows keeps the prior's rows.
    let mut renamed = set.names.clone();
    renamed[1] = "notInThePrior".into();
    let partly = prior
        .start(&config, &renamed, units, &fresh_jaw, &device)
        .unwrap();
    let c = e(&partly);
    assert_ne!(c[..3], a[..3]);
    assert_eq!(c[3..3 * m], a[3..3 * m]);

    // Refusals, each naming the file.
    let named = |err: PriorError| {
        let text = err.to_string();
        assert!(text.contains(&path.display().to_string()), "{text}");
        text
    };
    let wider = AimConfig {
        hidden: config.hidden * 2,
        ..config.clone()
    };
    let text = named(
        prior
            .start(&wider, &set.names, units, &fresh_jaw, &device)
            .unwrap_err(),
    );
    assert!(text.contains("hidden"), "{text}");
    let text = named(
        prior
            .start(&config, &set.names, "mm-not-the-run", &fresh_jaw, &device)
            .unwrap_err(),
    );
    assert!(text.contains("mm-not-the-run"), "{text}");
    let strangers: Vec<String> = set.names.iter().map(|n| format!("{n}X")).collect();
    let text = named(
        prior
            .start(&config, &strangers, units, &fresh_jaw, &device)
            .unwrap_err(),
    );
    assert!(text.contains("no shape"), "{text}");
    std::fs::write(&path, bake_with(true)).unwrap();
    let text = named(Prior::read(&path).unwrap_err());
    assert!(text.contains("playback-only"), "{text}");
    let whole = bake_with(false);
    std::fs::write(&path, &whole[..whole.len() / 2]).unwrap();
    named(Prior::read(&path).unwrap_err());

    // A run with a prior records where it started, and its first check is the prior's end.
    std::fs::write(&path, &whole).unwrap();
    let again = tempfile::tempdir().unwrap();
    let mut options = aim_train_options(again.path(), false, Some(0));
    options.prior = Some(Prior::read(&path).unwrap());
    let run = train(&set, &config, &options).unwrap();
    assert_eq!(run.state.normalisation, prior.normalisation);
    let recorded = run.state.metadata.iter().find(|(k, _)| k == "prior");
    assert_eq!(
        recorded.map(|(_, v)| v.as_str()),
        Some(format!("prior.sinew ({m} of {m} shapes)").as_str())
    );
    assert_eq!(
        measure(&run.model, &set, run.state.normalisation, 30),
        began
    );
}
