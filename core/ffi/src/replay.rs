//! Replay handles: a replay artefact's per-frame inputs and recorded hashes, so that C code can
//! check a model bit for bit without parsing bytes itself.

use sinew_core::replay::{self, AimReplay, Mode, S2D_INPUTS, S2dReplay};
use sinew_core::{ArtifactKind, SinewFile};

use crate::model::{SinewKind, SinewModel, expect_len};
use crate::ptr;
use crate::status::{Fail, Result, SinewError, SinewStatus, guard};

/// The numeric mode a replay was recorded in; also the `mode` argument of
/// `sinew_aim_frame_hash`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SinewMode {
    /// `f32` with `libm`: the reference.
    F32 = 0,
    /// Q16.16 fixed point, for parts without an FPU (needs the actor's Q16.16 cache).
    Q16 = 1,
    /// `f32` with micromath's approximate normal normalisation.
    Fast = 2,
}

impl From<Mode> for SinewMode {
    fn from(m: Mode) -> Self {
        match m {
            Mode::F32 => Self::F32,
            Mode::Q16 => Self::Q16,
            Mode::Fast => Self::Fast,
        }
    }
}

#[derive(Debug)]
enum Loaded {
    Aim(AimReplay<'static>),
    S2d(S2dReplay<'static>),
}

/// An opened replay (opaque to C). It borrows the bytes it was opened from: they must stay valid
/// and unchanged until [`sinew_replay_free`].
#[derive(Debug)]
pub struct SinewReplay {
    loaded: Loaded,
}

/// A replay's contents, from [`sinew_replay_info`]. Counts that do not apply to the kind are 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SinewReplayInfo {
    /// The kind of model it replays.
    pub kind: SinewKind,
    /// The numeric mode (always f32 for S2D).
    pub mode: SinewMode,
    /// Frames (at least one).
    pub frame_count: usize,
    /// AIM: coefficients per frame.
    pub shape_count: usize,
    /// S2D: decoder inputs per frame.
    pub input_len: usize,
    /// S2D: floats of the neutral the frames decode onto (`3 * V`), 0 when the replay carries
    /// none and frames decode onto the decoder's template.
    pub neutral_len: usize,
    /// The content hash (xxh64 of the bytes) of the model the replay was recorded with.
    pub model_hash: u64,
}

impl SinewReplay {
    fn aim(&self) -> Result<&AimReplay<'static>> {
        match &self.loaded {
            Loaded::Aim(r) => Ok(r),
            Loaded::S2d(_) => Err(Fail::new(
                SinewStatus::WrongKind,
                "the replay is an S2D replay, not an AIM replay",
            )),
        }
    }

    fn s2d(&self) -> Result<&S2dReplay<'static>> {
        match &self.loaded {
            Loaded::S2d(r) => Ok(r),
            Loaded::Aim(_) => Err(Fail::new(
                SinewStatus::WrongKind,
                "the replay is an AIM replay, not an S2D replay",
            )),
        }
    }

    fn info(&self) -> SinewReplayInfo {
        match &self.loaded {
            Loaded::Aim(r) => SinewReplayInfo {
                kind: SinewKind::Aim,
                mode: r.mode().into(),
                frame_count: r.frames(),
                shape_count: r.shape_count(),
                input_len: 0,
                neutral_len: 0,
                model_hash: r.model_hash(),
            },
            Loaded::S2d(r) => SinewReplayInfo {
                kind: SinewKind::S2d,
                mode: SinewMode::F32,
                frame_count: r.frames(),
                shape_count: 0,
                input_len: r.input_len(),
                neutral_len: r.neutral().map_or(0, |n| n.len()),
                model_hash: r.model_hash(),
            },
        }
    }
}

/// A frame index checked against the replay's length.
fn frame_index(frame: usize, frames: usize) -> Result<usize> {
    if frame < frames {
        Ok(frame)
    } else {
        Err(Fail::new(
            SinewStatus::OutOfRange,
            format_args!("frame {frame} is past the replay's {frames} frames"),
        ))
    }
}

/// Validates `bytes` as an AIM or S2D replay (S2D replays carry `replay.s2d`).
fn open(bytes: &'static [u8]) -> Result<SinewReplay> {
    let file = SinewFile::from_bytes(bytes).map_err(|e| Fail::format("replay", e))?;
    if file.kind != ArtifactKind::Replay {
        return Err(Fail::new(
            SinewStatus::WrongKind,
            format_args!("the artefact is {}, not a replay", file.kind),
        ));
    }
    let loaded = if file.section(S2D_INPUTS).is_some() {
        Loaded::S2d(S2dReplay::from_bytes(bytes).map_err(|e| Fail::format("S2D replay", e))?)
    } else {
        Loaded::Aim(AimReplay::from_bytes(bytes).map_err(|e| Fail::format("AIM replay", e))?)
    };
    Ok(SinewReplay { loaded })
}

/// Opens a replay (`*.replay.sinew`, written by `sinew replay record`) from `len` bytes at
/// `bytes`, validated completely. On success `*out` is a new handle, to be released with
/// `sinew_replay_free`; on failure `*out` is set to NULL.
///
/// # Safety
/// `bytes` must point to `len` readable bytes that stay valid and unchanged until the handle is
/// freed (the handle borrows them). `out` must point to writable memory for one pointer; `err`
/// is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_replay_open(
    bytes: *const u8,
    len: usize,
    out: *mut *mut SinewReplay,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        ptr::write(out, std::ptr::null_mut(), "out")?;
        let bytes = ptr::slice(bytes, len, "bytes")?;
        let replay = open(bytes)?;
        ptr::hand_out(out, replay, "out")
    })
}

/// Releases a handle from `sinew_replay_open`. NULL is ignored.
///
/// # Safety
/// `replay` is NULL or a handle from `sinew_replay_open` not yet freed; no other call may be
/// using it, and it must not be used afterwards.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_replay_free(replay: *mut SinewReplay) {
    // Safety: the caller's promise above is `release`'s.
    unsafe { ptr::release(replay) }
}

/// Writes the replay's kind, mode and sizes to `*out`.
///
/// # Safety
/// `replay` is a live handle; `out` points to a writable `SinewReplayInfo`; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_replay_info(
    replay: *const SinewReplay,
    out: *mut SinewReplayInfo,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let replay = ptr::handle(replay, "replay")?;
        ptr::write(out, replay.info(), "out")
    })
}

/// Checks that `replay` was recorded with `model` (the content hash of the model's bytes) and
/// fits it (coefficient count, or input width and neutral size): `SINEW_STATUS_MODEL_MISMATCH`
/// with the reason otherwise, `SINEW_STATUS_WRONG_KIND` if the kinds differ.
///
/// # Safety
/// `replay` and `model` are live handles; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_replay_check_model(
    replay: *const SinewReplay,
    model: *const SinewModel,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let replay = ptr::handle(replay, "replay")?;
        let model = ptr::handle(model, "model")?;
        match &replay.loaded {
            Loaded::Aim(r) => replay::check_model(model.bytes, model.aim()?, r),
            Loaded::S2d(r) => replay::check_s2d_model(model.bytes, model.s2d()?, r),
        }
        .map_err(Fail::replay)
    })
}

/// Frame `frame` of an AIM replay: writes head and jaw (9 floats each, the form
/// `sinew_aim_frame_hash` takes), the coefficients (`weights_len == shape_count`) and, when
/// `expected` is not NULL, the hash recorded for the frame.
///
/// # Safety
/// `replay` is a live handle; `head` and `jaw` point to 9 writable floats each, `weights` to
/// `weights_len`; `expected` is NULL or points to a writable `uint64_t`; `err` is NULL or points
/// to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_replay_aim_frame(
    replay: *const SinewReplay,
    frame: usize,
    head: *mut f32,
    jaw: *mut f32,
    weights: *mut f32,
    weights_len: usize,
    expected: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let replay = ptr::handle(replay, "replay")?.aim()?;
        let frame = frame_index(frame, replay.frames())?;
        let head = ptr::slice_mut(head, 9, "head")?;
        let jaw = ptr::slice_mut(jaw, 9, "jaw")?;
        let weights = ptr::slice_mut(weights, weights_len, "weights")?;
        expect_len("weights", weights.len(), replay.shape_count())?;
        let (h, j) = replay.frame(frame, weights).ok_or_else(|| {
            Fail::new(
                SinewStatus::Internal,
                "a validated replay frame is unreadable",
            )
        })?;
        head.copy_from_slice(&h);
        jaw.copy_from_slice(&j);
        if !expected.is_null() {
            ptr::write(expected, expected_hash(replay.expected(frame))?, "expected")?;
        }
        Ok(())
    })
}

fn expected_hash(h: Option<u64>) -> Result<u64> {
    h.ok_or_else(|| {
        Fail::new(
            SinewStatus::Internal,
            "a validated replay hash is unreadable",
        )
    })
}

/// Frame `frame` of an S2D replay: writes the decoder input (`input_len` of the replay info)
/// and, when `expected` is not NULL, the hash recorded for the frame.
///
/// # Safety
/// `replay` is a live handle; `input` points to `input_len` writable floats; `expected` is NULL
/// or points to a writable `uint64_t`; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_replay_s2d_frame(
    replay: *const SinewReplay,
    frame: usize,
    input: *mut f32,
    input_len: usize,
    expected: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let replay = ptr::handle(replay, "replay")?.s2d()?;
        let frame = frame_index(frame, replay.frames())?;
        let input = ptr::slice_mut(input, input_len, "input")?;
        expect_len("input", input.len(), replay.input_len())?;
        replay.frame(frame, input).ok_or_else(|| {
            Fail::new(
                SinewStatus::Internal,
                "a validated replay frame is unreadable",
            )
        })?;
        if !expected.is_null() {
            ptr::write(expected, expected_hash(replay.expected(frame))?, "expected")?;
        }
        Ok(())
    })
}

/// Copies an S2D replay's neutral (`neutral_len` of the replay info floats), the face its frames
/// decode onto, to `out`. `SINEW_STATUS_UNSUPPORTED` if the replay carries none (its frames
/// decode onto the decoder's template: pass NULL as `sinew_s2d_decode`'s neutral).
///
/// # Safety
/// `replay` is a live handle; `out` points to `out_len` writable floats; `err` is NULL or points
/// to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_replay_s2d_neutral(
    replay: *const SinewReplay,
    out: *mut f32,
    out_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let replay = ptr::handle(replay, "replay")?.s2d()?;
        let neutral = replay.neutral().ok_or_else(|| {
            Fail::new(
                SinewStatus::Unsupported,
                "the replay carries no neutral (its frames decode onto the template)",
            )
        })?;
        let out = ptr::slice_mut(out, out_len, "out")?;
        expect_len("out", out.len(), neutral.len())?;
        for (o, n) in out.iter_mut().zip(neutral.iter()) {
            *o = n;
        }
        Ok(())
    })
}
