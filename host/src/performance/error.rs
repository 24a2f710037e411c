//! The refusals and failures of the performance generator (`sinew data performance`,
//! `sinew data neutral`), each naming the file or setting concerned.

use std::path::PathBuf;

use crate::io::atomic::AtomicWriteError;
use crate::io::container::ContainerError;
use crate::io::ict::IctError;
use crate::io::mesh::MeshError;

/// Settings that cannot make a performance (the message names the flag).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidPerformanceConfig {
    /// No frame asked for.
    #[error("--frames must be at least 1")]
    NoFrames,
    /// Mesh noise that is negative or not finite.
    #[error("--noise-mm must be finite and not negative, not {0}")]
    NoiseMm(f32),
    /// Landmark noise that is negative or not finite.
    #[error("--landmark-noise-px must be finite and not negative, not {0}")]
    LandmarkNoisePx(f32),
    /// A frame rate that is not positive.
    #[error("fps must be positive")]
    Fps,
    /// A camera with no positive focal length, distance or image size.
    #[error("the camera needs a positive focal length, distance and image size")]
    Camera,
    /// A convention amplitude that is negative or not finite.
    #[error("--convention-mm must be finite and not negative, not {0}")]
    ConventionMm(f32),
    /// Frames at rest that leave no frame to perform.
    #[error("--rest-frames {rest} leaves none of the {frames} frames to perform")]
    RestFrames {
        /// The frames at rest asked for.
        rest: usize,
        /// The frames.
        frames: usize,
    },
    /// More failures than the frames after the rest have room for.
    #[error(
        "--failures {failures}: {frames} frames have no room for them (each with a quarter second apart)"
    )]
    Failures {
        /// The failures asked for.
        failures: usize,
        /// The frames.
        frames: usize,
    },
}

/// A performance or neutral that could not be generated.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GenerateError {
    /// Settings that cannot make a performance.
    #[error(transparent)]
    Config(#[from] InvalidPerformanceConfig),
    /// The ICT-FaceKit folder cannot be read (the error names the file).
    #[error(transparent)]
    Kit(#[from] IctError),
    /// The actor file cannot be read, or is not an AIM actor (the error names it).
    #[error(transparent)]
    ActorFile(#[from] ContainerError),
    /// An actor whose template point is not a vertex of the kit's face region.
    #[error(
        "{}: template vertex {vertex} at {position:?} is not a vertex of the ICT-FaceKit face \
         region; the actor must be made on the kit's generic neutral (or a decimation of it)",
        path.display()
    )]
    OffTheKit {
        /// The actor file.
        path: PathBuf,
        /// The template point.
        vertex: usize,
        /// Its position.
        position: [f32; 3],
    },
    /// A kit landmark without a vertex in the face region.
    #[error("iBUG landmark {landmark} lies outside the face region")]
    LandmarkOutsideRegion {
        /// The landmark (0-based iBUG index).
        landmark: usize,
    },
    /// A landmark that the camera does not see inside its image.
    #[error(
        "{}: frame {frame}: landmark {landmark} (vertex {vertex} at {position:?}) projects \
         outside the {width}×{height} image of the camera at {camera:?}",
        path.display()
    )]
    LandmarkOutsideImage {
        /// The output folder.
        path: PathBuf,
        /// The frame.
        frame: usize,
        /// The landmark (0-based iBUG index).
        landmark: usize,
        /// Its mesh vertex.
        vertex: u32,
        /// The vertex's position in the frame.
        position: [f32; 3],
        /// The image width, pixels.
        width: u32,
        /// The image height, pixels.
        height: u32,
        /// The camera's centre.
        camera: [f32; 3],
    },
    /// The output folder cannot be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// A mesh that cannot be written (the error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The manifest cannot be encoded as JSON.
    #[error("{}: cannot encode the manifest", path.display())]
    Encode {
        /// The manifest file.
        path: PathBuf,
        /// What serde said.
        #[source]
        source: serde_json::Error,
    },
    /// The manifest cannot be written (the error names the file).
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}
