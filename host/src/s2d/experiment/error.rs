//! Why `sinew train s2d` or `sinew eval s2d` stopped.

use std::path::PathBuf;

use super::super::bake::S2dBakeError;
use super::super::baseline::BaselineModelError;
use super::super::data::PairsError;
use super::super::decoder::DecoderError;
use super::super::hierarchy::HierarchyError;
use super::super::objective::LandmarkError;
use super::super::protocol::{FOLDS, Protocol, SplitError};
use super::super::symmetry::SymmetryError;
use super::super::train::TrainError;
use crate::figures::render::PngError;
use crate::io::atomic::AtomicWriteError;
use crate::io::container::ContainerError;
use crate::io::dataset::DataSetError;
use crate::training::backend::BackendError;

/// A failed S2D experiment; each variant names the file or the setting at fault, and keeps the
/// cause as its source.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExperimentError {
    /// `--folds` outside 1 to [`FOLDS`].
    #[error("--folds {0}: between 1 and {FOLDS}")]
    Folds(usize),
    /// `--resume` without a checkpoint of fold 0.
    #[error(
        "{}: no checkpoint to resume (no {file}); run without --resume to start, or give the \
         --out of the run to continue",
        path.display()
    )]
    NoCheckpoint {
        /// Fold 0's checkpoint folder.
        path: PathBuf,
        /// The state file it lacks.
        file: &'static str,
    },
    /// A model that is not an S2D decoder.
    #[error("not an S2D decoder: {0}")]
    NotADecoder(sinew_core::FormatError),
    /// A model of another vertex count than the pairs'.
    #[error("the model decodes {model} vertices, the pairs have {pairs}")]
    VertexCount {
        /// The model's vertices.
        model: usize,
        /// The pairs' vertices.
        pairs: usize,
    },
    /// A model of other landmark vertices than the pairs'.
    #[error("the model's landmark vertices differ from the pairs'")]
    Landmarks,
    /// The core refused to decode a pair.
    #[error("decoding pair {pair}: {error}")]
    Decode {
        /// The pair.
        pair: usize,
        /// The core's error.
        error: sinew_core::EvalError,
    },
    /// A model file the core cannot read.
    #[error("{}: {source}", path.display())]
    Format {
        /// The model.
        path: PathBuf,
        /// The core's error.
        source: sinew_core::FormatError,
    },
    /// A model without `train s2d`'s protocol metadata.
    #[error(
        "{}: no S2D protocol in the metadata{}; train it with `sinew train s2d`",
        path.display(),
        found_protocol(protocol)
    )]
    NoProtocol {
        /// The model.
        path: PathBuf,
        /// The metadata's value, if any.
        protocol: Option<String>,
    },
    /// A model without `train s2d`'s fold metadata.
    #[error("{}: no fold in the metadata", path.display())]
    NoFold {
        /// The model.
        path: PathBuf,
    },
    /// A model trained on pairs of another seed.
    #[error(
        "{}: trained on pairs of seed {model_seed}, but {} has seed {pairs_seed}",
        path.display(),
        pairs.display()
    )]
    PairsSeed {
        /// The model.
        path: PathBuf,
        /// The seed in its metadata.
        model_seed: String,
        /// The pairs' folder.
        pairs: PathBuf,
        /// The pairs' seed.
        pairs_seed: u64,
    },
    /// A fold's model in the place of another fold's.
    #[error(
        "{}: a model of fold {fold}, where `train s2d --folds {folds}` puts fold {expected}",
        path.display()
    )]
    WrongFold {
        /// The model.
        path: PathBuf,
        /// Its fold.
        fold: usize,
        /// The folds evaluated.
        folds: usize,
        /// The fold its place holds.
        expected: usize,
    },
    /// A fold's model trained on another split than fold 0's.
    #[error(
        "{}: trained on the {protocol} split, fold 0 on the {first} split",
        path.display()
    )]
    OtherProtocol {
        /// The model.
        path: PathBuf,
        /// Its protocol.
        protocol: Protocol,
        /// Fold 0's.
        first: Protocol,
    },
    /// Evaluating one fold's model failed.
    #[error("{}", path.display())]
    InModel {
        /// The model.
        path: PathBuf,
        /// What failed.
        source: Box<ExperimentError>,
    },
    /// The pair set.
    #[error(transparent)]
    PairSet(#[from] DataSetError),
    /// A pair's sample.
    #[error(transparent)]
    Pairs(#[from] PairsError),
    /// The mesh hierarchy.
    #[error("building the face region's mesh hierarchy")]
    Hierarchy(#[source] HierarchyError),
    /// The landmark distances of the objective.
    #[error(transparent)]
    Landmark(#[from] LandmarkError),
    /// The face region's mirror symmetry.
    #[error("mirroring the pairs' face region")]
    Symmetry(#[source] SymmetryError),
    /// The protocol's split.
    #[error(transparent)]
    Split(#[from] SplitError),
    /// The burn backend.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// The decoder's construction or input normalisation.
    #[error(transparent)]
    Decoder(#[from] DecoderError),
    /// Training.
    #[error(transparent)]
    Train(#[from] TrainError),
    /// Baking.
    #[error(transparent)]
    Bake(#[from] S2dBakeError),
    /// A baseline model.
    #[error(transparent)]
    Baseline(#[from] BaselineModelError),
    /// Reading a model.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// Writing a model or the report.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// The cumulative-error plot.
    #[error(transparent)]
    Plot(#[from] PngError),
    /// Laying out metadata or the report as JSON.
    #[error("laying out JSON")]
    Json(#[from] serde_json::Error),
}

/// The `protocol` a model's metadata names when it is neither S2D protocol (nothing when absent).
fn found_protocol(protocol: &Option<String>) -> String {
    protocol.as_ref().map_or_else(String::new, |p| {
        format!(" (protocol={p}, neither identity nor expression)")
    })
}
