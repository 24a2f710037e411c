//! ARKit's 52 blendshape names (in the column order of Live Link Face, whose channels are here
//! too) and the spellings rigs give them: Apple's camelCase
//! (`mouthSmileLeft`), Live Link Face's PascalCase (`MouthSmileLeft`), ICT-FaceKit's and many
//! studios' `_L`/`_R` (`mouthSmile_L`), Blender's `.L`/`.R`, and a namespace before the name as
//! Maya writes it (`blendShape1.jawOpen`). Names are compared ignoring case and punctuation.

/// The channels Live Link Face records, in its column order: ARKit's 52 blendshapes, then the
/// head's and eyes' rotations.
pub const LIVE_LINK_FACE_CHANNELS: [&str; 61] = [
    "EyeBlinkLeft",
    "EyeLookDownLeft",
    "EyeLookInLeft",
    "EyeLookOutLeft",
    "EyeLookUpLeft",
    "EyeSquintLeft",
    "EyeWideLeft",
    "EyeBlinkRight",
    "EyeLookDownRight",
    "EyeLookInRight",
    "EyeLookOutRight",
    "EyeLookUpRight",
    "EyeSquintRight",
    "EyeWideRight",
    "JawForward",
    "JawRight",
    "JawLeft",
    "JawOpen",
    "MouthClose",
    "MouthFunnel",
    "MouthPucker",
    "MouthRight",
    "MouthLeft",
    "MouthSmileLeft",
    "MouthSmileRight",
    "MouthFrownLeft",
    "MouthFrownRight",
    "MouthDimpleLeft",
    "MouthDimpleRight",
    "MouthStretchLeft",
    "MouthStretchRight",
    "MouthRollLower",
    "MouthRollUpper",
    "MouthShrugLower",
    "MouthShrugUpper",
    "MouthPressLeft",
    "MouthPressRight",
    "MouthLowerDownLeft",
    "MouthLowerDownRight",
    "MouthUpperUpLeft",
    "MouthUpperUpRight",
    "BrowDownLeft",
    "BrowDownRight",
    "BrowInnerUp",
    "BrowOuterUpLeft",
    "BrowOuterUpRight",
    "CheekPuff",
    "CheekSquintLeft",
    "CheekSquintRight",
    "NoseSneerLeft",
    "NoseSneerRight",
    "TongueOut",
    "HeadYaw",
    "HeadPitch",
    "HeadRoll",
    "LeftEyeYaw",
    "LeftEyePitch",
    "LeftEyeRoll",
    "RightEyeYaw",
    "RightEyePitch",
    "RightEyeRoll",
];

/// The number of ARKit blendshapes.
pub const ARKIT_SHAPES: usize = 52;

/// ARKit's blendshape names as Apple spells them (`ARFaceAnchor.BlendShapeLocation`), in Live
/// Link Face's column order.
pub fn arkit_shapes() -> impl Iterator<Item = String> {
    LIVE_LINK_FACE_CHANNELS[..ARKIT_SHAPES].iter().map(|c| {
        let mut name = c.to_string();
        name[..1].make_ascii_lowercase();
        name
    })
}

/// A name reduced for comparison: the part after a `.`, `:` or `|` namespace (unless that part
/// is a side letter), a side suffix (`_L`, `.L`, `-L`, ` L`, `_Left`, `Left`, and the same for
/// right) spelled `left`/`right`, lower case, letters and digits only.
pub fn comparable(name: &str) -> String {
    let name = name.trim();
    let name = match name.rsplit_once(['.', ':', '|']) {
        Some((_, last)) if last.len() > 1 => last,
        _ => name,
    };
    let lower = name.to_ascii_lowercase();
    let mut stem = lower.as_str();
    let mut side = "";
    'sides: for (word, letter) in [("left", 'l'), ("right", 'r')] {
        for sep in ["_", ".", "-", " ", ""] {
            for suffix in [format!("{sep}{word}"), format!("{sep}{letter}")] {
                // A bare trailing letter is a side only after a separator (`jawl` is no side).
                if sep.is_empty() && suffix.len() == 1 {
                    continue;
                }
                if let Some(s) = lower
                    .strip_suffix(suffix.as_str())
                    .filter(|s| !s.is_empty())
                {
                    stem = s;
                    side = word;
                    break 'sides;
                }
            }
        }
    }
    stem.chars()
        .chain(side.chars())
        .filter(char::is_ascii_alphanumeric)
        .collect()
}

/// Which rig shapes play each ARKit blendshape: the shape whose name compares equal; for the
/// blendshapes ARKit does not split by side (`browInnerUp`, `cheekPuff`, …), both sides of a rig
/// that splits them. Returns, per ARKit name in order, the indices of `shapes` it plays (empty
/// where the rig lacks it).
pub fn arkit_bindings(shapes: &[String]) -> Vec<(String, Vec<usize>)> {
    let keys: Vec<String> = shapes.iter().map(|s| comparable(s)).collect();
    arkit_shapes()
        .map(|arkit| {
            let key = comparable(&arkit);
            let exact: Vec<usize> = (0..shapes.len()).filter(|&s| keys[s] == key).collect();
            let bound = if exact.is_empty() && !key.ends_with("left") && !key.ends_with("right") {
                (0..shapes.len())
                    .filter(|&s| {
                        keys[s] == format!("{key}left") || keys[s] == format!("{key}right")
                    })
                    .collect()
            } else {
                exact
            };
            (arkit, bound)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spelling_compares_equal() {
        let want = comparable("mouthSmileLeft");
        assert_eq!(want, "mouthsmileleft");
        for s in [
            "MouthSmileLeft",
            "mouthSmile_L",
            "mouthSmile.L",
            "mouthSmile_Left",
            "mouthSmile-l",
            "blendShape1.mouthSmileLeft",
            "head:mouthSmile_L",
        ] {
            assert_eq!(comparable(s), want, "{s}");
        }
        assert_eq!(comparable("jawOpen"), "jawopen");
        assert_eq!(comparable("mouthRollLower"), "mouthrolllower");
        assert_ne!(comparable("mouthSmile_R"), want);
    }

    #[test]
    fn bindings_cover_split_and_unsplit_shapes() {
        let shapes: Vec<String> = [
            "jawOpen",
            "browInnerUp_L",
            "browInnerUp_R",
            "MouthSmile.L",
            "extra",
        ]
        .map(String::from)
        .to_vec();
        let b = arkit_bindings(&shapes);
        assert_eq!(b.len(), ARKIT_SHAPES);
        let get = |n: &str| b.iter().find(|(a, _)| a == n).unwrap().1.clone();
        assert_eq!(get("jawOpen"), [0]);
        assert_eq!(get("browInnerUp"), [1, 2]);
        assert_eq!(get("mouthSmileLeft"), [3]);
        assert!(get("mouthSmileRight").is_empty());
        assert_eq!(b.iter().filter(|(_, s)| !s.is_empty()).count(), 3);
        assert_eq!(arkit_shapes().next().as_deref(), Some("eyeBlinkLeft"));
    }
}
