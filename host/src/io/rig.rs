//! A studio's blendshape rig as its files hold it: a glTF 2.0 head with morph targets, or a
//! folder of OBJs (`neutral.obj`, `shapes/NAME.obj`).
//!
//! This module only reads: positions stay in the skin mesh's own coordinates and vertex order,
//! seam vertices stay split, and nothing is scaled or turned. What the coordinates mean (units,
//! axes, the node's place in its scene) and the welding of seams are resolved once, by
//! `crate::rig`.

use std::path::Path;

mod file;
mod gltf;
mod obj;
mod scenery;
mod write;
pub use file::{
    Avatar, DroppedExpression, Expression, ExpressionProblem, ExtensionUse, IDENTITY, RigFile,
    RigFormat, RigReadError, Treatment,
};
pub use gltf::COMPENSATION_KEY;
pub use gltf::vrm_group_name_0x;
pub use scenery::{Image, Part, PartPrimitive, Scenery};
pub use write::RigWriteError;

impl RigFile {
    /// Reads the rig at `path`: a `.glb`/`.gltf`/`.vrm` file (its skin being the mesh named `mesh`, or
    /// the one with the most morph targets) or an OBJ folder.
    pub fn read(path: &Path, mesh: Option<&str>) -> Result<Self, RigReadError> {
        let lower = path.to_string_lossy().to_ascii_lowercase();
        let rig = if [".glb", ".gltf", ".vrm"].iter().any(|e| lower.ends_with(e)) {
            gltf::read(path, mesh)?
        } else if path.is_dir() {
            obj::read(path)?
        } else {
            return Err(RigReadError::UnknownKind {
                path: path.to_owned(),
            });
        };
        rig.check()?;
        Ok(rig)
    }
}

impl Scenery {
    /// What the rig at `path` holds besides its skin mesh: a glTF rig's other meshes, materials
    /// and textures (its skin the mesh named `mesh`, else the one [`RigFile::read`] picks), or
    /// an OBJ folder's material and textures (`obj::scenery`).
    pub fn read(path: &Path, mesh: Option<&str>) -> Result<Self, RigReadError> {
        let lower = path.to_string_lossy().to_ascii_lowercase();
        if [".glb", ".gltf", ".vrm"].iter().any(|e| lower.ends_with(e)) {
            gltf::scenery(path, mesh)
        } else if path.is_dir() {
            obj::scenery(path)
        } else {
            Err(RigReadError::UnknownKind {
                path: path.to_owned(),
            })
        }
    }
}
