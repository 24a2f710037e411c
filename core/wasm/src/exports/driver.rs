//! The landmark driver's exports ([`Driver`]): load against a model, pixels, pose, filter, play
//! and hash, over the I/O area of the parent module's protocol.

use super::{
    Object, f32_bytes, finish, handle_or_error, insert, io_bytes, io_f32s, split_at, with,
    with_on_model,
};
use crate::driver::Driver;
use crate::model::Model;

/// Loads the landmark driver whose bytes are in the I/O area for the actor `model`
/// ([`Driver::load`]); returns its handle, or -1.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_load(model: i32) -> i32 {
    let bytes = io_bytes();
    let loaded = with(model, |m: &Model| Driver::load(bytes, m));
    handle_or_error(loaded.and_then(|d| insert(Object::Driver(d))))
}

/// A tracker's pixels through the camera ([`Driver::pixels`]); the I/O area holds the 136
/// pixels, then fx, fy, cx, cy. Result: the landmarks (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_pixels(pixels_len: u32) -> i32 {
    let values = io_f32s();
    finish(
        split_at(&values, pixels_len)
            .and_then(|(pixels, camera)| Ok(f32_bytes(&Driver::pixels(pixels, camera)?))),
    )
}

/// One frame's landmarks (the I/O area) to the pose ([`Driver::pose`]). Result: the pose
/// (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_pose(driver: i32) -> i32 {
    let landmarks = io_f32s();
    finish(with(driver, |d: &Driver| {
        Ok(f32_bytes(&d.pose(&landmarks)?))
    }))
}

/// The One Euro filter on a pose at `time` ([`Driver::filter`]); the I/O area holds the three
/// settings, the pose (`pose_len` values), then the state. Result: the filtered pose, then the
/// new state (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_filter(driver: i32, time: f32, pose_len: u32) -> i32 {
    let values = io_f32s();
    finish(with(driver, |d: &Driver| {
        let (settings, rest) = split_at(&values, 3)?;
        let (pose, state) = split_at(rest, pose_len)?;
        let (mut pose, mut state) = (pose.to_vec(), state.to_vec());
        d.filter(settings, time, &mut state, &mut pose)?;
        Ok(f32_bytes(&[pose, state].concat()))
    }))
}

/// `model` posed by the pose in the I/O area ([`Driver::play`]). Result: the positions (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_play(driver: i32, model: i32) -> i32 {
    let pose = io_f32s();
    finish(with_on_model(driver, model, |d: &Driver, m| {
        Ok(f32_bytes(&d.play(m, &pose)?))
    }))
}

/// The frame hash of `model` posed by the pose in the I/O area ([`Driver::frame_hash`]).
/// Result: 16 hex digits.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_hash(driver: i32, model: i32) -> i32 {
    let pose = io_f32s();
    finish(with_on_model(driver, model, |d: &Driver, m| {
        let hash = d.frame_hash(m, &pose)?;
        Ok(format!("{hash:016x}").into_bytes())
    }))
}

/// One frame of live driving ([`Driver::live_step`]) on `model` at `time`; the I/O area holds the
/// five settings, the landmarks when `found` is 1 (`landmarks_len` values), then the state.
/// Result (`f32`): the outcome's code, the frames the calibration has taken, its deviation (-1
/// before it completes), the last residual, the pose (`pose_len`), then the new state.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_live(
    driver: i32,
    model: i32,
    time: f32,
    found: u32,
    landmarks_len: u32,
) -> i32 {
    let values = io_f32s();
    finish(with_on_model(driver, model, |d: &Driver, m| {
        let (settings, rest) = split_at(&values, 5)?;
        let (landmarks, state) = if found == 1 {
            let (l, s) = split_at(rest, landmarks_len)?;
            (Some(l), s)
        } else {
            (None, rest)
        };
        let mut state = state.to_vec();
        let f = d.live_step(m, settings, landmarks, time, &mut state)?;
        let head = [
            f.outcome as f32,
            f.calibrated as f32,
            f.deviation,
            f.residual,
        ];
        Ok(f32_bytes(&[&head[..], &f.pose, &state].concat()))
    }))
}

/// The core's default live settings calibrating on `frames` frames
/// (`sinew_core::live::Settings::defaults`). Result: the five values (`f32`).
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_live_defaults(frames: u32) -> i32 {
    finish(Ok(f32_bytes(
        &sinew_core::live::Settings::defaults(frames).values(),
    )))
}
