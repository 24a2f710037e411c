//! Landmark tracks without allocation: an OpenFace 2.0 CSV read in place ([`Track`], the golden
//! driver's track), and the frames a tracker hands a device ([`Frames`], the live track).
//!
//! The build script (`build.rs`) includes this file to turn the live track's CSV into
//! [`Frames`]: the Cortex-M4F's 4 MiB of flash holds every golden only with the live track in
//! that form (its CSV is 89 KB of text, its frames 33 KB). The build reads the CSV with
//! [`Track`] and core's `f32` parser, which rounds the decimal text to the nearest `f32` on every
//! machine, so a frame holds the values a target would read from the text.

/// An OpenFace 2.0 CSV read in place: the columns of the time stamp, of `success` (where the
/// header has one) and of the first x and y.
#[derive(Clone, Copy, Debug)]
pub struct Track<'t> {
    text: &'t str,
    landmarks: usize,
    time: usize,
    success: Option<usize>,
    x: usize,
    y: usize,
    /// Rows after the header.
    pub rows: usize,
}

impl<'t> Track<'t> {
    /// Finds the `timestamp`, `x_0` and `y_0` columns of the header (`x_1` … follow `x_0`, as
    /// OpenFace writes them, up to `x_{landmarks - 1}`); `None` for text that is not UTF-8 or
    /// lacks them.
    pub fn parse(bytes: &'t [u8], landmarks: usize) -> Option<Self> {
        let text = core::str::from_utf8(bytes).ok()?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines.next()?;
        let column = |name: &str| header.split(',').position(|c| c.trim() == name);
        let (time, x, y) = (column("timestamp")?, column("x_0")?, column("y_0")?);
        // The last landmark's columns end the runs that start at x_0 and y_0.
        let last = landmarks.checked_sub(1)?;
        let is_last = |c: usize, axis: &str| {
            let name = header.split(',').nth(c).map(str::trim);
            name.and_then(|n| n.strip_prefix(axis)?.parse::<usize>().ok()) == Some(last)
        };
        if !is_last(x + last, "x_") || !is_last(y + last, "y_") {
            return None;
        }
        Some(Self {
            text,
            landmarks,
            time,
            success: column("success"),
            x,
            y,
            rows: lines.count(),
        })
    }

    /// The text of row `row` (after the header).
    fn line(&self, row: usize) -> Option<&'t str> {
        self.text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .nth(row + 1)
    }

    /// Whether the tracker found the face in row `row` (its `success` is not 0; always, without
    /// the column); `None` if the row or its value is missing or not a number.
    pub fn found(&self, row: usize) -> Option<bool> {
        let Some(column) = self.success else {
            return Some(true);
        };
        let v: f32 = self
            .line(row)?
            .split(',')
            .nth(column)?
            .trim()
            .parse()
            .ok()?;
        Some(v != 0.0)
    }

    /// Row `row`'s time stamp and its `[u, v]` pixels into `pixels` (two values a landmark);
    /// `None` if the row is missing or a value is not a number.
    pub fn row(&self, row: usize, pixels: &mut [f32]) -> Option<f32> {
        let line = self.line(row)?;
        let n = self.landmarks;
        let mut time = None;
        let mut seen = 0;
        for (c, cell) in line.split(',').enumerate() {
            let at = if c == self.time {
                None
            } else if (self.x..self.x + n).contains(&c) {
                Some(2 * (c - self.x))
            } else if (self.y..self.y + n).contains(&c) {
                Some(2 * (c - self.y) + 1)
            } else {
                continue;
            };
            // core's parser rounds the decimal text to the nearest f32, as the host's does.
            let v: f32 = cell.trim().parse().ok()?;
            match at {
                None => time = Some(v),
                Some(i) => *pixels.get_mut(i)? = v,
            }
            seen += 1;
        }
        (seen == 1 + 2 * n).then_some(time?)
    }
}

/// Values a frame of [`Frames`] holds besides its pixels: the time stamp and whether the face
/// was found.
pub const FRAME_HEAD: usize = 2;

/// A track as the frames a tracker hands a device, made from a CSV by the build (`build.rs`):
/// little-endian, the rows and the landmarks as `u32`, then per row the time stamp in seconds,
/// 1 where the face was found (0 where not) and the `[u, v]` pixels, all `f32`.
#[derive(Clone, Copy, Debug)]
pub struct Frames<'t> {
    bytes: &'t [u8],
    landmarks: usize,
    /// Rows of the track.
    pub rows: usize,
}

impl<'t> Frames<'t> {
    /// Reads the header; `None` unless it gives `landmarks` landmarks and the length its rows
    /// need.
    pub fn parse(bytes: &'t [u8], landmarks: usize) -> Option<Self> {
        let word = |i: usize| {
            let b = bytes.get(4 * i..4 * i + 4)?.try_into().ok()?;
            usize::try_from(u32::from_le_bytes(b)).ok()
        };
        let rows = word(0)?;
        if word(1)? != landmarks {
            return None;
        }
        let values = rows.checked_mul(FRAME_HEAD + 2 * landmarks)?;
        (bytes.len() == 8 + 4 * values).then_some(Self {
            bytes,
            landmarks,
            rows,
        })
    }

    /// Row `row`'s time stamp and whether the face was found, its pixels into `pixels` (two
    /// values a landmark); `None` past the last row or for too small a `pixels`.
    pub fn row(&self, row: usize, pixels: &mut [f32]) -> Option<(f32, bool)> {
        let len = FRAME_HEAD + 2 * self.landmarks;
        let start = 8 + 4 * row.checked_mul(len)?;
        let frame = self.bytes.get(start..start + 4 * len)?;
        let mut values = frame
            .chunks_exact(4)
            .map_while(|b| b.try_into().ok().map(f32::from_le_bytes));
        let time = values.next()?;
        let found = values.next()? != 0.0;
        for p in pixels.get_mut(..2 * self.landmarks)? {
            *p = values.next()?;
        }
        Some((time, found))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::live::LIVE_TRACK;
    use sinew_core::driver::LANDMARKS;

    #[test]
    fn the_live_frames_hold_what_the_csv_says_and_a_wrong_shape_is_refused() {
        let csv = include_bytes!("../../../tests/data/driver-ict-live.csv");
        let track = Track::parse(csv, LANDMARKS).unwrap();
        let frames = Frames::parse(LIVE_TRACK, LANDMARKS).unwrap();
        assert_eq!(frames.rows, track.rows);
        let (mut a, mut b) = ([0.0; 2 * LANDMARKS], [0.0; 2 * LANDMARKS]);
        let mut missing = 0;
        for row in 0..track.rows {
            let (time, found) = frames.row(row, &mut a).unwrap();
            assert_eq!(time.to_bits(), track.row(row, &mut b).unwrap().to_bits());
            assert_eq!(found, track.found(row).unwrap());
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "row {row}");
            missing += usize::from(!found);
        }
        assert!(missing > 0, "the track has a frame without a face");
        assert!(frames.row(track.rows, &mut a).is_none());
        assert!(Frames::parse(LIVE_TRACK, LANDMARKS - 1).is_none());
        assert!(Frames::parse(&LIVE_TRACK[..LIVE_TRACK.len() - 4], LANDMARKS).is_none());
        assert!(Track::parse(csv, LANDMARKS + 1).is_none());
    }
}
