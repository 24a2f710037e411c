//! `sinew train motion`: Motion3DGAN trained on a motion set, with checkpoints and `--resume`, a
//! progress bar, a loss-curve PNG and a JSON report, baked into a `.sinew` generator
//! (docs/MOTION.md; the sections in docs/FORMAT.md, "Motion generator").

use std::path::PathBuf;

use anyhow::{Context, Result, ensure};
use burn::tensor::Device;
use serde::{Deserialize, Serialize};
use sinew_core::ArtifactKind;
use sinew_core::srvf::FRAMES;

use super::checkpoint::{load_checkpoint, save_checkpoint};
use super::classes::LABELS;
use super::data::MotionSet;
use super::gan::{GanConfig, Generator, StepLosses};
use super::train::{Run, TangentData};
use crate::io::container::SinewWriter;
use crate::training::backend::Backend;
use crate::training::checkpoint;
use crate::training::interrupt::{Pieces, take_stop_request, train_in_pieces};

/// `content` metadata of a baked generator.
pub const CONTENT: &str = "motion-generator";

/// The baked generator: kind `MotionGenerator`, the generator's MLP under `motion.g`, the
/// reference motion `motion.p`, per label the mean and spread of the arc length,
/// `motion.length` `[LABELS, 2]`, and, for motions with curves, of the reach's logarithm,
/// `motion.log_reach` `[LABELS, 2]`.
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
    w.f32s("motion.length", &[LABELS.len(), 2], &data.lengths_flat())?;
    if let Some(reaches) = data.log_reaches_flat() {
        w.f32s("motion.log_reach", &[LABELS.len(), 2], &reaches)?;
    }
    let bytes = w.to_bytes()?;
    // The core must take what the host writes: a generator whose weights let the network exceed
    // the core's value bounds is refused here, before a file that cannot play is written (the
    // checkpoints stay).
    sinew_core::motion::MotionGenerator::from_bytes(&bytes)
        .context("the trained generator does not validate in sinew-core; nothing was baked")?;
    Ok(bytes)
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
    /// Per label (in `LABELS` order), the mean and the standard deviation of the training
    /// curves' arc length.
    pub lengths: Vec<[f32; 2]>,
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
    ensure!(
        config.lr.is_finite() && config.lr > 0.0,
        "--lr must be a positive number, not {}",
        config.lr
    );
    ensure!(
        config.alpha_rec.is_finite() && config.alpha_rec >= 0.0,
        "--rec-weight must be a number of at least 0, not {}",
        config.alpha_rec
    );
    ensure!(
        config.diversity.is_finite() && config.diversity >= 0.0,
        "--diversity-weight must be a number of at least 0, not {}",
        config.diversity
    );
    ensure!(
        config.class_weight.is_finite() && config.class_weight >= 0.0,
        "--class-weight must be a number of at least 0, not {}",
        config.class_weight
    );
    let device: Device = opts.backend.autodiff_device(config.seed)?;
    let fresh = Run::new(&data, config, &device).with_context(|| {
        format!(
            "{}: the label guide of --class-weight",
            opts.motions.display()
        )
    })?;
    let (dir, run) = match &opts.resume {
        Some(dir) => (dir.clone(), load_checkpoint(dir, fresh, config, &data)?),
        None => (checkpoint::checkpoint_dir_for(&opts.out), fresh),
    };
    let started = std::time::Instant::now();
    let pieces = Pieces {
        steps: config.steps,
        every: opts.checkpoint_every,
        quiet: opts.quiet,
        dir: &dir,
    };
    let run = train_in_pieces(
        run,
        &pieces,
        |run| run.step,
        take_stop_request,
        |run, until, bar, stop| {
            run.advance(
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
                stop,
            )
        },
        |run| save_checkpoint(&dir, run, config, &data),
    )?;
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
    png.save_png(&opts.out.with_extension("losses.png"))?;
    let report = TrainReport {
        config: config.clone(),
        sequences: data.tangents.len(),
        lengths: data.lengths.clone(),
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
