//! What a baked actor records of the rig it was learned from (metadata `rig`), so that its
//! frames go back into the rig's own frame, units, vertex order and count, seams split again,
//! with the rig's polygons and texture coordinates.

use serde::{Deserialize, Serialize};

use super::{Axis, Conventions, Rig};
use crate::io::mesh::Mesh;
use crate::io::units::Unit;

/// The metadata key.
pub const KEY: &str = "rig";

/// A rig as a baked actor records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// `gltf` or `obj`.
    pub format: String,
    /// The skin mesh's name.
    pub mesh: String,
    /// The rig's unit.
    pub units: Unit,
    /// Its up axis.
    pub up: Axis,
    /// Its forward axis.
    pub forward: Axis,
    /// The skin mesh's node transform, column-major.
    pub node_transform: [[f64; 4]; 4],
    /// The head's placement in its scene (face frame from the scene's), column-major.
    pub placement: [[f64; 4]; 4],
    /// Per rig vertex, the actor's vertex (seam copies share one).
    pub welded: Vec<u32>,
    /// The rig's polygons over its own vertices.
    pub polygons: Vec<Vec<u32>>,
    /// Its texture coordinates (per vertex, or per corner with `polygon_uvs`).
    pub uvs: Vec<[f32; 2]>,
    /// Per-corner texture indices, or empty.
    pub polygon_uvs: Vec<Vec<u32>>,
}

/// Why a recorded rig cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    /// The metadata is not a rig record.
    #[error("metadata `rig` is not a rig record")]
    Json(#[source] serde_json::Error),
    /// An index past what it indexes.
    #[error("metadata `rig`: {0}")]
    Invalid(String),
}

impl Record {
    /// The record of a resolved rig.
    pub fn of(rig: &Rig) -> Self {
        let c = &rig.conventions;
        Self {
            format: rig.file.format.name().into(),
            mesh: rig.file.mesh_name.clone(),
            units: c.units,
            up: c.up,
            forward: c.forward,
            node_transform: c.node_transform,
            placement: c.placement,
            welded: rig.weld.welded.clone(),
            polygons: rig.file.neutral.polygons.clone(),
            uvs: rig.file.neutral.uvs.clone(),
            polygon_uvs: rig.file.neutral.polygon_uvs.clone(),
        }
    }

    /// Reads the record of an actor of `vertices` vertices from its metadata value.
    pub fn parse(value: &str, vertices: usize) -> Result<Self, RecordError> {
        let r: Self = serde_json::from_str(value).map_err(RecordError::Json)?;
        if let Some(v) = r.welded.iter().find(|&&v| v as usize >= vertices) {
            return Err(RecordError::Invalid(format!(
                "rig vertex maps to actor vertex {v}, past its {vertices}"
            )));
        }
        let mesh = r.rest_mesh(vec![[0.0; 3]; r.welded.len()]);
        mesh.validate()
            .map_err(|e| RecordError::Invalid(format!("the rig's mesh: {e}")))?;
        Ok(r)
    }

    /// The rig's conventions.
    pub fn conventions(&self) -> Conventions {
        Conventions {
            units: self.units,
            units_guessed: false,
            up: self.up,
            forward: self.forward,
            node_transform: self.node_transform,
            placement: self.placement,
        }
    }

    fn rest_mesh(&self, positions: Vec<[f32; 3]>) -> Mesh {
        Mesh {
            positions,
            polygons: self.polygons.clone(),
            uvs: self.uvs.clone(),
            polygon_uvs: self.polygon_uvs.clone(),
        }
    }

    /// The actor's vertices (face frame) as the rig's mesh: in its own frame and units, every
    /// rig vertex (seam copies too) in its order, with its polygons and texture coordinates.
    pub fn mesh(&self, face: &[[f32; 3]]) -> Mesh {
        let c = self.conventions();
        let own: Vec<[f32; 3]> = face
            .iter()
            .map(|&p| {
                let q = p.map(f64::from);
                c.from_face(q).unwrap_or(q).map(|v| v as f32)
            })
            .collect();
        self.rest_mesh(self.welded.iter().map(|&w| own[w as usize]).collect())
    }
}

impl<'de> Deserialize<'de> for Axis {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}
