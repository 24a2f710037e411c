//! Live driving (`sinew_core::live`, docs/FIT.md "Live driving"): a driver's frames through the
//! calibration and the lost-frame rules, over a state the caller keeps. Per frame:
//! `sinew_live_step` (landmarks, or NULL when the tracker found no face, and the frame's time
//! stamp → the pose to play and what became of the frame), then optionally
//! `sinew_driver_filter` and `sinew_driver_play`, as without the rules.

use sinew_core::error::{Argument, InputError};
use sinew_core::live::{Live, Lost, Outcome, Settings};

use crate::driver::SinewDriver;
use crate::model::{SinewModel, expect_len, expect_scratch};
use crate::ptr;
use crate::status::{Fail, Result, SinewError, SinewStatus, guard};

/// Live driving's settings (`sinew_core::live::Settings`): a limit of 0 turns its rule off.
/// `sinew_live_defaults` gives the measured defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinewLive {
    /// Found frames taken as the face at rest looking at the camera (0: no calibration; at most
    /// 1000). They are played at rest.
    pub calibrate_frames: u32,
    /// The largest residual of a found frame (the driven landmarks' root mean square distance
    /// from the track's, in units of the face's size in the image); above it the frame is lost.
    pub max_residual: f32,
    /// The fastest the face's centre moves, in face sizes per second.
    pub max_speed: f32,
    /// The fastest the head turns, radians per second.
    pub max_turn: f32,
    /// Seconds after which a run of frames lost to a jump is taken as the head's real motion.
    pub reacquire: f32,
}

/// What became of one frame (`sinew_live_step`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SinewLiveOutcome {
    /// Driven and accepted: the pose is the frame's.
    Driven = 0,
    /// Taken into the calibration: the pose is the rest pose.
    Calibrating = 1,
    /// No landmarks: the pose is the last accepted one (the rest pose before any).
    Missing = 2,
    /// Lost: the driven landmarks lie too far from the track's; the last pose holds.
    LostResidual = 3,
    /// Lost: the head moved or turned faster than a head does; the last pose holds.
    LostJump = 4,
}

impl From<Outcome> for SinewLiveOutcome {
    fn from(o: Outcome) -> Self {
        match o {
            Outcome::Calibrating => Self::Calibrating,
            Outcome::Missing => Self::Missing,
            Outcome::Lost(Lost::Residual) => Self::LostResidual,
            Outcome::Lost(Lost::Jump) => Self::LostJump,
            _ => Self::Driven,
        }
    }
}

/// The buffers live driving needs, from `sinew_live_info`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinewLiveInfo {
    /// Floats of the state (zeros: a session that has seen nothing).
    pub state_floats: usize,
    /// Floats of scratch `sinew_live_step` needs.
    pub scratch_floats: usize,
    /// The actor's face size in its unit (the rest spread of the nose and eyes), the unit of the
    /// residual and the speed.
    pub face_size: f32,
}

/// Where a calibration stands, from `sinew_live_calibration`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinewLiveCalibration {
    /// Found frames taken so far.
    pub frames: u32,
    /// Whether it is complete.
    pub complete: bool,
    /// Once complete, the root mean square deviation of its frames' offsets from their mean, in
    /// face sizes (the tracker's noise at rest; more where the face moved); 0 before.
    pub deviation: f32,
}

impl From<SinewLive> for Settings {
    fn from(s: SinewLive) -> Self {
        Self {
            calibrate_frames: s.calibrate_frames,
            max_residual: s.max_residual,
            max_speed: s.max_speed,
            max_turn: s.max_turn,
            reacquire: s.reacquire,
        }
    }
}

/// A refused setting, named as the C struct's field.
fn settings_refusal(e: InputError) -> Fail {
    if e.argument != Argument::Live {
        return Fail::input(e);
    }
    let field = [
        "calibrate_frames",
        "max_residual",
        "max_speed",
        "max_turn",
        "reacquire",
    ]
    .get(e.index)
    .copied()
    .unwrap_or("?");
    let core = e.to_string();
    let rest = core.split_once(']').map_or("", |(_, rest)| rest);
    let rest = if e.index == 0 && rest.contains("outside") {
        " is outside [0, 1000]"
    } else {
        rest
    };
    Fail::new(
        SinewStatus::InvalidInput,
        format_args!("settings.{field}{rest}"),
    )
}

/// The live driving of `driver` on `model` (its actor, checked) under `settings`.
fn live<'a>(
    driver: *const SinewDriver,
    model: *const SinewModel,
    settings: *const SinewLive,
) -> Result<Live<'a, 'static>> {
    let d: &'a SinewDriver = ptr::handle(driver, "driver")?;
    let actor = d.actor(ptr::handle(model, "model")?)?;
    let settings = Settings::from(*ptr::handle(settings, "settings")?);
    settings.check().map_err(settings_refusal)?;
    Live::new(&d.driver, actor, settings).map_err(|e| Fail::eval("live", e))
}

/// Writes the core's default settings, calibrating on `calibrate_frames` frames, to `*out`.
///
/// # Safety
/// `out` points to a writable `SinewLive`; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_live_defaults(
    calibrate_frames: u32,
    out: *mut SinewLive,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let s = Settings::defaults(calibrate_frames);
        ptr::write(
            out,
            SinewLive {
                calibrate_frames: s.calibrate_frames,
                max_residual: s.max_residual,
                max_speed: s.max_speed,
                max_turn: s.max_turn,
                reacquire: s.reacquire,
            },
            "out",
        )
    })
}

/// Writes the buffer sizes live driving of `driver` on `model` (the driver's actor) needs to
/// `*out`.
///
/// # Safety
/// `driver` and `model` are live handles; `out` points to a writable `SinewLiveInfo`; `err` is
/// NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_live_info(
    driver: *const SinewDriver,
    model: *const SinewModel,
    out: *mut SinewLiveInfo,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let off = SinewLive {
            calibrate_frames: 0,
            max_residual: 0.0,
            max_speed: 0.0,
            max_turn: 0.0,
            reacquire: 0.0,
        };
        let l = live(driver, model, &off)?;
        ptr::write(
            out,
            SinewLiveInfo {
                state_floats: l.state_len(),
                scratch_floats: l.scratch_len(),
                face_size: l.face_size(),
            },
            "out",
        )
    })
}

/// One frame of live driving (`sinew_core::live::Live::step`): `landmarks` (`input_len` floats,
/// as `sinew_driver_pose` takes them; NULL when the tracker found no face) taken at `time`
/// seconds → the pose to play in `pose` (`pose_len` floats: the rest pose while calibrating, the
/// frame's when driven, the last accepted one when lost or missing) and, when `outcome` is not
/// NULL, what became of the frame. `state` (`state_floats` of `sinew_live_info`; zeros to start)
/// carries the calibration and the held pose from frame to frame. `SINEW_STATUS_INVALID_INPUT`
/// naming `settings.<field>` for a setting that is not finite or outside `[0, 1e3]`, `time[0]`
/// for a time stamp that is not finite, outside ±1e5 or less than 1 ms after the last frame's,
/// `landmarks[i]` as `sinew_driver_pose`; nothing changes then.
///
/// # Safety
/// `driver`, `model` are live handles, `settings` points to a `SinewLive`; `landmarks` is NULL
/// or points to `landmarks_len` floats; `state`, `scratch` and `pose` point to the stated number
/// of writable floats, overlapping no other argument; `outcome` is NULL or points to a writable
/// `SinewLiveOutcome`; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code, clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_live_step(
    driver: *const SinewDriver,
    model: *const SinewModel,
    settings: *const SinewLive,
    landmarks: *const f32,
    landmarks_len: usize,
    time: f32,
    state: *mut f32,
    state_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    pose: *mut f32,
    pose_len: usize,
    outcome: *mut SinewLiveOutcome,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let l = live(driver, model, settings)?;
        let d = &ptr::handle(driver, "driver")?.driver;
        let landmarks = ptr::optional(landmarks, landmarks_len, "landmarks")?;
        if let Some(l) = landmarks {
            expect_len("landmarks", l.len(), d.input_len())?;
        }
        let state = ptr::slice_mut(state, state_len, "state")?;
        expect_len("state", state.len(), l.state_len())?;
        let scratch = ptr::slice_mut(scratch, scratch_len, "scratch")?;
        expect_scratch(scratch.len(), l.scratch_len())?;
        let pose = ptr::slice_mut(pose, pose_len, "pose")?;
        expect_len("pose", pose.len(), d.output_len())?;
        let o = l
            .step(state, landmarks, time, scratch, pose)
            .map_err(|e| Fail::eval("live", e))?;
        if !outcome.is_null() {
            ptr::write(outcome, SinewLiveOutcome::from(o), "outcome")?;
        }
        Ok(())
    })
}

/// Where the calibration of a live `state` stands, into `*out`.
///
/// # Safety
/// As `sinew_live_step` for `driver`, `model`, `settings` and `state` (read only); `out` points
/// to a writable `SinewLiveCalibration`; `err` is NULL or points to a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_live_calibration(
    driver: *const SinewDriver,
    model: *const SinewModel,
    settings: *const SinewLive,
    state: *const f32,
    state_len: usize,
    out: *mut SinewLiveCalibration,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let l = live(driver, model, settings)?;
        let state = ptr::slice(state, state_len, "state")?;
        expect_len("state", state.len(), l.state_len())?;
        let deviation = l.calibration_deviation(state);
        ptr::write(
            out,
            SinewLiveCalibration {
                frames: l.calibrated_frames(state),
                complete: deviation.is_some(),
                deviation: deviation.unwrap_or(0.0),
            },
            "out",
        )
    })
}
