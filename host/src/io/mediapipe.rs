//! MediaPipe Face Mesh landmark tracks, as MediaPipe gives them: per frame 468 points (478 with
//! the irises, `refine_landmarks`), x and y normalised by the image's width and height (0 to 1
//! inside the image, y down), z a relative depth on x's scale. Read whole and checked before
//! anything uses it, each bad value named by file, row and point.
//!
//! # Layout (JSON lines)
//! One JSON object a line, one line a frame, in order; blank lines are skipped:
//!
//! ```text
//! {"timestamp": 0.0, "width": 640, "height": 480, "landmarks": [[0.512, 0.433, -0.031], …]}
//! {"timestamp": 0.033, "width": 640, "height": 480, "landmarks": []}
//! ```
//!
//! - `width`, `height`: the image's size in pixels, the same on every line;
//! - `landmarks`: 468 or 478 `[x, y, z]` (478: the ten iris points follow the face's 468), or
//!   none where the tracker found no face;
//! - `timestamp` (optional): seconds;
//! - other keys are ignored. `NaN` and `Infinity`, which Python's `json` writes, are read and
//!   refused as non-finite values.
//!
//! A point more than [`MARGIN`] (in image sizes) outside the image is refused: MediaPipe places
//! points a little outside the image when the face touches its edge, never far.

use std::path::{Path, PathBuf};

use serde::Deserialize;

/// The face's points.
pub const FACE_POINTS: usize = 468;
/// The face's points and the irises' (`refine_landmarks`).
pub const WITH_IRISES: usize = 478;
/// How far outside the image a point may lie, in image sizes (on each side).
pub const MARGIN: f64 = 0.25;

/// One frame of a track.
#[derive(Clone, Debug, PartialEq)]
pub struct MediaPipeFrame {
    /// The face's 468 points `[x, y, z]` (normalised), the irises' dropped; `None`: no face.
    pub points: Option<Vec<[f32; 3]>>,
    /// The frame's time stamp in seconds, if the line has one.
    pub timestamp: Option<f32>,
}

/// A track read back.
#[derive(Clone, Debug, PartialEq)]
pub struct MediaPipeTrack {
    /// The image's size in pixels.
    pub size: [u32; 2],
    /// The frames, in order.
    pub frames: Vec<MediaPipeFrame>,
}

/// Why a MediaPipe track cannot be read; each names the file, and the row (line, 1-based) and
/// point (0-based) where a value is at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MediaPipeError {
    /// The file could not be read.
    #[error("{}: cannot read the MediaPipe track", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// No frame in the file.
    #[error("{}: no frames (one JSON object a line with width, height and landmarks)", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// A line that is not a frame object.
    #[error("{}: row {row}: not a MediaPipe frame ({{\"width\", \"height\", \"landmarks\": [[x, y, z], …]}}): {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The line.
        row: usize,
        /// What the JSON reader said.
        #[source]
        source: serde_json::Error,
    },
    /// A frame whose image size is zero or differs from the first frame's.
    #[error("{}: row {row}: image {width}×{height}, {why}", path.display())]
    ImageSize {
        /// The file.
        path: PathBuf,
        /// The line.
        row: usize,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// What is wrong with it.
        why: String,
    },
    /// A frame with neither 468 nor 478 points (nor none).
    #[error("{}: row {row}: {found} points; MediaPipe Face Mesh gives {FACE_POINTS}, or {WITH_IRISES} with the irises (none: no face)", path.display())]
    PointCount {
        /// The file.
        path: PathBuf,
        /// The line.
        row: usize,
        /// Its points.
        found: usize,
    },
    /// A point that is not `[x, y, z]`.
    #[error("{}: row {row}: point {point} has {found} values, not [x, y, z]", path.display())]
    PointShape {
        /// The file.
        path: PathBuf,
        /// The line.
        row: usize,
        /// The point.
        point: usize,
        /// Its values.
        found: usize,
    },
    /// A value that is NaN, infinite or null.
    #[error("{}: row {row}: point {point}: {axis} is not a finite number", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The line.
        row: usize,
        /// The point.
        point: usize,
        /// `x`, `y`, `z` or `timestamp`.
        axis: &'static str,
    },
    /// A point too far outside the image.
    #[error("{}: row {row}: point {point}: {axis} = {value} lies more than {MARGIN} image sizes outside the image (0 to 1)", path.display())]
    OutsideImage {
        /// The file.
        path: PathBuf,
        /// The line.
        row: usize,
        /// The point.
        point: usize,
        /// `x` or `y`.
        axis: &'static str,
        /// The value.
        value: f64,
    },
}

#[derive(Deserialize)]
struct Line {
    width: u32,
    height: u32,
    landmarks: Vec<Vec<Option<f64>>>,
    /// Absent: `None`; present, `null` included: `Some` (so that a `NaN` read as `null` is
    /// refused rather than taken for a missing time stamp).
    #[serde(default, deserialize_with = "present")]
    timestamp: Option<Option<f64>>,
}

fn present<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Option<f64>>, D::Error> {
    Option::<f64>::deserialize(d).map(Some)
}

/// Python's `json` writes `NaN`, `Infinity` and `-Infinity`, which JSON lacks: they are read as
/// `null`, which the checks refuse as non-finite. (The layout has no strings to protect.)
fn nulled(line: &str) -> String {
    line.replace("-Infinity", "null")
        .replace("Infinity", "null")
        .replace("NaN", "null")
}

/// Reads and checks the track at `path`.
///
/// # Errors
/// A [`MediaPipeError`] naming the file, row and point.
pub fn read(path: &Path) -> Result<MediaPipeTrack, MediaPipeError> {
    let text = std::fs::read_to_string(path).map_err(|source| MediaPipeError::Read {
        path: path.to_owned(),
        source,
    })?;
    parse(path, &text)
}

/// [`read`] on the file's text.
pub fn parse(path: &Path, text: &str) -> Result<MediaPipeTrack, MediaPipeError> {
    let mut size: Option<[u32; 2]> = None;
    let mut frames = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        if raw.trim().is_empty() {
            continue;
        }
        let line: Line =
            serde_json::from_str(&nulled(raw)).map_err(|source| MediaPipeError::Json {
                path: path.to_owned(),
                row,
                source,
            })?;
        let bad_size = |why: String| MediaPipeError::ImageSize {
            path: path.to_owned(),
            row,
            width: line.width,
            height: line.height,
            why,
        };
        if line.width == 0 || line.height == 0 {
            return Err(bad_size("an image has pixels".into()));
        }
        match size {
            None => size = Some([line.width, line.height]),
            Some(s) if s != [line.width, line.height] => {
                return Err(bad_size(format!(
                    "the first row's is {}×{}: one track, one camera",
                    s[0], s[1]
                )));
            }
            Some(_) => {}
        }
        let timestamp = match line.timestamp {
            None => None,
            Some(Some(t)) if t.is_finite() => Some(t as f32),
            Some(_) => {
                return Err(MediaPipeError::NonFinite {
                    path: path.to_owned(),
                    row,
                    point: 0,
                    axis: "timestamp",
                });
            }
        };
        let n = line.landmarks.len();
        if !(n == 0 || n == FACE_POINTS || n == WITH_IRISES) {
            return Err(MediaPipeError::PointCount {
                path: path.to_owned(),
                row,
                found: n,
            });
        }
        let mut points = Vec::with_capacity(FACE_POINTS);
        for (point, p) in line.landmarks.iter().enumerate() {
            if p.len() != 3 {
                return Err(MediaPipeError::PointShape {
                    path: path.to_owned(),
                    row,
                    point,
                    found: p.len(),
                });
            }
            let mut q = [0.0f32; 3];
            for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
                let v = match p[k] {
                    Some(v) if v.is_finite() => v,
                    _ => {
                        return Err(MediaPipeError::NonFinite {
                            path: path.to_owned(),
                            row,
                            point,
                            axis,
                        });
                    }
                };
                if k < 2 && !(-MARGIN..=1.0 + MARGIN).contains(&v) {
                    return Err(MediaPipeError::OutsideImage {
                        path: path.to_owned(),
                        row,
                        point,
                        axis,
                        value: v,
                    });
                }
                q[k] = v as f32;
            }
            if point < FACE_POINTS {
                points.push(q);
            }
        }
        frames.push(MediaPipeFrame {
            points: (n > 0).then_some(points),
            timestamp,
        });
    }
    let Some(size) = size else {
        return Err(MediaPipeError::Empty {
            path: path.to_owned(),
        });
    };
    Ok(MediaPipeTrack { size, frames })
}

#[cfg(test)]
mod tests;
