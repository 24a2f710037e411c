//! An AIM frame's outputs in the two other numeric modes, from a pose call: Q16.16 positions for
//! parts without an FPU, and the fast mode's micromath normals. The same arithmetic as
//! `sinew_aim_frame_hash` (`sinew_core::replay::pose_frame`), so hashing these outputs gives the
//! frame hashes of the Q16 and fast replays.

use fixed::types::I16F16;
use sinew_core::aim::MAX_SHAPES;
use sinew_core::hash::FrameHasher;
use sinew_core::replay::{self, FrameBuffers, Mode};

use crate::model::{SinewModel, expect_len};
use crate::ptr;
use crate::status::{Fail, SinewError, SinewStatus, guard};

/// Poses an AIM actor for one frame in Q16.16 fixed point (`SINEW_MODE_Q16`: the actor's Q16.16
/// cache, integer arithmetic only) and writes the positions' raw Q16.16 values (value × 65536, as
/// `int32_t`) to `positions`, `positions_len == 3 * vertex_count`. `sinew_hash_q16` of them is the
/// frame's Q16 hash. Inputs are refused as `sinew_aim_pose` refuses them;
/// `SINEW_STATUS_UNSUPPORTED` for an actor baked without the cache (`has_q16` of the info).
///
/// # Safety
/// `model` is a live handle; `head` and `jaw` point to 9 floats, `weights` to `weights_len`,
/// `positions` to `positions_len` writable `int32_t` overlapping no other argument; `err` is NULL
/// or points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_aim_pose_q16(
    model: *const SinewModel,
    head: *const f32,
    jaw: *const f32,
    weights: *const f32,
    weights_len: usize,
    positions: *mut i32,
    positions_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let actor = ptr::handle(model, "model")?.aim()?;
        let head = ptr::nine(head, "head")?;
        let jaw = ptr::nine(jaw, "jaw")?;
        let weights = ptr::slice(weights, weights_len, "weights")?;
        let m = actor.shape_count();
        expect_len("weights", weights.len(), m)?;
        let positions = ptr::slice_mut(positions, positions_len, "positions")?;
        expect_len("positions", positions.len(), 3 * actor.vertex_count())?;
        // The core's frame buffers take the coefficients writable; M is bounded by `MAX_SHAPES`
        // at load, so both copies live on the stack.
        let mut w = [0.0f32; MAX_SHAPES];
        let w = &mut w[..m];
        w.copy_from_slice(weights);
        let mut wq = [I16F16::ZERO; MAX_SHAPES];
        let mut buf = FrameBuffers {
            positions: &mut [],
            normals: &mut [],
            positions_q16: bytemuck::cast_slice_mut(positions),
            weights: w,
            weights_q16: &mut wq[..m],
        };
        replay::pose_frame(actor, Mode::Q16, &head, &jaw, &mut buf).map_err(Fail::replay)
    })
}

/// Poses an AIM actor for one frame in the fast mode (`SINEW_MODE_FAST`): the positions as
/// `sinew_aim_pose` computes them, and the vertex normals normalised with micromath's
/// approximate inverse square root. `positions_len == normals_len == 3 * vertex_count`; both are
/// required. `sinew_hash_frame(positions, normals)` is the frame's fast hash. Inputs are refused
/// as `sinew_aim_pose` refuses them.
///
/// # Safety
/// As `sinew_aim_pose`, with `normals` required.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_aim_pose_fast(
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
        let m = actor.shape_count();
        expect_len("weights", weights.len(), m)?;
        let v3 = 3 * actor.vertex_count();
        let positions = ptr::slice_mut(positions, positions_len, "positions")?;
        expect_len("positions", positions.len(), v3)?;
        let normals = ptr::slice_mut(normals, normals_len, "normals")?;
        expect_len("normals", normals.len(), v3)?;
        let mut w = [0.0f32; MAX_SHAPES];
        let w = &mut w[..m];
        w.copy_from_slice(weights);
        let mut buf = FrameBuffers {
            positions,
            normals,
            positions_q16: &mut [],
            weights: w,
            weights_q16: &mut [],
        };
        replay::pose_frame(actor, Mode::Fast, &head, &jaw, &mut buf).map_err(Fail::replay)
    })
}

/// The frame hash of Q16.16 values the caller holds (`sinew_aim_pose_q16`'s positions): each
/// value's 32 bits through xxh64, exactly the Q16 mode's `sinew_aim_frame_hash`.
///
/// # Safety
/// `values` points to `len` `int32_t`; `hash` points to a writable `uint64_t`; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_hash_q16(
    values: *const i32,
    len: usize,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let values = ptr::slice(values, len, "values")?;
        let mut h = FrameHasher::new();
        for v in values {
            h.write_u32(*v as u32);
        }
        ptr::write(hash, h.finish(), "hash")
    })
}
