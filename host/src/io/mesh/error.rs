//! Why a mesh could not be read, written or used: [`MeshError`] names the file and the failure,
//! [`ParseReason`] the syntax error inside a file, [`InvalidMesh`] the broken rule of a mesh.

use std::path::PathBuf;

/// A mesh file that could not be read or written, always with its path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file name ends in none of `.obj`, `.obj.gz`, `.ply`, `.ply.gz`.
    #[error(
        "{}: unknown mesh format (expected .obj, .obj.gz, .ply or .ply.gz)",
        path.display()
    )]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file could not be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The file is gzip-compressed (by name or magic) but does not decompress.
    #[error("{}: not a valid gzip file", path.display())]
    Gzip {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        #[source]
        source: std::io::Error,
    },
    /// The file is not valid OBJ or PLY.
    #[error("{}: not a valid mesh{}", path.display(), line_suffix(*line))]
    Parse {
        /// The file.
        path: PathBuf,
        /// The 1-based line of an OBJ file the error is on (PLY errors have none).
        line: Option<usize>,
        /// What is wrong there.
        #[source]
        reason: ParseReason,
    },
    /// The file parses, but the mesh it holds breaks a rule of [`crate::io::mesh::Mesh`].
    #[error("{}: inconsistent mesh", path.display())]
    Inconsistent {
        /// The file.
        path: PathBuf,
        /// The broken rule.
        #[source]
        source: InvalidMesh,
    },
    /// A mesh that breaks a rule of [`crate::io::mesh::Mesh`] was not written.
    #[error("{}: refusing to write an inconsistent mesh", path.display())]
    WriteInconsistent {
        /// The file it would have been written to.
        path: PathBuf,
        /// The broken rule.
        #[source]
        source: InvalidMesh,
    },
    /// The mesh cannot be expressed in the file's format.
    #[error("{}: cannot encode the mesh", path.display())]
    Encode {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: EncodeError,
    },
    /// Gzip compression of the encoded mesh failed.
    #[error("{}: cannot compress", path.display())]
    Compress {
        /// The file.
        path: PathBuf,
        /// What the encoder said.
        #[source]
        source: std::io::Error,
    },
    /// The encoded mesh could not be written to disk (the message names the file).
    #[error(transparent)]
    Write(crate::io::atomic::AtomicWriteError),
    /// A mesh that should correspond vertex by vertex to a reference has other counts.
    #[error(
        "{}: topology differs from the reference: expected {expected_vertices} vertices and \
         {expected_polygons} polygons, found {vertices} vertices and {polygons} polygons",
        path.display()
    )]
    TopologyCounts {
        /// The file of the differing mesh.
        path: PathBuf,
        /// The reference's vertex count.
        expected_vertices: usize,
        /// The reference's polygon count.
        expected_polygons: usize,
        /// This mesh's vertex count.
        vertices: usize,
        /// This mesh's polygon count.
        polygons: usize,
    },
    /// A mesh with the reference's counts has a different polygon.
    #[error(
        "{}: topology differs from the reference: both have {vertices} vertices and {polygons} \
         polygons, but polygon {polygon} is {found:?} instead of {expected:?}",
        path.display()
    )]
    TopologyPolygon {
        /// The file of the differing mesh.
        path: PathBuf,
        /// The common vertex count.
        vertices: usize,
        /// The common polygon count.
        polygons: usize,
        /// The first polygon that differs.
        polygon: usize,
        /// Its corners in this mesh.
        found: Vec<u32>,
        /// Its corners in the reference.
        expected: Vec<u32>,
    },
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|n| format!(": line {n}")).unwrap_or_default()
}

/// A syntax error in an OBJ or PLY file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParseReason {
    /// An OBJ index that is not an integer.
    #[error("bad {what} index {token:?}")]
    BadIndex {
        /// `vertex` or `texture`.
        what: &'static str,
        /// The text.
        token: String,
    },
    /// An OBJ index of 0 (indices start at 1).
    #[error("{what} index 0 (OBJ indices start at 1)")]
    ZeroIndex {
        /// `vertex` or `texture`.
        what: &'static str,
    },
    /// An OBJ index that resolves before the first element or beyond `u32`.
    #[error("{what} index {token} is out of range")]
    IndexOutOfRange {
        /// `vertex` or `texture`.
        what: &'static str,
        /// The text.
        token: String,
    },
    /// An OBJ coordinate that is not a number.
    #[error("bad number {token:?}")]
    BadNumber {
        /// The text.
        token: String,
    },
    /// An OBJ statement with too few numbers.
    #[error("expected {expected} numbers, found {found}")]
    MissingNumbers {
        /// How many are required.
        expected: usize,
        /// How many there are.
        found: usize,
    },
    /// An OBJ face with fewer than 3 corners.
    #[error("face with {corners} corners (at least 3 needed)")]
    FaceTooSmall {
        /// Its corners.
        corners: usize,
    },
    /// An OBJ face with texture indices on some corners only.
    #[error("face gives texture indices for only some corners")]
    PartialFaceTexture,
    /// The PLY reader's error.
    #[error("PLY parse error: {0}")]
    Ply(ply_rs_bw::parser::ParseError),
    /// A PLY vertex without a scalar coordinate.
    #[error("vertex {vertex}: missing or non-scalar property {name:?}")]
    VertexProperty {
        /// The vertex.
        vertex: usize,
        /// The property.
        name: &'static str,
    },
    /// A PLY face without a `vertex_indices` (or `vertex_index`) list.
    #[error("face {face}: no vertex_indices list")]
    NoVertexIndices {
        /// The face.
        face: usize,
    },
    /// A PLY face whose indices are not a list of non-negative integers.
    #[error("face {face}: vertex_indices is not a list of indices >= 0")]
    BadVertexIndices {
        /// The face.
        face: usize,
    },
    /// A PLY face whose `texcoord` is not a list of floats.
    #[error("face {face}: texcoord is not a float list")]
    TexcoordNotFloat {
        /// The face.
        face: usize,
    },
    /// A PLY face with other than two `texcoord` values per corner.
    #[error("face {face}: {values} texcoord values for {corners} corners")]
    TexcoordCount {
        /// The face.
        face: usize,
        /// Its `texcoord` values.
        values: usize,
        /// Its corners.
        corners: usize,
    },
    /// Some PLY faces carry `texcoord`, others do not.
    #[error("only some faces carry texcoord")]
    PartialTexcoord,
}

/// The rule of [`crate::io::mesh::Mesh`] a mesh breaks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidMesh {
    /// A position with a NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite coordinate {position:?}")]
    NonFiniteVertex {
        /// The vertex.
        vertex: usize,
        /// Its position.
        position: [f32; 3],
    },
    /// A polygon with fewer than 3 corners.
    #[error("polygon {polygon} has {corners} corners (at least 3 needed)")]
    TooFewCorners {
        /// The polygon.
        polygon: usize,
        /// Its corners.
        corners: usize,
    },
    /// A polygon corner beyond the vertex list.
    #[error("polygon {polygon} refers to vertex {vertex} but the mesh has {vertices} vertices")]
    VertexOutOfRange {
        /// The polygon.
        polygon: usize,
        /// The vertex it names.
        vertex: u32,
        /// The mesh's vertex count.
        vertices: usize,
    },
    /// Per-vertex texture coordinates whose count is not the vertex count.
    #[error("{uvs} texture coordinates for {vertices} vertices and no per-corner indices")]
    UvCount {
        /// The texture coordinates.
        uvs: usize,
        /// The vertices.
        vertices: usize,
    },
    /// Per-corner texture indices not parallel to the polygons.
    #[error("{polygons} polygons but {uv_polygons} polygons of texture indices")]
    UvPolygonCount {
        /// The polygons.
        polygons: usize,
        /// The polygons of texture indices.
        uv_polygons: usize,
    },
    /// A polygon whose texture indices do not match its corners.
    #[error("polygon {polygon} has {corners} corners but {uv_indices} texture indices")]
    UvCornerCount {
        /// The polygon.
        polygon: usize,
        /// Its corners.
        corners: usize,
        /// Its texture indices.
        uv_indices: usize,
    },
    /// A texture index beyond the texture coordinates.
    #[error("polygon {polygon} refers to texture coordinate {uv} but there are {uvs}")]
    UvOutOfRange {
        /// The polygon.
        polygon: usize,
        /// The texture coordinate it names.
        uv: u32,
        /// The texture coordinates there are.
        uvs: usize,
    },
    /// A texture coordinate that is NaN or infinite.
    #[error("texture coordinate {index} is not finite: {uv:?}")]
    NonFiniteUv {
        /// The texture coordinate.
        index: usize,
        /// Its value.
        uv: [f32; 2],
    },
}

/// Why a mesh cannot be encoded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EncodeError {
    /// Formatting the OBJ text failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// A polygon with more corners than a PLY list (with a `uchar` length) holds.
    #[error("polygon {polygon} has {corners} corners; PLY lists hold 255")]
    TooManyCorners {
        /// The polygon.
        polygon: usize,
        /// Its corners.
        corners: usize,
    },
    /// A vertex index beyond PLY's `int`.
    #[error("polygon {polygon}: vertex index beyond the PLY int range")]
    IndexBeyondInt {
        /// The polygon.
        polygon: usize,
    },
    /// The PLY writer's error.
    #[error("PLY encoding failed: {0}")]
    Ply(std::io::Error),
}
