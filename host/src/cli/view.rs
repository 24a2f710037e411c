//! `sinew view`: the arguments, and the hand-over to [`sinew_host::view`].

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Result, bail};
use clap::Args;

#[derive(Debug, Args)]
pub(crate) struct ViewArgs {
    /// The baked AIM actor or S2D decoder (.sinew).
    model: PathBuf,
    /// A replay recorded with this actor (`sinew replay record`): the page plays it at 30 frames
    /// per second and checks every frame's hash.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// A pose file for this actor (`sinew play`'s JSON) to play instead of, or beside, a replay.
    #[arg(long)]
    poses: Option<PathBuf>,
    /// A performance fitted to this actor (`sinew fit --out FIT.sinew`): the page plays it at 30
    /// frames per second and checks every frame's hash against those baked in the file.
    #[arg(long)]
    performance: Option<PathBuf>,
    /// For an S2D decoder: a landmark track, an S2D replay recorded with it (`sinew replay
    /// record --model S2D.sinew`); the page decodes it at 30 frames per second, draws the
    /// landmarks and checks every frame's hash.
    #[arg(long)]
    track: Option<PathBuf>,
    /// For an S2D decoder: a face in its topology (.obj or .ply) to decode onto and draw with its
    /// polygons (without it, the track's neutral or the decoder's template, drawn as points).
    #[arg(long)]
    neutral: Option<PathBuf>,
    /// A landmark driver of this actor (`sinew train driver`): the page plays `--landmarks`
    /// through it, or with `--webcam` drives it live from the camera, in the core compiled to
    /// WebAssembly.
    #[arg(long)]
    driver: Option<PathBuf>,
    /// Drive the actor live from the browser's camera: the page runs MediaPipe Face Mesh (from
    /// `--tracker-dir`), calibrates on the first second and drives every frame through
    /// `--driver`, a MediaPipe driver (`sinew train driver --input mediapipe`).
    #[arg(long, requires = "driver", conflicts_with = "landmarks")]
    webcam: bool,
    /// The folder of MediaPipe Face Mesh's web files for `--webcam`: what `npm install
    /// @mediapipe/face_mesh@0.4.1633559619` makes in the folder it runs in.
    #[arg(
        long,
        env = "SINEW_TRACKER_DIR",
        default_value = sinew_host::view::webcam::DEFAULT_TRACKER_DIR
    )]
    tracker_dir: PathBuf,
    /// The driver's track: an OpenFace 2.0 CSV (2D pixels through `--intrinsics`, or 3D
    /// landmarks for a 3D driver) or a performance folder, as `sinew drive` reads it; a lost
    /// frame holds the last pose.
    #[arg(long, requires = "driver")]
    landmarks: Option<PathBuf>,
    /// The track's or the webcam's camera: focal lengths and principal point in pixels,
    /// FX,FY,CX,CY (for the webcam, default: the focal length the video's width, the principal
    /// point at its centre).
    #[arg(long, value_delimiter = ',', requires = "driver")]
    intrinsics: Option<Vec<f32>>,
    /// A CSV row whose confidence is below this is a lost frame.
    #[arg(long, default_value_t = 0.5)]
    min_confidence: f32,
    /// Port on 127.0.0.1; 0 takes any free port.
    #[arg(long, env = "SINEW_VIEW_PORT", default_value_t = 8123)]
    port: u16,
    /// Stop serving after this many seconds (for scripts and tests); without it, serve until
    /// Ctrl-C.
    #[arg(long, value_name = "SECONDS")]
    exit_after_seconds: Option<u64>,
}

/// `sinew view`.
pub(crate) fn run(args: ViewArgs) -> Result<()> {
    let intrinsics = super::driver::intrinsics(args.intrinsics.as_deref())?;
    let (driver, webcam) = match (&args.driver, &args.landmarks) {
        (Some(driver), Some(landmarks)) => (
            Some(sinew_host::view::DriverInputs {
                driver,
                landmarks,
                intrinsics,
                min_confidence: args.min_confidence,
            }),
            None,
        ),
        (Some(driver), None) if args.webcam => (
            None,
            Some(sinew_host::view::WebcamInputs {
                driver,
                tracker: &args.tracker_dir,
                intrinsics,
            }),
        ),
        (Some(driver), None) => bail!(
            "--driver {}: give the track it plays (--landmarks TRACK) or drive it from the \
             camera (--webcam)",
            driver.display()
        ),
        _ => (None, None),
    };
    let inputs = sinew_host::view::Inputs {
        model: &args.model,
        replay: args.replay.as_deref(),
        poses: args.poses.as_deref(),
        performance: args.performance.as_deref(),
        track: args.track.as_deref(),
        neutral: args.neutral.as_deref(),
        driver,
        webcam,
    };
    Ok(sinew_host::view::view(
        inputs,
        args.port,
        args.exit_after_seconds.map(Duration::from_secs),
        |url| {
            println!("{url}");
            eprintln!(
                "sinew view: serving {} on {url} (Ctrl-C stops)",
                args.model.display()
            );
        },
    )?)
}
