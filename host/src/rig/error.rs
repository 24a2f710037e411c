//! Why a rig cannot be used ([`RigError`]), always naming the file.

use std::path::PathBuf;

use super::conventions::Axis;
use super::template;
use crate::io::rig::RigReadError;

/// Why a rig cannot be used, always naming the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigError {
    /// The files could not be read.
    #[error(transparent)]
    Read(#[from] RigReadError),
    /// Up and forward are the same line.
    #[error("{}: up {} and forward {} are not perpendicular", path.display(), up.name(), forward.name())]
    Axes {
        /// The rig.
        path: PathBuf,
        /// Up.
        up: Axis,
        /// Forward.
        forward: Axis,
    },
    /// No unit makes the head a head's size.
    #[error(
        "{}: cannot tell the unit: the head is {width} units wide, which is no head's width in \
         mm, cm or m; pass --units",
        path.display()
    )]
    Units {
        /// The rig.
        path: PathBuf,
        /// The width across the face frame's x, in the file's units.
        width: f64,
    },
    /// The node transform flattens the mesh.
    #[error("{}: the skin mesh's node transform cannot be inverted", path.display())]
    NodeTransform {
        /// The rig.
        path: PathBuf,
    },
    /// The registration cannot start or did not hold on the rig's surface.
    #[error("{}: {what}", path.display())]
    Registration {
        /// The rig.
        path: PathBuf,
        /// What went wrong.
        what: String,
    },
    /// A landmarks file that cannot be used.
    #[error("{}: {what}", path.display())]
    Landmarks {
        /// The landmarks file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// The built-in face template is broken.
    #[error(transparent)]
    Template(#[from] template::TemplateError),
}
