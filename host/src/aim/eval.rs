//! Accuracy of a baked actor, measured through `sinew-core` playback: each training shape is
//! posed with its learned jaw transform and a one-hot coefficient vector (AIM eq. 17) and
//! compared with the ground-truth mesh, per vertex, in millimetres.

use serde::Serialize;
use sinew_core::FormatError;
use sinew_core::aim::AimActor;

use super::ErrorStats;
use super::model::IDENTITY_9D;

/// Why a baked actor could not be measured.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// The artefact lacks a valid `train.jaw` section (the learned jaw transforms).
    #[error("train.jaw")]
    TrainJaw(#[source] FormatError),
    /// Measuring needs the learned jaw transforms, which the artefact lacks.
    #[error("the model carries no training poses: train.jaw")]
    NoTrainingPoses(#[source] FormatError),
    /// Ground truth with another shape count than the model.
    #[error("the model has {model} shapes, the data {data}")]
    ShapeCount {
        /// The model's shapes (neutral included).
        model: usize,
        /// The data's shapes.
        data: usize,
    },
    /// The core refused to pose a training shape (its learned jaw transform is degenerate or out
    /// of range).
    #[error("training shape {shape}")]
    Pose {
        /// The shape's index (0 = neutral).
        shape: usize,
        /// What the core said.
        #[source]
        source: sinew_core::EvalError,
    },
    /// A ground-truth shape with another vertex count than the model.
    #[error("shape {shape} has {vertices} vertices, the model {model}")]
    VertexCount {
        /// The shape's name.
        shape: String,
        /// Its vertices.
        vertices: usize,
        /// The model's vertices.
        model: usize,
    },
}

/// Per-shape and overall errors.
#[derive(Clone, Debug, Serialize)]
pub struct ShapeErrors {
    /// Over all shapes and vertices.
    pub overall: ErrorStats,
    /// Per shape, in the actor's shape order (neutral first).
    pub per_shape: Vec<(String, ErrorStats)>,
    /// Per vertex, the mean error over shapes (mm), for heatmaps.
    pub per_vertex_mean: Vec<f32>,
    /// Per vertex, the error in each shape (mm), shape-major.
    pub per_shape_vertex: Vec<Vec<f32>>,
}

/// The learned jaw transform of every training shape, neutral (identity) first.
pub fn training_poses(actor: &AimActor<'_>) -> Result<Vec<[f32; 9]>, EvalError> {
    let m = actor.shape_count();
    let jaw = actor
        .file()
        .f32_tensor("train.jaw", &[m as u32, 9])
        .map_err(EvalError::TrainJaw)?;
    let mut poses = vec![IDENTITY_9D];
    for i in 0..m {
        poses.push(std::array::from_fn(|j| jaw.at(9 * i + j)));
    }
    Ok(poses)
}

/// The angle of a 9D transform's rotation (as the core builds it), in degrees.
pub fn rotation_degrees(transform: &[f32; 9]) -> f64 {
    let [r0, r1, r2, r3, r4, r5, ..] = *transform;
    let r = sinew_core::rotation::from_6d(&[r0, r1, r2, r3, r4, r5]);
    let trace = f64::from(r.cols[0].x) + f64::from(r.cols[1].y) + f64::from(r.cols[2].z);
    ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Poses training shape `i` (0 = neutral) through the core.
///
/// # Errors
/// [`EvalError::Pose`] if the core refuses the learned jaw transform `jaw` (the buffers' sizes
/// come from the actor itself).
pub fn pose_training_shape(
    actor: &AimActor<'_>,
    jaw: &[f32; 9],
    i: usize,
) -> Result<Vec<f32>, EvalError> {
    let mut w = vec![0.0; actor.shape_count()];
    if i > 0 {
        w[i - 1] = 1.0;
    }
    let refused = |source| EvalError::Pose { shape: i, source };
    let pose = actor
        .pose_from_9d(jaw, &IDENTITY_9D)
        .map_err(|e| refused(e.into()))?;
    let mut out = vec![0.0; 3 * actor.vertex_count()];
    actor.pose(&pose, &w, &mut out).map_err(refused)?;
    Ok(out)
}

/// Errors of the baked `actor` against `shapes` (neutral first, the training order).
pub fn shape_errors(
    actor: &AimActor<'_>,
    names: &[String],
    shapes: &[Vec<[f32; 3]>],
    mm_per_unit: f32,
) -> Result<ShapeErrors, EvalError> {
    if shapes.len() != actor.shape_count() + 1 {
        return Err(EvalError::ShapeCount {
            model: actor.shape_count() + 1,
            data: shapes.len(),
        });
    }
    let poses = training_poses(actor).map_err(|e| match e {
        EvalError::TrainJaw(source) => EvalError::NoTrainingPoses(source),
        other => other,
    })?;
    let v = actor.vertex_count();
    let mut all = Vec::with_capacity(v * shapes.len());
    let mut per_shape = Vec::new();
    let mut per_vertex_sum = vec![0.0f32; v];
    let mut per_shape_vertex = Vec::new();
    for (i, (gt, name)) in shapes.iter().zip(names).enumerate() {
        if gt.len() != v {
            return Err(EvalError::VertexCount {
                shape: name.clone(),
                vertices: gt.len(),
                model: v,
            });
        }
        let posed = pose_training_shape(actor, &poses[i], i)?;
        let errs: Vec<f32> = gt
            .iter()
            .zip(posed.chunks_exact(3))
            .map(|(g, p)| {
                ((g[0] - p[0]).powi(2) + (g[1] - p[1]).powi(2) + (g[2] - p[2]).powi(2)).sqrt()
                    * mm_per_unit
            })
            .collect();
        for (s, e) in per_vertex_sum.iter_mut().zip(&errs) {
            *s += e;
        }
        per_shape.push((
            name.clone(),
            ErrorStats::of(errs.iter().map(|&e| f64::from(e)).collect()),
        ));
        all.extend(errs.iter().map(|&e| f64::from(e)));
        per_shape_vertex.push(errs);
    }
    let n = shapes.len() as f32;
    Ok(ShapeErrors {
        overall: ErrorStats::of(all),
        per_shape,
        per_vertex_mean: per_vertex_sum.iter().map(|s| s / n).collect(),
        per_shape_vertex,
    })
}

/// The learned jaw skinning weight k where it should be 1 and where it should be 0.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SkinningWeightMeans {
    /// Mean k over the jaw-constrained vertices (the skin over the mandible; ideally near 1).
    pub jaw: f64,
    /// Mean k over the forehead region c* of eq. 15 (ideally 0).
    pub forehead: f64,
}

impl SkinningWeightMeans {
    /// The means of `k` (one value per template vertex of `set`; vertices beyond `k` are
    /// skipped) over the set's jaw-constrained vertices and its forehead; 0 for an empty region.
    pub fn of(k: &[f32], set: &super::TrainingSet) -> Self {
        let mean = |idx: &[u32]| {
            let vals: Vec<f64> = idx
                .iter()
                .filter_map(|&i| k.get(i as usize).map(|&v| f64::from(v)))
                .collect();
            vals.iter().sum::<f64>() / vals.len().max(1) as f64
        };
        Self {
            jaw: mean(&set.jaw_constrained()),
            forehead: mean(&set.forehead),
        }
    }
}

/// How far the learned thickness is from the bone constraints, in mm, over constrained vertices.
pub fn thickness_deviation(
    actor: &AimActor<'_>,
    anchors: &[Option<super::Anchor>],
    mm_per_unit: f32,
) -> ErrorStats {
    let d = actor.thickness();
    ErrorStats::of(
        anchors
            .iter()
            .enumerate()
            .filter_map(|(i, a)| a.map(|a| f64::from((d.at(i) - a.thickness).abs() * mm_per_unit)))
            .collect(),
    )
}
