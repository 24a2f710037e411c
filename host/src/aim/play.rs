//! Pose files and `sinew play`: an actor's frames (head, jaw, coefficients) posed through the
//! core, one OBJ per frame.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;

use crate::io::container::ContainerError;
use crate::io::mesh::{Mesh, MeshError};

/// Why a pose file could not be read; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PoseFileError {
    /// The file could not be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The pose file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The text is not a pose file's JSON.
    #[error("{}: invalid pose file", path.display())]
    Parse {
        /// The pose file.
        path: PathBuf,
        /// What the JSON reader said.
        #[source]
        source: serde_json::Error,
    },
    /// A pose file without frames.
    #[error("{}: no frames", path.display())]
    NoFrames {
        /// The pose file.
        path: PathBuf,
    },
    /// A frame whose coefficient count is not the actor's.
    #[error("{}: frame {frame} has {weights} weights, the model {shapes} shapes", path.display())]
    WeightCount {
        /// The pose file.
        path: PathBuf,
        /// The frame.
        frame: usize,
        /// Its coefficients.
        weights: usize,
        /// The actor's shapes.
        shapes: usize,
    },
    /// A frame with a NaN or infinite value.
    #[error("{}: frame {frame} has a non-finite value", path.display())]
    NonFinite {
        /// The pose file.
        path: PathBuf,
        /// The frame.
        frame: usize,
    },
}

/// Why `sinew play` failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlayError {
    /// The model file could not be read or is no `.sinew` artefact.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The pose file is unreadable or does not fit the actor.
    #[error(transparent)]
    Poses(#[from] PoseFileError),
    /// The output folder could not be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// The core refused to pose a frame.
    #[error("frame {frame}")]
    Pose {
        /// The frame.
        frame: usize,
        /// The core's reason.
        #[source]
        source: sinew_core::EvalError,
    },
    /// A frame's OBJ could not be written.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The actor's record of its rig is broken.
    #[error(transparent)]
    Rig(#[from] crate::rig::record::RecordError),
}

/// The rig an actor was learned from, when it records one.
pub fn rig_record(
    actor: &AimActor<'_>,
) -> Result<Option<crate::rig::record::Record>, crate::rig::record::RecordError> {
    actor
        .file()
        .metadata()
        .get(crate::rig::record::KEY)
        .map(|value| crate::rig::record::Record::parse(value, actor.vertex_count()))
        .transpose()
}

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
    pub fn read(path: &Path, shapes: usize) -> Result<Self, PoseFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| PoseFileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let file: PoseFile =
            serde_json::from_str(&text).map_err(|source| PoseFileError::Parse {
                path: path.to_path_buf(),
                source,
            })?;
        if file.frames.is_empty() {
            return Err(PoseFileError::NoFrames {
                path: path.to_path_buf(),
            });
        }
        for (i, f) in file.frames.iter().enumerate() {
            if f.weights.len() != shapes {
                return Err(PoseFileError::WeightCount {
                    path: path.to_path_buf(),
                    frame: i,
                    weights: f.weights.len(),
                    shapes,
                });
            }
            if f.head
                .iter()
                .chain(&f.jaw)
                .chain(&f.weights)
                .any(|v| !v.is_finite())
            {
                return Err(PoseFileError::NonFinite {
                    path: path.to_path_buf(),
                    frame: i,
                });
            }
        }
        Ok(file)
    }
}

/// `sinew play`: poses the baked actor through the core, one OBJ per frame.
pub fn play(
    model: &Path,
    poses: &Path,
    out: &Path,
    template: Option<&Mesh>,
) -> Result<usize, PlayError> {
    let bytes = crate::io::container::read(model)?;
    let actor = crate::io::container::actor(model, &bytes)?;
    let file = PoseFile::read(poses, actor.shape_count())?;
    play_frames(&actor, &file.frames, out, template)
}

/// Poses `frames` through the core and writes `frame_NNNNN.obj` into `out`: on `template`'s
/// polygons when given; else, for an actor learned from a rig, as the rig's mesh (its own frame,
/// units, vertices, polygons and texture coordinates); else on the actor's triangles.
pub fn play_frames(
    actor: &AimActor<'_>,
    frames: &[Frame],
    out: &Path,
    template: Option<&Mesh>,
) -> Result<usize, PlayError> {
    let mesh = match template {
        Some(t) => t.clone(),
        None => Mesh::of_actor(actor),
    };
    let rig = match template {
        Some(_) => None,
        None => rig_record(actor)?,
    };
    crate::io::atomic::create_folder(out, "folder")?;
    let mut buf = vec![0.0; 3 * actor.vertex_count()];
    // The core's f32 posing, as `sinew_core::replay::pose_frame` does it in f32 mode, without
    // the normals an OBJ does not carry.
    for (i, f) in frames.iter().enumerate() {
        let pose = actor
            .pose_from_9d(&f.jaw, &f.head)
            .map_err(|e| PlayError::Pose {
                frame: i,
                source: e.into(),
            })?;
        actor
            .pose(&pose, &f.weights, &mut buf)
            .map_err(|source| PlayError::Pose { frame: i, source })?;
        let positions = crate::io::mesh::points(buf.iter().copied());
        let frame = match &rig {
            Some(r) => r.mesh(&positions),
            None => mesh.with_positions(positions),
        };
        frame.write(&out.join(format!("frame_{i:05}.obj")))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_file_errors_name_the_failure() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.json");
        let err = PoseFile::read(&missing, 2).unwrap_err();
        assert!(matches!(&err, PoseFileError::Read { path, .. } if *path == missing));

        let damaged = dir.path().join("damaged.json");
        std::fs::write(&damaged, "{\"frames\": [{\"weights\": [0.1,").unwrap();
        let err = PoseFile::read(&damaged, 2).unwrap_err();
        assert!(matches!(&err, PoseFileError::Parse { path, .. } if *path == damaged));

        let short = dir.path().join("short.json");
        std::fs::write(&short, "{\"frames\": [{\"weights\": [0.1]}]}").unwrap();
        let err = PoseFile::read(&short, 2).unwrap_err();
        assert!(matches!(
            err,
            PoseFileError::WeightCount {
                frame: 0,
                weights: 1,
                shapes: 2,
                ..
            }
        ));
    }

    #[test]
    fn play_refuses_a_damaged_model_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let model = dir.path().join("actor.sinew");
        std::fs::write(&model, b"not an actor").unwrap();
        let poses = dir.path().join("poses.json");
        std::fs::write(&poses, "{\"frames\": []}").unwrap();
        let err = play(&model, &poses, &dir.path().join("out"), None).unwrap_err();
        assert!(matches!(
            err,
            PlayError::Container(ContainerError::Invalid { .. })
        ));
    }
}
