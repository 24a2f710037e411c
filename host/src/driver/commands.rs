//! `sinew train driver`, `sinew drive` and `sinew eval driver`: the commands' glue (checkpoints,
//! progress, the loss picture, reports).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, ensure};
use serde::{Deserialize, Serialize};
use sinew_core::driver::Intrinsics;
use sinew_core::filter::OneEuro;
use sinew_core::live::Settings;
use sinew_core::replay::model_hash;

use super::DriverConfig;
use super::bake::{BakeInputs, bake};
use super::drive::{Driven, bind, drive_track, poses, write_frames};
use super::measure::{DriverMeasure, measure};
use super::sample::Sampler;
use super::train::{Normalisation, Run, load_checkpoint, save_checkpoint};
use crate::io::container::{self, read_actor};
use crate::io::performance::Performance;
use crate::training::backend::Backend;
use crate::training::checkpoint;
use crate::training::interrupt::{Pieces, take_stop_request, train_in_pieces};

/// `sinew train driver`'s settings.
#[derive(Clone, Debug)]
pub struct TrainDriver {
    /// The actor.
    pub model: PathBuf,
    /// The driver to write.
    pub out: PathBuf,
    /// A JSON report to write.
    pub report: Option<PathBuf>,
    /// A checkpoint folder to resume from (default: a fresh run, checkpoints in `OUT.ckpt/`).
    pub resume: Option<PathBuf>,
    /// The run's settings.
    pub config: DriverConfig,
    /// Steps between checkpoints.
    pub checkpoint_every: usize,
    /// The burn backend.
    pub backend: Backend,
    /// No progress bar.
    pub quiet: bool,
    /// MediaPipe's canonical face, for a driver that reads MediaPipe's points.
    pub canonical_face: Option<PathBuf>,
}

/// The report of a run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TrainDriverReport {
    /// The settings.
    pub config: DriverConfig,
    /// The actor's content hash, 16 hex digits.
    pub actor: String,
    /// The actor's vertex of each landmark.
    pub landmark_vertices: Vec<u32>,
    /// Seconds this invocation trained.
    pub seconds: f64,
    /// The mean of the last 100 steps' losses (normalised units).
    pub final_loss: f32,
    /// The loss of every step.
    pub history: Vec<f32>,
}

/// `sinew train driver`: trains (or resumes), checkpoints, bakes the driver, writes the loss
/// picture beside it (`OUT` with extension `losses.png`) and the report.
pub fn train_driver(opts: &TrainDriver) -> Result<TrainDriverReport> {
    let config = &opts.config;
    ensure!(
        config.steps > 0 && config.batch > 0 && config.hidden > 0 && opts.checkpoint_every > 0,
        "steps, batch, hidden units and the checkpoint interval must be positive"
    );
    for (name, v) in [
        ("--noise-px", config.noise),
        ("--convention-amplitude", config.convention_amplitude),
    ] {
        ensure!(
            v.is_finite() && v >= 0.0,
            "{name} {v}: must be a finite number, 0 or more"
        );
    }
    let bytes = container::read(&opts.model)?;
    let actor = container::actor(&opts.model, &bytes)?;
    let vertices = match config.tracker {
        super::Tracker::Ibug => super::landmark_vertices(&opts.model, &actor)?,
        super::Tracker::MediaPipe => {
            ensure!(
                config.input == sinew_core::driver::Space::Image,
                "a MediaPipe driver reads 2D landmarks"
            );
            let face = opts.canonical_face.as_deref().ok_or_else(|| {
                anyhow!(
                    "a MediaPipe driver needs MediaPipe's canonical face (--canonical-face \
                     canonical_face_model.obj, from MediaPipe's \
                     mediapipe/modules/face_geometry/data)"
                )
            })?;
            super::mediapipe::actor_vertices(&opts.model, &actor, face)?
        }
    };
    let sampler = Sampler::new(&actor, &vertices, config);
    let norm = Normalisation::measure(&sampler, config.seed);
    let g = super::metric::gauss_newton(&actor)
        .map_err(|e| anyhow!("{}: posing the actor at rest: {e}", opts.model.display()))?;
    let metric = super::metric::normalised(&g, &norm.output_scale);
    let hash = model_hash(&bytes);
    let actor_hex = format!("{hash:016x}");
    let device = opts.backend.autodiff_device(config.seed)?;
    let inputs = config.input.features();
    let outputs = 18 + actor.shape_count();
    let fresh = Run::new(inputs, outputs, config, &device);
    let (dir, run) = match &opts.resume {
        Some(dir) => (
            dir.clone(),
            load_checkpoint(dir, fresh, config, &actor_hex)?,
        ),
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
                &sampler,
                &norm,
                &metric,
                config,
                &device,
                until,
                &mut |_, loss| {
                    bar.inc(1);
                    bar.set_message(format!("loss {loss:.4}"));
                },
                stop,
            )
        },
        |run| save_checkpoint(&dir, run, config, &actor_hex),
    )?;
    let units = actor
        .file()
        .metadata()
        .get("units")
        .unwrap_or("cm")
        .to_owned();
    let baked = bake(
        &run.net,
        &norm,
        config,
        &BakeInputs {
            actor_hash: hash,
            units: &units,
            vertices: &vertices,
            camera: sampler.camera,
        },
    )?;
    sinew_core::driver::Driver::from_bytes(&baked).map_err(|e| {
        anyhow!(
            "{}: the baked driver does not load: {e}",
            opts.out.display()
        )
    })?;
    crate::io::atomic::write(&opts.out, &baked)?;
    let curve: Vec<(f64, f64)> = run
        .history
        .iter()
        .enumerate()
        .map(|(i, &l)| (i as f64, f64::from(l)))
        .collect();
    crate::figures::plot::loss_curves(&[("loss", &curve)], "driver", true, 800, 500)
        .save_png(&opts.out.with_extension("losses.png"))?;
    let tail = &run.history[run.history.len().saturating_sub(100)..];
    let report = TrainDriverReport {
        config: config.clone(),
        actor: actor_hex,
        landmark_vertices: vertices,
        seconds: started.elapsed().as_secs_f64(),
        final_loss: tail.iter().sum::<f32>() / tail.len().max(1) as f32,
        history: run.history,
    };
    if let Some(path) = &opts.report {
        crate::io::atomic::write(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(report)
}

/// `sinew drive`'s settings.
#[derive(Clone, Debug)]
pub struct DriveCommand {
    /// The actor.
    pub model: PathBuf,
    /// Its driver.
    pub driver: PathBuf,
    /// The track: an OpenFace 2.0 CSV or a performance folder.
    pub landmarks: PathBuf,
    /// The output folder.
    pub out: PathBuf,
    /// A CSV's camera.
    pub intrinsics: Option<Intrinsics>,
    /// A CSV row below this confidence is a lost frame.
    pub min_confidence: f32,
    /// The One Euro filter: minimum cutoff (Hz), speed coefficient, frame rate (Hz).
    pub filter: Option<OneEuro>,
    /// The calibration and the lost-frame rules.
    pub live: Settings,
    /// The driver's `calibration_depth` share replaced for this run (`--calibration-depth`).
    pub calibration_depth: Option<f32>,
}

/// The driver at `path`, its `calibration_depth` entry (the share of its own answer in the
/// calibrated head's depth, docs/FIT.md "The head's depth") replaced by `share` when given.
pub fn read_driver(path: &Path, share: Option<f32>) -> Result<Vec<u8>> {
    let bytes = container::read(path)?;
    let Some(share) = share else {
        return Ok(bytes);
    };
    ensure!(
        (0.0..=1.0).contains(&share),
        "--calibration-depth {share}: a share from 0 to 1"
    );
    let file = sinew_core::SinewFile::from_bytes(&bytes)
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let mut w = container::SinewWriter::from_file(&file)?;
    w.meta(sinew_core::driver::CALIBRATION_DEPTH, share);
    Ok(w.to_bytes()?)
}

/// `sinew drive`: every frame's pose through the core, written as OBJs and `strip.png` once the
/// whole track has been read and driven (bad input leaves no output); returns what became of
/// each frame and the calibration.
pub fn drive_command(opts: &DriveCommand) -> Result<Driven> {
    let actor_bytes = read_actor(&opts.model)?;
    let driver_bytes = read_driver(&opts.driver, opts.calibration_depth)?;
    let bound = bind(&opts.model, &actor_bytes, &opts.driver, &driver_bytes)?;
    let placement = super::track::Placement::of(&opts.model, &bound.actor, &bound.driver)?;
    let track = read_track(
        &opts.landmarks,
        &driver_bytes,
        &bound,
        opts.intrinsics,
        opts.min_confidence,
        placement,
    )?;
    let driven = drive_track(
        &bound,
        &opts.driver,
        &track,
        opts.live,
        opts.filter.as_ref(),
    )
    .with_context(|| format!("{}: driving", opts.landmarks.display()))?;
    write_frames(&bound.actor, &driven.poses, &opts.out)?;
    Ok(driven)
}

/// The track at `path` as the driver reads it: a MediaPipe driver's as MediaPipe writes it
/// (`driver::mediapipe`), another's as `track::read` reads it. A track of the other tracker's
/// landmarks is refused.
fn read_track(
    path: &Path,
    driver_bytes: &[u8],
    bound: &super::drive::Bound<'_>,
    intrinsics: Option<Intrinsics>,
    min_confidence: f32,
    placement: super::track::Placement,
) -> Result<super::track::Track, super::track::TrackError> {
    use super::track::TrackError;
    let jsonl = path.extension().is_some_and(|e| e == "jsonl");
    if super::mediapipe::reads_mediapipe(driver_bytes) {
        if path.is_dir() || !jsonl {
            return Err(TrackError::Tracker {
                path: path.to_owned(),
                why: "the driver reads MediaPipe Face Mesh's points: give a MediaPipe track \
                      (.jsonl, docs/FIT.md \"MediaPipe Face Mesh\")",
            });
        }
        return super::mediapipe::read_track(path, intrinsics);
    }
    if jsonl {
        return Err(TrackError::Tracker {
            path: path.to_owned(),
            why: "a MediaPipe track for a driver of iBUG's 68 landmarks: train one with \
                  `sinew train driver --input mediapipe`",
        });
    }
    super::track::read(
        path,
        bound.driver.space(),
        intrinsics,
        min_confidence,
        placement,
    )
}

/// `sinew eval driver`: the driver on a performance folder against its meshes, under the live
/// `settings`, its `calibration_depth` share replaced by `share` when given.
pub fn eval_driver(
    model: &Path,
    driver: &Path,
    target: &Path,
    track: Option<(&Path, Option<Intrinsics>)>,
    settings: Settings,
    share: Option<f32>,
) -> Result<DriverMeasure> {
    let actor_bytes = read_actor(model)?;
    let driver_bytes = read_driver(driver, share)?;
    let bound = bind(model, &actor_bytes, driver, &driver_bytes)?;
    let perf = Performance::read(target)?;
    ensure!(
        perf.manifest.vertices == bound.actor.vertex_count(),
        "{}: meshes of {} vertices, the actor has {}",
        target.display(),
        perf.manifest.vertices,
        bound.actor.vertex_count()
    );
    let placement = super::track::Placement::of(model, &bound.actor, &bound.driver)?;
    let track = match track {
        Some((path, intrinsics)) => {
            let intrinsics = intrinsics.or(Some(Intrinsics {
                fx: perf.manifest.camera.fx,
                fy: perf.manifest.camera.fy,
                cx: perf.manifest.camera.cx,
                cy: perf.manifest.camera.cy,
            }));
            let t = read_track(path, &driver_bytes, &bound, intrinsics, 0.0, placement)?;
            ensure!(
                t.frames.len() == perf.manifest.frames,
                "{}: {} frames, the performance {} has {}",
                path.display(),
                t.frames.len(),
                target.display(),
                perf.manifest.frames
            );
            t
        }
        None => read_track(target, &driver_bytes, &bound, None, 0.0, placement)?,
    };
    Ok(measure(
        &bound,
        driver,
        &track,
        &perf,
        perf.unit.mm(),
        settings,
    )?)
}

/// `sinew fit --start driver`'s starts: the driver at `driver_path` bound to the actor at `model`
/// and run over the performance at `target` (its 2D track, or its meshes' landmarks for a 3D
/// driver). Returns the driver's content hash (16 hex digits) and each frame's head (9) and jaw
/// (9).
pub fn driven_starts(
    model: &Path,
    driver_path: &Path,
    target: &Path,
) -> Result<(String, Vec<[f32; 18]>)> {
    let bytes = crate::io::container::read(model)?;
    let driver_bytes = crate::io::container::read(driver_path)?;
    let bound = bind(model, &bytes, driver_path, &driver_bytes)?;
    let placement = super::track::Placement::of(model, &bound.actor, &bound.driver)?;
    let track = super::track::read(target, bound.driver.space(), None, 0.0, placement)?;
    let poses = poses(&bound, driver_path, &track, Settings::OFF, None)
        .with_context(|| format!("{}: driving", target.display()))?;
    let starts = poses
        .iter()
        .map(|p| std::array::from_fn(|i| p[i]))
        .collect();
    Ok((format!("{:016x}", model_hash(&driver_bytes)), starts))
}
