//! Model handles: an AIM actor or an S2D decoder over the caller's bytes, and the per-frame calls.

use fixed::types::I16F16;
use sinew_core::aim::{AimActor, MAX_SHAPES};
use sinew_core::hash::FrameHasher;
use sinew_core::replay::{self, FrameBuffers, Mode};
use sinew_core::s2d::S2dDecoder;
use sinew_core::{ArtifactKind, SinewFile};

use crate::ptr;
use crate::status::{Fail, Result, SinewError, SinewStatus, guard};

/// What a model or replay handle holds.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SinewKind {
    /// An AIM actor (`sinew bake`): posed per frame from head, jaw and coefficients.
    Aim = 1,
    /// An S2D decoder (`sinew train s2d`): 68 landmarks to a dense mesh per frame.
    S2d = 2,
}

/// The validated model inside a handle.
// The handle is boxed whole, so the variants' size difference costs nothing per call; boxing
// the larger one too would only add a second allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub(crate) enum Loaded {
    Aim(AimActor<'static>),
    S2d(S2dDecoder<'static>),
}

/// An opened model (opaque to C). It borrows the bytes it was opened from: they must stay
/// valid and unchanged until [`sinew_model_free`].
#[derive(Debug)]
pub struct SinewModel {
    pub(crate) bytes: &'static [u8],
    pub(crate) loaded: Loaded,
    /// The content hash of `bytes` ([`replay::model_hash`]), computed once at open: replays and
    /// performances name it, and a performance compares it at every frame.
    pub(crate) hash: u64,
}

/// A model's sizes, from [`sinew_model_info`]. Counts that do not apply to the kind are 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SinewModelInfo {
    /// AIM actor or S2D decoder.
    pub kind: SinewKind,
    /// Vertices V of the output mesh; positions, normals and vertices buffers hold `3 * V`
    /// floats (x, y, z per vertex).
    pub vertex_count: usize,
    /// AIM: triangles of the template (`sinew_aim_triangles` copies `3 *` this many indices).
    pub triangle_count: usize,
    /// AIM: corrective coefficients M per frame (the `weights` length).
    pub shape_count: usize,
    /// S2D: landmarks K per set (68 for the ICT-FaceKit decoders); a landmark set is `3 * K`
    /// floats.
    pub landmark_count: usize,
    /// S2D: the decoder input's length (`3 * K`).
    pub input_len: usize,
    /// Floats of scratch the frame calls need (`sinew_aim_frame_hash`, `sinew_s2d_decode`).
    pub scratch_floats: usize,
    /// The same in bytes (`4 * scratch_floats`), for allocators that count bytes.
    pub scratch_bytes: usize,
    /// AIM: whether the actor carries the Q16.16 cache that `SINEW_MODE_Q16` needs.
    pub has_q16: bool,
}

impl SinewModel {
    /// The actor, or a `WrongKind` failure naming what the handle holds instead.
    pub(crate) fn aim(&self) -> Result<&AimActor<'static>> {
        match &self.loaded {
            Loaded::Aim(a) => Ok(a),
            Loaded::S2d(_) => Err(Fail::new(
                SinewStatus::WrongKind,
                "the model is an S2D decoder, not an AIM actor",
            )),
        }
    }

    /// The decoder, or a `WrongKind` failure naming what the handle holds instead.
    pub(crate) fn s2d(&self) -> Result<&S2dDecoder<'static>> {
        match &self.loaded {
            Loaded::S2d(d) => Ok(d),
            Loaded::Aim(_) => Err(Fail::new(
                SinewStatus::WrongKind,
                "the model is an AIM actor, not an S2D decoder",
            )),
        }
    }

    /// The validated container (metadata, sections).
    pub(crate) fn file(&self) -> &SinewFile<'static> {
        match &self.loaded {
            Loaded::Aim(a) => a.file(),
            Loaded::S2d(d) => d.file(),
        }
    }

    fn info(&self) -> SinewModelInfo {
        match &self.loaded {
            Loaded::Aim(a) => {
                let v = a.vertex_count();
                SinewModelInfo {
                    kind: SinewKind::Aim,
                    vertex_count: v,
                    triangle_count: a.triangles().len(),
                    shape_count: a.shape_count(),
                    landmark_count: 0,
                    input_len: 0,
                    scratch_floats: aim_scratch(v),
                    scratch_bytes: 4 * aim_scratch(v),
                    has_q16: a.q16().is_some(),
                }
            }
            Loaded::S2d(d) => SinewModelInfo {
                kind: SinewKind::S2d,
                vertex_count: d.vertex_count(),
                triangle_count: 0,
                shape_count: 0,
                landmark_count: d.landmarks().len(),
                input_len: d.input_len(),
                scratch_floats: d.scratch_len(),
                scratch_bytes: 4 * d.scratch_len(),
                has_q16: false,
            },
        }
    }
}

/// Scratch of an AIM frame hash: positions and normals, `[V, 3]` each (the Q16 mode uses the
/// first `3 V` as Q16.16 positions).
const fn aim_scratch(vertices: usize) -> usize {
    6 * vertices
}

/// Checks that a buffer has exactly the length the model needs.
pub(crate) fn expect_len(what: &str, len: usize, expected: usize) -> Result<()> {
    if len == expected {
        Ok(())
    } else {
        Err(Fail::new(
            SinewStatus::BufferLength,
            format_args!("{what} has {len} elements, {expected} expected"),
        ))
    }
}

/// Checks that scratch holds at least what the model needs.
pub(crate) fn expect_scratch(len: usize, needed: usize) -> Result<()> {
    if len >= needed {
        Ok(())
    } else {
        Err(Fail::new(
            SinewStatus::BufferLength,
            format_args!("scratch has {len} floats, the model needs at least {needed}"),
        ))
    }
}

/// Validates `bytes` as an AIM actor or an S2D decoder.
fn open(bytes: &'static [u8]) -> Result<SinewModel> {
    let file = SinewFile::from_bytes(bytes).map_err(|e| Fail::format("model", e))?;
    let loaded = match file.kind {
        ArtifactKind::AimActor => {
            Loaded::Aim(AimActor::from_bytes(bytes).map_err(|e| Fail::format("AIM actor", e))?)
        }
        ArtifactKind::S2dDecoder => {
            Loaded::S2d(S2dDecoder::from_bytes(bytes).map_err(|e| Fail::format("S2D decoder", e))?)
        }
        other => {
            return Err(Fail::new(
                SinewStatus::WrongKind,
                format_args!("the artefact is {other}, not an AIM actor or an S2D decoder"),
            ));
        }
    };
    Ok(SinewModel {
        bytes,
        loaded,
        hash: replay::model_hash(bytes),
    })
}

/// Opens a model from `len` bytes at `bytes`: a `.sinew` AIM actor or S2D decoder, validated
/// completely (every later call on the handle only reads in-range data).
///
/// On success `*out` is a new handle, to be released with `sinew_model_free`; on failure `*out`
/// is set to NULL.
///
/// # Safety
/// `bytes` must point to `len` readable bytes that stay valid and unchanged until the handle is
/// freed: the handle borrows them, it does not copy. `out` must point to writable memory for one
/// pointer; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_model_open(
    bytes: *const u8,
    len: usize,
    out: *mut *mut SinewModel,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        ptr::write(out, std::ptr::null_mut(), "out")?;
        let bytes = ptr::slice(bytes, len, "bytes")?;
        let model = open(bytes)?;
        ptr::hand_out(out, model, "out")
    })
}

/// Releases a handle from `sinew_model_open`. NULL is ignored.
///
/// # Safety
/// `model` is NULL or a handle from `sinew_model_open` not yet freed; no other call may be using
/// it, and it must not be used afterwards. Replays checked against it are unaffected.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_model_free(model: *mut SinewModel) {
    // Safety: the caller's promise above is `release`'s.
    unsafe { ptr::release(model) }
}

/// Writes the model's kind and sizes to `*out`.
///
/// # Safety
/// `model` is a live handle; `out` points to a writable `SinewModelInfo`; `err` is NULL or points
/// to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_model_info(
    model: *const SinewModel,
    out: *mut SinewModelInfo,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let model = ptr::handle(model, "model")?;
        ptr::write(out, model.info(), "out")
    })
}

/// Copies an AIM actor's template triangles, `3 * triangle_count` vertex indices, to `out`.
///
/// # Safety
/// `model` is a live handle; `out` points to `out_len` writable `uint32_t`; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_aim_triangles(
    model: *const SinewModel,
    out: *mut u32,
    out_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let actor = ptr::handle(model, "model")?.aim()?;
        let indices = actor.triangles().indices();
        let out = ptr::slice_mut(out, out_len, "out")?;
        expect_len("out", out.len(), indices.len())?;
        for (o, i) in out.iter_mut().zip(indices.iter()) {
            *o = i;
        }
        Ok(())
    })
}

/// Poses an AIM actor for one frame in f32 (the reference mode): AIM eq. 17 with the head and
/// jaw in the core's 9-float form (`[6D rotation, translation]`, the jaw about the actor's
/// pivot) and the M coefficients. Writes the positions and, when `normals` is not NULL, the
/// area-weighted vertex normals.
///
/// `head`, `jaw`: 9 floats each; `weights`: `weights_len == shape_count`; `positions`:
/// `positions_len == 3 * vertex_count`; `normals`: NULL, or `normals_len == 3 * vertex_count`.
///
/// A NaN or infinite value, a value out of range (a rotation's beyond ±1e6, a translation's
/// beyond ±1e5, a coefficient's beyond ±1e3) or a degenerate rotation (a column shorter than
/// 1e-6, or the columns parallel) is refused with `SINEW_STATUS_INVALID_INPUT`, the message
/// naming the argument and the index (`head[3] is NaN or infinite`); nothing is written then.
///
/// # Safety
/// `model` is a live handle; every non-NULL pointer points to at least the stated number of
/// floats (read or written), and output buffers overlap no other argument; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_aim_pose(
    model: *const SinewModel,
    head: *const f32,
    jaw: *const f32,
    weights: *const f32,
    weights_len: usize,
    positions: *mut f32,
    positions_len: usize,
    normals: *mut f32,
    normals_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let actor = ptr::handle(model, "model")?.aim()?;
        let head = ptr::nine(head, "head")?;
        let jaw = ptr::nine(jaw, "jaw")?;
        let weights = ptr::slice(weights, weights_len, "weights")?;
        expect_len("weights", weights.len(), actor.shape_count())?;
        let positions = ptr::slice_mut(positions, positions_len, "positions")?;
        expect_len("positions", positions.len(), 3 * actor.vertex_count())?;
        let normals = ptr::optional_mut(normals, normals_len, "normals")?;
        if let Some(n) = &normals {
            expect_len("normals", n.len(), 3 * actor.vertex_count())?;
        }
        let pose = actor.pose_from_9d(&jaw, &head).map_err(Fail::input)?;
        actor
            .pose(&pose, weights, positions)
            .map_err(|e| Fail::eval("pose", e))?;
        if let Some(n) = normals {
            actor
                .normals(positions, n)
                .map_err(|e| Fail::eval("normals", e))?;
        }
        Ok(())
    })
}

/// The jaw of a pose given by coefficients alone (an ARKit capture, sliders, shapes driven by
/// name): every training shape's learned jaw transform blended by its coefficient and held within
/// the range the shapes span (docs/ENGINES.md, "The jaw of a pose given by coefficients"; the
/// identity for an actor that records no learned jaws). Writes 9 floats to `jaw` (`[6D rotation,
/// translation]`, the form `sinew_aim_pose` takes); the result is always a jaw `sinew_aim_pose`
/// accepts.
///
/// `weights`: `weights_len == shape_count`. A NaN, infinite or out-of-range coefficient is
/// refused with `SINEW_STATUS_INVALID_INPUT`, naming it; nothing is written then.
///
/// # Safety
/// `model` is a live handle; `weights` points to `weights_len` floats; `jaw` points to 9
/// writable floats overlapping no other argument; `err` is NULL or points to a writable
/// `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_aim_jaw_from_weights(
    model: *const SinewModel,
    weights: *const f32,
    weights_len: usize,
    jaw: *mut f32,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let actor = ptr::handle(model, "model")?.aim()?;
        let weights = ptr::slice(weights, weights_len, "weights")?;
        expect_len("weights", weights.len(), actor.shape_count())?;
        let out = ptr::slice_mut(jaw, 9, "jaw")?;
        let blended = actor
            .jaw_from_weights(weights)
            .map_err(|e| Fail::eval("jaw_from_weights", e))?;
        out.copy_from_slice(&blended);
        Ok(())
    })
}

/// The numeric mode of a `SINEW_MODE_*` code.
pub(crate) fn mode_of(code: u32) -> Result<Mode> {
    match code {
        0 => Ok(Mode::F32),
        1 => Ok(Mode::Q16),
        2 => Ok(Mode::Fast),
        _ => Err(Fail::new(
            SinewStatus::OutOfRange,
            format_args!("mode {code} is unknown (0 f32, 1 q16, 2 fast)"),
        )),
    }
}

/// Poses an AIM frame in `mode` (a `SINEW_MODE_*` code) and writes its hash to `*hash`: the very
/// hash `sinew replay record` pins and every target checks (`sinew_core::replay::pose_frame_hash`).
/// f32 and fast modes hash the positions then the normals, Q16 mode the positions' raw Q16.16
/// bits. Inputs are refused as `sinew_aim_pose` refuses them, in every mode alike.
///
/// `scratch`: at least `scratch_floats` floats. Afterwards, in the f32 and fast modes, it holds
/// the frame's positions (first `3 * vertex_count` floats) then its normals; in Q16 mode its
/// first `3 * vertex_count` elements are the Q16.16 positions as `int32_t`.
///
/// # Safety
/// As `sinew_aim_pose`; `hash` points to a writable `uint64_t`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_aim_frame_hash(
    model: *const SinewModel,
    mode: u32,
    head: *const f32,
    jaw: *const f32,
    weights: *const f32,
    weights_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let actor = ptr::handle(model, "model")?.aim()?;
        let mode = mode_of(mode)?;
        let head = ptr::nine(head, "head")?;
        let jaw = ptr::nine(jaw, "jaw")?;
        let weights = ptr::slice(weights, weights_len, "weights")?;
        let m = actor.shape_count();
        expect_len("weights", weights.len(), m)?;
        let scratch = ptr::slice_mut(scratch, scratch_len, "scratch")?;
        let v3 = 3 * actor.vertex_count();
        expect_scratch(scratch.len(), aim_scratch(actor.vertex_count()))?;
        ptr::write(hash, 0, "hash")?;
        // The coefficients are copied because the core's frame buffers are writable (Q16 mode
        // converts them in place of the caller's); M is bounded by `MAX_SHAPES` at load.
        let mut w = [0.0f32; MAX_SHAPES];
        let w = &mut w[..m];
        w.copy_from_slice(weights);
        let mut wq = [I16F16::ZERO; MAX_SHAPES];
        let (positions, rest) = scratch.split_at_mut(v3);
        let mut buf = if mode == Mode::Q16 {
            FrameBuffers {
                positions: &mut [],
                normals: &mut [],
                positions_q16: bytemuck::cast_slice_mut(positions),
                weights: w,
                weights_q16: &mut wq[..m],
            }
        } else {
            FrameBuffers {
                positions,
                normals: &mut rest[..v3],
                positions_q16: &mut [],
                weights: w,
                weights_q16: &mut [],
            }
        };
        let h =
            replay::pose_frame_hash(actor, mode, &head, &jaw, &mut buf).map_err(Fail::replay)?;
        ptr::write(hash, h, "hash")
    })
}

/// Copies an S2D decoder's landmark vertex indices (`landmark_count` of them: which output
/// vertex each input landmark is) to `out`.
///
/// # Safety
/// `model` is a live handle; `out` points to `out_len` writable `uint32_t`; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_s2d_landmarks(
    model: *const SinewModel,
    out: *mut u32,
    out_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let decoder = ptr::handle(model, "model")?.s2d()?;
        let out = ptr::slice_mut(out, out_len, "out")?;
        expect_len("out", out.len(), decoder.landmarks().len())?;
        for (o, i) in out.iter_mut().zip(decoder.landmarks().iter()) {
            *o = i;
        }
        Ok(())
    })
}

/// An S2D decoder's input from a neutral and an expressive landmark set (`[K, 3]` each,
/// `landmarks_len == 3 * landmark_count`), normalised as the decoder was trained; `input_len ==
/// input_len` of the model info.
///
/// # Safety
/// `model` is a live handle; each pointer points to the stated number of floats, `input`
/// overlapping neither set; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_s2d_landmark_input(
    model: *const SinewModel,
    neutral: *const f32,
    expressive: *const f32,
    landmarks_len: usize,
    input: *mut f32,
    input_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let decoder = ptr::handle(model, "model")?.s2d()?;
        let neutral = ptr::slice(neutral, landmarks_len, "neutral")?;
        let expressive = ptr::slice(expressive, landmarks_len, "expressive")?;
        if landmarks_len != decoder.input_len() {
            return Err(Fail::new(
                SinewStatus::BufferLength,
                format_args!(
                    "neutral and expressive have {landmarks_len} elements each, {} expected",
                    decoder.input_len()
                ),
            ));
        }
        let input = ptr::slice_mut(input, input_len, "input")?;
        expect_len("input", input.len(), decoder.input_len())?;
        decoder
            .input(neutral, expressive, input)
            .map_err(|e| Fail::eval("landmark input", e))
    })
}

/// Decodes one S2D frame: the decoder input (`sinew_s2d_landmark_input`, or a replay's frame)
/// to the dense mesh, added to `neutral` (`3 * vertex_count` floats, the identity to animate) or,
/// when `neutral` is NULL, to the decoder's own template. Writes `3 * vertex_count` floats to
/// `vertices` and, when `hash` is not NULL, the frame's hash
/// (`sinew_core::replay::s2d_frame_hash`: the vertices' f32 bits).
///
/// `scratch`: at least `scratch_floats` floats; contents on entry ignored, on exit unspecified.
///
/// # Safety
/// `model` is a live handle; every non-NULL pointer points to the stated number of elements,
/// output buffers overlapping no other argument; `err` is NULL or points to a writable
/// `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_s2d_decode(
    model: *const SinewModel,
    input: *const f32,
    input_len: usize,
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
        let decoder = ptr::handle(model, "model")?.s2d()?;
        let v3 = 3 * decoder.vertex_count();
        let input = ptr::slice(input, input_len, "input")?;
        expect_len("input", input.len(), decoder.input_len())?;
        let neutral = ptr::optional(neutral, neutral_len, "neutral")?;
        if let Some(n) = neutral {
            expect_len("neutral", n.len(), v3)?;
        }
        let scratch = ptr::slice_mut(scratch, scratch_len, "scratch")?;
        expect_scratch(scratch.len(), decoder.scratch_len())?;
        let vertices = ptr::slice_mut(vertices, vertices_len, "vertices")?;
        expect_len("vertices", vertices.len(), v3)?;
        match neutral {
            Some(n) => decoder.decode_onto(n, input, scratch, vertices),
            None => decoder.decode(input, scratch, vertices),
        }
        .map_err(|e| Fail::eval("decode", e))?;
        if !hash.is_null() {
            let mut h = FrameHasher::new();
            h.write_f32s(vertices);
            ptr::write(hash, h.finish(), "hash")?;
        }
        Ok(())
    })
}

/// The frame hash of floats the caller holds: `first`, then `second` when it is not NULL, each
/// value's bits (NaN canonicalised) through xxh64. For an AIM frame posed by `sinew_aim_pose`,
/// pass the positions then the normals to get `sinew_aim_frame_hash`'s f32 hash; for S2D
/// vertices, pass them alone.
///
/// # Safety
/// `first` points to `first_len` floats; `second` is NULL or points to `second_len` floats;
/// `hash` points to a writable `uint64_t`; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_hash_frame(
    first: *const f32,
    first_len: usize,
    second: *const f32,
    second_len: usize,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let first = ptr::slice(first, first_len, "first")?;
        let second = ptr::optional(second, second_len, "second")?;
        let mut h = FrameHasher::new();
        h.write_f32s(first);
        if let Some(s) = second {
            h.write_f32s(s);
        }
        ptr::write(hash, h.finish(), "hash")
    })
}
