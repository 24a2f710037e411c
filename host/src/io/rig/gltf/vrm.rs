//! A VRM avatar's expressions as the rig's shapes: VRM 1.0 (`VRMC_vrm`: `expressions.preset`
//! and `expressions.custom`, each with `morphTargetBinds` of a node, a target index and a
//! weight in [0, 1]) and VRM 0.x (`VRM`: `blendShapeMaster.blendShapeGroups`, each with
//! `binds` of a mesh, a target index and a weight in [0, 100], its preset under VRM 1.0's
//! name). Each expression is one shape, the sum of the morph targets it binds on the face, each
//! by its weight; the face is the mesh most binds reach. Custom expressions keep their names, so
//! that a "perfect sync" avatar's ARKit-named expressions bind to ARKit by the usual name rules.

use std::fmt;
use std::path::Path;

use serde::Deserialize;
use serde::de::{Deserializer, MapAccess, Visitor};

use crate::io::rig::file::{
    Avatar, DroppedExpression, Expression, ExpressionProblem, RigReadError,
};

/// VRM 1.0's preset expressions.
const PRESETS: [&str; 18] = [
    "happy",
    "angry",
    "sad",
    "relaxed",
    "surprised",
    "aa",
    "ih",
    "ou",
    "ee",
    "oh",
    "blink",
    "blinkLeft",
    "blinkRight",
    "lookUp",
    "lookDown",
    "lookLeft",
    "lookRight",
    "neutral",
];

/// VRM 0.x's preset names and VRM 1.0's names for them.
const PRESETS_0X: [(&str, &str); 18] = [
    ("a", "aa"),
    ("i", "ih"),
    ("u", "ou"),
    ("e", "ee"),
    ("o", "oh"),
    ("joy", "happy"),
    ("angry", "angry"),
    ("sorrow", "sad"),
    ("fun", "relaxed"),
    ("surprised", "surprised"),
    ("blink", "blink"),
    ("blink_l", "blinkLeft"),
    ("blink_r", "blinkRight"),
    ("lookup", "lookUp"),
    ("lookdown", "lookDown"),
    ("lookleft", "lookLeft"),
    ("lookright", "lookRight"),
    ("neutral", "neutral"),
];

/// The shape name the `k`-th VRM 0.x blend shape group is read under, and whether it is a
/// preset: its preset's VRM 1.0 name (`a` is `aa`, `joy` is `happy`), else its own name, else
/// `group k`. The export binds the group again by the same name (`crate::export`).
pub fn group_name_0x(k: usize, group: &serde_json::Value) -> (String, bool) {
    let name = group.get("name").and_then(|n| n.as_str()).unwrap_or("");
    let preset = group
        .get("presetName")
        .and_then(|n| n.as_str())
        .unwrap_or("unknown");
    match PRESETS_0X
        .iter()
        .find(|(p, _)| p.eq_ignore_ascii_case(preset))
    {
        Some((_, v1)) => ((*v1).to_owned(), true),
        None if !name.is_empty() => (name.to_owned(), false),
        None => (format!("group {k}"), false),
    }
}

/// One morph target bind.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bind {
    /// The mesh's index.
    mesh: usize,
    /// The target's index in it.
    index: usize,
    /// Its weight, in [0, 1] as VRM 1.0 writes it.
    weight: f32,
}

/// One expression as the file has it.
#[derive(Clone, Debug, PartialEq)]
struct Parsed {
    name: String,
    preset: bool,
    binds: Vec<Bind>,
}

/// An avatar's expressions, their binds checked against the file's meshes.
#[derive(Clone, Debug)]
pub(super) struct Expressions {
    version: &'static str,
    list: Vec<Parsed>,
    face: usize,
}

/// A JSON object's entries in order, a key that appears twice kept twice (a map would keep
/// one and hide the other).
#[derive(Debug, Default)]
struct Entries(Vec<(String, serde_json::Value)>);

impl<'de> Deserialize<'de> for Entries {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Entries;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an object of expressions")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Entries, A::Error> {
                let mut out = Vec::new();
                while let Some(entry) = map.next_entry()? {
                    out.push(entry);
                }
                Ok(Entries(out))
            }
        }
        d.deserialize_map(V)
    }
}

/// The parts of a glTF document's JSON that hold a VRM avatar's expressions.
#[derive(Deserialize)]
struct Root {
    #[serde(default)]
    extensions: Option<RootExtensions>,
}

#[derive(Deserialize)]
struct RootExtensions {
    #[serde(rename = "VRMC_vrm", default)]
    vrm1: Option<Vrm1>,
    #[serde(rename = "VRM", default)]
    vrm0: Option<Vrm0>,
}

#[derive(Deserialize)]
struct Vrm1 {
    #[serde(default)]
    expressions: Option<Expressions1>,
}

#[derive(Deserialize)]
struct Expressions1 {
    #[serde(default)]
    preset: Entries,
    #[serde(default)]
    custom: Entries,
}

#[derive(Deserialize)]
struct Vrm0 {
    #[serde(rename = "blendShapeMaster", default)]
    master: Option<Master0>,
}

#[derive(Deserialize)]
struct Master0 {
    #[serde(rename = "blendShapeGroups", default)]
    groups: Vec<serde_json::Value>,
}

impl Expressions {
    /// The expressions of the VRM avatar whose glTF JSON is `json`, or `None` when it is no
    /// avatar (or one without expressions).
    pub(super) fn read(
        path: &Path,
        json: &[u8],
        document: &gltf::Document,
    ) -> Result<Option<Self>, RigReadError> {
        let problem = |expression: &str, what: ExpressionProblem| RigReadError::Expression {
            path: path.to_owned(),
            expression: expression.to_owned(),
            what,
        };
        let root: Root = serde_json::from_slice(json).map_err(|e| RigReadError::Gltf {
            path: path.to_owned(),
            reason: format!("VRM extension: {e}"),
        })?;
        let Some(ext) = root.extensions else {
            return Ok(None);
        };
        let (version, list) = match (ext.vrm1, ext.vrm0) {
            (Some(v), _) => {
                let Some(e) = v.expressions else {
                    return Ok(None);
                };
                let mut list = Vec::new();
                for (entries, preset) in [(e.preset, true), (e.custom, false)] {
                    for (name, value) in entries.0 {
                        let binds = binds(&value, "morphTargetBinds", "node", 1.0, document)
                            .map_err(|w| problem(&name, w))?;
                        list.push(Parsed {
                            preset: preset || PRESETS.contains(&name.as_str()),
                            name,
                            binds,
                        });
                    }
                }
                ("1.0", list)
            }
            (None, Some(v)) => {
                let mut list = Vec::new();
                for (k, group) in v
                    .master
                    .map(|m| m.groups)
                    .unwrap_or_default()
                    .iter()
                    .enumerate()
                {
                    let (name, is_preset) = group_name_0x(k, group);
                    let binds = binds(group, "binds", "mesh", 0.01, document)
                        .map_err(|w| problem(&name, w))?;
                    list.push(Parsed {
                        name,
                        preset: is_preset,
                        binds,
                    });
                }
                ("0.x", list)
            }
            (None, None) => return Ok(None),
        };
        for (k, e) in list.iter().enumerate() {
            if list[..k].iter().any(|o| o.name == e.name) {
                return Err(problem(&e.name, ExpressionProblem::Repeated));
            }
        }
        // The face: the mesh most binds reach (the first of those with as many).
        let mut reach = vec![0usize; document.meshes().len()];
        for b in list.iter().flat_map(|e| &e.binds) {
            reach[b.mesh] += 1;
        }
        let Some(face) = (0..reach.len())
            .filter(|&m| reach[m] > 0)
            .max_by_key(|&m| (reach[m], std::cmp::Reverse(m)))
        else {
            return Ok(None);
        };
        Ok(Some(Self {
            version,
            list,
            face,
        }))
    }

    /// The face mesh's index: the mesh most binds reach.
    pub(super) fn face(&self) -> usize {
        self.face
    }

    /// Each expression that binds `mesh`'s targets as a shape: the avatar's report, the shapes'
    /// names and their offsets (`deltas`: each of the mesh's targets, per vertex).
    pub(super) fn shapes(
        self,
        mesh: &gltf::Mesh<'_>,
        target_names: &[String],
        deltas: &[Vec<[f32; 3]>],
    ) -> (Avatar, Vec<String>, Vec<Vec<[f32; 3]>>) {
        let vertices = deltas.first().map_or(0, Vec::len);
        let mut avatar = Avatar {
            version: self.version,
            expressions: Vec::new(),
            dropped: Vec::new(),
        };
        let mut names = Vec::new();
        let mut shapes = Vec::new();
        for e in self.list {
            let (on, off): (Vec<Bind>, Vec<Bind>) =
                e.binds.iter().partition(|b| b.mesh == mesh.index());
            if !off.is_empty() {
                let mut others: Vec<usize> = off.iter().map(|b| b.mesh).collect();
                others.dedup();
                avatar.dropped.push(DroppedExpression {
                    name: e.name.clone(),
                    reason: format!(
                        "its binds on mesh {} are not read (only the face's, mesh {})",
                        others
                            .iter()
                            .map(usize::to_string)
                            .collect::<Vec<_>>()
                            .join(", "),
                        mesh.index()
                    ),
                });
            }
            if on.is_empty() {
                avatar.dropped.push(DroppedExpression {
                    name: e.name.clone(),
                    reason: "binds no morph target of the face".into(),
                });
                continue;
            }
            // VRM expression: the face moves by Σ weight × target.
            let mut shape = vec![[0.0f32; 3]; vertices];
            for b in &on {
                for (s, d) in shape.iter_mut().zip(&deltas[b.index]) {
                    for k in 0..3 {
                        s[k] += b.weight * d[k];
                    }
                }
            }
            avatar.expressions.push(Expression {
                name: e.name.clone(),
                preset: e.preset,
                binds: on
                    .iter()
                    .map(|b| (target_names[b.index].clone(), b.weight))
                    .collect(),
            });
            names.push(e.name);
            shapes.push(shape);
        }
        (avatar, names, shapes)
    }
}

/// The binds of `value[key]`, each naming its mesh by `by` (`node` in VRM 1.0, `mesh` in 0.x),
/// weights scaled by `scale` to [0, 1], checked against `document`'s meshes and targets.
fn binds(
    value: &serde_json::Value,
    key: &str,
    by: &str,
    scale: f64,
    document: &gltf::Document,
) -> Result<Vec<Bind>, ExpressionProblem> {
    let schema = |what: String| ExpressionProblem::Schema(what);
    let Some(list) = value.get(key) else {
        return Ok(Vec::new());
    };
    let list = list
        .as_array()
        .ok_or_else(|| schema(format!("`{key}` is not a list")))?;
    let mut out = Vec::new();
    for b in list {
        let field = |name: &str| {
            b.get(name)
                .and_then(serde_json::Value::as_u64)
                .ok_or_else(|| {
                    schema(format!(
                        "a bind's `{name}` is {}, not an index",
                        b.get(name).unwrap_or(&serde_json::Value::Null)
                    ))
                })
        };
        let (at, index) = (field(by)?, field("index")?);
        let mesh = if by == "node" {
            document
                .nodes()
                .nth(usize::try_from(at).unwrap_or(usize::MAX))
                .and_then(|n| n.mesh())
                .ok_or_else(|| ExpressionProblem::NoSuchMesh {
                    what: format!("node {at} (as a mesh's node)"),
                })?
        } else {
            document
                .meshes()
                .nth(usize::try_from(at).unwrap_or(usize::MAX))
                .ok_or_else(|| ExpressionProblem::NoSuchMesh {
                    what: format!("mesh {at}"),
                })?
        };
        let targets = mesh
            .primitives()
            .map(|p| p.morph_targets().len())
            .max()
            .unwrap_or(0);
        let Some(index_ok) = usize::try_from(index).ok().filter(|&i| i < targets) else {
            return Err(ExpressionProblem::NoSuchTarget {
                mesh: mesh
                    .name()
                    .map_or_else(|| format!("mesh {}", mesh.index()), str::to_owned),
                index,
                targets,
            });
        };
        let raw = b
            .get("weight")
            .cloned()
            .unwrap_or(serde_json::json!(1.0 / scale));
        let weight = raw.as_f64().map(|w| (w * scale) as f32);
        let Some(weight) = weight.filter(|w| w.is_finite()) else {
            return Err(ExpressionProblem::NonFiniteWeight {
                index,
                weight: raw.to_string(),
            });
        };
        out.push(Bind {
            mesh: mesh.index(),
            index: index_ok,
            weight,
        });
    }
    Ok(out)
}
