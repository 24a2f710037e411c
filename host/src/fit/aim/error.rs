//! Why an AIM fit was refused or failed ([`FitError`]).

use std::path::PathBuf;

use crate::training::backend::BackendError;
use crate::training::checkpoint::CheckpointError;

/// An AIM fit that was refused or failed; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    /// Settings with no iteration, point, code dimension or hidden unit.
    #[error("the fit needs at least one iteration, point, code dimension and hidden unit")]
    EmptyConfig,
    /// A frame with another vertex count than the actor's.
    #[error("{}: {frame_vertices} vertices, the actor has {actor_vertices}", path.display())]
    VertexCount {
        /// The frame's mesh.
        path: PathBuf,
        /// Its vertices.
        frame_vertices: usize,
        /// The actor's vertices.
        actor_vertices: usize,
    },
    /// The backend cannot run.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// A checkpoint that cannot be saved or resumed (the error names the file).
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// Landmark vertices that do not index the performance's meshes.
    #[error("{}: the landmark vertices do not index the meshes", path.display())]
    Landmarks {
        /// The performance's manifest.
        path: PathBuf,
    },
    /// Landmark tracks without one pixel per landmark and frame.
    #[error(
        "{}: the landmark tracks do not have one pixel per landmark and frame",
        path.display()
    )]
    LandmarkTracks {
        /// The performance's manifest.
        path: PathBuf,
    },
    /// Ctrl-C: the fit stopped after saving a checkpoint.
    #[error(
        "stopped after step {step} of {iterations}; the fit is saved in {}: continue with \
         --resume {}",
        dir.display(),
        dir.display()
    )]
    Stopped {
        /// Steps done.
        step: usize,
        /// Steps asked for.
        iterations: usize,
        /// The checkpoint folder.
        dir: PathBuf,
    },
    /// The fit's mean error is not finite.
    #[error(
        "the fit diverged (mean error {mean_error_mm}); try fewer points or a smaller learning rate"
    )]
    Diverged {
        /// The mean error, mm.
        mean_error_mm: f64,
    },
    /// A fit asked to start where a driver put the head without one driven pose per frame.
    #[error("a fit from the driver's poses needs one per frame: {frames} frames, {driven} poses")]
    DriverStart {
        /// The performance's frames.
        frames: usize,
        /// The driven poses given.
        driven: usize,
    },
}
