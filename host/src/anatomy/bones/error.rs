//! [`BonesError`]: why the template bones could not be loaded or fitted.

use std::path::PathBuf;

use crate::anatomy::constraints::Bone;
use crate::io::mesh::{InvalidMesh, MeshError};

/// The bone landmark file's name in messages.
pub(super) const LANDMARKS_NAME: &str = "host/data/bone_landmarks.json";

/// Why the template bones could not be loaded or fitted to a face. The template variants name
/// the file, the landmark-file variants `host/data/bone_landmarks.json`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BonesError {
    /// The bone landmark file is not valid JSON of its schema.
    #[error("{}: invalid", LANDMARKS_NAME)]
    LandmarkFile(#[source] serde_json::Error),
    /// A registration pair names a landmark of another template (or none).
    #[error(
        "{}: registration pair names {name}, not a {want} landmark",
        LANDMARKS_NAME
    )]
    RegistrationPair {
        /// The landmark named.
        name: String,
        /// The template it must lie on.
        want: String,
    },
    /// Fewer than three registration pairs.
    #[error("{}: cranium registration needs at least 3 pairs", LANDMARKS_NAME)]
    TooFewPairs,
    /// The skull cut's axis is not 0, 1 or 2.
    #[error("{}: keep_axis must be 0, 1 or 2", LANDMARKS_NAME)]
    KeepAxis,
    /// A landmark with a skin rule and no soft-tissue thickness.
    #[error("{}: landmark {name} has a skin rule but no fstt_mm", LANDMARKS_NAME)]
    NoThickness {
        /// The landmark.
        name: String,
    },
    /// A template file is absent from the data folder.
    #[error(
        "{}: missing (a bone template; the data folder is described in {})",
        path.display(),
        readme.display()
    )]
    TemplateMissing {
        /// The template file.
        path: PathBuf,
        /// The data folder's README.
        readme: PathBuf,
    },
    /// A template file could not be read.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A landmark names a vertex the template lacks.
    #[error(
        "{}: landmark {landmark} names vertex {vertex}, but the file has {vertices} vertices",
        path.display()
    )]
    LandmarkVertex {
        /// The template file.
        path: PathBuf,
        /// The landmark.
        landmark: String,
        /// The vertex it names.
        vertex: u32,
        /// The template's vertices.
        vertices: usize,
    },
    /// A landmark vertex away from where the landmark file puts it: another version of the
    /// template.
    #[error(
        "{}: vertex {vertex} (landmark {landmark}) is at {at:?}, {} expects {expected:?}: not \
         the published file?",
        path.display(),
        LANDMARKS_NAME
    )]
    LandmarkMoved {
        /// The template file.
        path: PathBuf,
        /// The vertex.
        vertex: u32,
        /// The landmark.
        landmark: String,
        /// Where the template has it.
        at: [f32; 3],
        /// Where the landmark file expects it.
        expected: [f32; 3],
    },
    /// The skull's registration gave a transform without an inverse.
    #[error("cranium registration failed: degenerate transform")]
    DegenerateRegistration,
    /// Not 68 iBUG landmarks.
    #[error("{given} iBUG landmarks given, 68 expected")]
    IbugCount {
        /// The landmarks given.
        given: usize,
    },
    /// A mesh unit of zero, negative or non-finite millimetres.
    #[error("mm per unit must be positive, got {mm_per_unit}")]
    MmPerUnit {
        /// The value given.
        mm_per_unit: f32,
    },
    /// The neutral mesh breaks a rule of [`crate::io::mesh::Mesh::validate`].
    #[error("the neutral mesh to {purpose}")]
    InvalidNeutral {
        /// What the mesh was for.
        purpose: &'static str,
        /// The broken rule.
        #[source]
        source: InvalidMesh,
    },
    /// An iBUG landmark beyond the mesh's vertices.
    #[error("iBUG landmark vertex {vertex} is not below the mesh's {vertices} vertices")]
    IbugVertex {
        /// The landmark's vertex.
        vertex: u32,
        /// The mesh's vertices.
        vertices: usize,
    },
    /// A skin landmark the fit needs is absent.
    #[error("skin landmark {name} is missing (needed for {needed_for})")]
    SkinLandmarkMissing {
        /// The landmark.
        name: String,
        /// What needs it.
        needed_for: &'static str,
    },
    /// A skin landmark beyond the mesh's vertices.
    #[error("skin landmark {name} is vertex {vertex}, beyond the mesh's {vertices} vertices")]
    SkinLandmarkVertex {
        /// The landmark.
        name: String,
        /// Its vertex.
        vertex: u32,
        /// The mesh's vertices.
        vertices: usize,
    },
    /// Skin landmarks that span no face frame.
    #[error("degenerate skin landmarks: cannot build the face frame")]
    DegenerateFrame,
    /// Fewer than three weighted skin landmarks for a bone.
    #[error("only {count} weighted skin landmarks for the {bone}; 3 needed")]
    TooFewLandmarks {
        /// The bone.
        bone: Bone,
        /// Its weighted landmarks.
        count: usize,
    },
}
