//! Pose files and `sinew play`: an actor's frames (head, jaw, coefficients) posed through the
//! core, one OBJ per frame.

use std::path::Path;

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;

use crate::io::mesh::Mesh;

/// One frame of a pose file.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Frame {
    /// Head transform: 6D rotation + translation (identity if absent).
    #[serde(default = "identity9")]
    pub head: [f32; 9],
    /// Jaw transform about the actor's pivot: 6D rotation + translation (identity if absent).
    #[serde(default = "identity9")]
    pub jaw: [f32; 9],
    /// One coefficient per corrective shape.
    pub weights: Vec<f32>,
}

fn identity9() -> [f32; 9] {
    crate::aim::model::IDENTITY_9D
}

/// A pose file: `{"frames": [{"head": [...9], "jaw": [...9], "weights": [...]}, ...]}`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PoseFile {
    /// The frames in order.
    pub frames: Vec<Frame>,
}

impl PoseFile {
    /// Reads a pose file for an actor with `shapes` coefficients; the error names the file and
    /// the first bad frame.
    pub fn read(path: &Path, shapes: usize) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read", path.display()))?;
        let file: PoseFile = serde_json::from_str(&text)
            .with_context(|| format!("{}: invalid pose file", path.display()))?;
        if file.frames.is_empty() {
            bail!("{}: no frames", path.display());
        }
        for (i, f) in file.frames.iter().enumerate() {
            if f.weights.len() != shapes {
                bail!(
                    "{}: frame {i} has {} weights, the model {shapes} shapes",
                    path.display(),
                    f.weights.len(),
                );
            }
            if f.head
                .iter()
                .chain(&f.jaw)
                .chain(&f.weights)
                .any(|v| !v.is_finite())
            {
                bail!("{}: frame {i} has a non-finite value", path.display());
            }
        }
        Ok(file)
    }
}

/// `sinew play`: poses the baked actor through the core, one OBJ per frame.
pub fn play(model: &Path, poses: &Path, out: &Path, template: Option<&Mesh>) -> Result<usize> {
    let bytes = crate::io::container::read(model)?;
    let actor =
        AimActor::from_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let file = PoseFile::read(poses, actor.shape_count())?;
    play_frames(&actor, &file.frames, out, template)
}

/// Poses `frames` through the core and writes `frame_NNNNN.obj` into `out`.
pub fn play_frames(
    actor: &AimActor<'_>,
    frames: &[Frame],
    out: &Path,
    template: Option<&Mesh>,
) -> Result<usize> {
    let mesh = match template {
        Some(t) => t.clone(),
        None => Mesh::of_actor(actor),
    };
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    let mut buf = vec![0.0; 3 * actor.vertex_count()];
    // The core's f32 posing, as `sinew_core::replay::pose_frame` does it in f32 mode, without
    // the normals an OBJ does not carry.
    for (i, f) in frames.iter().enumerate() {
        let pose = actor.pose_from_9d(&f.jaw, &f.head);
        actor
            .pose(&pose, &f.weights, &mut buf)
            .map_err(|e| anyhow::anyhow!("frame {i}: {e}"))?;
        let positions = crate::io::mesh::points(buf.iter().copied());
        mesh.with_positions(positions)
            .write(&out.join(format!("frame_{i:05}.obj")))?;
    }
    Ok(frames.len())
}

/// The names of the actor's corrective shapes (metadata `shapes` without the neutral), or
/// `shape_1` … `shape_M` when the artefact does not record them.
pub fn corrective_names(actor: &AimActor<'_>) -> Vec<String> {
    let m = actor.shape_count();
    let recorded: Option<Vec<String>> = actor
        .file()
        .metadata()
        .get("shapes")
        .map(|s| s.split(',').skip(1).map(|n| n.trim().to_string()).collect());
    match recorded {
        Some(names) if names.len() == m => names,
        _ => (1..=m).map(|j| format!("shape_{j}")).collect(),
    }
}
