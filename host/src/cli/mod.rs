//! The `sinew` command line: one clap-derived struct per command, one file per command group.
//! Each command's options are typed here (a flag beats its environment variable, which beats the
//! default: clap's `env`), then the work is handed to the library; nothing here computes.

mod aim;
mod args;
mod bones;
mod data;
mod driver;
mod export;
mod fit;
mod motion;
mod render;
mod replay;
mod rig;
mod s2d;
mod view;

use std::path::PathBuf;

use anyhow::Result;
use clap::{Parser, Subcommand};

/// Sinew: learn an actor's face from meshes, and play it back anywhere, bit for bit.
#[derive(Debug, Parser)]
#[command(name = "sinew", version, about)]
pub(crate) struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The built-in demo: train a small AIM on the built-in face (the ICT-FaceKit face region,
    /// decimated), bake it, play it back through sinew-core, and write the report, pictures and
    /// OBJs. Needs no data files.
    Demo(aim::DemoArgs),
    /// Train a model.
    #[command(subcommand)]
    Train(Train),
    /// Measure a baked model on data.
    #[command(subcommand)]
    Eval(Eval),
    /// Re-bake a model from a training checkpoint.
    Bake(aim::BakeArgs),
    /// Pose a baked actor through sinew-core, one OBJ per frame, from a pose file or an ARKit
    /// capture.
    Play(aim::PlayArgs),
    /// Write a baked actor in another engine's format.
    #[command(subcommand)]
    Export(export::Export),
    /// Show what a .sinew file holds: kind, version, sections, shapes, sizes, checksum status.
    Inspect {
        /// The .sinew file.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Anatomy editing.
    #[command(subcommand)]
    Edit(aim::Edit),
    /// Bones under the skin.
    #[command(subcommand)]
    Bones(bones::Bones),
    /// A studio's blendshape rig (glTF or OBJ folder): what Sinew understands of it.
    #[command(subcommand)]
    Rig(rig::RigCommand),
    /// Record and verify bit-exact playback replays.
    #[command(subcommand)]
    Replay(replay::Replay),
    /// S2D: sparse-to-dense expression decoding.
    #[command(subcommand)]
    S2d(s2d::S2d),
    /// Fit a baked AIM actor to a performance's meshes (AIM eqs. 17–24): per-frame head, jaw
    /// and corrective coefficients, and the fitted meshes.
    Fit(fit::FitArgs),
    /// Retarget a performance from one AIM actor to another in vertex correspondence (AIM Fig.
    /// 8): the source fitted (or a fit of it), its head, jaw and coefficients played on the
    /// target, and the jaw-only and soft-tissue-only parts, through sinew-core.
    Retarget(fit::RetargetArgs),
    /// Generate data sets.
    #[command(subcommand)]
    Data(data::Data),
    /// A label and a seed become a 4D expression of a face: a baked Motion3DGAN generator makes
    /// the landmark motion on the neutral, a baked S2D-Dec the meshes (frame_01.obj to
    /// frame_30.obj and strip.png), all through sinew-core.
    Generate(motion::GenerateLabelArgs),
    /// Two labels' motions (same seed) joined along the hypersphere's geodesic: each step's apex
    /// as a mesh (frame_NN.obj) and strip.png.
    Interpolate(motion::InterpolateArgs),
    /// Show a baked actor in a web browser: serves a page on 127.0.0.1 that poses it through
    /// sinew-core compiled to WebAssembly (sliders, orbit, replay playback). Prints the page's
    /// address as its first line; stops on Ctrl-C.
    View(view::ViewArgs),
    /// Drive a baked actor with a landmark track (an OpenFace 2.0 CSV or a performance folder)
    /// through its driver in sinew-core: one OBJ per frame and strip.png; a lost frame holds
    /// the last pose.
    Drive(driver::DriveArgs),
    /// Photograph a performance's frames through its camera with a lit skin shading that face
    /// trackers take for a face: frame_00000.png, … and performance.y4m (the video a browser's
    /// fake camera, ffmpeg or MediaPipe reads).
    Render(render::RenderArgs),
}

#[derive(Debug, Subcommand)]
enum Train {
    /// Learn an AIM actor from ICT-FaceKit blendshapes or a studio's rig, to an accuracy.
    Aim(Box<aim::TrainAim>),
    /// Train S2D-Dec on pairs from `sinew data s2d-pairs` under a cross-validation protocol,
    /// bake each fold's model, and compare it with the PCA baselines on the held-out pairs
    /// (report JSON, and a cumulative-error PNG beside it).
    S2d(s2d::TrainS2dArgs),
    /// Train Motion3DGAN (conditional WGAN-GP on SRVF tangent vectors) on a motion set from
    /// `sinew data motions`, with checkpoints and --resume; bake the generator (.sinew) and
    /// write the loss curves beside it.
    Motion(motion::TrainMotionArgs),
    /// Train a landmark driver for a baked actor: a network from one frame's 68 landmarks to
    /// its head, jaw and coefficients, learnt from the actor's own poses drawn on the fly, with
    /// checkpoints and --resume; bake it (.sinew) and write the loss curve beside it.
    Driver(driver::TrainDriverArgs),
}

#[derive(Debug, Subcommand)]
enum Eval {
    /// Evaluate a model from `sinew train s2d` (through sinew-core) and the 3DMM baselines on the
    /// held-out pairs of the fold it was trained for (or of each of its folds, `--folds`).
    S2d(s2d::EvalS2d),
    /// Per-vertex error of a baked AIM actor on its ICT-FaceKit training shapes.
    Aim(aim::EvalAim),
    /// AIM's Table 1 on a performance: GBS, PBS, and the global and local AIM fits.
    Fit(fit::EvalFitArgs),
    /// Table 3 of S2D: a sequence classifier and the LSTM baseline trained on the training
    /// motions; accuracy, Fréchet distance and diversity of the ground truth, a baked Motion3DGAN
    /// generator (through sinew-core) and the LSTM, on generated landmarks and on landmarks
    /// re-extracted from S2D-Dec meshes (report JSON).
    Motion(motion::EvalMotionArgs),
    /// A landmark driver on a performance folder: per-vertex error against its meshes and the
    /// core's time per frame.
    Driver(driver::EvalDriverArgs),
}

/// Runs the parsed command.
pub(crate) fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo(args) => aim::demo(args),
        Command::Train(Train::Aim(args)) => aim::train(*args),
        Command::Train(Train::S2d(args)) => s2d::train(args),
        Command::Train(Train::Motion(args)) => motion::train(args),
        Command::Train(Train::Driver(args)) => driver::train(args),
        Command::Eval(Eval::Driver(args)) => driver::eval(args),
        Command::Drive(args) => driver::drive(args),
        Command::Eval(Eval::S2d(args)) => s2d::eval(args),
        Command::Eval(Eval::Aim(args)) => aim::eval(args),
        Command::Eval(Eval::Fit(args)) => fit::eval(args),
        Command::Eval(Eval::Motion(args)) => motion::eval(args),
        Command::Fit(args) => fit::fit(args),
        Command::Retarget(args) => fit::retarget(args),
        Command::Bake(args) => aim::bake(args),
        Command::Play(args) => aim::play(args),
        Command::Export(cmd) => export::run(cmd),
        Command::Rig(cmd) => rig::run(cmd),
        Command::Inspect { file, json } => {
            let report = sinew_host::io::inspect::inspect(&file)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print!("{report}");
            }
            Ok(())
        }
        Command::Edit(cmd) => aim::edit(cmd),
        Command::Bones(cmd) => bones::run(cmd),
        Command::Replay(cmd) => replay::run(cmd),
        Command::S2d(cmd) => s2d::run(cmd),
        Command::Data(cmd) => data::run(cmd),
        Command::Generate(args) => motion::generate(args),
        Command::Interpolate(args) => motion::interpolate(args),
        Command::View(args) => view::run(args),
        Command::Render(args) => render::run(args),
    }
}
