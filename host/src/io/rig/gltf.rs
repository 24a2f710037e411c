//! A rig as a glTF 2.0 file, read with the `gltf` crate: the skin is the mesh with morph targets
//! (the one with the most, or the one named), its primitives joined into one vertex list in
//! their order; target names from `mesh.extras.targetNames` (Blender's, three.js's and most
//! exporters' convention), else `target_N`; sparse accessors as the crate reads them; the node
//! transforms above the mesh multiplied out (skinned meshes sit in their bind pose, where the
//! spec ignores the node's transform). Other meshes (eyes, teeth) are not read, nor the targets a
//! Sinew export adds to compensate its animation (`extras.sinewCompensationTargets`, the last N).

use std::path::Path;

use gltf::mesh::Mode;

use super::file::{IDENTITY, RigFile, RigFormat, RigReadError};
use crate::io::mesh::Mesh;
use crate::io::units::Unit;

/// The mesh compression extensions, whose data Sinew does not decode.
const COMPRESSION: [&str; 3] = [
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

fn cut(s: &str) -> String {
    match s.char_indices().nth(80) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_owned(),
    }
}

pub(super) fn read(path: &Path, wanted: Option<&str>) -> Result<RigFile, RigReadError> {
    let bytes = std::fs::read(path).map_err(|source| RigReadError::Read {
        path: path.to_owned(),
        source,
    })?;
    let invalid = |reason: String| RigReadError::Gltf {
        path: path.to_owned(),
        reason,
    };
    let parsed =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| invalid(e.to_string()))?;
    let blob = parsed.blob;
    let json = parsed.document.into_json();
    for extension in &json.extensions_required {
        if COMPRESSION.contains(&extension.as_str()) {
            return Err(RigReadError::Compressed {
                path: path.to_owned(),
                extension: extension.clone(),
            });
        }
    }
    let document = gltf::Document::from_json(json).map_err(|e| match e {
        gltf::Error::Validation(list) => {
            let unsupported = list.iter().find_map(|(p, e)| {
                (*e == gltf::json::validation::Error::Unsupported
                    && p.as_str().starts_with("extensionsRequired"))
                .then(|| p.as_str().to_owned())
            });
            match unsupported {
                Some(at) => RigReadError::Extension {
                    path: path.to_owned(),
                    extension: at,
                },
                None => invalid(
                    list.iter()
                        .take(3)
                        .map(|(p, e)| format!("{}: {e}", p.as_str()))
                        .collect::<Vec<_>>()
                        .join("; "),
                ),
            }
        }
        other => invalid(other.to_string()),
    })?;
    let buffers = load_buffers(path, &document, blob)?;

    let meshes: Vec<gltf::Mesh<'_>> = document.meshes().collect();
    let name_of = |m: &gltf::Mesh<'_>| {
        m.name()
            .map_or_else(|| format!("mesh {}", m.index()), str::to_owned)
    };
    let targets = |m: &gltf::Mesh<'_>| {
        m.primitives()
            .map(|p| p.morph_targets().len())
            .max()
            .unwrap_or(0)
    };
    let mesh =
        match wanted {
            Some(name) => meshes.iter().find(|m| name_of(m) == name).ok_or_else(|| {
                RigReadError::NoSuchMesh {
                    path: path.to_owned(),
                    name: name.to_owned(),
                    names: meshes.iter().map(name_of).collect(),
                }
            })?,
            None => meshes
                .iter()
                .filter(|m| targets(m) > 0)
                .max_by_key(|m| (targets(m), std::cmp::Reverse(m.index())))
                .ok_or(RigReadError::NoMorphTargets {
                    path: path.to_owned(),
                    meshes: meshes.len(),
                })?,
        };
    let mesh_name = name_of(mesh);
    let target_count = targets(mesh);
    if target_count == 0 {
        return Err(RigReadError::NoMorphTargets {
            path: path.to_owned(),
            meshes: meshes.len(),
        });
    }
    let attribute = |primitive: usize, what: String| RigReadError::Attribute {
        path: path.to_owned(),
        mesh: mesh_name.clone(),
        primitive,
        what,
    };

    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut polygons: Vec<Vec<u32>> = Vec::new();
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    let mut all_uvs = true;
    let mut deltas: Vec<Vec<[f32; 3]>> = vec![Vec::new(); target_count];
    for (pi, primitive) in mesh.primitives().enumerate() {
        if primitive.mode() != Mode::Triangles {
            return Err(RigReadError::NotTriangles {
                path: path.to_owned(),
                mesh: mesh_name.clone(),
                primitive: pi,
                mode: format!("{:?}", primitive.mode()),
            });
        }
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let points: Vec<[f32; 3]> = reader
            .read_positions()
            .ok_or_else(|| attribute(pi, "no readable POSITION attribute".into()))?
            .collect();
        let base = positions.len() as u32;
        let count = points.len();
        match reader.read_indices() {
            Some(indices) => {
                let indices: Vec<u32> = indices.into_u32().collect();
                if !indices.len().is_multiple_of(3) {
                    return Err(attribute(
                        pi,
                        format!("{} indices, not a multiple of 3", indices.len()),
                    ));
                }
                if let Some(&i) = indices.iter().find(|&&i| i as usize >= count) {
                    return Err(attribute(
                        pi,
                        format!("index {i} past its {count} vertices"),
                    ));
                }
                polygons.extend(
                    indices
                        .chunks_exact(3)
                        .map(|t| t.iter().map(|&i| base + i).collect()),
                );
            }
            None if primitive.indices().is_some() => {
                return Err(attribute(pi, "its indices cannot be read".into()));
            }
            None => {
                if !count.is_multiple_of(3) {
                    return Err(attribute(
                        pi,
                        format!("{count} unindexed vertices, not a multiple of 3"),
                    ));
                }
                polygons.extend(
                    (0..count as u32 / 3)
                        .map(|t| vec![base + 3 * t, base + 3 * t + 1, base + 3 * t + 2]),
                );
            }
        }
        match reader.read_tex_coords(0) {
            Some(t) => {
                let t: Vec<[f32; 2]> = t.into_f32().collect();
                if t.len() != count {
                    return Err(attribute(
                        pi,
                        format!("{} TEXCOORD_0 values for {count} positions", t.len()),
                    ));
                }
                uvs.extend(t);
            }
            None => all_uvs = false,
        }
        let declared: Vec<bool> = primitive
            .morph_targets()
            .map(|t| t.positions().is_some())
            .collect();
        if declared.len() != target_count {
            return Err(attribute(
                pi,
                format!(
                    "{} morph targets where the mesh's other primitives have {target_count}",
                    declared.len()
                ),
            ));
        }
        for (k, (target, declared)) in reader.read_morph_targets().zip(declared).enumerate() {
            let d: Vec<[f32; 3]> = match target.0 {
                Some(p) => p.collect(),
                None if declared => {
                    return Err(attribute(
                        pi,
                        format!("morph target {k}'s POSITION cannot be read"),
                    ));
                }
                None => vec![[0.0; 3]; count],
            };
            if d.len() != count {
                return Err(attribute(
                    pi,
                    format!(
                        "morph target {k} has {} positions, the primitive {count}",
                        d.len()
                    ),
                ));
            }
            deltas[k].extend(d);
        }
        positions.extend(points);
    }

    let mut shape_names = target_names(mesh.extras(), target_count);
    // A Sinew export's last targets compensate its animation for glTF's order of operations
    // (docs/ENGINES.md); they are no shapes of the face.
    let kept = target_count - compensation_targets(mesh.extras()).min(target_count);
    shape_names.truncate(kept);
    deltas.truncate(kept);
    let mut neutral = Mesh::new(positions, polygons);
    if all_uvs {
        neutral.uvs = uvs;
    }
    Ok(RigFile {
        path: path.to_owned(),
        format: RigFormat::Gltf,
        mesh_name,
        neutral,
        shape_names,
        deltas,
        node_transform: node_transform(&document, mesh.index()),
        units: Some(Unit::Metre),
    })
}

/// `extras.targetNames` when it names every target, else `target_0` ….
fn target_names(extras: &gltf::json::Extras, count: usize) -> Vec<String> {
    let named = extras
        .as_ref()
        .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
        .and_then(|v| {
            let list = v.get("targetNames")?.as_array()?.clone();
            list.iter()
                .map(|n| n.as_str().map(str::to_owned))
                .collect::<Option<Vec<String>>>()
        })
        .filter(|names| names.len() == count);
    named.unwrap_or_else(|| (0..count).map(|k| format!("target_{k}")).collect())
}

/// `extras.sinewCompensationTargets`: how many of the last targets a Sinew export added to
/// compensate its animation (0 when absent).
fn compensation_targets(extras: &gltf::json::Extras) -> usize {
    extras
        .as_ref()
        .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
        .and_then(|v| v.get(COMPENSATION_KEY)?.as_u64())
        .map_or(0, |n| usize::try_from(n).unwrap_or(usize::MAX))
}

/// The mesh `extras` key under which a Sinew export counts its compensation targets.
pub const COMPENSATION_KEY: &str = "sinewCompensationTargets";

/// Each buffer's bytes: the `.glb`'s binary chunk, a `data:` URI or a file beside the glTF.
fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, RigReadError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let bad_uri = |uri: &str| RigReadError::BufferUri {
            path: path.to_owned(),
            buffer: buffer.index(),
            uri: cut(uri),
        };
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| RigReadError::Gltf {
                path: path.to_owned(),
                reason: format!(
                    "buffer {} is the binary chunk, which the file lacks",
                    buffer.index()
                ),
            })?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| bad_uri(uri))?;
                    use base64::Engine as _;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|_| bad_uri(uri))?
                } else {
                    let decoded = urlencoding::decode(uri).map_err(|_| bad_uri(uri))?;
                    let relative = Path::new(decoded.as_ref());
                    if decoded.contains(':') || relative.is_absolute() {
                        return Err(bad_uri(uri));
                    }
                    let file = path.parent().unwrap_or(Path::new(".")).join(relative);
                    std::fs::read(&file).map_err(|source| RigReadError::Read {
                        path: file.clone(),
                        source,
                    })?
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(RigReadError::BufferLength {
                path: path.to_owned(),
                buffer: buffer.index(),
                declared: buffer.length(),
                found: data.len(),
            });
        }
        out.push(data);
    }
    Ok(out)
}

/// Column-major product of two 4 × 4 matrices.
fn mul(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|c| std::array::from_fn(|r| (0..4).map(|k| a[k][r] * b[c][k]).sum()))
}

/// The scene transform of the first node (depth first from the default scene's roots, else
/// every scene's) that holds `mesh`; the identity for a skinned node or an unplaced mesh.
fn node_transform(document: &gltf::Document, mesh: usize) -> [[f64; 4]; 4] {
    fn visit(
        node: gltf::Node<'_>,
        parent: [[f64; 4]; 4],
        mesh: usize,
        depth: usize,
    ) -> Option<[[f64; 4]; 4]> {
        // A node graph is a forest by the spec; the depth bound keeps a broken file finite.
        if depth > 256 {
            return None;
        }
        let local = node.transform().matrix().map(|c| c.map(f64::from));
        let world = mul(&parent, &local);
        if node.mesh().is_some_and(|m| m.index() == mesh) {
            return Some(if node.skin().is_some() {
                IDENTITY
            } else {
                world
            });
        }
        node.children()
            .find_map(|child| visit(child, world, mesh, depth + 1))
    }
    let scenes: Vec<gltf::Scene<'_>> = match document.default_scene() {
        Some(s) => vec![s],
        None => document.scenes().collect(),
    };
    scenes
        .iter()
        .flat_map(gltf::Scene::nodes)
        .find_map(|root| visit(root, IDENTITY, mesh, 0))
        .unwrap_or(IDENTITY)
}
