//! S2D training checkpoints on a small synthetic decoder: a run stopped mid-epoch and resumed
//! (twice), or interrupted as by Ctrl-C, reaches the same weights and epoch losses bit for bit as
//! an uninterrupted one; a checkpoint of another run, or a damaged one, is refused with the
//! folder or file named.

use std::path::Path;

use sinew_host::s2d::checkpoint::{STATE_FILE, read_state};
use sinew_host::s2d::decoder::S2dDecoder;
use sinew_host::s2d::synthetic;
use sinew_host::s2d::train::{
    Sample, TrainConfig, TrainError, TrainOptions, Trained, request_stop, train,
};
use sinew_host::training::backend::Backend;
use sinew_host::training::checkpoint::{CheckpointError, InvalidState};
use sinew_host::training::nn::to_vec;

/// Training runs one at a time in this process: burn's CPU kernels split reductions across the
/// shared thread pool according to the work in flight, so two trainings at once round differently
/// (a resumed run then differs from an uninterrupted one). Alone, a run is bit-reproducible.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// 20 samples of a random linear map from 6 inputs to 30 vertices' displacements, with the
/// vertex weights.
fn data() -> (Vec<Sample>, Vec<f32>) {
    let mut rng = synthetic::Rng::new(11);
    let basis: Vec<f32> = (0..6 * 90).map(|_| rng.uniform(-0.5, 0.5)).collect();
    let set = (0..20)
        .map(|_| {
            let input: Vec<f32> = (0..6).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let displacement = (0..90)
                .map(|j| (0..6).map(|i| input[i] * basis[i * 90 + j]).sum())
                .collect();
            Sample {
                input,
                displacement,
            }
        })
        .collect();
    let weights = (0..30).map(|_| rng.uniform(0.0, 1.0)).collect();
    (set, weights)
}

/// 4 epochs of 4 batches (6, 6, 6 and 2 samples): 16 steps.
fn config() -> TrainConfig {
    TrainConfig {
        epochs: 4,
        batch: 6,
        lr: 3e-3,
        ..TrainConfig::default()
    }
}

fn options(dir: &Path, resume: bool, stop_after: Option<usize>) -> TrainOptions {
    TrainOptions {
        checkpoint_dir: Some(dir.to_path_buf()),
        resume,
        stop_after,
        context: [("fold".to_owned(), "0".to_owned())].into(),
    }
}

/// A fresh decoder on the small synthetic hierarchy (seeded: every call starts from the same
/// weights) trained on `set` with `options`.
fn run(
    set: &[Sample],
    weights: &[f32],
    config: &TrainConfig,
    options: &TrainOptions,
) -> Result<Trained, TrainError> {
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let h = synthetic::hierarchy(&[30, 12, 5], &[5, 4, 3], 1);
    let decoder = S2dDecoder::new(&synthetic::small_config(), &h, &device).unwrap();
    train(decoder, set, weights, config, &device, options)
}

/// The bits of every trained parameter: the fully connected layer and each spiral convolution,
/// weights then biases.
fn weight_bits(d: &S2dDecoder) -> Vec<u32> {
    let mut values = to_vec(d.fc.weight.val());
    values.extend(d.fc.bias.as_ref().map_or(Vec::new(), |b| to_vec(b.val())));
    for c in &d.convs {
        values.extend(to_vec(c.linear.weight.val()));
        values.extend(
            c.linear
                .bias
                .as_ref()
                .map_or(Vec::new(), |b| to_vec(b.val())),
        );
    }
    values.iter().map(|v| v.to_bits()).collect()
}

fn loss_bits(t: &Trained) -> Vec<u32> {
    t.state.losses.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn resumed_training_reaches_the_same_weights_and_losses() {
    let _serial = serial();
    let (set, w) = data();
    let config = config();
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let whole = run(&set, &w, &config, &options(a.path(), false, None)).unwrap();
    assert!(whole.complete());
    assert_eq!(whole.state.steps_done, 16);
    assert_eq!(whole.state.losses.len(), 4);

    // Stopped in epoch 1 after its second step, then in epoch 2 after its third.
    let first = run(&set, &w, &config, &options(b.path(), false, Some(6))).unwrap();
    assert!(!first.complete());
    let s = read_state(b.path()).unwrap();
    assert_eq!((s.epochs_done, s.steps_in_epoch, s.steps_done), (1, 2, 6));
    assert_eq!(s.losses.len(), 1);
    assert!(s.epoch_loss_total > 0.0);
    let second = run(&set, &w, &config, &options(b.path(), true, Some(5))).unwrap();
    assert_eq!(
        (second.state.epochs_done, second.state.steps_in_epoch),
        (2, 3)
    );
    let rest = run(&set, &w, &config, &options(b.path(), true, None)).unwrap();
    assert!(rest.complete());
    assert_eq!(rest.state.steps_done, 16);

    let trained = weight_bits(&whole.decoder);
    let c = tempfile::tempdir().unwrap();
    let untrained = run(&set, &w, &config, &options(c.path(), false, Some(0))).unwrap();
    assert_eq!(untrained.state.steps_done, 0);
    assert_ne!(
        weight_bits(&untrained.decoder),
        trained,
        "training changed nothing"
    );
    assert!(
        weight_bits(&rest.decoder) == trained,
        "the resumed run's weights differ from the uninterrupted run's"
    );
    assert_eq!(
        loss_bits(&rest),
        loss_bits(&whole),
        "the resumed run's epoch losses differ: {:?} vs {:?}",
        rest.state.losses,
        whole.state.losses
    );

    // A complete checkpoint resumes to the same weights without training.
    let again = run(&set, &w, &config, &options(a.path(), true, None)).unwrap();
    assert!(again.complete());
    assert_eq!(again.state.steps_done, 16);
    assert!(weight_bits(&again.decoder) == trained);
    assert_eq!(loss_bits(&again), loss_bits(&whole));
    // Only the last checkpoint's weight files remain.
    let mut names: Vec<String> = std::fs::read_dir(a.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["model-16.bpk", "optim-16.bpk", STATE_FILE]);
}

/// Ctrl-C's path ([`request_stop`]): interrupted after the first step of epoch 0, then after its
/// last step (the epoch closes before the checkpoint is written), the run still ends where an
/// uninterrupted one does.
#[test]
fn interrupted_training_resumes_to_the_same_weights() {
    let _serial = serial();
    let (set, w) = data();
    let config = config();
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let whole = run(&set, &w, &config, &options(a.path(), false, None)).unwrap();
    let folder = b.path().display().to_string();
    let position = |dir: &Path| {
        let s = read_state(dir).unwrap();
        (s.epochs_done, s.steps_in_epoch, s.steps_done)
    };

    request_stop();
    let e = format!(
        "{:#}",
        run(&set, &w, &config, &options(b.path(), false, None)).unwrap_err()
    );
    assert!(e.contains("interrupted") && e.contains(&folder), "{e}");
    assert_eq!(position(b.path()), (0, 1, 1));
    run(&set, &w, &config, &options(b.path(), true, Some(2))).unwrap();
    assert_eq!(position(b.path()), (0, 3, 3));
    request_stop();
    let e = format!(
        "{:#}",
        run(&set, &w, &config, &options(b.path(), true, None)).unwrap_err()
    );
    assert!(e.contains("interrupted") && e.contains(&folder), "{e}");
    assert_eq!(position(b.path()), (1, 0, 4));
    let rest = run(&set, &w, &config, &options(b.path(), true, None)).unwrap();
    assert!(rest.complete());
    assert!(
        weight_bits(&rest.decoder) == weight_bits(&whole.decoder),
        "the interrupted run's weights differ from the uninterrupted run's"
    );
    assert_eq!(loss_bits(&rest), loss_bits(&whole));
}

#[test]
fn resuming_another_run_is_refused_with_the_folder_and_the_difference() {
    let _serial = serial();
    let (set, w) = data();
    let config = config();
    let dir = tempfile::tempdir().unwrap();
    run(&set, &w, &config, &options(dir.path(), false, Some(3))).unwrap();
    let folder = dir.path().display().to_string();
    let state = dir.path().join(STATE_FILE);
    let refused = |set: &[Sample], config: &TrainConfig, options: &TrainOptions| {
        run(set, &w, config, options).expect_err("resumed another run")
    };
    // The differences named by a refusal as another run's checkpoint, in `state`.
    let differences = |e: &TrainError| match e {
        TrainError::Checkpoint(CheckpointError::Invalid {
            path,
            source: InvalidState::OtherRun { differences },
        }) if *path == state => differences.clone(),
        _ => panic!("not refused as another run: {e:#}"),
    };

    let longer = TrainConfig {
        epochs: 5,
        ..config.clone()
    };
    let e = refused(&set, &longer, &options(dir.path(), true, None));
    assert_eq!(
        differences(&e),
        ["config.epochs: 4 in the checkpoint, 5 now"]
    );
    assert!(format!("{e:#}").contains(&folder), "{e:#}");

    let mut other = set.clone();
    other[7].displacement[5] += 1e-3;
    let e = refused(&other, &config, &options(dir.path(), true, None));
    let d = differences(&e);
    assert!(d.len() == 1 && d[0].starts_with("data.crc: "), "{d:?}");

    let e = refused(&set[..19], &config, &options(dir.path(), true, None));
    assert!(
        differences(&e).contains(&"data.samples: 20 in the checkpoint, 19 now".to_owned()),
        "{e:#}"
    );

    let mut fold1 = options(dir.path(), true, None);
    fold1.context.insert("fold".to_owned(), "1".to_owned());
    let e = refused(&set, &config, &fold1);
    assert_eq!(
        differences(&e),
        ["context.fold: \"0\" in the checkpoint, \"1\" now"]
    );

    // Nothing to resume.
    let empty = tempfile::tempdir().unwrap();
    let e = refused(&set, &config, &options(empty.path(), true, None));
    assert!(
        matches!(&e, TrainError::Checkpoint(CheckpointError::StateRead { path, .. }) if *path == empty.path().join(STATE_FILE)),
        "{e:#}"
    );

    // The checkpoint is untouched: the same run still resumes.
    let resumed = run(&set, &w, &config, &options(dir.path(), true, None)).unwrap();
    assert!(resumed.complete());
}

#[test]
fn a_damaged_checkpoint_is_refused_naming_the_file() {
    let _serial = serial();
    let (set, w) = data();
    let config = config();
    let dir = tempfile::tempdir().unwrap();
    run(&set, &w, &config, &options(dir.path(), false, Some(6))).unwrap();
    let state_path = dir.path().join(STATE_FILE);
    let good = std::fs::read(&state_path).unwrap();
    let resume = || {
        let e = run(&set, &w, &config, &options(dir.path(), true, None))
            .expect_err("resumed from a damaged checkpoint");
        format!("{e:#}")
    };
    let text = String::from_utf8(good.clone()).unwrap();

    for (what, bytes) in [
        ("truncated", good[..good.len() / 2].to_vec()),
        ("empty", Vec::new()),
        ("not JSON", b"\x00\xffmodel".to_vec()),
        (
            "losses of another epoch count",
            text.replacen("\"epochs_done\": 1", "\"epochs_done\": 2", 1)
                .into_bytes(),
        ),
        (
            "an unreadable loss",
            text.replacen("\"epoch_loss_total\": \"", "\"epoch_loss_total\": \"x", 1)
                .into_bytes(),
        ),
        (
            "a weight file outside the folder",
            text.replacen("\"model-6.bpk\"", "\"../model-6.bpk\"", 1)
                .into_bytes(),
        ),
    ] {
        assert_ne!(bytes, good, "{what}: the damage did not apply");
        std::fs::write(&state_path, &bytes).unwrap();
        let e = resume();
        assert!(e.contains(&state_path.display().to_string()), "{what}: {e}");
    }

    std::fs::write(&state_path, &good).unwrap();
    let model = dir.path().join("model-6.bpk");
    let mut bytes = std::fs::read(&model).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&model, &bytes).unwrap();
    let e = resume();
    assert!(e.contains(&model.display().to_string()), "{e}");
    std::fs::remove_file(&model).unwrap();
    let e = resume();
    assert!(e.contains(&model.display().to_string()), "{e}");
}
