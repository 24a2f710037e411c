//! The landmark driver's exports ([`Driver`]): load against a model, pixels, pose, filter, play
//! and hash, over the I/O area of the parent module's protocol.

use super::{
    OBJECTS, Object, f32_bytes, finish, handle_or_error, insert, io_bytes, io_f32s, not_a, slot,
    split_at, stale,
};
use crate::{Driver, Error, Model};

/// Runs `f` on the driver behind `driver` and, when `model` is given, the model behind it.
fn with_driver<T>(
    driver: i32,
    model: Option<i32>,
    f: impl FnOnce(&Driver, Option<&Model>) -> Result<T, Error>,
) -> Result<T, Error> {
    OBJECTS.with_borrow(|objects| {
        let get = |h: i32| {
            slot(h)
                .and_then(|i| objects.get(i))
                .and_then(Option::as_ref)
        };
        let d = match get(driver) {
            Some(Object::Driver(d)) => d,
            Some(other) => return Err(not_a(driver, other, "a landmark driver")),
            None => return Err(stale(driver)),
        };
        let m = match model.map(|h| (h, get(h))) {
            None => None,
            Some((_, Some(Object::Model(m)))) => Some(m),
            Some((h, Some(other))) => return Err(not_a(h, other, "a model")),
            Some((h, None)) => return Err(stale(h)),
        };
        f(d, m)
    })
}

/// The model of an operation that named one (always there: [`with_driver`] was given its
/// handle).
fn needs_model(model: Option<&Model>) -> Result<&Model, Error> {
    model.ok_or_else(|| Error::new("a driver plays on a model; none was given"))
}

/// Loads the landmark driver whose bytes are in the I/O area for the actor `model`
/// ([`Driver::load`]); returns its handle, or -1.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_load(model: i32) -> i32 {
    let bytes = io_bytes();
    let loaded = OBJECTS.with_borrow(|objects| {
        match slot(model)
            .and_then(|i| objects.get(i))
            .and_then(Option::as_ref)
        {
            Some(Object::Model(m)) => Driver::load(bytes, m),
            Some(other) => Err(not_a(model, other, "a model")),
            None => Err(stale(model)),
        }
    });
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
    finish(with_driver(driver, None, |d, _| {
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
    finish(with_driver(driver, None, |d, _| {
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
    finish(with_driver(driver, Some(model), |d, m| {
        Ok(f32_bytes(&d.play(needs_model(m)?, &pose)?))
    }))
}

/// The frame hash of `model` posed by the pose in the I/O area ([`Driver::frame_hash`]).
/// Result: 16 hex digits.
// Safety: exported under its own name; no other symbol in the module is called so.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_driver_hash(driver: i32, model: i32) -> i32 {
    let pose = io_f32s();
    finish(with_driver(driver, Some(model), |d, m| {
        let hash = d.frame_hash(needs_model(m)?, &pose)?;
        Ok(format!("{hash:016x}").into_bytes())
    }))
}
