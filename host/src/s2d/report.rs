//! The reports of `train s2d` and `eval s2d`: error statistics per method, per fold and per
//! held-out shape or identity, and the cumulative-error plot (S2D Fig. 3).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::objective::{Objective, TrainConfig};
use super::protocol::Protocol;
use super::protocol::Split;
/// Mean and standard deviation of per-vertex errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Mean per-vertex error (mm).
    pub mean_error_mm: f64,
    /// Standard deviation of the per-vertex error (mm).
    pub std_error_mm: f64,
    /// Components (PCA) or atoms (DL-3DMM) used, baselines only; in a pooled entry, only when
    /// all folds agree.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub components: Option<usize>,
}

impl ErrorStats {
    pub(crate) fn of(errors: &[f32], components: Option<usize>) -> Self {
        let n = errors.len().max(1) as f64;
        let mean = errors.iter().map(|&e| f64::from(e)).sum::<f64>() / n;
        let var = errors
            .iter()
            .map(|&e| (f64::from(e) - mean).powi(2))
            .sum::<f64>()
            / n;
        Self {
            mean_error_mm: mean,
            std_error_mm: var.sqrt(),
            components,
        }
    }
}

/// The 3DMM baselines of Table 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Baselines {
    /// PCA with the components that explain 99% of the training variance.
    pub pca99: ErrorStats,
    /// PCA with min(220, rank) components.
    pub pca_max: ErrorStats,
    /// DL-3DMM, a dictionary of 220 sparse-coded atoms ([`Dictionary`](super::baseline::Dictionary)); its count is the atoms
    /// the training codes use.
    pub dl_3dmm: ErrorStats,
    /// Not a method but a bound: the test displacements' orthogonal projection onto the
    /// training displacements' affine span ([`Pca::project`](super::baseline::Pca::project), all `rank` components, reading
    /// the whole dense ground truth). It is the least-squares closest displacement any model
    /// built from that span (the three above) can give, so their errors do not go below it
    /// (strictly so for the root-mean-square error; the mean per-vertex error is a different
    /// norm).
    pub span_floor: ErrorStats,
}

/// Per-vertex errors (mm) on a split's test pairs of the baselines, with their component
/// (atom) counts, and of the training span's floor ([`Baselines::span_floor`]).
#[derive(Clone, Debug)]
pub struct BaselineErrors {
    /// PCA, 99% of the variance.
    pub pca99: (Vec<f32>, usize),
    /// PCA, min(220, rank) components.
    pub pca_max: (Vec<f32>, usize),
    /// DL-3DMM, atoms used.
    pub dl_3dmm: (Vec<f32>, usize),
    /// The training span's floor, and the span's dimension (the PCA's rank).
    pub span_floor: (Vec<f32>, usize),
}

/// One fold's results.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FoldReport {
    /// The fold.
    pub fold: usize,
    /// Held-out identities (indices) or expression shapes (names).
    pub held_out: Vec<String>,
    /// Training pairs.
    pub train_pairs: usize,
    /// Test pairs.
    pub test_pairs: usize,
    /// S2D-Dec on the test pairs.
    pub s2d: ErrorStats,
    /// The baselines on the same split.
    pub baselines: Baselines,
    /// The baked model of this fold.
    pub model: PathBuf,
    /// Mean training loss of each epoch (empty for `eval`).
    pub losses: Vec<f32>,
    /// Training time (s), over every invocation when the fold was resumed.
    pub train_seconds: f64,
    /// Each held-out shape (expression split) or identity (identity split), with the errors on
    /// the test pairs that involve it (absent from reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_held_out: Vec<HeldOutErrors>,
    /// Mirror images of training pairs added to the training set, of S2D-Dec and of every
    /// baseline (`train s2d --mirror`; absent when none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub mirrored_pairs: usize,
}

pub(crate) fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The errors on the test pairs of a fold that involve one held-out expression shape (every pair
/// that combines it with others of its group) or identity: the mean per-vertex error (mm) over
/// those pairs' vertices, for S2D-Dec and each baseline (0 when no test pair involves it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeldOutErrors {
    /// The shape's name or the identity's index.
    pub held_out: String,
    /// Test pairs that involve it.
    pub pairs: usize,
    /// S2D-Dec.
    pub s2d_mm: f64,
    /// PCA, 99% of the variance.
    pub pca99_mm: f64,
    /// PCA, min(220, rank) components.
    pub pca_max_mm: f64,
    /// DL-3DMM.
    pub dl_3dmm_mm: f64,
}

/// [`HeldOutErrors`] of every held-out item of `s`; `involves(p, item)` says whether pair `p`
/// involves it, and `errors` are per-vertex errors of S2D-Dec, pca99, pca_max and DL-3DMM on
/// the test pairs in order, `vertices` a pair.
pub(crate) fn per_held_out(
    s: &Split,
    involves: impl Fn(usize, &str) -> bool,
    vertices: usize,
    errors: [&[f32]; 4],
) -> Vec<HeldOutErrors> {
    s.held_out
        .iter()
        .map(|item| {
            let pairs: Vec<usize> = (0..s.test.len())
                .filter(|&i| involves(s.test[i], item))
                .collect();
            let mean = |e: &[f32]| {
                let sum: f64 = pairs
                    .iter()
                    .flat_map(|&i| &e[i * vertices..(i + 1) * vertices])
                    .map(|&x| f64::from(x))
                    .sum();
                sum / (pairs.len() * vertices).max(1) as f64
            };
            HeldOutErrors {
                held_out: item.clone(),
                pairs: pairs.len(),
                s2d_mm: mean(errors[0]),
                pca99_mm: mean(errors[1]),
                pca_max_mm: mean(errors[2]),
                dl_3dmm_mm: mean(errors[3]),
            }
        })
        .collect()
}

/// The report of `train s2d` / `eval s2d`: the folds pooled (every test vertex of every fold),
/// then each fold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The protocol.
    pub protocol: Protocol,
    /// Folds run.
    pub folds: usize,
    /// Test pairs over all folds run.
    pub test_pairs: usize,
    /// S2D-Dec mean per-vertex error (mm).
    pub mean_error_mm: f64,
    /// S2D-Dec standard deviation (mm).
    pub std_error_mm: f64,
    /// Baselines, pooled the same way.
    pub baselines: Baselines,
    /// Each fold.
    pub per_fold: Vec<FoldReport>,
    /// The training configuration (absent for `eval`).
    pub train: Option<TrainConfig>,
    /// The objective.
    pub objective: Option<Objective>,
    /// The data set folder.
    pub pairs: PathBuf,
    /// The cumulative-error plot written beside the report.
    pub plot: PathBuf,
    /// Wall time (s).
    pub seconds: f64,
}

/// The cumulative per-vertex error curves (S2D Fig. 3): for each method, the percentage of
/// vertices with an error at most x mm, x from 0 to the largest 99th percentile.
pub fn cumulative_plot(methods: &[(&str, &[f32])], title: &str) -> crate::figures::render::Image {
    let sorted: Vec<Vec<f32>> = methods
        .iter()
        .map(|(_, e)| {
            let mut v = e.to_vec();
            v.sort_by(f32::total_cmp);
            v
        })
        .collect();
    let x_max = sorted
        .iter()
        .filter(|v| !v.is_empty())
        .map(|v| f64::from(v[(v.len() - 1) * 99 / 100]))
        .fold(0.0f64, f64::max)
        .max(1e-3);
    let curves: Vec<Vec<(f64, f64)>> = sorted
        .iter()
        .map(|v| {
            (0..=200)
                .map(|i| {
                    let x = x_max * f64::from(i) / 200.0;
                    let below = v.partition_point(|&e| f64::from(e) <= x);
                    (x, 100.0 * below as f64 / v.len().max(1) as f64)
                })
                .collect()
        })
        .collect();
    let series: Vec<(&str, &[(f64, f64)])> = methods
        .iter()
        .zip(&curves)
        .map(|((name, _), c)| (*name, c.as_slice()))
        .collect();
    crate::figures::plot::line_plot(
        &series,
        title,
        "per-vertex error (mm)",
        "% of vertices",
        false,
        720,
        480,
    )
}
