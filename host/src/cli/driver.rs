//! `sinew train driver`, `sinew drive` and `sinew eval driver`: the live driver (docs/FIT.md,
//! "Live driver").

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use sinew_core::driver::{Intrinsics, Space};
use sinew_core::filter::OneEuro;
use sinew_core::live::{self, Settings};
use sinew_host::driver::commands::{
    DriveCommand, TrainDriver, drive_command, eval_driver, train_driver,
};
use sinew_host::driver::{DriverConfig, Tracker, drive};
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
    /// MediaPipe Face Mesh's points (2D, at iBUG's 68 places), the actor's found by
    /// registering MediaPipe's canonical face (--canonical-face).
    #[value(name = "mediapipe")]
    MediaPipe,
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
    /// 2D (a webcam tracker's pixels), 3D landmarks, or MediaPipe Face Mesh's.
    #[arg(long, value_enum, default_value_t = InputArg::TwoD)]
    input: InputArg,
    /// MediaPipe's canonical face (canonical_face_model.obj, 468 vertices, from MediaPipe's
    /// mediapipe/modules/face_geometry/data), for --input mediapipe.
    #[arg(long)]
    canonical_face: Option<PathBuf>,
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
    /// A tracker's convention drawn for each sample: smooth offsets of the landmarks from the
    /// landmark vertices (`sinew data performance --convention`), this root mean square on the
    /// contour in the actor's unit (0.2: 2 mm on an actor in centimetres; 0: none).
    #[arg(long, default_value_t = DriverConfig::default().convention_amplitude)]
    convention_amplitude: f64,
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
            InputArg::TwoD | InputArg::MediaPipe => Space::Image,
            InputArg::ThreeD => Space::World,
        },
        tracker: match args.input {
            InputArg::MediaPipe => Tracker::MediaPipe,
            InputArg::TwoD | InputArg::ThreeD => Tracker::Ibug,
        },
        seed: args.seed,
        steps: args.steps,
        batch: args.batch,
        hidden: args.hidden,
        lr: args.lr,
        lr_final: args.lr_final,
        noise: args.noise_px,
        convention_amplitude: args.convention_amplitude,
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
        canonical_face: args.canonical_face,
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
    /// X_0…Z_67 millimetres, with confidence and success), a performance folder (its 2D
    /// track, or its meshes' landmarks for a 3D driver), or for a MediaPipe driver a MediaPipe
    /// Face Mesh track (.jsonl, docs/FIT.md "MediaPipe Face Mesh").
    #[arg(long)]
    landmarks: PathBuf,
    /// Output folder: frame_00000.obj, … and strip.png.
    #[arg(long)]
    out: PathBuf,
    /// The CSV's camera: focal lengths and principal point in pixels, FX,FY,CX,CY (a
    /// MediaPipe track without it: a webcam's, the focal length the image's width).
    #[arg(long, value_delimiter = ',')]
    intrinsics: Option<Vec<f32>>,
    /// A CSV row whose confidence is below this is a lost frame (it holds the last pose).
    #[arg(long, default_value_t = 0.5)]
    min_confidence: f32,
    /// The One Euro filter on the driven poses: MIN_CUTOFF_HZ,BETA,FPS (off without it).
    #[arg(long, value_delimiter = ',')]
    filter: Option<Vec<f32>>,
    #[command(flatten)]
    live: LiveArgs,
}

/// The calibration and the lost-frame rules (`sinew drive`, `sinew eval driver`).
#[derive(Debug, Args)]
pub(crate) struct LiveArgs {
    /// Take the first N found frames as the face at rest looking at the camera: the tracker's
    /// convention is measured there and taken off every later frame, which are written at rest
    /// until then (docs/FIT.md, "Live driving"). 0: no calibration.
    #[arg(long, default_value_t = 0)]
    calibrate_frames: u32,
    /// The lost-frame rules, RESIDUAL,SPEED,TURN,REACQUIRE: the largest residual (face sizes),
    /// the fastest the face moves (face sizes a second) and turns (radians a second), and the
    /// seconds after which a run of jumps is taken as real motion; 0 turns a rule off,
    /// `0,0,0,0` all of them.
    #[arg(long, value_delimiter = ',', default_values_t = live::Settings::defaults(0).values()[1..].to_vec())]
    lost_rules: Vec<f32>,
    /// The share of the driver's own answer in the calibrated head's depth, from 0 (the head
    /// found on the nose and eyes alone) to 1, for this run in place of the one the driver
    /// records (docs/FIT.md, "The head's depth"): a tracker whose eyes or nose sit off the
    /// actor's may want more.
    #[arg(long, value_name = "SHARE")]
    calibration_depth: Option<f32>,
}

impl LiveArgs {
    /// The settings, checked.
    fn settings(&self) -> Result<Settings> {
        let &[max_residual, max_speed, max_turn, reacquire] = self.lost_rules.as_slice() else {
            bail!(
                "--lost-rules: expected RESIDUAL,SPEED,TURN,REACQUIRE, got {} values",
                self.lost_rules.len()
            );
        };
        let settings = Settings {
            calibrate_frames: self.calibrate_frames,
            max_residual,
            max_speed,
            max_turn,
            reacquire,
        };
        settings.check().map_err(|e| {
            anyhow::anyhow!(
                "{}: {e}",
                [
                    "--calibrate-frames",
                    "--lost-rules",
                    "--lost-rules",
                    "--lost-rules",
                    "--lost-rules"
                ][e.index.min(4)]
            )
        })?;
        Ok(settings)
    }
}

/// The calibration as `report_frames` prints it: its frames, its deviation, and each frame's.
struct CalibrationSeen<'a> {
    frames: &'a [usize],
    deviation: f32,
    frame_deviation: &'a [f32],
}

/// What became of a driven track, on standard error: lost frames, the calibration and the
/// frames of it where the face was not at rest.
fn report_frames(lost: &[usize], missing: &[usize], calibration: Option<CalibrationSeen<'_>>) {
    if let Some(c) = calibration {
        eprintln!(
            "calibrated on frames {} ({} frames), deviation {:.3} face sizes",
            ranges(c.frames),
            c.frames.len(),
            c.deviation
        );
        let unsteady = drive::unsteady_frames(c.frames, c.frame_deviation);
        if !unsteady.is_empty() {
            let worst = c.frame_deviation.iter().copied().fold(0.0, f32::max);
            eprintln!(
                "warning: the face was not at rest on calibration frames {} (up to {worst:.3} \
                 face sizes from the calibration's mean, the other frames' noise is below \
                 {:.3}): calibrate on frames where the face holds still and neutral",
                ranges(&unsteady),
                drive::UNSTEADY_RATIO * median(c.frame_deviation)
            );
        } else if c.deviation > drive::UNSTEADY {
            eprintln!(
                "warning: the face was not at rest during the calibration, frames {} (they \
                 deviate by {:.3} face sizes, more than {}): calibrate on frames where the face \
                 holds still and neutral",
                ranges(c.frames),
                c.deviation,
                drive::UNSTEADY
            );
        }
    }
    eprintln!(
        "{} frames lost to the rules (the last pose held): {}",
        lost.len(),
        if lost.is_empty() {
            "none".into()
        } else {
            ranges(lost)
        }
    );
    if !missing.is_empty() {
        eprintln!(
            "{} frames without a face in the track: {}",
            missing.len(),
            ranges(missing)
        );
    }
}

/// The median of `values` (0 for none).
fn median(values: &[f32]) -> f32 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f32::total_cmp);
    sorted.get(sorted.len() / 2).copied().unwrap_or(0.0)
}

/// Frame numbers as ranges: `3-5, 9`.
fn ranges(frames: &[usize]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < frames.len() {
        let mut j = i;
        while j + 1 < frames.len() && frames[j + 1] == frames[j] + 1 {
            j += 1;
        }
        out.push(if i == j {
            frames[i].to_string()
        } else {
            format!("{}-{}", frames[i], frames[j])
        });
        i = j + 1;
    }
    out.join(", ")
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
    let live = args.live.settings()?;
    let driven = drive_command(&DriveCommand {
        model: args.model,
        driver: args.driver,
        landmarks: args.landmarks,
        out: args.out.clone(),
        intrinsics,
        min_confidence: args.min_confidence,
        filter,
        live,
        calibration_depth: args.live.calibration_depth,
    })?;
    report_frames(
        &driven.lost(),
        &driven.missing(),
        driven.calibration.as_ref().map(|c| CalibrationSeen {
            frames: &c.frames,
            deviation: c.deviation,
            frame_deviation: &c.frame_deviation,
        }),
    );
    println!(
        "{}: {} frames driven through sinew-core (frame_NNNNN.obj, strip.png)",
        args.out.display(),
        driven.poses.len()
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
    /// A tracker's track of the performance's video (`sinew render`) to drive with instead of
    /// the performance's own track: a MediaPipe track (.jsonl) or an OpenFace CSV, one frame
    /// per performance frame.
    #[arg(long)]
    landmarks: Option<PathBuf>,
    /// The track's camera, FX,FY,CX,CY (default: the performance's).
    #[arg(long, value_delimiter = ',')]
    intrinsics: Option<Vec<f32>>,
    /// JSON report.
    #[arg(long)]
    report: Option<PathBuf>,
    #[command(flatten)]
    live: LiveArgs,
}

/// `sinew eval driver`.
pub(crate) fn eval(args: EvalDriverArgs) -> Result<()> {
    let camera = intrinsics(args.intrinsics.as_deref())?;
    let m = eval_driver(
        &args.model,
        &args.driver,
        &args.target,
        args.landmarks.as_deref().map(|p| (p, camera)),
        args.live.settings()?,
        args.live.calibration_depth,
    )?;
    let calibration_frames: Vec<usize> = (m.outcomes.iter().enumerate())
        .filter(|(_, o)| *o == "calibrating")
        .map(|(f, _)| f)
        .collect();
    report_frames(
        &m.lost_frames,
        &m.missing_frames,
        m.calibration_deviation.map(|deviation| CalibrationSeen {
            frames: &calibration_frames,
            deviation,
            frame_deviation: &m.calibration_frame_deviation,
        }),
    );
    println!(
        "{}: {} frames, mean per-vertex error {:.3} mm ({:.3} mm over the performing frames, \
         worst frame {:.3} mm); the core's driver {:.4} ms a frame, with posing {:.3} ms",
        args.target.display(),
        m.frames,
        m.mean_error_mm,
        m.performing_error_mm,
        m.worst_frame_error_mm,
        1e3 * m.drive_seconds_per_frame,
        1e3 * m.seconds_per_frame
    );
    if let Some(path) = &args.report {
        sinew_host::io::atomic::write(path, serde_json::to_string_pretty(&m)?.as_bytes())?;
    }
    Ok(())
}
