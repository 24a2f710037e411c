//! `sinew drive`: a landmark track played through the core's driver onto its actor, one OBJ per
//! frame and a picture strip, every frame through `sinew_core::live` (the calibration on the
//! first found frames, the lost-frame rules): a frame the tracker lost, or one the rules find
//! lost, holds the last pose (the rest pose before the first found one); the optional One Euro
//! filter smooths the poses.

use std::path::{Path, PathBuf};

use sinew_core::aim::AimActor;
use sinew_core::driver::{Driver, finish_pose, play};
use sinew_core::filter::OneEuro;
use sinew_core::live::{Live, Outcome, Settings};
use sinew_core::replay::ReplayError;
use sinew_core::{EvalError, FormatError};

use super::track::Track;
use crate::figures::render::{Image, PngError, View, render};
use crate::io::mesh::{Mesh, MeshError};

/// Why a track cannot be driven.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DriveError {
    /// A file that is not the artefact it should be.
    #[error("{}: not {what}", path.display())]
    NotA {
        /// The file.
        path: PathBuf,
        /// What it should be.
        what: &'static str,
        /// Why.
        #[source]
        source: FormatError,
    },
    /// A driver trained for another actor.
    #[error("{}: a driver of another actor than {}", driver.display(), actor.display())]
    OtherActor {
        /// The driver.
        driver: PathBuf,
        /// The actor.
        actor: PathBuf,
        /// What the core said.
        #[source]
        source: ReplayError,
    },
    /// A track of another space than the driver reads.
    #[error("{}: a track of {track} landmarks for a driver of {driver} ones", path.display())]
    Space {
        /// The driver.
        path: PathBuf,
        /// The track's space.
        track: &'static str,
        /// The driver's.
        driver: &'static str,
    },
    /// A frame the core refused.
    #[error("frame {frame}: {source}")]
    Frame {
        /// The frame (0-based).
        frame: usize,
        /// What the core said.
        #[source]
        source: EvalError,
    },
    /// An output folder that cannot be created.
    #[error(transparent)]
    Folder(#[from] crate::io::atomic::CreateFolderError),
    /// A frame that cannot be written.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The strip that cannot be written.
    #[error(transparent)]
    Png(#[from] PngError),
}

/// A validated actor and its driver, bound to each other.
#[derive(Debug)]
pub struct Bound<'a> {
    /// The actor.
    pub actor: AimActor<'a>,
    /// The driver.
    pub driver: Driver<'a>,
}

/// Validates `actor_bytes` (from `actor_path`) and `driver_bytes` (from `driver_path`) and checks
/// that the driver was trained for the actor.
///
/// # Errors
/// [`DriveError::NotA`] or [`DriveError::OtherActor`], naming the file.
pub fn bind<'a>(
    actor_path: &Path,
    actor_bytes: &'a [u8],
    driver_path: &Path,
    driver_bytes: &'a [u8],
) -> Result<Bound<'a>, DriveError> {
    let actor = AimActor::from_bytes(actor_bytes).map_err(|source| DriveError::NotA {
        path: actor_path.to_owned(),
        what: "an AIM actor",
        source,
    })?;
    let driver = Driver::from_bytes(driver_bytes).map_err(|source| DriveError::NotA {
        path: driver_path.to_owned(),
        what: "a landmark driver",
        source,
    })?;
    driver
        .check_actor(actor_bytes, &actor)
        .map_err(|source| DriveError::OtherActor {
            driver: driver_path.to_owned(),
            actor: actor_path.to_owned(),
            source,
        })?;
    Ok(Bound { actor, driver })
}

/// A calibration whose frames' offsets deviate from their mean by more than this (face sizes,
/// root mean square, `Live::calibration_deviation`) was not made at rest: above what a
/// tracker's noise of up to 4 px gives at rest (docs/FIT.md, "Live driving").
pub const UNSTEADY: f32 = 0.15;
/// A calibration frame was not at rest when its deviation (`Live::deviation`) is more than
/// this many times the calibration's median frame's and above [`UNSTEADY_FLOOR`]: the noise
/// of a tracker moves every frame alike, a face that moved moves a few.
pub const UNSTEADY_RATIO: f32 = 2.0;
/// Frame deviations below this (face sizes, 1.75 mm on the ICT actor) are never flagged.
pub const UNSTEADY_FLOOR: f32 = 0.05;

/// The calibration frames whose deviations (`frame_deviation`, in the order of `frames`) say the
/// face was not at rest ([`UNSTEADY_RATIO`], [`UNSTEADY_FLOOR`]).
pub fn unsteady_frames(frames: &[usize], frame_deviation: &[f32]) -> Vec<usize> {
    let mut sorted = frame_deviation.to_vec();
    sorted.sort_by(f32::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let limit = (UNSTEADY_RATIO * median).max(UNSTEADY_FLOOR);
    (frames.iter().zip(frame_deviation))
        .filter(|(_, d)| **d > limit)
        .map(|(f, _)| *f)
        .collect()
}

/// What the calibration found.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationReport {
    /// The track's frames it took.
    pub frames: Vec<usize>,
    /// The root mean square deviation of their offsets from the mean, in face sizes.
    pub deviation: f32,
    /// Each frame's deviation, in face sizes.
    pub frame_deviation: Vec<f32>,
    /// The frames where the face was not at rest ([`unsteady_frames`]).
    pub unsteady: Vec<usize>,
    /// The face size the deviations are in units of, the actor's unit.
    pub face_size: f32,
}

/// A track driven: each frame's pose and what became of the frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Driven {
    /// Per frame, the pose played (`[18 + M]`).
    pub poses: Vec<Vec<f32>>,
    /// Per frame, what became of it.
    pub outcomes: Vec<Outcome>,
    /// Per frame driven (accepted or lost), its residual in face sizes (`Live::residual`).
    pub residuals: Vec<Option<f32>>,
    /// The calibration, once complete.
    pub calibration: Option<CalibrationReport>,
}

impl Driven {
    /// The frames lost to the rules (found by the tracker, refused by `sinew_core::live`).
    pub fn lost(&self) -> Vec<usize> {
        (self.outcomes.iter().enumerate())
            .filter(|(_, o)| matches!(o, Outcome::Lost(_)))
            .map(|(f, _)| f)
            .collect()
    }

    /// The frames the tracker lost (no landmarks).
    pub fn missing(&self) -> Vec<usize> {
        (self.outcomes.iter().enumerate())
            .filter(|(_, o)| **o == Outcome::Missing)
            .map(|(f, _)| f)
            .collect()
    }
}

/// Every frame of `track` through the core's live step under `settings` (`driver_path` named in
/// errors), filtered when `filter` is given.
///
/// # Errors
/// [`DriveError::Space`] for a track of the other space; [`DriveError::Frame`] for a frame the
/// core refuses, or settings it refuses (frame 0).
pub fn drive_track(
    bound: &Bound<'_>,
    driver_path: &Path,
    track: &Track,
    settings: Settings,
    filter: Option<&OneEuro>,
) -> Result<Driven, DriveError> {
    let d = &bound.driver;
    if track.space != d.space() {
        return Err(DriveError::Space {
            path: driver_path.to_owned(),
            track: track.space.name(),
            driver: d.space().name(),
        });
    }
    let live = Live::new(d, &bound.actor, settings)
        .map_err(|source| DriveError::Frame { frame: 0, source })?;
    let mut state = vec![0.0; live.state_len()];
    let mut scratch = vec![0.0; live.scratch_len()];
    let mut smooth = vec![0.0; OneEuro::state_len(d.output_len())];
    let mut driven = Driven {
        poses: Vec::with_capacity(track.frames.len()),
        outcomes: Vec::with_capacity(track.frames.len()),
        residuals: Vec::with_capacity(track.frames.len()),
        calibration: None,
    };
    let mut calibration_frames = Vec::new();
    for (frame, (landmarks, &time)) in track.frames.iter().zip(&track.times).enumerate() {
        let mut pose = vec![0.0; d.output_len()];
        let outcome = live
            .step(
                &mut state,
                landmarks.as_deref(),
                time,
                &mut scratch,
                &mut pose,
            )
            .map_err(|source| DriveError::Frame { frame, source })?;
        if outcome == Outcome::Calibrating {
            calibration_frames.push(frame);
        }
        if let Some(f) = filter {
            f.apply(&mut smooth, &mut pose)
                .map_err(|e| DriveError::Frame {
                    frame,
                    source: e.into(),
                })?;
            finish_pose(&mut pose);
        }
        driven.poses.push(pose);
        driven.outcomes.push(outcome);
        let judged = matches!(outcome, Outcome::Driven | Outcome::Lost(_));
        driven
            .residuals
            .push(judged.then(|| live.last_residual(&state)));
    }
    if let Some(deviation) = live.calibration_deviation(&state) {
        let frame_deviation = calibration_frames
            .iter()
            .map(|&frame| {
                let l = track.frames[frame].as_deref().unwrap_or(&[]);
                live.deviation(&state, l, &mut scratch)
                    .map(Option::unwrap_or_default)
                    .map_err(|source| DriveError::Frame { frame, source })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let unsteady = unsteady_frames(&calibration_frames, &frame_deviation);
        driven.calibration = Some(CalibrationReport {
            frames: calibration_frames,
            deviation,
            frame_deviation,
            unsteady,
            face_size: live.face_size(),
        });
    }
    Ok(driven)
}

/// Every frame's pose for `track` under `settings` ([`drive_track`]).
///
/// # Errors
/// As [`drive_track`].
pub fn poses(
    bound: &Bound<'_>,
    driver_path: &Path,
    track: &Track,
    settings: Settings,
    filter: Option<&OneEuro>,
) -> Result<Vec<Vec<f32>>, DriveError> {
    Ok(drive_track(bound, driver_path, track, settings, filter)?.poses)
}

/// The actor posed by each of `poses` through the core, `[V]` positions per frame.
///
/// # Errors
/// [`DriveError::Frame`] for a pose the actor refuses.
pub fn meshes(actor: &AimActor<'_>, poses: &[Vec<f32>]) -> Result<Vec<Vec<[f32; 3]>>, DriveError> {
    let mut flat = vec![0.0; 3 * actor.vertex_count()];
    poses
        .iter()
        .enumerate()
        .map(|(frame, p)| {
            play(actor, p, &mut flat).map_err(|source| DriveError::Frame { frame, source })?;
            Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        })
        .collect()
}

/// Writes `frame_00000.obj`, … and `strip.png` (up to six frames spread over the track, front
/// view) into `out`.
///
/// # Errors
/// [`DriveError::Folder`], [`DriveError::Mesh`] or [`DriveError::Png`], naming the file.
pub fn write_frames(
    actor: &AimActor<'_>,
    poses: &[Vec<f32>],
    out: &Path,
) -> Result<usize, DriveError> {
    crate::io::atomic::create_folder(out, "output folder")?;
    let mesh = Mesh::of_actor(actor);
    let triangles = mesh.triangles();
    let shown: Vec<usize> = spread(poses.len(), 6);
    let mut panels = Vec::new();
    let mut flat = vec![0.0; 3 * actor.vertex_count()];
    for (frame, p) in poses.iter().enumerate() {
        play(actor, p, &mut flat).map_err(|source| DriveError::Frame { frame, source })?;
        let positions: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        if shown.contains(&frame) {
            let mut panel = render(&positions, &triangles, &[], &View::front(240, 300));
            panel.text(6, 6, &format!("frame {frame}"), [40, 40, 40], 1);
            panels.push(panel);
        }
        mesh.with_positions(positions)
            .write(&out.join(format!("frame_{frame:05}.obj")))?;
    }
    Image::hstack(&panels).save_png(&out.join("strip.png"))?;
    Ok(poses.len())
}

/// `n` frames of `len` spread from the first to the last (all when fewer).
fn spread(len: usize, n: usize) -> Vec<usize> {
    if len <= n {
        return (0..len).collect();
    }
    (0..n).map(|i| i * (len - 1) / (n - 1)).collect()
}
