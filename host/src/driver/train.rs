//! Training a driver: an MLP (three hidden GELU layers) from the normalised landmark features to
//! the normalised pose, Adam over fresh samples each step on the posed vertices' squared error
//! (the Gauss–Newton metric of `metric`) plus a little of the pose's own squared error (which
//! keeps what no vertex sees, such as a 6D column's length, near its training values),
//! checkpoints in the shared layout of `training::checkpoint`.

use std::path::Path;

use burn::module::Module;
use burn::optim::GradientsParams;
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use sinew_core::driver::MAX_INPUT;
use sinew_core::nn::Activation;

use super::DriverConfig;
use super::sample::{Sample, Sampler};
use crate::training::adam::Adam;
use crate::training::checkpoint::{self, CheckpointError, WeightFiles};
use crate::training::nn::{Mlp, tensor, to_vec};
use crate::training::random::Stream;

/// `format` of a driver checkpoint's `state.json`.
pub const CHECKPOINT_FORMAT: &str = "sinew-driver-checkpoint";

/// Samples the normalisation is measured on.
const NORMALISATION_SAMPLES: usize = 8192;

/// The mean and scale (1 / standard deviation) of each input and the offset and scale (standard
/// deviation) of each output, measured on samples of their own seeded stream.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Normalisation {
    /// μ_in.
    pub input_mean: Vec<f32>,
    /// s_in.
    pub input_scale: Vec<f32>,
    /// μ_out.
    pub output_offset: Vec<f32>,
    /// s_out.
    pub output_scale: Vec<f32>,
}

impl Normalisation {
    /// Measured on `NORMALISATION_SAMPLES` samples.
    pub fn measure(sampler: &Sampler, seed: u64) -> Self {
        let mut rng = step_stream(seed, u64::MAX);
        let samples: Vec<Sample> = (0..NORMALISATION_SAMPLES)
            .map(|_| sampler.sample(&mut rng))
            .collect();
        let stats = |rows: Vec<&Vec<f32>>| -> (Vec<f32>, Vec<f32>) {
            let n = rows.len() as f64;
            let d = rows[0].len();
            let mean: Vec<f64> = (0..d)
                .map(|i| rows.iter().map(|r| f64::from(r[i])).sum::<f64>() / n)
                .collect();
            let sd = (0..d)
                .map(|i| {
                    let v = rows
                        .iter()
                        .map(|r| (f64::from(r[i]) - mean[i]).powi(2))
                        .sum::<f64>()
                        / n;
                    // A value that never moves (a coefficient the actor lacks) keeps unit scale.
                    if v.sqrt() > 1e-6 { v.sqrt() } else { 1.0 }
                })
                .collect::<Vec<f64>>();
            (
                mean.iter().map(|&m| m as f32).collect(),
                sd.iter().map(|&s| s as f32).collect(),
            )
        };
        let (input_mean, input_sd) = stats(samples.iter().map(|s| &s.features).collect());
        let (output_offset, output_scale) = stats(samples.iter().map(|s| &s.pose).collect());
        Self {
            input_mean,
            input_scale: input_sd.iter().map(|s| 1.0 / s).collect(),
            output_offset,
            output_scale,
        }
    }

    fn input(&self, s: &Sample) -> Vec<f32> {
        s.features
            .iter()
            .zip(self.input_mean.iter().zip(&self.input_scale))
            .map(|(x, (m, k))| ((x - m) * k).clamp(-MAX_INPUT, MAX_INPUT))
            .collect()
    }

    fn target(&self, s: &Sample) -> Vec<f32> {
        s.pose
            .iter()
            .zip(self.output_offset.iter().zip(&self.output_scale))
            .map(|(y, (o, k))| (y - o) / k)
            .collect()
    }
}

/// The seeded stream of step `step`'s samples.
fn step_stream(seed: u64, step: u64) -> Stream {
    Stream::new(seed, 0xd1_7e_50_01, u128::from(step) << 1 | 1)
}

/// The driver network: `[D, H, H, H, 18 + M]`, GELU then linear.
pub fn network(inputs: usize, hidden: usize, outputs: usize, device: &Device) -> Mlp {
    let acts = [
        Activation::Gelu,
        Activation::Gelu,
        Activation::Gelu,
        Activation::Identity,
    ];
    Mlp::new(&[inputs, hidden, hidden, hidden, outputs], &acts, device)
}

/// A training run: the network, Adam, and where it stands.
pub struct Run {
    /// The network.
    pub net: Mlp,
    /// Adam.
    pub optim: Adam,
    /// Steps done.
    pub step: usize,
    /// The loss of every step.
    pub history: Vec<f32>,
}

impl std::fmt::Debug for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Run")
            .field("step", &self.step)
            .finish_non_exhaustive()
    }
}

impl Run {
    /// A fresh run on the autodiff `device` (seeded by the caller).
    pub fn new(inputs: usize, outputs: usize, config: &DriverConfig, device: &Device) -> Self {
        Self {
            net: network(inputs, config.hidden, outputs, device),
            optim: Adam::default(),
            step: 0,
            history: Vec::new(),
        }
    }

    /// Steps until `until` are done or `stop` says so after a step; `observe` sees each loss.
    /// `metric` is the vertex metric on normalised outputs (`metric::normalised`, `[P, P]`).
    #[allow(clippy::too_many_arguments)]
    pub fn advance(
        mut self,
        sampler: &Sampler,
        norm: &Normalisation,
        metric: &[f32],
        config: &DriverConfig,
        device: &Device,
        until: usize,
        observe: &mut dyn FnMut(usize, f32),
        stop: &mut dyn FnMut() -> bool,
    ) -> Self {
        while self.step < until {
            let mut rng = step_stream(config.seed, self.step as u64);
            let (mut x, mut y) = (Vec::new(), Vec::new());
            for _ in 0..config.batch {
                let s = sampler.sample(&mut rng);
                x.extend(norm.input(&s));
                y.extend(norm.target(&s));
            }
            let d = x.len() / config.batch;
            let p = y.len() / config.batch;
            let x: Tensor<2> = tensor(x, [config.batch, d], device);
            let y: Tensor<2> = tensor(y, [config.batch, p], device);
            let metric: Tensor<2> = tensor(metric.to_vec(), [p, p], device);
            let diff = self.net.forward(x) - y;
            // êᵀ M ê per sample, then the mean over the batch and the outputs.
            let vertices = (diff.clone().matmul(metric) * diff.clone()).mean();
            let loss = vertices + (diff.clone() * diff).mean().mul_scalar(config.pose_weight);
            let value = to_vec(loss.clone().detach())
                .first()
                .copied()
                .unwrap_or(f32::NAN);
            let grads = GradientsParams::from_grads(loss.backward(), &self.net);
            self.net = self.optim.step(config.lr_at(self.step), self.net, grads);
            observe(self.step, value);
            self.history.push(value);
            self.step += 1;
            if stop() {
                break;
            }
        }
        self
    }
}

/// A driver checkpoint's `state.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointState {
    /// [`CHECKPOINT_FORMAT`].
    pub format: String,
    /// The run's settings (a resumed run must have the same).
    pub config: DriverConfig,
    /// The actor's content hash, 16 hex digits (a resumed run must train for the same actor).
    pub actor: String,
    /// Steps done.
    pub steps_done: usize,
    /// The loss of every step.
    pub history: Vec<f32>,
    /// The weight files.
    pub files: WeightFiles,
}

/// Writes the run into `dir` (created if missing).
pub fn save_checkpoint(
    dir: &Path,
    run: &Run,
    config: &DriverConfig,
    actor: &str,
) -> Result<(), CheckpointError> {
    std::fs::create_dir_all(dir).map_err(|source| CheckpointError::CreateDir {
        path: dir.to_owned(),
        source,
    })?;
    let model = run
        .net
        .clone()
        .into_record()
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "network", e))?;
    let optim = run
        .optim
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "optimiser", e))?;
    let mut state = CheckpointState {
        format: CHECKPOINT_FORMAT.to_owned(),
        config: config.clone(),
        actor: actor.to_owned(),
        steps_done: run.step,
        history: run.history.clone(),
        files: WeightFiles::default(),
    };
    checkpoint::save(dir, run.step, &model, &optim, &mut state, |s, f| {
        s.files = f;
    })
}

/// Loads the checkpoint in `dir` into `run` (built as for a fresh run), after checking that it
/// belongs to the same settings and actor; errors name the file and every difference.
pub fn load_checkpoint(
    dir: &Path,
    run: Run,
    config: &DriverConfig,
    actor: &str,
) -> Result<Run, CheckpointError> {
    let (state, _): (CheckpointState, _) =
        checkpoint::read_state(dir, "a driver checkpoint state")?;
    let mut other = Vec::new();
    if state.actor != actor {
        other.push(format!(
            "actor (content hash): {} in the checkpoint, {actor} now",
            state.actor
        ));
    }
    let run_state = checkpoint::StepRunState {
        format: &state.format,
        files: &state.files,
        config: &state.config,
        steps_done: state.steps_done,
        history: state.history.len(),
    };
    checkpoint::check_step_run(
        dir,
        &run_state,
        CHECKPOINT_FORMAT,
        config,
        config.steps,
        other,
    )?;
    let net = checkpoint::load_module(
        run.net,
        dir.join(&state.files.model_file),
        state.files.read_model(dir)?,
        "the driver network",
    )?;
    let optim_path = dir.join(&state.files.optim_file);
    let optim = run
        .optim
        .load(state.files.read_optim(dir)?, &net)
        .map_err(|e| CheckpointError::Record {
            path: optim_path,
            detail: format!("{e:?}"),
        })?;
    Ok(Run {
        net,
        optim,
        step: state.steps_done,
        history: state.history,
    })
}
