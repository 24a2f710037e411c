//! Training Motion3DGAN: the training sequences as tangent vectors at the reference motion, and
//! the loop of 4 critic steps per generator step (S2D section 4.2).

use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use sinew_core::srvf::FRAMES;

use super::classes::LABELS;
use super::data::{MotionSet, Split};
use super::gan::{
    Batch, Critic, GanConfig, Generator, StepLosses, critic_step, generator_step, optimizer,
};
use super::guide::{GuideError, LabelGuide};
use super::labels::one_hot;
use super::srvf::{self, SrvfError};
use crate::training::adam::Adam;
use crate::training::nn::tensor;
use crate::training::random::Stream;

/// Motions that cannot be brought into the GAN's tangent space.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TangentError {
    /// A motion set without training sequences.
    #[error("the motion set has no training sequences")]
    NoTrainingSequences,
    /// A sequence that cannot be encoded as an SRVF (it does not move).
    #[error("encoding sequence {sequence}")]
    Encode {
        /// The sequence's index in the set.
        sequence: usize,
        /// Why.
        #[source]
        source: SrvfError,
    },
    /// No motions, or labels not one per motion.
    #[error("no motions, or labels not one per motion")]
    NoMotions,
    /// Motions of different shapes, or of a length that is not a whole number of frames.
    #[error("motions of different shapes")]
    Shapes,
    /// Motions whose mean is zero (no reference motion).
    #[error("the motions' mean is zero")]
    ZeroMean,
    /// A motion that has no log map at the reference (its antipode).
    #[error("log-mapping a motion at the reference")]
    LogMap(#[source] SrvfError),
}

/// The training sequences as the GAN sees them.
#[derive(Clone, Debug, PartialEq)]
pub struct TangentData {
    /// The reference motion p: the training SRVFs' mean, scaled back onto the sphere (the paper
    /// takes "the mean SRVF of the CoMA data").
    pub p: Vec<f32>,
    /// Each training sequence's `log_p(q)`.
    pub tangents: Vec<Vec<f32>>,
    /// Each one's label index.
    pub labels: Vec<usize>,
    /// Per label, the mean and the standard deviation of its training curves' arc length (the
    /// length a decoded motion of intensity 1 draws from; SRVFs are scale-free). A label without
    /// training curves takes every curve's.
    pub lengths: Vec<[f32; 2]>,
    /// Per label, the mean and the standard deviation of the logarithm of its training curves'
    /// reach (the apex's distance from the neutral; [`log_reach`]), as `lengths`: a motion's
    /// reach is drawn log-normally, always positive; `None` for motions without curves
    /// ([`TangentData::from_motions`]), which decode at their `lengths`.
    pub log_reaches: Option<Vec<[f32; 2]>>,
}

impl TangentData {
    /// The training side of `set`, encoded (eq. 1) and log-mapped at the mean (eq. 8).
    ///
    /// # Errors
    /// If a sequence cannot be encoded (it does not move), naming it.
    pub fn from_set(set: &MotionSet) -> Result<Self, TangentError> {
        let train = set.split(Split::Train);
        if train.is_empty() {
            return Err(TangentError::NoTrainingSequences);
        }
        let mut qs = Vec::with_capacity(train.len());
        let mut lengths = Vec::with_capacity(train.len());
        let mut reaches = Vec::with_capacity(train.len());
        for &s in &train {
            let e =
                srvf::encode(&set.landmark_frames(s)).map_err(|source| TangentError::Encode {
                    sequence: s,
                    source,
                })?;
            lengths.push(f64::from(e.length));
            reaches.push(log_reach(e.reach));
            qs.push(e.q);
        }
        let labels: Vec<usize> = train.iter().map(|&s| set.label(s)).collect();
        let mut data = Self::from_motions(&qs, labels)?;
        data.lengths = per_label(&lengths, &data.labels);
        data.log_reaches = Some(per_label(&reaches, &data.labels));
        Ok(data)
    }

    /// Motions `qs` (unit SRVFs of one shape) with their labels, log-mapped at their mean; every
    /// label's length is 1, without spread.
    ///
    /// # Errors
    /// If there are no motions, or they differ in shape, or their mean is zero.
    pub fn from_motions(qs: &[Vec<f32>], labels: Vec<usize>) -> Result<Self, TangentError> {
        if qs.is_empty() || qs.len() != labels.len() {
            return Err(TangentError::NoMotions);
        }
        let d = qs[0].len();
        if !(d > 0 && d.is_multiple_of(FRAMES) && qs.iter().all(|q| q.len() == d)) {
            return Err(TangentError::Shapes);
        }
        let mut mean = vec![0.0f64; d];
        for q in qs {
            for (m, x) in mean.iter_mut().zip(q) {
                *m += f64::from(*x);
            }
        }
        let n = (mean.iter().map(|x| x * x).sum::<f64>() / FRAMES as f64).sqrt();
        if n.is_nan() || n <= 0.0 {
            return Err(TangentError::ZeroMean);
        }
        let p: Vec<f32> = mean.iter().map(|x| (x / n) as f32).collect();
        let tangents = qs
            .iter()
            .map(|q| srvf::log_map(&p, q))
            .collect::<Result<_, _>>()
            .map_err(TangentError::LogMap)?;
        Ok(Self {
            p,
            tangents,
            labels,
            lengths: vec![[1.0, 0.0]; LABELS.len()],
            log_reaches: None,
        })
    }

    /// `lengths` flattened, `[LABELS × 2]`, as `motion.length` stores them.
    pub fn lengths_flat(&self) -> Vec<f32> {
        self.lengths.iter().flatten().copied().collect()
    }

    /// `log_reaches` flattened, `[LABELS × 2]`, as `motion.log_reach` stores them, each spread
    /// at most what keeps every draw within the core's factors: `exp(mean + NOISE_BOUND ·
    /// spread)` at most `MAX_FACTOR` (a normalised landmark curve reaches about 0.2; only a set
    /// of wildly different reaches comes near it).
    pub fn log_reaches_flat(&self) -> Option<Vec<f32>> {
        let largest = f64::from(sinew_core::layout::MAX_FACTOR).ln() * (1.0 - 1e-6);
        let noise = f64::from(sinew_core::motion::NOISE_BOUND);
        let pairs = self
            .log_reaches
            .as_ref()?
            .iter()
            .flat_map(|&[mean, spread]| {
                let most = ((largest - f64::from(mean)) / noise).max(0.0) as f32;
                [mean, spread.min(most)]
            });
        Some(pairs.collect())
    }

    /// Coordinates of one tangent vector (`FRAMES × dims`).
    pub fn dims(&self) -> usize {
        self.p.len()
    }
}

/// Per-step state the loop reports (for a progress bar).
pub trait Observer {
    /// After generator step `step` (0-based) with its losses.
    fn step(&mut self, step: usize, losses: &StepLosses);
}

impl<F: FnMut(usize, &StepLosses)> Observer for F {
    fn step(&mut self, step: usize, losses: &StepLosses) {
        self(step, losses)
    }
}

/// The randomness of generator step `step`, critic step `k` (`k = critic_steps` for the
/// generator's own batch), from a PCG-64 seeded by (seed, step, k) alone, so a resumed run draws
/// what an uninterrupted one would: `size` sample indices uniform with replacement below `n`,
/// then `size × noise` standard normals (Box–Muller), then `size` uniforms in [0, 1).
pub fn draw(
    n: usize,
    size: usize,
    noise: usize,
    seed: u64,
    step: usize,
    k: usize,
) -> (Vec<usize>, Vec<f32>, Vec<f32>) {
    let mut rng = Stream::seed_from_u64(
        seed ^ (step as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ ((k as u64) << 56),
    );
    let indices = (0..size).map(|_| rng.below(n)).collect();
    let z = (0..size * noise).map(|_| rng.normal() as f32).collect();
    let tau = (0..size).map(|_| rng.unit() as f32).collect();
    (indices, z, tau)
}

/// The sample indices of [`draw`].
pub fn batch_indices(n: usize, size: usize, seed: u64, step: usize, k: usize) -> Vec<usize> {
    draw(n, size, 0, seed, step, k).0
}

fn batch(data: &TangentData, config: &GanConfig, step: usize, k: usize, device: &Device) -> Batch {
    let d = data.dims();
    let n = data.tangents.len();
    let size = config.batch.min(n).max(1);
    let (indices, z, tau) = draw(n, size, config.noise, config.seed, step, k);
    let real: Vec<f32> = indices
        .iter()
        .flat_map(|&i| data.tangents[i].iter().copied())
        .collect();
    let labels: Vec<usize> = indices.iter().map(|&i| data.labels[i]).collect();
    Batch {
        real: tensor(real, [size, d], device),
        labels: one_hot(&labels, LABELS.len(), device),
        noise: tensor(z, [size, config.noise], device),
        tau: tensor(tau, [size, 1], device),
    }
}

/// A training run: both networks, both optimisers, and where it stands.
pub struct Run {
    /// The generator.
    pub generator: Generator,
    /// The critic.
    pub critic: Critic,
    /// The generator's Adam.
    pub g_optim: Adam,
    /// The critic's Adam.
    pub c_optim: Adam,
    /// Generator steps done.
    pub step: usize,
    /// Per generator step: the last critic step's losses with the generator's.
    pub history: Vec<StepLosses>,
    /// The label guide, where the settings weigh it ([`GanConfig::class_weight`]): made from
    /// the training motions when the run is made, never saved.
    pub guide: Option<LabelGuide>,
}

impl std::fmt::Debug for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Run")
            .field("step", &self.step)
            .finish_non_exhaustive()
    }
}

impl Run {
    /// A fresh run for `data` on the autodiff `device` (seed the device first).
    ///
    /// # Errors
    /// Where the settings weigh the label guide and `data` cannot have one ([`GuideError`]).
    pub fn new(
        data: &TangentData,
        config: &GanConfig,
        device: &Device,
    ) -> Result<Self, GuideError> {
        let d = data.dims();
        let guide = (config.class_weight > 0.0)
            .then(|| LabelGuide::new(&data.tangents, &data.labels, LABELS.len(), device))
            .transpose()?;
        Ok(Self {
            generator: Generator::new(
                config.noise,
                LABELS.len(),
                d,
                &config.hidden,
                config.slope,
                device,
            ),
            critic: Critic::new(d + LABELS.len(), &config.hidden, config.slope, device),
            g_optim: optimizer(),
            c_optim: optimizer(),
            step: 0,
            history: Vec::new(),
            guide,
        })
    }

    /// Runs generator steps (each after `critic_steps` critic steps) until `until` steps are
    /// done or `stop` says so after a step.
    pub fn advance(
        mut self,
        data: &TangentData,
        config: &GanConfig,
        device: &Device,
        until: usize,
        observer: &mut dyn Observer,
        stop: &mut dyn FnMut() -> bool,
    ) -> Self {
        let p: Tensor<2> = tensor(data.p.clone(), [1, data.dims()], device);
        while self.step < until {
            let step = self.step;
            let mut losses = StepLosses::default();
            for k in 0..config.critic_steps {
                let b = batch(data, config, step, k, device);
                let (c, l) = critic_step(
                    &self.generator,
                    self.critic,
                    &mut self.c_optim,
                    &b,
                    &p,
                    config,
                );
                self.critic = c;
                losses = l;
            }
            let b = batch(data, config, step, config.critic_steps, device);
            let (g, l) = generator_step(
                self.generator,
                &self.critic,
                self.guide.as_ref(),
                &mut self.g_optim,
                &b,
                &p,
                config,
            );
            self.generator = g;
            losses.generator = l.generator;
            losses.reconstruction = l.reconstruction;
            losses.classes = l.classes;
            observer.step(step, &losses);
            self.history.push(losses);
            self.step += 1;
            if stop() {
                break;
            }
        }
        self
    }
}

/// The run's record, saved beside the model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TrainRecord {
    /// The settings.
    pub config: GanConfig,
    /// Per generator step.
    pub history: Vec<StepLosses>,
}

/// Per label, the mean and spread of the `values` (one per motion, labelled `labels`); a label
/// without motions takes every motion's.
fn per_label(values: &[f64], labels: &[usize]) -> Vec<[f32; 2]> {
    let all = mean_and_spread(values);
    (0..LABELS.len())
        .map(|l| {
            let mine: Vec<f64> = values
                .iter()
                .zip(labels)
                .filter(|&(_, &k)| k == l)
                .map(|(x, _)| *x)
                .collect();
            if mine.is_empty() {
                all
            } else {
                mean_and_spread(&mine)
            }
        })
        .collect()
}

/// The smallest reach whose logarithm a label's statistics take: a training curve that ends
/// where it starts counts as this close, so that its logarithm stays finite.
pub const MIN_REACH: f32 = 1e-6;

/// `ln(max(reach, MIN_REACH))`, what `motion.log_reach` keeps the statistics of.
pub fn log_reach(reach: f32) -> f64 {
    f64::from(reach.max(MIN_REACH)).ln()
}

/// The mean and the population standard deviation of `xs` (not empty), in f32.
fn mean_and_spread(xs: &[f64]) -> [f32; 2] {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    [mean as f32, var.sqrt() as f32]
}

#[cfg(test)]
mod tests;
