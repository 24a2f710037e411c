//! Table 3's LSTM baseline (S2D section 4.3, the paper's reference \[39\]): a deterministic
//! generator that maps a label and a time code to the landmarks of each frame. Input at step t
//! (1 to `FRAMES`): the one-hot label and `t / FRAMES`; one LSTM layer (burn's `nn::Lstm`) and a
//! linear layer give the frame's displacement in the classifier's form
//! ([`super::classifier::sequence_features`]: normalised landmarks less frame 0), trained by mean
//! squared error on the training sequences. It has no noise input, so a label always gives the
//! same motion: its diversity is 0 by construction, and the evaluation computes it anyway.

use burn::module::Module;
use burn::nn::{Linear, Lstm, LstmConfig};
use burn::optim::GradientsParams;
use burn::tensor::{Device, Tensor};
use sinew_core::srvf::FRAMES;

use super::classifier::{
    SequenceTraining, TrainingSetError, batches, check_training_set, stack, unit_scale,
};
use super::srvf::{SrvfError, normalise_frame};
use crate::training::adam::Adam;
use crate::training::nn::{pytorch_linear, tensor, to_vec};

/// A label the generator was not trained on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("label {label} of {classes} classes")]
pub struct UnknownLabel {
    /// The label asked for.
    pub label: usize,
    /// The classes it knows.
    pub classes: usize,
}

/// The LSTM generator.
#[derive(Module, Debug)]
pub struct LstmGenerator {
    /// The recurrent layer.
    pub lstm: Lstm,
    /// Hidden state → the frame's (scaled) displacement.
    pub out: Linear,
    /// The output scale ([`unit_scale`] of the training sequences): outputs are divided by it.
    #[module(skip)]
    pub scale: f32,
    /// Number of labels.
    #[module(skip)]
    pub classes: usize,
}

/// The inputs of `labels`: per step t, the one-hot label and `t / FRAMES`.
///
/// # Shapes
/// → `[labels.len(), FRAMES, classes + 1]`
fn inputs(labels: &[usize], classes: usize, device: &Device) -> Tensor<3> {
    let width = classes + 1;
    let mut v = vec![0.0f32; labels.len() * FRAMES * width];
    for (row, &l) in labels.iter().enumerate() {
        for t in 0..FRAMES {
            let at = (row * FRAMES + t) * width;
            v[at + l] = 1.0;
            v[at + classes] = (t + 1) as f32 / FRAMES as f32;
        }
    }
    tensor(v, [labels.len(), FRAMES, width], device)
}

impl LstmGenerator {
    /// A fresh generator of `outputs` values per frame (seed the device first).
    pub fn new(classes: usize, outputs: usize, hidden: usize, scale: f32, device: &Device) -> Self {
        Self {
            lstm: LstmConfig::new(classes + 1, hidden, true).init(device),
            out: pytorch_linear(hidden, outputs, device),
            scale,
            classes,
        }
    }

    /// The scaled displacements of each label's motion.
    ///
    /// # Shapes
    /// → `[labels.len(), FRAMES, outputs]`
    pub fn forward(&self, labels: &[usize], device: &Device) -> Tensor<3> {
        let (h, _) = self
            .lstm
            .forward(inputs(labels, self.classes, device), None);
        self.out.forward(h)
    }

    /// `label`'s motion in the classifier's form, `[FRAMES × outputs]` (unscaled).
    ///
    /// # Errors
    /// A label out of range.
    pub fn generate(&self, label: usize, device: &Device) -> Result<Vec<f32>, UnknownLabel> {
        if label >= self.classes {
            return Err(UnknownLabel {
                label,
                classes: self.classes,
            });
        }
        let y = self.forward(&[label], device).detach();
        let k = 1.0 / self.scale;
        Ok(to_vec(y).into_iter().map(|x| x * k).collect())
    }
}

/// Trains the generator on `seqs` (each `[FRAMES × outputs]`, from
/// [`super::classifier::sequence_features`]) with their `labels` below `classes`, by mean squared
/// error and Adam; `on_epoch(epoch, mean loss)` after each pass. Returns the generator and each
/// epoch's mean loss (on the scaled values). `device` must have autodiff.
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
) -> Result<(LstmGenerator, Vec<f32>), TrainingSetError> {
    let len = check_training_set(seqs, labels, classes, config)?;
    device.seed(config.seed);
    let scale = unit_scale(seqs);
    let mut model = LstmGenerator::new(classes, len / FRAMES, config.hidden, scale, device);
    let mut optim = Adam::default();
    let mut losses = Vec::with_capacity(config.epochs);
    for epoch in 0..config.epochs {
        let (mut sum, mut count) = (0.0f64, 0usize);
        for rows in batches(seqs.len(), config.batch, config.seed, epoch) {
            let target = stack(seqs, &rows, FRAMES, device).mul_scalar(scale as f64);
            let picked: Vec<usize> = rows.iter().map(|&r| labels[r]).collect();
            let loss = (model.forward(&picked, device) - target)
                .powi_scalar(2)
                .mean();
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

/// A motion in the classifier's form (`[FRAMES × K · 3]`, normalised landmarks less frame 0)
/// played on `neutral`'s landmarks (`[K · 3]`): `FRAMES + 1` landmark frames, frame 0 the neutral,
/// frame t the neutral's normalised landmarks plus displacement t, brought back to the neutral's
/// centre and size.
///
/// # Errors
/// A neutral of another length or of zero size.
pub fn on_neutral(displacements: &[f32], neutral: &[f32]) -> Result<Vec<Vec<f32>>, SrvfError> {
    let d = neutral.len();
    if d == 0 || displacements.len() != FRAMES * d {
        return Err(SrvfError::Shape);
    }
    let normal = normalise_frame(neutral, 0)?;
    let k = (d / 3) as f64;
    let mut centre = [0.0f64; 3];
    for p in neutral.chunks_exact(3) {
        for (c, x) in centre.iter_mut().zip(p) {
            *c += f64::from(*x) / k;
        }
    }
    let size = neutral
        .chunks_exact(3)
        .flat_map(|p| (0..3).map(move |j| f64::from(p[j]) - centre[j]))
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt();
    let mut frames = vec![neutral.to_vec()];
    for step in displacements.chunks_exact(d) {
        frames.push(
            step.iter()
                .zip(&normal)
                .enumerate()
                .map(|(i, (s, n))| (centre[i % 3] + size * (n + f64::from(*s))) as f32)
                .collect(),
        );
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::classifier::sequence_features;
    use crate::training::backend::Backend;

    #[test]
    fn the_baseline_is_deterministic_and_shaped_per_frame() {
        let (seqs, labels) = crate::motion::classifier::tests::toy_set(12, 0);
        let config = SequenceTraining {
            seed: 3,
            epochs: 30,
            batch: 4,
            lr: 1e-2,
            hidden: 8,
        };
        let device = Backend::Flex.autodiff_device(config.seed).unwrap();
        // burn's CPU kernels split reductions by the work in flight on the shared thread pool,
        // so trainings run beside other tests round differently; one thread of its own makes
        // this test's two trainings comparable bit for bit.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let run = || pool.install(|| train(&seqs, &labels, 2, &config, &device, &mut |_, _| {}));
        let (model, losses) = run().unwrap();
        assert_eq!(losses.len(), 30);
        assert!(losses[29] < 0.5 * losses[0], "{losses:?}");
        let generate = |m: &LstmGenerator, label| pool.install(|| m.generate(label, &device));
        let a = generate(&model, 0).unwrap();
        assert_eq!(a.len(), FRAMES * 9);
        // No noise: the same label gives the same bits, every call.
        let again = generate(&model, 0).unwrap();
        assert_eq!(
            a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            again.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        assert_ne!(a, model.generate(1, &device).unwrap());
        assert_eq!(
            model.generate(2, &device),
            Err(UnknownLabel {
                label: 2,
                classes: 2
            })
        );
        // The same seed trains the same weights.
        let (other, _) = run().unwrap();
        assert_eq!(a, generate(&other, 0).unwrap());
        // Class 0 moves landmark 0 up: its last frame's mean displacement in y is positive.
        let mean_dy: f32 = (0..12)
            .filter(|k| k % 2 == 0)
            .map(|k| seqs[k][(FRAMES - 1) * 9 + 1])
            .sum::<f32>()
            / 6.0;
        let dy = a[(FRAMES - 1) * 9 + 1];
        assert!(dy > 0.5 * mean_dy && mean_dy > 0.0, "{dy} vs {mean_dy}");
    }

    #[test]
    fn a_motion_on_its_own_neutral_reads_back() {
        let frames = crate::motion::classifier::tests::toy_motion(1, 0.5, 2, 15);
        let refs: Vec<&[f32]> = frames.iter().map(Vec::as_slice).collect();
        let f = sequence_features(&refs).unwrap();
        let played = on_neutral(&f, &frames[0]).unwrap();
        assert_eq!(played.len(), FRAMES + 1);
        assert_eq!(played[0], frames[0]);
        let refs: Vec<&[f32]> = played.iter().map(Vec::as_slice).collect();
        let g = sequence_features(&refs).unwrap();
        // The played curve is renormalised per frame and resampled again: close, not exact.
        let worst = f
            .iter()
            .zip(&g)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 0.02, "{worst}");
        assert!(on_neutral(&f, &frames[0][..6]).is_err());
    }
}
