//! A rig as a folder of OBJs: `neutral.obj` and `shapes/NAME.obj` (`.obj.gz` too), every shape
//! a full mesh with the neutral's vertices in the neutral's order; the shape is the file's name.

use std::path::Path;

use super::file::{IDENTITY, RigFile, RigFormat, RigReadError};
use super::scenery::{Image, Scenery};
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
    let neutral_path = neutral_path(dir);
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

/// What an OBJ-folder rig holds besides its skin: the material its faces use first, from the
/// material library `neutral.obj` names (`mtllib`), as a glTF material (the diffuse colour and
/// dissolve as its base colour, the diffuse map as its base colour texture, the bump or normal
/// map as its normal texture), and the images those maps name, read from beside the library.
/// Every other material the faces use is listed in `dropped`; the OBJ holds no other meshes
/// apart from the skin (`neutral.obj` is the skin whole).
pub(super) fn scenery(dir: &Path) -> Result<Scenery, RigReadError> {
    let neutral_path = neutral_path(dir);
    let neutral = Mesh::read(&neutral_path)?;
    let bytes = crate::io::mesh::read_bytes(&neutral_path)?;
    let text = String::from_utf8_lossy(&bytes);
    let mut libraries = Vec::new();
    let mut used: Vec<String> = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("mtllib") => libraries.extend(words.map(str::to_owned)),
            Some("usemtl") => {
                let name = words.collect::<Vec<_>>().join(" ");
                if !name.is_empty() && !used.contains(&name) {
                    used.push(name);
                }
            }
            _ => {}
        }
    }
    let mut scenery = Scenery {
        skin_vertices: neutral.positions.len(),
        skin_material: None,
        parts: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
        samplers: Vec::new(),
        images: Vec::new(),
        extensions: Vec::new(),
        vrm: None,
        vrm0: None,
        dropped: Vec::new(),
    };
    let Some(first) = used.first() else {
        return Ok(scenery);
    };
    for other in &used[1..] {
        scenery.dropped.push(format!(
            "the material {other} (the face is one primitive with the first material its faces use)"
        ));
    }
    for library in &libraries {
        let path = neutral_path.parent().unwrap_or(dir).join(library);
        let (materials, _) = tobj::load_mtl(&path).map_err(|e| RigReadError::Material {
            path: path.clone(),
            reason: format!("not a material library that can be read: {e}"),
        })?;
        let Some(m) = materials.iter().find(|m| &m.name == first) else {
            continue;
        };
        let base = path.parent().unwrap_or(dir);
        let mut image = |map: &str| -> Result<serde_json::Value, RigReadError> {
            // A map statement's options (`-bm 1.0 file.png`) come before the file name.
            let file = map.split_whitespace().last().unwrap_or(map);
            let at = base.join(file);
            let bytes = std::fs::read(&at).map_err(|e| RigReadError::Material {
                path: path.clone(),
                reason: format!("its texture {} cannot be read: {e}", at.display()),
            })?;
            let mime_type =
                super::scenery::image_type(&bytes).ok_or_else(|| RigReadError::Material {
                    path: path.clone(),
                    reason: format!(
                        "its texture {} is not PNG, JPEG, WebP or KTX2",
                        at.display()
                    ),
                })?;
            scenery.images.push(Image {
                name: Some(file.to_owned()),
                mime_type: mime_type.to_owned(),
                bytes,
            });
            scenery
                .textures
                .push(serde_json::json!({"source": scenery.images.len() - 1}));
            Ok(serde_json::json!({"index": scenery.textures.len() - 1}))
        };
        let [r, g, b] = m.diffuse.unwrap_or([1.0; 3]);
        let alpha = m.dissolve.unwrap_or(1.0);
        let colour = [r, g, b, alpha].map(|c| c.clamp(0.0, 1.0));
        let mut pbr = serde_json::json!({
            "baseColorFactor": colour,
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        });
        if let Some(map) = &m.diffuse_texture {
            pbr["baseColorTexture"] = image(map)?;
        }
        let mut material = serde_json::json!({"name": m.name, "pbrMetallicRoughness": pbr});
        let bump = m
            .normal_texture
            .clone()
            .or_else(|| m.unknown_param.get("map_bump").cloned())
            .or_else(|| m.unknown_param.get("bump").cloned());
        if let Some(map) = bump {
            material["normalTexture"] = image(&map)?;
        }
        if alpha < 1.0 {
            material["alphaMode"] = "BLEND".into();
        }
        scenery.materials.push(material);
        scenery.skin_material = Some(0);
        return Ok(scenery);
    }
    scenery.dropped.push(format!(
        "the material {first}: no material library of {} defines it",
        neutral_path.display()
    ));
    Ok(scenery)
}

/// The folder's `neutral.obj` (or `neutral.obj.gz`); `neutral.obj` when neither is there, so
/// that the error names the file expected.
fn neutral_path(dir: &Path) -> std::path::PathBuf {
    ["neutral.obj", "neutral.obj.gz"]
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
        .unwrap_or_else(|| dir.join("neutral.obj"))
}
