//! The exported morph targets' names: the actor's own (`--names actor`), or ARKit's spelling
//! (`--names arkit`), so that an engine's ARKit retargeting binds by name.
//!
//! With ARKit's names, a shape whose name compares equal to an ARKit blendshape's
//! (`io::arkit::comparable`: `mouthSmile_L` and `mouthSmileLeft`) takes ARKit's spelling. A
//! blendshape ARKit does not split by side but the actor does (`browInnerUp`, `cheekPuff`: the
//! kit learns `browInnerUp_L` and `browInnerUp_R`) gets one more target under ARKit's name, the
//! sum of the sides, so that the one ARKit channel moves what `sinew play --arkit` moves for it;
//! the sided targets keep their names. Shapes ARKit does not know keep theirs.

use crate::io::arkit::{arkit_bindings, comparable};

/// How the morph targets are named.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Names {
    /// The actor's shape names (metadata `shapes`), as it learned them.
    #[default]
    Actor,
    /// ARKit's blendshape names where a shape is one of ARKit's.
    Arkit,
}

/// The morph targets of an export.
#[derive(Clone, Debug, PartialEq)]
pub struct Targets {
    /// One name per corrective shape, in the actor's order.
    pub names: Vec<String>,
    /// Targets after the actor's shapes: a name and the shapes whose correctives it sums.
    pub combined: Vec<(String, Vec<usize>)>,
}

impl Targets {
    /// The targets for an actor whose corrective shapes are named `shapes`.
    pub fn of(shapes: &[String], style: Names) -> Self {
        let mut names = shapes.to_vec();
        let mut combined = Vec::new();
        if style == Names::Arkit {
            let mut renamed = vec![false; shapes.len()];
            for (arkit, bound) in arkit_bindings(shapes) {
                match bound.as_slice() {
                    [] => {}
                    &[j] if comparable(&shapes[j]) == comparable(&arkit) && !renamed[j] => {
                        names[j] = arkit;
                        renamed[j] = true;
                    }
                    _ => combined.push((arkit, bound)),
                }
            }
        }
        Self { names, combined }
    }

    /// Every target's name: the shapes', then the combined ones'.
    pub fn all_names(&self) -> Vec<String> {
        self.names
            .iter()
            .cloned()
            .chain(self.combined.iter().map(|(n, _)| n.clone()))
            .collect()
    }

    /// The number of targets.
    pub fn len(&self) -> usize {
        self.names.len() + self.combined.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kit_names_take_arkit_spelling_and_unsplit_shapes_are_combined() {
        let shapes: Vec<String> = [
            "jawOpen",
            "mouthSmile_L",
            "blendShape1.eyeBlink_Right",
            "browInnerUp_L",
            "browInnerUp_R",
            "cheekPuff_L",
            "frown",
        ]
        .map(String::from)
        .to_vec();
        let t = Targets::of(&shapes, Names::Arkit);
        assert_eq!(
            t.names,
            [
                "jawOpen",
                "mouthSmileLeft",
                "eyeBlinkRight",
                "browInnerUp_L",
                "browInnerUp_R",
                "cheekPuff_L",
                "frown"
            ]
        );
        assert_eq!(
            t.combined,
            [
                ("browInnerUp".to_string(), vec![3, 4]),
                ("cheekPuff".to_string(), vec![5])
            ]
        );
        assert_eq!(t.len(), 9);
        let own = Targets::of(&shapes, Names::Actor);
        assert_eq!(own.names, shapes);
        assert!(own.combined.is_empty());
    }
}
