//! What an engine binds animation curves with, through the C API: the content hash, the units
//! and axes, the whole metadata text and the corrective shapes' names in coefficient order, each
//! compared with what the core parses from the same bytes (the metadata `sinew inspect` prints).
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.

use std::ffi::CString;
use std::ptr::null_mut;

use sinew::*;
use sinew_core::SinewFile;
use sinew_core::replay::{AimReplay, model_hash};

mod common;
use common::{Model, data, message, new_error};

/// A text call made twice, as a C caller does: a size query, then the copy.
fn text(
    call: impl Fn(*mut std::ffi::c_char, usize, *mut usize, *mut SinewError) -> SinewStatus,
) -> Result<String, (SinewStatus, String)> {
    let mut needed = 0;
    let mut err = new_error();
    let status = call(null_mut(), 0, &mut needed, &mut err);
    if status != SinewStatus::Ok {
        return Err((status, message(&err)));
    }
    let mut buf = vec![0u8; needed];
    let status = call(buf.as_mut_ptr().cast(), buf.len(), null_mut(), &mut err);
    assert_eq!(status, SinewStatus::Ok, "{}", message(&err));
    assert_eq!(buf.pop(), Some(0), "NUL-terminated");
    Ok(String::from_utf8(buf).unwrap())
}

fn meta(model: &Model, key: &str) -> Result<String, (SinewStatus, String)> {
    let key = CString::new(key).unwrap();
    // Safety: a live handle, a NUL-terminated key, and buffers of the lengths passed.
    text(|b, l, n, e| unsafe { sinew_model_meta(model.handle, key.as_ptr(), b, l, n, e) })
}

fn shape_name(model: &Model, i: usize) -> Result<String, (SinewStatus, String)> {
    // Safety: a live handle and buffers of the lengths passed.
    text(|b, l, n, e| unsafe { sinew_model_shape_name(model.handle, i, b, l, n, e) })
}

#[test]
fn the_ict_actor_reports_its_hash_units_axes_and_shape_names() {
    let bytes = data("aim-ict.sinew");
    let file = SinewFile::from_bytes(&bytes).unwrap();
    let recorded = file.metadata();
    let model = Model::open("aim-ict.sinew");
    let info = model.info();

    let mut hash = 0;
    // Safety: a live handle and a writable hash.
    let status = unsafe { sinew_model_content_hash(model.handle, &mut hash, null_mut()) };
    assert_eq!(status, SinewStatus::Ok);
    assert_eq!(hash, model_hash(&bytes));
    // The hash the golden replay names, so an engine can check a replay without opening it.
    let replay = data("aim-ict.f32.replay.sinew");
    assert_eq!(hash, AimReplay::from_bytes(&replay).unwrap().model_hash());

    for key in ["units", "axes", "source", "tool"] {
        let want = recorded
            .get(key)
            .unwrap_or_else(|| panic!("aim-ict records {key}"));
        assert_eq!(meta(&model, key).unwrap(), want, "{key}");
    }
    assert_eq!(meta(&model, "units").unwrap(), "cm");
    // Safety: a live handle and buffers of the lengths passed.
    let whole = text(|b, l, n, e| unsafe { sinew_model_metadata(model.handle, b, l, n, e) });
    assert_eq!(whole.unwrap(), recorded.text());

    // The shapes in coefficient order: the recorded training shapes without the neutral.
    let names: Vec<&str> = recorded.get("shapes").unwrap().split(',').collect();
    assert_eq!(names[0], "neutral");
    assert_eq!(names.len(), info.shape_count + 1);
    for (i, want) in names[1..].iter().enumerate() {
        assert_eq!(shape_name(&model, i).unwrap(), *want, "shape {i}");
    }
    let m = info.shape_count;
    assert_eq!(
        shape_name(&model, m).unwrap_err(),
        (
            SinewStatus::OutOfRange,
            format!("shape {m} is past the actor's {m} corrective shapes")
        )
    );
}

#[test]
fn missing_metadata_and_short_buffers_are_named() {
    let model = Model::open("aim-procedural.sinew");
    assert_eq!(
        meta(&model, "no-such-key").unwrap_err(),
        (
            SinewStatus::NotFound,
            "the model's metadata has no key \"no-such-key\"".to_owned()
        )
    );
    // An actor whose file records no shape names gets the names glTF export gives its morph
    // targets.
    let bytes = data("aim-procedural.sinew");
    let recorded = SinewFile::from_bytes(&bytes).unwrap().metadata();
    assert_eq!(
        recorded.get("shapes"),
        None,
        "aim-procedural records no shape names"
    );
    assert_eq!(shape_name(&model, 0).unwrap(), "shape_1");
    let m = model.info().shape_count;
    assert_eq!(shape_name(&model, m - 1).unwrap(), format!("shape_{m}"));
    // A buffer too short for the text and its NUL.
    let units = CString::new("units").unwrap();
    let value = meta(&model, "units").unwrap();
    let mut buf = vec![0u8; value.len()];
    let mut err = new_error();
    // Safety: `buf` has the length passed.
    let status = unsafe {
        sinew_model_meta(
            model.handle,
            units.as_ptr(),
            buf.as_mut_ptr().cast(),
            buf.len(),
            null_mut(),
            &mut err,
        )
    };
    assert_eq!(status, SinewStatus::BufferLength);
    assert_eq!(
        message(&err),
        format!(
            "buf has {} bytes, the text needs {} with its NUL",
            value.len(),
            value.len() + 1
        )
    );
    // Neither a buffer nor a size to write to.
    // Safety: NULL pointers are refused before any access.
    let status = unsafe {
        sinew_model_meta(
            model.handle,
            units.as_ptr(),
            null_mut(),
            0,
            null_mut(),
            &mut err,
        )
    };
    assert_eq!(
        (status, message(&err)),
        (SinewStatus::NullPointer, "buf is NULL".to_owned())
    );
    // Safety: as above, for the key.
    let status = unsafe {
        sinew_model_meta(
            model.handle,
            std::ptr::null(),
            buf.as_mut_ptr().cast(),
            buf.len(),
            null_mut(),
            &mut err,
        )
    };
    assert_eq!(
        (status, message(&err)),
        (SinewStatus::NullPointer, "key is NULL".to_owned())
    );
    // A key that is not UTF-8.
    let bad = CString::new(vec![0xFFu8, b'k']).unwrap();
    // Safety: a NUL-terminated key and a buffer of the length passed.
    let status = unsafe {
        sinew_model_meta(
            model.handle,
            bad.as_ptr(),
            buf.as_mut_ptr().cast(),
            buf.len(),
            null_mut(),
            &mut err,
        )
    };
    assert_eq!(
        (status, message(&err)),
        (SinewStatus::InvalidInput, "key is not UTF-8".to_owned())
    );
}

#[test]
fn shape_names_are_an_actor_s_and_labels_a_generator_s() {
    let s2d = Model::open("s2d-ict.sinew");
    assert_eq!(
        shape_name(&s2d, 0).unwrap_err(),
        (
            SinewStatus::WrongKind,
            "the model is an S2D decoder, not an AIM actor".to_owned()
        )
    );
    // The decoder's own metadata is there all the same.
    assert_eq!(meta(&s2d, "units").unwrap(), "cm");
    let mut hash = 0;
    // Safety: a NULL handle is refused before any access.
    let status = unsafe { sinew_model_content_hash(std::ptr::null(), &mut hash, null_mut()) };
    assert_eq!(status, SinewStatus::NullPointer);
}
