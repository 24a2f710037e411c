//! Landmark drivers (`sinew train driver`, docs/FORMAT.md "Landmark driver"): one frame of a
//! tracker's 68 landmarks to the actor's pose in one forward pass (`sinew_core::driver`), with the
//! optional One Euro filter stepped at the caller's time stamps, and the pose played on the actor.
//!
//! Per frame, as `sinew drive` and every firmware target do it: `sinew_driver_pixels` (a 2D
//! driver's pixels through the camera's intrinsics), `sinew_driver_pose` (landmarks → head, jaw,
//! coefficients), `sinew_driver_filter` (optional; its state is the caller's, zeros or
//! `sinew_driver_filter_reset` to start again), `sinew_driver_play` (the pose → positions,
//! normals and the frame hash).

use sinew_core::EvalError;
use sinew_core::aim::AimActor;
use sinew_core::driver::{Driver, Intrinsics, LANDMARKS, filter_pose, normalise_pixels, pose_hash};
use sinew_core::error::{InputError, InputErrorKind};
use sinew_core::filter::OneEuro;
use sinew_core::replay::ReplayError;
use sinew_core::{ArtifactKind, SinewFile};

use crate::model::{SinewModel, expect_len, expect_scratch};
use crate::ptr;
use crate::status::{Fail, Result, SinewError, SinewStatus, guard};

/// An opened landmark driver (opaque to C), checked against the actor it was opened with. It
/// borrows the bytes it was opened from: they must stay valid and unchanged until
/// [`sinew_driver_free`]. It does not keep the model's handle.
#[derive(Debug)]
pub struct SinewDriver {
    pub(crate) driver: Driver<'static>,
    vertex_count: usize,
}

/// A driver's sizes, from [`sinew_driver_info`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SinewDriverInfo {
    /// Landmarks per frame (68, the iBUG points of OpenFace, dlib, OpenSeeFace).
    pub landmark_count: usize,
    /// Coordinates per landmark: 2 (a 2D driver: pixels through `sinew_driver_pixels`) or 3 (a
    /// 3D driver: the actor's unit and frame).
    pub landmark_dims: usize,
    /// Floats of one frame's `landmarks`: `landmark_count * landmark_dims`.
    pub input_len: usize,
    /// The actor's corrective coefficients M.
    pub shape_count: usize,
    /// Floats of a pose: head (9: 6D rotation, translation), jaw (9), then M coefficients.
    pub pose_len: usize,
    /// Vertices V of the actor; `positions` and `normals` hold `3 * V` floats.
    pub vertex_count: usize,
    /// The content hash of the actor the driver was trained for (`sinew_model_content_hash`).
    pub model_hash: u64,
    /// Floats of scratch `sinew_driver_pose` needs.
    pub scratch_floats: usize,
    /// Floats of the One Euro filter's state (`sinew_driver_filter`): `2 + 2 * pose_len`.
    pub filter_state_floats: usize,
}

/// A pinhole camera's intrinsics in pixels, for `sinew_driver_pixels`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinewIntrinsics {
    /// Focal length along u.
    pub fx: f32,
    /// Focal length along v.
    pub fy: f32,
    /// Principal point u.
    pub cx: f32,
    /// Principal point v.
    pub cy: f32,
}

/// The One Euro filter's settings (Casiez et al. 2012), for `sinew_driver_filter`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinewFilter {
    /// The cutoff of a still signal, Hz (above 0): lower smooths more.
    pub min_cutoff: f32,
    /// How fast the cutoff rises with the speed (0 or more): higher lags less.
    pub beta: f32,
    /// The cutoff of the speed's own low-pass, Hz (above 0; 1 is usual).
    pub d_cutoff: f32,
}

impl SinewDriver {
    fn info(&self) -> SinewDriverInfo {
        let d = &self.driver;
        SinewDriverInfo {
            landmark_count: LANDMARKS,
            landmark_dims: d.space().dims(),
            input_len: d.input_len(),
            shape_count: d.shape_count(),
            pose_len: d.output_len(),
            vertex_count: self.vertex_count,
            model_hash: d.model_hash(),
            scratch_floats: d.scratch_len(),
            filter_state_floats: OneEuro::timed_state_len(d.output_len()),
        }
    }

    /// The actor of `model`, checked to be this driver's: the content hash (computed once when
    /// each was opened; `sinew_driver_open` checked the rest against these very bytes).
    pub(crate) fn actor<'m>(&self, model: &'m SinewModel) -> Result<&'m AimActor<'static>> {
        let actor = model.aim()?;
        if model.hash != self.driver.model_hash() || actor.vertex_count() != self.vertex_count {
            return Err(mismatch(
                &self.driver,
                model,
                ReplayError::WrongModel {
                    expected: self.driver.model_hash(),
                    found: model.hash,
                },
            ));
        }
        Ok(actor)
    }
}

/// A driver refused on `model`, the message naming what differs.
fn mismatch(driver: &Driver<'_>, model: &SinewModel, e: ReplayError) -> Fail {
    match e {
        ReplayError::WrongModel { expected, found } => Fail::new(
            SinewStatus::ModelMismatch,
            format_args!(
                "the driver was trained for the actor {expected:016x}, this model is {found:016x}"
            ),
        ),
        ReplayError::ShapeCount { replay, actor } => Fail::new(
            SinewStatus::ModelMismatch,
            format_args!("the driver poses {replay} coefficients, the actor has {actor}"),
        ),
        other => Fail::new(
            SinewStatus::ModelMismatch,
            format_args!(
                "the driver does not fit the actor {:016x} ({} expected): {other}",
                model.hash,
                driver.model_hash()
            ),
        ),
    }
}

fn open(bytes: &'static [u8], model: &SinewModel) -> Result<SinewDriver> {
    let actor = model.aim()?;
    let file = SinewFile::from_bytes(bytes).map_err(|e| Fail::format("driver", e))?;
    if file.kind != ArtifactKind::Driver {
        return Err(Fail::new(
            SinewStatus::WrongKind,
            format_args!("the artefact is {}, not a landmark driver", file.kind),
        ));
    }
    let driver = Driver::from_bytes(bytes).map_err(|e| Fail::format("driver", e))?;
    // The model's content hash was computed once when it was opened.
    if model.hash != driver.model_hash() {
        return Err(mismatch(
            &driver,
            model,
            ReplayError::WrongModel {
                expected: driver.model_hash(),
                found: model.hash,
            },
        ));
    }
    driver
        .check_actor(model.bytes, actor)
        .map_err(|e| mismatch(&driver, model, e))?;
    Ok(SinewDriver {
        vertex_count: actor.vertex_count(),
        driver,
    })
}

/// Opens a landmark driver (`sinew train driver`, `len` bytes at `bytes`, validated
/// completely) for `model`, the AIM actor it was trained for. On success `*out` is a new handle,
/// to be released with `sinew_driver_free`; on failure `*out` is set to NULL.
/// `SINEW_STATUS_WRONG_KIND` if `model` is an S2D decoder or the bytes another kind of artefact;
/// `SINEW_STATUS_MODEL_MISMATCH` if the driver was trained for another actor (its content hash),
/// poses another number of coefficients, or names a landmark vertex the actor lacks.
///
/// # Safety
/// `bytes` must point to `len` readable bytes that stay valid and unchanged until the handle is
/// freed (the handle borrows them); `model` is a live handle (it may be freed first). `out` must
/// point to writable memory for one pointer; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_open(
    bytes: *const u8,
    len: usize,
    model: *const SinewModel,
    out: *mut *mut SinewDriver,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        ptr::write(out, std::ptr::null_mut(), "out")?;
        let model = ptr::handle(model, "model")?;
        let bytes = ptr::slice(bytes, len, "bytes")?;
        let driver = open(bytes, model)?;
        ptr::hand_out(out, driver, "out")
    })
}

/// Releases a handle from `sinew_driver_open`. NULL is ignored.
///
/// # Safety
/// `driver` is NULL or a handle from `sinew_driver_open` not yet freed; no other call may be using
/// it, and it must not be used afterwards.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_free(driver: *mut SinewDriver) {
    // Safety: the caller's promise above is `release`'s.
    unsafe { ptr::release(driver) }
}

/// Writes the driver's sizes to `*out`.
///
/// # Safety
/// `driver` is a live handle; `out` points to a writable `SinewDriverInfo`; `err` is NULL or
/// points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_info(
    driver: *const SinewDriver,
    out: *mut SinewDriverInfo,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let d = ptr::handle(driver, "driver")?;
        ptr::write(out, d.info(), "out")
    })
}

/// A tracker's pixels (`pixels`: 68 × `[u, v]`, v down, 136 floats) as a 2D driver reads them,
/// into `landmarks` (136 floats): `((u − cx) / fx, (v − cy) / fy)`
/// (`sinew_core::driver::normalise_pixels`). `SINEW_STATUS_INVALID_INPUT` naming `pixels[i]` for
/// a pixel that is NaN, infinite or outside ±1e5, or the field (`intrinsics.fx`) for intrinsics
/// that are not finite or within ±1e5, or a focal length that is not positive; nothing is
/// written then.
///
/// # Safety
/// `pixels` points to `pixels_len` floats, `intrinsics` to a `SinewIntrinsics`, `landmarks` to
/// `landmarks_len` writable floats overlapping neither; `err` is NULL or points to a writable
/// `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_pixels(
    pixels: *const f32,
    pixels_len: usize,
    intrinsics: *const SinewIntrinsics,
    landmarks: *mut f32,
    landmarks_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let pixels = ptr::slice(pixels, pixels_len, "pixels")?;
        expect_len("pixels", pixels.len(), 2 * LANDMARKS)?;
        let k = *ptr::handle(intrinsics, "intrinsics")?;
        let landmarks = ptr::slice_mut(landmarks, landmarks_len, "landmarks")?;
        expect_len("landmarks", landmarks.len(), 2 * LANDMARKS)?;
        let camera = Intrinsics {
            fx: k.fx,
            fy: k.fy,
            cx: k.cx,
            cy: k.cy,
        };
        normalise_pixels(pixels, &camera, landmarks).map_err(|e| match e {
            EvalError::Input(e) => pixel_refusal(e),
            e => Fail::eval("pixels", e),
        })
    })
}

/// The core names a refused pixel or intrinsic as `landmarks[i]` (its one argument); C has two
/// parameters, so the message names `pixels[i]`, or the `intrinsics` field.
fn pixel_refusal(e: InputError) -> Fail {
    let pixels = 2 * LANDMARKS;
    if e.index < pixels {
        let core = e.to_string();
        let rest = core.split_once(']').map_or("", |(_, rest)| rest);
        return Fail::new(
            SinewStatus::InvalidInput,
            format_args!("pixels[{}]{rest}", e.index),
        );
    }
    let field = ["fx", "fy", "cx", "cy"]
        .get(e.index - pixels)
        .copied()
        .unwrap_or("?");
    let problem = match e.kind {
        InputErrorKind::NonFinite => "is NaN or infinite",
        _ if e.index - pixels < 2 => "is not a focal length in (0, 1e5]",
        _ => "is outside ±1e5",
    };
    Fail::new(
        SinewStatus::InvalidInput,
        format_args!("intrinsics.{field} {problem}"),
    )
}

/// One frame's `landmarks` (`input_len` floats) to the actor's pose in `pose` (`pose_len`
/// floats: head 6D rotation and translation, jaw the same, then the coefficients), exactly
/// `sinew_core::driver::Driver::drive`. `SINEW_STATUS_INVALID_INPUT` naming `landmarks[i]` for a
/// landmark that is NaN, infinite or outside ±1e5, or (`landmarks[0]`) 2D landmarks whose nose
/// and eyes all but coincide; nothing is written then.
///
/// # Safety
/// `driver` is a live handle; `landmarks` points to `landmarks_len` floats; `scratch` and `pose`
/// point to the stated number of writable floats, overlapping no other argument; `err` is NULL
/// or points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_pose(
    driver: *const SinewDriver,
    landmarks: *const f32,
    landmarks_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    pose: *mut f32,
    pose_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let d = &ptr::handle(driver, "driver")?.driver;
        let landmarks = ptr::slice(landmarks, landmarks_len, "landmarks")?;
        expect_len("landmarks", landmarks.len(), d.input_len())?;
        let scratch = ptr::slice_mut(scratch, scratch_len, "scratch")?;
        expect_scratch(scratch.len(), d.scratch_len())?;
        let pose = ptr::slice_mut(pose, pose_len, "pose")?;
        expect_len("pose", pose.len(), d.output_len())?;
        d.drive(landmarks, scratch, pose)
            .map_err(|e| Fail::eval("drive", e))
    })
}

/// Sets a filter state (`filter_state_floats` floats) to a filter that has seen nothing: the
/// next `sinew_driver_filter` passes its frame through. Zeroing the floats does the same.
///
/// # Safety
/// `state` points to `state_len` writable floats; `err` is NULL or points to a writable
/// `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_filter_reset(
    state: *mut f32,
    state_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        ptr::slice_mut(state, state_len, "state")?.fill(0.0);
        Ok(())
    })
}

/// Smooths a driven `pose` (`pose_len` floats, from `sinew_driver_pose`) taken at `time`
/// seconds in place with the One Euro filter `filter`, updating `state` (`filter_state_floats`
/// floats; zeros or `sinew_driver_filter_reset` to start), then makes its rotations orthonormal
/// again (`sinew_core::driver::filter_pose`). Each step's rate is `1 / (time − the last
/// frame's time)`; the first frame after a reset passes through. Count time from the track's
/// start. `SINEW_STATUS_INVALID_INPUT` naming `filter[i]` for a setting that is not finite, out
/// of `[0, 1e3]` or a cutoff of 0; `time[0]` for a time stamp that is not finite, outside ±1e5 or
/// less than 1 ms after the last; `head[i]`, `jaw[i]` or `weights[i]` for a pose value posing
/// would refuse. Nothing changes then.
///
/// # Safety
/// `driver` is a live handle; `filter` points to a `SinewFilter`; `state` and `pose` point to the
/// stated number of writable floats, not overlapping; `err` is NULL or points to a writable
/// `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_filter(
    driver: *const SinewDriver,
    filter: *const SinewFilter,
    time: f32,
    state: *mut f32,
    state_len: usize,
    pose: *mut f32,
    pose_len: usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let d = ptr::handle(driver, "driver")?;
        let s = *ptr::handle(filter, "filter")?;
        // The time-stamped step takes its rate from the stamps; 1 Hz only fills the setting.
        let one_euro = OneEuro::new(s.min_cutoff, s.beta, s.d_cutoff, 1.0).map_err(Fail::input)?;
        let state = ptr::slice_mut(state, state_len, "state")?;
        expect_len("state", state.len(), d.info().filter_state_floats)?;
        let pose = ptr::slice_mut(pose, pose_len, "pose")?;
        expect_len("pose", pose.len(), d.driver.output_len())?;
        filter_pose(&one_euro, state, time, pose).map_err(|e| Fail::eval("filter", e))
    })
}

/// Poses `model`, the driver's actor (checked at every call), with a driven `pose` (`pose_len`
/// floats) in f32 (`sinew_core::driver::play`): writes `positions` (`3 * vertex_count`) and,
/// when `normals` is not NULL, the area-weighted vertex normals; when `hash` is not NULL too, the
/// frame's hash (positions then normals, `sinew_core::driver::pose_hash`, the `frame` hashes of
/// `tests/data/driver-ict.hashes`). A `hash` without `normals` is `SINEW_STATUS_NULL_POINTER`:
/// the hash covers the normals. `SINEW_STATUS_INVALID_INPUT` naming `head[i]`, `jaw[i]` or
/// `weights[i]` for a pose value posing refuses.
///
/// # Safety
/// `driver` and `model` are live handles; every non-NULL pointer points to the stated number of
/// elements, output buffers overlapping no other argument; `hash` is NULL or points to a writable
/// `uint64_t`; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_driver_play(
    driver: *const SinewDriver,
    model: *const SinewModel,
    pose: *const f32,
    pose_len: usize,
    positions: *mut f32,
    positions_len: usize,
    normals: *mut f32,
    normals_len: usize,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let d = ptr::handle(driver, "driver")?;
        let actor = d.actor(ptr::handle(model, "model")?)?;
        let pose = ptr::slice(pose, pose_len, "pose")?;
        expect_len("pose", pose.len(), d.driver.output_len())?;
        let v3 = 3 * actor.vertex_count();
        let positions = ptr::slice_mut(positions, positions_len, "positions")?;
        expect_len("positions", positions.len(), v3)?;
        let normals = ptr::optional_mut(normals, normals_len, "normals")?;
        match normals {
            Some(n) => {
                expect_len("normals", n.len(), v3)?;
                let h = pose_hash(actor, pose, positions, n).map_err(|e| Fail::eval("pose", e))?;
                if !hash.is_null() {
                    ptr::write(hash, h, "hash")?;
                }
            }
            None if !hash.is_null() => {
                return Err(Fail::null("normals (the frame hash covers the normals)"));
            }
            None => sinew_core::driver::play(actor, pose, positions)
                .map_err(|e| Fail::eval("pose", e))?,
        }
        Ok(())
    })
}
