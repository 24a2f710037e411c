//! [`ViewError`]: why `sinew view` could not load its files or serve them.

use std::path::PathBuf;

use sinew_core::FormatError;
use sinew_core::replay::ReplayError;

use crate::aim::play::PoseFileError;
use crate::io::container::ContainerError;
use crate::io::mesh::MeshError;

/// Why `sinew view` could not load its files or serve them. Every variant about a file names
/// it, and the model where the file does not fit it.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewError {
    /// The landmark driver is no driver, or one of another actor.
    #[error(transparent)]
    Driver(#[from] crate::driver::drive::DriveError),
    /// The `--webcam` driver reads another tracker's points than MediaPipe Face Mesh's, which
    /// the page runs.
    #[error(
        "{}: --webcam runs MediaPipe Face Mesh in the page, and this driver reads iBUG's 68 \
         landmarks; train one for it with `sinew train driver --input mediapipe`",
        path.display()
    )]
    NotAMediaPipeDriver {
        /// The driver.
        path: PathBuf,
    },
    /// MediaPipe Face Mesh's web files cannot be served from the folder named.
    #[error(
        "{}: MediaPipe Face Mesh's web files are not there ({file} {problem}); install them with \
         `npm install {package}` (into node_modules/@mediapipe/face_mesh of the folder it runs \
         in) or name their folder with --tracker-dir",
        dir.display()
    )]
    TrackerMissing {
        /// The folder.
        dir: PathBuf,
        /// The first file that cannot be served.
        file: &'static str,
        /// What is wrong with it.
        problem: String,
        /// The npm package that holds the files, at its tested version.
        package: &'static str,
    },
    /// The driver's track cannot be read for it (the error names the file, and a CSV's row and
    /// column).
    #[error(transparent)]
    Track(#[from] crate::driver::track::TrackError),
    /// A `.sinew` file could not be read or is no valid artefact.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The model's header could not be read.
    #[error("{}", path.display())]
    Model {
        /// The model file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// The model is neither an AIM actor nor an S2D decoder.
    #[error(
        "{}: neither an AIM actor nor an S2D decoder that the viewer can show",
        path.display()
    )]
    NotViewable {
        /// The model file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// An S2D decoder's artefact that the core refuses.
    #[error("{}: not an S2D decoder that the viewer can show", path.display())]
    NotAnS2dDecoder {
        /// The model file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A file for an S2D decoder (`--track`, `--neutral`) given with an AIM actor.
    #[error(
        "{}: {flag} is for an S2D decoder, and {} is an AIM actor",
        path.display(),
        model.display()
    )]
    S2dFileForActor {
        /// The file.
        path: PathBuf,
        /// Its flag.
        flag: &'static str,
        /// The model file.
        model: PathBuf,
    },
    /// A file for an AIM actor (`--replay`, `--poses`, `--performance`) given with an S2D
    /// decoder.
    #[error(
        "{}: {flag} is for an AIM actor, and {} is an S2D decoder (it plays a --track)",
        path.display(),
        model.display()
    )]
    ActorFileForS2d {
        /// The file.
        path: PathBuf,
        /// Its flag.
        flag: &'static str,
        /// The model file.
        model: PathBuf,
    },
    /// The `--replay` file is not an AIM replay.
    #[error("{}: not an AIM replay", path.display())]
    NotAnAimReplay {
        /// The replay file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// The `--track` file is not an S2D replay.
    #[error("{}: not an S2D replay (a landmark track)", path.display())]
    NotAnS2dReplay {
        /// The track file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A replay or track recorded with another model.
    #[error("{}: does not play {}", path.display(), model.display())]
    DoesNotPlay {
        /// The replay or track file.
        path: PathBuf,
        /// The model file.
        model: PathBuf,
        /// What the core said.
        #[source]
        source: ReplayError,
    },
    /// The pose file is unreadable or does not fit the actor.
    #[error(transparent)]
    Poses(#[from] PoseFileError),
    /// The pose file could not be serialised for the page.
    #[error("{}: cannot serialise", path.display())]
    Serialise {
        /// The pose file.
        path: PathBuf,
        /// What the JSON writer said.
        #[source]
        source: serde_json::Error,
    },
    /// The `--performance` file is not a fitted performance.
    #[error("{}: not a fitted performance", path.display())]
    NotAPerformance {
        /// The performance file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A performance fitted to another actor.
    #[error(
        "{}: was fitted to another actor than {} ({reason})",
        path.display(),
        model.display()
    )]
    OtherActor {
        /// The performance file.
        path: PathBuf,
        /// The model file.
        model: PathBuf,
        /// What the core said.
        reason: ReplayError,
    },
    /// The `--neutral` face could not be read.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A `--neutral` face of another vertex count than the decoder's.
    #[error(
        "{}: has {vertices} vertices, the decoder {} {expected}: not a face in its topology",
        path.display(),
        model.display()
    )]
    NeutralVertices {
        /// The face file.
        path: PathBuf,
        /// Its vertices.
        vertices: usize,
        /// The model file.
        model: PathBuf,
        /// The decoder's vertices.
        expected: usize,
    },
    /// A `--neutral` face with a NaN or infinite position.
    #[error("{}: a vertex position is not finite", path.display())]
    NeutralNonFinite {
        /// The face file.
        path: PathBuf,
    },
    /// The page's configuration could not be serialised.
    #[error(transparent)]
    Json(serde_json::Error),
    /// An embedded file of the page is empty.
    #[error("an embedded file of the viewer is empty: the build is broken")]
    EmptyEntry,
    /// The port could not be listened on.
    #[error("cannot listen on 127.0.0.1:{port}")]
    Listen {
        /// The port.
        port: u16,
        /// What the system said.
        #[source]
        source: std::io::Error,
    },
    /// The server's runtime (its event loop and timers) could not start.
    #[error("cannot start the server")]
    Runtime(#[source] std::io::Error),
}
