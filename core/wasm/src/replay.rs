//! A validated replay that owns its bytes ([`Replay`]): per-frame inputs ([`FrameInputs`]) and
//! the hash recorded for each.

use self_cell::self_cell;
use sinew_core::format::{ArtifactKind, SinewFile};
use sinew_core::replay::{self, AimReplay, S2D_INPUTS, S2dReplay};

use crate::error::Error;
use crate::model::{Kind, Model, ModelInner, POSE_9D};

self_cell!(
    struct AimReplayCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: AimReplay,
    }
    impl {Debug}
);

self_cell!(
    struct S2dReplayCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: S2dReplay,
    }
    impl {Debug}
);

#[derive(Debug)]
enum ReplayInner {
    Aim(AimReplayCell),
    S2d(S2dReplayCell),
}

/// A validated replay that owns its bytes: per-frame inputs and the hash recorded for each.
#[derive(Debug)]
pub struct Replay {
    inner: ReplayInner,
}

/// One frame's inputs.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameInputs {
    /// An AIM frame.
    Aim {
        /// `[9]` head pose.
        head: [f32; POSE_9D],
        /// `[9]` jaw pose.
        jaw: [f32; POSE_9D],
        /// `[M]` coefficients.
        coefficients: Vec<f32>,
    },
    /// An S2D frame: `[inputs]`, the decoder's (normalised) input.
    S2d(Vec<f32>),
}

impl Replay {
    /// Validates `bytes` as a replay: an S2D replay when it has the `replay.s2d` section, else an
    /// AIM replay.
    ///
    /// # Errors
    /// The core's [`sinew_core::FormatError`] message.
    pub fn load(bytes: Vec<u8>) -> Result<Self, Error> {
        let file = SinewFile::from_bytes(&bytes)?;
        if file.kind != ArtifactKind::Replay {
            return Err(Error::new(format!(
                "{} ({}, not a replay)",
                sinew_core::FormatError::WrongKind,
                file.kind
            )));
        }
        let s2d = file.section(S2D_INPUTS).is_some();
        let bytes = bytes.into_boxed_slice();
        let inner = if s2d {
            ReplayInner::S2d(S2dReplayCell::try_new(bytes, |b| {
                S2dReplay::from_bytes(b).map_err(Error::from)
            })?)
        } else {
            ReplayInner::Aim(AimReplayCell::try_new(bytes, |b| {
                AimReplay::from_bytes(b).map_err(Error::from)
            })?)
        };
        Ok(Self { inner })
    }

    /// A replay of an AIM actor or of an S2D decoder.
    pub const fn kind(&self) -> Kind {
        match self.inner {
            ReplayInner::Aim(_) => Kind::Aim,
            ReplayInner::S2d(_) => Kind::S2d,
        }
    }

    /// The numeric mode it was recorded in (`f32`, `q16`, `fast`; S2D replays are `f32`).
    pub fn mode(&self) -> &'static str {
        match &self.inner {
            ReplayInner::Aim(c) => c.borrow_dependent().mode().name(),
            ReplayInner::S2d(_) => replay::Mode::F32.name(),
        }
    }

    /// Number of frames (at least one).
    pub fn frames(&self) -> usize {
        match &self.inner {
            ReplayInner::Aim(c) => c.borrow_dependent().frames(),
            ReplayInner::S2d(c) => c.borrow_dependent().frames(),
        }
    }

    /// The content hash of the model it was recorded with.
    pub fn model_hash(&self) -> u64 {
        match &self.inner {
            ReplayInner::Aim(c) => c.borrow_dependent().model_hash(),
            ReplayInner::S2d(c) => c.borrow_dependent().model_hash(),
        }
    }

    /// The neutral face an S2D replay's frames decode onto, `[V, 3]`, if it carries one.
    pub fn neutral(&self) -> Option<Vec<f32>> {
        match &self.inner {
            ReplayInner::Aim(_) => None,
            ReplayInner::S2d(c) => c.borrow_dependent().neutral().map(|n| n.iter().collect()),
        }
    }

    /// Whether an S2D replay carries the neutral its frames decode onto.
    pub fn has_neutral(&self) -> bool {
        match &self.inner {
            ReplayInner::Aim(_) => false,
            ReplayInner::S2d(c) => c.borrow_dependent().neutral().is_some(),
        }
    }

    fn check_frame(&self, f: usize) -> Result<(), Error> {
        if f < self.frames() {
            Ok(())
        } else {
            Err(Error::new(format!(
                "frame {f} is past the end of the replay ({} frames)",
                self.frames()
            )))
        }
    }

    /// Frame `f`'s inputs.
    ///
    /// # Errors
    /// `f` is past the end.
    pub fn frame(&self, f: usize) -> Result<FrameInputs, Error> {
        self.check_frame(f)?;
        match &self.inner {
            ReplayInner::Aim(c) => {
                let r = c.borrow_dependent();
                let mut coefficients = vec![0.0; r.shape_count()];
                let (head, jaw) = r
                    .frame(f, &mut coefficients)
                    .ok_or_else(|| Error::from(sinew_core::BufferError::Input))?;
                Ok(FrameInputs::Aim {
                    head,
                    jaw,
                    coefficients,
                })
            }
            ReplayInner::S2d(c) => {
                let r = c.borrow_dependent();
                let mut input = vec![0.0; r.input_len()];
                r.frame(f, &mut input)
                    .ok_or_else(|| Error::from(sinew_core::BufferError::Input))?;
                Ok(FrameInputs::S2d(input))
            }
        }
    }

    /// The hash recorded for frame `f`.
    ///
    /// # Errors
    /// `f` is past the end.
    pub fn expected(&self, f: usize) -> Result<u64, Error> {
        self.check_frame(f)?;
        let hash = match &self.inner {
            ReplayInner::Aim(c) => c.borrow_dependent().expected(f),
            ReplayInner::S2d(c) => c.borrow_dependent().expected(f),
        };
        hash.ok_or_else(|| {
            Error::from(sinew_core::FormatError::incompatible_shapes(
                replay::FRAME_HASHES,
            ))
        })
    }

    /// Checks that this replay was recorded with `model` ([`replay::check_model`] or
    /// [`replay::check_s2d_model`]: content hash, coefficient or input count, neutral size).
    ///
    /// # Errors
    /// The core's `ReplayError` message, or a replay of another kind of model.
    pub fn check(&self, model: &Model) -> Result<(), Error> {
        match (&self.inner, &model.inner) {
            (ReplayInner::Aim(r), ModelInner::Aim(m)) => Ok(replay::check_model(
                m.borrow_owner(),
                m.borrow_dependent(),
                r.borrow_dependent(),
            )?),
            (ReplayInner::S2d(r), ModelInner::S2d { cell, .. }) => Ok(replay::check_s2d_model(
                cell.borrow_owner(),
                cell.borrow_dependent(),
                r.borrow_dependent(),
            )?),
            _ => Err(Error::new(format!(
                "this replay is of {}, the model is {}",
                self.kind().long_name(),
                model.kind().long_name()
            ))),
        }
    }
}
