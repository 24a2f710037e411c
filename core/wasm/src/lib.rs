//! `sinew-wasm`: Sinew's face models in a browser.
//!
//! `sinew-core` compiled to `wasm32-unknown-unknown`, with owned models, replays and fitted
//! performances (the core borrows a byte slice; here each value owns its bytes) and errors as
//! the core's messages. Two layers:
//!
//! - this module, plain safe Rust ([`Model`], [`Replay`], [`Performance`], [`frame_hash`]),
//!   tested on the host;
//! - [`exports`], the module's `extern "C"` functions, which a hand-written ES module
//!   (`core/wasm/js/sinew.mjs`) wraps into the JavaScript API of `docs/WASM.md`.
//!
//! Every value here is `f32`, computed by the core exactly as on every other target, so a frame
//! posed in the browser hashes as the host recorded it (`tests/data/*.hashes`).

use std::fmt;

use self_cell::self_cell;
use sinew_core::aim::AimActor;
use sinew_core::error::{Argument, EvalError, InputError};
use sinew_core::format::{ArtifactKind, SinewFile};
use sinew_core::hash::FrameHasher;
use sinew_core::replay::{self, AimReplay, S2D_INPUTS, S2dReplay};
use sinew_core::s2d::S2dDecoder;

mod driver;
pub mod exports;
mod modes;
mod motion;
mod performance;

pub use driver::Driver;
pub use modes::frame_hash_q16;
pub use motion::Motion;
pub use performance::{Performance, PerformanceFrame};

/// Values in a head or jaw pose: a 6D rotation, then a translation.
pub const POSE_9D: usize = 9;

/// Why a call failed: the core's message ([`sinew_core::FormatError`], `BufferError`,
/// `InputError` or `ReplayError` as displayed, a refused input named as the JavaScript API names
/// the argument) or this crate's own about a caller's input.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    message: String,
    input: Option<Refused>,
}

/// Which input the core refused, named as the JavaScript call names the argument: what the
/// JavaScript `InputError` carries besides the message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Refused {
    /// The argument's name in the JavaScript API (`head`, `coefficients`, `neutralLandmarks`).
    pub argument: &'static str,
    /// The value's index in it (for a degenerate 6D rotation, its column's first index).
    pub index: usize,
}

impl Error {
    fn new(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            input: None,
        }
    }

    /// The message.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The refused input, when the core refused one of the call's values.
    pub fn refused(&self) -> Option<Refused> {
        self.input
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

impl From<sinew_core::FormatError> for Error {
    fn from(e: sinew_core::FormatError) -> Self {
        Self::new(e.to_string())
    }
}

impl From<sinew_core::BufferError> for Error {
    fn from(e: sinew_core::BufferError) -> Self {
        Self::new(e.to_string())
    }
}

impl From<replay::ReplayError> for Error {
    fn from(e: replay::ReplayError) -> Self {
        match e {
            replay::ReplayError::Input(e) => e.into(),
            e => Self::new(e.to_string()),
        }
    }
}

impl From<InputError> for Error {
    fn from(e: InputError) -> Self {
        Self::input(e, &[])
    }
}

impl From<EvalError> for Error {
    fn from(e: EvalError) -> Self {
        match e {
            EvalError::Input(e) => e.into(),
            e => Self::new(e.to_string()),
        }
    }
}

impl Error {
    /// The core's message about a refused input, with the argument named as the JavaScript call
    /// names it: `coefficients` for the core's `weights`, and the names in `rename`.
    fn input(e: InputError, rename: &[(Argument, &'static str)]) -> Self {
        let core = e.argument.name();
        let js = rename
            .iter()
            .find(|(a, _)| *a == e.argument)
            .map(|(_, name)| *name)
            .unwrap_or(match e.argument {
                Argument::Weights => "coefficients",
                _ => core,
            });
        let message = e.to_string();
        Self {
            message: match message.strip_prefix(core) {
                Some(rest) => format!("{js}{rest}"),
                None => message,
            },
            input: Some(Refused {
                argument: js,
                index: e.index,
            }),
        }
    }

    /// [`Self::input`] for an input refusal, the message as it is otherwise.
    fn eval(e: EvalError, rename: &[(Argument, &'static str)]) -> Self {
        match e {
            EvalError::Input(e) => Self::input(e, rename),
            e => e.into(),
        }
    }
}

self_cell!(
    struct AimCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: AimActor,
    }
    impl {Debug}
);

self_cell!(
    struct S2dCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: S2dDecoder,
    }
    impl {Debug}
);

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

    const fn long_name(self) -> &'static str {
        match self {
            Self::Aim => "an AIM actor",
            Self::S2d => "an S2D decoder",
        }
    }
}

#[derive(Debug)]
enum ModelInner {
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
    inner: ModelInner,
    /// The content hash of the bytes ([`replay::model_hash`]), computed once: a performance
    /// compares it at every frame.
    hash: u64,
}

/// `what` must hold `expected` values.
fn check_len(what: &str, got: usize, expected: usize) -> Result<(), Error> {
    if got == expected {
        Ok(())
    } else {
        Err(Error::new(format!(
            "{what} has {got} values, expected {expected}"
        )))
    }
}

fn pose_9d(what: &str, values: &[f32]) -> Result<[f32; POSE_9D], Error> {
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

    fn aim(&self, call: &str) -> Result<&AimActor<'_>, Error> {
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
/// them. `[positions, normals]` gives [`sinew_core::replay::frame_hash`] in the f32 mode,
/// `[vertices]` gives [`sinew_core::replay::s2d_frame_hash`].
pub fn frame_hash(parts: &[&[f32]]) -> u64 {
    let mut h = FrameHasher::new();
    for p in parts {
        h.write_f32s(p);
    }
    h.finish()
}

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
