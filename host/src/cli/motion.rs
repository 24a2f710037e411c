//! `sinew data motions`: labelled landmark motions for Motion3DGAN (docs/MOTION.md).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use sinew_host::motion::data::{MotionsConfig, Split, generate_to};

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
