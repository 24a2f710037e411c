//! `sinew train motion`: Motion3DGAN trained on a motion set, with checkpoints and `--resume`, a
//! progress bar, a loss-curve PNG and a JSON report, baked into a `.sinew` generator
//! (docs/MOTION.md; the sections in docs/FORMAT.md, "Motion generator").

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail, ensure};
use burn::module::Module;
use burn::tensor::Device;
use serde::{Deserialize, Serialize};
use sinew_core::ArtifactKind;
use sinew_core::srvf::FRAMES;

use super::classes::LABELS;
use super::data::MotionSet;
use super::gan::{Critic, GanConfig, Generator, StepLosses};
use super::train::{Run, TangentData};
use crate::io::container::SinewWriter;
use crate::training::backend::Backend;
use crate::training::checkpoint::{self, STATE_FILE, WeightFiles};

/// `format` of a checkpoint's `state.json`.
pub const CHECKPOINT_FORMAT: &str = "sinew-motion-checkpoint";
/// `content` metadata of a baked generator.
pub const CONTENT: &str = "motion-generator";

/// Both networks, as one burn record in a checkpoint.
#[derive(Module, Debug)]
pub struct Networks {
    /// The generator.
    pub generator: Generator,
    /// The critic.
    pub critic: Critic,
}

/// A checkpoint's `state.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointState {
    /// [`CHECKPOINT_FORMAT`].
    pub format: String,
    /// The run's settings (a resumed run must have the same).
    pub config: GanConfig,
    /// CRC of the training tangent vectors (a resumed run must train on the same data).
    pub data_crc: String,
    /// Generator steps done.
    pub steps_done: usize,
    /// Per generator step.
    pub history: Vec<StepLosses>,
    /// The weight files.
    pub files: WeightFiles,
}

/// CRC of the reference point and every tangent vector with its label.
pub fn data_crc(data: &TangentData) -> String {
    let mut bytes = Vec::new();
    for x in &data.p {
        bytes.extend(x.to_bits().to_le_bytes());
    }
    for (t, l) in data.tangents.iter().zip(&data.labels) {
        bytes.extend((*l as u32).to_le_bytes());
        for x in t {
            bytes.extend(x.to_bits().to_le_bytes());
        }
    }
    checkpoint::crc_hex(&bytes)
}

/// Writes the run into the checkpoint folder `dir` (created if missing).
pub fn save_checkpoint(
    dir: &Path,
    run: &Run,
    config: &GanConfig,
    data: &TangentData,
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let nets = Networks {
        generator: run.generator.clone(),
        critic: run.critic.clone(),
    };
    let model = nets
        .into_record()
        .into_bytes()
        .map_err(|e| anyhow!("{}: cannot serialise the networks: {e:?}", dir.display()))?;
    let mut opt = Vec::new();
    for o in [&run.g_optim, &run.c_optim] {
        let bytes = o
            .into_bytes()
            .map_err(|e| anyhow!("{}: cannot serialise an optimiser: {e:?}", dir.display()))?;
        // The generator's Adam state, then the critic's, each after its length.
        opt.extend((bytes.len() as u64).to_le_bytes());
        opt.extend_from_slice(&bytes);
    }
    let mut state = CheckpointState {
        format: CHECKPOINT_FORMAT.to_owned(),
        config: config.clone(),
        data_crc: data_crc(data),
        steps_done: run.step,
        history: run.history.clone(),
        files: WeightFiles::default(),
    };
    checkpoint::save(dir, run.step, &model, &opt, &mut state, |s, f| s.files = f)?;
    Ok(())
}

/// Loads the checkpoint in `dir` into `run` (built as for a fresh run), after checking that it
/// belongs to the same settings and data; errors name the file and the difference.
pub fn load_checkpoint(
    dir: &Path,
    run: Run,
    config: &GanConfig,
    data: &TangentData,
) -> Result<Run> {
    let path = dir.join(STATE_FILE);
    let value = checkpoint::read_state_value(dir)?;
    let state: CheckpointState = serde_json::from_value(value)
        .with_context(|| format!("{}: not a Motion3DGAN checkpoint state", path.display()))?;
    ensure!(
        state.format == CHECKPOINT_FORMAT,
        "{}: format {:?}, expected {CHECKPOINT_FORMAT:?}",
        path.display(),
        state.format
    );
    state
        .files
        .validate()
        .with_context(|| format!("{}", path.display()))?;
    ensure!(
        state.config == *config,
        "{}: the checkpoint was trained with other settings ({:?}) than this run's ({:?})",
        path.display(),
        state.config,
        config
    );
    ensure!(
        state.data_crc == data_crc(data),
        "{}: the checkpoint was trained on other motions (data CRC {} here {})",
        path.display(),
        state.data_crc,
        data_crc(data)
    );
    ensure!(
        state.history.len() == state.steps_done,
        "{}: {} steps done but {} recorded",
        path.display(),
        state.steps_done,
        state.history.len()
    );
    let model_path = dir.join(&state.files.model_file);
    let record = burn::store::ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(
        state.files.read_model(dir)?,
    ))
    .map_err(|e| anyhow!("{}: invalid: {e:?}", model_path.display()))?;
    let nets = Networks {
        generator: run.generator,
        critic: run.critic,
    }
    .try_load_record(record)
    .map_err(|e| anyhow!("{}: does not fit the networks: {e:?}", model_path.display()))?;
    let optim_path = dir.join(&state.files.optim_file);
    let opt = state.files.read_optim(dir)?;
    let split = |at: usize| -> Result<(Vec<u8>, usize)> {
        let len = opt
            .get(at..at + 8)
            .and_then(|b| b.try_into().ok())
            .map(u64::from_le_bytes)
            .ok_or_else(|| anyhow!("{}: truncated", optim_path.display()))?
            as usize;
        let bytes = opt
            .get(at + 8..at + 8 + len)
            .ok_or_else(|| anyhow!("{}: truncated", optim_path.display()))?;
        Ok((bytes.to_vec(), at + 8 + len))
    };
    let (g, next) = split(0)?;
    let (c, end) = split(next)?;
    ensure!(end == opt.len(), "{}: trailing bytes", optim_path.display());
    let load = |o: burn::optim::ModuleOptimizer, b: Vec<u8>| {
        o.from_bytes(burn::tensor::Bytes::from_bytes_vec(b))
            .map_err(|e| anyhow!("{}: invalid: {e:?}", optim_path.display()))
    };
    Ok(Run {
        generator: nets.generator,
        critic: nets.critic,
        g_optim: load(run.g_optim, g)?,
        c_optim: load(run.c_optim, c)?,
        step: state.steps_done,
        history: state.history,
    })
}

/// The baked generator: kind `MotionGenerator`, the generator's MLP under `motion.g`, the
/// reference motion `motion.p` and the default intensity `motion.length`.
pub fn bake(generator: &Generator, data: &TangentData, config: &GanConfig) -> Result<Vec<u8>> {
    let d = data.dims() / FRAMES;
    let mut w = SinewWriter::new(ArtifactKind::MotionGenerator);
    w.meta("content", CONTENT)
        .meta("version", 1)
        .meta("labels", LABELS.join(","))
        .meta("noise", config.noise)
        .meta("frames", FRAMES)
        .meta("landmarks", d / 3)
        .meta("seed", config.seed)
        .meta(
            "source",
            "Motion3DGAN (S2D section 3.1) trained by sinew train motion on synthetic motions",
        );
    generator.mlp.export(&mut w, "motion.g")?;
    w.f32s("motion.p", &[FRAMES, d], &data.p)?;
    w.f32s("motion.length", &[1], &[data.length])?;
    Ok(w.to_bytes()?)
}

/// `sinew train motion`'s settings.
#[derive(Clone, Debug)]
pub struct TrainMotion {
    /// The motion set folder.
    pub motions: PathBuf,
    /// The baked generator to write.
    pub out: PathBuf,
    /// A JSON report to write.
    pub report: Option<PathBuf>,
    /// A checkpoint folder to resume from (default: a fresh run, checkpoints in `OUT.ckpt/`).
    pub resume: Option<PathBuf>,
    /// The GAN's settings.
    pub config: GanConfig,
    /// Generator steps between checkpoints.
    pub checkpoint_every: usize,
    /// The burn backend.
    pub backend: Backend,
    /// No progress bar.
    pub quiet: bool,
}

/// The report of a run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TrainReport {
    /// The settings.
    pub config: GanConfig,
    /// Training sequences.
    pub sequences: usize,
    /// The default intensity (mean arc length of the training curves).
    pub length: f32,
    /// Seconds this invocation trained.
    pub seconds: f64,
    /// Per generator step.
    pub history: Vec<StepLosses>,
}

/// `sinew train motion`: trains (or resumes), checkpoints every `checkpoint_every` steps, bakes
/// the generator, and writes the loss curves beside it (`OUT` with extension `losses.png`).
pub fn train_motion(opts: &TrainMotion) -> Result<TrainReport> {
    let set = MotionSet::read(&opts.motions)?;
    let data = TangentData::from_set(&set)
        .with_context(|| format!("{}: the training motions", opts.motions.display()))?;
    let config = &opts.config;
    ensure!(
        config.steps > 0
            && config.batch > 0
            && config.critic_steps > 0
            && opts.checkpoint_every > 0,
        "steps, batch, critic steps and the checkpoint interval must be positive"
    );
    let device: Device = opts.backend.autodiff_device(config.seed)?;
    let fresh = Run::new(&data, config, &device);
    let (dir, mut run) = match &opts.resume {
        Some(dir) => (dir.clone(), load_checkpoint(dir, fresh, config, &data)?),
        None => (checkpoint::checkpoint_dir_for(&opts.out), fresh),
    };
    crate::training::interrupt::watch_ctrl_c();
    let bar = crate::training::progress::bar(config.steps as u64, opts.quiet);
    bar.set_position(run.step as u64);
    let started = std::time::Instant::now();
    let mut stopped = false;
    while run.step < config.steps {
        let until = (run.step + opts.checkpoint_every).min(config.steps);
        run = run.advance(
            &data,
            config,
            &device,
            until,
            &mut |_: usize, l: &StepLosses| {
                bar.inc(1);
                bar.set_message(format!(
                    "W {:.3} GP {:.3} L_r {:.4}",
                    l.wasserstein, l.penalty, l.reconstruction
                ));
            },
            &mut || {
                stopped = crate::training::interrupt::take_stop_request();
                stopped
            },
        );
        save_checkpoint(&dir, &run, config, &data)?;
        if stopped {
            bar.abandon();
            bail!(
                "interrupted after {} steps; checkpoint in {}: continue with --resume {}",
                run.step,
                dir.display(),
                dir.display()
            );
        }
    }
    bar.finish();
    crate::io::atomic::write(&opts.out, &bake(&run.generator, &data, config)?)?;
    let series = |f: fn(&StepLosses) -> f32| -> Vec<(f64, f64)> {
        run.history
            .iter()
            .enumerate()
            .map(|(i, l)| (i as f64, f64::from(f(l))))
            .collect()
    };
    let (w, gp, rec) = (
        series(|l| l.wasserstein),
        series(|l| l.penalty),
        series(|l| l.reconstruction),
    );
    let png = crate::figures::plot::loss_curves(
        &[
            ("Wasserstein estimate", &w),
            ("gradient penalty", &gp),
            ("L_r", &rec),
        ],
        "Motion3DGAN",
        false,
        800,
        500,
    );
    png.write_png(&opts.out.with_extension("losses.png"))?;
    let report = TrainReport {
        config: config.clone(),
        sequences: data.tangents.len(),
        length: data.length,
        seconds: started.elapsed().as_secs_f64(),
        history: run.history,
    };
    if let Some(path) = &opts.report {
        crate::io::atomic::write(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(report)
}

#[cfg(test)]
mod tests;
