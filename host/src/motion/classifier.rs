//! The sequence classifier of Table 3 (S2D section 4.3: "a classifier composed of one LSTM layer
//! and a fully connected layer", here a GRU layer, burn's `nn::Gru`, and a linear layer),
//! trained on the training sequences' landmark motions; its accuracy on a set of motions and its
//! last hidden state (the penultimate features) for the Fréchet distance.
//!
//! Every motion reaches the classifier in one form ([`sequence_features`]): each frame's
//! landmarks centred and scaled to unit Frobenius norm as the SRVF encoding does, the curve
//! resampled to `FRAMES + 1` frames equally spaced in arc length (the parametrisation in which
//! Motion3DGAN generates), and frame 0 subtracted from frames 1 to `FRAMES`: `FRAMES` steps of
//! the landmark displacement, so that a motion on any face reads the same.

use burn::module::Module;
use burn::nn::{Gru, GruConfig, Linear};
use burn::optim::GradientsParams;
use burn::tensor::activation::log_softmax;
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use sinew_core::srvf::FRAMES;

use super::labels::best_labels;
use super::srvf::{SrvfError, normalised_curve};
use crate::training::adam::Adam;
use crate::training::nn::{pytorch_linear, tensor, to_vec};
use crate::training::random::Stream;

/// A landmark sequence (frames `[K · 3]`, at least 2, moving) as the classifier and the LSTM
/// baseline read it: `[FRAMES × K · 3]`, row t − 1 the normalised, arc-length-resampled frame t
/// less frame 0.
///
/// # Errors
/// As [`super::srvf::encode`]: too few frames, frames of different shapes, degenerate frames, or
/// landmarks that do not move.
pub fn sequence_features(frames: &[&[f32]]) -> Result<Vec<f32>, SrvfError> {
    let (curve, _) = normalised_curve(frames)?;
    let first = &curve[0];
    Ok(curve[1..]
        .iter()
        .flat_map(|c| c.iter().zip(first).map(|(a, b)| (a - b) as f32))
        .collect())
}

/// Settings of a sequence model's training (the classifier's and the LSTM baseline's).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SequenceTraining {
    /// Seed of the weights and the batch order.
    pub seed: u64,
    /// Passes over the training sequences.
    pub epochs: usize,
    /// Sequences per batch.
    pub batch: usize,
    /// Adam's learning rate.
    pub lr: f64,
    /// Width of the recurrent layer.
    pub hidden: usize,
}

/// The order of the sequences in each batch of `epoch`: a Fisher–Yates shuffle of `0..n` by a
/// PCG-64 seeded by (seed, epoch) alone, cut into batches of `batch`.
pub fn batches(n: usize, batch: usize, seed: u64, epoch: usize) -> Vec<Vec<usize>> {
    let mut rng = Stream::seed_from_u64(
        seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (epoch as u64).wrapping_add(0x5ec1),
    );
    let mut order: Vec<usize> = (0..n).collect();
    rng.shuffle(&mut order);
    order.chunks(batch.max(1)).map(<[usize]>::to_vec).collect()
}

/// `1 / RMS` of every value of `seqs` (1 if they are all 0): the scale that brings the
/// displacements, a few hundredths of the unit-norm frame, to unit size for the networks.
pub fn unit_scale(seqs: &[Vec<f32>]) -> f32 {
    let (sum, count) = seqs.iter().flatten().fold((0.0f64, 0usize), |(s, c), &x| {
        (s + f64::from(x) * f64::from(x), c + 1)
    });
    let rms = (sum / count.max(1) as f64).sqrt();
    if rms > 0.0 { (1.0 / rms) as f32 } else { 1.0 }
}

/// The rows `rows` of `seqs` (each `[frames × d]`) as one tensor.
///
/// # Shapes
/// → `[rows.len(), frames, d]`
pub fn stack(seqs: &[Vec<f32>], rows: &[usize], frames: usize, device: &Device) -> Tensor<3> {
    let d = seqs.first().map_or(0, |s| s.len() / frames.max(1));
    let values: Vec<f32> = rows.iter().flat_map(|&r| seqs[r].iter().copied()).collect();
    tensor(values, [rows.len(), frames, d], device)
}

/// The classifier: a GRU over the frames, its last hidden state the features, a linear layer to
/// the class scores.
#[derive(Module, Debug)]
pub struct Classifier {
    /// The recurrent layer.
    pub gru: Gru,
    /// Hidden state → class scores.
    pub fc: Linear,
    /// The input scale ([`unit_scale`] of the training sequences).
    #[module(skip)]
    pub scale: f32,
}

impl Classifier {
    /// A fresh classifier of `inputs` values per frame (seed the device first).
    pub fn new(inputs: usize, hidden: usize, classes: usize, scale: f32, device: &Device) -> Self {
        Self {
            gru: GruConfig::new(inputs, hidden, true).init(device),
            fc: pytorch_linear(hidden, classes, device),
            scale,
        }
    }

    /// Class scores and features (the last hidden state).
    ///
    /// # Shapes
    /// - x: `[n, frames, inputs]`
    /// - scores: `[n, classes]`; features: `[n, hidden]`
    pub fn forward(&self, x: Tensor<3>) -> (Tensor<2>, Tensor<2>) {
        let [n, frames, _] = x.dims();
        let h = self.gru.forward(x.mul_scalar(self.scale as f64), None);
        let hidden = h.dims()[2];
        let last: Tensor<2> = h.narrow(1, frames - 1, 1).reshape([n, hidden]);
        (self.fc.forward(last.clone()), last)
    }

    /// The predicted class and the features of each sequence (`[FRAMES × inputs]` each), in
    /// chunks of 256.
    pub fn predict(&self, seqs: &[Vec<f32>], device: &Device) -> (Vec<usize>, Vec<Vec<f32>>) {
        let (mut classes, mut features) = (Vec::new(), Vec::new());
        let rows: Vec<usize> = (0..seqs.len()).collect();
        for chunk in rows.chunks(256) {
            let (scores, f) = self.forward(stack(seqs, chunk, FRAMES, device));
            let k = scores.dims()[1];
            let h = f.dims()[1];
            let s = to_vec(scores.detach());
            classes.extend(best_labels(&s, k));
            features.extend(to_vec(f.detach()).chunks_exact(h).map(<[f32]>::to_vec));
        }
        (classes, features)
    }
}

/// A training set or settings that the sequence models cannot train on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum TrainingSetError {
    /// No sequences, or labels not one per sequence.
    #[error("no training sequences, or labels not one per sequence")]
    NoSequences,
    /// A label at or above the class count.
    #[error("a label is out of range")]
    LabelOutOfRange,
    /// Empty sequences, sequences of different lengths, or of a length that is not a whole
    /// number of frames.
    #[error("training sequences of different lengths")]
    Lengths,
    /// A zero epoch count, batch or width.
    #[error("epochs, batch and hidden width must be positive")]
    Settings,
}

/// Checks what both sequence models train on: sequences, one label each below `classes`, all of
/// one length (a multiple of the frame count), and positive epochs, batch and width. Returns the
/// sequences' length.
///
/// # Errors
/// As the check says, naming what is wrong.
pub fn check_training_set(
    seqs: &[Vec<f32>],
    labels: &[usize],
    classes: usize,
    config: &SequenceTraining,
) -> Result<usize, TrainingSetError> {
    if seqs.is_empty() || seqs.len() != labels.len() {
        return Err(TrainingSetError::NoSequences);
    }
    if labels.iter().any(|&l| l >= classes) {
        return Err(TrainingSetError::LabelOutOfRange);
    }
    let len = seqs[0].len();
    if !(len > 0 && len.is_multiple_of(FRAMES) && seqs.iter().all(|s| s.len() == len)) {
        return Err(TrainingSetError::Lengths);
    }
    if config.epochs == 0 || config.batch == 0 || config.hidden == 0 {
        return Err(TrainingSetError::Settings);
    }
    Ok(len)
}

/// Trains a classifier on `seqs` (each `[FRAMES × inputs]`, from [`sequence_features`]) with
/// their `labels` below `classes` by cross-entropy and Adam; `on_epoch(epoch, mean loss)` after
/// each pass. Returns the classifier and each epoch's mean loss. `device` must have autodiff.
///
/// # Errors
/// No sequences, labels not one per sequence or out of range, sequences of different lengths,
/// or a zero epoch count, batch or width.
pub fn train(
    seqs: &[Vec<f32>],
    labels: &[usize],
    classes: usize,
    config: &SequenceTraining,
    device: &Device,
    on_epoch: &mut dyn FnMut(usize, f32),
) -> Result<(Classifier, Vec<f32>), TrainingSetError> {
    let len = check_training_set(seqs, labels, classes, config)?;
    device.seed(config.seed);
    let mut model = Classifier::new(
        len / FRAMES,
        config.hidden,
        classes,
        unit_scale(seqs),
        device,
    );
    let mut optim = Adam::default();
    let mut losses = Vec::with_capacity(config.epochs);
    for epoch in 0..config.epochs {
        let (mut sum, mut count) = (0.0f64, 0usize);
        for rows in batches(seqs.len(), config.batch, config.seed, epoch) {
            let x = stack(seqs, &rows, FRAMES, device);
            let picked: Vec<usize> = rows.iter().map(|&r| labels[r]).collect();
            let target = super::labels::one_hot(&picked, classes, device);
            let (scores, _) = model.forward(x);
            let loss = (log_softmax(scores, 1) * target).sum_dim(1).mean().neg();
            let value = to_vec(loss.clone().detach()).first().copied();
            sum += f64::from(value.unwrap_or(f32::NAN)) * rows.len() as f64;
            count += rows.len();
            let grads = GradientsParams::from_grads(loss.backward(), &model);
            model = optim.step(config.lr, model, grads);
        }
        let mean = (sum / count as f64) as f32;
        losses.push(mean);
        on_epoch(epoch, mean);
    }
    Ok((model, losses))
}

/// The fraction of `predicted` equal to `labels`.
pub fn accuracy(predicted: &[usize], labels: &[usize]) -> f32 {
    let right = predicted.iter().zip(labels).filter(|(a, b)| a == b).count();
    right as f32 / labels.len().max(1) as f32
}

#[cfg(test)]
pub(crate) mod tests;
