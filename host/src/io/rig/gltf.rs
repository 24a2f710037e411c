//! A rig as a glTF 2.0 file (`.glb`, `.gltf`, or a VRM avatar's `.vrm`), read with the `gltf`
//! crate's document and this module's own accessor reader: the skin is the mesh with morph
//! targets (the one with the most, the one named, or a VRM avatar's face, the mesh its
//! expressions bind), its primitives joined into one vertex list in their order; target names
//! from `mesh.extras.targetNames` (Blender's, three.js's and most exporters' convention), else
//! `target_N`; a VRM avatar's shapes are its expressions instead. Quantised attributes
//! (`KHR_mesh_quantization`) are dequantised, meshopt-compressed views decoded, sparse accessors
//! applied, and the node transforms above the mesh multiplied out (skinned meshes sit in their
//! bind pose, where the spec ignores the node's transform). Other meshes (eyes, teeth), materials
//! and images are read only for an export to carry ([`scenery`]). The targets a Sinew export
//! adds to compensate its animation (`extras.sinewCompensationTargets`, the last N) are not read.

use std::path::Path;

use gltf::mesh::Mode;

use super::file::{Avatar, ExtensionUse, IDENTITY, RigFile, RigFormat, RigReadError};
use super::scenery::{Image, Part, PartPrimitive, Scenery, image_type};
use crate::io::mesh::Mesh;
use crate::io::units::Unit;

mod accessor;
mod extensions;
mod meshopt;
mod vrm;

pub use vrm::group_name_0x as vrm_group_name_0x;

use accessor::{Data, Role};

/// The mesh `extras` key under which a Sinew export counts its compensation targets.
pub const COMPENSATION_KEY: &str = "sinewCompensationTargets";

pub(super) fn read(path: &Path, wanted: Option<&str>) -> Result<RigFile, RigReadError> {
    let Parsed {
        document,
        json,
        blob,
        extensions,
    } = parse(path)?;
    let data = Data::load(path, &document, blob)?;
    let avatar = vrm::Expressions::read(path, &json, &document)?;
    let mesh = skin_mesh(path, &document, wanted, avatar.as_ref())?;
    let mut skin = read_skin(path, &mesh, &data)?;
    let mut names = target_names(mesh.extras(), skin.deltas.len());
    let (shape_names, deltas, avatar) = match avatar {
        Some(expressions) => {
            let (avatar, names, deltas) = expressions.shapes(&mesh, &names, &skin.deltas);
            (names, deltas, Some(avatar))
        }
        None => {
            // A Sinew export's last targets compensate its animation for glTF's order of
            // operations (docs/ENGINES.md); they are no shapes of the face.
            let kept =
                skin.deltas.len() - compensation_targets(mesh.extras()).min(skin.deltas.len());
            names.truncate(kept);
            skin.deltas.truncate(kept);
            (names, skin.deltas, None::<Avatar>)
        }
    };
    let mut neutral = Mesh::new(skin.positions, skin.polygons);
    neutral.uvs = skin.uvs;
    Ok(RigFile {
        path: path.to_owned(),
        format: RigFormat::Gltf,
        mesh_name: name_of(&mesh),
        neutral,
        shape_names,
        deltas,
        node_transform: node_transform(&document, mesh.index(), &data)?,
        units: Some(Unit::Metre),
        extensions,
        avatar,
    })
}

/// What the glTF rig at `path` holds besides its skin mesh (`wanted`, else the one [`read`]
/// picks): the other meshes in their scene place, the materials and what they use.
pub(super) fn scenery(path: &Path, wanted: Option<&str>) -> Result<Scenery, RigReadError> {
    let Parsed {
        document,
        json,
        blob,
        ..
    } = parse(path)?;
    let data = Data::load(path, &document, blob)?;
    let avatar = vrm::Expressions::read(path, &json, &document)?;
    let skin = skin_mesh(path, &document, wanted, avatar.as_ref())?;
    let invalid = |reason: String| RigReadError::Gltf {
        path: path.to_owned(),
        reason,
    };
    let raw: serde_json::Value =
        serde_json::from_slice(&json).map_err(|e| invalid(e.to_string()))?;
    let list = |key: &str| -> Vec<serde_json::Value> {
        raw.get(key)
            .and_then(serde_json::Value::as_array)
            .cloned()
            .unwrap_or_default()
    };
    let mut dropped = Vec::new();
    let skin_materials: std::collections::BTreeSet<Option<usize>> =
        skin.primitives().map(|p| p.material().index()).collect();
    if skin_materials.len() > 1 {
        dropped.push(format!(
            "the materials of {}'s primitives after the first (the face is one primitive)",
            name_of(&skin)
        ));
    }
    let mut skin_vertices = 0;
    for p in skin.primitives() {
        skin_vertices += p.get(&gltf::Semantic::Positions).map_or(0, |a| a.count());
    }
    let worlds = worlds(&document);
    let mut parts = Vec::new();
    for &(n, world) in &worlds {
        let Some(node) = document.nodes().nth(n) else {
            continue;
        };
        let Some(mesh) = node.mesh().filter(|m| m.index() != skin.index()) else {
            continue;
        };
        let name = node
            .name()
            .or(mesh.name())
            .map_or_else(|| format!("node {n}"), str::to_owned);
        if target_count(&mesh) > 0 {
            dropped.push(format!("{name}: its morph targets (carried at rest)"));
        }
        if node.skin().is_some() {
            dropped.push(format!(
                "{name}: its skin (carried in its bind pose, following the head)"
            ));
        }
        let world = placement(&node, world, &worlds, &data)?;
        let on_jaw = on_jaw(&document, &node);
        let mut primitives = Vec::new();
        for (pi, primitive) in mesh.primitives().enumerate() {
            let attribute = |what: String| RigReadError::Attribute {
                path: path.to_owned(),
                mesh: name_of(&mesh),
                primitive: pi,
                what,
            };
            let Some(position) = primitive.get(&gltf::Semantic::Positions) else {
                return Err(attribute("no POSITION attribute".into()));
            };
            if primitive.mode() != Mode::Triangles {
                dropped.push(format!(
                    "{name}: primitive {pi} ({:?}, not triangles)",
                    primitive.mode()
                ));
                continue;
            }
            let positions = triples(&data.read(&position, Role::Position)?);
            let count = positions.len();
            let triangles = triangles(&primitive, &data, count, 0)
                .map_err(|e| match e {
                    Triangles::Read(e) => e,
                    Triangles::Bad(what) => attribute(what),
                })?
                .concat();
            let normals = match primitive.get(&gltf::Semantic::Normals) {
                Some(a) => Some(triples(&data.read(&a, Role::Normal)?)),
                None => None,
            };
            let uvs = match primitive.get(&gltf::Semantic::TexCoords(0)) {
                Some(a) => Some(
                    data.read(&a, Role::TexCoord)?
                        .chunks_exact(2)
                        .map(|c| [c[0], c[1]])
                        .collect::<Vec<_>>(),
                ),
                None => None,
            };
            if normals.as_ref().is_some_and(|n| n.len() != count)
                || uvs.as_ref().is_some_and(|u| u.len() != count)
            {
                return Err(attribute(format!(
                    "NORMAL or TEXCOORD_0 of another length than its {count} positions"
                )));
            }
            primitives.push(PartPrimitive {
                positions,
                normals,
                uvs,
                triangles,
                material: primitive.material().index(),
            });
        }
        parts.push(Part {
            name,
            world,
            primitives,
            on_jaw,
        });
    }
    let mut images = Vec::new();
    for image in document.images() {
        let i = image.index();
        let (bytes, mime) = match image.source() {
            gltf::image::Source::View { view, mime_type } => {
                (data.view(&view)?.to_vec(), Some(mime_type.to_owned()))
            }
            gltf::image::Source::Uri { uri, mime_type } => (
                accessor::read_uri(path, i, uri)?,
                mime_type.map(str::to_owned),
            ),
        };
        let mime_type = match mime.or_else(|| image_type(&bytes).map(str::to_owned)) {
            Some(m) => m,
            None => return Err(invalid(format!("image {i}: not PNG, JPEG, WebP or KTX2"))),
        };
        images.push(Image {
            name: image.name().map(str::to_owned),
            mime_type,
            bytes,
        });
    }
    let (materials, textures, samplers) = (list("materials"), list("textures"), list("samplers"));
    let used_text = serde_json::json!([materials, textures, samplers]).to_string();
    let required = list("extensionsRequired");
    let mut extensions = Vec::new();
    let vrm = raw
        .get("extensions")
        .and_then(|e| e.get("VRMC_vrm"))
        .filter(|v| v.is_object())
        .cloned();
    let vrm0 = raw
        .get("extensions")
        .and_then(|e| e.get("VRM"))
        .filter(|v| v.is_object())
        .cloned();
    for name in list("extensionsUsed")
        .iter()
        .filter_map(serde_json::Value::as_str)
    {
        if (name == "VRMC_vrm" && vrm.is_some()) || (name == "VRM" && vrm0.is_some()) {
            // Kept by the export, its expressions bound again (`crate::export`).
        } else if used_text.contains(&format!("\"{name}\"")) {
            extensions.push((name.to_owned(), required.contains(&name.into())));
        } else if !matches!(
            name,
            "KHR_mesh_quantization" | "EXT_meshopt_compression" | "KHR_meshopt_compression"
        ) {
            dropped.push(format!("the extension {name}"));
        }
    }
    for (key, what) in [
        ("animations", "animation(s)"),
        ("cameras", "camera(s)"),
        ("skins", "skin(s) and their joints"),
    ] {
        if !list(key).is_empty() {
            dropped.push(format!("{} {what}", list(key).len()));
        }
    }
    Ok(Scenery {
        skin_vertices,
        skin_material: skin.primitives().next().and_then(|p| p.material().index()),
        parts,
        materials,
        textures,
        samplers,
        images,
        extensions,
        vrm,
        vrm0,
        dropped,
    })
}

/// Whether the rig hangs `node` on a jaw: it or a node above it is named like a jaw joint
/// (`jaw` in the name, in any case: `Jaw`, `jaw_bone`, `J_Bip_C_Jaw`), or it is skinned and
/// every joint of its skin is.
fn on_jaw(document: &gltf::Document, node: &gltf::Node<'_>) -> bool {
    let jaw_named = |n: &gltf::Node<'_>| {
        n.name()
            .is_some_and(|s| s.to_ascii_lowercase().contains("jaw"))
    };
    if let Some(skin) = node.skin() {
        let mut joints = skin.joints().peekable();
        if joints.peek().is_some() && joints.all(|j| jaw_named(&j)) {
            return true;
        }
    }
    // Up the parents; the depth bound keeps a broken (cyclic) node graph finite.
    let mut at = node.index();
    for _ in 0..=256 {
        let Some(n) = document.nodes().nth(at) else {
            return false;
        };
        if jaw_named(&n) {
            return true;
        }
        match document
            .nodes()
            .find(|p| p.children().any(|c| c.index() == at))
        {
            Some(parent) => at = parent.index(),
            None => return false,
        }
    }
    false
}

/// A glTF file parsed and validated.
struct Parsed {
    /// Its document.
    document: gltf::Document,
    /// Its JSON, as written.
    json: Vec<u8>,
    /// A `.glb`'s binary chunk.
    blob: Option<Vec<u8>>,
    /// Its extensions, each with what Sinew makes of it.
    extensions: Vec<ExtensionUse>,
}

/// The file parsed and validated; a required extension that may change the geometry and is not
/// decoded is an error.
fn parse(path: &Path) -> Result<Parsed, RigReadError> {
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
    let text = if bytes.starts_with(b"glTF") {
        gltf::Glb::from_slice(&bytes)
            .map_err(|e| invalid(e.to_string()))?
            .json
            .into_owned()
    } else {
        bytes.clone()
    };
    let mut json = parsed.document.into_json();
    let extensions = extensions::check(path, &json.extensions_used, &json.extensions_required)?;
    // The policy above decided on every required extension; the crate's validation knows only
    // its own few, so it checks the rest of the file without them.
    json.extensions_required.clear();
    positions_in_range(&json).map_err(invalid)?;
    let document = gltf::Document::from_json(json).map_err(|e| match e {
        gltf::Error::Validation(list) => invalid(
            list.iter()
                .take(3)
                .map(|(p, e)| format!("{}: {e}", p.as_str()))
                .collect::<Vec<_>>()
                .join("; "),
        ),
        other => invalid(other.to_string()),
    })?;
    Ok(Parsed {
        document,
        json: text,
        blob: parsed.blob,
        extensions,
    })
}

/// Every primitive's `POSITION` names an accessor of the file. The crate's validation checks
/// every other index of the document, but reads the `POSITION` accessor's bounds by indexing,
/// so a file whose index lies past the accessors would panic there instead of being refused.
fn positions_in_range(json: &gltf::json::Root) -> Result<(), String> {
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&position)
                && index.value() >= json.accessors.len()
            {
                return Err(format!(
                    "meshes[{m}].primitives[{p}].attributes[\"POSITION\"]: accessor {} is past \
                     the file's {} accessors",
                    index.value(),
                    json.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// A mesh's name in messages and reports: its own, else `mesh N`.
fn name_of(m: &gltf::Mesh<'_>) -> String {
    m.name()
        .map_or_else(|| format!("mesh {}", m.index()), str::to_owned)
}

/// The most morph targets any primitive of `m` has.
fn target_count(m: &gltf::Mesh<'_>) -> usize {
    m.primitives()
        .map(|p| p.morph_targets().len())
        .max()
        .unwrap_or(0)
}

/// The skin: the mesh named `wanted`, else a VRM avatar's face, else the mesh with the most
/// morph targets (the first of those with as many).
fn skin_mesh<'a>(
    path: &Path,
    document: &'a gltf::Document,
    wanted: Option<&str>,
    avatar: Option<&vrm::Expressions>,
) -> Result<gltf::Mesh<'a>, RigReadError> {
    let meshes: Vec<gltf::Mesh<'a>> = document.meshes().collect();
    let no_targets = || RigReadError::NoMorphTargets {
        path: path.to_owned(),
        meshes: meshes.len(),
    };
    let mesh = match (wanted, avatar) {
        (Some(name), _) => meshes
            .iter()
            .find(|m| name_of(m) == name)
            .cloned()
            .ok_or_else(|| RigReadError::NoSuchMesh {
                path: path.to_owned(),
                name: name.to_owned(),
                names: meshes.iter().map(name_of).collect(),
            })?,
        (None, Some(expressions)) => document
            .meshes()
            .nth(expressions.face())
            .ok_or_else(no_targets)?,
        (None, None) => meshes
            .iter()
            .filter(|m| target_count(m) > 0)
            .max_by_key(|m| (target_count(m), std::cmp::Reverse(m.index())))
            .cloned()
            .ok_or_else(no_targets)?,
    };
    if target_count(&mesh) == 0 {
        return Err(no_targets());
    }
    Ok(mesh)
}

/// The skin mesh's primitives joined: positions, triangles, texture coordinates (where every
/// primitive has them) and each morph target's position offsets.
struct Skin {
    positions: Vec<[f32; 3]>,
    polygons: Vec<Vec<u32>>,
    uvs: Vec<[f32; 2]>,
    deltas: Vec<Vec<[f32; 3]>>,
}

fn read_skin(path: &Path, mesh: &gltf::Mesh<'_>, data: &Data<'_>) -> Result<Skin, RigReadError> {
    let target_count = target_count(mesh);
    let attribute = |primitive: usize, what: String| RigReadError::Attribute {
        path: path.to_owned(),
        mesh: name_of(mesh),
        primitive,
        what,
    };
    let mut skin = Skin {
        positions: Vec::new(),
        polygons: Vec::new(),
        uvs: Vec::new(),
        deltas: vec![Vec::new(); target_count],
    };
    let mut all_uvs = true;
    for (pi, primitive) in mesh.primitives().enumerate() {
        if primitive.mode() != Mode::Triangles {
            return Err(RigReadError::NotTriangles {
                path: path.to_owned(),
                mesh: name_of(mesh),
                primitive: pi,
                mode: format!("{:?}", primitive.mode()),
            });
        }
        let position = primitive
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| attribute(pi, "no POSITION attribute".into()))?;
        let points = triples(&data.read(&position, Role::Position)?);
        let base = u32::try_from(skin.positions.len())
            .map_err(|_| attribute(pi, "more vertices than 32-bit indices reach".into()))?;
        let count = points.len();
        skin.polygons.extend(
            triangles(&primitive, data, count, base).map_err(|e| match e {
                Triangles::Read(e) => e,
                Triangles::Bad(what) => attribute(pi, what),
            })?,
        );
        match primitive.get(&gltf::Semantic::TexCoords(0)) {
            Some(uv) => {
                let values = data.read(&uv, Role::TexCoord)?;
                let transform = uv_transform(&primitive);
                skin.uvs
                    .extend(values.chunks_exact(2).map(|c| transform([c[0], c[1]])));
            }
            None => all_uvs = false,
        }
        let targets: Vec<gltf::mesh::MorphTarget<'_>> = primitive.morph_targets().collect();
        if targets.len() != target_count {
            return Err(attribute(
                pi,
                format!(
                    "{} morph targets where the mesh's other primitives have {target_count}",
                    targets.len()
                ),
            ));
        }
        for (k, target) in targets.iter().enumerate() {
            let d = match target.positions() {
                Some(a) => triples(&data.read(&a, Role::TargetPosition(k))?),
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
            skin.deltas[k].extend(d);
        }
        skin.positions.extend(points);
    }
    if !all_uvs {
        skin.uvs.clear();
    }
    Ok(skin)
}

fn triples(flat: &[f32]) -> Vec<[f32; 3]> {
    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Why a primitive's triangles cannot be had.
enum Triangles {
    Read(RigReadError),
    Bad(String),
}

/// A triangle list primitive's triangles over `count` vertices, offset by `base`.
fn triangles(
    primitive: &gltf::Primitive<'_>,
    data: &Data<'_>,
    count: usize,
    base: u32,
) -> Result<Vec<Vec<u32>>, Triangles> {
    let Some(accessor) = primitive.indices() else {
        if !count.is_multiple_of(3) {
            return Err(Triangles::Bad(format!(
                "{count} unindexed vertices, not a multiple of 3"
            )));
        }
        return Ok((0..count as u32 / 3)
            .map(|t| vec![base + 3 * t, base + 3 * t + 1, base + 3 * t + 2])
            .collect());
    };
    let indices = data.indices(&accessor).map_err(Triangles::Read)?;
    if !indices.len().is_multiple_of(3) {
        return Err(Triangles::Bad(format!(
            "{} indices, not a multiple of 3",
            indices.len()
        )));
    }
    if let Some(&i) = indices.iter().find(|&&i| i as usize >= count) {
        return Err(Triangles::Bad(format!(
            "index {i} past its {count} vertices"
        )));
    }
    Ok(indices
        .chunks_exact(3)
        .map(|t| t.iter().map(|&i| base + i).collect())
        .collect())
}

/// The map from a primitive's stored `TEXCOORD_0` to texture space: the identity, or the
/// `KHR_texture_transform` of its material's first texture that reads set 0 (where
/// `KHR_mesh_quantization` keeps the dequantisation of quantised coordinates).
fn uv_transform(primitive: &gltf::Primitive<'_>) -> impl Fn([f32; 2]) -> [f32; 2] + use<> {
    let material = primitive.material();
    let pbr = material.pbr_metallic_roughness();
    let transform = [pbr.base_color_texture(), pbr.metallic_roughness_texture()]
        .into_iter()
        .flatten()
        .chain(material.emissive_texture())
        .filter(|info| info.tex_coord() == 0)
        .find_map(|info| info.texture_transform())
        .map(|t| (t.offset(), t.scale(), t.rotation()));
    move |uv: [f32; 2]| match transform {
        None => uv,
        Some((offset, scale, rotation)) => {
            let (s, c) = rotation.sin_cos();
            let (u, v) = (uv[0] * scale[0], uv[1] * scale[1]);
            [c * u + s * v + offset[0], -s * u + c * v + offset[1]]
        }
    }
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

/// Column-major product of two 4 × 4 matrices.
fn mul(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|c| std::array::from_fn(|r| (0..4).map(|k| a[k][r] * b[c][k]).sum()))
}

/// The scene transform of the first node (depth first from the default scene's roots, else
/// every scene's) that holds `mesh`; the identity for an unplaced mesh.
fn node_transform(
    document: &gltf::Document,
    mesh: usize,
    data: &Data<'_>,
) -> Result<[[f64; 4]; 4], RigReadError> {
    let worlds = worlds(document);
    match worlds.iter().find_map(|&(n, w)| {
        let node = document.nodes().nth(n)?;
        node.mesh()
            .is_some_and(|m| m.index() == mesh)
            .then_some((node, w))
    }) {
        Some((node, world)) => placement(&node, world, &worlds, data),
        None => Ok(IDENTITY),
    }
}

/// Each node's scene transform, in depth-first order from the default scene's roots, else
/// every scene's.
fn worlds(document: &gltf::Document) -> Vec<(usize, [[f64; 4]; 4])> {
    fn visit(
        node: gltf::Node<'_>,
        parent: [[f64; 4]; 4],
        depth: usize,
        out: &mut Vec<(usize, [[f64; 4]; 4])>,
    ) {
        // A node graph is a forest by the spec; the depth bound keeps a broken file finite.
        if depth > 256 || out.iter().any(|(n, _)| *n == node.index()) {
            return;
        }
        let local = node.transform().matrix().map(|c| c.map(f64::from));
        let world = mul(&parent, &local);
        out.push((node.index(), world));
        for child in node.children() {
            visit(child, world, depth + 1, out);
        }
    }
    let scenes: Vec<gltf::Scene<'_>> = match document.default_scene() {
        Some(s) => vec![s],
        None => document.scenes().collect(),
    };
    let mut worlds = Vec::new();
    for root in scenes.iter().flat_map(gltf::Scene::nodes) {
        visit(root, IDENTITY, 0, &mut worlds);
    }
    worlds
}

/// Where `node`'s mesh stands in the scene: its scene transform `world`, or for a skinned mesh,
/// whose node's transform the spec ignores, its bind pose: its first joint's scene transform
/// times that joint's inverse bind matrix (the identity for most exporters;
/// `KHR_mesh_quantization`'s dequantisation for a quantised skinned mesh).
fn placement(
    node: &gltf::Node<'_>,
    world: [[f64; 4]; 4],
    worlds: &[(usize, [[f64; 4]; 4])],
    data: &Data<'_>,
) -> Result<[[f64; 4]; 4], RigReadError> {
    let Some(skin) = node.skin() else {
        return Ok(world);
    };
    let Some(joint) = skin.joints().next() else {
        return Ok(IDENTITY);
    };
    let joint_world = worlds
        .iter()
        .find(|(n, _)| *n == joint.index())
        .map_or(IDENTITY, |(_, w)| *w);
    let inverse_bind = match skin.inverse_bind_matrices() {
        Some(accessor) => {
            let m = data.read(&accessor, Role::InverseBind)?;
            match m.get(..16) {
                Some(first) => {
                    std::array::from_fn(|c| std::array::from_fn(|r| f64::from(first[4 * c + r])))
                }
                None => IDENTITY,
            }
        }
        None => IDENTITY,
    };
    Ok(mul(&joint_world, &inverse_bind))
}
