//! The golden AIM replay that every firmware simulator runs: load the baked actor, pose it through
//! the fixed 16-frame sequence of `tests/tests/golden_aim.rs`, compute vertex normals, hash
//! positions then normals per frame with [`FrameHasher`], and compare each hash with the pinned
//! list `tests/data/aim-procedural.hashes`.
//!
//! Nothing here allocates: the posed positions and normals live in a caller-owned [`Scratch`]
//! (a `static` on the microcontrollers), sized for up to [`MAX_VERTICES`] vertices. The hash list
//! is parsed line by line as the frames are played, so its length is not limited either.
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

#[cfg(test)]
extern crate std;

use core::fmt;
use core::str::Lines;

use sinew_core::aim::{AimActor, MAX_SHAPES};
use sinew_core::hash::FrameHasher;
use sinew_core::skinning::Pose;
use sinew_core::{BufferError, FormatError};

/// The golden actor: baked, playback-only, 336 vertices and 6 shapes (written by
/// `UPDATE_EXPECT=1 cargo test -p sinew-tests --test golden_aim`).
pub const GOLDEN_MODEL: &[u8] = include_bytes!("../../../tests/data/aim-procedural.sinew");

/// The pinned per-frame hashes of [`GOLDEN_MODEL`] on the x86_64 host.
pub const GOLDEN_HASHES: &str = include_str!("../../../tests/data/aim-procedural.hashes");

/// Largest vertex count [`Scratch`] holds. The golden actor has 336; 1024 keeps the scratch at
/// 24 KiB, small enough for any of the simulated boards.
pub const MAX_VERTICES: usize = 1024;

/// Number of frames in the golden sequence: `t = f / 16` runs over `[0, 1)`.
pub const SEQUENCE_FRAMES: usize = 16;

/// Caller-owned buffers for one frame: posed positions, their normals and the pose's corrective
/// coefficients.
#[derive(Clone, Debug)]
pub struct Scratch {
    positions: [f32; 3 * MAX_VERTICES],
    normals: [f32; 3 * MAX_VERTICES],
    weights: [f32; MAX_SHAPES],
}

impl Scratch {
    /// Zeroed buffers (a `const fn`, so a `static` can hold them).
    pub const fn new() -> Self {
        Self {
            positions: [0.0; 3 * MAX_VERTICES],
            normals: [0.0; 3 * MAX_VERTICES],
            weights: [0.0; MAX_SHAPES],
        }
    }
}

impl Default for Scratch {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a replay could not run to the end. A hash that differs is not an error: it is reported as a
/// [`FrameReport`] whose [`FrameReport::ok`] is false.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// The model bytes are not a valid AIM actor.
    Model(FormatError),
    /// The actor has more vertices than [`MAX_VERTICES`].
    TooManyVertices {
        /// The actor's vertex count.
        vertices: usize,
    },
    /// A line of the hash list is not `<frame> <16 hex digits>`.
    BadLine {
        /// 1-based line number.
        line: usize,
    },
    /// A line names another frame than the next one (frames must run 0, 1, 2, … in order).
    FrameOrder {
        /// 1-based line number.
        line: usize,
        /// The frame that line should have named.
        expected: usize,
    },
    /// The hash list names no frame at all (a replay that checks nothing must not pass).
    NoFrames,
    /// The core rejected a buffer length. Cannot happen once the actor loaded; kept so that the
    /// replay never panics.
    Buffer(BufferError),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Model(e) => write!(f, "golden model: {e}"),
            Self::TooManyVertices { vertices } => write!(
                f,
                "golden model has {vertices} vertices, more than the {MAX_VERTICES} the firmware holds"
            ),
            Self::BadLine { line } => {
                write!(
                    f,
                    "hash list line {line}: expected `<frame> <16 hex digits>`"
                )
            }
            Self::FrameOrder { line, expected } => {
                write!(f, "hash list line {line}: expected frame {expected}")
            }
            Self::NoFrames => write!(f, "hash list names no frame"),
            Self::Buffer(e) => write!(f, "replay buffers: {e}"),
        }
    }
}

impl core::error::Error for Error {}

impl From<FormatError> for Error {
    fn from(e: FormatError) -> Self {
        Self::Model(e)
    }
}

impl From<BufferError> for Error {
    fn from(e: BufferError) -> Self {
        Self::Buffer(e)
    }
}

/// The outcome of one frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameReport {
    /// Frame index f.
    pub frame: usize,
    /// Hash of this target's positions then normals.
    pub hash: u64,
    /// Hash pinned on the host.
    pub expected: u64,
}

impl FrameReport {
    /// Whether this target's frame is bit-identical to the host's.
    pub const fn ok(&self) -> bool {
        self.hash == self.expected
    }
}

impl fmt::Display for FrameReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.ok() {
            write!(f, "frame {:2} {:016x} ok", self.frame, self.hash)
        } else {
            write!(
                f,
                "frame {:2} {:016x} MISMATCH (expected {:016x})",
                self.frame, self.hash, self.expected
            )
        }
    }
}

/// Totals of a finished replay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Summary {
    /// Frames played.
    pub frames: usize,
    /// Frames whose hash differed from the pinned one.
    pub mismatches: usize,
}

impl Summary {
    /// Whether every frame matched (and there was at least one).
    pub const fn passed(&self) -> bool {
        self.frames > 0 && self.mismatches == 0
    }
}

/// Frame `f` of the golden sequence: head turn, jaw opening, coefficients ramping. Writes the
/// coefficients into `weights` (`[M]`) and returns the pose.
///
/// This duplicates `pose` in `tests/tests/golden_aim.rs` expression for expression (same `f32`
/// operations in the same order), so that it produces the same bits; keep the two in step. The
/// host test of this crate replays the pinned hashes, which fails if they drift apart.
pub fn pose(actor: &AimActor<'_>, f: usize, weights: &mut [f32]) -> Pose {
    let t = f as f32 / 16.0;
    let jaw = [
        1.0,
        0.0,
        0.0,
        0.0,
        1.0 - 0.1 * t,
        -0.25 * t,
        0.0,
        -0.05 * t,
        0.02 * t,
    ];
    let head = [1.0, 0.0, 0.05 * t, 0.0, 1.0, 0.0, 0.3 * t, -0.1 * t, 0.2];
    for (j, w) in weights.iter_mut().enumerate() {
        // `%` on f32 is fmod, which is exact (no rounding), so every target's fmodf agrees.
        *w = ((j + 1) as f32 * 0.13 * t) % 1.0;
    }
    actor.pose_from_9d(&jaw, &head)
}

/// A replay in progress: an iterator over the frames named by the hash list, so that a firmware
/// can time each frame on its own.
#[derive(Debug)]
pub struct Replay<'m, 'h, 's> {
    actor: AimActor<'m>,
    lines: Lines<'h>,
    line: usize,
    next: usize,
    scratch: &'s mut Scratch,
}

impl<'m, 'h, 's> Replay<'m, 'h, 's> {
    /// Validates `model` as an AIM actor that fits in `scratch`. The hash list `hashes` is read
    /// lazily: blank lines and lines starting with `#` are skipped, every other line is
    /// `<frame> <16 hex digits>` with frames 0, 1, 2, … in order.
    pub fn new(model: &'m [u8], hashes: &'h str, scratch: &'s mut Scratch) -> Result<Self, Error> {
        let actor = AimActor::from_bytes(model)?;
        if actor.vertex_count() > MAX_VERTICES {
            return Err(Error::TooManyVertices {
                vertices: actor.vertex_count(),
            });
        }
        Ok(Self {
            actor,
            lines: hashes.lines(),
            line: 0,
            next: 0,
            scratch,
        })
    }

    /// The loaded actor.
    pub const fn actor(&self) -> &AimActor<'m> {
        &self.actor
    }

    /// The next `(frame, expected hash)` of the list, `None` at its end.
    fn next_expected(&mut self) -> Option<Result<(usize, u64), Error>> {
        for text in self.lines.by_ref() {
            self.line += 1;
            let text = text.trim();
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            return Some(parse_line(text, self.line, self.next));
        }
        None
    }

    /// Poses, computes normals and hashes frame `f`.
    fn play(&mut self, f: usize) -> Result<u64, Error> {
        let n = 3 * self.actor.vertex_count();
        let scratch = &mut *self.scratch;
        // The lengths were checked in `new`; `get_mut` keeps the replay free of panics anyway.
        let (Some(positions), Some(normals), Some(weights)) = (
            scratch.positions.get_mut(..n),
            scratch.normals.get_mut(..n),
            scratch.weights.get_mut(..self.actor.shape_count()),
        ) else {
            return Err(Error::TooManyVertices {
                vertices: self.actor.vertex_count(),
            });
        };
        let p = pose(&self.actor, f, weights);
        self.actor.pose(&p, weights, positions)?;
        self.actor.normals(positions, normals)?;
        let mut h = FrameHasher::new();
        h.write_f32s(positions);
        h.write_f32s(normals);
        Ok(h.finish())
    }
}

impl Iterator for Replay<'_, '_, '_> {
    type Item = Result<FrameReport, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        let (frame, expected) = match self.next_expected()? {
            Ok(v) => v,
            Err(e) => return Some(Err(e)),
        };
        self.next += 1;
        Some(self.play(frame).map(|hash| FrameReport {
            frame,
            hash,
            expected,
        }))
    }
}

/// Parses `<frame> <16 hex digits>` and checks that the frame is `expected`.
fn parse_line(text: &str, line: usize, expected: usize) -> Result<(usize, u64), Error> {
    let mut fields = text.split_ascii_whitespace();
    let (Some(frame), Some(hash), None) = (fields.next(), fields.next(), fields.next()) else {
        return Err(Error::BadLine { line });
    };
    let frame: usize = frame.parse().map_err(|_| Error::BadLine { line })?;
    // Exactly 16 hex digits: `from_str_radix` alone would accept a sign or a shorter number.
    if hash.len() != 16 || !hash.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(Error::BadLine { line });
    }
    let hash = u64::from_str_radix(hash, 16).map_err(|_| Error::BadLine { line })?;
    if frame != expected {
        return Err(Error::FrameOrder { line, expected });
    }
    Ok((frame, hash))
}

/// Plays every frame of `hashes` on `model`, calling `report` after each one, and returns the
/// totals. A mismatch is counted, not an error; an empty hash list is [`Error::NoFrames`].
pub fn replay(
    model: &[u8],
    hashes: &str,
    scratch: &mut Scratch,
    mut report: impl FnMut(&FrameReport),
) -> Result<Summary, Error> {
    let mut summary = Summary {
        frames: 0,
        mismatches: 0,
    };
    for r in Replay::new(model, hashes, scratch)? {
        let r = r?;
        report(&r);
        summary.frames += 1;
        if !r.ok() {
            summary.mismatches += 1;
        }
    }
    if summary.frames == 0 {
        return Err(Error::NoFrames);
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::boxed::Box;
    use std::string::{String, ToString};
    use std::vec::Vec;

    fn scratch() -> Box<Scratch> {
        Box::default()
    }

    #[test]
    fn golden_replay_matches_host_hashes() {
        // The host run of the firmware code path: if the duplicated sequence drifted from
        // tests/tests/golden_aim.rs, every frame would mismatch here.
        let mut seen = Vec::new();
        let s = replay(GOLDEN_MODEL, GOLDEN_HASHES, &mut scratch(), |r| {
            seen.push(*r)
        })
        .unwrap();
        assert_eq!(
            s,
            Summary {
                frames: SEQUENCE_FRAMES,
                mismatches: 0
            }
        );
        assert!(s.passed());
        assert_eq!(
            seen.iter().map(|r| r.frame).collect::<Vec<_>>(),
            (0..SEQUENCE_FRAMES).collect::<Vec<_>>()
        );
        assert_eq!(seen[0].expected, 0xc608_a4a3_deac_77fe);
        assert!(seen.iter().all(FrameReport::ok));
        // Frames differ from each other: the sequence really moves.
        assert_ne!(seen[0].hash, seen[15].hash);
    }

    #[test]
    fn golden_actor_fits() {
        let mut sc = scratch();
        let r = Replay::new(GOLDEN_MODEL, GOLDEN_HASHES, &mut sc).unwrap();
        assert_eq!(r.actor().vertex_count(), 336);
        assert_eq!(r.actor().shape_count(), 6);
    }

    #[test]
    fn corrupted_hash_is_a_mismatch() {
        // Flip the last digit of frame 7's hash.
        let text: String = GOLDEN_HASHES
            .lines()
            .map(|l| {
                if let Some(h) = l.strip_prefix("7 ") {
                    let mut h = h.to_string();
                    let last = if h.ends_with('0') { "1" } else { "0" };
                    h.replace_range(15.., last);
                    std::format!("7 {h}\n")
                } else {
                    std::format!("{l}\n")
                }
            })
            .collect();
        assert_ne!(text, GOLDEN_HASHES);
        let mut bad = Vec::new();
        let s = replay(GOLDEN_MODEL, &text, &mut scratch(), |r| {
            if !r.ok() {
                bad.push(*r);
            }
        })
        .unwrap();
        assert_eq!(s.frames, 16);
        assert_eq!(s.mismatches, 1);
        assert!(!s.passed());
        assert_eq!(bad.len(), 1);
        assert_eq!(bad[0].frame, 7);
        assert!(bad[0].to_string().contains("MISMATCH"));
    }

    #[test]
    fn prefix_of_the_list_plays_that_many_frames() {
        let text = "# c\n\n0 c608a4a3deac77fe\n1 0c0c5ae7b7b0d37a\n";
        let s = replay(GOLDEN_MODEL, text, &mut scratch(), |_| {}).unwrap();
        assert_eq!(
            s,
            Summary {
                frames: 2,
                mismatches: 0
            }
        );
    }

    #[test]
    fn malformed_lists_are_errors() {
        let cases = [
            ("# only a comment\n", Error::NoFrames),
            ("", Error::NoFrames),
            ("0\n", Error::BadLine { line: 1 }),
            ("0 c608a4a3deac77fe x\n", Error::BadLine { line: 1 }),
            ("0 c608a4a3deac77f\n", Error::BadLine { line: 1 }),
            ("0 +608a4a3deac77fe\n", Error::BadLine { line: 1 }),
            ("x c608a4a3deac77fe\n", Error::BadLine { line: 1 }),
            (
                "# c\n1 0c0c5ae7b7b0d37a\n",
                Error::FrameOrder {
                    line: 2,
                    expected: 0,
                },
            ),
            (
                "0 c608a4a3deac77fe\n0 c608a4a3deac77fe\n",
                Error::FrameOrder {
                    line: 2,
                    expected: 1,
                },
            ),
        ];
        for (text, want) in cases {
            let got = replay(GOLDEN_MODEL, text, &mut scratch(), |_| {});
            assert_eq!(got, Err(want), "{text:?}");
        }
    }

    #[test]
    fn bad_model_is_an_error() {
        let got = replay(
            GOLDEN_MODEL.get(..100).unwrap(),
            GOLDEN_HASHES,
            &mut scratch(),
            |_| {},
        );
        assert!(matches!(got, Err(Error::Model(_))), "{got:?}");
        let mut flipped = GOLDEN_MODEL.to_vec();
        let last = flipped.len() - 1;
        flipped[last] ^= 1;
        let got = replay(&flipped, GOLDEN_HASHES, &mut scratch(), |_| {});
        assert!(matches!(got, Err(Error::Model(_))), "{got:?}");
        assert!(got.unwrap_err().to_string().starts_with("golden model: "));
    }
}
