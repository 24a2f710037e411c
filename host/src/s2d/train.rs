//! S2D-Dec training (S2D §3.2 and §4.2): input normalisation, the landmark-distance vertex
//! weights, both loss variants, and the Adam loop of the reference (lr 1e-3 decayed ×0.99 per
//! epoch over 300 epochs, L2 weight decay 5e-5 added to the gradient, batch 16), with
//! checkpoints and resumption ([`super::checkpoint`]).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::{Device, Tensor, TensorData};

use super::checkpoint::{
    CheckpointState, DataFingerprint, STATE_FILE, load_checkpoint, save_checkpoint,
};
use super::decoder::S2dDecoder;
use crate::training::adam::Adam;
use crate::training::random::Stream;

mod error;
pub use error::TrainError;

pub use super::objective::{
    LossVariant, Sample, TrainConfig, landmark_distances, landmark_input, loss,
    normalise_landmarks, vertex_weights,
};

/// A batch on the device.
#[derive(Debug)]
pub struct Batch {
    /// `[batch, inputs]`.
    pub input: Tensor<2>,
    /// `[batch, vertices, 3]`.
    pub target: Tensor<3>,
}

impl Batch {
    /// Stacks the samples `indices` of `set`.
    ///
    /// # Panics
    /// If `indices` is empty or names a sample outside `set` ([`train`] checks the samples'
    /// lengths first).
    pub fn new(set: &[Sample], indices: &[usize], device: &Device) -> Self {
        let inputs = set[indices[0]].input.len();
        let values = set[indices[0]].displacement.len();
        let mut x = Vec::with_capacity(indices.len() * inputs);
        let mut y = Vec::with_capacity(indices.len() * values);
        for &i in indices {
            x.extend_from_slice(&set[i].input);
            y.extend_from_slice(&set[i].displacement);
        }
        let b = indices.len();
        Self {
            input: Tensor::from_data(TensorData::new(x, [b, inputs]), device),
            target: Tensor::from_data(TensorData::new(y, [b, values / 3, 3]), device),
        }
    }
}

/// The weights `w_v` as the `[1, vertices, 1]` tensor [`loss`] takes.
pub fn weights_tensor(weights: &[f32], device: &Device) -> Tensor<3> {
    Tensor::from_data(
        TensorData::new(weights.to_vec(), [1, weights.len(), 1]),
        device,
    )
}

/// Two single-thread rayon pools, one per half of a batch, for [`step_once`].
#[derive(Debug)]
pub struct Halves {
    pools: [rayon::ThreadPool; 2],
}

impl Halves {
    /// Two pools of one thread each.
    pub fn new() -> Result<Self, rayon::ThreadPoolBuildError> {
        let pool = |i: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .thread_name(move |_| format!("s2d-half-{i}"))
                .build()
        };
        Ok(Self {
            pools: [pool(0)?, pool(1)?],
        })
    }
}

/// The same module with every parameter a fresh leaf of the autodiff graph (same values, same
/// parameter ids), so that two copies differentiate in separate graphs.
struct FreshLeaves;

impl ModuleMapper for FreshLeaves {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        param.map(|t| t.detach().require_grad())
    }
}

/// Adds the gradients of `other` into `into`, parameter by parameter.
struct AddGradients<'a> {
    into: &'a mut GradientsParams,
    other: GradientsParams,
}

impl ModuleVisitor for AddGradients<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let id = param.id;
        let sum = match (self.into.remove::<D>(id), self.other.remove::<D>(id)) {
            (Some(a), Some(b)) => a + b,
            (Some(g), None) | (None, Some(g)) => g,
            (None, None) => return,
        };
        self.into.register(id, sum);
    }
}

/// One Adam step at learning rate `lr`; returns the model and the (detached) loss.
///
/// With `halves` (and at least two samples) the batch is split in two halves that are
/// evaluated and differentiated at the same time, each in its own autodiff graph on its own
/// single-thread pool; their gradients, each weighted by its share of the batch, add up to the
/// whole batch's (the loss is a mean over samples). burn-flex runs most of an S2D step on one
/// thread (the gathers, the element-wise operations and the thin matrix products of the spiral
/// convolutions: a step used 108 % CPU), so this puts a second core to work. Deterministic: the
/// split, the order of the sum and each half's single-thread arithmetic do not depend on timing
/// or on the machine's core count.
pub fn step_once(
    decoder: S2dDecoder,
    optim: &mut Adam,
    batch: &Batch,
    weights: &Tensor<3>,
    variant: LossVariant,
    lr: f64,
    halves: Option<&Halves>,
) -> (S2dDecoder, Tensor<1>) {
    let [size, _] = batch.input.dims();
    let (grads, l) = match halves {
        Some(halves) if size >= 2 => {
            let split = size / 2;
            let half = |start: usize, len: usize| {
                let copy = decoder.clone().map(&mut FreshLeaves);
                let predicted = copy.forward(batch.input.clone().narrow(0, start, len));
                let target = batch.target.clone().narrow(0, start, len);
                let l = loss(variant, predicted, target, weights.clone())
                    .mul_scalar(len as f64 / size as f64);
                (GradientsParams::from_grads(l.backward(), &copy), l.detach())
            };
            let ((mut grads, first), (other, second)) = std::thread::scope(|scope| {
                let second = scope.spawn(|| halves.pools[1].install(|| half(split, size - split)));
                let first = halves.pools[0].install(|| half(0, split));
                let second = second
                    .join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
                (first, second)
            });
            decoder.visit(&mut AddGradients {
                into: &mut grads,
                other,
            });
            (grads, first + second)
        }
        _ => {
            let predicted = decoder.forward(batch.input.clone());
            let l = loss(variant, predicted, batch.target.clone(), weights.clone());
            (
                GradientsParams::from_grads(l.backward(), &decoder),
                l.detach(),
            )
        }
    };
    (optim.step(lr, decoder, grads), l)
}

/// The order of the samples in `epoch`: a Fisher–Yates shuffle from a generator seeded by
/// (seed, epoch) alone, so any epoch can be reproduced on its own.
pub fn epoch_order(n: usize, seed: u64, epoch: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    Stream::new(
        seed,
        epoch as u64,
        0x5d2d_ec00_0000_0000_0000_0000_0000_0001,
    )
    .shuffle(&mut order);
    order
}

/// Set by the Ctrl-C handler: a training that checkpoints stops after its current step.
pub use crate::training::interrupt::request_stop;

/// Options of one training run besides its data and configuration.
#[derive(Clone, Debug, Default)]
pub struct TrainOptions {
    /// Folder for checkpoints (created), written after every epoch, on Ctrl-C after the current
    /// step, and where `stop_after` stops; `None` trains without checkpoints (and without the
    /// Ctrl-C handling).
    pub checkpoint_dir: Option<PathBuf>,
    /// Continue from the checkpoint in `checkpoint_dir` (an error if there is none, or if it
    /// belongs to another run).
    pub resume: bool,
    /// Stop after this many steps in this invocation (tests of resumption); `None` runs to the
    /// end.
    pub stop_after: Option<usize>,
    /// What else a resumed run must match, recorded in the checkpoint (protocol, fold, …).
    pub context: BTreeMap<String, String>,
}

/// A finished (or stopped) training run.
#[derive(Debug)]
pub struct Trained {
    /// The decoder, on the training device.
    pub decoder: S2dDecoder,
    /// Where training stands: epochs and steps done, the epoch losses, the seconds spent.
    pub state: CheckpointState,
}

impl Trained {
    /// Whether every configured epoch ran.
    pub fn complete(&self) -> bool {
        self.state.complete()
    }
}

/// Trains `decoder` on `set` for `config.epochs` epochs (the last batch of an epoch may be short,
/// as PyTorch's `DataLoader` without `drop_last`), or continues a checkpointed run
/// (`options.resume`). The state's `losses` are the mean loss of each epoch (batch losses
/// weighted by batch size).
///
/// The order of epoch e is a function of (seed, e) alone and the checkpoint holds the weights,
/// the Adam state and the unfinished epoch's loss sum, so a run stopped after any step and
/// resumed reaches the same weights and losses bit for bit as an uninterrupted one (in the same
/// build, with no other training running in the process: see docs/S2D.md). A resumed run whose
/// checkpoint is complete returns its weights without training.
pub fn train(
    decoder: S2dDecoder,
    set: &[Sample],
    vertex_weights: &[f32],
    config: &TrainConfig,
    device: &Device,
    options: &TrainOptions,
) -> Result<Trained, TrainError> {
    config.validate()?;
    if set.is_empty() {
        return Err(TrainError::NoSamples);
    }
    let v = decoder.output_vertices();
    if vertex_weights.len() != v {
        return Err(TrainError::VertexWeights {
            found: vertex_weights.len(),
            vertices: v,
        });
    }
    for (i, s) in set.iter().enumerate() {
        if s.input.len() != decoder.config.inputs || s.displacement.len() != 3 * v {
            return Err(TrainError::Sample {
                index: i,
                input: s.input.len(),
                expected_input: decoder.config.inputs,
                displacement: s.displacement.len(),
                expected_displacement: 3 * v,
            });
        }
    }
    let batches = set.len().div_ceil(config.batch);
    let mut state = CheckpointState::start(
        config,
        &decoder,
        DataFingerprint::of(set, vertex_weights),
        options.context.clone(),
    );
    let mut decoder = decoder;
    let mut optim = config.optimizer();
    // The position of the last checkpoint written or read (none yet on a fresh run).
    let mut saved = None;
    let dir = options.checkpoint_dir.as_deref();
    if options.resume {
        let Some(dir) = dir else {
            return Err(TrainError::ResumeWithoutFolder);
        };
        let (d, o, s) = load_checkpoint(dir, decoder, optim, &state)?;
        if !(s.steps_in_epoch < batches
            && s.steps_done == s.epochs_done * batches + s.steps_in_epoch)
        {
            return Err(TrainError::Position {
                path: dir.join(STATE_FILE),
                step: s.steps_in_epoch,
                epoch: s.epochs_done,
                steps_done: s.steps_done,
                batches,
            });
        }
        (decoder, optim, state) = (d, o, s);
        saved = Some(state.steps_done);
    } else if let Some(dir) = dir {
        crate::io::atomic::create_folder(dir, "checkpoint folder")?;
    }
    if dir.is_some() {
        crate::training::interrupt::watch_ctrl_c();
    }

    let weights = weights_tensor(vertex_weights, device);
    // On the CPU every batch trains as two halves at once (`step_once`).
    let halves = if crate::training::backend::on_flex(&weights) {
        Some(Halves::new().map_err(TrainError::Threads)?)
    } else {
        None
    };
    let start = Instant::now();
    let seconds_before = state.seconds;
    let first = state.steps_done;
    let total_steps = config.epochs * batches;
    let last = options
        .stop_after
        .map_or(total_steps, |n| (state.steps_done + n).min(total_steps));
    'epochs: while state.epochs_done < config.epochs {
        let epoch = state.epochs_done;
        let lr = config.lr_at(epoch);
        let order = epoch_order(set.len(), config.seed, epoch);
        for chunk in order.chunks(config.batch).skip(state.steps_in_epoch) {
            if state.steps_done >= last {
                break 'epochs;
            }
            let batch = Batch::new(set, chunk, device);
            let l;
            (decoder, l) = step_once(
                decoder,
                &mut optim,
                &batch,
                &weights,
                config.loss,
                lr,
                halves.as_ref(),
            );
            let value = crate::training::nn::to_vec(l)[0];
            if !value.is_finite() {
                return Err(TrainError::Diverged { epoch, loss: value });
            }
            state.epoch_loss_total += f64::from(value) * chunk.len() as f64;
            state.steps_in_epoch += 1;
            state.steps_done += 1;
            // The epoch closes with its last step, before a checkpoint can record its position.
            if state.steps_in_epoch == batches {
                state
                    .losses
                    .push((state.epoch_loss_total / set.len() as f64) as f32);
                state.epochs_done += 1;
                state.steps_in_epoch = 0;
                state.epoch_loss_total = 0.0;
                if let Some(dir) = dir {
                    state.seconds = seconds_before + start.elapsed().as_secs_f64();
                    save_checkpoint(dir, &decoder, &optim, &mut state)?;
                    saved = Some(state.steps_done);
                }
            }
            if crate::training::interrupt::take_stop_request() {
                let at = format!(
                    "epoch {}, step {} ({} steps done)",
                    state.epochs_done, state.steps_in_epoch, state.steps_done
                );
                let Some(dir) = dir else {
                    return Err(TrainError::Interrupted { at });
                };
                if saved != Some(state.steps_done) {
                    state.seconds = seconds_before + start.elapsed().as_secs_f64();
                    save_checkpoint(dir, &decoder, &optim, &mut state)?;
                }
                return Err(TrainError::InterruptedSaved {
                    at,
                    dir: dir.to_owned(),
                });
            }
        }
    }
    if state.steps_done != first {
        state.seconds = seconds_before + start.elapsed().as_secs_f64();
    }
    if let Some(dir) = dir
        && saved != Some(state.steps_done)
    {
        save_checkpoint(dir, &decoder, &optim, &mut state)?;
    }
    Ok(Trained { decoder, state })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s2d::decoder::DecoderConfig;
    use crate::s2d::decoder::InputNormalisation;
    use crate::s2d::decoder::InputNormalisation::{Frobenius, NeutralScale};
    use crate::s2d::synthetic;
    use crate::training::nn::{tensor, to_vec};

    #[test]
    fn normalisation_centres_and_scales() {
        // Points (0,0,0), (2,0,0): centre (1,0,0), centred ±(1,0,0), norm √2.
        let n = normalise_landmarks(&[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]);
        let s = std::f32::consts::FRAC_1_SQRT_2;
        assert!((n[0][0] + s).abs() < 1e-7 && (n[1][0] - s).abs() < 1e-7);
        assert_eq!((n[0][1], n[1][2]), (0.0, 0.0));
        // Translating and scaling the expressive set changes nothing; a displacement does.
        let neutral = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let moved = neutral.map(|p| [p[0] * 3.0 + 5.0, p[1] * 3.0 - 1.0, p[2] * 3.0]);
        assert!(
            landmark_input(Frobenius, &neutral, &moved)
                .unwrap()
                .iter()
                .all(|v| v.abs() < 1e-6)
        );
        let open = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.5, 0.0]];
        let d = landmark_input(Frobenius, &neutral, &open).unwrap();
        assert_eq!(d.len(), 9);
        assert!(d.iter().any(|v| v.abs() > 0.05));
        assert_eq!(
            landmark_input(Frobenius, &neutral, &open[..2]),
            Err(crate::s2d::objective::LandmarkError::Counts {
                neutral: 3,
                expressive: 2
            })
        );
    }

    #[test]
    fn neutral_scale_input_is_linear_in_the_displacement() {
        let neutral = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let open = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.5, 0.0]];
        let at = |k: f32, shift: f32| -> Vec<f32> {
            let e: Vec<[f32; 3]> = neutral
                .iter()
                .zip(&open)
                .map(|(n, o)| [0, 1, 2].map(|i| n[i] + k * (o[i] - n[i]) + shift))
                .collect();
            landmark_input(NeutralScale, &neutral, &e).unwrap()
        };
        let one = at(1.0, 0.0);
        // The displacement (0, 0.5, 0) at the third point, less its mean (0, 1/6, 0), over the
        // neutral's centred norm √(4/3).
        let norm = (4.0f32 / 3.0).sqrt();
        let expected = [
            0.0,
            -1.0 / 6.0,
            0.0,
            0.0,
            -1.0 / 6.0,
            0.0,
            0.0,
            1.0 / 3.0,
            0.0,
        ];
        for (a, b) in one.iter().zip(expected) {
            assert!((a - b / norm).abs() < 1e-6, "{one:?}");
        }
        // Twice the displacement, twice the input; a translation changes nothing.
        for (a, b) in at(2.0, 0.0).iter().zip(&one) {
            assert!((a - 2.0 * b).abs() < 1e-6);
        }
        for (a, b) in at(1.0, 7.0).iter().zip(&one) {
            assert!((a - b).abs() < 1e-6);
        }
        // The core computes the same in f32.
        let flat = |p: &[[f32; 3]]| p.iter().flatten().copied().collect::<Vec<f32>>();
        let mut core = vec![0.0; 9];
        sinew_core::s2d::landmark_input_neutral_scale(&flat(&neutral), &flat(&open), &mut core)
            .unwrap();
        for (a, b) in core.iter().zip(&one) {
            assert!((a - b).abs() < 1e-6);
        }
        assert_eq!(
            InputNormalisation::from_code(NeutralScale.code()).unwrap(),
            NeutralScale
        );
        assert_eq!(
            InputNormalisation::from_code(Frobenius.code()).unwrap(),
            Frobenius
        );
        assert_eq!(
            InputNormalisation::from_code(0),
            Err(crate::s2d::decoder::DecoderError::UnknownInputCode(0))
        );
    }

    #[test]
    fn weights_of_both_variants() {
        // Vertices at x = 0 (the landmark), 1, 2, 4.
        let tpl = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
        ];
        let d = landmark_distances(&tpl, &[0]).unwrap();
        assert_eq!(d, [0.0, 1.0, 2.0, 4.0]);
        // Code: 1 − d/4.
        assert_eq!(vertex_weights(LossVariant::Code, &d), [1.0, 0.75, 0.5, 0.0]);
        // Paper: 1/d = [·, 1, 0.5, 0.25], landmark gets the max 1; rescaled (u − 0.25)/0.75.
        let w = vertex_weights(LossVariant::Paper, &d);
        let expected = [1.0, 1.0, 1.0 / 3.0, 0.0];
        assert!(w.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-6));
        assert!(matches!(
            landmark_distances(&tpl, &[4]),
            Err(crate::s2d::objective::LandmarkError::Outside { vertex: 4, .. })
        ));
        assert_eq!(vertex_weights(LossVariant::Code, &[2.0, 2.0]), [1.0, 1.0]);
        assert_eq!(vertex_weights(LossVariant::Paper, &[2.0, 2.0]), [1.0, 1.0]);
    }

    #[test]
    fn loss_values_hand_computed() {
        let device = crate::training::backend::Backend::Flex.device(1).unwrap();
        // batch 1, 2 vertices: e = [[1, 0, 2], [0, 3, 0]], w = [1, 0.5].
        let p = tensor(vec![1.0, 0.0, 2.0, 0.0, 3.0, 0.0], [1, 2, 3], &device);
        let t = tensor(vec![0.0; 6], [1, 2, 3], &device);
        let w = weights_tensor(&[1.0, 0.5], &device);
        // Code: (1·3 + 0.5·3)/3 + 0.1·6/6 = 1.5 + 0.1 = 1.6.
        let code = to_vec(loss(LossVariant::Code, p.clone(), t.clone(), w.clone()))[0];
        assert!((code - 1.6).abs() < 1e-6, "{code}");
        // Paper: L_dr = 6/2 = 3, L_pr = 4.5/2 = 2.25; 3 + 0.225 = 3.225.
        let paper = to_vec(loss(LossVariant::Paper, p, t, w))[0];
        assert!((paper - 3.225).abs() < 1e-6, "{paper}");
    }

    #[test]
    fn schedule_and_shuffle() {
        let c = TrainConfig::default();
        assert_eq!(c.lr_at(0), 1e-3);
        assert!((c.lr_at(1) - 0.99e-3).abs() < 1e-12);
        let short = TrainConfig {
            epochs: 30,
            ..TrainConfig::default()
        };
        // 30 epochs decay like 300: ×0.99^10 per epoch.
        assert!((short.lr_at(3) - c.lr_at(30)).abs() < 1e-12);
        let a = epoch_order(50, 1, 0);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..50).collect::<Vec<_>>());
        assert_eq!(a, epoch_order(50, 1, 0));
        assert_ne!(a, epoch_order(50, 1, 1));
        assert_ne!(a, epoch_order(50, 2, 0));
    }

    /// Every float parameter of `d`, in visiting order.
    fn parameters(d: &S2dDecoder) -> Vec<f32> {
        struct Collect(Vec<f32>);
        impl ModuleVisitor for Collect {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                self.0.extend(to_vec(param.val()));
            }
        }
        let mut c = Collect(Vec::new());
        d.visit(&mut c);
        c.0
    }

    /// Two halves at once take the same Adam step as the whole batch (up to rounding), and the
    /// same step every time, bit for bit.
    #[test]
    fn halves_step_like_the_whole_batch() {
        let device = crate::training::backend::Backend::Flex
            .autodiff_device(6)
            .unwrap();
        let h = synthetic::hierarchy(&[40, 15, 6], &[6, 5, 4], 3);
        let config = synthetic::small_config();
        let decoder = S2dDecoder::new(&config, &h, &device).unwrap();
        let mut rng = synthetic::Rng::new(8);
        // An odd batch: halves of 2 and 3 samples.
        let set: Vec<Sample> = (0..5)
            .map(|_| Sample {
                input: (0..6).map(|_| rng.uniform(-1.0, 1.0)).collect(),
                displacement: (0..120).map(|_| rng.uniform(-0.1, 0.1)).collect(),
            })
            .collect();
        let batch = Batch::new(&set, &[0, 1, 2, 3, 4], &device);
        let weights = weights_tensor(
            &(0..40).map(|v| v as f32 / 40.0).collect::<Vec<_>>(),
            &device,
        );
        let tc = TrainConfig::default();
        let halves = Halves::new().unwrap();
        let before = parameters(&decoder);
        let step = |split: bool| {
            let mut optim = tc.optimizer();
            let (d, l) = step_once(
                decoder.clone(),
                &mut optim,
                &batch,
                &weights,
                LossVariant::Code,
                1e-3,
                split.then_some(&halves),
            );
            (parameters(&d), to_vec(l)[0])
        };
        let (whole, whole_loss) = step(false);
        let (split, split_loss) = step(true);
        assert!((whole_loss - split_loss).abs() <= 1e-6 * whole_loss.abs());
        // Adam's first step moves every parameter by about lr = 1e-3 whatever the gradient's
        // size, so a wrong gradient shows as a different sign or a missing step.
        let moved = |p: &[f32]| {
            p.iter()
                .zip(&before)
                .map(|(a, b)| a - b)
                .collect::<Vec<_>>()
        };
        let (a, b) = (moved(&whole), moved(&split));
        assert!(a.iter().filter(|d| d.abs() > 5e-4).count() > a.len() / 2);
        let worst = a
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "the halves' step differs by {worst}");
        let (again, again_loss) = step(true);
        assert_eq!(
            again.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            split.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(again_loss.to_bits(), split_loss.to_bits());
    }

    /// A small decoder learns a fixed linear map from inputs to displacements: the epoch loss falls.
    #[test]
    fn training_reduces_the_loss() {
        let device = crate::training::backend::Backend::Flex
            .autodiff_device(5)
            .unwrap();
        let h = synthetic::hierarchy(&[40, 15, 6], &[6, 5, 4], 3);
        let config = DecoderConfig {
            inputs: 6,
            fc_features: 8,
            filters: vec![8, 8],
            ..DecoderConfig::default()
        };
        let decoder = S2dDecoder::new(&config, &h, &device).unwrap();
        let mut rng = synthetic::Rng::new(4);
        let basis: Vec<f32> = (0..6 * 120).map(|_| rng.uniform(-0.5, 0.5)).collect();
        let set: Vec<Sample> = (0..48)
            .map(|_| {
                let input: Vec<f32> = (0..6).map(|_| rng.uniform(-1.0, 1.0)).collect();
                let displacement = (0..120)
                    .map(|j| (0..6).map(|i| input[i] * basis[i * 120 + j]).sum())
                    .collect();
                Sample {
                    input,
                    displacement,
                }
            })
            .collect();
        let tc = TrainConfig {
            epochs: 60,
            batch: 8,
            lr: 3e-3,
            ..TrainConfig::default()
        };
        let w = vec![1.0; 40];
        let trained = train(decoder, &set, &w, &tc, &device, &TrainOptions::default()).unwrap();
        assert!(trained.complete());
        let losses = trained.state.losses;
        assert_eq!(losses.len(), 60);
        assert!(
            losses[59] < 0.5 * losses[0],
            "loss did not fall: {losses:?}"
        );
    }

    #[test]
    fn bad_runs_are_refused_by_variant() {
        let device = crate::training::backend::Backend::Flex
            .autodiff_device(6)
            .unwrap();
        let h = synthetic::hierarchy(&[40, 15, 6], &[6, 5, 4], 3);
        let decoder = S2dDecoder::new(&synthetic::small_config(), &h, &device).unwrap();
        let set = vec![Sample {
            input: vec![0.0; 6],
            displacement: vec![0.0; 120],
        }];
        let weights = vec![1.0; 40];
        let tc = TrainConfig {
            epochs: 1,
            batch: 1,
            ..TrainConfig::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let resume = |dir: Option<PathBuf>| TrainOptions {
            checkpoint_dir: dir,
            resume: true,
            stop_after: None,
            context: BTreeMap::new(),
        };
        // Resuming from an empty folder: its missing state file is named.
        let e = train(
            decoder.clone(),
            &set,
            &weights,
            &tc,
            &device,
            &resume(Some(dir.path().to_owned())),
        )
        .unwrap_err();
        assert!(
            matches!(&e, TrainError::Checkpoint(_)) && e.to_string().contains(STATE_FILE),
            "{e:?}"
        );
        let e = train(decoder.clone(), &set, &weights, &tc, &device, &resume(None)).unwrap_err();
        assert!(matches!(e, TrainError::ResumeWithoutFolder), "{e:?}");
        let e = train(decoder, &set, &weights[1..], &tc, &device, &resume(None)).unwrap_err();
        assert!(
            matches!(
                e,
                TrainError::VertexWeights {
                    found: 39,
                    vertices: 40
                }
            ),
            "{e:?}"
        );
    }
}
