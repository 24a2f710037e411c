//! The twelve expression classes of CoMA (Ranjan et al. 2018), which the S2D paper trains
//! Motion3DGAN on, as patterns over ICT-FaceKit's expression deltas.
//!
//! CoMA is captured 4D data and no licensed copy is reachable, so `sinew data motions` plays
//! these patterns instead (docs/MOTION.md says so). Each class is one or more variants (mouth_side
//! goes left or right), each a list of (expression delta, apex weight). Classes share deltas, as
//! CoMA's expressions share muscles: jaw opening is in mouth_open, mouth_extreme and
//! mouth_middle; lip stretching in bareteeth, lips_back and mouth_extreme; the pucker in
//! cheeks_in and mouth_middle; the upper-lip raise in bareteeth, lips_up and high_smile; so that
//! the classes are not separable by which landmarks move alone, only by how much and together
//! with what.

/// One delta of a pattern and its weight at the apex (before the sequence's intensity).
pub type Part = (&'static str, f32);

/// CoMA's labels, in CoMA's (alphabetical) order: the label index of every sequence, one-hot
/// code and class output.
pub const LABELS: [&str; 12] = [
    "bareteeth",
    "cheeks_in",
    "eyebrow",
    "high_smile",
    "lips_back",
    "lips_up",
    "mouth_down",
    "mouth_extreme",
    "mouth_middle",
    "mouth_open",
    "mouth_side",
    "mouth_up",
];

const BARETEETH: &[Part] = &[
    ("mouthUpperUp_L", 0.9),
    ("mouthUpperUp_R", 0.9),
    ("mouthLowerDown_L", 0.8),
    ("mouthLowerDown_R", 0.8),
    ("mouthStretch_L", 0.5),
    ("mouthStretch_R", 0.5),
    ("jawOpen", 0.1),
];
const CHEEKS_IN: &[Part] = &[
    ("mouthPucker", 0.7),
    ("mouthFunnel", 0.3),
    ("mouthRollLower", 0.3),
    ("mouthRollUpper", 0.3),
    ("cheekSquint_L", 0.2),
    ("cheekSquint_R", 0.2),
];
const EYEBROW: &[Part] = &[
    ("browInnerUp_L", 1.0),
    ("browInnerUp_R", 1.0),
    ("browOuterUp_L", 0.8),
    ("browOuterUp_R", 0.8),
    ("eyeWide_L", 0.4),
    ("eyeWide_R", 0.4),
];
const HIGH_SMILE: &[Part] = &[
    ("mouthSmile_L", 1.0),
    ("mouthSmile_R", 1.0),
    ("cheekSquint_L", 0.6),
    ("cheekSquint_R", 0.6),
    ("eyeSquint_L", 0.3),
    ("eyeSquint_R", 0.3),
    ("mouthUpperUp_L", 0.3),
    ("mouthUpperUp_R", 0.3),
];
const LIPS_BACK: &[Part] = &[
    ("mouthStretch_L", 0.8),
    ("mouthStretch_R", 0.8),
    ("mouthDimple_L", 0.6),
    ("mouthDimple_R", 0.6),
    ("mouthPress_L", 0.4),
    ("mouthPress_R", 0.4),
];
const LIPS_UP: &[Part] = &[
    ("mouthUpperUp_L", 0.7),
    ("mouthUpperUp_R", 0.7),
    ("mouthShrugUpper", 0.6),
    ("noseSneer_L", 0.4),
    ("noseSneer_R", 0.4),
];
const MOUTH_DOWN: &[Part] = &[
    ("mouthFrown_L", 1.0),
    ("mouthFrown_R", 1.0),
    ("mouthShrugLower", 0.5),
    ("mouthLowerDown_L", 0.3),
    ("mouthLowerDown_R", 0.3),
];
const MOUTH_EXTREME: &[Part] = &[
    ("jawOpen", 1.0),
    ("mouthStretch_L", 0.7),
    ("mouthStretch_R", 0.7),
    ("mouthLowerDown_L", 0.6),
    ("mouthLowerDown_R", 0.6),
    ("mouthUpperUp_L", 0.4),
    ("mouthUpperUp_R", 0.4),
    ("browInnerUp_L", 0.3),
    ("browInnerUp_R", 0.3),
];
const MOUTH_MIDDLE: &[Part] = &[
    ("mouthFunnel", 0.8),
    ("mouthPucker", 0.4),
    ("jawOpen", 0.25),
];
const MOUTH_OPEN: &[Part] = &[
    ("jawOpen", 0.8),
    ("mouthLowerDown_L", 0.3),
    ("mouthLowerDown_R", 0.3),
];
const MOUTH_SIDE_LEFT: &[Part] = &[("mouthLeft", 1.0), ("jawLeft", 0.4), ("mouthPress_L", 0.3)];
const MOUTH_SIDE_RIGHT: &[Part] = &[
    ("mouthRight", 1.0),
    ("jawRight", 0.4),
    ("mouthPress_R", 0.3),
];
const MOUTH_UP: &[Part] = &[
    ("mouthShrugLower", 0.9),
    ("mouthShrugUpper", 0.5),
    ("mouthPress_L", 0.4),
    ("mouthPress_R", 0.4),
    ("mouthClose", 0.2),
];

/// Each label's variants (in [`LABELS`] order); a sequence plays one, drawn uniformly.
pub const PATTERNS: [&[&[Part]]; 12] = [
    &[BARETEETH],
    &[CHEEKS_IN],
    &[EYEBROW],
    &[HIGH_SMILE],
    &[LIPS_BACK],
    &[LIPS_UP],
    &[MOUTH_DOWN],
    &[MOUTH_EXTREME],
    &[MOUTH_MIDDLE],
    &[MOUTH_OPEN],
    &[MOUTH_SIDE_LEFT, MOUTH_SIDE_RIGHT],
    &[MOUTH_UP],
];

/// The index of `label` in [`LABELS`].
pub fn label_index(label: &str) -> Option<usize> {
    LABELS.iter().position(|l| *l == label)
}

/// Every delta some pattern uses, sorted and without repeats (the deltas a motion set stores).
pub fn used_expressions() -> Vec<&'static str> {
    let mut names: Vec<&'static str> = PATTERNS
        .iter()
        .flat_map(|variants| variants.iter())
        .flat_map(|parts| parts.iter().map(|(name, _)| *name))
        .collect();
    names.sort_unstable();
    names.dedup();
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_share_deltas_but_no_two_are_equal() {
        let used = used_expressions();
        assert!(used.len() > 20 && used.len() <= 53, "{} deltas", used.len());
        // Every class shares at least one delta with another class.
        for (a, pa) in PATTERNS.iter().enumerate() {
            let names = |p: &[&[Part]]| -> Vec<&str> {
                p.iter().flat_map(|v| v.iter().map(|x| x.0)).collect()
            };
            let mine = names(pa);
            let shared = PATTERNS
                .iter()
                .enumerate()
                .any(|(b, pb)| b != a && names(pb).iter().any(|n| mine.contains(n)));
            assert!(shared, "{} shares no delta", LABELS[a]);
            for pb in &PATTERNS[a + 1..] {
                assert_ne!(pa, pb);
            }
        }
        assert_eq!(label_index("mouth_open"), Some(9));
        assert_eq!(label_index("smile"), None);
    }
}
