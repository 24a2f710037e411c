//! A VRM 1.0 avatar's `VRMC_vrm` extension kept in its actor's export (`--rig`): each expression
//! the actor learned a shape for (presets such as `aa` and `blink`, and custom ones such as a
//! "perfect sync" avatar's ARKit names) bound to that shape's exported morph target with weight
//! 1, since the learned shape is the expression whole; the avatar's `meta` (licence, authors)
//! as written; a humanoid of the two joints the export has, `head` and `jaw`. What cannot be
//! bound again is listed for the report's `dropped`.

use serde_json::{Value, json};

/// The exported nodes the extension names.
pub(super) struct Nodes {
    /// The face mesh's node, whose morph targets the expressions bind.
    pub face: usize,
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
}
