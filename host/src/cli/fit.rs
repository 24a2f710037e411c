//! `sinew data performance`: the arguments, and the hand-over to [`sinew_host::fit`].

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use sinew_host::fit::performance::{PerformanceConfig, generate};

/// `sinew data performance`.
#[derive(Debug, Args)]
pub(crate) struct PerformanceArgs {
    /// ICT-FaceKit folder.
    #[arg(long)]
    data: PathBuf,
    /// Output folder (one OBJ per frame and performance.json).
    #[arg(long)]
    out: PathBuf,
    /// Seed of the trajectories and the noise.
    #[arg(long, env = "SINEW_SEED", default_value_t = PerformanceConfig::default().seed)]
    seed: u64,
    /// Number of frames (30 per second).
    #[arg(long, default_value_t = PerformanceConfig::default().frames)]
    frames: usize,
    /// Gaussian noise on every coordinate, standard deviation in mm.
    #[arg(long, default_value_t = 0.0)]
    noise_mm: f32,
    /// A baked AIM actor made on the kit: the meshes take its topology (every template vertex
    /// must be a vertex of the kit's face region), and the jaw moves rigidly about its pivot with
    /// its skinning weights. Without it: the full face region, the jaw through the kit's jaw
    /// shapes only.
    #[arg(long)]
    actor: Option<PathBuf>,
}

/// `sinew data performance`.
pub(crate) fn performance(args: PerformanceArgs) -> Result<()> {
    let config = PerformanceConfig {
        seed: args.seed,
        frames: args.frames,
        noise_mm: args.noise_mm,
        ..PerformanceConfig::default()
    };
    config.validate()?;
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let m = generate(&args.data, args.actor.as_deref(), &config, &args.out)?;
    println!(
        "{}: synthetic performance, {} frames of {} vertices over {} expression shapes, 68 \
         landmarks in a {}×{} image",
        args.out.display(),
        m.frames,
        m.vertices,
        m.expressions.len(),
        m.camera.width,
        m.camera.height
    );
    Ok(())
}
