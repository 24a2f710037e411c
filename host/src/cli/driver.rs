//! `sinew train driver`, `sinew drive` and `sinew eval driver`: the live driver (docs/FIT.md,
//! "Live driver").

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use sinew_core::driver::{Intrinsics, Space};
use sinew_core::filter::OneEuro;
use sinew_host::driver::DriverConfig;
use sinew_host::driver::commands::{
    DriveCommand, TrainDriver, drive_command, eval_driver, train_driver,
};
use sinew_host::training::backend::Backend;

/// The landmarks a driver reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum InputArg {
    /// 2D pixels normalised by the camera's intrinsics.
    #[value(name = "2d")]
    TwoD,
    /// 3D landmarks in the actor's unit and frame.
    #[value(name = "3d")]
    ThreeD,
}

/// `sinew train driver`'s options.
#[derive(Debug, Args)]
pub(crate) struct TrainDriverArgs {
    /// The baked actor the driver drives.
    #[arg(long)]
    model: PathBuf,
    /// The driver to write (`.sinew`); the loss picture goes beside it (`OUT.losses.png`),
    /// checkpoints into `OUT.ckpt/`.
    #[arg(long)]
    out: PathBuf,
    /// JSON report (settings, landmark vertices, loss per step, time).
    #[arg(long)]
    report: Option<PathBuf>,
    /// 2D (a webcam tracker's pixels) or 3D landmarks.
    #[arg(long, value_enum, default_value_t = InputArg::TwoD)]
    input: InputArg,
    /// Continue from this checkpoint folder (same settings and actor).
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Seed of the weights and of every step's samples.
    #[arg(long, env = "SINEW_SEED", default_value_t = DriverConfig::default().seed)]
    seed: u64,
    /// Adam steps.
    #[arg(long, default_value_t = DriverConfig::default().steps)]
    steps: usize,
    /// Samples per step.
    #[arg(long, default_value_t = DriverConfig::default().batch)]
    batch: usize,
    /// Hidden units per layer (three hidden layers).
    #[arg(long, default_value_t = DriverConfig::default().hidden)]
    hidden: usize,
    /// Adam's first learning rate (decaying exponentially to --lr-final).
    #[arg(long, default_value_t = DriverConfig::default().lr)]
    lr: f64,
    /// Adam's last learning rate.
    #[arg(long, default_value_t = DriverConfig::default().lr_final)]
    lr_final: f64,
    /// Largest landmark noise drawn, pixels.
    #[arg(long, default_value_t = DriverConfig::default().noise)]
    noise_px: f64,
    /// Steps between checkpoints.
    #[arg(long, default_value_t = 1000)]
    checkpoint_every: usize,
    /// burn backend.
    #[arg(long, value_enum, default_value_t = Backend::default())]
    backend: Backend,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// `sinew train driver`.
pub(crate) fn train(args: TrainDriverArgs) -> Result<()> {
    let config = DriverConfig {
        input: match args.input {
            InputArg::TwoD => Space::Image,
            InputArg::ThreeD => Space::World,
        },
        seed: args.seed,
        steps: args.steps,
        batch: args.batch,
        hidden: args.hidden,
        lr: args.lr,
        lr_final: args.lr_final,
        noise: args.noise_px,
        ..DriverConfig::default()
    };
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let report = train_driver(&TrainDriver {
        model: args.model,
        out: args.out.clone(),
        report: args.report,
        resume: args.resume,
        config,
        checkpoint_every: args.checkpoint_every,
        backend: args.backend,
        quiet: args.quiet,
    })?;
    println!(
        "{}: landmark driver ({} input), {} steps in {:.1} s, final loss {:.4}",
        args.out.display(),
        report.config.input.name(),
        report.history.len(),
        report.seconds,
        report.final_loss
    );
    Ok(())
}

/// `sinew drive`'s options.
#[derive(Debug, Args)]
pub(crate) struct DriveArgs {
    /// The baked actor.
    #[arg(long)]
    model: PathBuf,
    /// Its driver (from `sinew train driver`).
    #[arg(long)]
    driver: PathBuf,
    /// The track: an OpenFace 2.0 CSV (x_0…x_67, y_0…y_67 pixels, or for a 3D driver
    /// X_0…Z_67 millimetres, with confidence and success) or a performance folder (its 2D
    /// track, or its meshes' landmarks for a 3D driver).
    #[arg(long)]
    landmarks: PathBuf,
    /// Output folder: frame_00000.obj, … and strip.png.
    #[arg(long)]
    out: PathBuf,
    /// The CSV's camera: focal lengths and principal point in pixels, FX,FY,CX,CY.
    #[arg(long, value_delimiter = ',')]
    intrinsics: Option<Vec<f32>>,
    /// A CSV row whose confidence is below this is a lost frame (it holds the last pose).
    #[arg(long, default_value_t = 0.5)]
    min_confidence: f32,
    /// The One Euro filter on the driven poses: MIN_CUTOFF_HZ,BETA,FPS (off without it).
    #[arg(long, value_delimiter = ',')]
    filter: Option<Vec<f32>>,
}

/// `--intrinsics FX,FY,CX,CY` as the camera it names (`sinew drive`, `sinew view`).
pub(crate) fn intrinsics(values: Option<&[f32]>) -> Result<Option<Intrinsics>> {
    Ok(match values {
        None => None,
        Some(&[fx, fy, cx, cy]) => Some(Intrinsics { fx, fy, cx, cy }),
        Some(other) => bail!(
            "--intrinsics: expected FX,FY,CX,CY, got {} values",
            other.len()
        ),
    })
}

/// `sinew drive`.
pub(crate) fn drive(args: DriveArgs) -> Result<()> {
    let intrinsics = intrinsics(args.intrinsics.as_deref())?;
    let filter = match args.filter.as_deref() {
        None => None,
        Some(&[min_cutoff, beta, rate]) => Some(
            OneEuro::new(min_cutoff, beta, 1.0, rate)
                .map_err(|e| anyhow::anyhow!("--filter: {e}"))?,
        ),
        Some(other) => bail!(
            "--filter: expected MIN_CUTOFF,BETA,FPS, got {} values",
            other.len()
        ),
    };
    let frames = drive_command(&DriveCommand {
        model: args.model,
        driver: args.driver,
        landmarks: args.landmarks,
        out: args.out.clone(),
        intrinsics,
        min_confidence: args.min_confidence,
        filter,
    })?;
    println!(
        "{}: {frames} frames driven through sinew-core (frame_NNNNN.obj, strip.png)",
        args.out.display()
    );
    Ok(())
}

/// `sinew eval driver`'s options.
#[derive(Debug, Args)]
pub(crate) struct EvalDriverArgs {
    /// The baked actor.
    #[arg(long)]
    model: PathBuf,
    /// Its driver.
    #[arg(long)]
    driver: PathBuf,
    /// A performance folder (`sinew data performance`) on the actor.
    #[arg(long)]
    target: PathBuf,
    /// JSON report.
    #[arg(long)]
    report: Option<PathBuf>,
}

/// `sinew eval driver`.
pub(crate) fn eval(args: EvalDriverArgs) -> Result<()> {
    let m = eval_driver(&args.model, &args.driver, &args.target)?;
    println!(
        "{}: {} frames, mean per-vertex error {:.3} mm; the core's driver {:.4} ms a frame, \
         with posing {:.3} ms",
        args.target.display(),
        m.frames,
        m.mean_error_mm,
        1e3 * m.drive_seconds_per_frame,
        1e3 * m.seconds_per_frame
    );
    if let Some(path) = &args.report {
        sinew_host::io::atomic::write(path, serde_json::to_string_pretty(&m)?.as_bytes())?;
    }
    Ok(())
}
