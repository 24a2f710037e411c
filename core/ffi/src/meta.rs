//! What an engine needs to bind a model's animation curves: the content hash, the metadata an
//! artefact records (units, axes, provenance), and the names of an actor's corrective shapes in
//! coefficient order. Text is copied into the caller's buffers, never allocated for the caller.

use std::ffi::c_char;

use crate::model::SinewModel;
use crate::ptr;
use crate::status::{Fail, SinewError, SinewStatus, guard};

/// The name an actor's corrective shape `i` goes by when the file records none: `shape_1` …
/// `shape_M`, the names `sinew export gltf` gives such morph targets.
pub(crate) fn fallback_shape_name(i: usize) -> String {
    format!("shape_{}", i + 1)
}

/// Writes the content hash of the model's bytes (xxh64, `sinew_core::replay::model_hash`) to
/// `*hash`: the hash that replays and fitted performances name, and `sinew inspect` reports.
/// Computed once when the model was opened.
///
/// # Safety
/// `model` is a live handle; `hash` points to a writable `uint64_t`; `err` is NULL or points to
/// a writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_model_content_hash(
    model: *const SinewModel,
    hash: *mut u64,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let model = ptr::handle(model, "model")?;
        ptr::write(hash, model.hash, "hash")
    })
}

/// Copies the model's whole metadata text (`key=value` lines separated by `\n`, docs/FORMAT.md
/// "Metadata") and a NUL to `buf` (`buf_len` bytes), and the bytes that takes to `*needed` when
/// `needed` is not NULL. With `buf` NULL, `buf_len` 0 and `needed` not NULL, only the size is
/// written. A `buf` too short is `SINEW_STATUS_BUFFER_LENGTH`.
///
/// # Safety
/// `model` is a live handle; `buf` points to `buf_len` writable bytes (or is NULL for a size
/// query); `needed` is NULL or points to a writable `size_t`; `err` is NULL or points to a
/// writable `SinewError`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_model_metadata(
    model: *const SinewModel,
    buf: *mut c_char,
    buf_len: usize,
    needed: *mut usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let model = ptr::handle(model, "model")?;
        ptr::write_text(model.file().metadata().text(), buf, buf_len, needed)
    })
}

/// Copies the value of the metadata key `key` (a NUL-terminated UTF-8 string: `units`, e.g.
/// `cm`; `axes`, e.g. `x-left-of-actor,y-up,z-forward`; `source`, `tool`, …) and a NUL to `buf`,
/// as `sinew_model_metadata` copies the whole text. A key the file does not record is
/// `SINEW_STATUS_NOT_FOUND`.
///
/// # Safety
/// As `sinew_model_metadata`; `key` points to a NUL-terminated string.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_model_meta(
    model: *const SinewModel,
    key: *const c_char,
    buf: *mut c_char,
    buf_len: usize,
    needed: *mut usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let model = ptr::handle(model, "model")?;
        let key = ptr::c_str(key, "key")?;
        let value = model.file().metadata().get(key).ok_or_else(|| {
            Fail::new(
                SinewStatus::NotFound,
                format_args!("the model's metadata has no key \"{key}\""),
            )
        })?;
        ptr::write_text(value, buf, buf_len, needed)
    })
}

/// Copies the name of an AIM actor's corrective shape `index` (the coefficient at `weights[index]`,
/// below `shape_count`) and a NUL to `buf`, as `sinew_model_metadata` copies text: the training
/// shape's name the file records (metadata `shapes`, the neutral first and skipped), or
/// `shape_1` … `shape_M` when it records none, as `sinew export gltf` names the morph targets.
/// `SINEW_STATUS_OUT_OF_RANGE` for an index past the shapes, `SINEW_STATUS_WRONG_KIND` for an S2D
/// decoder.
///
/// # Safety
/// As `sinew_model_metadata`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub unsafe extern "C" fn sinew_model_shape_name(
    model: *const SinewModel,
    index: usize,
    buf: *mut c_char,
    buf_len: usize,
    needed: *mut usize,
    err: *mut SinewError,
) -> SinewStatus {
    guard(err, || {
        let actor = ptr::handle(model, "model")?.aim()?;
        let m = actor.shape_count();
        if index >= m {
            return Err(Fail::new(
                SinewStatus::OutOfRange,
                format_args!("shape {index} is past the actor's {m} corrective shapes"),
            ));
        }
        match actor.shape_name(index) {
            Some(name) => ptr::write_text(name, buf, buf_len, needed),
            None => ptr::write_text(&fallback_shape_name(index), buf, buf_len, needed),
        }
    })
}
