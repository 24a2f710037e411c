//! What a rig's files hold ([`RigFile`]), in which format ([`RigFormat`]), and why they cannot
//! be read ([`RigReadError`]).

use std::path::PathBuf;

use serde::Serialize;

use crate::io::mesh::{InvalidMesh, Mesh, MeshError};
use crate::io::units::Unit;

/// Which kind of file a rig came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RigFormat {
    /// A glTF 2.0 file (`.glb`, or `.gltf` with its buffers).
    Gltf,
    /// A folder with `neutral.obj` and `shapes/NAME.obj`.
    ObjFolder,
}

impl RigFormat {
    /// The name reports and metadata write.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Gltf => "gltf",
            Self::ObjFolder => "obj",
        }
    }
}

/// A rig as read: the skin mesh's neutral and each shape's offsets from it, in the file's own
/// coordinates, vertex order and count.
#[derive(Clone, Debug)]
pub struct RigFile {
    /// The file or folder read.
    pub path: PathBuf,
    /// Its format.
    pub format: RigFormat,
    /// The skin mesh's name in the file (glTF: the mesh's name, else `mesh N`; OBJ: `neutral`).
    pub mesh_name: String,
    /// The neutral: positions, polygons and, where the file has them, texture coordinates (per
    /// vertex for glTF, per corner for OBJ).
    pub neutral: Mesh,
    /// Each shape's name, as the file names it.
    pub shape_names: Vec<String>,
    /// Each shape's offset from the neutral, per vertex.
    pub deltas: Vec<Vec<[f32; 3]>>,
    /// The skin mesh's coordinates to the scene's (glTF: the product of the node transforms
    /// above the mesh; OBJ and skinned glTF meshes: the identity), column-major.
    pub node_transform: [[f64; 4]; 4],
    /// The unit the file states (glTF: metres); `None` where the format has none (OBJ).
    pub units: Option<Unit>,
    /// The glTF extensions the file uses and what Sinew made of each (empty for OBJ).
    pub extensions: Vec<ExtensionUse>,
    /// A VRM avatar's expressions, which are then the rig's shapes; `None` for other rigs.
    pub avatar: Option<Avatar>,
}

/// A glTF extension a rig uses, and what Sinew made of it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ExtensionUse {
    /// The extension's name.
    pub name: String,
    /// Whether the file lists it in `extensionsRequired`.
    pub required: bool,
    /// What Sinew did with it.
    pub treatment: Treatment,
}

/// What Sinew does with an extension a rig uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Treatment {
    /// Sinew decodes it (quantised or compressed geometry, a VRM avatar's expressions).
    Decoded,
    /// It concerns only what Sinew does not read (textures, materials, lights, animation,
    /// physics), so the skin and its shapes read the same without it.
    NotRead,
}

/// A VRM avatar's expressions, each of which is one of the rig's shapes: the sum of its morph
/// target binds, each target by its weight.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Avatar {
    /// `1.0` (`VRMC_vrm`) or `0.x` (`VRM`).
    pub version: &'static str,
    /// The expressions that became shapes, in the rig's shape order.
    pub expressions: Vec<Expression>,
    /// The expressions, or parts of them, that did not, and why.
    pub dropped: Vec<DroppedExpression>,
}

/// One expression of a VRM avatar as a shape.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Expression {
    /// Its name: the preset's (`aa`, `blink`, `happy`, …; VRM 0.x presets under VRM 1.0's
    /// names) or the custom expression's.
    pub name: String,
    /// Whether it is one of VRM's presets.
    pub preset: bool,
    /// The face mesh's morph targets it binds, by name, with their weights.
    pub binds: Vec<(String, f32)>,
}

/// An expression, or a part of one, that is not a shape.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DroppedExpression {
    /// The expression.
    pub name: String,
    /// Why (no morph target binds; binds on another mesh than the face).
    pub reason: String,
}

/// The 4 × 4 identity, column-major.
pub const IDENTITY: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// Why a rig could not be read, always naming the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigReadError {
    /// The path is neither a `.glb`/`.gltf`/`.vrm` file nor a folder.
    #[error(
        "{}: not a rig (a .glb, .gltf or .vrm file, or a folder with neutral.obj and shapes/NAME.obj)",
        path.display()
    )]
    UnknownKind {
        /// The path.
        path: PathBuf,
    },
    /// A file could not be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// An OBJ rig's material library or a texture it names could not be read.
    #[error("{}: {reason}", path.display())]
    Material {
        /// The material library (`.mtl`).
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The glTF file could not be parsed (a truncated `.glb`, broken JSON, a broken index).
    #[error("{}: not a valid glTF 2.0 file: {reason}", path.display())]
    Gltf {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        reason: String,
    },
    /// The file needs a mesh compression extension that Sinew does not decode.
    #[error(
        "{}: its meshes are compressed with {extension}, which Sinew does not decode; export \
         the rig without it (Blender: untick \"Compression\" in the glTF exporter) or with \
         meshopt compression (gltfpack -c), which Sinew reads",
        path.display()
    )]
    Compressed {
        /// The file.
        path: PathBuf,
        /// The extension (`KHR_draco_mesh_compression`).
        extension: String,
    },
    /// The file requires another extension that may change the geometry and that Sinew does
    /// not decode.
    #[error(
        "{}: requires the glTF extension {extension}, which may change the geometry and which \
         Sinew does not decode",
        path.display()
    )]
    Extension {
        /// The file.
        path: PathBuf,
        /// The extension.
        extension: String,
    },
    /// A buffer that is neither the `.glb`'s binary chunk, a `data:` URI nor a relative file.
    #[error("{}: buffer {buffer} has URI {uri:?}, which is not a relative file or data: URI", path.display())]
    BufferUri {
        /// The glTF file.
        path: PathBuf,
        /// The buffer.
        buffer: usize,
        /// Its URI (cut to 80 characters).
        uri: String,
    },
    /// A buffer shorter than the file says it is.
    #[error("{}: buffer {buffer} holds {found} bytes, {declared} declared", path.display())]
    BufferLength {
        /// The glTF file.
        path: PathBuf,
        /// The buffer.
        buffer: usize,
        /// Its declared length.
        declared: usize,
        /// The bytes found.
        found: usize,
    },
    /// An accessor the skin reads that breaks a rule of glTF or of `KHR_mesh_quantization`
    /// (a component type the attribute may not have, data past its buffer view).
    #[error("{}: accessor {accessor} ({role}): {what}", path.display())]
    Accessor {
        /// The glTF file.
        path: PathBuf,
        /// The accessor's index.
        accessor: usize,
        /// What the skin reads it as (`POSITION`, `morph target 3 POSITION`, `indices`, …).
        role: String,
        /// What is wrong.
        what: String,
    },
    /// A buffer view whose data cannot be had: compressed data that does not decode, a range
    /// past its buffer, a fallback buffer without data.
    #[error("{}: buffer view {view}: {what}", path.display())]
    BufferView {
        /// The glTF file.
        path: PathBuf,
        /// The buffer view's index.
        view: usize,
        /// What is wrong.
        what: String,
    },
    /// A VRM avatar's expression that cannot be a shape.
    #[error("{}: VRM expression {expression:?}: {what}", path.display())]
    Expression {
        /// The file.
        path: PathBuf,
        /// The expression.
        expression: String,
        /// What is wrong with it.
        what: ExpressionProblem,
    },
    /// No mesh of the file has morph targets.
    #[error("{}: no mesh has morph targets (blendshapes); {meshes} mesh(es) found", path.display())]
    NoMorphTargets {
        /// The glTF file.
        path: PathBuf,
        /// The meshes it has.
        meshes: usize,
    },
    /// `--mesh NAME` names no mesh of the file.
    #[error("{}: no mesh named {name:?}; meshes: {}", path.display(), names.join(", "))]
    NoSuchMesh {
        /// The glTF file.
        path: PathBuf,
        /// The name asked for.
        name: String,
        /// The meshes' names.
        names: Vec<String>,
    },
    /// A primitive that is not a list of triangles.
    #[error("{}: mesh {mesh:?} primitive {primitive} is {mode}, not triangles", path.display())]
    NotTriangles {
        /// The glTF file.
        path: PathBuf,
        /// The mesh.
        mesh: String,
        /// The primitive.
        primitive: usize,
        /// Its mode.
        mode: String,
    },
    /// An attribute that is missing, unreadable, or of another length than the positions.
    #[error("{}: mesh {mesh:?} primitive {primitive}: {what}", path.display())]
    Attribute {
        /// The glTF file.
        path: PathBuf,
        /// The mesh.
        mesh: String,
        /// The primitive.
        primitive: usize,
        /// What is wrong.
        what: String,
    },
    /// A neutral or shape mesh that could not be read (the mesh error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// An OBJ folder without shapes.
    #[error("{}: no shapes (shapes/NAME.obj)", path.display())]
    NoShapes {
        /// The `shapes` folder.
        path: PathBuf,
    },
    /// A shape whose vertex count is not the neutral's.
    #[error("{}: {found} vertices, but the neutral has {expected}", path.display())]
    VertexCount {
        /// The shape's file.
        path: PathBuf,
        /// The neutral's vertex count.
        expected: usize,
        /// The shape's.
        found: usize,
    },
    /// A shape offset that is NaN or infinite.
    #[error("{}: shape {shape:?} moves vertex {vertex} by a non-finite offset", path.display())]
    NonFiniteShape {
        /// The file.
        path: PathBuf,
        /// The shape.
        shape: String,
        /// The vertex.
        vertex: usize,
    },
    /// A neutral that breaks a mesh rule (a NaN position, a polygon past the vertices).
    #[error("{}: {source}", path.display())]
    InvalidNeutral {
        /// The file.
        path: PathBuf,
        /// The rule broken.
        #[source]
        source: InvalidMesh,
    },
    /// Two shapes of one name.
    #[error("{}: two shapes are named {name:?}", path.display())]
    RepeatedShape {
        /// The file.
        path: PathBuf,
        /// The name.
        name: String,
    },
}

/// What is wrong with a VRM expression.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ExpressionProblem {
    /// Two expressions of one name (VRM 0.x groups, or one name twice in an object).
    #[error("is defined twice")]
    Repeated,
    /// A bind to a node or mesh the file does not have, or to a node without a mesh.
    #[error("binds {what}, which the file does not have")]
    NoSuchMesh {
        /// The node or mesh named.
        what: String,
    },
    /// A bind to a morph target its mesh does not have.
    #[error("binds morph target {index} of mesh {mesh:?}, which has {targets}")]
    NoSuchTarget {
        /// The mesh.
        mesh: String,
        /// The target's index.
        index: u64,
        /// The mesh's target count.
        targets: usize,
    },
    /// A bind whose weight is NaN or infinite.
    #[error(
        "binds morph target {index} with the weight {weight}, which is not a finite 32-bit number"
    )]
    NonFiniteWeight {
        /// The target's index.
        index: u64,
        /// The weight as written.
        weight: String,
    },
    /// The extension's JSON breaks the schema.
    #[error("{0}")]
    Schema(String),
}

impl RigFile {
    /// The vertex count, as the file has it.
    pub fn vertex_count(&self) -> usize {
        self.neutral.positions.len()
    }

    pub(super) fn check(&self) -> Result<(), RigReadError> {
        self.neutral
            .validate()
            .map_err(|source| RigReadError::InvalidNeutral {
                path: self.path.clone(),
                source,
            })?;
        for (k, name) in self.shape_names.iter().enumerate() {
            if self.shape_names[..k].contains(name) {
                return Err(RigReadError::RepeatedShape {
                    path: self.path.clone(),
                    name: name.clone(),
                });
            }
        }
        for (name, delta) in self.shape_names.iter().zip(&self.deltas) {
            if delta.len() != self.vertex_count() {
                return Err(RigReadError::VertexCount {
                    path: self.path.clone(),
                    expected: self.vertex_count(),
                    found: delta.len(),
                });
            }
            if let Some(vertex) = delta.iter().position(|d| d.iter().any(|c| !c.is_finite())) {
                return Err(RigReadError::NonFiniteShape {
                    path: self.path.clone(),
                    shape: name.clone(),
                    vertex,
                });
            }
        }
        Ok(())
    }
}
