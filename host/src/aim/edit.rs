//! `sinew edit thickness`: anatomy editing (AIM eq. 6), the learned soft-tissue thickness scaled
//! in a region of the face.

use std::path::Path;

use anyhow::{Context, Result, bail};
use serde::Deserialize;
use sinew_core::aim::AimActor;

use crate::io::mesh::Mesh;

/// Reads a region file: JSON, either a list of vertex indices (weight 1) or an object
/// `{"weights": [w_0, …, w_{V−1}]}`; returns per-vertex weights in [0, 1].
pub fn read_region(path: &Path, vertices: usize) -> Result<Vec<f32>> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Region {
        Indices(Vec<u32>),
        Weights { weights: Vec<f32> },
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let region: Region = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: expected a list of vertex indices or {{\"weights\": [...]}}",
            path.display()
        )
    })?;
    match region {
        Region::Indices(idx) => {
            let mut w = vec![0.0; vertices];
            for i in idx {
                *w.get_mut(i as usize).with_context(|| {
                    format!(
                        "{}: vertex {i} out of range (model has {vertices})",
                        path.display()
                    )
                })? = 1.0;
            }
            Ok(w)
        }
        Region::Weights { weights } => {
            if weights.len() != vertices {
                bail!(
                    "{}: {} weights for a model of {vertices} vertices",
                    path.display(),
                    weights.len()
                );
            }
            if let Some(w) = weights.iter().find(|w| !(0.0..=1.0).contains(*w)) {
                bail!("{}: weight {w} outside [0, 1]", path.display());
            }
            Ok(weights)
        }
    }
}

/// `sinew edit thickness`: scales the learned thickness in a region, writes the edited neutral
/// and a before/after picture.
pub fn edit_thickness(model: &Path, region: &Path, scale: f32, out: &Path) -> Result<()> {
    let bytes = crate::io::container::read(model)?;
    let actor =
        AimActor::from_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    if !scale.is_finite() || scale < 0.0 {
        bail!("--scale must be a finite non-negative number, got {scale}");
    }
    let mask = read_region(region, actor.vertex_count())?;
    let mut edited = vec![0.0; 3 * actor.vertex_count()];
    actor
        .edit_thickness(&mask, scale, &mut edited)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mesh = Mesh::of_actor(&actor);
    let before: Vec<[f32; 3]> = crate::io::mesh::points(actor.rest().iter());
    let after: Vec<[f32; 3]> = crate::io::mesh::points(edited.iter().copied());
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
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
    crate::figures::render::Image::hstack(&[a, b]).write_png(&out.join("edit.png"))
}
