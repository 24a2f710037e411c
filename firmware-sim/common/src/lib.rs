//! The golden replays every firmware simulator runs (and, in [`performance`], the golden fitted
//! performance): each is a baked actor and a replay recorded
//! on the x86_64 host (`tests/data/*.replay.sinew`: the model's content hash, the pose of every
//! frame and the hash the host computed for it, in one numeric mode). A target plays each frame
//! through `sinew-core` ([`sinew_core::replay::check_frame`], the step of the host's
//! verification, which hashes with [`sinew_core::replay::pose_frame_hash`], the function the host
//! recorded with) and compares hashes.
//!
//! The S2D golden ([`S2D_GOLDENS`], [`s2d::S2dRun`], [`s2d::replay_s2d`]) is a baked S2D decoder and its
//! replay (each frame's decoder input, the neutral it decodes onto, the host's hash of the decoded
//! vertices), played with [`sinew_core::replay::check_s2d_frame`].
//!
//! Nothing here allocates: the frame buffers live in a caller-owned [`Scratch`] (a `static` on
//! the microcontrollers), sized for up to [`MAX_VERTICES`] vertices. An S2D replay reuses the
//! same `f32` buffers (the AIM positions and normals, [`ARENA`] values) for its input,
//! neutral, decoded vertices and the decoder's activations. The generated sequence
//! ([`motion::MOTION_GOLDENS`], [`motion::MotionRun`]) uses the same arena for its landmark
//! curve, the decoder's input, the decoded vertices and a scratch the generator and the decoder
//! share.
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

pub mod driver;
pub mod kernels;
mod list;
pub mod live;
pub mod motion;
pub mod performance;
pub mod s2d;
pub mod suite;
pub mod target;
pub mod track;

use core::fmt;

use sinew_core::FormatError;
use sinew_core::aim::{AimActor, MAX_SHAPES};
use sinew_core::q16::Q16;
pub use sinew_core::replay::FrameCheck;
use sinew_core::replay::{AimReplay, FrameBuffers, ReplayError, check_frame, check_model};

/// A golden model and one of its replays.
#[derive(Clone, Copy, Debug)]
pub struct Golden {
    /// Name for the log (`model.mode`).
    pub name: &'static str,
    /// The baked actor.
    pub model: &'static [u8],
    /// The replay recorded on the host.
    pub replay: &'static [u8],
}

/// Values of [`Scratch`]'s performance buffer: a fitted performance's coefficients, F_W's input
/// and its scratch ([`performance`]); a driver's landmarks, poses, filter state and network
/// scratch ([`driver`]).
pub const PERFORMANCE_SCRATCH: usize = 1024;

/// The procedural actor: 336 vertices, 6 shapes.
const PROCEDURAL: &[u8] = include_bytes!("../../../tests/data/aim-procedural.sinew");
/// The decimated ICT-FaceKit actor.
const ICT: &[u8] = include_bytes!("../../../tests/data/aim-ict.sinew");

/// Every golden replay, in the order the targets play them.
pub const GOLDENS: [Golden; 6] = [
    Golden {
        name: "aim-procedural.f32",
        model: PROCEDURAL,
        replay: include_bytes!("../../../tests/data/aim-procedural.f32.replay.sinew"),
    },
    Golden {
        name: "aim-procedural.q16",
        model: PROCEDURAL,
        replay: include_bytes!("../../../tests/data/aim-procedural.q16.replay.sinew"),
    },
    Golden {
        name: "aim-procedural.fast",
        model: PROCEDURAL,
        replay: include_bytes!("../../../tests/data/aim-procedural.fast.replay.sinew"),
    },
    Golden {
        name: "aim-ict.f32",
        model: ICT,
        replay: include_bytes!("../../../tests/data/aim-ict.f32.replay.sinew"),
    },
    Golden {
        name: "aim-ict.q16",
        model: ICT,
        replay: include_bytes!("../../../tests/data/aim-ict.q16.replay.sinew"),
    },
    Golden {
        name: "aim-ict.fast",
        model: ICT,
        replay: include_bytes!("../../../tests/data/aim-ict.fast.replay.sinew"),
    },
];

/// The S2D golden: a decoder trained briefly on real ICT-FaceKit pairs (the face region
/// decimated to 1,177 vertices) and 16 frames of real ICT expressions decoded onto another
/// identity's neutral.
///
/// A `static`, not a `const`: the generated sequence decodes with the same decoder
/// ([`motion::MOTION_GOLDENS`]), and a `const` used there as well was placed in the image twice
/// (448 KB more flash).
pub static S2D_GOLDENS: [Golden; 1] = [Golden {
    name: "s2d-ict.f32",
    model: include_bytes!("../../../tests/data/s2d-ict.sinew"),
    replay: include_bytes!("../../../tests/data/s2d-ict.replay.sinew"),
}];

/// Largest vertex count [`Scratch`] holds: the ICT golden actor fits, with the three frame
/// buffers at 60 KiB each.
pub const MAX_VERTICES: usize = 5120;

/// `f32` values of the shared frame arena: the AIM positions and normals (`6 × MAX_VERTICES`),
/// and 2,560 values more so that the generated sequence fits
/// ([`sinew_core::sequence::Sequence::buffer_len`]: its landmark curve, 6,324 values, beside the
/// S2D decoder's input, vertices and scratch). An S2D replay uses it for its input, neutral,
/// decoded vertices and [`sinew_core::s2d::S2dDecoder::scratch_len`].
pub const ARENA: usize = 6 * MAX_VERTICES + 2560;

/// Caller-owned buffers for one frame.
#[derive(Clone, Debug)]
pub struct Scratch {
    /// AIM: positions (first half) and normals (second half); S2D: the arena of [`ARENA`].
    frame: [f32; ARENA],
    positions_q16: [Q16; 3 * MAX_VERTICES],
    weights: [f32; MAX_SHAPES],
    weights_q16: [Q16; MAX_SHAPES],
    /// A fitted performance's coefficients, F_W's input and scratch; a driver's landmarks,
    /// poses, filter state and network scratch (one golden plays at a time).
    performance: [f32; PERFORMANCE_SCRATCH],
}

impl Scratch {
    /// Zeroed buffers (a `const fn`, so a `static` can hold them).
    pub const fn new() -> Self {
        Self {
            frame: [0.0; ARENA],
            positions_q16: [Q16::ZERO; 3 * MAX_VERTICES],
            weights: [0.0; MAX_SHAPES],
            weights_q16: [Q16::ZERO; MAX_SHAPES],
            performance: [0.0; PERFORMANCE_SCRATCH],
        }
    }

    /// The AIM frame buffers for `n` values each (`3 × vertices`) and `m` coefficients.
    fn aim(&mut self, n: usize, m: usize) -> Option<FrameBuffers<'_>> {
        let (positions, normals) = self.frame.split_at_mut_checked(3 * MAX_VERTICES)?;
        Some(FrameBuffers {
            positions: positions.get_mut(..n)?,
            normals: normals.get_mut(..n)?,
            positions_q16: self.positions_q16.get_mut(..n)?,
            weights: self.weights.get_mut(..m)?,
            weights_q16: self.weights_q16.get_mut(..m)?,
        })
    }
}

impl Default for Scratch {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a replay could not run to the end. A hash that differs is not an error: it is a
/// [`FrameCheck`] whose [`FrameCheck::ok`] is false.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// The model bytes are not a valid AIM actor.
    Model(FormatError),
    /// The replay bytes are not a valid AIM replay.
    Replay(FormatError),
    /// The actor has more vertices than [`MAX_VERTICES`].
    TooManyVertices {
        /// The actor's vertex count.
        vertices: usize,
    },
    /// The replay does not fit the model (another model's content hash, coefficient count,
    /// mode unavailable), or a buffer length is wrong.
    Playback(ReplayError),
    /// A fitted performance needs more scratch values than
    /// [`PERFORMANCE_SCRATCH`].
    ScratchTooSmall {
        /// Values needed.
        values: usize,
    },
    /// An S2D decoder needs more buffer values than [`ARENA`].
    S2dTooLarge {
        /// Values needed: input, neutral, decoded vertices and the decoder's scratch.
        values: usize,
    },
    /// A generated sequence needs more buffer values than [`ARENA`].
    MotionTooLarge {
        /// Values needed: curve, decoder input, decoded vertices and the shared scratch.
        values: usize,
    },
    /// The pinned hash list of a generated sequence is not UTF-8 or lacks its `sequence` line
    /// (label, seed, intensity); a driver's lacks its `track` or `filter` line.
    HashList,
    /// The driver's OpenFace track is not UTF-8, lacks a column (row 0: the header) or has a
    /// row that is missing or not numbers.
    Track {
        /// The row (1-based after the header; 0: the header).
        row: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Model(e) => write!(f, "golden model: {e}"),
            Self::Replay(e) => write!(f, "golden replay: {e}"),
            Self::TooManyVertices { vertices } => write!(
                f,
                "golden model has {vertices} vertices, more than the {MAX_VERTICES} the firmware holds"
            ),
            Self::Playback(e) => write!(f, "{e}"),
            Self::ScratchTooSmall { values } => write!(
                f,
                "golden performance needs {values} scratch values, more than the {} the firmware holds",
                PERFORMANCE_SCRATCH
            ),
            Self::S2dTooLarge { values } => write!(
                f,
                "golden S2D decoder needs {values} buffer values, more than the {ARENA} the firmware holds"
            ),
            Self::MotionTooLarge { values } => write!(
                f,
                "golden generated sequence needs {values} buffer values, more than the {ARENA} the firmware holds"
            ),
            Self::HashList => write!(
                f,
                "golden hash list: not UTF-8, or no `sequence LABEL-NAME LABEL SEED INTENSITY` \
                 line (a driver's: no `track FILE FX FY CX CY` or `filter A B C` line)"
            ),
            Self::Track { row: 0 } => write!(
                f,
                "golden track: not UTF-8, or no timestamp, x_0 … x_67 and y_0 … y_67 columns"
            ),
            Self::Track { row } => write!(
                f,
                "golden track: row {row} is missing, or a value of it is not a number"
            ),
        }
    }
}

impl core::error::Error for Error {}

/// Totals of finished replays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Summary {
    /// Frames played.
    pub frames: usize,
    /// Frames whose hash differed from the recorded one.
    pub mismatches: usize,
}

impl Summary {
    /// Counts one frame.
    pub fn add(&mut self, check: &FrameCheck) {
        self.frames += 1;
        if !check.ok() {
            self.mismatches += 1;
        }
    }

    /// Whether every frame matched (and there was at least one).
    pub const fn passed(&self) -> bool {
        self.frames > 0 && self.mismatches == 0
    }
}

/// A replay in progress: an iterator over its frames, so that a firmware can time each frame on
/// its own.
#[derive(Debug)]
pub struct Replay<'s> {
    actor: AimActor<'static>,
    replay: AimReplay<'static>,
    next: usize,
    scratch: &'s mut Scratch,
}

impl<'s> Replay<'s> {
    /// Validates the golden's model and replay, checks that the replay was recorded with this
    /// model (content hash) and that the actor fits in `scratch`.
    pub fn new(golden: &Golden, scratch: &'s mut Scratch) -> Result<Self, Error> {
        let actor = AimActor::from_bytes(golden.model).map_err(Error::Model)?;
        let replay = AimReplay::from_bytes(golden.replay).map_err(Error::Replay)?;
        check_model(golden.model, &actor, &replay).map_err(Error::Playback)?;
        if actor.vertex_count() > MAX_VERTICES {
            return Err(Error::TooManyVertices {
                vertices: actor.vertex_count(),
            });
        }
        Ok(Self {
            actor,
            replay,
            next: 0,
            scratch,
        })
    }

    /// The loaded actor.
    pub const fn actor(&self) -> &AimActor<'static> {
        &self.actor
    }

    /// The loaded replay.
    pub const fn replay(&self) -> &AimReplay<'static> {
        &self.replay
    }

    /// Plays frame `f` with the core's [`check_frame`], the step of the host's verification.
    fn play(&mut self, f: usize) -> Result<FrameCheck, Error> {
        let n = 3 * self.actor.vertex_count();
        let m = self.actor.shape_count();
        // The lengths were checked in `new`; `get_mut` keeps the replay free of panics anyway.
        let Some(mut buf) = self.scratch.aim(n, m) else {
            return Err(Error::TooManyVertices {
                vertices: self.actor.vertex_count(),
            });
        };
        check_frame(&self.actor, &self.replay, f, &mut buf).map_err(Error::Playback)
    }
}

impl Iterator for Replay<'_> {
    type Item = Result<FrameCheck, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        let f = self.next;
        if f >= self.replay.frames() {
            return None;
        }
        self.next += 1;
        Some(self.play(f))
    }
}

/// Plays every frame of `golden`, calling `report` after each one, and returns the totals.
pub fn replay(
    golden: &Golden,
    scratch: &mut Scratch,
    report: impl FnMut(&FrameCheck),
) -> Result<Summary, Error> {
    summarise(Replay::new(golden, scratch)?, report)
}

/// Runs `frames` to the end, calling `report` after each one, and returns the totals.
fn summarise(
    frames: impl Iterator<Item = Result<FrameCheck, Error>>,
    mut report: impl FnMut(&FrameCheck),
) -> Result<Summary, Error> {
    let mut summary = Summary::default();
    for r in frames {
        let r = r?;
        report(&r);
        summary.add(&r);
    }
    Ok(summary)
}

/// What one frame of a golden actor costs, phase by phase, in the units of the counter given to
/// [`phase_costs`] (instructions on the simulators).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct PhaseCosts {
    /// `f32` posing (AIM eq. 17), the reference mode.
    pub pose_f32: u64,
    /// Q16.16 posing, the weights' conversion included (0 without a Q16.16 cache).
    pub pose_q16: u64,
    /// Vertex normals with `libm` (f32 mode).
    pub normals_f32: u64,
    /// Vertex normals with micromath (fast mode).
    pub normals_fast: u64,
    /// Hashing positions and normals (the replay check, not playback).
    pub hash: u64,
}

impl fmt::Display for PhaseCosts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "pose_f32={} pose_q16={} normals_f32={} normals_fast={} hash={}",
            self.pose_f32, self.pose_q16, self.normals_f32, self.normals_fast, self.hash
        )
    }
}

/// Measures each phase of frame `frame` of `golden` separately with `now` (a monotonic counter:
/// retired instructions on RISC-V, SysTick on the Cortex-M).
///
/// This repeats the steps of [`sinew_core::replay::pose_frame`] and
/// [`sinew_core::replay::pose_frame_hash`] (posing in each mode, each mode's normals, hashing) only so
/// that the counter can be read between them, in every mode on the same frame; the replays
/// themselves ([`Replay`], [`s2d::S2dRun`]) play through the core's functions.
pub fn phase_costs(
    golden: &Golden,
    frame: usize,
    scratch: &mut Scratch,
    mut now: impl FnMut() -> u64,
) -> Result<PhaseCosts, Error> {
    use sinew_core::hash::FrameHasher;
    use sinew_core::q16::{PoseQ16, q16_slice};
    let r = Replay::new(golden, scratch)?;
    let (actor, replay) = (r.actor, r.replay);
    let n = 3 * actor.vertex_count();
    let m = actor.shape_count();
    let Some(FrameBuffers {
        positions,
        normals,
        positions_q16,
        weights,
        weights_q16,
    }) = r.scratch.aim(n, m)
    else {
        return Err(Error::TooManyVertices {
            vertices: actor.vertex_count(),
        });
    };
    let Some((head, jaw)) = replay.frame(frame, weights) else {
        return Err(Error::Replay(FormatError::incompatible_shapes(
            sinew_core::replay::AIM_INPUTS,
        )));
    };
    let buffer = |e| Error::Playback(ReplayError::Buffer(e));
    let mut costs = PhaseCosts::default();
    let t = now();
    let refused = |e: sinew_core::EvalError| Error::Playback(e.into());
    let pose = actor
        .pose_from_9d(&jaw, &head)
        .map_err(|e| refused(e.into()))?;
    actor.pose(&pose, weights, positions).map_err(refused)?;
    costs.pose_f32 = now() - t;
    if let Some(cache) = actor.q16() {
        let t = now();
        q16_slice(weights, weights_q16).map_err(buffer)?;
        cache
            .pose(&PoseQ16::from_pose(&pose), weights_q16, positions_q16)
            .map_err(buffer)?;
        costs.pose_q16 = now() - t;
    }
    let t = now();
    sinew_core::fast::vertex_normals(actor.triangles(), positions, normals).map_err(buffer)?;
    costs.normals_fast = now() - t;
    let t = now();
    actor.normals(positions, normals).map_err(refused)?;
    costs.normals_f32 = now() - t;
    let t = now();
    let mut h = FrameHasher::new();
    h.write_f32s(positions);
    h.write_f32s(normals);
    core::hint::black_box(h.finish());
    costs.hash = now() - t;
    Ok(costs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::boxed::Box;
    use std::string::ToString;
    use std::vec::Vec;

    fn scratch() -> Box<Scratch> {
        Box::default()
    }

    #[test]
    fn every_golden_replay_matches_the_host() {
        for g in &GOLDENS {
            let mut seen = Vec::new();
            let s = replay(g, &mut scratch(), |r| seen.push(*r)).unwrap();
            assert!(s.passed(), "{}", g.name);
            assert_eq!(s.frames, 16, "{}", g.name);
            // Frames differ from each other: the sequence really moves.
            assert_ne!(seen[0].hash, seen[15].hash, "{}", g.name);
        }
    }

    #[test]
    fn modes_differ() {
        let first = |g: &Golden| {
            replay(g, &mut scratch(), |_| {}).map(|_| {
                AimReplay::from_bytes(g.replay)
                    .unwrap()
                    .expected(15)
                    .unwrap()
            })
        };
        let hashes: Vec<u64> = GOLDENS.iter().map(|g| first(g).unwrap()).collect();
        for i in 0..hashes.len() {
            for j in 0..i {
                assert_ne!(
                    hashes[i], hashes[j],
                    "{} vs {}",
                    GOLDENS[i].name, GOLDENS[j].name
                );
            }
        }
    }

    #[test]
    fn corrupted_recorded_hash_is_a_mismatch_not_an_error() {
        // Flip one bit of frame 7's recorded hash, fixing the section CRC so the file loads.
        let g = GOLDENS[0];
        let mut bytes = g.replay.to_vec();
        let file = sinew_core::SinewFile::from_bytes(g.replay).unwrap();
        let s = file.section("replay.hash").unwrap();
        let offset = s.data().as_ptr() as usize - g.replay.as_ptr() as usize;
        bytes[offset + 7 * 8] ^= 1;
        let fixed = refresh_crcs(bytes, &file, "replay.hash");
        let leaked: &'static [u8] = Box::leak(fixed.into_boxed_slice());
        let bad = Golden {
            replay: leaked,
            ..g
        };
        let mut wrong = Vec::new();
        let sum = replay(&bad, &mut scratch(), |r| {
            if !r.ok() {
                wrong.push(*r);
            }
        })
        .unwrap();
        assert_eq!(sum.frames, 16);
        assert_eq!(sum.mismatches, 1);
        assert!(!sum.passed());
        assert_eq!(wrong[0].frame, 7);
        assert!(wrong[0].to_string().contains("DIFFERS"));
    }

    /// The hash list `text` with each line mapped by `edit` (`None` drops it), kept for the
    /// test's lifetime as a golden's list is.
    pub(crate) fn edited_list(
        text: &str,
        edit: impl Fn(&str) -> Option<std::string::String>,
    ) -> &'static [u8] {
        let lines: std::string::String = text
            .lines()
            .filter_map(|l| edit(l).map(|l| std::format!("{l}\n")))
            .collect();
        Box::leak(lines.into_bytes().into_boxed_slice())
    }

    /// `line` (a pinned check) with its last hexadecimal digit changed: a wrong pinned hash.
    pub(crate) fn wrong_last_digit(line: &str) -> std::string::String {
        let last = if line.ends_with('0') { '1' } else { '0' };
        std::format!("{}{last}", &line[..line.len() - 1])
    }

    /// Recomputes the CRC of section `name` (the last field of its table entry) and the header
    /// CRC (over the header before its CRC field, then the table).
    pub(crate) fn refresh_crcs(
        mut bytes: Vec<u8>,
        file: &sinew_core::SinewFile<'_>,
        name: &str,
    ) -> Vec<u8> {
        use sinew_core::format::{
            CRC32, ENTRY_CRC, HEADER_CRC, HEADER_CRC_OFFSET, HEADER_LEN, SECTION_ENTRY_LEN,
        };
        let s = file.section(name).unwrap();
        let entry = HEADER_LEN + usize::from(s.index) * SECTION_ENTRY_LEN;
        let start = s.data().as_ptr() as usize - file.bytes().as_ptr() as usize;
        let crc = CRC32.checksum(&bytes[start..start + s.data().len()]);
        bytes[ENTRY_CRC.at(entry)].copy_from_slice(&crc.to_le_bytes());
        let table_end = HEADER_LEN + file.section_count() * SECTION_ENTRY_LEN;
        let mut h = CRC32.digest();
        h.update(&bytes[..HEADER_CRC_OFFSET]);
        h.update(&bytes[HEADER_LEN..table_end]);
        bytes[HEADER_CRC.range()].copy_from_slice(&h.finalize().to_le_bytes());
        bytes
    }

    #[test]
    fn kernel_suite_matches_the_pinned_host_hashes() {
        let mut names = Vec::new();
        let (cases, bad) = kernels::check_kernels(&mut Box::default(), |name, _, ok| {
            names.push((name.to_string(), ok));
        })
        .unwrap();
        assert_eq!((cases, bad), (8, 0), "{names:?}");
        assert_eq!(cases, kernels::KERNEL_HASHES.lines().count());
    }

    #[test]
    fn phase_costs_measure_every_phase() {
        let mut clock = 0u64;
        let c = phase_costs(&GOLDENS[3], 8, &mut scratch(), || {
            clock += 1;
            clock
        })
        .unwrap();
        // Each phase is one tick of this counter: every phase ran and was timed on its own.
        assert_eq!(
            c,
            PhaseCosts {
                pose_f32: 1,
                pose_q16: 1,
                normals_f32: 1,
                normals_fast: 1,
                hash: 1
            }
        );
    }

    #[test]
    fn replay_of_another_model_is_refused() {
        let g = Golden {
            model: ICT,
            ..GOLDENS[0]
        };
        let got = Replay::new(&g, &mut scratch()).map(|_| ());
        assert!(
            matches!(got, Err(Error::Playback(ReplayError::WrongModel { .. }))),
            "{got:?}"
        );
        assert!(got.unwrap_err().to_string().contains("recorded with model"));
    }

    #[test]
    fn bad_model_is_an_error() {
        let g = Golden {
            model: PROCEDURAL.get(..100).unwrap(),
            ..GOLDENS[0]
        };
        let got = Replay::new(&g, &mut scratch()).map(|_| ());
        assert!(matches!(got, Err(Error::Model(_))), "{got:?}");
        assert!(got.unwrap_err().to_string().starts_with("golden model: "));
    }
}
