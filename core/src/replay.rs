//! Replays: a model's content hash, a sequence of inputs and the hash of every frame the core
//! computed from them, so that any target can prove it plays the model back bit for bit.
//!
//! A replay is a `.sinew` artefact of kind [`ArtifactKind::Replay`] (sections in
//! `docs/FORMAT.md`): `replay.model` (the xxh64 of the model's bytes, [`model_hash`]), the
//! numeric [`Mode`] in the metadata key `mode`, the per-frame inputs and `replay.hash`. AIM
//! inputs are `replay.aim`, `[F, 18 + M]` per frame: head `[6D rotation, translation]`, jaw
//! `[6D rotation, translation]` about the actor's pivot, then the `M` coefficients.
//!
//! S2D replays ([`S2dReplay`]) carry `replay.s2d` instead, `[F, inputs]`: each frame's decoder
//! input ([`crate::s2d::landmark_input`] of a neutral and an expressive landmark set), and
//! optionally `replay.neutral`, `[V, 3]`, the neutral face the displacements are added to
//! ([`S2dDecoder::decode_onto`]; without it, the decoder's own template, [`S2dDecoder::decode`]).
//! Their mode is always `f32`.
//!
//! [`pose_frame_hash`] (AIM) and [`s2d_frame_hash`] (S2D) play one frame and hash it as
//! [`crate::hash`] defines; recording (host) and verification (every target) both call them. [`check_frame`] and
//! [`check_s2d_frame`] play one frame of a replay and compare it with the recording: [`verify`]
//! and [`verify_s2d`] loop over them, and so do the firmware targets, one frame at a time.

use core::fmt;

use crate::aim::{AimActor, MAX_SHAPES};
use crate::error::{Argument, BufferError, EvalError, FormatError, InputError};
use crate::format::{ArtifactKind, SinewFile};
use crate::hash;
use crate::input::check_values;
use crate::q16::{PoseQ16, Q16, q16_slice};
use crate::s2d::S2dDecoder;
use crate::tensor::{F32s, U32s};

/// Values per AIM frame before the coefficients: head 9, jaw 9.
pub const AIM_POSE_LEN: usize = 18;

/// The section of every replay's model content hash ([`model_hash`]), `u32` `[2]` as
/// [`hash_words`] stores it.
pub const MODEL_HASH: &str = "replay.model";
/// The section of every replay's recorded frame hashes, `u32` `[F, 2]`, each as [`hash_words`]
/// stores it.
pub const FRAME_HASHES: &str = "replay.hash";
/// The section of an AIM replay's per-frame inputs, `f32` `[F, AIM_POSE_LEN + M]`.
pub const AIM_INPUTS: &str = "replay.aim";

/// The numeric mode a replay was recorded in; each has its own goldens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// `f32` with `libm`: the reference. Hash: positions, then normals.
    F32,
    /// Q16.16 fixed point ([`crate::q16`]). Hash: the positions' raw Q16.16 bits.
    Q16,
    /// `f32` with micromath's approximations ([`crate::fast`]). Hash: positions, then normals.
    Fast,
}

impl Mode {
    /// The name in the metadata (`f32`, `q16`, `fast`).
    pub const fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::Q16 => "q16",
            Self::Fast => "fast",
        }
    }

    /// The mode called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "f32" => Some(Self::F32),
            "q16" => Some(Self::Q16),
            "fast" => Some(Self::Fast),
            _ => None,
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A 64-bit hash as a replay stores it: two `u32` words, the low one first.
pub const fn hash_words(hash: u64) -> [u32; 2] {
    [hash as u32, (hash >> 32) as u32]
}

/// The `i`-th 64-bit value of a section stored as (low, high) 32-bit word pairs ([`hash_words`]).
fn word_pair(words: &U32s<'_>, i: usize) -> Option<u64> {
    let lo = words.get(2 * i)?;
    let hi = words.get(2 * i + 1)?;
    Some(u64::from(lo) | (u64::from(hi) << 32))
}

/// The content hash of a model artefact: xxh64 (seed 0) of all its bytes.
pub fn model_hash(bytes: &[u8]) -> u64 {
    xxhash_rust::xxh64::xxh64(bytes, 0)
}

/// A validated AIM replay over the artefact's bytes.
#[derive(Clone, Copy, Debug)]
pub struct AimReplay<'a> {
    model_hash: u64,
    mode: Mode,
    frames: usize,
    shapes: usize,
    inputs: F32s<'a>,
    hashes: U32s<'a>,
}

impl<'a> AimReplay<'a> {
    /// Validates `bytes` as an AIM replay.
    ///
    /// # Errors
    /// A [`FormatError`] for a bad container, a missing or misshapen section, an unknown mode,
    /// no frames, or more coefficients than [`MAX_SHAPES`].
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let file = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::Replay)?;
        let model = file.u32_tensor(MODEL_HASH, &[2])?;
        let mode = file
            .metadata()
            .get("mode")
            .and_then(Mode::from_name)
            .ok_or_else(|| file.metadata().bad_entry("mode"))?;
        let (shape, rank) = file.dims_of(AIM_INPUTS)?;
        let [frames, width, ..] = shape;
        if rank != 2 || frames == 0 || (width as usize) < AIM_POSE_LEN {
            return Err(FormatError::incompatible_shapes(AIM_INPUTS));
        }
        let shapes = width as usize - AIM_POSE_LEN;
        if shapes > MAX_SHAPES {
            return Err(FormatError::limit_exceeded(AIM_INPUTS, shapes, MAX_SHAPES));
        }
        Ok(Self {
            model_hash: word_pair(&model, 0).ok_or(FormatError::incompatible_shapes(MODEL_HASH))?,
            mode,
            frames: frames as usize,
            shapes,
            inputs: file.f32_tensor(AIM_INPUTS, &[frames, width])?,
            hashes: file.u32_tensor(FRAME_HASHES, &[frames, 2])?,
        })
    }

    /// The content hash ([`model_hash`]) of the model this replay was recorded with.
    pub const fn model_hash(&self) -> u64 {
        self.model_hash
    }

    /// The numeric mode.
    pub const fn mode(&self) -> Mode {
        self.mode
    }

    /// Number of frames (at least one).
    pub const fn frames(&self) -> usize {
        self.frames
    }

    /// Coefficients per frame.
    pub const fn shape_count(&self) -> usize {
        self.shapes
    }

    /// Frame `f`'s inputs: head 9, jaw 9, and the coefficients copied into `weights`
    /// (`[M]`). `None` if `f` is past the end or `weights` has the wrong length.
    pub fn frame(&self, f: usize, weights: &mut [f32]) -> Option<([f32; 9], [f32; 9])> {
        if f >= self.frames || weights.len() != self.shapes {
            return None;
        }
        let width = AIM_POSE_LEN + self.shapes;
        let row = self.inputs.slice(f * width, width);
        let mut head = [0.0; 9];
        let mut jaw = [0.0; 9];
        for (i, h) in head.iter_mut().enumerate() {
            *h = row.at(i);
        }
        for (i, j) in jaw.iter_mut().enumerate() {
            *j = row.at(9 + i);
        }
        for (i, w) in weights.iter_mut().enumerate() {
            *w = row.at(AIM_POSE_LEN + i);
        }
        Some((head, jaw))
    }

    /// The recorded hash of frame `f`.
    pub fn expected(&self, f: usize) -> Option<u64> {
        word_pair(&self.hashes, f)
    }
}

/// Caller-owned buffers for one frame of an actor with `V` vertices and `M` coefficients.
#[derive(Debug)]
pub struct FrameBuffers<'b> {
    /// `[V, 3]` posed positions (f32 and fast modes).
    pub positions: &'b mut [f32],
    /// `[V, 3]` vertex normals (f32 and fast modes).
    pub normals: &'b mut [f32],
    /// `[V, 3]` posed positions in Q16.16 (Q16 mode; may be empty otherwise).
    pub positions_q16: &'b mut [Q16],
    /// `[M]` coefficients.
    pub weights: &'b mut [f32],
    /// `[M]` coefficients in Q16.16 (Q16 mode; may be empty otherwise).
    pub weights_q16: &'b mut [Q16],
}

/// Why a frame could not be computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ReplayError {
    /// The replay was recorded with another model (content hashes differ).
    WrongModel {
        /// The hash the replay names.
        expected: u64,
        /// The hash of the model given.
        found: u64,
    },
    /// The replay's coefficient count differs from the actor's.
    ShapeCount {
        /// The replay's.
        replay: usize,
        /// The actor's.
        actor: usize,
    },
    /// Q16 mode asked of an actor baked without a Q16.16 cache.
    NoQ16Cache,
    /// The replay's input width differs from the S2D decoder's.
    InputCount {
        /// The replay's.
        replay: usize,
        /// The decoder's.
        model: usize,
    },
    /// The replay's neutral has another vertex count than the S2D decoder's template.
    NeutralVertices {
        /// Vertices of the replay's neutral.
        replay: usize,
        /// Vertices the decoder outputs.
        model: usize,
    },
    /// A performance's own template points number differently from the actor's vertices.
    PointCount {
        /// The performance's points.
        performance: usize,
        /// The actor's vertices.
        actor: usize,
    },
    /// A caller buffer has the wrong length.
    Buffer(BufferError),
    /// A frame's input is refused: NaN, infinite, out of range or a degenerate rotation.
    Input(InputError),
}

impl fmt::Display for ReplayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::WrongModel { expected, found } => write!(
                f,
                "replay was recorded with model {expected:016x}, this model is {found:016x}"
            ),
            Self::ShapeCount { replay, actor } => write!(
                f,
                "replay has {replay} coefficients per frame, the actor {actor}"
            ),
            Self::NoQ16Cache => write!(f, "q16 mode needs a model baked with a Q16.16 cache"),
            Self::InputCount { replay, model } => write!(
                f,
                "replay has {replay} inputs per frame, the S2D decoder {model}"
            ),
            Self::NeutralVertices { replay, model } => write!(
                f,
                "replay's neutral has {replay} vertices, the S2D decoder's template {model}"
            ),
            Self::PointCount { performance, actor } => write!(
                f,
                "performance evaluates its coefficients at {performance} points, the actor has \
                 {actor} vertices"
            ),
            Self::Buffer(e) => write!(f, "{e}"),
            Self::Input(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for ReplayError {}

impl From<InputError> for ReplayError {
    fn from(e: InputError) -> Self {
        Self::Input(e)
    }
}

impl From<EvalError> for ReplayError {
    fn from(e: EvalError) -> Self {
        match e {
            EvalError::Buffer(e) => Self::Buffer(e),
            EvalError::Input(e) => Self::Input(e),
        }
    }
}

impl From<BufferError> for ReplayError {
    fn from(e: BufferError) -> Self {
        Self::Buffer(e)
    }
}

/// Poses `actor` for one frame in `mode` into `buf`: in the f32 and fast modes the positions and
/// the normals (each mode's normalisation), in Q16 mode the Q16.16 positions.
/// `buf.weights` must hold the frame's coefficients.
///
/// # Errors
/// [`ReplayError::NoQ16Cache`] in Q16 mode without the cache; [`ReplayError::Buffer`] if a
/// buffer has the wrong length; [`ReplayError::Input`] if the head, the jaw or a coefficient is
/// refused ([`AimActor::pose_from_9d`], [`AimActor::pose`]), in every mode alike. Nothing is
/// written then.
pub fn pose_frame(
    actor: &AimActor<'_>,
    mode: Mode,
    head: &[f32; 9],
    jaw: &[f32; 9],
    buf: &mut FrameBuffers<'_>,
) -> Result<(), ReplayError> {
    let pose = actor.pose_from_9d(jaw, head)?;
    match mode {
        Mode::F32 => {
            actor.pose(&pose, buf.weights, buf.positions)?;
            actor.normals(buf.positions, buf.normals)?;
        }
        Mode::Fast => {
            actor.pose(&pose, buf.weights, buf.positions)?;
            crate::fast::vertex_normals(actor.triangles(), buf.positions, buf.normals)?;
        }
        Mode::Q16 => {
            let cache = actor.q16().ok_or(ReplayError::NoQ16Cache)?;
            if buf.weights.len() != actor.shape_count() {
                return Err(ReplayError::Buffer(BufferError::Input));
            }
            // The f32 path checks the coefficients in `AimActor::pose`; this one converts them
            // first, and Q16.16 would saturate what it refuses.
            check_values(Argument::Weights, buf.weights)?;
            q16_slice(buf.weights, buf.weights_q16)?;
            cache.pose(
                &PoseQ16::from_pose(&pose),
                buf.weights_q16,
                buf.positions_q16,
            )?;
        }
    }
    Ok(())
}

/// Poses `actor` for one frame in `mode` ([`pose_frame`]) and returns the frame's hash: in the
/// f32 and fast modes the positions then the normals ([`hash::posed_frame_hash`]); in Q16 mode
/// the positions' raw bits ([`hash::q16_frame_hash`]).
///
/// # Errors
/// As [`pose_frame`].
pub fn pose_frame_hash(
    actor: &AimActor<'_>,
    mode: Mode,
    head: &[f32; 9],
    jaw: &[f32; 9],
    buf: &mut FrameBuffers<'_>,
) -> Result<u64, ReplayError> {
    pose_frame(actor, mode, head, jaw, buf)?;
    Ok(if mode == Mode::Q16 {
        hash::q16_frame_hash(buf.positions_q16)
    } else {
        hash::posed_frame_hash(buf.positions, buf.normals)
    })
}

/// [`ReplayError::WrongModel`] unless `model_bytes` hash to `expected` ([`model_hash`]).
fn check_content_hash(model_bytes: &[u8], expected: u64) -> Result<(), ReplayError> {
    let found = model_hash(model_bytes);
    if found == expected {
        Ok(())
    } else {
        Err(ReplayError::WrongModel { expected, found })
    }
}

/// Checks that `replay` was recorded with the model whose bytes are `model_bytes` (content hash)
/// and that its coefficient count is `actor`'s.
///
/// # Errors
/// [`ReplayError::WrongModel`] or [`ReplayError::ShapeCount`].
pub fn check_model(
    model_bytes: &[u8],
    actor: &AimActor<'_>,
    replay: &AimReplay<'_>,
) -> Result<(), ReplayError> {
    check_content_hash(model_bytes, replay.model_hash())?;
    if replay.shape_count() != actor.shape_count() {
        return Err(ReplayError::ShapeCount {
            replay: replay.shape_count(),
            actor: actor.shape_count(),
        });
    }
    Ok(())
}

/// One verified frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameCheck {
    /// Frame index.
    pub frame: usize,
    /// The hash computed here.
    pub hash: u64,
    /// The hash the replay recorded.
    pub expected: u64,
}

impl FrameCheck {
    /// Whether the frame is bit-identical to the recording.
    pub const fn ok(&self) -> bool {
        self.hash == self.expected
    }
}

impl fmt::Display for FrameCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.ok() {
            write!(f, "frame {} {:016x} ok", self.frame, self.hash)
        } else {
            write!(
                f,
                "frame {} {:016x} DIFFERS (recorded {:016x})",
                self.frame, self.hash, self.expected
            )
        }
    }
}

/// Plays frame `f` of `replay` through `actor` ([`pose_frame_hash`] in the replay's mode) and compares
/// its hash with the recorded one: the step of [`verify`] and of every target's replay loop.
/// `buf.weights` receives the frame's coefficients. Call [`check_model`] once before the first
/// frame.
///
/// # Errors
/// [`ReplayError::Buffer`] if `f` is past the end or a buffer has the wrong length;
/// [`ReplayError::NoQ16Cache`] as [`pose_frame`].
pub fn check_frame(
    actor: &AimActor<'_>,
    replay: &AimReplay<'_>,
    f: usize,
    buf: &mut FrameBuffers<'_>,
) -> Result<FrameCheck, ReplayError> {
    let (head, jaw) = replay
        .frame(f, buf.weights)
        .ok_or(ReplayError::Buffer(BufferError::Input))?;
    let hash = pose_frame_hash(actor, replay.mode(), &head, &jaw, buf)?;
    Ok(FrameCheck {
        frame: f,
        hash,
        expected: replay.expected(f).unwrap_or(!hash),
    })
}

/// Plays `replay` through `actor` frame by frame ([`check_frame`]), calling `on_frame` after
/// each; returns the first frame whose hash differs, or `None` when every frame matched.
///
/// `model_bytes` must be the bytes `actor` was loaded from: the replay names their content hash.
///
/// # Errors
/// [`ReplayError`] if the replay belongs to another model, the coefficient counts differ, the
/// mode is unavailable or a buffer has the wrong length.
pub fn verify(
    model_bytes: &[u8],
    actor: &AimActor<'_>,
    replay: &AimReplay<'_>,
    buf: &mut FrameBuffers<'_>,
    mut on_frame: impl FnMut(&FrameCheck),
) -> Result<Option<usize>, ReplayError> {
    check_model(model_bytes, actor, replay)?;
    let mut first_bad = None;
    for f in 0..replay.frames() {
        let check = check_frame(actor, replay, f, buf)?;
        if !check.ok() && first_bad.is_none() {
            first_bad = Some(f);
        }
        on_frame(&check);
    }
    Ok(first_bad)
}

/// The section of an S2D replay's per-frame decoder inputs.
pub const S2D_INPUTS: &str = "replay.s2d";
/// The section of an S2D replay's optional neutral face.
pub const S2D_NEUTRAL: &str = "replay.neutral";

/// A validated S2D replay over the artefact's bytes.
#[derive(Clone, Copy, Debug)]
pub struct S2dReplay<'a> {
    model_hash: u64,
    frames: usize,
    inputs: usize,
    data: F32s<'a>,
    neutral: Option<F32s<'a>>,
    hashes: U32s<'a>,
}

impl<'a> S2dReplay<'a> {
    /// Validates `bytes` as an S2D replay.
    ///
    /// # Errors
    /// A [`FormatError`] for a bad container, a missing or misshapen section, a mode other than
    /// `f32`, no frames, or a neutral that is not `[V, 3]`.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let file = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::Replay)?;
        let model = file.u32_tensor(MODEL_HASH, &[2])?;
        if file.metadata().get("mode").and_then(Mode::from_name) != Some(Mode::F32) {
            return Err(file.metadata().bad_entry("mode"));
        }
        let (shape, rank) = file.dims_of(S2D_INPUTS)?;
        let [frames, width, ..] = shape;
        if rank != 2 || frames == 0 || width == 0 {
            return Err(FormatError::incompatible_shapes(S2D_INPUTS));
        }
        let neutral = match file.section(S2D_NEUTRAL) {
            None => None,
            Some(_) => {
                let ([v, three, ..], rank) = file.dims_of(S2D_NEUTRAL)?;
                if rank != 2 || three != 3 || v == 0 {
                    return Err(FormatError::incompatible_shapes(S2D_NEUTRAL));
                }
                Some(file.f32_tensor(S2D_NEUTRAL, &[v, 3])?)
            }
        };
        Ok(Self {
            model_hash: word_pair(&model, 0).ok_or(FormatError::incompatible_shapes(MODEL_HASH))?,
            frames: frames as usize,
            inputs: width as usize,
            data: file.f32_tensor(S2D_INPUTS, &[frames, width])?,
            neutral,
            hashes: file.u32_tensor(FRAME_HASHES, &[frames, 2])?,
        })
    }

    /// The content hash ([`model_hash`]) of the decoder this replay was recorded with.
    pub const fn model_hash(&self) -> u64 {
        self.model_hash
    }

    /// Number of frames (at least one).
    pub const fn frames(&self) -> usize {
        self.frames
    }

    /// Decoder inputs per frame.
    pub const fn input_len(&self) -> usize {
        self.inputs
    }

    /// The neutral the frames decode onto, `[V, 3]`, if the replay carries one.
    pub const fn neutral(&self) -> Option<F32s<'a>> {
        self.neutral
    }

    /// Copies frame `f`'s decoder input into `input` (`[inputs]`). `None` if `f` is past the
    /// end or `input` has the wrong length.
    pub fn frame(&self, f: usize, input: &mut [f32]) -> Option<()> {
        if f >= self.frames || input.len() != self.inputs {
            return None;
        }
        let row = self.data.slice(f * self.inputs, self.inputs);
        for (i, x) in input.iter_mut().enumerate() {
            *x = row.at(i);
        }
        Some(())
    }

    /// The recorded hash of frame `f`.
    pub fn expected(&self, f: usize) -> Option<u64> {
        word_pair(&self.hashes, f)
    }

    /// Copies the replay's neutral into `out` (`[V, 3]`, [`S2dBuffers::neutral`]) once, before
    /// the first frame. Without a neutral, `out` must be empty: the frames then decode onto the
    /// decoder's template.
    ///
    /// # Errors
    /// [`BufferError::Input`] if `out` has another length.
    pub fn copy_neutral(&self, out: &mut [f32]) -> Result<(), BufferError> {
        match self.neutral {
            Some(n) if n.len() == out.len() => {
                for (d, s) in out.iter_mut().zip(n.iter()) {
                    *d = s;
                }
                Ok(())
            }
            None if out.is_empty() => Ok(()),
            _ => Err(BufferError::Input),
        }
    }
}

/// Caller-owned buffers for one S2D frame of a decoder with `I` inputs and `V` vertices.
#[derive(Debug)]
pub struct S2dBuffers<'b> {
    /// `[I]` the frame's decoder input.
    pub input: &'b mut [f32],
    /// `[V, 3]` the neutral to decode onto, or empty to decode onto the decoder's template.
    pub neutral: &'b mut [f32],
    /// At least [`S2dDecoder::scratch_len`] values.
    pub scratch: &'b mut [f32],
    /// `[V, 3]` the decoded vertices.
    pub vertices: &'b mut [f32],
}

/// Decodes one frame (`buf.input`) onto `buf.neutral`, or onto the decoder's template when
/// `buf.neutral` is empty, into `buf.vertices`: S2D's counterpart of [`pose_frame`].
///
/// # Errors
/// [`ReplayError::Buffer`] if a buffer has the wrong length.
pub fn decode_frame(decoder: &S2dDecoder<'_>, buf: &mut S2dBuffers<'_>) -> Result<(), ReplayError> {
    if buf.neutral.is_empty() {
        decoder.decode(buf.input, buf.scratch, buf.vertices)?;
    } else {
        decoder.decode_onto(buf.neutral, buf.input, buf.scratch, buf.vertices)?;
    }
    Ok(())
}

/// Decodes one frame ([`decode_frame`]) and returns the frame's hash: the decoded vertices' bits
/// ([`hash::frame_hash`]).
///
/// # Errors
/// [`ReplayError::Buffer`] if a buffer has the wrong length.
pub fn s2d_frame_hash(
    decoder: &S2dDecoder<'_>,
    buf: &mut S2dBuffers<'_>,
) -> Result<u64, ReplayError> {
    decode_frame(decoder, buf)?;
    Ok(hash::frame_hash(buf.vertices))
}

/// Checks that `replay` was recorded with the decoder whose bytes are `model_bytes` (content
/// hash) and that its input width and neutral fit `decoder`.
///
/// # Errors
/// [`ReplayError::WrongModel`], [`ReplayError::InputCount`] or
/// [`ReplayError::NeutralVertices`].
pub fn check_s2d_model(
    model_bytes: &[u8],
    decoder: &S2dDecoder<'_>,
    replay: &S2dReplay<'_>,
) -> Result<(), ReplayError> {
    check_content_hash(model_bytes, replay.model_hash())?;
    if replay.input_len() != decoder.input_len() {
        return Err(ReplayError::InputCount {
            replay: replay.input_len(),
            model: decoder.input_len(),
        });
    }
    if let Some(n) = replay.neutral()
        && n.len() != 3 * decoder.vertex_count()
    {
        return Err(ReplayError::NeutralVertices {
            replay: n.len() / 3,
            model: decoder.vertex_count(),
        });
    }
    Ok(())
}

/// Plays frame `f` of `replay` through `decoder` ([`s2d_frame_hash`]) and compares its hash with
/// the recorded one: the step of [`verify_s2d`] and of every target's replay loop. `buf.input`
/// receives the frame's input; `buf.neutral` must already hold the replay's neutral
/// ([`S2dReplay::copy_neutral`]). Call [`check_s2d_model`] once before the first frame.
///
/// # Errors
/// [`ReplayError::Buffer`] if `f` is past the end or a buffer has the wrong length.
pub fn check_s2d_frame(
    decoder: &S2dDecoder<'_>,
    replay: &S2dReplay<'_>,
    f: usize,
    buf: &mut S2dBuffers<'_>,
) -> Result<FrameCheck, ReplayError> {
    replay
        .frame(f, buf.input)
        .ok_or(ReplayError::Buffer(BufferError::Input))?;
    let hash = s2d_frame_hash(decoder, buf)?;
    Ok(FrameCheck {
        frame: f,
        hash,
        expected: replay.expected(f).unwrap_or(!hash),
    })
}

/// Plays `replay` through `decoder` frame by frame ([`check_s2d_frame`]), calling `on_frame`
/// after each; returns the first frame whose hash differs, or `None` when every frame matched.
/// `buf.neutral` must be `[V, 3]` when the replay carries a neutral (it is copied in here) and
/// empty otherwise.
///
/// # Errors
/// [`ReplayError`] if the replay belongs to another decoder, does not fit it, or a buffer has
/// the wrong length.
pub fn verify_s2d(
    model_bytes: &[u8],
    decoder: &S2dDecoder<'_>,
    replay: &S2dReplay<'_>,
    buf: &mut S2dBuffers<'_>,
    mut on_frame: impl FnMut(&FrameCheck),
) -> Result<Option<usize>, ReplayError> {
    check_s2d_model(model_bytes, decoder, replay)?;
    replay.copy_neutral(buf.neutral)?;
    let mut first_bad = None;
    for f in 0..replay.frames() {
        let check = check_s2d_frame(decoder, replay, f, buf)?;
        if !check.ok() && first_bad.is_none() {
            first_bad = Some(f);
        }
        on_frame(&check);
    }
    Ok(first_bad)
}

#[cfg(test)]
mod tests;
