//! AIM, "Anatomically Constrained Implicit Face Models" (Chandran & Zoss 2024): the training
//! set, the five-network model, its training (eqs. 11–16), baking into the core's format and the
//! accuracy report.

pub mod arkit;
pub mod bake;
pub mod commands;
pub mod config;
pub mod data;
pub mod demo;
pub mod demo_face;
mod draw;
pub mod edit;
pub mod eval;
pub mod face_template;
pub mod model;
pub mod play;
pub mod prior;
pub mod procedural;
pub mod run;
pub mod target;
#[cfg(any(test, feature = "test-support"))]
pub mod testing;
pub mod train;

use serde::Serialize;

pub use crate::anatomy::constraints::Anchor;
pub use config::AimConfig;

/// A training set that breaks a rule of [`TrainingSet::validate`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidTrainingSet {
    /// An actor without shapes to build a set from.
    #[error("the actor has no shapes")]
    NoShapes,
    /// Fewer than two shapes: AIM needs a neutral and an expression.
    #[error("AIM needs a neutral and at least one expression, got {shapes} shapes")]
    TooFewShapes {
        /// The shapes given.
        shapes: usize,
    },
    /// Shape and name counts differ.
    #[error("{shapes} shapes but {names} names")]
    NameCount {
        /// The shapes.
        shapes: usize,
        /// The names.
        names: usize,
    },
    /// A shape with another vertex count than the template.
    #[error("shape {name} has {vertices} vertices, the template {template}")]
    ShapeVertices {
        /// The shape's name.
        name: String,
        /// Its vertices.
        vertices: usize,
        /// The template's vertices.
        template: usize,
    },
    /// Constraints of another count than the template's vertices.
    #[error("{constraints} constraints for {vertices} vertices")]
    ConstraintCount {
        /// The constraints.
        constraints: usize,
        /// The template's vertices.
        vertices: usize,
    },
    /// A forehead vertex beyond the template.
    #[error("forehead index out of range")]
    ForeheadIndex,
}

pub use crate::geometry::symmetry::Plane;

/// Everything AIM learns from: template points, the actor's shapes and the anatomy priors.
#[derive(Clone, Debug)]
pub struct TrainingSet {
    /// Template points c and their polygons (for baking, rendering and OBJ export).
    pub template: crate::io::mesh::Mesh,
    /// The N shapes, neutral first, each `[V]` points in the template's order.
    pub shapes: Vec<Vec<[f32; 3]>>,
    /// Shape names, "neutral" first.
    pub names: Vec<String>,
    /// Per template vertex, the bone constraint where one was found.
    pub anchors: Vec<Option<Anchor>>,
    /// Template vertices of the forehead region c* (eq. 15).
    pub forehead: Vec<u32>,
    /// The face's plane of symmetry (eq. 14), estimated from the neutral.
    pub symmetry: Plane,
    /// The jaw's pivot for LBS (eq. 10).
    pub jaw_pivot: [f32; 3],
    /// Length unit of all coordinates (cm for ICT-FaceKit).
    pub units: crate::io::units::Unit,
    /// Millimetres per unit (10 for cm), for reports.
    pub mm_per_unit: f32,
    /// Where the data came from, with its licence.
    pub source: String,
    /// More metadata the baked actor records (a rig's conventions, `rig`), as (key, value).
    pub provenance: Vec<(String, String)>,
}

impl TrainingSet {
    /// Number of template points V.
    pub fn vertices(&self) -> usize {
        self.template.positions.len()
    }

    /// Template vertices whose constraint lies on the jaw (the skin over the mandible), ascending.
    pub fn jaw_constrained(&self) -> Vec<u32> {
        (0..self.anchors.len() as u32)
            .filter(|&i| {
                self.anchors[i as usize]
                    .is_some_and(|a| a.on == crate::anatomy::constraints::Bone::Jaw)
            })
            .collect()
    }

    /// Fraction of template vertices with a bone constraint.
    pub fn constrained_fraction(&self) -> f64 {
        self.anchors.iter().filter(|a| a.is_some()).count() as f64
            / self.anchors.len().max(1) as f64
    }

    /// Checks the set is consistent; the error says what is wrong.
    pub fn validate(&self) -> Result<(), InvalidTrainingSet> {
        let v = self.vertices();
        if self.shapes.len() < 2 {
            return Err(InvalidTrainingSet::TooFewShapes {
                shapes: self.shapes.len(),
            });
        }
        if self.shapes.len() != self.names.len() {
            return Err(InvalidTrainingSet::NameCount {
                shapes: self.shapes.len(),
                names: self.names.len(),
            });
        }
        for (s, name) in self.shapes.iter().zip(&self.names) {
            if s.len() != v {
                return Err(InvalidTrainingSet::ShapeVertices {
                    name: name.clone(),
                    vertices: s.len(),
                    template: v,
                });
            }
        }
        if self.anchors.len() != v {
            return Err(InvalidTrainingSet::ConstraintCount {
                constraints: self.anchors.len(),
                vertices: v,
            });
        }
        if !self.forehead.iter().all(|&i| (i as usize) < v) {
            return Err(InvalidTrainingSet::ForeheadIndex);
        }
        Ok(())
    }
}

/// Per-vertex error statistics in millimetres.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ErrorStats {
    /// Mean.
    pub mean: f64,
    /// Median.
    pub median: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

impl ErrorStats {
    /// Statistics of `values` (any order).
    pub fn of(mut values: Vec<f64>) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        values.sort_by(f64::total_cmp);
        let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
        Self {
            mean: values.iter().sum::<f64>() / values.len() as f64,
            median: at(0.5),
            p95: at(0.95),
            max: at(1.0),
        }
    }
}
