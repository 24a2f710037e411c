//! The label guide, a difference from the paper (off by default, `--class-weight`): the
//! nearest-centroid classifier of the training motions, whose cross-entropy on the generated
//! motions joins the generator's loss, as the auxiliary classifier of AC-GAN does (Odena et al.,
//! "Conditional Image Synthesis with Auxiliary Classifier GANs", ICML 2017). The critic says
//! whether a motion looks real; the guide says whether it looks like its label.
//!
//! A motion's score for label k is `−‖s − μ_k‖² / τ`: μ_k the mean tangent vector of the label's
//! training motions, τ their mean squared distance from their own label's mean (the
//! hypersphere's norm, `Σ / FRAMES`, as everywhere; from the common mean where each label has a
//! single motion). The cross-entropy's gradient moves a motion
//! along `μ_y − Σ_k P(k) μ_k`, so a motion that is clearly of its label is hardly moved, and one
//! that sits between its label and a neighbour's (a mouth_middle with most of a mouth_open in it)
//! is moved away from the neighbour: the generator leaves out the real motions' ambiguous tail,
//! and keeps the rest of their variety. The score differences are affine in s (`2 ⟨s, μ_y − μ_k⟩
//! / τ` plus a constant), so the guide looks at the motion only through the labels' means and
//! cannot be satisfied by a direction the training motions do not span, as a trained classifier
//! of 6,120 values from 1,008 motions can (one was tried: docs/MOTION.md, "The GAN").
//!
//! The guide is a function of the training motions alone, so a resumed run rebuilds it rather
//! than storing it in the checkpoint.

use burn::tensor::activation::log_softmax;
use burn::tensor::{Device, Tensor};
use sinew_core::srvf::FRAMES;

use super::labels::best_labels;
use crate::training::nn::{tensor, to_vec};

/// The guide: each label's mean tangent vector and the temperature.
#[derive(Clone, Debug)]
pub struct LabelGuide {
    /// `[labels, d]`: each label's mean training tangent vector (zero for a label without
    /// training motions).
    pub centroids: Tensor<2>,
    /// `[1, labels]`: 0, or −1e30 for a label without training motions, which no motion is
    /// then given.
    pub absent: Tensor<2>,
    /// τ, the training motions' mean squared distance from their own label's mean (where every
    /// label has one motion, or copies of one, from the motions' common mean).
    pub temperature: f32,
}

/// A guide cannot be made from these motions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum GuideError {
    /// No motions, labels not one per motion or out of range, or motions of different lengths.
    #[error(
        "no motions, labels not one per motion or out of range, or motions of different lengths"
    )]
    Motions,
    /// Every motion is the same: there is no spread to set τ.
    #[error("the training motions are all the same")]
    NoSpread,
}

impl LabelGuide {
    /// The guide of the tangent vectors `tangents` (one length, not empty) and their `labels`
    /// below `classes`.
    ///
    /// # Errors
    /// As [`GuideError`].
    pub fn new(
        tangents: &[Vec<f32>],
        labels: &[usize],
        classes: usize,
        device: &Device,
    ) -> Result<Self, GuideError> {
        let d = tangents.first().map_or(0, Vec::len);
        if d == 0
            || tangents.len() != labels.len()
            || tangents.iter().any(|t| t.len() != d)
            || labels.iter().any(|&l| l >= classes)
        {
            return Err(GuideError::Motions);
        }
        let mut sums = vec![vec![0.0f64; d]; classes];
        let mut counts = vec![0usize; classes];
        for (t, &l) in tangents.iter().zip(labels) {
            counts[l] += 1;
            for (s, &x) in sums[l].iter_mut().zip(t) {
                *s += f64::from(x);
            }
        }
        let means: Vec<Vec<f64>> = sums
            .iter()
            .zip(&counts)
            .map(|(s, &n)| s.iter().map(|x| x / n.max(1) as f64).collect())
            .collect();
        let squared_from = |t: &[f32], m: &[f64]| {
            t.iter()
                .zip(m)
                .map(|(&x, m)| (f64::from(x) - m).powi(2))
                .sum::<f64>()
                / FRAMES as f64
        };
        let n = tangents.len() as f64;
        let mut spread = tangents
            .iter()
            .zip(labels)
            .map(|(t, &l)| squared_from(t, &means[l]))
            .sum::<f64>()
            / n;
        if spread == 0.0 {
            // One motion per label (or copies): the spread about the motions' common mean.
            let mut mean = vec![0.0f64; d];
            for t in tangents {
                for (m, &x) in mean.iter_mut().zip(t) {
                    *m += f64::from(x) / n;
                }
            }
            spread = tangents.iter().map(|t| squared_from(t, &mean)).sum::<f64>() / n;
        }
        if !(spread.is_finite() && spread > 0.0) {
            return Err(GuideError::NoSpread);
        }
        let flat: Vec<f32> = means.iter().flatten().map(|&m| m as f32).collect();
        let absent: Vec<f32> = counts
            .iter()
            .map(|&n| if n == 0 { -1e30 } else { 0.0 })
            .collect();
        Ok(Self {
            centroids: tensor(flat, [classes, d], device),
            absent: tensor(absent, [1, classes], device),
            temperature: spread as f32,
        })
    }

    /// The label scores `−‖s − μ_k‖² / τ` of tangent vectors.
    ///
    /// # Shapes
    /// - x: `[n, d]` → `[n, labels]`
    pub fn scores(&self, x: Tensor<2>) -> Tensor<2> {
        let xx = x.clone().square().sum_dim(1);
        let mm = self.centroids.clone().square().sum_dim(1).transpose();
        let cross = x.matmul(self.centroids.clone().transpose());
        let squared = (xx + mm - cross.mul_scalar(2.0)).div_scalar(FRAMES as f64);
        squared
            .div_scalar(f64::from(self.temperature))
            .neg()
            .add(self.absent.clone())
    }

    /// The mean cross-entropy of the scores of `x` against the one-hot `labels`.
    ///
    /// # Shapes
    /// - x: `[n, d]`, labels: `[n, labels]` → `[1]`
    pub fn cross_entropy(&self, x: Tensor<2>, labels: Tensor<2>) -> Tensor<1> {
        (log_softmax(self.scores(x), 1) * labels)
            .sum_dim(1)
            .mean()
            .neg()
    }

    /// The label of each row of `x` with the highest score (the nearest mean).
    ///
    /// # Shapes
    /// - x: `[n, d]` → n labels
    pub fn predict(&self, x: Tensor<2>) -> Vec<usize> {
        let scores = self.scores(x).detach();
        let k = scores.dims()[1];
        best_labels(&to_vec(scores), k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::labels::one_hot;
    use crate::training::backend::Backend;

    fn rows(ts: &[Vec<f32>], device: &Device) -> Tensor<2> {
        let d = ts[0].len();
        tensor(
            ts.iter().flatten().copied().collect(),
            [ts.len(), d],
            device,
        )
    }

    /// Three of four labels, each a direction of its own plus noise: the guide's means and
    /// temperature are the motions', it labels them by the nearest mean, never gives the absent
    /// label, and its cross-entropy is low for the right labels and high for wrong ones.
    #[test]
    fn the_guide_labels_motions_by_the_nearest_mean_of_their_training_motions() {
        let device = Backend::Flex.autodiff_device(3).unwrap();
        let mut rng = crate::training::random::Stream::seed_from_u64(9);
        let d = FRAMES * 2;
        let (mut tangents, mut labels) = (Vec::new(), Vec::new());
        for i in 0..90 {
            let l = i % 3;
            let t: Vec<f32> = (0..d)
                .map(|k| {
                    let own = if k % 3 == l { 1.0 } else { 0.0 };
                    own + 0.1 * rng.normal() as f32
                })
                .collect();
            tangents.push(t);
            labels.push(l);
        }
        let guide = LabelGuide::new(&tangents, &labels, 4, &device).unwrap();
        // τ: each value's spread 0.1² (less the means' share), `d / FRAMES` = 2 values a frame.
        let tau = guide.temperature;
        assert!((tau - 0.02).abs() < 0.002, "{tau}");
        let centroids = to_vec(guide.centroids.clone());
        assert!((centroids[0] - 1.0).abs() < 0.05 && centroids[1].abs() < 0.05);
        assert!(centroids[3 * d..].iter().all(|&c| c == 0.0));
        assert_eq!(guide.predict(rows(&tangents, &device)), labels);
        let ce = |labels: &[usize]| {
            to_vec(guide.cross_entropy(rows(&tangents, &device), one_hot(labels, 4, &device)))[0]
        };
        let wrong: Vec<usize> = labels.iter().map(|l| (l + 1) % 3).collect();
        assert!(
            ce(&labels) < 1e-3 && ce(&wrong) > 30.0,
            "{} {}",
            ce(&labels),
            ce(&wrong)
        );
        // Halfway between two means, both are as likely.
        let half: Vec<f32> = (0..d).map(|k| if k % 3 < 2 { 0.5 } else { 0.0 }).collect();
        let scores = to_vec(guide.scores(rows(&[half], &device)));
        assert!(
            (scores[0] - scores[1]).abs() < 0.05 * scores[0].abs(),
            "{scores:?}"
        );
        assert!(scores[3] < -1e29);
        assert_eq!(
            LabelGuide::new(&tangents[..2], &[0, 4], 4, &device).err(),
            Some(GuideError::Motions)
        );
        assert_eq!(
            LabelGuide::new(&[vec![0.5; d], vec![0.5; d]], &[1, 2], 4, &device).err(),
            Some(GuideError::NoSpread)
        );
        // One motion per label: τ is their spread about their common mean, 0.25² · 2 a frame.
        let one_each = LabelGuide::new(&[vec![0.5; d], vec![0.0; d]], &[1, 2], 4, &device).unwrap();
        assert!(
            (one_each.temperature - 0.125).abs() < 1e-6,
            "{}",
            one_each.temperature
        );
    }
}
