//! Landmark tracks a driver plays: an OpenFace 2.0 CSV (2D pixels through the intrinsics the
//! caller gives; a frame the tracker lost or was unsure of is a lost frame), a performance
//! folder's 2D track (through its own camera), or the 3D landmarks of a performance folder's
//! meshes. Read whole and checked before anything is played, so bad input leaves no output.

use std::path::{Path, PathBuf};

use sinew_core::driver::{Intrinsics, LANDMARKS, Space, normalise_pixels};

use crate::fit::performance::{Performance, PerformanceError};
use crate::io::openface::{self, OpenFaceError};

/// A track in a driver's input space: per frame the landmarks, or `None` where the tracker lost
/// the face.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// Where the landmarks live.
    pub space: Space,
    /// Per frame, `[68 × dims]` or `None`.
    pub frames: Vec<Option<Vec<f32>>>,
}

/// Why a track cannot be read for a driver.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrackError {
    /// The OpenFace CSV is broken (the error names the file, row and column).
    #[error(transparent)]
    OpenFace(#[from] OpenFaceError),
    /// The performance folder is broken (the error names the file).
    #[error(transparent)]
    Performance(#[from] PerformanceError),
    /// A CSV track without the camera's intrinsics.
    #[error("{}: an OpenFace track needs the camera's intrinsics (--intrinsics FX,FY,CX,CY)", path.display())]
    NoIntrinsics {
        /// The track.
        path: PathBuf,
    },
    /// A CSV track for a 3D driver.
    #[error("{}: an OpenFace CSV holds 2D landmarks, the driver reads 3D ones", path.display())]
    NotThreeD {
        /// The track.
        path: PathBuf,
    },
    /// A frame the core refuses (a pixel or intrinsic out of range).
    #[error("{}: frame {frame}: {source}", path.display())]
    Refused {
        /// The track.
        path: PathBuf,
        /// The frame (0-based).
        frame: usize,
        /// What the core said.
        #[source]
        source: sinew_core::EvalError,
    },
    /// A performance whose landmark list is not 68 long, or names a vertex its meshes lack.
    #[error("{}: its landmarks are not 68 vertices of its meshes", path.display())]
    Landmarks {
        /// The manifest.
        path: PathBuf,
    },
}

/// Reads the track at `path` for a driver reading `space`: a folder is a performance
/// (`performance.json`), a file an OpenFace 2.0 CSV, lost where `success` is 0 or `confidence`
/// is below `min_confidence`.
///
/// # Errors
/// A [`TrackError`] naming the file (and the row and column of a CSV's bad value).
pub fn read(
    path: &Path,
    space: Space,
    intrinsics: Option<Intrinsics>,
    min_confidence: f32,
) -> Result<Track, TrackError> {
    if path.is_dir() {
        return performance(path, space);
    }
    if space == Space::World {
        return Err(TrackError::NotThreeD {
            path: path.to_owned(),
        });
    }
    let rows = openface::read(path)?;
    let camera = intrinsics.ok_or_else(|| TrackError::NoIntrinsics {
        path: path.to_owned(),
    })?;
    let frames = rows
        .iter()
        .enumerate()
        .map(|(f, row)| {
            if !row.success || row.confidence < min_confidence {
                return Ok(None);
            }
            let mut out = vec![0.0; 2 * LANDMARKS];
            normalise_pixels(&row.pixels, &camera, &mut out).map_err(|source| {
                TrackError::Refused {
                    path: path.to_owned(),
                    frame: f,
                    source,
                }
            })?;
            Ok(Some(out))
        })
        .collect::<Result<Vec<_>, TrackError>>()?;
    Ok(Track { space, frames })
}

/// A performance folder's track: its 2D pixels through its camera, or its meshes' landmark
/// vertices in 3D.
fn performance(dir: &Path, space: Space) -> Result<Track, TrackError> {
    let perf = Performance::read(dir)?;
    let m = &perf.manifest;
    let bad = || TrackError::Landmarks {
        path: dir.join(crate::fit::performance::MANIFEST),
    };
    if m.landmarks.vertices.len() != LANDMARKS
        || m.landmarks
            .vertices
            .iter()
            .any(|&v| v as usize >= m.vertices)
        || m.landmarks.pixels.iter().any(|p| p.len() != LANDMARKS)
    {
        return Err(bad());
    }
    let camera = Intrinsics {
        fx: m.camera.fx,
        fy: m.camera.fy,
        cx: m.camera.cx,
        cy: m.camera.cy,
    };
    let frames = (0..m.frames)
        .map(|f| match space {
            Space::Image => {
                let pixels: Vec<f32> = m.landmarks.pixels[f].iter().flatten().copied().collect();
                let mut out = vec![0.0; 2 * LANDMARKS];
                normalise_pixels(&pixels, &camera, &mut out).map_err(|source| {
                    TrackError::Refused {
                        path: dir.to_owned(),
                        frame: f,
                        source,
                    }
                })?;
                Ok(Some(out))
            }
            Space::World => Ok(Some(
                m.landmarks
                    .vertices
                    .iter()
                    .flat_map(|&v| perf.frames[f][v as usize])
                    .collect(),
            )),
        })
        .collect::<Result<Vec<_>, TrackError>>()?;
    Ok(Track { space, frames })
}
