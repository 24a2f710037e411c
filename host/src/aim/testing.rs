//! The small AIM training set and configuration the tests and benchmarks share.

use std::path::Path;

/// The procedural actor at `resolution` as an AIM training set, as the tests train on it.
pub fn procedural_training_set(resolution: usize) -> crate::aim::TrainingSet {
    let (actor, bones) = crate::aim::procedural::actor(resolution);
    crate::aim::data::training_set(&actor, &bones.skull, &bones.jaw, Some(bones.jaw_pivot), 2.5)
        .expect("the procedural actor makes a training set")
}

/// A small AIM configuration that trains in seconds: two hidden layers of 32, batch 512,
/// auxiliary batches of 64, learning rate 1e-3 → 1e-4 over `iterations` steps, the default
/// objective otherwise.
pub fn small_aim_config(iterations: usize) -> crate::aim::AimConfig {
    crate::aim::AimConfig {
        hidden: 32,
        layers: 2,
        batch: 512,
        symmetry_batch: 64,
        forehead_batch: 64,
        iterations,
        lr: 1e-3,
        lr_end: 1e-4,
        ..crate::aim::AimConfig::default()
    }
}

/// Options of a quiet AIM training on the flex backend, checkpointing to `dir`.
pub fn aim_train_options(
    dir: &Path,
    resume: bool,
    stop_after: Option<usize>,
) -> crate::aim::train::TrainOptions {
    crate::aim::train::TrainOptions {
        backend: crate::training::backend::Backend::Flex,
        checkpoint_dir: dir.to_path_buf(),
        resume,
        stop_after,
        quiet: true,
        target: None,
        prior: None,
    }
}
