//! A validated model that owns its bytes ([`Model`]: an AIM actor or an S2D decoder), its
//! [`Kind`], and the checks of a caller's values every value type here shares.

use self_cell::self_cell;
use sinew_core::aim::AimActor;
use sinew_core::error::Argument;
use sinew_core::format::{ArtifactKind, SinewFile};
use sinew_core::hash::FrameHasher;
use sinew_core::replay;
use sinew_core::s2d::S2dDecoder;

use crate::error::Error;

/// Values in a head or jaw pose: a 6D rotation, then a translation.
pub const POSE_9D: usize = 9;

self_cell!(
    pub(crate) struct AimCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: AimActor,
    }
    impl {Debug}
);

self_cell!(
    pub(crate) struct S2dCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: S2dDecoder,
    }
    impl {Debug}
);

/// The kind of a model or replay: an AIM actor or an S2D decoder (or a replay of one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An AIM actor, posed per frame.
    Aim,
    /// An S2D decoder, landmark displacements to a dense mesh.
    S2d,
}

impl Kind {
    /// `"aim"` or `"s2d"`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Aim => "aim",
            Self::S2d => "s2d",
        }
    }

    pub(crate) const fn long_name(self) -> &'static str {
        match self {
            Self::Aim => "an AIM actor",
            Self::S2d => "an S2D decoder",
        }
    }
}

#[derive(Debug)]
pub(crate) enum ModelInner {
    Aim(AimCell),
    S2d {
        cell: S2dCell,
        /// The decoder's scratch ([`S2dDecoder::scratch_len`]), kept between frames.
        scratch: Vec<f32>,
    },
}

/// A validated model that owns its bytes: an AIM actor or an S2D decoder.
#[derive(Debug)]
pub struct Model {
    pub(crate) inner: ModelInner,
    /// The content hash of the bytes ([`replay::model_hash`]), computed once: a performance
    /// compares it at every frame.
    hash: u64,
}

/// `what` must hold `expected` values.
pub(crate) fn check_len(what: &str, got: usize, expected: usize) -> Result<(), Error> {
    if got == expected {
        Ok(())
    } else {
        Err(Error::new(format!(
            "{what} has {got} values, expected {expected}"
        )))
    }
}

pub(crate) fn pose_9d(what: &str, values: &[f32]) -> Result<[f32; POSE_9D], Error> {
    <[f32; POSE_9D]>::try_from(values).map_err(|_| {
        Error::new(format!(
            "{what} has {} values, expected {POSE_9D} (6D rotation, then translation)",
            values.len()
        ))
    })
}

impl Model {
    /// Validates `bytes` as an AIM actor or an S2D decoder, whichever the header says.
    ///
    /// # Errors
    /// The core's [`sinew_core::FormatError`] message, or, for another kind of artefact, that of
    /// `WrongKind` with the kind found.
    pub fn load(bytes: Vec<u8>) -> Result<Self, Error> {
        let kind = SinewFile::from_bytes(&bytes)?.kind;
        let hash = replay::model_hash(&bytes);
        let bytes = bytes.into_boxed_slice();
        let inner = match kind {
            ArtifactKind::AimActor => ModelInner::Aim(AimCell::try_new(bytes, |b| {
                AimActor::from_bytes(b).map_err(Error::from)
            })?),
            ArtifactKind::S2dDecoder => {
                let cell =
                    S2dCell::try_new(bytes, |b| S2dDecoder::from_bytes(b).map_err(Error::from))?;
                let scratch = vec![0.0; cell.borrow_dependent().scratch_len()];
                ModelInner::S2d { cell, scratch }
            }
            other => {
                return Err(Error::new(format!(
                    "{} ({other}; a model is an AIM actor or an S2D decoder)",
                    sinew_core::FormatError::WrongKind,
                )));
            }
        };
        Ok(Self { inner, hash })
    }

    /// AIM actor or S2D decoder.
    pub const fn kind(&self) -> Kind {
        match self.inner {
            ModelInner::Aim(_) => Kind::Aim,
            ModelInner::S2d { .. } => Kind::S2d,
        }
    }

    fn file(&self) -> &SinewFile<'_> {
        match &self.inner {
            ModelInner::Aim(c) => c.borrow_dependent().file(),
            ModelInner::S2d { cell, .. } => cell.borrow_dependent().file(),
        }
    }

    /// The content hash of the model's bytes ([`sinew_core::replay::model_hash`]), which a
    /// replay names.
    pub const fn content_hash(&self) -> u64 {
        self.hash
    }

    /// The metadata text: `key=value` lines (`units=cm`, provenance).
    pub fn metadata(&self) -> &str {
        self.file().metadata().text()
    }

    /// Vertices of the output mesh.
    pub fn vertex_count(&self) -> usize {
        match &self.inner {
            ModelInner::Aim(c) => c.borrow_dependent().vertex_count(),
            ModelInner::S2d { cell, .. } => cell.borrow_dependent().vertex_count(),
        }
    }

    /// Coefficients per pose (corrective shapes M) of an AIM actor; 0 for an S2D decoder.
    pub fn shape_count(&self) -> usize {
        match &self.inner {
            ModelInner::Aim(c) => c.borrow_dependent().shape_count(),
            ModelInner::S2d { .. } => 0,
        }
    }

    /// Decoder inputs (3 × landmarks) of an S2D decoder; 0 for an AIM actor.
    pub fn input_len(&self) -> usize {
        match &self.inner {
            ModelInner::Aim(_) => 0,
            ModelInner::S2d { cell, .. } => cell.borrow_dependent().input_len(),
        }
    }

    /// The triangles of an AIM actor's template, `[T, 3]` vertex indices; empty for an S2D
    /// decoder, whose artefact carries no faces.
    pub fn triangles(&self) -> Vec<u32> {
        match &self.inner {
            ModelInner::Aim(c) => c.borrow_dependent().triangles().indices().iter().collect(),
            ModelInner::S2d { .. } => Vec::new(),
        }
    }

    /// Triangles of an AIM actor's template; 0 for an S2D decoder.
    pub fn triangle_count(&self) -> usize {
        match &self.inner {
            ModelInner::Aim(c) => c.borrow_dependent().triangles().len(),
            ModelInner::S2d { .. } => 0,
        }
    }

    /// The landmark vertex of each decoder input landmark, `[inputs / 3]`; empty for an AIM
    /// actor.
    pub fn landmark_vertices(&self) -> Vec<u32> {
        match &self.inner {
            ModelInner::Aim(_) => Vec::new(),
            ModelInner::S2d { cell, .. } => cell.borrow_dependent().landmarks().iter().collect(),
        }
    }

    /// The neutral mesh, `[V, 3]`: an AIM actor's cached neutral skin s0, an S2D decoder's
    /// template.
    pub fn neutral(&self) -> Vec<f32> {
        match &self.inner {
            ModelInner::Aim(c) => c.borrow_dependent().rest().iter().collect(),
            ModelInner::S2d { cell, .. } => cell.borrow_dependent().neutral().iter().collect(),
        }
    }

    /// An AIM actor's cached soft-tissue thickness d0 at each vertex, `[V]`, in the actor's unit.
    pub fn thickness(&self) -> Result<Vec<f32>, Error> {
        Ok(self.aim("thickness")?.thickness().iter().collect())
    }

    pub(crate) fn aim(&self, call: &str) -> Result<&AimActor<'_>, Error> {
        match &self.inner {
            ModelInner::Aim(c) => Ok(c.borrow_dependent()),
            ModelInner::S2d { .. } => Err(self.wrong_kind(call, Kind::Aim)),
        }
    }

    fn wrong_kind(&self, call: &str, needs: Kind) -> Error {
        Error::new(format!(
            "{call} needs {}, this model is {}",
            needs.long_name(),
            self.kind().long_name()
        ))
    }

    /// Poses an AIM actor (AIM eq. 17 through [`AimActor::pose`]), head and jaw in the 9-value
    /// form of [`AimActor::pose_from_9d`].
    ///
    /// # Shapes
    /// `head`, `jaw`: `[9]`; `coefficients`: `[M]`; returns `[V, 3]` positions.
    ///
    /// # Errors
    /// Not an AIM actor, an input of the wrong length, or a value the core refuses (NaN,
    /// infinite, out of range, a degenerate rotation), named with its argument and index.
    pub fn pose(&self, head: &[f32], jaw: &[f32], coefficients: &[f32]) -> Result<Vec<f32>, Error> {
        let actor = self.aim("pose")?;
        let head = pose_9d("head", head)?;
        let jaw = pose_9d("jaw", jaw)?;
        check_len("coefficients", coefficients.len(), actor.shape_count())?;
        let mut out = vec![0.0; 3 * actor.vertex_count()];
        actor.pose(&actor.pose_from_9d(&jaw, &head)?, coefficients, &mut out)?;
        Ok(out)
    }

    /// The jaw of a pose given by coefficients alone ([`AimActor::jaw_from_weights`]): every
    /// training shape's learned jaw blended by its coefficient, held within the range the shapes
    /// span; 9 values for [`Self::pose`]'s `jaw`.
    ///
    /// # Shapes
    /// `coefficients`: `[M]`; returns `[9]`.
    ///
    /// # Errors
    /// Not an AIM actor, coefficients of the wrong length, or a coefficient the core refuses
    /// (NaN, infinite, out of range), named with its index.
    pub fn jaw_from_weights(&self, coefficients: &[f32]) -> Result<Vec<f32>, Error> {
        let actor = self.aim("jawFromWeights")?;
        check_len("coefficients", coefficients.len(), actor.shape_count())?;
        Ok(actor.jaw_from_weights(coefficients)?.to_vec())
    }

    /// Area-weighted vertex normals of an AIM actor's posed positions ([`AimActor::normals`]).
    ///
    /// # Shapes
    /// `positions`: `[V, 3]`; returns `[V, 3]`.
    ///
    /// # Errors
    /// Not an AIM actor, positions of the wrong length, or a position that is NaN or infinite.
    pub fn normals(&self, positions: &[f32]) -> Result<Vec<f32>, Error> {
        let actor = self.aim("normals")?;
        check_len("positions", positions.len(), 3 * actor.vertex_count())?;
        let mut out = vec![0.0; positions.len()];
        actor.normals(positions, &mut out)?;
        Ok(out)
    }

    /// An S2D decoder's input from a neutral and an expressive landmark set, normalised as the
    /// decoder was trained ([`S2dDecoder::input`]).
    ///
    /// # Shapes
    /// `neutral`, `landmarks`: `[inputs / 3, 3]`; returns `[inputs]`.
    ///
    /// # Errors
    /// Not an S2D decoder, landmark sets of the wrong length, or a coordinate the core refuses
    /// (NaN, infinite, out of range) or a set whose points all coincide.
    pub fn landmark_input(&self, neutral: &[f32], landmarks: &[f32]) -> Result<Vec<f32>, Error> {
        let ModelInner::S2d { cell, .. } = &self.inner else {
            return Err(self.wrong_kind("landmarkInput", Kind::S2d));
        };
        let decoder = cell.borrow_dependent();
        check_len("neutral landmarks", neutral.len(), decoder.input_len())?;
        check_len("landmarks", landmarks.len(), decoder.input_len())?;
        let mut out = vec![0.0; decoder.input_len()];
        decoder.input(neutral, landmarks, &mut out).map_err(|e| {
            Error::eval(
                e,
                &[
                    (Argument::Neutral, "neutralLandmarks"),
                    (Argument::Expressive, "landmarks"),
                ],
            )
        })?;
        Ok(out)
    }

    /// Decodes an S2D input onto `neutral` (another face of the same topology,
    /// [`S2dDecoder::decode_onto`]) or, when `neutral` is `None`, onto the decoder's template
    /// ([`S2dDecoder::decode`]): the frame [`sinew_core::replay::s2d_frame_hash`] hashes.
    ///
    /// # Shapes
    /// `input`: `[inputs]`; `neutral`: `[V, 3]`; returns `[V, 3]` vertices.
    ///
    /// # Errors
    /// Not an S2D decoder, an input or neutral of the wrong length, or a value the core
    /// refuses (NaN, infinite, out of range).
    pub fn decode(&mut self, input: &[f32], neutral: Option<&[f32]>) -> Result<Vec<f32>, Error> {
        let kind_error = self.wrong_kind("decode", Kind::S2d);
        let ModelInner::S2d { cell, scratch } = &mut self.inner else {
            return Err(kind_error);
        };
        let decoder = cell.borrow_dependent();
        check_len("input", input.len(), decoder.input_len())?;
        let mut out = vec![0.0; 3 * decoder.vertex_count()];
        match neutral {
            Some(n) => {
                check_len("neutral", n.len(), out.len())?;
                decoder.decode_onto(n, input, scratch, &mut out)?;
            }
            None => decoder.decode(input, scratch, &mut out)?,
        }
        Ok(out)
    }
}

/// The hash of a frame: the values of `parts` in order, as [`FrameHasher::write_f32s`] writes
/// them. `[positions, normals]` gives [`sinew_core::hash::posed_frame_hash`] (the f32 mode's),
/// `[vertices]` gives [`sinew_core::replay::s2d_frame_hash`].
pub fn frame_hash(parts: &[&[f32]]) -> u64 {
    let mut h = FrameHasher::new();
    for p in parts {
        h.write_f32s(p);
    }
    h.finish()
}
