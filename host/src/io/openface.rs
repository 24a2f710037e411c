//! OpenFace 2.0's landmark CSV (`FeatureExtraction` output): one row per frame, the 68 iBUG
//! landmarks' pixels in the columns `x_0 … x_67`, `y_0 … y_67` (`-2Dfp`), their 3D positions in
//! millimetres in the camera's frame (x right, y down, z away from the camera) in `X_0 … X_67`,
//! `Y_0 … Y_67`, `Z_0 … Z_67` (`-3Dfp`), the tracker's `confidence` in [0, 1] and `success` (0:
//! the face was lost in that frame), and `timestamp` in seconds where present. A file holds the 2D or the 3D landmarks or both; a set whose
//! columns are partly there is an error naming the first missing one. Column names may carry the
//! spaces OpenFace writes after each comma; other columns are ignored. Every value read must be
//! a finite number; every error names the file, the row (1-based, the header is row 1) and the
//! column.

use std::path::{Path, PathBuf};

/// Landmarks per row.
pub const LANDMARKS: usize = 68;
/// The largest CSV this reader opens (1 GiB: about 250,000 frames of OpenFace's 700 columns).
pub const MAX_BYTES: u64 = 1 << 30;
/// The most frames a track may hold (more than two hours at 60 frames per second).
pub const MAX_FRAMES: usize = 500_000;

/// One frame of the track.
#[derive(Clone, Debug, PartialEq)]
pub struct OpenFaceFrame {
    /// `[68, 2]`: each landmark's `[u, v]` in pixels (v down); empty where the file has no 2D
    /// landmarks.
    pub pixels: Vec<f32>,
    /// `[68, 3]`: each landmark's `[x, y, z]` in millimetres in the camera's frame; empty where
    /// the file has no 3D landmarks.
    pub world: Vec<f32>,
    /// The tracker's confidence, [0, 1].
    pub confidence: f32,
    /// Whether the tracker found the face.
    pub success: bool,
    /// The frame's time stamp in seconds (the `timestamp` column), where the file has one.
    pub timestamp: Option<f32>,
}

/// A CSV that cannot be read as an OpenFace 2.0 landmark track.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OpenFaceError {
    /// The file cannot be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// A file larger than [`MAX_BYTES`].
    #[error("{}: {bytes} bytes, more than the {limit} a track may have", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size.
        bytes: u64,
        /// [`MAX_BYTES`].
        limit: u64,
    },
    /// More rows than [`MAX_FRAMES`].
    #[error("{}: more than {limit} frames", path.display())]
    TooManyFrames {
        /// The file.
        path: PathBuf,
        /// [`MAX_FRAMES`].
        limit: usize,
    },
    /// No header, or no rows after it.
    #[error("{}: no frames (an OpenFace CSV has a header row, then one row per frame)", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// A column the track needs is not in the header.
    #[error("{}: row 1 (the header) has no column {column:?} (not an OpenFace 2.0 landmark CSV?)", path.display())]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column.
        column: String,
    },
    /// A row with another number of columns than the header.
    #[error("{}: row {row} has {found} columns, the header has {expected}", path.display())]
    Columns {
        /// The file.
        path: PathBuf,
        /// The row (1-based; the header is row 1).
        row: usize,
        /// Its columns.
        found: usize,
        /// The header's.
        expected: usize,
    },
    /// A value that is not a number.
    #[error("{}: row {row}, column {column}: {text:?} is not a number", path.display())]
    NotANumber {
        /// The file.
        path: PathBuf,
        /// The row.
        row: usize,
        /// The column's name.
        column: String,
        /// The text.
        text: String,
    },
    /// A value that is NaN or infinite.
    #[error("{}: row {row}, column {column}: {text} is not finite", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The row.
        row: usize,
        /// The column's name.
        column: String,
        /// The text.
        text: String,
    },
}

/// Reads the OpenFace 2.0 CSV at `path` (see the module documentation).
///
/// # Errors
/// An [`OpenFaceError`] naming the file, and the row and column where a value is at fault.
pub fn read(path: &Path) -> Result<Vec<OpenFaceFrame>, OpenFaceError> {
    let read_error = |source| OpenFaceError::Read {
        path: path.to_owned(),
        source,
    };
    let bytes = std::fs::metadata(path).map_err(read_error)?.len();
    if bytes > MAX_BYTES {
        return Err(OpenFaceError::TooLarge {
            path: path.to_owned(),
            bytes,
            limit: MAX_BYTES,
        });
    }
    let text = std::fs::read_to_string(path).map_err(read_error)?;
    parse(path, &text)
}

/// Parses the text of an OpenFace 2.0 CSV read from `path` (named in errors).
///
/// # Errors
/// As [`read`].
pub fn parse(path: &Path, text: &str) -> Result<Vec<OpenFaceFrame>, OpenFaceError> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(OpenFaceError::Empty {
            path: path.to_owned(),
        });
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| {
        names
            .iter()
            .position(|n| *n == name)
            .ok_or_else(|| OpenFaceError::MissingColumn {
                path: path.to_owned(),
                column: name.to_owned(),
            })
    };
    // Each landmark set's columns, landmark-major, where the header has its first column.
    let set = |axes: &[&str]| -> Result<Vec<usize>, OpenFaceError> {
        if !names.contains(&format!("{}_0", axes[0]).as_str()) {
            return Ok(Vec::new());
        }
        (0..LANDMARKS)
            .flat_map(|l| axes.iter().map(move |a| format!("{a}_{l}")))
            .map(|name| column(&name))
            .collect()
    };
    let planar = set(&["x", "y"])?;
    let spatial = set(&["X", "Y", "Z"])?;
    if planar.is_empty() && spatial.is_empty() {
        column("x_0")?;
    }
    let confidence = column("confidence")?;
    let success = column("success")?;
    let timestamp = column("timestamp").ok();
    let mut frames = Vec::new();
    for (index, line) in lines {
        let row = index + 1;
        if frames.len() == MAX_FRAMES {
            return Err(OpenFaceError::TooManyFrames {
                path: path.to_owned(),
                limit: MAX_FRAMES,
            });
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(OpenFaceError::Columns {
                path: path.to_owned(),
                row,
                found: cells.len(),
                expected: names.len(),
            });
        }
        let value = |c: usize| -> Result<f32, OpenFaceError> {
            let text = cells[c];
            let v: f32 = text.parse().map_err(|_| OpenFaceError::NotANumber {
                path: path.to_owned(),
                row,
                column: names[c].to_owned(),
                text: text.to_owned(),
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(OpenFaceError::NonFinite {
                    path: path.to_owned(),
                    row,
                    column: names[c].to_owned(),
                    text: text.to_owned(),
                })
            }
        };
        let values = |columns: &[usize]| {
            columns
                .iter()
                .map(|&c| value(c))
                .collect::<Result<Vec<_>, _>>()
        };
        frames.push(OpenFaceFrame {
            pixels: values(&planar)?,
            world: values(&spatial)?,
            confidence: value(confidence)?,
            success: value(success)? != 0.0,
            timestamp: timestamp.map(value).transpose()?,
        });
    }
    if frames.is_empty() {
        return Err(OpenFaceError::Empty {
            path: path.to_owned(),
        });
    }
    Ok(frames)
}

/// One landmark set of a frame: its pixels or its 3D positions.
type LandmarkSet = fn(&OpenFaceFrame) -> &[f32];

/// An OpenFace 2.0 CSV of `frames` (each with its pixels `[68, 2]` and 3D landmarks `[68, 3]`
/// where the first frame has them, its confidence and success), taken at `fps` frames per
/// second, with the columns OpenFace writes before the landmarks (`frame` from 1, `face_id`,
/// `timestamp` in seconds to the millisecond as OpenFace rounds it, the frame's own or `f / fps`,
/// `confidence`, `success`).
/// Values are written in Rust's shortest form, which reads back to the same `f32` bits
/// ([`parse`], C's `strtof`).
pub fn write_csv(frames: &[OpenFaceFrame], fps: f32) -> String {
    let mut s = String::from("frame, face_id, timestamp, confidence, success");
    let first = frames.first();
    let planar = first.is_some_and(|f| !f.pixels.is_empty());
    let spatial = first.is_some_and(|f| !f.world.is_empty());
    let mut sets: Vec<(&[&str], LandmarkSet)> = Vec::new();
    if planar {
        sets.push((&["x", "y"], |f| f.pixels.as_slice()));
    }
    if spatial {
        sets.push((&["X", "Y", "Z"], |f| f.world.as_slice()));
    }
    for (axes, _) in &sets {
        for axis in *axes {
            for l in 0..LANDMARKS {
                s.push_str(&format!(", {axis}_{l}"));
            }
        }
    }
    s.push('\n');
    for (f, frame) in frames.iter().enumerate() {
        s.push_str(&format!(
            "{}, 0, {:.3}, {}, {}",
            f + 1,
            frame.timestamp.unwrap_or(f as f32 / fps),
            frame.confidence,
            u8::from(frame.success)
        ));
        for (axes, values) in &sets {
            let values = values(frame);
            for axis in 0..axes.len() {
                for l in 0..LANDMARKS {
                    s.push_str(&format!(", {}", values[axes.len() * l + axis]));
                }
            }
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(k: f32) -> OpenFaceFrame {
        OpenFaceFrame {
            pixels: (0..2 * LANDMARKS).map(|i| 100.0 + i as f32 + k).collect(),
            world: Vec::new(),
            confidence: 0.9,
            success: true,
            timestamp: None,
        }
    }

    /// The frames read back, their time stamps (which the writer adds) left out.
    fn untimed(frames: Vec<OpenFaceFrame>) -> Vec<OpenFaceFrame> {
        frames
            .into_iter()
            .map(|f| OpenFaceFrame {
                timestamp: None,
                ..f
            })
            .collect()
    }

    #[test]
    fn a_written_track_reads_back() {
        let mut frames = vec![frame(0.0), frame(1.5)];
        frames[1].success = false;
        let csv = write_csv(&frames, 30.0);
        let read = parse(Path::new("t.csv"), &csv).unwrap();
        assert_eq!(
            read.iter().map(|f| f.timestamp).collect::<Vec<_>>(),
            [Some(0.0), Some(0.033)]
        );
        assert_eq!(untimed(read), frames);
        // A frame's own time stamp is written as it is.
        frames[1].timestamp = Some(0.25);
        let csv = write_csv(&frames, 30.0);
        assert_eq!(
            parse(Path::new("t.csv"), &csv).unwrap()[1].timestamp,
            Some(0.25)
        );
    }

    #[test]
    fn three_d_landmarks_read_back_with_or_without_the_pixels() {
        let mut frames = vec![frame(0.0), frame(2.0)];
        for (f, frame) in frames.iter_mut().enumerate() {
            frame.world = (0..3 * LANDMARKS)
                .map(|i| -40.0 + i as f32 * 0.5 + f as f32)
                .collect();
        }
        let both = untimed(parse(Path::new("t.csv"), &write_csv(&frames, 30.0)).unwrap());
        assert_eq!(both, frames);
        // The landmark-major order: landmark 1's X, Y, Z follow landmark 0's.
        assert_eq!(both[0].world[3..6], [-38.5, -38.0, -37.5]);
        for f in &mut frames {
            f.pixels.clear();
        }
        let csv = write_csv(&frames, 30.0);
        assert!(!csv.contains(" x_0") && csv.contains(" Z_67"));
        assert_eq!(untimed(parse(Path::new("t.csv"), &csv).unwrap()), frames);
        // A set partly there names its first missing column.
        let cut = csv.replacen(", Y_5,", ", Q_5,", 1);
        let e = parse(Path::new("t.csv"), &cut).unwrap_err();
        assert!(
            matches!(&e, OpenFaceError::MissingColumn { column, .. } if column == "Y_5"),
            "{e}"
        );
    }

    #[test]
    fn bad_tracks_name_the_row_and_column() {
        let path = Path::new("track.csv");
        let csv = write_csv(&[frame(0.0), frame(1.0)], 30.0);
        let mut lines: Vec<String> = csv.lines().map(str::to_owned).collect();
        let short = format!("{}\n{}\n", lines[0], "1, 0, 0.0, 0.9, 1, 5");
        let e = parse(path, &short).unwrap_err();
        assert!(matches!(e, OpenFaceError::Columns { row: 2, .. }), "{e}");
        assert!(e.to_string().contains("track.csv: row 2"), "{e}");
        lines[2] = lines[2].replacen(", 101", ", abc", 1);
        let e = parse(path, &lines.join("\n")).unwrap_err();
        assert!(
            matches!(&e, OpenFaceError::NotANumber { row: 3, column, .. } if column == "x_0"),
            "{e}"
        );
        lines[2] = lines[2].replacen(", abc", ", NaN", 1);
        let e = parse(path, &lines.join("\n")).unwrap_err();
        assert!(matches!(e, OpenFaceError::NonFinite { row: 3, .. }), "{e}");
        let e = parse(path, "frame, x_0\n1, 2\n").unwrap_err();
        assert!(
            matches!(&e, OpenFaceError::MissingColumn { column, .. } if column == "y_0"),
            "{e}"
        );
        assert!(matches!(
            parse(path, &format!("{}\n", lines[0])),
            Err(OpenFaceError::Empty { .. })
        ));
    }
}
