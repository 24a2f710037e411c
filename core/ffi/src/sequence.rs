//! Generated sequences: a baked Motion3DGAN generator paired with the S2D decoder whose landmarks
//! it moves (`sinew_core::sequence::Sequence`), so that a label and a seed become dense frames in
//! C exactly as `sinew generate` and every firmware target make them.
//!
//! Two steps, as in the core: `sinew_sequence_curve` generates the whole landmark curve once
//! (frame 0 the neutral's landmarks, then `SINEW_SEQUENCE_FRAMES` frames), then
//! `sinew_sequence_frame` decodes one curve frame into the dense face. The curve and the scratch
//! are the caller's.

use std::ffi::c_char;

use sinew_core::motion::{LABELS, MotionGenerator};
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_core::srvf::FRAMES;
use sinew_core::{ArtifactKind, SinewFile};

use crate::model::{SinewModel, expect_len, expect_scratch};
use crate::ptr;
use crate::status::{Fail, Result, SinewError, SinewStatus, guard};

/// Frames of a generated motion after its neutral frame 0: `sinew_sequence_frame` plays
/// `t = 1 ..= SINEW_SEQUENCE_FRAMES` (and `t = 0`, the neutral itself).
// A literal, so that cbindgen can write it into the header; the assertion keeps it the core's.
pub const SINEW_SEQUENCE_FRAMES: usize = 30;
const _: () = assert!(SINEW_SEQUENCE_FRAMES == FRAMES);

/// A generator and the S2D decoder whose landmarks it moves (opaque to C). It borrows the
/// generator's bytes and the decoder model's bytes; it does not keep the decoder's handle, which
/// may be freed first (its bytes may not).
#[derive(Debug)]
pub struct SinewSequence {
    sequence: Sequence<'static>,
}

/// A generated sequence's sizes, from [`sinew_sequence_info`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SinewSequenceInfo {
    /// Labels the generator knows (CoMA's twelve expression classes); `label` is below this.
    pub label_count: usize,
    /// Frames after the neutral (`SINEW_SEQUENCE_FRAMES`).
    pub frame_count: usize,
    /// Landmarks K the generator moves and the decoder reads.
    pub landmark_count: usize,
    /// Vertices V of the decoded mesh; `vertices` and a `neutral` hold `3 * V` floats.
    pub vertex_count: usize,
    /// Noise values the generator draws from the seed.
    pub noise_len: usize,
    /// Floats of the landmark curve, `(frame_count + 1) * 3 * K`, frame 0 the neutral's
    /// landmarks.
    pub curve_floats: usize,
    /// Floats of scratch `sinew_sequence_curve` and `sinew_sequence_frame` need.
    pub scratch_floats: usize,
}

impl SinewSequence {
    fn info(&self) -> SinewSequenceInfo {
        let s = &self.sequence;
        SinewSequenceInfo {
            label_count: LABELS,
            frame_count: FRAMES,
            landmark_count: s.input_len() / 3,
            vertex_count: s.vertex_len() / 3,
            noise_len: s.generator().noise_len(),
            curve_floats: s.curve_len(),
            scratch_floats: self.scratch_len(),
        }
    }

    /// The decoder's input (`3 K`) is carved from the front of the caller's scratch, the core's
    /// shared scratch from the rest.
    fn scratch_len(&self) -> usize {
        self.sequence.input_len() + self.sequence.scratch_len()
    }

    /// The caller's neutral face (`3 V` floats) or, when NULL, none: the decoder's template.
    fn neutral(&self, neutral: *const f32, neutral_len: usize) -> Result<&'static [f32]> {
        match ptr::optional(neutral, neutral_len, "neutral")? {
            Some(n) => {
                expect_len("neutral", n.len(), self.sequence.vertex_len())?;
                Ok(n)
            }
            None => Ok(&[]),
        }
    }
}

fn open(bytes: &'static [u8], decoder: &SinewModel) -> Result<SinewSequence> {
    let decoder = decoder.s2d()?.clone();
    let file = SinewFile::from_bytes(bytes).map_err(|e| Fail::format("generator", e))?;
    if file.kind != ArtifactKind::MotionGenerator {
        return Err(Fail::new(
            SinewStatus::WrongKind,
            format_args!("the artefact is {}, not a motion generator", file.kind),
        ));
    }
    let generator = MotionGenerator::from_bytes(bytes).map_err(|e| Fail::format("generator", e))?;
    let (dims, inputs) = (generator.dims(), decoder.input_len());
    let sequence = Sequence::new(generator, decoder).map_err(|_| {
        Fail::new(
            SinewStatus::ModelMismatch,
            format_args!(
                "the generator moves {} landmarks, the decoder reads {}",
                dims / 3,
                inputs / 3
            ),
        )
    })?;
    Ok(SinewSequence { sequence })
}

/// Opens a Motion3DGAN generator (`sinew train motion`, `len` bytes at `bytes`, validated
/// completely) paired with `decoder`, an open S2D decoder whose landmarks it moves. On success
/// `*out` is a new handle, to be released with `sinew_sequence_free`; on failure `*out` is set to
/// NULL. `SINEW_STATUS_WRONG_KIND` if `decoder` is an AIM actor or the bytes another kind of
/// artefact; `SINEW_STATUS_MODEL_MISMATCH` if the generator moves another number of landmarks.
///
/// # Safety
/// `bytes` must point to `len` readable bytes that stay valid and unchanged until the handle is
/// freed, and so must the bytes `decoder` was opened from (the handle borrows both; `decoder`
/// itself may be freed first). `out` must point to writable memory for one pointer; `err` is NULL
/// or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_sequence_open(
    bytes: *const u8,
    len: usize,
    decoder: *const SinewModel,
    out: *mut *mut SinewSequence,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        ptr::write(out, std::ptr::null_mut(), "out")?;
        let decoder = ptr::handle(decoder, "decoder")?;
        let bytes = ptr::slice(bytes, len, "bytes")?;
        let sequence = open(bytes, decoder)?;
        ptr::hand_out(out, sequence, "out")
    })
}

/// Releases a handle from `sinew_sequence_open`. NULL is ignored.
///
/// # Safety
/// `sequence` is NULL or a handle from `sinew_sequence_open` not yet freed; no other call may be
/// using it, and it must not be used afterwards.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_sequence_free(sequence: *mut SinewSequence) {
    // Safety: the caller's promise above is `release`'s.
    unsafe { ptr::release(sequence) }
}

/// Writes the sequence's labels, frames and buffer sizes to `*out`.
///
/// # Safety
/// `sequence` is a live handle; `out` points to a writable `SinewSequenceInfo`; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_sequence_info(
    sequence: *const SinewSequence,
    out: *mut SinewSequenceInfo,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let s = ptr::handle(sequence, "sequence")?;
        ptr::write(out, s.info(), "out")
    })
}

/// Copies the name of `label` (below `label_count`, e.g. `mouth_open`) as the generator records
/// it (metadata `labels`) and a NUL to `buf`, the bytes that takes to `*needed` when not NULL
/// (with `buf` NULL and `buf_len` 0, only the size). `SINEW_STATUS_OUT_OF_RANGE` past the labels,
/// `SINEW_STATUS_NOT_FOUND` when the file records no names.
///
/// # Safety
/// `sequence` is a live handle; `buf` points to `buf_len` writable bytes (or is NULL for a size
/// query); `needed` is NULL or points to a writable `size_t`; `err` is NULL or points to a
/// writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_sequence_label_name(
    sequence: *const SinewSequence,
    label: usize,
    buf: *mut c_char,
    buf_len: usize,
    needed: *mut usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let s = ptr::handle(sequence, "sequence")?;
        let name = s.sequence.generator().label_name(check_label(label)?);
        let name = name.ok_or_else(|| {
            Fail::new(
                SinewStatus::NotFound,
                "the generator does not record its labels' names",
            )
        })?;
        ptr::write_text(name, buf, buf_len, needed)
    })
}

fn check_label(label: usize) -> Result<usize> {
    if label < LABELS {
        Ok(label)
    } else {
        Err(Fail::new(
            SinewStatus::OutOfRange,
            format_args!("label {label} is past the generator's {LABELS} labels"),
        ))
    }
}

/// Generates the landmark curve of `label` from `seed` at `intensity` (1: a reach drawn from the
/// label's training motions; 0.5 half as far) into `curve` (`curve_len == curve_floats`): frame
/// 0 the neutral's landmarks, then `frame_count` frames of the motion
/// (`sinew_core::sequence::Sequence::curve`). The neutral is `neutral` (`3 * vertex_count`
/// floats, the face the frames will decode onto) or, when NULL, the decoder's template.
/// `SINEW_STATUS_OUT_OF_RANGE` for a label past `label_count`; `SINEW_STATUS_INVALID_INPUT` for an
/// intensity or a neutral coordinate that is NaN, infinite or out of range.
///
/// # Safety
/// `sequence` is a live handle; `neutral` is NULL or points to `neutral_len` floats; `curve` and
/// `scratch` point to the stated number of writable floats, overlapping no other argument; `err`
/// is NULL or points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_sequence_curve(
    sequence: *const SinewSequence,
    label: usize,
    seed: u64,
    intensity: f32,
    neutral: *const f32,
    neutral_len: usize,
    curve: *mut f32,
    curve_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let s = ptr::handle(sequence, "sequence")?;
        let label = check_label(label)?;
        let neutral = s.neutral(neutral, neutral_len)?;
        let curve = ptr::slice_mut(curve, curve_len, "curve")?;
        expect_len("curve", curve.len(), s.sequence.curve_len())?;
        let scratch = ptr::slice_mut(scratch, scratch_len, "scratch")?;
        expect_scratch(scratch.len(), s.scratch_len())?;
        let (input, scratch) = scratch.split_at_mut(s.sequence.input_len());
        let mut buf = SequenceBuffers {
            curve,
            input,
            neutral,
            scratch,
            vertices: &mut [],
        };
        s.sequence
            .curve(label, seed, intensity, &mut buf)
            .map_err(|e| Fail::eval("curve", e))
    })
}

/// Decodes frame `t` (0 to `frame_count`; 0 is the neutral) of a curve from
/// `sinew_sequence_curve` into `vertices` (`3 * vertex_count` floats): the decoder's input from
/// curve frames 0 and `t`, decoded onto `neutral` (the one the curve was generated on) or, when
/// NULL, the decoder's template (`sinew_core::sequence::Sequence::frame`). When `hash` is not
/// NULL, writes the frame's hash (the vertices' f32 bits, as `sinew_s2d_decode` and the
/// `motion-ict` goldens hash them). `SINEW_STATUS_OUT_OF_RANGE` for `t` past `frame_count`.
///
/// # Safety
/// `sequence` is a live handle; `curve` points to `curve_len` floats, `neutral` is NULL or points
/// to `neutral_len` floats; `scratch` and `vertices` point to the stated number of writable
/// floats, overlapping no other argument; `hash` is NULL or points to a writable `uint64_t`;
/// `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_sequence_frame(
    sequence: *const SinewSequence,
    t: usize,
    curve: *const f32,
    curve_len: usize,
    neutral: *const f32,
    neutral_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    vertices: *mut f32,
    vertices_len: usize,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let s = ptr::handle(sequence, "sequence")?;
        if t > FRAMES {
            return Err(Fail::new(
                SinewStatus::OutOfRange,
                format_args!("frame {t} is past the sequence's {FRAMES} frames"),
            ));
        }
        let curve = ptr::slice(curve, curve_len, "curve")?;
        expect_len("curve", curve.len(), s.sequence.curve_len())?;
        let neutral = s.neutral(neutral, neutral_len)?;
        let scratch = ptr::slice_mut(scratch, scratch_len, "scratch")?;
        expect_scratch(scratch.len(), s.scratch_len())?;
        let vertices = ptr::slice_mut(vertices, vertices_len, "vertices")?;
        expect_len("vertices", vertices.len(), s.sequence.vertex_len())?;
        let (input, scratch) = scratch.split_at_mut(s.sequence.input_len());
        s.sequence
            .frame_of(t, curve, neutral, input, scratch, vertices)
            .map_err(|e| Fail::eval("frame", e))?;
        let h = sinew_core::hash::frame_hash(vertices);
        if !hash.is_null() {
            ptr::write(hash, h, "hash")?;
        }
        Ok(())
    })
}
