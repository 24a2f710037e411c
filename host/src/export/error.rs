//! Why `sinew export gltf` fails: the command's errors, each naming the file, and the layout's.

use std::path::PathBuf;

use sinew_core::FormatError;
use sinew_core::replay::ReplayError;

use crate::aim::arkit::ArkitError;
use crate::aim::play::PoseFileError;
use crate::geometry::uv::UvError;
use crate::io::atomic::AtomicWriteError;
use crate::io::container::ContainerError;
use crate::io::glb::GlbError;
use crate::io::rig::RigReadError;
use crate::io::units::UnknownUnit;

/// Why `sinew export gltf` failed; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// A frame rate that is not a positive number.
    #[error("--fps must be a positive number, got {fps}")]
    Fps {
        /// The rate given.
        fps: f32,
    },
    /// The model or performance file could not be read, is no `.sinew` artefact, or the model
    /// is not an AIM actor.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The pose file is unreadable or does not fit the actor.
    #[error(transparent)]
    Poses(#[from] PoseFileError),
    /// The capture could not be read or mapped onto the actor.
    #[error(transparent)]
    Arkit(#[from] ArkitError),
    /// The performance file is not a fitted performance.
    #[error("{}: not a fitted performance", path.display())]
    NotAPerformance {
        /// The performance file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A performance fitted to another actor.
    #[error("{}", path.display())]
    OtherActor {
        /// The performance file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: ReplayError,
    },
    /// A local fit, whose coefficients glTF's per-mesh morph weights cannot carry.
    #[error(
        "{}: a local fit's coefficients vary over the face, which glTF's per-mesh morph \
         weights cannot carry; fit with --global for an engine, or write the meshes with \
         sinew play --performance",
        path.display()
    )]
    LocalFit {
        /// The performance file.
        path: PathBuf,
    },
    /// A performance frame whose coefficients or transforms cannot be read.
    #[error("{}: frame {frame} unreadable", path.display())]
    Frame {
        /// The performance file.
        path: PathBuf,
        /// The frame.
        frame: usize,
    },
    /// The actor could not be laid out as glTF.
    #[error("{}: cannot export", path.display())]
    Gltf {
        /// The model file.
        path: PathBuf,
        /// Why.
        #[source]
        source: GltfError,
    },
    /// The rig given to carry the rest of the character from could not be read.
    #[error("the rig to carry the character from")]
    Rig(#[source] RigReadError),
    /// The `.glb` could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}

/// Why an actor could not be laid out as a glTF rig.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GltfError {
    /// The artefact's `units` metadata names no known unit.
    #[error(transparent)]
    Units(#[from] UnknownUnit),
    /// A cache section of the wrong shape or type.
    #[error("{name}")]
    Section {
        /// The section.
        name: String,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// The core refused the jaw transform learned for a shape (`train.jaw`).
    #[error("the jaw transform learned for {shape}")]
    LearnedJaw {
        /// The shape.
        shape: String,
        /// What the core said.
        #[source]
        source: sinew_core::InputError,
    },
    /// The core refused a frame's head or jaw (a degenerate or out-of-range transform).
    #[error("frame {frame}")]
    Frame {
        /// The frame.
        frame: usize,
        /// What the core said.
        #[source]
        source: sinew_core::InputError,
    },
    /// The glTF document could not be serialised.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The container could not be laid out.
    #[error(transparent)]
    Glb(#[from] GlbError),
    /// The geometry could not be compressed.
    #[error(transparent)]
    Compress(#[from] crate::io::glb_compress::CompressError),
    /// The actor's record of its rig is broken.
    #[error(transparent)]
    Rig(#[from] crate::rig::record::RecordError),
    /// The actor's texture coordinates (metadata `uv`) do not fit it.
    #[error(transparent)]
    Uv(#[from] UvError),
}

impl From<crate::io::glb::BuildError> for GltfError {
    fn from(e: crate::io::glb::BuildError) -> Self {
        match e {
            crate::io::glb::BuildError::Json(e) => Self::Json(e),
            crate::io::glb::BuildError::Glb(e) => Self::Glb(e),
            crate::io::glb::BuildError::Compress(e) => Self::Compress(e),
        }
    }
}
