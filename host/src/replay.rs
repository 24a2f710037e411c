//! Recording and verifying replays (`sinew replay record|verify`): a model's content hash, a pose
//! sequence and the hash of every frame `sinew-core` computes from it, in one numeric mode. The
//! frames are hashed by `sinew_core::replay::pose_frame_hash`, the same function every firmware target
//! runs, so a replay recorded here verifies bit for bit anywhere.
//!
//! S2D decoders have replays of their own ([`record_s2d`]): per frame the decoder input, and
//! optionally the neutral face the frames decode onto. [`verify`] tells the kinds apart by the
//! model artefact and refuses a replay of the other kind by name.

use std::path::{Path, PathBuf};

use sinew_core::FormatError;
use sinew_core::aim::AimActor;
use sinew_core::format::ArtifactKind;
use sinew_core::q16::Q16;
use sinew_core::replay::{
    AIM_INPUTS, AIM_POSE_LEN, AimReplay, FRAME_HASHES, FrameBuffers, FrameCheck, MODEL_HASH, Mode,
    ReplayError as CoreReplayError, S2D_INPUTS, S2D_NEUTRAL, S2dBuffers, S2dReplay, hash_words,
    model_hash, pose_frame, pose_frame_hash, s2d_frame_hash, verify as core_verify, verify_s2d,
};
use sinew_core::s2d::S2dDecoder;

use crate::aim::play::PoseFileError;
use crate::aim::play::{Frame, PoseFile};
use crate::io::atomic::AtomicWriteError;
use crate::io::container::{ContainerError, SinewWriter, WriterError};
use crate::io::units::UnknownUnit;

/// Why a replay could not be recorded, verified or measured.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReplayError {
    /// The model's bytes are not the artefact expected (an AIM actor or an S2D decoder).
    #[error("model")]
    Model(#[source] FormatError),
    /// The replay's bytes are not a valid replay of the kind expected.
    #[error("replay")]
    Replay(#[source] FormatError),
    /// The model is an S2D decoder, the replay an AIM replay.
    #[error("the model is an S2D decoder, the replay an AIM replay")]
    AimReplayForS2d,
    /// The replay is an S2D replay, the model not an S2D decoder.
    #[error("the replay is an S2D replay, the model is not an S2D decoder")]
    S2dReplayForAim,
    /// Nothing to record.
    #[error("a replay needs at least one frame")]
    NoFrames,
    /// A pose frame whose coefficient count is not the actor's.
    #[error("frame {frame} has {weights} weights, the model {shapes} shapes")]
    WeightCount {
        /// The frame.
        frame: usize,
        /// Its coefficients.
        weights: usize,
        /// The actor's shapes.
        shapes: usize,
    },
    /// An S2D frame whose input length is not the decoder's.
    #[error("frame {frame} has {inputs} inputs, the decoder {width}")]
    InputLength {
        /// The frame.
        frame: usize,
        /// Its input length.
        inputs: usize,
        /// The decoder's.
        width: usize,
    },
    /// An S2D neutral whose length is not three per template vertex.
    #[error("the neutral has {values} values, the decoder's template {vertices} vertices (× 3)")]
    NeutralLength {
        /// The neutral's values.
        values: usize,
        /// The template's vertices.
        vertices: usize,
    },
    /// The core refused to play a frame (for example Q16 without the Q16.16 cache).
    #[error("frame {frame}")]
    Frame {
        /// The frame.
        frame: usize,
        /// The core's reason.
        #[source]
        source: CoreReplayError,
    },
    /// An S2D replay frame that cannot be read back.
    #[error("replay: frame {frame} unreadable")]
    FrameUnreadable {
        /// The frame.
        frame: usize,
    },
    /// A replay whose coefficient count is not the model's.
    #[error("replay has another coefficient count than the model")]
    CoefficientCount,
    /// The core refused the replay for this model (another model's content hash, another
    /// coefficient count or input width, a mode the model cannot play).
    #[error(transparent)]
    Refused(CoreReplayError),
    /// The model's `units` metadata names no known unit.
    #[error("in the model's metadata (units)")]
    Units(#[source] UnknownUnit),
    /// The replay artefact could not be laid out.
    #[error(transparent)]
    Writer(#[from] WriterError),
}

/// Why `sinew replay record|verify` failed: the files involved, and the [`ReplayError`] or the
/// reader's error as the source.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReplayFileError {
    /// The model or replay file could not be read or is no `.sinew` artefact.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// A numeric mode other than `f32` for an S2D decoder.
    #[error("S2D replays are f32 only (--mode {mode})")]
    S2dMode {
        /// The mode asked for.
        mode: Mode,
    },
    /// The S2D input file could not be read.
    #[error("{}: cannot read", path.display())]
    ReadInputs {
        /// The input file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The S2D input file is not `{"frames": [{"input": [I]}, ...], "neutral": [V·3]?}`.
    #[error(
        "{}: not an S2D input file {{\"frames\": [{{\"input\": [I]}}, ...], \"neutral\": [V·3]?}}",
        path.display()
    )]
    ParseInputs {
        /// The input file.
        path: PathBuf,
        /// What the JSON reader said.
        #[source]
        source: serde_json::Error,
    },
    /// The pose file is unreadable or does not fit the actor.
    #[error(transparent)]
    Poses(#[from] PoseFileError),
    /// Recording the frames failed.
    #[error("recording {} with {}", inputs.display(), model.display())]
    Record {
        /// The pose or input file.
        inputs: PathBuf,
        /// The model file.
        model: PathBuf,
        /// Why.
        #[source]
        source: ReplayError,
    },
    /// Verifying the replay failed (not a verdict: a verification that could not run).
    #[error("verifying {} against {}", replay.display(), model.display())]
    Verify {
        /// The replay file.
        replay: PathBuf,
        /// The model file.
        model: PathBuf,
        /// Why.
        #[source]
        source: ReplayError,
    },
    /// Measuring the replay's deviation from `f32` failed.
    #[error("measuring {} against {}", replay.display(), model.display())]
    Measure {
        /// The replay file.
        replay: PathBuf,
        /// The model file.
        model: PathBuf,
        /// Why.
        #[source]
        source: ReplayError,
    },
    /// The replay could not be written (the message names the file).
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}

/// Buffers for one frame of an S2D `decoder`: its input, the neutral to decode onto (`neutral`
/// values, or none to decode onto the template), scratch and output.
struct S2dOwned {
    input: Vec<f32>,
    neutral: Vec<f32>,
    scratch: Vec<f32>,
    vertices: Vec<f32>,
}

impl S2dOwned {
    fn for_decoder(decoder: &S2dDecoder<'_>, neutral: Vec<f32>) -> Self {
        Self {
            input: vec![0.0; decoder.input_len()],
            neutral,
            scratch: vec![0.0; decoder.scratch_len()],
            vertices: vec![0.0; 3 * decoder.vertex_count()],
        }
    }

    /// The core's view of these buffers.
    fn frame(&mut self) -> S2dBuffers<'_> {
        S2dBuffers {
            input: &mut self.input,
            neutral: &mut self.neutral,
            scratch: &mut self.scratch,
            vertices: &mut self.vertices,
        }
    }
}

/// Buffers for one frame of `actor` in every mode.
struct Buffers {
    positions: Vec<f32>,
    normals: Vec<f32>,
    positions_q16: Vec<Q16>,
    weights: Vec<f32>,
    weights_q16: Vec<Q16>,
}

impl Buffers {
    fn for_actor(actor: &AimActor<'_>) -> Self {
        let (v, m) = (actor.vertex_count(), actor.shape_count());
        Self {
            positions: vec![0.0; 3 * v],
            normals: vec![0.0; 3 * v],
            positions_q16: vec![Q16::ZERO; 3 * v],
            weights: vec![0.0; m],
            weights_q16: vec![Q16::ZERO; m],
        }
    }

    fn view(&mut self) -> FrameBuffers<'_> {
        FrameBuffers {
            positions: &mut self.positions,
            normals: &mut self.normals,
            positions_q16: &mut self.positions_q16,
            weights: &mut self.weights,
            weights_q16: &mut self.weights_q16,
        }
    }
}

/// Records a replay of `frames` through the actor in `model` in `mode`.
///
/// # Errors
/// If `model` is not an AIM actor, a frame's coefficient count differs from the actor's, or
/// `mode` is Q16 and the actor has no Q16.16 cache (`sinew bake --q16`).
pub fn record(model: &[u8], mode: Mode, frames: &[Frame]) -> Result<Vec<u8>, ReplayError> {
    let actor = AimActor::from_bytes(model).map_err(ReplayError::Model)?;
    if frames.is_empty() {
        return Err(ReplayError::NoFrames);
    }
    let m = actor.shape_count();
    let mut buf = Buffers::for_actor(&actor);
    let mut inputs = Vec::with_capacity(frames.len() * (AIM_POSE_LEN + m));
    let mut hashes = Vec::with_capacity(2 * frames.len());
    for (i, f) in frames.iter().enumerate() {
        if f.weights.len() != m {
            return Err(ReplayError::WeightCount {
                frame: i,
                weights: f.weights.len(),
                shapes: m,
            });
        }
        buf.weights.copy_from_slice(&f.weights);
        let h = pose_frame_hash(&actor, mode, &f.head, &f.jaw, &mut buf.view())
            .map_err(|source| ReplayError::Frame { frame: i, source })?;
        inputs.extend(f.head.iter().chain(&f.jaw).chain(&f.weights));
        hashes.extend(hash_words(h));
    }
    let content = model_hash(model);
    let mut w = SinewWriter::new(ArtifactKind::Replay);
    w.meta("mode", mode.name())
        .meta("model", format!("{content:016x}"))
        .meta("frames", frames.len());
    w.u32s(MODEL_HASH, &[2], &hash_words(content))?;
    w.f32s(AIM_INPUTS, &[frames.len(), AIM_POSE_LEN + m], &inputs)?;
    w.u32s(FRAME_HASHES, &[frames.len(), 2], &hashes)?;
    Ok(w.to_bytes()?)
}

/// The outcome of [`verify`].
#[derive(Clone, Debug)]
pub struct Verification {
    /// The replay's numeric mode.
    pub mode: Mode,
    /// Every frame's check, in order.
    pub frames: Vec<FrameCheck>,
    /// The first frame whose hash differs, if any.
    pub first_mismatch: Option<usize>,
}

/// Whether `replay` is an S2D replay (it has the `replay.s2d` section) rather than an AIM one.
fn is_s2d_replay(replay: &[u8]) -> bool {
    sinew_core::SinewFile::from_bytes(replay).is_ok_and(|f| f.section(S2D_INPUTS).is_some())
}

/// Whether `model` is an S2D decoder artefact.
fn is_s2d_model(model: &[u8]) -> bool {
    sinew_core::SinewFile::from_bytes(model).is_ok_and(|f| f.kind == ArtifactKind::S2dDecoder)
}

/// Records an S2D replay: each of `inputs` (`[I]` decoder inputs, from
/// `sinew_core::s2d::S2dDecoder::input`) decoded by the decoder in `model` onto `neutral` (`[V, 3]`)
/// or, without it, onto the decoder's template, and hashed by `s2d_frame_hash`.
///
/// # Errors
/// If `model` is not an S2D decoder, there are no frames, or a frame's input or the neutral has
/// the wrong length.
pub fn record_s2d(
    model: &[u8],
    inputs: &[Vec<f32>],
    neutral: Option<&[f32]>,
) -> Result<Vec<u8>, ReplayError> {
    let decoder = S2dDecoder::from_bytes(model).map_err(ReplayError::Model)?;
    if inputs.is_empty() {
        return Err(ReplayError::NoFrames);
    }
    let (width, v) = (decoder.input_len(), decoder.vertex_count());
    if let Some(n) = neutral
        && n.len() != 3 * v
    {
        return Err(ReplayError::NeutralLength {
            values: n.len(),
            vertices: v,
        });
    }
    let mut owned =
        S2dOwned::for_decoder(&decoder, neutral.map(<[f32]>::to_vec).unwrap_or_default());
    let mut flat = Vec::with_capacity(inputs.len() * width);
    let mut hashes = Vec::with_capacity(2 * inputs.len());
    for (i, x) in inputs.iter().enumerate() {
        if x.len() != width {
            return Err(ReplayError::InputLength {
                frame: i,
                inputs: x.len(),
                width,
            });
        }
        owned.input.copy_from_slice(x);
        let h = s2d_frame_hash(&decoder, &mut owned.frame())
            .map_err(|source| ReplayError::Frame { frame: i, source })?;
        flat.extend_from_slice(x);
        hashes.extend(hash_words(h));
    }
    let content = model_hash(model);
    let mut w = SinewWriter::new(ArtifactKind::Replay);
    w.meta("mode", Mode::F32.name())
        .meta("model", format!("{content:016x}"))
        .meta("frames", inputs.len())
        .meta("content", "s2d-replay");
    w.u32s(MODEL_HASH, &[2], &hash_words(content))?;
    w.f32s(S2D_INPUTS, &[inputs.len(), width], &flat)?;
    if let Some(n) = neutral {
        w.f32s(S2D_NEUTRAL, &[v, 3], n)?;
    }
    w.u32s(FRAME_HASHES, &[inputs.len(), 2], &hashes)?;
    Ok(w.to_bytes()?)
}

/// An S2D replay's inputs as [`record_s2d`] takes them: each frame's decoder input, and the
/// neutral if the replay has one.
pub type S2dInputs = (Vec<Vec<f32>>, Option<Vec<f32>>);

/// An S2D replay's frame inputs and neutral ([`S2dInputs`]).
///
/// # Errors
/// If `replay` is not a valid S2D replay.
pub fn s2d_inputs(replay: &[u8]) -> Result<S2dInputs, ReplayError> {
    let r = S2dReplay::from_bytes(replay).map_err(ReplayError::Replay)?;
    let mut frames = Vec::with_capacity(r.frames());
    for f in 0..r.frames() {
        let mut x = vec![0.0f32; r.input_len()];
        r.frame(f, &mut x)
            .ok_or(ReplayError::FrameUnreadable { frame: f })?;
        frames.push(x);
    }
    Ok((frames, r.neutral().map(|n| n.iter().collect())))
}

/// Plays an S2D replay through the decoder in `model` (see [`verify`]).
fn verify_s2d_replay(model: &[u8], replay: &[u8]) -> Result<Verification, ReplayError> {
    let decoder = S2dDecoder::from_bytes(model).map_err(ReplayError::Model)?;
    let r = S2dReplay::from_bytes(replay).map_err(ReplayError::Replay)?;
    let neutral = vec![
        0.0f32;
        if r.neutral().is_some() {
            3 * decoder.vertex_count()
        } else {
            0
        }
    ];
    let mut owned = S2dOwned::for_decoder(&decoder, neutral);
    let mut frames = Vec::with_capacity(r.frames());
    let first_mismatch = verify_s2d(model, &decoder, &r, &mut owned.frame(), |c| frames.push(*c))
        .map_err(ReplayError::Refused)?;
    Ok(Verification {
        mode: Mode::F32,
        frames,
        first_mismatch,
    })
}

/// Plays the replay in `replay` through the model in `model` (an AIM actor or an S2D decoder)
/// with `sinew-core` and compares every frame's hash with the recorded one.
///
/// # Errors
/// If either file is invalid, the replay is of the other model kind or was recorded with another
/// model, or the mode is unavailable for this model. A differing frame is not an error: see
/// [`Verification::first_mismatch`].
pub fn verify(model: &[u8], replay: &[u8]) -> Result<Verification, ReplayError> {
    match (is_s2d_model(model), is_s2d_replay(replay)) {
        (true, true) => return verify_s2d_replay(model, replay),
        (true, false) => return Err(ReplayError::AimReplayForS2d),
        (false, true) => return Err(ReplayError::S2dReplayForAim),
        (false, false) => {}
    }
    let actor = AimActor::from_bytes(model).map_err(ReplayError::Model)?;
    let r = AimReplay::from_bytes(replay).map_err(ReplayError::Replay)?;
    let mut buf = Buffers::for_actor(&actor);
    let mut frames = Vec::with_capacity(r.frames());
    let first_mismatch = core_verify(model, &actor, &r, &mut buf.view(), |c| frames.push(*c))
        .map_err(ReplayError::Refused)?;
    Ok(Verification {
        mode: r.mode(),
        frames,
        first_mismatch,
    })
}

/// How far a mode's output lies from the `f32` reference over a replay's frames.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Deviation {
    /// Largest per-vertex position distance, mm.
    pub max_mm: f64,
    /// Mean per-vertex position distance, mm.
    pub mean_mm: f64,
    /// Largest distance between a unit vertex normal and the reference's (0 in Q16 mode, which
    /// computes no normals): the fast mode's normalisation changes lengths, not directions.
    pub max_normal_diff: f64,
    /// Mean distance between normals.
    pub mean_normal_diff: f64,
}

/// Millimetres per unit of a model's `units` metadata (`m`, `cm` or `mm`; cm if absent, the
/// ICT-FaceKit unit).
pub fn mm_per_unit(actor: &AimActor<'_>) -> Result<f64, ReplayError> {
    let name = actor.file().metadata().get("units").unwrap_or("cm");
    let unit: crate::io::units::Unit = name.parse().map_err(ReplayError::Units)?;
    Ok(unit.mm())
}

/// Plays the replay's inputs in its mode and in the `f32` reference mode and measures how far
/// the mode's positions (and normals) lie from the reference's.
///
/// # Errors
/// As [`verify`].
pub fn deviation(model: &[u8], replay: &[u8]) -> Result<Deviation, ReplayError> {
    let actor = AimActor::from_bytes(model).map_err(ReplayError::Model)?;
    let r = AimReplay::from_bytes(replay).map_err(ReplayError::Replay)?;
    let unit = mm_per_unit(&actor)?;
    let v = actor.vertex_count();
    let mut reference = Buffers::for_actor(&actor);
    let mut mode = Buffers::for_actor(&actor);
    let (mut max_mm, mut sum_mm, mut max_nd, mut sum_nd) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for f in 0..r.frames() {
        let (head, jaw) = r
            .frame(f, &mut reference.weights)
            .ok_or(ReplayError::CoefficientCount)?;
        mode.weights.copy_from_slice(&reference.weights);
        let play = |m, b: &mut Buffers| {
            pose_frame(&actor, m, &head, &jaw, &mut b.view())
                .map_err(|source| ReplayError::Frame { frame: f, source })
        };
        play(Mode::F32, &mut reference)?;
        play(r.mode(), &mut mode)?;
        if r.mode() == Mode::Q16 {
            // Q16 computes no normals: compare positions only.
            for (p, q) in mode.positions.iter_mut().zip(&mode.positions_q16) {
                *p = q.to_num();
            }
            mode.normals.copy_from_slice(&reference.normals);
        }
        let vec = |a: &[f32], i: usize| [0, 1, 2].map(|k| f64::from(a[3 * i + k]));
        for i in 0..v {
            let (p, q) = (vec(&mode.positions, i), vec(&reference.positions, i));
            let mm = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt() * unit;
            let (a, b) = (vec(&mode.normals, i), vec(&reference.normals, i));
            let nd = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
            max_mm = max_mm.max(mm);
            sum_mm += mm;
            max_nd = max_nd.max(nd);
            sum_nd += nd;
        }
    }
    let n = (r.frames() * v) as f64;
    Ok(Deviation {
        max_mm,
        mean_mm: sum_mm / n,
        max_normal_diff: max_nd,
        mean_normal_diff: sum_nd / n,
    })
}

/// One frame of an S2D input file.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct S2dInputFrame {
    /// The decoder input, `[I]` (`sinew_core::s2d::S2dDecoder::input`).
    input: Vec<f32>,
}

/// The input file of an S2D replay: the frames, and optionally the neutral to decode onto.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct S2dInputFile {
    frames: Vec<S2dInputFrame>,
    #[serde(default)]
    neutral: Option<Vec<f32>>,
}

/// `sinew replay record`: returns the number of frames recorded. An AIM actor takes a pose file;
/// an S2D decoder takes `{"frames": [{"input": [I]}, ...], "neutral": [V·3]}` (neutral
/// optional).
pub fn replay_record(
    model: &Path,
    poses: &Path,
    out: &Path,
    mode: sinew_core::replay::Mode,
) -> Result<usize, ReplayFileError> {
    let recording = |source| ReplayFileError::Record {
        inputs: poses.to_path_buf(),
        model: model.to_path_buf(),
        source,
    };
    let bytes = crate::io::container::read(model)?;
    if sinew_core::SinewFile::from_bytes(&bytes)
        .is_ok_and(|f| f.kind == sinew_core::ArtifactKind::S2dDecoder)
    {
        if mode != sinew_core::replay::Mode::F32 {
            return Err(ReplayFileError::S2dMode { mode });
        }
        let text =
            std::fs::read_to_string(poses).map_err(|source| ReplayFileError::ReadInputs {
                path: poses.to_path_buf(),
                source,
            })?;
        let file: S2dInputFile =
            serde_json::from_str(&text).map_err(|source| ReplayFileError::ParseInputs {
                path: poses.to_path_buf(),
                source,
            })?;
        let inputs: Vec<Vec<f32>> = file.frames.into_iter().map(|f| f.input).collect();
        let replay = crate::replay::record_s2d(&bytes, &inputs, file.neutral.as_deref())
            .map_err(recording)?;
        crate::io::atomic::write(out, &replay)?;
        return Ok(inputs.len());
    }
    let actor = crate::io::container::actor(model, &bytes)?;
    let file = PoseFile::read(poses, actor.shape_count())?;
    let replay = crate::replay::record(&bytes, mode, &file.frames).map_err(recording)?;
    crate::io::atomic::write(out, &replay)?;
    Ok(file.frames.len())
}

/// `sinew replay verify`.
pub fn replay_verify(
    model: &Path,
    replay: &Path,
) -> Result<crate::replay::Verification, ReplayFileError> {
    let m = crate::io::container::read(model)?;
    let r = crate::io::container::read(replay)?;
    crate::replay::verify(&m, &r).map_err(|source| ReplayFileError::Verify {
        replay: replay.to_path_buf(),
        model: model.to_path_buf(),
        source,
    })
}

/// The deviation of a replay's numeric mode from the `f32` reference (`sinew replay verify`).
pub fn replay_deviation(
    model: &Path,
    replay: &Path,
) -> Result<crate::replay::Deviation, ReplayFileError> {
    let m = crate::io::container::read(model)?;
    let r = crate::io::container::read(replay)?;
    crate::replay::deviation(&m, &r).map_err(|source| ReplayFileError::Measure {
        replay: replay.to_path_buf(),
        model: model.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests;
