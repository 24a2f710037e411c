//! A rig written back as files: a `.glb` (the skin mesh with its morph targets named in
//! `extras.targetNames`, per-vertex texture coordinates, the node transform) or an OBJ folder
//! (`neutral.obj`, `shapes/NAME.obj`). What `sinew data rig` writes, and what the tests build
//! their rigs with.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use gltf_json as json;
use json::validation::Checked::Valid;

use super::file::{IDENTITY, RigFile};
use crate::io::glb::{BuildError, Builder};
use crate::io::mesh::MeshError;

/// Why a rig could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigWriteError {
    /// The `.glb` could not be laid out.
    #[error("{}: cannot lay out the glTF", path.display())]
    Build {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: BuildError,
    },
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicWriteError),
    /// An OBJ could not be written.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

impl RigFile {
    /// The rig as `.glb` bytes.
    pub fn glb(&self) -> Result<Vec<u8>, BuildError> {
        use json::accessor::Type;
        use json::buffer::Target::ArrayBuffer;
        let mut b = Builder::new();
        let flat = |v: &[[f32; 3]]| -> Vec<f32> { v.iter().flatten().copied().collect() };
        let position = b.floats(
            &flat(&self.neutral.positions),
            Type::Vec3,
            true,
            Some(ArrayBuffer),
        );
        let mut attributes = BTreeMap::from([(Valid(json::mesh::Semantic::Positions), position)]);
        if self.neutral.polygon_uvs.is_empty() && self.neutral.uvs.len() == self.vertex_count() {
            let uv: Vec<f32> = self.neutral.uvs.iter().flatten().copied().collect();
            let uv = b.floats(&uv, Type::Vec2, false, Some(ArrayBuffer));
            attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), uv);
        }
        let triangles: Vec<u32> = self.neutral.triangles().into_iter().flatten().collect();
        let indices = b.indices(&triangles);
        let targets = self
            .deltas
            .iter()
            .map(|d| json::mesh::MorphTarget {
                positions: Some(b.floats(&flat(d), Type::Vec3, true, Some(ArrayBuffer))),
                normals: None,
                tangents: None,
            })
            .collect();
        let mesh = b.root.push(json::Mesh {
            extensions: None,
            extras: Some(serde_json::value::to_raw_value(
                &serde_json::json!({ "targetNames": self.shape_names }),
            )?),
            name: Some(self.mesh_name.clone()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(indices),
                material: None,
                mode: Valid(json::mesh::Mode::Triangles),
                targets: Some(targets),
            }],
            weights: Some(vec![0.0; self.deltas.len()]),
        });
        let matrix: Vec<f32> = self
            .node_transform
            .iter()
            .flatten()
            .map(|&v| v as f32)
            .collect();
        let is_identity = self.node_transform == IDENTITY;
        let node = b.root.push(json::Node {
            mesh: Some(mesh),
            name: Some(self.mesh_name.clone()),
            matrix: (!is_identity).then(|| std::array::from_fn(|k| matrix[k])),
            ..Default::default()
        });
        let scene = b.root.push(json::Scene {
            extensions: None,
            extras: None,
            name: Some("rig".into()),
            nodes: vec![node],
        });
        b.root.scene = Some(scene);
        b.finish()
    }

    /// Writes the rig as `.glb` to `path`, atomically.
    pub fn write_glb(&self, path: &Path) -> Result<(), RigWriteError> {
        let bytes = self.glb().map_err(|source| RigWriteError::Build {
            path: path.to_owned(),
            source,
        })?;
        Ok(crate::io::atomic::write(path, &bytes)?)
    }

    /// Writes the rig as an OBJ folder: `dir/neutral.obj` and `dir/shapes/NAME.obj`.
    pub fn write_obj_folder(&self, dir: &Path) -> Result<(), RigWriteError> {
        self.neutral.write(&dir.join("neutral.obj"))?;
        for (name, d) in self.shape_names.iter().zip(&self.deltas) {
            let positions = self
                .neutral
                .positions
                .iter()
                .zip(d)
                .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
                .collect();
            self.neutral
                .with_positions(positions)
                .write(&dir.join("shapes").join(format!("{name}.obj")))?;
        }
        Ok(())
    }
}
