//! Fitted performance handles (`sinew fit --out FIT.sinew`, AIM Sec. 4.2): per frame a head, a
//! jaw and the coefficients, global (one vector per frame) or local (the network F_W evaluated
//! at every vertex, AIM eq. 19), played on the actor they were fitted to.

use sinew_core::aim::AimActor;
use sinew_core::performance::{Performance, play_frame_hash};
use sinew_core::{ArtifactKind, SinewFile};

use crate::model::{SinewModel, expect_len, expect_scratch};
use crate::ptr;
use crate::status::{Fail, Result, SinewError, SinewStatus, guard};

/// An opened fitted performance (opaque to C). It borrows the bytes it was opened from: they
/// must stay valid and unchanged until [`sinew_performance_free`].
#[derive(Debug)]
pub struct SinewPerformance {
    perf: Performance<'static>,
}

/// A fitted performance's contents, from [`sinew_performance_info`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SinewPerformanceInfo {
    /// Frames (at least one).
    pub frame_count: usize,
    /// The actor's corrective coefficients M (per frame for a global fit, per vertex for a
    /// local one).
    pub shape_count: usize,
    /// Whether the coefficients vary per vertex (a local fit: F_W evaluated at every vertex);
    /// `sinew_performance_frame` then has no coefficients to give.
    pub is_local: bool,
    /// Whether the file carries each frame's hash as baked (`sinew_performance_expected`).
    pub has_hashes: bool,
    /// The content hash of the actor it was fitted to (`sinew_model_content_hash`).
    pub model_hash: u64,
    /// Floats of scratch `sinew_performance_pose` needs: the coefficients and, for a local fit,
    /// F_W's input and working memory.
    pub scratch_floats: usize,
}

impl SinewPerformance {
    /// The actor of `model`, checked to be the one this performance was fitted to: the content
    /// hash (computed once at open), the coefficient count and, for a performance with its own
    /// points, their count.
    fn actor<'m>(&self, model: &'m SinewModel) -> Result<&'m AimActor<'static>> {
        let actor = model.aim()?;
        if model.hash != self.perf.model_hash() {
            return Err(Fail::new(
                SinewStatus::ModelMismatch,
                format_args!(
                    "the performance was fitted to the actor {:016x}, this model is {:016x}",
                    self.perf.model_hash(),
                    model.hash
                ),
            ));
        }
        if actor.shape_count() != self.perf.shape_count() {
            return Err(Fail::new(
                SinewStatus::ModelMismatch,
                format_args!(
                    "the performance has {} coefficients per frame, the actor {}",
                    self.perf.shape_count(),
                    actor.shape_count()
                ),
            ));
        }
        if let Some(n) = self.perf.point_count()
            && n != actor.vertex_count()
        {
            return Err(Fail::new(
                SinewStatus::ModelMismatch,
                format_args!(
                    "the performance evaluates its coefficients at {n} points, the actor has {} \
                     vertices",
                    actor.vertex_count()
                ),
            ));
        }
        Ok(actor)
    }

    /// `frame` checked against the performance's length.
    fn frame(&self, frame: usize) -> Result<usize> {
        let frames = self.perf.frames();
        if frame < frames {
            Ok(frame)
        } else {
            Err(Fail::new(
                SinewStatus::OutOfRange,
                format_args!("frame {frame} is past the performance's {frames} frames"),
            ))
        }
    }
}

fn open(bytes: &'static [u8]) -> Result<SinewPerformance> {
    let file = SinewFile::from_bytes(bytes).map_err(|e| Fail::format("performance", e))?;
    if file.kind != ArtifactKind::Performance {
        return Err(Fail::new(
            SinewStatus::WrongKind,
            format_args!("the artefact is {}, not a fitted performance", file.kind),
        ));
    }
    let perf = Performance::from_bytes(bytes).map_err(|e| Fail::format("performance", e))?;
    Ok(SinewPerformance { perf })
}

/// Opens a fitted performance (`sinew fit --out`, docs/FORMAT.md "Performance") from `len`
/// bytes at `bytes`, validated completely (every frame's head and jaw, the coefficients, F_W's
/// bound). On success `*out` is a new handle, to be released with `sinew_performance_free`; on
/// failure `*out` is set to NULL.
///
/// # Safety
/// `bytes` must point to `len` readable bytes that stay valid and unchanged until the handle is
/// freed (the handle borrows them). `out` must point to writable memory for one pointer; `err`
/// is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_performance_open(
    bytes: *const u8,
    len: usize,
    out: *mut *mut SinewPerformance,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        ptr::write(out, std::ptr::null_mut(), "out")?;
        let bytes = ptr::slice(bytes, len, "bytes")?;
        let perf = open(bytes)?;
        ptr::hand_out(out, perf, "out")
    })
}

/// Releases a handle from `sinew_performance_open`. NULL is ignored.
///
/// # Safety
/// `perf` is NULL or a handle from `sinew_performance_open` not yet freed; no other call may be
/// using it, and it must not be used afterwards.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_performance_free(perf: *mut SinewPerformance) {
    // Safety: the caller's promise above is `release`'s.
    unsafe { ptr::release(perf) }
}

/// Writes the performance's frames, coefficient count, form and sizes to `*out`.
///
/// # Safety
/// `perf` is a live handle; `out` points to a writable `SinewPerformanceInfo`; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_performance_info(
    perf: *const SinewPerformance,
    out: *mut SinewPerformanceInfo,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let p = &ptr::handle(perf, "perf")?.perf;
        let info = SinewPerformanceInfo {
            frame_count: p.frames(),
            shape_count: p.shape_count(),
            is_local: p.is_local(),
            has_hashes: p.expected(0).is_some(),
            model_hash: p.model_hash(),
            scratch_floats: p.scratch_len(),
        };
        ptr::write(out, info, "out")
    })
}

/// Checks that `perf` was fitted (or retargeted) to `model`: the content hash, the coefficient
/// count and, for a performance carrying its own points, their count against the vertices.
/// `SINEW_STATUS_MODEL_MISMATCH` with the reason otherwise, `SINEW_STATUS_WRONG_KIND` for an S2D
/// decoder. `sinew_performance_pose` checks the same at every call.
///
/// # Safety
/// `perf` and `model` are live handles; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_performance_check_model(
    perf: *const SinewPerformance,
    model: *const SinewModel,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let perf = ptr::handle(perf, "perf")?;
        perf.actor(ptr::handle(model, "model")?).map(|_| ())
    })
}

/// Frame `frame`'s inputs: writes head and jaw (9 floats each: 6D rotation, translation; the
/// form `sinew_aim_pose` takes) and, when `weights` is not NULL, the frame's coefficients
/// (`weights_len == shape_count`). A local fit has no per-frame coefficients (they vary per
/// vertex): pass NULL, or get `SINEW_STATUS_UNSUPPORTED`.
///
/// # Safety
/// `perf` is a live handle; `head` and `jaw` point to 9 writable floats each; `weights` is NULL
/// or points to `weights_len` writable floats; `err` is NULL or points to a writable
/// `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_performance_frame(
    perf: *const SinewPerformance,
    frame: usize,
    head: *mut f32,
    jaw: *mut f32,
    weights: *mut f32,
    weights_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let perf = ptr::handle(perf, "perf")?;
        let f = perf.frame(frame)?;
        let head = ptr::slice_mut(head, 9, "head")?;
        let jaw = ptr::slice_mut(jaw, 9, "jaw")?;
        let weights = ptr::optional_mut(weights, weights_len, "weights")?;
        if let Some(w) = weights {
            if perf.perf.is_local() {
                return Err(Fail::new(
                    SinewStatus::Unsupported,
                    "a local fit has no per-frame coefficients (they vary per vertex): pass \
                     weights as NULL",
                ));
            }
            expect_len("weights", w.len(), perf.perf.shape_count())?;
            perf.perf.global_weights(f, w).ok_or_else(|| {
                Fail::new(SinewStatus::Internal, "a validated frame is unreadable")
            })?;
        }
        let (h, j) = perf
            .perf
            .head_jaw(f)
            .ok_or_else(|| Fail::new(SinewStatus::Internal, "a validated frame is unreadable"))?;
        head.copy_from_slice(&h);
        jaw.copy_from_slice(&j);
        Ok(())
    })
}

/// Writes the hash baked into the file for frame `frame` to `*hash`;
/// `SINEW_STATUS_UNSUPPORTED` when the file carries none (`has_hashes` of the info).
///
/// # Safety
/// `perf` is a live handle; `hash` points to a writable `uint64_t`; `err` is NULL or points to a
/// writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_performance_expected(
    perf: *const SinewPerformance,
    frame: usize,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let perf = ptr::handle(perf, "perf")?;
        let f = perf.frame(frame)?;
        let h = perf.perf.expected(f).ok_or_else(|| {
            Fail::new(
                SinewStatus::Unsupported,
                "the performance carries no frame hashes",
            )
        })?;
        ptr::write(hash, h, "hash")
    })
}

/// Poses `model`, the actor the performance was fitted to (checked at every call, as
/// `sinew_performance_check_model`), for frame `frame` in f32: AIM eq. 17 with the frame's head,
/// jaw and coefficients, the local ones evaluated per vertex by F_W (eq. 19). Writes
/// `positions` (`3 * vertex_count`) and, when `normals` is not NULL, the area-weighted vertex
/// normals; when `hash` is not NULL too, the frame's hash (positions then normals, exactly
/// `sinew_core::performance::play_frame_hash`, the hash `sinew fit` bakes). A `hash` without `normals`
/// is `SINEW_STATUS_NULL_POINTER`: the hash covers the normals.
///
/// `scratch`: at least `scratch_floats` of the performance info; contents on entry ignored.
///
/// # Safety
/// `perf` and `model` are live handles; every non-NULL pointer points to the stated number of
/// elements, output buffers overlapping no other argument; `hash` is NULL or points to a
/// writable `uint64_t`; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_performance_pose(
    perf: *const SinewPerformance,
    model: *const SinewModel,
    frame: usize,
    scratch: *mut f32,
    scratch_len: usize,
    positions: *mut f32,
    positions_len: usize,
    normals: *mut f32,
    normals_len: usize,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let perf = ptr::handle(perf, "perf")?;
        let actor = perf.actor(ptr::handle(model, "model")?)?;
        let f = perf.frame(frame)?;
        let v3 = 3 * actor.vertex_count();
        let scratch = ptr::slice_mut(scratch, scratch_len, "scratch")?;
        expect_scratch(scratch.len(), perf.perf.scratch_len())?;
        let positions = ptr::slice_mut(positions, positions_len, "positions")?;
        expect_len("positions", positions.len(), v3)?;
        let normals = ptr::optional_mut(normals, normals_len, "normals")?;
        if let Some(n) = &normals {
            expect_len("normals", n.len(), v3)?;
        } else if !hash.is_null() {
            return Err(Fail::null("normals (the frame hash covers the normals)"));
        }
        match normals {
            // The core's own frame hash: pose, normals, then positions and normals hashed.
            Some(n) if !hash.is_null() => {
                let h = play_frame_hash(&perf.perf, actor, f, scratch, positions, n)
                    .map_err(|e| Fail::eval("performance pose", e))?;
                ptr::write(hash, h, "hash")?;
            }
            Some(n) => {
                perf.perf
                    .pose(actor, f, scratch, positions)
                    .map_err(|e| Fail::eval("performance pose", e))?;
                actor
                    .normals(positions, n)
                    .map_err(|e| Fail::eval("normals", e))?;
            }
            None => perf
                .perf
                .pose(actor, f, scratch, positions)
                .map_err(|e| Fail::eval("performance pose", e))?,
        }
        Ok(())
    })
}
