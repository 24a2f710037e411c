//! The C API's refusals: a NaN, infinite, out-of-range or degenerate head, jaw or coefficient is
//! `SINEW_STATUS_INVALID_INPUT` in every mode, the message naming the argument and the index,
//! and nothing is written; `sinew_status_string` names every status.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.

use std::ffi::CStr;
use std::ptr::null_mut;

use sinew::*;

mod common;
use common::{Model, message, new_error};

/// Non-finite, out-of-range and degenerate inputs are refused with `SINEW_STATUS_INVALID_INPUT`
/// in every mode, the message naming the argument and the index, and nothing is written.
#[test]
fn refused_inputs_name_the_argument_and_index() {
    let aim = Model::open("aim-procedural.sinew");
    let info = aim.info();
    let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0f32];
    let weights = vec![0.0f32; info.shape_count];
    let with = |i: usize, v: f32| {
        let mut p = identity;
        p[i] = v;
        p
    };
    // Head, jaw, weights, and the message's start.
    type Case = ([f32; 9], [f32; 9], Vec<f32>, &'static str);
    let cases: [Case; 9] = [
        (
            with(3, f32::NAN),
            identity,
            weights.clone(),
            "head[3] is NaN or infinite",
        ),
        (
            identity,
            with(7, f32::INFINITY),
            weights.clone(),
            "jaw[7] is NaN or infinite",
        ),
        (
            with(8, f32::NAN),
            identity,
            weights.clone(),
            "head[8] is NaN or infinite",
        ),
        (
            [0.0; 9],
            identity,
            weights.clone(),
            "head[0..3], the 6D rotation's first column",
        ),
        (
            [1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 0.0],
            identity,
            weights.clone(),
            "head[3..6], the 6D rotation's second column",
        ),
        (
            identity.map(|x| x * 1e20),
            identity,
            weights.clone(),
            "head[0] is outside ±1e6",
        ),
        (
            identity,
            with(6, 2e5),
            weights.clone(),
            "jaw[6] is outside ±1e5",
        ),
        (
            identity,
            identity,
            {
                let mut w = weights.clone();
                w[2] = f32::NAN;
                w
            },
            "weights[2] is NaN or infinite",
        ),
        (
            identity,
            identity,
            {
                let mut w = weights.clone();
                w[5] = -1e4;
                w
            },
            "weights[5] is outside ±1e3",
        ),
    ];
    for (head, jaw, weights, text) in cases {
        let mut positions = vec![7.0f32; 3 * info.vertex_count];
        let mut err = new_error();
        // Safety: every buffer has the length passed.
        let status = unsafe {
            sinew_aim_pose(
                aim.handle,
                head.as_ptr(),
                jaw.as_ptr(),
                weights.as_ptr(),
                weights.len(),
                positions.as_mut_ptr(),
                positions.len(),
                null_mut(),
                0,
                &mut err,
            )
        };
        assert_eq!(status, SinewStatus::InvalidInput, "{text}");
        assert_eq!(err.status, status);
        assert!(
            message(&err).starts_with(text),
            "{:?} for {text:?}",
            message(&err)
        );
        assert!(
            positions.iter().all(|&p| p == 7.0),
            "{text}: nothing is written"
        );
        for mode in [0, 1, 2] {
            let mut scratch = vec![0.0f32; info.scratch_floats];
            let mut hash = 0;
            // Safety: every buffer has the length passed.
            let status = unsafe {
                sinew_aim_frame_hash(
                    aim.handle,
                    mode,
                    head.as_ptr(),
                    jaw.as_ptr(),
                    weights.as_ptr(),
                    weights.len(),
                    scratch.as_mut_ptr(),
                    scratch.len(),
                    &mut hash,
                    &mut err,
                )
            };
            assert_eq!(status, SinewStatus::InvalidInput, "{text}, mode {mode}");
            assert!(
                message(&err).starts_with(text),
                "{:?}, mode {mode}",
                message(&err)
            );
        }
    }
}

/// Every status has a sentence; the new one and an unknown code too.
#[test]
fn status_strings() {
    let text = |code| {
        // Safety: the library returns a static NUL-terminated string for every code.
        unsafe { CStr::from_ptr(sinew_status_string(code)) }
            .to_str()
            .unwrap()
            .to_owned()
    };
    assert_eq!(text(SinewStatus::Ok as u32), "success");
    assert_eq!(
        text(SinewStatus::InvalidInput as u32),
        "an input value is NaN, infinite, out of range or degenerate"
    );
    assert_eq!(
        text(SinewStatus::BufferLength as u32),
        "a buffer has the wrong length or alignment"
    );
    assert_eq!(text(99), "unknown status");
    for code in 0..=9 {
        assert_ne!(text(code), "unknown status", "{code}");
    }
}
