//! The S2D golden played on a target: [`S2dRun`] decodes each frame of the golden replay in the
//! shared frame buffers with the core's [`check_s2d_frame`]; [`s2d_costs`] measures one frame's
//! phases.

use core::fmt;

use sinew_core::hash::FrameHasher;
use sinew_core::replay::{
    FrameCheck, ReplayError, S2dBuffers, S2dReplay, check_s2d_frame, check_s2d_model, decode_frame,
};
use sinew_core::s2d::S2dDecoder;

use crate::{ARENA, Error, Golden, Scratch, Summary, summarise};

/// An S2D replay in progress: an iterator over its frames, so that a firmware can time each
/// frame on its own.
#[derive(Debug)]
pub struct S2dRun<'s> {
    decoder: S2dDecoder<'static>,
    replay: S2dReplay<'static>,
    next: usize,
    arena: &'s mut [f32; ARENA],
}

impl<'s> S2dRun<'s> {
    /// Validates the golden's decoder and replay, checks that the replay was recorded with this
    /// decoder (content hash) and fits it, that the buffers fit in `scratch`, and copies the
    /// replay's neutral into them.
    pub fn new(golden: &Golden, scratch: &'s mut Scratch) -> Result<Self, Error> {
        let decoder = S2dDecoder::from_bytes(golden.model).map_err(Error::Model)?;
        let replay = S2dReplay::from_bytes(golden.replay).map_err(Error::Replay)?;
        check_s2d_model(golden.model, &decoder, &replay).map_err(Error::Playback)?;
        let mut run = Self {
            decoder,
            replay,
            next: 0,
            arena: &mut scratch.frame,
        };
        let values = run.needed();
        let Some(buf) = run.buffers() else {
            return Err(Error::S2dTooLarge { values });
        };
        replay
            .copy_neutral(buf.neutral)
            .map_err(|e| Error::Playback(ReplayError::Buffer(e)))?;
        Ok(run)
    }

    /// The loaded decoder.
    pub const fn decoder(&self) -> &S2dDecoder<'static> {
        &self.decoder
    }

    /// The loaded replay.
    pub const fn replay(&self) -> &S2dReplay<'static> {
        &self.replay
    }

    /// Buffer values the replay needs: input, neutral (if the replay has one), decoded
    /// vertices, the decoder's scratch.
    pub fn needed(&self) -> usize {
        let v = 3 * self.decoder.vertex_count();
        let neutral = if self.replay.neutral().is_some() {
            v
        } else {
            0
        };
        self.decoder.input_len() + neutral + v + self.decoder.scratch_len()
    }

    /// The arena carved into input | neutral | vertices | scratch (`None` if it is too small).
    fn buffers(&mut self) -> Option<S2dBuffers<'_>> {
        let v = 3 * self.decoder.vertex_count();
        let neutral = if self.replay.neutral().is_some() {
            v
        } else {
            0
        };
        let (input, rest) = self.arena.split_at_mut_checked(self.decoder.input_len())?;
        let (neutral, rest) = rest.split_at_mut_checked(neutral)?;
        let (vertices, rest) = rest.split_at_mut_checked(v)?;
        let scratch = rest.get_mut(..self.decoder.scratch_len())?;
        Some(S2dBuffers {
            input,
            neutral,
            scratch,
            vertices,
        })
    }

    /// Plays frame `f` with the core's [`check_s2d_frame`], the step of the host's
    /// verification.
    fn play(&mut self, f: usize) -> Result<FrameCheck, Error> {
        let (replay, decoder) = (self.replay, self.decoder.clone());
        let values = self.needed();
        let Some(mut buf) = self.buffers() else {
            return Err(Error::S2dTooLarge { values });
        };
        check_s2d_frame(&decoder, &replay, f, &mut buf).map_err(Error::Playback)
    }
}

impl Iterator for S2dRun<'_> {
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

/// Plays every frame of the S2D `golden`, calling `report` after each one, and returns the
/// totals.
pub fn replay_s2d(
    golden: &Golden,
    scratch: &mut Scratch,
    report: impl FnMut(&FrameCheck),
) -> Result<Summary, Error> {
    summarise(S2dRun::new(golden, scratch)?, report)
}

/// What one S2D frame costs, in the units of the counter given to [`s2d_costs`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct S2dCosts {
    /// Decoding: the fully connected layer, up-samplings and spiral convolutions, and adding the
    /// neutral.
    pub decode: u64,
    /// Hashing the decoded vertices (the replay check, not playback).
    pub hash: u64,
}

impl fmt::Display for S2dCosts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "decode={} hash={}", self.decode, self.hash)
    }
}

/// Measures decoding and hashing of frame `frame` of the S2D `golden` separately with `now`.
///
/// Decoding is the core's [`decode_frame`], the first half of
/// [`sinew_core::replay::s2d_frame_hash`]; the hashing half is repeated here only so that the
/// counter can be read between the two.
pub fn s2d_costs(
    golden: &Golden,
    frame: usize,
    scratch: &mut Scratch,
    mut now: impl FnMut() -> u64,
) -> Result<S2dCosts, Error> {
    use sinew_core::FormatError;
    let mut run = S2dRun::new(golden, scratch)?;
    let (replay, decoder) = (run.replay, run.decoder.clone());
    let values = run.needed();
    let Some(mut buf) = run.buffers() else {
        return Err(Error::S2dTooLarge { values });
    };
    if replay.frame(frame, buf.input).is_none() {
        return Err(Error::Replay(FormatError::incompatible_shapes(
            sinew_core::replay::S2D_INPUTS,
        )));
    }
    let mut costs = S2dCosts::default();
    let t = now();
    decode_frame(&decoder, &mut buf).map_err(Error::Playback)?;
    costs.decode = now() - t;
    let t = now();
    let mut h = FrameHasher::new();
    h.write_f32s(buf.vertices);
    core::hint::black_box(h.finish());
    costs.hash = now() - t;
    Ok(costs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::refresh_crcs;
    use crate::{GOLDENS, ICT, Replay, S2D_GOLDENS};
    use std::boxed::Box;
    use std::vec::Vec;

    fn scratch() -> Box<Scratch> {
        Box::default()
    }

    #[test]
    fn the_s2d_golden_matches_the_host() {
        for g in &S2D_GOLDENS {
            let mut seen = Vec::new();
            let s = replay_s2d(g, &mut scratch(), |r| seen.push(*r)).unwrap();
            assert!(s.passed(), "{}", g.name);
            assert_eq!(s.frames, 16, "{}", g.name);
            assert_ne!(seen[1].hash, seen[15].hash, "{}", g.name);
            let mut sc = scratch();
            let run = S2dRun::new(g, &mut sc).unwrap();
            assert!(run.needed() <= ARENA);
            assert_eq!(run.decoder().vertex_count(), 1177);
        }
    }

    #[test]
    fn s2d_replay_of_another_model_or_kind_is_refused() {
        // An AIM actor is no S2D decoder.
        let g = Golden {
            model: ICT,
            ..S2D_GOLDENS[0]
        };
        let got = S2dRun::new(&g, &mut scratch()).map(|_| ());
        assert!(matches!(got, Err(Error::Model(_))), "{got:?}");
        // An AIM replay is no S2D replay.
        let g = Golden {
            replay: GOLDENS[3].replay,
            ..S2D_GOLDENS[0]
        };
        let got = S2dRun::new(&g, &mut scratch()).map(|_| ());
        assert!(matches!(got, Err(Error::Replay(_))), "{got:?}");
        // The S2D replay against the AIM pipeline.
        let g = Golden {
            replay: S2D_GOLDENS[0].replay,
            ..GOLDENS[3]
        };
        let got = Replay::new(&g, &mut scratch()).map(|_| ());
        assert!(matches!(got, Err(Error::Replay(_))), "{got:?}");
    }

    #[test]
    fn s2d_corrupted_recorded_hash_is_a_mismatch() {
        let g = S2D_GOLDENS[0];
        let mut bytes = g.replay.to_vec();
        let file = sinew_core::SinewFile::from_bytes(g.replay).unwrap();
        let s = file.section("replay.hash").unwrap();
        let offset = s.data().as_ptr() as usize - g.replay.as_ptr() as usize;
        bytes[offset + 11 * 8 + 3] ^= 0x40;
        let fixed = refresh_crcs(bytes, &file, "replay.hash");
        let leaked: &'static [u8] = Box::leak(fixed.into_boxed_slice());
        let bad = Golden {
            replay: leaked,
            ..g
        };
        let mut wrong = Vec::new();
        let sum = replay_s2d(&bad, &mut scratch(), |r| {
            if !r.ok() {
                wrong.push(r.frame);
            }
        })
        .unwrap();
        assert_eq!((sum.frames, sum.mismatches), (16, 1));
        assert_eq!(wrong, [11]);
    }

    #[test]
    fn s2d_costs_measure_both_phases() {
        let mut clock = 0u64;
        let c = s2d_costs(&S2D_GOLDENS[0], 8, &mut scratch(), || {
            clock += 1;
            clock
        })
        .unwrap();
        assert_eq!(c, S2dCosts { decode: 1, hash: 1 });
    }
}
