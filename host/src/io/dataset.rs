//! A data set on disk: a folder holding `manifest.json` (what the set holds, by name) and one
//! `.sinew` file of numbers (docs/FORMAT.md). The S2D pair sets (`s2d::pairs_file`) and the
//! motion sets (`motion::motions_file`) share this shape; this module reads and writes the two
//! files, checks the manifest's format and version, reads the sections, and says what is wrong
//! in a [`DataSetError`] that names the file.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde::de::DeserializeOwned;
use sinew_core::{ArtifactKind, FormatError, SinewFile};

use crate::io::container::{ContainerError, WriterError};
use crate::io::mesh::Mesh;

/// A data set folder that could not be read or written, always with the file's path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DataSetError {
    /// The manifest could not be read.
    #[error("{}: cannot read", path.display())]
    ManifestRead {
        /// The manifest.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The manifest is not JSON of the expected shape.
    #[error("{}: not {what}", path.display())]
    ManifestJson {
        /// The manifest.
        path: PathBuf,
        /// What it should be, e.g. "an S2D pairs manifest".
        what: &'static str,
        /// What the parser said.
        #[source]
        source: serde_json::Error,
    },
    /// The manifest is of another format or version.
    #[error(
        "{}: format {format:?} version {version}, expected {expected_format:?} version \
         {expected_version}",
        path.display()
    )]
    ManifestVersion {
        /// The manifest.
        path: PathBuf,
        /// Its format name.
        format: String,
        /// Its version.
        version: u32,
        /// The format name this reader takes.
        expected_format: &'static str,
        /// The version this reader takes.
        expected_version: u32,
    },
    /// The manifest breaks one of its own rules.
    #[error("{}: invalid manifest", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// The broken rule.
        #[source]
        source: ManifestProblem,
    },
    /// The data file could not be read, or is not a valid `.sinew` file (the error names it).
    #[error(transparent)]
    Data(#[from] ContainerError),
    /// The data file's sections disagree with the manifest or with each other.
    #[error("{}: invalid contents", path.display())]
    Contents {
        /// The data file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: ContentError,
    },
    /// The set could not be laid out as a `.sinew` file.
    #[error("{}: cannot encode", path.display())]
    Encode {
        /// The data file it would have been written to.
        path: PathBuf,
        /// Why.
        #[source]
        source: WriterError,
    },
    /// The manifest could not be written as JSON.
    #[error("{}: cannot encode", path.display())]
    EncodeManifest {
        /// The manifest it would have been written to.
        path: PathBuf,
        /// What the encoder said.
        #[source]
        source: serde_json::Error,
    },
    /// A file could not be written to disk (the message names the file).
    #[error(transparent)]
    Write(crate::io::atomic::AtomicWriteError),
}

/// An entry of a manifest: a pair of a pair set or a sequence of a motion set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entry {
    /// Pair `p` of an S2D pair set.
    Pair(usize),
    /// Sequence `s` of a motion set.
    Sequence(usize),
}

impl fmt::Display for Entry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Entry::Pair(p) => write!(f, "pair {p}"),
            Entry::Sequence(s) => write!(f, "sequence {s}"),
        }
    }
}

/// A rule of a manifest that it breaks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ManifestProblem {
    /// A shape named that is not in the expression list.
    #[error("{}expression {name:?} is not in the expression list", entry_prefix(*entry))]
    UnknownExpression {
        /// Where it is named (none: in the shape groups).
        entry: Option<Entry>,
        /// The name.
        name: String,
    },
    /// An expression in two shape groups.
    #[error("expression {name:?} is in two shape groups")]
    TwoGroups {
        /// The expression.
        name: String,
    },
    /// An expression in no shape group.
    #[error("expression {name:?} is in no shape group")]
    NoGroup {
        /// The expression.
        name: String,
    },
    /// An entry whose identity is not in the identity list.
    #[error("{entry}: identity {identity} of {count}")]
    Identity {
        /// The pair or sequence.
        entry: Entry,
        /// Its identity.
        identity: usize,
        /// The number of identities.
        count: usize,
    },
    /// A pair without shapes.
    #[error("{entry}: no expression shapes")]
    NoShapes {
        /// The pair.
        entry: Entry,
    },
    /// A pair's shape weight outside (0, 1].
    #[error("{entry}: weight {weight} of {shape:?} is not in (0, 1]")]
    Weight {
        /// The pair.
        entry: Entry,
        /// The shape.
        shape: String,
        /// Its weight.
        weight: f32,
    },
    /// A pair's shape from another group than the pair's.
    #[error("{entry}: {shape:?} is not in shape group {group}")]
    Group {
        /// The pair.
        entry: Entry,
        /// The shape.
        shape: String,
        /// The pair's group.
        group: usize,
    },
    /// A shape listed twice in one pair.
    #[error("{entry}: {shape:?} is listed twice")]
    Repeated {
        /// The pair.
        entry: Entry,
        /// The shape.
        shape: String,
    },
    /// Class labels other than the expected ones.
    #[error("labels {labels:?} are not CoMA's twelve")]
    Labels {
        /// The labels found.
        labels: Vec<String>,
    },
    /// A sequence whose label is not in the label list.
    #[error("{entry}: unknown label {label:?}")]
    UnknownLabel {
        /// The sequence.
        entry: Entry,
        /// Its label.
        label: String,
    },
    /// Not 68 landmarks, or one beyond the vertices.
    #[error("68 landmark vertices below {vertices} expected")]
    Landmarks {
        /// The vertex count.
        vertices: usize,
    },
    /// A sequence too short to move.
    #[error("{entry}: fewer than 2 frames")]
    TooFewFrames {
        /// The sequence.
        entry: Entry,
    },
    /// A generation setting out of its range (the problem names the option).
    #[error("settings: {problem}")]
    Setting {
        /// What is wrong.
        problem: String,
    },
    /// A sequence on the wrong side of the split (repetition 0 and only it is a test sequence).
    #[error(
        "{entry}: repetition {repetition} is on the {side} side; repetition 0 and only it is a \
         test sequence"
    )]
    Split {
        /// The sequence.
        entry: Entry,
        /// Its repetition.
        repetition: usize,
        /// The side it is on.
        side: String,
    },
}

fn entry_prefix(entry: Option<Entry>) -> String {
    entry.map(|e| format!("{e}: ")).unwrap_or_default()
}

/// What is wrong inside a data set's `.sinew` file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ContentError {
    /// The bytes are not a `.sinew` file of the expected kind.
    #[error(transparent)]
    Format(FormatError),
    /// The file holds something else (its `content` metadata differs).
    #[error("not {expected} data ({})", found_content(found))]
    Content {
        /// The `content` this reader takes.
        expected: &'static str,
        /// The file's.
        found: Option<String>,
    },
    /// A section that is missing or has another type or shape than the manifest implies.
    #[error("section {name}")]
    Section {
        /// The section.
        name: String,
        /// The core's verdict.
        source: FormatError,
    },
    /// A triangle section whose shape is not `[T, 3]`.
    #[error("{name}: shape must be [T, 3]")]
    TriangleShape {
        /// The section.
        name: String,
    },
    /// A vertex index beyond the template's vertices.
    #[error("{name}: vertex index out of range")]
    VertexIndex {
        /// The section.
        name: String,
    },
    /// Landmarks that differ from the manifest's.
    #[error("{name} differs from the manifest's landmarks")]
    Landmarks {
        /// The section.
        name: String,
    },
    /// Not 68 landmarks, or one beyond the template's vertices.
    #[error("{name}: 68 landmark vertices below {vertices} expected")]
    LandmarkCount {
        /// The section.
        name: String,
        /// The template's vertex count.
        vertices: u32,
    },
    /// A count of the manifest beyond what a section can hold.
    #[error("count {count} too large")]
    Count {
        /// The count.
        count: usize,
    },
    /// An entry's stored number differs from the manifest's (identity or weights).
    #[error("{name}: {entry} differs from the manifest")]
    Entry {
        /// The section.
        name: String,
        /// The pair or sequence.
        entry: Entry,
    },
    /// A weight outside [0, 1].
    #[error("{name}: a weight outside [0, 1]")]
    WeightRange {
        /// The section.
        name: String,
    },
    /// A stored frame that differs from the frame its weights give.
    #[error("{name}: {entry} frame {frame} differs from its weights' frame")]
    Frame {
        /// The section.
        name: String,
        /// The sequence.
        entry: Entry,
        /// The frame.
        frame: usize,
    },
}

/// The `content` a file's metadata names, or that it names none.
fn found_content(found: &Option<String>) -> String {
    match found {
        Some(found) => format!("its metadata says content={found}"),
        None => "its metadata has no content entry".into(),
    }
}

/// The manifest `dir/file`, parsed; `what` names the expected content in errors (e.g. "a
/// motion-set manifest").
pub fn read_manifest<M: DeserializeOwned>(
    dir: &Path,
    file: &str,
    what: &'static str,
) -> Result<(M, PathBuf), DataSetError> {
    let path = dir.join(file);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(source) => return Err(DataSetError::ManifestRead { path, source }),
    };
    match serde_json::from_str(&text) {
        Ok(m) => Ok((m, path)),
        Err(source) => Err(DataSetError::ManifestJson { path, what, source }),
    }
}

/// Checks a manifest's `format` and `version` against the reader's.
pub fn check_version(
    path: &Path,
    (format, version): (&str, u32),
    (expected_format, expected_version): (&'static str, u32),
) -> Result<(), DataSetError> {
    if format == expected_format && version == expected_version {
        return Ok(());
    }
    Err(DataSetError::ManifestVersion {
        path: path.to_owned(),
        format: format.to_owned(),
        version,
        expected_format,
        expected_version,
    })
}

/// The names of a kind of data set: its two files, the manifest's format and version, and what
/// errors call its manifest.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// The manifest's file name.
    pub manifest: &'static str,
    /// The data file's name.
    pub data: &'static str,
    /// What the manifest is, for errors (e.g. "a motion-set manifest").
    pub what: &'static str,
    /// The manifest's `format`.
    pub format: &'static str,
    /// The manifest's `version`.
    pub version: u32,
}

/// A manifest's own format name and version.
pub trait Versioned {
    /// `format` and `version` as the file has them.
    fn format_version(&self) -> (&str, u32);
}

/// Reads the set in `dir`: the manifest, checked for format and version and by `check` (which
/// returns what `parts` needs of it), then the data file's bytes, which `parts` reads against
/// the manifest. Every error names the file it is about.
pub fn read<M, C, T>(
    dir: &Path,
    layout: &Layout,
    check: impl FnOnce(&M) -> Result<C, ManifestProblem>,
    parts: impl FnOnce(M, C, &[u8]) -> Result<T, ContentError>,
) -> Result<T, DataSetError>
where
    M: DeserializeOwned + Versioned,
{
    let (manifest, mpath): (M, _) = read_manifest(dir, layout.manifest, layout.what)?;
    check_version(
        &mpath,
        manifest.format_version(),
        (layout.format, layout.version),
    )?;
    let checked = check(&manifest).map_err(|source| DataSetError::Manifest {
        path: mpath,
        source,
    })?;
    let dpath = dir.join(layout.data);
    let bytes = crate::io::container::read(&dpath)?;
    parts(manifest, checked, &bytes).map_err(|source| DataSetError::Contents {
        path: dpath,
        source,
    })
}

/// Writes the set into `dir` (created if missing): the data file (`bytes`, laid out by the
/// caller) and the manifest, each atomically, the manifest last.
pub fn write(
    dir: &Path,
    layout: &Layout,
    bytes: Result<Vec<u8>, WriterError>,
    manifest: &impl Serialize,
) -> Result<(), DataSetError> {
    let dpath = dir.join(layout.data);
    let bytes = bytes.map_err(|source| DataSetError::Encode {
        path: dpath.clone(),
        source,
    })?;
    let mpath = dir.join(layout.manifest);
    let json =
        serde_json::to_string_pretty(manifest).map_err(|source| DataSetError::EncodeManifest {
            path: mpath.clone(),
            source,
        })?;
    crate::io::atomic::write(&dpath, &bytes).map_err(DataSetError::Write)?;
    crate::io::atomic::write(&mpath, json.as_bytes()).map_err(DataSetError::Write)
}

/// A count of a manifest as a section dimension.
pub fn count(n: usize) -> Result<u32, ContentError> {
    u32::try_from(n).map_err(|_| ContentError::Count { count: n })
}

/// The sections of a data set's `.sinew` file, read by name and expected shape.
#[derive(Debug)]
pub struct Sections<'a> {
    file: SinewFile<'a>,
}

impl<'a> Sections<'a> {
    /// Opens `bytes` as a file of `kind` whose `content` metadata is `content`.
    pub fn open(
        bytes: &'a [u8],
        kind: ArtifactKind,
        content: &'static str,
    ) -> Result<Self, ContentError> {
        let file = SinewFile::from_bytes_of_kind(bytes, kind).map_err(ContentError::Format)?;
        let found = file.metadata().get("content");
        if found != Some(content) {
            return Err(ContentError::Content {
                expected: content,
                found: found.map(str::to_owned),
            });
        }
        Ok(Self { file })
    }

    /// The `f32` section `name` of shape `dims`, flattened.
    pub fn f32s(&self, name: &str, dims: &[u32]) -> Result<Vec<f32>, ContentError> {
        match self.file.f32_tensor(name, dims) {
            Ok(v) => Ok(v.iter().collect()),
            Err(source) => Err(section(name, source)),
        }
    }

    /// The `u32` section `name` of shape `dims`, flattened.
    pub fn u32s(&self, name: &str, dims: &[u32]) -> Result<Vec<u32>, ContentError> {
        match self.file.u32_tensor(name, dims) {
            Ok(v) => Ok(v.iter().collect()),
            Err(source) => Err(section(name, source)),
        }
    }

    /// The template mesh: `PREFIX.template` (`[V, 3]` positions, `V = vertices`) and
    /// `PREFIX.tri` (`[T, 3]` vertex indices below `V`).
    pub fn template(&self, prefix: &str, vertices: u32) -> Result<Mesh, ContentError> {
        let positions = points(&self.f32s(&format!("{prefix}.template"), &[vertices, 3])?);
        let name = format!("{prefix}.tri");
        let (dims, rank) = self
            .file
            .dims_of(&name)
            .map_err(|source| section(&name, source))?;
        if rank != 2 || dims[1] != 3 {
            return Err(ContentError::TriangleShape { name });
        }
        let tri = self.u32s(&name, &dims[..2])?;
        if tri.iter().any(|&x| x >= vertices) {
            return Err(ContentError::VertexIndex { name });
        }
        Ok(Mesh::new(
            positions,
            tri.chunks_exact(3).map(<[u32]>::to_vec).collect(),
        ))
    }
}

fn section(name: &str, source: FormatError) -> ContentError {
    ContentError::Section {
        name: name.to_owned(),
        source,
    }
}

/// Flat coordinates as points.
pub fn points(s: &[f32]) -> Vec<[f32; 3]> {
    s.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Point arrays flattened, one after another.
pub fn flat(v: &[Vec<[f32; 3]>]) -> Vec<f32> {
    v.iter().flatten().flatten().copied().collect()
}

#[cfg(test)]
mod tests;
