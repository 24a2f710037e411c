//! Why a training run of S2D-Dec was refused or stopped.

use std::path::PathBuf;

use crate::s2d::objective::InvalidTrainConfig;
use crate::training::checkpoint::CheckpointError;

/// A training run that was refused or stopped; each names the file or sample concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrainError {
    /// Settings out of range.
    #[error(transparent)]
    Config(#[from] InvalidTrainConfig),
    /// No training samples.
    #[error("no training samples")]
    NoSamples,
    /// Not one vertex weight per output vertex.
    #[error("{found} vertex weights for {vertices} vertices")]
    VertexWeights {
        /// The weights given.
        found: usize,
        /// The decoder's output vertices.
        vertices: usize,
    },
    /// A sample of another size than the decoder's input or output.
    #[error(
        "sample {index}: input {input} (expected {expected_input}), displacement {displacement} \
         (expected {expected_displacement})"
    )]
    Sample {
        /// The sample.
        index: usize,
        /// Its input's length.
        input: usize,
        /// The decoder's inputs.
        expected_input: usize,
        /// Its displacement's length.
        displacement: usize,
        /// The decoder's outputs.
        expected_displacement: usize,
    },
    /// `resume` without a checkpoint folder.
    #[error("resuming needs a checkpoint folder")]
    ResumeWithoutFolder,
    /// A checkpoint that cannot be read or written (the error names the file).
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// A checkpoint whose position does not fit the epoch's batches.
    #[error(
        "{}: step {step} of epoch {epoch} (step {steps_done} in all) does not fit {batches} \
         batches an epoch",
        path.display()
    )]
    Position {
        /// The checkpoint's state file.
        path: PathBuf,
        /// The step within the epoch.
        step: usize,
        /// The epoch.
        epoch: usize,
        /// The steps done in all.
        steps_done: usize,
        /// Batches per epoch.
        batches: usize,
    },
    /// The checkpoint folder cannot be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// The training threads cannot be started.
    #[error("cannot start a training thread")]
    Threads(#[source] rayon::ThreadPoolBuildError),
    /// A loss that is not finite.
    #[error("training diverged in epoch {epoch} (loss {loss})")]
    Diverged {
        /// The epoch.
        epoch: usize,
        /// The loss.
        loss: f32,
    },
    /// Ctrl-C without a checkpoint folder.
    #[error("interrupted at {at}")]
    Interrupted {
        /// Where: epoch, step and steps done.
        at: String,
    },
    /// Ctrl-C, with the checkpoint saved.
    #[error("interrupted at {at}; checkpoint saved in {} (continue with --resume)", dir.display())]
    InterruptedSaved {
        /// Where: epoch, step and steps done.
        at: String,
        /// The checkpoint folder.
        dir: PathBuf,
    },
}
