//! The golden generated sequence: a small Motion3DGAN generator (`tests/data/motion-ict.sinew`)
//! makes the landmark curve of a label and a seed, and the golden S2D decoder
//! (`tests/data/s2d-ict.sinew`) decodes each of its 30 frames onto its own template neutral, all
//! through [`sinew_core::sequence::Sequence`], the path `sinew generate` and the host's golden
//! test take. Each frame's hash is compared with `tests/data/motion-ict.hashes`, the list the
//! host test pins, which also names the label, the seed and the intensity.
//!
//! The curve is generated first, in the shared arena (the generator's scratch overlaps the
//! decoder's), and the frames are then decoded one at a time in the same arena.

use core::fmt;

use sinew_core::FormatError;
use sinew_core::hash::FrameHasher;
use sinew_core::motion::MotionGenerator;
use sinew_core::replay::{FrameCheck, ReplayError};
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_core::srvf::FRAMES;

use crate::list;
use crate::{ARENA, Error, Golden, S2D_GOLDENS, Scratch, Summary, summarise};

/// The golden generated sequence. `model` is the generator, `replay` the pinned hash list; the
/// decoder is the S2D golden's ([`S2D_GOLDENS`]).
pub const MOTION_GOLDENS: [Golden; 1] = [Golden {
    name: "motion-ict.f32",
    model: include_bytes!("../../../tests/data/motion-ict.sinew"),
    replay: include_bytes!("../../../tests/data/motion-ict.hashes"),
}];

/// What a hash list says: the sequence's label index, seed and intensity (its `sequence`
/// line) and the hash of each frame (its `motion T HASH` lines).
#[derive(Clone, Copy, Debug)]
pub struct HashList {
    text: &'static str,
    /// The label's index.
    pub label: usize,
    /// The seed of the noise.
    pub seed: u64,
    /// The motion's intensity.
    pub intensity: f32,
}

impl HashList {
    /// Reads the `sequence LABEL-NAME LABEL SEED INTENSITY` line of `bytes`; `None` if the text
    /// is not UTF-8 or the line is missing or malformed.
    pub fn parse(bytes: &'static [u8]) -> Option<Self> {
        let text = core::str::from_utf8(bytes).ok()?;
        let mut f = list::words(text, "sequence")?.skip(1);
        let label = f.next()?.parse().ok()?;
        let seed = f.next()?.parse().ok()?;
        let intensity = f.next()?.parse().ok()?;
        Some(Self {
            text,
            label,
            seed,
            intensity,
        })
    }

    /// The pinned hash of frame `t`, if the list has one.
    pub fn expected(&self, t: usize) -> Option<u64> {
        list::pinned_hash(self.text, "motion", t)
    }
}

/// A generated sequence in progress: its curve generated, an iterator over frames 1 to
/// [`FRAMES`], so that a firmware can time each frame on its own.
#[derive(Debug)]
pub struct MotionRun<'s> {
    sequence: Sequence<'static>,
    hashes: HashList,
    next: usize,
    arena: &'s mut [f32; ARENA],
}

impl<'s> MotionRun<'s> {
    /// Validates the golden's generator, the S2D golden's decoder and the hash list, checks that
    /// the buffers fit the arena, and generates the curve.
    pub fn new(golden: &Golden, scratch: &'s mut Scratch) -> Result<Self, Error> {
        let sequence = load(golden)?;
        let hashes = HashList::parse(golden.replay).ok_or(Error::HashList)?;
        carve(&sequence, &mut scratch.frame).and_then(|mut buf| {
            sequence
                .curve(hashes.label, hashes.seed, hashes.intensity, &mut buf)
                .map_err(|e| Error::Playback(ReplayError::from(e)))
        })?;
        Ok(Self {
            sequence,
            hashes,
            next: 1,
            arena: &mut scratch.frame,
        })
    }

    /// The sequence (generator and decoder).
    pub const fn sequence(&self) -> &Sequence<'static> {
        &self.sequence
    }

    /// The pinned hash list.
    pub const fn hashes(&self) -> &HashList {
        &self.hashes
    }

    /// Decodes frame `t` and compares its hash with the pinned one (a frame missing from the
    /// list is a mismatch).
    fn play(&mut self, t: usize) -> Result<FrameCheck, Error> {
        let expected = self.hashes.expected(t);
        let hash = self
            .sequence
            .decode_frame_hash(t, &mut carve(&self.sequence, self.arena)?)
            .map_err(|e| Error::Playback(ReplayError::from(e)))?;
        Ok(FrameCheck {
            frame: t,
            hash,
            expected: expected.unwrap_or(!hash),
        })
    }
}

/// The arena carved into curve | input | vertices | scratch for `s`, on the decoder's template
/// neutral.
fn carve<'b>(s: &Sequence<'_>, arena: &'b mut [f32]) -> Result<SequenceBuffers<'b>, Error> {
    let too_large = Error::MotionTooLarge {
        values: s.buffer_len(),
    };
    let (curve, rest) = arena.split_at_mut_checked(s.curve_len()).ok_or(too_large)?;
    let (input, rest) = rest.split_at_mut_checked(s.input_len()).ok_or(too_large)?;
    let (vertices, rest) = rest.split_at_mut_checked(s.vertex_len()).ok_or(too_large)?;
    let scratch = rest.get_mut(..s.scratch_len()).ok_or(too_large)?;
    Ok(SequenceBuffers {
        curve,
        input,
        neutral: &[],
        scratch,
        vertices,
    })
}

/// The golden's generator paired with the S2D golden's decoder.
fn load(golden: &Golden) -> Result<Sequence<'static>, Error> {
    let generator = MotionGenerator::from_bytes(golden.model).map_err(Error::Model)?;
    let decoder = S2D_GOLDENS
        .first()
        .ok_or(Error::Model(FormatError::MissingSection {
            section: sinew_core::error::SectionName::new("s2d.cfg"),
        }))?;
    let decoder = S2dDecoder::from_bytes(decoder.model).map_err(Error::Model)?;
    Sequence::new(generator, decoder).map_err(Error::Model)
}

impl Iterator for MotionRun<'_> {
    type Item = Result<FrameCheck, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        let t = self.next;
        if t > FRAMES {
            return None;
        }
        self.next += 1;
        Some(self.play(t))
    }
}

/// Plays every frame of the generated `golden`, calling `report` after each one, and returns the
/// totals.
pub fn replay_motion(
    golden: &Golden,
    scratch: &mut Scratch,
    report: impl FnMut(&FrameCheck),
) -> Result<Summary, Error> {
    summarise(MotionRun::new(golden, scratch)?, report)
}

/// What the generated sequence costs, in the units of the counter given to [`motion_costs`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct MotionCosts {
    /// Generating the landmark curve once (noise, generator MLP, exp map, decoding onto the
    /// neutral's landmarks).
    pub curve: u64,
    /// Decoding one frame: the decoder's input from the curve, then S2D-Dec onto the neutral.
    pub decode: u64,
    /// Hashing the decoded vertices (the golden check, not playback).
    pub hash: u64,
}

impl fmt::Display for MotionCosts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "curve={} decode={} hash={}",
            self.curve, self.decode, self.hash
        )
    }
}

/// Measures the curve's generation and the decoding and hashing of frame `t` of the generated
/// `golden` separately with `now`. Both steps are the core's [`Sequence::curve`] and
/// [`Sequence::frame`]; the hashing half of [`Sequence::decode_frame_hash`] is repeated here only so
/// that the counter can be read between the two.
pub fn motion_costs(
    golden: &Golden,
    t: usize,
    scratch: &mut Scratch,
    mut now: impl FnMut() -> u64,
) -> Result<MotionCosts, Error> {
    let sequence = load(golden)?;
    let h = HashList::parse(golden.replay).ok_or(Error::HashList)?;
    let mut buf = carve(&sequence, &mut scratch.frame)?;
    let buffer = |e: sinew_core::EvalError| Error::Playback(ReplayError::from(e));
    let mut costs = MotionCosts::default();
    let start = now();
    sequence
        .curve(h.label, h.seed, h.intensity, &mut buf)
        .map_err(buffer)?;
    costs.curve = now() - start;
    let start = now();
    sequence.frame(t, &mut buf).map_err(buffer)?;
    costs.decode = now() - start;
    let start = now();
    let mut hasher = FrameHasher::new();
    hasher.write_f32s(buf.vertices);
    core::hint::black_box(hasher.finish());
    costs.hash = now() - start;
    Ok(costs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::{edited_list, wrong_last_digit};
    use std::boxed::Box;
    use std::vec::Vec;

    #[test]
    fn the_generated_sequence_matches_the_host() {
        let g = &MOTION_GOLDENS[0];
        let mut seen = Vec::new();
        let s = replay_motion(g, &mut Box::default(), |r| seen.push(*r)).unwrap();
        assert!(s.passed(), "{seen:?}");
        assert_eq!(s.frames, FRAMES);
        assert_eq!(seen[0].frame, 1);
        // The sequence moves: its first and last frames differ.
        assert_ne!(seen[0].hash, seen[FRAMES - 1].hash);
    }

    #[test]
    fn a_wrong_pinned_hash_is_a_mismatch_and_a_bad_list_an_error() {
        let g = MOTION_GOLDENS[0];
        let text = core::str::from_utf8(g.replay).unwrap();
        // Frame 12's hash with its last digit changed.
        let leaked = edited_list(text, |l| {
            Some(if l.starts_with("motion 12 ") {
                wrong_last_digit(l)
            } else {
                l.into()
            })
        });
        let bad = Golden {
            replay: leaked,
            ..g
        };
        let mut wrong = Vec::new();
        let s = replay_motion(&bad, &mut Box::default(), |r| {
            if !r.ok() {
                wrong.push(r.frame);
            }
        })
        .unwrap();
        assert_eq!((s.frames, s.mismatches), (FRAMES, 1));
        assert_eq!(wrong, [12]);
        // Without its `sequence` line the list cannot say what to generate.
        let leaked = edited_list(text, |l| (!l.starts_with("sequence ")).then(|| l.into()));
        let got = MotionRun::new(
            &Golden {
                replay: leaked,
                ..g
            },
            &mut Box::default(),
        )
        .map(|_| ());
        assert_eq!(got, Err(Error::HashList));
    }

    #[test]
    fn another_kind_of_model_is_refused() {
        let g = Golden {
            model: S2D_GOLDENS[0].model,
            ..MOTION_GOLDENS[0]
        };
        let got = MotionRun::new(&g, &mut Box::default()).map(|_| ());
        assert_eq!(got, Err(Error::Model(FormatError::WrongKind)));
    }

    #[test]
    fn motion_costs_measure_every_phase() {
        let mut clock = 0u64;
        let c = motion_costs(&MOTION_GOLDENS[0], 15, &mut Box::default(), || {
            clock += 1;
            clock
        })
        .unwrap();
        assert_eq!(
            c,
            MotionCosts {
                curve: 1,
                decode: 1,
                hash: 1
            }
        );
    }
}
