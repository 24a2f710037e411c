//! Landmark tracks a driver plays: an OpenFace 2.0 CSV (2D pixels through the intrinsics the
//! caller gives, or 3D landmarks placed in the actor's frame by a [`Placement`]; a frame the
//! tracker lost or was unsure of is a lost frame), a performance folder's 2D track (through its
//! own camera), or the 3D landmarks of a performance folder's meshes. Read whole and checked
//! before anything is played, so bad input leaves no output.

use std::path::{Path, PathBuf};

use sinew_core::aim::AimActor;
use sinew_core::driver::{Driver, Intrinsics, LANDMARKS, Space, normalise_pixels};

use crate::io::openface::{self, OpenFaceError};
use crate::io::performance::{Performance, PerformanceError};

/// A track in a driver's input space: per frame the landmarks, or `None` where the tracker lost
/// the face.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// Where the landmarks live.
    pub space: Space,
    /// Per frame, `[68 × dims]` or `None`.
    pub frames: Vec<Option<Vec<f32>>>,
    /// Per frame, its time stamp in seconds: a CSV's `timestamp` column (frames 1/30 s apart
    /// where it has none), a performance's frame rate. Each at least 1 ms after the last.
    pub times: Vec<f32>,
}

/// The frame rate a CSV without time stamps is taken at.
pub const DEFAULT_FPS: f32 = 30.0;

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
    /// The MediaPipe track is broken (the error names the file, row and point).
    #[error(transparent)]
    MediaPipe(#[from] crate::io::mediapipe::MediaPipeError),
    /// A track of another tracker's landmarks than the driver reads.
    #[error("{}: {why}", path.display())]
    Tracker {
        /// The track.
        path: PathBuf,
        /// Which landmarks each has.
        why: &'static str,
    },
    /// A CSV track without the camera's intrinsics.
    #[error("{}: an OpenFace track needs the camera's intrinsics (--intrinsics FX,FY,CX,CY)", path.display())]
    NoIntrinsics {
        /// The track.
        path: PathBuf,
    },
    /// A CSV track without the 3D landmarks a 3D driver reads.
    #[error(
        "{}: the driver reads 3D landmarks and the CSV has none (OpenFace writes them as \
         X_0 … Z_67 with -3Dfp)",
        path.display()
    )]
    NotThreeD {
        /// The track.
        path: PathBuf,
    },
    /// A CSV track without the 2D landmarks a 2D driver reads.
    #[error(
        "{}: the driver reads 2D landmarks and the CSV has none (OpenFace writes them as \
         x_0 … y_67 with -2Dfp)",
        path.display()
    )]
    NotTwoD {
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
    /// The actor's `units` metadata names no unit this reader knows.
    #[error("{}: its units", path.display())]
    Units {
        /// The actor.
        path: PathBuf,
        /// What the unit parser said.
        #[source]
        source: crate::io::units::UnknownUnit,
    },
    /// A frame whose time stamp is not at least 1 ms after the last frame's.
    #[error("{}: row {row}: timestamp {time} s is not at least 1 ms after the last row's ({last} s)", path.display())]
    Time {
        /// The track.
        path: PathBuf,
        /// The row (1-based; the header is row 1).
        row: usize,
        /// Its time stamp.
        time: f32,
        /// The last row's.
        last: f32,
    },
    /// A performance (or actor) whose landmark list is not 68 long, or names a vertex its meshes
    /// lack.
    #[error("{}: its landmarks are not 68 vertices of its meshes", path.display())]
    Landmarks {
        /// The manifest.
        path: PathBuf,
    },
}

/// Where a camera's 3D landmarks (OpenFace's `X_i`, `Y_i`, `Z_i`: millimetres, x right, y down,
/// z away from the camera) land in the actor's frame: turned to the actor's axes (x to its left,
/// y up, z forward; the face looks at the camera), scaled to its unit, and moved as a whole so
/// that the first found frame's landmarks are centred where the actor's landmarks are at rest.
/// The head's motion from that frame on is kept; where the head sat in the camera's view is not
/// (a 3D driver learns the head within a few centimetres of the actor's rest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Millimetres per actor unit.
    pub mm_per_unit: f32,
    /// The centroid of the actor's 68 landmarks at rest, in its unit and frame.
    pub rest_centroid: [f32; 3],
}

impl Placement {
    /// The placement onto `actor` (read from `model`, named in errors) through `driver`'s
    /// landmark vertices; an actor that records no `units` is in metres, as glTF's.
    ///
    /// # Errors
    /// [`TrackError::Units`] or [`TrackError::Landmarks`], naming `model`.
    pub fn of(model: &Path, actor: &AimActor<'_>, driver: &Driver<'_>) -> Result<Self, TrackError> {
        let mm_per_unit = match actor.file().metadata().get("units") {
            Some(u) => u
                .parse::<crate::io::units::Unit>()
                .map_err(|source| TrackError::Units {
                    path: model.to_owned(),
                    source,
                })?
                .mm() as f32,
            None => 1000.0,
        };
        let rest: Vec<f32> = actor.rest().iter().collect();
        let mut at_rest = vec![0.0; 3 * LANDMARKS];
        driver
            .landmarks_of(&rest, &mut at_rest)
            .map_err(|_| TrackError::Landmarks {
                path: model.to_owned(),
            })?;
        Ok(Self {
            mm_per_unit,
            rest_centroid: centroid(&at_rest),
        })
    }

    /// `landmarks` (`[68, 3]`, camera millimetres) in the actor's axes and unit, not yet moved.
    fn turn(&self, landmarks: &[f32]) -> Vec<f32> {
        landmarks
            .chunks_exact(3)
            .flat_map(|p| [p[0], -p[1], -p[2]].map(|x| x / self.mm_per_unit))
            .collect()
    }
}

/// The centroid of `[n, 3]` points.
pub fn centroid(points: &[f32]) -> [f32; 3] {
    let n = (points.len() / 3).max(1) as f64;
    let mut c = [0.0f64; 3];
    for p in points.chunks_exact(3) {
        for k in 0..3 {
            c[k] += f64::from(p[k]);
        }
    }
    c.map(|x| (x / n) as f32)
}

/// Reads the track at `path` for a driver reading `space`: a folder is a performance
/// (`performance.json`), a file an OpenFace 2.0 CSV, lost where `success` is 0 or `confidence`
/// is below `min_confidence`; a CSV's 2D landmarks go through `intrinsics`, its 3D ones through
/// `placement`.
///
/// # Errors
/// A [`TrackError`] naming the file (and the row and column of a CSV's bad value).
pub fn read(
    path: &Path,
    space: Space,
    intrinsics: Option<Intrinsics>,
    min_confidence: f32,
    placement: Placement,
) -> Result<Track, TrackError> {
    if path.is_dir() {
        return performance(path, space);
    }
    let rows = openface::read(path)?;
    let times = times(path, &rows)?;
    let lost = |row: &openface::OpenFaceFrame| !row.success || row.confidence < min_confidence;
    if space == Space::World {
        if rows[0].world.is_empty() {
            return Err(TrackError::NotThreeD {
                path: path.to_owned(),
            });
        }
        let turned: Vec<Option<Vec<f32>>> = rows
            .iter()
            .map(|row| (!lost(row)).then(|| placement.turn(&row.world)))
            .collect();
        let offset = match turned.iter().flatten().next() {
            Some(first) => {
                let c = centroid(first);
                std::array::from_fn(|k| placement.rest_centroid[k] - c[k])
            }
            None => [0.0; 3],
        };
        let frames = turned
            .into_iter()
            .map(|f| {
                f.map(|mut p| {
                    for q in p.chunks_exact_mut(3) {
                        for k in 0..3 {
                            q[k] += offset[k];
                        }
                    }
                    p
                })
            })
            .collect();
        return Ok(Track {
            space,
            frames,
            times,
        });
    }
    if rows[0].pixels.is_empty() {
        return Err(TrackError::NotTwoD {
            path: path.to_owned(),
        });
    }
    let camera = intrinsics.ok_or_else(|| TrackError::NoIntrinsics {
        path: path.to_owned(),
    })?;
    let frames = rows
        .iter()
        .enumerate()
        .map(|(f, row)| {
            if lost(row) {
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
    Ok(Track {
        space,
        frames,
        times,
    })
}

/// The rows' time stamps (`DEFAULT_FPS` apart where the file has none), checked to rise by at
/// least 1 ms from row to row.
fn times(path: &Path, rows: &[openface::OpenFaceFrame]) -> Result<Vec<f32>, TrackError> {
    let times: Vec<f32> = rows
        .iter()
        .enumerate()
        .map(|(f, r)| r.timestamp.unwrap_or(f as f32 / DEFAULT_FPS))
        .collect();
    check_times(path, &times, 2)?;
    Ok(times)
}

/// Checks that `times` rise by at least 1 ms from frame to frame; `first_row` is the file's row
/// (1-based) of frame 0, for the error.
pub(crate) fn check_times(path: &Path, times: &[f32], first_row: usize) -> Result<(), TrackError> {
    for (i, w) in times.windows(2).enumerate() {
        if w[1] - w[0] < 1e-3 {
            return Err(TrackError::Time {
                path: path.to_owned(),
                row: i + 1 + first_row,
                time: w[1],
                last: w[0],
            });
        }
    }
    Ok(())
}

/// A performance folder's track: its 2D pixels through its camera, or its meshes' landmark
/// vertices in 3D.
fn performance(dir: &Path, space: Space) -> Result<Track, TrackError> {
    let perf = Performance::read(dir)?;
    let m = &perf.manifest;
    let bad = || TrackError::Landmarks {
        path: dir.join(crate::io::performance::MANIFEST),
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
            _ if m.tracker_lost(f) => Ok(None),
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
    let times = (0..m.frames).map(|f| f as f32 / m.fps).collect();
    Ok(Track {
        space,
        frames,
        times,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::openface::{OpenFaceFrame, write_csv};

    /// A CSV of 3D landmarks seen by a camera 60 cm away, read back in the actor's frame: turned,
    /// in its unit, and moved as a whole so that the first found frame sits at the rest centroid.
    #[test]
    fn three_d_landmarks_land_in_the_actors_frame() {
        // Landmarks in the actor's frame (cm), the head moving 1 cm right and 0.5 cm nearer.
        let face = |f: usize| -> Vec<f32> {
            (0..LANDMARKS)
                .flat_map(|l| {
                    let a = l as f32 * 0.37;
                    [
                        4.0 * a.cos() + f as f32,
                        5.0 * a.sin(),
                        1.0 + 0.5 * f as f32,
                    ]
                })
                .collect()
        };
        // The camera's view in mm: x right, y down, z away, the face 600 mm off and aside.
        let seen = |p: &[f32]| -> Vec<f32> {
            p.chunks_exact(3)
                .flat_map(|q| [10.0 * q[0] + 35.0, -10.0 * q[1] - 20.0, 600.0 - 10.0 * q[2]])
                .collect()
        };
        let rows: Vec<OpenFaceFrame> = (0..3)
            .map(|f| OpenFaceFrame {
                pixels: Vec::new(),
                world: seen(&face(f)),
                confidence: 0.95,
                success: f != 0,
                timestamp: None,
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("track.csv");
        std::fs::write(&path, write_csv(&rows, 30.0)).unwrap();
        let placement = Placement {
            mm_per_unit: 10.0,
            rest_centroid: [0.5, 1.0, 9.0],
        };
        let track = read(&path, Space::World, None, 0.5, placement).unwrap();
        assert_eq!(track.frames[0], None, "frame 0 is lost");
        // Frame 1 is the first found: its centroid lands on the rest centroid; frame 2 keeps
        // the head's motion from it.
        let c1 = centroid(&face(1));
        for f in 1..3 {
            let got = track.frames[f].as_ref().unwrap();
            for (i, (g, w)) in got.iter().zip(face(f)).enumerate() {
                let want = w - c1[i % 3] + placement.rest_centroid[i % 3];
                assert!(
                    (g - want).abs() < 1e-4,
                    "frame {f}, value {i}: {g} against {want}"
                );
            }
        }
        // A 2D driver cannot read it, nor a 3D driver a CSV of pixels only.
        let e = read(&path, Space::Image, None, 0.5, placement).unwrap_err();
        assert!(matches!(e, TrackError::NotTwoD { .. }), "{e}");
        let flat: Vec<OpenFaceFrame> = rows
            .iter()
            .map(|r| OpenFaceFrame {
                pixels: vec![300.0; 2 * LANDMARKS],
                world: Vec::new(),
                ..r.clone()
            })
            .collect();
        std::fs::write(&path, write_csv(&flat, 30.0)).unwrap();
        let e = read(&path, Space::World, None, 0.5, placement).unwrap_err();
        assert!(e.to_string().contains("X_0 … Z_67"), "{e}");
    }
}
