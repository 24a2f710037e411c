//! What S2D-Dec learns from and for (S2D §3.2, §4.2): the landmark input normalisation, the
//! landmark-distance vertex weights, both loss variants, the training configuration and a training
//! sample. The training loop is [`super::train`]; its checkpoints ([`super::checkpoint`]) record
//! the configuration.

use burn::tensor::Tensor;
use serde::{Deserialize, Serialize};

use super::decoder::InputNormalisation;
use crate::training::adam::Adam;

/// Centres a landmark set on its mean and scales it to unit Frobenius norm (the reference's
/// per-set normalisation). A set with zero norm (all points equal) is only centred.
pub fn normalise_landmarks(points: &[[f32; 3]]) -> Vec<[f32; 3]> {
    // The mean as a sum of p / n (not [`centred`]'s sum / n): the rounding every decoder
    // trained with this normalisation has seen, so that earlier runs reproduce bit for bit.
    let n = points.len().max(1) as f64;
    let mut centre = [0.0f64; 3];
    for p in points {
        for i in 0..3 {
            centre[i] += f64::from(p[i]) / n;
        }
    }
    let centred: Vec<[f64; 3]> = points
        .iter()
        .map(|p| [0, 1, 2].map(|i| f64::from(p[i]) - centre[i]))
        .collect();
    let norm = centred.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
    let scale = if norm > 0.0 { 1.0 / norm } else { 1.0 };
    centred
        .iter()
        .map(|p| p.map(|v| (v * scale) as f32))
        .collect()
}

/// A landmark set less its mean (the sum over n), in f64.
fn centred(points: &[[f32; 3]]) -> Vec<[f64; 3]> {
    let n = points.len().max(1) as f64;
    let centre = [0, 1, 2].map(|i| points.iter().map(|p| f64::from(p[i])).sum::<f64>() / n);
    points
        .iter()
        .map(|p| [0, 1, 2].map(|i| f64::from(p[i]) - centre[i]))
        .collect()
}

/// The decoder's input, flattened `x1, y1, z1, x2, …`: with [`InputNormalisation::Frobenius`]
/// `normalise(expressive) − normalise(neutral)` (S2D §3.2), with
/// Landmarks that give no decoder input or no vertex weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum LandmarkError {
    /// A neutral and an expressive set of different sizes.
    #[error("{neutral} neutral landmarks but {expressive} expressive ones")]
    Counts {
        /// The neutral's landmarks.
        neutral: usize,
        /// The expressive face's.
        expressive: usize,
    },
    /// No landmark vertices.
    #[error("no landmark vertices")]
    Empty,
    /// A landmark vertex past the template's last vertex.
    #[error("landmark vertex {vertex} is outside the template ({vertices} vertices)")]
    Outside {
        /// The landmark's vertex.
        vertex: u32,
        /// The template's vertices.
        vertices: usize,
    },
}

/// [`InputNormalisation::NeutralScale`] `(centred(expressive) − centred(neutral)) /
/// ‖centred(neutral)‖`. Computed in f64.
pub fn landmark_input(
    normalisation: InputNormalisation,
    neutral: &[[f32; 3]],
    expressive: &[[f32; 3]],
) -> Result<Vec<f32>, LandmarkError> {
    if neutral.len() != expressive.len() {
        return Err(LandmarkError::Counts {
            neutral: neutral.len(),
            expressive: expressive.len(),
        });
    }
    if normalisation == InputNormalisation::NeutralScale {
        let (n, e) = (centred(neutral), centred(expressive));
        let norm = n.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
        let scale = if norm > 0.0 { norm } else { 1.0 };
        return Ok(n
            .iter()
            .zip(&e)
            .flat_map(|(a, b)| [0, 1, 2].map(|i| ((b[i] - a[i]) / scale) as f32))
            .collect());
    }
    let (n, e) = (
        normalise_landmarks(neutral),
        normalise_landmarks(expressive),
    );
    Ok(n.iter()
        .zip(&e)
        .flat_map(|(a, b)| [0, 1, 2].map(|i| b[i] - a[i]))
        .collect())
}

/// Distance of every template vertex to its nearest landmark vertex.
pub fn landmark_distances(
    template: &[[f32; 3]],
    landmarks: &[u32],
) -> Result<Vec<f32>, LandmarkError> {
    if landmarks.is_empty() {
        return Err(LandmarkError::Empty);
    }
    let lm: Vec<[f32; 3]> = landmarks
        .iter()
        .map(|&i| {
            template
                .get(i as usize)
                .copied()
                .ok_or(LandmarkError::Outside {
                    vertex: i,
                    vertices: template.len(),
                })
        })
        .collect::<Result<_, _>>()?;
    Ok(template
        .iter()
        .map(|p| {
            lm.iter()
                .map(|q| {
                    let d = [0, 1, 2].map(|i| p[i] - q[i]);
                    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                })
                .fold(f32::INFINITY, f32::min)
        })
        .collect())
}

/// Which S2D objective to train with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum LossVariant {
    /// The authors' code (which produced the published numbers): `mean_{batch, xyz} Σ_v w_v |e_v|
    /// + 0.1 · mean |e|`, `w_v = 1 − d_v / max d` (1 at landmarks).
    #[default]
    Code,
    /// The paper's text: `L_S2D = β1 L_dr + β2 L_pr` with β1 = 1, β2 = 0.1 (eqs. 6–7), `w_v =
    /// 1/d_v` rescaled to [0, 1] (landmark vertices get the maximum).
    Paper,
}

/// The per-vertex weights `w_v` of `variant` from the distances to the nearest landmark.
///
/// - Code: `1 − (d − min d)/(max d − min d)`.
/// - Paper: `u_v = 1/d_v`, with landmark vertices (`d = 0`) given the largest `u` of the others,
///   then min–max rescaled to [0, 1].
///
/// All weights are 1 when every distance is equal.
pub fn vertex_weights(variant: LossVariant, distances: &[f32]) -> Vec<f32> {
    let rescale = |u: &[f32]| {
        let lo = u.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = u.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        (hi > lo).then(|| u.iter().map(|v| (v - lo) / (hi - lo)).collect::<Vec<f32>>())
    };
    let weights = match variant {
        LossVariant::Code => rescale(distances).map(|r| r.iter().map(|v| 1.0 - v).collect()),
        LossVariant::Paper => {
            let top = distances
                .iter()
                .filter(|&&d| d > 0.0)
                .map(|d| 1.0 / d)
                .fold(0.0f32, f32::max);
            let inverse: Vec<f32> = distances
                .iter()
                .map(|&d| if d > 0.0 { 1.0 / d } else { top })
                .collect();
            rescale(&inverse)
        }
    };
    weights.unwrap_or_else(|| vec![1.0; distances.len()])
}

/// The S2D objective on a batch of displacements.
///
/// The position error of the prediction `neutral + D^g` against `S^gt = neutral + D^gt` equals the
/// displacement error `e = D^g − D^gt`, so both terms read `e`.
///
/// # Shapes
/// - `predicted`, `target`: `[batch, vertices, 3]`
/// - `weights`: `[1, vertices, 1]`
/// - output: `[1]`
pub fn loss(
    variant: LossVariant,
    predicted: Tensor<3>,
    target: Tensor<3>,
    weights: Tensor<3>,
) -> Tensor<1> {
    let [batch, vertices, xyz] = predicted.dims();
    let e = predicted.sub(target).abs();
    match variant {
        // Reference code: mean over batch and xyz of Σ_v w_v |e| + 0.1 · mean |e|.
        LossVariant::Code => {
            let weighted = e
                .clone()
                .mul(weights)
                .sum()
                .div_scalar((batch * xyz) as f64);
            weighted + e.mean().mul_scalar(0.1)
        }
        // S2D eqs. 6–7: L_dr = 1/N Σ ||e_i||_1, L_pr = 1/N Σ w_i ||e_i||_1 (batch-averaged);
        // L_S2D = 1 · L_dr + 0.1 · L_pr.
        LossVariant::Paper => {
            let n = (batch * vertices) as f64;
            let dr = e.clone().sum().div_scalar(n);
            let pr = e.mul(weights).sum().div_scalar(n);
            dr + pr.mul_scalar(0.1)
        }
    }
}

/// Training hyper-parameters (the reference's defaults).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// Epochs (300).
    pub epochs: usize,
    /// Samples per batch (16).
    pub batch: usize,
    /// Initial learning rate (1e-3).
    pub lr: f64,
    /// Learning-rate factor per 300 epochs' worth of epochs (0.99: ×0.99^(300/epochs) per epoch,
    /// so that a shorter run ends at the same rate as the reference's 300).
    pub lr_decay: f64,
    /// L2 penalty added to the gradient, as PyTorch's `Adam(weight_decay=…)` (5e-5).
    pub weight_decay: f32,
    /// The objective.
    pub loss: LossVariant,
    /// Seed of the weights and of the shuffling.
    pub seed: u64,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            epochs: 300,
            batch: 16,
            lr: 1e-3,
            lr_decay: 0.99,
            weight_decay: 5e-5,
            loss: LossVariant::Code,
            seed: 42,
        }
    }
}

impl TrainConfig {
    /// Learning rate of `epoch` (0-based): `lr · lr_decay^(epoch · 300 / epochs)`.
    pub fn lr_at(&self, epoch: usize) -> f64 {
        self.lr
            * self
                .lr_decay
                .powf(epoch as f64 * 300.0 / self.epochs.max(1) as f64)
    }

    /// Adam as PyTorch configures it for S2D (β = (0.9, 0.999), ε = 1e-8, L2 weight decay added
    /// to the gradient — burn's `WeightDecay` adds `penalty · θ`, as PyTorch's `Adam` does, not
    /// AdamW's decoupled decay).
    pub fn optimizer(&self) -> Adam {
        Adam::new(1e-8).with_weight_decay(self.weight_decay)
    }

    pub(crate) fn validate(&self) -> Result<(), InvalidTrainConfig> {
        if !(self.epochs > 0 && self.batch > 0) {
            return Err(InvalidTrainConfig::Run);
        }
        if !(self.lr > 0.0 && self.lr_decay > 0.0 && self.weight_decay >= 0.0) {
            return Err(InvalidTrainConfig::Rates);
        }
        Ok(())
    }
}

/// The range rule of [`TrainConfig`] a configuration breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidTrainConfig {
    /// `epochs` or `batch` is 0.
    #[error("epochs and batch must be positive")]
    Run,
    /// The learning rate or its decay is not positive, or the weight decay is negative.
    #[error("learning rate, decay and weight decay must be positive")]
    Rates,
}

/// One training sample: the decoder's input and the ground-truth dense displacement.
#[derive(Clone, Debug)]
pub struct Sample {
    /// Normalised landmark displacement, `[inputs]` ([`landmark_input`]).
    pub input: Vec<f32>,
    /// Ground-truth displacement `S^gt − neutral`, `[vertices · 3]`.
    pub displacement: Vec<f32>,
}

/// The training objective, including Table 2's ablations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Objective {
    /// The authors' code (the published numbers): weighted sum + 0.1 · mean (Table 2's S3 as
    /// the code has it).
    #[default]
    Code,
    /// The paper's text: L_dr + 0.1 · L_pr with the 1/d weights (S3 as the paper writes it).
    Paper,
    /// Table 2's S1: L_dr alone (the paper's loss with every vertex weight 0).
    Dr,
    /// Table 2's S2: L_dr + 0.1 · L_pr without distance weights (every vertex weight 1).
    DrUnweighted,
}

impl Objective {
    /// The trainer's loss and the vertex weights it takes, from the landmark distances.
    pub fn loss_and_weights(self, distances: &[f32]) -> (LossVariant, Vec<f32>) {
        match self {
            Self::Code => (
                LossVariant::Code,
                vertex_weights(LossVariant::Code, distances),
            ),
            Self::Paper => (
                LossVariant::Paper,
                vertex_weights(LossVariant::Paper, distances),
            ),
            Self::Dr => (LossVariant::Paper, vec![0.0; distances.len()]),
            Self::DrUnweighted => (LossVariant::Paper, vec![1.0; distances.len()]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_names_the_broken_rule() {
        assert_eq!(TrainConfig::default().validate(), Ok(()));
        let no_epochs = TrainConfig {
            epochs: 0,
            ..TrainConfig::default()
        };
        assert_eq!(no_epochs.validate(), Err(InvalidTrainConfig::Run));
        let no_lr = TrainConfig {
            lr: 0.0,
            ..TrainConfig::default()
        };
        assert_eq!(no_lr.validate(), Err(InvalidTrainConfig::Rates));
    }
}
