//! A VRM avatar's extension kept in its actor's export (`--rig`): VRM 1.0's `VRMC_vrm` and VRM
//! 0.x's `VRM`. Each expression (0.x: blend shape group) the actor learned a shape for (presets
//! such as `aa` and `blink`, and custom ones such as a "perfect sync" avatar's ARKit names) bound
//! to that shape's exported morph target at full weight (1.0: 1; 0.x: 100), since the learned
//! shape is the expression whole; the avatar's `meta` (licence, authors) as written; a humanoid
//! of the two joints the export has, `head` and `jaw`. VRM 0.x's material properties are kept
//! (they name the materials the export carries). What cannot be bound again is listed for the
//! report's `dropped`.

use serde_json::{Value, json};

/// The exported nodes the extension names.
pub(super) struct Nodes {
    /// The face mesh's node, whose morph targets the expressions bind.
    pub face: usize,
    /// The face mesh (VRM 0.x binds name the mesh, not the node).
    pub face_mesh: usize,
    /// The head joint.
    pub head: usize,
    /// The jaw joint.
    pub jaw: usize,
}

/// The export's `VRMC_vrm` from the rig's (`vrm`), for an actor whose shape `j` (the face's
/// morph target `j`) is named `shapes[j]`; with what it drops, one line each.
pub(super) fn rebind(
    vrm: &Value,
    shapes: &[Option<String>],
    nodes: &Nodes,
) -> (Value, Vec<String>) {
    let mut dropped = Vec::new();
    let mut expressions = json!({"preset": {}, "custom": {}});
    for group in ["preset", "custom"] {
        let Some(list) = vrm
            .get("expressions")
            .and_then(|e| e.get(group))
            .and_then(Value::as_object)
        else {
            continue;
        };
        for (name, expression) in list {
            match shapes.iter().position(|s| s.as_deref() == Some(name)) {
                Some(j) => {
                    let mut e = expression.clone();
                    if !e.is_object() {
                        e = json!({});
                    }
                    e["morphTargetBinds"] =
                        json!([{"node": nodes.face, "index": j, "weight": 1.0}]);
                    expressions[group][name] = e;
                }
                None => dropped.push(format!(
                    "the VRM expression {name}: the actor learned no shape of that name"
                )),
            }
        }
    }
    let humanoid = vrm.get("humanoid").and_then(|h| h.get("humanBones"));
    if humanoid
        .and_then(Value::as_object)
        .is_some_and(|b| b.keys().any(|k| k != "head" && k != "jaw"))
    {
        dropped.push(
            "the VRM humanoid's bones other than head and jaw (the export's skeleton is those two)"
                .into(),
        );
    }
    for key in ["firstPerson", "lookAt"] {
        if vrm.get(key).is_some() {
            dropped.push(format!(
                "the VRM {key} (it names the avatar's bones and meshes, which the export does not carry)"
            ));
        }
    }
    let mut out = json!({
        "specVersion": vrm.get("specVersion").cloned().unwrap_or_else(|| json!("1.0")),
        "humanoid": {"humanBones": {"head": {"node": nodes.head}, "jaw": {"node": nodes.jaw}}},
        "expressions": expressions,
    });
    if let Some(meta) = vrm.get("meta") {
        out["meta"] = meta.clone();
    }
    (out, dropped)
}

/// The export's VRM 0.x `VRM` extension from the rig's (`vrm`), as [`rebind`] for VRM 1.0: each
/// blend shape group whose name the actor learned (`io::rig::vrm_group_name_0x`, the name the
/// rig was read under) bound to that shape's morph target at weight 100; with what it drops.
pub(super) fn rebind_0x(
    vrm: &Value,
    shapes: &[Option<String>],
    nodes: &Nodes,
) -> (Value, Vec<String>) {
    let mut dropped = Vec::new();
    let mut groups = Vec::new();
    let listed = vrm
        .get("blendShapeMaster")
        .and_then(|m| m.get("blendShapeGroups"))
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or_default();
    for (k, group) in listed.iter().enumerate() {
        let (name, _) = crate::io::rig::vrm_group_name_0x(k, group);
        match shapes
            .iter()
            .position(|s| s.as_deref() == Some(name.as_str()))
        {
            Some(j) => {
                let mut g = group.clone();
                if !g.is_object() {
                    g = json!({});
                }
                g["binds"] = json!([{"mesh": nodes.face_mesh, "index": j, "weight": 100.0}]);
                groups.push(g);
            }
            None => dropped.push(format!(
                "the VRM blend shape group {name}: the actor learned no shape of that name"
            )),
        }
    }
    let bones = vrm
        .get("humanoid")
        .and_then(|h| h.get("humanBones"))
        .and_then(Value::as_array);
    if bones.is_some_and(|b| {
        b.iter().any(|bone| {
            !matches!(
                bone.get("bone").and_then(Value::as_str),
                Some("head" | "jaw")
            )
        })
    }) {
        dropped.push(
            "the VRM humanoid's bones other than head and jaw (the export's skeleton is those two)"
                .into(),
        );
    }
    for key in ["firstPerson", "secondaryAnimation"] {
        if vrm.get(key).is_some() {
            dropped.push(format!(
                "the VRM {key} (it names the avatar's bones and meshes, which the export does not carry)"
            ));
        }
    }
    let mut out = json!({
        "specVersion": vrm.get("specVersion").cloned().unwrap_or_else(|| json!("0.0")),
        "humanoid": {"humanBones": [
            {"bone": "head", "node": nodes.head, "useDefaultValues": true},
            {"bone": "jaw", "node": nodes.jaw, "useDefaultValues": true},
        ]},
        "blendShapeMaster": {"blendShapeGroups": groups},
    });
    for key in ["meta", "exporterVersion", "materialProperties"] {
        if let Some(v) = vrm.get(key) {
            out[key] = v.clone();
        }
    }
    (out, dropped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn learned_expressions_are_bound_again_and_the_rest_listed() {
        let vrm = json!({"specVersion": "1.0", "meta": {"name": "avatar"},
            "humanoid": {"humanBones": {"head": {"node": 3}, "hips": {"node": 1}}},
            "lookAt": {"type": "expression"},
            "expressions": {
                "preset": {"aa": {"morphTargetBinds": [{"node": 7, "index": 4, "weight": 0.5}],
                                  "isBinary": true},
                           "blink": {"morphTargetBinds": []}},
                "custom": {"jawOpen": {"morphTargetBinds": [{"node": 7, "index": 2, "weight": 1.0}]}}}});
        let shapes = [Some("jawOpen".to_owned()), None, Some("aa".to_owned())];
        let nodes = Nodes {
            face: 2,
            face_mesh: 0,
            head: 0,
            jaw: 1,
        };
        let (out, dropped) = rebind(&vrm, &shapes, &nodes);
        let e = &out["expressions"];
        assert_eq!(
            e["preset"]["aa"]["morphTargetBinds"],
            json!([{"node": 2, "index": 2, "weight": 1.0}])
        );
        assert_eq!(e["preset"]["aa"]["isBinary"], true);
        assert_eq!(e["custom"]["jawOpen"]["morphTargetBinds"][0]["index"], 0);
        assert!(e["preset"].get("blink").is_none());
        assert_eq!(out["meta"]["name"], "avatar");
        assert_eq!(out["humanoid"]["humanBones"]["jaw"]["node"], 1);
        assert_eq!(dropped.len(), 3, "{dropped:?}");
        assert!(dropped[0].contains("blink"));
    }

    #[test]
    fn learned_blend_shape_groups_are_bound_again_and_the_rest_listed() {
        let vrm = json!({"specVersion": "0.0", "exporterVersion": "UniVRM-0.99",
            "meta": {"title": "avatar"},
            "humanoid": {"humanBones": [{"bone": "head", "node": 3}, {"bone": "hips", "node": 1}]},
            "firstPerson": {"firstPersonBone": 3},
            "materialProperties": [{"name": "skin", "shader": "VRM/MToon"}],
            "blendShapeMaster": {"blendShapeGroups": [
                {"name": "A", "presetName": "a", "binds": [{"mesh": 4, "index": 1, "weight": 50}]},
                {"name": "Blink", "presetName": "blink", "binds": []},
                {"name": "jawOpen", "presetName": "unknown", "isBinary": false,
                 "binds": [{"mesh": 4, "index": 0, "weight": 100}]}]}});
        let shapes = [Some("jawOpen".to_owned()), Some("aa".to_owned())];
        let nodes = Nodes {
            face: 2,
            face_mesh: 5,
            head: 0,
            jaw: 1,
        };
        let (out, dropped) = rebind_0x(&vrm, &shapes, &nodes);
        let groups = out["blendShapeMaster"]["blendShapeGroups"]
            .as_array()
            .unwrap();
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0]["presetName"], "a");
        assert_eq!(
            groups[0]["binds"],
            json!([{"mesh": 5, "index": 1, "weight": 100.0}])
        );
        assert_eq!(groups[1]["name"], "jawOpen");
        assert_eq!(groups[1]["binds"][0]["index"], 0);
        assert_eq!(groups[1]["isBinary"], false);
        assert_eq!(out["meta"]["title"], "avatar");
        assert_eq!(out["exporterVersion"], "UniVRM-0.99");
        assert_eq!(out["materialProperties"][0]["name"], "skin");
        assert_eq!(
            out["humanoid"]["humanBones"][1],
            json!({"bone": "jaw", "node": 1, "useDefaultValues": true})
        );
        assert!(out.get("firstPerson").is_none());
        assert_eq!(dropped.len(), 3, "{dropped:?}");
        assert!(
            dropped[0].contains("Blink") || dropped[0].contains("blink"),
            "{dropped:?}"
        );
    }
}
