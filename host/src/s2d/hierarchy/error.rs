//! Why a mesh hierarchy cannot be built, read or written; each names the face, vertex, section
//! or file concerned.

use std::path::PathBuf;

use sinew_core::FormatError;

use crate::io::atomic::AtomicWriteError;
use crate::io::container::WriterError;
use crate::io::mesh::MeshError;
use crate::s2d::spirals::NonManifoldVertex;

/// A mesh that is not a manifold surface the hierarchy can be built on, naming the face or
/// vertex at fault (see [`super::build`] for the conditions).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SurfaceError {
    /// A mesh without vertices.
    #[error("the mesh has no vertices")]
    NoVertices,
    /// A mesh without faces.
    #[error("the mesh has no faces")]
    NoFaces,
    /// A face with fewer than 3 corners.
    #[error("face {face} has {corners} corners (at least 3 needed)")]
    Corners {
        /// The face.
        face: usize,
        /// Its corners.
        corners: usize,
    },
    /// A face that refers to a vertex past the last.
    #[error("face {face} refers to vertex {vertex} but the mesh has {vertices} vertices")]
    VertexIndex {
        /// The face.
        face: usize,
        /// The vertex it names.
        vertex: u32,
        /// The mesh's vertices.
        vertices: usize,
    },
    /// A face that uses a vertex twice.
    #[error("face {face} uses vertex {vertex} twice (degenerate face)")]
    RepeatedVertex {
        /// The face.
        face: usize,
        /// The vertex.
        vertex: u32,
    },
    /// A face (or one triangle of its fan) of zero area.
    #[error("face {face} has zero area (vertices {polygon:?}; degenerate face)")]
    ZeroArea {
        /// The face.
        face: usize,
        /// Its vertices.
        polygon: Vec<u32>,
    },
    /// An edge shared by more than two faces.
    #[error(
        "edge ({}, {}) is shared by {} faces {faces:?} (non-manifold edge)",
        edge.0,
        edge.1,
        faces.len()
    )]
    NonManifoldEdge {
        /// The edge's vertices, lower first.
        edge: (u32, u32),
        /// The faces sharing it.
        faces: Vec<usize>,
    },
    /// Two faces that use an edge in the same direction.
    #[error(
        "faces {} and {} use edge ({}, {}) in the same direction (inconsistent orientation or a \
         non-manifold fold)",
        faces.0,
        faces.1,
        edge.0,
        edge.1
    )]
    Orientation {
        /// The two faces.
        faces: (usize, usize),
        /// The edge's vertices, lower first.
        edge: (u32, u32),
    },
    /// Two faces on the same vertices.
    #[error(
        "faces {} and {} use the same vertices {vertices:?} (duplicate face)",
        faces.0,
        faces.1
    )]
    DuplicateFace {
        /// The two faces.
        faces: (usize, usize),
        /// Their vertices, sorted.
        vertices: [u32; 3],
    },
    /// A vertex in no face.
    #[error("vertex {vertex} belongs to no face")]
    IsolatedVertex {
        /// The vertex.
        vertex: usize,
    },
    /// A vertex whose faces do not form one fan.
    #[error(
        "vertex {vertex} joins faces that do not form one fan (non-manifold vertex, faces \
         {faces:?})"
    )]
    NonManifoldVertex {
        /// The vertex.
        vertex: usize,
        /// Its faces.
        faces: Vec<usize>,
    },
}

/// A hierarchy that cannot be built from a mesh and a configuration.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BuildError {
    /// Spiral lengths that are not one positive length per level.
    #[error("spiral lengths {lengths:?}: need {levels} positive lengths, one per level")]
    SpiralLengths {
        /// The lengths given.
        lengths: Vec<usize>,
        /// The levels.
        levels: usize,
    },
    /// A decimation factor below 2.
    #[error("decimation factor {index} is {factor} (at least 2 needed)")]
    Factor {
        /// The factor's position.
        index: usize,
        /// Its value.
        factor: usize,
    },
    /// A mesh that is not a manifold surface.
    #[error(transparent)]
    Surface(#[from] SurfaceError),
    /// A level that cannot be decimated that far without breaking the surface.
    #[error("level {level} → {}", level + 1)]
    Decimate {
        /// The finer level.
        level: usize,
        /// What the decimation said.
        #[source]
        source: crate::geometry::qem::DecimateError,
    },
    /// A level with a vertex that has no spiral.
    #[error("spirals of level {level}")]
    Spirals {
        /// The level.
        level: usize,
        /// The vertex.
        #[source]
        source: NonManifoldVertex,
    },
}

/// Hierarchy sections that cannot be read back, naming the section.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SectionError {
    /// Bytes that are not a `.sinew` file.
    #[error("not a .sinew file")]
    NotASinewFile(#[source] FormatError),
    /// A section that is missing or that the core refuses.
    #[error("section {name}")]
    Format {
        /// The section.
        name: String,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A section of the wrong rank or shape.
    #[error("section {name}: {rule}")]
    Shape {
        /// The section.
        name: String,
        /// The shape it must have.
        rule: &'static str,
    },
    /// A level whose vertex count overflows with the dummy vertex.
    #[error("section {name}: level {level} is too large")]
    TooLarge {
        /// The levels section.
        name: String,
        /// The level.
        level: usize,
    },
    /// A triangle that refers to a vertex past the level's last.
    #[error("section {name}: vertex index out of range")]
    VertexIndex {
        /// The section.
        name: String,
    },
}

/// A hierarchy that cannot be built, laid out or written, or a template that cannot be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HierarchyError {
    /// The hierarchy cannot be built (callers name the mesh).
    #[error(transparent)]
    Build(#[from] BuildError),
    /// The hierarchy of a template file cannot be built.
    #[error("{}: cannot build the S2D hierarchy", path.display())]
    BuildFile {
        /// The template file.
        path: PathBuf,
        /// Why.
        #[source]
        source: BuildError,
    },
    /// The template cannot be read (the error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The hierarchy's sections cannot be laid out.
    #[error(transparent)]
    Layout(#[from] WriterError),
    /// The hierarchy file cannot be written (the error names the file).
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}
