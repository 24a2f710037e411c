//! `sinew data motions` and `sinew train motion`: Motion3DGAN's data and training
//! (docs/MOTION.md).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use sinew_host::motion::commands::{TrainMotion, train_motion};
use sinew_host::motion::data::{MotionsConfig, Split, generate_to};
use sinew_host::motion::gan::GanConfig;
use sinew_host::training::backend::Backend;

/// `sinew data motions`'s options.
#[derive(Debug, Args)]
pub(crate) struct MotionsArgs {
    /// ICT-FaceKit folder.
    #[arg(long)]
    data: PathBuf,
    /// Output folder (motions.sinew and manifest.json).
    #[arg(long)]
    out: PathBuf,
    /// Seed of the identities, the sequences' timing and the noise.
    #[arg(long, env = "SINEW_SEED", default_value_t = MotionsConfig::default().seed)]
    seed: u64,
    /// Number of identities.
    #[arg(long, default_value_t = MotionsConfig::default().identities)]
    identities: usize,
    /// Sequences per identity and label; the first of each is a test sequence.
    #[arg(long, default_value_t = MotionsConfig::default().per_class)]
    per_class: usize,
}

/// `sinew data motions`.
pub(crate) fn motions(args: MotionsArgs) -> Result<()> {
    let config = MotionsConfig {
        seed: args.seed,
        identities: args.identities,
        per_class: args.per_class,
    };
    config.validate()?;
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let set = generate_to(&args.data, &args.out, &config)?;
    println!(
        "{}: {} synthetic sequences ({} train, {} test) of {} identities in 12 classes over {} \
         expression deltas, {} vertices, 68 landmarks",
        args.out.display(),
        set.len(),
        set.split(Split::Train).len(),
        set.split(Split::Test).len(),
        set.neutrals.len(),
        set.manifest.expressions.len(),
        set.vertices()
    );
    Ok(())
}

/// `sinew train motion`'s options.
#[derive(Debug, Args)]
pub(crate) struct TrainMotionArgs {
    /// Motion set folder (from `sinew data motions`); its training sequences train.
    #[arg(long)]
    motions: PathBuf,
    /// The baked generator to write (`.sinew`); the loss curves go beside it
    /// (`OUT.losses.png`), checkpoints into `OUT.ckpt/`.
    #[arg(long)]
    out: PathBuf,
    /// JSON report (settings, losses per step, time).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Continue from this checkpoint folder (same settings and motions).
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Seed of the weights, the noise and the batches.
    #[arg(long, env = "SINEW_SEED", default_value_t = GanConfig::default().seed)]
    seed: u64,
    /// Generator steps (each after 4 critic steps).
    #[arg(long, default_value_t = GanConfig::default().steps)]
    steps: usize,
    /// Sequences per batch.
    #[arg(long, default_value_t = GanConfig::default().batch)]
    batch: usize,
    /// Adam's learning rate (β = 0.5, 0.9).
    #[arg(long, default_value_t = GanConfig::default().lr)]
    lr: f64,
    /// Hidden widths of the generator and the critic, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = GanConfig::default().hidden)]
    hidden: Vec<usize>,
    /// Generator steps between checkpoints.
    #[arg(long, default_value_t = 500)]
    checkpoint_every: usize,
    /// burn backend.
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// `sinew train motion`.
pub(crate) fn train(args: TrainMotionArgs) -> Result<()> {
    let config = GanConfig {
        seed: args.seed,
        steps: args.steps,
        batch: args.batch,
        lr: args.lr,
        hidden: args.hidden,
        ..GanConfig::default()
    };
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let report = train_motion(&TrainMotion {
        motions: args.motions,
        out: args.out.clone(),
        report: args.report,
        resume: args.resume,
        config,
        checkpoint_every: args.checkpoint_every,
        backend: args.backend,
        quiet: args.quiet,
    })?;
    let last = report.history.last().copied().unwrap_or_default();
    println!(
        "{}: Motion3DGAN generator, {} steps on {} training sequences in {:.1} s; last step: \
         Wasserstein estimate {:.4}, gradient penalty {:.4}, L_r {:.5}",
        args.out.display(),
        report.history.len(),
        report.sequences,
        report.seconds,
        last.wasserstein,
        last.penalty,
        last.reconstruction
    );
    Ok(())
}
