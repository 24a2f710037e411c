//! What a retargeting reads ([`Input`]: a file's bytes with its path) and why it is refused or
//! fails ([`RetargetError`], each naming the files concerned).

use std::path::{Path, PathBuf};

use sinew_core::error::FormatError;
use sinew_core::replay::ReplayError;

use crate::fit::bake::BakeError;
use crate::io::atomic::AtomicWriteError;
use crate::io::container::{ContainerError, WriterError};
use crate::io::mesh::MeshError;

/// A file's bytes with its path, so that a refusal can name the file.
#[derive(Clone, Copy, Debug)]
pub struct Input<'a> {
    /// Where the bytes were read from.
    pub path: &'a Path,
    /// The file's bytes.
    pub bytes: &'a [u8],
}

/// A retargeting that was refused or failed; each names the files concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RetargetError {
    /// A fit file that is not a `.sinew` performance.
    #[error("{}: not a performance", path.display())]
    NotAPerformance {
        /// The fit file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A fit of another actor than the source.
    #[error("{}: not a fit of the source actor {}", fit.display(), actor.display())]
    OtherActor {
        /// The fit file.
        fit: PathBuf,
        /// The source actor's file.
        actor: PathBuf,
        /// What the core said.
        #[source]
        source: ReplayError,
    },
    /// Actors that share no shape by name and have different numbers of shapes.
    #[error(
        "{} has {source_shapes} correctives and {} {target_shapes}, and no name in common: \
         the target cannot play the source's shapes",
        source_actor.display(),
        target_actor.display()
    )]
    NoSharedShapes {
        /// The source actor's file.
        source_actor: PathBuf,
        /// The target actor's file.
        target_actor: PathBuf,
        /// The source's correctives.
        source_shapes: usize,
        /// The target's correctives.
        target_shapes: usize,
    },
    /// An actor's shape names (its `shapes` metadata) that cannot be read.
    #[error("{}: its shape names", path.display())]
    ShapeNames {
        /// The actor file.
        path: PathBuf,
        /// Why.
        #[source]
        source: Box<crate::fit::baseline::BaselineError>,
    },
    /// Actors of other topologies whose rest shapes the face template cannot be registered on.
    #[error(
        "{}: no correspondence with the other actor (its topology differs, and the face \
         template could not be registered onto its rest shape)",
        path.display()
    )]
    Correspondence {
        /// The actor file.
        path: PathBuf,
        /// Why the registration failed.
        #[source]
        source: Box<crate::rig::RigError>,
    },
    /// A frame whose head and jaw transforms cannot be read.
    #[error("{}: frame {frame} unreadable", path.display())]
    Frame {
        /// The fit file.
        path: PathBuf,
        /// The frame (0-based).
        frame: usize,
    },
    /// The retargeted performance could not be laid out as a `.sinew` file.
    #[error("{}: retargeted onto {}", fit.display(), target_actor.display())]
    Layout {
        /// The fit file.
        fit: PathBuf,
        /// The target actor's file.
        target_actor: PathBuf,
        /// What the writer said.
        #[source]
        source: Box<WriterError>,
    },
    /// The retargeted performance does not play on the target.
    #[error("{}: retargeted onto {}", fit.display(), target_actor.display())]
    Play {
        /// The fit file.
        fit: PathBuf,
        /// The target actor's file.
        target_actor: PathBuf,
        /// Why it does not play.
        #[source]
        source: Box<BakeError>,
    },
    /// The fit does not play on the source actor it was fitted to.
    #[error("{}: cannot play on {}", fit.display(), actor.display())]
    PlaySource {
        /// The fit file.
        fit: PathBuf,
        /// The source actor's file.
        actor: PathBuf,
        /// Why it does not play.
        #[source]
        source: Box<BakeError>,
    },
    /// A file that cannot be read as a `.sinew` file, or an actor file that is not an AIM actor
    /// (the error names it).
    #[error(transparent)]
    Read(#[from] ContainerError),
    /// The output folder cannot be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// A retargeted performance that cannot be written (the error names the file).
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// A frame's mesh that cannot be written (the error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A strip frame past the performance's end.
    #[error("{}: strip frame {frame} is past the performance's {frames} frames", fit.display())]
    StripFrame {
        /// The fit file.
        fit: PathBuf,
        /// The frame asked for (0-based).
        frame: usize,
        /// The performance's frames.
        frames: usize,
    },
}
