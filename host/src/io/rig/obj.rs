//! A rig as a folder of OBJs: `neutral.obj` and `shapes/NAME.obj` (`.obj.gz` too), every shape
//! a full mesh with the neutral's vertices in the neutral's order; the shape is the file's name.

use std::path::Path;

use super::file::{IDENTITY, RigFile, RigFormat, RigReadError};
use crate::io::mesh::Mesh;

/// The mesh files of `dir`, as (name without `.obj`/`.obj.gz`, path), sorted by name.
fn shape_files(dir: &Path) -> Result<Vec<(String, std::path::PathBuf)>, RigReadError> {
    let read = |source| RigReadError::Read {
        path: dir.to_owned(),
        source,
    };
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(read)? {
        let entry = entry.map_err(read)?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let stem = name
            .strip_suffix(".obj.gz")
            .or_else(|| name.strip_suffix(".obj"));
        if let Some(stem) = stem.filter(|s| !s.is_empty()) {
            out.push((stem.to_owned(), entry.path()));
        }
    }
    out.sort();
    out.dedup_by(|a, b| a.0 == b.0);
    Ok(out)
}

pub(super) fn read(dir: &Path) -> Result<RigFile, RigReadError> {
    let neutral_path = ["neutral.obj", "neutral.obj.gz"]
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
        .unwrap_or_else(|| dir.join("neutral.obj"));
    let neutral = Mesh::read(&neutral_path)?;
    let shapes_dir = dir.join("shapes");
    let files = if shapes_dir.is_dir() {
        shape_files(&shapes_dir)?
    } else {
        Vec::new()
    };
    if files.is_empty() {
        return Err(RigReadError::NoShapes { path: shapes_dir });
    }
    let mut shape_names = Vec::with_capacity(files.len());
    let mut deltas = Vec::with_capacity(files.len());
    for (name, path) in files {
        let shape = Mesh::read(&path)?;
        if shape.positions.len() != neutral.positions.len() {
            return Err(RigReadError::VertexCount {
                path,
                expected: neutral.positions.len(),
                found: shape.positions.len(),
            });
        }
        deltas.push(
            shape
                .positions
                .iter()
                .zip(&neutral.positions)
                .map(|(s, n)| [s[0] - n[0], s[1] - n[1], s[2] - n[2]])
                .collect(),
        );
        shape_names.push(name);
    }
    Ok(RigFile {
        path: dir.to_owned(),
        format: RigFormat::ObjFolder,
        mesh_name: "neutral".into(),
        neutral,
        shape_names,
        deltas,
        node_transform: IDENTITY,
        units: None,
        extensions: Vec::new(),
        avatar: None,
    })
}
