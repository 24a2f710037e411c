//! `sinew drive`: a landmark track played through the core's driver onto its actor, one OBJ per
//! frame and a picture strip. A lost frame holds the last pose (the rest pose before the first
//! found one); the optional One Euro filter smooths the driven poses.

use std::path::{Path, PathBuf};

use sinew_core::aim::AimActor;
use sinew_core::driver::{Driver, finish_pose, play};
use sinew_core::filter::OneEuro;
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

/// The rest pose: identity head and jaw, zero coefficients.
pub fn rest_pose(shapes: usize) -> Vec<f32> {
    let mut p = vec![0.0; 18 + shapes];
    for i in [0, 4, 9, 13] {
        p[i] = 1.0;
    }
    p
}

/// Every frame's pose for `track` (`driver_path` named in errors): driven where the track has
/// landmarks, the last pose held where it lost them, filtered when `filter` is given.
///
/// # Errors
/// [`DriveError::Space`] for a track of the other space; [`DriveError::Frame`] for a frame the
/// core refuses.
pub fn poses(
    bound: &Bound<'_>,
    driver_path: &Path,
    track: &Track,
    filter: Option<&OneEuro>,
) -> Result<Vec<Vec<f32>>, DriveError> {
    let d = &bound.driver;
    if track.space != d.space() {
        return Err(DriveError::Space {
            path: driver_path.to_owned(),
            track: track.space.name(),
            driver: d.space().name(),
        });
    }
    let mut scratch = vec![0.0; d.scratch_len()];
    let mut last = rest_pose(d.shape_count());
    let mut state = vec![0.0; OneEuro::state_len(d.output_len())];
    let mut out = Vec::with_capacity(track.frames.len());
    for (frame, landmarks) in track.frames.iter().enumerate() {
        if let Some(l) = landmarks {
            let mut pose = vec![0.0; d.output_len()];
            d.drive(l, &mut scratch, &mut pose)
                .map_err(|source| DriveError::Frame { frame, source })?;
            if let Some(f) = filter {
                f.apply(&mut state, &mut pose)
                    .map_err(|e| DriveError::Frame {
                        frame,
                        source: e.into(),
                    })?;
                finish_pose(&mut pose);
            }
            last = pose;
        }
        out.push(last.clone());
    }
    Ok(out)
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
