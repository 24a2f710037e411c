//! `sinew edit thickness`: anatomy editing (AIM eq. 6), the learned soft-tissue thickness scaled
//! in a region of the face.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::figures::render::PngError;
use crate::io::container::ContainerError;
use crate::io::mesh::{Mesh, MeshError};

/// Why `sinew edit thickness` failed; the region variants name the region file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EditError {
    /// The model file could not be read or is no `.sinew` artefact.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// A negative or non-finite scale.
    #[error("--scale must be a finite non-negative number, got {scale}")]
    Scale {
        /// The scale given.
        scale: f32,
    },
    /// The region file could not be read.
    #[error("{}: cannot read", path.display())]
    ReadRegion {
        /// The region file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The region file is neither a list of indices nor `{"weights": [...]}`.
    #[error(
        "{}: expected a list of vertex indices or {{\"weights\": [...]}}",
        path.display()
    )]
    ParseRegion {
        /// The region file.
        path: PathBuf,
        /// What the JSON reader said.
        #[source]
        source: serde_json::Error,
    },
    /// A region index beyond the model's vertices.
    #[error("{}: vertex {vertex} out of range (model has {vertices})", path.display())]
    RegionVertex {
        /// The region file.
        path: PathBuf,
        /// The index.
        vertex: u32,
        /// The model's vertices.
        vertices: usize,
    },
    /// Region weights of another count than the model's vertices.
    #[error("{}: {weights} weights for a model of {vertices} vertices", path.display())]
    RegionWeights {
        /// The region file.
        path: PathBuf,
        /// The weights given.
        weights: usize,
        /// The model's vertices.
        vertices: usize,
    },
    /// A region weight outside [0, 1].
    #[error("{}: weight {weight} outside [0, 1]", path.display())]
    RegionWeight {
        /// The region file.
        path: PathBuf,
        /// The weight.
        weight: f32,
    },
    /// The core refused the edit.
    #[error(transparent)]
    Edit(sinew_core::EvalError),
    /// The output folder could not be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// The edited neutral could not be written.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The picture could not be written.
    #[error(transparent)]
    Png(#[from] PngError),
}

/// Reads a region file: JSON, either a list of vertex indices (weight 1) or an object
/// `{"weights": [w_0, …, w_{V−1}]}`; returns per-vertex weights in [0, 1].
pub fn read_region(path: &Path, vertices: usize) -> Result<Vec<f32>, EditError> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Region {
        Indices(Vec<u32>),
        Weights { weights: Vec<f32> },
    }
    let text = std::fs::read_to_string(path).map_err(|source| EditError::ReadRegion {
        path: path.to_path_buf(),
        source,
    })?;
    let region: Region = serde_json::from_str(&text).map_err(|source| EditError::ParseRegion {
        path: path.to_path_buf(),
        source,
    })?;
    match region {
        Region::Indices(idx) => {
            let mut w = vec![0.0; vertices];
            for i in idx {
                *w.get_mut(i as usize)
                    .ok_or_else(|| EditError::RegionVertex {
                        path: path.to_path_buf(),
                        vertex: i,
                        vertices,
                    })? = 1.0;
            }
            Ok(w)
        }
        Region::Weights { weights } => {
            if weights.len() != vertices {
                return Err(EditError::RegionWeights {
                    path: path.to_path_buf(),
                    weights: weights.len(),
                    vertices,
                });
            }
            if let Some(w) = weights.iter().find(|w| !(0.0..=1.0).contains(*w)) {
                return Err(EditError::RegionWeight {
                    path: path.to_path_buf(),
                    weight: *w,
                });
            }
            Ok(weights)
        }
    }
}

/// `sinew edit thickness`: scales the learned thickness in a region, writes the edited neutral
/// and a before/after picture.
pub fn edit_thickness(
    model: &Path,
    region: &Path,
    scale: f32,
    out: &Path,
) -> Result<(), EditError> {
    let bytes = crate::io::container::read(model)?;
    let actor = crate::io::container::actor(model, &bytes)?;
    if !scale.is_finite() || scale < 0.0 {
        return Err(EditError::Scale { scale });
    }
    let mask = read_region(region, actor.vertex_count())?;
    let mut edited = vec![0.0; 3 * actor.vertex_count()];
    actor
        .edit_thickness(&mask, scale, &mut edited)
        .map_err(EditError::Edit)?;
    let mesh = Mesh::of_actor(&actor);
    let before: Vec<[f32; 3]> = crate::io::mesh::points(actor.rest().iter());
    let after: Vec<[f32; 3]> = crate::io::mesh::points(edited.iter().copied());
    crate::io::atomic::create_folder(out, "folder")?;
    mesh.with_positions(after.clone())
        .write(&out.join("edited_neutral.obj"))?;
    let tri = mesh.triangles();
    let moved: Vec<f32> = before
        .iter()
        .zip(&after)
        .map(|(a, b)| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .collect();
    let hi = moved.iter().copied().fold(1e-6f32, f32::max);
    let view = crate::figures::render::View {
        yaw_deg: 30.0,
        pitch_deg: 0.0,
        width: 560,
        height: 560,
    };
    let a = crate::figures::render::render_heatmap(
        &before,
        &tri,
        &mask,
        0.0,
        1.0,
        "mask",
        "before (edit region)",
        &view,
    );
    let b = crate::figures::render::render_heatmap(
        &after,
        &tri,
        &moved,
        0.0,
        hi,
        "moved",
        &format!("after (thickness x{scale})"),
        &view,
    );
    Ok(crate::figures::render::Image::hstack(&[a, b]).save_png(&out.join("edit.png"))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn region_files_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.json");
        let e = read_region(&missing, 4).unwrap_err();
        assert!(matches!(&e, EditError::ReadRegion { path, .. } if *path == missing));
        let region = dir.path().join("region.json");
        std::fs::write(&region, "{\"weights\": [0.5,").unwrap();
        let e = read_region(&region, 4).unwrap_err();
        assert!(matches!(&e, EditError::ParseRegion { path, .. } if *path == region));
        std::fs::write(&region, "[0, 7]").unwrap();
        let e = read_region(&region, 4).unwrap_err();
        assert!(matches!(
            e,
            EditError::RegionVertex {
                vertex: 7,
                vertices: 4,
                ..
            }
        ));
        std::fs::write(&region, "{\"weights\": [0, 1, 2, 0]}").unwrap();
        let e = read_region(&region, 4).unwrap_err();
        assert!(matches!(e, EditError::RegionWeight { weight, .. } if weight > 1.0));
        std::fs::write(&region, "[0, 3]").unwrap();
        assert_eq!(read_region(&region, 4).unwrap(), [1.0, 0.0, 0.0, 1.0]);
    }
}
